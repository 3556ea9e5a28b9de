//! The matrix exponential and the `φ` functions behind every exact linear flow.
//!
//! `e^M` is nalgebra's [`Matrix::exp`](nalgebra::Matrix::exp): scaling and squaring with
//! Padé approximants of degree 3, 5, 7, 9 or 13 chosen by Al-Mohy & Higham's
//! backward-error bounds (Higham 2005; Al-Mohy & Higham 2009, the algorithm of scipy's
//! `expm`), never a truncated Taylor series. The `φ` functions,
//! `φ₀(z) = e^z`, `φ_{k+1}(z) = (φ_k(z) − φ_k(0))/z`, are read off one exponential of
//! an augmented block matrix (Saad 1992; Al-Mohy & Higham 2011, Theorem 2.1):
//!
//! ```text
//!     ⎡A  w_p … w_1⎤                          ⎡e^A  ·  …  Σ_k φ_k(A)·w_k⎤
//! exp ⎢0  0  1     ⎥ (shift block below)   =  ⎢ 0            …          ⎥
//!     ⎣0  …     0  ⎦                          ⎣ 0            …     1    ⎦
//! ```
//!
//! so `Σ_{k=1..p} φ_k(A)·w_k` costs one `(n + p)`-square exponential, with the same
//! accuracy as `e^A` itself (no division by `A`, so singular `A` is fine). This is why
//! reckon uses the block form and not `A⁻¹(e^A − I)`: the latter loses everything when
//! `A` is singular or nearly so (a double integrator, a held input).

use crate::error::{Error, Result};
use nalgebra::DMatrix;

/// `e^M` for a square matrix with finite entries (nalgebra's scaling and squaring).
///
/// Errors: [`Error::InvalidInput`] for a non-square matrix or a non-finite entry (a
/// non-finite norm would make the number of squarings meaningless).
///
/// ```
/// use reckon::linalg::expm::expm;
/// use nalgebra::DMatrix;
/// // rotation generator: e^{[[0, −θ], [θ, 0]]} = [[cos θ, −sin θ], [sin θ, cos θ]]
/// let m = DMatrix::from_row_slice(2, 2, &[0.0, -0.5, 0.5, 0.0]);
/// let e = expm(&m).unwrap();
/// assert!((e[(0, 0)] - 0.5f64.cos()).abs() < 1e-15 && (e[(1, 0)] - 0.5f64.sin()).abs() < 1e-15);
/// ```
pub fn expm(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    if !m.is_square() {
        return Err(Error::invalid(
            "matrix",
            format!("the exponential of a {}x{} matrix", m.nrows(), m.ncols()),
        ));
    }
    if let Some(i) = m.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "matrix",
            format!(
                "entry ({}, {}) is {} (the exponential needs finite entries)",
                i % m.nrows(),
                i / m.nrows(),
                m[i]
            ),
        ));
    }
    if m.nrows() == 0 {
        return Ok(m.clone());
    }
    let e = m.exp();
    if let Some(i) = e.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "matrix",
            format!(
                "the exponential overflows (entry ({}, {}) is {}; ‖M‖₁ = {:e})",
                i % e.nrows(),
                i / e.nrows(),
                e[i],
                m.lp_norm(1)
            ),
        ));
    }
    Ok(e)
}

/// `Σ_{k=1..p} φ_k(A)·w_k` for the columns `w = [w_1, …, w_p]` (`n × p`), from one
/// exponential of the `(n + p)`-square block matrix of the module's note; also returns
/// `e^A` (the block's top-left corner), which a caller usually needs as well.
///
/// ```
/// use reckon::linalg::expm::phi_combination;
/// use nalgebra::DMatrix;
/// // scalar a: φ₁(a) = (e^a − 1)/a, φ₂(a) = (e^a − 1 − a)/a²
/// let a = DMatrix::from_element(1, 1, -0.7);
/// let w = DMatrix::from_row_slice(1, 2, &[1.0, 2.0]);
/// let (e, s) = phi_combination(&a, &w).unwrap();
/// let (ea, x) = ((-0.7f64).exp(), -0.7);
/// assert!((e[(0, 0)] - ea).abs() < 1e-15);
/// assert!((s[0] - ((ea - 1.0) / x + 2.0 * (ea - 1.0 - x) / (x * x))).abs() < 1e-15);
/// ```
pub fn phi_combination(a: &DMatrix<f64>, w: &DMatrix<f64>) -> Result<(DMatrix<f64>, nalgebra::DVector<f64>)> {
    let n = a.nrows();
    if !a.is_square() || w.nrows() != n {
        return Err(Error::invalid(
            "matrix",
            format!(
                "φ functions of a {}x{} matrix on {}x{} vectors",
                a.nrows(),
                a.ncols(),
                w.nrows(),
                w.ncols()
            ),
        ));
    }
    let p = w.ncols();
    let mut m = DMatrix::zeros(n + p, n + p);
    m.view_mut((0, 0), (n, n)).copy_from(a);
    // w_p … w_1 left to right, then the shift block: e^{[[A, W], [0, J]]} has
    // Σ φ_k(A) w_k in the top of its last column
    for k in 0..p {
        m.view_mut((0, n + k), (n, 1)).copy_from(&w.column(p - 1 - k));
        if k + 1 < p {
            m[(n + k, n + k + 1)] = 1.0;
        }
    }
    let e = expm(&m)?;
    let ea = e.view((0, 0), (n, n)).into_owned();
    let s = if p == 0 {
        nalgebra::DVector::zeros(n)
    } else {
        e.view((0, n + p - 1), (n, 1)).column(0).into_owned()
    };
    Ok((ea, s))
}

/// The zero-order-hold discretisation of `x' = A·x + B·u` over `h`:
/// `Φ = e^{Ah}`, `Γ = ∫₀ʰ e^{As} ds · B = h·φ₁(Ah)·B`, from one exponential of
/// `[[A, B], [0, 0]]·h` (whose top-right block is `Γ`).
///
/// ```
/// use reckon::linalg::expm::zoh;
/// use nalgebra::DMatrix;
/// // double integrator: Φ = [[1, h], [0, 1]], Γ = [h²/2, h]
/// let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, 0.0, 0.0]);
/// let b = DMatrix::from_column_slice(2, 1, &[0.0, 1.0]);
/// let (phi, gamma) = zoh(&a, &b, 0.5).unwrap();
/// assert_eq!((phi[(0, 1)], gamma[(0, 0)], gamma[(1, 0)]), (0.5, 0.125, 0.5));
/// ```
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, h: f64) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let n = a.nrows();
    if !a.is_square() || b.nrows() != n {
        return Err(Error::invalid(
            "matrix",
            format!("A is {}x{} and B is {}x{}", a.nrows(), a.ncols(), b.nrows(), b.ncols()),
        ));
    }
    if !h.is_finite() {
        return Err(Error::invalid("h", format!("a step of {h}")));
    }
    let m = b.ncols();
    let mut blk = DMatrix::zeros(n + m, n + m);
    blk.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    blk.view_mut((0, n), (n, m)).copy_from(&(b * h));
    let e = expm(&blk)?;
    Ok((e.view((0, 0), (n, n)).into_owned(), e.view((0, n), (n, m)).into_owned()))
}

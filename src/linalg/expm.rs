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
/// Errors: [`Error::InvalidInput`] for a non-square matrix, a non-finite entry (a
/// non-finite norm would make the number of squarings meaningless), a norm above
/// [`MAX_NORM`], or an exponential that overflows.
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
    let norm = m
        .column_iter()
        .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max);
    // finite entries (checked above): the sum is a number, ∞ at worst
    if norm > MAX_NORM {
        return Err(Error::invalid(
            "matrix",
            format!(
                "‖M‖₁ = {norm:e} is above {MAX_NORM:e}: scaling and squaring would leave no correct digit (or never end)"
            ),
        ));
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

/// The largest `‖M‖₁` [`expm`] takes. nalgebra's [`Matrix::exp`](nalgebra::Matrix::exp)
/// picks its number of squarings from 1-norms of powers of `M` and of `|M|` up to the
/// 27th: above `1.8e308^(1/27) ≈ 2.6e11` they overflow to ∞, `∞ as u64` is `u64::MAX`,
/// and the squaring loop never ends (the `solve` fuzz target found exponential Euler
/// hanging on a state of 2e23; with debug assertions the count overflows and panics).
/// Scaling such a matrix down first does not help: after `k` squarings a relative error
/// of `2ᵏ·ε` is left, so `diag(−1e200, −1)` would come out `diag(0, 1)`. So it is refused.
/// The bound sits just below the overflow (`2.5e11²⁷ ≈ 5e307`): a lower one (1e11 was
/// tried) refuses steps that nalgebra computed before, and exponential Euler on Robertson
/// to 1e11 then took 37 172 steps instead of the demo's < 5 000.
pub const MAX_NORM: f64 = 2.5e11;

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
/// // a w far larger than A leaves e^A and φ₁(A) exact (the result is linear in w, computed
/// // for a scaled w): before, the block's norm 1e200 set the squarings and e^{−1} came out 1
/// let big = DMatrix::from_element(1, 1, 1e200);
/// let (e, s) = phi_combination(&DMatrix::from_element(1, 1, -1.0), &big).unwrap();
/// assert!((e[(0, 0)] - (-1f64).exp()).abs() < 1e-15);
/// assert!((s[0] / 1e200 - (1.0 - (-1f64).exp())).abs() < 1e-14);
/// // and e^{631}·10¹⁹¹ overflows: an error, not a number
/// assert!(phi_combination(&DMatrix::from_element(1, 1, 631.0), &DMatrix::from_element(1, 1, 1e191)).is_err());
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
    // the result is linear in W: scale W down to A's size by a power of two (exact) and
    // the result back up, so that a large W does not set the scaling-and-squaring's
    // scale (the block's norm): with ‖W‖ ≫ ‖A‖ it halves A so often that e^{A/2^s} rounds
    // to I, and e^A came out as I (x' = 710·x with a held forcing of 10¹⁹¹ took a factor
    // 632 for e^{631} over one step)
    let beta = block_scale(a, w);
    let mut m = DMatrix::zeros(n + p, n + p);
    m.view_mut((0, 0), (n, n)).copy_from(a);
    // w_p … w_1 left to right, then the shift block: e^{[[A, W], [0, J]]} has
    // Σ φ_k(A) w_k in the top of its last column
    for k in 0..p {
        m.view_mut((0, n + k), (n, 1)).copy_from(&(w.column(p - 1 - k) * beta));
        if k + 1 < p {
            m[(n + k, n + k + 1)] = 1.0;
        }
    }
    let e = expm(&m)?;
    let ea = e.view((0, 0), (n, n)).into_owned();
    let s = if p == 0 {
        nalgebra::DVector::zeros(n)
    } else {
        e.view((0, n + p - 1), (n, 1)).column(0) / beta
    };
    if let Some(i) = s.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "matrix",
            format!("Σ φ_k(A)·w_k overflows (component {i} is {})", s[i]),
        ));
    }
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
    // Γ is linear in B: scaled as in phi_combination so that a large B does not set the
    // exponential's scaling
    let ah = a * h;
    let bh = b * h;
    let beta = block_scale(&ah, &bh);
    let mut blk = DMatrix::zeros(n + m, n + m);
    blk.view_mut((0, 0), (n, n)).copy_from(&ah);
    blk.view_mut((0, n), (n, m)).copy_from(&(bh * beta));
    let e = expm(&blk)?;
    let gamma = e.view((0, n), (n, m)) / beta;
    if let Some(i) = gamma.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "matrix",
            format!("the input matrix Γ overflows (entry {i} is {})", gamma[i]),
        ));
    }
    Ok((e.view((0, 0), (n, n)).into_owned(), gamma))
}

/// A power of two `β ≤ 1` that brings the block `W` of `[[A, W], [0, ·]]` down to about
/// `max(‖A‖₁, 1)` (1 when it is not larger): the results read off the exponential are
/// linear in `W`, so they are computed for `β·W` and divided by `β`, exactly.
fn block_scale(a: &DMatrix<f64>, w: &DMatrix<f64>) -> f64 {
    let wn = w.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let an = a.lp_norm(1).max(1.0);
    if !(wn.is_finite() && wn > an) {
        return 1.0;
    }
    let k = (wn / an).log2().floor() as i32;
    2f64.powi(-k.min(1000))
}

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
    // the 1-norm in log₂, from column sums that cannot overflow (each term is scaled by
    // the largest entry first)
    let biggest = m.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let norm = if biggest == 0.0 {
        0.0
    } else {
        let sum = m
            .column_iter()
            .map(|c| c.iter().map(|v| v.abs() / biggest).sum::<f64>())
            .fold(0.0, f64::max);
        (sum.log2() + biggest.log2()).exp2()
    };
    // (∞ for a sum that overflows: refused too)
    if norm.is_nan() || norm > MAX_NORM {
        return Err(Error::invalid(
            "matrix",
            format!(
                "‖M‖₁ = {norm:e} is above {MAX_NORM:e}: scaling and squaring would square the result more than 52 times and leave no correct digit"
            ),
        ));
    }
    // nalgebra takes part of its squaring count from ‖|A|²⁷‖₁ (|A| entrywise), which
    // overflows to ∞ once the spectral radius of |A| passes 2.6e11, even where A's own
    // powers are small (A = [[a, a], [−a, −a]] is nilpotent): the count is then
    // `∞ as u64` and the squaring loop never ends. Scale by 2⁻ᵏ until that norm is below
    // 2¹⁰⁰⁰ and square k times here: the same algorithm (the total scaling is nalgebra's
    // own where it had one), bit for bit nalgebra's result when k = 0.
    let log2_abs_power = log2_abs_power_norm(m, 27);
    let k = if log2_abs_power > 1000.0 {
        ((log2_abs_power - 1000.0) / 27.0).ceil() as i32
    } else {
        0
    };
    let mut e = if k == 0 { m.exp() } else { (m * 2f64.powi(-k)).exp() };
    for _ in 0..k {
        e = &e * &e;
    }
    if let Some(i) = e.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "matrix",
            format!(
                "the exponential overflows (entry ({}, {}) is {}; ‖M‖₁ = {:e})",
                i % e.nrows(),
                i / e.nrows(),
                e[i],
                norm
            ),
        ));
    }
    Ok(e)
}

/// `log₂ ‖|M|ᵖ‖₁` (`|M|` entrywise), by `p` products `vᵀ|M|` from `v = 1`, each result
/// normalised by its largest entry so that nothing overflows; `−∞` when the power is 0.
fn log2_abs_power_norm(m: &DMatrix<f64>, p: usize) -> f64 {
    let n = m.nrows();
    let mut v = vec![1.0; n];
    let mut w = vec![0.0; n];
    let mut log2 = 0.0;
    for _ in 0..p {
        for (j, wj) in w.iter_mut().enumerate() {
            *wj = m.column(j).iter().zip(&v).map(|(a, b)| a.abs() * b).sum();
        }
        let top = w.iter().fold(0.0f64, |a, &b| a.max(b));
        if top == 0.0 {
            return f64::NEG_INFINITY;
        }
        log2 += top.log2();
        v.iter_mut().zip(&w).for_each(|(vi, wi)| *vi = wi / top);
    }
    log2
}

/// The largest `‖M‖₁` [`expm`] takes: `θ₁₃·2⁵²` (θ₁₃ = 4.25, the largest norm nalgebra's
/// degree-13 Padé approximant takes unscaled). Scaling and squaring with `s` squarings
/// leaves a relative error up to `2ˢ·ε` in the slow part of a badly scaled matrix
/// (`diag(−10¹⁵, −1)` needs 48 squarings and its `e⁻¹` comes out 3 % off, as in every
/// implementation of the algorithm, scipy's and MATLAB's included); beyond 52 squarings
/// not one digit is left (`diag(−10²⁰⁰, −1)` would give `diag(0, 1)`), so such a matrix is
/// refused rather than answered. An adaptive method that meets this error shrinks its
/// step.
pub const MAX_NORM: f64 = 4.25 * 4_503_599_627_370_496.0;

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

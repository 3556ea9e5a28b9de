//! Spectral estimates of a large sparse Jacobian without forming it dense: the largest
//! `|λ|` by restarted Arnoldi with a Gershgorin bound, the smallest `|λ|` by the same
//! iteration on `J⁻¹` (shift-invert at 0) through faer's sparse LU ([`SparseLu`]).
//!
//! Every iteration is capped: one that does not meet its tolerance within
//! [`SpectralOptions::max_restarts`] restarts is [`Error::NoConvergence`], never a hang.

use crate::error::{Error, Quantity, Result};
use crate::jacobian::Pattern;
use crate::linalg::SparseLu;
use num_complex::Complex64;

/// From this many states on, the stiffness study estimates the spectrum sparse
/// ([`sparse_spectrum`]) instead of computing every eigenvalue dense, when the model
/// offers a sparse Jacobian (`System::sparse_jacobian`). Dense QR costs `O(n³)` per
/// point (the whole BRUSS study at 198 states took 15 s dense, 0.6 s sparse at 200); the sparse estimate costs a few
/// dozen products and solves with `J`, `O(nnz)` each.
///
/// ```
/// use reckon::linalg::arnoldi::SPARSE_MIN_STATES;
/// // BRUSS 1-D with N grid points has 2N states: sparse from N = 50
/// assert_eq!(SPARSE_MIN_STATES, 2 * 50);
/// ```
pub const SPARSE_MIN_STATES: usize = 100;

/// `‖A·x − θ·x‖ ≤ tol·|θ|` (or `|θ| ≥ (1 − tol)·G`) within `max_restarts` restarts of
/// `krylov` steps: the caps and tolerance of the Arnoldi iterations of [`dominant`] and
/// [`sparse_spectrum`].
///
/// The iteration builds a Krylov basis of `krylov` vectors, takes the Ritz value `θ` of
/// largest modulus and stops when its residual `‖A·x − θ·x‖ ≤ tol·|θ|` (`x` the unit
/// Ritz vector: `θ` is then an exact eigenvalue of a matrix within `tol·|θ|` of `A`), or,
/// with an upper bound `G ≥ ρ(A)` given, when `|θ| ≥ (1 − tol)·G`. Otherwise it restarts
/// from the Ritz vector, at most `max_restarts` times.
///
/// ```
/// use reckon::linalg::arnoldi::SpectralOptions;
/// let o = SpectralOptions::default();
/// assert_eq!((o.krylov, o.max_restarts), (200, 100));
/// assert_eq!(o.tol, 1e-4);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralOptions {
    /// Krylov basis size per restart (at most the matrix size is used).
    pub krylov: usize,
    /// Relative tolerance on the Ritz residual (or on the gap to the upper bound).
    pub tol: f64,
    /// Restarts before [`Error::NoConvergence`].
    pub max_restarts: usize,
}

impl Default for SpectralOptions {
    /// Up to 200 Krylov vectors, `tol = 1e-4`, 100 restarts: ρ(J) to 0.01 %, ample for a
    /// stiffness index, which is an order-of-magnitude measure. A warm-started or
    /// well-separated case converges at the first check (10 vectors); the top of a
    /// diffusion spectrum (BRUSS with 50–500 points: relative gaps near 10⁻³) needs the
    /// large basis, which 40 vectors with restarts did not reach within 100 restarts.
    fn default() -> Self {
        SpectralOptions {
            krylov: 200,
            tol: 1e-4,
            max_restarts: 100,
        }
    }
}

/// `y ← J·x` for `J` with non-zeros `values` in `pattern` (CSC).
///
/// ```
/// use reckon::jacobian::Pattern;
/// use reckon::linalg::arnoldi::spmv;
/// // [[2, 0], [1, 3]]: column 0 rows 0, 1; column 1 row 1
/// let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (1, 1)]).unwrap();
/// let mut y = [0.0; 2];
/// spmv(&p, &[2.0, 1.0, 3.0], &[1.0, 1.0], &mut y);
/// assert_eq!(y, [2.0, 4.0]);
/// ```
pub fn spmv(pattern: &Pattern, values: &[f64], x: &[f64], y: &mut [f64]) {
    y.fill(0.0);
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    for j in 0..pattern.n() {
        let xj = x[j];
        if xj == 0.0 {
            continue;
        }
        for k in cp[j]..cp[j + 1] {
            y[ri[k]] += values[k] * xj;
        }
    }
}

/// Gershgorin's bound `ρ(J) ≤ min(‖J‖∞, ‖J‖₁) = min(maxᵢ Σⱼ |Jᵢⱼ|, maxⱼ Σᵢ |Jᵢⱼ|)`: every
/// eigenvalue lies in a disc `|λ − Jᵢᵢ| ≤ Σ_{j≠i} |Jᵢⱼ|` (rows, and likewise columns, as
/// `Jᵀ` has the same eigenvalues). Rigorous and `O(nnz)`.
///
/// ```
/// use reckon::jacobian::Pattern;
/// use reckon::linalg::arnoldi::gershgorin;
/// // [[-4, 1], [2, -1]]: row sums 5, 3; column sums 6, 2
/// let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (0, 1), (1, 1)]).unwrap();
/// assert_eq!(gershgorin(&p, &[-4.0, 2.0, 1.0, -1.0]), 5.0);
/// ```
pub fn gershgorin(pattern: &Pattern, values: &[f64]) -> f64 {
    let n = pattern.n();
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    let mut rows = vec![0.0f64; n];
    let mut max_col = 0.0f64;
    for j in 0..n {
        let mut c = 0.0;
        for k in cp[j]..cp[j + 1] {
            rows[ri[k]] += values[k].abs();
            c += values[k].abs();
        }
        max_col = max_col.max(c);
    }
    rows.iter().copied().fold(0.0, f64::max).min(max_col)
}

/// `θ ≈ argmax |λ|` of a linear operator, with its residual `‖A·x − θ·x‖`: what
/// [`dominant`] returns.
///
/// ```
/// use reckon::linalg::arnoldi::{dominant, SpectralOptions};
/// let mut op = |x: &[f64], y: &mut [f64]| { y[0] = 3.0 * x[0]; y[1] = -7.0 * x[1]; };
/// let d = dominant(2, &mut op, &SpectralOptions::default(), None, "test", 0.0).unwrap();
/// assert!((d.value.re + 7.0).abs() < 1e-12 && d.residual < 1e-12 && d.products == 2);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dominant {
    /// The Ritz value `θ` of largest `|θ|`.
    pub value: Complex64,
    /// `‖A·x − θ·x‖` for its unit Ritz vector `x`.
    pub residual: f64,
    /// Products with the operator.
    pub products: usize,
    /// Restarts taken.
    pub restarts: usize,
}

/// The Ritz values are computed, and convergence tested, after this many Arnoldi steps and
/// twice, four times, … as many (10, 20, 40, 80, 160), and at the basis' end: the `k³`
/// cost of the small eigenproblem stays a fraction of the `k²·n` of the basis.
const CHECK_EVERY: usize = 10;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// A fixed start vector without zeros or structure (xorshift in `[0.5, 1.5)`): the same
/// numbers on every run.
fn start_vector(n: usize) -> Vec<f64> {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            0.5 + (s >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

/// The eigenvalue `θ` of largest `|θ|` of the `n × n` operator `y ← op(x)` by explicitly
/// restarted Arnoldi: a Krylov basis `V` of up to `opts.krylov` vectors (modified
/// Gram–Schmidt, repeated when it cancels), the Hessenberg `H = Vᵀ·A·V`, its eigenvalues by faer's QR, and the residual
/// `‖A·x − θ·x‖ = h_{m+1,m}·|y_m|` of the Ritz pair `(θ, x = V·y)`, tested after 10, 20,
/// 40, … steps and at the basis' end. Stops when the
/// residual is `≤ opts.tol·|θ|` or, given `upper ≥ ρ(A)`, when `|θ| ≥ (1 − opts.tol)·upper`;
/// otherwise restarts from the Ritz vector (its real and imaginary parts for a complex
/// pair). `what` and `t` label the errors: a non-finite product is [`Error::NonFinite`]
/// (quantity Jacobian), no convergence within `opts.max_restarts` restarts is
/// [`Error::NoConvergence`].
///
/// ```
/// use reckon::linalg::arnoldi::{dominant, SpectralOptions};
/// use reckon::Error;
/// // diag(1, 2, …, 50): θ = 50
/// let mut op = |x: &[f64], y: &mut [f64]| {
///     for i in 0..x.len() { y[i] = (i + 1) as f64 * x[i]; }
/// };
/// let d = dominant(50, &mut op, &SpectralOptions { tol: 1e-12, ..Default::default() }, None, "test", 0.0).unwrap();
/// assert!((d.value.re - 50.0).abs() < 1e-10 && d.value.im == 0.0);
/// // the cyclic shift: all 500 eigenvalues on the unit circle, none dominant
/// let mut shift = |x: &[f64], y: &mut [f64]| {
///     for i in 0..x.len() { y[(i + 1) % x.len()] = x[i]; }
/// };
/// let o = SpectralOptions { krylov: 10, tol: 1e-8, max_restarts: 20 };
/// let e = dominant(500, &mut shift, &o, None, "spectral radius", 2.5).unwrap_err();
/// assert_eq!(e, Error::NoConvergence { what: "spectral radius", t: 2.5 });
/// ```
pub fn dominant(
    n: usize,
    op: &mut dyn FnMut(&[f64], &mut [f64]),
    opts: &SpectralOptions,
    upper: Option<f64>,
    what: &'static str,
    t: f64,
) -> Result<Dominant> {
    dominant_from(n, op, opts, upper, &mut Vec::new(), what, t)
}

/// [`dominant`] started from `start` (a fixed pseudo-random vector when its length is not
/// `n`), which it leaves holding the final Ritz vector (real: see [`dominant`]): the warm
/// start of the next call on a nearby operator, e.g. the Jacobian at the next point of a
/// solution.
///
/// ```
/// use reckon::linalg::arnoldi::{dominant_from, SpectralOptions};
/// let mut op = |x: &[f64], y: &mut [f64]| {
///     for i in 0..x.len() { y[i] = -((i + 1) as f64) * x[i]; }
/// };
/// let o = SpectralOptions { krylov: 10, tol: 1e-10, max_restarts: 100 };
/// let mut start = Vec::new();
/// let cold = dominant_from(200, &mut op, &o, None, &mut start, "test", 0.0).unwrap();
/// let warm = dominant_from(200, &mut op, &o, None, &mut start, "test", 0.0).unwrap();
/// assert!((warm.value.re + 200.0).abs() < 1e-6 && warm.products < cold.products);
/// ```
pub fn dominant_from(
    n: usize,
    op: &mut dyn FnMut(&[f64], &mut [f64]),
    opts: &SpectralOptions,
    upper: Option<f64>,
    start: &mut Vec<f64>,
    what: &'static str,
    t: f64,
) -> Result<Dominant> {
    if n == 0 {
        return Ok(Dominant {
            value: Complex64::new(0.0, 0.0),
            residual: 0.0,
            products: 0,
            restarts: 0,
        });
    }
    if !(opts.tol.is_finite() && opts.tol > 0.0) || opts.krylov == 0 {
        return Err(Error::invalid(
            "spectral options",
            format!(
                "tol must be positive and finite and krylov at least 1, got tol {} and krylov {}",
                opts.tol, opts.krylov
            ),
        ));
    }
    let m = opts.krylov.min(n);
    // the basis grows as the iteration needs it: a warm start that converges at the
    // first check holds 11 vectors, not `krylov`
    let mut v = vec![0.0; n];
    let mut x = if start.len() == n {
        std::mem::take(start)
    } else {
        start_vector(n)
    };
    let mut products = 0;
    for restart in 0..=opts.max_restarts {
        let norm = dot(&x, &x).sqrt();
        if !(norm.is_finite() && norm > 0.0) {
            // the Ritz vector vanished (cannot happen in exact arithmetic): start afresh
            x = start_vector(n);
        }
        let norm = dot(&x, &x).sqrt();
        for (vi, xi) in v[..n].iter_mut().zip(&x) {
            *vi = xi / norm;
        }
        let mut h = vec![0.0; (m + 1) * m]; // column-major (m + 1) × m
        let mut restart_from: Option<(Complex64, Vec<Complex64>)> = None;
        for j in 0..m {
            if v.len() < (j + 2) * n {
                v.resize((j + 2) * n, 0.0);
            }
            let (basis, rest) = v.split_at_mut((j + 1) * n);
            let w = &mut rest[..n];
            op(&basis[j * n..(j + 1) * n], w);
            products += 1;
            if let Some(c) = w.iter().position(|z| !z.is_finite()) {
                return Err(Error::NonFinite {
                    t,
                    quantity: Quantity::Jacobian,
                    component: c,
                });
            }
            let w0 = dot(w, w).sqrt();
            let mut beta = w0;
            // modified Gram–Schmidt, repeated once when it cancelled much (DGKS)
            for pass in 0..2 {
                if pass == 1 && beta > 0.717 * w0 {
                    break;
                }
                for i in 0..=j {
                    let vi = &basis[i * n..(i + 1) * n];
                    let c = dot(vi, w);
                    h[j * (m + 1) + i] += c;
                    for (wz, vz) in w.iter_mut().zip(vi) {
                        *wz -= c * vz;
                    }
                }
                beta = dot(w, w).sqrt();
            }
            // an invariant subspace: the Ritz values are eigenvalues of A
            let breakdown = beta <= 1e-13 * w0 || beta == 0.0;
            h[j * (m + 1) + j + 1] = if breakdown { 0.0 } else { beta };
            if !breakdown {
                for wz in w.iter_mut() {
                    *wz /= beta;
                }
            }
            let k = j + 1;
            if !(breakdown || k == m || (k.is_multiple_of(CHECK_EVERY) && (k / CHECK_EVERY).is_power_of_two())) {
                continue;
            }
            let hk = faer::Mat::<f64>::from_fn(k, k, |a, b| h[b * (m + 1) + a]);
            let eig = hk.eigen().map_err(|_| Error::NoConvergence { what, t })?;
            let (s, u) = (eig.S().column_vector(), eig.U());
            let mut best = 0;
            for i in 1..k {
                if s[i].norm() > s[best].norm() {
                    best = i;
                }
            }
            let theta = Complex64::new(s[best].re, s[best].im);
            let y: Vec<Complex64> = (0..k)
                .map(|i| Complex64::new(u[(i, best)].re, u[(i, best)].im))
                .collect();
            let ynorm = y.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt();
            let beta = h[j * (m + 1) + j + 1];
            let residual = if ynorm > 0.0 {
                beta * y[k - 1].norm() / ynorm
            } else {
                beta
            };
            if !theta.re.is_finite() || !theta.im.is_finite() || !residual.is_finite() {
                return Err(Error::NoConvergence { what, t });
            }
            let by_residual = residual <= opts.tol * theta.norm();
            let by_bound = upper.is_some_and(|g| theta.norm() >= (1.0 - opts.tol) * g);
            if by_residual || by_bound {
                *start = ritz_vector(theta, &y, &v, n);
                return Ok(Dominant {
                    value: theta,
                    residual,
                    products,
                    restarts: restart,
                });
            }
            if breakdown || k == m {
                restart_from = Some((theta, y));
                break;
            }
        }
        let Some((theta, y)) = restart_from else {
            return Err(Error::NoConvergence { what, t });
        };
        x = ritz_vector(theta, &y, &v, n);
    }
    Err(Error::NoConvergence { what, t })
}

/// A real vector of the Ritz pair `(θ, V·y)`: for a real `θ` the larger of `Re(V·y)`,
/// `Im(V·y)` (`y` may carry any phase), for a complex pair their sum (both lie in its
/// real invariant plane).
fn ritz_vector(theta: Complex64, y: &[Complex64], v: &[f64], n: usize) -> Vec<f64> {
    let (re, im): (Vec<f64>, Vec<f64>) = y.iter().map(|z| (z.re, z.im)).unzip();
    let (nre, nim) = (dot(&re, &re), dot(&im, &im));
    let coef: Vec<f64> = if theta.im.abs() <= 1e-12 * theta.norm() {
        if nre >= nim { re } else { im }
    } else {
        re.iter().zip(&im).map(|(a, b)| a + b).collect()
    };
    let mut x = vec![0.0; n];
    for (i, c) in coef.iter().enumerate() {
        for (xz, vz) in x.iter_mut().zip(&v[i * n..(i + 1) * n]) {
            *xz += c * vz;
        }
    }
    x
}

/// `ρ(J) = |λ_max|`, `λ_min`, Gershgorin's bound and `ρ(J)/|λ_min|`: what
/// [`sparse_spectrum`] estimates of `J` at one point.
///
/// ```
/// use reckon::jacobian::Pattern;
/// use reckon::linalg::arnoldi::{sparse_spectrum, SpectralOptions};
/// // diag(−1, −10, −100)
/// let p = Pattern::from_entries(3, &[(0, 0), (1, 1), (2, 2)]).unwrap();
/// let s = sparse_spectrum(0.0, &p, &[-1.0, -10.0, -100.0], &SpectralOptions::default()).unwrap();
/// assert!((s.spectral_radius - 100.0).abs() < 1e-10 && (s.smallest.re + 1.0).abs() < 1e-12);
/// assert!((s.ratio - 100.0).abs() < 1e-9 && s.gershgorin == 100.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SparseSpectrum {
    /// `ρ(J) ≈ |λ_max|`, the Arnoldi estimate of the largest `|λ|`.
    pub spectral_radius: f64,
    /// The eigenvalue `λ_max` of largest modulus.
    pub largest: Complex64,
    /// Gershgorin's rigorous upper bound on `ρ(J)` ([`gershgorin`]).
    pub gershgorin: f64,
    /// The eigenvalue `λ_min` of smallest modulus (0 when `J` is singular).
    pub smallest: Complex64,
    /// `ρ(J) / |λ_min|` (∞ for a singular `J`, 1 for `J = 0`).
    pub ratio: f64,
    /// Products with `J` and solves with `J` (after one sparse LU of `J`).
    pub products: usize,
    /// Solves with the LU of `J`.
    pub solves: usize,
}

/// The largest and smallest `|λ|` of the sparse `J` (non-zeros `values` in `pattern`) at
/// time `t`: `λ_max` by [`dominant`] on `x ↦ J·x` with the [`gershgorin`] bound, `λ_min =
/// 1/μ` with `μ` the dominant eigenvalue of `J⁻¹` (one sparse LU of `J`, then solves),
/// and the magnitude ratio `ρ(J)/|λ_min|`. A `J` whose LU finds no pivot is singular:
/// `λ_min = 0`, ratio ∞. A non-finite entry is [`Error::NonFinite`] (quantity Jacobian,
/// at its row-major index `row·n + col`), an iteration that misses `opts.tol` within its
/// restarts [`Error::NoConvergence`] (`what`: "spectral radius" or "smallest eigenvalue").
///
/// ```
/// use reckon::jacobian::Pattern;
/// use reckon::linalg::arnoldi::{sparse_spectrum, SpectralOptions};
/// // the 1-D Laplacian tridiag(1, −2, 1), n = 30: λ_k = −4 sin²(kπ/62)
/// let n = 30;
/// let mut e = Vec::new();
/// for i in 0..n { e.push((i, i)); if i + 1 < n { e.push((i + 1, i)); e.push((i, i + 1)); } }
/// let p = Pattern::from_entries(n, &e).unwrap();
/// let v: Vec<f64> = p.entries().map(|(r, c)| if r == c { -2.0 } else { 1.0 }).collect();
/// let o = SpectralOptions { tol: 1e-12, ..Default::default() };
/// let s = sparse_spectrum(0.0, &p, &v, &o).unwrap();
/// let lam = |k: f64| -4.0 * (k * std::f64::consts::PI / 62.0).sin().powi(2);
/// assert!((s.spectral_radius - lam(30.0).abs()).abs() < 1e-10);
/// assert!((s.smallest.re - lam(1.0)).abs() < 1e-10);
/// assert!(s.gershgorin >= s.spectral_radius && s.gershgorin == 4.0);
/// ```
pub fn sparse_spectrum(t: f64, pattern: &Pattern, values: &[f64], opts: &SpectralOptions) -> Result<SparseSpectrum> {
    sparse_spectrum_with(t, pattern, values, opts, &mut SpectralWorkspace::default())
}

/// `(x_J, x_{J⁻¹}, LU)`, what [`sparse_spectrum_with`] keeps between calls: the last Ritz vectors of `J` and
/// `J⁻¹` (warm starts) and the sparse LU with its symbolic analysis (COLAMD order), redone
/// only when the pattern changes.
///
/// ```
/// use reckon::linalg::arnoldi::SpectralWorkspace;
/// let ws = SpectralWorkspace::default(); // empty: the first call starts cold
/// assert!(format!("{ws:?}").starts_with("SpectralWorkspace"));
/// ```
#[derive(Debug, Default)]
pub struct SpectralWorkspace {
    big: Vec<f64>,
    small: Vec<f64>,
    lu: Option<(Pattern, Option<SparseLu>)>,
}

/// [`sparse_spectrum`] reusing `ws` from the previous call: the Arnoldi iterations start
/// from the previous Ritz vectors (the Jacobians at nearby points of a solution have
/// nearby dominant eigenvectors, so they converge in a few products) and the LU's
/// symbolic analysis is kept for the same pattern. The results meet the same tolerance.
///
/// ```
/// use reckon::jacobian::Pattern;
/// use reckon::linalg::arnoldi::{sparse_spectrum_with, SpectralOptions, SpectralWorkspace};
/// // diag(−1, −2, …, −300) and then twice that
/// let p = Pattern::from_entries(300, &(0..300).map(|i| (i, i)).collect::<Vec<_>>()).unwrap();
/// let v: Vec<f64> = (0..300).map(|i| -((i + 1) as f64)).collect();
/// let (o, mut ws) = (SpectralOptions { tol: 1e-10, ..Default::default() }, SpectralWorkspace::default());
/// let a = sparse_spectrum_with(0.0, &p, &v, &o, &mut ws).unwrap();
/// let v2: Vec<f64> = v.iter().map(|x| 2.0 * x).collect();
/// let b = sparse_spectrum_with(1.0, &p, &v2, &o, &mut ws).unwrap();
/// assert!((a.spectral_radius - 300.0).abs() < 1e-6 && (b.spectral_radius - 600.0).abs() < 1e-6);
/// assert!((a.smallest.re + 1.0).abs() < 1e-8 && (b.ratio - 300.0).abs() < 1e-5);
/// ```
pub fn sparse_spectrum_with(
    t: f64,
    pattern: &Pattern,
    values: &[f64],
    opts: &SpectralOptions,
    ws: &mut SpectralWorkspace,
) -> Result<SparseSpectrum> {
    let n = pattern.n();
    if values.len() != pattern.nnz() {
        return Err(Error::invalid(
            "jacobian",
            format!("{} values for a pattern of {} non-zeros", values.len(), pattern.nnz()),
        ));
    }
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        let col = pattern.col_ptr().partition_point(|&c| c <= k) - 1;
        return Err(Error::NonFinite {
            t,
            quantity: Quantity::Jacobian,
            component: pattern.row_idx()[k] * n + col,
        });
    }
    let g = gershgorin(pattern, values);
    let mut jx = |x: &[f64], y: &mut [f64]| spmv(pattern, values, x, y);
    let big = dominant_from(n, &mut jx, opts, Some(g), &mut ws.big, "spectral radius", t)?;
    let rho = big.value.norm();
    let zero = Complex64::new(0.0, 0.0);
    let mut out = SparseSpectrum {
        spectral_radius: rho,
        largest: big.value,
        gershgorin: g,
        smallest: zero,
        ratio: if rho == 0.0 { 1.0 } else { f64::INFINITY },
        products: big.products,
        solves: 0,
    };
    if rho == 0.0 || n == 0 {
        return Ok(out);
    }
    if ws.lu.as_ref().is_none_or(|(p, _)| p != pattern) {
        ws.lu = Some((pattern.clone(), SparseLu::new(pattern)));
    }
    let Some((_, Some(lu))) = ws.lu.as_mut() else {
        return Ok(out); // structurally singular
    };
    if !lu.factor(values)? {
        return Ok(out);
    }
    let mut inv = |x: &[f64], y: &mut [f64]| {
        y.copy_from_slice(x);
        // n entries, factored just above; were it refused, NaN stops the iteration
        if lu.solve_in_place(y).is_err() {
            y.fill(f64::NAN);
        }
    };
    let small = dominant_from(n, &mut inv, opts, None, &mut ws.small, "smallest eigenvalue", t)?;
    out.solves = small.products;
    if small.value.norm() > 0.0 {
        out.smallest = small.value.inv();
        out.ratio = rho / out.smallest.norm();
    }
    Ok(out)
}

//! Kalman prediction and correction, the EKF with step-map Jacobians by automatic
//! differentiation, landmark SLAM for an underwater robot, and Gaussians on SE(2) and
//! SE(3) in the tangent space ([`manifold`]).
//!
//! Notation follows the robotics teaching material reckon reproduces: estimate `x̂`,
//! covariance `Γ`, evolution `x ← A·x + u + α` with `α ~ N(0, Γ_α)`, observation
//! `y = C·x + β` with `β ~ N(0, Γ_β)`.

pub mod manifold;
pub mod slam;
pub mod step;

use crate::error::{Error, Result};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};

/// A Gaussian estimate `x ~ N(x̂, Γ)`, fixed or dynamic size.
#[derive(Debug, Clone, PartialEq)]
pub struct Kalman<D: Dim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Mean `x̂`.
    pub x: OVector<f64, D>,
    /// Covariance `Γ`.
    pub p: OMatrix<f64, D, D>,
}

/// What a correction saw: innovation `ỹ = y − C x̂` and its covariance `S = CΓCᵀ + Γ_β`.
#[derive(Debug, Clone, PartialEq)]
pub struct Innovation<M: Dim>
where
    DefaultAllocator: Allocator<M> + Allocator<M, M>,
{
    /// `ỹ`.
    pub y: OVector<f64, M>,
    /// `S`.
    pub s: OMatrix<f64, M, M>,
}

impl<M: Dim> Innovation<M>
where
    DefaultAllocator: Allocator<M> + Allocator<M, M>,
{
    /// Squared Mahalanobis distance `ỹᵀ S⁻¹ ỹ` (χ² with dim(y) degrees of freedom when consistent).
    pub fn nis(&self) -> f64 {
        match self.s.clone().cholesky() {
            Some(c) => self.y.dot(&c.solve(&self.y)),
            None => f64::INFINITY,
        }
    }
}

impl<D: Dim> Kalman<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// An estimate with mean `x` and covariance `p`.
    pub fn new(x: OVector<f64, D>, p: OMatrix<f64, D, D>) -> Self {
        Kalman { x, p }
    }

    /// Prediction: `x̂ ← A·x̂ + u`, `Γ ← A·Γ·Aᵀ + Γ_α`.
    ///
    /// ```
    /// use reckon::kalman::Kalman;
    /// use nalgebra::{Matrix2, Vector2};
    /// let mut k = Kalman::new(Vector2::new(0.0, 1.0), Matrix2::identity());
    /// let a = Matrix2::new(1.0, 0.1, 0.0, 1.0); // position += 0.1·velocity
    /// k.predict(&a, &Vector2::zeros(), &(Matrix2::identity() * 0.01)).unwrap();
    /// assert!((k.x[0] - 0.1).abs() < 1e-15);
    /// assert!((k.p[(0, 0)] - 1.02).abs() < 1e-15); // 1 + 0.1² + 0.01
    /// ```
    /// Dimensions that do not match (dynamic sizes) are [`Error::InvalidInput`].
    pub fn predict(&mut self, a: &OMatrix<f64, D, D>, u: &OVector<f64, D>, q: &OMatrix<f64, D, D>) -> Result<()> {
        let n = self.x.len();
        if a.shape() != (n, n) || u.len() != n || q.shape() != (n, n) || self.p.shape() != (n, n) {
            return Err(Error::invalid(
                "kalman",
                format!(
                    "predict with a state of {n}: A {:?}, u {}, Γ_α {:?}, Γ {:?}",
                    a.shape(),
                    u.len(),
                    q.shape(),
                    self.p.shape()
                ),
            ));
        }
        self.x = a * &self.x + u;
        self.p = a * &self.p * a.transpose() + q;
        symmetrize(&mut self.p);
        Ok(())
    }

    /// Correction with `y = C·x + β`, `β ~ N(0, Γ_β)`: innovation `ỹ = y − C x̂`,
    /// `S = CΓCᵀ + Γ_β`, gain `K = ΓCᵀS⁻¹`, `x̂ ← x̂ + Kỹ`, and the Joseph form
    /// `Γ ← (I − KC)Γ(I − KC)ᵀ + KΓ_βKᵀ`, which stays symmetric positive semi-definite.
    /// A non-positive-definite `S` is [`Error::NotPositiveDefinite`].
    ///
    /// ```
    /// use reckon::kalman::Kalman;
    /// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
    /// let mut k = Kalman::new(Vector2::new(0.0, 0.0), Matrix2::identity() * 4.0);
    /// // measure the first component with variance 4: the mean moves halfway, the variance halves
    /// k.correct(&Vector1::new(2.0), &Matrix1x2::new(1.0, 0.0), &Matrix1::new(4.0)).unwrap();
    /// assert!((k.x[0] - 1.0).abs() < 1e-15 && (k.p[(0, 0)] - 2.0).abs() < 1e-15);
    /// assert_eq!(k.p[(1, 1)], 4.0);
    /// ```
    pub fn correct<M: Dim>(
        &mut self,
        y: &OVector<f64, M>,
        c: &OMatrix<f64, M, D>,
        r: &OMatrix<f64, M, M>,
    ) -> Result<Innovation<M>>
    where
        DefaultAllocator: Allocator<M> + Allocator<M, M> + Allocator<M, D> + Allocator<D, M>,
    {
        let (n, m) = (self.x.len(), y.len());
        if c.shape() != (m, n) || r.shape() != (m, m) || self.p.shape() != (n, n) {
            return Err(Error::invalid(
                "kalman",
                format!(
                    "correct with a state of {n} and {m} measurements: C {:?}, Γ_β {:?}",
                    c.shape(),
                    r.shape()
                ),
            ));
        }
        let innovation = y - c * &self.x;
        let s = c * &self.p * c.transpose() + r;
        let chol = s.clone().cholesky().ok_or(Error::NotPositiveDefinite {
            what: "innovation covariance S",
        })?;
        // K = Γ Cᵀ S⁻¹  ⇔  S Kᵀ = C Γ (S symmetric)
        let kt = chol.solve(&(c * &self.p));
        let k = kt.transpose();
        self.x += &k * &innovation;
        let (r_dim, _) = self.p.shape_generic();
        let i_kc = OMatrix::<f64, D, D>::identity_generic(r_dim, r_dim) - &k * c;
        self.p = &i_kc * &self.p * i_kc.transpose() + &k * r * k.transpose();
        symmetrize(&mut self.p);
        Ok(Innovation { y: innovation, s })
    }
}

fn symmetrize<D: Dim>(p: &mut OMatrix<f64, D, D>)
where
    DefaultAllocator: Allocator<D, D>,
{
    let n = p.nrows();
    for i in 0..n {
        for j in 0..i {
            let m = 0.5 * (p[(i, j)] + p[(j, i)]);
            p[(i, j)] = m;
            p[(j, i)] = m;
        }
    }
}

/// The discrete process noise of `x' = A·x + G·w`, `w` white with spectral density `Q`,
/// over a step `h`: `Q_d = ∫₀ʰ e^{As}·G·Q·Gᵀ·e^{Aᵀs} ds`, by Van Loan's method (1978):
/// `exp([[−A, G Q Gᵀ], [0, Aᵀ]]·h) = [[·, F₁₂], [0, F₂₂]]`, `Φ = F₂₂ᵀ`, `Q_d = Φ·F₁₂`,
/// symmetrised. Van Loan's block holds `e^{−Ah}`, which for a stiff `A` is huge and
/// cancels in `Φ·F₁₂`, so the block is taken over `h/2^k` with `‖A‖₁·h/2^k ≤ 1` and
/// doubled back, `Q_d(2τ) = Q_d(τ) + Φ(τ)·Q_d(τ)·Φ(τ)ᵀ`, `Φ(2τ) = Φ(τ)²` (exact
/// identities of the integral), which keeps the relative accuracy of the exponential.
///
/// The constant-velocity model (position, velocity; white acceleration of density `q`):
///
/// ```
/// use reckon::kalman::discretise_noise;
/// use nalgebra::{Matrix1, Matrix2, Vector2};
/// let (h, q) = (0.1, 2.0);
/// let a = Matrix2::new(0.0, 1.0, 0.0, 0.0);
/// let qd = discretise_noise(&a, &Vector2::new(0.0, 1.0), &Matrix1::new(q), h).unwrap();
/// let want = Matrix2::new(h * h * h / 3.0, h * h / 2.0, h * h / 2.0, h) * q;
/// assert!((qd - want).amax() < 1e-16);
/// ```
///
/// Errors: [`Error::InvalidInput`] for sizes that do not match, a non-finite entry or
/// `h`, or `h < 0`.
pub fn discretise_noise<D: Dim, W: Dim>(
    a: &OMatrix<f64, D, D>,
    g: &OMatrix<f64, D, W>,
    q: &OMatrix<f64, W, W>,
    h: f64,
) -> Result<OMatrix<f64, D, D>>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D, W> + Allocator<W, W>,
{
    let n = a.nrows();
    let w = g.ncols();
    if a.ncols() != n || g.nrows() != n || q.nrows() != w || q.ncols() != w {
        return Err(Error::invalid(
            "noise",
            format!(
                "A is {}x{}, G is {}x{}, Q is {}x{}",
                a.nrows(),
                a.ncols(),
                g.nrows(),
                g.ncols(),
                q.nrows(),
                q.ncols()
            ),
        ));
    }
    if !(h.is_finite() && h >= 0.0) {
        return Err(Error::invalid("h", format!("a noise step of {h}")));
    }
    let ad = nalgebra::DMatrix::from_column_slice(n, n, a.as_slice());
    let gd = nalgebra::DMatrix::from_column_slice(n, w, g.as_slice());
    let qq = nalgebra::DMatrix::from_column_slice(w, w, q.as_slice());
    let gqg = &gd * qq * gd.transpose();
    let norm = ad.lp_norm(1) * h;
    let k = if norm > 1.0 { norm.log2().ceil() as i32 } else { 0 };
    let tau = h / 2f64.powi(k);
    let mut m = nalgebra::DMatrix::zeros(2 * n, 2 * n);
    m.view_mut((0, 0), (n, n)).copy_from(&(-&ad * tau));
    m.view_mut((0, n), (n, n)).copy_from(&(&gqg * tau));
    m.view_mut((n, n), (n, n)).copy_from(&(ad.transpose() * tau));
    let e = crate::linalg::expm::expm(&m)?;
    let mut phi = e.view((n, n), (n, n)).transpose();
    let mut qd = &phi * e.view((0, n), (n, n));
    for _ in 0..k {
        qd = &qd + &phi * &qd * phi.transpose();
        phi = &phi * &phi;
    }
    let qd = (&qd + qd.transpose()) * 0.5;
    if let Some(i) = qd.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "noise",
            format!("Q_d overflows (entry {i} is {})", qd[i]),
        ));
    }
    let (r, c) = a.shape_generic();
    Ok(OMatrix::<f64, D, D>::from_column_slice_generic(r, c, qd.as_slice()))
}

/// Semi-axes and orientation of the confidence ellipse of a 2-D Gaussian at level `η`:
/// the region `(x − x̂)ᵀΓ⁻¹(x − x̂) ≤ a²` with `a = √(−2 ln(1 − η))` (η = 0.9 gives
/// a = 2.146). Returns `(a·√λ₁, a·√λ₂, angle of the first axis)`.
///
/// ```
/// use reckon::kalman::confidence_ellipse;
/// use nalgebra::Matrix2;
/// let (r1, r2, _) = confidence_ellipse(&Matrix2::new(4.0, 0.0, 0.0, 1.0), 0.9);
/// let a = (-2.0 * (1.0f64 - 0.9).ln()).sqrt();
/// assert!((r1.max(r2) - 2.0 * a).abs() < 1e-12 && (r1.min(r2) - a).abs() < 1e-12);
/// ```
pub fn confidence_ellipse(p: &nalgebra::Matrix2<f64>, eta: f64) -> (f64, f64, f64) {
    let a = (-2.0 * (1.0 - eta).ln()).sqrt();
    let e = p.symmetric_eigen();
    let v = e.eigenvectors.column(0);
    (
        a * e.eigenvalues[0].max(0.0).sqrt(),
        a * e.eigenvalues[1].max(0.0).sqrt(),
        v[1].atan2(v[0]),
    )
}

/// `(x − x̂)ᵀ Γ⁻¹ (x − x̂)` for a 2-D Gaussian; inside the η-ellipse when `≤ −2 ln(1 − η)`.
pub fn mahalanobis2(x: &nalgebra::Vector2<f64>, mean: &nalgebra::Vector2<f64>, p: &nalgebra::Matrix2<f64>) -> f64 {
    let d = x - mean;
    match p.try_inverse() {
        Some(inv) => d.dot(&(inv * d)),
        None => f64::INFINITY,
    }
}

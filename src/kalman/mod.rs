//! Kalman prediction and correction, the EKF with step-map Jacobians by automatic
//! differentiation, and landmark SLAM for an underwater robot.
//!
//! Notation follows the robotics teaching material reckon reproduces: estimate `x̂`,
//! covariance `Γ`, evolution `x ← A·x + u + α` with `α ~ N(0, Γ_α)`, observation
//! `y = C·x + β` with `β ~ N(0, Γ_β)`.

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

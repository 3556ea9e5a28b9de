//! SE(2), planar poses `(θ, t)` acting as `p ↦ R(θ)·p + t`; tangent `ξ = (ρ_x, ρ_y, θ)`,
//! translation first as GTSAM's `Pose2`. Notation: Solà et al. 2018, "A micro Lie
//! theory", §C (same order).

use super::{SMALL, rodrigues};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use std::f64::consts::{PI, TAU};
use std::ops::Mul;

/// A planar pose `(θ, t) ∈ SE(2)`, the matrix `[[R(θ), t], [0, 1]]`; `θ` is kept in
/// `(−π, π]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Se2 {
    theta: f64,
    /// Translation `t`.
    pub translation: Vector2<f64>,
}

/// `θ` wrapped to `(−π, π]`.
fn wrap(t: f64) -> f64 {
    let w = t - TAU * (t / TAU).round();
    if w <= -PI { w + TAU } else { w }
}

/// `(sin θ/θ, (1 − cos θ)/θ, (θ − sin θ)/θ², (1 − cos θ)/θ²)`, without cancellation.
fn coefficients(t: f64) -> (f64, f64, f64, f64) {
    let (a, f, c) = rodrigues(t.abs());
    (a, t * f, t * c, f)
}

/// `V(θ)⁻¹ = [[α, θ/2], [−θ/2, α]]`, `α = (θ/2)·cot(θ/2)`, where `V(θ) = [[a, −b], [b, a]]`.
fn v_inv(t: f64) -> Matrix2<f64> {
    let alpha = if t.abs() < SMALL {
        let t2 = t * t;
        1.0 - t2 / 12.0 * (1.0 + t2 / 60.0)
    } else {
        0.5 * t / (0.5 * t).tan()
    };
    Matrix2::new(alpha, 0.5 * t, -0.5 * t, alpha)
}

/// `[[A, c], [0, 1]]` as a 3×3 matrix.
fn blocks(a: &Matrix2<f64>, c: &Vector2<f64>) -> Matrix3<f64> {
    Matrix3::new(a[(0, 0)], a[(0, 1)], c[0], a[(1, 0)], a[(1, 1)], c[1], 0.0, 0.0, 1.0)
}

impl Se2 {
    /// `(θ, t)`, `θ` wrapped to `(−π, π]`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let g = Se2::new(3.0 * std::f64::consts::PI, vector![1.0, 2.0]);
    /// assert!((g.angle() - std::f64::consts::PI).abs() < 1e-15);
    /// ```
    pub fn new(theta: f64, translation: Vector2<f64>) -> Self {
        Se2 {
            theta: wrap(theta),
            translation,
        }
    }

    /// The identity `(0, 0)`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// assert_eq!(Se2::identity().matrix(), nalgebra::Matrix3::identity());
    /// ```
    pub fn identity() -> Self {
        Se2::new(0.0, Vector2::zeros())
    }

    /// The heading `θ ∈ (−π, π]`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// assert_eq!(Se2::new(-0.5, nalgebra::Vector2::zeros()).angle(), -0.5);
    /// ```
    pub fn angle(&self) -> f64 {
        self.theta
    }

    /// The rotation `R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// let r = Se2::new(std::f64::consts::FRAC_PI_2, nalgebra::Vector2::zeros()).rotation();
    /// assert!((r[(1, 0)] - 1.0).abs() < 1e-15);
    /// ```
    pub fn rotation(&self) -> Matrix2<f64> {
        let (s, c) = self.theta.sin_cos();
        Matrix2::new(c, -s, s, c)
    }

    /// The homogeneous matrix `[[R(θ), t], [0, 1]]`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let m = Se2::new(0.0, vector![1.0, 2.0]).matrix();
    /// assert_eq!((m[(0, 2)], m[(1, 2)], m[(2, 2)]), (1.0, 2.0, 1.0));
    /// ```
    pub fn matrix(&self) -> Matrix3<f64> {
        blocks(&self.rotation(), &self.translation)
    }

    /// `Exp(ρ, θ) = (θ, V(θ)·ρ)`, `V(θ) = [[sin θ/θ, −(1 − cos θ)/θ], [(1 − cos θ)/θ, sin θ/θ]]`:
    /// the pose after unit time at constant body velocity `ρ` and turn rate `θ` (the
    /// unicycle arc).
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// use std::f64::consts::PI;
    /// // half a circle at 1 m/s: radius 1/π, ends at (0, 2/π)
    /// let g = Se2::exp(&vector![1.0, 0.0, PI]);
    /// assert!((g.translation - vector![0.0, 2.0 / PI]).norm() < 1e-15);
    /// ```
    pub fn exp(xi: &Vector3<f64>) -> Self {
        let t = xi[2];
        let (a, b, _, _) = coefficients(t);
        let v = Matrix2::new(a, -b, b, a);
        Se2::new(t, v * Vector2::new(xi[0], xi[1]))
    }

    /// `Log(θ, t) = (V(θ)⁻¹·t, θ)` with `V(θ)⁻¹ = [[α, θ/2], [−θ/2, α]]`,
    /// `α = (θ/2)·cot(θ/2)`, `θ ∈ (−π, π]`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let xi = vector![1.0, -2.0, 3.1];
    /// assert!((Se2::exp(&xi).log() - xi).norm() < 1e-14);
    /// ```
    pub fn log(&self) -> Vector3<f64> {
        let rho = v_inv(self.theta) * self.translation;
        Vector3::new(rho[0], rho[1], self.theta)
    }

    /// `g₁·g₂ = (θ₁ + θ₂, R(θ₁)·t₂ + t₁)`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let (a, b) = (Se2::new(0.5, vector![1.0, 0.0]), Se2::new(-0.2, vector![0.0, 3.0]));
    /// let p = vector![0.3, 0.4];
    /// assert!((a.compose(&b).act(&p) - a.act(&b.act(&p))).norm() < 1e-15);
    /// ```
    pub fn compose(&self, other: &Se2) -> Se2 {
        Se2::new(
            self.theta + other.theta,
            self.rotation() * other.translation + self.translation,
        )
    }

    /// `g⁻¹ = (−θ, −R(θ)ᵀ·t)`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let g = Se2::new(2.0, vector![1.0, -1.0]);
    /// assert!(g.compose(&g.inverse()).log().norm() < 1e-15);
    /// ```
    pub fn inverse(&self) -> Se2 {
        Se2::new(-self.theta, -(self.rotation().transpose() * self.translation))
    }

    /// The transformed point `R(θ)·p + t`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let g = Se2::new(std::f64::consts::FRAC_PI_2, vector![1.0, 0.0]);
    /// assert!((g.act(&vector![1.0, 0.0]) - vector![1.0, 1.0]).norm() < 1e-15);
    /// ```
    pub fn act(&self, p: &Vector2<f64>) -> Vector2<f64> {
        self.rotation() * p + self.translation
    }

    /// The adjoint `Ad_g = [[R(θ), (t_y, −t_x)ᵀ], [0, 1]]` in `(ρ, θ)` order (GTSAM's
    /// `Pose2::AdjointMap`): `g·Exp(ξ)·g⁻¹ = Exp(Ad_g·ξ)`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let (g, xi) = (Se2::new(1.0, vector![2.0, -1.0]), vector![0.5, 0.2, -0.7]);
    /// let conj = g.compose(&Se2::exp(&xi)).compose(&g.inverse());
    /// assert!((conj.log() - g.adjoint() * xi).norm() < 1e-15);
    /// ```
    pub fn adjoint(&self) -> Matrix3<f64> {
        let t = &self.translation;
        blocks(&self.rotation(), &Vector2::new(t[1], -t[0]))
    }

    /// The right Jacobian, `Exp(ξ + δ) ≈ Exp(ξ)·Exp(J_r(ξ)·δ)` (GTSAM's
    /// `Pose2::ExpmapDerivative`): with `a = sin θ/θ`, `b = (1 − cos θ)/θ`,
    /// `e = (θ − sin θ)/θ²`, `f = (1 − cos θ)/θ²`,
    /// `J_r = [[a, b, e·ρ_x − f·ρ_y], [−b, a, f·ρ_x + e·ρ_y], [0, 0, 1]]`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let (xi, d) = (vector![1.0, -2.0, 2.5], vector![1e-7, 2e-7, -1e-7]);
    /// let lhs = Se2::exp(&(xi + d));
    /// let rhs = Se2::exp(&xi).compose(&Se2::exp(&(Se2::right_jacobian(&xi) * d)));
    /// assert!((lhs.matrix() - rhs.matrix()).amax() < 1e-13); // second order in |δ|
    /// ```
    pub fn right_jacobian(xi: &Vector3<f64>) -> Matrix3<f64> {
        let (a, b, e, f) = coefficients(xi[2]);
        let (x, y) = (xi[0], xi[1]);
        blocks(&Matrix2::new(a, b, -b, a), &Vector2::new(e * x - f * y, f * x + e * y))
    }

    /// The left Jacobian `J_l(ξ) = J_r(−ξ)`, `Exp(ξ + δ) ≈ Exp(J_l(ξ)·δ)·Exp(ξ)`:
    /// `J_l = [[a, −b, e·ρ_x + f·ρ_y], [b, a, −f·ρ_x + e·ρ_y], [0, 0, 1]]` (as
    /// [`Se2::right_jacobian`]).
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::vector;
    /// let xi = vector![1.0, -2.0, 2.5];
    /// assert!((Se2::left_jacobian(&xi) * xi - xi).norm() < 1e-15); // J_l(ξ)·ξ = ξ
    /// ```
    pub fn left_jacobian(xi: &Vector3<f64>) -> Matrix3<f64> {
        Self::right_jacobian(&-xi)
    }

    /// `J_r⁻¹(ξ) = [[A⁻¹, −A⁻¹c], [0, 1]]` for `J_r = [[A, c], [0, 1]]`, with
    /// `A⁻¹ = V(−θ)⁻¹ = [[α, −θ/2], [θ/2, α]]`, `α = (θ/2)·cot(θ/2)`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::{vector, Matrix3};
    /// let xi = vector![1.0, -2.0, 3.1];
    /// let p = Se2::right_jacobian_inv(&xi) * Se2::right_jacobian(&xi);
    /// assert!((p - Matrix3::identity()).amax() < 1e-14);
    /// ```
    pub fn right_jacobian_inv(xi: &Vector3<f64>) -> Matrix3<f64> {
        let t = xi[2];
        let (_, _, e, f) = coefficients(t);
        let (x, y) = (xi[0], xi[1]);
        let ai = v_inv(-t);
        blocks(&ai, &-(ai * Vector2::new(e * x - f * y, f * x + e * y)))
    }

    /// `J_l⁻¹(ξ) = J_r⁻¹(−ξ)`.
    ///
    /// ```
    /// use reckon::lie::Se2;
    /// use nalgebra::{vector, Matrix3};
    /// let xi = vector![1.0, -2.0, -3.1];
    /// let p = Se2::left_jacobian_inv(&xi) * Se2::left_jacobian(&xi);
    /// assert!((p - Matrix3::identity()).amax() < 1e-14);
    /// ```
    pub fn left_jacobian_inv(xi: &Vector3<f64>) -> Matrix3<f64> {
        Self::right_jacobian_inv(&-xi)
    }
}

impl Mul for Se2 {
    type Output = Se2;
    /// `g₁·g₂`, as [`Se2::compose`].
    fn mul(self, rhs: Se2) -> Se2 {
        self.compose(&rhs)
    }
}

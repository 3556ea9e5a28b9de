//! SE(3), rigid motions `(R, t)` acting as `p ↦ R·p + t`; tangent `ξ = (φ, ρ)`,
//! rotation first as GTSAM's `Pose3`. Notation: Solà et al. 2018, "A micro Lie theory",
//! §D, and Barfoot and Furgale 2014 for `Q` (both order `(ρ, φ)`; their blocks are
//! rearranged here).

use super::rodrigues;
use super::so3::{So3, hat};

/// Below this angle `Q`'s coefficients `c₂`, `c₃` are evaluated by their series.
const Q_SERIES: f64 = 0.1;
use nalgebra::{Matrix3, Matrix4, Matrix6, Vector3, Vector6};
use std::ops::Mul;

/// A rigid motion `g = (R, t) ∈ SE(3)`, the matrix `[[R, t], [0, 1]]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Se3 {
    /// Rotation `R`.
    pub rotation: So3,
    /// Translation `t`.
    pub translation: Vector3<f64>,
}

/// `ξ = (φ, ρ)` split into its rotation and translation parts.
fn split(xi: &Vector6<f64>) -> (Vector3<f64>, Vector3<f64>) {
    (xi.fixed_rows::<3>(0).into_owned(), xi.fixed_rows::<3>(3).into_owned())
}

/// `[[A, 0], [C, D]]` as a 6×6 matrix.
fn blocks(a: &Matrix3<f64>, c: &Matrix3<f64>, d: &Matrix3<f64>) -> Matrix6<f64> {
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(a);
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(c);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(d);
    m
}

impl Se3 {
    /// `(R, t)`.
    ///
    /// ```
    /// use reckon::lie::{Se3, So3};
    /// use nalgebra::vector;
    /// let g = Se3::new(So3::identity(), vector![1.0, 2.0, 3.0]);
    /// assert_eq!(g.act(&vector![0.0, 0.0, 0.0]), vector![1.0, 2.0, 3.0]);
    /// ```
    pub fn new(rotation: So3, translation: Vector3<f64>) -> Self {
        Se3 { rotation, translation }
    }

    /// The identity `(I, 0)`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// assert_eq!(Se3::identity().matrix(), nalgebra::Matrix4::identity());
    /// ```
    pub fn identity() -> Self {
        Se3::new(So3::identity(), Vector3::zeros())
    }

    /// The homogeneous matrix `[[R, t], [0, 1]]`.
    ///
    /// ```
    /// use reckon::lie::{Se3, So3};
    /// use nalgebra::vector;
    /// let m = Se3::new(So3::identity(), vector![1.0, 2.0, 3.0]).matrix();
    /// assert_eq!((m[(0, 3)], m[(3, 3)]), (1.0, 1.0));
    /// ```
    pub fn matrix(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.rotation.matrix());
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }

    /// `Exp(φ, ρ) = (Exp(φ), J_l(φ)·ρ)`, `J_l` the SO(3) left Jacobian: the motion after
    /// unit time at constant body twist `(ω, v) = (φ, ρ)`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::vector;
    /// use std::f64::consts::PI;
    /// // half a turn about z while moving at 1 m/s along body x: a half circle of radius 1/π
    /// let g = Se3::exp(&vector![0.0, 0.0, PI, 1.0, 0.0, 0.0]);
    /// assert!((g.translation - vector![0.0, 2.0 / PI, 0.0]).norm() < 1e-15);
    /// ```
    pub fn exp(xi: &Vector6<f64>) -> Self {
        let (phi, rho) = split(xi);
        Se3::new(So3::exp(&phi), So3::left_jacobian(&phi) * rho)
    }

    /// `Log(R, t) = (φ, J_l⁻¹(φ)·t)` with `φ = Log(R)`, `|φ| ≤ π`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::vector;
    /// let xi = vector![0.1, -3.0, 0.2, 1.0, 2.0, -0.5];
    /// assert!((Se3::exp(&xi).log() - xi).norm() < 1e-14);
    /// ```
    pub fn log(&self) -> Vector6<f64> {
        let phi = self.rotation.log();
        let rho = So3::left_jacobian_inv(&phi) * self.translation;
        Vector6::new(phi[0], phi[1], phi[2], rho[0], rho[1], rho[2])
    }

    /// `g₁·g₂ = (R₁R₂, R₁t₂ + t₁)`.
    ///
    /// ```
    /// use reckon::lie::{Se3, So3};
    /// use nalgebra::vector;
    /// let a = Se3::new(So3::exp(&vector![0.0, 0.0, 1.0]), vector![1.0, 0.0, 0.0]);
    /// let b = Se3::new(So3::identity(), vector![0.0, 2.0, 0.0]);
    /// let p = vector![0.3, 0.4, 0.5];
    /// assert!((a.compose(&b).act(&p) - a.act(&b.act(&p))).norm() < 1e-15);
    /// ```
    pub fn compose(&self, other: &Se3) -> Se3 {
        Se3::new(
            self.rotation.compose(&other.rotation),
            self.rotation.act(&other.translation) + self.translation,
        )
    }

    /// `g⁻¹ = (Rᵀ, −Rᵀt)`.
    ///
    /// ```
    /// use reckon::lie::{Se3, So3};
    /// use nalgebra::vector;
    /// let g = Se3::new(So3::exp(&vector![0.3, 0.2, 1.0]), vector![1.0, -2.0, 0.5]);
    /// assert!((g.compose(&g.inverse()).log()).norm() < 1e-15);
    /// ```
    pub fn inverse(&self) -> Se3 {
        let rt = self.rotation.inverse();
        Se3::new(rt, -rt.act(&self.translation))
    }

    /// The transformed point `R·p + t`.
    ///
    /// ```
    /// use reckon::lie::{Se3, So3};
    /// use nalgebra::vector;
    /// let g = Se3::new(So3::exp(&vector![0.0, 0.0, std::f64::consts::FRAC_PI_2]), vector![1.0, 0.0, 0.0]);
    /// assert!((g.act(&vector![1.0, 0.0, 0.0]) - vector![1.0, 1.0, 0.0]).norm() < 1e-15);
    /// ```
    pub fn act(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation.act(p) + self.translation
    }

    /// The adjoint `Ad_g = [[R, 0], [[t]×R, R]]` in `(φ, ρ)` order (GTSAM's
    /// `Pose3::AdjointMap`): `g·Exp(ξ)·g⁻¹ = Exp(Ad_g·ξ)`.
    ///
    /// ```
    /// use reckon::lie::{Se3, So3};
    /// use nalgebra::vector;
    /// let g = Se3::new(So3::exp(&vector![0.3, 0.2, 1.0]), vector![1.0, -2.0, 0.5]);
    /// let xi = vector![0.1, 0.2, -0.3, 0.5, 0.0, 1.0];
    /// let conj = g.compose(&Se3::exp(&xi)).compose(&g.inverse());
    /// assert!((conj.log() - g.adjoint() * xi).norm() < 1e-14);
    /// ```
    pub fn adjoint(&self) -> Matrix6<f64> {
        let r = self.rotation.matrix();
        blocks(&r, &(hat(&self.translation) * r), &r)
    }

    /// Barfoot and Furgale's `Q(φ, ρ)`, the lower-left block of the left Jacobian:
    /// `Q = ½P + c₁(ΦP + PΦ + ΦPΦ) + c₂(Φ²P + PΦ² − 3ΦPΦ) + c₃(ΦPΦ² + Φ²PΦ)` with
    /// `Φ = [φ]×`, `P = [ρ]×`, `c₁ = (θ − sin θ)/θ³`, `c₂ = (θ²/2 + cos θ − 1)/θ⁴`,
    /// `c₃ = (2θ + θ cos θ − 3 sin θ)/(2θ⁵)`; `c₂` and `c₃` by their series below `θ = 0.1`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::vector;
    /// // at φ = 0, Q = ½[ρ]×
    /// let q = Se3::q_block(&vector![0.0, 0.0, 0.0], &vector![0.0, 0.0, 2.0]);
    /// assert_eq!((q[(1, 0)], q[(0, 1)]), (1.0, -1.0));
    /// ```
    pub fn q_block(phi: &Vector3<f64>, rho: &Vector3<f64>) -> Matrix3<f64> {
        let t = phi.norm();
        let (_, _, c1) = rodrigues(t);
        // c₂'s numerator cancels to θ⁴/24 and c₃'s to θ⁵/60: the closed forms lose
        // (24/θ⁴)·ε relative, so the series (its next terms ≈ 10⁻¹⁷ at 0.1) runs to θ = 0.1
        let (c2, c3) = if t < Q_SERIES {
            let t2 = t * t;
            (
                1.0 / 24.0 - t2 / 720.0 * (1.0 - t2 / 56.0 * (1.0 - t2 / 90.0)),
                1.0 / 120.0 - t2 / 2520.0 * (1.0 - t2 / 48.0 * (1.0 - t2 / 82.5)),
            )
        } else {
            let (s, c) = t.sin_cos();
            let t4 = t * t * t * t;
            (
                (0.5 * t * t + c - 1.0) / t4,
                (2.0 * t + t * c - 3.0 * s) / (2.0 * t4 * t),
            )
        };
        let (f, p) = (hat(phi), hat(rho));
        let (fp, pf, fpf) = (f * p, p * f, f * p * f);
        p * 0.5 + (fp + pf + fpf) * c1 + (f * fp + pf * f - fpf * 3.0) * c2 + (fpf * f + f * fpf) * c3
    }

    /// The left Jacobian `J_l(ξ) = [[J_l(φ), 0], [Q(φ, ρ), J_l(φ)]]`:
    /// `Exp(ξ + δ) ≈ Exp(J_l(ξ)·δ)·Exp(ξ)`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::vector;
    /// let xi = vector![0.3, -0.2, 1.0, 1.0, 2.0, 0.5];
    /// // J_l(ξ)·ξ = ξ, as for every Lie group
    /// assert!((Se3::left_jacobian(&xi) * xi - xi).norm() < 1e-15);
    /// ```
    pub fn left_jacobian(xi: &Vector6<f64>) -> Matrix6<f64> {
        let (phi, rho) = split(xi);
        let j = So3::left_jacobian(&phi);
        blocks(&j, &Self::q_block(&phi, &rho), &j)
    }

    /// The right Jacobian `J_r(ξ) = J_l(−ξ) = [[J_r(φ), 0], [Q(−φ, −ρ), J_r(φ)]]`:
    /// `Exp(ξ + δ) ≈ Exp(ξ)·Exp(J_r(ξ)·δ)` (GTSAM's `Pose3::ExpmapDerivative`).
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::vector;
    /// let xi = vector![0.3, -0.2, 1.0, 1.0, 2.0, 0.5];
    /// // J_l(ξ) = Ad_{Exp(ξ)}·J_r(ξ)
    /// let jl = Se3::exp(&xi).adjoint() * Se3::right_jacobian(&xi);
    /// assert!((jl - Se3::left_jacobian(&xi)).amax() < 1e-14);
    /// ```
    pub fn right_jacobian(xi: &Vector6<f64>) -> Matrix6<f64> {
        Self::left_jacobian(&-xi)
    }

    /// `J_l⁻¹(ξ) = [[J_l⁻¹(φ), 0], [−J_l⁻¹(φ)·Q·J_l⁻¹(φ), J_l⁻¹(φ)]]`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::{vector, Matrix6};
    /// let xi = vector![0.3, -0.2, 1.0, 1.0, 2.0, 0.5];
    /// let p = Se3::left_jacobian_inv(&xi) * Se3::left_jacobian(&xi);
    /// assert!((p - Matrix6::identity()).amax() < 1e-14);
    /// ```
    pub fn left_jacobian_inv(xi: &Vector6<f64>) -> Matrix6<f64> {
        let (phi, rho) = split(xi);
        let ji = So3::left_jacobian_inv(&phi);
        blocks(&ji, &(-ji * Self::q_block(&phi, &rho) * ji), &ji)
    }

    /// `J_r⁻¹(ξ) = J_l⁻¹(−ξ)`.
    ///
    /// ```
    /// use reckon::lie::Se3;
    /// use nalgebra::{vector, Matrix6};
    /// let xi = vector![0.3, -0.2, 3.0, 1.0, 2.0, 0.5]; // |φ| ≈ 3.02, near π
    /// let p = Se3::right_jacobian_inv(&xi) * Se3::right_jacobian(&xi);
    /// assert!((p - Matrix6::identity()).amax() < 1e-13);
    /// ```
    pub fn right_jacobian_inv(xi: &Vector6<f64>) -> Matrix6<f64> {
        Self::left_jacobian_inv(&-xi)
    }
}

impl Mul for Se3 {
    type Output = Se3;
    /// `g₁·g₂`, as [`Se3::compose`].
    fn mul(self, rhs: Se3) -> Se3 {
        self.compose(&rhs)
    }
}

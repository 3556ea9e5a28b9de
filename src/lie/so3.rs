//! SO(3), the rotations of ℝ³: `exp`, `log` (accurate near 0 and near π), the Jacobians.
//! Notation: Solà et al. 2018, "A micro Lie theory", §B (with `θ = |φ|`, `K = [φ]×`).

use super::{SMALL, rodrigues};
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Vector3};
use std::ops::Mul;

/// The skew-symmetric matrix of `v`: `[v]× = [[0, −v₃, v₂], [v₃, 0, −v₁], [−v₂, v₁, 0]]`,
/// so that `[v]×·w = v × w`.
///
/// ```
/// use reckon::lie::hat;
/// use nalgebra::vector;
/// let (v, w) = (vector![1.0, 2.0, 3.0], vector![-1.0, 0.5, 2.0]);
/// assert_eq!(hat(&v) * w, v.cross(&w));
/// ```
pub fn hat(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// The vector of a skew-symmetric matrix, `vee([v]×) = v` (the antisymmetric part of any
/// other matrix: `(m₃₂ − m₂₃, m₁₃ − m₃₁, m₂₁ − m₁₂)/2`).
///
/// ```
/// use reckon::lie::{hat, vee};
/// use nalgebra::vector;
/// assert_eq!(vee(&hat(&vector![1.0, 2.0, 3.0])), vector![1.0, 2.0, 3.0]);
/// ```
pub fn vee(m: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]) * 0.5
}

/// A rotation `R ∈ SO(3)`: `RᵀR = I`, `det R = 1`. As an attitude it maps body to world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct So3 {
    m: Matrix3<f64>,
}

impl So3 {
    /// The identity rotation `I`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// assert_eq!(So3::identity().matrix(), nalgebra::Matrix3::identity());
    /// ```
    pub fn identity() -> Self {
        So3 { m: Matrix3::identity() }
    }

    /// `R` from a matrix with `‖RᵀR − I‖_max ≤ 10⁻⁹` and `det R > 0`, or
    /// [`Error::InvalidInput`] (a reflection, a non-orthogonal or a non-finite matrix).
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::Matrix3;
    /// assert!(So3::from_matrix(Matrix3::identity()).is_ok());
    /// assert!(So3::from_matrix(-Matrix3::identity()).is_err()); // det = −1
    /// assert!(So3::from_matrix(Matrix3::identity() * 2.0).is_err());
    /// ```
    pub fn from_matrix(m: Matrix3<f64>) -> Result<Self> {
        if !m.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid("rotation", "non-finite entry"));
        }
        let orth = (m.transpose() * m - Matrix3::identity()).amax();
        if orth > 1e-9 {
            return Err(Error::invalid("rotation", format!("‖RᵀR − I‖ = {orth:e} > 1e-9")));
        }
        if m.determinant() <= 0.0 {
            return Err(Error::invalid("rotation", "det R < 0: a reflection"));
        }
        Ok(So3 { m })
    }

    /// `R` from a matrix taken to be a rotation, unchecked (for matrices built as products
    /// of rotations).
    ///
    /// ```
    /// use reckon::lie::So3;
    /// let r = So3::from_matrix_unchecked(nalgebra::Matrix3::identity());
    /// assert_eq!(r, So3::identity());
    /// ```
    pub fn from_matrix_unchecked(m: Matrix3<f64>) -> Self {
        So3 { m }
    }

    /// The matrix `R`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// assert_eq!(So3::identity().matrix().trace(), 3.0);
    /// ```
    pub fn matrix(&self) -> Matrix3<f64> {
        self.m
    }

    /// `Exp(φ) = I + (sin θ/θ)·K + ((1 − cos θ)/θ²)·K²` (Rodrigues), `θ = |φ|`, `K = [φ]×`:
    /// the rotation by `θ` about `φ/θ`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let r = So3::exp(&vector![0.0, 0.0, std::f64::consts::FRAC_PI_2]);
    /// assert!((r.act(&vector![1.0, 0.0, 0.0]) - vector![0.0, 1.0, 0.0]).norm() < 1e-15);
    /// ```
    pub fn exp(phi: &Vector3<f64>) -> Self {
        let (a, b, _) = rodrigues(phi.norm());
        let k = hat(phi);
        So3 {
            m: Matrix3::identity() + k * a + k * k * b,
        }
    }

    /// `Log(R) = φ` with `|φ| ≤ π` and `Exp(φ) = R`: through the unit quaternion
    /// `q = (cos(θ/2), sin(θ/2)·u)` taken by Shepperd's largest-pivot rule (no division by
    /// a small number anywhere, so accurate near π), `q₀ ≥ 0`, and
    /// `φ = 2·atan2(|q_v|, q₀)·q_v/|q_v|`, by its series `2(1 − |q_v|²/(3q₀²))/q₀·q_v`
    /// near 0. At exactly `θ = π` either of `±π·u` is returned.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let phi = vector![0.3, -2.0, 2.2]; // |φ| = 2.99, near π
    /// assert!((So3::exp(&phi).log() - phi).norm() < 1e-14);
    /// ```
    pub fn log(&self) -> Vector3<f64> {
        let m = &self.m;
        let tr = m.trace();
        let (d0, d1, d2) = (m[(0, 0)], m[(1, 1)], m[(2, 2)]);
        // 4q₀q = (m₃₂ − m₂₃, …) and 4qᵢqⱼ = mᵢⱼ + mⱼᵢ: divide by the largest 4qₖ
        let (w, x, y, z) = if tr >= d0.max(d1).max(d2) {
            let s = 2.0 * (1.0 + tr).sqrt();
            (
                0.25 * s,
                (m[(2, 1)] - m[(1, 2)]) / s,
                (m[(0, 2)] - m[(2, 0)]) / s,
                (m[(1, 0)] - m[(0, 1)]) / s,
            )
        } else if d0 >= d1 && d0 >= d2 {
            let s = 2.0 * (1.0 + d0 - d1 - d2).sqrt();
            (
                (m[(2, 1)] - m[(1, 2)]) / s,
                0.25 * s,
                (m[(0, 1)] + m[(1, 0)]) / s,
                (m[(0, 2)] + m[(2, 0)]) / s,
            )
        } else if d1 >= d2 {
            let s = 2.0 * (1.0 + d1 - d0 - d2).sqrt();
            (
                (m[(0, 2)] - m[(2, 0)]) / s,
                (m[(0, 1)] + m[(1, 0)]) / s,
                0.25 * s,
                (m[(1, 2)] + m[(2, 1)]) / s,
            )
        } else {
            let s = 2.0 * (1.0 + d2 - d0 - d1).sqrt();
            (
                (m[(1, 0)] - m[(0, 1)]) / s,
                (m[(0, 2)] + m[(2, 0)]) / s,
                (m[(1, 2)] + m[(2, 1)]) / s,
                0.25 * s,
            )
        };
        let (w, v) = if w < 0.0 {
            (-w, -Vector3::new(x, y, z))
        } else {
            (w, Vector3::new(x, y, z))
        };
        let n = v.norm();
        if n < 1e-6 * w {
            // 2·atan(n/w)/n = (2/w)(1 − (n/w)²/3 + …); the next term is (n/w)⁴/5 < 1e-24
            let r = n / w;
            v * (2.0 / w * (1.0 - r * r / 3.0))
        } else {
            v * (2.0 * n.atan2(w) / n)
        }
    }

    /// The product `R₁R₂` (first `R₂`, then `R₁`, acting on points).
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let (a, b) = (So3::exp(&vector![0.0, 0.0, 0.5]), So3::exp(&vector![0.0, 0.0, 0.25]));
    /// assert!((a.compose(&b).log() - vector![0.0, 0.0, 0.75]).norm() < 1e-15);
    /// ```
    pub fn compose(&self, other: &So3) -> So3 {
        So3 { m: self.m * other.m }
    }

    /// `R⁻¹ = Rᵀ`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let r = So3::exp(&vector![0.1, 0.2, 0.3]);
    /// assert!((r.compose(&r.inverse()).matrix() - nalgebra::Matrix3::identity()).amax() < 1e-15);
    /// ```
    pub fn inverse(&self) -> So3 {
        So3 { m: self.m.transpose() }
    }

    /// The rotated point `R·p`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let r = So3::exp(&vector![std::f64::consts::PI, 0.0, 0.0]); // half a turn about x
    /// assert!((r.act(&vector![0.0, 1.0, 2.0]) - vector![0.0, -1.0, -2.0]).norm() < 1e-14);
    /// ```
    pub fn act(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.m * p
    }

    /// The adjoint `Ad_R = R`: `R·Exp(φ)·Rᵀ = Exp(R·φ)`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let (r, phi) = (So3::exp(&vector![0.4, -0.1, 0.9]), vector![0.2, 0.3, -0.5]);
    /// let conj = r.compose(&So3::exp(&phi)).compose(&r.inverse());
    /// assert!((conj.log() - r.adjoint() * phi).norm() < 1e-15);
    /// ```
    pub fn adjoint(&self) -> Matrix3<f64> {
        self.m
    }

    /// The right Jacobian `J_r(φ) = I − ((1 − cos θ)/θ²)·K + ((θ − sin θ)/θ³)·K²`:
    /// `Exp(φ + δ) ≈ Exp(φ)·Exp(J_r(φ)·δ)` (GTSAM's `Rot3::ExpmapDerivative`).
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let (phi, d) = (vector![0.5, -1.0, 2.0], vector![1e-7, 2e-7, -1e-7]);
    /// let lhs = So3::exp(&(phi + d));
    /// let rhs = So3::exp(&phi).compose(&So3::exp(&(So3::right_jacobian(&phi) * d)));
    /// assert!((lhs.matrix() - rhs.matrix()).amax() < 1e-13); // second order in |δ|
    /// ```
    pub fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
        let (_, b, c) = rodrigues(phi.norm());
        let k = hat(phi);
        Matrix3::identity() - k * b + k * k * c
    }

    /// The left Jacobian `J_l(φ) = J_r(−φ) = I + ((1 − cos θ)/θ²)·K + ((θ − sin θ)/θ³)·K²`:
    /// `Exp(φ + δ) ≈ Exp(J_l(φ)·δ)·Exp(φ)`; also `J_l(φ) = R·J_r(φ)` and `J_l(φ)·φ = φ`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::vector;
    /// let phi = vector![0.5, -1.0, 2.0];
    /// let jl = So3::left_jacobian(&phi);
    /// assert!((jl - So3::exp(&phi).matrix() * So3::right_jacobian(&phi)).amax() < 1e-15);
    /// assert!((jl * phi - phi).norm() < 1e-15);
    /// ```
    pub fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
        Self::right_jacobian(&-phi)
    }

    /// `J_r⁻¹(φ) = I + ½K + (1/θ² − (1 + cos θ)/(2θ sin θ))·K²`, the last coefficient
    /// written `1/θ² − cot(θ/2)/(2θ)` (finite at π) and `1/12 + θ²/720 + θ⁴/30240` near 0.
    /// Singular only at `θ = 2π`, outside `log`'s range.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::{vector, Matrix3};
    /// let phi = vector![0.5, -1.0, 2.0];
    /// let p = So3::right_jacobian_inv(&phi) * So3::right_jacobian(&phi);
    /// assert!((p - Matrix3::identity()).amax() < 1e-15);
    /// ```
    pub fn right_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
        let t = phi.norm();
        let d = if t < SMALL {
            let t2 = t * t;
            1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0
        } else {
            1.0 / (t * t) - 0.5 / (t * (0.5 * t).tan())
        };
        let k = hat(phi);
        Matrix3::identity() + k * 0.5 + k * k * d
    }

    /// `J_l⁻¹(φ) = J_r⁻¹(−φ) = I − ½K + (1/θ² − (1 + cos θ)/(2θ sin θ))·K²`.
    ///
    /// ```
    /// use reckon::lie::So3;
    /// use nalgebra::{vector, Matrix3};
    /// let phi = vector![3.0, 0.1, -0.2]; // near π
    /// let p = So3::left_jacobian_inv(&phi) * So3::left_jacobian(&phi);
    /// assert!((p - Matrix3::identity()).amax() < 1e-13);
    /// ```
    pub fn left_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
        Self::right_jacobian_inv(&-phi)
    }
}

impl Mul for So3 {
    type Output = So3;
    /// `R₁·R₂`, as [`So3::compose`].
    fn mul(self, rhs: So3) -> So3 {
        self.compose(&rhs)
    }
}

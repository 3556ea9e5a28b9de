//! A 3-D vehicle driven by body-frame velocities (an underwater robot): position
//! `p ∈ R³`, orientation from Euler angles `(φ, θ, ψ)` (roll, pitch, yaw) with
//! `R = Rz(ψ)·Ry(θ)·Rx(φ)`, and `p' = R·v_body`.

use nalgebra::{Const, Matrix3, Vector3};

/// `R = Rz(ψ)·Ry(θ)·Rx(φ)`: body frame (x forward, y left, z up) to world frame.
///
/// ```
/// use reckon::vehicles::body3d::rotation;
/// use nalgebra::vector;
/// // yaw 90°: body x points along world y
/// let r = rotation(0.0, 0.0, std::f64::consts::FRAC_PI_2);
/// assert!((r * vector![1.0, 0.0, 0.0] - vector![0.0, 1.0, 0.0]).norm() < 1e-15);
/// assert!((r.determinant() - 1.0).abs() < 1e-15);
/// ```
///
/// Generic in the scalar so that the same function serves `f64` and the traced copy
/// of [`model`] (whose inputs are symbols).
pub fn rotation<S: num_dual::DualNum<Primitive = f64> + Copy>(roll: S, pitch: S, yaw: S) -> Matrix3<S> {
    let (sf, cf) = roll.sin_cos();
    let (st, ct) = pitch.sin_cos();
    let (sp, cp) = yaw.sin_cos();
    Matrix3::new(
        cp * ct,
        cp * st * sf - sp * cf,
        cp * st * cf + sp * sf,
        sp * ct,
        sp * st * sf + cp * cf,
        sp * st * cf - cp * sf,
        -st,
        ct * sf,
        ct * cf,
    )
}

/// `p' = R(φ, θ, ψ)·v_body` with inputs `u = (φ, θ, ψ, v_x, v_y, v_z)` held.
///
/// ```
/// use reckon::{vehicles::body3d, System};
/// use nalgebra::vector;
/// let mut dp = vector![0.0, 0.0, 0.0];
/// body3d::model().rhs(0.0, &vector![0.0, 0.0, 0.0], &[0.0, 0.0, std::f64::consts::PI, 1.0, 0.0, 0.5], &mut dp);
/// assert!((dp - vector![-1.0, 0.0, 0.5]).norm() < 1e-15);
/// ```
pub fn model() -> impl crate::DualSystem<Const<3>> + Clone {
    crate::model!(|_t, p: [S; 3], u: [6]| {
        let v = rotation(u[0], u[1], u[2]) * Vector3::new(u[3], u[4], u[5]);
        // p' does not depend on p: lift the constants into the state's scalar
        nalgebra::vector![p[0] * 0.0 + v[0], p[1] * 0.0 + v[1], p[2] * 0.0 + v[2]]
    })
}

/// Exact flow with held angles and body velocities: `p₁ = p + h·R·v_body`.
///
/// ```
/// use reckon::vehicles::body3d::flow;
/// use nalgebra::vector;
/// let p = flow(0.0, &vector![1.0, 1.0, -5.0], &[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], 1.5);
/// assert_eq!(p, vector![4.0, 1.0, -5.0]);
/// ```
#[inline]
pub fn flow(_t: f64, p: &Vector3<f64>, u: &[f64], h: f64) -> Vector3<f64> {
    let g = |i: usize| u.get(i).copied().unwrap_or(f64::NAN);
    p + rotation(g(0), g(1), g(2)) * Vector3::new(g(3), g(4), g(5)) * h
}

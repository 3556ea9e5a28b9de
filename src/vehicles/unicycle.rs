//! Unicycle / differential drive: state `(x, y, θ)`, inputs `(v, ω)`
//! (REP-103: x forward, y left, θ counter-clockwise from +x, θ unwrapped).

use nalgebra::{Const, Vector3};

/// `x' = v cos θ`, `y' = v sin θ`, `θ' = ω` with `u = (v, ω)` held.
///
/// ```
/// use reckon::{vehicles::unicycle, System};
/// use nalgebra::vector;
/// let mut dx = vector![0.0, 0.0, 0.0];
/// unicycle::model().rhs(0.0, &vector![0.0, 0.0, 0.0], &[2.0, 0.5], &mut dx);
/// assert_eq!(dx, vector![2.0, 0.0, 0.5]);
/// ```
pub fn model() -> impl crate::DualSystem<Const<3>> + Clone {
    crate::model!(|_t, x: [S; 3], u: [2]| nalgebra::vector![x[2].cos() * u[0], x[2].sin() * u[0], S::from(u[1])])
}

/// `sinc z = sin z / z`, exact to rounding everywhere (Taylor series near 0).
#[inline]
pub fn sinc(z: f64) -> f64 {
    if z.abs() < 1e-4 {
        let z2 = z * z;
        1.0 - z2 / 6.0 * (1.0 - z2 / 20.0)
    } else {
        z.sin() / z
    }
}

/// The exact arc over `h` with `(v, ω)` held, in a form that stays exact as ω → 0:
/// `Δθ = ωh`, `d = v·h·sinc(Δθ/2)`, `x₁ = x + d cos(θ + Δθ/2)`, `y₁ = y + d sin(θ + Δθ/2)`, `θ₁ = θ + Δθ`.
///
/// ```
/// use reckon::vehicles::unicycle::flow;
/// use nalgebra::vector;
/// // a quarter circle of radius 1: v = 1, ω = 1 for π/2
/// let x = flow(0.0, &vector![0.0, 0.0, 0.0], &[1.0, 1.0], std::f64::consts::FRAC_PI_2);
/// assert!((x - vector![1.0, 1.0, std::f64::consts::FRAC_PI_2]).norm() < 1e-15);
/// ```
#[inline]
pub fn flow(_t: f64, x: &Vector3<f64>, u: &[f64], h: f64) -> Vector3<f64> {
    // missing inputs give NaN, which the driver reports as a non-finite state
    let v = u.first().copied().unwrap_or(f64::NAN);
    let w = u.get(1).copied().unwrap_or(f64::NAN);
    let dth = w * h;
    let d = v * h * sinc(0.5 * dth);
    let mid = x[2] + 0.5 * dth;
    Vector3::new(x[0] + d * mid.cos(), x[1] + d * mid.sin(), x[2] + dth)
}

/// [`flow`] as a value that is also a [`DualFlow`](crate::model::DualFlow): the
/// exact arc at dual `x`, so that [`Exact`](crate::methods::Exact) gives the exact
/// sensitivities `∂x(t)/∂x₀` ([`crate::sensitivity::solve`]): `∂φ_h/∂x = [[1, 0, −d sin m], [0, 1, d cos m], [0, 0, 1]]`
/// with `m = θ + Δθ/2`.
///
/// ```
/// use reckon::{model::Flow, vehicles::unicycle};
/// use nalgebra::vector;
/// let (x, u) = (vector![1.0, 2.0, 0.3], [1.5, 0.4]);
/// let mut out = vector![0.0, 0.0, 0.0];
/// unicycle::ExactFlow.flow(0.0, &x, &u, 0.7, &mut out);
/// assert_eq!(out, unicycle::flow(0.0, &x, &u, 0.7));
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ExactFlow;

impl crate::model::Flow<Const<3>> for ExactFlow {
    #[inline(always)]
    fn flow(&self, t: f64, x: &Vector3<f64>, u: &[f64], h: f64, out: &mut Vector3<f64>) {
        *out = flow(t, x, u, h);
    }
}

impl crate::model::DualFlow<Const<3>> for ExactFlow {
    fn flow_dual(
        &self,
        _t: f64,
        x: &Vector3<num_dual::DualSVec64<3>>,
        u: &[f64],
        h: f64,
    ) -> Vector3<num_dual::DualSVec64<3>> {
        use num_dual::DualNum;
        let v = u.first().copied().unwrap_or(f64::NAN);
        let w = u.get(1).copied().unwrap_or(f64::NAN);
        let dth = w * h;
        let d = v * h * sinc(0.5 * dth);
        let mid = x[2] + 0.5 * dth;
        let (s, c) = mid.sin_cos();
        Vector3::new(x[0] + c * d, x[1] + s * d, x[2] + dth)
    }
}

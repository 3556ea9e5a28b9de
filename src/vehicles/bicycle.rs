//! Kinematic bicycle: state `(x, y, θ)`, inputs `(v, α)` (speed at the rear axle,
//! steering angle), wheelbase `L`: `θ' = v·tan α / L`.

use super::unicycle;
use nalgebra::{Const, Vector3};

/// `x' = v cos θ`, `y' = v sin θ`, `θ' = v·tan α / L` with `u = (v, α)` held.
///
/// ```
/// use reckon::{vehicles::bicycle, System};
/// use nalgebra::vector;
/// let mut dx = vector![0.0, 0.0, 0.0];
/// bicycle::model(0.5).rhs(0.0, &vector![0.0, 0.0, 0.0], &[2.0, std::f64::consts::FRAC_PI_4], &mut dx);
/// assert!((dx - vector![2.0, 0.0, 4.0]).norm() < 1e-14); // 2·tan(π/4)/0.5
/// ```
pub fn model(wheelbase: f64) -> impl crate::DualSystem<Const<3>> + Clone {
    let l = wheelbase;
    crate::model!(|_t, x: [S; 3], u: [2]| nalgebra::vector![
        x[2].cos() * u[0],
        x[2].sin() * u[0],
        S::from(u[0] * u[1].tan() / l)
    ])
}

/// The exact flow with `(v, α)` held: the unicycle arc with `ω = v·tan α / L`.
/// `α = 0` gives `ω = 0` exactly and the arc formula's straight-line limit, with no
/// small-angle guard.
///
/// ```
/// use reckon::vehicles::bicycle;
/// use nalgebra::vector;
/// let phi = bicycle::flow(0.5);
/// // straight: α = 0
/// assert_eq!(phi(0.0, &vector![1.0, 2.0, 0.0], &[2.0, 0.0], 3.0), vector![7.0, 2.0, 0.0]);
/// // turning radius R = L / tan α: a half circle takes π R / v
/// let (l, a, v) = (0.5, 0.3f64, 2.0);
/// let r = l / a.tan();
/// let x = phi(0.0, &vector![0.0, 0.0, 0.0], &[v, a], std::f64::consts::PI * r / v);
/// assert!((x - vector![0.0, 2.0 * r, std::f64::consts::PI]).amax() < 1e-14);
/// ```
pub fn flow(wheelbase: f64) -> impl Fn(f64, &Vector3<f64>, &[f64], f64) -> Vector3<f64> + Clone {
    move |t, x, u, h| {
        let v = u.first().copied().unwrap_or(f64::NAN);
        let a = u.get(1).copied().unwrap_or(f64::NAN);
        unicycle::flow(t, x, &[v, v * a.tan() / wheelbase], h)
    }
}

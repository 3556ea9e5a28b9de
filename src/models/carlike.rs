//! Car-like vehicle with a steering state: `(x, y, θ, γ)`, inputs `(v, ω)` with `ω` the
//! steering rate, wheelbase `L`: `θ' = v·tan γ / L`, `γ' = ω`.

use super::unicycle;
use nalgebra::{Const, Vector3, Vector4};

/// `x' = v cos θ`, `y' = v sin θ`, `θ' = v·tan γ / L`, `γ' = ω` with `u = (v, ω)` held.
///
/// ```
/// use reckon::{models::carlike, System};
/// use nalgebra::vector;
/// let mut dx = vector![0.0, 0.0, 0.0, 0.0];
/// carlike::model(2.5).rhs(0.0, &vector![0.0, 0.0, 0.0, 0.1], &[5.0, 0.2], &mut dx);
/// assert!((dx - vector![5.0, 0.0, 5.0 * 0.1f64.tan() / 2.5, 0.2]).norm() < 1e-15);
/// ```
pub fn model(wheelbase: f64) -> impl crate::DualSystem<Const<4>> + Clone {
    let l = wheelbase;
    crate::model!(|_t, x: [S; 4], u: [2]| nalgebra::vector![
        x[2].cos() * u[0],
        x[2].sin() * u[0],
        x[3].tan() * (u[0] / l),
        S::from(u[1])
    ])
}

/// The midpoint-steering flow: over a step `h` the steering angle is held at its
/// midpoint value `γ_m = γ + ½ωh` and `(x, y, θ)` follow the exact unicycle arc with
/// `ω_θ = v·tan γ_m / L`; `γ₁ = γ + ωh` exactly.
///
/// **Order 2**: `θ₁ − θ₀ = (v/L)∫tan γ(s) ds` and the midpoint rule integrates it with
/// local error `(v/L)·h³/24·(tan γ)''`, so the global error is `O(h²)` (tested against
/// RK45 in `tests/vehicles.rs`). It is exact when `ω = 0`.
///
/// ```
/// use reckon::models::carlike;
/// use nalgebra::vector;
/// let phi = carlike::flow(2.5);
/// // no steering rate: a circle of radius L / tan γ
/// let (l, g, v) = (2.5, 0.2f64, 4.0);
/// let r = l / g.tan();
/// let x = phi(0.0, &vector![0.0, 0.0, 0.0, g], &[v, 0.0], std::f64::consts::PI * r / v);
/// assert!((x - vector![0.0, 2.0 * r, std::f64::consts::PI, g]).amax() < 1e-13);
/// ```
pub fn flow(wheelbase: f64) -> impl Fn(f64, &Vector4<f64>, &[f64], f64) -> Vector4<f64> + Clone {
    move |t, x, u, h| {
        let v = u.first().copied().unwrap_or(f64::NAN);
        let w = u.get(1).copied().unwrap_or(f64::NAN);
        let gm = x[3] + 0.5 * w * h;
        let p = unicycle::flow(t, &Vector3::new(x[0], x[1], x[2]), &[v, v * gm.tan() / wheelbase], h);
        Vector4::new(p[0], p[1], p[2], x[3] + w * h)
    }
}

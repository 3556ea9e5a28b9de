//! Dense output shared by methods: the cubic Hermite interpolant through both ends of a
//! step (exact flows, exponential Euler).

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Cubic Hermite in powers of θ: `c₀ = x₀, c₁ = h f₀, c₂ = 3Δ − 2h f₀ − h f₁,
/// c₃ = −2Δ + h f₀ + h f₁`, `Δ = x₁ − x₀`; on entry `c[1]` holds `f₀ = f(t, x₀)` and
/// `c[3]` holds `f₁ = f(t + h, x₁)`. It matches both ends and both slopes, so the
/// interpolant is third order.
pub(crate) fn cubic_hermite<D: Dim>(h: f64, x: &OVector<f64, D>, x_new: &OVector<f64, D>, c: &mut [OVector<f64, D>])
where
    DefaultAllocator: Allocator<D>,
{
    let (c01, c23) = c.split_at_mut(2);
    for i in 0..x.len() {
        let d = x_new[i] - x[i];
        let (f0, f1) = (h * c01[1][i], h * c23[1][i]);
        c01[0][i] = x[i];
        c01[1][i] = f0;
        c23[0][i] = 3.0 * d - 2.0 * f0 - f1;
        c23[1][i] = -2.0 * d + f0 + f1;
    }
}

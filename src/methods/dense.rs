//! Dense output shared by methods: the Hermite interpolant through both ends of a step
//! (exact flows, exponential Euler), with the method's own value at the midpoint when
//! it has one.

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

/// The cubic Hermite interpolant's miss at the midpoint,
/// `e = x_m − ((x₀ + x₁)/2 + h(f₀ − f₁)/8)`, where `x_m` is the method's own value at
/// `t + h/2`: the estimate of the interpolant's error that a method whose step error
/// says nothing about the interpolant (a long exact or exponential step across a fast
/// transient or a turn) adds to its step's estimate when the dense output is used.
pub(crate) fn midpoint_miss<D: Dim>(
    h: f64,
    x: &OVector<f64, D>,
    x_new: &OVector<f64, D>,
    f0: &OVector<f64, D>,
    f1: &OVector<f64, D>,
    xm: &OVector<f64, D>,
) -> OVector<f64, D>
where
    DefaultAllocator: Allocator<D>,
{
    let mut e = xm.clone();
    for i in 0..x.len() {
        e[i] -= 0.5 * (x[i] + x_new[i]) + 0.125 * h * (f0[i] - f1[i]);
    }
    e
}

/// Quartic through both ends, both slopes and the midpoint value `x_m`: the cubic
/// Hermite of [`cubic_hermite`] plus `a·θ²(1 − θ)²`, `a = 16·(x_m − H(½))` (that term has
/// no value and no slope at either end). On entry `c[1]` and `c[3]` hold `f₀` and `f₁`
/// as for [`cubic_hermite`]; `c` has five coefficients.
pub(crate) fn quartic_through_midpoint<D: Dim>(
    h: f64,
    x: &OVector<f64, D>,
    x_new: &OVector<f64, D>,
    xm: &OVector<f64, D>,
    c: &mut [OVector<f64, D>],
) where
    DefaultAllocator: Allocator<D>,
{
    cubic_hermite(h, x, x_new, &mut c[..4]);
    for i in 0..x.len() {
        let half = c[0][i] + 0.5 * c[1][i] + 0.25 * c[2][i] + 0.125 * c[3][i];
        let a = 16.0 * (xm[i] - half);
        c[2][i] += a;
        c[3][i] -= 2.0 * a;
        c[4][i] = a;
    }
}

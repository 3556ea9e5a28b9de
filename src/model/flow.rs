//! Closed-form flows: a model whose flow over a step with held inputs is known,
//! `x(t + h) = φ_h(t, x, u)`, offers it as a [`Flow`] (stepped by
//! [`Exact`](crate::methods::Exact)) and, evaluated at dual numbers, as a [`DualFlow`]
//! (whose derivative carries the sensitivities).

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};
use num_dual::DualVec64;

/// A closed-form flow `out ← φ_h(t, x, u)` of `x' = f(t, x, u)` with `u` held.
///
/// Any `Fn(f64, &OVector, &[f64], f64) -> OVector` is a `Flow`.
pub trait Flow<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// `out ← φ_h(t, x, u)`.
    fn flow(&self, t: f64, x: &OVector<f64, D>, u: &[f64], h: f64, out: &mut OVector<f64, D>);
}

impl<D: Dim, F> Flow<D> for F
where
    F: Fn(f64, &OVector<f64, D>, &[f64], f64) -> OVector<f64, D>,
    DefaultAllocator: Allocator<D>,
{
    fn flow(&self, t: f64, x: &OVector<f64, D>, u: &[f64], h: f64, out: &mut OVector<f64, D>) {
        *out = self(t, x, u, h);
    }
}

/// A flow map that can also be evaluated at num-dual numbers, so that its derivative
/// `∂φ_h/∂x` carries the sensitivities of [`Exact`](crate::methods::Exact) ([`sensitivity::solve`](crate::sensitivity::solve)).
///
/// ```
/// use reckon::{model::{DualFlow, Flow}, vehicles::unicycle};
/// use nalgebra::{vector, Vector3};
/// use num_dual::{DualSVec64, Derivative};
/// let x = vector![0.0, 0.0, 0.3];
/// let xd: Vector3<DualSVec64<3>> = x.map_with_location(|i, _, v| DualSVec64::new(v, Derivative::derivative_generic(nalgebra::Const::<3>, nalgebra::U1, i)));
/// let y = unicycle::ExactFlow.flow_dual(0.0, &xd, &[1.0, 0.0], 2.0);
/// // straight line: ∂x₁/∂θ = −2 sin 0.3
/// assert!((y[0].eps.unwrap_generic(nalgebra::Const::<3>, nalgebra::U1)[2] + 2.0 * 0.3f64.sin()).abs() < 1e-15);
/// ```
pub trait DualFlow<D: Dim>: Flow<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// `φ_h(t, x, u)` at dual `x` (derivative parts in `D`'s `n` directions).
    fn flow_dual(&self, t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64], h: f64) -> OVector<DualVec64<D>, D>;
}

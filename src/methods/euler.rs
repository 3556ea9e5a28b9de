//! Explicit (forward) Euler, the first-order one-stage Runge–Kutta method.

use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Explicit Euler: `x₁ = x₀ + h·f(t₀, x₀)`, order 1, fixed step only (no error estimate).
///
/// ```
/// use reckon::{model, methods::Euler, Options, Problem, StepSize};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let sol = Problem::new(&f, vector![1.0], (0.0, 0.1))
///     .solve(Euler, &Options::default().step(StepSize::Fixed(0.1)))
///     .unwrap();
/// assert_eq!(sol.last().1[0], 0.9); // 1 − 0.1·1
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct Euler;

impl<D: Dim> Method<D> for Euler
where
    DefaultAllocator: Allocator<D>,
{
    type Stepper = Euler;
    fn name(&self) -> &'static str {
        "euler"
    }
    fn order(&self) -> u32 {
        1
    }
    fn error_order(&self) -> Option<u32> {
        None
    }
    fn never_retries(&self) -> bool {
        true
    }
    fn stepper<S: System<D>>(self, _f: &mut Eval<'_, D, S>, _t0: f64, _x0: &OVector<f64, D>) -> Result<Self> {
        Ok(self)
    }
}

/// Explicit Euler carries nothing from step to step: it is its own stepper.
impl<D: Dim> Stepper<D> for Euler
where
    DefaultAllocator: Allocator<D>,
{
    #[inline]
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step { t, x, h, x_new, .. } = s;
        // x_new doubles as the buffer for k = f(t, x)
        f.rhs_unchecked(t, x, x_new);
        for i in 0..x.len() {
            x_new[i] = x[i] + h * x_new[i];
        }
        Ok(Outcome::Done { err: 0.0 })
    }
}

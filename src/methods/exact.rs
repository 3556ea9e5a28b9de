//! Exact flow maps: for models whose flow over a step with held inputs is known in
//! closed form, `x(t + h) = φ_h(t, x, u)` is the step itself.

use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::model::{Eval, Flow, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// The exact method: `x₁ = φ_h(t₀, x₀, u)`. Error-free up to rounding for any `h`, so it
/// takes one step per control interval unless a fixed step asks for a finer grid.
/// Dense output is the cubic Hermite interpolant through both ends (two `f` calls).
///
/// ```
/// use reckon::{methods::Exact, vehicles::unicycle, Options, Problem, Controls};
/// use nalgebra::vector;
/// let controls = Controls::new(vec![0.0, 2.0], vec![vec![1.0, 0.0], vec![0.0, 0.0]]).unwrap();
/// let sol = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 2.0))
///     .controls(controls)
///     .solve(Exact::new(unicycle::flow), &Options::default())
///     .unwrap();
/// assert_eq!(*sol.last().1, vector![2.0, 0.0, 0.0]); // straight line at v = 1
/// ```
#[derive(Debug, Clone)]
pub struct Exact<F> {
    flow: F,
}

impl<F> Exact<F> {
    /// Wrap a flow map.
    pub fn new(flow: F) -> Self {
        Exact { flow }
    }
    /// The flow map.
    pub fn into_flow(self) -> F {
        self.flow
    }
}

impl<D: Dim, F: Flow<D>> Method<D> for Exact<F>
where
    DefaultAllocator: Allocator<D>,
{
    type Stepper = Self;
    fn name(&self) -> &'static str {
        "exact"
    }
    fn order(&self) -> u32 {
        u32::MAX
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

/// A flow carries nothing from step to step: [`Exact`] is its own stepper.
impl<D: Dim, F: Flow<D>> Stepper<D> for Exact<F>
where
    DefaultAllocator: Allocator<D>,
{
    #[inline(always)]
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step { t, x, h, x_new, .. } = s;
        self.flow.flow(t, x, &f.u, h, x_new);
        if x_new.len() != x.len() {
            let n = x_new.len();
            x_new.clone_from(x);
            return Err(crate::Error::invalid(
                "flow",
                format!("the flow returned {n} components for a state of {}", x.len()),
            ));
        }
        // the driver checks x_new (and asks `diagnose` where it broke)
        Ok(Outcome::Done { err: 0.0 })
    }
    /// A flow evaluates no derivative: a non-finite result is the state at `t + h`.
    fn diagnose<S: System<D>>(
        &mut self,
        _f: &mut Eval<'_, D, S>,
        t: f64,
        _x: &OVector<f64, D>,
        h: f64,
        x_new: &OVector<f64, D>,
    ) -> crate::Error {
        super::state_error(x_new, t + h)
    }
    fn dense_len(&self) -> usize {
        4
    }
    /// Cubic Hermite (`methods::dense::cubic_hermite`) from `f` at both ends.
    fn dense<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        let (c01, c23) = c.split_at_mut(2);
        f.rhs(t, x, &mut c01[1])?;
        f.rhs(t + h, x_new, &mut c23[1])?;
        super::dense::cubic_hermite(h, x, x_new, c);
        Ok(())
    }
}

//! Exact flow maps: for models whose flow over a step with held inputs is known in
//! closed form, `x(t + h) = φ_h(t, x, u)` is the step itself.

use super::step_size::Controller;
use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::model::{Eval, Flow, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// The exact method: `x₁ = φ_h(t₀, x₀, u)`. Error-free up to rounding for any `h`, so it
/// takes one step per control interval unless a fixed step asks for a finer grid.
/// Dense output is the quartic through both ends, both slopes and the flow's own
/// midpoint (two `f` calls and one more flow per step). When the dense output is used
/// (events, output times, `Options::dense`) and the step is not fixed, steps are
/// shortened until the cubic Hermite interpolant misses that midpoint by less than the
/// tolerance, so that values between the steps are good to the tolerance too: without
/// that, one long exact step across a turn or a fast transient interpolates badly.
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
    type Stepper = ExactStepper<D, F>;
    fn name(&self) -> &'static str {
        "exact"
    }
    fn order(&self) -> u32 {
        u32::MAX
    }
    fn error_order(&self) -> Option<u32> {
        None
    }
    /// For the interpolant's error (`O(h⁴)`), the one error an exact flow controls, and
    /// only when its dense output is used.
    fn controller(&self) -> Controller {
        Controller::new(3, 0.0)
    }
    fn never_retries(&self) -> bool {
        true
    }
    fn stepper<S: System<D>>(
        self,
        _f: &mut Eval<'_, D, S>,
        _t0: f64,
        x0: &OVector<f64, D>,
    ) -> Result<ExactStepper<D, F>> {
        Ok(ExactStepper {
            flow: self.flow,
            dense: false,
            f0: x0.clone(),
            f1: x0.clone(),
            xm: x0.clone(),
            at: None,
        })
    }
}

/// [`Exact`]'s run: the flow, and when the dense output is used, the step's slopes at
/// both ends and its midpoint `φ_{h/2}(t₀, x₀)`.
#[derive(Debug, Clone)]
pub struct ExactStepper<D: Dim, F>
where
    DefaultAllocator: Allocator<D>,
{
    flow: F,
    /// Whether the driver keeps the dense output ([`Stepper::dense_needed`]).
    dense: bool,
    f0: OVector<f64, D>,
    f1: OVector<f64, D>,
    xm: OVector<f64, D>,
    /// `(t, h)` of the step whose `f0`, `f1` and `xm` these are.
    at: Option<(f64, f64)>,
}

impl<D: Dim, F> ExactStepper<D, F>
where
    DefaultAllocator: Allocator<D>,
{
    /// The flow map.
    pub fn into_flow(self) -> F {
        self.flow
    }
}

impl<D: Dim, F: Flow<D>> ExactStepper<D, F>
where
    DefaultAllocator: Allocator<D>,
{
    /// `f` at both ends and the flow to the midpoint, for the step `(t, h)` from `x` to
    /// `x_new`, unless they are there already.
    fn ends_and_midpoint<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
    ) -> Result<()> {
        if self.at == Some((t, h)) {
            return Ok(());
        }
        f.rhs(t, x, &mut self.f0)?;
        f.rhs(t + h, x_new, &mut self.f1)?;
        self.flow.flow(t, x, &f.u, 0.5 * h, &mut self.xm);
        if self.xm.len() != x.len() {
            let n = self.xm.len();
            self.xm.clone_from(x);
            return Err(wrong_length(n, x.len()));
        }
        self.at = Some((t, h));
        Ok(())
    }
}

fn wrong_length(n: usize, m: usize) -> crate::Error {
    crate::Error::invalid("flow", format!("the flow returned {n} components for a state of {m}"))
}

impl<D: Dim, F: Flow<D>> Stepper<D> for ExactStepper<D, F>
where
    DefaultAllocator: Allocator<D>,
{
    /// The step is the flow. When the dense output is used and the step is adaptive,
    /// the estimate is the cubic Hermite interpolant's miss at the midpoint
    /// ([`dense`](Stepper::dense) then keeps the quartic through that midpoint).
    #[inline(always)]
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step {
            t,
            x,
            h,
            x_new,
            w,
            adaptive,
        } = s;
        self.flow.flow(t, x, &f.u, h, x_new);
        if x_new.len() != x.len() {
            let n = x_new.len();
            x_new.clone_from(x);
            return Err(wrong_length(n, x.len()));
        }
        if !(self.dense && adaptive) {
            // the driver checks x_new (and asks `diagnose` where it broke)
            return Ok(Outcome::Done { err: 0.0 });
        }
        self.at = None;
        self.ends_and_midpoint(f, t, h, x, x_new)?;
        let miss = super::dense::midpoint_miss(h, x, x_new, &self.f0, &self.f1, &self.xm);
        Ok(Outcome::Done {
            err: w.norm(&miss, x, x_new),
        })
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
    fn dense_needed(&mut self) {
        self.dense = true;
    }
    fn reset(&mut self) {
        self.at = None;
    }
    fn dense_len(&self) -> usize {
        5
    }
    /// The quartic through both ends, both slopes and the flow's own midpoint
    /// (`methods::dense::quartic_through_midpoint`).
    fn dense<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        self.ends_and_midpoint(f, t, h, x, x_new)?;
        c[1].copy_from(&self.f0);
        c[3].copy_from(&self.f1);
        super::dense::quartic_through_midpoint(h, x, x_new, &self.xm, c);
        self.at = None;
        Ok(())
    }
}

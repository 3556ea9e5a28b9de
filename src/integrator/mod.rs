//! The driver: step-size control, breakpoints, dense output, events, statistics and
//! errors, for any [`Method`]. It never asks which method it holds.

mod checks;
mod event_watch;
mod lean;
mod output;
pub(crate) mod save;
mod step_control;
mod stiffness_watch;
mod stops;

use crate::error::{Error, Result};
use crate::methods::step_size::initial_step;
use crate::methods::{Failure, Method, Outcome, Step, Stepper};
use crate::model::Stats;
use crate::model::{Eval, System};
use crate::problem::Problem;
use crate::problem::options::{Options, StepSize};
use crate::problem::solution::{DenseSegment, Solution, Stiffness, Switch};
use checks::EventEnd;
use event_watch::EventWatch;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};
use output::Output;
use step_control::StepControl;
use stiffness_watch::StiffnessWatch;
use stops::Stops;

/// Integrates a [`Problem`] one accepted step at a time.
///
/// ```
/// use reckon::{model, Problem, Options, methods::Euler};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// let mut it = p.integrator(Euler, &Options::default().fixed(0.25)).unwrap();
/// while it.step().unwrap().is_some() {}
/// assert_eq!(it.t(), 1.0);
/// assert!((it.x()[0] - 1.25f64.powi(4)).abs() < 1e-15);
/// ```
pub struct Integrator<'p, 'a, D: Dim, S, M: Method<D>>
where
    DefaultAllocator: Allocator<D>,
{
    problem: &'p Problem<'a, D, S>,
    /// The model, counted and checked.
    f: Eval<'p, D, S>,
    /// The method's run, and what the method said of itself once.
    stepper: M::Stepper,
    facts: Facts,
    /// Current time as reported (a stop's own value when one was landed on).
    t: f64,
    /// Current time measured from `t0`: steps advance this, so that steps far below
    /// `ulp(t0)` still advance (epoch timestamps).
    tau: f64,
    x: OVector<f64, D>,
    x_new: OVector<f64, D>,
    dir: f64,
    /// Breakpoints, `t_end`, the fixed-step grid and the control interval.
    stops: Stops<'p>,
    /// Tolerances, the step size and its controller, failures and limits.
    control: StepControl<D>,
    /// What the run keeps: dense polynomials, saved states, switches.
    output: Output<D>,
    /// Event functions' last values and the occurrences found.
    events: EventWatch<D>,
    /// A DAE's initial state put on its algebraic equations, when it was not.
    x0_corrected: Option<OVector<f64, D>>,
    /// DOPRI5's stiffness test.
    stiff: StiffnessWatch,
    done: bool,
}

/// What a [`Method`] says of itself, asked once when the run starts.
#[derive(Debug, Clone, Copy)]
struct Facts {
    name: &'static str,
    /// [`Method::crossing_test`].
    crossing_test: bool,
    /// [`Method::never_retries`].
    never_retries: bool,
    /// The order the first step is sized for (the error estimate's, plus one).
    iord: u32,
    /// [`Method::error_scale`].
    error_scale: f64,
}

impl<'p, 'a, D: Dim, S: System<D>, M: Method<D>> Integrator<'p, 'a, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    // inlined so that the caller builds the (large) integrator in place, not in a
    // temporary it then copies
    #[inline]
    pub(crate) fn new(problem: &'p Problem<'a, D, S>, method: M, opts: &Options) -> Result<Self> {
        opts.validate()?;
        let (t0, t_end, x0) = (problem.t0, problem.t_end, &problem.x0);
        if !t0.is_finite() || t_end.is_nan() {
            return Err(Error::invalid(
                "span",
                format!("({}, {}) is not finite", brief(t0), brief(t_end)),
            ));
        }
        if t0 == t_end {
            return Err(Error::invalid(
                "span",
                format!("empty span: t0 = t_end = {}", brief(t0)),
            ));
        }
        if x0.is_empty() {
            return Err(Error::invalid("x0", "the state has no components"));
        }
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid("x0", format!("component {i} is {}", x0[i])));
        }
        let dir = (t_end - t0).signum();
        let w = step_control::weights(opts, x0, method.tightens_loose_tolerances())?;
        let (segment, u) = stops::held_at_start(problem, dir)?;
        let mut f = Eval::new(&problem.system, u);
        f.sparse.choice = opts.linear_solver;
        let (method_name, error_order) = (method.name(), method.error_order());
        // the crossing test reads f_i as x_i': not so with a mass matrix
        let crossing_test = method.crossing_test() && problem.mass.is_none();
        let never_retries = method.never_retries();
        let mut x0_corrected = None;
        if let Some(m) = &problem.mass {
            m.check(x0.len())?;
            if !method.takes_mass() {
                return Err(Error::invalid(
                    "mass",
                    format!("{method_name} takes no mass matrix (M·x' = f): use Bdf or Rodas5P"),
                ));
            }
            f.mass = Some(m);
            x0_corrected = method.consistent_start(&mut f, t0, x0, &w)?;
        }
        let x0 = x0_corrected.as_ref().unwrap_or(x0);
        let (controller, error_scale) = (method.controller(), method.error_scale(&w));
        let exact = method.order() == u32::MAX;
        let mut stepper = method.stepper(&mut f, t0, x0)?;
        let output = Output::new(opts, problem, x0, dir, stepper.dense_len())?;
        if output.keep_dense {
            stepper.dense_needed();
        }
        let (adaptive, fixed_h) = match (opts.step, error_order) {
            (StepSize::Fixed(h), _) => (false, h),
            (StepSize::Adaptive, Some(_)) => (true, f64::NAN),
            // an exact flow's one error is its interpolant's: controlled when used
            (StepSize::Adaptive, None) if exact && output.keep_dense => (true, f64::NAN),
            (StepSize::Adaptive, None) if exact => (false, opts.h_max),
            (StepSize::Adaptive, None) => {
                return Err(Error::invalid(
                    "step",
                    format!(
                        "{} has no error estimate: give a fixed step (StepSize::Fixed)",
                        method_name
                    ),
                ));
            }
        };
        let iord = error_order.unwrap_or(1) + 1;
        let mut h = f64::NAN;
        if adaptive {
            h = match opts.h0 {
                Some(h0) => h0.min(opts.h_max),
                None => {
                    let mut f0 = match stepper.derivative_at_start() {
                        Some(f0) => f0.clone(),
                        None => {
                            let mut f0 = x0.clone();
                            f.rhs(t0, x0, &mut f0)?;
                            f0
                        }
                    };
                    slope(&f, &mut f0);
                    first_step(&mut f, &w, t0, x0, &f0, iord, error_scale, opts.h_max, dir)?
                }
            };
        }
        let events = EventWatch::new(problem, opts.zeno, t0, x0)?;
        Ok(Integrator {
            problem,
            f,
            stepper,
            facts: Facts {
                name: method_name,
                crossing_test,
                never_retries,
                iord,
                error_scale,
            },
            t: t0,
            tau: 0.0,
            x: x0.clone(),
            x_new: x0.clone(),
            dir,
            stops: Stops::new(problem, opts, dir, segment, fixed_h),
            control: StepControl::new(w, controller, adaptive, h, opts),
            output,
            events,
            x0_corrected,
            stiff: StiffnessWatch::new(opts),
            done: false,
        })
    }

    /// Refuse an accepted step whose error estimate over the components outside the
    /// error control ([`Weights::uncontrolled`], those components the columns of a
    /// sensitivity matrix with the scales `column_scales`) exceeds `limit` with
    /// [`Error::SensitivityUnresolved`]: the sensitivities of an augmented solve, which
    /// are integrated on the steps chosen for `x` alone. Such a run takes the general
    /// loop (the lean ones do not watch).
    pub(crate) fn watch_uncontrolled(&mut self, limit: f64, column_scales: Vec<f64>) {
        self.control.watch = Some(limit);
        self.control.w.set_columns(column_scales);
    }

    /// Current time.
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Current state.
    pub fn x(&self) -> &OVector<f64, D> {
        &self.x
    }
    /// Counters so far.
    pub fn stats(&self) -> Stats {
        self.f.stats
    }
    /// Accepted steps so far (`stats().accepted` without copying the counters).
    #[inline]
    pub(crate) fn accepted(&self) -> u64 {
        self.f.stats.accepted
    }
    /// Where DOPRI5's stiffness test fired so far.
    pub fn stiffness(&self) -> Option<Stiffness> {
        self.stiff.verdict
    }
    /// The direction of integration, `±1`.
    pub(crate) fn direction(&self) -> f64 {
        self.dir
    }
    /// The method's stepper, as the last step left it.
    pub(crate) fn stepper(&self) -> &M::Stepper {
        &self.stepper
    }
    /// Whether the steps are adaptive (error-controlled).
    pub(crate) fn is_adaptive(&self) -> bool {
        self.control.adaptive
    }
    /// The inputs held now: those the next step uses.
    pub(crate) fn held_inputs(&self) -> &[f64] {
        &self.f.u
    }
    /// The last accepted step of [`step`](Self::step): `(t, h, t + h)` as the method took
    /// it (`t + h` where it landed).
    pub(crate) fn last_step(&self) -> (f64, f64, f64) {
        self.output.last_step
    }
    /// Whether `t_end` (or a terminal event) has been reached.
    pub fn is_done(&self) -> bool {
        self.done
    }
    /// The step size the controller proposes next (adaptive mode).
    pub fn proposed_step(&self) -> f64 {
        self.dir * self.control.h.abs()
    }

    /// Switch the held inputs at the current time: a jump, so the method drops what it
    /// carried over from the last step (as at a control breakpoint). Streaming use:
    /// set the inputs of the interval ahead, then [`step_until`](Self::step_until) its end.
    ///
    /// ```
    /// use reckon::{methods::Exact, vehicles::unicycle, Options, Problem};
    /// use nalgebra::vector;
    /// // an open-ended problem fed one control interval at a time
    /// let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, f64::INFINITY)).inputs(vec![1.0, 0.0]);
    /// let mut it = p.integrator(Exact::new(unicycle::flow), &Options::default()).unwrap();
    /// it.step_until(2.0).unwrap();
    /// it.set_inputs(&[0.0, 0.5]).unwrap(); // stop and turn in place
    /// while !it.reached(3.0) {
    ///     it.step_until(3.0).unwrap();
    /// }
    /// assert_eq!(*it.x(), vector![2.0, 0.0, 0.5]);
    /// assert!(it.set_inputs(&[1.0]).is_err()); // the unicycle reads two inputs
    /// ```
    pub fn set_inputs(&mut self, u: &[f64]) -> Result<()> {
        check_inputs(u, self.problem.system.inputs())?;
        self.f.hold(u);
        self.stepper.reset();
        Ok(())
    }

    /// Whether the integrator stands exactly at `t_stop`: measured from the start,
    /// `t − t₀ == t_stop − t₀`, the way the driver lands on a stop. Drive a stream with
    /// `while !it.reached(t_stop) { it.step_until(t_stop)?; }`, not with `t() != t_stop`:
    /// far from the origin (`t₀ = 10¹⁵`, where an `f64` time has a resolution of 0.125)
    /// a step that ends short of `t_stop` can have a [`t`](Self::t) that rounds to it.
    ///
    /// ```
    /// use reckon::{model, Problem, Options, methods::Bdf};
    /// use nalgebra::vector;
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let p = Problem::new(&f, vector![1.0], (1e15, f64::INFINITY));
    /// let mut it = p.integrator(Bdf::default(), &Options::default()).unwrap();
    /// while !it.reached(1e15 + 2.0) {
    ///     it.step_until(1e15 + 2.0).unwrap();
    /// }
    /// assert!((it.x()[0] - (-2.0f64).exp()).abs() < 1e-5);
    /// ```
    pub fn reached(&self, t_stop: f64) -> bool {
        self.t == t_stop && self.tau == t_stop - self.problem.t0
    }

    /// Take one accepted step that does not pass `t_stop`, landing on it exactly when it
    /// reaches it (then [`reached`](Self::reached)`(t_stop)`); `Ok(None)` once the end of
    /// the span has been reached. `t_stop` must lie ahead in the direction of integration; one beyond
    /// `t_end` acts as `t_end`. This is how an open-ended span (`t_end = ±∞`) is driven.
    ///
    /// ```
    /// use reckon::{model, Problem, Options, methods::Rk45};
    /// use nalgebra::vector;
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let p = Problem::new(&f, vector![1.0], (1.7e12, f64::INFINITY)); // epoch milliseconds
    /// let mut it = p.integrator(Rk45, &Options::default().rtol(1e-10).atol(1e-12)).unwrap();
    /// while !it.reached(1.7e12 + 1.0) {
    ///     it.step_until(1.7e12 + 1.0).unwrap();
    /// }
    /// assert!((it.x()[0] - (-1.0f64).exp()).abs() < 1e-9);
    /// assert!(it.step_until(1.0).is_err()); // behind
    /// ```
    pub fn step_until(&mut self, t_stop: f64) -> Result<Option<f64>> {
        if self.done {
            return Ok(None);
        }
        // ahead measured from t0, as the driver measures (t itself may already round to it)
        if !t_stop.is_finite() || self.dir * ((t_stop - self.problem.t0) - self.tau) <= 0.0 {
            return Err(Error::invalid(
                "t_stop",
                format!(
                    "{} is not ahead of t = {} in the direction of integration",
                    brief(t_stop),
                    brief(self.t)
                ),
            ));
        }
        self.stops.until = Some(t_stop);
        let r = self.step();
        self.stops.until = None;
        r
    }

    /// The next time the integrator must land on: the next breakpoint (or `t_end`), or
    /// the caller's `until` when it comes first.
    fn next_stop(&self) -> f64 {
        let stop = self.stop();
        match self.stops.until {
            Some(u) if self.dir * (u - stop) < 0.0 => u,
            _ => stop,
        }
    }

    /// The size of the next attempt and, when it lands on a stop or grid point, that
    /// time. Sizes are differences of times measured from `t0` (`tau`).
    fn next_h(&self, stop: f64) -> (f64, Option<(f64, f64)>) {
        let stop_tau = stop - self.problem.t0;
        if self.control.adaptive {
            let h = self.dir * self.control.h.abs().min(self.control.h_max);
            if self.dir * (self.tau + 1.01 * h - stop_tau) >= 0.0 {
                return (stop_tau - self.tau, Some((stop, stop_tau)));
            }
            return (h, None);
        }
        let grid = grid_point(self.stops.grid_k, self.dir * self.stops.fixed_h);
        let (target, target_tau) = if self.dir * (grid - stop_tau) >= -self.stops.grid_tol {
            (stop, stop_tau)
        } else {
            (self.problem.t0 + grid, grid)
        };
        let h = target_tau - self.tau;
        match self.stops.sub_h {
            Some(hs) if hs.abs() < h.abs() => (hs, None),
            _ => (h, Some((target, target_tau))),
        }
    }

    /// Take one accepted step; `Ok(None)` once the end has been reached.
    pub fn step(&mut self) -> Result<Option<f64>> {
        if self.done {
            return Ok(None);
        }
        let stop = self.next_stop();
        if stop.is_infinite() && !self.control.adaptive && self.stops.fixed_h.is_infinite() {
            return Err(Error::invalid(
                "span",
                "an open-ended span needs a finite stop ahead: use step_until",
            ));
        }
        let mut failures = 0;
        loop {
            if self.control.attempts >= self.control.max_steps {
                return Err(Error::MaxSteps {
                    t: self.t,
                    steps: self.control.attempts,
                });
            }
            let (h, landing) = self.next_h(stop);
            let land = landing.map(|l| l.0);
            if land.is_some() && h == 0.0 {
                // two stops that differ by less than the resolution of t − t0
                self.land_without_step(stop);
                return Ok(Some(self.t));
            }
            // zero, NaN, ±∞ or below what t − t0 can resolve (dopri5.f: 0.1|h| ≤ |t|·uround);
            // a step that lands on a stop advances to it exactly, however small
            let resolvable = land.is_some() || h.abs() > 10.0 * f64::EPSILON * self.tau.abs();
            if !(resolvable && h.abs() > 0.0 && h.abs() < f64::INFINITY) {
                return Err(self.underflow(h, failures));
            }
            self.control.attempts += 1;
            if self.control.watch.is_some() {
                self.control.w.clear_uncontrolled();
            }
            let outcome = self.stepper.step(
                &mut self.f,
                Step {
                    t: self.t,
                    x: &self.x,
                    h,
                    x_new: &mut self.x_new,
                    w: &self.control.w,
                    adaptive: self.control.adaptive,
                },
            )?;
            let err = match outcome {
                Outcome::Retry(why) => {
                    self.retry(why, h, &mut failures)?;
                    continue;
                }
                Outcome::Done { err } => err,
            };
            // explicit kernels evaluate f unchecked: every result is checked here, once
            // (by its sum, and component by component only when the sum is not finite)
            if err.is_nan() || has_non_finite(&self.x_new) {
                self.reject_non_finite(h, &mut failures)?;
                continue;
            }
            if self.control.adaptive && err > 1.0 {
                self.reject(h, err);
                continue;
            }
            if self.control.adaptive
                && self.facts.crossing_test
                && let Some(fac) = self.crossing_factor(self.t, h)
            {
                self.reject_by(h, fac);
                continue;
            }
            if let Some(limit) = self.control.watch
                && self.control.adaptive
                && self.control.w.uncontrolled() > limit
            {
                return Err(Error::SensitivityUnresolved {
                    t: self.t,
                    h,
                    ratio: self.control.w.uncontrolled(),
                });
            }
            let (t_new, tau_new) = landing.unwrap_or((self.problem.t0 + (self.tau + h), self.tau + h));
            self.accept(h, err, land, t_new, tau_new)?;
            return Ok(Some(self.t));
        }
    }

    /// An implicit solve failed at `h`: halve the step, or give up with the typed error.
    #[cold]
    fn retry(&mut self, why: Failure, h: f64, failures: &mut usize) -> Result<()> {
        self.f.stats.rejected += 1;
        *failures += 1;
        // a fixed step at which I − hJ is singular has no implicit Euler map
        let singular_fixed = !self.control.adaptive && why == Failure::Singular;
        self.control.last_failure = Some(why);
        self.control.non_finite_trial = None;
        if *failures > self.control.max_failures || singular_fixed {
            return Err(self.failure_error(why, h));
        }
        if self.control.adaptive {
            self.control.h = 0.5 * h.abs();
            self.control.last_rejected = true;
        } else {
            self.stops.sub_h = Some(0.5 * h);
        }
        Ok(())
    }

    /// The typed error for an implicit solve that failed at `h` for good.
    fn failure_error(&self, why: Failure, h: f64) -> Error {
        match why {
            Failure::NonFinite { t, component } => Error::NonFinite {
                t,
                quantity: crate::error::Quantity::Derivative,
                component,
            },
            Failure::Newton { iterations, residual } => Error::NewtonDiverged {
                t: self.t,
                h,
                iterations,
                residual,
            },
            Failure::Singular => Error::SingularMatrix { t: self.t, h },
        }
    }

    /// The step size shrank below what `t − t0` resolves. When it shrank because `f` was
    /// non-finite at the Newton attempts since the last accepted step (`failures` of
    /// them, the last one recorded), that is the error: say where `f` broke.
    #[cold]
    fn underflow(&self, h: f64, failures: usize) -> Error {
        if failures > 0
            && let Some(e) = &self.control.non_finite_trial
        {
            return e.clone();
        }
        match self.control.last_failure {
            Some(why @ Failure::NonFinite { .. }) if failures > 0 => self.failure_error(why, h),
            _ => self
                .zeno_underflow()
                .unwrap_or(Error::StepSizeUnderflow { t: self.t, h }),
        }
    }

    /// The step produced NaN or ±∞: say where.
    #[cold]
    fn non_finite(&mut self, h: f64) -> Error {
        if let Some(e) = self.f.fault.take() {
            return e;
        }
        self.stepper.diagnose(&mut self.f, self.t, &self.x, h, &self.x_new)
    }

    /// The error estimate `err > 1` rejects the step: shrink it.
    #[inline]
    fn reject(&mut self, h: f64, err: f64) {
        let fac = self.reject_factor(err);
        self.reject_by(h, fac);
    }

    /// Reject the step `h` and retry with `|h|·fac`.
    #[inline]
    fn reject_by(&mut self, h: f64, fac: f64) {
        self.f.stats.rejected += 1;
        self.control.h = h.abs() * fac;
        self.control.last_rejected = true;
    }

    /// The step `h` from `(t, x)` gave a non-finite `x_new` or error estimate. With a
    /// fixed step, or when `f` is already non-finite at `(t, x)` (the model itself is
    /// broken there, and no smaller step helps), that is the typed error. An adaptive
    /// run rejects the trial and retries with [`NON_FINITE_FACTOR`] of the step, like a
    /// failed error test: a trial state that overflowed says only that the step was far
    /// too long. Should `h` then shrink to nothing, the error is the diagnosis of the
    /// last non-finite trial (see [`underflow`](Self::underflow)).
    #[cold]
    fn reject_non_finite(&mut self, h: f64, failures: &mut usize) -> Result<()> {
        if self.f.fault.is_some() || !self.control.adaptive {
            return Err(self.non_finite(h));
        }
        let e = self.non_finite(h);
        let at_start = matches!(e, Error::NonFinite { t, .. } if t == self.t);
        if at_start || !matches!(e, Error::NonFinite { .. }) {
            return Err(e);
        }
        *failures += 1;
        self.control.non_finite_trial = Some(e);
        self.reject_by(h, NON_FINITE_FACTOR);
        Ok(())
    }

    /// The crossing test, after a step from `(t, x)` with `h` passed the error test: when
    /// a component `i` changed sign (or left an exact zero) by more than
    /// [`CROSSING_NOISE`] of its tolerance scale, `f_i` is evaluated on the face
    /// `x_i = 0` next to the step: at the start (`x` with `x_i = 0`, at `t`) and where the
    /// step's line crosses it (`x + θ(x_new − x)` with `x_i = 0`, at `t + θh`), for the
    /// first such component. A solution cannot leave through a face where `f_i` points
    /// back, so if it does at either point the step is rejected and retried with
    /// `h·clamp(0.9θ, 0.1, 0.5)`: `Some(factor)`. Both points, because a component slaved
    /// to the crossing one (Robertson's quasi-steady `y₂ ≈ 4·10⁻⁶·y₁`) crosses with it,
    /// and on the line it is already on the wrong side where `y₁` crosses, while at the
    /// start it says `f₁ = 10⁴·y₂·y₃ > 0`. A false rejection (a legitimate crossing whose
    /// step also spans a turn) only shortens the step until it no longer spans both.
    ///
    /// Why: at a loose tolerance a component decaying toward zero (a concentration) may
    /// be stepped past it by an error within `atol`, and past zero the model may have no
    /// stable solution at all. Robertson's `y₁` at `t ≈ 2·10⁹` with `atol = 10⁻⁶` went
    /// to −1.6·10⁻⁶, and from there the exact flow of the model itself runs off to
    /// `y₁ = −4.65·10⁷` by `t = 10¹¹`, every step within tolerance (scipy's BDF, Radau
    /// and LSODA do the same at some of `rtol` 10⁻¹ … 10⁻³). Nothing is clamped: the
    /// step is only retried shorter, and accepted once it does not cross or the
    /// crossing agrees with `f`. One or two extra `f` calls per step that crosses; only
    /// for methods whose [`Method::crossing_test`] is on (the implicit ones).
    fn crossing_factor(&mut self, t: f64, h: f64) -> Option<f64> {
        let mut first: Option<(usize, f64)> = None;
        for (i, (&a, &b)) in self.x.as_slice().iter().zip(self.x_new.as_slice()).enumerate() {
            let crossed = a * b < 0.0 || (a == 0.0 && b != 0.0);
            if crossed && b.abs() > CROSSING_NOISE * self.control.w.scale(i, b) {
                let theta = a / (a - b);
                if first.is_none_or(|(_, th)| theta < th) {
                    first = Some((i, theta));
                }
            }
        }
        let (i, theta) = first?;
        // the way the step moved component i, against the way f moves it over h (h < 0 backward)
        let moved = (self.x_new[i] - self.x[i]) * h.signum();
        let fac = (0.9 * theta).clamp(0.1, 0.5);
        let (xs, fs) = self
            .control
            .probe
            .get_or_insert_with(|| (self.x.clone(), self.x.clone()));
        // where the step starts, component i moved to zero
        xs.copy_from(&self.x);
        xs[i] = 0.0;
        self.f.rhs(t, xs, fs).ok()?;
        if fs[i] * moved < 0.0 {
            return Some(fac);
        }
        if theta == 0.0 {
            return None;
        }
        // where the step's line crosses zero
        xs.copy_from(&self.x_new);
        *xs -= &self.x;
        *xs *= theta;
        *xs += &self.x;
        xs[i] = 0.0;
        self.f.rhs(t + theta * h, xs, fs).ok()?;
        (fs[i] * moved < 0.0).then_some(fac)
    }

    /// The factor that shrinks a step rejected with estimate `err > 1`.
    #[inline]
    fn reject_factor(&mut self, err: f64) -> f64 {
        match self.stepper.step_factor(false, err) {
            Some(fac) => fac,
            None if err.is_finite() => self.control.controller.reject(err),
            None => self.control.controller.min_factor,
        }
    }

    /// The next step size after an accepted step of size `h` with estimate `err`.
    #[inline]
    fn propose(&mut self, h: f64, err: f64, landed: bool) {
        self.control.h = self.accepted_h(h, err, self.control.h.abs(), self.control.last_rejected, landed);
        self.control.last_rejected = false;
    }

    /// The step size after an accepted step `h` with estimate `err`, where `proposal`
    /// was the size planned for it and `last_rejected` says whether a rejection came
    /// just before: `|h|·fac`, no larger than `|h|` after a rejection, and not below the
    /// plan when `h` was only shortened to land on a stop.
    #[inline]
    fn accepted_h(&mut self, h: f64, err: f64, proposal: f64, last_rejected: bool, landed: bool) -> f64 {
        let fac = match self.stepper.step_factor(true, err) {
            Some(fac) => fac,
            None => self.control.controller.accept(err),
        };
        let mut next = h.abs() * fac;
        if last_rejected {
            next = next.min(h.abs());
        }
        // a step shortened to land on a stop says nothing against the plan
        if landed && h.abs() < proposal && !last_rejected {
            next = next.max(proposal);
        }
        next
    }

    /// The next stop: a breakpoint, or `t_end` after the last.
    #[inline]
    fn stop(&self) -> f64 {
        self.stops.list.get(self.stops.idx).copied().unwrap_or(self.stops.t_end)
    }

    /// Reach `stop` without a step: it is closer than `t − t0` can resolve.
    fn land_without_step(&mut self, stop: f64) {
        self.t = stop;
        self.arrive(Some(stop));
    }

    /// After landing on `land` (or after any step when `None`): pass a breakpoint,
    /// switch inputs, reset the per-interval step count.
    fn arrive(&mut self, land: Option<f64>) {
        let Some(l) = land else { return };
        // arrival measured from t0: a grid point whose absolute time rounds to the stop's
        // (t0 = 1e15 resolves 0.125) is not the stop, and the next row's inputs wait
        if l == self.stop() && self.tau == l - self.problem.t0 {
            self.control.attempts = 0;
            self.stops.idx += 1;
            if self.stops.idx > self.stops.list.len() {
                self.done = true;
            } else {
                self.enter_segment();
            }
        } else if Some(l) == self.stops.until {
            self.control.attempts = 0;
        }
    }

    fn accept(&mut self, h: f64, err: f64, land: Option<f64>, mut t_new: f64, tau_new: f64) -> Result<()> {
        self.f.stats.accepted += 1;
        self.control.non_finite_trial = None;
        if self.control.adaptive {
            self.check_stiffness(h, t_new);
        }
        let mut end = EventEnd::Passed;
        if self.output.keep_dense {
            self.output.dense_fresh = false;
            // an output time before the step's end is interpolated (one at the end is x_new)
            let inside = self.output.next_time.is_some_and(|ta| self.dir * (ta - t_new) < 0.0);
            if self.output.store_dense || inside {
                self.ensure_dense(h)?;
            }
            end = self.check_events(h, &mut t_new)?;
        }
        self.output.last_step = (self.t, h, t_new);
        self.stepper.accept();
        if let Some((to, reason)) = self.stepper.switched() {
            self.output.switches.push(Switch { t: t_new, to, reason });
        }
        std::mem::swap(&mut self.x, &mut self.x_new);
        self.t = t_new;
        // a step cut short at an event ends at the event's time, measured from t0
        self.tau = if end == EventEnd::Passed {
            tau_new
        } else {
            t_new - self.problem.t0
        };
        match end {
            EventEnd::Passed => {}
            EventEnd::Stopped => {
                self.done = true;
                return Ok(());
            }
            EventEnd::Reset => return self.restart(),
        }
        if self.control.adaptive {
            self.propose(h, err, land.is_some());
        } else {
            self.stops.sub_h = None;
            let grid = grid_point(self.stops.grid_k, self.dir * self.stops.fixed_h);
            if land.is_some() && (tau_new == grid || (tau_new - grid).abs() <= self.stops.grid_tol) {
                self.stops.grid_k += 1;
            }
        }
        self.arrive(land);
        Ok(())
    }
    /// The dense polynomial of the step of size `h` being accepted (from `self.t`), into
    /// `output.dense`, unless it is there already.
    pub(super) fn ensure_dense(&mut self, h: f64) -> Result<()> {
        if !self.output.dense_fresh {
            self.stepper
                .dense(&mut self.f, self.t, h, &self.x, &self.x_new, &mut self.output.dense)?;
            self.output.dense_fresh = true;
        }
        Ok(())
    }

    /// After a reset of the state: the method starts afresh from `(t, x)` (its carried
    /// stages, history and factorisations dropped), and an adaptive run chooses its
    /// step again as at the start (Hairer's algorithm, the controller's memory cleared).
    /// A fixed-step run goes on to the next point of its grid.
    #[cold]
    fn restart(&mut self) -> Result<()> {
        self.stepper.reset();
        if self.control.adaptive {
            let mut f0 = self.x.clone();
            self.f.rhs(self.t, &self.x, &mut f0)?;
            slope(&self.f, &mut f0);
            let (iord, scale) = (self.facts.iord, self.facts.error_scale);
            let h_max = self.control.h_max;
            self.control.h = first_step(
                &mut self.f,
                &self.control.w,
                self.t,
                &self.x,
                &f0,
                iord,
                scale,
                h_max,
                self.dir,
            )?;
            self.control.controller.restart();
            self.control.last_rejected = false;
        } else {
            self.stops.sub_h = None;
        }
        Ok(())
    }

    /// Every event occurrence so far, in time order (what
    /// [`Solution::events`](crate::Solution::events) holds at the end of a solve).
    pub fn events(&self) -> &[crate::problem::solution::EventHit<D>] {
        &self.events.hits
    }

    /// Run to the end and collect every step.
    pub fn solve(mut self) -> Result<Solution<D>> {
        if self.problem.t_end.is_infinite() {
            return Err(Error::invalid(
                "span",
                "an open-ended span (t_end = ±∞) has no end to solve to: drive it with step_until",
            ));
        }
        let mut out = save::Saver::new(&self.output.save, self.dir, self.t, &self.x);
        // at least one step per interval between stops (a long control log): kept states
        // grow into reserved room instead of by repeated doubling (capped at 2²⁴ up front)
        out.reserve((self.stops.list.len() - self.stops.idx + 1).min(1 << 24));
        let mut dense = Vec::new();
        // every step kept (the default): the lean loops push directly; the end state
        // only: they keep nothing, and it is stored once, after they return `Ok` (at
        // `t_end`: an error returns no solution)
        if self.is_lean() {
            if out.every_step() {
                self.run_lean(|t, x| out.push(t, x))?;
            } else if out.end_only() {
                self.run_lean(|_, _| {})?;
                out.step(self.t, &self.x, None);
            } else {
                self.run_lean(|t, x| out.step(t, x, None))?;
            }
        } else if self.is_lean_fixed() {
            if out.every_step() {
                self.run_lean_fixed(save::Slots::new(&mut out))?;
            } else if out.end_only() {
                self.run_lean_fixed(|_: f64, _: &OVector<f64, D>| {})?;
                out.step(self.t, &self.x, None);
            } else {
                self.run_lean_fixed(|t: f64, x: &OVector<f64, D>| out.step(t, x, None))?;
            }
        }
        loop {
            self.output.next_time = out.next_time();
            if self.step()?.is_none() {
                break;
            }
            let (t0, h, t1) = self.output.last_step;
            let seg = self.output.dense_fresh.then_some((t0, h, self.output.dense.as_slice()));
            match self.output.jump.take() {
                // a reset: the state before it ends the step, the one after it starts the next
                Some(before) => {
                    out.step(self.t, &before, seg);
                    out.jump(self.t, &self.x);
                }
                None => out.step(self.t, &self.x, seg),
            }
            if self.output.store_dense {
                dense.push(DenseSegment {
                    t0,
                    h,
                    t1,
                    c: self.output.dense.clone(),
                });
            }
        }
        let (t, x) = out.finish();
        Ok(Solution {
            t,
            x,
            stats: self.f.stats,
            events: std::mem::take(&mut self.events.hits),
            stiffness: self.stiff.verdict,
            method: self.facts.name,
            switches: std::mem::take(&mut self.output.switches),
            dense,
            x0_corrected: self.x0_corrected.take(),
        })
    }
}

impl<D: Dim, S: System<D>, M: Method<D>> Iterator for Integrator<'_, '_, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    type Item = Result<(f64, OVector<f64, D>)>;
    fn next(&mut self) -> Option<Self::Item> {
        match self.step() {
            Ok(Some(t)) => Some(Ok((t, self.x.clone()))),
            Ok(None) => None,
            Err(e) => {
                self.done = true;
                Some(Err(e))
            }
        }
    }
}

/// Held inputs must be as many as the model reads, and finite.
fn check_inputs(u: &[f64], n_in: usize) -> Result<()> {
    if u.len() != n_in {
        return Err(Error::invalid(
            "inputs",
            format!("{} inputs given, the model reads {n_in}", u.len()),
        ));
    }
    if let Some(i) = u.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid("inputs", format!("input {i} is {}", u[i])));
    }
    Ok(())
}

/// A number for a message (see [`Brief`](crate::error::Brief)).
pub(crate) fn brief(v: f64) -> String {
    crate::error::Brief(v).to_string()
}

/// `Problem::integrator` and `Problem::solve` live with the driver, so that the problem
/// (data) depends on nothing that runs it.
impl<'a, D: Dim, S: System<D>> Problem<'a, D, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// A stepper over this problem: call [`Integrator::step`] or iterate.
    pub fn integrator<M: Method<D>>(&self, method: M, opts: &Options) -> Result<Integrator<'_, 'a, D, S, M>> {
        Integrator::new(self, method, opts)
    }
    /// Integrate from `t0` to `t_end` and return every step.
    pub fn solve<M: Method<D>>(&self, method: M, opts: &Options) -> Result<Solution<D>> {
        self.integrator(method, opts)?.solve()
    }
}

/// How near a grid point (relative to the fixed step `h`) a stop counts as on it: the
/// step to the stop is then the step to the grid point, and the grid moves on.
pub(super) const GRID_TOL: f64 = 1e-10;
/// The most a step to a stop is stretched past the fixed step by [`grid_tol`]'s clock
/// term (relative to `h`).
const GRID_CLOCK_CAP: f64 = 1e-3;

/// How near grid point `τ = k·h` a stop `s` (`τ_s = s − t0`) counts as on it:
/// `max(10⁻¹⁰·h, min(2·ulp(max(|t0|, |t_end|)), 10⁻³·h))`. The clock term: stops are
/// times on the caller's clock, rounded there, so `τ_s` of a row meant to be on the grid
/// (a log at 0.05 s from `t0` = 1.7e9, ulp 2.4e-7) misses it by up to an ulp; within
/// that the step goes straight to the stop instead of to the grid point and then a step
/// of 10⁻⁸ `h` to the stop. Capped at 10⁻³·h: far from the epoch (t0 = 1e15 resolves
/// 0.125 s) the grid point and the stop are distinct points of the solution, and the
/// step to the grid point does not arrive at the stop (arrival is measured from t0).
pub(super) fn grid_tol(fixed_h: f64, t0: f64, t_end: f64) -> f64 {
    let far = if t_end.is_finite() {
        t0.abs().max(t_end.abs())
    } else {
        t0.abs()
    };
    let ulp = f64::from_bits(far.to_bits() + 1) - far;
    let h = fixed_h.abs();
    if !h.is_finite() {
        return GRID_TOL * h;
    }
    (GRID_TOL * h).max((2.0 * ulp).min(GRID_CLOCK_CAP * h))
}

/// The step factor after a trial step that came out non-finite in an adaptive run
/// (the smallest factor of the error-test rejection, 0.2, would often retry into the same
/// overflow; a quarter is CVODE's factor after repeated failures).
pub const NON_FINITE_FACTOR: f64 = 0.25;

/// A sign change of a component by less than this fraction of its tolerance scale
/// `atol + rtol·|x|` is rounding noise about zero, not a crossing
/// ([`Integrator::crossing_factor`] does not test it).
pub const CROSSING_NOISE: f64 = 1e-3;

/// The fixed-step grid's point `k + 1` from the start, `τ = (k + 1)·(±h)`: the count
/// converted through `i64` (one `cvtsi2sd`; `u64 → f64` takes six instructions without
/// AVX-512), which is the same value for every count below 2⁶³, and `dir·h` is exact.
#[inline(always)]
pub(super) fn grid_point(k: u64, signed_h: f64) -> f64 {
    (k + 1) as i64 as f64 * signed_h
}

/// Whether `x` holds a NaN or ±∞. The sum `s = Σ v` is non-finite (`s − s` is NaN)
/// whenever some `v` is, and for finite `v` only when it overflows: that rare case is
/// settled by [`any_non_finite`](crate::linalg::any_non_finite), which past 8
/// components is the whole test. The sum starts from −0, which `−0 + a = a` lets the
/// compiler drop (n − 1 additions, a subtraction and a compare).
#[inline(always)]
pub(super) fn has_non_finite<D: Dim>(x: &OVector<f64, D>) -> bool
where
    DefaultAllocator: Allocator<D>,
{
    if x.len() > 8 {
        // past a few components the sum's chain of additions is the slower test
        return crate::linalg::any_non_finite(x.as_slice());
    }
    let s = x.iter().fold(-0.0, |a, v| a + v);
    // (`s − s` on purpose: one subtraction, NaN exactly for a non-finite `s`)
    #[allow(clippy::eq_op)]
    let bad = (s - s).is_nan();
    bad && crate::linalg::any_non_finite(x.as_slice())
}

/// Hairer's first step from `(t0, x0)` with `f0 = f(t0, x0)` for an estimate of order
/// `iord − 1`, shortened by `scale^(−1/iord)` for a method that holds its error `scale`
/// times tighter than the tolerance ([`Method::error_scale`]).
#[allow(clippy::too_many_arguments)]
fn first_step<D: Dim, S: System<D>>(
    f: &mut Eval<'_, D, S>,
    w: &crate::methods::step_size::Weights<D>,
    t0: f64,
    x0: &OVector<f64, D>,
    f0: &OVector<f64, D>,
    iord: u32,
    scale: f64,
    h_max: f64,
    dir: f64,
) -> Result<f64>
where
    DefaultAllocator: Allocator<D>,
{
    let mut probe = x0.clone();
    let mut f1 = x0.clone();
    let h = initial_step(w, x0, f0, iord, h_max, dir, &mut probe, |dt, y| {
        f.rhs(t0 + dt, y, &mut f1)?;
        Ok(f1.clone())
    })?;
    Ok(h * scale.max(1.0).powf(-1.0 / iord as f64))
}

/// `f(t, x)` turned into the slope `x' = M⁺·f` for a mass-matrix problem (the first
/// step's size is set by the slope); unchanged without one.
fn slope<D: Dim, S: System<D>>(f: &Eval<'_, D, S>, fx: &mut OVector<f64, D>)
where
    DefaultAllocator: Allocator<D>,
{
    if let Some(m) = f.mass {
        let v = fx.clone();
        m.derivative(v.as_slice(), fx.as_mut_slice());
    }
}

//! The driver: step-size control, breakpoints, dense output, events, statistics and
//! errors, for any [`Method`]. It never asks which method it holds.

use crate::control::{Controller, Weights, initial_step};
use crate::controls::Controls;
use crate::error::{Error, Result};
use crate::events::{Event, locate};
use crate::methods::{Failure, Method, Outcome};
use crate::options::{Options, StepSize};
use crate::solution::{DenseSegment, EventHit, Solution, Stats, Stiffness, horner};
use crate::system::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// An initial-value problem `x' = f(t, x, u)`, `x(t0) = x0`, on `[t0, t_end]`
/// (`t_end < t0` integrates backward), with optional held inputs and events.
///
/// ```
/// use reckon::{model, Problem, Options, methods::Dopri5};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]); // harmonic oscillator
/// let sol = Problem::new(&f, vector![1.0, 0.0], (0.0, std::f64::consts::PI))
///     .solve(Dopri5::default(), &Options::default().rtol(1e-10).atol(1e-12))
///     .unwrap();
/// assert!((sol.last().1[0] + 1.0).abs() < 1e-9); // cos π = −1
/// ```
pub struct Problem<'a, D: Dim, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// The model.
    pub system: S,
    /// Initial state.
    pub x0: OVector<f64, D>,
    /// Start time.
    pub t0: f64,
    /// End time.
    pub t_end: f64,
    /// Inputs held piecewise constant, if the model reads any.
    pub controls: Option<Controls>,
    events: Vec<Event<'a, D>>,
}

impl<'a, D: Dim, S: System<D>> Problem<'a, D, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// `x' = f(t, x)`, `x(span.0) = x0`, integrated to `span.1`.
    pub fn new(system: S, x0: OVector<f64, D>, span: (f64, f64)) -> Self {
        Problem {
            system,
            x0,
            t0: span.0,
            t_end: span.1,
            controls: None,
            events: Vec::new(),
        }
    }
    /// Hold inputs piecewise constant; every control time becomes a breakpoint.
    pub fn controls(mut self, controls: Controls) -> Self {
        self.controls = Some(controls);
        self
    }
    /// Watch for zeros of an event function.
    pub fn event(mut self, event: Event<'a, D>) -> Self {
        self.events.push(event);
        self
    }
    /// A stepper over this problem: call [`Integrator::step`] or iterate.
    pub fn integrator<M: Method<D>>(&self, method: M, opts: &Options) -> Result<Integrator<'_, 'a, D, S, M>> {
        Integrator::new(self, method, opts)
    }
    /// Integrate from `t0` to `t_end` and return every step.
    pub fn solve<M: Method<D>>(&self, method: M, opts: &Options) -> Result<Solution<D>> {
        self.integrator(method, opts)?.solve()
    }
}

/// Integrates a [`Problem`] one accepted step at a time.
///
/// ```
/// use reckon::{model, Problem, Options, methods::ExplicitEuler};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// let mut it = p.integrator(ExplicitEuler, &Options::default().fixed(0.25)).unwrap();
/// while it.step().unwrap().is_some() {}
/// assert_eq!(it.t(), 1.0);
/// assert!((it.x()[0] - 1.25f64.powi(4)).abs() < 1e-15);
/// ```
pub struct Integrator<'p, 'a, D: Dim, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    problem: &'p Problem<'a, D, S>,
    f: Eval<'p, D, S>,
    method: M,
    w: Weights<D>,
    t: f64,
    x: OVector<f64, D>,
    x_new: OVector<f64, D>,
    dir: f64,
    adaptive: bool,
    fixed_h: f64,
    grid_k: u64,
    sub_h: Option<f64>,
    stops: Vec<f64>,
    stop_idx: usize,
    h: f64,
    controller: Controller,
    last_rejected: bool,
    attempts: usize,
    max_steps: usize,
    h_max: f64,
    max_failures: usize,
    segment: Option<usize>,
    keep_dense: bool,
    dense: Vec<OVector<f64, D>>,
    last_step: (f64, f64, f64),
    g_prev: Vec<f64>,
    hits: Vec<EventHit<D>>,
    stiff_every: Option<usize>,
    stiff_count: (u32, u32),
    stiff_countdown: usize,
    stiffness: Option<Stiffness>,
    done: bool,
}

impl<'p, 'a, D: Dim, S: System<D>, M: Method<D>> Integrator<'p, 'a, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    fn new(problem: &'p Problem<'a, D, S>, mut method: M, opts: &Options) -> Result<Self> {
        opts.validate()?;
        let (t0, t_end, x0) = (problem.t0, problem.t_end, &problem.x0);
        if !t0.is_finite() || !t_end.is_finite() {
            return Err(Error::invalid("span", format!("({t0}, {t_end}) is not finite")));
        }
        if t0 == t_end {
            return Err(Error::invalid("span", format!("empty span: t0 = t_end = {t0}")));
        }
        if x0.is_empty() {
            return Err(Error::invalid("x0", "the state has no components"));
        }
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid("x0", format!("component {i} is {}", x0[i])));
        }
        let dir = (t_end - t0).signum();
        let (r, _) = x0.shape_generic();
        let w = Weights {
            rtol: opts.rtol.expand("rtol", r)?,
            atol: opts.atol.expand("atol", r)?,
        };
        if (0..x0.len()).any(|i| w.rtol[i] == 0.0 && w.atol[i] == 0.0) {
            return Err(Error::invalid("atol", "rtol and atol are both zero for a component"));
        }
        // inputs
        let n_in = problem.system.inputs();
        let (segment, u) = match &problem.controls {
            None if n_in > 0 => {
                return Err(Error::invalid(
                    "controls",
                    format!("the model reads {n_in} inputs but no controls were given"),
                ));
            }
            None => (None, Vec::new()),
            Some(c) => {
                if c.width() != n_in {
                    return Err(Error::invalid(
                        "controls",
                        format!("{} inputs per sample, the model reads {n_in}", c.width()),
                    ));
                }
                let k = c.segment(t0, dir).ok_or_else(|| {
                    Error::invalid(
                        "controls",
                        format!("t0 = {t0} is not after the first control time {}", c.times()[0]),
                    )
                })?;
                (Some(k), c.values(k).to_vec())
            }
        };
        // stops: breakpoints strictly inside the span, in the direction of travel, then t_end
        let inside = |b: f64| dir * (b - t0) > 0.0 && dir * (t_end - b) > 0.0;
        let mut stops: Vec<f64> = opts.breakpoints.iter().copied().filter(|&b| inside(b)).collect();
        if let Some(c) = &problem.controls {
            stops.extend(c.times().iter().copied().filter(|&b| inside(b)));
        }
        stops.sort_by(|a, b| (dir * a).total_cmp(&(dir * b)));
        stops.dedup();
        stops.push(t_end);

        let mut f = Eval::new(&problem.system, u);
        method.init(&mut f, t0, x0)?;
        let (adaptive, fixed_h) = match (opts.step, method.error_order()) {
            (StepSize::Fixed(h), _) => (false, h),
            (StepSize::Adaptive, Some(_)) => (true, f64::NAN),
            (StepSize::Adaptive, None) if method.order() == u32::MAX => (false, opts.h_max),
            (StepSize::Adaptive, None) => {
                return Err(Error::invalid(
                    "step",
                    format!(
                        "{} has no error estimate: give a fixed step (StepSize::Fixed)",
                        method.name()
                    ),
                ));
            }
        };
        let mut h = f64::NAN;
        if adaptive {
            h = match opts.h0 {
                Some(h0) => h0.min(opts.h_max),
                None => {
                    let f0 = match method.derivative_at_start() {
                        Some(f0) => f0.clone(),
                        None => {
                            let mut f0 = x0.clone();
                            f.rhs(t0, x0, &mut f0)?;
                            f0
                        }
                    };
                    let iord = method.error_order().unwrap_or(1) + 1;
                    let mut probe = x0.clone();
                    let mut f1 = x0.clone();
                    initial_step(&w, x0, &f0, iord, opts.h_max, dir, &mut probe, |dt, y| {
                        f.rhs(t0 + dt, y, &mut f1)?;
                        Ok(f1.clone())
                    })?
                }
            };
        }
        let keep_dense = opts.dense || !problem.events.is_empty();
        let dense = if keep_dense {
            vec![x0.clone(); method.dense_len()]
        } else {
            Vec::new()
        };
        let g_prev = problem.events.iter().map(|e| (e.g)(t0, x0)).collect();
        Ok(Integrator {
            problem,
            controller: method.controller(),
            f,
            method,
            w,
            t: t0,
            x: x0.clone(),
            x_new: x0.clone(),
            dir,
            adaptive,
            fixed_h,
            grid_k: 0,
            sub_h: None,
            stops,
            stop_idx: 0,
            h,
            last_rejected: false,
            attempts: 0,
            max_steps: opts.max_steps,
            h_max: opts.h_max,
            max_failures: opts.max_step_failures,
            segment,
            keep_dense,
            dense,
            last_step: (t0, 0.0, t0),
            g_prev,
            hits: Vec::new(),
            stiff_every: opts.stiffness_check,
            stiff_count: (0, 0),
            stiff_countdown: opts.stiffness_check.unwrap_or(0),
            stiffness: None,
            done: false,
        })
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
    /// Where DOPRI5's stiffness test fired so far.
    pub fn stiffness(&self) -> Option<Stiffness> {
        self.stiffness
    }
    /// Whether `t_end` (or a terminal event) has been reached.
    pub fn is_done(&self) -> bool {
        self.done
    }
    /// The step size the controller proposes next (adaptive mode).
    pub fn proposed_step(&self) -> f64 {
        self.dir * self.h.abs()
    }

    /// The size of the next attempt and, when it lands on a stop or grid point, that time.
    fn next_h(&self, stop: f64) -> (f64, Option<f64>) {
        if self.adaptive {
            let h = self.dir * self.h.abs().min(self.h_max);
            if self.dir * (self.t + 1.01 * h - stop) >= 0.0 {
                return (stop - self.t, Some(stop));
            }
            return (h, None);
        }
        let grid = self.problem.t0 + (self.grid_k + 1) as f64 * self.dir * self.fixed_h;
        let target = if self.dir * (grid - stop) >= -1e-10 * self.fixed_h {
            stop
        } else {
            grid
        };
        let h = target - self.t;
        match self.sub_h {
            Some(hs) if hs.abs() < h.abs() => (hs, None),
            _ => (h, Some(target)),
        }
    }

    /// Take one accepted step; `Ok(None)` once the end has been reached.
    pub fn step(&mut self) -> Result<Option<f64>> {
        if self.done {
            return Ok(None);
        }
        let stop = self.stops[self.stop_idx];
        let mut failures = 0;
        loop {
            if self.attempts >= self.max_steps {
                return Err(Error::MaxSteps {
                    t: self.t,
                    steps: self.attempts,
                });
            }
            let (h, land) = self.next_h(stop);
            // zero, NaN, ±∞ or below what t can resolve (dopri5.f: 0.1|h| ≤ |t|·uround)
            if !(h.abs() > 10.0 * f64::EPSILON * self.t.abs() && h.abs() < f64::INFINITY) {
                return Err(Error::StepSizeUnderflow { t: self.t, h });
            }
            self.attempts += 1;
            let outcome = self
                .method
                .step(&mut self.f, self.t, &self.x, h, &mut self.x_new, &self.w, self.adaptive)?;
            let err = match outcome {
                Outcome::Retry(why) => {
                    self.f.stats.rejected += 1;
                    failures += 1;
                    // a fixed step at which I − hJ is singular has no implicit Euler map
                    let singular_fixed = !self.adaptive && why == Failure::Singular;
                    if failures > self.max_failures || singular_fixed {
                        return Err(match why {
                            Failure::Newton { iterations, residual } => Error::NewtonDiverged {
                                t: self.t,
                                h,
                                iterations,
                                residual,
                            },
                            Failure::Singular => Error::SingularMatrix { t: self.t, h },
                        });
                    }
                    if self.adaptive {
                        self.h = 0.5 * h.abs();
                        self.last_rejected = true;
                    } else {
                        self.sub_h = Some(0.5 * h);
                    }
                    continue;
                }
                Outcome::Done { err } => err,
            };
            // explicit kernels evaluate f unchecked: every result is checked here, once
            // (v·0 is NaN exactly when v is ±∞ or NaN; the sum of zeros cannot overflow)
            if err.is_nan() || self.x_new.iter().fold(0.0, |a, v| a + v * 0.0).is_nan() {
                return Err(self.method.diagnose(&mut self.f, self.t, &self.x, h, &self.x_new));
            }
            if self.adaptive && err > 1.0 {
                self.f.stats.rejected += 1;
                let fac = if err.is_finite() {
                    self.controller.reject(err)
                } else {
                    self.controller.min_factor
                };
                self.h = h.abs() * fac;
                self.last_rejected = true;
                continue;
            }
            let t_new = land.unwrap_or(self.t + h);
            self.accept(h, err, land, t_new)?;
            return Ok(Some(self.t));
        }
    }

    fn accept(&mut self, h: f64, err: f64, land: Option<f64>, mut t_new: f64) -> Result<()> {
        self.f.stats.accepted += 1;
        if self.adaptive {
            self.check_stiffness(h, t_new);
        }
        let mut stopped = false;
        if self.keep_dense {
            self.method
                .dense(&mut self.f, self.t, h, &self.x, &self.x_new, &mut self.dense)?;
            stopped = self.check_events(h, &mut t_new)?;
            self.last_step = (self.t, h, t_new);
        }
        self.method.accept();
        std::mem::swap(&mut self.x, &mut self.x_new);
        self.t = t_new;
        if stopped {
            self.done = true;
            return Ok(());
        }
        if self.adaptive {
            let fac = self.controller.accept(err);
            let proposal = self.h.abs();
            let mut next = h.abs() * fac;
            if self.last_rejected {
                next = next.min(h.abs());
            }
            // a step shortened to land on a stop says nothing against the plan
            if land.is_some() && h.abs() < proposal && !self.last_rejected {
                next = next.max(proposal);
            }
            self.h = next;
            self.last_rejected = false;
        } else {
            self.sub_h = None;
            let grid = self.problem.t0 + (self.grid_k + 1) as f64 * self.dir * self.fixed_h;
            if land.is_some() && (t_new == grid || (t_new - grid).abs() <= 1e-10 * self.fixed_h) {
                self.grid_k += 1;
            }
        }
        if land == Some(self.stops[self.stop_idx]) {
            self.stop_idx += 1;
            if self.stop_idx == self.stops.len() {
                self.done = true;
            } else {
                self.enter_segment();
            }
        }
        Ok(())
    }

    /// At a breakpoint: switch to the inputs of the interval ahead and tell the method.
    fn enter_segment(&mut self) {
        if let Some(c) = &self.problem.controls
            && let Some(k) = c.segment(self.t, self.dir)
            && Some(k) != self.segment
        {
            self.segment = Some(k);
            self.f.u.clear();
            self.f.u.extend_from_slice(c.values(k));
        }
        self.method.reset();
    }

    /// DOPRI5's test: `h·λ > 3.25` fifteen times without six non-stiff verdicts between.
    fn check_stiffness(&mut self, h: f64, t_new: f64) {
        let Some(every) = self.stiff_every else { return };
        let (stiff, nonstiff) = &mut self.stiff_count;
        self.stiff_countdown -= 1;
        if self.stiff_countdown > 0 && *stiff == 0 {
            return;
        }
        if self.stiff_countdown == 0 {
            self.stiff_countdown = every;
        }
        let Some(hl) = self.method.stiffness(h, &self.x_new) else {
            return;
        };
        if hl > 3.25 {
            *nonstiff = 0;
            *stiff += 1;
            if *stiff == 15 && self.stiffness.is_none() {
                self.stiffness = Some(Stiffness { t: t_new, h_lambda: hl });
            }
        } else {
            *nonstiff += 1;
            if *nonstiff == 6 {
                *stiff = 0;
            }
        }
    }

    /// Locate event zeros in the step just taken (dense output is on whenever there are
    /// events); `true` if a terminal one cut it short (then `t_new` and `x_new` are moved
    /// to the event).
    fn check_events(&mut self, h: f64, t_new: &mut f64) -> Result<bool> {
        let events = &self.problem.events;
        if events.is_empty() {
            return Ok(false);
        }
        let mut found: Vec<(f64, usize)> = Vec::new();
        for (i, ev) in events.iter().enumerate() {
            let g1 = (ev.g)(*t_new, &self.x_new);
            if ev.crosses(self.g_prev[i], g1) {
                let te = if g1 == 0.0 {
                    *t_new
                } else {
                    locate(ev, i, &self.dense, self.t, h, *t_new)?
                };
                found.push((te, i));
            }
            self.g_prev[i] = g1;
        }
        found.sort_by(|a, b| (self.dir * a.0).total_cmp(&(self.dir * b.0)));
        for (te, i) in found {
            let x = horner(&self.dense, (te - self.t) / h);
            self.hits.push(EventHit {
                index: i,
                t: te,
                x: x.clone(),
            });
            if events[i].terminal {
                *t_new = te;
                self.x_new = x;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Run to the end and collect every step.
    pub fn solve(mut self) -> Result<Solution<D>> {
        let mut t = vec![self.t];
        let mut x = vec![self.x.clone()];
        let mut dense = Vec::new();
        while self.step()?.is_some() {
            t.push(self.t);
            x.push(self.x.clone());
            if self.keep_dense {
                let (t0, h, t1) = self.last_step;
                dense.push(DenseSegment {
                    t0,
                    h,
                    t1,
                    c: self.dense.clone(),
                });
            }
        }
        Ok(Solution {
            t,
            x,
            stats: self.f.stats,
            events: std::mem::take(&mut self.hits),
            stiffness: self.stiffness,
            method: self.method.name(),
            dense,
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

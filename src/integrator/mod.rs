//! The driver: step-size control, breakpoints, dense output, events, statistics and
//! errors, for any [`Method`]. It never asks which method it holds.

mod checks;

use crate::control::{Controller, Weights, initial_step};
use crate::error::{Error, Result};
use crate::methods::{Failure, Method, Outcome};
use crate::options::{Options, StepSize};
use crate::problem::Problem;
use crate::solution::{DenseSegment, EventHit, Solution, Stats, Stiffness};
use crate::system::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

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
    pub(crate) fn new(problem: &'p Problem<'a, D, S>, mut method: M, opts: &Options) -> Result<Self> {
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
                (Some(k), c.values(k).unwrap_or_default().to_vec())
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

//! The lean path of [`Integrator::solve`]: an adaptive run with nothing to stop for but
//! `t_end` (no breakpoints, control times, events or dense output) needs none of the
//! general step's bookkeeping. It takes exactly the steps [`Integrator::step`] would take,
//! bit for bit (the shared pieces — rejection, retry, step-size proposal, checks — are
//! the same functions), with the loop reduced to what a hand-written one does.

use super::Integrator;
use crate::error::{Error, Result};
use crate::methods::{Method, Outcome, Step, Stepper};
use crate::model::System;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// What the fixed-step lean loop keeps of a step ending at `(t, x)`: a closure's
/// choice, or every step ([`Slots`](super::save::Slots)).
pub(super) trait Keep<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Keep `(t, x)`.
    fn keep(&mut self, t: f64, x: &OVector<f64, D>);
}

impl<D: Dim, F: FnMut(f64, &OVector<f64, D>)> Keep<D> for F
where
    DefaultAllocator: Allocator<D>,
{
    #[inline(always)]
    fn keep(&mut self, t: f64, x: &OVector<f64, D>) {
        self(t, x);
    }
}

impl<D: Dim> Keep<D> for super::save::Slots<'_, D>
where
    DefaultAllocator: Allocator<D>,
{
    #[inline(always)]
    fn keep(&mut self, t: f64, x: &OVector<f64, D>) {
        super::save::Slots::keep(self, t, x);
    }
}

impl<D: Dim, S: System<D>, M: Method<D>> Integrator<'_, '_, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    /// Whether [`run_lean`](Self::run_lean) applies.
    pub(super) fn is_lean(&self) -> bool {
        self.control.adaptive
            && !self.done
            && !self.output.keep_dense
            && self.control.watch.is_none()
            && self.problem.events.is_empty()
            && self.stops.until.is_none()
            && self.stops.idx == self.stops.list.len()
            && self.stops.t_end.is_finite()
    }

    /// Step to `t_end`, pushing every accepted step; the state afterwards is what the
    /// same steps through [`step`](Self::step) leave. The loop keeps the step size,
    /// time, counters and rejection flag in locals (registers, across the model calls)
    /// and writes them back before every exit and every call that reads them.
    pub(super) fn run_lean(&mut self, mut keep: impl FnMut(f64, &nalgebra::OVector<f64, D>)) -> Result<()> {
        let t0 = self.problem.t0;
        let t_end = self.stops.t_end;
        let end_tau = t_end - t0;
        let (dir, h_max, max_steps) = (self.dir, self.control.h_max, self.control.max_steps);
        let (mut h_abs, mut tau, mut t) = (self.control.h.abs(), self.tau, self.t);
        let (mut attempts, mut last_rejected) = (self.control.attempts, self.control.last_rejected);
        let (mut accepted, mut rejected) = (0u64, 0u64);
        let mut failures = 0;
        // the smallest step `t − t0 = tau` still resolves: 10 ulp of tau
        let mut tiny = 10.0 * f64::EPSILON * tau.abs();
        macro_rules! sync {
            () => {
                self.control.h = h_abs;
                self.tau = tau;
                self.t = t;
                self.control.attempts = attempts;
                self.control.last_rejected = last_rejected;
                self.f.stats.accepted += accepted;
                self.f.stats.rejected += rejected;
            };
        }
        loop {
            if attempts >= max_steps {
                sync!();
                return Err(Error::MaxSteps { t, steps: attempts });
            }
            // `min` by compare: one instruction, and the same as `f64::min` here (h_max is
            // never NaN; a NaN h_abs gives h_max either way)
            let mut h = dir * if h_abs < h_max { h_abs } else { h_max };
            let last = dir * (tau + 1.01 * h - end_tau) >= 0.0;
            if last {
                h = end_tau - tau;
                if h == 0.0 {
                    sync!();
                    self.land_without_step(t_end);
                    keep(self.t, &self.x);
                    return Ok(());
                }
            }
            // a step too small for `tau` to resolve (0 included), ±∞ or NaN: underflow
            let ha = h.abs();
            if !(ha < f64::INFINITY && ha > if last { 0.0 } else { tiny }) {
                sync!();
                return Err(self.underflow(h, failures));
            }
            attempts += 1;
            let outcome = self.stepper.step(
                &mut self.f,
                Step {
                    t,
                    x: &self.x,
                    h,
                    x_new: &mut self.x_new,
                    w: &self.control.w,
                    adaptive: true,
                },
            )?;
            let err = match outcome {
                Outcome::Retry(why) => {
                    sync!();
                    (accepted, rejected) = (0, 0);
                    self.retry(why, h, &mut failures)?;
                    (h_abs, last_rejected) = (self.control.h.abs(), self.control.last_rejected);
                    continue;
                }
                Outcome::Done { err } => err,
            };
            if err.is_nan() || super::has_non_finite(&self.x_new) {
                sync!();
                (accepted, rejected) = (0, 0);
                self.reject_non_finite(h, &mut failures)?;
                (h_abs, last_rejected) = (self.control.h.abs(), self.control.last_rejected);
                continue;
            }
            if err > 1.0 {
                rejected += 1;
                h_abs = ha * self.reject_factor(err);
                last_rejected = true;
                continue;
            }
            if self.facts.crossing_test
                && let Some(fac) = self.crossing_factor(t, h)
            {
                rejected += 1;
                h_abs = ha * fac;
                last_rejected = true;
                continue;
            }
            if failures > 0 {
                self.control.non_finite_trial = None;
            }
            failures = 0;
            accepted += 1;
            let (t_new, tau_new) = if last {
                (t_end, end_tau)
            } else {
                (t0 + (tau + h), tau + h)
            };
            self.check_stiffness(h, t_new);
            self.stepper.accept();
            if let Some((to, reason)) = self.stepper.switched() {
                self.output.switches.push(super::Switch { t: t_new, to, reason });
            }
            // a copy, not a swap: x_new is overwritten by the next attempt anyway
            self.x.copy_from(&self.x_new);
            t = t_new;
            tau = tau_new;
            tiny = 10.0 * f64::EPSILON * tau.abs();
            h_abs = self.accepted_h(h, err, h_abs, last_rejected, last);
            last_rejected = false;
            keep(t_new, &self.x);
            if last {
                sync!();
                self.arrive(Some(t_end));
                return Ok(());
            }
        }
    }
}

impl<D: Dim, S: System<D>, M: Method<D>> Integrator<'_, '_, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    /// Whether [`run_lean_fixed`](Self::run_lean_fixed) applies: a fixed-step run (or
    /// an exact flow, one step per interval) of a method that never retries a step, with
    /// nothing to stop for but the breakpoints and `t_end`.
    pub(super) fn is_lean_fixed(&self) -> bool {
        !self.control.adaptive
            && !self.done
            && !self.output.keep_dense
            && self.problem.events.is_empty()
            && self.stops.until.is_none()
            && self.stops.sub_h.is_none()
            && self.stops.t_end.is_finite()
            && self.facts.never_retries
            && self.times_bounded()
    }

    /// Whether `t0`, `t`, `t_end` and every stop are below 2¹⁰²¹ in magnitude (the stops
    /// are sorted: the first and the last), so that every `stop − t0`, grid point and
    /// step `h` between them is finite: the lean loop then tests `h` for zero alone
    /// (times near `f64::MAX` take the general path, which reports the overflow).
    fn times_bounded(&self) -> bool {
        const BOUND: f64 = f64::MAX / 8.0;
        [self.problem.t0, self.t, self.stops.t_end]
            .into_iter()
            .chain(self.stops.list.first().copied())
            .chain(self.stops.list.last().copied())
            .all(|v| v.abs() < BOUND)
    }

    /// Step to `t_end` through every breakpoint and control time, pushing every step:
    /// the steps, times, input switches, counters and errors of [`step`](Self::step),
    /// bit for bit, with the time, the next stop, the grid index and the counters in
    /// locals (`arrive` and `enter_segment` written out around them).
    pub(super) fn run_lean_fixed(&mut self, mut keep: impl Keep<D>) -> Result<()> {
        // an exact flow's step is infinite: one step to each stop, every step on the grid
        // (a loop of its own, without the grid arithmetic)
        // and when the stops are a control log's own times (forwards, no breakpoints),
        // a loop that opens the next row at every stop, with `dir = 1` known
        let rows = self.stops.from.is_some() && self.problem.controls.is_some();
        // the rows loop replaces the held row at every stop without a test for owned
        // inputs: until a row is held again (after `set_inputs`, which holds owned
        // values), the general step takes the run, keeping what `solve` keeps (no dense
        // output on this path)
        while rows && !self.f.holds_row() {
            match self.step()? {
                Some(t) => keep.keep(t, &self.x),
                None => return Ok(()),
            }
        }
        let all = usize::MAX;
        match (self.stops.fixed_h.is_infinite(), rows) {
            (true, true) => return self.run_lean_fixed_with::<true, true, _>(keep, all).map(drop),
            (true, false) => return self.run_lean_fixed_with::<true, false, _>(keep, all).map(drop),
            (false, _) => {}
        }
        // A fixed step: the stops ahead that each take one step on the grid (a log at the
        // step's rate, the usual case) go through the one-step-per-stop loop, which has no
        // grid arithmetic (told apart here in blocks, out of the loop: `on_grid_run`);
        // the others through the grid loop, for a stretch that doubles while the stops
        // stay off the grid (so that a log at another rate costs a scan per 2048 stops).
        let mut off = MIN_RUN;
        while !self.done {
            let from = self.stops.idx;
            let run = self.on_grid_run(CHUNK);
            // (a short run: only at the end of the log, where nothing follows it)
            if run >= MIN_RUN || from + run > self.stops.list.len() {
                off = MIN_RUN;
                let bound = from + run;
                keep = match rows {
                    true => self.run_lean_fixed_with::<true, true, _>(keep, bound)?,
                    false => self.run_lean_fixed_with::<true, false, _>(keep, bound)?,
                };
            } else {
                let bound = from + off;
                off = (2 * off).min(CHUNK);
                keep = match rows {
                    true => self.run_lean_fixed_with::<false, true, _>(keep, bound)?,
                    false => self.run_lean_fixed_with::<false, false, _>(keep, bound)?,
                };
            }
        }
        Ok(())
    }

    /// How many of the stops ahead (from `stop_idx`, with `t_end` after the last; at
    /// most `limit`) the fixed-step loop reaches in one step each: stop `i` (`τᵢ = sᵢ − t0`)
    /// within [`grid_tol`](super::grid_tol) of grid point `grid_k + 1 + i`, `τ = (grid_k + 1 + i)·(±h)`, the
    /// test by which the grid loop steps straight to a stop and counts it on the grid.
    /// (The grid loop takes exactly those steps: the same `h = τᵢ − τᵢ₋₁`, nonzero as
    /// consecutive grid points below 2⁵⁰ are at least `3h/4` apart; counts that far
    /// take the grid loop.) In blocks of 8, without a branch per stop.
    fn on_grid_run(&self, limit: usize) -> usize {
        let (t0, fixed_h) = (self.problem.t0, self.stops.fixed_h);
        let signed_h = self.dir * fixed_h;
        let tol = self.stops.grid_tol;
        let k0 = self.stops.grid_k + 1;
        if k0.saturating_add(limit as u64) >= 1 << 50 {
            return 0;
        }
        let rest = self.stops.list.get(self.stops.idx..).unwrap_or_default();
        // (a first stop where the run stands is landed on without a step)
        if rest.first().copied().unwrap_or(self.stops.t_end) - t0 == self.tau {
            return 0;
        }
        let n = rest.len().min(limit);
        let on = |i: usize, s: f64| ((s - t0) - super::grid_point(self.stops.grid_k + i as u64, signed_h)).abs() <= tol;
        let mut i = 0;
        for block in rest[..n].chunks_exact(8) {
            // (`k + j` for `j < 8` exact: every count here is below 2⁵³)
            let k = (k0 + i as u64) as i64 as f64;
            let mut all = true;
            for (j, &s) in block.iter().enumerate() {
                all &= ((s - t0) - (k + j as f64) * signed_h).abs() <= tol;
            }
            if !all {
                break;
            }
            i += 8;
        }
        while i < n && on(i, rest[i]) {
            i += 1;
        }
        if i == rest.len() && i < limit && on(i, self.stops.t_end) {
            i += 1;
        }
        i
    }

    /// [`run_lean_fixed`](Self::run_lean_fixed) with `ONE_PER_STOP = fixed_h.is_infinite()`
    /// and `ROWS`: the stops are the control times `lo..` (`stops_from = Some(lo)`, which
    /// the driver sets only forwards). Out of line: each copy is a function of its own,
    /// so its registers are allocated for its loop alone, not for all twelve copies
    /// inlined into `solve` (callgrind: unicycle `Exact` 336 → 318 instructions per step,
    /// bicycle 440 → 395; explicit Euler 286 → 289). A grid point before the stop is a
    /// step of its own (a second expansion of `step_to!`), so the step to the stop has
    /// its target fixed (no selects), and the grid test starts with `grid == stop_tau`
    /// (a log at the step's rate); with the cheaper finiteness tests: Euler 289 → 262,
    /// unicycle 318 → 310, bicycle 395 → 388; the row index written back on exit only:
    /// 258, 302, 379; `h` known finite (`times_bounded`), a log's stops read from the
    /// log, and the state alternating between two buffers (no swap): 252, 296, 373; the
    /// step limit tested only where the count can have reached it (at entry, after a
    /// grid step short of the stop), a step to the stop counted only on its way out with
    /// an error, and the last stop told before the increment: 242, 293, 371; a log's
    /// rows replaced without the test for owned inputs (a row held from the start):
    /// 235, 287, 365; every step written into the output's spare capacity, one count
    /// and one room test for the times and the states (`Slots`), and the end of the log
    /// fetched out of line: 232, 279, 357; a log at the step's rate told apart a block
    /// of stops at a time out of the loop (`on_grid_run`, 5.5 instructions per stop) and
    /// run through the one-step-per-stop loop, with no grid arithmetic: Euler 225.
    // (`!(a >= b)` on purpose: a NaN takes the grid branch, as in `next_h`)
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    #[inline(never)]
    fn run_lean_fixed_with<const ONE_PER_STOP: bool, const ROWS: bool, K: Keep<D>>(
        &mut self,
        mut keep: K,
        bound: usize,
    ) -> Result<K> {
        let t0 = self.problem.t0;
        let dir = if ROWS { 1.0 } else { self.dir };
        let (fixed_h, max_steps, grid_tol) = (self.stops.fixed_h, self.control.max_steps, self.stops.grid_tol);
        let signed_h = dir * fixed_h;
        let t_end = self.stops.t_end;
        let problem = self.problem;
        let controls = problem.controls.as_ref();
        // stop `i` opens interval `lo + i` (`times[lo + i] = t < times[lo + i + 1]`: what
        // the search finds)
        let lo = self.stops.from.unwrap_or(0);
        // a log's stops are its own times `lo..lo + n_stops` (borrowed for 'p, not through
        // `self`), with its rows cut to the same length: the row of a stop passed is in
        // bounds once `stop_idx ≤ n_stops` is known
        let (all_stops, all_rows) = match controls {
            Some(c) if ROWS => {
                let n = self.stops.list.len();
                let times = c.times().get(lo..lo + n).unwrap_or_default();
                let rows = c.rows().get(lo..).unwrap_or_default();
                let n = times.len().min(rows.len());
                (&times[..n], &rows[..n])
            }
            _ => (&[][..], &[][..]),
        };
        let n_all = if ROWS { all_stops.len() } else { self.stops.list.len() };
        debug_assert!(!ROWS || all_stops == &self.stops.list[..]);
        // this call's stops: those before `bound − 1`, the last it arrives at (`t_end` at
        // `n_all`), after which it returns (a pause, when the run goes on)
        let n_stops = bound.saturating_sub(1).min(n_all);
        let (log_stops, rows) = if ROWS {
            (&all_stops[..n_stops], &all_rows[..n_stops])
        } else {
            (&[][..], &[][..])
        };
        let last_stop = if n_stops < n_all {
            self.stops.list[n_stops]
        } else {
            t_end
        };
        // the stop after `i` passed (`last_stop` after the last of this call's)
        macro_rules! stop_at {
            ($i:expr) => {
                if ROWS {
                    // (the last once per call: out of the loop's way)
                    match log_stops.get($i) {
                        Some(&s) => s,
                        None => cold(last_stop),
                    }
                } else {
                    match self.stops.list.get($i) {
                        Some(&s) if $i < n_stops => s,
                        _ => last_stop,
                    }
                }
            };
        }
        let (mut t, mut tau, mut attempts) = (self.t, self.tau, self.control.attempts);
        let (mut stop_idx, mut grid_k) = (self.stops.idx, self.stops.grid_k);
        let mut accepted = 0u64;
        // (a log's row index is written back on exit only: every stop passed since
        // `entry` opened interval `lo + stop_idx − 1`)
        let entry = self.stops.idx;
        macro_rules! sync {
            () => {
                self.t = t;
                self.tau = tau;
                self.control.attempts = attempts;
                self.stops.idx = stop_idx;
                self.stops.grid_k = grid_k;
                self.f.stats.accepted += std::mem::take(&mut accepted);
                // (not for the arrival at t_end, as `arrive`, which stops there)
                if ROWS && stop_idx.min(n_all) > entry {
                    self.stops.segment = Some(lo + stop_idx.min(n_all) - 1);
                }
            };
        }
        let mut stop = stop_at!(stop_idx);
        let mut stop_tau = stop - t0;
        // The state alternates between `self.x` and `self.x_new` (no swap per step): the
        // loop body is written twice, the even half stepping `x → x_new` and the odd half
        // `x_new → x`, each taking exactly one step. `$odd` says where the state is; every
        // way out first puts it back in `self.x` (`home!`), as the general path has it.
        macro_rules! home {
            ($odd:expr) => {
                if $odd {
                    std::mem::swap(&mut self.x, &mut self.x_new);
                }
            };
        }
        // `step`'s step limit (`$odd`: where the state is)
        macro_rules! limit {
            ($odd:expr) => {
                if attempts >= max_steps {
                    home!($odd);
                    sync!();
                    return Err(Error::MaxSteps { t, steps: attempts });
                }
            };
        }
        // one step to `target` (`target_tau = target − t0`) from `self.$src` into
        // `self.$dst`: the checks of `step`, the method's step, the finiteness of the
        // result, then the time advanced
        macro_rules! step_to {
            ($target:expr, $target_tau:expr, $src:ident, $dst:ident, $odd:expr, $steps:lifetime, $pending:expr) => {{
                let (target, target_tau) = ($target, $target_tau);
                let h = target_tau - tau;
                // (finite: `times_bounded`)
                debug_assert!(h.is_finite());
                if h == 0.0 {
                    // two stops closer than t − t0 resolves: the general path lands
                    // without a step (then the loop starts again at the even half)
                    home!($odd);
                    sync!();
                    self.land_without_step(stop);
                    keep.keep(self.t, &self.x);
                    // (past this call's last stop: back to the caller, which looks again)
                    if self.done || self.stops.idx > n_stops {
                        return Ok(keep);
                    }
                    (t, attempts, stop_idx) = (self.t, self.control.attempts, self.stops.idx);
                    stop = stop_at!(stop_idx);
                    stop_tau = stop - t0;
                    limit!(false);
                    continue $steps;
                }
                // (a step to the stop is counted only on its way out with an error:
                // `arrive!` sets the count to zero after it)
                attempts += 1 - $pending;
                let outcome = self
                    .stepper
                    .step(&mut self.f, Step { t, x: &self.$src, h, x_new: &mut self.$dst, w: &self.control.w, adaptive: false });
                let err = match outcome {
                    Ok(Outcome::Done { err }) => err,
                    // never_retries: a retry is a method's own error
                    Ok(Outcome::Retry(why)) => {
                        attempts += $pending;
                        home!($odd);
                        sync!();
                        return Err(self.failure_error(why, h));
                    }
                    Err(e) => {
                        attempts += $pending;
                        home!($odd);
                        sync!();
                        return Err(e);
                    }
                };
                if err.is_nan() || super::has_non_finite(&self.$dst) {
                    attempts += $pending;
                    home!($odd);
                    sync!();
                    return Err(self.non_finite(h));
                }
                accepted += 1;
                self.stepper.accept();
                if let Some((to, reason)) = self.stepper.switched() {
                    self.output.switches.push(super::Switch { t: target, to, reason });
                }
                t = target;
                tau = target_tau;
            }};
        }
        // `arrive` at the stop (the state in `self.$dst`, `$odd` before the step that
        // arrived): the next stop, the inputs of the interval it opens
        // `enter_segment` with the time in a register, for stop `stop_idx − 1` passed
        // (`$rows`: the rows it may be in)
        macro_rules! enter {
            ($rows:expr) => {
                if ROWS {
                    // a new row at every stop (`segment` is written back by `sync!`)
                    // (a row is held: `run_lean_fixed` enters with one, and every
                    // arrival holds the next)
                    self.f
                        .replace_row($rows.get(stop_idx - 1).map_or(&[], |r| r.as_slice()));
                } else if let Some(c) = controls
                    && let Some(k) = c.segment_near(t, dir, self.stops.segment)
                    && Some(k) != self.stops.segment
                {
                    self.stops.segment = Some(k);
                    self.f.hold_row(c.values(k).unwrap_or_default());
                }
                self.stepper.reset();
            };
        }
        macro_rules! arrive {
            ($dst:ident, $odd:expr) => {{
                attempts = 0;
                // (`stop_idx < n_stops` known before the increment: the row index
                // `stop_idx − 1` after it is in bounds, and nothing wraps)
                let last = stop_idx >= n_stops;
                stop_idx += 1;
                if last {
                    // (after the step the state is home when it was not before)
                    home!(!$odd);
                    if stop_idx > n_all {
                        sync!();
                        self.done = true;
                        keep.keep(t, &self.x);
                        return Ok(keep);
                    }
                    // the last stop of this call, not the end: into the next interval,
                    // then back to the caller
                    enter!(all_rows);
                    sync!();
                    keep.keep(t, &self.x);
                    return Ok(keep);
                }
                enter!(rows);
                stop = stop_at!(stop_idx);
                stop_tau = stop - t0;
            }};
        }
        // one step from `self.$src` into `self.$dst` (`break $half` once it is taken,
        // `continue $steps` when a landing without a step brings the state home)
        macro_rules! half {
            ($src:ident, $dst:ident, $odd:expr, $half:lifetime, $steps:lifetime) => {{
                // `next_h` for a fixed step: the next grid point, or the stop when it is
                // no farther (always the stop for an exact flow's infinite step). A grid
                // point before the stop takes a step of its own, kept apart from the step
                // to the stop so that the usual one (a log at the step's rate or slower)
                // has its target fixed: no selects, and a grid test decided before the call.
                let mut on_grid = ONE_PER_STOP;
                if !ONE_PER_STOP {
                    let grid = super::grid_point(grid_k, signed_h);
                    // (the grid point on the stop first: one compare for a log at the step)
                    on_grid = stop_tau == grid;
                    if !on_grid {
                        if !(dir * (grid - stop_tau) >= -grid_tol) {
                            let target = t0 + grid;
                            step_to!(target, grid, $src, $dst, $odd, $steps, 0);
                            grid_k += 1;
                            // (not an arrival even when `target` rounds to `stop`:
                            // arrival is measured from t0, `grid ≠ stop_tau` here)
                            keep.keep(t, &self.$dst);
                            // the step limit, before the next step: reached only here,
                            // as every arrival sets the count to zero (max_steps ≥ 1)
                            limit!(!$odd);
                            break $half;
                        }
                        on_grid = (stop_tau - grid).abs() <= grid_tol;
                    }
                }
                step_to!(stop, stop_tau, $src, $dst, $odd, $steps, 1);
                if on_grid {
                    grid_k += 1;
                }
                arrive!($dst, $odd);
                keep.keep(t, &self.$dst);
            }};
        }
        limit!(false);
        'steps: loop {
            'even: {
                half!(x, x_new, false, 'even, 'steps);
            }
            'odd: {
                half!(x_new, x, true, 'odd, 'steps);
            }
        }
    }
}

/// Stops in a row on the grid worth the one-step-per-stop loop (and the grid loop's
/// first stretch when they are not).
const MIN_RUN: usize = 16;
/// The most stops looked at (or taken by the grid loop) at a time: a scan stays in cache
/// for the run that follows it.
const CHUNK: usize = 2048;

/// `v`, on a path the compiler is to keep out of the way.
#[cold]
#[inline(never)]
fn cold(v: f64) -> f64 {
    v
}

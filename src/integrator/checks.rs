//! What the driver checks after each accepted step: breakpoints (input switches),
//! DOPRI5's stiffness test, and event zeros.

use super::Integrator;
use crate::error::{Error, Result};
use crate::methods::{Method, Stepper};
use crate::model::System;
use crate::problem::Problem;
use crate::problem::events::{ResetFn, locate};
use crate::problem::solution::{EventHit, Stiffness, horner};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

impl<'p, D: Dim, S: System<D>, M: Method<D>> Integrator<'p, '_, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    /// At a breakpoint: switch to the inputs of the interval ahead and tell the method.
    #[inline(always)]
    pub(super) fn enter_segment(&mut self) {
        let problem: &'p _ = self.problem;
        if let Some(c) = &problem.controls
            && let Some(k) = c.segment_near(self.t, self.dir, self.stops.segment)
            && Some(k) != self.stops.segment
        {
            self.stops.segment = Some(k);
            self.f.hold_row(c.values(k).unwrap_or_default());
        }
        self.stepper.reset();
    }

    /// DOPRI5's test: `h·λ > 3.25` fifteen times without six non-stiff verdicts between.
    /// Evaluated every `every`-th accepted step, and on every step while a stiff verdict
    /// stands (dopri5.f: `MOD(NACCPT,NSTIFF).EQ.0 .OR. IASTI.GT.0`).
    #[inline(always)]
    pub(super) fn check_stiffness(&mut self, h: f64, t_new: f64) {
        // the common case in two compares: not due, no stiff verdict standing (the same
        // branch as the first return in `stiffness_test`, without reading the option)
        if self.stiff.countdown > 1 && self.stiff.count.0 == 0 {
            self.stiff.countdown -= 1;
            return;
        }
        self.stiffness_test(h, t_new);
    }

    /// The body of [`check_stiffness`](Self::check_stiffness) off its fast path.
    #[inline(never)]
    fn stiffness_test(&mut self, h: f64, t_new: f64) {
        let Some(every) = self.stiff.every else { return };
        let (stiff, nonstiff) = &mut self.stiff.count;
        self.stiff.countdown -= 1;
        if self.stiff.countdown > 0 && *stiff == 0 {
            return;
        }
        if self.stiff.countdown == 0 {
            self.stiff.countdown = every;
        }
        let Some(hl) = self.stepper.stiffness(h, &self.x_new) else {
            return;
        };
        if hl > 3.25 {
            *nonstiff = 0;
            *stiff += 1;
            if *stiff == 15 && self.stiff.verdict.is_none() {
                self.stiff.verdict = Some(Stiffness { t: t_new, h_lambda: hl });
            }
        } else {
            *nonstiff += 1;
            if *nonstiff == 6 {
                *stiff = 0;
            }
        }
    }

    /// Locate event zeros in the step just taken (dense output is on whenever there are
    /// events) and act on them in time order. A terminal one (its n-th occurrence) cuts
    /// the step short at the zero: [`EventEnd::Stopped`]; a resetting one cuts it there
    /// and puts the reset state in `x_new` (the state before it in `output.jump`):
    /// [`EventEnd::Reset`]. Either moves `t_new` to the zero; zeros after it in the same
    /// step are dropped (the solution they belonged to has changed or ended).
    pub(super) fn check_events(&mut self, h: f64, t_new: &mut f64) -> Result<EventEnd> {
        let problem: &'p Problem<'_, D, S> = self.problem;
        let events = &problem.events;
        if events.is_empty() {
            return Ok(EventEnd::Passed);
        }
        let mut found: Vec<(f64, usize, f64)> = Vec::new();
        for (i, ev) in events.iter().enumerate() {
            let g1 = (ev.g)(*t_new, &self.x_new);
            if g1.is_nan() {
                return Err(Error::EventNaN { index: i, t: *t_new });
            }
            let g0 = self.events.g_prev[i];
            if let Some(band) = self.events.held[i] {
                // held on the surface since a reset: leaving the band is not a crossing
                if g1.abs() > band {
                    self.events.held[i] = None;
                }
                self.events.g_prev[i] = g1;
                continue;
            }
            if ev.crosses(g0, g1) {
                self.ensure_dense(h)?;
                let mut te = if g1 == 0.0 {
                    *t_new
                } else {
                    locate(ev, i, &self.output.dense, self.t, h, *t_new)?
                };
                if ev.reset.is_some() {
                    te = self.before_crossing(i, g0, te, h)?;
                }
                found.push((te, i, g0));
            }
            self.events.g_prev[i] = g1;
        }
        // stable: simultaneous zeros in the order the events were given
        found.sort_by(|a, b| (self.dir * a.0).total_cmp(&(self.dir * b.0)));
        for (te, i, g_start) in found {
            let x = horner(&self.output.dense, (te - self.t) / h);
            let ev = &events[i];
            self.events.counts[i] += 1;
            let stop = ev.stop_at.is_some_and(|n| self.events.counts[i] >= n);
            // the slope before a reset (with the inputs before it), for `passed_at_reset`
            let mut f_before = None;
            let reset = match &ev.reset {
                Some(r) if !stop => {
                    let mut fx = x.clone();
                    self.f.rhs(te, &x, &mut fx)?;
                    f_before = Some(fx);
                    Some(self.apply_reset(i, r, te, &x)?)
                }
                _ => None,
            };
            self.events.hits.push(EventHit {
                index: i,
                t: te,
                x: x.clone(),
                x_after: reset.clone(),
            });
            if stop {
                *t_new = te;
                self.x_new = x;
                return Ok(EventEnd::Stopped);
            }
            if let (Some(xa), Some(f_before)) = (reset, f_before) {
                *t_new = te;
                self.x_new = xa;
                // every event's sign now, at the reset state
                for (j, e) in events.iter().enumerate() {
                    let g = (e.g)(te, &self.x_new);
                    if g.is_nan() {
                        return Err(Error::EventNaN { index: j, t: te });
                    }
                    self.events.g_prev[j] = g;
                    self.events.held[j] = None;
                }
                // the events recorded at this time, the reset's own included
                let at_te: Vec<usize> = self
                    .events
                    .hits
                    .iter()
                    .rev()
                    .take_while(|h| h.t == te)
                    .map(|h| h.index)
                    .collect();
                self.passed_at_reset(te, &at_te, &x, &f_before, g_start.abs())?;
                self.output.jump = Some(x);
                self.check_zeno(te)?;
                return Ok(EventEnd::Reset);
            }
        }
        Ok(EventEnd::Passed)
    }

    /// After a reset at `te`: an event just recorded there whose zero the motion crossed
    /// on both sides of the reset counts as passed, so that one crossing is one
    /// occurrence. The reset placed the state a few ulps before the zero; when the flow
    /// before the reset (from `x⁻` along `f⁻`) and after it (from `x⁺` along `f(te, x⁺)`)
    /// both carry `g` through it within 64 ulps of `t` (one Euler probe each), the reset
    /// left the crossing motion alone (a counter, a change of inputs that does not turn
    /// it): its next step must not find the same crossing again. A bounce turns the motion
    /// away, and a reset that turns it into the surface starts a new crossing (an event
    /// again at once, Zeno if it repeats): neither is touched. A reset that leaves `g`
    /// unchanged with the flow after it tangent to the surface (the probe does not move
    /// `g` at all: a turn onto the surface) holds the event while `|g| ≤ 1000·ε·|g₀|`
    /// (`g₀`, passed as `g_start`, its value at the start of the crossing step): rounding
    /// drift along the surface is not a second occurrence, and the first value outside
    /// that band re-arms it (a drift past the band, e.g. `v·cos(π/2 in f64)·t` growing,
    /// counts again). One `f` call per reset here, one before it.
    fn passed_at_reset(
        &mut self,
        te: f64,
        recorded: &[usize],
        x_before: &OVector<f64, D>,
        f_before: &OVector<f64, D>,
        g_start: f64,
    ) -> Result<()> {
        if recorded.is_empty() {
            return Ok(());
        }
        let events = &self.problem.events;
        let mut fx = self.x_new.clone();
        self.f.rhs(te, &self.x_new, &mut fx)?;
        let dt = self.dir * 64.0 * f64::EPSILON * te.abs().max(self.t.abs()).max(f64::MIN_POSITIVE);
        let mut after = self.x_new.clone();
        after.axpy(dt, &fx, 1.0);
        let mut before = x_before.clone();
        before.axpy(dt, f_before, 1.0);
        for &j in recorded {
            let g = &events[j].g;
            let g_minus = g(te, x_before);
            let through_before = events[j].crosses(g_minus, g(te + dt, &before));
            let g_plus = self.events.g_prev[j];
            let g_after = g(te + dt, &after);
            if events[j].crosses(g_plus, g_after) {
                if through_before {
                    self.events.g_prev[j] = g_after;
                }
            } else if g_after == g_plus && g_plus == g_minus {
                // the reset left `g` where it was, at the surface, and the flow after it
                // runs along the surface to rounding (a turn onto it): held until `g`
                // leaves the rounding band of the approach, so drift along the surface is
                // not a second occurrence
                self.events.held[j] = Some(1e3 * f64::EPSILON * g_start.max(g_minus.abs()));
            }
        }
        Ok(())
    }

    /// The reset of event `index` at `(te, x)`: the new state, checked, and the held
    /// inputs as the map left them.
    fn apply_reset(
        &mut self,
        index: usize,
        r: &ResetFn<'_, D>,
        te: f64,
        x: &OVector<f64, D>,
    ) -> Result<OVector<f64, D>> {
        let mut u = self.f.u.to_vec();
        let xa = r(te, x, &mut u);
        let fail = |reason: String| Error::EventReset { index, t: te, reason };
        if xa.len() != x.len() {
            return Err(fail(format!(
                "returned {} components for a state of {}",
                xa.len(),
                x.len()
            )));
        }
        if let Some(k) = xa.iter().position(|v| !v.is_finite()) {
            return Err(fail(format!("component {k} of the new state is {}", xa[k])));
        }
        if let Some(k) = u.iter().position(|v| !v.is_finite()) {
            return Err(fail(format!("held input {k} set to {}", u[k])));
        }
        if u[..] != self.f.u[..] {
            self.f.hold(&u);
        }
        Ok(xa)
    }

    /// A zero `te` of event `index` (whose value was `g0` at the step start), moved
    /// to the side where `g` has not crossed yet: a few ulps back when the root finder
    /// returned a point just past it, by bisection on `[t, te]` otherwise. A reset there
    /// starts from a state from which `g` can cross again (a bounce from `x = +10⁻¹⁷`,
    /// not from `−10⁻¹⁷`, whose next descent would never cross zero).
    fn before_crossing(&self, index: usize, g0: f64, te: f64, h: f64) -> Result<f64> {
        let ev = &self.problem.events[index];
        let crossed = |t: f64| -> Result<bool> {
            let g = (ev.g)(t, &horner(&self.output.dense, (t - self.t) / h));
            if g.is_nan() {
                return Err(Error::EventNaN { index, t });
            }
            Ok(ev.crosses(g0, g))
        };
        let back = |t: f64| if self.dir > 0.0 { t.next_down() } else { t.next_up() };
        let mut t = te;
        for _ in 0..8 {
            if !crossed(t)? || t == self.t {
                return Ok(t);
            }
            t = back(t);
        }
        // bisection: `lo` not crossed (the step start), `hi` crossed
        let (mut lo, mut hi) = (self.t, t);
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            if mid == lo || mid == hi {
                break;
            }
            if crossed(mid)? {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Ok(lo)
    }

    /// After a reset at `te`: [`Error::Zeno`] when the last `ZenoLimit::count` resets
    /// fall within the window.
    fn check_zeno(&mut self, te: f64) -> Result<()> {
        let limit = self.events.zeno;
        let window = self.zeno_window(te);
        let r = &mut self.events.resets;
        r.push_back(te);
        if r.len() > limit.count {
            r.pop_front();
        }
        match r.front() {
            Some(&first) if r.len() == limit.count && (te - first).abs() <= window => Err(Error::Zeno {
                t: te,
                count: limit.count,
                window,
            }),
            _ => Ok(()),
        }
    }

    /// `ZenoLimit::window` in time at `t`.
    fn zeno_window(&self, t: f64) -> f64 {
        let (t0, t_end) = (self.problem.t0, self.problem.t_end);
        let span = if t_end.is_finite() {
            (t_end - t0).abs()
        } else {
            (t - t0).abs().max(1.0)
        };
        self.events.zeno.window * span
    }

    /// The step size underflowed: right after a run of at least three resets (the next
    /// occurrence is closer than `t` resolves) that is a Zeno execution.
    pub(super) fn zeno_underflow(&self) -> Option<Error> {
        let r = &self.events.resets;
        match (r.front(), r.back()) {
            (Some(&first), Some(&last)) if r.len() >= 3 && last == self.t => Some(Error::Zeno {
                t: last,
                count: r.len(),
                window: (last - first).abs(),
            }),
            _ => None,
        }
    }
}

/// What the events of a step did to it ([`Integrator::check_events`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum EventEnd {
    /// Nothing: every zero in it was recorded and passed.
    Passed,
    /// A terminal event ended the run.
    Stopped,
    /// A reset replaced the state at the step's (new) end.
    Reset,
}

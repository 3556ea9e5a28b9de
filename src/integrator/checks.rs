//! What the driver checks after each accepted step: breakpoints (input switches),
//! DOPRI5's stiffness test, and event zeros.

use super::Integrator;
use crate::error::Result;
use crate::methods::{Method, Stepper};
use crate::model::System;
use crate::problem::events::locate;
use crate::problem::solution::{EventHit, Stiffness, horner};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim};

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
    /// events); `true` if a terminal one cut it short (then `t_new` and `x_new` are moved
    /// to the event).
    pub(super) fn check_events(&mut self, h: f64, t_new: &mut f64) -> Result<bool> {
        let events = &self.problem.events;
        if events.is_empty() {
            return Ok(false);
        }
        let mut found: Vec<(f64, usize)> = Vec::new();
        for (i, ev) in events.iter().enumerate() {
            let g1 = (ev.g)(*t_new, &self.x_new);
            if g1.is_nan() {
                return Err(crate::Error::EventNaN { index: i, t: *t_new });
            }
            if ev.crosses(self.events.g_prev[i], g1) {
                let te = if g1 == 0.0 {
                    *t_new
                } else {
                    locate(ev, i, &self.output.dense, self.t, h, *t_new)?
                };
                found.push((te, i));
            }
            self.events.g_prev[i] = g1;
        }
        found.sort_by(|a, b| (self.dir * a.0).total_cmp(&(self.dir * b.0)));
        for (te, i) in found {
            let x = horner(&self.output.dense, (te - self.t) / h);
            self.events.hits.push(EventHit {
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
}

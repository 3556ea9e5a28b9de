//! The lean path of [`Integrator::solve`]: an adaptive run with nothing to stop for but
//! `t_end` (no breakpoints, control times, events or dense output) needs none of the
//! general step's bookkeeping. It takes exactly the steps [`Integrator::step`] would take,
//! bit for bit (the shared pieces — rejection, retry, step-size proposal, checks — are
//! the same functions), with the loop reduced to what a hand-written one does.

use super::Integrator;
use crate::error::{Error, Result};
use crate::methods::{Method, Outcome};
use crate::system::System;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim};

impl<D: Dim, S: System<D>, M: Method<D>> Integrator<'_, '_, D, S, M>
where
    DefaultAllocator: Allocator<D>,
{
    /// Whether [`run_lean`](Self::run_lean) applies.
    pub(super) fn is_lean(&self) -> bool {
        self.adaptive
            && !self.done
            && !self.keep_dense
            && self.problem.events.is_empty()
            && self.until.is_none()
            && self.stop_idx == self.stops.len()
            && self.t_end.is_finite()
    }

    /// Step to `t_end`, pushing every accepted step; the state afterwards is what the
    /// same steps through [`step`](Self::step) leave. The loop keeps the step size,
    /// time, counters and rejection flag in locals (registers, across the model calls)
    /// and writes them back before every exit and every call that reads them.
    pub(super) fn run_lean(&mut self, mut keep: impl FnMut(f64, &nalgebra::OVector<f64, D>)) -> Result<()> {
        let t0 = self.problem.t0;
        let t_end = self.t_end;
        let end_tau = t_end - t0;
        let (dir, h_max, max_steps) = (self.dir, self.h_max, self.max_steps);
        let (mut h_abs, mut tau, mut t) = (self.h.abs(), self.tau, self.t);
        let (mut attempts, mut last_rejected) = (self.attempts, self.last_rejected);
        let (mut accepted, mut rejected) = (0u64, 0u64);
        let mut failures = 0;
        // the smallest step `t − t0 = tau` still resolves: 10 ulp of tau
        let mut tiny = 10.0 * f64::EPSILON * tau.abs();
        macro_rules! sync {
            () => {
                self.h = h_abs;
                self.tau = tau;
                self.t = t;
                self.attempts = attempts;
                self.last_rejected = last_rejected;
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
            let outcome = self
                .method
                .step(&mut self.f, t, &self.x, h, &mut self.x_new, &self.w, true)?;
            let err = match outcome {
                Outcome::Retry(why) => {
                    sync!();
                    (accepted, rejected) = (0, 0);
                    self.retry(why, h, &mut failures)?;
                    (h_abs, last_rejected) = (self.h.abs(), self.last_rejected);
                    continue;
                }
                Outcome::Done { err } => err,
            };
            if err.is_nan() || self.x_new.iter().fold(0.0, |a, v| a + v * 0.0).is_nan() {
                sync!();
                return Err(self.non_finite(h));
            }
            if err > 1.0 {
                rejected += 1;
                h_abs = ha * self.reject_factor(err);
                last_rejected = true;
                continue;
            }
            failures = 0;
            accepted += 1;
            let (t_new, tau_new) = if last {
                (t_end, end_tau)
            } else {
                (t0 + (tau + h), tau + h)
            };
            self.check_stiffness(h, t_new);
            self.method.accept();
            if let Some(to) = self.method.switched() {
                self.switches.push(super::Switch { t: t_new, to });
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

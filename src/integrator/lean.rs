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
use nalgebra::{DefaultAllocator, Dim, OVector};

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
            && self.stop_idx + 1 == self.stops.len()
            && self.stops[self.stop_idx].is_finite()
    }

    /// Step to `t_end`, pushing every accepted step; the state afterwards is what the
    /// same steps through [`step`](Self::step) leave.
    pub(super) fn run_lean(&mut self, ts: &mut Vec<f64>, xs: &mut Vec<OVector<f64, D>>) -> Result<()> {
        let t0 = self.problem.t0;
        let t_end = self.stops[self.stop_idx];
        let end_tau = t_end - t0;
        let dir = self.dir;
        let mut failures = 0;
        loop {
            if self.attempts >= self.max_steps {
                return Err(Error::MaxSteps {
                    t: self.t,
                    steps: self.attempts,
                });
            }
            let mut h = dir * self.h.abs().min(self.h_max);
            let last = dir * (self.tau + 1.01 * h - end_tau) >= 0.0;
            if last {
                h = end_tau - self.tau;
                if h == 0.0 {
                    self.land_without_step(t_end);
                    ts.push(self.t);
                    xs.push(self.x.clone());
                    return Ok(());
                }
            }
            let resolvable = last || h.abs() > 10.0 * f64::EPSILON * self.tau.abs();
            if !(resolvable && h.abs() > 0.0 && h.abs() < f64::INFINITY) {
                return Err(self.underflow(h, failures));
            }
            self.attempts += 1;
            let outcome = self
                .method
                .step(&mut self.f, self.t, &self.x, h, &mut self.x_new, &self.w, true)?;
            let err = match outcome {
                Outcome::Retry(why) => {
                    self.retry(why, h, &mut failures)?;
                    continue;
                }
                Outcome::Done { err } => err,
            };
            if err.is_nan() || self.x_new.iter().fold(0.0, |a, v| a + v * 0.0).is_nan() {
                return Err(self.non_finite(h));
            }
            if err > 1.0 {
                self.reject(h, err);
                continue;
            }
            failures = 0;
            self.f.stats.accepted += 1;
            let (t_new, tau_new) = if last {
                (t_end, end_tau)
            } else {
                (t0 + (self.tau + h), self.tau + h)
            };
            self.check_stiffness(h, t_new);
            self.method.accept();
            if let Some(to) = self.method.switched() {
                self.switches.push(super::Switch { t: t_new, to });
            }
            std::mem::swap(&mut self.x, &mut self.x_new);
            self.t = t_new;
            self.tau = tau_new;
            self.propose(h, err, last);
            ts.push(t_new);
            xs.push(self.x.clone());
            if last {
                self.arrive(Some(t_end));
                return Ok(());
            }
        }
    }
}

//! The driver's output part: the dense polynomial of the step just taken (kept for
//! events, output times and [`Options::dense`]), what [`Save`] asks to keep, the last
//! step and the method switches.

use super::brief;
use super::save;
use crate::error::{Error, Result};
use crate::problem::Problem;
use crate::problem::options::{Options, Save};
use crate::problem::solution::Switch;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// What the run keeps.
pub(super) struct Output<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Whether a step's dense polynomial may be read (events, output times, `dense`).
    pub(super) keep_dense: bool,
    /// Whether `dense` holds the polynomial of the step being accepted: it is computed
    /// when something reads it (an output time inside the step, a crossing, `dense`),
    /// not at every step.
    pub(super) dense_fresh: bool,
    /// The first output time the solution has not saved yet ([`Save::At`]), set by
    /// [`solve`](super::Integrator::solve) before each step.
    pub(super) next_time: Option<f64>,
    /// Whether [`solve`](super::Integrator::solve) stores the dense segments
    /// (`Options::dense` only).
    pub(super) store_dense: bool,
    pub(super) save: Save,
    /// The dense polynomial's coefficients of the step just taken.
    pub(super) dense: Vec<OVector<f64, D>>,
    /// `(t, h, t + h)` of the last accepted step.
    pub(super) last_step: (f64, f64, f64),
    pub(super) switches: Vec<Switch>,
    /// The state just before a reset that ended the last step (its dense polynomial ends
    /// there; the integrator's state is the one after).
    pub(super) jump: Option<OVector<f64, D>>,
}

impl<D: Dim> Output<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// For a run of `problem` in direction `dir` with a method whose dense polynomial has
    /// `dense_len` coefficients; output times outside the span or out of order are
    /// [`Error::InvalidInput`].
    pub(super) fn new<S>(
        opts: &Options,
        problem: &Problem<'_, D, S>,
        x0: &OVector<f64, D>,
        dir: f64,
        dense_len: usize,
    ) -> Result<Self> {
        let (t0, t_end) = (problem.t0, problem.t_end);
        if let Save::At(ts) = &opts.save {
            let inside = |t: f64| dir * (t - t0) >= 0.0 && dir * (t_end - t) >= 0.0;
            if let Some(t) = ts.iter().find(|t| !inside(**t)) {
                return Err(Error::invalid(
                    "save",
                    format!(
                        "output time {} is outside the span ({}, {})",
                        brief(*t),
                        brief(t0),
                        brief(t_end)
                    ),
                ));
            }
            if let Some(w) = ts.windows(2).find(|w| dir * (w[1] - w[0]) <= 0.0) {
                return Err(Error::invalid(
                    "save",
                    format!(
                        "output times must run in the direction of integration: {} then {}",
                        brief(w[0]),
                        brief(w[1])
                    ),
                ));
            }
        }
        let at_times = save::needs_dense(&opts.save);
        let keep_dense = opts.dense || !problem.events.is_empty() || at_times;
        Ok(Output {
            keep_dense,
            dense_fresh: false,
            next_time: None,
            // the polynomials are computed for events and output times, but kept in the
            // solution only when asked (`Options::dense`)
            store_dense: opts.dense,
            save: opts.save.clone(),
            dense: if keep_dense {
                vec![x0.clone(); dense_len]
            } else {
                Vec::new()
            },
            last_step: (t0, 0.0, t0),
            switches: Vec::new(),
            jump: None,
        })
    }
}

//! The driver's events part: each event function's value at the last accepted state
//! (a sign change over a step is an occurrence, located on the dense output by
//! `Integrator::check_events`), and the occurrences found.

use crate::error::{Error, Result};
use crate::problem::Problem;
use crate::problem::options::ZenoLimit;
use crate::problem::solution::EventHit;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Event values and occurrences.
pub(super) struct EventWatch<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// `g_i(t, x)` at the last accepted state.
    pub(super) g_prev: Vec<f64>,
    /// `Some(b)` while event `i` is held after a reset that left the state on its surface
    /// moving along it: no crossing is looked for while `|g_i| ≤ b` (rounding drift along
    /// the surface is not a new occurrence); the first value outside re-arms it.
    pub(super) held: Vec<Option<f64>>,
    pub(super) hits: Vec<EventHit<D>>,
    /// Occurrences of each event so far (for `terminal_after`).
    pub(super) counts: Vec<u64>,
    /// Times of the latest resets, at most `ZenoLimit::count` of them.
    pub(super) resets: std::collections::VecDeque<f64>,
    pub(super) zeno: ZenoLimit,
}

impl<D: Dim> EventWatch<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// The events' values at `(t0, x0)`; a NaN one is [`Error::EventNaN`].
    pub(super) fn new<S>(problem: &Problem<'_, D, S>, zeno: ZenoLimit, t0: f64, x0: &OVector<f64, D>) -> Result<Self> {
        let mut g_prev = Vec::with_capacity(problem.events.len());
        for (index, e) in problem.events.iter().enumerate() {
            let g = (e.g)(t0, x0);
            if g.is_nan() {
                return Err(Error::EventNaN { index, t: t0 });
            }
            g_prev.push(g);
        }
        Ok(EventWatch {
            counts: vec![0; g_prev.len()],
            held: vec![None; g_prev.len()],
            g_prev,
            hits: Vec::new(),
            resets: std::collections::VecDeque::new(),
            zeno,
        })
    }
}

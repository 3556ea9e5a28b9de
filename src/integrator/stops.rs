//! The driver's stops part: the times no step may cross (breakpoints, a control log's
//! times, `t_end`, a caller's temporary stop), the fixed-step grid `t0 + k·h` between
//! them, and the control interval whose inputs are held.

use super::{check_inputs, grid_tol};
use crate::error::{Error, Result};
use crate::problem::Problem;
use crate::problem::options::Options;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim};
use std::borrow::Cow;

/// Stops and grid.
pub(super) struct Stops<'p> {
    /// Breakpoints strictly inside the span, in the direction of travel; `t_end` is the
    /// stop after the last of them (kept apart so that a plain run allocates nothing here);
    /// a control log's own times, borrowed, when nothing else is merged in.
    pub(super) list: Cow<'p, [f64]>,
    /// `Some(lo)` when `list` is the control times `lo..` (so stop `i` opens interval
    /// `lo + i`).
    pub(super) from: Option<usize>,
    pub(super) t_end: f64,
    /// The next stop in `list`.
    pub(super) idx: usize,
    /// A caller's temporary stop (`Integrator::step_until`).
    pub(super) until: Option<f64>,
    /// The fixed step (NaN on adaptive runs; `h_max` for an exact flow's steps).
    pub(super) fixed_h: f64,
    /// How near a grid point a stop counts as on it ([`grid_tol`]).
    pub(super) grid_tol: f64,
    /// Grid points since the last stop.
    pub(super) grid_k: u64,
    /// A shortened step that lands on a stop between grid points.
    pub(super) sub_h: Option<f64>,
    /// The control interval whose inputs are held (a control log's row).
    pub(super) segment: Option<usize>,
}

impl<'p> Stops<'p> {
    /// For a run of `problem` in direction `dir`, starting in control interval
    /// `segment`, with fixed step `fixed_h` (NaN when adaptive).
    pub(super) fn new<D: Dim, S>(
        problem: &'p Problem<'_, D, S>,
        opts: &Options,
        dir: f64,
        segment: Option<usize>,
        fixed_h: f64,
    ) -> Self
    where
        DefaultAllocator: Allocator<D>,
    {
        let (t0, t_end) = (problem.t0, problem.t_end);
        // breakpoints strictly inside the span, in the direction of travel (then t_end)
        let inside = |b: f64| dir * (b - t0) > 0.0 && dir * (t_end - b) > 0.0;
        let mut stops: Vec<f64> = opts.breakpoints.iter().copied().filter(|&b| inside(b)).collect();
        let mut from = None;
        let list: Cow<'p, [f64]> = match &problem.controls {
            // forwards with no breakpoints of its own, the stops are the control times
            // inside the span: strictly increasing, and (b − t0 and t_end − b being
            // monotone in b) one contiguous run of them, so a long log is borrowed
            Some(c) if stops.is_empty() && dir > 0.0 => {
                let times = c.times();
                let lo = times.partition_point(|&b| b - t0 <= 0.0);
                let hi = times.partition_point(|&b| t_end - b > 0.0).max(lo);
                from = Some(lo);
                Cow::Borrowed(&times[lo..hi])
            }
            controls => {
                if let Some(c) = controls {
                    stops.extend(c.times().iter().copied().filter(|&b| inside(b)));
                }
                // (a control log's times are sorted already: a long log skips the sort)
                if !stops.is_sorted_by(|a, b| dir * a < dir * b) {
                    stops.sort_by(|a, b| (dir * a).total_cmp(&(dir * b)));
                }
                stops.dedup();
                Cow::Owned(stops)
            }
        };
        Stops {
            list,
            from,
            t_end,
            idx: 0,
            until: None,
            fixed_h,
            grid_tol: grid_tol(fixed_h, t0, t_end),
            grid_k: 0,
            sub_h: None,
            segment,
        }
    }
}

/// The inputs held at the start of a run of `problem` in direction `dir`: the caller's
/// values, or the row of the control interval `t0` is in (borrowed, with its index).
/// Inputs of the wrong width, non-finite ones, both kinds at once, or none for a model
/// that reads some are [`Error::InvalidInput`].
pub(super) fn held_at_start<'p, D: Dim, S: crate::model::System<D>>(
    problem: &'p Problem<'_, D, S>,
    dir: f64,
) -> Result<(Option<usize>, Cow<'p, [f64]>)>
where
    DefaultAllocator: Allocator<D>,
{
    let t0 = problem.t0;
    let n_in = problem.system.inputs();
    Ok(match &problem.controls {
        None if problem.held.is_some() => {
            let u = problem.held.clone().unwrap_or_default();
            check_inputs(&u, n_in)?;
            (None, u.into())
        }
        None if n_in > 0 => {
            return Err(Error::invalid(
                "controls",
                format!("the model reads {n_in} inputs but no controls were given"),
            ));
        }
        None => (None, Vec::new().into()),
        Some(_) if problem.held.is_some() => {
            return Err(Error::invalid(
                "controls",
                "both a control schedule and held inputs were given",
            ));
        }
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
            // (the row borrowed, as at every breakpoint after)
            (Some(k), Cow::Borrowed(c.values(k).unwrap_or_default()))
        }
    })
}

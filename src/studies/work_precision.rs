//! Work–precision: error against rhs evaluations and wall time over a tolerance sweep.

use super::{MethodKind, solve_with};
use crate::error::{Error, Result};
use crate::linalg::LuDim;
use crate::methods::Flow;
use crate::{Options, Problem, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};
use std::time::Instant;

/// One point of a work–precision diagram.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WorkPoint {
    /// Method.
    pub method: MethodKind,
    /// Tolerance (adaptive methods: rtol = atol) or step size (fixed-step methods).
    pub setting: f64,
    /// Max-norm error at the final time against the reference.
    pub error: f64,
    /// rhs evaluations.
    pub rhs_evals: u64,
    /// Accepted steps.
    pub steps: u64,
    /// Best wall time over the repetitions (s).
    pub seconds: f64,
}

/// For each method and each setting, solve `runs` times (timing the fastest) and
/// measure the final error against `reference`. Adaptive methods (rk45, implicit Euler)
/// take `tolerances` as rtol = atol; explicit Euler takes `steps` as fixed steps.
pub fn work_precision<D: LuDim, S: System<D>>(
    problem: &Problem<'_, D, S>,
    methods: &[MethodKind],
    tolerances: &[f64],
    steps: &[f64],
    reference: &OVector<f64, D>,
    flow: Option<&dyn Flow<D>>,
    runs: usize,
) -> Result<Vec<WorkPoint>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    if tolerances.is_empty() {
        return Err(Error::invalid("tolerances", "the tolerance list is empty"));
    }
    let mut out = Vec::new();
    for &m in methods {
        let settings: Vec<(f64, Options)> = match m {
            MethodKind::Euler => steps
                .iter()
                .map(|&h| (h, Options::default().fixed(h).dense(false)))
                .collect(),
            _ => tolerances
                .iter()
                .map(|&tol| {
                    (
                        tol,
                        Options::default()
                            .rtol(tol)
                            .atol(tol)
                            .dense(false)
                            .max_steps(10_000_000),
                    )
                })
                .collect(),
        };
        for (setting, opts) in settings {
            let mut best = f64::INFINITY;
            let mut last = None;
            for _ in 0..runs.max(1) {
                let start = Instant::now();
                let sol = solve_with(problem, m, &opts, flow)?;
                best = best.min(start.elapsed().as_secs_f64());
                last = Some(sol);
            }
            let Some(sol) = last else { continue };
            out.push(WorkPoint {
                method: m,
                setting,
                error: (sol.last().1 - reference).amax(),
                rhs_evals: sol.stats.rhs_evals,
                steps: sol.stats.accepted,
                seconds: best,
            });
        }
    }
    Ok(out)
}

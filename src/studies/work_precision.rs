//! Work–precision: error against rhs evaluations and wall time over a tolerance sweep.

use super::convergence::{DEFAULT_MAX_STEPS, steps_needed};
use super::{MethodKind, drive};
use crate::error::{Error, Result};
use crate::linalg::LuDim;
use crate::model::Flow;
use crate::{Options, Problem, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};
use std::time::Instant;

/// One point of a work–precision diagram.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct WorkPoint {
    /// Method.
    pub method: MethodKind,
    /// Tolerance (adaptive methods: rtol, with atol = rtol unless the study scales it)
    /// or step size (fixed-step methods).
    pub setting: f64,
    /// Max-norm error at the final time against the reference.
    pub error: f64,
    /// Correct digits at the final time, the Test Set's mixed significant digits
    /// `mescd = −log10 max_i |y_i − r_i| / (atol/rtol + |r_i|)` with the study's atol/rtol
    /// ratio: relative digits where `|r_i|` is above atol/rtol, absolute below
    /// (`+∞` for an exact end state).
    pub digits: f64,
    /// rhs evaluations.
    pub rhs_evals: u64,
    /// Accepted steps.
    pub steps: u64,
    /// Best wall time over the repetitions (s).
    pub seconds: f64,
}

/// For each method and each setting, solve `runs` times (timing the fastest) and
/// measure the final error against `reference`. Adaptive methods (rk45, implicit Euler)
/// take `tolerances` as rtol = atol; explicit Euler takes `steps` as fixed steps. Only
/// the final state is kept (memory is constant); a run stops at
/// [`DEFAULT_MAX_STEPS`] steps, and a fixed step that would need more is refused.
///
/// ```
/// use reckon::studies::{work_precision::work_precision, MethodKind};
/// use reckon::{model, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// let reference = vector![(-1.0f64).exp()];
/// let w = work_precision(&p, &[MethodKind::Euler], &[1e-6], &[0.01, 0.001], &reference, None, 1).unwrap();
/// assert!(w[1].error < w[0].error / 9.0 && w[1].steps == 1000);
/// // digits: −log10(error / (1 + e⁻¹)), the error relative to atol/rtol + |reference|
/// let d = -(w[1].error / (1.0 + (-1.0f64).exp())).log10();
/// assert!((w[1].digits - d).abs() < 1e-12 && w[1].digits > 3.0);
/// assert!(work_precision(&p, &[MethodKind::Euler], &[1e-6], &[1e-12], &reference, None, 1).is_err());
/// ```
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
    work_precision_scaled(problem, methods, tolerances, steps, reference, flow, runs, 1.0)
}

/// [`work_precision`] with `atol = atol_over_rtol · rtol` for the adaptive methods (the
/// Test Set's convention for ROBER is `1e-4`: its y₂ stays near 1e-5…1e-13, and an
/// absolute tolerance above that lets it go negative and the solution blow up).
#[allow(clippy::too_many_arguments)]
pub fn work_precision_scaled<D: LuDim, S: System<D>>(
    problem: &Problem<'_, D, S>,
    methods: &[MethodKind],
    tolerances: &[f64],
    steps: &[f64],
    reference: &OVector<f64, D>,
    flow: Option<&dyn Flow<D>>,
    runs: usize,
    atol_over_rtol: f64,
) -> Result<Vec<WorkPoint>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    if tolerances.is_empty() {
        return Err(Error::invalid("tolerances", "the tolerance list is empty"));
    }
    if let Some(h) = steps.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
        return Err(Error::invalid("steps", format!("must be positive and finite, got {h}")));
    }
    if methods.contains(&MethodKind::Euler) {
        for &h in steps {
            let n = steps_needed(problem, h);
            if n > DEFAULT_MAX_STEPS as f64 {
                return Err(Error::invalid(
                    "steps",
                    format!("h = {h:e} needs {n:.3e} steps, more than the cap of {DEFAULT_MAX_STEPS} steps"),
                ));
            }
        }
    }
    let mut out = Vec::new();
    for &m in methods {
        let settings: Vec<(f64, Options)> = match m {
            MethodKind::Euler => steps
                .iter()
                .map(|&h| {
                    let limit = (2.0 * steps_needed(problem, h) + 64.0) as usize;
                    (h, Options::default().fixed(h).dense(false).max_steps(limit))
                })
                .collect(),
            _ => tolerances
                .iter()
                .map(|&tol| {
                    (
                        tol,
                        Options::default()
                            .rtol(tol)
                            .atol(tol * atol_over_rtol)
                            .dense(false)
                            .max_steps(DEFAULT_MAX_STEPS as usize),
                    )
                })
                .collect(),
        };
        for (setting, opts) in settings {
            let mut best = f64::INFINITY;
            let mut last = None;
            for _ in 0..runs.max(1) {
                let start = Instant::now();
                let (end, stats) = drive(problem, m, &opts, flow, &mut |_, _| {})?;
                best = best.min(start.elapsed().as_secs_f64());
                last = Some((end, stats));
            }
            let Some((end, stats)) = last else { continue };
            let digits = -(end.iter().zip(reference.iter()))
                .map(|(y, r)| (y - r).abs() / (atol_over_rtol + r.abs()))
                .fold(0.0, f64::max)
                .log10();
            out.push(WorkPoint {
                method: m,
                setting,
                digits,
                error: (end - reference).amax(),
                rhs_evals: stats.rhs_evals,
                steps: stats.accepted,
                seconds: best,
            });
        }
    }
    Ok(out)
}

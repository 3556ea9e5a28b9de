//! Observed order of convergence over a sequence of fixed step sizes.

use super::{MethodKind, drive, fit_order};
use crate::error::{Error, Result};
use crate::linalg::LuDim;
use crate::model::Flow;
use crate::{Options, Problem, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// One run of a convergence study.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ConvergenceRow {
    /// Method.
    pub method: MethodKind,
    /// Fixed step size.
    pub h: f64,
    /// Accepted steps.
    pub steps: u64,
    /// rhs evaluations.
    pub rhs_evals: u64,
    /// Max-norm error at the final time.
    pub final_error: f64,
    /// Max over the grid of the max-norm error.
    pub max_error: f64,
}

/// The least-squares order of one method, or why there is none.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ConvergenceFit {
    /// Method.
    pub method: MethodKind,
    /// Order fitted to the final-time errors (`None` when they are not in the
    /// asymptotic range, or for the exact flow).
    pub order_final: Option<f64>,
    /// Order fitted to the max-over-grid errors (`None` likewise).
    pub order_max: Option<f64>,
    /// The classical order.
    pub theory: Option<f64>,
    /// Whether both error series are in the asymptotic range: strictly decreasing as
    /// `h` decreases, finite, and below a tenth of the solution's size.
    pub asymptotic: bool,
    /// Why a series is not asymptotic (`None` when it is).
    pub reason: Option<String>,
}

/// Table and fitted orders.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Convergence {
    /// Every run.
    pub rows: Vec<ConvergenceRow>,
    /// One fit per method.
    pub fits: Vec<ConvergenceFit>,
}

/// The default cap on the steps of one fixed-step run (`reckon convergence --max-steps`).
pub const DEFAULT_MAX_STEPS: u64 = 10_000_000;

/// Errors at or above this fraction of the solution's size are not asymptotic.
pub const ASYMPTOTIC_FRACTION: f64 = 0.1;

/// Steps a fixed step `h` takes over `problem`'s span, at most: `⌈|t_end − t0|/h⌉` plus
/// one per control time (a step is cut short to land on each breakpoint).
///
/// ```
/// use reckon::studies::convergence::steps_needed;
/// use reckon::{model, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 5.0));
/// assert_eq!(steps_needed(&p, 1e-9), 5e9);
/// ```
pub fn steps_needed<D: Dim, S>(problem: &Problem<'_, D, S>, h: f64) -> f64
where
    DefaultAllocator: Allocator<D>,
{
    let inside = problem.controls.as_ref().map_or(0, |c| c.times().len());
    ((problem.t_end - problem.t0).abs() / h).ceil() + inside as f64
}

/// Check a convergence study before any run: at least two steps, each positive and
/// finite, at least one method, an exact flow for `Exact`, and no step that would take
/// more than `max_steps` steps over the span. Returns the typed refusal.
///
/// ```
/// use reckon::studies::{convergence::check, MethodKind};
/// use reckon::{model, Error, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 5.0));
/// assert!(check(&p, &[MethodKind::Euler], &[0.1, 0.05], false, 1000).is_ok());
/// let e = check(&p, &[MethodKind::Euler], &[1e-9, 5e-10], false, 10_000_000).unwrap_err();
/// assert!(matches!(e, Error::InvalidInput { what: "steps", .. }));
/// assert!(check(&p, &[MethodKind::Euler], &[0.1], false, 1000).is_err());
/// ```
pub fn check<D: Dim, S>(
    problem: &Problem<'_, D, S>,
    methods: &[MethodKind],
    steps: &[f64],
    has_flow: bool,
    max_steps: u64,
) -> Result<()>
where
    DefaultAllocator: Allocator<D>,
{
    if steps.len() < 2 {
        return Err(Error::invalid(
            "steps",
            format!(
                "at least two step sizes are needed to fit an order, got {}",
                steps.len()
            ),
        ));
    }
    if let Some(h) = steps.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
        return Err(Error::invalid("steps", format!("must be positive and finite, got {h}")));
    }
    if methods.is_empty() {
        return Err(Error::invalid("methods", "no method given"));
    }
    if !has_flow && methods.contains(&MethodKind::Exact) {
        return Err(Error::invalid("method", "this problem has no exact flow"));
    }
    if let Some(m) = methods.iter().find(|m| !m.fixed_step_order()) {
        return Err(Error::invalid(
            "method",
            format!(
                "{} changes its order (or its method) as it goes, so a fixed-step order fit means nothing: study it with `reckon work-precision`",
                m.name()
            ),
        ));
    }
    for &h in steps {
        let n = steps_needed(problem, h);
        if n > max_steps as f64 {
            return Err(Error::invalid(
                "steps",
                format!(
                    "h = {h:e} needs {n:.3e} steps over [{}, {}], more than the cap of {max_steps} steps (max_steps)",
                    problem.t0, problem.t_end
                ),
            ));
        }
    }
    Ok(())
}

/// Whether an error series is in the asymptotic range (see [`ConvergenceFit::asymptotic`]):
/// `Err` says why not.
fn asymptotic(steps: &[f64], errors: &[f64], size: f64) -> std::result::Result<(), String> {
    if let Some(e) = errors.iter().find(|e| !e.is_finite()) {
        return Err(format!("an error is {e}"));
    }
    let mut pairs: Vec<(f64, f64)> = steps.iter().copied().zip(errors.iter().copied()).collect();
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
    if let Some(w) = pairs.windows(2).find(|w| w[1].1 >= w[0].1) {
        return Err(format!(
            "errors do not decrease with h ({:.3e} at h = {:e}, {:.3e} at h = {:e})",
            w[0].1, w[0].0, w[1].1, w[1].0
        ));
    }
    let worst = pairs[0].1;
    if worst.partial_cmp(&(ASYMPTOTIC_FRACTION * size)) != Some(std::cmp::Ordering::Less) {
        return Err(format!(
            "errors up to {worst:.3e} are of the size of the solution ({size:.3e})"
        ));
    }
    Ok(())
}

/// Integrate `problem` with each method at each fixed step `h`, measure the error
/// against `exact(t)` at the final time and at every grid point (on the fly: no step is
/// stored, so memory is constant), and fit the order by least squares on log–log when
/// the errors are in the asymptotic range. A step that would take more than `max_steps`
/// steps is refused before any run ([`check`]).
///
/// ```
/// use reckon::studies::{convergence::convergence, MethodKind};
/// use reckon::{model, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// let study = convergence(&p, &[MethodKind::Euler], &[0.1, 0.05, 0.025, 0.0125], &|t| vector![(-t).exp()], None, 1000).unwrap();
/// assert!(study.fits[0].asymptotic);
/// assert!((study.fits[0].order_final.unwrap() - 1.0).abs() < 0.1);
/// ```
pub fn convergence<D: LuDim, S: System<D>>(
    problem: &Problem<'_, D, S>,
    methods: &[MethodKind],
    steps: &[f64],
    exact: &dyn Fn(f64) -> OVector<f64, D>,
    flow: Option<&dyn Flow<D>>,
    max_steps: u64,
) -> Result<Convergence>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    check(problem, methods, steps, flow.is_some(), max_steps)?;
    let mut rows = Vec::new();
    let mut fits = Vec::new();
    for &m in methods {
        let mut fin = Vec::new();
        let mut max = Vec::new();
        let mut size = 0.0f64;
        for &h in steps {
            // room for the steps an implicit solve halves, never unbounded
            let limit = (2.0 * steps_needed(problem, h) + 64.0).min(usize::MAX as f64) as usize;
            let opts = Options::default()
                .fixed(h)
                .rtol(1e-12)
                .atol(1e-14)
                .dense(false)
                .max_steps(limit);
            let (mut max_error, mut end) = (0.0f64, (problem.t0, 0.0f64));
            let (_, stats) = drive(problem, m, &opts, flow, &mut |t, x| {
                let xe = exact(t);
                let e = (x - &xe).amax();
                // NaN propagates: a non-finite error is never hidden by max
                max_error = if e.is_nan() { f64::NAN } else { max_error.max(e) };
                size = size.max(xe.amax());
                end = (t, e);
            })?;
            fin.push(end.1);
            max.push(max_error);
            rows.push(ConvergenceRow {
                method: m,
                h,
                steps: stats.accepted,
                rhs_evals: stats.rhs_evals,
                final_error: end.1,
                max_error,
            });
        }
        let fit = match m.order() {
            // an exact flow has rounding error only: there is no order to fit
            None => ConvergenceFit {
                method: m,
                order_final: None,
                order_max: None,
                theory: None,
                asymptotic: false,
                reason: Some("the exact flow has no step-size error".into()),
            },
            Some(theory) => {
                let a_fin = asymptotic(steps, &fin, size);
                let a_max = asymptotic(steps, &max, size);
                ConvergenceFit {
                    method: m,
                    order_final: a_fin.is_ok().then(|| fit_order(steps, &fin)).flatten(),
                    order_max: a_max.is_ok().then(|| fit_order(steps, &max)).flatten(),
                    theory: Some(theory),
                    asymptotic: a_fin.is_ok() && a_max.is_ok(),
                    reason: a_fin.err().or(a_max.err()),
                }
            }
        };
        fits.push(fit);
    }
    Ok(Convergence { rows, fits })
}

//! Observed order of convergence over a sequence of fixed step sizes.

use super::{MethodKind, fit_order, solve_with};
use crate::error::{Error, Result};
use crate::linalg::LuDim;
use crate::methods::Flow;
use crate::{Options, Problem, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};

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

/// The least-squares order of one method.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ConvergenceFit {
    /// Method.
    pub method: MethodKind,
    /// Order fitted to the final-time errors.
    pub order_final: Option<f64>,
    /// Order fitted to the max-over-grid errors.
    pub order_max: Option<f64>,
    /// The classical order.
    pub theory: Option<f64>,
}

/// Table and fitted orders.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Convergence {
    /// Every run.
    pub rows: Vec<ConvergenceRow>,
    /// One fit per method.
    pub fits: Vec<ConvergenceFit>,
}

/// Integrate `problem` with each method at each fixed step `h`, measure the error
/// against `exact(t)` at the final time and at every grid point, and fit the order by
/// least squares on log–log.
///
/// ```
/// use reckon::studies::{convergence::convergence, MethodKind};
/// use reckon::{model, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// let study = convergence(&p, &[MethodKind::Euler], &[0.1, 0.05, 0.025, 0.0125], &|t| vector![(-t).exp()], None).unwrap();
/// assert!((study.fits[0].order_final.unwrap() - 1.0).abs() < 0.1);
/// ```
pub fn convergence<D: LuDim, S: System<D>>(
    problem: &Problem<'_, D, S>,
    methods: &[MethodKind],
    steps: &[f64],
    exact: &dyn Fn(f64) -> OVector<f64, D>,
    flow: Option<&dyn Flow<D>>,
) -> Result<Convergence>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    if steps.len() < 2 {
        return Err(Error::invalid(
            "steps",
            "at least two step sizes are needed to fit an order",
        ));
    }
    if methods.is_empty() {
        return Err(Error::invalid("methods", "no method given"));
    }
    let mut rows = Vec::new();
    let mut fits = Vec::new();
    for &m in methods {
        let mut fin = Vec::new();
        let mut max = Vec::new();
        for &h in steps {
            let opts = Options::default()
                .fixed(h)
                .rtol(1e-12)
                .atol(1e-14)
                .dense(false)
                .max_steps(usize::MAX);
            let sol = solve_with(problem, m, &opts, flow)?;
            let (t_end, x_end) = sol.last();
            let final_error = (x_end - exact(t_end)).amax();
            let max_error = sol
                .t
                .iter()
                .zip(&sol.x)
                .map(|(t, x)| (x - exact(*t)).amax())
                .fold(0.0, f64::max);
            fin.push(final_error);
            max.push(max_error);
            rows.push(ConvergenceRow {
                method: m,
                h,
                steps: sol.stats.accepted,
                rhs_evals: sol.stats.rhs_evals,
                final_error,
                max_error,
            });
        }
        // an exact flow has rounding error only: there is no order to fit
        let fit = |e: &[f64]| m.order().and(fit_order(steps, e));
        fits.push(ConvergenceFit {
            method: m,
            order_final: fit(&fin),
            order_max: fit(&max),
            theory: m.order(),
        });
    }
    Ok(Convergence { rows, fits })
}

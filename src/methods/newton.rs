//! Simplified Newton for `G(x₁) = x₁ − x₀ − h·f(t₁, x₁) = 0` with a frozen iteration
//! matrix `M = I − h·J` (scipy `_ivp/bdf.py::solve_bdf_system`, Hairer–Wanner ODE II §IV.8).

use crate::control::Weights;
use crate::error::Result;
use crate::linalg::Lu;
use crate::system::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Result of one Newton solve.
pub(crate) enum Solve {
    Converged,
    Failed { iterations: usize, residual: f64 },
}

/// Work space for the iteration.
pub(crate) struct Work<'b, D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    pub fx: &'b mut OVector<f64, D>,
    pub dx: &'b mut OVector<f64, D>,
}

/// Iterate `x ← x − M⁻¹ G(x)` from the guess already in `x` until the estimated
/// distance to the solution, `ρ/(1−ρ)·‖Δx‖`, is below `tol` (ρ the observed
/// contraction rate), giving up when ρ ≥ 1 or when `max_iters` cannot reach `tol`
/// at the current rate. Non-finite `f` at the first iterate (a finite predictor) is a
/// model error; later it means the iterates have left the region and the step is retried.
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve<D: Dim, S: System<D>, L: Lu<D>>(
    f: &mut Eval<'_, D, S>,
    lu: &L,
    t1: f64,
    x0: &OVector<f64, D>,
    h: f64,
    x: &mut OVector<f64, D>,
    w: &Weights<D>,
    tol: f64,
    max_iters: usize,
    work: Work<'_, D>,
) -> Result<Solve>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    let Work { fx, dx } = work;
    let n = x.len();
    let mut norm_old: Option<f64> = None;
    let mut last = f64::INFINITY;
    for k in 0..max_iters {
        match f.rhs(t1, x, fx) {
            Ok(()) => {}
            Err(e) if k == 0 => return Err(e),
            Err(_) => {
                return Ok(Solve::Failed {
                    iterations: k,
                    residual: last,
                });
            }
        }
        f.stats.newton_iterations += 1;
        for i in 0..n {
            dx[i] = -(x[i] - x0[i] - h * fx[i]);
        }
        lu.solve_in_place(dx);
        let mut s = 0.0;
        for i in 0..n {
            let r = dx[i] / w.scale(i, x[i]);
            s += r * r;
        }
        let norm = (s / n.max(1) as f64).sqrt();
        last = norm;
        // a correction below the rounding of every component cannot change the iterate:
        // it is as converged as floating point allows (x₀ = 1e12, say, with a tiny step)
        if norm.is_finite() && (0..n).all(|i| x[i] + dx[i] == x[i]) {
            return Ok(Solve::Converged);
        }
        if !norm.is_finite() {
            return Ok(Solve::Failed {
                iterations: k + 1,
                residual: norm,
            });
        }
        let rate = norm_old.map(|old| norm / old);
        if let Some(rate) = rate
            && (rate >= 1.0 || rate.powi((max_iters - k) as i32) / (1.0 - rate) * norm > tol)
        {
            return Ok(Solve::Failed {
                iterations: k + 1,
                residual: norm,
            });
        }
        *x += &*dx;
        if norm == 0.0 || rate.is_some_and(|rate| rate / (1.0 - rate) * norm < tol) {
            return Ok(Solve::Converged);
        }
        norm_old = Some(norm);
    }
    Ok(Solve::Failed {
        iterations: max_iters,
        residual: last,
    })
}

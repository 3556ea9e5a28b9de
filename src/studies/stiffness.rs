//! Step-size behaviour on stiff problems and the stiffness ratio along a solution.

use crate::error::Result;
use crate::solution::{Solution, Stats, Stiffness};
use crate::system::System;
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DefaultAllocator, Dim, OMatrix};

/// Accepted step sizes over time.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StepHistory {
    /// Method name.
    pub method: &'static str,
    /// Step start times.
    pub t: Vec<f64>,
    /// Step sizes.
    pub h: Vec<f64>,
    /// Work counters.
    #[serde(skip)]
    pub stats: Stats,
    /// Where DOPRI5's stiffness test fired.
    #[serde(skip)]
    pub stiffness: Option<Stiffness>,
}

/// The step sizes of a solution.
pub fn step_history<D: Dim>(sol: &Solution<D>) -> StepHistory
where
    DefaultAllocator: Allocator<D>,
{
    StepHistory {
        method: sol.method,
        t: sol.t[..sol.t.len().saturating_sub(1)].to_vec(),
        h: sol.t.windows(2).map(|w| w[1] - w[0]).collect(),
        stats: sol.stats,
        stiffness: sol.stiffness,
    }
}

/// Eigenvalue summary of the Jacobian at one point of a solution.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StiffnessPoint {
    /// Time.
    pub t: f64,
    /// Spectral radius `max |λ|`.
    pub spectral_radius: f64,
    /// `max |Re λ| / min |Re λ|` over eigenvalues with `Re λ < 0` (∞ with a zero one, 1 with one).
    pub ratio: f64,
}

/// Eigenvalues of the autodiff Jacobian `∂f/∂x` at the solution's points (every `every`-th).
pub fn stiffness_along<D: Dim, S: System<D>>(
    sys: &S,
    sol: &Solution<D>,
    u: &[f64],
    every: usize,
) -> Result<Vec<StiffnessPoint>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    let mut out = Vec::new();
    for (t, x) in sol.t.iter().zip(&sol.x).step_by(every.max(1)) {
        let (r, _) = x.shape_generic();
        let mut j = OMatrix::<f64, D, D>::zeros_generic(r, r);
        sys.jacobian(*t, x, u, &mut j);
        let n = x.len();
        let jd = DMatrix::from_fn(n, n, |a, b| j[(a, b)]);
        let ev = jd.complex_eigenvalues();
        let spectral_radius = ev.iter().map(|l| l.norm()).fold(0.0, f64::max);
        let decaying: Vec<f64> = ev.iter().filter(|l| l.re < 0.0).map(|l| -l.re).collect();
        let ratio = if decaying.is_empty() {
            1.0
        } else {
            let (lo, hi) = decaying
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            if lo > 0.0 { hi / lo } else { f64::INFINITY }
        };
        out.push(StiffnessPoint {
            t: *t,
            spectral_radius,
            ratio,
        });
    }
    Ok(out)
}

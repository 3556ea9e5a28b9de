//! Step-size behaviour on stiff problems and the stiffness ratio along a solution.

use crate::error::{Error, Quantity, Result};
use crate::jacobian::SparseJacobian;
use crate::linalg::arnoldi::{SpectralOptions, SpectralWorkspace, sparse_spectrum_with};
use crate::methods::Method;
use crate::model::Stats;
use crate::model::System;
use crate::problem::solution::{Solution, Stiffness};
use crate::{Options, Problem};
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DefaultAllocator, Dim, OMatrix};
use num_complex::Complex64;

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
    /// The time reached (`t_end` unless the run stopped early).
    pub reached: f64,
    /// The error that stopped the run early, if any.
    #[serde(skip)]
    pub stopped_by: Option<Error>,
}

/// Drive `problem` with `method` one step at a time and record the accepted step sizes.
/// A run that ends in an error (RK45 at its step limit on a stiff problem) keeps what it
/// measured: the steps so far, the counters, the time reached, the error, and where
/// DOPRI5's stiffness test fired.
///
/// ```
/// use reckon::studies::stiffness::history;
/// use reckon::methods::Rk45;
/// use reckon::{studies::problems::van_der_pol, Error, Options, Problem};
/// use nalgebra::vector;
/// let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
/// let h = history(&p, Rk45, &Options::default().rtol(1e-4).atol(1e-7).max_steps(5000));
/// assert!(matches!(h.stopped_by, Some(Error::MaxSteps { steps: 5000, .. })));
/// // the verdict survives the error: DOPRI5's test fired on the slow branch
/// let st = h.stiffness.unwrap();
/// assert!(st.t > 0.0 && st.t <= h.reached && h.reached < 2000.0);
/// assert_eq!(h.h.len() as u64, h.stats.accepted);
/// ```
pub fn history<D: Dim, S: System<D>, M: Method<D>>(
    problem: &Problem<'_, D, S>,
    method: M,
    opts: &Options,
) -> StepHistory
where
    DefaultAllocator: Allocator<D>,
{
    let mut out = StepHistory {
        method: method.name(),
        t: Vec::new(),
        h: Vec::new(),
        stats: Stats::default(),
        stiffness: None,
        reached: problem.t0,
        stopped_by: None,
    };
    let mut it = match problem.integrator(method, opts) {
        Ok(it) => it,
        Err(e) => {
            out.stopped_by = Some(e);
            return out;
        }
    };
    let mut t0 = it.t();
    loop {
        match it.step() {
            Ok(Some(t)) => {
                out.t.push(t0);
                out.h.push(t - t0);
                t0 = t;
            }
            Ok(None) => break,
            Err(e) => {
                out.stopped_by = Some(e);
                break;
            }
        }
    }
    out.stats = it.stats();
    out.stiffness = it.stiffness();
    out.reached = it.t();
    out
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
        reached: sol.last().0,
        stopped_by: None,
    }
}

/// Eigenvalues of a square matrix, from faer's Hessenberg–Schur QR iteration, which
/// stops after a bounded number of sweeps. `t` only labels the errors: a non-finite
/// entry gives [`Error::NonFinite`] (quantity Jacobian), an iteration that does not
/// converge gives [`Error::NoConvergence`] (`what: "eigenvalues"`), never a hang.
///
/// ```
/// use reckon::studies::stiffness::eigenvalues;
/// use nalgebra::dmatrix;
/// // a rotation–decay block: eigenvalues −0.5 ± 2i
/// let mut ev = eigenvalues(0.0, &dmatrix![-0.5, -2.0; 2.0, -0.5]).unwrap();
/// ev.sort_by(|a, b| a.im.total_cmp(&b.im));
/// assert!((ev[0].re + 0.5).abs() < 1e-14 && (ev[0].im + 2.0).abs() < 1e-14);
/// assert!((ev[1].re + 0.5).abs() < 1e-14 && (ev[1].im - 2.0).abs() < 1e-14);
/// assert!(eigenvalues(1.5, &dmatrix![f64::NAN, 0.0; 0.0, 1.0]).is_err());
/// ```
pub fn eigenvalues(t: f64, m: &DMatrix<f64>) -> Result<Vec<Complex64>> {
    let n = m.nrows();
    if m.ncols() != n {
        return Err(Error::invalid("jacobian", format!("{}x{} is not square", n, m.ncols())));
    }
    if let Some(component) = m.iter().position(|v| !v.is_finite()) {
        // nalgebra is column-major; the error names the row-major index
        let (r, c) = (component % n, component / n);
        return Err(Error::NonFinite {
            t,
            quantity: Quantity::Jacobian,
            component: r * n + c,
        });
    }
    let fm = faer::MatRef::from_column_major_slice(m.as_slice(), n, n);
    let ev = fm
        .eigenvalues()
        .map_err(|_| Error::NoConvergence { what: "eigenvalues", t })?;
    Ok(ev.into_iter().map(|z| Complex64::new(z.re, z.im)).collect())
}

/// DP5's stability limit on the negative real axis, `|hλ| ≤ 3.3066`
/// ([`real_axis_limit`](super::stability::real_axis_limit)).
pub const DP5_LIMIT: f64 = 3.3065678926349467;

/// Eigenvalue summary of the Jacobian at one point of a solution, and how stiff the
/// problem is there.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StiffnessPoint {
    /// Time.
    pub t: f64,
    /// Spectral radius `ρ(J) = max |λ|`.
    pub spectral_radius: f64,
    /// `max |Re λ| / min |Re λ|` over eigenvalues with `Re λ < 0` (∞ with a zero one, 1
    /// with one). Exactly 1 for every scalar problem, however stiff: see `index`. On the
    /// sparse path ([`stiffness_along_sparse`]) the magnitude ratio `ρ(J)/min |λ|` instead.
    pub ratio: f64,
    /// The step the solution's accuracy needs here: the accepted step of the A-stable
    /// run (its step is limited by accuracy alone) from this point to the next.
    pub h_accuracy: f64,
    /// The step DP5's stability allows here: `3.3066 / ρ(J)`.
    pub h_stability: f64,
    /// Stiffness index `h_accuracy / h_stability = ρ(J)·h_accuracy / 3.3066`: above 1,
    /// stability, not accuracy, limits an explicit method's step (by this factor).
    pub index: f64,
}

/// Eigenvalues of the autodiff Jacobian `∂f/∂x` at the solution's points (every
/// `every`-th, the last point excluded), and the stiffness index there with the
/// solution's own steps as the accuracy-limited steps (give it the solution of an
/// A-stable method, e.g. implicit Euler). Eigenvalues come from [`eigenvalues`]: a
/// non-finite Jacobian or an iteration that does not converge is a typed error.
///
/// ```
/// use reckon::studies::stiffness::{stiffness_along, DP5_LIMIT};
/// use reckon::methods::ImplicitEuler;
/// use reckon::{studies::problems::stiff_cosine, Options, Problem};
/// use nalgebra::vector;
/// let p = Problem::new(stiff_cosine(), vector![1.0], (0.0, 1.0));
/// let sol = p.solve(ImplicitEuler::default(), &Options::default().fixed(0.01)).unwrap();
/// let pts = stiffness_along(&stiff_cosine(), &sol, &[], 1).unwrap();
/// assert_eq!(pts.len(), 100);
/// // λ = −1000: ρ = 1000, and a step of 0.01 is 1000·0.01/3.3066 = 3.02 times DP5's limit
/// assert!((pts[0].spectral_radius - 1000.0).abs() < 1e-9);
/// assert!((pts[0].index - 10.0 / DP5_LIMIT).abs() < 1e-9);
/// ```
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
    let n_pts = sol.t.len().saturating_sub(1);
    for k in (0..n_pts).step_by(every.max(1)) {
        let (t, x) = (sol.t[k], &sol.x[k]);
        let (r, _) = x.shape_generic();
        let mut j = OMatrix::<f64, D, D>::zeros_generic(r, r);
        sys.jacobian(t, x, u, &mut j);
        let n = x.len();
        let jd = DMatrix::from_fn(n, n, |a, b| j[(a, b)]);
        let ev = eigenvalues(t, &jd)?;
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
        let h_accuracy = (sol.t[k + 1] - t).abs();
        let h_stability = DP5_LIMIT / spectral_radius;
        out.push(StiffnessPoint {
            t,
            spectral_radius,
            ratio,
            h_accuracy,
            h_stability,
            index: spectral_radius * h_accuracy / DP5_LIMIT,
        });
    }
    Ok(out)
}

/// The stiffness index over a whole run, each point weighted by the time its step covers.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct IndexSummary {
    /// Largest index.
    pub max: f64,
    /// Time-weighted median: half the span has an index at or below it.
    pub median: f64,
    /// Fraction of the span (of the time the points' steps cover) where the index is
    /// above 1, i.e. where an explicit DP5 step of the size accuracy needs is unstable.
    pub stiff_fraction: f64,
}

/// Summarise [`StiffnessPoint::index`] over a run, weighting each point by its step
/// `h_accuracy` (an A-stable run takes many small steps in fast transients and few large
/// ones where the problem is stiff: an unweighted median would hide the stiff part).
///
/// ```
/// use reckon::studies::stiffness::{summarize, StiffnessPoint};
/// let pt = |t: f64, h: f64, index: f64| StiffnessPoint {
///     t, spectral_radius: 1.0, ratio: 1.0, h_accuracy: h, h_stability: 1.0, index,
/// };
/// // 100 small steps with index 0.01 over 1 s, then one 9-s step with index 500
/// let mut pts: Vec<_> = (0..100).map(|k| pt(k as f64 * 0.01, 0.01, 0.01)).collect();
/// pts.push(pt(1.0, 9.0, 500.0));
/// let s = summarize(&pts);
/// assert_eq!((s.max, s.median), (500.0, 500.0));
/// assert!((s.stiff_fraction - 0.9).abs() < 1e-12);
/// ```
pub fn summarize(pts: &[StiffnessPoint]) -> IndexSummary {
    let mut v: Vec<(f64, f64)> = pts
        .iter()
        .filter(|p| p.index.is_finite() && p.h_accuracy.is_finite())
        .map(|p| (p.index, p.h_accuracy))
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total = v.iter().fold(0.0, |a, p| a + p.1);
    if v.is_empty() || total <= 0.0 {
        return IndexSummary {
            max: f64::NAN,
            median: f64::NAN,
            stiff_fraction: f64::NAN,
        };
    }
    let mut acc = 0.0;
    let mut median = v[v.len() - 1].0;
    for &(index, h) in &v {
        acc += h;
        if acc >= 0.5 * total {
            median = index;
            break;
        }
    }
    let stiff = v.iter().filter(|p| p.0 > 1.0).fold(0.0, |a, p| a + p.1);
    IndexSummary {
        max: v[v.len() - 1].0,
        median,
        stiff_fraction: stiff / total,
    }
}

fn point(t: f64, h_accuracy: f64, spectral_radius: f64, ratio: f64) -> StiffnessPoint {
    StiffnessPoint {
        t,
        spectral_radius,
        ratio,
        h_accuracy,
        h_stability: DP5_LIMIT / spectral_radius,
        index: spectral_radius * h_accuracy / DP5_LIMIT,
    }
}

fn sparse_evaluator<'s, D: Dim, S: System<D>>(sys: &'s S, n: usize) -> Result<Box<dyn SparseJacobian + 's>>
where
    DefaultAllocator: Allocator<D>,
{
    let ev = sys.sparse_jacobian(n).ok_or_else(|| {
        Error::invalid(
            "model",
            "the sparse stiffness estimate needs a model that offers a sparse Jacobian \
             (System::sparse_jacobian returned None)",
        )
    })?;
    if ev.pattern().n() != n {
        return Err(Error::invalid(
            "model",
            format!(
                "the sparse Jacobian's pattern is {0}x{0} for a state of {n}",
                ev.pattern().n()
            ),
        ));
    }
    Ok(ev)
}

fn sparse_point(
    ev: &mut dyn SparseJacobian,
    (values, ws): (&mut [f64], &mut SpectralWorkspace),
    (t, x, u, h): (f64, &[f64], &[f64], f64),
    opts: &SpectralOptions,
) -> Result<StiffnessPoint> {
    ev.eval(t, x, u, values)?;
    let s = sparse_spectrum_with(t, ev.pattern(), values, opts, ws)?;
    Ok(point(t, h, s.spectral_radius, s.ratio))
}

/// `index = ρ(J)·h_accuracy/3.3066` with `ρ(J)` from a sparse estimate: [`stiffness_along`]
/// without a dense matrix. At every `every`-th point the model's sparse
/// Jacobian ([`System::sparse_jacobian`]) and [`sparse_spectrum`] of it, so
/// `spectral_radius = |λ_max|` (restarted Arnoldi, to `opts.tol`, checked against
/// Gershgorin's bound), `h_stability = 3.3066/ρ(J)` and `index = ρ(J)·h_accuracy/3.3066`
/// as on the dense path, and `ratio = ρ(J)/|λ_min|` (`λ_min` by Arnoldi on `J⁻¹` through
/// faer's sparse LU): the magnitude ratio, where the dense path gives
/// `max|Re λ|/min|Re λ|` over the decaying eigenvalues (the two agree when the extreme
/// eigenvalues are real and negative). A model without a sparse Jacobian is
/// [`Error::InvalidInput`]; a non-finite Jacobian [`Error::NonFinite`]; an iteration over
/// its cap [`Error::NoConvergence`].
///
/// ```
/// use reckon::linalg::arnoldi::SpectralOptions;
/// use reckon::studies::stiffness::{stiffness_along, stiffness_along_sparse};
/// use reckon::methods::ImplicitEuler;
/// use reckon::studies::problems::{brusselator, brusselator_y0};
/// use reckon::{Options, Problem};
/// let p = Problem::new(brusselator(20), brusselator_y0(20), (0.0, 1.0));
/// let sol = p.solve(ImplicitEuler::default(), &Options::default().fixed(0.1)).unwrap();
/// let o = SpectralOptions { tol: 1e-10, ..Default::default() };
/// let sparse = stiffness_along_sparse(&p.system, &sol, &[], 5, &o).unwrap();
/// let dense = stiffness_along(&p.system, &sol, &[], 5).unwrap();
/// assert_eq!(sparse.len(), 2);
/// for (s, d) in sparse.iter().zip(&dense) {
///     assert!((s.spectral_radius / d.spectral_radius - 1.0).abs() < 1e-8);
///     assert!((s.index / d.index - 1.0).abs() < 1e-8);
/// }
/// ```
pub fn stiffness_along_sparse<D: Dim, S: System<D>>(
    sys: &S,
    sol: &Solution<D>,
    u: &[f64],
    every: usize,
    opts: &SpectralOptions,
) -> Result<Vec<StiffnessPoint>>
where
    DefaultAllocator: Allocator<D>,
{
    let n_pts = sol.t.len().saturating_sub(1);
    let Some(x0) = sol.x.first() else {
        return Ok(Vec::new());
    };
    let mut ev = sparse_evaluator(sys, x0.len())?;
    let mut values = vec![0.0; ev.pattern().nnz()];
    let mut ws = SpectralWorkspace::default();
    let mut out = Vec::new();
    for k in (0..n_pts).step_by(every.max(1)) {
        let (t, x) = (sol.t[k], &sol.x[k]);
        let h = (sol.t[k + 1] - t).abs();
        out.push(sparse_point(
            ev.as_mut(),
            (&mut values, &mut ws),
            (t, x.as_slice(), u, h),
            opts,
        )?);
    }
    Ok(out)
}

/// The stiffness points of a run too large to keep: `problem` driven by `method` step by
/// step (no state stored), and at every `k`-th accepted step, `k = ⌈steps/samples⌉` with
/// `steps` the run's accepted steps (given, from an earlier run with the same options, or
/// counted by a first run that keeps only its count; at most `samples` points when it is
/// right), the [`stiffness_along_sparse`] point of that step, the spectral iterations
/// warm-started from the previous point ([`sparse_spectrum_with`]). Each
/// sampled point stands for `k` steps around it, and weighting it by its own step (as
/// [`summarize`] does) weights it by the time those steps cover, as on the full run.
/// Returns the points and `k`. `inputs` are the held inputs the Jacobian is taken at.
///
/// ```
/// use reckon::linalg::arnoldi::SpectralOptions;
/// use reckon::studies::stiffness::sampled_stiffness;
/// use reckon::methods::ImplicitEuler;
/// use reckon::studies::problems::{brusselator, brusselator_y0};
/// use reckon::{Options, Problem};
/// let p = Problem::new(brusselator(200), brusselator_y0(200), (0.0, 1.0));
/// let opts = Options::default().rtol(1e-3).atol(1e-6);
/// let (pts, every) = sampled_stiffness(&p, ImplicitEuler::default, &opts, 10, None, &[], &SpectralOptions::default()).unwrap();
/// assert!(pts.len() <= 10 && pts.len() >= 5 && every >= 1);
/// // c = 201²/50, ρ(J) ≈ 4c: DP5's step limit is about 3.3066/3232
/// assert!(pts.iter().all(|q| (q.spectral_radius / (4.0 * 201.0f64.powi(2) / 50.0) - 1.0).abs() < 0.01));
/// ```
pub fn sampled_stiffness<D: Dim, S: System<D>, M: Method<D>>(
    problem: &Problem<'_, D, S>,
    method: impl Fn() -> M,
    opts: &Options,
    samples: usize,
    steps: Option<usize>,
    inputs: &[f64],
    spectral: &SpectralOptions,
) -> Result<(Vec<StiffnessPoint>, usize)>
where
    DefaultAllocator: Allocator<D>,
{
    let steps = match steps {
        Some(s) => s,
        None => {
            let count = history(problem, method(), opts);
            if let Some(e) = count.stopped_by {
                return Err(e);
            }
            count.h.len()
        }
    };
    let every = steps.div_ceil(samples.max(1)).max(1);
    let mut it = problem.integrator(method(), opts)?;
    let mut ev = sparse_evaluator(&problem.system, it.x().len())?;
    let mut values = vec![0.0; ev.pattern().nnz()];
    let mut ws = SpectralWorkspace::default();
    let mut out = Vec::new();
    let mut k = 0usize;
    loop {
        let (t0, x0) = (it.t(), k.is_multiple_of(every).then(|| it.x().clone()));
        match it.step()? {
            Some(t) => {
                if let Some(x) = x0 {
                    let h = (t - t0).abs();
                    out.push(sparse_point(
                        ev.as_mut(),
                        (&mut values, &mut ws),
                        (t0, x.as_slice(), inputs, h),
                        spectral,
                    )?);
                }
                k += 1;
            }
            None => break,
        }
    }
    Ok((out, every))
}

//! General nonlinear least squares: any model parameters from a logged trajectory against
//! measured poses, by Levenberg–Marquardt (Gauss–Newton steps, damped when they do not
//! decrease the cost), with the exact residual Jacobian from the forward sensitivities
//! ([`crate::sensitivity`]).
//!
//! Minimises `½ Σ_k Σ_{c ∈ C} ((x_c(t_k; p) − y_{k,c}) / σ_c)²` over `p`, with `x(t; p)` the
//! model integrated from `x₀` under the logged inputs, `y_k` the measured poses at `t_k`,
//! `C` the observed components (angles wrapped to `(−π, π]`). The Jacobian of the
//! residuals is `∂x_c(t_k)/∂p / σ_c`, read off the sensitivity solve at the observation
//! times. The covariance is `σ̂²·(JᵀJ)⁻¹` at the optimum with `σ̂² = ‖r‖² / (N − n_p)`
//! (the residuals' own scale: with correct `σ_c`, `σ̂² ≈ 1`).
//!
//! Before it starts and at the optimum the column-scaled `J` is checked by its singular
//! values: a parameter the data cannot determine (a condition number above
//! [`LsqOptions::max_condition`]) is [`Error::Unidentifiable`], not a number.
//!
//! **Steps.** From `p`, the step `δ` solves `(JᵀJ + λ·diag(JᵀJ))·δ = −Jᵀr` (Marquardt
//! 1963; `λ` updated by the gain ratio as in Nielsen 1999, starting at 10⁻³). A step that
//! lowers the cost `½‖r‖²` is taken; one that does not (or whose solve fails) is retried
//! with a larger `λ`, a shorter step closer to steepest descent. The fit has converged
//! when the Gauss–Newton step from `p` moves it by less than [`LsqOptions::tol`] standard
//! deviations (`δᵀJᵀJδ ≤ tol²`: the weighted residuals make `JᵀJ` the information matrix
//! at the stated σ); this holds at a noise floor too, where the solver's own error stops
//! every step from lowering the cost. That last small step is taken too when it lowers
//! the cost. It is [`Error::FitFailed`] after
//! [`LsqOptions::max_iters`] steps without converging, and when no step from a point
//! lowers the cost although its Gauss–Newton step is not small: the start is returned
//! only when it is the optimum, never because no step was found.
//!
//! (reckon used argmin's `GaussNewtonLS` before. Its line search measures the cost as
//! `‖r‖` but the slope as `(Jᵀr)ᵀδ`, the slope of `½‖r‖²`: the Armijo test then asks a
//! decrease `‖r‖` times too large, no step length passes once `‖r‖ > 10⁴` (1/c), the
//! backtracking ends at step length 0, and the fit reported the starting point as
//! converged, with a covariance. Real logs with a few thousand poses reach `‖r‖ > 10⁴`
//! from a nominal geometry.)

use crate::error::{Error, Result};
use crate::model::DualSystem;
use crate::problem::Problem;
use crate::problem::controls::Controls;
use crate::problem::options::{Options, Save};
use crate::sensitivity::{self, Augment, SensitivityOptions, Wrt};
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DVector, DefaultAllocator, Dim, OVector, U1};

/// Measured poses and what is compared.
#[derive(Debug, Clone)]
pub struct Observations {
    /// Observation times (increasing, after `t₀`).
    pub t: Vec<f64>,
    /// Measured state components at each time (`y[k][c]` for `c` in [`components`](Self::components)).
    pub y: Vec<Vec<f64>>,
    /// Which state components are observed.
    pub components: Vec<usize>,
    /// Standard deviation of each observed component's measurement.
    pub sigma: Vec<f64>,
    /// Observed components that are angles (residuals wrapped to `(−π, π]`).
    pub angles: Vec<usize>,
}

/// Options of [`fit`].
#[derive(Debug, Clone)]
pub struct LsqOptions {
    /// Steps at most (default 50): accepted steps, and rejected trials at most 10 times
    /// as many.
    pub max_iters: u64,
    /// Converged when the Gauss–Newton step moves the parameters by less than this many
    /// of their standard deviations at the stated σ: `δᵀJᵀJδ ≤ tol²` with
    /// `δ = −(JᵀJ)⁻¹Jᵀr` (default 1e-3). Further steps would change the estimate by less
    /// than its uncertainty can tell.
    pub tol: f64,
    /// Largest condition number of the column-scaled residual Jacobian accepted (default 1e8).
    pub max_condition: f64,
    /// The sensitivity solve's options (the fit always asks for [`Wrt::Params`]: `∂x/∂p` only).
    pub sensitivity: SensitivityOptions,
}

impl Default for LsqOptions {
    fn default() -> Self {
        LsqOptions {
            max_iters: 50,
            tol: 1e-3,
            max_condition: 1e8,
            sensitivity: SensitivityOptions::default(),
        }
    }
}

/// A least-squares estimate: [`Estimate`](super::Estimate) with `covariance = σ̂²·(JᵀJ)⁻¹`
/// at `p̂`, `σ̂² = ‖r‖² / (N − n_p)`, the weighted residuals observation-major
/// (`r[k·|C| + c]`), and how the fit went.
#[derive(Debug, Clone)]
pub struct Fit {
    /// Names, `p̂`, covariance, residuals, `σ̂²`.
    pub estimate: super::Estimate,
    /// Accepted Levenberg–Marquardt steps.
    pub iterations: u64,
    /// Condition number of the column-scaled `J` at `p̂`.
    pub condition: f64,
}

/// What the iteration sees: the weighted residuals and their Jacobian at `p`.
struct Residuals<'a, D: Dim, S, B, M>
where
    DefaultAllocator: Allocator<D>,
{
    build: &'a B,
    x0: &'a OVector<f64, D>,
    span: (f64, f64),
    controls: &'a Controls,
    obs: &'a Observations,
    method: &'a M,
    opts: Options,
    sens: SensitivityOptions,
    _s: std::marker::PhantomData<S>,
}

impl<D: Dim, S, B, M> Residuals<'_, D, S, B, M>
where
    S: DualSystem<D>,
    B: Fn(&[f64]) -> Result<S>,
    M: Augment<D> + Clone,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    /// Weighted residuals and their Jacobian at `p`.
    fn eval(&self, p: &[f64]) -> Result<(Vec<f64>, DMatrix<f64>)> {
        let model = (self.build)(p)?;
        let np = model.n_params();
        if np != p.len() {
            return Err(Error::invalid(
                "params",
                format!("the model has {np} parameters, {} were given", p.len()),
            ));
        }
        let problem = Problem::new(&model, self.x0.clone(), self.span).controls(self.controls.clone());
        let sol = sensitivity::solve(&problem, self.method.clone(), &self.opts, &self.sens.wrt(Wrt::Params))?;
        let nc = self.obs.components.len();
        let mut r = Vec::with_capacity(self.obs.t.len() * nc);
        let mut j = DMatrix::zeros(self.obs.t.len() * nc, np);
        // Save::At keeps exactly the observation times, in order
        for (k, (&t, y)) in self.obs.t.iter().zip(&self.obs.y).enumerate() {
            let i = sol
                .t
                .iter()
                .position(|&s| s == t)
                .ok_or_else(|| Error::invalid("observations", format!("no state saved at t = {t}")))?;
            for (c, &comp) in self.obs.components.iter().enumerate() {
                let mut d = sol.x[i][comp] - y[c];
                if self.obs.angles.contains(&comp) {
                    d = crate::vehicles::wrap_angle(d);
                }
                let w = 1.0 / self.obs.sigma[c];
                r.push(d * w);
                for q in 0..np {
                    j[(k * nc + c, q)] = sol.dx_dp(i, comp, q) * w;
                }
            }
        }
        Ok((r, j))
    }
}

/// Weighted residuals `r` and their Jacobian `J`.
type RJ = (Vec<f64>, DMatrix<f64>);
/// `p ↦ (r, J)`.
type Evaluator<'a> = dyn Fn(&[f64]) -> Result<RJ> + 'a;

/// The residuals and their Jacobian at `p` from one sensitivity solve, the last pair kept:
/// the fit checks the start and the optimum again.
struct Cached<'a> {
    eval: &'a Evaluator<'a>,
    last: Option<(Vec<f64>, RJ)>,
}

impl<'a> Cached<'a> {
    fn new(eval: &'a Evaluator<'a>) -> Self {
        Cached { eval, last: None }
    }

    /// `(r, J)` at `p`: the kept pair when `p` is the point it was computed at.
    fn at(&mut self, p: &[f64]) -> Result<RJ> {
        if let Some((q, rj)) = self.last.as_ref()
            && q.as_slice() == p
        {
            return Ok(rj.clone());
        }
        let rj = (self.eval)(p)?;
        self.last = Some((p.to_vec(), rj.clone()));
        Ok(rj)
    }
}

/// `½‖r‖²`.
fn half_ss(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// Levenberg–Marquardt from `p0` (see the module's notes): the optimum and the accepted
/// steps taken.
fn levenberg_marquardt(cached: &mut Cached<'_>, p0: &[f64], lsq: &LsqOptions) -> Result<(Vec<f64>, u64)> {
    let np = p0.len();
    let mut p = p0.to_vec();
    let (mut r, mut j) = cached.at(&p)?;
    let mut cost = half_ss(&r);
    let (mut lambda, mut nu) = (1e-3, 2.0);
    let (mut accepted, mut trials) = (0u64, 0u64);
    let fail = |reason: String| Error::FitFailed {
        what: "Levenberg-Marquardt (lsq)",
        reason,
    };
    let tol2 = lsq.tol * lsq.tol;
    loop {
        let a = j.transpose() * &j;
        let g = j.transpose() * DVector::from_column_slice(&r);
        // converged: the Gauss–Newton step δ = −A⁻¹g moves p by under tol standard
        // deviations at the stated σ (δᵀAδ = gᵀA⁻¹g); that last step is taken too when
        // it lowers the cost (it only polishes digits: on noise-free data the quadratic
        // convergence gives the parameters to rounding)
        let chol = a.clone().cholesky();
        let gn = chol.as_ref().map(|c| g.dot(&c.solve(&g)));
        if let (Some(q), Some(c)) = (gn, &chol)
            && q <= tol2
        {
            let d = c.solve(&g);
            let last: Vec<f64> = p.iter().zip(d.iter()).map(|(a, b)| a - b).collect();
            if let Ok((rq, _)) = cached.at(&last)
                && half_ss(&rq) < cost
            {
                return Ok((last, accepted + 1));
            }
            return Ok((p, accepted));
        }
        trials += 1;
        if accepted >= lsq.max_iters || trials > 10 * lsq.max_iters.max(1) {
            return Err(fail(format!(
                "no convergence after {accepted} steps ({trials} trials): the Gauss-Newton step is still {:e} standard deviations; try a starting point closer to the optimum",
                gn.unwrap_or(f64::NAN).sqrt()
            )));
        }
        let mut damped = a.clone();
        for i in 0..np {
            damped[(i, i)] += lambda * a[(i, i)].max(f64::MIN_POSITIVE);
        }
        // a step that cannot be solved for, or whose model cannot be integrated, or that
        // does not lower the cost, is retried shorter (a larger λ)
        let step = damped.cholesky().map(|c| -c.solve(&g));
        let trial = step.as_ref().and_then(|d| {
            let q: Vec<f64> = p.iter().zip(d.iter()).map(|(a, b)| a + b).collect();
            let (rq, jq) = cached.at(&q).ok()?;
            let cq = half_ss(&rq);
            cq.is_finite().then_some((q, rq, jq, cq))
        });
        match (trial, &step) {
            (Some((q, rq, jq, cq)), Some(d)) if cq < cost => {
                // gain ratio: actual / predicted decrease, predicted ½δᵀ(λ·diag(A)·δ − g)
                let mut pred = 0.0;
                for i in 0..np {
                    pred += d[i] * (lambda * a[(i, i)] * d[i] - g[i]);
                }
                let rho = (cost - cq) / (0.5 * pred).max(f64::MIN_POSITIVE);
                (p, r, j, cost) = (q, rq, jq, cq);
                accepted += 1;
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
            }
            _ => {
                lambda *= nu;
                nu *= 2.0;
                if lambda >= 1e16 {
                    return Err(fail(format!(
                        "no step from p = {p:?} lowers the cost ½‖r‖² = {cost:e}, although its Gauss-Newton step is {:e} standard deviations: the model cannot be integrated near there, or the residuals are not smooth in the parameters",
                        gn.unwrap_or(f64::NAN).sqrt()
                    )));
                }
            }
        }
    }
}

/// The data leave `name` undetermined: the scaled residual Jacobian's condition is `cond`.
fn unidentifiable(name: &str, cond: f64) -> Error {
    Error::Unidentifiable {
        parameter: name.to_string(),
        reason: format!(
            "the residual Jacobian (columns scaled to unit norm) has condition number {cond:e}; drive a path that excites it, or fix it"
        ),
    }
}

/// Condition number of `J` with its columns scaled to unit norm, and the parameter that
/// leans most on the smallest singular direction.
fn identifiability(j: &DMatrix<f64>) -> (f64, usize) {
    if let Some(q) = j.column_iter().position(|c| c.norm() == 0.0) {
        return (f64::INFINITY, q);
    }
    let mut js = j.clone();
    for mut c in js.column_iter_mut() {
        c /= c.norm();
    }
    let svd = js.svd(false, true);
    let (imin, smin) = svd
        .singular_values
        .iter()
        .enumerate()
        .fold((0, f64::INFINITY), |a, (i, &s)| if s < a.1 { (i, s) } else { a });
    let smax = svd.singular_values.max();
    let v = svd.v_t.expect("v_t was asked for");
    let row = v.row(imin);
    let q = (0..row.len())
        .max_by(|&a, &b| row[a].abs().total_cmp(&row[b].abs()))
        .unwrap_or(0);
    (smax / smin, q)
}

/// Fit the parameters of `build(p)` (a model with a parameter block, rebuilt for each `p`)
/// from `p0` so that the model driven by `controls` from `x0` at `t0` matches `obs`.
/// `method` integrates with sensitivities ([`sensitivity::solve`]).
///
/// Errors: [`Error::Unidentifiable`] when the data cannot determine a parameter (named),
/// [`Error::InvalidInput`] for malformed observations, the solve's errors as they are (at
/// the start and the optimum; a trial step whose solve fails is only retried shorter),
/// and [`Error::FitFailed`] when the iteration does not converge or finds no step that
/// lowers the cost (see the module's notes).
///
/// ```
/// use reckon::calibration::lsq::{self, LsqOptions, Observations};
/// use reckon::{model, Controls, Options, Problem, methods::Rk45};
/// use nalgebra::vector;
/// // x' = −k·x from noise-free samples of x(t) = e^{−0.7 t}
/// let build = |p: &[f64]| model!(|_, x: [S; 1], u: [1], p: [S; 1] = [1.0]| vector![-(p[0] * x[0])]).with_params(p);
/// let t: Vec<f64> = (1..=10).map(|k| 0.3 * k as f64).collect();
/// let obs = Observations {
///     y: t.iter().map(|t| vec![(-0.7 * t).exp()]).collect(),
///     t, components: vec![0], sigma: vec![1e-3], angles: vec![],
/// };
/// let u = Controls::new(vec![0.0], vec![vec![0.0]]).unwrap();
/// let fit = lsq::fit(&build, &[0.2], &vector![1.0], 0.0, &u, &obs, Rk45,
///     &Options::default().rtol(1e-10).atol(1e-12), &LsqOptions::default()).unwrap();
/// assert!((fit.estimate.value[0] - 0.7).abs() < 1e-8);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn fit<D, S, B, M>(
    build: &B,
    p0: &[f64],
    x0: &OVector<f64, D>,
    t0: f64,
    controls: &Controls,
    obs: &Observations,
    method: M,
    opts: &Options,
    lsq: &LsqOptions,
) -> Result<Fit>
where
    D: Dim,
    S: DualSystem<D>,
    B: Fn(&[f64]) -> Result<S>,
    M: Augment<D> + Clone,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    let nc = obs.components.len();
    if obs.t.is_empty() || obs.t.len() != obs.y.len() {
        return Err(Error::invalid(
            "observations",
            format!(
                "{} times for {} measurements (at least one needed)",
                obs.t.len(),
                obs.y.len()
            ),
        ));
    }
    if nc == 0 || obs.sigma.len() != nc || obs.sigma.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(Error::invalid(
            "observations",
            "one positive finite σ per observed component is needed",
        ));
    }
    if let Some(&c) = obs.components.iter().find(|&&c| c >= x0.len()) {
        return Err(Error::invalid(
            "observations",
            format!("component {c} of a {}-state model", x0.len()),
        ));
    }
    if let Some(k) = obs
        .y
        .iter()
        .position(|y| y.len() != nc || y.iter().any(|v| !v.is_finite()))
    {
        return Err(Error::invalid(
            "observations",
            format!("measurement {k} needs {nc} finite values"),
        ));
    }
    let increasing = obs.t.windows(2).all(|w| w[1] > w[0]) && obs.t[0] > t0;
    if !increasing || obs.t.iter().any(|t| !t.is_finite()) {
        return Err(Error::invalid(
            "observations",
            "times must be finite, increasing and after t0",
        ));
    }
    let n_res = obs.t.len() * nc;
    if n_res <= p0.len() {
        return Err(Error::invalid(
            "observations",
            format!("{n_res} residuals for {} parameters: more are needed", p0.len()),
        ));
    }
    let t_end = *obs.t.last().expect("not empty");
    let opts = opts.clone().save(Save::At(obs.t.clone()));
    let res = Residuals {
        build,
        x0,
        span: (t0, t_end),
        controls,
        obs,
        method: &method,
        opts,
        sens: lsq.sensitivity,
        _s: std::marker::PhantomData,
    };
    let names: Vec<String> = (0..p0.len()).map(|i| format!("p[{i}]")).collect();
    // identifiable at the start?
    let eval = |p: &[f64]| res.eval(p);
    let mut cached = Cached::new(&eval);
    let (_, j0) = cached.at(p0)?;
    let (cond, q) = identifiability(&j0);
    if cond.is_nan() || cond > lsq.max_condition {
        return Err(unidentifiable(&names[q], cond));
    }
    let (p, iterations) = levenberg_marquardt(&mut cached, p0, lsq)?;
    let (r, j) = cached.at(&p)?;
    let (cond, q) = identifiability(&j);
    if cond.is_nan() || cond > lsq.max_condition {
        return Err(unidentifiable(&names[q], cond));
    }
    let inv = (j.transpose() * &j)
        .cholesky()
        .map(|c| c.inverse())
        .ok_or_else(|| unidentifiable(&names[q], cond))?;
    let mut estimate = super::Estimate::new(names, p, inv, r);
    estimate.covariance *= estimate.sigma2;
    Ok(Fit {
        estimate,
        iterations,
        condition: cond,
    })
}

/// The differential drive with wheel angular speeds as inputs and its geometry as
/// parameters: `u = (ω_l, ω_r)` (rad/s), `p = (r_l, r_r, b)` (wheel radii, wheelbase):
/// `v = (r_r ω_r + r_l ω_l)/2`, `ω = (r_r ω_r − r_l ω_l)/b`, `x' = v cos θ`, `y' = v sin θ`, `θ' = ω`.
///
/// ```
/// use reckon::{calibration::lsq::diff_drive, System};
/// use nalgebra::vector;
/// let f = diff_drive(&[0.05, 0.05, 0.5]).unwrap();
/// let mut dx = vector![0.0, 0.0, 0.0];
/// f.rhs(0.0, &vector![0.0, 0.0, 0.0], &[10.0, 12.0], &mut dx);
/// assert!((dx - vector![0.55, 0.0, 0.2]).norm() < 1e-15);
/// ```
pub fn diff_drive(p: &[f64]) -> Result<impl DualSystem<nalgebra::Const<3>> + Clone + use<>> {
    crate::model!(|_, x: [S; 3], u: [2], p: [S; 3] = [0.05, 0.05, 0.5]| {
        let v = (p[1] * u[1] + p[0] * u[0]) * 0.5;
        let w = (p[1] * u[1] - p[0] * u[0]) / p[2];
        nalgebra::vector![x[2].cos() * v, x[2].sin() * v, w]
    })
    .with_params(p)
}

/// Wheel angular speeds held over each encoder interval: `ω = 2π·Δn / (N·Δt)` for the
/// increments `Δn` of sample `k` over `(t_{k−1}, t_k]` (`samples[k] = (t_k, Δn_l, Δn_r)`,
/// the first sample's increments ignored), as [`Controls`] from `t₀`.
///
/// ```
/// use reckon::calibration::lsq::wheel_speeds;
/// let u = wheel_speeds(&[(0.0, 0.0, 0.0), (0.5, 100.0, 200.0)], 1000.0).unwrap();
/// let w = u.values(0).unwrap(); // held from t = 0: 100 and 200 pulses in 0.5 s
/// assert_eq!(u.times(), &[0.0]);
/// assert!((w[0] - 2.0 * std::f64::consts::PI * 0.2).abs() < 1e-15);
/// assert!((w[1] - 2.0 * std::f64::consts::PI * 0.4).abs() < 1e-15);
/// ```
pub fn wheel_speeds(samples: &[(f64, f64, f64)], pulses_per_rev: f64) -> Result<Controls> {
    if samples.len() < 2 {
        return Err(Error::invalid("encoders", "at least two samples are needed"));
    }
    let mut t = Vec::with_capacity(samples.len() - 1);
    let mut u = Vec::with_capacity(samples.len() - 1);
    for (k, w) in samples.windows(2).enumerate() {
        let dt = w[1].0 - w[0].0;
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(Error::invalid(
                "encoders",
                format!(
                    "sample {} is not after sample {k} (t = {} then {})",
                    k + 1,
                    w[0].0,
                    w[1].0
                ),
            ));
        }
        let s = std::f64::consts::TAU / (pulses_per_rev * dt);
        t.push(w[0].0);
        u.push(vec![w[1].1 * s, w[1].2 * s]);
    }
    Controls::new(t, u)
}

/// Calibrate a differential drive's wheel radii and wheelbase from an encoder log and
/// measured poses `(t, x, y, θ)` ([`fit`] with [`diff_drive`] and RK45 at rtol 1e-9):
/// the start pose is the first pose (at or after the first encoder sample), the later
/// poses up to the last encoder sample are the observations, with standard deviations
/// `sigma = (σ_x, σ_y, σ_θ)`. Starts from the nominal geometry `robot`. Parameters:
/// `r_l, r_r` (m), `b` (m).
pub fn fit_encoder_log(
    samples: &[(f64, f64, f64)],
    robot: &crate::reckoning::encoders::DiffDrive,
    poses: &[(f64, nalgebra::Vector3<f64>)],
    sigma: [f64; 3],
) -> Result<Fit> {
    let controls = wheel_speeds(samples, robot.pulses_per_rev)?;
    let (t_first, t_last) = (samples[0].0, samples[samples.len() - 1].0);
    let start = poses
        .iter()
        .position(|(t, _)| *t >= t_first)
        .ok_or_else(|| Error::invalid("poses", "no pose inside the encoder log's time span"))?;
    let (t0, x0) = poses[start];
    let later: Vec<&(f64, nalgebra::Vector3<f64>)> = poses[start + 1..].iter().filter(|(t, _)| *t <= t_last).collect();
    let obs = Observations {
        t: later.iter().map(|(t, _)| *t).collect(),
        y: later.iter().map(|(_, p)| p.as_slice().to_vec()).collect(),
        components: vec![0, 1, 2],
        sigma: sigma.to_vec(),
        angles: vec![2],
    };
    let r = 0.5 * robot.wheel_diameter;
    let mut f = fit(
        &|p: &[f64]| diff_drive(p),
        &[r, r, robot.wheel_separation],
        &x0,
        t0,
        &controls,
        &obs,
        crate::methods::Rk45,
        &Options::default().rtol(1e-9).atol(1e-12).max_steps(10_000_000),
        &LsqOptions::default(),
    )?;
    f.estimate.names = vec![
        "left wheel radius".into(),
        "right wheel radius".into(),
        "wheel separation".into(),
    ];
    Ok(f)
}

//! General nonlinear least squares: any model parameters from a logged trajectory against
//! measured poses, by argmin's Gauss–Newton with a line search, with the exact residual
//! Jacobian from the forward sensitivities ([`crate::sensitivity`]).
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

use crate::controls::Controls;
use crate::error::{Error, Result};
use crate::options::{Options, Save};
use crate::problem::Problem;
use crate::sensitivity::{self, Augment, SensitivityOptions, Wrt};
use crate::system::DualSystem;
use argmin::core::{Executor, Jacobian, Operator, State};
use argmin::solver::gaussnewton::GaussNewtonLS;
use argmin::solver::linesearch::{BacktrackingLineSearch, condition::ArmijoCondition};
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
    /// Gauss–Newton iterations at most (default 50).
    pub max_iters: u64,
    /// Stop when the cost changes by less than this relative amount (default 1e-12).
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
            tol: 1e-12,
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
    /// Gauss–Newton iterations.
    pub iterations: u64,
    /// Condition number of the column-scaled `J` at `p̂`.
    pub condition: f64,
}

/// The residual Jacobian as argmin's Jacobian type (a nalgebra matrix behind a newtype:
/// argmin sees `Vec<f64>` parameters and residuals, never a second nalgebra).
#[derive(Debug, Clone)]
pub struct Jac(pub DMatrix<f64>);

impl argmin_math::ArgminTranspose<Jac> for Jac {
    fn t(self) -> Jac {
        Jac(self.0.transpose())
    }
}
impl argmin_math::ArgminDot<Jac, Jac> for Jac {
    fn dot(&self, other: &Jac) -> Jac {
        Jac(&self.0 * &other.0)
    }
}
impl argmin_math::ArgminDot<Vec<f64>, Vec<f64>> for Jac {
    fn dot(&self, v: &Vec<f64>) -> Vec<f64> {
        (&self.0 * DVector::from_column_slice(v)).as_slice().to_vec()
    }
}
impl argmin_math::ArgminInv<Jac> for Jac {
    fn inv(&self) -> std::result::Result<Jac, argmin_math::Error> {
        // JᵀJ is symmetric positive definite when the data determine p (checked before)
        self.0
            .clone()
            .cholesky()
            .map(|c| Jac(c.inverse()))
            .ok_or_else(|| argmin_math::Error::msg("JᵀJ is not positive definite"))
    }
}

/// What the Gauss–Newton iteration sees.
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
                    d = crate::models::wrap_angle(d);
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

/// The residuals and their Jacobian at `p` from one sensitivity solve (`eval`), the last
/// pair kept: Gauss–Newton asks for both at the same point, and the fit checks the start
/// and the optimum again. The first solve error is kept too (argmin's errors are strings).
struct Cached<'a> {
    eval: &'a Evaluator<'a>,
    last: std::cell::RefCell<Option<(Vec<f64>, RJ)>>,
    failure: std::cell::RefCell<Option<Error>>,
}

impl<'a> Cached<'a> {
    fn new(eval: &'a Evaluator<'a>) -> Self {
        Cached {
            eval,
            last: Default::default(),
            failure: Default::default(),
        }
    }

    /// `(r, J)` at `p`: the kept pair when `p` is the point it was computed at.
    fn at(&self, p: &[f64]) -> Result<RJ> {
        if let Some((q, rj)) = self.last.borrow().as_ref()
            && q.as_slice() == p
        {
            return Ok(rj.clone());
        }
        let rj = (self.eval)(p)?;
        *self.last.borrow_mut() = Some((p.to_vec(), rj.clone()));
        Ok(rj)
    }
}

/// What argmin sees: [`Cached`] with its errors kept.
struct Argmin<'a, 'b>(&'b Cached<'a>);

impl Argmin<'_, '_> {
    fn at(&self, p: &[f64]) -> std::result::Result<RJ, argmin_math::Error> {
        self.0.at(p).map_err(|e| {
            let msg = e.to_string();
            self.0.failure.borrow_mut().get_or_insert(e);
            argmin_math::Error::msg(msg)
        })
    }
}

impl Operator for Argmin<'_, '_> {
    type Param = Vec<f64>;
    type Output = Vec<f64>;
    fn apply(&self, p: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin_math::Error> {
        Ok(self.at(p)?.0)
    }
}

impl Jacobian for Argmin<'_, '_> {
    type Param = Vec<f64>;
    type Jacobian = Jac;
    fn jacobian(&self, p: &Vec<f64>) -> std::result::Result<Jac, argmin_math::Error> {
        Ok(Jac(self.at(p)?.1))
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
/// [`Error::InvalidInput`] for malformed observations, the solve's errors as they are, and
/// [`Error::FitFailed`] when Gauss–Newton fails.
///
/// ```
/// use reckon::calibration::lsq::{self, LsqOptions, Observations};
/// use reckon::{model, Controls, Options, Problem, methods::Dopri5};
/// use nalgebra::vector;
/// // x' = −k·x from noise-free samples of x(t) = e^{−0.7 t}
/// let build = |p: &[f64]| model!(|_, x: [S; 1], u: [1], p: [S; 1] = [1.0]| vector![-(p[0] * x[0])]).with_params(p);
/// let t: Vec<f64> = (1..=10).map(|k| 0.3 * k as f64).collect();
/// let obs = Observations {
///     y: t.iter().map(|t| vec![(-0.7 * t).exp()]).collect(),
///     t, components: vec![0], sigma: vec![1e-3], angles: vec![],
/// };
/// let u = Controls::new(vec![0.0], vec![vec![0.0]]).unwrap();
/// let fit = lsq::fit(&build, &[0.2], &vector![1.0], 0.0, &u, &obs, Dopri5::default(),
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
    let cached = Cached::new(&eval);
    let (_, j0) = cached.at(p0)?;
    let (cond, q) = identifiability(&j0);
    if cond.is_nan() || cond > lsq.max_condition {
        return Err(unidentifiable(&names[q], cond));
    }
    let armijo = ArmijoCondition::new(1e-4).map_err(|e| Error::invalid("lsq", e.to_string()))?;
    let ls = BacktrackingLineSearch::new(armijo);
    let gn = GaussNewtonLS::new(ls)
        .with_tolerance(lsq.tol.max(f64::MIN_POSITIVE))
        .map_err(|e| Error::invalid("lsq", e.to_string()))?;
    let out = Executor::new(Argmin(&cached), gn)
        .configure(|c| c.param(p0.to_vec()).max_iters(lsq.max_iters))
        .run();
    let out = match out {
        Ok(o) => o,
        Err(e) => {
            return Err(cached.failure.take().unwrap_or(Error::FitFailed {
                what: "Gauss-Newton (lsq)",
                reason: e.to_string(),
            }));
        }
    };
    let iterations = out.state.get_iter();
    let p = out
        .state
        .get_best_param()
        .or(out.state.get_param())
        .cloned()
        .unwrap_or_else(|| p0.to_vec());
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
        crate::methods::Dopri5::default(),
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

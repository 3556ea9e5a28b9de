//! The rest of reckon for Python: vehicles and their exact flows driven by held inputs,
//! encoder odometry, forward sensitivities of traced models, and calibration (least
//! squares, UMBmark, Censi). The argument checks with numpy's shapes and the result
//! objects live in `reckon/vehicles.py`, `reckon/calibration.py` and `reckon/__init__.py`;
//! here every array arrives flat and C-ordered, with its dimensions.
//!
//! The native work runs with the GIL released (`py.detach`): none of it calls Python.

use crate::errors;
use crate::traced::Model;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use reckon::calibration::{Estimate, censi, lsq, umbmark};
use reckon::linalg::LuDim;
use reckon::methods::{Auto, Bdf, Euler, Exact, ImplicitEuler, Rk45, Rodas5P};
use reckon::model::Flow;
use reckon::nalgebra::{Const, DMatrix, DVector, Dyn, SVector, Vector2, Vector3};
use reckon::num_dual::{Derivative, DualVec64};
use reckon::reckoning::encoders::{self, DiffDrive, Update};
use reckon::sensitivity::{self, SensitivityOptions, Wrt};
use reckon::symbolic::{CompiledJacobian, CompiledVector};
use reckon::vehicles::{bicycle, body3d, carlike, unicycle};
use reckon::{Controls, DualSystem, Options, Problem, Save, Solution, System};
use std::cell::RefCell;

fn slice<'a>(py: Python<'_>, a: &'a PyReadonlyArray1<'_, f64>, what: &str) -> PyResult<&'a [f64]> {
    a.as_slice()
        .map_err(|_| errors::invalid(py, what, "the array is not contiguous".into()))
}

fn finite(py: Python<'_>, v: &[f64], what: &str) -> PyResult<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(errors::invalid(py, what, format!("value {i} is {}", v[i]))),
        None => Ok(()),
    }
}

fn positive(py: Python<'_>, v: f64, what: &str) -> PyResult<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(errors::invalid(
            py,
            what,
            format!("must be finite and positive, got {v}"),
        ))
    }
}

fn stats_dict<'py>(py: Python<'py>, s: &reckon::model::Stats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("rhs_evals", s.rhs_evals)?;
    d.set_item("jacobian_evals", s.jacobian_evals)?;
    d.set_item("lu_decompositions", s.lu_decompositions)?;
    d.set_item("newton_iterations", s.newton_iterations)?;
    d.set_item("accepted", s.accepted)?;
    d.set_item("rejected", s.rejected)?;
    Ok(d)
}

// ---------------------------------------------------------------------------------------
// vehicles

/// The vehicles by name: `(states, inputs, parameters)`.
fn shape(kind: &str) -> Option<(usize, usize, usize)> {
    Some(match kind {
        "unicycle" => (3, 2, 0),
        "bicycle" => (3, 2, 1),
        "carlike" => (4, 2, 1),
        "body3d" => (3, 6, 0),
        "diffdrive" => (3, 2, 3),
        _ => return None,
    })
}

/// The wheel-speed differential drive's exact flow: the unicycle arc with
/// `v = (r_r ω_r + r_l ω_l)/2`, `ω = (r_r ω_r − r_l ω_l)/b`.
fn diffdrive_flow(p: [f64; 3]) -> impl Fn(f64, &Vector3<f64>, &[f64], f64) -> Vector3<f64> + Clone {
    move |t: f64, x: &Vector3<f64>, u: &[f64], h: f64| {
        let wl = u.first().copied().unwrap_or(f64::NAN);
        let wr = u.get(1).copied().unwrap_or(f64::NAN);
        let v = 0.5 * (p[1] * wr + p[0] * wl);
        let w = (p[1] * wr - p[0] * wl) / p[2];
        unicycle::flow(t, x, &[v, w], h)
    }
}

/// `$body` with `$sys` the vehicle's model and `$flow` its exact flow.
macro_rules! with_vehicle {
    ($py:expr, $kind:expr, $p:expr, |$sys:ident, $flow:ident| $body:expr) => {
        match $kind {
            "unicycle" => {
                let $sys = unicycle::model();
                let $flow = unicycle::flow;
                $body
            }
            "bicycle" => {
                let $sys = bicycle::model($p[0]);
                let $flow = bicycle::flow($p[0]);
                $body
            }
            "carlike" => {
                let $sys = carlike::model($p[0]);
                let $flow = carlike::flow($p[0]);
                $body
            }
            "body3d" => {
                let $sys = body3d::model();
                let $flow = body3d::flow;
                $body
            }
            "diffdrive" => {
                let $sys = lsq::diff_drive($p).map_err(|e| errors::to_py($py, &e))?;
                let $flow = diffdrive_flow([$p[0], $p[1], $p[2]]);
                $body
            }
            other => {
                return Err(errors::invalid($py, "vehicle", format!("unknown vehicle {other:?}")));
            }
        }
    };
}

/// Check a vehicle's name, parameters, state and inputs: `(n, m)`.
fn check_vehicle(py: Python<'_>, kind: &str, params: &[f64]) -> PyResult<(usize, usize)> {
    let (n, m, np) = shape(kind).ok_or_else(|| errors::invalid(py, "vehicle", format!("unknown vehicle {kind:?}")))?;
    if params.len() != np {
        return Err(errors::invalid(
            py,
            "params",
            format!("the {kind} vehicle has {np} parameters, got {}", params.len()),
        ));
    }
    let names: &[&str] = match kind {
        "diffdrive" => &["left_radius", "right_radius", "wheelbase"],
        _ => &["wheelbase"],
    };
    for (v, what) in params.iter().zip(names) {
        positive(py, *v, what)?;
    }
    Ok((n, m))
}

fn run_vehicle<const N: usize, S: System<Const<N>>, F: Flow<Const<N>>>(
    problem: Problem<'_, Const<N>, S>,
    flow: F,
    method: &str,
    opts: &Options,
    step: Option<f64>,
) -> reckon::Result<Solution<Const<N>>>
where
    Const<N>: LuDim,
{
    // fixed-step methods: one step per control interval unless `step` is given
    let fixed = opts.clone().fixed(step.unwrap_or(f64::MAX));
    let adaptive = match step {
        Some(h) => opts.clone().fixed(h),
        None => opts.clone(),
    };
    match method {
        "Exact" => problem.solve(Exact::new(flow), &fixed),
        "Euler" => problem.solve(Euler, &fixed),
        "ImplicitEuler" => problem.solve(ImplicitEuler::default(), &fixed),
        "RK45" => problem.solve(Rk45, &adaptive),
        "BDF" => problem.solve(Bdf::default(), &adaptive),
        "Rodas5P" => problem.solve(Rodas5P, &adaptive),
        _ => problem.solve(Auto::default(), &adaptive),
    }
}

/// The vehicle `sys` from `x0` over `[t_0, t_K]` with row `k` of `u` (`m` values) held
/// over `[t_k, t_{k+1})`.
fn held<'a, const N: usize, S: System<Const<N>>>(
    sys: S,
    x0: &[f64],
    t: &[f64],
    u: &[f64],
    m: usize,
) -> reckon::Result<Problem<'a, Const<N>, S>> {
    let k = t.len() - 1;
    let rows: Vec<Vec<f64>> = (0..k).map(|i| u[i * m..(i + 1) * m].to_vec()).collect();
    let controls = Controls::new(t[..k].to_vec(), rows)?;
    Ok(Problem::new(sys, SVector::<f64, N>::from_column_slice(x0), (t[0], t[k])).controls(controls))
}

/// Integrate with `x0` and the rows of `u` (`len(t) − 1` rows of `m`) held over
/// `[t_k, t_{k+1})`, keeping the state at every `t_k`: `(t, y row-major (n, len t), stats)`.
#[allow(clippy::too_many_arguments)]
fn simulate_n<const N: usize, S: System<Const<N>>, F: Flow<Const<N>>>(
    sys: S,
    flow: F,
    x0: &[f64],
    t: &[f64],
    u: &[f64],
    m: usize,
    method: &str,
    opts: Options,
    step: Option<f64>,
) -> reckon::Result<(Vec<f64>, Vec<f64>, reckon::model::Stats)>
where
    Const<N>: LuDim,
{
    let problem = held(sys, x0, t, u, m)?;
    let sol = run_vehicle(problem, flow, method, &opts.save(Save::At(t.to_vec())), step)?;
    let cols = sol.t.len();
    let mut y = vec![0.0; N * cols];
    for (j, x) in sol.x.iter().enumerate() {
        for i in 0..N {
            y[i * cols + j] = x[i];
        }
    }
    Ok((sol.t, y, sol.stats))
}

const VEHICLE_METHODS: [&str; 7] = ["Exact", "RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "Euler"];

/// `reckon.vehicles.simulate`'s native half: see `reckon/vehicles.py`.
#[pyfunction]
#[pyo3(signature = (kind, params, x0, t, u, method, rtol, atol, max_step, step, max_steps))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn vehicle_simulate<'py>(
    py: Python<'py>,
    kind: &str,
    params: Vec<f64>,
    x0: Vec<f64>,
    t: PyReadonlyArray1<'py, f64>,
    u: PyReadonlyArray1<'py, f64>,
    method: &str,
    rtol: f64,
    atol: f64,
    max_step: f64,
    step: Option<f64>,
    max_steps: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let (n, m) = check_vehicle(py, kind, &params)?;
    let (t, u) = (slice(py, &t, "t")?, slice(py, &u, "u")?);
    check_run(py, kind, n, m, method, &x0, t, u, step)?;
    let opts = run_options(py, rtol, atol, max_step, max_steps)?;
    let p = params.as_slice();
    let result = with_vehicle!(py, kind, p, |sys, flow| py
        .detach(|| simulate_n(sys, flow, &x0, t, u, m, method, opts, step)));
    let (ts, y, stats) = result.map_err(|e| errors::to_py(py, &e))?;
    let out = PyDict::new(py);
    let cols = ts.len();
    out.set_item("t", PyArray1::from_vec(py, ts))?;
    out.set_item("y", PyArray1::from_vec(py, y).reshape([n, cols])?)?;
    out.set_item("stats", stats_dict(py, &stats)?)?;
    Ok(out)
}

/// A vehicle's sensitivities `S = ∂x/∂(x₀, p)` (`p`: the model's parameter block, the
/// wheel-speed drive's `(r_l, r_r, b)`) at every `t_k`.
#[allow(clippy::too_many_arguments)]
fn sensitivities_n<const N: usize, S: DualSystem<Const<N>>>(
    sys: S,
    x0: &[f64],
    t: &[f64],
    u: &[f64],
    m: usize,
    method: &str,
    opts: Options,
    step: Option<f64>,
) -> reckon::Result<Packed>
where
    Const<N>: LuDim,
{
    let problem = held(sys, x0, t, u, m)?;
    let opts = opts.save(Save::At(t.to_vec()));
    let fixed = opts.clone().fixed(step.unwrap_or(f64::MAX));
    let adaptive = match step {
        Some(h) => opts.clone().fixed(h),
        None => opts,
    };
    let sens = SensitivityOptions::default();
    let sol = match method {
        "Euler" => sensitivity::solve(&problem, Euler, &fixed, &sens),
        "ImplicitEuler" => sensitivity::solve(&problem, ImplicitEuler::default(), &fixed, &sens),
        "RK45" => sensitivity::solve(&problem, Rk45, &adaptive, &sens),
        "BDF" => sensitivity::solve(&problem, Bdf::default(), &adaptive, &sens),
        "Rodas5P" => sensitivity::solve(&problem, Rodas5P, &adaptive, &sens),
        "Auto" => sensitivity::solve(&problem, Auto::default(), &adaptive, &sens),
        other => Err(reckon::Error::invalid(
            "method",
            format!("{other:?} has no sensitivities here"),
        )),
    }?;
    Ok(pack_sensitivities(
        &sol.t,
        |j| sol.x[j].as_slice().to_vec(),
        |j| sol.s(j).into_owned(),
        sol.stats,
    ))
}

/// `(t, y (n, K) row-major, S (K, n, m) row-major, m, stats)`.
type Packed = (Vec<f64>, Vec<f64>, Vec<f64>, usize, reckon::model::Stats);

fn pack_sensitivities(
    t: &[f64],
    x: impl Fn(usize) -> Vec<f64>,
    s: impl Fn(usize) -> DMatrix<f64>,
    stats: reckon::model::Stats,
) -> Packed {
    let k = t.len();
    let (n, m) = if k == 0 { (0, 0) } else { s(0).shape() };
    let mut y = vec![0.0; n * k];
    let mut flat = vec![0.0; k * n * m];
    for j in 0..k {
        let (xj, sj) = (x(j), s(j));
        for i in 0..n {
            y[i * k + j] = xj[i];
            for c in 0..m {
                flat[(j * n + i) * m + c] = sj[(i, c)];
            }
        }
    }
    (t.to_vec(), y, flat, m, stats)
}

/// `reckon.vehicles.simulate(..., sensitivities=True)`'s native half: `t`, `y` and
/// `s` `(K, n, n + n_p)`.
#[pyfunction]
#[pyo3(signature = (kind, params, x0, t, u, method, rtol, atol, max_step, step, max_steps))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn vehicle_sensitivities<'py>(
    py: Python<'py>,
    kind: &str,
    params: Vec<f64>,
    x0: Vec<f64>,
    t: PyReadonlyArray1<'py, f64>,
    u: PyReadonlyArray1<'py, f64>,
    method: &str,
    rtol: f64,
    atol: f64,
    max_step: f64,
    step: Option<f64>,
    max_steps: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let (n, m) = check_vehicle(py, kind, &params)?;
    let (t, u) = (slice(py, &t, "t")?, slice(py, &u, "u")?);
    check_run(py, kind, n, m, method, &x0, t, u, step)?;
    let opts = run_options(py, rtol, atol, max_step, max_steps)?;
    let p = params.as_slice();
    let result = if method == "Exact" {
        if kind != "unicycle" {
            return Err(errors::invalid(
                py,
                "method",
                format!(
                    "exact sensitivities are the unicycle's flow's; for the {kind} use an integrator (method=\"RK45\", ...)"
                ),
            ));
        }
        py.detach(|| -> reckon::Result<Packed> {
            let problem = held(unicycle::model(), &x0, t, u, m)?;
            let opts = opts.save(Save::At(t.to_vec())).fixed(step.unwrap_or(f64::MAX));
            let sol = sensitivity::solve(
                &problem,
                Exact::new(unicycle::ExactFlow),
                &opts,
                &SensitivityOptions::default(),
            )?;
            Ok(pack_sensitivities(
                &sol.t,
                |j| sol.x[j].as_slice().to_vec(),
                |j| sol.s(j).into_owned(),
                sol.stats,
            ))
        })
    } else {
        with_vehicle!(py, kind, p, |sys, _flow| py
            .detach(|| sensitivities_n(sys, &x0, t, u, m, method, opts, step)))
    };
    let (ts, y, s, cols, stats) = result.map_err(|e| errors::to_py(py, &e))?;
    let k = ts.len();
    let out = PyDict::new(py);
    out.set_item("t", PyArray1::from_vec(py, ts))?;
    out.set_item("y", PyArray1::from_vec(py, y).reshape([n, k])?)?;
    out.set_item("s", PyArray1::from_vec(py, s).reshape([k, n, cols])?)?;
    out.set_item("stats", stats_dict(py, &stats)?)?;
    Ok(out)
}

/// The options of a vehicle run, validated.
fn run_options(py: Python<'_>, rtol: f64, atol: f64, max_step: f64, max_steps: usize) -> PyResult<Options> {
    let opts = Options::default()
        .rtol(rtol)
        .atol(atol)
        .h_max(max_step)
        .max_steps(max_steps);
    opts.validate().map_err(|e| errors::to_py(py, &e))?;
    Ok(opts)
}

/// The checks of a vehicle run's method, state, times and inputs.
#[allow(clippy::too_many_arguments)]
fn check_run(
    py: Python<'_>,
    kind: &str,
    n: usize,
    m: usize,
    method: &str,
    x0: &[f64],
    t: &[f64],
    u: &[f64],
    step: Option<f64>,
) -> PyResult<()> {
    if !VEHICLE_METHODS.contains(&method) {
        return Err(errors::invalid(
            py,
            "method",
            format!("{method:?} is not one of {}", VEHICLE_METHODS.join(", ")),
        ));
    }
    if t.len() < 2 {
        return Err(errors::invalid(
            py,
            "t",
            format!("at least two times are needed, got {}", t.len()),
        ));
    }
    if x0.len() != n {
        return Err(errors::invalid(
            py,
            "x0",
            format!("{} values, the {kind} state has {n}", x0.len()),
        ));
    }
    if u.len() != (t.len() - 1) * m {
        return Err(errors::invalid(
            py,
            "u",
            format!("{} values for {} intervals of {m} inputs", u.len(), t.len() - 1),
        ));
    }
    finite(py, x0, "x0")?;
    finite(py, t, "t")?;
    if let Some(k) = (1..t.len()).find(|&k| t[k] <= t[k - 1]) {
        return Err(errors::invalid(
            py,
            "t",
            format!("times must increase: t[{k}] = {} after {}", t[k], t[k - 1]),
        ));
    }
    finite(py, u, "u")?;
    if let Some(h) = step {
        positive(py, h, "step")?;
    }
    Ok(())
}

/// One step of a vehicle's exact flow, or its right-hand side (`h = None`).
#[pyfunction]
#[pyo3(signature = (kind, params, x, u, h))]
pub(crate) fn vehicle_step<'py>(
    py: Python<'py>,
    kind: &str,
    params: Vec<f64>,
    x: Vec<f64>,
    u: Vec<f64>,
    h: Option<f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (n, m) = check_vehicle(py, kind, &params)?;
    if x.len() != n {
        return Err(errors::invalid(
            py,
            "x",
            format!("{} values, the {kind} state has {n}", x.len()),
        ));
    }
    if u.len() != m {
        return Err(errors::invalid(
            py,
            "u",
            format!("{} values, the {kind} vehicle has {m} inputs", u.len()),
        ));
    }
    finite(py, &x, "x")?;
    finite(py, &u, "u")?;
    if let Some(h) = h
        && !h.is_finite()
    {
        return Err(errors::invalid(py, "h", format!("must be finite, got {h}")));
    }
    let p = params.as_slice();
    let out: Vec<f64> = with_vehicle!(py, kind, p, |sys, flow| step_n(&sys, &flow, &x, &u, h));
    Ok(PyArray1::from_vec(py, out))
}

fn step_n<const N: usize, S: System<Const<N>>, F: Flow<Const<N>>>(
    sys: &S,
    flow: &F,
    x: &[f64],
    u: &[f64],
    h: Option<f64>,
) -> Vec<f64> {
    let x = SVector::<f64, N>::from_column_slice(x);
    let mut out = SVector::<f64, N>::zeros();
    match h {
        Some(h) => flow.flow(0.0, &x, u, h, &mut out),
        None => sys.rhs(0.0, &x, u, &mut out),
    }
    out.as_slice().to_vec()
}

// ---------------------------------------------------------------------------------------
// odometry

/// Differential-drive odometry from encoder increments: `(3, len t)` row-major poses.
#[pyfunction]
#[pyo3(signature = (t, left, right, wheel_diameter, wheel_separation, pulses_per_rev, update))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn odometry<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    left: PyReadonlyArray1<'py, f64>,
    right: PyReadonlyArray1<'py, f64>,
    wheel_diameter: f64,
    wheel_separation: f64,
    pulses_per_rev: f64,
    update: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let robot = DiffDrive::new(wheel_diameter, wheel_separation, pulses_per_rev).map_err(|e| errors::to_py(py, &e))?;
    let rule: Update = update.parse().map_err(|e| errors::to_py(py, &e))?;
    let (t, l, r) = (
        slice(py, &t, "t")?,
        slice(py, &left, "left")?,
        slice(py, &right, "right")?,
    );
    if t.is_empty() || l.len() != t.len() || r.len() != t.len() {
        return Err(errors::invalid(
            py,
            "samples",
            format!(
                "t, left and right need the same non-zero length, got {}, {}, {}",
                t.len(),
                l.len(),
                r.len()
            ),
        ));
    }
    let samples: Vec<(f64, f64, f64)> = (0..t.len()).map(|k| (t[k], l[k], r[k])).collect();
    let path = py
        .detach(|| encoders::odometry(&robot, &samples, rule))
        .map_err(|e| errors::to_py(py, &e))?;
    let k = path.len();
    let mut y = vec![0.0; 3 * k];
    for (j, (_, p)) in path.iter().enumerate() {
        for i in 0..3 {
            y[i * k + j] = p[i];
        }
    }
    Ok(PyArray1::from_vec(py, y).reshape([3, k])?.into_any())
}

// ---------------------------------------------------------------------------------------
// sensitivities of traced models

/// A traced model `z' = g(t, z)` over `z = (x, p)` with `g = (f(t, x; p), 0)` (the
/// parameters traced as states), seen as `x' = f(t, x; p)` with `n_p` parameters: `f`,
/// `∂f/∂x` and `∂f/∂p` are blocks of the compiled `g` and `∂g/∂z`, so `J·S + [0 | ∂f/∂p]`
/// is exact to rounding.
#[derive(Clone)]
pub(crate) struct ParamSystem {
    rhs: RefCell<CompiledVector>,
    jac: RefCell<CompiledJacobian>,
    n: usize,
    params: Vec<f64>,
    /// Scratch: `z`, `g(z)`, `∂g/∂z` (column-major).
    z: RefCell<(Vec<f64>, Vec<f64>, Vec<f64>)>,
}

impl ParamSystem {
    fn new(model: &Model, n: usize, params: &[f64]) -> Self {
        let nz = model.n;
        ParamSystem {
            rhs: RefCell::new(model.rhs.clone()),
            jac: RefCell::new(model.jac.clone()),
            n,
            params: params.to_vec(),
            z: RefCell::new((vec![0.0; nz], vec![0.0; nz], vec![0.0; nz * nz])),
        }
    }

    fn with_params(&self, p: &[f64]) -> reckon::Result<Self> {
        if p.len() != self.params.len() {
            return Err(reckon::Error::invalid(
                "params",
                format!("{} values for {} parameters", p.len(), self.params.len()),
            ));
        }
        if let Some(i) = p.iter().position(|v| !v.is_finite()) {
            return Err(reckon::Error::invalid("params", format!("parameter {i} is {}", p[i])));
        }
        let mut s = self.clone();
        s.params = p.to_vec();
        Ok(s)
    }

    /// `g(t, (x, p))` into the scratch; false on a failure of the compiled code.
    fn eval_g(&self, t: f64, x: &[f64]) -> bool {
        let mut z = self.z.borrow_mut();
        let (zz, g, _) = &mut *z;
        zz[..self.n].copy_from_slice(x);
        zz[self.n..].copy_from_slice(&self.params);
        self.rhs.borrow_mut().eval(t, zz, &[], g).is_ok()
    }

    /// `∂g/∂z (t, (x, p))` into the scratch; false on a failure.
    fn eval_jac(&self, t: f64, x: &[f64]) -> bool {
        let mut z = self.z.borrow_mut();
        let (zz, _, j) = &mut *z;
        zz[..self.n].copy_from_slice(x);
        zz[self.n..].copy_from_slice(&self.params);
        self.jac.borrow_mut().eval_dense(t, zz, &[], j).is_ok()
    }
}

impl System<Dyn> for ParamSystem {
    fn rhs(&self, t: f64, x: &DVector<f64>, _u: &[f64], dx: &mut DVector<f64>) {
        if self.eval_g(t, x.as_slice()) {
            dx.as_mut_slice().copy_from_slice(&self.z.borrow().1[..self.n]);
        } else {
            dx.fill(f64::NAN);
        }
    }
    fn jacobian(&self, t: f64, x: &DVector<f64>, _u: &[f64], jac: &mut DMatrix<f64>) {
        let n = self.n;
        if !self.eval_jac(t, x.as_slice()) {
            jac.fill(f64::NAN);
            return;
        }
        let z = self.z.borrow();
        let nz = z.0.len();
        for j in 0..n {
            for i in 0..n {
                jac[(i, j)] = z.2[i + nz * j];
            }
        }
    }
}

impl DualSystem<Dyn> for ParamSystem {
    fn rhs_dual(&self, t: f64, x: &DVector<DualVec64<Dyn>>, _u: &[f64]) -> DVector<DualVec64<Dyn>> {
        let n = self.n;
        let re: Vec<f64> = x.iter().map(|v| v.re).collect();
        let ok = self.eval_g(t, &re) && self.eval_jac(t, &re);
        let z = self.z.borrow();
        let nz = z.0.len();
        let eps: Vec<Option<DVector<f64>>> = x.iter().map(|v| v.eps.0.clone()).collect();
        let width = eps.iter().flatten().map(|e| e.len()).next();
        DVector::from_fn(n, |i, _| {
            let value = if ok { z.1[i] } else { f64::NAN };
            let d = width.map(|w| {
                DVector::from_fn(w, |k, _| {
                    (0..n)
                        .map(|j| eps[j].as_ref().map_or(0.0, |e| z.2[i + nz * j] * e[k]))
                        .sum::<f64>()
                })
            });
            DualVec64::new(value, d.map_or_else(Derivative::none, Derivative::some))
        })
    }
    fn n_params(&self) -> usize {
        self.params.len()
    }
    fn params(&self) -> &[f64] {
        &self.params
    }
    fn tangent(&self, t: f64, x: &DVector<f64>, _u: &[f64], s: &[f64], m: usize, ds: &mut [f64]) {
        let (n, np) = (self.n, self.params.len());
        if m < np || m > n + np || !self.eval_jac(t, x.as_slice()) {
            ds.fill(f64::NAN);
            return;
        }
        let z = self.z.borrow();
        let nz = z.0.len();
        // the last n_p columns of S are the parameters'
        for k in 0..m {
            for i in 0..n {
                let mut v = (0..n).map(|j| z.2[i + nz * j] * s[j + n * k]).sum::<f64>();
                if k + np >= m {
                    v += z.2[i + nz * (n + k + np - m)];
                }
                ds[i + n * k] = v;
            }
        }
    }
}

/// Forward sensitivities of a traced model: `model` traces `g(t, (x, p)) = (f, 0)` over
/// `n + len(params)` states. Returns `t`, `y` `(n, K)`, `s` `(K, n, m)` row-major and `m`.
#[pyfunction]
#[pyo3(signature = (model, n, params, t0, t1, y0, method, rtol, atol, first_step, max_step, fixed_step, t_eval, max_steps, error_control, wrt_params))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sensitivities<'py>(
    py: Python<'py>,
    model: Bound<'py, Model>,
    n: usize,
    params: Vec<f64>,
    t0: f64,
    t1: f64,
    y0: Vec<f64>,
    method: &str,
    rtol: f64,
    atol: f64,
    first_step: Option<f64>,
    max_step: f64,
    fixed_step: Option<f64>,
    t_eval: Option<Vec<f64>>,
    max_steps: usize,
    error_control: bool,
    wrt_params: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let mdl = model.get();
    let np = params.len();
    if mdl.n != n + np || y0.len() != n {
        return Err(errors::invalid(
            py,
            "y0",
            format!("{} values for a model of {n} states and {np} parameters", y0.len()),
        ));
    }
    finite(py, &y0, "y0")?;
    finite(py, &params, "params")?;
    let mut opts = Options::default()
        .rtol(rtol)
        .atol(atol)
        .h_max(max_step)
        .max_steps(max_steps);
    if let Some(h) = fixed_step {
        opts = opts.fixed(h);
    } else if let Some(h) = first_step {
        opts = opts.h0(h);
    }
    if method == "Euler" && fixed_step.is_none() {
        return Err(errors::invalid(
            py,
            "fixed_step",
            "method=\"Euler\" takes fixed steps: give fixed_step=h".into(),
        ));
    }
    if let Some(ts) = t_eval {
        opts = opts.save(Save::At(ts));
    }
    let sens = SensitivityOptions::default()
        .error_control(error_control)
        .wrt(if wrt_params { Wrt::Params } else { Wrt::All });
    let result = py.detach(|| {
        let sys = ParamSystem::new(mdl, n, &params);
        let p = Problem::new(&sys, DVector::from_vec(y0), (t0, t1));
        match method {
            "RK45" => sensitivity::solve(&p, Rk45, &opts, &sens),
            "BDF" => sensitivity::solve(&p, Bdf::default(), &opts, &sens),
            "Rodas5P" => sensitivity::solve(&p, Rodas5P, &opts, &sens),
            "ImplicitEuler" => sensitivity::solve(&p, ImplicitEuler::default(), &opts, &sens),
            "Euler" => sensitivity::solve(&p, Euler, &opts, &sens),
            "Auto" => sensitivity::solve(&p, Auto::default(), &opts, &sens),
            other => Err(reckon::Error::invalid(
                "method",
                format!("{other:?} is not one of RK45, BDF, Rodas5P, Auto, ImplicitEuler, Euler"),
            )),
        }
    });
    let sol = result.map_err(|e| errors::to_py(py, &e))?;
    let k = sol.t.len();
    let m = if wrt_params { np } else { n + np };
    let mut y = vec![0.0; n * k];
    let mut s = vec![0.0; k * n * m];
    for (j, x) in sol.x.iter().enumerate() {
        for i in 0..n {
            y[i * k + j] = x[i];
        }
        let sj = sol.s(j);
        for i in 0..n {
            for c in 0..m {
                s[(j * n + i) * m + c] = sj[(i, c)];
            }
        }
    }
    let out = PyDict::new(py);
    out.set_item("t", PyArray1::from_slice(py, &sol.t))?;
    out.set_item("y", PyArray1::from_vec(py, y).reshape([n, k])?)?;
    out.set_item("s", PyArray1::from_vec(py, s).reshape([k, n, m])?)?;
    out.set_item("stats", stats_dict(py, &sol.stats)?)?;
    out.set_item("method", sol.method)?;
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// calibration

fn estimate_dict<'py>(py: Python<'py>, e: &Estimate) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let k = e.value.len();
    d.set_item("names", e.names.clone())?;
    d.set_item("value", PyArray1::from_slice(py, &e.value))?;
    let cov: Vec<f64> = (0..k * k).map(|i| e.covariance[(i / k, i % k)]).collect();
    d.set_item("covariance", PyArray1::from_vec(py, cov).reshape([k, k])?)?;
    d.set_item("residuals", PyArray1::from_slice(py, &e.residuals))?;
    d.set_item("dof", e.dof)?;
    d.set_item("sigma2", e.sigma2)?;
    Ok(d)
}

/// Least-squares fit of the parameters of a traced model (see `ParamSystem`) to observed
/// state components.
#[pyfunction]
#[pyo3(signature = (model, n, p0, t0, y0, t_obs, y_obs, components, sigma, angles, method, rtol, atol, max_iters, tol, max_condition))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn least_squares<'py>(
    py: Python<'py>,
    model: Bound<'py, Model>,
    n: usize,
    p0: Vec<f64>,
    t0: f64,
    y0: Vec<f64>,
    t_obs: Vec<f64>,
    y_obs: PyReadonlyArray1<'py, f64>,
    components: Vec<usize>,
    sigma: Vec<f64>,
    angles: Vec<usize>,
    method: &str,
    rtol: f64,
    atol: f64,
    max_iters: u64,
    tol: f64,
    max_condition: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let mdl = model.get();
    let np = p0.len();
    if np == 0 {
        return Err(errors::invalid(py, "p0", "no parameters to fit".into()));
    }
    if mdl.n != n + np || y0.len() != n {
        return Err(errors::invalid(
            py,
            "y0",
            format!("{} values for a model of {n} states and {np} parameters", y0.len()),
        ));
    }
    finite(py, &y0, "y0")?;
    finite(py, &p0, "p0")?;
    let yo = slice(py, &y_obs, "y_obs")?;
    let nc = components.len();
    if nc == 0 || yo.len() != t_obs.len() * nc {
        return Err(errors::invalid(
            py,
            "y_obs",
            format!("{} values for {} times of {nc} components", yo.len(), t_obs.len()),
        ));
    }
    let obs = lsq::Observations {
        t: t_obs.clone(),
        y: (0..t_obs.len()).map(|k| yo[k * nc..(k + 1) * nc].to_vec()).collect(),
        components,
        sigma,
        angles,
    };
    let lo = lsq::LsqOptions {
        max_iters,
        tol,
        max_condition,
        ..Default::default()
    };
    let opts = Options::default().rtol(rtol).atol(atol).max_steps(10_000_000);
    let controls = Controls::new(vec![t0], vec![vec![]]).map_err(|e| errors::to_py(py, &e))?;
    let x0 = DVector::from_vec(y0);
    let result = py.detach(|| {
        let base = ParamSystem::new(mdl, n, &p0);
        let build = |p: &[f64]| base.with_params(p);
        match method {
            "RK45" => lsq::fit(&build, &p0, &x0, t0, &controls, &obs, Rk45, &opts, &lo),
            "BDF" => lsq::fit(&build, &p0, &x0, t0, &controls, &obs, Bdf::default(), &opts, &lo),
            "Rodas5P" => lsq::fit(&build, &p0, &x0, t0, &controls, &obs, Rodas5P, &opts, &lo),
            other => Err(reckon::Error::invalid(
                "method",
                format!("{other:?} is not one of RK45, BDF, Rodas5P"),
            )),
        }
    });
    let fit = result.map_err(|e| errors::to_py(py, &e))?;
    let d = estimate_dict(py, &fit.estimate)?;
    d.set_item("iterations", fit.iterations)?;
    d.set_item("condition", fit.condition)?;
    Ok(d)
}

/// UMBmark from return errors `cw` and `ccw` (flat `(k, 2)` row-major).
#[pyfunction]
pub(crate) fn umbmark_fit<'py>(
    py: Python<'py>,
    cw: PyReadonlyArray1<'py, f64>,
    ccw: PyReadonlyArray1<'py, f64>,
    side: f64,
    wheelbase: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let pairs = |a: &[f64]| -> Vec<Vector2<f64>> { a.chunks_exact(2).map(|c| Vector2::new(c[0], c[1])).collect() };
    let (cw, ccw) = (pairs(slice(py, &cw, "cw")?), pairs(slice(py, &ccw, "ccw")?));
    let fit = umbmark::calibrate(&cw, &ccw, side, wheelbase).map_err(|e| errors::to_py(py, &e))?;
    let d = estimate_dict(py, &fit.estimate)?;
    d.set_item("e_d", fit.e_d())?;
    d.set_item("e_b", fit.e_b())?;
    d.set_item("alpha", fit.alpha)?;
    d.set_item("beta", fit.beta)?;
    d.set_item("radius", fit.radius)?;
    d.set_item("cg_cw", PyArray1::from_slice(py, fit.cg_cw.as_slice()))?;
    d.set_item("cg_ccw", PyArray1::from_slice(py, fit.cg_ccw.as_slice()))?;
    d.set_item("e_max_syst", fit.e_max_syst())?;
    let (dl, dr) = fit.wheel_diameters(1.0);
    d.set_item("diameter_factors", (dl, dr))?;
    Ok(d)
}

/// Censi et al.'s calibration: `wheels` flat `(Σ counts, 2)`, `counts[k]` sub-samples of
/// interval `k`, `sensor` flat `(K, 3)`.
#[pyfunction]
pub(crate) fn censi_fit<'py>(
    py: Python<'py>,
    wheels: PyReadonlyArray1<'py, f64>,
    counts: Vec<usize>,
    sensor: PyReadonlyArray1<'py, f64>,
    trim_fraction: f64,
    trim_rounds: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let (w, s) = (slice(py, &wheels, "wheels")?, slice(py, &sensor, "sensor")?);
    if s.len() != 3 * counts.len() || w.len() != 2 * counts.iter().sum::<usize>() {
        return Err(errors::invalid(
            py,
            "intervals",
            "one (Δφ_L, Δφ_R) row per sub-sample and one (s_x, s_y, s_θ) row per interval are needed".into(),
        ));
    }
    if !(trim_fraction.is_finite() && (0.0..0.5).contains(&trim_fraction)) {
        return Err(errors::invalid(
            py,
            "trim",
            format!("the fraction must be in [0, 0.5), got {trim_fraction}"),
        ));
    }
    let mut at = 0;
    let data: Vec<censi::Interval> = counts
        .iter()
        .enumerate()
        .map(|(k, &c)| {
            let wheels = (at..at + c).map(|i| [w[2 * i], w[2 * i + 1]]).collect();
            at += c;
            censi::Interval {
                wheels,
                sensor: Vector3::new(s[3 * k], s[3 * k + 1], s[3 * k + 2]),
            }
        })
        .collect();
    let trim = censi::Trim {
        fraction: trim_fraction,
        rounds: trim_rounds,
    };
    let fit = py
        .detach(|| censi::calibrate(&data, trim))
        .map_err(|e| errors::to_py(py, &e))?;
    let d = estimate_dict(py, &fit.estimate)?;
    let p = fit.params;
    d.set_item("r_l", p.r_l)?;
    d.set_item("r_r", p.r_r)?;
    d.set_item("b", p.b)?;
    d.set_item("sensor", PyArray1::from_slice(py, p.sensor.as_slice()))?;
    d.set_item("kept", fit.kept)?;
    d.set_item("sigma2_theta", fit.sigma2_theta)?;
    d.set_item("sigma2_xy", fit.sigma2_xy)?;
    Ok(d)
}

/// `lsq::fit_encoder_log`: a differential drive's wheel radii and wheelbase from encoder
/// increments `(t, left, right)` and measured poses (`poses` flat `(3, K)` row-major).
#[pyfunction]
#[pyo3(signature = (t, left, right, pose_t, poses, wheel_diameter, wheel_separation, pulses_per_rev, sigma))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn encoder_least_squares<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    left: PyReadonlyArray1<'py, f64>,
    right: PyReadonlyArray1<'py, f64>,
    pose_t: PyReadonlyArray1<'py, f64>,
    poses: PyReadonlyArray1<'py, f64>,
    wheel_diameter: f64,
    wheel_separation: f64,
    pulses_per_rev: f64,
    sigma: [f64; 3],
) -> PyResult<Bound<'py, PyDict>> {
    let robot = DiffDrive::new(wheel_diameter, wheel_separation, pulses_per_rev).map_err(|e| errors::to_py(py, &e))?;
    let (t, l, r) = (
        slice(py, &t, "t")?,
        slice(py, &left, "left")?,
        slice(py, &right, "right")?,
    );
    let (pt, ps) = (slice(py, &pose_t, "pose_t")?, slice(py, &poses, "poses")?);
    if l.len() != t.len() || r.len() != t.len() {
        return Err(errors::invalid(
            py,
            "samples",
            format!(
                "t, left and right need the same length, got {}, {}, {}",
                t.len(),
                l.len(),
                r.len()
            ),
        ));
    }
    if ps.len() != 3 * pt.len() {
        return Err(errors::invalid(
            py,
            "poses",
            format!("shape (3, {}) is needed, got {} values", pt.len(), ps.len()),
        ));
    }
    finite(py, t, "t")?;
    finite(py, l, "left")?;
    finite(py, r, "right")?;
    finite(py, pt, "pose_t")?;
    finite(py, ps, "poses")?;
    let k = pt.len();
    let samples: Vec<(f64, f64, f64)> = (0..t.len()).map(|i| (t[i], l[i], r[i])).collect();
    let measured: Vec<(f64, Vector3<f64>)> = (0..k)
        .map(|j| (pt[j], Vector3::new(ps[j], ps[k + j], ps[2 * k + j])))
        .collect();
    let fit = py
        .detach(|| lsq::fit_encoder_log(&samples, &robot, &measured, sigma))
        .map_err(|e| errors::to_py(py, &e))?;
    let d = estimate_dict(py, &fit.estimate)?;
    d.set_item("iterations", fit.iterations)?;
    d.set_item("condition", fit.condition)?;
    Ok(d)
}

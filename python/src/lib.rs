//! `reckon._reckon`: the native half of the Python package.
//!
//! [`solve`] integrates `y' = fun(t, y)` with one of reckon's methods, calling the
//! Python function back for every right-hand side (the callback mode): a [`PyModel`]
//! is a `System<Dyn>` whose `rhs` calls `fun`, whose Jacobian is the user's `jac`
//! (callable or constant) or forward differences of `fun` done here, and whose events
//! call the user's event functions. The argument handling with scipy's names and the
//! result object live in `reckon/__init__.py`.
//!
//! A Python exception raised by a user function (or a wrong-length return, or a
//! non-finite one inside a difference quotient or from `jac`) is kept in the [`Host`]'s
//! `fault`; from then on every call returns NaN without calling Python, so the library
//! stops at once with a typed error, and [`solve`] raises the kept exception instead of
//! that error. A non-finite `fun(t, y)` at a trial state is handed to the library as it
//! is, which rejects the step and retries shorter, as for a traced model; should the run
//! end on it, [`solve`] raises the last such return as `reckon.NonFinite`.

mod ensemble;
mod errors;
mod rest;
mod traced;

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use reckon::linalg::LuDim;
use reckon::methods::Method;
use reckon::methods::{Auto, Bdf, Euler, ExponentialEuler, ImplicitEuler, Rk45, Rodas5P};
use reckon::nalgebra::allocator::Allocator;
use reckon::nalgebra::{Const, DMatrix, DVector, DefaultAllocator, Dim, Dyn, OVector};
use reckon::{Direction, Event, Options, Problem, Save, Solution, System};
use std::cell::{Cell, RefCell};

/// The user's Jacobian: a callable `jac(t, y)`, a constant matrix, or none (forward
/// differences of `fun`, [`Differences`]).
enum Jac<'py> {
    Callable(Bound<'py, PyAny>),
    Constant(DMatrix<f64>),
    Differences(Differences),
}

/// scipy's `num_jac` (`scipy/integrate/_ivp/common.py`, as its BDF and Radau use it):
/// column `j` of `∂f/∂y` is `(f(y + h_j·e_j) − f(y))/h_j` with
/// `h_j = factor_j·sign(f_j)·max(threshold_j, |y_j|)` (`threshold` = `atol`), and each
/// column's `factor_j` (from `√ε`) adapted across calls: a difference at the roundoff
/// level of `f` (below `ε^0.875` of it) is retried with a 10× longer step that is kept
/// if it resolves more, below `ε^0.75` the next call's factor grows 10×, above `ε^0.25` it
/// shrinks 10×, never below `1000·ε` (nor, here, above 1: `h_j` at most the component's
/// scale). A fixed `√ε·max(|y_j|, 1)` step is far too long for a component that lives at
/// `atol`'s size: on Robertson's `y₂ ~ 10⁻¹²` it made `∂f₃/∂y₂` 0.45 instead of ~10⁻⁵,
/// and Rodas5P's answer at `t = 4·10¹⁰` 80× off with status 0.
struct Differences {
    threshold: Vec<f64>,
    factor: RefCell<Vec<f64>>,
}

impl Differences {
    fn new(atol: &[f64], n: usize) -> Self {
        // `atol` per component or one for all (checked with the options; 0 if absent)
        let threshold = (0..n)
            .map(|i| atol.get(if atol.len() == n { i } else { 0 }).copied().unwrap_or(0.0))
            .collect();
        Differences {
            threshold,
            factor: RefCell::new(vec![f64::EPSILON.sqrt(); n]),
        }
    }
}

/// The component of `d = f₁ − f₀` largest in magnitude: `(|d_i|, max(|f₀_i|, |f₁_i|))`.
fn largest_difference(f0: &[f64], f1: &[f64]) -> (f64, f64) {
    let mut best = (0.0, 0.0);
    let mut first = true;
    for (&a, &b) in f0.iter().zip(f1) {
        let d = (b - a).abs();
        if first || d > best.0 {
            best = (d, a.abs().max(b.abs()));
            first = false;
        }
    }
    best
}

/// `y' = fun(t, y)` with `fun` a Python callable: reckon's `System` for a `Dyn` state.
struct PyModel<'py> {
    host: Host<'py>,
    fun: Bound<'py, PyAny>,
    jac: Jac<'py>,
    n: usize,
    /// Calls of `fun` (the library's counted calls and the difference quotients).
    fun_calls: Cell<u64>,
    /// Calls of a callable `jac`.
    jac_calls: Cell<u64>,
    /// The last non-finite return of `fun` at a trial state, as `reckon.NonFinite`.
    non_finite: RefCell<Option<PyErr>>,
}

/// What the Python callbacks of one solve share: the interpreter, `numpy.asarray` (for
/// returns that are not float64 arrays) and the first failure of a user function.
struct Host<'py> {
    py: Python<'py>,
    asarray: Bound<'py, PyAny>,
    /// The first failure of a user function; once set, every call returns NaN.
    fault: RefCell<Option<PyErr>>,
}

impl<'py> Host<'py> {
    fn new(py: Python<'py>) -> PyResult<Self> {
        Ok(Host {
            py,
            asarray: py.import("numpy")?.getattr("asarray")?,
            fault: RefCell::new(None),
        })
    }

    fn failed(&self) -> bool {
        self.fault.borrow().is_some()
    }

    fn keep(&self, err: PyErr) {
        let mut f = self.fault.borrow_mut();
        if f.is_none() {
            *f = Some(err);
        }
    }
}

impl<'py> PyModel<'py> {
    fn failed(&self) -> bool {
        self.host.failed()
    }

    fn keep(&self, err: PyErr) {
        self.host.keep(err)
    }

    /// `out ← fun(t, x)` with finite values, or the error that stops the run.
    fn call_fun(&self, t: f64, x: &[f64], out: &mut [f64]) -> PyResult<()> {
        self.call_fun_values(t, x, out)?;
        check_finite(self.host.py, out, t, "fun")
    }

    /// `out ← fun(t, x)`, finite or not; the error of a call that failed.
    fn call_fun_values(&self, t: f64, x: &[f64], out: &mut [f64]) -> PyResult<()> {
        self.fun_calls.set(self.fun_calls.get() + 1);
        let y = PyArray1::from_slice(self.host.py, x);
        let r = self.fun.call1((t, y))?;
        self.read_vector(&r, out, t, "fun")
    }

    /// Copy a returned vector of `n` values into `out`, refusing another shape (finite
    /// or not: the caller decides).
    fn read_vector(&self, r: &Bound<'py, PyAny>, out: &mut [f64], t: f64, who: &str) -> PyResult<()> {
        let arr = match r.cast::<PyArray1<f64>>() {
            Ok(a) => a.clone(),
            Err(_) if r.is_none() => {
                // numpy would read it as one NaN
                return Err(pyo3::exceptions::PyValueError::new_err(format!(
                    "{who}(t, y) returned None (a missing return?), expected {} values at t = {t}",
                    self.n
                )));
            }
            Err(_) => {
                let a = self.host.asarray.call1((r, "float64")).map_err(|e| {
                    pyo3::exceptions::PyValueError::new_err(format!(
                        "{who}(t, y) returned {} that is not an array of floats at t = {t}: {e}",
                        r.get_type().name().map(|n| n.to_string()).unwrap_or_default()
                    ))
                })?;
                if a.cast::<numpy::PyUntypedArray>()?.ndim() == 0 && self.n == 1 {
                    out[0] = a.extract::<f64>()?;
                    return Ok(());
                }
                match a.cast::<PyArray1<f64>>() {
                    Ok(a) => a.clone(),
                    Err(_) => {
                        let shape = a.getattr("shape")?;
                        return Err(pyo3::exceptions::PyValueError::new_err(format!(
                            "{who}(t, y) returned an array of shape {shape}, expected ({},) at t = {t}",
                            self.n
                        )));
                    }
                }
            }
        };
        if arr.len() != self.n {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "{who}(t, y) returned {} values, expected {} (the length of y0) at t = {t}",
                arr.len(),
                self.n
            )));
        }
        // SAFETY: the GIL is held and no Python code runs while the slice is read.
        match unsafe { arr.as_slice() } {
            Ok(s) => out.copy_from_slice(s),
            Err(_) => {
                // a strided view: element by element
                let ro = arr.readonly();
                for (o, v) in out.iter_mut().zip(ro.as_array().iter()) {
                    *o = *v;
                }
            }
        }
        Ok(())
    }

    fn rhs_into(&self, t: f64, x: &[f64], out: &mut [f64]) {
        if !self.failed() {
            match self.call_fun_values(t, x, out) {
                Ok(()) => {
                    // the library rejects the trial and retries shorter; kept in case the
                    // run ends on it (not when `x` itself was non-finite: a stage built
                    // from an earlier non-finite `f`, which is the one to report)
                    if x.iter().all(|v| v.is_finite())
                        && let Err(e) = check_finite(self.host.py, out, t, "fun")
                    {
                        *self.non_finite.borrow_mut() = Some(e);
                    }
                }
                Err(e) => self.keep(e),
            }
        }
        if self.failed() {
            out.fill(f64::NAN);
        }
    }

    fn jacobian_into(&self, t: f64, x: &DVector<f64>, jac: &mut DMatrix<f64>) -> PyResult<()> {
        match &self.jac {
            Jac::Constant(m) => jac.copy_from(m),
            Jac::Callable(j) => {
                self.jac_calls.set(self.jac_calls.get() + 1);
                let y = PyArray1::from_slice(self.host.py, x.as_slice());
                let r = j.call1((t, y))?;
                let m = read_matrix(&r, &self.host.asarray, self.n, t)?;
                jac.copy_from(&m);
            }
            Jac::Differences(d) => {
                const EPS: f64 = f64::EPSILON;
                let (reject, small, big) = (EPS.powf(0.875), EPS.powf(0.75), EPS.powf(0.25));
                let n = self.n;
                let mut factor = d.factor.borrow_mut();
                let (mut f0, mut f1, mut f2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
                self.call_fun(t, x.as_slice(), &mut f0)?;
                let mut xp = x.as_slice().to_vec();
                for j in 0..n {
                    let xj = xp[j];
                    let sign = if f0[j] >= 0.0 { 1.0 } else { -1.0 };
                    let size = d.threshold[j].max(xj.abs());
                    let scale = sign * if size > 0.0 { size } else { 1.0 };
                    let step = |fac: f64| (xj + fac * scale) - xj;
                    let mut h = step(factor[j]);
                    while h == 0.0 && factor[j] < 1.0 {
                        factor[j] = (factor[j] * 10.0).min(1.0);
                        h = step(factor[j]);
                    }
                    xp[j] = xj + h;
                    self.call_fun(t, &xp, &mut f1)?;
                    let (mut max_diff, mut size_f) = largest_difference(&f0, &f1);
                    if max_diff < reject * size_f && factor[j] < 1.0 {
                        // at f's roundoff: try a 10× longer step, kept if it resolves more
                        let fac = (factor[j] * 10.0).min(1.0);
                        let h_new = step(fac);
                        xp[j] = xj + h_new;
                        self.call_fun(t, &xp, &mut f2)?;
                        let (diff_new, size_new) = largest_difference(&f0, &f2);
                        if max_diff * size_new < diff_new * size_f {
                            factor[j] = fac;
                            h = h_new;
                            (max_diff, size_f) = (diff_new, size_new);
                            std::mem::swap(&mut f1, &mut f2);
                        }
                    }
                    xp[j] = xj;
                    for i in 0..n {
                        jac[(i, j)] = (f1[i] - f0[i]) / h;
                    }
                    if max_diff < small * size_f {
                        factor[j] *= 10.0;
                    }
                    if max_diff > big * size_f {
                        factor[j] *= 0.1;
                    }
                    factor[j] = factor[j].clamp(1e3 * EPS, 1.0);
                }
            }
        }
        Ok(())
    }
}

/// An event function's return as a number: a float, or anything numpy reads as one value
/// (a 0-d or 1-element array).
fn event_value(r: &Bound<'_, PyAny>, asarray: &Bound<'_, PyAny>, t: f64) -> PyResult<f64> {
    if let Ok(v) = r.extract::<f64>() {
        return Ok(v);
    }
    let a = asarray.call1((r, "float64"))?;
    if a.getattr("size")?.extract::<usize>()? == 1 {
        return a.call_method0("item")?.extract();
    }
    Err(pyo3::exceptions::PyValueError::new_err(format!(
        "an event function returned an array of shape {}, expected one number at t = {t}",
        a.getattr("shape")?
    )))
}

/// Refuse NaN and ±∞ in what `who` returned: `reckon.NonFinite` naming the component.
fn check_finite(py: Python<'_>, v: &[f64], t: f64, who: &str) -> PyResult<()> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(errors::non_finite(
            py,
            format!("{who}(t, y) returned {} in component {i} at t = {t}", v[i]),
            t,
            if who == "jac" { "Jacobian" } else { "derivative" },
            i,
        )),
    }
}

/// An `(n, n)` matrix from a returned array-like (a scipy sparse matrix is densified).
fn read_matrix(r: &Bound<'_, PyAny>, asarray: &Bound<'_, PyAny>, n: usize, t: f64) -> PyResult<DMatrix<f64>> {
    let r = if r.hasattr("toarray")? {
        r.call_method0("toarray")?
    } else {
        r.clone()
    };
    let a = asarray.call1((r, "float64"))?;
    let bad = || {
        let shape = a.getattr("shape").map(|s| s.to_string()).unwrap_or_default();
        pyo3::exceptions::PyValueError::new_err(format!(
            "jac returned an array of shape {shape}, expected ({n}, {n}) at t = {t}"
        ))
    };
    let Ok(a2) = a.cast::<numpy::PyArray2<f64>>() else {
        if n == 1 && a.cast::<numpy::PyUntypedArray>()?.ndim() <= 1 {
            let v: Vec<f64> = a.call_method0("ravel")?.extract()?;
            if v.len() == 1 {
                check_finite(a.py(), &v, t, "jac")?;
                return Ok(DMatrix::from_element(1, 1, v[0]));
            }
        }
        return Err(bad());
    };
    if a2.shape() != [n, n] {
        return Err(bad());
    }
    let ro = a2.readonly();
    let view = ro.as_array();
    let m = DMatrix::from_fn(n, n, |i, j| view[[i, j]]);
    check_finite(a.py(), m.as_slice(), t, "jac")?;
    Ok(m)
}

impl System<Dyn> for PyModel<'_> {
    fn rhs(&self, t: f64, x: &DVector<f64>, _u: &[f64], dx: &mut DVector<f64>) {
        self.rhs_into(t, x.as_slice(), dx.as_mut_slice());
    }
    fn jacobian(&self, t: f64, x: &DVector<f64>, _u: &[f64], jac: &mut DMatrix<f64>) {
        if !self.failed()
            && let Err(e) = self.jacobian_into(t, x, jac)
        {
            self.keep(e);
        }
        if self.failed() {
            jac.fill(f64::NAN);
        }
    }
}

/// One step's dense polynomial `y(t₀ + θh) = Σ_j c_j θʲ` (`c` is `k × n`, row `j` = `c_j`).
struct Segment {
    t0: f64,
    h: f64,
    t1: f64,
    c: Vec<f64>,
}

/// The continuous solution of a `solve_ivp(..., dense_output=True)` run, as scipy's
/// `OdeSolution`: `sol(t)` is `y(t)` of shape `(n,)` for a scalar `t` and `(n, m)` for
/// `m` times, from the method's dense output on the step holding `t` (outside
/// `[t_min, t_max]` the first or last step's polynomial is extrapolated, as scipy does).
#[pyclass(module = "reckon", frozen)]
struct DenseOutput {
    n: usize,
    segments: Vec<Segment>,
    #[pyo3(get)]
    t_min: f64,
    #[pyo3(get)]
    t_max: f64,
    forward: bool,
}

impl DenseOutput {
    fn from_solution<D: Dim>(sol: &Solution<D>, n: usize) -> Self
    where
        DefaultAllocator: Allocator<D>,
    {
        let segments: Vec<Segment> = sol
            .dense_segments()
            .iter()
            .map(|s| Segment {
                t0: s.t0,
                h: s.h,
                t1: s.t1,
                c: s.c.iter().flat_map(|v| v.iter().copied()).collect(),
            })
            .collect();
        let (a, b) = (sol.t[0], *sol.t.last().unwrap_or(&sol.t[0]));
        DenseOutput {
            n,
            forward: segments.first().is_none_or(|s| s.h > 0.0),
            segments,
            t_min: a.min(b),
            t_max: a.max(b),
        }
    }

    fn eval_into(&self, t: f64, out: &mut [f64]) {
        let k = if self.forward {
            self.segments.partition_point(|s| s.t1 < t)
        } else {
            self.segments.partition_point(|s| s.t1 > t)
        };
        let s = &self.segments[k.min(self.segments.len() - 1)];
        let theta = (t - s.t0) / s.h;
        let m = s.c.len() / self.n;
        for (i, o) in out.iter_mut().enumerate() {
            let mut y = s.c[(m - 1) * self.n + i];
            for j in (0..m - 1).rev() {
                y = y * theta + s.c[j * self.n + i];
            }
            *o = y;
        }
    }
}

#[pymethods]
impl DenseOutput {
    /// Pickling (joblib, multiprocessing): the polynomials as plain data, rebuilt by
    /// [`_restore`](Self::_restore).
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let d = slf.get();
        let segments: Vec<(f64, f64, f64, Vec<f64>)> =
            d.segments.iter().map(|s| (s.t0, s.h, s.t1, s.c.clone())).collect();
        let args = (d.n, d.t_min, d.t_max, d.forward, segments).into_pyobject(py)?;
        Ok((slf.get_type().getattr("_restore")?, args))
    }

    /// The inverse of `__reduce__`, checking what it is given (pickles are data from
    /// outside): `n ≥ 1`, each step's coefficients a non-empty multiple of `n`, every
    /// value finite, the steps non-zero, in the direction of `forward` and in order.
    #[staticmethod]
    fn _restore(
        py: Python<'_>,
        n: usize,
        t_min: f64,
        t_max: f64,
        forward: bool,
        segments: Vec<(f64, f64, f64, Vec<f64>)>,
    ) -> PyResult<Self> {
        let bad = |reason: &str| Err(errors::invalid(py, "DenseOutput", reason.into()));
        if n == 0 || !(t_min.is_finite() && t_max.is_finite() && t_min <= t_max) {
            return bad("n ≥ 1 and finite t_min ≤ t_max are needed");
        }
        let mut last: Option<f64> = None;
        let mut out = Vec::with_capacity(segments.len());
        for (t0, h, t1, c) in segments {
            let ordered = last.is_none_or(|l| if forward { t1 >= l } else { t1 <= l });
            if c.is_empty()
                || c.len() % n != 0
                || !(t0.is_finite() && h.is_finite() && t1.is_finite())
                || h == 0.0
                || (h > 0.0) != forward
                || !ordered
                || c.iter().any(|v| !v.is_finite())
            {
                return bad("a step's polynomial is not one DenseOutput writes");
            }
            last = Some(t1);
            out.push(Segment { t0, h, t1, c });
        }
        Ok(DenseOutput {
            n,
            segments: out,
            t_min,
            t_max,
            forward,
        })
    }

    fn __call__<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        if self.segments.is_empty() {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "the run took no step, so there is no dense output to evaluate",
            ));
        }
        let n = self.n;
        if let Ok(ts) = t.extract::<f64>() {
            let mut out = vec![0.0; n];
            self.eval_into(ts, &mut out);
            return Ok(PyArray1::from_vec(py, out).into_any());
        }
        let ts: Vec<f64> = py
            .import("numpy")?
            .call_method1("asarray", (t, "float64"))?
            .call_method0("ravel")?
            .extract()?;
        let m = ts.len();
        let mut col = vec![0.0; n];
        let mut flat = vec![0.0; n * m];
        for (j, &tj) in ts.iter().enumerate() {
            self.eval_into(tj, &mut col);
            for i in 0..n {
                flat[i * m + j] = col[i];
            }
        }
        Ok(PyArray1::from_vec(py, flat).reshape([n, m])?.into_any())
    }

    /// The step boundaries, from `t0` to where the run stopped.
    #[getter]
    fn ts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let mut ts: Vec<f64> = self.segments.iter().map(|s| s.t0).collect();
        if let Some(s) = self.segments.last() {
            ts.push(s.t1);
        }
        PyArray1::from_vec(py, ts)
    }

    /// The number of steps (polynomial pieces).
    fn __len__(&self) -> usize {
        self.segments.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "DenseOutput(t_min={}, t_max={}, {} steps, {} states)",
            self.t_min,
            self.t_max,
            self.segments.len(),
            self.n
        )
    }
}

/// The options of one solve, from `solve_ivp`'s arguments.
#[allow(clippy::too_many_arguments)]
fn options(
    py: Python<'_>,
    method: &str,
    rtol: Vec<f64>,
    atol: Vec<f64>,
    first_step: Option<f64>,
    max_step: f64,
    fixed_step: Option<f64>,
    t_eval: Option<Vec<f64>>,
    dense: bool,
    max_steps: Option<usize>,
) -> PyResult<Options> {
    if !METHODS.contains(&method) {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "unknown method {method:?}"
        )));
    }
    let tol =
        |v: Vec<f64>| -> reckon::problem::options::Tolerance { if v.len() == 1 { v[0].into() } else { v.into() } };
    let mut opts = Options::default()
        .rtol(tol(rtol))
        .atol(tol(atol))
        .h_max(max_step)
        .dense(dense);
    if let Some(m) = max_steps {
        opts = opts.max_steps(m);
    }
    match (method, fixed_step, first_step) {
        (_, Some(h), _) => opts = opts.fixed(h),
        ("Euler", None, Some(h)) => opts = opts.fixed(h),
        ("Euler", None, None) => {
            return Err(errors::invalid(
                py,
                "first_step",
                "method=\"Euler\" takes fixed steps: give the step as first_step=h (or fixed_step=h)".into(),
            ));
        }
        (_, None, Some(h)) => opts = opts.h0(h),
        _ => {}
    }
    if let Some(ts) = t_eval {
        opts = opts.save(Save::At(ts));
    }
    Ok(opts)
}

const METHODS: [&str; 7] = [
    "RK45",
    "BDF",
    "Rodas5P",
    "Auto",
    "ImplicitEuler",
    "ExponentialEuler",
    "Euler",
];

/// Solve `problem` with the method named `method` (one of [`METHODS`]).
fn run<D: LuDim, S: System<D>>(problem: Problem<'_, D, S>, method: &str, opts: &Options) -> reckon::Result<Solution<D>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    match method {
        "RK45" => problem.solve(Rk45, opts),
        "BDF" => problem.solve(Bdf::default(), opts),
        "Rodas5P" => problem.solve(Rodas5P, opts),
        "Auto" => problem.solve(Auto::default(), opts),
        "ImplicitEuler" => problem.solve(ImplicitEuler::default(), opts),
        "ExponentialEuler" => problem.solve(ExponentialEuler, opts),
        _ => problem.solve(Euler, opts),
    }
}

/// Watch the Python event functions `events` in `problem`, their failures kept in `host`.
fn with_events<'a, S: System<Dyn>>(
    mut problem: Problem<'a, Dyn, S>,
    events: &'a [(Bound<'a, PyAny>, u64, f64)],
    host: &'a Host<'a>,
) -> Problem<'a, Dyn, S> {
    for (g, terminal, direction) in events {
        let g = g.clone();
        let mut e = Event::new(move |t: f64, x: &DVector<f64>| {
            if host.failed() {
                return f64::NAN;
            }
            let y = PyArray1::from_slice(host.py, x.as_slice());
            match g.call1((t, y)).and_then(|r| event_value(&r, &host.asarray, t)) {
                Ok(v) => v,
                Err(e) => {
                    host.keep(e);
                    f64::NAN
                }
            }
        });
        e = match *direction {
            d if d > 0.0 => e.direction(Direction::Rising),
            d if d < 0.0 => e.direction(Direction::Falling),
            _ => e,
        };
        if *terminal > 0 {
            e = e.terminal_after(*terminal);
        }
        problem = problem.event(e);
    }
    problem
}

/// Integrate `y' = fun(t, y)`, `y(t0) = y0` to `t1` with `method`, calling `fun` back.
///
/// Fills `out` (the caller's `OdeResult`) with scipy's fields and reckon's (see
/// [`fill_result`]); an integration failure is `status = -1` with `error` the typed
/// exception, not raised. A user function's failure, and invalid input, are raised.
#[pyfunction]
#[pyo3(signature = (fun, t0, t1, y0, method, rtol, atol, jac, first_step, max_step, fixed_step, t_eval, dense, events, max_steps, out))]
#[allow(clippy::too_many_arguments)]
fn solve<'py>(
    py: Python<'py>,
    fun: Bound<'py, PyAny>,
    t0: f64,
    t1: f64,
    y0: Vec<f64>,
    method: &str,
    rtol: Vec<f64>,
    atol: Vec<f64>,
    jac: Option<Bound<'py, PyAny>>,
    first_step: Option<f64>,
    max_step: f64,
    fixed_step: Option<f64>,
    t_eval: Option<Vec<f64>>,
    dense: bool,
    events: Vec<(Bound<'py, PyAny>, u64, f64)>,
    max_steps: Option<usize>,
    out: Bound<'py, PyDict>,
) -> PyResult<()> {
    let n = y0.len();
    let host = Host::new(py)?;
    let jac = match jac {
        None => Jac::Differences(Differences::new(&atol, n)),
        Some(j) if j.is_callable() => Jac::Callable(j),
        Some(j) => Jac::Constant(read_matrix(&j, &host.asarray, n, t0)?),
    };
    let jac_kind = match &jac {
        Jac::Callable(_) => "jac",
        Jac::Constant(_) => "constant jac",
        Jac::Differences(_) => "finite differences",
    };
    let opts = options(
        py, method, rtol, atol, first_step, max_step, fixed_step, t_eval, dense, max_steps,
    )?;
    let model = PyModel {
        host,
        fun,
        jac,
        n,
        fun_calls: Cell::new(0),
        jac_calls: Cell::new(0),
        non_finite: RefCell::new(None),
    };
    let problem = with_events(
        Problem::new(&model, DVector::from_column_slice(&y0), (t0, t1)),
        &events,
        &model.host,
    );
    let result = run(problem, method, &opts);
    if let Some(e) = model.host.fault.borrow_mut().take() {
        return Err(e);
    }
    if let Err(reckon::Error::NonFinite {
        quantity: reckon::error::Quantity::Derivative,
        ..
    }) = &result
        && let Some(e) = model.non_finite.borrow_mut().take()
    {
        // the run ended on a non-finite `f`: the user's return, in its words
        return Err(e);
    }
    let terminal: Vec<u64> = events.iter().map(|e| e.1).collect();
    let fill = Fill {
        out: &out,
        method,
        terminal: &terminal,
        dense,
        jac_kind,
        calls: (model.fun_calls.get(), model.jac_calls.get()),
    };
    fill_result(py, fill, result, (t0, &y0))
}

/// Integrate the traced `model` as [`solve`] integrates a Python function, on its compiled
/// code: with no event function the GIL is released for the whole solve (other Python
/// threads run meanwhile); event functions are Python calls, so with them it is held.
#[pyfunction]
#[pyo3(signature = (model, t0, t1, y0, method, rtol, atol, first_step, max_step, fixed_step, t_eval, dense, events, max_steps, out))]
#[allow(clippy::too_many_arguments)]
fn solve_traced<'py>(
    py: Python<'py>,
    model: Bound<'py, traced::Model>,
    t0: f64,
    t1: f64,
    y0: Vec<f64>,
    method: &str,
    rtol: Vec<f64>,
    atol: Vec<f64>,
    first_step: Option<f64>,
    max_step: f64,
    fixed_step: Option<f64>,
    t_eval: Option<Vec<f64>>,
    dense: bool,
    events: Vec<(Bound<'py, PyAny>, u64, f64)>,
    max_steps: Option<usize>,
    out: Bound<'py, PyDict>,
) -> PyResult<()> {
    let m = model.get();
    if y0.len() != m.n {
        return Err(errors::invalid(
            py,
            "y0",
            format!("{} values for a traced model of {} states", y0.len(), m.n),
        ));
    }
    let opts = options(
        py, method, rtol, atol, first_step, max_step, fixed_step, t_eval, dense, max_steps,
    )?;
    let terminal: Vec<u64> = events.iter().map(|e| e.1).collect();
    let fill = Fill {
        out: &out,
        method,
        terminal: &terminal,
        dense,
        jac_kind: "traced",
        calls: (0, 0),
    };
    if events.is_empty() {
        // small models on fixed-size states (stack vectors, a stack LU), as a `model!`
        // model gets in Rust: 2–4× less time per solve than `Dyn` on 2 or 3 states
        macro_rules! fixed {
            ($($n:literal)*) => {
                match m.n {
                    $($n => traced_run::<Const<$n>>(py, m, &y0, (t0, t1), &opts, fill),)*
                    _ => traced_run::<Dyn>(py, m, &y0, (t0, t1), &opts, fill),
                }
            };
        }
        fixed!(1 2 3 4 5 6 7 8)
    } else {
        let host = Host::new(py)?;
        let sys = traced::TracedSystem::new(m);
        let guarded = Guarded {
            inner: &sys,
            host: &host,
        };
        let problem = with_events(
            Problem::new(&guarded, DVector::from_column_slice(&y0), (t0, t1)),
            &events,
            &host,
        );
        let result = run(problem, method, &opts);
        if let Some(e) = host.fault.borrow_mut().take() {
            return Err(e);
        }
        fill_result(py, fill, result, (t0, &y0))
    }
}

/// The traced `m` from `y0` over `span` with the GIL released, on a state of dimension
/// `D`, into `fill`'s result.
fn traced_run<D: LuDim>(
    py: Python<'_>,
    m: &traced::Model,
    y0: &[f64],
    (t0, t1): (f64, f64),
    opts: &Options,
    fill: Fill<'_, '_>,
) -> PyResult<()>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
    <DefaultAllocator as Allocator<D>>::Buffer<f64>: Send,
{
    let method = fill.method;
    let (result, interrupted) = py.detach(|| {
        let sys = traced::TracedSystem::watched(m);
        let x0 = OVector::<f64, D>::from_iterator_generic(D::from_usize(y0.len()), Const::<1>, y0.iter().copied());
        let result = run(Problem::new(&sys, x0, (t0, t1)), method, opts);
        (result, sys.interrupted())
    });
    if let Some(e) = interrupted {
        // Ctrl-C (or another signal handler that raised) stopped the run
        return Err(e);
    }
    fill_result(py, fill, result, (t0, y0))
}

/// A system that gives NaN once a Python event function has failed, so the run stops.
struct Guarded<'a, S> {
    inner: S,
    host: &'a Host<'a>,
}

impl<S: System<Dyn>> System<Dyn> for Guarded<'_, S> {
    fn rhs(&self, t: f64, x: &DVector<f64>, u: &[f64], dx: &mut DVector<f64>) {
        if self.host.failed() {
            dx.fill(f64::NAN);
        } else {
            self.inner.rhs(t, x, u, dx);
        }
    }
    fn jacobian(&self, t: f64, x: &DVector<f64>, u: &[f64], jac: &mut DMatrix<f64>) {
        self.inner.jacobian(t, x, u, jac);
    }
    fn time_derivative(&self, t: f64, x: &DVector<f64>, u: &[f64], dfdt: &mut DVector<f64>) -> bool {
        self.inner.time_derivative(t, x, u, dfdt)
    }
    fn sparse_jacobian(&self, n: usize) -> Option<Box<dyn reckon::jacobian::SparseJacobian + '_>> {
        self.inner.sparse_jacobian(n)
    }
}

/// What a run adds to the result besides the library's solution: the dict to fill (the
/// caller's `OdeResult`), the method's name as the user gave it, the event functions'
/// `terminal` counts, whether dense output was asked for, where the Jacobian came from,
/// and the Python calls of `fun` and `jac` (0 for a traced model).
struct Fill<'a, 'py> {
    out: &'a Bound<'py, PyDict>,
    method: &'a str,
    terminal: &'a [u64],
    dense: bool,
    jac_kind: &'a str,
    calls: (u64, u64),
}

/// Fill `f.out` with scipy's fields from the library's result: `t`, `y` (n × m), `sol`,
/// `t_events`/`y_events` (None without event functions), `nfev`, `njev`, `nlu`,
/// `status` (0 the end reached, 1 a terminal event, −1 a failure), `message`, `success`,
/// and reckon's `stats`, `stiffness`, `switches`, `method`, `jacobian`, `error` (the
/// typed exception of a failure, not raised; `t` and `y` then hold the initial point).
/// Invalid input and other errors are raised.
fn fill_result<D: Dim>(
    py: Python<'_>,
    f: Fill<'_, '_>,
    result: reckon::Result<Solution<D>>,
    (t0, y0): (f64, &[f64]),
) -> PyResult<()>
where
    DefaultAllocator: Allocator<D>,
{
    let out = f.out;
    let n = y0.len();
    let stats = PyDict::new(py);
    let (fun_calls, jac_calls) = f.calls;
    let events = !f.terminal.is_empty();
    out.set_item(intern!(py, "method"), f.method)?;
    let sol = match result {
        Ok(sol) => sol,
        Err(e) if errors::is_failure(&e) => {
            let error = errors::to_py(py, &e);
            out.set_item(intern!(py, "t"), PyArray1::from_vec(py, vec![t0]))?;
            let y = numpy::ndarray::Array2::from_shape_vec((n, 1), y0.to_vec()).expect("n values");
            out.set_item(intern!(py, "y"), PyArray2::from_owned_array(py, y))?;
            out.set_item(intern!(py, "sol"), py.None())?;
            if events {
                // no hits are kept from a failed run
                let empty = || PyArray1::<f64>::zeros(py, [0], false);
                let none: Vec<_> = f.terminal.iter().map(|_| empty()).collect();
                out.set_item(intern!(py, "t_events"), PyList::new(py, &none)?)?;
                out.set_item(intern!(py, "y_events"), PyList::new(py, &none)?)?;
            } else {
                out.set_item(intern!(py, "t_events"), py.None())?;
                out.set_item(intern!(py, "y_events"), py.None())?;
            }
            out.set_item(intern!(py, "nfev"), fun_calls)?;
            out.set_item(intern!(py, "njev"), jac_calls)?;
            out.set_item(intern!(py, "nlu"), 0)?;
            out.set_item(intern!(py, "status"), -1)?;
            out.set_item(intern!(py, "message"), error.value(py).str()?)?;
            out.set_item(intern!(py, "success"), false)?;
            stats.set_item(intern!(py, "fun_calls"), fun_calls)?;
            stats.set_item(intern!(py, "jac_calls"), jac_calls)?;
            out.set_item(intern!(py, "stats"), stats)?;
            out.set_item(intern!(py, "stiffness"), py.None())?;
            out.set_item(intern!(py, "switches"), PyList::empty(py))?;
            out.set_item(intern!(py, "jacobian"), (jac_calls > 0).then_some(f.jac_kind))?;
            out.set_item(intern!(py, "error"), error)?;
            return Ok(());
        }
        Err(e) => return Err(errors::to_py(py, &e)),
    };
    let m = sol.t.len();
    let mut flat = vec![0.0; n * m];
    for (j, x) in sol.x.iter().enumerate() {
        for i in 0..n {
            flat[i * m + j] = x[i];
        }
    }
    out.set_item(intern!(py, "t"), PyArray1::from_slice(py, &sol.t))?;
    let y = numpy::ndarray::Array2::from_shape_vec((n, m), flat).expect("n·m values");
    out.set_item(intern!(py, "y"), PyArray2::from_owned_array(py, y))?;
    if f.dense {
        out.set_item(intern!(py, "sol"), Bound::new(py, DenseOutput::from_solution(&sol, n))?)?;
    } else {
        out.set_item(intern!(py, "sol"), py.None())?;
    }
    let mut terminated = false;
    if events {
        let mut per_event: Vec<(Vec<f64>, Vec<f64>)> = vec![(Vec::new(), Vec::new()); f.terminal.len()];
        for hit in &sol.events {
            per_event[hit.index].0.push(hit.t);
            per_event[hit.index].1.extend(hit.x.iter().copied());
            // the run stopped at the terminal[i]-th zero of event i
            let k = f.terminal[hit.index];
            terminated |= k > 0 && per_event[hit.index].0.len() as u64 >= k;
        }
        let (ts, ys) = (PyList::empty(py), PyList::empty(py));
        for (t, y) in per_event {
            let k = t.len();
            ts.append(PyArray1::from_vec(py, t))?;
            if k == 0 {
                ys.append(PyArray1::<f64>::zeros(py, [0], false))?;
            } else {
                let y = numpy::ndarray::Array2::from_shape_vec((k, n), y).expect("k·n values");
                ys.append(PyArray2::from_owned_array(py, y))?;
            }
        }
        out.set_item(intern!(py, "t_events"), ts)?;
        out.set_item(intern!(py, "y_events"), ys)?;
    } else {
        out.set_item(intern!(py, "t_events"), py.None())?;
        out.set_item(intern!(py, "y_events"), py.None())?;
    }
    let s = sol.stats;
    out.set_item(intern!(py, "nfev"), s.rhs_evals)?;
    out.set_item(intern!(py, "njev"), s.jacobian_evals)?;
    out.set_item(intern!(py, "nlu"), s.lu_decompositions)?;
    out.set_item(intern!(py, "status"), if terminated { 1 } else { 0 })?;
    out.set_item(
        intern!(py, "message"),
        if terminated {
            intern!(py, "A termination event occurred.")
        } else {
            intern!(
                py,
                "The solver successfully reached the end of the integration interval."
            )
        },
    )?;
    out.set_item(intern!(py, "success"), true)?;
    stats.set_item(intern!(py, "rhs_evals"), s.rhs_evals)?;
    stats.set_item(intern!(py, "jacobian_evals"), s.jacobian_evals)?;
    stats.set_item(intern!(py, "time_derivative_evals"), s.time_derivative_evals)?;
    stats.set_item(intern!(py, "lu_decompositions"), s.lu_decompositions)?;
    stats.set_item(intern!(py, "newton_iterations"), s.newton_iterations)?;
    stats.set_item(intern!(py, "accepted"), s.accepted)?;
    stats.set_item(intern!(py, "rejected"), s.rejected)?;
    stats.set_item(intern!(py, "fun_calls"), fun_calls)?;
    stats.set_item(intern!(py, "jac_calls"), jac_calls)?;
    out.set_item(intern!(py, "stats"), stats)?;
    match sol.stiffness {
        Some(st) => {
            let d = PyDict::new(py);
            d.set_item(intern!(py, "t"), st.t)?;
            d.set_item(intern!(py, "h_lambda"), st.h_lambda)?;
            out.set_item(intern!(py, "stiffness"), d)?;
        }
        None => out.set_item(intern!(py, "stiffness"), py.None())?,
    }
    let sw = PyList::empty(py);
    for w in &sol.switches {
        let d = PyDict::new(py);
        d.set_item(intern!(py, "t"), w.t)?;
        d.set_item(intern!(py, "to"), w.to)?;
        d.set_item(intern!(py, "reason"), w.reason.to_string())?;
        sw.append(d)?;
    }
    out.set_item(intern!(py, "switches"), sw)?;
    out.set_item(intern!(py, "jacobian"), (s.jacobian_evals > 0).then_some(f.jac_kind))?;
    out.set_item(intern!(py, "error"), py.None())?;
    Ok(())
}

/// The same problems solved by reckon's own `model!` models (`reckon::studies::problems`),
/// timed in Rust: the reference of `bench/traced.py`. `problem` is `"robertson"`,
/// `"vdp"` (μ = `param`) or `"brusselator"` (`param` grid points, 2·param states);
/// returns the best wall time of `repeats` solves in seconds, the end state and the
/// steps taken. Not part of the public API.
#[pyfunction]
#[pyo3(signature = (problem, param, method, t1, rtol, atol, repeats))]
#[allow(clippy::too_many_arguments)]
fn _rust_reference(
    py: Python<'_>,
    problem: &str,
    param: f64,
    method: &str,
    t1: f64,
    rtol: f64,
    atol: f64,
    repeats: usize,
) -> PyResult<(f64, Vec<f64>, u64)> {
    use reckon::studies::problems as p;
    let opts = Options::default().rtol(rtol).atol(atol).save(Save::At(vec![t1]));
    if !["BDF", "Rodas5P", "RK45"].contains(&method) {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "unknown method {method:?}"
        )));
    }
    fn time<D, S>(
        sys: S,
        y0: OVector<f64, D>,
        t1: f64,
        method: &str,
        opts: &Options,
        repeats: usize,
    ) -> reckon::Result<(f64, Vec<f64>, u64)>
    where
        D: Dim,
        S: System<D>,
        DefaultAllocator: Allocator<D>,
        Bdf: Method<D>,
        Rodas5P: Method<D>,
        Rk45: Method<D>,
    {
        let mut best = f64::INFINITY;
        let mut last = (Vec::new(), 0);
        for _ in 0..repeats.max(1) {
            let start = std::time::Instant::now();
            let problem = Problem::new(&sys, y0.clone(), (0.0, t1));
            let sol = match method {
                "BDF" => problem.solve(Bdf::default(), opts),
                "Rodas5P" => problem.solve(Rodas5P, opts),
                _ => problem.solve(Rk45, opts),
            }?;
            best = best.min(start.elapsed().as_secs_f64());
            last = (
                sol.x.last().map(|x| x.as_slice().to_vec()).unwrap_or_default(),
                sol.stats.accepted,
            );
        }
        Ok((best, last.0, last.1))
    }
    let r = py.detach(|| match problem {
        "robertson" => time(
            p::robertson(),
            reckon::nalgebra::Vector3::new(1.0, 0.0, 0.0),
            t1,
            method,
            &opts,
            repeats,
        ),
        "vdp" => time(
            p::van_der_pol(param),
            reckon::nalgebra::Vector2::new(2.0, 0.0),
            t1,
            method,
            &opts,
            repeats,
        ),
        _ => {
            let n = param as usize;
            time(p::brusselator(n), p::brusselator_y0(n), t1, method, &opts, repeats)
        }
    });
    r.map_err(|e| errors::to_py(py, &e))
}

#[pymodule]
fn _reckon(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(solve_traced, m)?)?;
    m.add_function(wrap_pyfunction!(_rust_reference, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::encoder_plan, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::encoder_run, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::model_run, m)?)?;
    m.add_function(wrap_pyfunction!(rest::vehicle_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(rest::vehicle_step, m)?)?;
    m.add_function(wrap_pyfunction!(rest::vehicle_sensitivities, m)?)?;
    m.add_function(wrap_pyfunction!(rest::odometry, m)?)?;
    m.add_function(wrap_pyfunction!(rest::sensitivities, m)?)?;
    m.add_function(wrap_pyfunction!(rest::least_squares, m)?)?;
    m.add_function(wrap_pyfunction!(rest::encoder_least_squares, m)?)?;
    m.add_function(wrap_pyfunction!(rest::umbmark_fit, m)?)?;
    m.add_function(wrap_pyfunction!(rest::censi_fit, m)?)?;
    m.add_class::<ensemble::Statistics>()?;
    m.add_class::<DenseOutput>()?;
    m.add_class::<traced::Model>()?;
    m.add_class::<traced::Symbol>()?;
    Ok(())
}

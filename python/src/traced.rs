//! Models traced from Python: [`Model`] calls the user's `fun(t, y, *params)` once with
//! [`Symbol`]s (handles to nodes of reckon's expression graph, `reckon::symbolic::Sym`),
//! and from then on evaluates `f`, `∂f/∂x` and `∂f/∂t` as compiled code
//! ([`CompiledVector`], [`CompiledJacobian`]) without calling Python.
//!
//! A trace is identified by a number: a [`Symbol`] works only inside the trace that made
//! it, on the thread that made it (the graph is the thread's recording). Whatever a graph
//! cannot answer (a comparison, `bool()`, `float()`, `int()`) raises `reckon.Untraceable`
//! at once, so the Python function stops where its control flow would depend on the state.

use crate::errors;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};
use reckon::__private::Signed;
use reckon::Error;
use reckon::jacobian::{AUTO_MAX_DENSITY, AUTO_MIN_STATES, SparseJacobian};
use reckon::nalgebra::allocator::Allocator;
use reckon::nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};
use reckon::num_dual::DualNum;
use reckon::symbolic::{CompiledJacobian, CompiledVector, Sym, Traced};
use std::cell::{Cell, RefCell};
use std::sync::atomic::{AtomicU64, Ordering};

static NEXT_TRACE: AtomicU64 = AtomicU64::new(1);

thread_local! {
    /// The trace running on this thread: its number (0: none) and the model's name.
    static CURRENT: Cell<u64> = const { Cell::new(0) };
    static MODEL: RefCell<String> = const { RefCell::new(String::new()) };
}

fn untraceable(py: Python<'_>, reason: String) -> PyErr {
    let model = MODEL.with(|m| m.borrow().clone());
    errors::to_py(py, &Error::Untraceable { model, reason })
}

/// A traced scalar: what `fun` sees in place of each `y[i]`, `t` and each numeric
/// parameter while `reckon.Model` traces it. Arithmetic (`+ − * / **`, unary `−`,
/// `abs`) with other symbols, ints and floats, numpy's ufuncs on object arrays of them
/// (`np.sin(y)`), and `reckon.sin`… record expressions; a comparison, `bool()`,
/// `float()` or `int()` raises `reckon.Untraceable`.
#[pyclass(module = "reckon", name = "Symbol", frozen)]
pub(crate) struct Symbol {
    sym: Sym,
    trace: u64,
}

/// An operand: a symbol of the running trace, a real number, or neither (`None`:
/// `NotImplemented`, so that numpy or the other operand can answer).
fn operand(other: &Bound<'_, PyAny>) -> PyResult<Option<Sym>> {
    if let Ok(s) = other.cast::<Symbol>() {
        return s.get().live(other.py()).map(Some);
    }
    if other.cast::<numpy::PyUntypedArray>().is_ok()
        || other.cast::<PyList>().is_ok()
        || other.cast::<PyTuple>().is_ok()
    {
        return Ok(None);
    }
    match other.extract::<f64>() {
        Ok(v) => Ok(Some(Sym::from(v))),
        Err(_) => Ok(None),
    }
}

impl Symbol {
    fn live(&self, py: Python<'_>) -> PyResult<Sym> {
        if CURRENT.with(|c| c.get()) == self.trace {
            Ok(self.sym)
        } else {
            Err(untraceable(
                py,
                "a Symbol was used outside the trace that made it (kept from an earlier trace, \
                 or used from another thread)"
                    .into(),
            ))
        }
    }

    fn wrap(&self, py: Python<'_>, s: Sym) -> PyResult<Py<PyAny>> {
        Ok(Bound::new(
            py,
            Symbol {
                sym: s,
                trace: self.trace,
            },
        )?
        .into_any()
        .unbind())
    }

    fn binary(&self, other: &Bound<'_, PyAny>, op: impl FnOnce(Sym, Sym) -> Sym) -> PyResult<Py<PyAny>> {
        let py = other.py();
        let a = self.live(py)?;
        match operand(other)? {
            Some(b) => self.wrap(py, op(a, b)),
            None => Ok(py.NotImplemented()),
        }
    }

    fn unary(&self, py: Python<'_>, op: impl FnOnce(Sym) -> Sym) -> PyResult<Py<PyAny>> {
        let a = self.live(py)?;
        self.wrap(py, op(a))
    }

    fn refuse(&self, py: Python<'_>, what: &str) -> PyErr {
        untraceable(
            py,
            format!(
                "fun applies {what} to a traced value: its result or its control flow would \
                 depend on the state's value, which one trace cannot stand for (use np.sin or \
                 reckon.sin instead of math.sin, abs() instead of a sign test, and return a list \
                 or np.array of the values, or fill np.empty_like(y), instead of a float array)"
            ),
        )
    }
}

/// `a ** b`: an integer power as `powi`, a real one as `powf`, a traced exponent as
/// `exp(b·ln a)` (for `a > 0`).
fn power(a: Sym, b: Sym, b_const: Option<f64>) -> Sym {
    match b_const {
        Some(p) if p.fract() == 0.0 && p.abs() <= i32::MAX as f64 => a.powi(p as i32),
        Some(p) => a.powf(p),
        None => (b * a.ln()).exp(),
    }
}

fn number(other: &Bound<'_, PyAny>) -> Option<f64> {
    if other.cast::<Symbol>().is_ok() {
        return None;
    }
    other.extract::<f64>().ok()
}

#[pymethods]
impl Symbol {
    fn __add__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| a + b)
    }
    fn __radd__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| b + a)
    }
    fn __sub__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| a - b)
    }
    fn __rsub__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| b - a)
    }
    fn __mul__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| a * b)
    }
    fn __rmul__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| b * a)
    }
    fn __truediv__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| a / b)
    }
    fn __rtruediv__(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| b / a)
    }
    fn __pow__(&self, o: &Bound<'_, PyAny>, modulo: Option<&Bound<'_, PyAny>>) -> PyResult<Py<PyAny>> {
        if modulo.is_some_and(|m| !m.is_none()) {
            return Err(PyTypeError::new_err(
                "pow() with a modulus is not defined for a traced value",
            ));
        }
        let c = number(o);
        self.binary(o, |a, b| power(a, b, c))
    }
    fn __rpow__(&self, o: &Bound<'_, PyAny>, modulo: Option<&Bound<'_, PyAny>>) -> PyResult<Py<PyAny>> {
        if modulo.is_some_and(|m| !m.is_none()) {
            return Err(PyTypeError::new_err(
                "pow() with a modulus is not defined for a traced value",
            ));
        }
        self.binary(o, |a, b| power(b, a, None))
    }
    fn __neg__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| -a)
    }
    fn __pos__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a)
    }
    fn __abs__(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.abs())
    }
    fn __bool__(&self, py: Python<'_>) -> PyResult<bool> {
        Err(self.refuse(py, "bool() (an `if`, `and`, `or` or `while` on it)"))
    }
    fn __float__(&self, py: Python<'_>) -> PyResult<f64> {
        Err(self.refuse(py, "float() (math.* functions and float arrays call it)"))
    }
    fn __int__(&self, py: Python<'_>) -> PyResult<i64> {
        Err(self.refuse(py, "int()"))
    }
    fn __index__(&self, py: Python<'_>) -> PyResult<i64> {
        Err(self.refuse(py, "an index conversion"))
    }
    fn __complex__(&self, py: Python<'_>) -> PyResult<f64> {
        Err(self.refuse(py, "complex()"))
    }
    #[pyo3(signature = (_n=None))]
    fn __round__(&self, py: Python<'_>, _n: Option<&Bound<'_, PyAny>>) -> PyResult<f64> {
        Err(self.refuse(py, "round()"))
    }
    fn __floor__(&self, py: Python<'_>) -> PyResult<f64> {
        Err(self.refuse(py, "math.floor()"))
    }
    fn __ceil__(&self, py: Python<'_>) -> PyResult<f64> {
        Err(self.refuse(py, "math.ceil()"))
    }
    fn __trunc__(&self, py: Python<'_>) -> PyResult<f64> {
        Err(self.refuse(py, "math.trunc()"))
    }
    fn __floordiv__(&self, o: &Bound<'_, PyAny>) -> PyResult<f64> {
        Err(self.refuse(o.py(), "// (floor division)"))
    }
    fn __rfloordiv__(&self, o: &Bound<'_, PyAny>) -> PyResult<f64> {
        Err(self.refuse(o.py(), "// (floor division)"))
    }
    fn __mod__(&self, o: &Bound<'_, PyAny>) -> PyResult<f64> {
        Err(self.refuse(o.py(), "% (modulo)"))
    }
    fn __rmod__(&self, o: &Bound<'_, PyAny>) -> PyResult<f64> {
        Err(self.refuse(o.py(), "% (modulo)"))
    }
    fn __lt__(&self, o: &Bound<'_, PyAny>) -> PyResult<bool> {
        Err(self.refuse(o.py(), "a comparison (<)"))
    }
    fn __le__(&self, o: &Bound<'_, PyAny>) -> PyResult<bool> {
        Err(self.refuse(o.py(), "a comparison (<=)"))
    }
    fn __gt__(&self, o: &Bound<'_, PyAny>) -> PyResult<bool> {
        Err(self.refuse(o.py(), "a comparison (>)"))
    }
    fn __ge__(&self, o: &Bound<'_, PyAny>) -> PyResult<bool> {
        Err(self.refuse(o.py(), "a comparison (>=)"))
    }
    fn __eq__(&self, o: &Bound<'_, PyAny>) -> PyResult<bool> {
        Err(self.refuse(o.py(), "a comparison (==)"))
    }
    fn __ne__(&self, o: &Bound<'_, PyAny>) -> PyResult<bool> {
        Err(self.refuse(o.py(), "a comparison (!=)"))
    }
    fn __repr__(&self) -> String {
        if CURRENT.with(|c| c.get()) == self.trace {
            format!("Symbol({})", self.sym)
        } else {
            "Symbol(<outside its trace>)".into()
        }
    }

    // numpy's ufuncs on object arrays call the method of the ufunc's name
    fn sin(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.sin())
    }
    fn cos(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.cos())
    }
    fn tan(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.tan())
    }
    fn arcsin(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.asin())
    }
    fn arccos(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.acos())
    }
    fn arctan(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.atan())
    }
    fn sinh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.sinh())
    }
    fn cosh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.cosh())
    }
    fn tanh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.tanh())
    }
    fn arcsinh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.asinh())
    }
    fn arccosh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.acosh())
    }
    fn arctanh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.atanh())
    }
    fn exp(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.exp())
    }
    fn exp2(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.exp2())
    }
    fn expm1(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.exp_m1())
    }
    fn log(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.ln())
    }
    fn log1p(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.ln_1p())
    }
    fn log2(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.log2())
    }
    fn log10(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.log10())
    }
    fn sqrt(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.sqrt())
    }
    fn cbrt(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.cbrt())
    }
    fn square(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.powi(2))
    }
    fn absolute(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.abs())
    }
    fn fabs(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.abs())
    }
    /// `sgn(a)`, with derivative 0 (traced as a function, not a branch).
    fn sign(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a.signum())
    }
    fn arctan2(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| a.atan2(b))
    }
    fn hypot(&self, o: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        self.binary(o, |a, b| (a * a + b * b).sqrt())
    }
    fn conjugate(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        self.unary(py, |a| a)
    }
}

/// `fun(t, y, *params)` traced into reckon's expression graph and compiled: `f`, the exact
/// Jacobian `∂f/∂y` and `∂f/∂t` run as native code (Cranelift) or, for very large models,
/// as a compiled instruction list, never calling Python again. Numeric entries of
/// `params` are traced as parameters `p₀, p₁, …` (named after `fun`'s own arguments when
/// it has them); other entries are passed as they are.
#[pyclass(module = "reckon", frozen)]
pub(crate) struct Model {
    pub(crate) traced: Traced,
    pub(crate) rhs: CompiledVector,
    pub(crate) jac: CompiledJacobian,
    pub(crate) dt: Option<CompiledVector>,
    pub(crate) n: usize,
    /// Seconds spent calling `fun` on symbols and differentiating.
    #[pyo3(get)]
    trace_seconds: f64,
    /// Seconds spent flattening and compiling `f`, `∂f/∂y`, `∂f/∂t` to machine code.
    #[pyo3(get)]
    compile_seconds: f64,
}

/// State and parameter names: `y₀, y₁, …` and `fun`'s own argument names after `(t, y)`.
fn param_names(fun: &Bound<'_, PyAny>, k: usize) -> Vec<String> {
    let named = (|| -> PyResult<Vec<String>> {
        let sig = fun.py().import("inspect")?.call_method1("signature", (fun,))?;
        let names: Vec<String> = sig
            .getattr("parameters")?
            .call_method0("keys")?
            .try_iter()?
            .map(|n| n?.extract())
            .collect::<PyResult<_>>()?;
        Ok(names)
    })()
    .unwrap_or_default();
    (0..k)
        .map(|i| named.get(i + 2).cloned().unwrap_or_else(|| format!("p{i}")))
        .collect()
}

/// The most states [`Model::new`] traces: its graph, Jacobian and solver take about
/// 1.7 KiB per state on the 1-D Brusselator (1.69 GiB peak at 10⁶ states), so 10⁷ is
/// what a large workstation holds; past it a request is refused up front rather than
/// aborting the process on a failed allocation.
const MAX_STATES: usize = 10_000_000;

fn subscript(i: usize) -> String {
    i.to_string()
        .chars()
        .map(|c| char::from_u32(0x2080 + c.to_digit(10).unwrap_or(0)).unwrap_or(c))
        .collect()
}

#[pymethods]
impl Model {
    /// Trace `fun(t, y, *params)` for a state of `n` components.
    #[new]
    #[pyo3(signature = (fun, n, params=None))]
    fn new(
        py: Python<'_>,
        fun: Bound<'_, PyAny>,
        n: Bound<'_, PyAny>,
        params: Option<Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        // any Python integer: a negative or huge one is `InvalidInput`, not an OverflowError
        let none = || errors::invalid(py, "n", "a model needs at least one state".into());
        let n = match n.extract::<i64>() {
            Ok(v) if v >= 1 => usize::try_from(v).unwrap_or(usize::MAX),
            Ok(_) => return Err(none()),
            Err(_) if n.is_instance_of::<pyo3::types::PyInt>() => {
                if n.lt(0)? {
                    return Err(none());
                }
                usize::MAX
            }
            Err(_) => {
                let kind = n.get_type().name().map(|s| s.to_string()).unwrap_or_default();
                return Err(errors::invalid(
                    py,
                    "n",
                    format!("the number of states must be an integer, got {kind}"),
                ));
            }
        };
        if n > MAX_STATES {
            return Err(errors::invalid(
                py,
                "n",
                format!(
                    "{n} states: reckon traces models of up to {MAX_STATES} (the 10⁶-state \
                     Brusselator's trace and sparse solve peak at 1.7 GiB)"
                ),
            ));
        }
        if !fun.is_callable() {
            return Err(PyTypeError::new_err("fun must be callable as fun(t, y, *params)"));
        }
        let params: Vec<Bound<'_, PyAny>> = match params {
            None => Vec::new(),
            Some(p) => p
                .try_iter()
                .map_err(|_| PyTypeError::new_err("params must be a tuple (e.g. params=(a,)), as scipy's args"))?
                .collect::<PyResult<_>>()?,
        };
        // numeric params become the leaves pₖ
        let mut values = Vec::new();
        let mut slots = Vec::new(); // Some(k): params[i] is the leaf p_k
        for p in &params {
            let numeric = p.cast::<Symbol>().is_err()
                && !p.is_instance_of::<pyo3::types::PyBool>()
                && (p.is_instance_of::<pyo3::types::PyFloat>()
                    || p.is_instance_of::<pyo3::types::PyInt>()
                    || p.getattr("ndim")
                        .and_then(|d| d.extract::<usize>())
                        .is_ok_and(|d| d == 0))
                && p.extract::<f64>().is_ok();
            if numeric {
                slots.push(Some(values.len()));
                values.push(p.extract::<f64>()?);
            } else {
                slots.push(None);
            }
        }
        let names = param_names(&fun, params.len());
        let param_names: Vec<String> = slots
            .iter()
            .zip(&names)
            .filter_map(|(s, name)| s.map(|_| name.clone()))
            .collect();
        let model_name = fun
            .getattr("__qualname__")
            .or_else(|_| fun.getattr("__name__"))
            .and_then(|n| n.extract::<String>())
            .unwrap_or_else(|_| "fun".into());

        let trace = NEXT_TRACE.fetch_add(1, Ordering::Relaxed);
        let fault: RefCell<Option<PyErr>> = RefCell::new(None);
        let previous = CURRENT.with(|c| c.replace(trace));
        MODEL.with(|m| *m.borrow_mut() = model_name.clone());
        struct Restore(u64);
        impl Drop for Restore {
            fn drop(&mut self) {
                CURRENT.with(|c| c.set(self.0));
            }
        }
        let restore = Restore(previous);
        let started = std::time::Instant::now();
        let body = |t: Sym, x: &[Sym], p: &[Sym]| -> Vec<Sym> {
            let run = || -> PyResult<Vec<Sym>> {
                let sym = |s: Sym| Bound::new(py, Symbol { sym: s, trace });
                let ys = PyList::empty(py);
                for &s in x {
                    ys.append(sym(s)?)?;
                }
                let y = py.import("numpy")?.call_method1("array", (ys, "object"))?;
                let mut args = vec![sym(t)?.into_any(), y];
                for (obj, slot) in params.iter().zip(&slots) {
                    args.push(match slot {
                        Some(k) => sym(p[*k])?.into_any(),
                        None => obj.clone(),
                    });
                }
                let r = fun.call1(PyTuple::new(py, args)?)?;
                read_symbols(&r, n, py)
            };
            match run() {
                Ok(v) => v,
                Err(e) => {
                    *fault.borrow_mut() = Some(e);
                    Vec::new()
                }
            }
        };
        let result = reckon::symbolic::trace_fn(&model_name, n, &values, body);
        drop(restore);
        if let Some(e) = fault.take() {
            let plain = !e.is_instance_of::<pyo3::exceptions::PyException>(py); // KeyboardInterrupt…
            if plain || e.is_instance_of::<PyValueError>(py) || is_untraceable(py, &e) {
                return Err(e);
            }
            let err = untraceable(
                py,
                format!(
                    "fun raised {} while traced: {}",
                    e.get_type(py).name().map(|n| n.to_string()).unwrap_or_default(),
                    e.value(py)
                ),
            );
            err.set_cause(py, Some(e));
            return Err(err);
        }
        let traced = result.map_err(|e| errors::to_py(py, &e))?;
        let states: Vec<String> = (0..n).map(|i| format!("y{}", subscript(i))).collect();
        let states: Vec<&str> = states.iter().map(|s| s.as_str()).collect();
        let pn: Vec<&str> = param_names.iter().map(|s| s.as_str()).collect();
        let traced = traced.with_names(&states, &[]).with_param_names(&pn);
        let trace_seconds = started.elapsed().as_secs_f64();
        let started = std::time::Instant::now();
        let (rhs, jac, dt) = py.detach(|| {
            let rhs = traced.compile_rhs();
            let jac = traced.compile_jacobian();
            let dt = traced.reads_time().then(|| traced.compile_time_derivative());
            (rhs, jac, dt)
        });
        Ok(Model {
            n,
            rhs,
            jac,
            dt,
            traced,
            trace_seconds,
            compile_seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// The number of states.
    #[getter]
    fn n(&self) -> usize {
        self.n
    }

    /// The number of structural non-zeros of `∂f/∂y`.
    #[getter]
    fn nnz(&self) -> usize {
        self.jac.pattern().nnz()
    }

    /// Whether the implicit methods use the sparse Jacobian (and sparse LU) for this model:
    /// at least 64 states and at most 10 % of `∂f/∂y` non-zero (reckon's automatic choice).
    #[getter]
    fn sparse(&self) -> bool {
        self.n >= AUTO_MIN_STATES && self.jac.pattern().density() <= AUTO_MAX_DENSITY
    }

    /// Whether `f` and `∂f/∂y` run as machine code (`(f, jac)`); the compiled instruction
    /// list otherwise (programs above 5 000 instructions).
    #[getter]
    fn native(&self) -> (bool, bool) {
        (self.rhs.is_native(), self.jac.is_native())
    }

    /// `f(t, y)` from the compiled code.
    fn __call__<'py>(&self, py: Python<'py>, t: f64, y: Vec<f64>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        self.check_len(py, y.len())?;
        let mut out = vec![0.0; self.n];
        self.rhs
            .clone()
            .eval(t, &y, &[], &mut out)
            .map_err(|e| errors::to_py(py, &e))?;
        Ok(PyArray1::from_vec(py, out))
    }

    /// `∂f/∂y (t, y)` as a dense `(n, n)` array, from the compiled code.
    fn jacobian<'py>(&self, py: Python<'py>, t: f64, y: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
        self.check_len(py, y.len())?;
        let n = self.n;
        let mut m = vec![0.0; n * n];
        self.jac
            .clone()
            .eval_dense(t, &y, &[], &mut m)
            .map_err(|e| errors::to_py(py, &e))?;
        // column-major → row-major
        let mut r = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                r[i * n + j] = m[i + n * j];
            }
        }
        Ok(PyArray1::from_vec(py, r).reshape([n, n])?.into_any())
    }

    /// The sparsity pattern of `∂f/∂y` in CSC form: `(indptr, indices)`, column `j`'s
    /// rows being `indices[indptr[j]:indptr[j+1]]` (scipy's `csc_array` layout).
    fn pattern<'py>(&self, py: Python<'py>) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>) {
        let p = self.jac.pattern();
        (
            PyArray1::from_iter(py, p.col_ptr().iter().map(|&v| v as i64)),
            PyArray1::from_iter(py, p.row_idx().iter().map(|&v| v as i64)),
        )
    }

    /// The sparsity pattern of `∂f/∂y` as a `scipy.sparse.csc_array` of ones (needs scipy).
    fn sparsity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (indptr, indices) = self.pattern(py);
        let ones = PyArray1::from_vec(py, vec![1.0; self.nnz()]);
        py.import("scipy.sparse")?
            .getattr("csc_array")?
            .call1(((ones, indices, indptr), (self.n, self.n)))
    }

    /// The pattern of `∂f/∂y` drawn with `*` (non-zero) and `.` (structural zero), one
    /// line a row.
    fn spy(&self) -> String {
        let n = self.n;
        let mut rows = vec![vec!['.'; n]; n];
        for (i, j) in self.jac.pattern().entries() {
            rows[i][j] = '*';
        }
        rows.into_iter()
            .map(|r| r.into_iter().collect::<String>() + "\n")
            .collect()
    }

    /// `f` and the non-zeros of `∂f/∂y` (and `∂f/∂t`) as text, one equation a line.
    fn text(&self) -> String {
        self.traced.text()
    }

    /// The non-zeros of `∂f/∂y` as text, `∂ẏᵢ/∂yⱼ = …`, one a line, row by row.
    fn jacobian_text(&self) -> String {
        self.traced.jacobian_text()
    }

    /// `f`, `∂f/∂y` (and `∂f/∂t`) in LaTeX (amsmath `aligned` with `pmatrix`).
    fn latex(&self) -> String {
        self.traced.latex()
    }

    /// `f`, `∂f/∂y` (and `∂f/∂t`) as one MathML `<math>` element.
    fn mathml(&self) -> String {
        self.traced.mathml()
    }

    /// `fᵢ` as text.
    fn rhs_text(&self, i: usize) -> PyResult<String> {
        if i >= self.n {
            return Err(PyValueError::new_err(format!(
                "component {i} of a model of {} states",
                self.n
            )));
        }
        Ok(self.traced.rhs(i).to_string())
    }

    fn __repr__(&self) -> String {
        format!(
            "Model('{}', n={}, nnz={}, nodes={}, native=({}, {}), sparse={})",
            self.traced.model(),
            self.n,
            self.nnz(),
            self.traced.nodes(),
            py_bool(self.rhs.is_native()),
            py_bool(self.jac.is_native()),
            py_bool(self.sparse())
        )
    }
}

fn py_bool(b: bool) -> &'static str {
    if b { "True" } else { "False" }
}

impl Model {
    fn check_len(&self, py: Python<'_>, k: usize) -> PyResult<()> {
        if k != self.n {
            return Err(errors::invalid(
                py,
                "y",
                format!("{k} values for a model of {} states", self.n),
            ));
        }
        Ok(())
    }
}

fn is_untraceable(py: Python<'_>, e: &PyErr) -> bool {
    (|| -> PyResult<bool> {
        let cls = py.import("reckon._errors")?.getattr("Untraceable")?;
        e.value(py).is_instance(&cls)
    })()
    .unwrap_or(false)
}

/// The traced values of what `fun` returned: `n` symbols or numbers, from a list, a tuple
/// or a 1-d array.
fn read_symbols(r: &Bound<'_, PyAny>, n: usize, py: Python<'_>) -> PyResult<Vec<Sym>> {
    let arr = py.import("numpy")?.call_method1("asarray", (r, "object"))?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let items: Vec<Bound<'_, PyAny>> = match shape.as_slice() {
        [] if n == 1 => vec![arr.call_method0("item")?],
        [k] if *k == n => arr.try_iter()?.collect::<PyResult<_>>()?,
        [k] => {
            return Err(PyValueError::new_err(format!(
                "fun(t, y) returned {k} values, expected {n} (the length of y0)"
            )));
        }
        s => {
            return Err(PyValueError::new_err(format!(
                "fun(t, y) returned an array of shape {s:?}, expected ({n},)"
            )));
        }
    };
    items
        .iter()
        .enumerate()
        .map(|(i, v)| match v.cast::<Symbol>() {
            Ok(s) => s.get().live(py),
            Err(_) => match v.extract::<f64>() {
                Ok(c) => Ok(Sym::from(c)),
                Err(_) => Err(PyTypeError::new_err(format!(
                    "fun(t, y) returned {} in component {i}, not a number or a traced value",
                    v.get_type().name().map(|n| n.to_string()).unwrap_or_default()
                ))),
            },
        })
        .collect()
}

/// A [`Model`]'s compiled code as reckon's `System`, for one solve (its own scratch).
pub(crate) struct TracedSystem {
    rhs: RefCell<CompiledVector>,
    jac: RefCell<CompiledJacobian>,
    dt: Option<RefCell<CompiledVector>>,
    /// Python's signals, checked while the GIL is released ([`watched`](Self::watched)).
    watch: Option<Watch>,
}

/// Python's pending signals (Ctrl-C) looked at every [`Watch::EVERY`] state values of
/// `f` evaluated (every ~10⁻² s: 10 calls of `f` at 10⁵ states, 3·10⁵ at 3), the GIL
/// taken for the look only. Once a handler raised, every `f` is NaN, so the run stops at
/// once (a NaN at the start of a step is an error), and the solve raises what it raised.
struct Watch {
    left: Cell<usize>,
    raised: RefCell<Option<PyErr>>,
}

impl Watch {
    const EVERY: usize = 1 << 20;

    /// Count `n` values; whether the run is to stop.
    #[inline]
    fn stop(&self, n: usize) -> bool {
        match self.left.get().checked_sub(n) {
            Some(left) => {
                self.left.set(left);
                false
            }
            None => self.look(),
        }
    }

    #[cold]
    fn look(&self) -> bool {
        if self.raised.borrow().is_none()
            && let Err(e) = Python::attach(|py| py.check_signals())
        {
            *self.raised.borrow_mut() = Some(e);
        }
        let stop = self.raised.borrow().is_some();
        // once stopped, every later call comes here (nothing left to count)
        self.left.set(if stop { 0 } else { Self::EVERY });
        stop
    }
}

impl TracedSystem {
    pub(crate) fn new(m: &Model) -> Self {
        TracedSystem {
            rhs: RefCell::new(m.rhs.clone()),
            jac: RefCell::new(m.jac.clone()),
            dt: m.dt.clone().map(RefCell::new),
            watch: None,
        }
    }

    /// [`new`](Self::new) for a solve that runs with the GIL released: it looks at
    /// Python's signals now and then, so Ctrl-C stops it ([`Watch`]).
    pub(crate) fn watched(m: &Model) -> Self {
        TracedSystem {
            watch: Some(Watch {
                left: Cell::new(Watch::EVERY),
                raised: RefCell::new(None),
            }),
            ..Self::new(m)
        }
    }

    /// What a signal handler raised during the solve, if one did.
    pub(crate) fn interrupted(&self) -> Option<PyErr> {
        self.watch.as_ref().and_then(|w| w.raised.borrow_mut().take())
    }
}

/// Generic over the state's dimension: `Dyn`, or a fixed `Const<N>` for small models
/// (stack vectors and a stack LU, as a `model!` model in Rust gets).
impl<D: Dim> reckon::System<D> for TracedSystem
where
    DefaultAllocator: Allocator<D>,
{
    fn rhs(&self, t: f64, x: &OVector<f64, D>, _u: &[f64], dx: &mut OVector<f64, D>) {
        if let Some(w) = &self.watch
            && w.stop(x.len())
        {
            dx.fill(f64::NAN);
            return;
        }
        if self
            .rhs
            .borrow_mut()
            .eval(t, x.as_slice(), &[], dx.as_mut_slice())
            .is_err()
        {
            dx.fill(f64::NAN);
        }
    }
    fn jacobian(&self, t: f64, x: &OVector<f64, D>, _u: &[f64], jac: &mut OMatrix<f64, D, D>)
    where
        DefaultAllocator: Allocator<D, D>,
    {
        if self
            .jac
            .borrow_mut()
            .eval_dense(t, x.as_slice(), &[], jac.as_mut_slice())
            .is_err()
        {
            jac.fill(f64::NAN);
        }
    }
    fn time_derivative(&self, t: f64, x: &OVector<f64, D>, _u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        match &self.dt {
            Some(dt) => {
                if dt.borrow_mut().eval(t, x.as_slice(), &[], dfdt.as_mut_slice()).is_err() {
                    dfdt.fill(f64::NAN);
                }
            }
            None => dfdt.fill(0.0),
        }
        true
    }
    fn sparse_jacobian(&self, _n: usize) -> Option<Box<dyn SparseJacobian + '_>> {
        Some(Box::new(self.jac.borrow().clone()))
    }
}

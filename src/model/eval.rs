//! The counting evaluator: every call of the model goes through [`Eval`], which counts
//! it and checks the result for NaN/∞ at the time it appears.

use super::System;
use crate::error::{Error, Quantity, Result};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector};
use num_dual::DualVec64;
use std::marker::PhantomData;

/// Work counters, all counted in one place ([`Eval`] and the driver).
///
/// `accepted + rejected` is the number of step attempts; `rejected` includes steps
/// retried because Newton failed.
///
/// ```
/// use reckon::{model, Options, Problem, methods::Euler};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let s = Problem::new(&f, vector![1.0], (0.0, 1.0)).solve(Euler, &Options::default().fixed(0.1)).unwrap().stats;
/// assert_eq!((s.accepted, s.rhs_evals, s.jacobian_evals), (10, 10, 0)); // one f call per Euler step
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Calls of `f(t, x)`.
    pub rhs_evals: u64,
    /// Calls of the autodiff Jacobian `∂f/∂x`.
    pub jacobian_evals: u64,
    /// Calls of the model's exact `∂f/∂t` (Rosenbrock methods on non-autonomous models).
    pub time_derivative_evals: u64,
    /// LU factorisations of `I − h·J`.
    pub lu_decompositions: u64,
    /// Newton iterations (each costs one `f` call and one LU solve).
    pub newton_iterations: u64,
    /// Accepted steps.
    pub accepted: u64,
    /// Rejected step attempts (error too large or Newton failure).
    pub rejected: u64,
}

/// The one place where the model is called: counts every evaluation and checks
/// every result for NaN/∞ at the time it appears.
pub struct Eval<'a, D: Dim, S>
where
    DefaultAllocator: Allocator<D>,
{
    sys: &'a S,
    /// Inputs held over the current control interval: a control log's row, borrowed,
    /// or the caller's own values.
    pub(crate) u: std::borrow::Cow<'a, [f64]>,
    /// Counters.
    pub stats: Stats,
    /// A wrong-length result from an unchecked call, reported by the driver when it
    /// finds the NaN left in its place.
    pub(crate) fault: Option<Error>,
    /// The linear-algebra choice and the model's sparse Jacobian (`crate::sparse`).
    pub(crate) sparse: crate::jacobian::choice::Slot<'a>,
    /// The problem's mass matrix (`None`: the identity).
    pub(crate) mass: Option<&'a crate::model::mass::Mass>,
    _dim: PhantomData<D>,
}

impl<'a, D: Dim, S: System<D>> Eval<'a, D, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// The model `sys` holding the inputs `u`: owned values, or a control log's row
    /// (borrowed).
    pub(crate) fn new(sys: &'a S, u: impl Into<std::borrow::Cow<'a, [f64]>>) -> Self {
        Eval {
            sys,
            u: u.into(),
            stats: Stats::default(),
            fault: None,
            sparse: Default::default(),
            mass: None,
            _dim: PhantomData,
        }
    }

    /// The model.
    pub(crate) fn system(&self) -> &'a S {
        self.sys
    }

    /// Hold the inputs `v` from now on (the caller's values: copied into the owned
    /// buffer, which is reused while the count is unchanged).
    pub(crate) fn hold(&mut self, v: &[f64]) {
        match &mut self.u {
            std::borrow::Cow::Owned(o) if o.len() == v.len() => o.copy_from_slice(v),
            _ => self.u = std::borrow::Cow::Owned(v.to_vec()),
        }
    }

    /// Hold a control log's row `v` from now on: borrowed, nothing copied (one store of
    /// a slice per interval of a long log).
    #[inline(always)]
    pub(crate) fn hold_row(&mut self, v: &'a [f64]) {
        match &mut self.u {
            // the usual case on a log: a row replaces a row, two stores
            std::borrow::Cow::Borrowed(r) => *r = v,
            u => *u = std::borrow::Cow::Borrowed(v),
        }
    }

    /// [`hold_row`](Self::hold_row) where the inputs held now are known to be a row:
    /// the slice replaced without the test for owned inputs to free (the lean loop
    /// over a log's rows, entered only with a row held; an owned value replaced here
    /// would be leaked, not freed, so debug builds check).
    #[inline(always)]
    pub(crate) fn replace_row(&mut self, v: &'a [f64]) {
        debug_assert!(matches!(self.u, std::borrow::Cow::Borrowed(_)));
        std::mem::forget(std::mem::replace(&mut self.u, std::borrow::Cow::Borrowed(v)));
    }

    /// Whether the inputs held now are a borrowed row (not owned values).
    pub(crate) fn holds_row(&self) -> bool {
        matches!(self.u, std::borrow::Cow::Borrowed(_))
    }

    /// `dx ← f(t, x)`, counted but not checked: for explicit kernels whose step result
    /// the driver checks (and then asks [`Stepper::diagnose`](crate::methods::Stepper::diagnose) where it broke).
    #[inline(always)]
    pub fn rhs_unchecked(&mut self, t: f64, x: &OVector<f64, D>, dx: &mut OVector<f64, D>) {
        self.stats.rhs_evals += 1;
        self.rhs_uncounted(t, x, dx);
    }

    /// `dx ← f(t, x)` like [`rhs_unchecked`](Self::rhs_unchecked), but not counted: a
    /// kernel that makes a known number of calls adds them to `stats.rhs_evals` at once
    /// (one memory update per step instead of one per stage).
    #[inline(always)]
    pub(crate) fn rhs_uncounted(&mut self, t: f64, x: &OVector<f64, D>, dx: &mut OVector<f64, D>) {
        self.sys.rhs(t, x, &self.u, dx);
        if dx.len() != x.len() {
            self.wrong_length(t, x, dx);
        }
    }

    /// Record a wrong-length derivative and leave NaN of the right length in its place,
    /// so that the step fails the driver's finiteness check and reports this.
    #[cold]
    #[inline(never)]
    fn wrong_length(&mut self, t: f64, x: &OVector<f64, D>, dx: &mut OVector<f64, D>) {
        self.fault.get_or_insert(length_error(dx.len(), x.len(), t));
        let (r, c) = x.shape_generic();
        *dx = OVector::from_element_generic(r, c, f64::NAN);
    }

    /// `dx ← f(t, x)`, counted and checked.
    #[inline]
    pub fn rhs(&mut self, t: f64, x: &OVector<f64, D>, dx: &mut OVector<f64, D>) -> Result<()> {
        self.stats.rhs_evals += 1;
        self.sys.rhs(t, x, &self.u, dx);
        if dx.len() != x.len() {
            return Err(Error::invalid(
                "model",
                format!("f returned {} components for a state of {}", dx.len(), x.len()),
            ));
        }
        finite(dx.as_slice(), t, Quantity::Derivative)
    }

    /// `jac ← ∂f/∂x (t, x)`, counted and checked.
    pub fn jacobian(&mut self, t: f64, x: &OVector<f64, D>, jac: &mut OMatrix<f64, D, D>) -> Result<()>
    where
        DefaultAllocator: Allocator<D, D>,
    {
        self.stats.jacobian_evals += 1;
        self.sys.jacobian(t, x, &self.u, jac);
        if jac.nrows() != x.len() || jac.ncols() != x.len() {
            return Err(Error::invalid(
                "model",
                format!("Jacobian is {}x{} for a state of {}", jac.nrows(), jac.ncols(), x.len()),
            ));
        }
        finite(jac.as_slice(), t, Quantity::Jacobian).map_err(|e| self.length_error(t, x).unwrap_or(e))
    }

    /// `dfdt ← ∂f/∂t (t, x)` when the model provides it (`Ok(true)`, counted and
    /// checked); `Ok(false)` when it does not (nothing counted, `dfdt` untouched).
    pub fn time_derivative(&mut self, t: f64, x: &OVector<f64, D>, dfdt: &mut OVector<f64, D>) -> Result<bool> {
        if !self.sys.time_derivative(t, x, &self.u, dfdt) {
            return Ok(false);
        }
        self.stats.time_derivative_evals += 1;
        if dfdt.len() != x.len() {
            return Err(Error::invalid(
                "model",
                format!("∂f/∂t has {} components for a state of {}", dfdt.len(), x.len()),
            ));
        }
        finite(dfdt.as_slice(), t, Quantity::Derivative).map(|()| true)
    }

    /// After a non-finite Jacobian: a model whose output has the wrong length says so.
    #[cold]
    fn length_error(&mut self, t: f64, x: &OVector<f64, D>) -> Option<Error> {
        let mut dx = x.clone();
        self.sys.rhs(t, x, &self.u, &mut dx);
        (dx.len() != x.len()).then(|| length_error(dx.len(), x.len(), t))
    }
}

/// The model's output has `got` components for a state of `n`.
fn length_error(got: usize, n: usize, t: f64) -> Error {
    Error::invalid(
        "model",
        format!(
            "f returned {got} components for a state of {n} (at t = {})",
            crate::error::Brief(t)
        ),
    )
}

/// The sparse path ([`crate::jacobian`]): the choice asked of the run's
/// [`Slot`](crate::jacobian::choice::Slot), the evaluations counted and checked here.
impl<'a, D: Dim, S: System<D>> Eval<'a, D, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// The pattern of `J` if the implicit methods are to use the sparse path for a state
    /// of `n` components, decided on the first call from
    /// [`Options::linear_solver`](crate::Options::linear_solver) and the model's
    /// [`System::sparse_jacobian`] (asked only when the choice may be sparse).
    pub(crate) fn sparse_pattern(&mut self, n: usize) -> Result<Option<crate::jacobian::Pattern>> {
        let sys = self.sys;
        self.sparse.pattern(n, |n| sys.sparse_jacobian(n))
    }

    /// `values ← J(t, x)` in the pattern of [`sparse_pattern`](Self::sparse_pattern),
    /// counted as a Jacobian evaluation and checked (a non-finite entry is reported at
    /// its row-major index `row·n + col`, as the dense path reports).
    pub(crate) fn sparse_jacobian(&mut self, t: f64, x: &OVector<f64, D>, values: &mut [f64]) -> Result<()> {
        self.stats.jacobian_evals += 1;
        let Some(component) = self.sparse.eval(t, x.as_slice(), &self.u, values)? else {
            return Ok(());
        };
        let mut dx = x.clone();
        self.sys.rhs(t, x, &self.u, &mut dx);
        if dx.len() != x.len() {
            return Err(Error::invalid(
                "model",
                format!("f returned {} components for a state of {}", dx.len(), x.len()),
            ));
        }
        Err(Error::NonFinite {
            t,
            quantity: Quantity::Jacobian,
            component,
        })
    }
}

/// `Ok` when every value is finite, else [`Error::NonFinite`] naming the first bad one.
#[inline]
pub(crate) fn finite(v: &[f64], t: f64, quantity: Quantity) -> Result<()> {
    if !crate::linalg::any_non_finite(v) {
        return Ok(());
    }
    let component = v.iter().position(|a| !a.is_finite()).unwrap_or(0);
    Err(Error::NonFinite { t, quantity, component })
}

/// The derivative parts of `r` (`n` duals with `m` directions) into `ds` column-major;
/// NaN for a result of the wrong length (the driver reports it).
pub(crate) fn write_eps<D: Dim, M: Dim>(r: &OVector<DualVec64<M>, D>, n: usize, m: usize, ds: &mut [f64])
where
    DefaultAllocator: Allocator<D> + Allocator<M>,
{
    if r.len() != n {
        ds.fill(f64::NAN);
        return;
    }
    for i in 0..n {
        match &r[i].eps.0 {
            Some(e) => {
                for k in 0..m {
                    ds[i + k * n] = e[k];
                }
            }
            None => {
                for k in 0..m {
                    ds[i + k * n] = 0.0;
                }
            }
        }
    }
}

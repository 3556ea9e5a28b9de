//! The model abstraction: `x' = f(t, x, u)` written once, evaluated at `f64` for
//! explicit methods and at dual numbers for exact Jacobians (num-dual).
//!
//! Notation follows Hairer–Nørsett–Wanner: `t` time, `x` state, `u` inputs held
//! constant over a control interval, `f` the right-hand side, `J = ∂f/∂x`.

use crate::error::Result;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector, U1};
use num_dual::DualVec64;
use std::marker::PhantomData;

mod eval;
mod flow;
pub(crate) mod lhs;
pub mod lti;
pub mod mass;
pub mod params;

#[doc(hidden)]
pub use eval::Eval;
pub use eval::Stats;
pub(crate) use eval::{finite, write_eps};
pub use flow::{DualFlow, Flow};
pub use lti::Lti;
pub use params::ParamModel;

/// A right-hand side `x' = f(t, x, u)` with its Jacobian `J = ∂f/∂x`.
///
/// Most users never implement this by hand: [`model!`](crate::model) turns a
/// closure into a `System` whose Jacobian is exact (automatic differentiation).
/// Implementing it directly is how a hand-written Jacobian can be supplied.
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{vector, Matrix2};
/// let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
/// let mut dx = vector![0.0, 0.0];
/// f.rhs(0.0, &vector![1.0, 2.0], &[], &mut dx);
/// assert_eq!(dx, vector![2.0, -1.0]);
/// let mut j = Matrix2::zeros();
/// f.jacobian(0.0, &vector![1.0, 2.0], &[], &mut j);
/// assert_eq!(j, Matrix2::new(0.0, 1.0, -1.0, 0.0));
/// ```
pub trait System<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Number of held inputs `u` the model reads (0 for an autonomous model).
    fn inputs(&self) -> usize {
        0
    }
    /// `dx ← f(t, x, u)`.
    fn rhs(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dx: &mut OVector<f64, D>);
    /// `jac ← ∂f/∂x (t, x, u)`.
    fn jacobian(&self, t: f64, x: &OVector<f64, D>, u: &[f64], jac: &mut OMatrix<f64, D, D>)
    where
        DefaultAllocator: Allocator<D, D>;
    /// `dfdt ← ∂f/∂t (t, x, u)` if the model can give it exactly; returns `false`
    /// (the default, `dfdt` untouched) when it cannot. Rosenbrock methods need this term
    /// for non-autonomous models and fall back to a forward difference in `t` without it.
    fn time_derivative(&self, _t: f64, _x: &OVector<f64, D>, _u: &[f64], _dfdt: &mut OVector<f64, D>) -> bool {
        false
    }
    /// An evaluator of `J` into its sparsity pattern, for a state of `n` components, if
    /// the model can give one (a traced [`model!`](crate::model): the compiled symbolic
    /// Jacobian). `None` (the default): the implicit methods use the dense [`jacobian`](Self::jacobian).
    fn sparse_jacobian(&self, _n: usize) -> Option<Box<dyn crate::jacobian::SparseJacobian + '_>> {
        None
    }
    /// `Some(b)` when `J` has the block form `[[A, 0], [L, blockdiag(A, …, A)]]` with `A`
    /// of size `b × b` (the stacked state of [`crate::sensitivity`]): the implicit methods
    /// then factor `a·I + b·A` once and solve block by block. `None` (the default): no such
    /// structure.
    fn jacobian_blocks(&self) -> Option<usize> {
        None
    }
    /// The model traced into expressions ([`crate::symbolic::trace`]) for a state of `n`
    /// components: `None` for a model with no traced copy of its body (the default, and
    /// any hand-written `System`), `Some(Err(`[`Error::Untraceable`]`))` for a body whose
    /// control flow depends on the state.
    fn symbolic(&self, _n: usize) -> Option<Result<crate::symbolic::Traced>> {
        None
    }
    /// What this model's [`sparse_jacobian`](Self::sparse_jacobian) calls did with the
    /// compiled-program cache ([`crate::symbolic::cache`]): bodies recorded, traced and
    /// compiled. All zero (the default) for a model that is not traced.
    ///
    /// ```
    /// use reckon::{studies::problems::brusselator, System};
    /// let f = brusselator(40);
    /// let _ = f.sparse_jacobian(80).unwrap();
    /// assert_eq!(f.trace_counts().records, 1);
    /// assert!(f.trace_counts().traces <= 1); // 0 when another brusselator(40) was traced before
    /// ```
    fn trace_counts(&self) -> crate::symbolic::TraceCounts {
        crate::symbolic::TraceCounts::default()
    }
}

impl<D: Dim, T: System<D> + ?Sized> System<D> for &T
where
    DefaultAllocator: Allocator<D>,
{
    fn inputs(&self) -> usize {
        (**self).inputs()
    }
    #[inline(always)]
    fn rhs(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dx: &mut OVector<f64, D>) {
        (**self).rhs(t, x, u, dx)
    }
    fn jacobian(&self, t: f64, x: &OVector<f64, D>, u: &[f64], jac: &mut OMatrix<f64, D, D>)
    where
        DefaultAllocator: Allocator<D, D>,
    {
        (**self).jacobian(t, x, u, jac)
    }
    fn time_derivative(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        (**self).time_derivative(t, x, u, dfdt)
    }
    fn sparse_jacobian(&self, n: usize) -> Option<Box<dyn crate::jacobian::SparseJacobian + '_>> {
        (**self).sparse_jacobian(n)
    }
    fn symbolic(&self, n: usize) -> Option<Result<crate::symbolic::Traced>> {
        (**self).symbolic(n)
    }
    fn trace_counts(&self) -> crate::symbolic::TraceCounts {
        (**self).trace_counts()
    }
    fn jacobian_blocks(&self) -> Option<usize> {
        (**self).jacobian_blocks()
    }
}

/// A model given as one closure body instantiated twice: at `f64` (`F`) and at
/// num-dual's `DualVec64<D>` (`G`). Build it with [`model!`](crate::model).
///
/// `f(t, x, u)` runs at hand-written `f64` cost; `J = ∂f/∂x` is exact to rounding
/// because `G` propagates derivatives alongside values.
pub struct ClosureModel<D, F, G, T = NoTimeDerivative, Tr = crate::symbolic::NoTrace> {
    inputs: usize,
    f: F,
    g: G,
    dt: T,
    tr: Tr,
    /// What [`System::sparse_jacobian`] did: recordings, traces, compiles.
    counters: crate::symbolic::cache::Counters,
    _dim: PhantomData<D>,
}

impl<D, F: Clone, G: Clone, T: Clone, Tr: Clone> Clone for ClosureModel<D, F, G, T, Tr> {
    fn clone(&self) -> Self {
        ClosureModel {
            inputs: self.inputs,
            f: self.f.clone(),
            g: self.g.clone(),
            dt: self.dt.clone(),
            tr: self.tr.clone(),
            counters: Default::default(),
            _dim: PhantomData,
        }
    }
}

impl<D, F, G> ClosureModel<D, F, G> {
    /// Pair a real and a dual instantiation of the same body; `inputs` is the number
    /// of held inputs the body reads. Prefer [`model!`](crate::model).
    pub fn new(inputs: usize, f: F, g: G) -> Self {
        ClosureModel {
            inputs,
            f,
            g,
            dt: NoTimeDerivative,
            tr: crate::symbolic::NoTrace,
            counters: Default::default(),
            _dim: PhantomData,
        }
    }
}

impl<D, F, G, T, Tr> ClosureModel<D, F, G, T, Tr> {
    /// The same model with `∂f/∂t` given by `dt` ([`Autonomous`] or [`TimeDual`]).
    /// [`model!`](crate::model) does this for `|_, x: …|` and `|t: S, x: …|`.
    pub fn with_time_derivative<T2>(self, dt: T2) -> ClosureModel<D, F, G, T2, Tr> {
        ClosureModel {
            inputs: self.inputs,
            f: self.f,
            g: self.g,
            dt,
            tr: self.tr,
            counters: self.counters,
            _dim: PhantomData,
        }
    }

    /// The same model with a copy of its body on the tracing scalar
    /// ([`crate::symbolic::TraceFn`]), which gives its symbolic forms and its compiled
    /// sparse Jacobian. [`model!`](crate::model) does this for every body.
    pub fn with_trace<Tr2>(self, tr: Tr2) -> ClosureModel<D, F, G, T, Tr2> {
        ClosureModel {
            inputs: self.inputs,
            f: self.f,
            g: self.g,
            dt: self.dt,
            tr,
            counters: Default::default(),
            _dim: PhantomData,
        }
    }
}

impl<D, F, G, T, Tr> ClosureModel<D, F, G, T, Tr> {
    /// How many times [`System::sparse_jacobian`] traced the body: recorded it *and*
    /// differentiated and flattened it, because no equal recording was in the compiled-program
    /// cache ([`crate::symbolic::cache`]). A model rebuilt with the same structure traces 0 times.
    ///
    /// ```
    /// use reckon::{model, System};
    /// use nalgebra::DVector;
    /// let f = model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].tanh() * 0.375));
    /// let _ = f.sparse_jacobian(67).unwrap();
    /// let again = model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].tanh() * 0.375));
    /// let _ = again.sparse_jacobian(67).unwrap();
    /// assert_eq!((again.records(), again.traces(), again.compiles()), (1, 0, 0));
    /// ```
    pub fn traces(&self) -> usize {
        crate::symbolic::cache::Counters::get(&self.counters.traces)
    }
    /// How many times [`System::sparse_jacobian`] recorded the body on the tracing scalar
    /// (once per call: the recording is the cache's key, so a captured value that changed
    /// is always seen).
    ///
    /// ```
    /// use reckon::{model, System};
    /// use nalgebra::DVector;
    /// let f = model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].atan() * 0.625));
    /// let _ = f.sparse_jacobian(68).unwrap();
    /// let _ = f.sparse_jacobian(68).unwrap();
    /// assert_eq!(f.records(), 2);
    /// ```
    pub fn records(&self) -> usize {
        crate::symbolic::cache::Counters::get(&self.counters.records)
    }
    /// How many times [`System::sparse_jacobian`] generated native code (Cranelift) for
    /// this model: 0 when a program of the same shape was compiled before.
    ///
    /// ```
    /// use reckon::{model, System};
    /// use nalgebra::DVector;
    /// let f = model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].sinh() * 0.875));
    /// let _ = f.sparse_jacobian(69).unwrap();
    /// let _ = f.sparse_jacobian(69).unwrap();
    /// assert!(f.compiles() <= 1); // at most the first call compiled
    /// ```
    pub fn compiles(&self) -> usize {
        crate::symbolic::cache::Counters::get(&self.counters.compiles)
    }
}

/// The model's name for messages: the path of the function whose body defined it.
pub(crate) fn model_name<F>() -> String {
    let name = std::any::type_name::<F>();
    name.strip_suffix("::{{closure}}").unwrap_or(name).to_string()
}

/// How a [`ClosureModel`] provides `∂f/∂t`.
pub trait TimeDerivative<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// `dfdt ← ∂f/∂t (t, x, u)`; `false` if not available.
    fn time_derivative(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dfdt: &mut OVector<f64, D>) -> bool;
}

/// `∂f/∂t` is not available (a `model!` whose time argument is a plain `f64` name).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoTimeDerivative;

impl<D: Dim> TimeDerivative<D> for NoTimeDerivative
where
    DefaultAllocator: Allocator<D>,
{
    fn time_derivative(&self, _t: f64, _x: &OVector<f64, D>, _u: &[f64], _dfdt: &mut OVector<f64, D>) -> bool {
        false
    }
}

/// `∂f/∂t = 0`: the model does not read `t` (`model!(|_, x: …| …)`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Autonomous;

impl<D: Dim> TimeDerivative<D> for Autonomous
where
    DefaultAllocator: Allocator<D>,
{
    fn time_derivative(&self, _t: f64, _x: &OVector<f64, D>, _u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        dfdt.fill(0.0);
        true
    }
}

/// `∂f/∂t = ε-part of f(t + ε, x, u)`: the body instantiated at num-dual's `Dual64`
/// with `t` seeded (derivative 1) and `x` constant (`model!(|t: S, x: …| …)`).
#[derive(Clone)]
pub struct TimeDual<H>(pub H);

impl<D: Dim, H> TimeDerivative<D> for TimeDual<H>
where
    H: Fn(f64, &OVector<f64, D>, &[f64]) -> OVector<num_dual::Dual64, D>,
    DefaultAllocator: Allocator<D>,
{
    fn time_derivative(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        let r = (self.0)(t, x, u);
        if r.len() == dfdt.len() {
            for (d, v) in dfdt.iter_mut().zip(r.iter()) {
                *d = v.eps;
            }
        } else {
            // wrong length: NaN, which `Eval::time_derivative` reports
            dfdt.fill(f64::NAN);
        }
        true
    }
}

impl<D: crate::jacobian::colour::ColourDim, F, G, T, Tr> System<D> for ClosureModel<D, F, G, T, Tr>
where
    F: Fn(f64, &OVector<f64, D>, &[f64]) -> OVector<f64, D>,
    G: Fn(f64, &OVector<DualVec64<D>, D>, &[f64]) -> OVector<DualVec64<D>, D>,
    T: TimeDerivative<D>,
    Tr: crate::symbolic::TraceBody<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    fn inputs(&self) -> usize {
        self.inputs
    }
    #[inline(always)]
    fn rhs(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dx: &mut OVector<f64, D>) {
        *dx = (self.f)(t, x, u);
    }
    fn jacobian(&self, t: f64, x: &OVector<f64, D>, u: &[f64], jac: &mut OMatrix<f64, D, D>)
    where
        DefaultAllocator: Allocator<D, D>,
    {
        let (_, j) = num_dual::jacobian(
            |xd: OVector<DualVec64<D>, D>| {
                let r = (self.g)(t, &xd, u);
                if r.len() == xd.len() {
                    r
                } else {
                    // a wrong-length output (num-dual cannot even build an empty
                    // Jacobian): NaN of the right shape, which `Eval::jacobian` reports
                    // as the model's length error
                    xd.map(|v| v * f64::NAN)
                }
            },
            x,
        );
        *jac = j;
    }
    fn time_derivative(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        self.dt.time_derivative(t, x, u, dfdt)
    }
    fn trace_counts(&self) -> crate::symbolic::TraceCounts {
        self.counters.counts()
    }
    fn symbolic(&self, n: usize) -> Option<Result<crate::symbolic::Traced>> {
        let shape = crate::symbolic::Shape {
            n,
            m: self.inputs,
            p: &[],
        };
        self.tr
            .traceable()
            .then(|| crate::symbolic::trace_body(&self.tr, &model_name::<F>(), &shape))
    }
    /// The compiled symbolic Jacobian when the body can be traced; for a `DVector` body that
    /// cannot be (its control flow depends on the state or on a plain-f64 time), num-dual
    /// with a column colouring of the pattern detected from the body
    /// ([`ColourDim`](crate::jacobian::colour::ColourDim)).
    ///
    /// Every call records the body on the tracing scalar and takes the compiled Jacobian of
    /// an equal recording from the compiled-program cache ([`crate::symbolic::cache`]), so a
    /// model kept or rebuilt with the same structure skips the differentiation and the
    /// compile, and one whose captured values changed is traced afresh.
    fn sparse_jacobian(&self, n: usize) -> Option<Box<dyn crate::jacobian::SparseJacobian + '_>> {
        if self.tr.traceable() {
            let shape = crate::symbolic::Shape {
                n,
                m: self.inputs,
                p: &[],
            };
            if let Ok(c) = crate::symbolic::cached_jacobian(&self.tr, &model_name::<F>(), &shape, &self.counters) {
                return Some(Box::new(c));
            }
        }
        D::coloured(&self.g, n, self.inputs)
    }
}

/// A model that can also be evaluated on num-dual numbers, so that maps built from it
/// (a whole integration step, say) can be differentiated exactly.
pub trait DualSystem<D: Dim>: System<D>
where
    DefaultAllocator: Allocator<D> + Allocator<U1, D>,
{
    /// `f(t, x, u)` at dual `x`.
    fn rhs_dual(&self, t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64]) -> OVector<DualVec64<D>, D>;
    /// Number of model parameters `n_p` (a [`model!`](crate::model) parameter block; 0 by default).
    fn n_params(&self) -> usize {
        0
    }
    /// The parameter values (empty by default).
    fn params(&self) -> &[f64] {
        &[]
    }
    /// `dx ← f(t, x, u)` and `ds ← J·S + [0 | ∂f/∂p]` for the `n × m` sensitivity matrix
    /// `S` stored column-major in `s` (and `ds`), whose last `n_p` columns are those of the
    /// parameters (`m = n + n_p`: `∂/∂(x₀, p)`; `m = n_p`: `∂/∂p` only): the right-hand
    /// side of [`crate::sensitivity`]. The default (`n_p = 0`, `m ≤ n`) evaluates
    /// [`rhs_dual`](Self::rhs_dual) at `x` with the rows of `S` as derivative parts, so
    /// `J·S` is exact to rounding, and `f` with [`rhs`](System::rhs).
    ///
    /// ```
    /// use reckon::{model, DualSystem};
    /// use nalgebra::vector;
    /// let f = model!(|_, x: [S; 2]| vector![x[1], -x[0]]);
    /// let (mut dx, mut ds) = (vector![0.0, 0.0], [0.0; 4]);
    /// // S = I: Ṡ = J = [[0, 1], [−1, 0]] (column-major)
    /// f.rhs_sensitivity(0.0, &vector![1.0, 0.0], &[], &[1.0, 0.0, 0.0, 1.0], 2, &mut dx, &mut ds);
    /// assert_eq!((dx, ds), (vector![0.0, -1.0], [0.0, -1.0, 1.0, 0.0]));
    /// ```
    #[allow(clippy::too_many_arguments)]
    fn rhs_sensitivity(
        &self,
        t: f64,
        x: &OVector<f64, D>,
        u: &[f64],
        s: &[f64],
        m: usize,
        dx: &mut OVector<f64, D>,
        ds: &mut [f64],
    ) {
        self.tangent(t, x, u, s, m, ds);
        self.rhs(t, x, u, dx);
    }
    /// `ds ← J·S + [0 | ∂f/∂p]` alone, as in [`rhs_sensitivity`](Self::rhs_sensitivity)
    /// without `f`: the one dual evaluation a scheme needs when it has `f` already (the
    /// stages of [`Rk45`](crate::methods::Rk45)'s staggered sensitivities).
    ///
    /// ```
    /// use reckon::{model, DualSystem};
    /// use nalgebra::vector;
    /// let f = model!(|_, x: [S; 2]| vector![x[0] * x[1], -x[0]]);
    /// let mut ds = [0.0; 2];
    /// // one column s = (1, 2): J·s = (x₁·1 + x₀·2, −1) at x = (3, 4)
    /// f.tangent(0.0, &vector![3.0, 4.0], &[], &[1.0, 2.0], 1, &mut ds);
    /// assert_eq!(ds, [10.0, -1.0]);
    /// ```
    fn tangent(&self, t: f64, x: &OVector<f64, D>, u: &[f64], s: &[f64], m: usize, ds: &mut [f64]) {
        let n = x.len();
        let (r, _) = x.shape_generic();
        if m > n {
            ds.fill(f64::NAN);
            return;
        }
        let xd = x.map_with_location(|i, _, v| {
            DualVec64::new(
                v,
                num_dual::Derivative::some(OVector::<f64, D>::from_fn_generic(r, U1, |k, _| {
                    if k < m { s[i + k * n] } else { 0.0 }
                })),
            )
        });
        let out = self.rhs_dual(t, &xd, u);
        crate::model::write_eps(&out, n, m, ds);
    }
}

impl<D: crate::jacobian::colour::ColourDim, F, G, T, Tr> DualSystem<D> for ClosureModel<D, F, G, T, Tr>
where
    F: Fn(f64, &OVector<f64, D>, &[f64]) -> OVector<f64, D>,
    G: Fn(f64, &OVector<DualVec64<D>, D>, &[f64]) -> OVector<DualVec64<D>, D>,
    T: TimeDerivative<D>,
    Tr: crate::symbolic::TraceBody<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    fn rhs_dual(&self, t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64]) -> OVector<DualVec64<D>, D> {
        (self.g)(t, x, u)
    }
}

impl<D: Dim, T: DualSystem<D> + ?Sized> DualSystem<D> for &T
where
    DefaultAllocator: Allocator<D> + Allocator<U1, D>,
{
    fn rhs_dual(&self, t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64]) -> OVector<DualVec64<D>, D> {
        (**self).rhs_dual(t, x, u)
    }
    fn n_params(&self) -> usize {
        (**self).n_params()
    }
    fn params(&self) -> &[f64] {
        (**self).params()
    }
    fn rhs_sensitivity(
        &self,
        t: f64,
        x: &OVector<f64, D>,
        u: &[f64],
        s: &[f64],
        m: usize,
        dx: &mut OVector<f64, D>,
        ds: &mut [f64],
    ) {
        (**self).rhs_sensitivity(t, x, u, s, m, dx, ds)
    }
    fn tangent(&self, t: f64, x: &OVector<f64, D>, u: &[f64], s: &[f64], m: usize, ds: &mut [f64]) {
        (**self).tangent(t, x, u, s, m, ds)
    }
}

/// Turn a closure body into a [`System`] with an exact autodiff Jacobian.
///
/// `model!(|t, x: [S; N]| body)` for a fixed-size state `SVector<S, N>`,
/// `model!(|t, x: [S; Dyn]| body)` for a `DVector<S>`, and `, u: [M]` after the state
/// for `M` held inputs (`u: &[f64]`). The body is written once and compiled twice,
/// with `S = f64` and with `S` a num-dual number (three times with `t: S`, and three with a
/// fixed-size parameter block: duals of `n + n_p` directions, and of `n_p` for the
/// sensitivities to the parameters alone, [`ParamsBody`](crate::model::params::ParamsBody)), so it must be generic in spirit.
/// Float literals may stand on either side of an operator (`2.0 * x[0]`, see below);
/// a captured `f64` variable goes on the right (`x[0] * mu`) or is lifted
/// (`S::from(mu) * x[0]`), and so does a value that does not depend on the state
/// (`S::from(u[1])`). Captured variables are moved into every copy: capture
/// `Copy` values or references.
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{vector, Matrix3};
/// // unicycle: x' = v cos θ, y' = v sin θ, θ' = ω with u = (v, ω)
/// let f = model!(|_t, x: [S; 3], u: [2]| vector![x[2].cos() * u[0], x[2].sin() * u[0], S::from(u[1])]);
/// let mut j = Matrix3::zeros();
/// f.jacobian(0.0, &vector![0.0, 0.0, 0.5], &[2.0, 0.1], &mut j);
/// assert!((j[(0, 2)] + 2.0 * 0.5f64.sin()).abs() < 1e-15); // ∂ẋ/∂θ = −v sin θ
/// ```
///
/// **Time.** A plain `t` is an `f64` in the body. Write `t: S` (the state's scalar name)
/// to see `t` as `S` instead: the body is then also compiled a third time at num-dual's
/// `Dual64` with `t` seeded and `x` constant, which gives the exact `∂f/∂t` that
/// Rosenbrock methods ([`Rodas5P`](crate::methods::Rodas5P)) need for non-autonomous
/// models ([`System::time_derivative`]); without it they take a forward difference in
/// `t`. A time pattern written `_` marks the model autonomous: `∂f/∂t = 0` exactly.
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::vector;
/// let f = model!(|t: S, x: [S; 1]| vector![x[0] * t.sin()]);
/// let mut d = vector![0.0];
/// assert!(f.time_derivative(0.5, &vector![2.0], &[], &mut d));
/// assert!((d[0] - 2.0 * 0.5f64.cos()).abs() < 1e-15); // ∂/∂t (x sin t) = x cos t
/// let g = model!(|_, x: [S; 1]| vector![-x[0]]);
/// assert!(g.time_derivative(0.5, &vector![2.0], &[], &mut d) && d[0] == 0.0);
/// let h = model!(|t, x: [S; 1]| vector![x[0] * t]);
/// assert!(!h.time_derivative(0.5, &vector![2.0], &[], &mut d)); // not available
/// ```
///
/// # Common mistakes, and what they do
///
/// `abs()`, `signum()`, `sqrt()`, `powi()`, `sin()`… work on `S` in the body with no import:
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{vector, Matrix1};
/// // quadratic drag: v' = −c·v·|v|
/// let f = model!(|_t, x: [S; 1]| vector![-x[0] * x[0].abs() * 0.5 + x[0].signum() * 0.0]);
/// let mut j = Matrix1::zeros();
/// f.jacobian(0.0, &vector![-3.0], &[], &mut j);
/// assert_eq!(j[(0, 0)], -3.0); // ∂/∂v (−v|v|/2) = −|v|
/// ```
///
/// Helper functions take the scalar as a generic `S: DualNum<Primitive = f64>` (num-dual's trait,
/// re-exported as `reckon::num_dual::DualNum`), so that both copies can call them:
///
/// ```
/// use reckon::{model, System, num_dual::DualNum};
/// use nalgebra::{vector, Matrix2};
/// /// Duffing spring force `k·x + β·x³`.
/// fn spring<S: DualNum<Primitive = f64>>(x: &S, k: f64, beta: f64) -> S {
///     x.clone() * k + x.powi(3) * beta
/// }
/// let f = model!(|_t, x: [S; 2]| vector![x[1].clone(), -spring(&x[0], 1.0, 0.1)]);
/// let mut j = Matrix2::zeros();
/// f.jacobian(0.0, &vector![2.0, 0.0], &[], &mut j);
/// assert!((j[(1, 0)] + (1.0 + 0.3 * 4.0)).abs() < 1e-15); // −(k + 3βx²)
/// ```
///
/// Writing the state as `[f64; N]` is refused with a message that names the fix
/// (`S` must be a name the macro can define as `f64` and as a dual number):
///
/// ```compile_fail
/// let f = reckon::model!(|_t, x: [f64; 2]| reckon::vector![x[1], -x[0]]);
/// ```
///
/// **Literals on the left.** `2.0 * x[0]` has no meaning in the dual copy by itself:
/// Rust's orphan rule lets no crate but num-dual define `f64 × dual`. So `model!`
/// rewrites every float literal that is the left operand of a binary `+ - * /` into a
/// reckon type with those operators (`Lhs(2.0) * x[0]`, a call, so precedence is
/// unchanged). The values are bit for bit Rust's `f64` ones, and the dual copy gets the
/// derivative of the expression as written:
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{vector, Matrix2};
/// // Van der Pol, μ = 1, written as on paper
/// let f = model!(|_t, x: [S; 2]| vector![2.0 * x[1] - x[1], (1.0 - x[0] * x[0]) * x[1] - x[0]]);
/// let (x, mut dx, mut j) = (vector![2.0, 0.5], vector![0.0, 0.0], Matrix2::zeros());
/// f.rhs(0.0, &x, &[], &mut dx);
/// assert_eq!(dx, vector![2.0 * 0.5 - 0.5, (1.0 - 2.0 * 2.0) * 0.5 - 2.0]);
/// f.jacobian(0.0, &x, &[], &mut j);
/// assert_eq!(j, Matrix2::new(0.0, 1.0, -2.0 * 2.0 * 0.5 - 1.0, 1.0 - 2.0 * 2.0));
/// ```
///
/// A negated literal is one operand (`-3.0 * x` is Rust's `(-3.0) * x`), and a literal
/// on the left of `/` gives the quotient rule:
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{vector, Matrix1};
/// let f = model!(|_t, x: [S; 1]| vector![-3.0 * x[0] + 2.0 / x[0]]);
/// let (mut dx, mut j) = (vector![0.0], Matrix1::zeros());
/// f.rhs(0.0, &vector![4.0], &[], &mut dx);
/// assert_eq!(dx[0], -3.0 * 4.0 + 2.0 / 4.0);
/// f.jacobian(0.0, &vector![4.0], &[], &mut j);
/// assert_eq!(j[(0, 0)], -3.0 - 2.0 / 16.0);
/// ```
///
/// An expression of literals alone is still an `f64`, and integer literals are never
/// touched (`2 * n` stays a `usize`):
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{DVector, DMatrix};
/// let f = model!(|_t, x: [S; Dyn]| {
///     let half: f64 = 1.0 - 0.5;
///     let n = x.len();
///     DVector::from_fn(n, |i, _| x[(i + 2 * n - 1) % n].clone() * half)
/// });
/// let (mut dx, mut j) = (DVector::zeros(3), DMatrix::zeros(3, 3));
/// f.rhs(0.0, &DVector::from_vec(vec![1.0, 2.0, 3.0]), &[], &mut dx);
/// assert_eq!(dx.as_slice(), &[1.5, 0.5, 1.0]);
/// f.jacobian(0.0, &DVector::from_vec(vec![1.0, 2.0, 3.0]), &[], &mut j);
/// assert_eq!(j[(0, 2)], 0.5);
/// ```
///
/// Literals inside macro calls are lifted too:
///
/// ```
/// use reckon::{model, vector, System};
/// let f = model!(|_t, x: [S; 2]| vector![2.0 * x[1], 0.5 * x[0] - 1.0]);
/// let mut dx = vector![0.0, 0.0];
/// f.rhs(0.0, &vector![3.0, 4.0], &[], &mut dx);
/// assert_eq!(dx, vector![8.0, 0.5]);
/// ```
///
/// A captured `f64` *variable* on the left, `mu * x[0]`, cannot be lifted this way (the
/// macro sees a name, not a number) and does not compile in the dual copy, where the
/// compiler lists every `Mul` impl for `f64`. Write `x[0] * mu` or `S::from(mu) * x[0]`.
/// The same holds for any `f64` expression on the left: `u[0] * x[1]`, `(2.0 * mu) * x[0]`,
/// or `2.0 * 3.0 * x[0]` (that is `(2.0 * 3.0) * x[0]`; write `6.0 * x[0]`):
///
/// ```compile_fail,E0277
/// let mu = 2.0;
/// let f = reckon::model!(|_t, x: [S; 1]| reckon::vector![mu * x[0]]);
/// ```
///
/// ```
/// let mu = 2.0;
/// let f = reckon::model!(|_t, x: [S; 1]| reckon::vector![S::from(mu) * x[0] + x[0] * mu]);
/// # let _ = f;
/// ```
///
/// Only `f64` literals are lifted: `2.0f32 * y` is left as written, but an unsuffixed
/// literal is taken for an `f64`, so `2.0 * y` with `y: f32` does not compile in a body
/// (write `y * 2.0`).
#[macro_export]
macro_rules! model {
    (|$t:tt, $x:ident : [f64; $($rest:tt)*] $($more:tt)*) => {
        ::core::compile_error!(
            "model!: the state's scalar must be a type *name* the macro defines twice, not f64: \
             write `x: [S; N]` (or `[S; Dyn]`) and use `S` in the body (`S::from(2.0)`); \
             S is f64 for values and a dual number for the Jacobian"
        )
    };
    (|$t:tt : $ts:ident, $x:ident : [f64; $($rest:tt)*] $($more:tt)*) => {
        ::core::compile_error!(
            "model!: the state's scalar must be a type *name* the macro defines, not f64: \
             write `|t: S, x: [S; N]|` and use `S` in the body"
        )
    };
    (|$t:tt : f64, $($rest:tt)*) => {
        ::core::compile_error!(
            "model!: write the time as `t: S` (the state's scalar name: exact ∂f/∂t by \
             autodiff) or as a plain `t` (an f64)"
        )
    };
    // a parameter block `p: [S; P] = [p₁, …]`: a ParamModel (sensitivities to p)
    (|$t:tt : $ts:ident, $x:ident : [$s:ident; $n:tt], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        ::core::compile_error!(
            "model!: a parameter block goes with a plain `t` or `_` time, not `t: S` \
             (write `|t, x: [S; N], p: [S; P] = [...]|`)"
        )
    };
    (|$t:tt : $ts:ident, $x:ident : [$s:ident; $n:tt], $u:ident : [$m:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        ::core::compile_error!(
            "model!: a parameter block goes with a plain `t` or `_` time, not `t: S` \
             (write `|t, x: [S; N], p: [S; P] = [...]|`)"
        )
    };
    (|_, $x:ident : [$s:ident; Dyn], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pdyn auto, 0, _, $x, $s, _, $p, $np, $pv, $body)
    };
    (|_, $x:ident : [$s:ident; Dyn], $u:tt : [$m:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pdyn auto, $m, _, $x, $s, $u, $p, $np, $pv, $body)
    };
    (|_, $x:ident : [$s:ident; $n:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pfixed auto, 0, $n, _, $x, $s, _, $p, $np, $pv, $body)
    };
    (|_, $x:ident : [$s:ident; $n:expr], $u:tt : [$m:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pfixed auto, $m, $n, _, $x, $s, $u, $p, $np, $pv, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; Dyn], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pdyn plain, 0, $t, $x, $s, _, $p, $np, $pv, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; Dyn], $u:tt : [$m:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pdyn plain, $m, $t, $x, $s, $u, $p, $np, $pv, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; $n:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pfixed plain, 0, $n, $t, $x, $s, _, $p, $np, $pv, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; $n:expr], $u:tt : [$m:expr], $p:ident : [$ps:ident; $np:expr] = $pv:tt| $body:expr) => {
        $crate::model!(@pfixed plain, $m, $n, $t, $x, $s, $u, $p, $np, $pv, $body)
    };
    (@ptime plain, $model:expr) => { $model };
    (@ptime auto, $model:expr) => { $model.with_time_derivative($crate::model::Autonomous) };
    (@pfixed $mode:ident, $m:expr, $n:expr, $t:tt, $x:ident, $s:ident, $u:tt, $p:ident, $np:expr, $pv:tt, $body:expr) => {{
        let __pv: [f64; $np] = $pv;
        $crate::model!(@ptime $mode, $crate::ParamModel::<
            $crate::nalgebra::Const<{ $n }>,
            $crate::nalgebra::Const<{ $n + $np }>,
            _,
            _,
        >::new(
            $m,
            &__pv,
            #[allow(unused_variables, clippy::clone_on_copy)]
            #[inline(always)]
            move |__t: f64,
                  $x: &$crate::nalgebra::SVector<f64, { $n }>,
                  $u: &[f64],
                  $p: &[f64]|
                  -> $crate::nalgebra::SVector<f64, { $n }> {
                $crate::model!(@body $mode, $t, __t, $s, f64, $body)
            },
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  $x: &$crate::nalgebra::SVector<$crate::num_dual::DualSVec64<{ $n + $np }>, { $n }>,
                  $u: &[f64],
                  $p: &[$crate::num_dual::DualSVec64<{ $n + $np }>]|
                  -> $crate::nalgebra::SVector<$crate::num_dual::DualSVec64<{ $n + $np }>, { $n }> {
                $crate::model!(@body $mode, $t, __t, $s, $crate::num_dual::DualSVec64<{ $n + $np }>, $body)
            },
        )
        .with_params_tangent($crate::model::params::ParamsBody::<$crate::nalgebra::Const<{ $np }>, _>::new(
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  $x: &$crate::nalgebra::SVector<$crate::num_dual::DualSVec64<{ $np }>, { $n }>,
                  $u: &[f64],
                  $p: &[$crate::num_dual::DualSVec64<{ $np }>]|
                  -> $crate::nalgebra::SVector<$crate::num_dual::DualSVec64<{ $np }>, { $n }> {
                $crate::model!(@body $mode, $t, __t, $s, $crate::num_dual::DualSVec64<{ $np }>, $body)
            },
        ))
        .with_trace($crate::model!(@ptrace $mode, $crate::nalgebra::SVector<$crate::symbolic::Sym, { $n }>, $t, $x, $s, $u, $p, $body)))
    }};
    (@pdyn $mode:ident, $m:expr, $t:tt, $x:ident, $s:ident, $u:tt, $p:ident, $np:expr, $pv:tt, $body:expr) => {{
        let __pv: [f64; $np] = $pv;
        $crate::model!(@ptime $mode, $crate::ParamModel::<$crate::nalgebra::Dyn, $crate::nalgebra::Dyn, _, _>::new(
            $m,
            &__pv,
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64, $x: &$crate::nalgebra::DVector<f64>, $u: &[f64], $p: &[f64]| -> $crate::nalgebra::DVector<f64> {
                $crate::model!(@body $mode, $t, __t, $s, f64, $body)
            },
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  $x: &$crate::nalgebra::DVector<$crate::num_dual::DualDVec64>,
                  $u: &[f64],
                  $p: &[$crate::num_dual::DualDVec64]|
                  -> $crate::nalgebra::DVector<$crate::num_dual::DualDVec64> {
                $crate::model!(@body $mode, $t, __t, $s, $crate::num_dual::DualDVec64, $body)
            },
        )
        .with_trace($crate::model!(@ptrace $mode, $crate::nalgebra::DVector<$crate::symbolic::Sym>, $t, $x, $s, $u, $p, $body)))
    }};
    (@ptrace $mode:ident, $vec:ty, $t:tt, $x:ident, $s:ident, $u:tt, $p:ident, $body:expr) => {
        $crate::symbolic::TraceParamsFn::new(
            $crate::model!(@plain $mode, $t, $body),
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: $crate::symbolic::Sym,
                  $x: &$vec,
                  $u: &[$crate::symbolic::Sym],
                  $p: &[$crate::symbolic::Sym]|
                  -> $vec {
                #[allow(unused_imports)]
                use $crate::num_dual::DualNum as _;
                #[allow(unused_imports)]
                use $crate::__private::Signed as _;
                #[allow(dead_code)]
                type $s = $crate::symbolic::Sym;
                $crate::model!(@ttrace $mode, $t, $s, __t);
                $crate::__private::lift_literals!($crate, $body)
            },
        )
    };
    // typed time `t: S`: exact ∂f/∂t from a third instantiation at Dual64
    (|$t:tt : $ts:ident, $x:ident : [$s:ident; Dyn]| $body:expr) => {
        $crate::model!(@dyn typed, 0, $t, $x, $s, _, $body)
    };
    (|$t:tt : $ts:ident, $x:ident : [$s:ident; Dyn], $u:tt : [$m:expr]| $body:expr) => {
        $crate::model!(@dyn typed, $m, $t, $x, $s, $u, $body)
    };
    (|$t:tt : $ts:ident, $x:ident : [$s:ident; $n:expr]| $body:expr) => {
        $crate::model!(@fixed typed, 0, $n, $t, $x, $s, _, $body)
    };
    (|$t:tt : $ts:ident, $x:ident : [$s:ident; $n:expr], $u:tt : [$m:expr]| $body:expr) => {
        $crate::model!(@fixed typed, $m, $n, $t, $x, $s, $u, $body)
    };
    // time pattern `_`: autonomous, ∂f/∂t = 0
    (|_, $x:ident : [$s:ident; Dyn]| $body:expr) => {
        $crate::model!(@dyn auto, 0, _, $x, $s, _, $body)
    };
    (|_, $x:ident : [$s:ident; Dyn], $u:tt : [$m:expr]| $body:expr) => {
        $crate::model!(@dyn auto, $m, _, $x, $s, $u, $body)
    };
    (|_, $x:ident : [$s:ident; $n:expr]| $body:expr) => {
        $crate::model!(@fixed auto, 0, $n, _, $x, $s, _, $body)
    };
    (|_, $x:ident : [$s:ident; $n:expr], $u:tt : [$m:expr]| $body:expr) => {
        $crate::model!(@fixed auto, $m, $n, _, $x, $s, $u, $body)
    };
    // plain `t` (an f64): no ∂f/∂t
    (|$t:tt, $x:ident : [$s:ident; Dyn]| $body:expr) => {
        $crate::model!(@dyn plain, 0, $t, $x, $s, _, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; Dyn], $u:ident : [$m:expr]| $body:expr) => {
        $crate::model!(@dyn plain, $m, $t, $x, $s, $u, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; $n:expr]| $body:expr) => {
        $crate::model!(@fixed plain, 0, $n, $t, $x, $s, _, $body)
    };
    (|$t:tt, $x:ident : [$s:ident; $n:expr], $u:tt : [$m:expr]| $body:expr) => {
        $crate::model!(@fixed plain, $m, $n, $t, $x, $s, $u, $body)
    };
    // one copy of the body at scalar `$ty` (named `$s` inside), with t as `$tv` sees it
    (@body $mode:ident, $t:tt, $tv:ident, $s:ident, $ty:ty, $body:expr) => {{
        #[allow(unused_imports)]
        use $crate::num_dual::DualNum as _;
        #[allow(unused_imports)]
        use $crate::__private::Signed as _;
        #[allow(dead_code)]
        type $s = $ty;
        $crate::model!(@tlet $mode, $t, $s, $tv);
        $crate::__private::lift_literals!($crate, $body)
    }};
    // how the body sees t: an f64 (plain, auto) or the scalar S (typed)
    (@tlet plain, $t:tt, $s:ident, $v:expr) => { let $t: f64 = $v; };
    (@tlet auto, $t:tt, $s:ident, $v:expr) => { let $t: f64 = $v; };
    (@tlet typed, $t:tt, $s:ident, $v:expr) => { let $t: $s = <$s>::from($v); };
    // how the traced copy sees t: +∞ (plain or `_`: a body that names a plain `t` is
    // refused before it runs, so this is only a guard against a hidden use, which records
    // a non-finite constant and is refused) or the time symbol (typed)
    (@ttrace plain, $t:tt, $s:ident, $v:expr) => { let $t: f64 = $crate::symbolic::plain_time(); };
    (@ttrace auto, $t:tt, $s:ident, $v:expr) => { let $t: f64 = $crate::symbolic::plain_time(); };
    (@ttrace typed, $t:tt, $s:ident, $v:expr) => { let $t: $s = $v; };
    // whether the body reads a plain-f64 time (its name occurs in the body): the trace
    // refuses such a body, whose branches on `t` it could record for one time only
    (@plain plain, $t:tt, $body:expr) => { $crate::__private::mentions!($t, $body) };
    (@plain auto, $t:tt, $body:expr) => { false };
    (@plain typed, $t:tt, $body:expr) => { false };
    (@trace $mode:ident, $vec:ty, $t:tt, $x:ident, $s:ident, $u:tt, $body:expr) => {
        $crate::symbolic::TraceFn::new(
            $crate::model!(@plain $mode, $t, $body),
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: $crate::symbolic::Sym, $x: &$vec, $u: &[$crate::symbolic::Sym]| -> $vec {
                #[allow(unused_imports)]
                use $crate::num_dual::DualNum as _;
                #[allow(unused_imports)]
                use $crate::__private::Signed as _;
                #[allow(dead_code)]
                type $s = $crate::symbolic::Sym;
                $crate::model!(@ttrace $mode, $t, $s, __t);
                $crate::__private::lift_literals!($crate, $body)
            },
        )
    };
    (@time plain, $model:expr, $($rest:tt)*) => { $model };
    (@time auto, $model:expr, $($rest:tt)*) => { $model.with_time_derivative($crate::model::Autonomous) };
    (@time typed, $model:expr, fixed, $n:expr, $t:tt, $x:ident, $s:ident, $u:tt, $body:expr) => {
        $model.with_time_derivative($crate::model::TimeDual(
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  __x: &$crate::nalgebra::SVector<f64, { $n }>,
                  $u: &[f64]|
                  -> $crate::nalgebra::SVector<$crate::num_dual::Dual64, { $n }> {
                #[allow(unused_imports)]
                use $crate::num_dual::DualNum as _;
                #[allow(unused_imports)]
                use $crate::__private::Signed as _;
                #[allow(dead_code)]
                type $s = $crate::num_dual::Dual64;
                let __xd = __x.map(<$s>::from);
                let $x = &__xd;
                let $t: $s = $crate::num_dual::Dual64::new(__t, 1.0);
                $crate::__private::lift_literals!($crate, $body)
            },
        ))
    };
    (@time typed, $model:expr, dyn, $t:tt, $x:ident, $s:ident, $u:tt, $body:expr) => {
        $model.with_time_derivative($crate::model::TimeDual(
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  __x: &$crate::nalgebra::DVector<f64>,
                  $u: &[f64]|
                  -> $crate::nalgebra::DVector<$crate::num_dual::Dual64> {
                #[allow(unused_imports)]
                use $crate::num_dual::DualNum as _;
                #[allow(unused_imports)]
                use $crate::__private::Signed as _;
                #[allow(dead_code)]
                type $s = $crate::num_dual::Dual64;
                let __xd = __x.map(<$s>::from);
                let $x = &__xd;
                let $t: $s = $crate::num_dual::Dual64::new(__t, 1.0);
                $crate::__private::lift_literals!($crate, $body)
            },
        ))
    };
    (@fixed $mode:ident, $m:expr, $n:expr, $t:tt, $x:ident, $s:ident, $u:tt, $body:expr) => {
        $crate::model!(@time $mode, $crate::ClosureModel::<$crate::nalgebra::Const<{ $n }>, _, _>::new(
            $m,
            #[allow(unused_variables, clippy::clone_on_copy)]
            #[inline(always)]
            move |__t: f64,
                  $x: &$crate::nalgebra::SVector<f64, { $n }>,
                  $u: &[f64]|
                  -> $crate::nalgebra::SVector<f64, { $n }> {
                $crate::model!(@body $mode, $t, __t, $s, f64, $body)
            },
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  $x: &$crate::nalgebra::SVector<$crate::num_dual::DualSVec64<{ $n }>, { $n }>,
                  $u: &[f64]|
                  -> $crate::nalgebra::SVector<$crate::num_dual::DualSVec64<{ $n }>, { $n }> {
                $crate::model!(@body $mode, $t, __t, $s, $crate::num_dual::DualSVec64<{ $n }>, $body)
            },
        ).with_trace($crate::model!(@trace $mode, $crate::nalgebra::SVector<$crate::symbolic::Sym, { $n }>, $t, $x, $s, $u, $body)),
        fixed, $n, $t, $x, $s, $u, $body)
    };
    (@dyn $mode:ident, $m:expr, $t:tt, $x:ident, $s:ident, $u:tt, $body:expr) => {
        $crate::model!(@time $mode, $crate::ClosureModel::<$crate::nalgebra::Dyn, _, _>::new(
            $m,
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64, $x: &$crate::nalgebra::DVector<f64>, $u: &[f64]| -> $crate::nalgebra::DVector<f64> {
                $crate::model!(@body $mode, $t, __t, $s, f64, $body)
            },
            #[allow(unused_variables, clippy::clone_on_copy)]
            move |__t: f64,
                  $x: &$crate::nalgebra::DVector<$crate::num_dual::DualDVec64>,
                  $u: &[f64]|
                  -> $crate::nalgebra::DVector<$crate::num_dual::DualDVec64> {
                $crate::model!(@body $mode, $t, __t, $s, $crate::num_dual::DualDVec64, $body)
            },
        ).with_trace($crate::model!(@trace $mode, $crate::nalgebra::DVector<$crate::symbolic::Sym>, $t, $x, $s, $u, $body)),
        dyn, $t, $x, $s, $u, $body)
    };
    ($($other:tt)*) => {
        ::core::compile_error!(
            "model!: expected `|t, x: [S; N]| body`, `|t, x: [S; N], u: [M]| body`, \
             `|t, x: [S; Dyn]| body` or `|t, x: [S; Dyn], u: [M]| body` \
             (N states, M held inputs, S the scalar type name the body uses; \
             `t: S` gives the body t as S and an exact ∂f/∂t; `_` marks an autonomous model)"
        )
    };
}

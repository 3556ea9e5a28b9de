//! Models with a parameter block: `x' = f(t, x, u; p)`, with `p` differentiable like the
//! state. Built by [`model!`](crate::model) from `|t, x: [S; N], p: [S; P] = [p₁, …]| body`.

use crate::error::{Error, Result};
use crate::model::{NoTimeDerivative, System, TimeDerivative};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OMatrix, OVector, U1};
use num_dual::{Derivative, DualVec64};
use std::marker::PhantomData;

/// A model `x' = f(t, x, u; p)` whose body is instantiated at `f64` (`F`) and at num-dual's
/// `DualVec64<M>` with `M = n + n_p` directions (`G`): the first `n` directions carry
/// `∂/∂x`, the last `n_p` carry `∂/∂p`. `J = ∂f/∂x` and the sensitivity right-hand side
/// `J·s + ∂f/∂p` ([`crate::sensitivity`]) both come from `G`, exact to rounding; `Q`
/// ([`ParamsTangent`]) is an optional copy at `n_p` directions for `∂x/∂p` alone.
///
/// The parameter values live in the model: [`params`](Self::params),
/// [`set_params`](Self::set_params), [`with_params`](Self::with_params).
///
/// ```
/// use reckon::{model, System};
/// use nalgebra::{vector, Matrix1};
/// // exponential decay x' = −k·x with k a parameter (nominal 2)
/// let f = model!(|_, x: [S; 1], p: [S; 1] = [2.0]| vector![-(p[0] * x[0])]);
/// assert_eq!(f.params(), &[2.0]);
/// let g = f.with_params(&[3.0]).unwrap();
/// let (mut dx, mut j) = (vector![0.0], Matrix1::zeros());
/// g.rhs(0.0, &vector![2.0], &[], &mut dx);
/// g.jacobian(0.0, &vector![2.0], &[], &mut j);
/// assert_eq!((dx[0], j[(0, 0)]), (-6.0, -3.0));
/// ```
pub struct ParamModel<D, M, F, G, T = NoTimeDerivative, Q = NoParamsTangent, Tr = crate::symbolic::NoTrace> {
    inputs: usize,
    params: Vec<f64>,
    f: F,
    g: G,
    dt: T,
    pt: Q,
    tr: Tr,
    /// What [`System::sparse_jacobian`] did: recordings, traces, compiles.
    counters: crate::symbolic::cache::Counters,
    _dim: PhantomData<(D, M)>,
}

impl<D, M, F: Clone, G: Clone, T: Clone, Q: Clone, Tr: Clone> Clone for ParamModel<D, M, F, G, T, Q, Tr> {
    fn clone(&self) -> Self {
        ParamModel {
            inputs: self.inputs,
            params: self.params.clone(),
            f: self.f.clone(),
            g: self.g.clone(),
            dt: self.dt.clone(),
            pt: self.pt.clone(),
            tr: self.tr.clone(),
            counters: Default::default(),
            _dim: PhantomData,
        }
    }
}

impl<D, M, F, G> ParamModel<D, M, F, G> {
    /// Pair a real and a dual instantiation of the same body with nominal parameters `p`;
    /// `inputs` is the number of held inputs the body reads. Prefer [`model!`](crate::model).
    pub fn new(inputs: usize, p: &[f64], f: F, g: G) -> Self {
        ParamModel {
            inputs,
            params: p.to_vec(),
            f,
            g,
            dt: NoTimeDerivative,
            pt: NoParamsTangent,
            tr: crate::symbolic::NoTrace,
            counters: Default::default(),
            _dim: PhantomData,
        }
    }
}

impl<D, M, F, G, T, Q, Tr> ParamModel<D, M, F, G, T, Q, Tr> {
    /// The same model with `∂f/∂t` given by `dt` (`model!` gives [`Autonomous`](crate::model::Autonomous) for `|_, …|`).
    pub fn with_time_derivative<T2>(self, dt: T2) -> ParamModel<D, M, F, G, T2, Q, Tr> {
        ParamModel {
            inputs: self.inputs,
            params: self.params,
            f: self.f,
            g: self.g,
            dt,
            pt: self.pt,
            tr: self.tr,
            counters: self.counters,
            _dim: PhantomData,
        }
    }
    /// The same model with a copy of its body on the tracing scalar, the parameters traced
    /// as leaves `pₖ` ([`TraceParamsFn`](crate::symbolic::TraceParamsFn)), which gives its
    /// symbolic forms and its compiled sparse Jacobian. [`model!`](crate::model) does this.
    pub fn with_trace<Tr2>(self, tr: Tr2) -> ParamModel<D, M, F, G, T, Q, Tr2> {
        ParamModel {
            inputs: self.inputs,
            params: self.params,
            f: self.f,
            g: self.g,
            dt: self.dt,
            pt: self.pt,
            tr,
            counters: Default::default(),
            _dim: PhantomData,
        }
    }
    /// How many times [`System::sparse_jacobian`] traced the body (recorded it and
    /// differentiated and flattened it: no equal recording was in the compiled-program
    /// cache, [`crate::symbolic::cache`]). Parameters are leaves of the recording, so a model
    /// rebuilt with other parameter values traces 0 times.
    ///
    /// ```
    /// use reckon::{model, System};
    /// use nalgebra::DVector;
    /// let build = |k: f64| model!(|_, x: [S; Dyn], p: [S; 1] = [k]| DVector::from_fn(x.len(), |i, _| x[i].sin() * p[0].clone()));
    /// let _ = build(2.0).sparse_jacobian(71).unwrap();
    /// let other = build(5.0);
    /// let _ = other.sparse_jacobian(71).unwrap();
    /// assert_eq!((other.records(), other.traces(), other.compiles()), (1, 0, 0));
    /// ```
    pub fn traces(&self) -> usize {
        crate::symbolic::cache::Counters::get(&self.counters.traces)
    }
    /// How many times [`System::sparse_jacobian`] recorded the body (once per call).
    ///
    /// ```
    /// use reckon::{model, System};
    /// use nalgebra::DVector;
    /// let f = model!(|_, x: [S; Dyn], p: [S; 1] = [0.5]| DVector::from_fn(x.len(), |i, _| x[i].cos() * p[0].clone()));
    /// let _ = f.sparse_jacobian(72).unwrap();
    /// assert_eq!(f.records(), 1);
    /// ```
    pub fn records(&self) -> usize {
        crate::symbolic::cache::Counters::get(&self.counters.records)
    }
    /// How many times [`System::sparse_jacobian`] generated native code for this model (0
    /// when a program of the same shape was compiled before).
    ///
    /// ```
    /// use reckon::{model, System};
    /// use nalgebra::DVector;
    /// let f = model!(|_, x: [S; Dyn], p: [S; 1] = [0.25]| DVector::from_fn(x.len(), |i, _| x[i].exp() * p[0].clone()));
    /// let _ = f.sparse_jacobian(73).unwrap();
    /// let _ = f.sparse_jacobian(73).unwrap();
    /// assert!(f.compiles() <= 1);
    /// ```
    pub fn compiles(&self) -> usize {
        crate::symbolic::cache::Counters::get(&self.counters.compiles)
    }
    /// The same model with a copy of the body at `n_p` directions for the sensitivities to
    /// the parameters alone ([`ParamsBody`]; `model!` gives it to a fixed-size model).
    pub fn with_params_tangent<Q2>(self, pt: Q2) -> ParamModel<D, M, F, G, T, Q2, Tr> {
        ParamModel {
            inputs: self.inputs,
            params: self.params,
            f: self.f,
            g: self.g,
            dt: self.dt,
            pt,
            tr: self.tr,
            counters: self.counters,
            _dim: PhantomData,
        }
    }
    /// The current parameter values `p`.
    pub fn params(&self) -> &[f64] {
        &self.params
    }
    /// Set `p`: [`Error::InvalidInput`] for the wrong number of values or a non-finite one.
    pub fn set_params(&mut self, p: &[f64]) -> Result<()> {
        if p.len() != self.params.len() {
            return Err(Error::invalid(
                "params",
                format!("{} values for a model with {} parameters", p.len(), self.params.len()),
            ));
        }
        if let Some(i) = p.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid("params", format!("parameter {i} is {}", p[i])));
        }
        self.params.copy_from_slice(p);
        Ok(())
    }
    /// The same model with parameters `p` ([`set_params`](Self::set_params)).
    pub fn with_params(mut self, p: &[f64]) -> Result<Self> {
        self.set_params(p)?;
        Ok(self)
    }
}

impl<D, M, F, G, T, Q, Tr> System<D> for ParamModel<D, M, F, G, T, Q, Tr>
where
    D: Dim,
    M: Dim,
    F: Fn(f64, &OVector<f64, D>, &[f64], &[f64]) -> OVector<f64, D>,
    G: Fn(f64, &OVector<DualVec64<M>, D>, &[f64], &[DualVec64<M>]) -> OVector<DualVec64<M>, D>,
    T: TimeDerivative<D>,
    Tr: crate::symbolic::TraceBody<D>,
    DefaultAllocator: Allocator<D> + Allocator<M>,
{
    fn trace_counts(&self) -> crate::symbolic::TraceCounts {
        self.counters.counts()
    }
    /// The traced body, the parameters as the leaves `pₖ` at their current values.
    fn symbolic(&self, n: usize) -> Option<Result<crate::symbolic::Traced>> {
        let shape = crate::symbolic::Shape {
            n,
            m: self.inputs,
            p: &self.params,
        };
        self.tr
            .traceable()
            .then(|| crate::symbolic::trace_body(&self.tr, &crate::model::model_name::<F>(), &shape))
    }
    /// The compiled symbolic Jacobian (from the compiled-program cache,
    /// [`crate::symbolic::cache`]: the parameters are inputs of the compiled code, so other
    /// parameter values reuse it), `None` when the body cannot be traced (the implicit
    /// methods then use the dense num-dual [`jacobian`](System::jacobian)).
    fn sparse_jacobian(&self, n: usize) -> Option<Box<dyn crate::jacobian::SparseJacobian + '_>> {
        if !self.tr.traceable() {
            return None;
        }
        let shape = crate::symbolic::Shape {
            n,
            m: self.inputs,
            p: &self.params,
        };
        crate::symbolic::cached_jacobian(&self.tr, &crate::model::model_name::<F>(), &shape, &self.counters)
            .ok()
            .map(|c| Box::new(c) as Box<dyn crate::jacobian::SparseJacobian>)
    }
    fn inputs(&self) -> usize {
        self.inputs
    }
    #[inline(always)]
    fn rhs(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dx: &mut OVector<f64, D>) {
        *dx = (self.f)(t, x, u, &self.params);
    }
    /// `J` from the dual body with `x` seeded in the first `n` directions and `p` constant.
    fn jacobian(&self, t: f64, x: &OVector<f64, D>, u: &[f64], jac: &mut OMatrix<f64, D, D>)
    where
        DefaultAllocator: Allocator<D, D>,
    {
        let n = x.len();
        let md = M::from_usize(n + self.params.len());
        let xd = x.map_with_location(|i, _, v| DualVec64::new(v, Derivative::derivative_generic(md, U1, i)));
        let pd = constants::<M>(md, &self.params);
        let r = (self.g)(t, &xd, u, &pd.as_slice()[..self.params.len()]);
        // row i of J is the first n derivative parts of f_i: column-major as write_eps writes
        crate::model::write_eps(&r, n, n, jac.as_mut_slice());
    }
    fn time_derivative(&self, t: f64, x: &OVector<f64, D>, u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        self.dt.time_derivative(t, x, u, dfdt)
    }
}

impl<D, M, F, G, T, Q, Tr> crate::DualSystem<D> for ParamModel<D, M, F, G, T, Q, Tr>
where
    D: Dim,
    M: Dim,
    F: Fn(f64, &OVector<f64, D>, &[f64], &[f64]) -> OVector<f64, D>,
    G: Fn(f64, &OVector<DualVec64<M>, D>, &[f64], &[DualVec64<M>]) -> OVector<DualVec64<M>, D>,
    T: TimeDerivative<D>,
    Q: ParamsTangent<D>,
    Tr: crate::symbolic::TraceBody<D>,
    DefaultAllocator: Allocator<D> + Allocator<M> + Allocator<U1, D>,
{
    /// `f` at dual `x` (`n` directions): the body at `M` directions with `x`'s derivative
    /// parts padded by zeros for `p`, truncated back to `n`.
    fn rhs_dual(&self, t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64]) -> OVector<DualVec64<D>, D> {
        let n = x.len();
        let md = M::from_usize(n + self.params.len());
        let xd = x.map(|v| {
            let eps = v
                .eps
                .0
                .as_ref()
                .map(|e| OVector::<f64, M>::from_fn_generic(md, U1, |k, _| if k < n { e[k] } else { 0.0 }));
            DualVec64::new(v.re, Derivative::new(eps))
        });
        let pd = constants::<M>(md, &self.params);
        let r = (self.g)(t, &xd, u, &pd.as_slice()[..self.params.len()]);
        let (rn, _) = x.shape_generic();
        r.map(|v| {
            let eps = v
                .eps
                .0
                .as_ref()
                .map(|e| OVector::<f64, D>::from_fn_generic(rn, U1, |k, _| e[k]));
            DualVec64::new(v.re, Derivative::new(eps))
        })
    }
    fn n_params(&self) -> usize {
        self.params.len()
    }
    fn params(&self) -> &[f64] {
        &self.params
    }
    fn tangent(&self, t: f64, x: &OVector<f64, D>, u: &[f64], s: &[f64], m: usize, ds: &mut [f64]) {
        let n = x.len();
        let np = self.params.len();
        if m < np || m > n + np {
            ds.fill(f64::NAN);
            return;
        }
        // S = ∂x/∂p alone: the copy of the body at n_p directions, when there is one
        if m == np && self.pt.params_tangent(t, x, u, &self.params, s, ds) {
            return;
        }
        // a dynamic M takes exactly the m directions used; a fixed one is n + n_p wide
        let md = M::from_usize(if M::try_to_usize().is_some() { n + np } else { m });
        // x_i + Σ_k s_ik ε_k (k < m), p_j + ε_{m − n_p + j}; directions m.. stay zero
        let xd = x.map_with_location(|i, _, v| {
            DualVec64::new(
                v,
                Derivative::some(OVector::<f64, M>::from_fn_generic(md, U1, |k, _| {
                    if k < m { s[i + k * n] } else { 0.0 }
                })),
            )
        });
        // on the stack for a fixed-size model (M ≥ n_p slots, the first n_p used)
        let pd = OVector::<DualVec64<M>, M>::from_fn_generic(md, U1, |j, _| match self.params.get(j) {
            Some(&v) => DualVec64::new(v, Derivative::derivative_generic(md, U1, m - np + j)),
            None => DualVec64::new(0.0, Derivative::none()),
        });
        let r = (self.g)(t, &xd, u, &pd.as_slice()[..np]);
        crate::model::write_eps(&r, n, m, ds);
    }
}

/// `J·S + ∂f/∂p` for `S = ∂x/∂p` alone (`n × n_p`, [`Wrt::Params`](crate::sensitivity::Wrt::Params))
/// from a copy of the body whose duals carry one direction per parameter: `x` seeded with
/// `S`'s rows, `p_j` with the unit vector `e_j`. [`ParamModel`]'s `G` carries `n + n_p`
/// directions, of which this case uses `n_p`.
pub trait ParamsTangent<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Write `J·S + ∂f/∂p` at `(t, x, u; p)` into `ds` (`n × n_p`, column-major, as `s`);
    /// `false` (and `ds` untouched) when there is no such copy.
    #[allow(clippy::too_many_arguments)]
    fn params_tangent(&self, t: f64, x: &OVector<f64, D>, u: &[f64], p: &[f64], s: &[f64], ds: &mut [f64]) -> bool;
}

/// No copy of the body at `n_p` directions: [`ParamModel`] uses its `G`.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoParamsTangent;

impl<D: Dim> ParamsTangent<D> for NoParamsTangent
where
    DefaultAllocator: Allocator<D>,
{
    fn params_tangent(&self, _: f64, _: &OVector<f64, D>, _: &[f64], _: &[f64], _: &[f64], _: &mut [f64]) -> bool {
        false
    }
}

/// The model's body at num-dual's `DualVec64<P>`, `P = n_p` directions
/// ([`ParamsTangent`]); built by [`model!`](crate::model) for a fixed-size model with a
/// parameter block.
///
/// ```
/// use reckon::{model, DualSystem};
/// use nalgebra::vector;
/// // x' = −k·x: J·s + ∂f/∂k = −k·s − x
/// let f = model!(|_, x: [S; 1], p: [S; 1] = [2.0]| vector![-(p[0] * x[0])]);
/// let mut ds = [0.0];
/// f.tangent(0.0, &vector![3.0], &[], &[0.5], 1, &mut ds);
/// assert_eq!(ds, [-2.0 * 0.5 - 3.0]);
/// ```
pub struct ParamsBody<P, H> {
    body: H,
    _dim: PhantomData<P>,
}

impl<P, H: Clone> Clone for ParamsBody<P, H> {
    fn clone(&self) -> Self {
        ParamsBody::new(self.body.clone())
    }
}

impl<P, H> ParamsBody<P, H> {
    /// Wrap the body at `DualVec64<P>`.
    pub fn new(body: H) -> Self {
        ParamsBody {
            body,
            _dim: PhantomData,
        }
    }
}

impl<D, P, H> ParamsTangent<D> for ParamsBody<P, H>
where
    D: Dim,
    P: Dim,
    H: Fn(f64, &OVector<DualVec64<P>, D>, &[f64], &[DualVec64<P>]) -> OVector<DualVec64<P>, D>,
    DefaultAllocator: Allocator<D> + Allocator<P>,
{
    #[inline(always)]
    fn params_tangent(&self, t: f64, x: &OVector<f64, D>, u: &[f64], p: &[f64], s: &[f64], ds: &mut [f64]) -> bool {
        let (n, np) = (x.len(), p.len());
        if P::try_to_usize().is_some_and(|w| w != np) {
            return false;
        }
        let pw = P::from_usize(np);
        let xd = x.map_with_location(|i, _, v| {
            DualVec64::new(
                v,
                Derivative::some(OVector::<f64, P>::from_fn_generic(pw, U1, |k, _| s[i + k * n])),
            )
        });
        let pd = OVector::<DualVec64<P>, P>::from_fn_generic(pw, U1, |j, _| {
            DualVec64::new(p[j], Derivative::derivative_generic(pw, U1, j))
        });
        let r = (self.body)(t, &xd, u, pd.as_slice());
        crate::model::write_eps(&r, n, np, ds);
        true
    }
}

/// A parameter block needs a plain `t` or `_` time: `t: S` is refused with a message.
///
/// ```compile_fail
/// let f = reckon::model!(|t: S, x: [S; 1], p: [S; 1] = [1.0]| reckon::vector![x[0] * p[0]]);
/// ```
///
/// The values must match the block's size (a type error otherwise):
///
/// ```compile_fail
/// let f = reckon::model!(|_, x: [S; 1], p: [S; 2] = [1.0]| reckon::vector![x[0] * p[0]]);
/// ```
#[doc(hidden)]
pub struct ParamBlockChecks;

/// The parameters as dual constants (no derivative part): `p` held fixed, in the first
/// `p.len()` of `M ≥ n_p` slots (on the stack for a fixed-size model).
fn constants<M: Dim>(md: M, p: &[f64]) -> OVector<DualVec64<M>, M>
where
    DefaultAllocator: Allocator<M>,
{
    OVector::<DualVec64<M>, M>::from_fn_generic(md, U1, |j, _| {
        DualVec64::new(p.get(j).copied().unwrap_or(0.0), Derivative::none())
    })
}

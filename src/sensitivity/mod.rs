//! Forward sensitivities `S(t) = ∂x(t)/∂(x₀, p)` of a solution, through every method.
//!
//! The state is augmented with the `n × m` sensitivity matrix `S` (`m = n + n_p`: the
//! initial state's `n` columns, then one per model parameter), and the method integrates
//! `x' = f(t, x, u; p)`, `S' = J·S + [0 | ∂f/∂p]`, `S(t₀) = [I | 0]`. The right-hand side
//! of `S` comes from one evaluation of the model's body at num-dual numbers whose
//! derivative parts are the rows of `S` (and the unit vectors of `p`), so `J·S + ∂f/∂p`
//! is exact to rounding, never a difference quotient.
//!
//! **What `S` is the derivative of.** For a linear multistep or Runge–Kutta method with
//! the steps it took, integrating the augmented system gives exactly the derivative of the
//! computed `x` with respect to `x₀` and `p` (internal differentiation: the method's
//! stages are linear in `f`, so differentiating the step and stepping the variational
//! system are the same computation) — for [`Rk45`](crate::methods::Rk45),
//! [`Euler`](crate::methods::Euler) and [`Exact`](crate::methods::Exact)
//! to rounding; for [`Bdf`](crate::methods::Bdf) it is the derivative of the solution of
//! the discrete implicit equations (the implicit function theorem), to the Newton
//! tolerance, because Newton's iterate is not the exact root.
//!
//! **Rk45: the staggered direct scheme.** Without `S` in the error control,
//! [`Rk45`](crate::methods::Rk45) does not integrate the stacked state either: the
//! plain kernel takes every step at the model's own dimension (so `x`, the times and the
//! step count are the plain solve's, bit for bit), and after each accepted step the
//! stage sensitivities `Kᵢ = J(Yᵢ)·(S₀ + h Σ aᵢⱼ Kⱼ) + [0 | ∂f/∂p (Yᵢ)]` are evaluated at
//! the kernel's own stage arguments `Yᵢ` (one dual evaluation each,
//! [`DualSystem::tangent`](crate::DualSystem::tangent)) and `S₁ = S₀ + h Σ bᵢ Kᵢ` — the
//! same numbers the augmented system would give on those steps, without integrating it:
//! six dual evaluations per accepted step (`K₇` is the next step's `K₁`), none for a
//! rejected one, and no stacked vector through the kernel.
//!
//! **Implicit Euler: the staggered direct scheme.** [`ImplicitEuler`](crate::methods::ImplicitEuler)
//! does not integrate the augmented system (unless `S` is in the error control): it takes
//! the plain solve's steps — so `x`, the times and the step count are the plain solve's,
//! bit for bit — and after each accepted step `x₁ = x₀ + h·f(t + h, x₁)` solves for the
//! step's exact derivative, `(I − h·J(x₁))·S₁ = S₀ + h·[0 | ∂f/∂p (x₁)]`, with `J` and
//! `∂f/∂p` from one dual evaluation at the computed `x₁` and `I − h·J` factored once
//! (Caracotsios & Stewart 1985). `S` is then the implicit function theorem's derivative
//! of the implicit Euler map on the steps taken, to rounding, whatever Newton's tolerance;
//! the cost is one dual evaluation, one `n × n` LU and `m` back-substitutions per step
//! on top of the plain solve. At output times `S` is the step's linear interpolant, as `x` is. [`Rodas5P`](crate::methods::Rodas5P) and
//! [`ExponentialEuler`](crate::methods::ExponentialEuler) have the Jacobian in their formula, so the derivative of its step needs the second derivatives
//! `∂(J·S + [0 | ∂f/∂p])/∂x` (the lower-left block of the augmented Jacobian): these are
//! central differences of the exact dual `J·S` (relative error about 1e-10, the one
//! difference quotient here; the `x` block `J` stays exact), so their `S` is the
//! derivative of the computed solution to about that accuracy.
//!
//! **Steps.** By default the error estimate covers `x` only
//! ([`Options::error_components`](crate::Options::error_components)), so an explicit
//! method takes the same steps as the plain solve and returns the same `x` bit for bit;
//! with [`SensitivityOptions::error_control`] the sensitivities are controlled too
//! (tolerances repeated for each column).
//!
//! ```
//! use reckon::{model, Options, Problem, methods::Rk45, sensitivity::{self, SensitivityOptions}};
//! use nalgebra::vector;
//! // x' = −k·x: x(t) = x₀·e^{−kt}, ∂x/∂x₀ = e^{−kt}, ∂x/∂k = −t·x₀·e^{−kt}
//! let f = model!(|_, x: [S; 1], p: [S; 1] = [0.5]| vector![-(p[0] * x[0])]);
//! let p = Problem::new(&f, vector![2.0], (0.0, 3.0));
//! let o = Options::default().rtol(1e-10).atol(1e-12);
//! let sol = sensitivity::solve(&p, Rk45, &o, &SensitivityOptions::default()).unwrap();
//! let e = (-1.5f64).exp();
//! assert!((sol.last_x()[0] - 2.0 * e).abs() < 1e-9);
//! assert!((sol.wrt_x0(sol.t.len() - 1)[(0, 0)] - e).abs() < 1e-9);
//! assert!((sol.wrt_params(sol.t.len() - 1)[(0, 0)] + 3.0 * 2.0 * e).abs() < 1e-8);
//! ```

use crate::error::{Error, Result};
use crate::integrator::save::Store;
use crate::linalg::LuDim;
use crate::methods::{Exact, ImplicitEuler, Method, Rk45};
use crate::model::Stats;
use crate::model::{DualFlow, Flow};
use crate::model::{DualSystem, System};
use crate::problem::Problem;
use crate::problem::options::Options;
use crate::problem::options::Tolerance;
use crate::problem::solution::Solution;
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DMatrixView, DVector, DefaultAllocator, Dim, Dyn, OMatrix, OVector, U1};
use num_dual::{Derivative, DualVec64};
use std::marker::PhantomData;

mod direct;
mod saltation;

/// The largest local error an accepted step may leave in the sensitivities, relative to
/// their size, when they are outside the error control (the default): `0.1`. Above it
/// [`solve`] returns [`Error::SensitivityUnresolved`] rather than an `S` that is wrong by
/// orders of magnitude.
///
/// Without [`SensitivityOptions::error_control`] the steps are chosen for `x` alone and
/// `S` rides along; where `x` and `S` change alike (the usual case) `S` is then about as
/// accurate as `x`. It is not when `x` sits still while `S` moves: `x' = 710·x` from
/// `x₀ = 0` keeps `x ≡ 0`, the steps grow without bound, and `S = ∂x/∂x₀ = e^{710t}`
/// came out as 4.6·10³⁷ (RK45), 4.5·10⁻⁸ (implicit Euler), 4·10⁻⁶ (BDF) or 2.8
/// (Rodas5P) at `t = 1.5`, where the truth, e¹⁰⁶⁵, overflows. So every adaptive method
/// estimates the error of `S` on the steps it takes (the embedded estimate it uses for
/// `x`; for RK45 also the step's own error `|R(z)e^{−z} − 1|` on the growing mode the
/// last two stages show, which the embedded estimate misses far outside the accuracy
/// region: at `hλ = 6.3` it reads under 10 % where the step is 41 % short) and the solve
/// stops as soon as one step's estimate exceeds this bound, measured as
/// [`Weights::uncontrolled`](crate::methods::step_size::Weights::uncontrolled) does: the RMS of the
/// errors over the size of `S` (its largest entry, and at least `(|x_r| + atol)/p̄_k`,
/// the natural size of `∂x_r/∂q_k` for a quantity of magnitude `p̄_k`: `|x₀_k|` or
/// `|p_k|`, 1 where that is 0). On that example the worst step's estimate is 0.78
/// (Rodas5P), 0.87 (implicit Euler), 17 (RK45) or 82 (BDF); the test suite's other
/// sensitivity solves stay below 4·10⁻⁵. On `[0, 0.01]` (S = e^{7.1}) RK45's last step
/// is refused at 0.41; on `[0, 0.005]` it passes with `S` 1.5 % off (under the bound: use
/// the error control for accuracy). It is a guard against answers that are wrong,
/// not an accuracy control: `S` as accurate as the tolerance asks needs
/// [`SensitivityOptions::error_control`]`(true)` (then the steps follow `S`, and that
/// example stops with [`Error::NonFinite`] when `S` overflows, as it should). Fixed steps
/// are not checked: their accuracy is the caller's choice.
pub const UNRESOLVED: f64 = 0.1;

/// How [`solve`] treats the sensitivities.
///
/// ```
/// use reckon::sensitivity::{SensitivityOptions, Wrt};
/// let o = SensitivityOptions::default().wrt(Wrt::Params).error_control(true);
/// assert_eq!((o.wrt, o.error_control), (Wrt::Params, true));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SensitivityOptions {
    /// Put `S` in the error estimate of adaptive methods too (default `false`: `x` only,
    /// so that the steps are those of the plain solve).
    pub error_control: bool,
    /// Which derivatives `S` carries (default [`Wrt::All`]: `∂x/∂x₀` and `∂x/∂p`).
    pub wrt: Wrt,
}

impl SensitivityOptions {
    /// Set [`error_control`](Self::error_control).
    pub fn error_control(mut self, on: bool) -> Self {
        self.error_control = on;
        self
    }
    /// Set [`wrt`](Self::wrt).
    pub fn wrt(mut self, wrt: Wrt) -> Self {
        self.wrt = wrt;
        self
    }
}

/// The columns of `S`: with respect to the initial state and the parameters
/// (`S = ∂x/∂(x₀, p)`, `n + n_p` columns, `S(t₀) = [I | 0]`), or to the parameters alone
/// (`S = ∂x/∂p`, `n_p` columns, `S(t₀) = 0`), which is what a fit of `p` needs and costs
/// `n` fewer columns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Wrt {
    /// `∂x/∂x₀` and `∂x/∂p`.
    #[default]
    All,
    /// `∂x/∂p` only ([`Error::InvalidInput`] for a model without parameters).
    Params,
}

impl Wrt {
    /// `(m, n_x0)`: the columns of `S` for a state of `n` components and `n_p`
    /// parameters, and how many of them are `∂x/∂x₀`'s (`(n + n_p, n)` or `(n_p, 0)`).
    fn columns(self, n: usize, np: usize) -> (usize, usize) {
        match self {
            Wrt::All => (n + np, n),
            Wrt::Params => (np, 0),
        }
    }
}

/// `x' = f`, `Ṡ = J·S + [0 | ∂f/∂p]` as one [`System`] on the stacked state
/// `z = (x, vec S)` of `n·(1 + m)` components (`m = n + n_p`, or `m = n_p` for
/// [`Wrt::Params`]: `Ṡ = J·S + ∂f/∂p`).
pub struct Augmented<'s, D, S> {
    sys: &'s S,
    n: usize,
    m: usize,
    _dim: PhantomData<D>,
}

impl<'s, D: Dim, S: DualSystem<D>> Augmented<'s, D, S>
where
    DefaultAllocator: Allocator<D> + Allocator<U1, D>,
{
    /// The augmented system of `sys` for a state of `n` components, with the columns of
    /// `wrt` (`m = n + n_p` or `n_p`).
    pub fn new(sys: &'s S, n: usize, wrt: Wrt) -> Self {
        let np = sys.n_params();
        Augmented {
            sys,
            n,
            m: wrt.columns(n, np).0,
            _dim: PhantomData,
        }
    }
    fn x_of(&self, z: &DVector<f64>) -> OVector<f64, D> {
        OVector::<f64, D>::from_column_slice_generic(D::from_usize(self.n), U1, &z.as_slice()[..self.n])
    }
}

impl<D: Dim, S: DualSystem<D>> System<Dyn> for Augmented<'_, D, S>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    fn inputs(&self) -> usize {
        self.sys.inputs()
    }
    fn jacobian_blocks(&self) -> Option<usize> {
        Some(self.n)
    }
    fn rhs(&self, t: f64, z: &DVector<f64>, u: &[f64], dz: &mut DVector<f64>) {
        let n = self.n;
        if z.len() != n * (1 + self.m) || dz.len() != z.len() {
            *dz = DVector::from_element(z.len(), f64::NAN);
            return;
        }
        let x = self.x_of(z);
        let mut dx = x.clone();
        let (zs, dzs) = (z.as_slice(), dz.as_mut_slice());
        self.sys
            .rhs_sensitivity(t, &x, u, &zs[n..], self.m, &mut dx, &mut dzs[n..]);
        if dx.len() != n {
            dzs.fill(f64::NAN);
            return;
        }
        dzs[..n].copy_from_slice(dx.as_slice());
    }
    /// `[[J, 0], [∂(J·S + [0 | ∂f/∂p])/∂x, blockdiag(J, …, J)]]`: `J` exact (the model's
    /// [`jacobian`](System::jacobian)); the second-derivative block by central differences
    /// of the exact `J·S + [0 | ∂f/∂p]` in each `x_j` (step `∛ε·max(|x_j|, 1)`, relative error
    /// about 1e-10): the one difference quotient in the sensitivities (see the module's note).
    fn jacobian(&self, t: f64, z: &DVector<f64>, u: &[f64], jac: &mut DMatrix<f64>) {
        let (n, m) = (self.n, self.m);
        let x = self.x_of(z);
        let mut j = OMatrix::<f64, D, D>::zeros_generic(D::from_usize(n), D::from_usize(n));
        self.sys.jacobian(t, &x, u, &mut j);
        jac.fill(0.0);
        for b in 0..=m {
            for c in 0..n {
                for r in 0..n {
                    jac[(b * n + r, b * n + c)] = j[(r, c)];
                }
            }
        }
        let s = &z.as_slice()[n..];
        let (mut dx, mut up, mut down) = (x.clone(), vec![0.0; n * m], vec![0.0; n * m]);
        for c in 0..n {
            let d = f64::EPSILON.cbrt() * x[c].abs().max(1.0);
            let mut xp = x.clone();
            xp[c] += d;
            let dp = xp[c] - x[c];
            self.sys.rhs_sensitivity(t, &xp, u, s, m, &mut dx, &mut up);
            xp[c] = x[c] - d;
            let dm = x[c] - xp[c];
            self.sys.rhs_sensitivity(t, &xp, u, s, m, &mut dx, &mut down);
            for r in 0..n * m {
                jac[(n + r, c)] = (up[r] - down[r]) / (dp + dm);
            }
        }
    }
}

/// The exact flow of the augmented system: `x₁ = φ_h(x₀)`, `S₁ = ∂φ_h/∂x (x₀)·S₀`.
pub struct AugmentedFlow<D, F> {
    flow: F,
    n: usize,
    _dim: PhantomData<D>,
}

impl<D: Dim, F: DualFlow<D>> Flow<Dyn> for AugmentedFlow<D, F>
where
    DefaultAllocator: Allocator<D>,
{
    fn flow(&self, t: f64, z: &DVector<f64>, u: &[f64], h: f64, out: &mut DVector<f64>) {
        let n = self.n;
        let r = D::from_usize(n);
        let s = &z.as_slice()[n..];
        let xd = OVector::<DualVec64<D>, D>::from_fn_generic(r, U1, |i, _| {
            DualVec64::new(
                z[i],
                Derivative::some(OVector::<f64, D>::from_fn_generic(r, U1, |k, _| s[i + k * n])),
            )
        });
        let y = self.flow.flow_dual(t, &xd, u, h);
        if y.len() != n || out.len() != z.len() {
            *out = DVector::from_element(z.len(), f64::NAN);
            return;
        }
        let mut x1 = OVector::<f64, D>::zeros_generic(r, U1);
        self.flow.flow(
            t,
            &OVector::<f64, D>::from_column_slice_generic(r, U1, &z.as_slice()[..n]),
            u,
            h,
            &mut x1,
        );
        let o = out.as_mut_slice();
        o[..n].copy_from_slice(x1.as_slice());
        crate::model::write_eps(&y, n, n, &mut o[n..]);
    }
}

/// A method that can integrate the augmented system of [`solve`]: every method of
/// [`crate::methods`] (at `Dyn`), and [`Exact`] with a [`DualFlow`].
pub trait Augment<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// The method on the stacked state.
    type Method: Method<Dyn>;
    /// For a state of `n` components and a model of `n_params` parameters.
    fn augment(self, n: usize, n_params: usize) -> Result<Self::Method>;
    /// Sensitivities by a scheme of the method's own instead of the augmented system
    /// (`None`: integrate the augmented system). [`ImplicitEuler`](crate::methods::ImplicitEuler)
    /// without [`SensitivityOptions::error_control`] takes the staggered direct scheme
    /// (see [`solve`]).
    fn direct<S: DualSystem<D>>(
        &self,
        _problem: &Problem<'_, D, S>,
        _opts: &Options,
        _sens: &SensitivityOptions,
    ) -> Option<Result<Sensitivities<D>>>
    where
        DefaultAllocator: Allocator<D, D> + Allocator<U1, D>,
    {
        None
    }
}

macro_rules! augment_as_is {
    ($($ty:ty),*) => {$(
        impl<D: Dim> Augment<D> for $ty
        where
            DefaultAllocator: Allocator<D>,
        {
            type Method = $ty;
            fn augment(self, _n: usize, _n_params: usize) -> Result<Self::Method> {
                Ok(self)
            }
        }
    )*};
}

augment_as_is!(
    crate::methods::Euler,
    crate::methods::Bdf,
    crate::methods::Rodas5P,
    crate::methods::ExponentialEuler,
    crate::methods::Auto
);

/// Dormand–Prince: the augmented system when the sensitivities are in the error control,
/// otherwise the staggered direct scheme on the plain solve's steps ([`solve`]).
impl<D: Dim> Augment<D> for Rk45
where
    DefaultAllocator: Allocator<D>,
{
    type Method = Rk45;
    fn augment(self, _n: usize, _n_params: usize) -> Result<Self::Method> {
        Ok(self)
    }
    fn direct<S: DualSystem<D>>(
        &self,
        problem: &Problem<'_, D, S>,
        opts: &Options,
        sens: &SensitivityOptions,
    ) -> Option<Result<Sensitivities<D>>>
    where
        DefaultAllocator: Allocator<D, D> + Allocator<U1, D>,
    {
        (!sens.error_control).then(|| direct::dopri5(problem, opts, sens))
    }
}

/// Implicit Euler: the augmented system when the sensitivities are in the error
/// control, otherwise the staggered direct scheme ([`solve`]), which needs the plain
/// method at `D` (`D: LuDim`, as a plain implicit Euler solve does).
impl<D: LuDim> Augment<D> for ImplicitEuler
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    type Method = ImplicitEuler;
    fn augment(self, _n: usize, _n_params: usize) -> Result<Self::Method> {
        Ok(self)
    }
    fn direct<S: DualSystem<D>>(
        &self,
        problem: &Problem<'_, D, S>,
        opts: &Options,
        sens: &SensitivityOptions,
    ) -> Option<Result<Sensitivities<D>>>
    where
        DefaultAllocator: Allocator<D, D> + Allocator<U1, D>,
    {
        (!sens.error_control).then(|| direct::implicit_euler(problem, *self, opts, sens))
    }
}

/// The scale `p̄_k` of each column of `S` ([`control::Weights::uncontrolled`](crate::methods::step_size::Weights::uncontrolled)):
/// `|x₀_k|` for the columns of `∂x/∂x₀`, `|p_k|` for a parameter's (1 where that is 0).
pub(crate) fn column_scales(x0: &[f64], params: &[f64], wrt: Wrt) -> Vec<f64> {
    let x0 = if wrt == Wrt::All { x0 } else { &[] };
    let size = |v: &f64| if v.is_finite() && *v != 0.0 { v.abs() } else { 1.0 };
    x0.iter().map(size).chain(params.iter().map(size)).collect()
}

/// The stacked state at `t₀`, `z = (x₀, vec S₀)` with `m` columns: `S₀ = [I | 0]` for
/// [`Wrt::All`], `0` for [`Wrt::Params`].
fn stacked_start(x0: &[f64], m: usize, wrt: Wrt) -> DVector<f64> {
    let n = x0.len();
    let mut z = DVector::zeros(n * (1 + m));
    z.rows_mut(0, n).copy_from_slice(x0);
    if wrt == Wrt::All {
        for i in 0..n {
            z[n + i + i * n] = 1.0;
        }
    }
    z
}

/// The saved stacked states `z = (x, vec S)` split as they come ([`Store`]): `x` at `D`,
/// `S` appended to one flat column-major buffer, so nothing is allocated per point (for a
/// fixed-size `x`).
pub(super) struct Split<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    n: usize,
    m: usize,
    x: Vec<OVector<f64, D>>,
    s: Vec<f64>,
}

impl<D: Dim> Split<D>
where
    DefaultAllocator: Allocator<D>,
{
    pub(super) fn new(n: usize, m: usize) -> Self {
        Split {
            n,
            m,
            x: Vec::new(),
            s: Vec::new(),
        }
    }
    pub(super) fn into_sensitivities(
        self,
        t: Vec<f64>,
        wrt: Wrt,
        n_params: usize,
        stats: Stats,
        method: &'static str,
    ) -> Sensitivities<D> {
        Sensitivities {
            t,
            x: self.x,
            s_flat: self.s,
            n: self.n,
            m: self.m,
            wrt,
            n_params,
            stats,
            method,
        }
    }
}

impl<D: Dim> Store<Dyn> for Split<D>
where
    DefaultAllocator: Allocator<D>,
{
    fn push(&mut self, z: &DVector<f64>) {
        let (x, s) = z.as_slice().split_at(self.n);
        self.x
            .push(OVector::from_column_slice_generic(D::from_usize(self.n), U1, x));
        self.s.extend_from_slice(s);
    }
    /// Element by element, the same operations as [`horner`](crate::problem::solution::horner).
    fn push_dense(&mut self, c: &[DVector<f64>], theta: f64) {
        let (last, rest) = c.split_last().expect("a dense polynomial has coefficients");
        let at = |e: usize| rest.iter().rev().fold(last[e], |y, cj| y * theta + cj[e]);
        self.x
            .push(OVector::from_fn_generic(D::from_usize(self.n), U1, |i, _| at(i)));
        self.s.extend((self.n..last.len()).map(at));
    }
    fn reserve(&mut self, k: usize) {
        self.x.reserve(k);
        self.s.reserve(k * self.n * self.m);
    }
}

/// The augmented solve's saved stacked states as [`Sensitivities`].
#[allow(clippy::too_many_arguments)]
fn unstack<D: Dim>(
    t: Vec<f64>,
    zs: Vec<DVector<f64>>,
    n: usize,
    m: usize,
    wrt: Wrt,
    n_params: usize,
    stats: Stats,
    method: &'static str,
) -> Sensitivities<D>
where
    DefaultAllocator: Allocator<D>,
{
    let mut split = Split::new(n, m);
    Store::<Dyn>::reserve(&mut split, zs.len());
    for z in &zs {
        Store::<Dyn>::push(&mut split, z);
    }
    split.into_sensitivities(t, wrt, n_params, stats, method)
}

impl<D: Dim, F: DualFlow<D>> Augment<D> for Exact<F>
where
    DefaultAllocator: Allocator<D>,
{
    type Method = Exact<AugmentedFlow<D, F>>;
    fn augment(self, n: usize, n_params: usize) -> Result<Self::Method> {
        if n_params > 0 {
            return Err(Error::invalid(
                "method",
                "an exact flow gives no derivatives with respect to model parameters: use a \
                 time-stepping method for a model with a parameter block",
            ));
        }
        Ok(Exact::new(AugmentedFlow {
            flow: self.into_flow(),
            n,
            _dim: PhantomData,
        }))
    }
}

/// A solution with its sensitivities at the saved times.
#[derive(Debug, Clone)]
pub struct Sensitivities<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Saved times.
    pub t: Vec<f64>,
    /// States at the saved times.
    pub x: Vec<OVector<f64, D>>,
    /// `S` at the saved times, one after the other, each `n × m` column-major ([`s`](Self::s)).
    s_flat: Vec<f64>,
    n: usize,
    m: usize,
    /// The columns `S` carries.
    pub wrt: Wrt,
    /// Number of model parameters.
    pub n_params: usize,
    /// Counters of the run: of the augmented system (each `f` evaluation one dual
    /// evaluation of the body); for the staggered schemes, the plain solve's, with the
    /// dual evaluations added (RK45: to `rhs_evals`; implicit Euler: one Jacobian and one
    /// LU per accepted step).
    pub stats: Stats,
    /// The method's name.
    pub method: &'static str,
}

impl<D: Dim> Sensitivities<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// `S(t_k) = ∂x(t_k)/∂(x₀, p)`, `n × (n + n_p)` (`∂x/∂p`, `n × n_p`, for
    /// [`Wrt::Params`]), a view into the run's one buffer.
    ///
    /// ```
    /// use reckon::{model, Options, Problem, methods::Euler, sensitivity::{self, SensitivityOptions}};
    /// use nalgebra::vector;
    /// // x' = −k·x, one explicit Euler step of h = 0.1: x₁ = (1 − hk)·x₀
    /// let f = model!(|_, x: [S; 1], p: [S; 1] = [2.0]| vector![-(p[0] * x[0])]);
    /// let p = Problem::new(&f, vector![3.0], (0.0, 0.1));
    /// let sol = sensitivity::solve(&p, Euler, &Options::default().fixed(0.1), &SensitivityOptions::default()).unwrap();
    /// let s = sol.s(1);
    /// assert_eq!(s.shape(), (1, 2));
    /// // ∂x₁/∂x₀ = 1 − hk, ∂x₁/∂k = −h·x₀
    /// assert!((s[(0, 0)] - 0.8).abs() < 1e-15 && (s[(0, 1)] + 0.3).abs() < 1e-15);
    /// ```
    pub fn s(&self, k: usize) -> DMatrixView<'_, f64> {
        let len = self.n * self.m;
        DMatrixView::from_slice(&self.s_flat[k * len..(k + 1) * len], self.n, self.m)
    }
    /// `S` at the last saved time.
    pub fn last_s(&self) -> DMatrixView<'_, f64> {
        self.s(self.t.len() - 1)
    }
    /// `∂x(t_k)/∂x₀` (`n × n`; `n × 0` when the solve had [`Wrt::Params`]).
    pub fn wrt_x0(&self, k: usize) -> DMatrix<f64> {
        self.s(k).columns(0, self.x0_columns()).into_owned()
    }
    /// `∂x(t_k)/∂p` (`n × n_p`).
    pub fn wrt_params(&self, k: usize) -> DMatrix<f64> {
        self.s(k).columns(self.x0_columns(), self.n_params).into_owned()
    }
    /// `∂x_i(t_k)/∂p_j`.
    pub fn dx_dp(&self, k: usize, i: usize, j: usize) -> f64 {
        self.s(k)[(i, self.x0_columns() + j)]
    }
    fn x0_columns(&self) -> usize {
        match self.wrt {
            Wrt::All => self.n,
            Wrt::Params => 0,
        }
    }
    /// The last state.
    pub fn last_x(&self) -> &OVector<f64, D> {
        self.x.last().expect("a solution has at least its initial point")
    }
}

/// Integrate `problem` with its sensitivities `S = ∂x/∂(x₀, p)` (see the module's doc):
/// `method` is any method of [`crate::methods`] (`Rk45`, `Bdf::default()`, …,
/// inferred at `Dyn`) or `Exact::new(flow)` with a [`DualFlow`].
///
/// Events that reset the state apply the saltation matrix to `S` (see the guide's
/// events section); recorded events leave it alone. Errors: those of the solve, and
/// [`Error::InvalidInput`] for a terminal event (the stop time's own sensitivity is not
/// applied) or a mass matrix.
///
/// ```
/// use reckon::{methods::Exact, vehicles::unicycle, sensitivity::{self, SensitivityOptions}, Options, Problem};
/// use nalgebra::vector;
/// let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 2.0)).inputs(vec![1.0, 0.0]);
/// let sol = sensitivity::solve(&p, Exact::new(unicycle::ExactFlow), &Options::default(), &SensitivityOptions::default()).unwrap();
/// let s = sol.wrt_x0(sol.t.len() - 1);
/// assert!((s[(1, 2)] - 2.0).abs() < 1e-15); // ∂y/∂θ₀ = distance driven
/// ```
pub fn solve<D, S, M>(
    problem: &Problem<'_, D, S>,
    method: M,
    opts: &Options,
    sens: &SensitivityOptions,
) -> Result<Sensitivities<D>>
where
    D: Dim,
    S: DualSystem<D>,
    M: Augment<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    if problem.events.iter().any(|e| e.stop_at.is_some()) {
        return Err(Error::invalid(
            "events",
            "sensitivities with a terminal event: the stop time's own sensitivity is not applied (integrate to t_end, or record the event without stopping)",
        ));
    }
    if problem.mass.is_some() {
        return Err(Error::invalid(
            "mass",
            "sensitivities are not computed for a mass-matrix problem (M·x' = f)",
        ));
    }
    let n = problem.x0.len();
    let np = problem.system.n_params();
    if sens.wrt == Wrt::Params && np == 0 {
        return Err(Error::invalid(
            "wrt",
            "sensitivities with respect to the parameters of a model without a parameter block",
        ));
    }
    // the direct schemes know no events; resets take the saltation matrix on the stacked state
    if !problem.has_events()
        && let Some(direct) = method.direct(problem, opts, sens)
    {
        return direct;
    }
    let method = method.augment(n, np)?;
    let aug = Augmented::new(&problem.system, n, sens.wrt);
    let m = aug.m;
    let z0 = stacked_start(problem.x0.as_slice(), m, sens.wrt);
    let mut ap = Problem::<Dyn, Augmented<'_, D, S>>::new(aug, z0, (problem.t0, problem.t_end));
    ap.controls = problem.controls.clone();
    ap.held = problem.held.clone();
    for ev in &problem.events {
        ap = ap.event(saltation::on_stacked(ev, &problem.system, n, m));
    }
    let mut o = opts.clone();
    let widen = |tol: &Tolerance| -> Tolerance {
        match tol {
            Tolerance::Scalar(v) => Tolerance::Scalar(*v),
            // each column of S gets the tolerances of x (checked for length by the solve)
            Tolerance::PerComponent(v) if v.len() == n => {
                Tolerance::PerComponent((0..=m).flat_map(|_| v.iter().copied()).collect())
            }
            Tolerance::PerComponent(v) => Tolerance::PerComponent(v.clone()),
        }
    };
    o.rtol = widen(&opts.rtol);
    o.atol = widen(&opts.atol);
    if !sens.error_control {
        o.error_components = Some(opts.error_components.unwrap_or(n).min(n));
    }
    let mut it = ap.integrator(method, &o)?;
    if !sens.error_control {
        it.watch_uncontrolled(
            UNRESOLVED,
            column_scales(problem.x0.as_slice(), problem.system.params(), sens.wrt),
        );
    }
    let sol: Solution<Dyn> = it.solve()?;
    Ok(unstack(sol.t, sol.x, n, m, sens.wrt, np, sol.stats, sol.method))
}

//! Linear time-invariant models `x' = A·x + B·u` and their exact zero-order-hold flow.
//!
//! With `u` held over a step of length `h` the solution is exactly
//! `x(t + h) = Φ·x(t) + Γ·u`, `Φ = e^{Ah}`, `Γ = ∫₀ʰ e^{As} ds · B`, both read off one
//! exponential of the block matrix `[[A, B], [0, 0]]·h` ([`crate::linalg::expm::zoh`]).
//! [`Lti`] is a model like any other (`A` is its exact Jacobian, so every method
//! integrates it) and [`Lti::flow`] its exact flow, so [`Exact`](crate::methods::Exact)
//! takes one step per control interval, exact to rounding for any `h`, with controls,
//! breakpoints and events as usual.
//!
//! ```
//! use reckon::{Lti, Controls, Options, Problem, methods::Exact};
//! use nalgebra::{Matrix2, Vector2, vector};
//! // double integrator driven by a held acceleration: 1 m/s² for 2 s, then −1 m/s² for 2 s
//! let lti = Lti::new(Matrix2::new(0.0, 1.0, 0.0, 0.0), Vector2::new(0.0, 1.0)).unwrap();
//! let c = Controls::new(vec![0.0, 2.0], vec![vec![1.0], vec![-1.0]]).unwrap();
//! let sol = Problem::new(&lti, vector![0.0, 0.0], (0.0, 4.0))
//!     .controls(c)
//!     .solve(Exact::new(lti.flow()), &Options::default())
//!     .unwrap();
//! let x = sol.last().1;
//! assert!((x[0] - 4.0).abs() < 1e-14 && x[1].abs() < 1e-15); // 2 m + 2 m, at rest
//! assert_eq!(sol.stats.accepted, 2); // one step per control interval
//! ```

use crate::error::{Error, Result};
use crate::linalg::expm::zoh;
use crate::model::DualFlow;
use crate::model::Flow;
use crate::model::{DualSystem, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DefaultAllocator, Dim, OMatrix, OVector, U1};
use num_dual::{Derivative, DualVec64};
use std::sync::Mutex;

/// How many step lengths [`Lti::flow`] keeps `(Φ, Γ)` for (a control log has one or a few).
const CACHED_STEPS: usize = 4;

/// `(h, Φ, Γ)` for the last few step lengths.
type Cache<D> = Vec<(u64, OMatrix<f64, D, D>, DMatrix<f64>)>;

/// The model `x' = A·x + B·u` with `n` states and `m` held inputs (`B` is `n × m`),
/// fixed-size or dynamic.
///
/// ```
/// use reckon::{Lti, System};
/// use nalgebra::{Matrix2, Vector2, vector};
/// let lti = Lti::new(Matrix2::new(-1.0, 1.0, 0.0, -2.0), Vector2::new(0.0, 3.0)).unwrap();
/// let mut dx = vector![0.0, 0.0];
/// lti.rhs(0.0, &vector![1.0, 1.0], &[2.0], &mut dx);
/// assert_eq!(dx, vector![0.0, 4.0]); // A·x + B·u = (0, −2) + (0, 6)
/// assert_eq!(lti.inputs(), 1);
/// ```
pub struct Lti<D: Dim>
where
    DefaultAllocator: Allocator<D, D>,
{
    a: OMatrix<f64, D, D>,
    b: DMatrix<f64>,
    cache: Mutex<Cache<D>>,
}

impl<D: Dim> Clone for Lti<D>
where
    DefaultAllocator: Allocator<D, D>,
{
    fn clone(&self) -> Self {
        Lti {
            a: self.a.clone(),
            b: self.b.clone(),
            cache: Mutex::new(Vec::new()),
        }
    }
}

impl<D: Dim> std::fmt::Debug for Lti<D>
where
    DefaultAllocator: Allocator<D, D>,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Lti").field("a", &self.a).field("b", &self.b).finish()
    }
}

impl<D: Dim> Lti<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// `x' = A·x + B·u`: `A` square `n × n`, `B` with `n` rows and one column per input
    /// (a vector for one input).
    ///
    /// Errors: [`Error::InvalidInput`] for a `B` with the wrong number of rows or a
    /// non-finite entry in either.
    pub fn new<U: Dim>(a: OMatrix<f64, D, D>, b: OMatrix<f64, D, U>) -> Result<Self>
    where
        DefaultAllocator: Allocator<D, U>,
    {
        let n = a.nrows();
        if a.ncols() != n || b.nrows() != n {
            return Err(Error::invalid(
                "lti",
                format!("A is {}x{} and B is {}x{}", a.nrows(), a.ncols(), b.nrows(), b.ncols()),
            ));
        }
        for (name, m) in [("A", a.as_slice()), ("B", b.as_slice())] {
            if let Some(i) = m.iter().position(|v| !v.is_finite()) {
                return Err(Error::invalid(
                    "lti",
                    format!("{name} has the entry {} (index {i})", m[i]),
                ));
            }
        }
        Ok(Lti {
            a,
            b: DMatrix::from_column_slice(n, b.ncols(), b.as_slice()),
            cache: Mutex::new(Vec::new()),
        })
    }

    /// `A`.
    pub fn a(&self) -> &OMatrix<f64, D, D> {
        &self.a
    }
    /// `B` (`n × m`).
    pub fn b(&self) -> &DMatrix<f64> {
        &self.b
    }

    /// The zero-order-hold discretisation over `h`: `(Φ, Γ)` with `Φ = e^{Ah}` and
    /// `Γ = ∫₀ʰ e^{As} ds · B`, so that `x_{k+1} = Φ·x_k + Γ·u_k` exactly.
    ///
    /// Errors: [`Error::InvalidInput`] for a non-finite `h` or an exponential that
    /// overflows.
    ///
    /// ```
    /// use reckon::Lti;
    /// use nalgebra::{Matrix1, Vector1};
    /// // x' = −2x + u: Φ = e^{−2h}, Γ = (1 − e^{−2h})/2
    /// let lti = Lti::new(Matrix1::new(-2.0), Vector1::new(1.0)).unwrap();
    /// let (phi, gamma) = lti.discretise(0.3).unwrap();
    /// let e = (-0.6f64).exp();
    /// // Padé scaling and squaring against libm's `exp`: a few ulps apart (2 here)
    /// assert!((phi[(0, 0)] / e - 1.0).abs() < 4.0 * f64::EPSILON);
    /// assert!((gamma[(0, 0)] / ((1.0 - e) / 2.0) - 1.0).abs() < 4.0 * f64::EPSILON);
    /// ```
    pub fn discretise(&self, h: f64) -> Result<(OMatrix<f64, D, D>, DMatrix<f64>)> {
        let n = self.a.nrows();
        let a = DMatrix::from_column_slice(n, n, self.a.as_slice());
        let (phi, gamma) = zoh(&a, &self.b, h)?;
        let (r, c) = self.a.shape_generic();
        Ok((
            OMatrix::<f64, D, D>::from_column_slice_generic(r, c, phi.as_slice()),
            gamma,
        ))
    }

    /// The exact flow `φ_h(x, u) = Φ·x + Γ·u`, for [`Exact`](crate::methods::Exact); it
    /// keeps `(Φ, Γ)` for the last few step lengths, so a log of equal intervals costs one
    /// exponential.
    pub fn flow(&self) -> LtiFlow<'_, D> {
        LtiFlow(self)
    }

    /// `use(Φ, Γ)` for `h`, from the cache or computed and kept.
    fn with_held<R>(&self, h: f64, use_: impl FnOnce(&OMatrix<f64, D, D>, &DMatrix<f64>) -> R) -> Result<R> {
        let key = h.to_bits();
        let mut c = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, phi, gamma)) = c.iter().find(|e| e.0 == key) {
            return Ok(use_(phi, gamma));
        }
        let (phi, gamma) = self.discretise(h)?;
        let r = use_(&phi, &gamma);
        if c.len() == CACHED_STEPS {
            c.remove(0);
        }
        c.push((key, phi, gamma));
        Ok(r)
    }

    /// `B·u` or `Γ·u` into `out` (added); `false` for a wrong number of inputs.
    fn add_input(m: &DMatrix<f64>, u: &[f64], out: &mut OVector<f64, D>) -> bool {
        if u.len() != m.ncols() {
            return false;
        }
        for (j, &uj) in u.iter().enumerate() {
            if uj != 0.0 {
                for i in 0..m.nrows() {
                    out[i] += m[(i, j)] * uj;
                }
            }
        }
        true
    }
}

impl<D: Dim> System<D> for Lti<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    fn inputs(&self) -> usize {
        self.b.ncols()
    }
    fn rhs(&self, _t: f64, x: &OVector<f64, D>, u: &[f64], dx: &mut OVector<f64, D>) {
        if x.len() != self.a.nrows() {
            dx.fill(f64::NAN);
            return;
        }
        self.a.mul_to(x, dx);
        if !Self::add_input(&self.b, u, dx) {
            dx.fill(f64::NAN);
        }
    }
    /// `J = A`, exactly.
    fn jacobian(&self, _t: f64, _x: &OVector<f64, D>, _u: &[f64], jac: &mut OMatrix<f64, D, D>)
    where
        DefaultAllocator: Allocator<D, D>,
    {
        jac.copy_from(&self.a);
    }
    /// Autonomous: `∂f/∂t = 0`.
    fn time_derivative(&self, _t: f64, _x: &OVector<f64, D>, _u: &[f64], dfdt: &mut OVector<f64, D>) -> bool {
        dfdt.fill(0.0);
        true
    }
}

/// The model is its own exact flow too (the same as [`Lti::flow`], owned: for
/// `Exact::new(lti.clone())` where a `'static` flow is needed).
impl<D: Dim> Flow<D> for Lti<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    fn flow(&self, t: f64, x: &OVector<f64, D>, u: &[f64], h: f64, out: &mut OVector<f64, D>) {
        LtiFlow(self).flow(t, x, u, h, out)
    }
}

/// `A·x` at dual `x` plus the constant `B·u`.
fn affine_dual<D: Dim>(
    a: &OMatrix<f64, D, D>,
    b: &DMatrix<f64>,
    x: &OVector<DualVec64<D>, D>,
    u: &[f64],
) -> OVector<DualVec64<D>, D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    let n = a.nrows();
    let (r, _) = x.shape_generic();
    OVector::<DualVec64<D>, D>::from_fn_generic(r, U1, |i, _| {
        let mut acc = DualVec64::new(0.0, Derivative::none());
        if x.len() != n || u.len() != b.ncols() {
            return DualVec64::new(f64::NAN, Derivative::none());
        }
        for j in 0..n {
            if a[(i, j)] != 0.0 {
                acc += x[j].clone() * a[(i, j)];
            }
        }
        let c: f64 = (0..u.len()).map(|k| b[(i, k)] * u[k]).sum();
        acc + c
    })
}

impl<D: Dim> DualSystem<D> for Lti<D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D> + Allocator<U1, D>,
{
    fn rhs_dual(&self, _t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64]) -> OVector<DualVec64<D>, D> {
        affine_dual(&self.a, &self.b, x, u)
    }
}

/// The exact zero-order-hold flow of an [`Lti`] model ([`Lti::flow`]).
#[derive(Debug, Clone, Copy)]
pub struct LtiFlow<'a, D: Dim>(&'a Lti<D>)
where
    DefaultAllocator: Allocator<D, D>;

impl<D: Dim> Flow<D> for LtiFlow<'_, D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// `out ← Φ·x + Γ·u`; NaN (reported by the driver) when the exponential fails or the
    /// inputs do not match `B`.
    fn flow(&self, _t: f64, x: &OVector<f64, D>, u: &[f64], h: f64, out: &mut OVector<f64, D>) {
        let ok = x.len() == self.0.a.nrows()
            && self
                .0
                .with_held(h, |phi, gamma| {
                    phi.mul_to(x, out);
                    Lti::add_input(gamma, u, out)
                })
                .unwrap_or(false);
        if !ok {
            out.fill(f64::NAN);
        }
    }
}

impl<D: Dim> DualFlow<D> for LtiFlow<'_, D>
where
    DefaultAllocator: Allocator<D, D> + Allocator<D>,
{
    /// `Φ·x + Γ·u` at dual `x`: the sensitivities of the exact flow are `Φ·S`.
    fn flow_dual(&self, _t: f64, x: &OVector<DualVec64<D>, D>, u: &[f64], h: f64) -> OVector<DualVec64<D>, D> {
        self.0
            .with_held(h, |phi, gamma| affine_dual(phi, gamma, x, u))
            .unwrap_or_else(|_| x.map(|_| DualVec64::new(f64::NAN, Derivative::none())))
    }
}

//! The exponential Rosenbrock–Euler method (Hochbruck, Ostermann & Schweitzer 2009):
//! the exact flow of the model linearised at the start of each step.

use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::linalg::expm::phi_combination;
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DefaultAllocator, Dim, OMatrix, OVector};

/// Exponential Rosenbrock–Euler:
/// `x₁ = x₀ + h·φ₁(hJ)·f(t₀, x₀) + h²·φ₂(hJ)·∂f/∂t(t₀, x₀)`, `J = ∂f/∂x (t₀, x₀)` exact
/// from the model's dual body, `φ₁(z) = (e^z − 1)/z`, `φ₂(z) = (e^z − 1 − z)/z²`.
///
/// It integrates the linearisation `x' = f₀ + J·(x − x₀) + f_t·(t − t₀)` exactly, so it
/// is **exact for linear models** (to rounding, at any step), **second order** for
/// nonlinear ones (the remainder `f − f₀ − J·(x − x₀)` is `O(‖x − x₀‖²)`), and stable for
/// any step on stiff linear parts (`φ₁(hλ) → 0` as `hλ → −∞`, so a fast decaying mode is
/// damped, not amplified). Without `∂f/∂t` from the model
/// ([`System::time_derivative`]) a forward difference in `t` stands in, as in
/// [`Rodas5P`](super::Rodas5P). The `φ` combination comes from one exponential of an
/// `(n + 2)`-square block matrix ([`crate::linalg::expm`], Padé scaling and squaring):
/// `O(n³)` per step, so this method is for small and medium dense systems.
///
/// **Error estimate** (adaptive mode): the embedded pair of `exprb32` (Hochbruck,
/// Ostermann & Schweitzer 2009, §5), whose third-order solution adds
/// `2h·φ₃(hJ)·D` to this one, `D = f(t₁, x₁) − f₀ − J·(x₁ − x₀) − h·f_t` (the nonlinear
/// remainder at the end of the step, `O(h²)`). So `ê = 2h·φ₃(hJ)·D` estimates this
/// method's local error `O(h³)` (error order 2, controller exponent ⅓); it vanishes on a
/// linear model, where the method is exact and the steps grow freely. One more `f` and
/// one more `(n + 3)`-square exponential per step; `f(t₁, x₁)` is reused as the next
/// step's `f₀`.
///
/// **Dense output**: the quartic through both ends, both slopes and the linearisation's
/// own value at the midpoint (one more exponential per step). When the dense output is
/// used (events, output times, `Options::dense`) the adaptive estimate also takes the
/// cubic Hermite interpolant's miss at that midpoint, so a long step across a fast
/// transient (where the ends are exact and a polynomial between them is not) is
/// shortened until values between the steps are good to the tolerance.
///
/// ```
/// use reckon::{model, methods::ExponentialEuler, Options, Problem, StepSize};
/// use nalgebra::vector;
/// // linear: x' = −50·x + 1 is integrated exactly with one step of h = 1
/// let f = model!(|_t, x: [S; 1]| vector![x[0] * -50.0 + 1.0]);
/// let sol = Problem::new(&f, vector![1.0], (0.0, 1.0))
///     .solve(ExponentialEuler, &Options::default().step(StepSize::Fixed(1.0)))
///     .unwrap();
/// let exact = 0.02 + 0.98 * (-50.0f64).exp();
/// assert!((sol.last().1[0] - exact).abs() < 1e-15);
/// ```
#[derive(Debug, Clone, Copy, Default)]
pub struct ExponentialEuler;

/// [`ExponentialEuler`]'s run: the linearisation and the end of the step just attempted.
#[derive(Debug, Clone)]
pub struct ExponentialEulerStepper<D: Dim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// `f`, `J` and `f_t` at `(t_at, x_at)`.
    t_at: f64,
    x_at: OVector<f64, D>,
    fx: OVector<f64, D>,
    jac: OMatrix<f64, D, D>,
    dfdt: OVector<f64, D>,
    /// Whether `jac` and `dfdt` belong to `(t_at, x_at)` (after an accepted step only
    /// `fx` does: the end-of-step `f` of the estimate).
    linearised: bool,
    /// `f(t₁, x₁)` of the step just attempted (adaptive mode).
    f_new: OVector<f64, D>,
    f_new_valid: bool,
    /// `(t₁, x₁)` of the attempt.
    t_new: f64,
    x_new: OVector<f64, D>,
    /// Whether the driver keeps the dense output ([`Stepper::dense_needed`]).
    dense: bool,
    /// The linearisation's flow to the midpoint `t₀ + h/2` of the step `(t₀, h)` in
    /// `xm_at`.
    xm: OVector<f64, D>,
    xm_at: Option<(f64, f64)>,
}

impl<D: Dim> ExponentialEulerStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// `f`, `J`, `f_t` at `(t, x)`, evaluated only if they are not there already.
    fn linearise<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, t: f64, x: &OVector<f64, D>) -> Result<()> {
        let here = self.t_at == t && self.x_at == *x;
        if here && self.linearised {
            return Ok(());
        }
        if !here {
            f.rhs(t, x, &mut self.fx)?;
        }
        f.jacobian(t, x, &mut self.jac)?;
        if !f.time_derivative(t, x, &mut self.dfdt)? {
            // forward difference in t, for the h²·φ₂·f_t term only
            let dt = f64::EPSILON.sqrt() * t.abs().max(1.0);
            let t1 = t + dt;
            let dt = t1 - t;
            f.rhs(t1, x, &mut self.dfdt)?;
            self.dfdt -= &self.fx;
            self.dfdt /= dt;
        }
        self.t_at = t;
        self.x_at.copy_from(x);
        self.linearised = true;
        Ok(())
    }
    /// `x_m = x₀ + (h/2)·φ₁(hJ/2)·f₀ + (h/2)²·φ₂(hJ/2)·f_t`, the linearisation's own
    /// value at the midpoint of the step `(t, h)` from `x` (linearised there already).
    fn midpoint(&mut self, t: f64, h: f64, x: &OVector<f64, D>) {
        if self.xm_at == Some((t, h)) {
            return;
        }
        let g = 0.5 * h;
        let hj = self.h_jac(g);
        if !linear_flow(&self.fx, &self.dfdt, &hj, g, x, &mut self.xm) {
            // e^{hJ/2} overflowed (the step's own did not): no midpoint, an infinite miss
            self.xm.fill(f64::NAN);
        }
        self.xm_at = Some((t, h));
    }
    /// `hJ` as a dense matrix.
    fn h_jac(&self, h: f64) -> DMatrix<f64> {
        let n = self.jac.nrows();
        DMatrix::from_fn(n, n, |r, c| h * self.jac[(r, c)])
    }
}

/// The linearisation's flow over `h` from `x` into `out`:
/// `x + h·φ₁(hJ)·f₀ + h²·φ₂(hJ)·f_t`, with `hj = hJ`, `f₀ = fx` and `f_t = dfdt`;
/// `false` (and `out` untouched) when `e^{hJ}` overflowed.
fn linear_flow<D: Dim>(
    fx: &OVector<f64, D>,
    dfdt: &OVector<f64, D>,
    hj: &DMatrix<f64>,
    h: f64,
    x: &OVector<f64, D>,
    out: &mut OVector<f64, D>,
) -> bool
where
    DefaultAllocator: Allocator<D>,
{
    let n = x.len();
    let mut wcols = DMatrix::zeros(n, 2);
    for i in 0..n {
        wcols[(i, 0)] = h * fx[i];
        wcols[(i, 1)] = h * h * dfdt[i];
    }
    let Ok((_, step)) = phi_combination(hj, &wcols) else {
        return false;
    };
    for i in 0..n {
        out[i] = x[i] + step[i];
    }
    true
}

impl<D: Dim> Method<D> for ExponentialEuler
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    type Stepper = ExponentialEulerStepper<D>;
    fn name(&self) -> &'static str {
        "exponential-euler"
    }
    fn order(&self) -> u32 {
        2
    }
    fn error_order(&self) -> Option<u32> {
        Some(2)
    }
    fn never_retries(&self) -> bool {
        true
    }
    fn stepper<S: System<D>>(
        self,
        f: &mut Eval<'_, D, S>,
        t0: f64,
        x0: &OVector<f64, D>,
    ) -> Result<ExponentialEulerStepper<D>> {
        let (r, _) = x0.shape_generic();
        let mut fx = x0.clone();
        f.rhs(t0, x0, &mut fx)?;
        Ok(ExponentialEulerStepper {
            t_at: t0,
            x_at: x0.clone(),
            fx,
            jac: OMatrix::<f64, D, D>::zeros_generic(r, r),
            dfdt: x0.clone(),
            linearised: false,
            f_new: x0.clone(),
            f_new_valid: false,
            t_new: t0,
            x_new: x0.clone(),
            dense: false,
            xm: x0.clone(),
            xm_at: None,
        })
    }
}

impl<D: Dim> Stepper<D> for ExponentialEulerStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn derivative_at_start(&self) -> Option<&OVector<f64, D>> {
        Some(&self.fx)
    }
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome> {
        let Step {
            t,
            x,
            h,
            x_new,
            w,
            adaptive,
        } = s;
        let s = self;
        s.linearise(f, t, x)?;
        let n = x.len();
        let hj = s.h_jac(h);
        s.f_new_valid = false;
        s.xm_at = None;
        if !linear_flow(&s.fx, &s.dfdt, &hj, h, x, x_new) {
            // e^{hJ} overflowed: the solution blows up over this step; the driver
            // reports the non-finite state
            x_new.fill(f64::NAN);
            return Ok(Outcome::Done { err: f64::NAN });
        }
        s.t_new = t + h;
        s.x_new.copy_from(x_new);
        if !adaptive {
            return Ok(Outcome::Done { err: 0.0 });
        }
        // D = f(t₁, x₁) − f₀ − J·(x₁ − x₀) − h·f_t; ê = 2h·φ₃(hJ)·D
        f.rhs(t + h, x_new, &mut s.f_new)?;
        s.f_new_valid = true;
        let mut e = DMatrix::zeros(n, 3);
        for i in 0..n {
            let mut jd = 0.0;
            for k in 0..n {
                jd += s.jac[(i, k)] * (x_new[k] - x[k]);
            }
            e[(i, 2)] = 2.0 * h * (s.f_new[i] - s.fx[i] - jd - h * s.dfdt[i]);
        }
        let Ok((_, est)) = phi_combination(&hj, &e) else {
            return Ok(Outcome::Done { err: f64::NAN });
        };
        let est = OVector::<f64, D>::from_iterator_generic(x.shape_generic().0, nalgebra::U1, est.iter().copied());
        let mut err = w.norm(&est, x, x_new);
        if s.dense {
            // the interpolant between the ends must be as good as they are
            s.midpoint(t, h, x);
            let miss = super::dense::midpoint_miss(h, x, x_new, &s.fx, &s.f_new, &s.xm);
            err = err.max(w.norm(&miss, x, x_new));
        }
        Ok(Outcome::Done { err })
    }
    fn accept(&mut self) {
        // f(t₁, x₁) of the estimate is the next step's f₀ (FSAL); J is not
        if self.f_new_valid {
            std::mem::swap(&mut self.fx, &mut self.f_new);
            self.t_at = self.t_new;
            self.x_at.copy_from(&self.x_new);
            self.linearised = false;
            self.f_new_valid = false;
        }
    }
    fn reset(&mut self) {
        // the inputs jumped: f, J and f_t belong to the old interval
        self.t_at = f64::NAN;
        self.linearised = false;
        self.f_new_valid = false;
        self.xm_at = None;
    }
    fn dense_needed(&mut self) {
        self.dense = true;
    }
    fn dense_len(&self) -> usize {
        5
    }
    /// The quartic (`methods::dense::quartic_through_midpoint`) through both ends, `f`
    /// at both ends and the linearisation's flow to the midpoint.
    fn dense<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        if !(self.t_at == t && self.x_at == *x && self.linearised) {
            self.xm_at = None;
            self.linearise(f, t, x)?;
        }
        self.midpoint(t, h, x);
        c[1].copy_from(&self.fx);
        if self.f_new_valid && self.t_new == t + h && self.x_new == *x_new {
            c[3].copy_from(&self.f_new);
        } else {
            f.rhs(t + h, x_new, &mut c[3])?;
        }
        super::dense::quartic_through_midpoint(h, x, x_new, &self.xm, c);
        Ok(())
    }
}

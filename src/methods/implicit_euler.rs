//! Implicit (backward) Euler solved by simplified Newton with an exact Jacobian.

use super::newton::{self, Solve, Work};
use super::{Failure, Method, Outcome};
use crate::control::{Controller, Weights};
use crate::error::Result;
use crate::linalg::{Lu, LuDim};
use crate::system::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OMatrix, OVector};

/// Newton settings for implicit steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Iterations per attempt (7, as in RADAU5).
    pub max_iters: usize,
    /// Stop when the estimated distance to the solution, in the tolerance-scaled RMS
    /// norm, is below this. `None`: scipy's rule `max(10ε/rtol, min(0.03, √rtol))`.
    pub tol: Option<f64>,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        NewtonOptions {
            max_iters: 7,
            tol: None,
        }
    }
}

/// Implicit Euler: solve `x₁ = x₀ + h·f(t₀ + h, x₁)` by simplified Newton.
///
/// The iteration matrix `M = I − h·J` uses the exact Jacobian `J = ∂f/∂x` from
/// automatic differentiation. `J` and the LU of `M` are kept across iterations and
/// across steps while Newton converges (the LU is refactored when `h` changes); on
/// failure `J` is refreshed at the last Newton iterate, and if that fails too the step is
/// handed back to the driver to shrink.
///
/// **Error estimate** (adaptive mode). The local error of backward Euler is
/// `−h²/2·x'' + O(h³)`; `(h/2)(f(t₁,x₁) − f(t₀,x₀))` estimates it, and since Newton
/// made `f(t₁, x₁) = (x₁ − x₀)/h`, that is `ê = (x₁ − x₀ − h·f(t₀, x₀))/2`. On stiff
/// components (`|hλ| ≫ 1`) this raw estimate grows like `|hλ|` while the true local
/// error stays bounded, so it is filtered as in Hairer–Wanner's RADAU5 and Shampine:
/// `err = (I − hJ)⁻¹ ê`, which is `ê` for non-stiff components and damps stiff ones.
/// One extra `f` call and one LU solve per step; the error has order 2 in `h`, so the
/// controller uses exponent 1/2.
///
/// ```
/// use reckon::{model, methods::ImplicitEuler, Options, Problem, StepSize};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
/// let sol = Problem::new(&f, vector![1.0], (0.0, 0.1))
///     .solve(ImplicitEuler::default(), &Options::default().step(StepSize::Fixed(0.1)))
///     .unwrap();
/// assert!((sol.last().1[0] - 1.0 / 1.1).abs() < 1e-12); // x₁ = x₀/(1 + h)
/// ```
pub struct ImplicitEuler<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Newton settings.
    pub newton: NewtonOptions,
    j: Option<OMatrix<f64, D, D>>,
    m: Option<OMatrix<f64, D, D>>,
    lu: Option<D::Lu>,
    lu_h: f64,
    j_current: bool,
    j_valid: bool,
    fx: Option<OVector<f64, D>>,
    dx: Option<OVector<f64, D>>,
}

impl<D: LuDim> Default for ImplicitEuler<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn default() -> Self {
        Self::new(NewtonOptions::default())
    }
}

impl<D: LuDim> ImplicitEuler<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Implicit Euler with the given Newton settings.
    pub fn new(newton: NewtonOptions) -> Self {
        ImplicitEuler {
            newton,
            j: None,
            m: None,
            lu: None,
            lu_h: f64::NAN,
            j_current: false,
            j_valid: false,
            fx: None,
            dx: None,
        }
    }

    fn refresh_jacobian<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, t: f64, x: &OVector<f64, D>) -> Result<()> {
        if let Some(j) = self.j.as_mut() {
            f.jacobian(t, x, j)?;
        }
        self.j_valid = true;
        self.j_current = true;
        self.lu = None;
        Ok(())
    }

    /// Factor `I − h·J` unless the LU for this `h` is at hand; `false` if singular.
    /// A fixed-step grid `t₀ + k·h` gives step sizes that differ in the last bits; those
    /// reuse the LU (simplified Newton only needs an approximate `M`, and its convergence
    /// test guards the rest).
    fn factor(&mut self, stats: &mut crate::Stats, h: f64) -> bool {
        if self.lu.is_some() && (h - self.lu_h).abs() <= 1e-9 * h.abs() {
            return true;
        }
        let (Some(j), Some(m)) = (self.j.as_ref(), self.m.as_mut()) else {
            return false;
        };
        m.copy_from(j);
        *m *= -h;
        for i in 0..m.nrows() {
            m[(i, i)] += 1.0;
        }
        stats.lu_decompositions += 1;
        self.lu = D::Lu::factor(m);
        self.lu_h = h;
        self.lu.is_some()
    }
}

impl<D: LuDim> Method<D> for ImplicitEuler<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn name(&self) -> &'static str {
        "implicit-euler"
    }
    fn order(&self) -> u32 {
        1
    }
    fn error_order(&self) -> Option<u32> {
        Some(1)
    }
    /// An I controller (exponent ½) that keeps `h` when the proposed growth is below
    /// 20% (as RADAU5 does), so that the LU of `I − hJ` can be reused.
    fn controller(&self) -> Controller {
        Controller::new(1, 0.0).with_hold(1.0, 1.2)
    }
    fn init<S: System<D>>(&mut self, _f: &mut Eval<'_, D, S>, _t0: f64, x0: &OVector<f64, D>) -> Result<()> {
        let (r, _) = x0.shape_generic();
        self.j = Some(OMatrix::<f64, D, D>::zeros_generic(r, r));
        self.m = Some(OMatrix::<f64, D, D>::zeros_generic(r, r));
        self.fx = Some(x0.clone());
        self.dx = Some(x0.clone());
        self.j_valid = false;
        self.lu = None;
        Ok(())
    }
    fn step<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        x: &OVector<f64, D>,
        h: f64,
        x_new: &mut OVector<f64, D>,
        w: &Weights<D>,
        adaptive: bool,
    ) -> Result<Outcome> {
        if !self.j_valid {
            self.refresh_jacobian(f, t, x)?;
        }
        let rtol = w.rtol.iter().copied().fold(f64::INFINITY, f64::min).max(f64::EPSILON);
        let tol = self
            .newton
            .tol
            .unwrap_or_else(|| (10.0 * f64::EPSILON / rtol).max(0.03f64.min(rtol.sqrt())));
        let mut refreshed_at_iterate = false;
        loop {
            if !self.factor(&mut f.stats, h) {
                if self.j_current {
                    return Ok(Outcome::Retry(Failure::Singular));
                }
                self.refresh_jacobian(f, t, x)?;
                continue;
            }
            let (Some(lu), Some(fx), Some(dx)) = (self.lu.as_ref(), self.fx.as_mut(), self.dx.as_mut()) else {
                return Err(crate::Error::invalid(
                    "method",
                    "ImplicitEuler::step called before init",
                ));
            };
            x_new.copy_from(x);
            let work = Work { fx, dx };
            match newton::solve(f, lu, t + h, x, h, x_new, w, tol, self.newton.max_iters, work)? {
                Solve::Converged => break,
                Solve::Failed { iterations, residual } => {
                    // refresh J where Newton got to (closer to x₁ than x₀ is), once per
                    // step; then give the step back to the driver to shrink
                    let iterate_ok = x_new.iter().all(|v| v.is_finite()) && *x_new != *x;
                    if self.j_current && (refreshed_at_iterate || !iterate_ok) {
                        return Ok(Outcome::Retry(Failure::Newton { iterations, residual }));
                    }
                    if iterate_ok {
                        let at = x_new.clone();
                        self.refresh_jacobian(f, t + h, &at)?;
                        refreshed_at_iterate = true;
                    } else {
                        self.refresh_jacobian(f, t, x)?;
                    }
                }
            }
        }
        self.j_current = false;
        if !adaptive {
            return Ok(Outcome::Done { err: 0.0 });
        }
        let (Some(lu), Some(fx)) = (self.lu.as_ref(), self.fx.as_mut()) else {
            return Err(crate::Error::invalid(
                "method",
                "ImplicitEuler::step called before init",
            ));
        };
        f.rhs(t, x, fx)?;
        for i in 0..x.len() {
            fx[i] = 0.5 * (x_new[i] - x[i] - h * fx[i]);
        }
        lu.solve_in_place(fx);
        Ok(Outcome::Done {
            err: w.norm(fx, x, x_new),
        })
    }
    fn reset(&mut self) {
        // the inputs jumped: the Jacobian belongs to the old interval
        self.j_valid = false;
    }
}

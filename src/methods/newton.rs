//! The Newton solver shared by the implicit multistep family ([`ImplicitEuler`](super::ImplicitEuler)
//! and [`Bdf`](super::Bdf)): find the correction `d` that solves
//!
//! `c·f(t₁, y_p + d) − ψ − d = 0`,
//!
//! where `y_p` is the method's predictor, `c = h/α` and `ψ` collect the known past
//! (scipy `_ivp/bdf.py`, Shampine & Reichelt 1997). Implicit Euler is `c = h`,
//! `ψ = y_p − x₀`; BDF/NDF of order `k` is `c = h/α_k`, `ψ = Σ_{j≤k} γ_j ∇ʲ y_n / α_k`.
//!
//! Simplified Newton: the iteration matrix `M = I − c·J` is frozen. `J` (the exact
//! autodiff Jacobian) is kept across steps and refreshed only when Newton fails to
//! converge; the LU of `M` is kept while `c` stays within [`LU_REUSE`] of the value it
//! was factored at (CVODE's rule), and each correction is then scaled by
//! `2/(1 + c/c_LU)` (CVODE's `crate`), which restores the contraction on stiff
//! components that a stale `c` would slow.

use super::Failure;
use super::iteration::IterationMatrix;
use crate::error::Result;
use crate::linalg::LuDim;
use crate::methods::step_size::{Weights, sum_sq};
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};

/// The LU of `I − c·J` is refactored when `|c/c_LU − 1|` exceeds this (0.3, CVODE's
/// `DGMAX`); below it the stale LU only slows Newton slightly, and the correction
/// scaling `2/(1 + c/c_LU)` makes up most of that.
pub const LU_REUSE: f64 = 0.3;

/// Iteration matrix, its LU and the Jacobian it was built from (dense or sparse, as the
/// run chose: [`Options::linear_solver`](crate::Options::linear_solver)), plus work vectors.
pub(crate) struct Newton<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    lin: IterationMatrix<D>,
    c_lu: f64,
    /// `J` was evaluated for the current step (a failure then means: shrink `h`).
    j_current: bool,
    /// `J` exists and belongs to the current control interval.
    j_valid: bool,
    fx: OVector<f64, D>,
    dy: OVector<f64, D>,
    /// `atol + rtol·|y_p|`, the convergence test's scale.
    scale: OVector<f64, D>,
    /// Iterations of the last successful solve.
    pub iterations: usize,
}

/// Settings of one solve.
pub(crate) struct Goal {
    /// Convergence threshold on the estimated distance to the solution.
    pub tol: f64,
    /// Iterations per attempt.
    pub max_iters: usize,
}

impl<D: LuDim> Newton<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Work space for states shaped like `x0`, on the linear algebra the run chose.
    pub fn new<S: System<D>>(f: &mut Eval<'_, D, S>, x0: &OVector<f64, D>) -> Result<Self> {
        Ok(Newton {
            lin: IterationMatrix::new(f, x0)?,
            c_lu: f64::NAN,
            j_current: false,
            j_valid: false,
            fx: x0.clone(),
            dy: x0.clone(),
            scale: x0.clone(),
            iterations: 0,
        })
    }

    /// `‖J‖∞` of the Jacobian in use, if there is one for this interval.
    pub fn jacobian_norm(&self) -> Option<f64> {
        self.j_valid.then(|| self.lin.norm_inf())
    }

    /// The inputs jumped: the Jacobian belongs to the old interval.
    pub fn invalidate(&mut self) {
        self.j_valid = false;
        self.lin.drop_lu();
    }

    /// Evaluate `J` at `(t, x)` unless a valid one is at hand.
    pub fn ensure_jacobian<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, t: f64, x: &OVector<f64, D>) -> Result<()> {
        if self.j_valid {
            return Ok(());
        }
        self.refresh(f, t, x)
    }

    fn refresh<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, t: f64, x: &OVector<f64, D>) -> Result<()> {
        self.lin.evaluate(f, t, x)?;
        self.j_valid = true;
        self.j_current = true;
        Ok(())
    }

    /// The LU of `I − c·J`, refactored when `c` moved more than [`LU_REUSE`]; `None`
    /// when singular.
    fn factor(&mut self, stats: &mut crate::Stats, c: f64) -> bool {
        let fresh = self.lin.is_factored() && ((c - self.c_lu) / self.c_lu).abs() <= LU_REUSE;
        if !fresh {
            stats.lu_decompositions += 1;
            self.c_lu = c;
            return self.lin.factor(1.0, -c);
        }
        true
    }

    /// `v ← M⁻¹·v` with the current LU (after a successful [`solve`](Self::solve));
    /// `false` (v untouched) when there is none.
    pub fn solve_lu(&mut self, v: &mut OVector<f64, D>) -> bool {
        self.lin.solve(v)
    }

    /// Solve for `d` (into `d`, with `y = y_p + d`), refreshing `J` once when the stale one
    /// fails; `Some(failure)` when even a fresh `J` does not converge at this step.
    #[allow(clippy::too_many_arguments)]
    pub fn solve<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t1: f64,
        y_p: &OVector<f64, D>,
        c: f64,
        psi: &OVector<f64, D>,
        y: &mut OVector<f64, D>,
        d: &mut OVector<f64, D>,
        w: &Weights<D>,
        goal: &Goal,
    ) -> Result<Option<Failure>> {
        let mut refreshed_at_iterate = false;
        loop {
            if !self.factor(&mut f.stats, c) {
                if self.j_current {
                    return Ok(Some(Failure::Singular));
                }
                self.refresh(f, t1, y_p)?;
                continue;
            }
            let scale_c = 2.0 / (1.0 + c / self.c_lu);
            let work = Work {
                fx: &mut self.fx,
                dy: &mut self.dy,
                scale: &mut self.scale,
            };
            match iterate(f, &mut self.lin, t1, y_p, c, psi, y, d, w, goal, scale_c, work)? {
                Iterated::Converged(k) => {
                    self.iterations = k;
                    self.j_current = false;
                    return Ok(None);
                }
                Iterated::Failed {
                    iterations,
                    residual,
                    non_finite,
                } => {
                    let failure = match non_finite {
                        Some((t, component)) => Failure::NonFinite { t, component },
                        None => Failure::Newton { iterations, residual },
                    };
                    // refresh J where Newton got to (closer to the solution than the
                    // predictor), once per step; then hand the step back to shrink
                    let iterate_ok = y.iter().all(|v| v.is_finite()) && *y != *y_p;
                    if self.j_current && (refreshed_at_iterate || !iterate_ok) {
                        return Ok(Some(failure));
                    }
                    if iterate_ok {
                        let at = y.clone();
                        self.refresh(f, t1, &at)?;
                        refreshed_at_iterate = true;
                    } else {
                        self.refresh(f, t1, y_p)?;
                    }
                }
            }
        }
    }
}

enum Iterated {
    Converged(usize),
    Failed {
        iterations: usize,
        residual: f64,
        /// `(t, component)` when the attempt ended at a non-finite `f`.
        non_finite: Option<(f64, usize)>,
    },
}

struct Work<'b, D: nalgebra::Dim>
where
    DefaultAllocator: Allocator<D>,
{
    fx: &'b mut OVector<f64, D>,
    dy: &'b mut OVector<f64, D>,
    scale: &'b mut OVector<f64, D>,
}

/// Iterate `d ← d + s·M⁻¹(c·f(t₁, y_p + d) − ψ − d)` from `d = 0` until the estimated
/// distance to the solution, `ρ/(1−ρ)·‖Δ‖`, is below `tol` (ρ the observed contraction
/// rate, the norm scaled by the tolerances at `y_p`), giving up when ρ ≥ 1 or when the
/// iterations left cannot reach `tol` at the current rate. A non-finite `f` at an iterate
/// (the predictor included) fails the attempt, so the step is retried smaller; the
/// methods check `f` where they start, so a model that is NaN there is still reported.
#[allow(clippy::too_many_arguments)]
fn iterate<D: LuDim, S: System<D>>(
    f: &mut Eval<'_, D, S>,
    lu: &mut IterationMatrix<D>,
    t1: f64,
    y_p: &OVector<f64, D>,
    c: f64,
    psi: &OVector<f64, D>,
    y: &mut OVector<f64, D>,
    d: &mut OVector<f64, D>,
    w: &Weights<D>,
    goal: &Goal,
    s: f64,
    work: Work<'_, D>,
) -> Result<Iterated>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    let Work { fx, dy, scale } = work;
    let n = y.len();
    // the norm's scale at the predictor, the same for every iteration
    w.scales(y_p.as_slice(), 1.0, scale.as_mut_slice());
    y.copy_from(y_p);
    d.fill(0.0);
    let mut norm_old: Option<f64> = None;
    let mut last = f64::INFINITY;
    let max_iters = goal.max_iters;
    for k in 0..max_iters {
        match f.rhs(t1, y, fx) {
            Ok(()) => {}
            // a wrong-length model is the model's error wherever it shows
            Err(e @ crate::Error::InvalidInput { .. }) => return Err(e),
            // past the method's own start (a predictor or a later iterate) a non-finite
            // f means the iterate left the region where f is defined: shrink the step
            Err(e) => {
                let non_finite = match e {
                    crate::Error::NonFinite { t, component, .. } => Some((t, component)),
                    _ => None,
                };
                return Ok(Iterated::Failed {
                    iterations: k,
                    residual: last,
                    non_finite,
                });
            }
        }
        f.stats.newton_iterations += 1;
        match f.mass {
            None => {
                let (fx, psi, d) = (fx.as_slice(), psi.as_slice(), d.as_slice());
                for (((r, &fx), &psi), &d) in dy.as_mut_slice().iter_mut().zip(fx).zip(psi).zip(d) {
                    *r = c * fx - psi - d;
                }
            }
            Some(m) => m.residual(c, fx.as_slice(), psi.as_slice(), d.as_slice(), dy.as_mut_slice()),
        }
        lu.solve(dy);
        // the correction is s·dy (s = 1 exactly when the LU is at this c)
        let norm = (sum_sq(s, dy.as_slice(), scale.as_slice()) / n.max(1) as f64).sqrt();
        last = norm;
        // a correction below the rounding of every component cannot change the iterate:
        // it is as converged as floating point allows (x₀ = 1e12, say, with a tiny step)
        if norm.is_finite() && (0..n).all(|i| y[i] + s * dy[i] == y[i]) {
            return Ok(Iterated::Converged(k + 1));
        }
        if !norm.is_finite() {
            return Ok(Iterated::Failed {
                iterations: k + 1,
                residual: norm,
                non_finite: None,
            });
        }
        let rate = norm_old.map(|old| norm / old);
        if let Some(rate) = rate
            && (rate >= 1.0 || rate.powi((max_iters - k) as i32) / (1.0 - rate) * norm > goal.tol)
        {
            return Ok(Iterated::Failed {
                iterations: k + 1,
                residual: norm,
                non_finite: None,
            });
        }
        for ((y, d), &dy) in y.as_mut_slice().iter_mut().zip(d.as_mut_slice()).zip(dy.as_slice()) {
            let dy = s * dy;
            *y += dy;
            *d += dy;
        }
        if norm == 0.0 || rate.is_some_and(|rate| rate / (1.0 - rate) * norm < goal.tol) {
            return Ok(Iterated::Converged(k + 1));
        }
        norm_old = Some(norm);
    }
    Ok(Iterated::Failed {
        iterations: max_iters,
        residual: last,
        non_finite: None,
    })
}

/// [`Bdf`](super::Bdf)'s Newton tolerance: [`BDF_TOL_FLOOR`] of the tolerance its error
/// is held to (`factor` ≤ 1 times the given one), but not below what rounding lets Newton
/// see, `10ε/rtol`.
pub(crate) fn bdf_tol<D: nalgebra::Dim>(w: &Weights<D>, factor: f64) -> f64
where
    DefaultAllocator: Allocator<D>,
{
    (BDF_TOL_FLOOR * factor).max(10.0 * f64::EPSILON / min_rtol(w))
}

/// Lowest Newton tolerance of [`Bdf`](super::Bdf) (0.01), in the tolerance-scaled norm
/// of the convergence test.
///
/// The norm is already relative to `atol + rtol·|y|`, so 0.01 is 1 % of the tolerance at
/// any `rtol`, and 6 % of the error Bdf aims each step at (1/6 of the tolerance). scipy's
/// `max(10ε/rtol, min(0.03, √rtol))` (RADAU5's `FNEWT`) asks for 1e-3 of the tolerance at
/// `rtol` 1e-6 and 2e-5 at 1e-10; tightening it a further 100× moves the Test Set end
/// states of VDPOLM and OREGO by at most 0.05 digits, so the iteration per step that
/// the `√rtol` costs buys nothing. It also made the rate test fail whenever the reused LU
/// was factored at a `c` a few per cent off, and every such failure refreshed `J`: on
/// VDPOLM at 1e-10 a Jacobian every 13 steps, with the floor one every 300.
/// At loose tolerances scipy's value is up to 0.03, and its Newton error, 18 % of the error
/// aimed at, was enough to move OREGO's limit cycle by a spike (`rtol` 0.1: 4.7 digits
/// short; 5.6e-3: 1.4 short); Bdf uses the 1 % at every `rtol` (`10ε/rtol` above it below
/// `rtol` 2.2e-13). ImplicitEuler keeps `default_tol`.
pub const BDF_TOL_FLOOR: f64 = 0.01;

/// The smallest `rtol`, at least ε: the one the Newton tolerances read.
pub(crate) fn min_rtol<D: nalgebra::Dim>(w: &Weights<D>) -> f64
where
    DefaultAllocator: Allocator<D>,
{
    w.rtol.iter().copied().fold(f64::INFINITY, f64::min).max(f64::EPSILON)
}

/// The smallest positive `rtol`, `∞` when every `rtol` is 0 (pure absolute control): the
/// one the tolerance-proportionality factors of Bdf and ImplicitEuler read.
pub(crate) fn min_positive_rtol<D: nalgebra::Dim>(w: &Weights<D>) -> f64
where
    DefaultAllocator: Allocator<D>,
{
    w.rtol
        .iter()
        .copied()
        .filter(|r| *r > 0.0)
        .fold(f64::INFINITY, f64::min)
}

/// scipy's Newton tolerance `max(10ε/rtol, min(0.03, √rtol))` for the smallest `rtol`.
pub(crate) fn default_tol<D: nalgebra::Dim>(w: &Weights<D>) -> f64
where
    DefaultAllocator: Allocator<D>,
{
    let rtol = min_rtol(w);
    (10.0 * f64::EPSILON / rtol).max(0.03f64.min(rtol.sqrt()))
}

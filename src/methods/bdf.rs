//! Variable-order, variable-step BDF/NDF in the quasi-constant-step form with backward
//! differences (Shampine & Reichelt, "The MATLAB ODE suite", 1997; scipy `_ivp/bdf.py`).
// the difference-array algebra reads as the papers print it, with indices
#![allow(clippy::needless_range_loop)]

use super::newton::{self, Goal, Newton};
use super::{Method, Outcome, Step, Stepper};
use crate::error::Result;
use crate::linalg::LuDim;
use crate::methods::step_size::{Weights, sum_sq};
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};

/// Highest order.
pub const MAX_ORDER: usize = 5;
/// States per block of the passes over the differences: a block of every difference
/// stays in L1 while it is worked on (at 10⁶ states the vectors fit in no cache), and
/// each pass over a block is vectorised along the states.
const BLOCK: usize = 256;
/// Klopfenstein–Shampine NDF coefficients `κ_k` (MATLAB `ode15s`, scipy): the NDF of
/// order `k` adds `κ_k·γ_k·∇^{k+1}y_{n+1}` to the BDF formula, which lowers the error
/// constant (by 26 % at k = 1, 2) at a small cost in stability (order 5 uses plain BDF).
const KAPPA: [f64; MAX_ORDER + 1] = [0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0];
/// Newton iterations per attempt (scipy's `NEWTON_MAXITER`).
const NEWTON_MAXITER: usize = 4;
const MIN_FACTOR: f64 = 0.2;
const MAX_FACTOR: f64 = 10.0;
/// Every step-size proposal aims at an error estimate of `1/BIAS` of the tolerance,
/// `h·(BIAS·ε)^{−1/(q+1)}` (CVODE's `BIAS2`), where scipy's `0.9·ε^{−1/(q+1)}` aims at
/// `0.9^{q+1}` ≈ 0.5. Why: on VDPOLM and OREGO the end error is made on the slow
/// branches, by the few dozen long steps there, whose local errors (estimated correctly:
/// at constant `h` the true one-step error is a median 0.9–1.05× the estimate) add up
/// with one sign and are not damped later. The global error is then the per-step error level times the
/// number of those steps; the many short steps of the fast transients, where most of the
/// work goes, contribute almost nothing (their errors are damped).
pub(crate) const BIAS: f64 = 6.0;

/// `γ_k = Σ_{j=1..k} 1/j`.
fn gamma(k: usize) -> f64 {
    (1..=k).map(|j| 1.0 / j as f64).sum()
}

/// Coefficients of one order: `α_k = (1 − κ_k)γ_k` and the error constant
/// `C_k = κ_k γ_k + 1/(k+1)`.
#[derive(Debug, Clone, Copy)]
struct Coefficients {
    gamma: [f64; MAX_ORDER + 2],
    alpha: [f64; MAX_ORDER + 2],
    error: [f64; MAX_ORDER + 2],
}

impl Coefficients {
    fn new(ndf: bool) -> Self {
        let mut c = Coefficients {
            gamma: [0.0; MAX_ORDER + 2],
            alpha: [0.0; MAX_ORDER + 2],
            error: [0.0; MAX_ORDER + 2],
        };
        for k in 0..=MAX_ORDER + 1 {
            let kappa = if ndf && k <= MAX_ORDER { KAPPA[k] } else { 0.0 };
            c.gamma[k] = gamma(k);
            c.alpha[k] = (1.0 - kappa) * c.gamma[k];
            c.error[k] = kappa * c.gamma[k] + 1.0 / (k as f64 + 1.0);
        }
        c
    }
}

/// Variable-order BDF (orders 1–5) with the NDF variant by default.
///
/// With `∇ʲ` the backward differences of the past solution values on a constant step
/// `h` (kept in an array `D`, `D_j = ∇ʲ y_n`, and interpolated to a new `h` whenever the
/// step changes), the order-`k` formula solved for `y_{n+1}` is
///
/// `Σ_{j=1..k} γ_j ∇ʲ y_{n+1} − κ_k γ_k (y_{n+1} − y⁽⁰⁾_{n+1}) = h·f(t_{n+1}, y_{n+1})`,
///
/// `γ_j = Σ_{i≤j} 1/i`, with the predictor `y⁽⁰⁾_{n+1} = Σ_{j≤k} ∇ʲ y_n`. `κ = 0` is the
/// plain BDF ([`Bdf::bdf`]), whose order-1 member is implicit Euler; the default NDF
/// (`κ` of Klopfenstein and Shampine, as MATLAB's `ode15s` and scipy's `BDF`) has smaller
/// error constants at a slight loss of stability.
///
/// **Newton.** Simplified Newton from the predictor with the exact autodiff Jacobian,
/// shared with [`ImplicitEuler`](super::ImplicitEuler): `J` is kept over many steps
/// and refreshed only when Newton fails to converge; the LU of `I − (h/α_k)J` is
/// refactored only when `h/α_k` moved by more than
/// `newton::LU_REUSE` (30 %) since it was factored. Newton stops when
/// its estimated error is below `newton::BDF_TOL_FLOOR` = 1 % of
/// the tolerance (`10ε/rtol` where that is larger). scipy's `max(10ε/rtol, min(0.03,
/// √rtol))` asks 2e-5 at `rtol` 1e-10, which costs an iteration per step and buys no
/// digit, and 3 % at loose tolerances, which moved OREGO's limit cycle by a spike.
///
/// **Loose tolerances** above 1e-3 are tightened to `0.1·rtol^{2/3}`
/// ([`Weights::tighten_loose`](crate::methods::step_size::Weights::tighten_loose)), as RADAU5 does.
///
/// **Tolerance proportionality.** Held to the tolerance step by step, an order-`p` method
/// takes `N ∝ tol^{−1/(p+1)}` steps, each with an error of the order of `tol`, so its
/// global error grows like `tol^{p/(p+1)}`: on OREGO 0.8 digits per decade of `rtol`,
/// 2.36 digits short of `−log₁₀ rtol` at 1e-12 (scipy's BDF: 2.9). Below `rtol` 1e-6 the
/// error (and Newton's tolerance with it) is therefore held to `tol·(rtol/1e-6)^{1/p}`,
/// `p` the highest order allowed, which restores slope 1 and leaves every `rtol` from
/// 1e-6 up as it was; the tightened `rtol` never goes below `min(rtol, 1e-14)`. Inside
/// [`Auto`](super::Auto) only the BDF steps are held so: its DOPRI5 steps stay those of
/// [`Rk45`](super::Rk45).
///
/// **Error and order.** The local error is `C_k ∇^{k+1} y_{n+1}` with `C_k = κ_kγ_k +
/// 1/(k+1)`, accepted when its weighted RMS norm `ε ≤ 1`. Every proposal aims at
/// `ε = 1/6` (CVODE's bias 6), not at scipy's `0.9^{k+1}` ≈ 0.5: the step that order `q`
/// allows is `h·s·(6ε_q)^{−1/(q+1)}`, with `s = (2m + 1)/(2m + n)` ≤ 1 lower when Newton
/// needed `n` of its `m` iterations (scipy's factor). After `k + 1` steps at constant `h`,
/// the estimates of orders `k − 1`, `k`, `k + 1` are compared and the order whose step is
/// largest is taken (factor at most 10). Before that `h` is held, as in scipy and
/// `ode15s`, except that it is *reduced* at once when the current order's factor is below
/// 1 (DASSL also reduces after an accepted step): held while the error grows toward the
/// end of a slow branch, every third step or so was rejected and the accepted ones rode
/// at the tolerance. A rejected step shrinks by the same factor (at least 0.2); a Newton
/// failure halves it.
///
/// With the Test Set tolerances (`atol = rtol`, Robertson `1e-4·rtol`) this takes VDPOLM
/// from 4.3 to 4.9 and OREGO from 4.2 to 4.9 mixed significant digits at `rtol` 1e-6
/// (scipy's BDF: 4.4, 4.2), and every Test Set problem up by 0.4–1.4 digits at 1e-6 and
/// 1e-10, with 14–33 % more steps but, together with the Newton floor above, 1–24 % fewer
/// `f` evaluations (fewer Newton iterations, almost no rejections), 8–58 % fewer LUs and
/// 45–95 % fewer Jacobians (`tests/it/bdf.rs`).
///
/// **Dense output** is the interpolating polynomial of the differences, exact at the
/// last `k + 1` solution values. A jump in the inputs (a breakpoint) restarts at order 1.
///
/// ```
/// use reckon::{model, methods::Bdf, Options, Problem};
/// use nalgebra::vector;
/// // Robertson's kinetics to t = 40: y₁ from the Hairer–Wanner table
/// let f = model!(|_t, y: [S; 3]| vector![
///     y[0] * -0.04 + y[1] * y[2] * 1e4,
///     y[0] * 0.04 - y[1] * y[1] * 3e7 - y[1] * y[2] * 1e4,
///     y[1] * y[1] * 3e7
/// ]);
/// let opts = Options::default().rtol(1e-8).atol(1e-12);
/// let sol = Problem::new(&f, vector![1.0, 0.0, 0.0], (0.0, 40.0)).solve(Bdf::default(), &opts).unwrap();
/// let y = sol.last().1;
/// assert!((y[0] - 0.7158270687).abs() < 1e-6);
/// assert!((y.sum() - 1.0).abs() < 1e-12); // the linear invariant
/// assert!(sol.stats.accepted < 400);
/// ```
#[derive(Debug, Clone)]
pub struct Bdf {
    /// Newton settings (`max_iters` defaults to scipy's 4 here; `tol: None` is scipy's
    /// rule floored at `newton::BDF_TOL_FLOOR`).
    pub newton: super::NewtonOptions,
    /// Highest order the selection may reach (1–5).
    pub max_order: usize,
    coef: Coefficients,
    ndf: bool,
    fixed_order: Option<usize>,
    /// Past values `x(t₀ − h), x(t₀ − 2h), …` ([`history`](Self::history)), each as
    /// its components.
    start_history: Option<Vec<Vec<f64>>>,
}

/// [`Bdf`]'s run: everything carried from step to step.
pub struct BdfStepper<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// The settings (without the start history, used up).
    pub(crate) method: Bdf,
    newton: Newton<D>,
    /// `D[j] = ∇ʲ y_n` on the step `h`, `j = 0..=MAX_ORDER + 2`.
    diffs: Vec<OVector<f64, D>>,
    /// Work copies for the step-change interpolation.
    tmp: Vec<OVector<f64, D>>,
    order: usize,
    /// The step `diffs` is scaled to; NaN before the first step of an interval.
    h: f64,
    equal_steps: usize,
    /// `f` at the start of an interval, for `D₁ = h·f`, and whether it is current.
    f0: OVector<f64, D>,
    f0_valid: bool,
    restart: bool,
    y_p: OVector<f64, D>,
    psi: OVector<f64, D>,
    /// Newton's correction `y_{n+1} − y⁽⁰⁾`, which is `∇^{k+1} y_{n+1}`.
    d: OVector<f64, D>,
    /// Tolerance scale at the accepted `y_{n+1}`, for the order-selection norms.
    scale: OVector<f64, D>,
    /// Leading components in the error estimate ([`Weights::controlled`]).
    controlled: usize,
    /// [`Bdf::factor`] and Newton's tolerance for the run's weights (computed at the
    /// first step).
    tols: Option<(f64, f64)>,
    /// Step factor of the last attempt's Newton work: `(2m + 1)/(2m + n)` for `n` of
    /// `m` iterations (scipy's; 1 after one iteration, lower after many).
    safety: f64,
}

impl Default for Bdf {
    fn default() -> Self {
        Bdf {
            newton: super::NewtonOptions {
                max_iters: NEWTON_MAXITER,
                tol: None,
            },
            max_order: MAX_ORDER,
            coef: Coefficients::new(true),
            ndf: true,
            fixed_order: None,
            start_history: None,
        }
    }
}

impl Bdf {
    /// The factor of tolerance proportionality below `rtol` 1e-6 (1 above):
    /// `(r/1e-6)^{1/p}` for the smallest positive `rtol` `r` and the highest order `p`,
    /// but never so small that `r·factor` falls below `min(r, 1e-14)`. See the type's
    /// documentation, "Tolerance proportionality".
    pub(crate) fn factor<D: nalgebra::Dim>(&self, w: &Weights<D>) -> f64
    where
        DefaultAllocator: Allocator<D>,
    {
        const PIVOT: f64 = 1e-6;
        let p = self.fixed_order.unwrap_or(self.max_order).max(1) as f64;
        let r = newton::min_positive_rtol(w);
        if r < PIVOT {
            (r / PIVOT).powf(1.0 / p).max((1e-14 / r).min(1.0))
        } else {
            1.0
        }
    }

    /// The NDF variant (the default).
    pub fn ndf() -> Self {
        Self::default()
    }
    /// Plain BDF (`κ = 0`); its order-1 member is implicit Euler.
    #[allow(clippy::self_named_constructors)]
    pub fn bdf() -> Self {
        Bdf {
            coef: Coefficients::new(false),
            ndf: false,
            ..Self::default()
        }
    }
    /// Highest order the selection may reach, `1 ≤ k ≤ 5`.
    pub fn max_order(mut self, k: usize) -> Self {
        self.max_order = k.clamp(1, MAX_ORDER);
        self
    }
    /// Keep the order fixed at `k` (for order studies). Without
    /// [`history`](Self::history) the run starts at order 1 and rises by one per step.
    pub fn fixed_order(mut self, k: usize) -> Self {
        let k = k.clamp(1, MAX_ORDER);
        self.fixed_order = Some(k);
        self.max_order = k;
        self
    }
    /// Start from known past values `x(t₀ − h), x(t₀ − 2h), …, x(t₀ − k·h)` on the first
    /// step's `h` (a fixed-step order study started from exact values): the run begins
    /// at order `k` = the number of values given (at most 5). A value whose length is not
    /// the state's is [`Error::InvalidInput`](crate::Error::InvalidInput) when the solve starts.
    pub fn history<D: nalgebra::Dim>(mut self, past: Vec<OVector<f64, D>>) -> Self
    where
        DefaultAllocator: Allocator<D>,
    {
        self.start_history = Some(past.iter().map(|v| v.as_slice().to_vec()).collect());
        self
    }
    /// The order of the first step: that of the start history, else 1.
    fn start_order(&self) -> usize {
        self.start_history
            .as_ref()
            .filter(|p| !p.is_empty())
            .map_or(1, |p| p.len().min(MAX_ORDER))
    }
    /// Whether this is the NDF variant.
    pub fn is_ndf(&self) -> bool {
        self.ndf
    }
    /// The error constant `C_q = κ_qγ_q + 1/(q+1)` of order `q` (1–5): the local error
    /// is `C_q ∇^{q+1}y ≈ C_q h^{q+1} y⁽q⁺¹⁾`.
    pub(crate) fn error_constant(&self, q: usize) -> f64 {
        self.coef.error[q.min(MAX_ORDER)]
    }
}

/// `R(order, factor)` of scipy's `compute_R`: `R[i][j] = Π_{m=1..i} (m − 1 − factor·j)/m`
/// (row 0 all ones), the map of differences on step `h` to differences on `factor·h`
/// together with `U = R(order, 1)`.
fn compute_r(order: usize, factor: f64) -> [[f64; MAX_ORDER + 1]; MAX_ORDER + 1] {
    let mut r = [[0.0; MAX_ORDER + 1]; MAX_ORDER + 1];
    for j in 0..=order {
        r[0][j] = 1.0;
    }
    for i in 1..=order {
        for j in 0..=order {
            let m = if j == 0 {
                0.0
            } else {
                (i as f64 - 1.0 - factor * j as f64) / i as f64
            };
            r[i][j] = r[i - 1][j] * m;
        }
    }
    r
}

impl<D: LuDim> BdfStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Re-express the differences on the step `factor·h` (scipy `change_D`):
    /// `D_j ← Σ_i (R·U)_ij D_i`, one pass over the states.
    fn change_h(&mut self, factor: f64) {
        let k = self.order;
        let r = compute_r(k, factor);
        let u = compute_r(k, 1.0);
        let mut ru = [[0.0; MAX_ORDER + 1]; MAX_ORDER + 1];
        for i in 0..=k {
            for j in 0..=k {
                ru[i][j] = (0..=k).map(|m| r[i][m] * u[m][j]).sum();
            }
        }
        // in blocks of states (BLOCK)
        let n = self.diffs[0].len();
        let mut acc = [[0.0; BLOCK]; MAX_ORDER + 1];
        for lo in (0..n).step_by(BLOCK) {
            let hi = (lo + BLOCK).min(n);
            for (j, a) in acc.iter_mut().enumerate().take(k + 1) {
                let a = &mut a[..hi - lo];
                a.fill(0.0);
                for i in 0..=k {
                    let c = ru[i][j];
                    for (a, &x) in a.iter_mut().zip(&self.diffs[i].as_slice()[lo..hi]) {
                        *a += c * x;
                    }
                }
            }
            for (j, a) in acc.iter().enumerate().take(k + 1) {
                self.diffs[j].as_mut_slice()[lo..hi].copy_from_slice(&a[..hi - lo]);
            }
        }
        self.h *= factor;
        self.equal_steps = 0;
    }

    /// Current order (after the last accepted step).
    pub fn current_order(&self) -> usize {
        self.order
    }
    /// `‖J‖∞` of Newton's Jacobian (a bound on `|λ|` for every eigenvalue), if one is
    /// held for the current interval.
    pub fn jacobian_norm(&self) -> Option<f64> {
        self.newton.jacobian_norm()
    }
    /// [`Bdf::factor`] of the settings.
    pub(crate) fn factor(&self, w: &Weights<D>) -> f64 {
        self.method.factor(w)
    }

    /// Weighted RMS of `c·v` in the scale of the accepted state.
    fn norm(&self, c: f64, v: &OVector<f64, D>) -> f64 {
        let n = self.controlled.min(v.len());
        let s = sum_sq(c, &v.as_slice()[..n], &self.scale.as_slice()[..n]);
        (s / n.max(1) as f64).sqrt()
    }
}

impl<D: LuDim> Method<D> for Bdf
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    type Stepper = BdfStepper<D>;
    fn tightens_loose_tolerances(&self) -> bool {
        true
    }
    fn takes_mass(&self) -> bool {
        true
    }
    fn consistent_start<S: System<D>>(
        &self,
        f: &mut Eval<'_, D, S>,
        t0: f64,
        x0: &OVector<f64, D>,
        w: &Weights<D>,
    ) -> Result<Option<OVector<f64, D>>> {
        match f.mass {
            Some(m) => super::consistent::consistent_start(f, m, t0, x0, w),
            None => Ok(None),
        }
    }
    fn error_scale(&self, w: &Weights<D>) -> f64 {
        1.0 / self.factor(w)
    }
    fn crossing_test(&self) -> bool {
        true
    }
    fn name(&self) -> &'static str {
        if self.ndf { "bdf" } else { "bdf-plain" }
    }
    fn order(&self) -> u32 {
        self.fixed_order.unwrap_or(self.max_order) as u32
    }
    fn error_order(&self) -> Option<u32> {
        Some(self.start_order() as u32)
    }
    fn stepper<S: System<D>>(mut self, f: &mut Eval<'_, D, S>, t0: f64, x0: &OVector<f64, D>) -> Result<BdfStepper<D>> {
        let mut f0 = x0.clone();
        f.rhs(t0, x0, &mut f0)?;
        let zero = x0.map(|_| 0.0);
        let mut diffs = vec![zero.clone(); MAX_ORDER + 3];
        diffs[0].copy_from(x0);
        let mut restart = true;
        let mut order = 1;
        if let Some(past) = self.start_history.take().filter(|p| !p.is_empty()) {
            // a dynamic state may be handed past values of another length (the fuzz target
            // `solve` found the subtraction below panicking on one)
            if let Some((j, v)) = past.iter().enumerate().find(|(_, v)| v.len() != x0.len()) {
                return Err(crate::Error::invalid(
                    "history",
                    format!("past value {j} has {} components, the state {}", v.len(), x0.len()),
                ));
            }
            // values y_n, y_{n−1}, …, y_{n−k} → backward differences ∇ʲ y_n
            let k = past.len().min(MAX_ORDER);
            let (r, _) = x0.shape_generic();
            let mut vals: Vec<OVector<f64, D>> = std::iter::once(x0.clone())
                .chain(
                    past[..k]
                        .iter()
                        .map(|v| OVector::from_iterator_generic(r, nalgebra::U1, v.iter().copied())),
                )
                .collect();
            for (j, diff) in diffs.iter_mut().enumerate().take(k + 1) {
                diff.copy_from(&vals[0]);
                for i in 0..k - j {
                    let next = &vals[i] - &vals[i + 1];
                    vals[i] = next;
                }
            }
            order = k;
            restart = false;
        }
        Ok(BdfStepper {
            method: self,
            newton: Newton::new(f, x0)?,
            tmp: vec![zero.clone(); MAX_ORDER + 1],
            diffs,
            order,
            h: f64::NAN,
            equal_steps: 0,
            f0,
            f0_valid: true,
            restart,
            y_p: zero.clone(),
            psi: zero.clone(),
            d: zero.clone(),
            scale: zero.map(|_| 1.0),
            controlled: zero.len(),
            tols: None,
            safety: 1.0,
        })
    }
}

impl<D: LuDim> Stepper<D> for BdfStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn derivative_at_start(&self) -> Option<&OVector<f64, D>> {
        Some(&self.f0)
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
        let coef = self.method.coef;
        // the tolerances are the run's: their minima are read once
        let (factor, newton_tol) = *self.tols.get_or_insert_with(|| {
            let factor = self.method.factor(w);
            (
                factor,
                self.method.newton.tol.unwrap_or_else(|| newton::bdf_tol(w, factor)),
            )
        });
        let goal = Goal {
            tol: newton_tol,
            max_iters: self.method.newton.max_iters,
        };
        let s = self;
        if s.restart {
            // the first step of an interval: order 1 from (x, f(t, x))
            if !s.f0_valid {
                f.rhs(t, x, &mut s.f0)?;
                s.f0_valid = true;
            }
            s.diffs[0].copy_from(x);
            match f.mass {
                // the slope M⁺·f (zero along M's null space: the algebraic components)
                Some(m) => m.derivative(s.f0.as_slice(), s.diffs[1].as_mut_slice()),
                None => s.diffs[1].copy_from(&s.f0),
            }
            s.diffs[1] *= h;
            for d in s.diffs.iter_mut().skip(2) {
                d.fill(0.0);
            }
            s.order = 1;
            s.h = h;
            s.equal_steps = 0;
            s.restart = false;
        } else if s.h.is_nan() {
            // history given for the first step's h
            s.h = h;
        } else if h != s.h {
            s.change_h(h / s.h);
            s.h = h;
        }
        s.newton.ensure_jacobian(f, t, x)?;
        let k = s.order;
        // predictor Σ_{j≤k} ∇ʲ y_n and the known part ψ = Σ_{j=1..k} γ_j ∇ʲ y_n / α_k
        // (one pass over the differences: at 10⁶ states the vectors leave the caches)
        let mut g = [0.0; MAX_ORDER + 1];
        for (j, gj) in g.iter_mut().enumerate().take(k + 1).skip(1) {
            *gj = coef.gamma[j] / coef.alpha[k];
        }
        let n = x.len();
        for lo in (0..n).step_by(BLOCK) {
            let hi = (lo + BLOCK).min(n);
            let yp = &mut s.y_p.as_mut_slice()[lo..hi];
            let ps = &mut s.psi.as_mut_slice()[lo..hi];
            yp.copy_from_slice(&s.diffs[0].as_slice()[lo..hi]);
            ps.fill(0.0);
            for (j, gj) in g.iter().enumerate().take(k + 1).skip(1) {
                let dj = &s.diffs[j].as_slice()[lo..hi];
                for ((yp, ps), &dj) in yp.iter_mut().zip(ps.iter_mut()).zip(dj) {
                    *yp += dj;
                    *ps += gj * dj;
                }
            }
        }
        let c = h / coef.alpha[k];
        let t1 = t + h;
        if let Some(why) = s.newton.solve(f, t1, &s.y_p, c, &s.psi, x_new, &mut s.d, w, &goal)? {
            return Ok(Outcome::Retry(why));
        }
        let n_iter = s.newton.iterations as f64;
        let mi = goal.max_iters as f64;
        s.safety = (2.0 * mi + 1.0) / (2.0 * mi + n_iter);
        s.controlled = w.controlled;
        let nc = s.controlled.min(n);
        // the scale at y_{n+1} (times the tolerance factor) in one pass, the error's
        // weighted RMS (as `norm`) in a second
        let ce = coef.error[k];
        w.scales(x_new.as_slice(), factor, s.scale.as_mut_slice());
        let acc = sum_sq(ce, &s.d.as_slice()[..nc], &s.scale.as_slice()[..nc]);
        if !adaptive {
            return Ok(Outcome::Done { err: 0.0 });
        }
        let err = (acc / nc.max(1) as f64).sqrt();
        if nc < n {
            // the components outside the error control, watched (the sensitivities)
            w.rest_from(|i| ce * s.d[i], x.as_slice(), x_new.as_slice());
        }
        Ok(Outcome::Done { err })
    }
    fn accept(&mut self) {
        let fixed_order = self.method.fixed_order;
        let s = self;
        let k = s.order;
        // ∇^{k+2} y_{n+1} = d − ∇^{k+1} y_n, ∇^{k+1} y_{n+1} = d, then ∇ʲ y_{n+1} = ∇ʲ y_n + ∇^{j+1} y_{n+1}
        // (one pass over the differences, as in the predictor)
        assert!(s.diffs.len() > k + 2, "Bdf: difference array shorter than order + 3");
        let n = s.d.len();
        for lo in (0..n).step_by(BLOCK) {
            let hi = (lo + BLOCK).min(n);
            let d = &s.d.as_slice()[lo..hi];
            let (low, high) = s.diffs.split_at_mut(k + 1);
            let (d1, d2) = high.split_at_mut(1);
            let (d1, d2) = (&mut d1[0].as_mut_slice()[lo..hi], &mut d2[0].as_mut_slice()[lo..hi]);
            for ((a, b), &di) in d2.iter_mut().zip(d1.iter_mut()).zip(d) {
                *a = di - *b;
                *b = di;
            }
            // ∇ʲ ← ∇ʲ + ∇^{j+1}, from j = k down
            let mut above: &[f64] = d1;
            for dj in low.iter_mut().rev() {
                let dj = &mut dj.as_mut_slice()[lo..hi];
                for (a, &u) in dj.iter_mut().zip(above) {
                    *a += u;
                }
                above = dj;
            }
        }
        s.equal_steps += 1;
        if let Some(target) = fixed_order {
            // start-up of a fixed-order run: rise one order per step until k
            if s.order < target {
                s.order += 1;
                s.equal_steps = 0;
            }
        }
    }
    fn step_factor(&mut self, accepted: bool, err: f64) -> Option<f64> {
        let fixed = self.method.fixed_order.is_some();
        let max_order = self.method.max_order;
        let coef = self.method.coef;
        let s = self;
        let k = s.order;
        // the step order q allows for an estimate e: aim at e = 1/BIAS
        let safety = s.safety;
        let factor = |e: f64, q: usize| safety * (BIAS * e).powf(-1.0 / (q as f64 + 1.0));
        let fac = factor(err, k);
        if !accepted {
            let fac = if err.is_finite() {
                fac.max(MIN_FACTOR)
            } else {
                MIN_FACTOR
            };
            return Some(fac.min(1.0));
        }
        if s.equal_steps < k + 1 {
            // h is held for k + 1 steps (the differences settle on it) unless the
            // estimate says it is already too long: then it shrinks now, not at a rejection
            return Some(if fac < 1.0 { fac.max(MIN_FACTOR) } else { 1.0 });
        }
        if fixed {
            return Some(fac.clamp(MIN_FACTOR, MAX_FACTOR));
        }
        let e_minus = if k > 1 {
            s.norm(coef.error[k - 1], &s.diffs[k])
        } else {
            f64::INFINITY
        };
        let e_plus = if k < max_order {
            s.norm(coef.error[k + 1], &s.diffs[k + 2])
        } else {
            f64::INFINITY
        };
        // orders k − 1, k, k + 1
        let facs = [factor(e_minus, k - 1), fac, factor(e_plus, k + 1)];
        let mut best = (0usize, f64::NEG_INFINITY);
        for (m, f) in facs.iter().enumerate() {
            if *f > best.1 {
                best = (m, *f);
            }
        }
        s.order = k + best.0 - 1;
        Some(best.1.min(MAX_FACTOR))
    }
    fn reset(&mut self) {
        self.newton.invalidate();
        self.restart = true;
        self.f0_valid = false;
        self.h = f64::NAN;
    }
    fn dense_len(&self) -> usize {
        MAX_ORDER + 1
    }
    /// `y(t_n + θh) = ∇⁰y_{n+1} + Σ_{j=1..k} ∇ʲ y_{n+1} Π_{m<j} (θ − 1 + m)/(m + 1)`,
    /// expanded in powers of θ (the differences after this step).
    fn dense<S: System<D>>(
        &mut self,
        _f: &mut Eval<'_, D, S>,
        _t: f64,
        _h: f64,
        _x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        let s = self;
        let k = s.order;
        // the differences of y_{n+1}, as accept() will make them, into tmp[0..=k]
        // (tmp has k+1 ≤ 6 slots: ∇^{k+1} is not needed for the degree-k polynomial)
        s.tmp[k].copy_from(&s.diffs[k]);
        s.tmp[k] += &s.d;
        for j in (1..k).rev() {
            let (a, b) = s.tmp.split_at_mut(j + 1);
            a[j].copy_from(&s.diffs[j]);
            a[j] += &b[0];
        }
        s.tmp[0].copy_from(x_new);
        for v in c.iter_mut() {
            v.fill(0.0);
        }
        c[0].copy_from(x_new);
        // p_j(θ) = p_{j−1}(θ)·(θ + j − 2)/j, p_0 = 1
        let mut p = [0.0; MAX_ORDER + 1];
        p[0] = 1.0;
        for j in 1..=k {
            let shift = j as f64 - 2.0;
            let mut next = [0.0; MAX_ORDER + 1];
            for i in 0..j {
                next[i + 1] += p[i] / j as f64;
                next[i] += p[i] * shift / j as f64;
            }
            p = next;
            for (i, pi) in p.iter().enumerate().take(j + 1) {
                if *pi != 0.0 {
                    c[i].axpy(*pi, &s.tmp[j], 1.0);
                }
            }
        }
        Ok(())
    }
}

//! Automatic switching between [`Rk45`] and [`Bdf`], in the manner of LSODA
//! (Petzold 1983): start explicit, go implicit when the explicit method's step is bound
//! by stability or when BDF's estimated cost per unit time is lower, and come back when
//! DOPRI5's is.

use super::bdf::BdfStepper;
use super::rk45::Rk45Stepper;
use super::{Bdf, Method, Outcome, Rk45, Step, Stepper};
use crate::error::Result;
use crate::linalg::LuDim;
use crate::methods::step_size::Controller;
use crate::model::{Eval, System};
use crate::problem::solution::SwitchReason;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OVector};

/// A DOPRI5 step with `|h·λ|` above this is stiff for [`Auto`]: within 40 % of the real
/// boundary of DOPRI5's stability region (3.31), where `dopri5.f` uses 3.25. Why lower:
/// at a loose tolerance the stiff components' own error keeps the step below the
/// boundary (Robertson at `rtol` 0.1: `h·λ` ≈ 2.4 for 10⁵ steps, 10⁶ `f` calls where BDF
/// needs 400), which is stiffness all the same: the step is set by λ, not by the smooth
/// solution. A non-stiff problem whose accurate step comes this close to the boundary
/// costs at most a visit to BDF, which hands back after [`TO_NON_STIFF_STEPS`].
pub const STIFF_H_LAMBDA: f64 = 2.0;
/// Verdicts for BDF (stiff, or BDF estimated cheaper) before switching to it, counted
/// as `dopri5.f` counts its stiff verdicts: a run of [`STIFF_RESET`] verdicts against
/// in a row starts the count again, single ones do not.
pub const TO_STIFF_STEPS: u32 = 15;
/// Verdicts against BDF in a row that clear the count of verdicts for it (`dopri5.f`'s 6).
///
/// Why not 15 stiff verdicts in a row: at the edge of its stability region DOPRI5's
/// step oscillates (a long step, a rejection, a short one), and the short step's
/// verdict is non-stiff. Counted in a row, Van der Pol μ = 1000 at `rtol` 3e-3 and HIRES
/// at `rtol` 0.1 never switched: the first ran into the step limit at 10⁵ DOPRI5 steps,
/// the second into an instability that its loose tolerance let grow to 10¹⁰.
pub const STIFF_RESET: u32 = 6;
/// Consecutive verdicts for DOPRI5 (estimated cheaper, stability included) before
/// switching back.
pub const TO_NON_STIFF_STEPS: u32 = 15;
/// The largest `h·‖J‖∞` at which [`Auto`] counts a step as one DOPRI5 could take stably:
/// `‖J‖∞` bounds the spectral radius, DOPRI5's stability region reaches −3.3 on the real
/// axis, and a factor 2 keeps the switch from flapping at the boundary.
pub const NON_STIFF_H_NORM: f64 = 1.65;
/// BDF steps after a switch before its verdicts count: from order 1 it climbs one order
/// after `k + 1` steps at order `k`, so 2 + 3 + 4 + 5 = 14 steps to order 5, and its
/// steps before are no measure of its cost (the middle-stiff problem of
/// `examples/auto_cost.rs` at `rtol` 1e-10 went back and forth 40 times without this).
pub const BDF_SETTLE_STEPS: u32 = 14;
/// DOPRI5's cost per step in `f` evaluations (seven stages, the last reused).
pub const DOPRI5_STEP_COST: f64 = 6.0;
/// BDF's cost per step in the same unit: its `f` calls (about 2 per step: Newton's
/// iterations) and its linear algebra (the solves, the difference-array updates, an LU
/// and a Jacobian every so many steps). Measured as BDF's time per step over DOPRI5's
/// times [`DOPRI5_STEP_COST`] at `rtol` 1e-9 (`examples/auto_cost.rs`, 2026-12-06):
/// HIRES 19, OREGO 17, Van der Pol 13, Lorenz 23 — small systems with cheap `f`, where
/// BDF's linear algebra weighs most; with an expensive `f` the ratio falls toward BDF's
/// `f` calls per step, and [`Auto`] then stays with DOPRI5 longer than it need.
pub const BDF_STEP_COST: f64 = 18.0;
/// The other method must be estimated cheaper by this factor, per unit time, for a
/// verdict for it: estimates of a step that is not taken are rough, and a switch costs
/// a restart at order 1 (toward BDF) or a rejected first step (toward DOPRI5).
pub const COST_MARGIN: f64 = 2.0;
/// DOPRI5's error estimate on `y' = λy` is `(b₅ − b₄)`'s `−(97/120000)(hλ)⁵y + O(h⁶)`,
/// so `≈ 8.1·10⁻⁴·h⁵‖y⁽⁵⁾‖` on a smooth solution.
const DOPRI5_ERROR_CONSTANT: f64 = 97.0 / 120_000.0;
/// Accepted states kept for the step estimates: divided differences up to order 6,
/// enough for BDF's orders 1–5 (`y⁽ᵏ⁺¹⁾`) and DOPRI5's `y⁽⁵⁾`.
const HISTORY: usize = 7;

/// The last accepted states, newest first, and the work vectors of their divided
/// differences.
struct History<D: nalgebra::Dim>
where
    DefaultAllocator: Allocator<D>,
{
    t: Vec<f64>,
    x: Vec<OVector<f64, D>>,
    work: Vec<OVector<f64, D>>,
}

impl<D: nalgebra::Dim> History<D>
where
    DefaultAllocator: Allocator<D>,
{
    fn new() -> Self {
        History {
            t: Vec::with_capacity(HISTORY),
            x: Vec::with_capacity(HISTORY),
            work: Vec::new(),
        }
    }
    fn clear(&mut self) {
        self.t.clear();
        self.x.clear();
    }
    fn push(&mut self, t: f64, x: &OVector<f64, D>) {
        let v = if self.x.len() == HISTORY {
            self.t.pop();
            let mut v = self.x.pop().expect("full history");
            v.copy_from(x);
            v
        } else {
            x.clone()
        };
        self.t.insert(0, t);
        self.x.insert(0, v);
    }
    /// `‖y⁽ʲ⁾‖ ≈ j!·‖y[t₀, …, t_j]‖` for `j = 1 … len − 1` (index `j`; 0 where no
    /// estimate), in the weighted RMS norm of `scale` over the `m` leading components,
    /// from the divided differences of the newest `j + 1` states.
    fn derivative_norms(&mut self, scale: &OVector<f64, D>, m: usize) -> [f64; HISTORY] {
        let len = self.x.len();
        let mut out = [0.0; HISTORY];
        if len < 2 {
            return out;
        }
        if self.work.len() < len {
            self.work = self.x.clone();
        }
        for (w, x) in self.work.iter_mut().zip(&self.x) {
            w.copy_from(x);
        }
        let mut fact = 1.0;
        for (l, o) in out.iter_mut().enumerate().take(len).skip(1) {
            for i in (l..len).rev() {
                let dt = self.t[i] - self.t[i - l];
                let (a, b) = self.work.split_at_mut(i);
                b[0] -= &a[i - 1];
                b[0] /= dt;
            }
            fact *= l as f64;
            let w = &self.work[l];
            let m = m.min(w.len()).max(1);
            let s: f64 = (0..m).map(|i| (w[i] / scale[i]).powi(2)).sum();
            *o = fact * (s / m as f64).sqrt();
        }
        out
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Explicit,
    Implicit,
}

/// Auto-switching: [`Rk45`] while it is the cheaper method, [`Bdf`] while the problem
/// is stiff or BDF is cheaper.
///
/// **Step estimates** (LSODA compares the steps its two methods would take; here from
/// the solution itself). After every accepted step the last seven states give divided
/// differences, so `‖y⁽ʲ⁾‖ ≈ j!·‖y[t_n, …, t_{n−j}]‖` (weighted RMS, the tolerance scale).
/// BDF's step at order `q` is the one whose error estimate `C_q H^{q+1}‖y⁽q⁺¹⁾‖` is `1/6`
/// of the tolerance, as [`Bdf`] aims, `H = max_q (6·C_q·‖y⁽q⁺¹⁾‖)^{−1/(q+1)}`; DOPRI5's is
/// `min(0.9·(8.1·10⁻⁴‖y⁽⁵⁾‖)^{−1/5}, 3.3/‖J‖∞)` (its error estimate on a smooth solution
/// and its stability boundary, `‖J‖∞` from BDF's Newton Jacobian bounding every `|λ|`).
/// Costs per unit time are [`DOPRI5_STEP_COST`]`/h` and [`BDF_STEP_COST`]`/H`.
///
/// **To BDF.** A DOPRI5 step speaks for BDF when it is stiff (Hairer's estimate
/// `h·λ ≈ |h|·‖k₇ − k₆‖/‖x₁ − y₆‖` above [`STIFF_H_LAMBDA`]: the step is set by the edge
/// of the stability region) or when BDF's estimated cost per unit time is below
/// DOPRI5's by [`COST_MARGIN`]; [`TO_STIFF_STEPS`] such steps, not interrupted by
/// [`STIFF_RESET`] others in a row, switch to BDF, which restarts at order 1 from the
/// current state with the current step.
///
/// **Back to DOPRI5.** [`TO_NON_STIFF_STEPS`] consecutive BDF steps at which BDF's
/// estimated step is one DOPRI5 could take stably (`H·‖J‖∞` below
/// [`NON_STIFF_H_NORM`]) and DOPRI5's estimated cost per unit time is below BDF's by
/// [`COST_MARGIN`] hand back to DOPRI5 (re-evaluating `f` for its first stage).
///
/// Every switch is recorded in [`Solution::switches`](crate::Solution::switches) with
/// its time and its [`SwitchReason`] (the estimates that decided it). Dense output is
/// the active method's. Breakpoints reset both methods and keep the mode.
///
/// ```
/// use reckon::{methods::{Auto, Rk45}, studies::problems::van_der_pol, Options, Problem, SwitchReason};
/// use nalgebra::vector;
/// let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 400.0));
/// let o = Options::default().rtol(1e-6).atol(1e-6);
/// let auto = p.solve(Auto::default(), &o).unwrap();
/// let rk = p.solve(Rk45, &o.clone().max_steps(10_000_000)).unwrap();
/// assert_eq!(auto.switches[0].to, "bdf");          // stiff from the start
/// assert!(auto.switches[0].t < 1.0);
/// assert!(matches!(auto.switches[0].reason, SwitchReason::Stiff { h_lambda } if h_lambda > 2.0));
/// assert!(auto.stats.accepted * 10 < rk.stats.accepted);
/// assert!((auto.last().1 - rk.last().1).amax() < 1e-2);
/// ```
#[derive(Debug, Clone, Default)]
pub struct Auto {
    /// The non-stiff method.
    pub explicit: Rk45,
    /// The stiff method.
    pub implicit: Bdf,
}

/// [`Auto`]'s run: both methods' steppers, the mode, and the evidence for switching.
pub struct AutoStepper<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    explicit: Rk45Stepper<D>,
    implicit: BdfStepper<D>,
    /// The two methods' names (for [`Solution::switches`](crate::Solution::switches)).
    names: (&'static str, &'static str),
    mode: Mode,
    /// Verdicts for the other method (consecutive ones, toward DOPRI5).
    streak: u32,
    /// Consecutive verdicts against switching to BDF (see [`STIFF_RESET`]).
    quiet: u32,
    /// The verdict of the step just attempted (`Some`: it speaks for switching, and why).
    verdict: Option<SwitchReason>,
    switched: Option<(&'static str, SwitchReason)>,
    /// The step just accepted switched methods: its step factor is not the new method's.
    fresh: bool,
    history: History<D>,
    /// Time since the start of the run (divided differences far from `t = 0` keep
    /// their digits), the step just attempted, its end state and tolerance scale.
    tau: f64,
    h: f64,
    x_new: Option<OVector<f64, D>>,
    scale: Option<OVector<f64, D>>,
    /// BDF's tolerance-proportionality factor at these tolerances: its steps are
    /// estimated for `tol·factor`, DOPRI5's for `tol`.
    bdf_factor: f64,
    controlled: usize,
    /// `h·λ` of the DOPRI5 step just attempted.
    h_lambda: Option<f64>,
    /// Steps accepted since the last switch or reset.
    in_mode: u32,
}

impl<D: LuDim> AutoStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Whether the stiff method is the active one.
    pub fn is_implicit(&self) -> bool {
        self.mode == Mode::Implicit
    }

    /// The verdict of the step just accepted, from the history that includes it.
    fn verdict(&mut self) -> Option<SwitchReason> {
        let h = self.h.abs();
        let (Some(scale), true) = (self.scale.as_ref(), h > 0.0) else {
            return None;
        };
        match self.mode {
            Mode::Explicit => {
                if let Some(hl) = self.h_lambda.filter(|hl| *hl > STIFF_H_LAMBDA) {
                    return Some(SwitchReason::Stiff { h_lambda: hl });
                }
                // far from the stability boundary DOPRI5's step is set by accuracy, and
                // BDF's (larger error constants, order ≤ 5) is no longer: skip the estimate
                if self.h_lambda.is_none_or(|hl| hl < STIFF_H_LAMBDA / 4.0) {
                    return None;
                }
                let d = self.history.derivative_norms(scale, self.controlled);
                let hb = self.bdf_step(&d)?;
                let (from, to) = (DOPRI5_STEP_COST / h, BDF_STEP_COST / hb);
                (to * COST_MARGIN < from).then_some(SwitchReason::Cost { from, to })
            }
            Mode::Implicit => {
                if self.in_mode < BDF_SETTLE_STEPS {
                    return None;
                }
                let j = self.implicit.jacobian_norm()?;
                let d = self.history.derivative_norms(scale, self.controlled);
                // BDF's step as it will be, not as it is while it climbs from order 1
                // after a switch or a breakpoint
                let hb = self.bdf_step(&d).map_or(h, |e| e.max(h));
                // and it must be one DOPRI5 could take stably: HIRES and OREGO at 1e-9
                // went back and forth a dozen times when BDF's first, short steps counted
                if hb * j >= NON_STIFF_H_NORM {
                    return None;
                }
                let stable = 2.0 * NON_STIFF_H_NORM / j;
                let accurate = if self.history.t.len() > 5 && d[5] > 0.0 {
                    0.9 * (DOPRI5_ERROR_CONSTANT * d[5]).powf(-0.2)
                } else {
                    f64::INFINITY
                };
                let hr = stable.min(accurate);
                let (from, to) = (BDF_STEP_COST / hb, DOPRI5_STEP_COST / hr);
                (to * COST_MARGIN < from).then_some(SwitchReason::Cost { from, to })
            }
        }
    }

    /// BDF's step at the order that allows the longest, from the derivative estimates;
    /// `None` without one.
    fn bdf_step(&self, d: &[f64; HISTORY]) -> Option<f64> {
        let len = self.history.t.len();
        (1..=self.implicit.method.max_order)
            .filter(|q| q + 1 < len && d[q + 1] > 0.0 && d[q + 1].is_finite())
            .map(|q| {
                let e = super::bdf::BIAS * self.implicit.method.error_constant(q) * d[q + 1] / self.bdf_factor;
                e.powf(-1.0 / (q as f64 + 1.0))
            })
            .reduce(f64::max)
    }
}

impl<D: LuDim> Method<D> for Auto
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    type Stepper = AutoStepper<D>;
    /// In both modes: at a loose tolerance DOPRI5 too steps Robertson's and HIRES's
    /// concentrations past zero, where the field points back, and the run then
    /// underflows (`rtol` 0.1, `tests/it/fail_safe.rs`).
    fn tightens_loose_tolerances(&self) -> bool {
        true
    }
    fn crossing_test(&self) -> bool {
        true
    }
    fn name(&self) -> &'static str {
        "auto"
    }
    fn order(&self) -> u32 {
        5
    }
    /// DOPRI5's: every run starts explicit.
    fn error_order(&self) -> Option<u32> {
        Method::<D>::error_order(&self.explicit)
    }
    /// DOPRI5's PI controller; BDF chooses its own steps ([`Stepper::step_factor`]).
    fn controller(&self) -> Controller {
        Method::<D>::controller(&self.explicit)
    }
    fn stepper<S: System<D>>(self, f: &mut Eval<'_, D, S>, t0: f64, x0: &OVector<f64, D>) -> Result<AutoStepper<D>> {
        let names = (Method::<D>::name(&self.explicit), Method::<D>::name(&self.implicit));
        let explicit = self.explicit.stepper(f, t0, x0)?;
        let mut implicit = self.implicit.stepper(f, t0, x0)?;
        // BDF starts afresh at its first step (order 1 from the state it is given)
        implicit.reset();
        let mut history = History::new();
        history.push(0.0, x0);
        Ok(AutoStepper {
            explicit,
            implicit,
            names,
            mode: Mode::Explicit,
            streak: 0,
            quiet: 0,
            verdict: None,
            switched: None,
            fresh: false,
            history,
            tau: 0.0,
            h: 0.0,
            x_new: None,
            scale: None,
            bdf_factor: 1.0,
            controlled: 0,
            h_lambda: None,
            in_mode: 0,
        })
    }
}

impl<D: LuDim> Stepper<D> for AutoStepper<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn derivative_at_start(&self) -> Option<&OVector<f64, D>> {
        self.explicit.derivative_at_start()
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
        let out = match self.mode {
            Mode::Explicit => {
                let out = self.explicit.step(
                    f,
                    Step {
                        t,
                        x,
                        h,
                        x_new: &mut *x_new,
                        w,
                        adaptive,
                    },
                )?;
                self.h_lambda = self.explicit.stiffness(h, x_new);
                out
            }
            Mode::Implicit => self.implicit.step(
                f,
                Step {
                    t,
                    x,
                    h,
                    x_new: &mut *x_new,
                    w,
                    adaptive,
                },
            )?,
        };
        self.h = h;
        self.bdf_factor = self.implicit.factor(w);
        self.controlled = w.controlled;
        let (xs, sc) = (
            self.x_new.get_or_insert_with(|| x_new.clone()),
            self.scale.get_or_insert_with(|| x_new.clone()),
        );
        xs.copy_from(x_new);
        for i in 0..sc.len() {
            sc[i] = w.scale(i, x_new[i]);
        }
        Ok(out)
    }
    fn accept(&mut self) {
        match self.mode {
            Mode::Explicit => self.explicit.accept(),
            Mode::Implicit => self.implicit.accept(),
        }
        self.tau += self.h;
        self.in_mode = self.in_mode.saturating_add(1);
        if let Some(x) = self.x_new.as_ref() {
            self.history.push(self.tau, x);
        }
        self.verdict = self.verdict();
        if self.verdict.is_some() {
            self.streak += 1;
            self.quiet = 0;
        } else {
            self.quiet += 1;
            // toward BDF a run of STIFF_RESET verdicts against clears the count; toward
            // DOPRI5 a single one does (switching back too early is the risky way)
            if self.mode == Mode::Implicit || self.quiet >= STIFF_RESET {
                self.streak = 0;
            }
        }
        let (limit, to) = match self.mode {
            Mode::Explicit => (TO_STIFF_STEPS, Mode::Implicit),
            Mode::Implicit => (TO_NON_STIFF_STEPS, Mode::Explicit),
        };
        if self.streak >= limit {
            let reason = self.verdict.expect("a streak ends in a verdict for switching");
            self.streak = 0;
            self.quiet = 0;
            self.mode = to;
            self.fresh = true;
            self.in_mode = 0;
            match to {
                Mode::Implicit => {
                    self.implicit.reset();
                    self.switched = Some((self.names.1, reason));
                }
                Mode::Explicit => {
                    self.explicit.reset();
                    self.switched = Some((self.names.0, reason));
                }
            }
        }
    }
    fn switched(&mut self) -> Option<(&'static str, SwitchReason)> {
        self.switched.take()
    }
    fn reset(&mut self) {
        self.explicit.reset();
        self.implicit.reset();
        // an input jump: the states before it say nothing of the solution after
        self.history.clear();
        self.in_mode = 0;
    }
    fn dense_len(&self) -> usize {
        self.explicit.dense_len().max(self.implicit.dense_len())
    }
    fn dense<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        let n = match self.mode {
            Mode::Explicit => self.explicit.dense_len(),
            Mode::Implicit => self.implicit.dense_len(),
        };
        let (used, rest) = c.split_at_mut(n);
        for v in rest {
            v.fill(0.0);
        }
        match self.mode {
            Mode::Explicit => self.explicit.dense(f, t, h, x, x_new, used),
            Mode::Implicit => self.implicit.dense(f, t, h, x, x_new, used),
        }
    }
    fn diagnose<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        x: &OVector<f64, D>,
        h: f64,
        x_new: &OVector<f64, D>,
    ) -> crate::Error {
        match self.mode {
            Mode::Explicit => self.explicit.diagnose(f, t, x, h, x_new),
            Mode::Implicit => self.implicit.diagnose(f, t, x, h, x_new),
        }
    }
    fn step_factor(&mut self, accepted: bool, err: f64) -> Option<f64> {
        if std::mem::take(&mut self.fresh) {
            // the step was the old method's: DOPRI5's controller judges a DOPRI5 step;
            // after BDF, DOPRI5 starts from BDF's step (and rejects it if too large)
            return match self.mode {
                Mode::Implicit => None,
                Mode::Explicit => Some(1.0),
            };
        }
        match self.mode {
            Mode::Explicit => self.explicit.step_factor(accepted, err),
            Mode::Implicit => self.implicit.step_factor(accepted, err),
        }
    }
    fn stiffness(&self, h: f64, x_new: &OVector<f64, D>) -> Option<f64> {
        match self.mode {
            Mode::Explicit => self.explicit.stiffness(h, x_new),
            Mode::Implicit => None,
        }
    }
}

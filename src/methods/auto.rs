//! Automatic stiffness switching between [`Dopri5`] and [`Bdf`], in the manner of LSODA
//! (Petzold 1983) and DifferentialEquations.jl's `AutoTsit5(Rodas5P())`: start explicit,
//! go implicit when the explicit method's step is bounded by stability rather than by
//! accuracy, and come back when it no longer is.

use super::{Bdf, Dopri5, Method, Outcome};
use crate::control::{Controller, Weights};
use crate::error::Result;
use crate::linalg::LuDim;
use crate::system::{Eval, System};
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
/// Stiff verdicts (`h·λ >` [`STIFF_H_LAMBDA`], DOPRI5's test on every step) before switching to BDF,
/// counted as `dopri5.f` counts them: a run of [`STIFF_RESET`] non-stiff verdicts in a
/// row starts the count again, single ones do not.
pub const TO_STIFF_STEPS: u32 = 15;
/// Non-stiff verdicts in a row that clear the count of stiff ones (`dopri5.f`'s 6).
///
/// Why not 15 stiff verdicts in a row: at the edge of its stability region DOPRI5's
/// step oscillates (a long step, a rejection, a short one), and the short step's
/// verdict is non-stiff. Counted in a row, Van der Pol μ = 1000 at `rtol` 3e-3 and HIRES
/// at `rtol` 0.1 never switched: the first ran into the step limit at 10⁵ DOPRI5 steps,
/// the second into an instability that its loose tolerance let grow to 10¹⁰.
pub const STIFF_RESET: u32 = 6;
/// Consecutive non-stiff verdicts (`h·‖J‖∞ < NON_STIFF_H_NORM`) before switching back.
pub const TO_NON_STIFF_STEPS: u32 = 15;
/// BDF's step is one DOPRI5 could take stably when `h·‖J‖∞` is below this: `‖J‖∞`
/// bounds the spectral radius, and DOPRI5's stability region reaches −3.3 on the real
/// axis; a factor 2 keeps the switch from flapping at the boundary.
pub const NON_STIFF_H_NORM: f64 = 1.65;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Explicit,
    Implicit,
}

/// Auto-switching: [`Dopri5`] while the problem is non-stiff, [`Bdf`] while it is stiff.
///
/// **To BDF.** After every accepted DOPRI5 step, Hairer's estimate
/// `h·λ ≈ |h|·‖k₇ − k₆‖/‖x₁ − y₆‖` is taken; [`TO_STIFF_STEPS`] values above
/// [`STIFF_H_LAMBDA`] (the step is set by the edge of DOPRI5's stability region), not interrupted by
/// [`STIFF_RESET`] values below it in a row, switch to BDF,
/// which restarts at order 1 from the current state with the current step.
///
/// **Back to DOPRI5.** After every accepted BDF step, `h·‖J‖∞` with BDF's Newton
/// Jacobian bounds `|h·λ|` for every eigenvalue; [`TO_NON_STIFF_STEPS`] consecutive values
/// below [`NON_STIFF_H_NORM`] mean DOPRI5 could take BDF's step stably, and it takes over
/// (re-evaluating `f` for its first stage).
///
/// Every switch is recorded in [`Solution::switches`](crate::Solution::switches) with
/// its time. Dense output is the active method's. Breakpoints reset both methods and
/// keep the mode.
///
/// ```
/// use reckon::{methods::{Auto, Dopri5}, problems::van_der_pol, Options, Problem};
/// use nalgebra::vector;
/// let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 400.0));
/// let o = Options::default().rtol(1e-6).atol(1e-6);
/// let auto = p.solve(Auto::default(), &o).unwrap();
/// let rk = p.solve(Dopri5::default(), &o.clone().max_steps(10_000_000)).unwrap();
/// assert_eq!(auto.switches[0].to, "bdf");          // stiff from the start
/// assert!(auto.switches[0].t < 1.0);
/// assert!(auto.stats.accepted * 10 < rk.stats.accepted);
/// assert!((auto.last().1 - rk.last().1).amax() < 1e-2);
/// ```
pub struct Auto<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// The non-stiff method.
    pub explicit: Dopri5<D>,
    /// The stiff method.
    pub implicit: Bdf<D>,
    mode: Mode,
    /// Verdicts for the other method (consecutive ones, toward DOPRI5).
    streak: u32,
    /// Consecutive verdicts against switching to BDF (see [`STIFF_RESET`]).
    quiet: u32,
    /// The verdict of the step just attempted (`true`: it speaks for switching).
    verdict: bool,
    switched: Option<&'static str>,
    /// The step just accepted switched methods: its step factor is not the new method's.
    fresh: bool,
}

impl<D: LuDim> Default for Auto<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn default() -> Self {
        Auto {
            explicit: Dopri5::default(),
            implicit: Bdf::default(),
            mode: Mode::Explicit,
            streak: 0,
            quiet: 0,
            verdict: false,
            switched: None,
            fresh: false,
        }
    }
}

impl<D: LuDim> Auto<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Whether the stiff method is the active one.
    pub fn is_implicit(&self) -> bool {
        self.mode == Mode::Implicit
    }
}

impl<D: LuDim> Method<D> for Auto<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    fn crossing_test(&self) -> bool {
        self.mode == Mode::Implicit
    }
    fn name(&self) -> &'static str {
        "auto"
    }
    fn order(&self) -> u32 {
        5
    }
    fn error_order(&self) -> Option<u32> {
        match self.mode {
            Mode::Explicit => self.explicit.error_order(),
            Mode::Implicit => self.implicit.error_order(),
        }
    }
    /// DOPRI5's PI controller; BDF chooses its own steps ([`Method::step_factor`]).
    fn controller(&self) -> Controller {
        self.explicit.controller()
    }
    fn init<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, t0: f64, x0: &OVector<f64, D>) -> Result<()> {
        self.explicit.init(f, t0, x0)?;
        self.implicit.init(f, t0, x0)?;
        // BDF starts afresh at its first step (order 1 from the state it is given)
        self.implicit.reset();
        self.mode = Mode::Explicit;
        self.streak = 0;
        self.quiet = 0;
        Ok(())
    }
    fn derivative_at_start(&self) -> Option<&OVector<f64, D>> {
        self.explicit.derivative_at_start()
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
        match self.mode {
            Mode::Explicit => {
                let out = self.explicit.step(f, t, x, h, x_new, w, adaptive)?;
                self.verdict = self.explicit.stiffness(h, x_new).is_some_and(|hl| hl > STIFF_H_LAMBDA);
                Ok(out)
            }
            Mode::Implicit => {
                let out = self.implicit.step(f, t, x, h, x_new, w, adaptive)?;
                self.verdict = self
                    .implicit
                    .jacobian_norm()
                    .is_some_and(|j| h.abs() * j < NON_STIFF_H_NORM);
                Ok(out)
            }
        }
    }
    fn accept(&mut self) {
        match self.mode {
            Mode::Explicit => self.explicit.accept(),
            Mode::Implicit => self.implicit.accept(),
        }
        if self.verdict {
            self.streak += 1;
            self.quiet = 0;
        } else {
            self.quiet += 1;
            // toward BDF a run of STIFF_RESET non-stiff verdicts clears the count; toward
            // DOPRI5 a single stiff one does (switching back too early is the risky way)
            if self.mode == Mode::Implicit || self.quiet >= STIFF_RESET {
                self.streak = 0;
            }
        }
        let (limit, to) = match self.mode {
            Mode::Explicit => (TO_STIFF_STEPS, Mode::Implicit),
            Mode::Implicit => (TO_NON_STIFF_STEPS, Mode::Explicit),
        };
        if self.streak >= limit {
            self.streak = 0;
            self.quiet = 0;
            self.mode = to;
            self.fresh = true;
            match to {
                Mode::Implicit => {
                    self.implicit.reset();
                    self.switched = Some(self.implicit.name());
                }
                Mode::Explicit => {
                    self.explicit.reset();
                    self.switched = Some(self.explicit.name());
                }
            }
        }
    }
    fn switched(&mut self) -> Option<&'static str> {
        self.switched.take()
    }
    fn reset(&mut self) {
        self.explicit.reset();
        self.implicit.reset();
    }
    fn dense_len(&self) -> usize {
        Method::<D>::dense_len(&self.explicit).max(Method::<D>::dense_len(&self.implicit))
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
            Mode::Explicit => Method::<D>::dense_len(&self.explicit),
            Mode::Implicit => Method::<D>::dense_len(&self.implicit),
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

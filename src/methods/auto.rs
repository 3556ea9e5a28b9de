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

/// Consecutive stiff verdicts (`h·λ > 3.25`, DOPRI5's test on every step) before
/// switching to BDF.
pub const TO_STIFF_STEPS: u32 = 15;
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
/// `h·λ ≈ |h|·‖k₇ − k₆‖/‖x₁ − y₆‖` is taken; [`TO_STIFF_STEPS`] consecutive values above
/// 3.25 (the step is pinned to the edge of DOPRI5's stability region) switch to BDF,
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
    /// Consecutive verdicts for the other method.
    streak: u32,
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
                self.verdict = self.explicit.stiffness(h, x_new).is_some_and(|hl| hl > 3.25);
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
        self.streak = if self.verdict { self.streak + 1 } else { 0 };
        let (limit, to) = match self.mode {
            Mode::Explicit => (TO_STIFF_STEPS, Mode::Implicit),
            Mode::Implicit => (TO_NON_STIFF_STEPS, Mode::Explicit),
        };
        if self.streak >= limit {
            self.streak = 0;
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

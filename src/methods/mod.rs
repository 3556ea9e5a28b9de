//! One file per method. A method value is configuration ([`Method`]: its name, orders
//! and settings); the [`Integrator`](crate::Integrator) asks it once for a [`Stepper`],
//! the work space of one run, and then drives every stepper through [`Stepper::step`]
//! with one [`Step`] at a time, never asking which method it holds. A stepper takes one
//! step from `(t, x)` with step `h`; it never loops over time.
//!
//! Shared by the methods: the error norm and step-size controller ([`step_size`]),
//! Newton's iteration ([`newton`]) and its matrix `I − c·J`, and the Hermite dense
//! output of the methods without one of their own.

use crate::error::Result;
use crate::methods::step_size::{Controller, Weights};
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

pub mod auto;
pub mod bdf;
pub mod cf4;
pub(crate) mod consistent;
mod dense;
pub mod euler;
pub mod exact;
pub mod exponential_euler;
pub mod implicit_euler;
pub(crate) mod iteration;
pub mod lie_euler;
pub(crate) mod newton;
pub mod rk45;
pub mod rkmk4;
pub mod rodas5p;
#[doc(hidden)]
pub mod step_size;

pub use auto::Auto;
pub use bdf::Bdf;
pub use cf4::Cf4;
pub use euler::Euler;
pub use exact::Exact;
pub use exponential_euler::ExponentialEuler;
pub use implicit_euler::{ImplicitEuler, NewtonOptions};
pub use lie_euler::LieEuler;
pub use rk45::Rk45;
pub use rkmk4::Rkmk4;
pub use rodas5p::Rodas5P;

/// What one step attempt produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outcome {
    /// `x_new` holds the step result; `err` is the weighted RMS error estimate
    /// (0 when the method has none or adaptivity is off).
    Done {
        /// Error estimate, accept when `err ≤ 1`.
        err: f64,
    },
    /// The implicit equation could not be solved with this `h`; retry with a smaller step.
    Retry(Failure),
}

/// Why an implicit step must be retried.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Failure {
    /// Newton did not converge even with a fresh Jacobian.
    Newton {
        /// Iterations in the failed attempt.
        iterations: usize,
        /// Scaled norm of the last correction.
        residual: f64,
    },
    /// `I − h·J` was singular with a fresh Jacobian.
    Singular,
    /// `f` was NaN or ±∞ at a Newton iterate: the step is retried smaller, and if it
    /// shrinks to nothing this is reported as [`Error::NonFinite`](crate::Error::NonFinite)
    /// at `t` (where `f` broke), not as a step-size underflow.
    NonFinite {
        /// Time of the evaluation.
        t: f64,
        /// The first non-finite component of `f`.
        component: usize,
    },
}

/// One step attempt: from `(t, x)` with step `h` into `x_new`; with `adaptive`, the
/// error estimate in the norm of `w` (Hairer's notation, as in every method file).
pub struct Step<'s, D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Time at the start of the step.
    pub t: f64,
    /// State at `t`.
    pub x: &'s OVector<f64, D>,
    /// Step size (negative when integrating backward).
    pub h: f64,
    /// Receives the state at `t + h`.
    pub x_new: &'s mut OVector<f64, D>,
    /// Tolerances: the norm of the error estimate.
    pub w: &'s Weights<D>,
    /// Whether to estimate the error (off on fixed steps).
    pub adaptive: bool,
}

/// A method as configuration: what it is (name, orders, the controller that suits it)
/// and how to build its [`Stepper`] for a state like `x0`. A method value holds only
/// settings; the work space lives in the stepper it builds (OrdinaryDiffEq's algorithm
/// and cache), so no step can run before its work space exists.
///
/// ```
/// use reckon::methods::{Method, Rk45};
/// use nalgebra::U2;
/// let m = Rk45;
/// assert_eq!(<Rk45 as Method<U2>>::name(&m), "rk45");
/// assert_eq!((<Rk45 as Method<U2>>::order(&m), <Rk45 as Method<U2>>::error_order(&m)), (5, Some(4)));
/// ```
pub trait Method<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// The work space and carried state of a run.
    type Stepper: Stepper<D>;
    /// Name used in tables and errors (the command's name for the method).
    fn name(&self) -> &'static str;
    /// Classical order `p` (global error `O(hᵖ)`); `u32::MAX` for an exact flow.
    fn order(&self) -> u32;
    /// Order `q` of the embedded error estimate, `None` when there is none.
    fn error_order(&self) -> Option<u32>;
    /// How many times the tolerance-scaled norm this method's `err` reads (≥ 1): a method
    /// that holds its local error tighter than the tolerance (implicit Euler's tolerance
    /// proportionality) says so, and the first step is sized for it, `h₀·scale^(−1/(q+1))`.
    fn error_scale(&self, _w: &Weights<D>) -> f64 {
        1.0
    }
    /// The step-size controller that suits the estimate.
    fn controller(&self) -> Controller {
        Controller::new(self.error_order().unwrap_or(1), 0.0)
    }
    /// Whether [`Stepper::step`] never returns [`Outcome::Retry`] (explicit
    /// formulas and exact flows), so that a fixed-step run needs no retry logic.
    fn never_retries(&self) -> bool {
        false
    }
    /// Whether the driver's crossing test applies to this method's adaptive steps (a
    /// component stepped past zero where `f` points back is retried shorter; see
    /// [`Integrator`](crate::Integrator)). On for the implicit methods, whose long steps
    /// at a loose tolerance can carry a decaying component past zero, and for
    /// [`Auto`](super::Auto) in both modes (its DOPRI5 steps do the same at `rtol` 0.1
    /// before it switches); off for the plain explicit methods, where the one or two
    /// `f` calls per crossing would cost 8 % on an orbit (Arenstorf at 1e-4) and a
    /// stiff problem holds the step at the stability limit anyway.
    fn crossing_test(&self) -> bool {
        false
    }
    /// Whether the driver holds this method to [`Weights::tighten_loose`]'s tolerances
    /// (`rtol` above 1e-3 tightened to `0.1·rtol^{2/3}`): on for the implicit methods,
    /// whose large steps at a loose tolerance otherwise shift a limit cycle's phase by a
    /// spike (OREGO at `rtol` 0.1–3e-2, `examples/tolerance_sweep.rs`).
    fn tightens_loose_tolerances(&self) -> bool {
        false
    }
    /// Whether the method solves `M·x' = f(t, x)` with a mass matrix
    /// ([`Problem::mass`](crate::Problem::mass)): on for `Bdf` and `Rodas5P`.
    fn takes_mass(&self) -> bool {
        false
    }
    /// For a method that [takes a mass matrix](Self::takes_mass): the initial state made
    /// consistent with a singular `M` (`None`: `x0` is consistent as given).
    fn consistent_start<S: System<D>>(
        &self,
        _f: &mut Eval<'_, D, S>,
        _t0: f64,
        _x0: &OVector<f64, D>,
        _w: &Weights<D>,
    ) -> Result<Option<OVector<f64, D>>> {
        Ok(None)
    }
    /// The stepper for a run from `(t0, x0)`: work space for `x0`'s dimension, and what
    /// the first step needs evaluated (e.g. `f(t0, x0)` for FSAL).
    fn stepper<S: System<D>>(self, f: &mut Eval<'_, D, S>, t0: f64, x0: &OVector<f64, D>) -> Result<Self::Stepper>;
}

/// A method's run: its work space and what it carries from step to step. It takes one
/// step from `(t, x)` with step `h`; it never loops over time. The
/// [`Integrator`](crate::Integrator) drives every stepper through this trait and never
/// asks which one it holds.
pub trait Stepper<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// `f(t0, x0)` if building the stepper (or the last step, FSAL) already has it.
    fn derivative_at_start(&self) -> Option<&OVector<f64, D>> {
        None
    }
    /// Attempt one step ([`Step`]) into `s.x_new`.
    fn step<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, s: Step<'_, D>) -> Result<Outcome>;
    /// The step from `x` to `x_new` was accepted (e.g. keep `k7` as the next `k1`).
    fn accept(&mut self) {}
    /// The inputs jumped at a breakpoint: drop anything carried over from the last step.
    fn reset(&mut self) {}
    /// The driver keeps this run's dense output (events, output times,
    /// [`Options::dense`](crate::Options::dense)); called once, before the first step. A
    /// method whose step error says nothing about its interpolant (an exact flow or an
    /// exponential step, long across a fast transient or a turn) adds the interpolant's
    /// error to its estimate from then on, so that values between the steps are as good
    /// as the steps' ends.
    fn dense_needed(&mut self) {}
    /// Number of coefficients of the dense polynomial `x(t + θh) = Σ_j c_j θʲ`.
    fn dense_len(&self) -> usize {
        2
    }
    /// Fill `c` with the dense-output coefficients of the step just taken
    /// (before [`accept`](Stepper::accept)). The default is linear interpolation.
    fn dense<S: System<D>>(
        &mut self,
        _f: &mut Eval<'_, D, S>,
        _t: f64,
        _h: f64,
        x: &OVector<f64, D>,
        x_new: &OVector<f64, D>,
        c: &mut [OVector<f64, D>],
    ) -> Result<()> {
        c[0].copy_from(x);
        c[1].copy_from(x_new);
        c[1] -= x;
        Ok(())
    }
    /// The step from `(t, x)` with `h` produced a non-finite error estimate or `x_new`:
    /// say where. The default re-evaluates `f(t, x)` (a non-finite derivative there) and
    /// otherwise blames the state at `t + h`.
    fn diagnose<S: System<D>>(
        &mut self,
        f: &mut Eval<'_, D, S>,
        t: f64,
        x: &OVector<f64, D>,
        h: f64,
        x_new: &OVector<f64, D>,
    ) -> crate::Error {
        let mut k = x.clone();
        if let Err(e) = f.rhs(t, x, &mut k) {
            return e;
        }
        state_error(x_new, t + h)
    }
    /// A stepper that picks its own next step (variable order: BDF compares the error
    /// estimates of neighbouring orders) returns the factor for the next `|h|` after an
    /// accepted step (`accepted`, called after [`accept`](Stepper::accept)) or a rejected
    /// one with estimate `err`; `None` leaves it to the driver's
    /// [`controller`](Method::controller).
    fn step_factor(&mut self, _accepted: bool, _err: f64) -> Option<f64> {
        None
    }
    /// After [`accept`](Stepper::accept): the name of the method an auto-switching method
    /// ([`Auto`]) has just switched to, once; the driver records it in
    /// [`Solution::switches`](crate::Solution::switches).
    fn switched(&mut self) -> Option<(&'static str, crate::problem::solution::SwitchReason)> {
        None
    }
    /// Estimate `|h·λ|` of the dominant eigenvalue for the step just taken
    /// (before `accept`), for stiffness detection; `None` if the method has none.
    fn stiffness(&self, _h: f64, _x_new: &OVector<f64, D>) -> Option<f64> {
        None
    }
}

/// The error for a non-finite step result `x_new` at `t`: its first non-finite component,
/// or component 0 when every component is finite (the estimate was the non-finite one).
pub(crate) fn state_error<D: Dim>(x_new: &OVector<f64, D>, t: f64) -> crate::Error
where
    DefaultAllocator: Allocator<D>,
{
    match crate::model::finite(x_new.as_slice(), t, crate::error::Quantity::State) {
        Err(e) => e,
        Ok(()) => crate::Error::NonFinite {
            t,
            quantity: crate::error::Quantity::State,
            component: 0,
        },
    }
}

//! One error type for the whole crate.
//!
//! Every variant says *where* (time, step size) and *why*, so a caller can react
//! without parsing a message: `NonFinite { t, .. }` at the time the non-finite
//! value appeared, `NewtonDiverged { t, h, .. }`, `StepSizeUnderflow { t, h }`,
//! `MaxSteps { t, steps }`, `InvalidInput { what, reason }`.

/// What kind of quantity turned non-finite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The state `x` (an initial value or a step result).
    State,
    /// The derivative `f(t, x)` returned by the model.
    Derivative,
    /// The Jacobian `∂f/∂x`.
    Jacobian,
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Quantity::State => "state",
            Quantity::Derivative => "derivative",
            Quantity::Jacobian => "Jacobian",
        })
    }
}

/// Everything that can go wrong while setting up or running an integration.
///
/// ```
/// use reckon::{Error, Options};
/// let err = Options::default().rtol(-1.0).validate().unwrap_err();
/// assert!(matches!(err, Error::InvalidInput { what: "rtol", .. }));
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The model returned (or a step produced) NaN or ±∞.
    #[error("non-finite {quantity} (component {component}) at t = {}", Brief(*.t))]
    NonFinite {
        /// Time at which the value was evaluated.
        t: f64,
        /// Which quantity.
        quantity: Quantity,
        /// First offending component (row-major index for the Jacobian).
        component: usize,
    },
    /// Newton's iteration for an implicit step did not converge, even with a fresh
    /// Jacobian and after shrinking the step.
    #[error(
        "Newton iteration diverged at t = {} with h = {} after {iterations} iterations (scaled residual {residual:e})",
        Brief(*.t),
        Brief(*.h)
    )]
    NewtonDiverged {
        /// Start of the failed step.
        t: f64,
        /// Last step size tried.
        h: f64,
        /// Newton iterations in the last attempt.
        iterations: usize,
        /// Scaled norm of the last Newton correction.
        residual: f64,
    },
    /// The iteration matrix `I − h·J` could not be factorised.
    #[error("singular iteration matrix I - h*J at t = {} with h = {}", Brief(*.t), Brief(*.h))]
    SingularMatrix {
        /// Start of the step.
        t: f64,
        /// Step size.
        h: f64,
    },
    /// The step size fell below what floating point can resolve at `t`.
    #[error("step size underflow at t = {}: h = {:e}", Brief(*.t), .h)]
    StepSizeUnderflow {
        /// Time reached.
        t: f64,
        /// Step size that was too small.
        h: f64,
    },
    /// The step limit (`Options::max_steps`, counted between two stops) was reached.
    #[error("step limit of {steps} steps between two stops reached at t = {}", Brief(*.t))]
    MaxSteps {
        /// Time reached.
        t: f64,
        /// Steps taken (accepted and rejected).
        steps: usize,
    },
    /// A model could not be traced into expressions ([`crate::symbolic`]): its body asks
    /// a traced value something only a number can answer (its control flow depends on
    /// the state), or it is not a [`model!`](crate::model) at all. Its Jacobian still
    /// comes from num-dual; only the symbolic forms are unavailable.
    #[error("model `{model}` cannot be traced: {reason}")]
    Untraceable {
        /// The model (the function that defined it, or the name it was given).
        model: String,
        /// What the body did that a trace cannot follow.
        reason: String,
    },
    /// [`Solution::at`](crate::Solution::at) was asked for a state between the kept
    /// points of a run that kept no dense output: the polynomials are kept only when
    /// [`Options::dense`](crate::Options::dense) is on (it is off by default).
    #[error(
        "no dense output was kept, so the state at t = {} cannot be interpolated: set Options::dense(true) before solving",
        Brief(*.t)
    )]
    NoDenseOutput {
        /// The time asked for.
        t: f64,
    },
    /// An option, a span, a dimension or another input was invalid.
    #[error("invalid {what}: {reason}")]
    InvalidInput {
        /// Which input.
        what: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// Euler angles were asked of an attitude at pitch ±90°, where roll and yaw are not
    /// separable (gimbal lock).
    #[error("Euler angles are singular at t = {}: pitch = {} rad (±90°)", Brief(*.t), Brief(*.pitch))]
    PitchSingularity {
        /// Time of the attitude.
        t: f64,
        /// The pitch angle.
        pitch: f64,
    },
    /// A covariance that must be inverted (the Kalman innovation covariance `S`) is
    /// not positive definite.
    #[error("{what} is not positive definite (not invertible)")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
    },
    /// An iteration with a cap (the eigenvalue QR of a Jacobian) stopped without
    /// converging.
    #[error("the {what} iteration did not converge (Jacobian at t = {})", Brief(*.t))]
    NoConvergence {
        /// Which iteration.
        what: &'static str,
        /// Time of the matrix it worked on.
        t: f64,
    },
    /// A calibration's data cannot determine a parameter (for example only straight
    /// driving, which says nothing about the wheel base): no number is returned rather
    /// than an arbitrary one.
    #[error("{parameter} cannot be determined from the data: {reason}")]
    Unidentifiable {
        /// Which parameter (or group of parameters).
        parameter: String,
        /// Why the data do not determine it.
        reason: String,
    },
    /// The sensitivities `S = ∂x/∂(x₀, p)` are not resolved by the steps: outside the
    /// error control (the default, [`SensitivityOptions::error_control`](crate::sensitivity::SensitivityOptions::error_control)
    /// off) their local error estimate on an accepted step exceeded
    /// [`sensitivity::UNRESOLVED`](crate::sensitivity::UNRESOLVED) of their size, so the
    /// returned `S` would be wrong, by orders of magnitude on long spans (for example when
    /// `x` sits still on an unstable equilibrium while `S` grows).
    #[error(
        "the sensitivities are not resolved by the steps chosen for x: at t = {} with h = {} their local error estimate is {ratio:.3e} of their size (at most 0.1); solve with SensitivityOptions::error_control(true)",
        Brief(*.t),
        Brief(*.h)
    )]
    SensitivityUnresolved {
        /// Start of the step.
        t: f64,
        /// Its size.
        h: f64,
        /// The local error estimate of `S` relative to its size.
        ratio: f64,
    },
    /// A least-squares fit did not converge.
    #[error("the {what} fit did not converge: {reason}")]
    FitFailed {
        /// Which fit.
        what: &'static str,
        /// What the optimiser reported.
        reason: String,
    },
    /// A member of an ensemble failed (the lowest-numbered one that did).
    #[error("ensemble member {index} (seed {seed}): {reason}")]
    EnsembleMember {
        /// The member's index in the whole ensemble.
        index: u64,
        /// Its seed ([`member_seed`](crate::ensemble::member_seed)).
        seed: u64,
        /// What went wrong.
        reason: Box<Error>,
    },
    /// An event function returned NaN, so whether it changed sign is unknown (a pole,
    /// where it jumps through ±∞, is a sign change; NaN is not).
    #[error("event function {index} is NaN at t = {}", Brief(*.t))]
    EventNaN {
        /// Index of the event function.
        index: usize,
        /// Time at which it was evaluated.
        t: f64,
    },
    /// An event's reset map returned a state of the wrong length or with a NaN or ±∞
    /// component, or held inputs that are not finite.
    #[error("the reset of event {index} at t = {}: {reason}", Brief(*.t))]
    EventReset {
        /// Index of the event.
        index: usize,
        /// Time of the occurrence.
        t: f64,
        /// What was wrong with what it returned.
        reason: String,
    },
    /// Resetting events accumulate: `count` occurrences within `window` of time (a
    /// Zeno execution, such as a ball bouncing with restitution below 1 whose bounces
    /// accumulate at a finite time), or the steps between them shrank below what `t`
    /// resolves. Set the limit with [`Options::zeno`](crate::Options::zeno); stop the
    /// model yourself (a terminal event on a small velocity) to go past that time.
    #[error("Zeno behaviour: {count} resetting events within {} of time up to t = {}; stop or change the model there (Options::zeno sets the limit)", Brief(*.window), Brief(*.t))]
    Zeno {
        /// Time of the last occurrence.
        t: f64,
        /// Occurrences counted.
        count: usize,
        /// The time they fell within.
        window: f64,
    },
    /// A DAE's initial state could not be made consistent: Newton on the algebraic
    /// equations (with the differential components held) failed, or their Jacobian is
    /// singular (the problem is not of index 1 there).
    #[error("inconsistent initial values at t = {}: {reason}", Brief(*.t))]
    Inconsistent {
        /// The initial time.
        t: f64,
        /// Why no consistent state was found.
        reason: String,
    },
    /// The root finder could not locate an event inside a step.
    #[error("event {index} could not be located between t = {} and t = {}: {reason}", Brief(*.t0), Brief(*.t1))]
    EventLocation {
        /// Index of the event function.
        index: usize,
        /// Step start.
        t0: f64,
        /// Step end.
        t1: f64,
        /// The root finder's message.
        reason: String,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidInput`].
    pub fn invalid(what: &'static str, reason: impl Into<String>) -> Self {
        Error::InvalidInput {
            what,
            reason: reason.into(),
        }
    }
}

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// A number as messages print it: the shortest text that reads back to the same value,
/// switching to scientific notation when that is shorter (`1e308`, not 309 digits).
///
/// ```
/// use reckon::error::Brief;
/// assert_eq!(Brief(1e308).to_string(), "1e308");
/// assert_eq!(Brief(0.25).to_string(), "0.25");
/// assert_eq!(Brief(1.7e12).to_string(), "1.7e12");
/// assert_eq!(Brief(1700000000.25).to_string(), "1700000000.25");
/// assert_eq!(Brief(1e-300).to_string(), "1e-300");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Brief(pub f64);

impl std::fmt::Display for Brief {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let plain = format!("{}", self.0);
        let sci = format!("{:e}", self.0);
        f.write_str(if plain.len() <= sci.len() + 4 { &plain } else { &sci })
    }
}

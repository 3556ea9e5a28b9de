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
    #[error("non-finite {quantity} (component {component}) at t = {t}")]
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
        "Newton iteration diverged at t = {t} with h = {h} after {iterations} iterations (scaled residual {residual:e})"
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
    #[error("singular iteration matrix I - h*J at t = {t} with h = {h}")]
    SingularMatrix {
        /// Start of the step.
        t: f64,
        /// Step size.
        h: f64,
    },
    /// The step size fell below what floating point can resolve at `t`.
    #[error("step size underflow at t = {t}: h = {h:e}")]
    StepSizeUnderflow {
        /// Time reached.
        t: f64,
        /// Step size that was too small.
        h: f64,
    },
    /// The step limit (`Options::max_steps`) was reached before `t_end`.
    #[error("step limit of {steps} steps reached at t = {t}")]
    MaxSteps {
        /// Time reached.
        t: f64,
        /// Steps taken (accepted and rejected).
        steps: usize,
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
    #[error("Euler angles are singular at t = {t}: pitch = {pitch} rad (±90°)")]
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
    /// The root finder could not locate an event inside a step.
    #[error("event {index} could not be located between t = {t0} and t = {t1}: {reason}")]
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

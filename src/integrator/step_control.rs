//! The driver's step-size part: the tolerances (the error norm), the step size and the
//! controller that proposes the next one, and what the run counts against its limits
//! (attempts, failures in a row, why the last attempt failed).

use crate::error::{Error, Result};
use crate::methods::Failure;
use crate::methods::step_size::{Controller, Weights};
use crate::problem::options::Options;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// `rtol` and `atol` expanded to the state's components, checked, with the first
/// `error_components` controlled; held to [`Weights::tighten_loose`] when the method asks.
pub(super) fn weights<D: Dim>(opts: &Options, x0: &OVector<f64, D>, tighten: bool) -> Result<Weights<D>>
where
    DefaultAllocator: Allocator<D>,
{
    let (r, _) = x0.shape_generic();
    let mut w = Weights::new(
        opts.rtol.expand("rtol", r)?,
        opts.atol.expand("atol", r)?,
        match opts.error_components {
            None => x0.len(),
            Some(m) if (1..=x0.len()).contains(&m) => m,
            Some(m) => {
                return Err(Error::invalid(
                    "error_components",
                    format!("{m} for a state of {} components (1 to {} allowed)", x0.len(), x0.len()),
                ));
            }
        },
    );
    if (0..x0.len()).any(|i| w.rtol[i] == 0.0 && w.atol[i] == 0.0) {
        return Err(Error::invalid("atol", "rtol and atol are both zero for a component"));
    }
    if tighten {
        w.tighten_loose();
    }
    Ok(w)
}

/// Step size and its control.
pub(super) struct StepControl<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// The error norm.
    pub(super) w: Weights<D>,
    /// Whether the steps are error-controlled (else a fixed step).
    pub(super) adaptive: bool,
    /// The step to try next (adaptive runs).
    pub(super) h: f64,
    pub(super) controller: Controller,
    pub(super) last_rejected: bool,
    /// Step attempts so far, against `max_steps`.
    pub(super) attempts: usize,
    pub(super) max_steps: usize,
    pub(super) h_max: f64,
    /// Failed attempts in a row allowed before the run gives up.
    pub(super) max_failures: usize,
    /// Why the last implicit attempt failed (current while the step's failure count is
    /// non-zero).
    pub(super) last_failure: Option<Failure>,
    /// Why the last trial step since the last accepted one was rejected as non-finite
    /// (adaptive runs): the error reported if `h` then shrinks to nothing.
    pub(super) non_finite_trial: Option<Error>,
    /// Work space of the crossing test (`Integrator::crossing_factor`): the crossing
    /// state and `f` there, made at its first use.
    pub(super) probe: Option<(OVector<f64, D>, OVector<f64, D>)>,
    /// The largest error estimate of the components outside the error control an
    /// accepted step may have (`Integrator::watch_uncontrolled`).
    pub(super) watch: Option<f64>,
}

impl<D: Dim> StepControl<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// At the start of a run: the first step `h` (NaN on fixed steps).
    pub(super) fn new(w: Weights<D>, controller: Controller, adaptive: bool, h: f64, opts: &Options) -> Self {
        StepControl {
            w,
            adaptive,
            h,
            controller,
            last_rejected: false,
            attempts: 0,
            max_steps: opts.max_steps,
            h_max: opts.h_max,
            max_failures: opts.max_step_failures,
            last_failure: None,
            non_finite_trial: None,
            probe: None,
            watch: None,
        }
    }
}

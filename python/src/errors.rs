//! `reckon::Error` → the Python exception of the same name (`reckon/_errors.py`), the
//! variant's fields as attributes.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use reckon::Error;

/// The exception instance for `e`: `reckon.<Variant>(message, **fields)`.
pub(crate) fn to_py(py: Python<'_>, e: &Error) -> PyErr {
    build(py, e).unwrap_or_else(|err| err)
}

fn build(py: Python<'_>, e: &Error) -> PyResult<PyErr> {
    let kw = PyDict::new(py);
    let name = match e {
        Error::NonFinite { t, quantity, component } => {
            kw.set_item("t", t)?;
            kw.set_item("quantity", quantity.to_string())?;
            kw.set_item("component", component)?;
            "NonFinite"
        }
        Error::NewtonDiverged {
            t,
            h,
            iterations,
            residual,
        } => {
            kw.set_item("t", t)?;
            kw.set_item("h", h)?;
            kw.set_item("iterations", iterations)?;
            kw.set_item("residual", residual)?;
            "NewtonDiverged"
        }
        Error::SingularMatrix { t, h } => {
            kw.set_item("t", t)?;
            kw.set_item("h", h)?;
            "SingularMatrix"
        }
        Error::StepSizeUnderflow { t, h } => {
            kw.set_item("t", t)?;
            kw.set_item("h", h)?;
            "StepSizeUnderflow"
        }
        Error::MaxSteps { t, steps } => {
            kw.set_item("t", t)?;
            kw.set_item("steps", steps)?;
            "MaxSteps"
        }
        Error::Untraceable { model, reason } => {
            kw.set_item("model", model)?;
            kw.set_item("reason", reason)?;
            "Untraceable"
        }
        Error::NoDenseOutput { t } => {
            kw.set_item("t", t)?;
            "NoDenseOutput"
        }
        Error::InvalidInput { what, reason } => {
            kw.set_item("what", what)?;
            kw.set_item("reason", reason)?;
            "InvalidInput"
        }
        Error::PitchSingularity { t, pitch } => {
            kw.set_item("t", t)?;
            kw.set_item("pitch", pitch)?;
            "PitchSingularity"
        }
        Error::NotPositiveDefinite { what } => {
            kw.set_item("what", what)?;
            "NotPositiveDefinite"
        }
        Error::NoConvergence { what, t } => {
            kw.set_item("what", what)?;
            kw.set_item("t", t)?;
            "NoConvergence"
        }
        Error::Unidentifiable { parameter, reason } => {
            kw.set_item("parameter", parameter)?;
            kw.set_item("reason", reason)?;
            "Unidentifiable"
        }
        Error::SensitivityUnresolved { t, h, ratio } => {
            kw.set_item("t", t)?;
            kw.set_item("h", h)?;
            kw.set_item("ratio", ratio)?;
            "SensitivityUnresolved"
        }
        Error::FitFailed { what, reason } => {
            kw.set_item("what", what)?;
            kw.set_item("reason", reason)?;
            "FitFailed"
        }
        Error::EnsembleMember { index, seed, reason } => {
            kw.set_item("index", index)?;
            kw.set_item("seed", seed)?;
            kw.set_item("reason", to_py(py, reason).into_value(py))?;
            "EnsembleMember"
        }
        Error::EventNaN { index, t } => {
            kw.set_item("index", index)?;
            kw.set_item("t", t)?;
            "EventNaN"
        }
        Error::EventLocation { index, t0, t1, reason } => {
            kw.set_item("index", index)?;
            kw.set_item("t0", t0)?;
            kw.set_item("t1", t1)?;
            kw.set_item("reason", reason)?;
            "EventLocation"
        }
        // a variant newer than these bindings: the base class, with the message
        _ => "Error",
    };
    make(py, name, e.to_string(), &kw)
}

fn make(py: Python<'_>, name: &str, message: String, kw: &Bound<'_, PyDict>) -> PyResult<PyErr> {
    let class = py.import("reckon._errors")?.getattr(name)?;
    let value = class.call((message,), Some(kw))?;
    Ok(PyErr::from_value(value))
}

/// `reckon.NonFinite` for a user function that returned NaN or ±∞.
pub(crate) fn non_finite(py: Python<'_>, message: String, t: f64, quantity: &str, component: usize) -> PyErr {
    let run = || {
        let kw = PyDict::new(py);
        kw.set_item("t", t)?;
        kw.set_item("quantity", quantity)?;
        kw.set_item("component", component)?;
        make(py, "NonFinite", message, &kw)
    };
    run().unwrap_or_else(|err| err)
}

/// `reckon.InvalidInput` (also a `ValueError`).
pub(crate) fn invalid(py: Python<'_>, what: &str, reason: String) -> PyErr {
    let run = || {
        let kw = PyDict::new(py);
        kw.set_item("what", what)?;
        kw.set_item("reason", &reason)?;
        make(py, "InvalidInput", format!("invalid {what}: {reason}"), &kw)
    };
    run().unwrap_or_else(|err| err)
}

/// Whether `e` is the integration's own failure (scipy's `status = -1`, returned in the
/// result) rather than bad input or a user function's fault (raised).
pub(crate) fn is_failure(e: &Error) -> bool {
    matches!(
        e,
        Error::NewtonDiverged { .. }
            | Error::SingularMatrix { .. }
            | Error::StepSizeUnderflow { .. }
            | Error::MaxSteps { .. }
            | Error::NoConvergence { .. }
            | Error::EventLocation { .. }
            | Error::NonFinite {
                quantity: reckon::error::Quantity::State,
                ..
            }
    )
}

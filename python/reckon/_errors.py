"""reckon's typed errors as exceptions: one class per variant of ``reckon::Error``.

Each carries the variant's fields as attributes (``err.t``, ``err.h``...) and the
library's message as ``str(err)``. ``InvalidInput`` is also a ``ValueError``,
``NonFinite`` also a ``FloatingPointError``, so code written for scipy's exceptions
keeps working.
"""

from __future__ import annotations

__all__ = [
    "Error",
    "NonFinite",
    "NewtonDiverged",
    "SingularMatrix",
    "StepSizeUnderflow",
    "MaxSteps",
    "Untraceable",
    "NoDenseOutput",
    "InvalidInput",
    "PitchSingularity",
    "NotPositiveDefinite",
    "NoConvergence",
    "Unidentifiable",
    "SensitivityUnresolved",
    "FitFailed",
    "EnsembleMember",
    "EventNaN",
    "EventLocation",
]


class Error(Exception):
    """Base of every reckon error; ``fields`` names the attributes the variant carries."""

    fields: tuple[str, ...] = ()

    def __init__(self, message: str, **fields):
        super().__init__(message)
        unknown = set(fields) - set(self.fields)
        if unknown:
            raise TypeError(f"{type(self).__name__} has no field(s) {sorted(unknown)}")
        for name in self.fields:
            setattr(self, name, fields.get(name))

    def __reduce__(self):
        return (_rebuild, (type(self), str(self), {f: getattr(self, f) for f in self.fields}))


def _rebuild(cls, message, fields):
    return cls(message, **fields)


def _variant(name: str, doc: str, fields: tuple[str, ...], *bases: type) -> type:
    return type(name, (Error, *bases), {"__doc__": doc, "fields": fields, "__module__": "reckon"})


NonFinite = _variant(
    "NonFinite",
    "The model returned (or a step produced) NaN or ±inf: t, quantity "
    "('state', 'derivative' or 'Jacobian'), component.",
    ("t", "quantity", "component"),
    FloatingPointError,
)
NewtonDiverged = _variant(
    "NewtonDiverged",
    "Newton's iteration did not converge, even with a fresh Jacobian and smaller steps.",
    ("t", "h", "iterations", "residual"),
)
SingularMatrix = _variant(
    "SingularMatrix", "The iteration matrix I - h*J could not be factorised.", ("t", "h")
)
StepSizeUnderflow = _variant(
    "StepSizeUnderflow", "The step size fell below what floating point resolves at t.", ("t", "h")
)
MaxSteps = _variant(
    "MaxSteps", "The step limit (max_steps, counted between two stops) was reached.", ("t", "steps")
)
Untraceable = _variant(
    "Untraceable", "A model could not be traced into expressions.", ("model", "reason")
)
NoDenseOutput = _variant(
    "NoDenseOutput", "No dense output was kept, so the state at t cannot be interpolated.", ("t",)
)
InvalidInput = _variant(
    "InvalidInput", "An option, a span, a dimension or another input was invalid.",
    ("what", "reason"), ValueError,
)
PitchSingularity = _variant(
    "PitchSingularity", "Euler angles asked at pitch ±90° (gimbal lock).", ("t", "pitch")
)
NotPositiveDefinite = _variant(
    "NotPositiveDefinite", "A covariance that must be inverted is not positive definite.", ("what",)
)
NoConvergence = _variant(
    "NoConvergence", "An iteration with a cap stopped without converging.", ("what", "t")
)
Unidentifiable = _variant(
    "Unidentifiable", "A calibration's data cannot determine a parameter.", ("parameter", "reason")
)
SensitivityUnresolved = _variant(
    "SensitivityUnresolved", "The sensitivities are not resolved by the steps.", ("t", "h", "ratio")
)
FitFailed = _variant("FitFailed", "A least-squares fit did not converge.", ("what", "reason"))
EnsembleMember = _variant(
    "EnsembleMember", "A member of an ensemble failed; reason is that member's reckon.Error.",
    ("index", "seed", "reason"),
)
EventNaN = _variant("EventNaN", "An event function returned NaN.", ("index", "t"))
EventLocation = _variant(
    "EventLocation", "The root finder could not locate an event inside a step.",
    ("index", "t0", "t1", "reason"),
)

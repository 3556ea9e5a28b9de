"""Vehicle models with exact flows, driven by inputs held over intervals.

Conventions (REP-103): x forward, y left, z up, θ counter-clockwise from +x, SI units;
θ is integrated unwrapped. Each vehicle is a small frozen dataclass naming its state and
inputs; :func:`simulate` integrates it with the inputs ``u[k]`` held over
``[t[k], t[k+1])``, by its exact flow (``method="Exact"``, one step per interval, exact
to rounding) or any of reckon's methods.

>>> import numpy as np
>>> from reckon import vehicles
>>> # a quarter circle of radius 1: v = 1, ω = 1 for π/2
>>> r = vehicles.simulate(vehicles.Unicycle(), [0, 0, 0], [0, np.pi / 2], [[1.0, 1.0]])
>>> bool(np.allclose(r.y[:, -1], [1, 1, np.pi / 2], atol=1e-15))
True
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ._errors import InvalidInput
from ._reckon import vehicle_sensitivities as _sensitivities
from ._reckon import vehicle_simulate as _simulate
from ._reckon import vehicle_step as _step

__all__ = [
    "Unicycle",
    "Bicycle",
    "CarLike",
    "Body3D",
    "DiffDrive",
    "Vehicle",
    "Trajectory",
    "simulate",
    "METHODS",
]

#: The methods :func:`simulate` takes: the exact flow and reckon's integrators.
METHODS = ("Exact", "RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "Euler")


class Vehicle:
    """Base of the vehicles: ``states`` and ``inputs`` name the components."""

    kind: ClassVar[str] = ""
    states: ClassVar[tuple[str, ...]] = ()
    inputs: ClassVar[tuple[str, ...]] = ()

    def _params(self) -> list[float]:
        return []

    @property
    def n(self) -> int:
        """The number of states."""
        return len(self.states)

    def rhs(self, x: Any, u: Any) -> np.ndarray:
        """``f(x, u)``, the state's time derivative with inputs ``u``."""
        return _step(self.kind, self._params(), _vector(x, "x"), _vector(u, "u"), None)

    def flow(self, x: Any, u: Any, h: float) -> np.ndarray:
        """``φ_h(x; u)``: the exact state after ``h`` seconds with ``u`` held."""
        return _step(self.kind, self._params(), _vector(x, "x"), _vector(u, "u"), float(h))


@dataclass(frozen=True)
class Unicycle(Vehicle):
    """Unicycle / differential drive on (v, ω): ``x' = v cos θ, y' = v sin θ, θ' = ω``.

    Exact flow with ``(v, ω)`` held over ``h``: ``Δθ = ωh``, ``d = v·h·sinc(Δθ/2)``,
    ``x₁ = x + d cos(θ + Δθ/2)``, ``y₁ = y + d sin(θ + Δθ/2)``, ``θ₁ = θ + Δθ``.

    >>> Unicycle().flow([0, 0, 0], [2.0, 0.0], 3.0).tolist()
    [6.0, 0.0, 0.0]
    """

    kind: ClassVar[str] = "unicycle"
    states: ClassVar[tuple[str, ...]] = ("x", "y", "theta")
    inputs: ClassVar[tuple[str, ...]] = ("v", "omega")


@dataclass(frozen=True)
class Bicycle(Vehicle):
    """Kinematic bicycle on (v, α), wheelbase L: ``θ' = v·tan α / L``; the exact flow
    is the unicycle arc with ``ω = v·tan α / L``.

    >>> import math
    >>> x = Bicycle(0.5).flow([0, 0, 0], [2.0, math.pi / 4], 0.25)
    >>> round(float(x[2]), 12)  # θ' = 2·tan(π/4)/0.5 = 4 for 0.25 s
    1.0
    """

    wheelbase: float = 0.5
    kind: ClassVar[str] = "bicycle"
    states: ClassVar[tuple[str, ...]] = ("x", "y", "theta")
    inputs: ClassVar[tuple[str, ...]] = ("v", "steer")

    def _params(self) -> list[float]:
        return [float(self.wheelbase)]


@dataclass(frozen=True)
class CarLike(Vehicle):
    """Car-like vehicle with a steering state, on (v, ω) with ω the steering rate:
    ``θ' = v·tan γ / L``, ``γ' = ω``. Exact flow: steering and heading in closed form,
    positions by adaptive Gauss–Kronrod quadrature (to ≤ 1e-12); a step whose steering
    reaches ±π/2 is singular and gives ``reckon.NonFinite`` in :func:`simulate`.

    >>> import math
    >>> x = CarLike(2.5).flow([0, 0, 0, 0.2], [5.0, 0.0], 1.0)  # no steering rate: an arc
    >>> abs(float(x[2]) - 5.0 * math.tan(0.2) / 2.5) < 1e-14
    True
    """

    wheelbase: float = 2.5
    kind: ClassVar[str] = "carlike"
    states: ClassVar[tuple[str, ...]] = ("x", "y", "theta", "steer")
    inputs: ClassVar[tuple[str, ...]] = ("v", "steer_rate")

    def _params(self) -> list[float]:
        return [float(self.wheelbase)]


@dataclass(frozen=True)
class Body3D(Vehicle):
    """A 3-D vehicle driven by body-frame velocities: ``p' = R(φ, θ, ψ)·v_body`` with
    ``R = Rz(ψ)·Ry(θ)·Rx(φ)`` and inputs ``(roll, pitch, yaw, v_x, v_y, v_z)`` held.
    Exact flow: ``p₁ = p + h·R·v_body``.

    >>> Body3D().flow([1, 1, -5], [0, 0, 0, 2, 0, 0], 1.5).tolist()
    [4.0, 1.0, -5.0]
    """

    kind: ClassVar[str] = "body3d"
    states: ClassVar[tuple[str, ...]] = ("x", "y", "z")
    inputs: ClassVar[tuple[str, ...]] = ("roll", "pitch", "yaw", "vx", "vy", "vz")


@dataclass(frozen=True)
class DiffDrive(Vehicle):
    """Differential drive on wheel angular speeds (ω_l, ω_r) in rad/s, with wheel radii
    and wheelbase b: ``v = (r_r ω_r + r_l ω_l)/2``, ``ω = (r_r ω_r − r_l ω_l)/b``; the
    exact flow is the unicycle arc with that ``(v, ω)``.

    >>> x = DiffDrive(0.05, 0.05, 0.5).rhs([0, 0, 0], [10.0, 12.0])
    >>> [round(float(v), 12) for v in x]
    [0.55, 0.0, 0.2]
    """

    left_radius: float = 0.05
    right_radius: float = 0.05
    wheelbase: float = 0.5
    kind: ClassVar[str] = "diffdrive"
    states: ClassVar[tuple[str, ...]] = ("x", "y", "theta")
    inputs: ClassVar[tuple[str, ...]] = ("omega_left", "omega_right")

    def _params(self) -> list[float]:
        return [float(self.left_radius), float(self.right_radius), float(self.wheelbase)]


@dataclass(frozen=True)
class Trajectory:
    """The result of :func:`simulate`: ``y[:, k]`` is the state at ``t[k]``; with
    ``sensitivities=True`` also ``dy_dx0[:, :, k] = ∂x(t_k)/∂x₀`` (``(n, n, K)``) and
    ``dy_dp[:, :, k] = ∂x(t_k)/∂p`` (``(n, n_p, K)``; the parameters are
    :class:`DiffDrive`'s ``(left_radius, right_radius, wheelbase)``, none for the others)."""

    t: np.ndarray
    y: np.ndarray
    method: str
    stats: dict = field(default_factory=dict)
    dy_dx0: np.ndarray | None = None
    dy_dp: np.ndarray | None = None


def _vector(v: Any, what: str) -> list[float]:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError) as e:
        raise InvalidInput(f"invalid {what}: not an array of numbers ({e})", what=what, reason=str(e)) from None
    if a.ndim != 1:
        reason = f"a 1-d array is needed, got shape {a.shape}"
        raise InvalidInput(f"invalid {what}: {reason}", what=what, reason=reason)
    return a.tolist()


def _array(v: Any, what: str) -> np.ndarray:
    try:
        return np.ascontiguousarray(np.asarray(v, dtype=float))
    except (TypeError, ValueError) as e:
        raise InvalidInput(f"invalid {what}: not an array of numbers ({e})", what=what, reason=str(e)) from None


def simulate(
    vehicle: Vehicle,
    x0: Any,
    t: Any,
    u: Any,
    method: str = "Exact",
    *,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_step: float = np.inf,
    step: float | None = None,
    max_steps: int = 100_000,
    sensitivities: bool = False,
) -> Trajectory:
    """Drive ``vehicle`` from ``x0`` with the inputs ``u[k]`` held over ``[t[k], t[k+1])``.

    ``t``: increasing times, at least two; ``u``: shape ``(len(t) − 1, m)`` (one row of the
    vehicle's ``m`` inputs per interval) or ``(m,)`` (held throughout). Returns a
    :class:`Trajectory` whose ``y`` has shape ``(n, len(t))``: the state at every ``t[k]``.

    ``method="Exact"`` steps the vehicle's exact flow once per interval (``step=h``: steps of
    at most ``h``), exact to rounding; ``"Euler"`` and ``"ImplicitEuler"`` take one step
    per interval unless ``step`` is given (as ``reckon simulate``); the adaptive methods
    (``"RK45"``, ``"BDF"``, ``"Rodas5P"``, ``"Auto"``) use ``rtol``, ``atol``, ``max_step``
    and land on every ``t[k]``. The integration runs with the GIL released.

    ``sensitivities=True`` also integrates ``S = ∂x/∂(x₀, p)`` (``reckon::sensitivity``:
    exact derivatives of the model, the derivative of the computed solution for RK45,
    Euler and the exact flow): ``Trajectory.dy_dx0`` and ``dy_dp``. With
    ``method="Exact"`` only the unicycle, whose flow has its exact derivative.

    Errors: ``reckon.InvalidInput`` (also a ``ValueError``) for wrong shapes, non-finite
    values, times that do not increase, or a non-positive wheelbase; ``reckon.NonFinite``
    when the state leaves the finite numbers (a car-like step across ±90° steering);
    ``reckon.MaxSteps`` and the integrators' other errors as they are.

    >>> import numpy as np
    >>> from reckon import vehicles
    >>> r = vehicles.simulate(vehicles.Unicycle(), [0, 0, 0], [0, 1, 3], [[2, 0], [1, 0]])
    >>> r.y[0].tolist()
    [0.0, 2.0, 4.0]
    """
    if not isinstance(vehicle, Vehicle):
        raise TypeError(f"vehicle must be one of reckon.vehicles' classes, got {type(vehicle).__name__}")
    if method not in METHODS:
        reason = f"{method!r} is not one of {', '.join(METHODS)}"
        raise InvalidInput(f"invalid method: {reason}", what="method", reason=reason)
    ts = _array(t, "t")
    if ts.ndim != 1:
        reason = f"a 1-d array of times is needed, got shape {ts.shape}"
        raise InvalidInput(f"invalid t: {reason}", what="t", reason=reason)
    m = len(vehicle.inputs)
    us = _array(u, "u")
    if us.ndim == 1 and us.shape == (m,) and len(ts) >= 2:
        us = np.tile(us, (len(ts) - 1, 1))
    if us.ndim != 2 or us.shape != (max(len(ts) - 1, 0), m):
        reason = (
            f"shape ({max(len(ts) - 1, 0)}, {m}) (one row of {', '.join(vehicle.inputs)} per "
            f"interval) or ({m},) is needed, got {us.shape}"
        )
        raise InvalidInput(f"invalid u: {reason}", what="u", reason=reason)
    out = (_sensitivities if sensitivities else _simulate)(
        vehicle.kind,
        vehicle._params(),
        _vector(x0, "x0"),
        ts,
        np.ascontiguousarray(us.reshape(-1)),
        method,
        float(rtol),
        float(atol),
        float(max_step),
        None if step is None else float(step),
        int(max_steps),
    )
    if not sensitivities:
        return Trajectory(t=out["t"], y=out["y"], method=method, stats=out["stats"])
    sens = np.transpose(out["s"], (1, 2, 0))  # (n, n + n_p, K)
    n = vehicle.n
    return Trajectory(
        t=out["t"], y=out["y"], method=method, stats=out["stats"],
        dy_dx0=np.ascontiguousarray(sens[:, :n, :]), dy_dp=np.ascontiguousarray(sens[:, n:, :]),
    )

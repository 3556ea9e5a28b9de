"""Calibration: model parameters by least squares on trajectories, UMBmark's odometry
correction factors, and Censi et al.'s simultaneous odometry and sensor calibration.

Each result is a frozen dataclass with the estimate, its covariance and the fit's
residuals (``dof`` residuals − parameters, ``sigma2 = ‖r‖²/dof``); ``std`` is
``√diag(covariance)``. Bad input raises ``reckon.InvalidInput``; data that cannot
determine a parameter ``reckon.Unidentifiable``; a fit that does not converge
``reckon.FitFailed``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ._reckon import censi_fit as _censi
from ._reckon import encoder_least_squares as _encoder_least_squares
from ._reckon import least_squares as _least_squares
from ._reckon import umbmark_fit as _umbmark
from ._sensitivity import _floats, _invalid, _param_names, _traced

__all__ = [
    "least_squares",
    "encoder_least_squares",
    "umbmark",
    "censi",
    "LeastSquaresResult",
    "UmbmarkResult",
    "CensiResult",
]


def _std(cov: np.ndarray) -> np.ndarray:
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def _matrix(v: Any, cols: int, what: str) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError) as e:
        raise _invalid(what, f"not an array of numbers ({e})") from None
    if a.ndim != 2 or a.shape[1] != cols:
        raise _invalid(what, f"shape (k, {cols}) is needed, got {a.shape}")
    return np.ascontiguousarray(a.reshape(-1))


@dataclass(frozen=True)
class LeastSquaresResult:
    """The result of :func:`least_squares`: ``params`` (p̂, named ``names``), ``covariance``
    ``σ̂²·(JᵀJ)⁻¹``, ``std``, the weighted ``residuals`` observation-major, ``dof``,
    ``sigma2``, the Levenberg–Marquardt ``iterations`` and the ``condition`` number of the
    column-scaled residual Jacobian at p̂."""

    params: np.ndarray
    names: tuple[str, ...]
    covariance: np.ndarray
    std: np.ndarray
    residuals: np.ndarray
    dof: int
    sigma2: float
    iterations: int
    condition: float


def least_squares(
    fun: Callable,
    t_obs: Any,
    y_obs: Any,
    p0: Sequence[float],
    y0: Any,
    *,
    t0: float = 0.0,
    components: Sequence[int] | None = None,
    sigma: Any = 1.0,
    angles: Sequence[int] = (),
    args: tuple = (),
    method: str = "RK45",
    rtol: float = 1e-9,
    atol: float = 1e-12,
    max_iters: int = 50,
    tol: float = 1e-3,
    max_condition: float = 1e8,
) -> LeastSquaresResult:
    """Fit the parameters ``p`` of ``y' = fun(t, y, *p, *args)``, ``y(t0) = y0``, to observed
    state components: minimises ``½ Σ_k Σ_c ((y_c(t_k; p) − y_obs[c, k]) / σ_c)²`` by
    Levenberg–Marquardt with the exact residual Jacobian ``∂y_c(t_k)/∂p / σ_c`` from the
    forward sensitivities of the traced ``fun`` (see :func:`reckon.sensitivities`).

    ``y_obs`` has shape ``(len(components), len(t_obs))`` as ``sol.y[components]`` (1-d for
    one component); ``components`` defaults to every state; ``sigma`` is a scalar or one σ
    per component; residuals of the components listed in ``angles`` are wrapped to
    ``(−π, π]``. ``t_obs`` must increase and be after ``t0``. Converged when the
    Gauss–Newton step moves ``p`` by less than ``tol`` standard deviations.

    >>> import numpy as np
    >>> from reckon import calibration
    >>> t = np.linspace(0.3, 3.0, 10)
    >>> fit = calibration.least_squares(lambda t, y, k: -k * y, t, np.exp(-0.7 * t), [0.2], [1.0],
    ...                                 sigma=1e-3)
    >>> round(float(fit.params[0]), 8), fit.names
    (0.7, ('k',))
    """
    if method not in ("RK45", "BDF", "Rodas5P"):
        raise _invalid("method", f"{method!r} is not one of RK45, BDF, Rodas5P")
    y = _floats(y0, "y0")
    p = _floats(p0, "p0")
    n = len(y)
    if n == 0:
        raise _invalid("y0", "at least one state is needed")
    if not p:
        raise _invalid("p0", "at least one parameter to fit is needed")
    comps = list(range(n)) if components is None else [int(c) for c in components]
    if any(c < 0 or c >= n for c in comps) or not comps:
        raise _invalid("components", f"indices into a state of {n} components are needed, got {comps}")
    if any(int(a) not in comps for a in angles):
        raise _invalid("angles", f"the angles must be observed components {comps}, got {list(angles)}")
    ts = _floats(t_obs, "t_obs")
    try:
        yo = np.asarray(y_obs, dtype=float)
    except (TypeError, ValueError) as e:
        raise _invalid("y_obs", f"not an array of numbers ({e})") from None
    if yo.ndim == 1 and len(comps) == 1:
        yo = yo[None, :]
    if yo.shape != (len(comps), len(ts)):
        raise _invalid("y_obs", f"shape ({len(comps)}, {len(ts)}) (components × times) is needed, got {yo.shape}")
    s = np.asarray(sigma, dtype=float)
    sig = [float(s)] * len(comps) if s.ndim == 0 else _floats(s, "sigma")
    if len(sig) != len(comps):
        raise _invalid("sigma", f"a scalar or {len(comps)} values are needed, got {len(sig)}")
    model = _traced(fun, n, len(p), tuple(args))
    out = _least_squares(
        model, n, p, float(t0), y, ts, np.ascontiguousarray(yo.T.reshape(-1)), comps, sig,
        [int(a) for a in angles], method, float(rtol), float(atol), int(max_iters), float(tol),
        float(max_condition),
    )
    cov = out["covariance"]
    return LeastSquaresResult(
        params=out["value"], names=tuple(_param_names(fun, len(p))), covariance=cov, std=_std(cov),
        residuals=out["residuals"], dof=out["dof"], sigma2=out["sigma2"],
        iterations=out["iterations"], condition=out["condition"],
    )


def encoder_least_squares(
    t: Any,
    left: Any,
    right: Any,
    pose_t: Any,
    poses: Any,
    *,
    wheel_diameter: float,
    wheel_separation: float,
    pulses_per_rev: float,
    sigma: Sequence[float] = (0.01, 0.01, 0.01),
) -> LeastSquaresResult:
    """A differential drive's wheel radii and wheelbase ``(r_l, r_r, b)`` from an encoder
    log and measured poses: :func:`least_squares` on ``x' = v cos θ, y' = v sin θ,
    θ' = ω`` with ``v = (r_r ω_r + r_l ω_l)/2``, ``ω = (r_r ω_r − r_l ω_l)/b`` and the
    wheel speeds ``ω = 2π·Δn/(N·Δt)`` held over each encoder interval (RK45 at rtol
    1e-9), starting from the nominal geometry (``r = D/2``, ``b`` = ``wheel_separation``).

    ``t``, ``left``, ``right``: the encoder samples (pulse increments over ``(t[k−1], t[k]]``;
    the first sample's increments are ignored). ``pose_t``, ``poses`` (shape ``(3, K)``:
    x, y, θ): the measured poses; the first one at or after ``t[0]`` is the start, the later
    ones up to ``t[-1]`` are observed with standard deviations ``sigma = (σ_x, σ_y, σ_θ)``
    (θ's residuals wrapped). This is ``reckon calibrate``'s least-squares fit.
    """
    arrays = [_floats(v, w) for v, w in ((t, "t"), (left, "left"), (right, "right"), (pose_t, "pose_t"))]
    try:
        p = np.asarray(poses, dtype=float)
    except (TypeError, ValueError) as e:
        raise _invalid("poses", f"not an array of numbers ({e})") from None
    if p.shape != (3, len(arrays[3])):
        raise _invalid("poses", f"shape (3, {len(arrays[3])}) (x, y, θ × times) is needed, got {p.shape}")
    sig = _floats(sigma, "sigma")
    if len(sig) != 3:
        raise _invalid("sigma", f"(σ_x, σ_y, σ_θ) is needed, got {len(sig)} values")
    ts, ls, rs, pt = (np.ascontiguousarray(v, dtype=float) for v in arrays)
    out = _encoder_least_squares(
        ts, ls, rs, pt, np.ascontiguousarray(p.reshape(-1)), float(wheel_diameter),
        float(wheel_separation), float(pulses_per_rev), sig,
    )
    cov = out["covariance"]
    return LeastSquaresResult(
        params=out["value"], names=tuple(out["names"]), covariance=cov, std=_std(cov),
        residuals=out["residuals"], dof=out["dof"], sigma2=out["sigma2"],
        iterations=out["iterations"], condition=out["condition"],
    )


@dataclass(frozen=True)
class UmbmarkResult:
    """The result of :func:`umbmark`: the correction factors ``e_d = D_R/D_L`` and
    ``e_b`` (actual ÷ nominal wheelbase) with their ``covariance`` (order ``(E_d, E_b)``),
    the turn error ``alpha`` and leg curvature ``beta`` (rad), the legs' ``radius``, the
    centres of gravity ``cg_cw``, ``cg_ccw`` and the four coordinates' ``residuals``."""

    e_d: float
    e_b: float
    alpha: float
    beta: float
    radius: float
    cg_cw: np.ndarray
    cg_ccw: np.ndarray
    covariance: np.ndarray
    std: np.ndarray
    residuals: np.ndarray
    dof: int
    sigma2: float
    e_max_syst: float
    _diameter_factors: tuple[float, float]

    def wheel_diameters(self, nominal: float) -> tuple[float, float]:
        """Corrected ``(D_L, D_R) = (2/(E_d + 1)·D, 2/(1/E_d + 1)·D)``; their mean is ``D``."""
        return (self._diameter_factors[0] * nominal, self._diameter_factors[1] * nominal)

    def wheelbase(self, nominal: float) -> float:
        """Corrected wheelbase ``E_b·b``."""
        return self.e_b * nominal


def umbmark(cw: Any, ccw: Any, side: float, wheelbase: float) -> UmbmarkResult:
    """UMBmark (Borenstein & Feng 1996): ``E_d``, ``E_b`` from the return errors
    ``ε = truth − odometry`` (shape ``(k, 2)``, one ``(x, y)`` per run) of clockwise runs
    ``cw`` and counter-clockwise runs ``ccw`` of a square of side ``side`` (m), for a
    robot of nominal ``wheelbase`` (m):

    ``α = (x_cw + x_ccw)/(−4L)``, ``β = (x_cw − x_ccw)/(−4L)`` (each averaged with its y
    form), ``R = (L/2)/sin(β/2)``, ``E_d = (R + b/2)/(R − b/2)``, ``E_b = (π/2)/(π/2 − α)``.

    >>> from reckon import calibration
    >>> fit = calibration.umbmark([[-0.08, -0.08]], [[-0.08, 0.08]], 4.0, 0.5)  # α = 0.01
    >>> round(fit.alpha, 15), round(fit.e_b, 12), fit.e_d
    (0.01, 1.006406985862, 1.0)
    """
    out = _umbmark(_matrix(cw, 2, "cw"), _matrix(ccw, 2, "ccw"), float(side), float(wheelbase))
    cov = out["covariance"]
    return UmbmarkResult(
        e_d=out["e_d"], e_b=out["e_b"], alpha=out["alpha"], beta=out["beta"], radius=out["radius"],
        cg_cw=out["cg_cw"], cg_ccw=out["cg_ccw"], covariance=cov, std=_std(cov),
        residuals=out["residuals"], dof=out["dof"], sigma2=out["sigma2"],
        e_max_syst=out["e_max_syst"], _diameter_factors=tuple(out["diameter_factors"]),
    )


@dataclass(frozen=True)
class CensiResult:
    """The result of :func:`censi`: wheel radii ``r_l``, ``r_r`` and wheel base ``b`` (m),
    the sensor pose ``sensor = (ℓ_x, ℓ_y, ℓ_θ)`` in the robot frame, ``j21 = −r_L/b``,
    ``j22 = r_R/b``; ``names``, ``value``, ``covariance`` (8 × 8, rank 6) in the order
    ``J21, J22, b, l_x, l_y, l_theta, r_L, r_R``; ``residuals`` ``(r_θ, r_x, r_y)`` per
    kept interval; ``kept`` the intervals kept after trimming; ``sigma2_theta``,
    ``sigma2_xy`` the two residual variances."""

    r_l: float
    r_r: float
    b: float
    sensor: np.ndarray
    j21: float
    j22: float
    names: tuple[str, ...]
    value: np.ndarray
    covariance: np.ndarray
    std: np.ndarray
    residuals: np.ndarray
    kept: np.ndarray
    dof: int
    sigma2_theta: float
    sigma2_xy: float


def censi(wheels: Any, sensor: Any, *, trim: tuple[float, int] = (0.01, 4)) -> CensiResult:
    """Censi, Franchi, Marchionni & Oriolo (2013): wheel radii, wheel base and the pose of
    an exteroceptive sensor from intervals of wheel rotations and the sensor's measured
    displacements.

    ``wheels``: one array per interval of shape ``(k_i, 2)``, the wheel rotations
    ``(Δφ_L, Δφ_R)`` in rad per sub-sample (speeds constant within one), or one array of
    shape ``(K, k, 2)``; ``sensor``: shape ``(K, 3)``, the displacement ``(s_x, s_y, s_θ)``
    over each interval in the sensor frame at its start. Step 1 fits ``(J21, J22)`` from
    ``s_θ = J21·Φ_L + J22·Φ_R``; step 2 solves for ``(b, ℓ)`` in closed form;
    ``r_L = −b·J21``, ``r_R = b·J22``. ``trim=(fraction, rounds)``: drop that fraction of
    the worst intervals per round (``(0, 0)`` keeps them all). At least 3 intervals.
    """
    s = _matrix(sensor, 3, "sensor")
    if isinstance(wheels, np.ndarray) and wheels.ndim == 3:
        per = list(wheels)
    else:
        per = list(wheels)
    if len(per) * 3 != len(s):
        raise _invalid("wheels", f"{len(per)} intervals of wheel rotations for {len(s) // 3} sensor displacements")
    arrays = [_matrix(w, 2, f"wheels[{k}]") for k, w in enumerate(per)]
    counts = [len(a) // 2 for a in arrays]
    flat = np.ascontiguousarray(np.concatenate(arrays)) if arrays else np.zeros(0)
    fraction, rounds = trim
    out = _censi(flat, counts, s, float(fraction), int(rounds))
    cov = out["covariance"]
    v = out["value"]
    return CensiResult(
        r_l=out["r_l"], r_r=out["r_r"], b=out["b"], sensor=out["sensor"], j21=float(v[0]), j22=float(v[1]),
        names=tuple(out["names"]), value=v, covariance=cov, std=_std(cov), residuals=out["residuals"],
        kept=np.asarray(out["kept"], dtype=np.int64), dof=out["dof"], sigma2_theta=out["sigma2_theta"],
        sigma2_xy=out["sigma2_xy"],
    )

"""Forward sensitivities of traced models: :func:`sensitivities` and the traced model
with its parameters as states that it and ``reckon.calibration.least_squares`` share."""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ._errors import InvalidInput
from ._reckon import Model
from ._reckon import sensitivities as _sensitivities

__all__ = ["sensitivities", "SensitivityResult"]

_METHODS = ("RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "Euler")


def _invalid(what: str, reason: str) -> Exception:
    return InvalidInput(f"invalid {what}: {reason}", what=what, reason=reason)


def _floats(v: Any, what: str) -> list[float]:
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError) as e:
        raise _invalid(what, f"not an array of numbers ({e})") from None
    if a.ndim > 1:
        raise _invalid(what, f"a 1-d array is needed, got shape {a.shape}")
    a = a.reshape(-1)
    if not np.all(np.isfinite(a)):
        raise _invalid(what, f"value {int(np.argmin(np.isfinite(a)))} is not finite")
    return a.tolist()


def _param_names(fun: Callable, k: int) -> list[str]:
    try:
        names = list(inspect.signature(fun).parameters)[2:]
    except (TypeError, ValueError):
        names = []
    return [names[i] if i < len(names) else f"p{i}" for i in range(k)]


def _traced(fun: Callable, n: int, n_params: int, args: tuple) -> Model:
    """``fun(t, y, *p, *args)`` traced as ``g(t, (y, p)) = (f, 0)`` over ``n + n_params``
    states: the exact ``∂f/∂y`` and ``∂f/∂p`` are blocks of its Jacobian."""
    if not callable(fun):
        raise TypeError("fun must be callable as fun(t, y, *params, *args)")

    def g(t, z):
        r = fun(t, z[:n], *z[n:], *args)
        r = np.asarray(r, dtype=object).reshape(-1)
        if r.shape != (n,):
            raise _invalid("fun", f"fun(t, y, *params) returned {r.size} values, expected {n} (the length of y0)")
        return [*r, *([0.0] * n_params)]

    g.__qualname__ = getattr(fun, "__qualname__", "fun")
    return Model(g, n + n_params)


@dataclass(frozen=True)
class SensitivityResult:
    """The result of :func:`sensitivities` at the times ``t`` (index k last, as scipy's ``y``):

    - ``y[:, k]``: the state ``x(t_k)``, shape ``(n, K)``;
    - ``dy_dy0[:, :, k]``: ``∂x(t_k)/∂x₀``, shape ``(n, n, K)`` (None for ``wrt="params"``);
    - ``dy_dp[:, :, k]``: ``∂x(t_k)/∂p``, shape ``(n, n_p, K)``;
    - ``stats``: the run's counters; ``method``: the method's name.
    """

    t: np.ndarray
    y: np.ndarray
    dy_dy0: np.ndarray | None
    dy_dp: np.ndarray
    params: tuple[str, ...]
    method: str
    stats: dict = field(default_factory=dict)


def sensitivities(
    fun: Callable,
    t_span: Sequence[float],
    y0: Any,
    params: Sequence[float] = (),
    *,
    args: tuple = (),
    method: str = "RK45",
    t_eval: Any = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    first_step: float | None = None,
    max_step: float = np.inf,
    fixed_step: float | None = None,
    max_steps: int = 100_000,
    error_control: bool = False,
    wrt: str = "all",
) -> SensitivityResult:
    """Solve ``y' = fun(t, y, *params, *args)`` with its forward sensitivities
    ``S = ∂y/∂(y₀, p)``: ``S' = J·S + [0 | ∂f/∂p]``, ``S(t₀) = [I | 0]``.

    ``fun`` is traced once (as :class:`reckon.Model` traces) with the numeric ``params`` as
    traced values, so ``J = ∂f/∂y`` and ``∂f/∂p`` are exact compiled derivatives, never
    difference quotients; ``args`` are passed as they are. A ``fun`` whose control flow
    depends on the state raises ``reckon.Untraceable``. ``wrt="params"`` carries
    ``∂y/∂p`` only (``n`` fewer columns). With ``error_control=True`` the adaptive
    methods control the error of ``S`` too; by default the steps are the plain solve's
    and a step that leaves ``S`` unresolved raises ``reckon.SensitivityUnresolved``.
    ``t_eval``: the output times (default: every step). The integration runs with the
    GIL released.

    >>> import numpy as np, reckon
    >>> r = reckon.sensitivities(lambda t, y, k: -k * y, (0, 2), [3.0], [0.5],
    ...                          rtol=1e-10, atol=1e-12, t_eval=[1.0, 2.0])
    >>> bool(np.allclose(r.dy_dy0[0, 0], np.exp(-0.5 * r.t), rtol=1e-8))   # e^{−kt}
    True
    >>> bool(np.allclose(r.dy_dp[0, 0], -r.t * 3.0 * np.exp(-0.5 * r.t), rtol=1e-8))
    True
    """
    if method not in _METHODS:
        raise _invalid("method", f"{method!r} is not one of {', '.join(_METHODS)}")
    if wrt not in ("all", "params"):
        raise _invalid("wrt", f"{wrt!r} is not 'all' or 'params'")
    span = _floats(t_span, "t_span")
    if len(span) != 2:
        raise _invalid("t_span", "two times (t0, t1) are needed")
    t0, t1 = span
    y = _floats(y0, "y0")
    p = _floats(params, "params")
    if not y:
        raise _invalid("y0", "at least one state is needed")
    if wrt == "params" and not p:
        raise _invalid("wrt", "sensitivities with respect to the parameters of a model without parameters")
    te = None if t_eval is None else _floats(t_eval, "t_eval")
    n = len(y)
    model = _traced(fun, n, len(p), tuple(args))
    out = _sensitivities(
        model, n, p, t0, t1, y, method, float(rtol), float(atol),
        None if first_step is None else float(first_step), float(max_step),
        None if fixed_step is None else float(fixed_step), te, int(max_steps),
        bool(error_control), wrt == "params",
    )
    s = np.transpose(out["s"], (1, 2, 0))  # (n, m, K)
    x0_cols = 0 if wrt == "params" else n
    return SensitivityResult(
        t=out["t"],
        y=out["y"],
        dy_dy0=None if wrt == "params" else np.ascontiguousarray(s[:, :n, :]),
        dy_dp=np.ascontiguousarray(s[:, x0_cols:, :]),
        params=tuple(_param_names(fun, len(p))),
        method=out["method"],
        stats=out["stats"],
    )

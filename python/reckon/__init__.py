"""reckon from Python: ``solve_ivp`` with scipy's names, on reckon's methods.

>>> import numpy as np, reckon
>>> sol = reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], rtol=1e-10, atol=1e-12)
>>> bool(abs(sol.y[0, -1] - np.exp(-1.0)) < 1e-9)
True

The Python function is called back for every right-hand side. The Jacobian the
implicit methods need is ``jac`` when given (a callable or a constant array), otherwise
forward differences of ``fun`` computed in Rust (``result.jacobian`` says which).
See docs/python.md for the scipy-to-reckon table of names.
"""

from __future__ import annotations

import math
import operator
import os
import warnings
from typing import Any, Callable, Sequence

import numpy as np

from . import _errors
from ._errors import *  # noqa: F401,F403  (the exception hierarchy under reckon.Error)
from ._errors import __all__ as _error_names
from ._ensemble import EncoderEnsemble, Ensemble, Statistics, _statistics_from_json  # noqa: F401
from ._reckon import DenseOutput, Model, Symbol
from ._reckon import solve as _solve
from ._reckon import solve_traced as _solve_traced
from ._reckon import odometry as _odometry
from ._sensitivity import SensitivityResult, sensitivities
from . import calibration, vehicles  # noqa: E402  (submodules: reckon.vehicles, reckon.calibration)

#: The functions of a traced value (numpy's ufuncs of the same name work too, on
#: symbols and on object arrays of them); on numbers and arrays they are numpy's.
_FUNCTIONS = (
    "sin", "cos", "tan", "arcsin", "arccos", "arctan", "sinh", "cosh", "tanh", "arcsinh",
    "arccosh", "arctanh", "exp", "exp2", "expm1", "log", "log1p", "log2", "log10", "sqrt",
    "cbrt", "square", "sign",
)

__all__ = [
    "solve_ivp", "OdeResult", "DenseOutput", "Model", "Symbol", "METHODS", "EncoderEnsemble", "Ensemble",
    "Statistics", "sensitivities", "SensitivityResult", "odometry", "vehicles", "calibration",
    *_FUNCTIONS,
    "arctan2", "hypot", *_error_names,
]


def _function(name: str) -> Callable[[Any], Any]:
    ufunc = getattr(np, name)

    def f(x: Any) -> Any:
        if isinstance(x, Symbol):
            return getattr(x, name)()
        return ufunc(x)

    f.__name__ = f.__qualname__ = name
    f.__doc__ = (
        f"``{name}(x)``: on a traced value (:class:`reckon.Symbol`) the traced ``{name}``, "
        f"otherwise ``numpy.{name}(x)``."
    )
    return f


for _name in _FUNCTIONS:
    globals()[_name] = _function(_name)
del _name

# the math module's names
asin, acos, atan, asinh, acosh, atanh, ln = arcsin, arccos, arctan, arcsinh, arccosh, arctanh, log  # noqa: F821


def arctan2(y: Any, x: Any) -> Any:
    """``atan2(y, x)``: traced when either is a :class:`reckon.Symbol`, else ``numpy.arctan2``."""
    if isinstance(y, Symbol):
        return y.arctan2(x)
    if isinstance(x, Symbol):
        return (x * 0 + y).arctan2(x)
    return np.arctan2(y, x)


def hypot(a: Any, b: Any) -> Any:
    """``√(a² + b²)``: traced when either is a :class:`reckon.Symbol`, else ``numpy.hypot``."""
    if isinstance(a, Symbol) or isinstance(b, Symbol):
        return (a * a + b * b) ** 0.5
    return np.hypot(a, b)


atan2 = arctan2

#: reckon's methods by the names ``solve_ivp`` takes.
METHODS = ("RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "ExponentialEuler", "Euler")

#: scipy methods reckon does not have, with what to use instead.
_INSTEAD = {
    "RK23": "use method='RK45' (Dormand–Prince 5(4), the same family, higher order)",
    "DOP853": "use method='RK45' with a tighter rtol, or method='Rodas5P' for stiff problems",
    "Radau": "use method='Rodas5P' (L-stable Rosenbrock, order 5) or method='BDF' for stiff problems",
}

#: scipy names reckon answers with another of its methods.
_ALIASES = {"LSODA": "Auto"}  # LSODA switches Adams ⇄ BDF; Auto switches RK45 ⇄ BDF

_EPS = np.finfo(float).eps


class OdeResult(dict):
    """The result of :func:`solve_ivp`: a dict whose keys are also attributes, as scipy's.

    Fields shared with scipy: ``t``, ``y`` (shape ``(n, n_points)``), ``sol``,
    ``t_events``, ``y_events``, ``nfev``, ``njev``, ``nlu``, ``status``, ``message``,
    ``success``. reckon's extras: ``stats`` (the library's counters and the Python
    calls), ``stiffness`` (where the stiffness test fired, or None), ``switches``
    (``method='Auto'``'s switches), ``method``, ``jacobian`` (where the Jacobian came
    from) and ``error`` (on ``status == -1``: the typed :class:`reckon.Error`, not raised).
    """

    def __getattr__(self, name: str) -> Any:
        try:
            return self[name]
        except KeyError as e:
            raise AttributeError(name) from e

    __setattr__ = dict.__setitem__  # type: ignore[assignment]
    __delattr__ = dict.__delitem__  # type: ignore[assignment]

    def __repr__(self) -> str:
        width = max(map(len, self)) + 1
        return "\n".join(f"{k.rjust(width)}: {v!r}" for k, v in self.items())

    def __dir__(self):
        return list(self.keys())


# every field of a result, in order: copying it sizes the dict once (the native code then
# only replaces values)
_RESULT_FIELDS = dict.fromkeys((
    "t", "y", "sol", "t_events", "y_events", "nfev", "njev", "nlu", "status", "message", "success",
    "stats", "stiffness", "switches", "method", "jacobian", "error", "traced", "trace_error",
))

_METHOD_SET = frozenset(METHODS)


def _method_name(method: Any) -> str:
    if type(method) is str and method in _METHOD_SET:  # the common case first
        return method
    name = method if isinstance(method, str) else getattr(method, "__name__", None)
    if not isinstance(name, str):
        raise ValueError(f"method must be a string, one of {METHODS}; got {method!r}")
    name = _ALIASES.get(name, name)
    if name in METHODS:
        return name
    if name in _INSTEAD:
        raise ValueError(f"reckon has no method {name!r}: {_INSTEAD[name]}")
    raise ValueError(f"unknown method {name!r}: reckon offers {', '.join(METHODS)}")


#: The methods that need `∂f/∂y`: called back, it is a dense n×n matrix.
_DENSE_JACOBIAN = frozenset(("BDF", "Rodas5P", "ImplicitEuler", "ExponentialEuler", "Auto"))


def _refuse_dense(n: int, name: str, trace_error: str | None) -> None:
    """Refuse up front a called-back run whose dense Jacobian, iteration matrix and its
    LU (three n×n arrays of float64) need more than this machine's physical memory, which
    would otherwise abort the process on a failed allocation."""
    need = 3 * 8 * n * n
    try:
        have = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return
    if need > have:
        why = f" ({trace_error})" if trace_error else ""
        reason = (
            f"{name} on a called-back fun of {n} states needs dense {n}×{n} matrices, "
            f"{need / 2**30:.0f} GiB against this machine's {have / 2**30:.0f} GiB; trace fun "
            f"(reckon.Model: the sparse path) or use an explicit method{why}"
        )
        raise InvalidInput(f"invalid method: {reason}", what="method", reason=reason)


def _count(value: Any, what: str) -> int:
    """A count of at least 1 (any integer type), else ``InvalidInput`` naming ``what``."""
    try:
        v = operator.index(value)
    except TypeError:
        reason = f"an integer is needed, got {type(value).__name__}"
        raise InvalidInput(f"invalid {what}: {reason}", what=what, reason=reason) from None
    if not 1 <= v < 2**63:
        reason = f"must be at least 1 and below 2^63, got {v}"
        raise InvalidInput(f"invalid {what}: {reason}", what=what, reason=reason)
    return v


def _tolerance(value: Any, n: int, what: str) -> list[float]:
    if type(value) is float:  # the common case, without numpy's per-call cost
        return [value]
    v = np.asarray(value, dtype=float)
    if v.ndim == 0:
        return [float(v)]
    if v.shape != (n,):
        raise ValueError(f"`{what}` must be a scalar or of shape ({n},), got shape {v.shape}")
    return [float(x) for x in v]


def _prepare_events(events: Any, args: tuple | None) -> list[tuple[Callable, int, float]]:
    if events is None:
        return []
    if callable(events):
        events = (events,)
    out = []
    for event in events:
        terminal = getattr(event, "terminal", False)
        if isinstance(terminal, (bool, np.bool_)):
            stop = int(bool(terminal))
        elif isinstance(terminal, (int, np.integer)) and terminal >= 0:
            stop = int(terminal)  # stop at the terminal-th zero, 0: never
        else:
            raise ValueError("The `terminal` attribute of each event must be a boolean or positive integer.")
        direction = float(getattr(event, "direction", 0))
        g = event if args is None else (lambda t, y, event=event: event(t, y, *args))
        out.append((g, stop, direction))
    return out


def solve_ivp(
    fun: Callable,
    t_span: Sequence[float],
    y0: Any,
    method: str = "RK45",
    t_eval: Any = None,
    dense_output: bool = False,
    events: Any = None,
    vectorized: bool = False,
    args: tuple | None = None,
    *,
    rtol: Any = 1e-3,
    atol: Any = 1e-6,
    jac: Any = None,
    first_step: float | None = None,
    max_step: float = np.inf,
    fixed_step: float | None = None,
    max_steps: int | None = None,
    trace: bool | None = None,
    **options: Any,
) -> OdeResult:
    """Solve ``y' = fun(t, y)``, ``y(t0) = y0`` on ``t_span`` with one of reckon's methods.

    Every argument scipy's ``solve_ivp`` has means what it means there: ``t_eval``
    (sorted output times inside ``t_span``), ``dense_output`` (``result.sol(t)``),
    ``events`` (callables ``g(t, y)`` with optional ``terminal`` and ``direction``
    attributes), ``vectorized``, ``args`` (passed to ``fun``, ``jac`` and the events),
    ``rtol`` (default 1e-3; values below 100·eps are raised to it, with a warning, as
    scipy does), ``atol`` (default 1e-6, scalar or per component), ``jac`` (callable
    ``jac(t, y)``, or a constant array or sparse matrix), ``first_step`` and
    ``max_step``.

    ``method``: ``"RK45"``, ``"BDF"``, ``"Rodas5P"``, ``"Auto"`` (RK45 ⇄ BDF),
    ``"ImplicitEuler"``, ``"ExponentialEuler"``, ``"Euler"``; ``"LSODA"`` runs
    ``"Auto"``. ``"Euler"`` takes fixed steps of size ``first_step`` (required).
    ``"RK23"``, ``"DOP853"`` and ``"Radau"`` raise ``ValueError`` naming what to use.

    reckon's extras: ``fixed_step=h`` (fixed steps of size h, any method),
    ``max_steps`` (step attempts between two stops, default 100 000) and ``trace``.

    ``fun`` is first traced (:class:`reckon.Model`: called once with symbols, then run
    as compiled code with its exact Jacobian, the GIL released while it integrates),
    unless ``trace=False``, ``jac`` is given or ``vectorized=True``. ``fun`` may also be a
    :class:`reckon.Model` itself. When ``fun`` cannot be traced (its control flow
    depends on the state, it calls ``math.*`` or ``float()`` on a value, or it raises
    on symbols) it is called back instead, with finite differences for the Jacobian;
    ``result.traced`` says which path ran and ``result.trace_error`` why tracing was
    refused. ``trace=True`` raises that error instead of falling back.

    A Python exception raised in ``fun``, ``jac`` or an event comes out as itself; a
    return of the wrong length is a ``ValueError``; NaN or ±inf is
    :class:`reckon.NonFinite`. Invalid arguments raise :class:`reckon.InvalidInput`
    (a ``ValueError``). A failure of the integration itself (step size underflow, Newton
    divergence, the step limit) gives ``status = -1`` with ``result.error`` the typed
    exception, as scipy returns ``status = -1``; reckon keeps no partial solution, so
    ``t`` and ``y`` then hold the initial point only.
    """
    name = _method_name(method)
    if isinstance(fun, Model) and (jac is not None or vectorized or args is not None):
        raise ValueError(
            "fun is a reckon.Model: its Jacobian is traced and its parameters were fixed when it "
            "was traced, so jac, vectorized and args do not apply (trace again with Model(fun, n, params=...))"
        )
    if options:
        warnings.warn(
            "The following arguments have no effect for a chosen solver: "
            + ", ".join(f"`{k}`" for k in options)
            + ".",
            stacklevel=2,
        )
    t0, tf = map(float, t_span)
    y0 = np.asarray(y0)
    if y0.dtype.kind == "c":
        raise ValueError("complex y0 is not supported by reckon: split it into real and imaginary parts")
    if y0.dtype.char != "d":
        y0 = y0.astype(float)
    if y0.ndim != 1:
        raise ValueError("`y0` must be 1-dimensional.")
    n = y0.shape[0]

    model = fun if isinstance(fun, Model) else None
    trace_error = None
    if model is not None and model.n != n:
        raise ValueError(f"y0 has {n} values for a reckon.Model of {model.n} states")
    if model is None and trace is not False:
        if jac is not None or vectorized:
            if trace:
                raise ValueError("trace=True cannot be combined with jac or vectorized=True")
            trace_error = "not traced: jac or vectorized=True was given"
        else:
            try:
                model = Model(fun, n, params=None if args is None else tuple(args))
            except Exception as e:  # noqa: BLE001  (any failure on symbols: call fun back)
                if trace:
                    raise
                trace_error = f"{type(e).__name__}: {e}"

    if args is not None:
        try:
            _ = [*(args)]
        except TypeError as exp:
            raise TypeError(
                "Supplied 'args' cannot be unpacked. Please supply `args` as a tuple (e.g. `args=(a,)`)"
            ) from exp
        user_fun = fun
        fun = lambda t, x: user_fun(t, x, *args)  # noqa: E731
        if callable(jac):
            user_jac = jac
            jac = lambda t, x: user_jac(t, x, *args)  # noqa: E731
    if vectorized:
        vfun = fun
        fun = lambda t, x: np.asarray(vfun(t, x[:, None])).ravel()  # noqa: E731

    rtol_v = _tolerance(rtol, n, "rtol")
    if min(rtol_v) < 100 * _EPS:
        warnings.warn(
            "At least one element of `rtol` is too small. "
            f"Setting `rtol = np.maximum(rtol, {100 * _EPS})`.",
            stacklevel=2,
        )
        rtol_v = [max(r, 100 * _EPS) for r in rtol_v]
    atol_v = _tolerance(atol, n, "atol")

    t_eval_list = None
    if t_eval is not None:
        if type(t_eval) is list and len(t_eval) <= 64 and all(type(v) is float for v in t_eval):
            t_eval_list = t_eval  # plain Python is cheaper than numpy's calls here
        else:
            t_eval = np.asarray(t_eval, dtype=float)
            if t_eval.ndim != 1:
                raise ValueError("`t_eval` must be 1-dimensional.")
            t_eval_list = t_eval.tolist()
        if t_eval_list:
            lo, hi = min(t0, tf), max(t0, tf)
            if min(t_eval_list) < lo or max(t_eval_list) > hi:
                raise ValueError("Values in `t_eval` are not within `t_span`.")
            if tf != t0 and len(t_eval_list) > 1:
                pairs = zip(t_eval_list, t_eval_list[1:])
                if any(b <= a for a, b in pairs) if tf > t0 else any(b >= a for a, b in pairs):
                    raise ValueError("Values in `t_eval` are not properly sorted.")
    evs = [] if events is None else _prepare_events(events, args)
    if first_step is not None and name != "Euler" and float(first_step) > abs(tf - t0):
        # scipy's check (Euler's first_step is its fixed step, not a first guess)
        raise ValueError("`first_step` exceeds bounds.")
    if max_steps is not None:
        max_steps = _count(max_steps, "max_steps")
    if max_step is None or math.isinf(max_step):
        max_step = math.inf

    common = (
        None if first_step is None else float(first_step),
        float(max_step),
        None if fixed_step is None else float(fixed_step),
        None if t_eval_list is None or len(t_eval_list) == 0 else t_eval_list,
        bool(dense_output),
        evs,
        max_steps,
    )
    result = OdeResult(_RESULT_FIELDS)
    if model is not None:
        _solve_traced(model, t0, tf, y0.tolist(), name, rtol_v, atol_v, *common, result)
    else:
        if name in _DENSE_JACOBIAN:
            _refuse_dense(n, name, trace_error)
        _solve(fun, t0, tf, y0.tolist(), name, rtol_v, atol_v, jac, *common, result)
    status = result["status"]
    if t_eval_list is not None and status >= 0:
        if not t_eval_list:
            result["t"], result["y"] = result["t"][:0], result["y"][:, :0]
        elif status == 1:
            # reckon keeps the stop point after the output times reached; scipy does not
            t_stop = result["t"][-1]
            reached = int(np.sum((np.asarray(t_eval_list) - t_stop) * np.sign(tf - t0) <= 0))
            result["t"], result["y"] = result["t"][:reached], result["y"][:, :reached]
    result["traced"] = model is not None
    result["trace_error"] = trace_error
    return result


del _errors


def odometry(
    t: Any,
    left: Any,
    right: Any,
    *,
    wheel_diameter: float,
    wheel_separation: float,
    pulses_per_rev: float,
    update: str = "midpoint",
) -> np.ndarray:
    """Differential-drive dead reckoning from wheel-encoder pulse increments.

    Per sample k: wheel distances ``d = n·πD/N`` (D ``wheel_diameter``, N
    ``pulses_per_rev``), ``Δs = (d_l + d_r)/2``, ``Δθ = (d_r − d_l)/B`` (B
    ``wheel_separation``), and the pose advanced by ``update``: ``"exact"`` (the circular
    arc, ``Δs·sinc(Δθ/2)`` along ``θ + Δθ/2``: exact when the wheel speeds are constant
    over the sample), ``"midpoint"`` (``Δs`` along ``θ + Δθ/2``) or ``"euler"`` (``Δs``
    along ``θ``). The pose before the first sample's increments is ``(0, 0, 0)``.

    ``t``, ``left``, ``right``: 1-d arrays of one length (``left[k]``, ``right[k]`` the
    pulses counted up to ``t[k]``, increasing). Returns the poses after each sample, shape
    ``(3, len(t))`` (rows x, y, θ; θ unwrapped), as ``solve_ivp``'s ``y``.

    Errors: ``reckon.InvalidInput`` for a non-positive or non-finite geometry, arrays of
    other shapes, non-finite samples or times that do not increase.

    >>> import numpy as np, reckon
    >>> p = reckon.odometry([0.0, 1.0], [0, 1000], [0, 1000], wheel_diameter=0.2,
    ...                     wheel_separation=0.5, pulses_per_rev=1000, update="exact")
    >>> bool(abs(p[0, 1] - 0.2 * np.pi) < 1e-15)
    True
    """
    arrays = []
    for what, v in (("t", t), ("left", left), ("right", right)):
        try:
            a = np.ascontiguousarray(np.asarray(v, dtype=float))
        except (TypeError, ValueError) as e:
            raise InvalidInput(f"invalid {what}: {e}", what=what, reason=str(e)) from None
        if a.ndim != 1:
            reason = f"a 1-d array is needed, got shape {a.shape}"
            raise InvalidInput(f"invalid {what}: {reason}", what=what, reason=reason)
        arrays.append(a)
    ts, ls, rs = arrays
    return _odometry(
        ts, ls, rs, float(wheel_diameter), float(wheel_separation), float(pulses_per_rev), str(update)
    )

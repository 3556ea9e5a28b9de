"""Monte-Carlo ensembles: ``reckon.Ensemble`` (of a traced model), ``reckon.EncoderEnsemble``
and their ``reckon.Statistics``.

Member ``i`` of an ensemble with master seed ``s`` draws only from the generator seeded
with ``splitmix64(s + (i + 1)·0x9E3779B97F4A7C15)``, and the statistics are exact sums,
so a run gives the same bits on any number of threads, and shards ``K/N`` (members
``K, K+N, K+2N, …``) merged in any order give the same bits as one run of all members.
"""

from __future__ import annotations

import hashlib
import operator
from typing import Any

import numpy as np

from ._errors import InvalidInput
from ._reckon import Statistics
from ._reckon import encoder_plan as _encoder_plan
from ._reckon import encoder_run as _encoder_run
from ._reckon import model_run as _model_run

__all__ = ["EncoderEnsemble", "Ensemble", "Statistics"]

_U64 = 2**64 - 1
#: reckon::ensemble::MAX_THREADS
MAX_THREADS = 1024


def _invalid(what: str, reason: str) -> InvalidInput:
    return InvalidInput(f"invalid {what}: {reason}", what=what, reason=reason)


def _whole(what: str, value: Any, lo: int, hi: int) -> int:
    """``value`` as an int in ``[lo, hi]`` (an int or numpy integer; not a bool or float)."""
    if isinstance(value, (bool, np.bool_)):
        raise _invalid(what, f"{value!r} is not a whole number")
    try:
        v = operator.index(value)
    except TypeError:
        raise _invalid(what, f"{value!r} is not a whole number") from None
    if not lo <= v <= hi:
        raise _invalid(what, f"{v}: need {lo} to {hi}")
    return v


def _real(what: str, value: Any) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise _invalid(what, f"{value!r} is not a number")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise _invalid(what, f"{value!r} is not a number") from None


def _shard(shard: Any) -> tuple[int, int]:
    try:
        k, n = shard
    except (TypeError, ValueError):
        raise _invalid("shard", f"{shard!r} is not a pair (K, N)") from None
    n = _whole("shard", n, 1, _U64)
    k = _whole("shard", k, 0, _U64)
    if k >= n:
        raise _invalid("shard", f"{k}/{n}: need 0 ≤ K < N (shards are numbered from 0)")
    return k, n


def _statistics_from_json(text: str) -> Statistics:
    """Unpickling a ``Statistics`` (its ``__reduce__``)."""
    return Statistics.from_json(text)


class EncoderEnsemble:
    """Noisy differential-drive robots driving the same commands, each dead-reckoning its
    own encoder counts with the nominal geometry; the statistics are those of the
    odometry error ``odometry − truth`` (columns ``ex``, ``ey``, ``etheta`` with mean and
    covariance, and ``radial = √(ex² + ey²)`` with quantiles) at the end of every
    ``save_every``-th command and of the last (at most 200 saved times by default).

    ``commands`` is an ``(m, 3)`` array of rows ``(v, omega, duration)``; the robot
    samples its encoders every ``dt``. Each member draws its wheel diameters
    ``left_scale·(1 + diameter_sigma·N)``, ``right_scale·(1 + diameter_sigma·N)`` and
    wheelbase ``wheelbase_scale·(1 + wheelbase_sigma·N)``, loses ``|N(0, slip)|`` of each
    wheel's travel per sample and counts pulses with white noise ``pulse_noise``
    (whole pulses only with ``quantize``); ``update`` is the odometry rule
    (``"exact"``, ``"midpoint"``, ``"euler"``). Everything is checked here
    (``reckon.InvalidInput``); ``run`` only runs.

    >>> import reckon
    >>> drive = reckon.EncoderEnsemble([(1.0, 0.0, 10.0)], 0.01, wheel_diameter=0.1,
    ...                                wheel_separation=0.5, pulses_per_rev=1000, pulse_noise=2.0)
    >>> s = drive.run(2000, seed=3)
    >>> # heading error after n = 1000 samples: σ² = n·2(σ_p·k)²/b², k = π·0.1/1000 m per pulse
    >>> k = 3.141592653589793 * 0.1 / 1000
    >>> bool(abs(s.covariance(0)[2, 2] / (1000 * 2 * (2 * k) ** 2 / 0.25) - 1) < 0.1)
    True
    """

    def __init__(
        self,
        commands: Any,
        dt: float,
        *,
        wheel_diameter: float,
        wheel_separation: float,
        pulses_per_rev: float,
        left_scale: float = 1.0,
        right_scale: float = 1.0,
        wheelbase_scale: float = 1.0,
        slip: float = 0.0,
        pulse_noise: float = 0.0,
        quantize: bool = False,
        diameter_sigma: float = 0.0,
        wheelbase_sigma: float = 0.0,
        update: str = "exact",
        save_every: int | None = None,
    ) -> None:
        try:
            rows = np.asarray(commands, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise _invalid("commands", f"not an array of numbers ({e})") from None
        if rows.ndim != 2 or rows.shape[1] != 3 or rows.shape[0] == 0:
            raise _invalid(
                "commands", f"shape {rows.shape}: need (m, 3) rows of (v, omega, duration), m ≥ 1"
            )
        if not isinstance(quantize, (bool, np.bool_)):
            raise _invalid("quantize", f"{quantize!r} is not True or False")
        if not isinstance(update, str):
            raise _invalid("update", f"{update!r} is not one of 'exact', 'midpoint', 'euler'")
        every = None if save_every is None else _whole("save_every", save_every, 1, 2**63 - 1)
        reals = {
            name: _real(name, value)
            for name, value in [
                ("dt", dt), ("wheel_diameter", wheel_diameter),
                ("wheel_separation", wheel_separation), ("pulses_per_rev", pulses_per_rev),
                ("left_scale", left_scale), ("right_scale", right_scale),
                ("wheelbase_scale", wheelbase_scale), ("slip", slip), ("pulse_noise", pulse_noise),
                ("diameter_sigma", diameter_sigma), ("wheelbase_sigma", wheelbase_sigma),
            ]
        }
        self._spec = dict(
            commands=[tuple(r) for r in rows.tolist()], quantize=bool(quantize), update=update,
            save_every=every, **reals,
        )
        job, times, samples = _encoder_plan(self._spec)
        #: What is run (every input that changes a member): shards merge only with equal jobs.
        self.job: str = job
        #: The saved times (the ends of the saved commands, from t = 0).
        self.times = np.array(times)
        #: Encoder samples each member drives.
        self.samples_per_member: float = samples

    def run(self, members: int, seed: int = 0, *, shard: tuple[int, int] = (0, 1),
            threads: int | None = None) -> Statistics:
        """Run the members ``K, K+N, …`` of shard ``shard = (K, N)`` of ``members``
        members from master seed ``seed`` (0 to 2⁶⁴ − 1) on ``threads`` threads
        (default: one per core), the GIL released; the same bits for any ``threads``.
        A member that fails raises ``reckon.EnsembleMember`` (its index and seed)."""
        members = _whole("members", members, 1, _U64)
        seed = _whole("seed", seed, 0, _U64)
        k, n = _shard(shard)
        if threads is not None:
            threads = _whole("threads", threads, 1, MAX_THREADS)
        return _encoder_run(self._spec, members, seed, (k, n), threads)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, EncoderEnsemble) and other._spec == self._spec

    def __hash__(self) -> int:
        return hash(self.job)

    def __repr__(self) -> str:
        return (
            f"EncoderEnsemble({len(self._spec['commands'])} commands, dt={self._spec['dt']!r}, "
            f"{len(self.times)} saved times, {self.samples_per_member:g} samples per member)"
        )


#: The methods an ``Ensemble`` member may use (``reckon.solve_ivp``'s native methods).
ENSEMBLE_METHODS = ("RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "ExponentialEuler", "Euler")


def _vector(what: str, value: Any, length: int | None = None) -> np.ndarray:
    """``value`` as a 1-d array of finite floats (of ``length`` values if given)."""
    if isinstance(value, (bool, np.bool_)):
        raise _invalid(what, f"{value!r} is not a number")
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise _invalid(what, f"not an array of numbers ({e})") from None
    if a.ndim > 1:
        raise _invalid(what, f"shape {a.shape}: a 1-d array is needed")
    a = a.reshape(-1)
    if length is not None and a.size != length:
        raise _invalid(what, f"{a.size} values, expected {length}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise _invalid(what, f"value {int(bad[0])} is {a[bad[0]]} (not finite)")
    return a


def _sigma(what: str, value: Any, length: int) -> np.ndarray:
    """Standard deviations: a scalar for every component or one per component, ≥ 0."""
    a = _vector(what, value)
    if a.size == 1:
        a = np.full(length, a[0])
    if a.size != length:
        raise _invalid(what, f"{a.size} values: need one, or {length} (one per component)")
    if (a < 0).any():
        raise _invalid(what, f"value {int(np.argmax(a < 0))} is {a[a < 0][0]}: a standard deviation is ≥ 0")
    return a


def _cov_factor(cov: Any, size: int) -> np.ndarray:
    """``F`` with ``F·Fᵀ = cov`` for a symmetric positive semi-definite ``cov`` of shape
    ``(size, size)``: its Cholesky factor, or ``V·√Λ`` from its eigenvalues when it is
    singular. ``reckon.InvalidInput`` (``what = "cov"``) otherwise."""
    try:
        c = np.asarray(cov, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise _invalid("cov", f"not an array of numbers ({e})") from None
    if c.shape != (size, size):
        raise _invalid("cov", f"shape {c.shape}: need ({size}, {size}) for the {size} perturbed values (y0, then params)")
    if not np.isfinite(c).all():
        raise _invalid("cov", "an entry is not finite")
    scale = float(np.abs(c).max()) if c.size else 0.0
    asym = float(np.abs(c - c.T).max()) if c.size else 0.0
    if asym > 1e-12 * scale:
        raise _invalid("cov", f"not symmetric: |C − Cᵀ| reaches {asym:g} (of entries up to {scale:g})")
    c = (c + c.T) / 2
    lam, v = np.linalg.eigh(c)
    if lam.size and lam.min() < -1e-10 * max(abs(lam).max(), 1e-300):
        raise _invalid("cov", f"not positive semi-definite: eigenvalue {lam.min():g} (largest {lam.max():g})")
    try:
        return np.linalg.cholesky(c)
    except np.linalg.LinAlgError:
        return v * np.sqrt(np.clip(lam, 0.0, None))


class Ensemble:
    """A Monte-Carlo ensemble of a traced model ``y' = fun(t, y, *params, *args)``:
    member ``i`` starts from ``(y₀, p) = (y0, params) + F·ξᵢ`` with ``F·Fᵀ = Σ`` and
    ``ξᵢ ~ N(0, I)`` drawn from member ``i``'s own seeded generator, and is integrated
    from ``t_span[0]`` to ``t_span[1]``; the statistics (``reckon.Statistics``: the exact
    count, mean and covariance of ``y`` and quantile sketches of each ``yⱼ``, columns
    ``y0, y1, …``) are taken at the times ``t_eval`` (default: ``t_span[1]`` only).

    ``Σ`` is ``diag(y0_sigma², params_sigma²)`` (each a scalar for every component or one
    standard deviation per component; 0 by default) or the joint covariance ``cov`` of
    ``(y0, params)`` (symmetric positive semi-definite, shape ``(n + n_p, n + n_p)``).
    ``fun`` is traced once, as ``reckon.Model`` traces it, with the parameters as extra
    states of zero derivative (``reckon.sensitivities``' model), so every member runs as
    compiled code with the exact Jacobian, the GIL released, the members spread over
    threads; ``args`` are passed to ``fun`` as they are. A ``fun`` that cannot be traced
    raises ``reckon.Untraceable``: ensembles never call Python back (a per-member Python
    callback would hold the GIL on every step), so there is no callback fallback.
    ``method``, ``rtol``, ``atol``, ``first_step``, ``max_step`` and ``max_steps`` mean
    what they mean for ``reckon.solve_ivp``.

    Member ``i``'s draws depend only on ``seed`` and ``i``, and the statistics are exact
    sums: ``run`` gives the same bits on any number of threads, and shards ``K/N`` merged
    in any order (``Statistics.merge``, ``reckon.dask.ensemble``) give the bits of one run.
    Every input is checked here (``reckon.InvalidInput``); a member that fails raises
    ``reckon.EnsembleMember`` (its index, seed and reason) from ``run``.

    >>> import numpy as np, reckon
    >>> # x' = −k·x, x₀ ~ N(2, 0.1²), k = 0.5: x(t) ~ N(2e^{−kt}, 0.1²e^{−2kt})
    >>> ens = reckon.Ensemble(lambda t, y, k: -k * y, (0, 2), [2.0], params=[0.5],
    ...                       y0_sigma=0.1, t_eval=[1.0, 2.0], rtol=1e-10, atol=1e-12)
    >>> s = ens.run(20_000, seed=1)
    >>> m, v = s.mean(1)[0], s.covariance(1)[0, 0]
    >>> bool(abs(m - 2 * np.exp(-1)) < 4 * 0.1 * np.exp(-1) / np.sqrt(20_000))
    True
    >>> bool(abs(v / (0.01 * np.exp(-2)) - 1) < 4 * np.sqrt(2 / 20_000))
    True
    """

    def __init__(
        self,
        fun: Any,
        t_span: Any,
        y0: Any,
        *,
        params: Any = (),
        args: tuple = (),
        y0_sigma: Any = None,
        params_sigma: Any = None,
        cov: Any = None,
        t_eval: Any = None,
        method: str = "RK45",
        rtol: Any = 1e-3,
        atol: Any = 1e-6,
        first_step: float | None = None,
        max_step: float = np.inf,
        max_steps: int | None = None,
    ) -> None:
        if not callable(fun):
            raise TypeError("fun must be callable as fun(t, y, *params, *args)")
        span = _vector("t_span", t_span)
        if span.size != 2 or span[0] == span[1]:
            raise _invalid("t_span", f"{span.tolist()}: need two different times (t0, t1)")
        t0, t1 = float(span[0]), float(span[1])
        y = _vector("y0", y0)
        if y.size == 0:
            raise _invalid("y0", "at least one state is needed")
        p = _vector("params", params)
        n, n_p = y.size, p.size
        if cov is not None:
            if y0_sigma is not None or params_sigma is not None:
                raise _invalid("cov", "give cov or y0_sigma/params_sigma, not both")
            factor = _cov_factor(cov, n + n_p)
        else:
            sig = _sigma("y0_sigma", 0.0 if y0_sigma is None else y0_sigma, n)
            if params_sigma is not None and n_p == 0:
                raise _invalid("params_sigma", "the model has no params to perturb")
            psig = _sigma("params_sigma", 0.0 if params_sigma is None else params_sigma, n_p)
            factor = np.diag(np.concatenate([sig, psig]))
        times = _vector("t_eval", [t1] if t_eval is None else t_eval)
        if times.size == 0:
            raise _invalid("t_eval", "at least one time is needed")
        lo, hi = min(t0, t1), max(t0, t1)
        if ((times < lo) | (times > hi)).any():
            bad = times[(times < lo) | (times > hi)][0]
            raise _invalid("t_eval", f"{bad} is outside t_span [{t0}, {t1}]")
        step = np.diff(times) * (1 if t1 > t0 else -1)
        if (step <= 0).any():
            raise _invalid("t_eval", "times must be distinct and sorted in the direction of integration")
        if not isinstance(method, str) or method not in ENSEMBLE_METHODS:
            raise _invalid("method", f"{method!r} is not one of {', '.join(ENSEMBLE_METHODS)}")
        tols = {}
        for name, value in (("rtol", rtol), ("atol", atol)):
            v = _vector(name, value)
            if v.size not in (1, n):
                raise _invalid(name, f"{v.size} values: need one, or {n} (one per state)")
            if (v <= 0).any():
                raise _invalid(name, f"{v[v <= 0][0]}: tolerances are > 0")
            # the parameters are states too, constant: any tolerance holds them
            tols[name] = v.tolist() if v.size == 1 else v.tolist() + [float(v.max())] * n_p
        if first_step is not None:
            first_step = _real("first_step", first_step)
            if not (np.isfinite(first_step) and first_step > 0):
                raise _invalid("first_step", f"{first_step}: need a finite step > 0")
        elif method == "Euler":
            raise _invalid("first_step", 'method="Euler" takes fixed steps: give the step as first_step=h')
        max_step = _real("max_step", max_step)
        if not max_step > 0:
            raise _invalid("max_step", f"{max_step}: need > 0")
        if max_steps is not None:
            max_steps = _whole("max_steps", max_steps, 1, 2**63 - 1)
        self._state = dict(
            fun=fun, args=tuple(args), n=n, n_p=n_p, t0=t0, t1=t1,
            mean=np.concatenate([y, p]).tolist(), factor=factor.reshape(-1).tolist(),
            times=times.tolist(), method=method, rtol=tols["rtol"], atol=tols["atol"],
            first_step=first_step, max_step=max_step, max_steps=max_steps,
        )
        self._trace()

    def _trace(self) -> None:
        from ._sensitivity import _traced

        s = self._state
        #: The traced model of ``(y, p)``: ``(fun, 0)``.
        self.model = _traced(s["fun"], s["n"], s["n_p"], s["args"])
        what = repr((
            self.model.text(), s["n"], s["mean"], s["factor"], s["t0"], s["t1"], s["times"],
            s["method"], s["rtol"], s["atol"], s["first_step"], s["max_step"], s["max_steps"],
        ))
        digest = hashlib.sha256(what.encode()).hexdigest()[:16]
        name = getattr(s["fun"], "__qualname__", "fun")
        #: What is run (the traced equations and every option, hashed): shards merge only
        #: with equal jobs.
        self.job: str = (
            f"traced model {name} ({s['n']} states, {s['n_p']} params, {s['method']}); {digest}"
        )

    @property
    def n(self) -> int:
        """The number of states ``y`` (the statistics' columns)."""
        return self._state["n"]

    @property
    def times(self) -> np.ndarray:
        """The saved times ``t_eval``."""
        return np.array(self._state["times"])

    @property
    def mean(self) -> np.ndarray:
        """The centre ``(y0, params)`` of the draws."""
        return np.array(self._state["mean"])

    @property
    def cov(self) -> np.ndarray:
        """The covariance ``Σ = F·Fᵀ`` of the draws of ``(y0, params)``."""
        k = len(self._state["mean"])
        f = np.array(self._state["factor"]).reshape(k, k)
        return f @ f.T

    def run(self, members: int, seed: int = 0, *, shard: tuple[int, int] = (0, 1),
            threads: int | None = None) -> Statistics:
        """Run the members ``K, K+N, …`` of shard ``shard = (K, N)`` of ``members``
        members from master seed ``seed`` (0 to 2⁶⁴ − 1) on ``threads`` threads
        (default: one per core), the GIL released; the same bits for any ``threads``.
        A member that fails raises ``reckon.EnsembleMember`` (its index and seed)."""
        members = _whole("members", members, 1, _U64)
        seed = _whole("seed", seed, 0, _U64)
        k, n = _shard(shard)
        if threads is not None:
            threads = _whole("threads", threads, 1, MAX_THREADS)
        s = self._state
        return _model_run(
            self.model, s["n"], s["mean"], s["factor"], s["t0"], s["t1"], s["times"],
            s["method"], s["rtol"], s["atol"], s["first_step"], s["max_step"], s["max_steps"],
            members, seed, (k, n), threads, self.job,
        )

    def __getstate__(self) -> dict:
        # the inputs (fun by cloudpickle, as Dask sends it); traced again when read
        return {"state": self._state, "job": self.job}

    def __setstate__(self, state: dict) -> None:
        self._state = state["state"]
        self._trace()
        if self.job != state["job"]:
            raise _invalid(
                "ensemble",
                f"fun traced to other equations here ({self.job}) than where it was made "
                f"({state['job']}): its globals or closure differ",
            )

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Ensemble) and other.job == self.job

    def __hash__(self) -> int:
        return hash(self.job)

    def __repr__(self) -> str:
        s = self._state
        return (
            f"Ensemble({getattr(s['fun'], '__qualname__', 'fun')}, {s['n']} states, "
            f"{s['n_p']} params, t_span=({s['t0']!r}, {s['t1']!r}), "
            f"{len(s['times'])} saved times, method={s['method']!r})"
        )

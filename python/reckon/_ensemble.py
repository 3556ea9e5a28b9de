"""Monte-Carlo ensembles: ``reckon.EncoderEnsemble`` and its ``reckon.Statistics``.

Member ``i`` of an ensemble with master seed ``s`` draws only from the generator seeded
with ``splitmix64(s + (i + 1)·0x9E3779B97F4A7C15)``, and the statistics are exact sums,
so a run gives the same bits on any number of threads, and shards ``K/N`` (members
``K, K+N, K+2N, …``) merged in any order give the same bits as one run of all members.
"""

from __future__ import annotations

import operator
from typing import Any

import numpy as np

from ._errors import InvalidInput
from ._reckon import Statistics
from ._reckon import encoder_plan as _encoder_plan
from ._reckon import encoder_run as _encoder_run

__all__ = ["EncoderEnsemble", "Statistics"]

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

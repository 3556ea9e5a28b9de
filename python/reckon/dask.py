"""Monte-Carlo ensembles spread over a Dask cluster (``pip install 'reckon[dask]'``).

One task per shard ``K/N``: each runs members ``K, K+N, K+2N, …`` in Rust on its
worker's threads (the GIL released) and returns the shard's statistics as JSON (a few
kilobytes per saved time, whatever the number of members); the client merges them
exactly. A member's random numbers depend only on the master seed and its index, so a
shard gives the same bytes on any worker, however often it is run: a shard lost with its
worker is run again by the scheduler (up to ``distributed.scheduler.allowed-failures``
times, default 3) and a shard that raised is retried ``retries`` times, and the merged
result is bit for bit what one call of ``run`` on all members gives. Either kind of
ensemble runs: ``reckon.Ensemble`` (a traced model of the user's; sent to the workers
with its function, by cloudpickle, and traced again there, the equations checked equal)
and ``reckon.EncoderEnsemble``.

>>> import distributed, reckon, reckon.dask
>>> drive = reckon.EncoderEnsemble([(1.0, 0.0, 5.0), (1.0, 0.5, 5.0)], 0.01, wheel_diameter=0.1,
...                                wheel_separation=0.5, pulses_per_rev=1000, pulse_noise=2.0)
>>> with distributed.Client(processes=False, n_workers=2, threads_per_worker=1,
...                          dashboard_address=":0") as client:
...     stats = reckon.dask.ensemble(client, drive, members=2000, seed=7, shards=4)
>>> whole = drive.run(2000, seed=7)
>>> bool((stats.mean(1) == whole.mean(1)).all() and (stats.covariance(1) == whole.covariance(1)).all())
True
"""

from __future__ import annotations

import hashlib
from typing import Any

try:
    import distributed
except ImportError as e:  # pragma: no cover - the message is the point
    raise ImportError(
        "reckon.dask needs Dask's distributed scheduler: pip install 'reckon[dask]' "
        "(or 'dask[distributed]')"
    ) from e

from ._ensemble import _U64, MAX_THREADS, EncoderEnsemble, Ensemble, Statistics, _invalid, _whole

__all__ = ["ensemble", "encoder_ensemble", "submit", "gather"]

AnyEnsemble = Ensemble | EncoderEnsemble


def _run_shard(ensemble: AnyEnsemble, members: int, seed: int, k: int, n: int,
               threads: int | None) -> str:
    """The task: shard ``k/n`` on ``threads`` threads (default: the worker's ``nthreads``),
    its statistics as JSON."""
    if threads is None:
        try:
            threads = distributed.get_worker().state.nthreads
        except ValueError:  # not on a worker (a synchronous scheduler): every core
            threads = None
    return ensemble.run(members, seed, shard=(k, n), threads=threads).to_json()


def submit(client: distributed.Client, ensemble: AnyEnsemble, members: int, seed: int = 0,
           *, shards: int | None = None, threads: int | None = None,
           retries: int = 3) -> list[distributed.Future]:
    """Submit shards ``0/N … (N−1)/N`` of ``ensemble`` (a ``reckon.Ensemble`` or
    ``reckon.EncoderEnsemble``; ``N = shards``, default: one per
    worker) as ``N`` tasks, each returning its shard's statistics as JSON; ``gather``
    merges them. A task's key names the job, members, seed and shard, so the same shard
    submitted twice is computed once. ``threads`` per task defaults to the worker's
    ``nthreads``; ``retries`` is Dask's count of reruns of a task that raised."""
    if not isinstance(ensemble, (Ensemble, EncoderEnsemble)):
        raise TypeError(
            f"ensemble must be a reckon.Ensemble or reckon.EncoderEnsemble, not {type(ensemble).__name__}"
        )
    members = _whole("members", members, 1, _U64)
    seed = _whole("seed", seed, 0, _U64)
    if shards is None:
        workers = len(client.scheduler_info().get("workers", {}))
        shards = max(1, min(workers, members))
    n = _whole("shards", shards, 1, _U64)
    if n > members:
        raise _invalid("shards", f"{n} shards of {members} members: some would be empty")
    if threads is not None:
        threads = _whole("threads", threads, 1, MAX_THREADS)
    retries = _whole("retries", retries, 0, 1000)
    # the result depends on these only (not on threads or workers)
    kind = "model" if isinstance(ensemble, Ensemble) else "encoder"
    ident = hashlib.sha256(f"{ensemble.job}|{members}|{seed}|{n}".encode()).hexdigest()[:16]
    return [
        client.submit(_run_shard, ensemble, members, seed, k, n, threads,
                      key=f"reckon-{kind}-{ident}-{k}of{n}", retries=retries)
        for k in range(n)
    ]


def gather(futures: list[Any]) -> Statistics:
    """Merge the shards' statistics as they finish (exactly, so the order does not
    matter); raises the first task's exception, or ``reckon.InvalidInput`` when the
    shards do not make one whole ensemble."""
    if not futures:
        raise _invalid("futures", "none to gather")
    merged: Statistics | None = None
    first = futures[0]
    loop = first.client.loop if isinstance(first, distributed.Future) else None
    for future in distributed.as_completed(futures, loop=loop):
        part = Statistics.from_json(future.result())
        merged = part if merged is None else merged.merge(part)
    assert merged is not None
    if not merged.complete:
        raise _invalid(
            "futures",
            f"shards {merged.shards} of {merged.shard_count}: not the whole ensemble",
        )
    return merged


def ensemble(client: distributed.Client, ensemble: AnyEnsemble, members: int, seed: int = 0,
             *, shards: int | None = None, threads: int | None = None,
             retries: int = 3) -> Statistics:
    """``members`` members of ``ensemble`` (a ``reckon.Ensemble`` or
    ``reckon.EncoderEnsemble``) from master seed ``seed``, in ``shards`` tasks on the
    cluster of ``client`` (see ``submit``), merged: the same bits as
    ``ensemble.run(members, seed)``."""
    return gather(submit(client, ensemble, members, seed, shards=shards, threads=threads,
                         retries=retries))


def encoder_ensemble(client: distributed.Client, ensemble: EncoderEnsemble, members: int,
                     seed: int = 0, *, shards: int | None = None, threads: int | None = None,
                     retries: int = 3) -> Statistics:
    """The same as ``reckon.dask.ensemble`` (its first name, for the encoder ensemble)."""
    return gather(submit(client, ensemble, members, seed, shards=shards, threads=threads,
                         retries=retries))

"""reckon.dask: an ensemble spread over a 2-process LocalCluster gives the same bits as
one call, even when a worker is killed in the middle of the run."""

import doctest
import json
import os
import signal
import time

import pytest

import reckon

distributed = pytest.importorskip("distributed")
import reckon.dask  # noqa: E402

DRIVE = reckon.EncoderEnsemble(
    [(1.0, 0.0, 5.0), (1.0, 0.5, 3.0), (0.8, -0.2, 5.0)], 0.01, wheel_diameter=0.1,
    wheel_separation=0.5, pulses_per_rev=1000, pulse_noise=2.0, slip=0.002,
    diameter_sigma=1e-3, wheelbase_sigma=1e-3,
)
MEMBERS, SEED = 8000, 20261207


def snapshots(s):
    """Everything but which shards: layout, counts, exact sums, sketches."""
    d = json.loads(s.to_json())
    del d["shard_count"], d["shards"]
    return d


def assert_same_bits(a, b):
    assert snapshots(a) == snapshots(b)
    for k in range(len(a.times)):
        assert (a.mean(k) == b.mean(k)).all()
        assert (a.covariance(k) == b.covariance(k)).all()
        for q in (0.5, 0.99):
            assert a.quantile(k, "radial", q) == b.quantile(k, "radial", q)


@pytest.fixture(scope="module")
def whole():
    return DRIVE.run(MEMBERS, SEED)


@pytest.fixture(scope="module")
def four():
    parts = [DRIVE.run(MEMBERS, SEED, shard=(k, 4)) for k in range(4)]
    return parts[0].merge(parts[1]).merge(parts[2]).merge(parts[3])


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as c:
            yield c


def test_dask_equals_one_call(client, whole, four):
    s = reckon.dask.encoder_ensemble(client, DRIVE, MEMBERS, SEED)
    # one shard per worker by default
    assert (s.shard_count, s.shards, s.count) == (2, [0, 1], MEMBERS)
    halves = [DRIVE.run(MEMBERS, SEED, shard=(k, 2)) for k in range(2)]
    assert s.to_json() == halves[1].merge(halves[0]).to_json()
    assert_same_bits(s, whole)
    s4 = reckon.dask.encoder_ensemble(client, DRIVE, MEMBERS, SEED, shards=4, threads=1)
    assert s4.to_json() == four.to_json()
    assert_same_bits(s4, whole)


def test_futures_merged_in_any_order(client, four):
    futures = reckon.dask.submit(client, DRIVE, MEMBERS, SEED, shards=4)
    parts = [reckon.Statistics.from_json(f.result()) for f in futures]
    assert [p.shards for p in parts] == [[0], [1], [2], [3]]
    for order in ([3, 2, 1, 0], [2, 0, 3, 1]):
        acc = parts[order[0]]
        for k in order[1:]:
            acc = acc.merge(parts[k])
        assert acc.to_json() == four.to_json()
    assert reckon.dask.gather(futures) == four


def test_a_shard_gathered_twice_is_refused(client):
    futures = reckon.dask.submit(client, DRIVE, 100, SEED, shards=2)
    with pytest.raises(reckon.InvalidInput, match="shard 1/2 is counted twice"):
        reckon.dask.gather(futures + futures[1:])
    with pytest.raises(reckon.InvalidInput, match=r"shards \[0\] of 2: not the whole"):
        reckon.dask.gather(futures[:1])


def test_bad_arguments(client):
    cases = [
        ({"members": 0}, "members"),
        ({"seed": -1}, "seed"),
        ({"shards": 0}, "shards"),
        ({"shards": 11}, "shards"),  # more shards than the 10 members
        ({"threads": 0}, "threads"),
        ({"retries": -1}, "retries"),
    ]
    for change, what in cases:
        args = {"members": 10, "seed": 0, **change}
        with pytest.raises(reckon.InvalidInput) as e:
            reckon.dask.encoder_ensemble(client, DRIVE, **args)
        assert e.value.what == what, change
    with pytest.raises(TypeError, match="reckon.EncoderEnsemble"):
        reckon.dask.encoder_ensemble(client, "unicycle", 10)
    with pytest.raises(reckon.InvalidInput, match="none to gather"):
        reckon.dask.gather([])


def test_doc_example():
    assert doctest.testmod(reckon.dask, raise_on_error=False).failed == 0


def test_a_worker_killed_during_the_run(client, four):
    # last: the nanny restarts the killed worker, but the cluster has been through a lot
    futures = reckon.dask.submit(client, DRIVE, MEMBERS, SEED + 1, shards=4)
    deadline = time.monotonic() + 20
    busy = []
    while not busy and time.monotonic() < deadline:
        busy = [w for w, keys in client.processing().items() if keys]
        time.sleep(0.01)
    assert busy, "no worker took a shard"
    victim = busy[0]
    pid = client.run(os.getpid, workers=[victim])[victim]
    os.kill(pid, signal.SIGKILL)
    s = reckon.dask.gather(futures)
    # the scheduler saw the worker die holding a shard, and ran it again
    lost = client.run_on_scheduler(
        lambda dask_scheduler: sum(
            ts.suspicious for key, ts in dask_scheduler.tasks.items()
            if str(key).startswith("reckon-encoder-")
        )
    )
    assert lost >= 1
    parts = [DRIVE.run(MEMBERS, SEED + 1, shard=(k, 4)) for k in range(4)]
    assert s.to_json() == parts[0].merge(parts[1]).merge(parts[2]).merge(parts[3]).to_json()
    assert_same_bits(s, DRIVE.run(MEMBERS, SEED + 1))

"""reckon.EncoderEnsemble and reckon.Statistics: closed forms, exact shards, errors."""

import doctest
import itertools
import json
import math
import pickle

import numpy as np
import pytest

import reckon
import reckon._ensemble

B, D, PPR = 0.5, 0.1, 1000.0
K = math.pi * D / PPR  # metres per pulse
SIGMA_P = 2.0  # pulses per sample


def noisy(**kw):
    return reckon.EncoderEnsemble(
        [(1.0, 0.0, 10.0)], 0.01, wheel_diameter=D, wheel_separation=B, pulses_per_rev=PPR,
        pulse_noise=SIGMA_P, **kw
    )


def snapshots(s):
    """Everything but which shards: layout, counts, exact sums, sketches."""
    d = json.loads(s.to_json())
    del d["shard_count"], d["shards"]
    return d


def test_straight_line_pulse_noise_closed_forms():
    # n samples of white pulse noise on each wheel, q = (σ_p·k)² per wheel travel, so
    # per sample var(δs) = q/2 and var(δθ) = qθ = 2q/b², independent. The heading error
    # θ_j (at the midpoint of sample j) is a random walk, cov(θ_i, θ_j) ≈ (min(i, j) − ½)·qθ:
    # eθ = Σ δθ:                 var = n·qθ
    # ey ≈ v·dt·Σ θ_j:           var = qθ·(v·dt)²·Σ (n − j + ½)²
    # ex ≈ Σ δs − v·dt·Σ θ_j²/2: mean = −(v·dt/2)·qθ·n²/2,
    #                            var = n·q/2 + (v·dt)²/2·qθ²·Σᵢⱼ (min(i, j) − ½)²
    n, members, vdt = 1000, 4000, 0.01
    s = noisy().run(members, seed=11)
    assert s.count == members and list(s.times) == [10.0]
    q = (SIGMA_P * K) ** 2
    qth = 2 * q / B**2
    j = np.arange(1, n + 1)
    var_ey = qth * vdt**2 * np.sum((n - j + 0.5) ** 2)
    var_ex = n * q / 2 + vdt**2 / 2 * qth**2 * np.sum((np.minimum.outer(j, j) - 0.5) ** 2)
    mean_ex = -vdt / 2 * qth * n**2 / 2
    c, m = s.covariance(0), s.mean(0)
    # the sample variance's relative sd is about √(2/members) = 2.2 %: 10 % is 4.5 sd
    assert c[2, 2] / (n * qth) == pytest.approx(1, abs=0.1)
    assert c[1, 1] / var_ey == pytest.approx(1, abs=0.1)
    # the second-order term is 30 % of var(ex): leaving it out fails the check
    assert c[0, 0] / var_ex == pytest.approx(1, abs=0.1)
    assert abs(m[0] - mean_ex) < 4 * math.sqrt(var_ex / members)
    for i in (1, 2):  # no bias across or in heading
        assert abs(m[i]) < 4 * math.sqrt(c[i, i] / members)
    # the radial error's median is that of √(ex² + ey²), dominated by ey: ≈ 0.674·sd(ey)
    assert s.quantile(0, "radial", 0.5) == pytest.approx(0.674 * math.sqrt(var_ey), rel=0.1)
    assert s.quantile(-1, 3, 0.5) == s.quantile(0, "radial", 0.5)


def test_threads_and_shards_give_the_same_bits():
    drive = noisy(slip=0.002, diameter_sigma=1e-3, wheelbase_sigma=2e-3, quantize=True)
    one = drive.run(600, seed=5, threads=1)
    assert drive.run(600, seed=5, threads=2) == one
    assert drive.run(600, seed=5, threads=2).to_json() == one.to_json()
    parts = [drive.run(600, seed=5, shard=(k, 4), threads=1) for k in range(4)]
    assert [p.count for p in parts] == [150] * 4
    merged = set()
    for order in itertools.permutations(range(4)):
        acc = parts[order[0]]
        for k in order[1:]:
            acc = acc.merge(parts[k])
        merged.add(acc.to_json())
    tree = parts[3].merge(parts[1]).merge(parts[2].merge(parts[0]))
    merged.add(tree.to_json())
    assert len(merged) == 1
    whole = reckon.Statistics.from_json(merged.pop())
    assert isinstance(whole, reckon.Statistics) and whole.complete and whole.shards == [0, 1, 2, 3]
    assert snapshots(whole) == snapshots(one)
    assert (whole.mean(0) == one.mean(0)).all() and (whole.covariance(0) == one.covariance(0)).all()
    assert not parts[0].complete and parts[0].merge(parts[1]).shards == [0, 1]


def test_json_and_pickle_round_trip():
    s = noisy().run(50, seed=1, shard=(1, 3))
    assert reckon.Statistics.from_json(s.to_json()) == s
    assert pickle.loads(pickle.dumps(s)) == s
    drive = noisy(slip=0.01)
    again = pickle.loads(pickle.dumps(drive))
    assert again == drive and again.job == drive.job
    assert again.run(20, seed=2) == drive.run(20, seed=2)
    assert (s.members, s.seed, s.shard_count, s.shards, s.count) == (50, 1, 3, [1], 17)
    assert s.names == ["ex", "ey", "etheta", "radial"] and s.moments == 3
    assert s.mean(0).shape == (3,) and s.covariance(0).shape == (3, 3)


def test_a_shard_merged_twice_is_refused():
    drive = noisy()
    a, b = (drive.run(40, seed=3, shard=(k, 2)) for k in range(2))
    with pytest.raises(reckon.InvalidInput, match="shard 0/2 is counted twice") as e:
        a.merge(a)
    assert e.value.what == "shards"
    with pytest.raises(reckon.InvalidInput, match="shard 1/2 is counted twice"):
        a.merge(b).merge(b)
    with pytest.raises(reckon.InvalidInput, match="not of one ensemble"):
        a.merge(drive.run(40, seed=4, shard=(1, 2)))
    with pytest.raises(reckon.InvalidInput, match="not of one ensemble"):
        a.merge(noisy(slip=0.01).run(40, seed=3, shard=(1, 2)))
    with pytest.raises(reckon.InvalidInput, match="not of one ensemble"):
        a.merge(drive.run(40, seed=3, shard=(1, 3)))
    with pytest.raises(TypeError, match="reckon.Statistics"):
        a.merge(a.to_json())
    # a file that claims both shards with one shard's counts
    lie = a.to_json().replace('"shards":[0]', '"shards":[0,1]')
    with pytest.raises(reckon.InvalidInput, match="members counted"):
        reckon.Statistics.from_json(lie)
    with pytest.raises(reckon.InvalidInput, match="not JSON"):
        reckon.Statistics.from_json("{")


@pytest.mark.parametrize(
    "kwargs, what",
    [
        ({"members": 0}, "members"),
        ({"members": -1}, "members"),
        ({"members": 2.0}, "members"),
        ({"members": True}, "members"),
        ({"seed": -1}, "seed"),
        ({"seed": 2**64}, "seed"),
        ({"shard": (4, 4)}, "shard"),
        ({"shard": (0, 0)}, "shard"),
        ({"shard": "0/4"}, "shard"),
        ({"threads": 0}, "threads"),
        ({"threads": 5000}, "threads"),
    ],
)
def test_bad_run_arguments(kwargs, what):
    args = {"members": 10, "seed": 0, **kwargs}
    with pytest.raises(reckon.InvalidInput) as e:
        noisy().run(**args)
    assert e.value.what == what


@pytest.mark.parametrize(
    "change, what",
    [
        ({"commands": [(1.0, 0.0)]}, "commands"),
        ({"commands": []}, "commands"),
        ({"commands": [(1.0, 0.0, -1.0)]}, "commands"),
        ({"commands": [(float("nan"), 0.0, 1.0)]}, "commands"),
        ({"dt": 0.0}, "dt"),
        ({"dt": float("inf")}, "dt"),
        ({"dt": 1e-12}, "dt"),  # 10¹³ samples per member
        ({"wheel_diameter": -0.1}, "wheel_diameter"),
        ({"pulses_per_rev": "many"}, "pulses_per_rev"),
        ({"update": "rk4"}, "update"),
        ({"quantize": "yes"}, "quantize"),
        ({"save_every": 0}, "save_every"),
        ({"pulse_noise": -1.0}, "errors"),
        ({"diameter_sigma": 0.7}, "spreads"),
    ],
)
def test_bad_model_arguments(change, what):
    args = {"commands": [(1.0, 0.0, 10.0)], "dt": 0.01, "wheel_diameter": D,
            "wheel_separation": B, "pulses_per_rev": PPR, **change}
    with pytest.raises(reckon.InvalidInput) as e:
        reckon.EncoderEnsemble(args.pop("commands"), args.pop("dt"), **args)
    assert e.value.what == what


def test_bad_statistics_questions():
    s = noisy().run(10, seed=0)
    with pytest.raises(IndexError):
        s.mean(1)
    with pytest.raises(IndexError):
        s.covariance(-2)
    with pytest.raises(IndexError):
        s.quantile(0, 4, 0.5)
    with pytest.raises(reckon.InvalidInput, match="'north' is not one of"):
        s.quantile(0, "north", 0.5)
    with pytest.raises(reckon.InvalidInput, match="need 0 ≤ q ≤ 1"):
        s.quantile(0, "radial", 1.5)
    # more work than one call may take: refused before anything runs
    with pytest.raises(reckon.InvalidInput, match="at most 1e12"):
        noisy().run(2 * 10**9, seed=0)


def test_doc_examples():
    assert doctest.testmod(reckon._ensemble, raise_on_error=False).failed == 0

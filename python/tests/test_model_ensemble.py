"""reckon.Ensemble: Monte-Carlo ensembles of a traced model against closed forms; the
same bits for any threads, shards and a 2-process Dask cluster; typed errors."""

import json
import pickle

import numpy as np
import pytest

import reckon

# x' = −k·x, x₀ ~ N(μ, σ²): x(t) ~ N(μe^{−kt}, σ²e^{−2kt})
MU, SIGMA, K = 2.0, 0.3, 0.7
T = np.array([0.5, 1.0, 2.0])
M = 40_000


def decay(t, y, k):
    return -k * y


def snapshots(s):
    """Everything but which shards: layout, job, counts, exact sums, sketches."""
    d = json.loads(s.to_json())
    del d["shard_count"], d["shards"]
    return d


@pytest.fixture(scope="module")
def x0_ensemble():
    return reckon.Ensemble(decay, (0.0, 2.0), [MU], params=[K], y0_sigma=SIGMA, t_eval=T,
                           rtol=1e-10, atol=1e-12)


@pytest.fixture(scope="module")
def x0_stats(x0_ensemble):
    return x0_ensemble.run(M, seed=11)


def test_gaussian_initial_state_against_closed_form(x0_stats):
    s = x0_stats
    assert (s.count, s.members, s.seed, s.names, s.moments) == (M, M, 11, ["y0"], 1)
    assert (s.times == T).all()
    for k, t in enumerate(T):
        mean, var = MU * np.exp(-K * t), SIGMA**2 * np.exp(-2 * K * t)
        se_mean = np.sqrt(var / M)
        se_var = var * np.sqrt(2 / (M - 1))  # Gaussian: Var(s²) = 2σ⁴/(M−1)
        assert abs(s.mean(k)[0] - mean) < 4 * se_mean, (t, s.mean(k)[0], mean)
        assert abs(s.covariance(k)[0, 0] - var) < 4 * se_var, (t, s.covariance(k)[0, 0], var)
        # the median of N(m, v) is m: to the sketch's 0.4 % and the sampling error
        assert abs(s.quantile(k, "y0", 0.5) / mean - 1) < 0.004 + 4 * 1.2533 * se_mean / mean


def test_gaussian_parameter_against_lognormal_moments():
    # x₀ = 1, k ~ N(k̄, s²): x(t) = e^{−kt}, E[xʲ] = e^{−j·k̄t + j²s²t²/2}
    kbar, s_k, m = 0.8, 0.2, 40_000
    ens = reckon.Ensemble(decay, (0.0, 3.0), [1.0], params=[kbar], params_sigma=s_k,
                          t_eval=[1.0, 3.0], rtol=1e-10, atol=1e-12)
    st = ens.run(m, seed=5)
    for k, t in enumerate([1.0, 3.0]):
        raw = [np.exp(-j * kbar * t + j * j * s_k**2 * t * t / 2) for j in range(5)]
        mean = raw[1]
        var = raw[2] - mean**2
        mu4 = raw[4] - 4 * raw[3] * mean + 6 * raw[2] * mean**2 - 3 * mean**4
        assert abs(st.mean(k)[0] - mean) < 4 * np.sqrt(var / m), (t, st.mean(k)[0], mean)
        assert abs(st.covariance(k)[0, 0] - var) < 4 * np.sqrt((mu4 - var**2) / m), (
            t, st.covariance(k)[0, 0], var)
        # against the deterministic run at k̄: the mean is e^{s²t²/2} above it
        assert st.mean(k)[0] > np.exp(-kbar * t)


def test_joint_singular_covariance_against_the_linear_flow():
    # y₁' = y₂, y₂' = −ω²y₁ with (y₁, y₂, ω) ~ N(μ, C), ω not perturbed (C singular)
    w = 1.5
    c = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.0], [0.0, 0.0, 0.0]])
    mu = np.array([1.0, -0.5])
    ens = reckon.Ensemble(lambda t, y, om: [y[1], -om**2 * y[0]], (0, 2), mu, params=[w], cov=c,
                          t_eval=[2.0], rtol=1e-10, atol=1e-12)
    assert np.allclose(ens.cov, c, atol=1e-15)
    m = 40_000
    st = ens.run(m, seed=3)
    t = 2.0
    phi = np.array([[np.cos(w * t), np.sin(w * t) / w], [-w * np.sin(w * t), np.cos(w * t)]])
    mean, cov = phi @ mu, phi @ c[:2, :2] @ phi.T
    se_mean = np.sqrt(np.diag(cov) / m)
    assert (abs(st.mean(0) - mean) < 4 * se_mean).all(), (st.mean(0), mean)
    se_cov = np.sqrt((np.outer(np.diag(cov), np.diag(cov)) + cov**2) / m)
    assert (abs(st.covariance(0) - cov) < 4 * se_cov).all(), (st.covariance(0), cov)


def test_shards_merge_to_the_bits_of_one_run(x0_ensemble, x0_stats):
    parts = [x0_ensemble.run(M, seed=11, shard=(k, 3)) for k in range(3)]
    assert [p.count for p in parts] == [13334, 13333, 13333]
    merged = parts[2].merge(parts[0]).merge(parts[1])
    assert merged.complete and merged.shards == [0, 1, 2]
    assert snapshots(merged) == snapshots(x0_stats)
    for k in range(len(T)):
        assert (merged.mean(k) == x0_stats.mean(k)).all()
        assert (merged.covariance(k) == x0_stats.covariance(k)).all()
    with pytest.raises(reckon.InvalidInput, match="counted twice"):
        merged.merge(parts[0])


def test_same_seed_same_bytes_threads_do_not_matter(x0_ensemble):
    a = x0_ensemble.run(5000, seed=99, threads=1)
    b = x0_ensemble.run(5000, seed=99, threads=2)
    c = x0_ensemble.run(5000, seed=99)
    assert a.to_json() == b.to_json() == c.to_json()
    assert x0_ensemble.run(5000, seed=100).to_json() != a.to_json()


def test_other_ensembles_do_not_merge(x0_ensemble):
    other = reckon.Ensemble(decay, (0.0, 2.0), [MU], params=[K], y0_sigma=2 * SIGMA, t_eval=T,
                            rtol=1e-10, atol=1e-12)
    assert other != x0_ensemble and other.job != x0_ensemble.job
    a = x0_ensemble.run(100, seed=1, shard=(0, 2))
    b = other.run(100, seed=1, shard=(1, 2))
    with pytest.raises(reckon.InvalidInput, match="not of one ensemble"):
        a.merge(b)


def test_pickled_ensemble_is_traced_again_to_the_same_job(x0_ensemble):
    again = pickle.loads(pickle.dumps(x0_ensemble))
    assert again == x0_ensemble and again.job == x0_ensemble.job
    assert again.run(300, seed=4).to_json() == x0_ensemble.run(300, seed=4).to_json()


def test_untraceable_fun_is_refused():
    def branchy(t, y):
        return [-y[0] if y[0] > 0 else y[0]]

    with pytest.raises(reckon.Untraceable) as e:
        reckon.Ensemble(branchy, (0, 1), [1.0], y0_sigma=0.1)
    assert isinstance(e.value, reckon.Error) and "comparison" in e.value.reason


def test_failing_members_raise_the_lowest_index():
    # y' = y² from y₀ = 1 blows up at t = 1: every member fails before t = 2
    ens = reckon.Ensemble(lambda t, y: y**2, (0, 2), [1.0], y0_sigma=0.01, t_eval=[2.0])
    for shard, first in (((0, 1), 0), ((1, 3), 1)):
        with pytest.raises(reckon.EnsembleMember) as e:
            ens.run(50, seed=2, shard=shard, threads=2)
        assert e.value.index == first and isinstance(e.value, reckon.Error)


BAD = [
    (dict(y0=[np.nan]), "y0"),
    (dict(y0=[[1.0]]), "y0"),
    (dict(y0=[]), "y0"),
    (dict(t_span=(0.0, 0.0)), "t_span"),
    (dict(t_span=(0.0, np.inf)), "t_span"),
    (dict(params=[np.nan]), "params"),
    (dict(y0_sigma=-0.1), "y0_sigma"),
    (dict(y0_sigma=[0.1, 0.2]), "y0_sigma"),
    (dict(y0_sigma=np.nan), "y0_sigma"),
    (dict(params_sigma=[0.1, 0.1]), "params_sigma"),
    (dict(cov=[[0.1, 0.01], [0.0, 0.1]]), "cov"),  # not symmetric
    (dict(cov=[[0.1, 0.2], [0.2, 0.1]]), "cov"),  # eigenvalue −0.1
    (dict(cov=[[0.1]]), "cov"),  # shape
    (dict(cov=[[0.1, 0.0], [0.0, np.nan]]), "cov"),
    (dict(cov=np.eye(2), y0_sigma=0.1), "cov"),
    (dict(t_eval=[0.5, 3.0]), "t_eval"),
    (dict(t_eval=[1.0, 0.5]), "t_eval"),
    (dict(t_eval=[]), "t_eval"),
    (dict(method="LSODA"), "method"),
    (dict(method="Euler"), "first_step"),
    (dict(rtol=0.0), "rtol"),
    (dict(atol=[1e-6, 1e-6]), "atol"),
    (dict(max_steps=0), "max_steps"),
]


@pytest.mark.parametrize("change,what", BAD, ids=[f"{w}-{i}" for i, (_, w) in enumerate(BAD)])
def test_bad_input_is_a_typed_error(change, what):
    kw = dict(t_span=(0.0, 1.0), y0=[1.0], params=[0.5])
    kw.update(change)
    with pytest.raises(reckon.InvalidInput) as e:
        reckon.Ensemble(decay, kw.pop("t_span"), kw.pop("y0"), **kw)
    assert e.value.what == what and isinstance(e.value, reckon.Error)


@pytest.mark.parametrize("run,what", [
    (dict(members=0), "members"), (dict(members=-3), "members"), (dict(members=2.5), "members"),
    (dict(members=10, shard=(3, 3)), "shard"), (dict(members=10, shard=(0, 0)), "shard"),
    (dict(members=10, seed=-1), "seed"), (dict(members=10, threads=0), "threads"),
])
def test_bad_run_arguments_are_typed_errors(x0_ensemble, run, what):
    with pytest.raises(reckon.InvalidInput) as e:
        x0_ensemble.run(**run)
    assert e.value.what == what


def test_wrong_length_fun_output_is_a_typed_error():
    with pytest.raises(reckon.InvalidInput, match="returned 2 values"):
        reckon.Ensemble(lambda t, y: [y[0], y[0]], (0, 1), [1.0], y0_sigma=0.1)


def test_dask_two_processes_equal_bytes():
    distributed = pytest.importorskip("distributed")
    import reckon.dask

    # a lambda, so that cloudpickle sends it by value to the worker processes
    ens = reckon.Ensemble(lambda t, y, a, b: [y[1], -a * y[0] - b * y[1] + np.sin(t)], (0, 3),
                          [1.0, 0.0], params=[2.0, 0.3], y0_sigma=[0.1, 0.05],
                          params_sigma=[0.2, 0.02], t_eval=[1.0, 2.0, 3.0], rtol=1e-8, atol=1e-10)
    members, seed = 6000, 20261207
    whole = ens.run(members, seed)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            s = reckon.dask.ensemble(client, ens, members, seed, shards=3)
    assert (s.shard_count, s.shards, s.count) == (3, [0, 1, 2], members)
    assert snapshots(s) == snapshots(whole)
    thirds = [ens.run(members, seed, shard=(k, 3)) for k in range(3)]
    assert s.to_json() == thirds[0].merge(thirds[1]).merge(thirds[2]).to_json()

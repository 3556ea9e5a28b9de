"""Members per second of `reckon.Ensemble` on a 3-state traced model, 1 and 2 threads.

The Lorenz system (σ, ρ, β) = (10, 28, 8/3) over t ∈ [0, 1] with RK45 at rtol 1e-6,
atol 1e-9, saved at 10 times, two ensembles:

- `x0`: x₀ ~ N((1, 1, 20), 0.1²·I), the parameters written into `fun` (3 states);
- `params`: the same x₀ draws and (σ, ρ, β) ~ N(·, (0.1, 0.5, 0.05)²) (traced as 3 more
  states of zero derivative: 6 states).

Best of `repeats` interleaved runs of `members` members each, on 1 thread, 2 threads and
(with `--dask`) 8 shards on a `LocalCluster(n_workers=2, threads_per_worker=1,
processes=True)` started and warmed up before the clock; checks that every run gives the
same bits. Prints the load average before and after.

    python bench/model_ensemble.py [members] [repeats] [--dask]
"""

import json
import os
import sys
import time

import numpy as np

import reckon


def lorenz_fixed(t, y):
    return [10.0 * (y[1] - y[0]), y[0] * (28.0 - y[2]) - y[1], y[0] * y[1] - 8.0 / 3.0 * y[2]]


def lorenz(t, y, s, r, b):
    return [s * (y[1] - y[0]), y[0] * (r - y[2]) - y[1], y[0] * y[1] - b * y[2]]


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    members = int(args[0]) if args else 10_000
    repeats = int(args[1]) if len(args) > 1 else 3
    client = None
    if "--dask" in sys.argv:
        import distributed

        import reckon.dask

        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=None)
        client = distributed.Client(cluster)
    common = dict(t_eval=np.linspace(0.1, 1.0, 10), rtol=1e-6, atol=1e-9)
    cases = {
        "x0 (3 states)": reckon.Ensemble(lorenz_fixed, (0, 1), [1.0, 1.0, 20.0], y0_sigma=0.1,
                                         **common),
        "params (3+3 states)": reckon.Ensemble(lorenz, (0, 1), [1.0, 1.0, 20.0],
                                               params=[10.0, 28.0, 8 / 3], y0_sigma=0.1,
                                               params_sigma=[0.1, 0.5, 0.05], **common),
    }
    print(f"load average before: {os.getloadavg()}")
    for name, ens in cases.items():
        runs = {1: lambda: ens.run(members, seed=1, threads=1).to_json(),
                2: lambda: ens.run(members, seed=1, threads=2).to_json()}
        if client is not None:
            reckon.dask.ensemble(client, ens, 200, seed=1, shards=2)  # warm-up: imports, trace
            runs["dask"] = lambda: reckon.dask.ensemble(client, ens, members, seed=1, shards=8).to_json()
        best = dict.fromkeys(runs, np.inf)
        out = {}
        for _ in range(repeats):
            for key, run in runs.items():
                t = time.perf_counter()
                out[key] = run()
                best[key] = min(best[key], time.perf_counter() - t)
        # the statistics, without which shards of how many made them
        same = [{k: v for k, v in json.loads(o).items() if k not in ("shards", "shard_count")}
                for o in out.values()]
        assert all(v == same[0] for v in same)
        line = (f"{name}: {members} members; 1 thread {best[1]:.3f} s = {members / best[1]:,.0f}/s; "
                f"2 threads {best[2]:.3f} s = {members / best[2]:,.0f}/s, speed-up {best[1] / best[2]:.2f}x")
        if "dask" in best:
            line += f"; Dask 8 shards {best['dask']:.3f} s, speed-up {best[1] / best['dask']:.2f}x"
        print(line + "; same bits")
    print(f"load average after: {os.getloadavg()}")
    if client is not None:
        client.close()
        cluster.close()


if __name__ == "__main__":
    main()

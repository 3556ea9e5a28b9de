"""Members per second of `reckon.Ensemble` on a 3-state traced model, 1 and 2 threads.

The Lorenz system (σ, ρ, β) = (10, 28, 8/3) over t ∈ [0, 1] with RK45 at rtol 1e-6,
atol 1e-9, saved at 10 times, two ensembles:

- `x0`: x₀ ~ N((1, 1, 20), 0.1²·I), the parameters written into `fun` (3 states);
- `params`: the same x₀ draws and (σ, ρ, β) ~ N(·, (0.1, 0.5, 0.05)²) (traced as 3 more
  states of zero derivative: 6 states).

Best of `repeats` interleaved runs of `members` members each; checks that the threads give
the same bits. Prints the load average before and after.

    python bench/model_ensemble.py [members] [repeats]
"""

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
    members = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
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
        best = {1: np.inf, 2: np.inf}
        out = {}
        for _ in range(repeats):
            for th in (1, 2):
                t = time.perf_counter()
                out[th] = ens.run(members, seed=1, threads=th).to_json()
                best[th] = min(best[th], time.perf_counter() - t)
        assert out[1] == out[2]
        print(f"{name}: {members} members; 1 thread {best[1]:.3f} s = {members / best[1]:,.0f}/s; "
              f"2 threads {best[2]:.3f} s = {members / best[2]:,.0f}/s; "
              f"speed-up {best[1] / best[2]:.2f}x; same bits")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

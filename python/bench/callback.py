"""Cost per right-hand-side call of reckon's callback mode against scipy's RK45.

Lorenz (3 states) on [0, 20], RK45 in both at rtol = 1e-6, atol = 1e-9, steps only (no
t_eval, no dense output). Reports, for each, the wall time per solve (best of the
repeats, after a warm-up run), the number of calls of the Python function and the time
per call; then the function's own cost per call, called from a plain Python loop, so
that per call − that is each driver's own overhead.

    python bench/callback.py [repeats]
"""

import sys
import time

import numpy as np
import scipy
import scipy.integrate as si

import reckon

SIGMA, RHO, BETA = 10.0, 28.0, 8.0 / 3.0


def lorenz(t, y):
    return np.array([SIGMA * (y[1] - y[0]), y[0] * (RHO - y[2]) - y[1], y[0] * y[1] - BETA * y[2]])


def counted(f):
    calls = [0]

    def g(t, y):
        calls[0] += 1
        return f(t, y)

    return g, calls


def measure(solve, fun, repeats):
    g, calls = counted(fun)
    solve(g)  # warm-up
    best = np.inf
    for _ in range(repeats):
        calls[0] = 0
        t0 = time.perf_counter()
        solve(g)
        best = min(best, time.perf_counter() - t0)
    return best, calls[0]


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    span, y0 = (0.0, 20.0), [1.0, 1.0, 1.0]
    opts = dict(rtol=1e-6, atol=1e-9)
    solvers = {
        f"scipy {scipy.__version__} RK45": lambda f: si.solve_ivp(f, span, y0, method="RK45", **opts),
        "reckon RK45 (callback)": lambda f: reckon.solve_ivp(f, span, y0, method="RK45", **opts),
    }
    print(f"Lorenz on {span}, rtol={opts['rtol']}, atol={opts['atol']}, best of {repeats}")
    print(f"{'':32} {'solve [ms]':>11} {'calls':>7} {'per call [us]':>14}")
    for name, solve in solvers.items():
        t, n = measure(solve, lorenz, repeats)
        print(f"{name:32} {1e3 * t:11.2f} {n:7d} {1e6 * t / n:14.2f}")
    # the function's own cost: the same calls from a plain Python loop
    y = np.array(y0)
    t, n = measure(lambda f: [f(0.0, y) for _ in range(5000)], lorenz, repeats)
    print(f"{'the function alone (Python loop)':32} {1e3 * t:11.2f} {n:7d} {1e6 * t / n:14.2f}")


if __name__ == "__main__":
    main()

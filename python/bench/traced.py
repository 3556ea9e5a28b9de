"""Traced Python models against the same models in Rust and against scipy's solve_ivp.

For each problem and method: the one-off cost of reckon.Model (tracing the Python function
and compiling f, ∂f/∂y, ∂f/∂t), then the best wall time of `repeats` solves of

- the traced model from Python: reckon.solve_ivp(model, ...) with t_eval=[t1], so the
  Python call, the argument conversion and the result arrays are included;
- the same model written with model! in Rust (reckon.studies.problems), timed in Rust
  (reckon._reckon._rust_reference: fixed-size states for Robertson and Van der Pol);
- scipy's solve_ivp BDF and Radau with the analytic Jacobian (Robertson, Van der Pol) or
  jac_sparsity (Brusselator), at the same rtol and atol;

and each one's error at t1 against a reference (scipy Radau at rtol 1e-12 for the small
problems, reckon Rodas5P at rtol 1e-11 for the Brusselator), so the accuracy is matched
or shown.

    python bench/traced.py [repeats] [--big]     (--big adds the 10⁵-state Brusselator)
"""

import sys
import time

import numpy as np
import scipy
import scipy.integrate as si

import reckon
from reckon import _reckon


def robertson(t, y):
    return [
        y[0] * -0.04 + y[1] * y[2] * 1e4,
        y[0] * 0.04 - y[1] * y[1] * 3e7 - y[1] * y[2] * 1e4,
        y[1] * y[1] * 3e7,
    ]


def robertson_jac(t, y):
    return [
        [-0.04, 1e4 * y[2], 1e4 * y[1]],
        [0.04, -6e7 * y[1] - 1e4 * y[2], -1e4 * y[1]],
        [0.0, 6e7 * y[1], 0.0],
    ]


MU = 1000.0


def vdp(t, y):
    return [y[1], (-y[0] * y[0] + 1.0) * y[1] * MU - y[0]]


def vdp_jac(t, y):
    return [[0.0, 1.0], [-2.0 * MU * y[0] * y[1] - 1.0, MU * (1.0 - y[0] ** 2)]]


def brusselator(N):
    """reckon.studies.problems.brusselator(N) written in numpy: 2N states (u_i, v_i)."""
    c = (N + 1.0) ** 2 / 50.0

    def f(t, y):
        u, v = y[0::2], y[1::2]
        up = np.concatenate(([1.0], u, [1.0]))
        vp = np.concatenate(([3.0], v, [3.0]))
        uuv = u * u * v
        du = uuv - u * 4.0 + 1.0 + (up[:-2] + up[2:] - u * 2.0) * c
        dv = u * 3.0 - uuv + (vp[:-2] + vp[2:] - v * 2.0) * c
        out = np.empty(2 * N, dtype=y.dtype)
        out[0::2], out[1::2] = du, dv
        return out

    x = np.arange(1, N + 1) / (N + 1.0)
    y0 = np.empty(2 * N)
    y0[0::2], y0[1::2] = 1 + 0.5 * np.sin(2 * np.pi * x), 3.0
    return f, y0


def best(f, repeats):
    f()  # warm-up
    b = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = f()
        b = min(b, time.perf_counter() - t0)
    return b, r


def row(label, seconds, err, extra=""):
    print(f"  {label:34} {seconds * 1e3:11.3f} ms   err {err:9.2e}  {extra}")


def case(name, fun, y0, t1, rust, jac, sparsity, methods, tol, repeats, scipy_too=True):
    n = len(y0)
    t0 = time.perf_counter()
    model = reckon.Model(fun, n)
    total = time.perf_counter() - t0
    print(f"\n{name}: n = {n}, t1 = {t1}, rtol = {tol[0]}, atol = {tol[1]}; {model!r}")
    print(
        f"  trace + compile (one-off): {total * 1e3:.1f} ms "
        f"(trace {model.trace_seconds * 1e3:.1f} ms, compile {model.compile_seconds * 1e3:.1f} ms)"
    )
    if n <= 16:
        ref = si.solve_ivp(fun, (0, t1), y0, method="Radau", jac=jac, rtol=1e-12, atol=tol[1] * 1e-4).y[:, -1]
    else:
        ref = reckon.solve_ivp(model, (0, t1), y0, method="Rodas5P", rtol=1e-11, atol=1e-13, t_eval=[t1]).y[:, -1]
    scale = np.abs(ref) * tol[0] + tol[1]

    def err(y):
        return float(np.max(np.abs(np.asarray(y) - ref) / scale))

    out = {}
    for m in methods:
        tp, sol = best(
            lambda: reckon.solve_ivp(model, (0, t1), y0, method=m, rtol=tol[0], atol=tol[1], t_eval=[t1]),
            repeats,
        )
        tr, y_r, steps = _reckon._rust_reference(rust[0], rust[1], m, t1, tol[0], tol[1], repeats)
        row(f"reckon {m}, traced from Python", tp, err(sol.y[:, -1]), f"{sol.stats['accepted']} steps")
        row(f"reckon {m}, model! in Rust", tr, err(y_r), f"{steps} steps; Python/Rust = {tp / tr:.2f}")
        out[m] = (tp, tr)
    if scipy_too:
        for sm in ("BDF", "Radau"):
            kw = dict(jac=jac) if jac is not None else dict(jac_sparsity=sparsity)
            ts, sol = best(
                lambda: si.solve_ivp(fun, (0, t1), y0, method=sm, rtol=tol[0], atol=tol[1], t_eval=[t1], **kw),
                max(1, min(repeats, 3)),
            )
            fastest = min(v[0] for v in out.values())
            row(f"scipy {sm}", ts, err(sol.y[:, -1]), f"scipy / fastest traced = {ts / fastest:.1f}")
    return out


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    repeats = int(args[0]) if args else 5
    print(
        f"reckon traced models, {time.strftime('%Y-%m-%d')}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"best of {repeats}"
    )
    methods = ("BDF", "Rodas5P")
    case("Robertson", robertson, np.array([1.0, 0.0, 0.0]), 1e5, ("robertson", 0.0), robertson_jac, None,
         methods, (1e-6, 1e-10), repeats)
    case("Van der Pol, mu = 1000", vdp, np.array([2.0, 0.0]), 3000.0, ("vdp", MU), vdp_jac, None,
         methods, (1e-6, 1e-6), repeats)
    f, y0 = brusselator(500)
    m = reckon.Model(f, len(y0))
    case("Brusselator 1-D, 500 points", f, y0, 10.0, ("brusselator", 500), None, m.sparsity(),
         methods, (1e-6, 1e-6), repeats)
    if "--big" in sys.argv:
        f, y0 = brusselator(50_000)
        case("Brusselator 1-D, 50 000 points", f, y0, 10.0, ("brusselator", 50_000), None, None,
             ("BDF",), (1e-6, 1e-6), 1, scipy_too=False)


if __name__ == "__main__":
    main()

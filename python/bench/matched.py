"""reckon against scipy's solve_ivp at matched accuracy: work-precision curves.

For each problem, scipy's BDF and Radau (analytic `jac`, or `jac_sparsity` for the
Brusselator) and reckon's BDF and Rodas5P (the traced model) each run at a grid of
tolerances (rtol = atol·k as in bench/traced.py; reckon's grid reaches one step looser
than scipy's on the Brusselator, so that scipy's loosest runs fall inside it). Every run's error at t1 is measured
against one reference (scipy Radau at rtol 1e-12 for the small problems, reckon Rodas5P
at rtol 1e-11 for the Brusselator) in a fixed scale: `err = max |y − y_ref| / (s·|y_ref|
+ a)` with the problem's (s, a) (the scale of its rtol = 1e-6 run), so errors of runs at
different tolerances compare. Time: best of `repeats` wall times, the Python call
included (reckon: `solve_ivp(model, …, t_eval=[t1])` after the one-off trace).

Matched accuracy: for each scipy run, reckon's time at the same error, interpolated
log-log along the curve of reckon's faster method there (between the two reckon runs
whose errors bracket scipy's; a scipy error outside reckon's range is not matched). The
ratio is scipy's time over that.

    python bench/matched.py [repeats] [--big]    (--big adds the 10⁵-state Brusselator)
"""

import math
import sys
import time

import numpy as np
import scipy
import scipy.integrate as si

import reckon
from traced import MU, brusselator, robertson, robertson_jac, vdp, vdp_jac


def best(f, repeats):
    f()
    b = math.inf
    r = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = f()
        b = min(b, time.perf_counter() - t0)
    return b, r


def curve(points):
    """(err, seconds) sorted by error, for interpolation."""
    return sorted((e, t) for e, t in points if e > 0 and math.isfinite(e))


def time_at(points, err):
    """Seconds at `err`, log-log between the bracketing points; None outside."""
    for (e0, t0), (e1, t1) in zip(points, points[1:]):
        if e0 <= err <= e1:
            if e1 == e0:
                return min(t0, t1)
            w = (math.log(err) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + w * (math.log(t1) - math.log(t0)))
    return None


def problem(name, fun, y0, t1, scale, jac, sparsity, tols, repeats, scipy_repeats, scipy_tols=None):
    n = len(y0)
    model = reckon.Model(fun, n)
    s_rel, s_abs, atol_of = scale
    if n <= 16:
        ref = si.solve_ivp(fun, (0, t1), y0, method="Radau", jac=jac, rtol=1e-12,
                           atol=atol_of(1e-12)).y[:, -1]
    else:
        ref = reckon.solve_ivp(model, (0, t1), y0, method="Rodas5P", rtol=1e-11, atol=1e-13,
                               t_eval=[t1]).y[:, -1]

    def err(y):
        return float(np.max(np.abs(np.asarray(y) - ref) / (np.abs(ref) * s_rel + s_abs)))

    print(f"\n{name} (n = {n}, t1 = {t1}); err in the scale rtol = {s_rel}, atol = {s_abs}")
    runs = {}
    for m in ("BDF", "Rodas5P"):
        pts = []
        for tol in tols:
            t, sol = best(lambda: reckon.solve_ivp(model, (0, t1), y0, method=m, rtol=tol,
                                                   atol=atol_of(tol), t_eval=[t1]), repeats)
            e = err(sol.y[:, -1])
            pts.append((e, t))
            print(f"  reckon {m:8} rtol {tol:7.1e}  {t * 1e3:10.3f} ms  err {e:9.3g}  "
                  f"{sol.stats['accepted']} steps")
        runs[m] = curve(pts)
    kw = dict(jac=jac) if jac is not None else dict(jac_sparsity=sparsity)
    out = []
    for sm in ("BDF", "Radau"):
        for tol in scipy_tols or tols:
            t, sol = best(lambda: si.solve_ivp(fun, (0, t1), y0, method=sm, rtol=tol,
                                               atol=atol_of(tol), t_eval=[t1], **kw), scipy_repeats)
            e = err(sol.y[:, -1])
            matched = [(time_at(runs[m], e), m) for m in runs]
            matched = [(tm, m) for tm, m in matched if tm is not None]
            if matched:
                tm, m = min(matched)
                note = f"reckon {m} at this err {tm * 1e3:9.3f} ms: scipy / reckon = {t / tm:7.1f}"
                out.append((sm, tol, e, t, m, tm))
            else:
                note = "outside reckon's range of errors"
            print(f"  scipy  {sm:8} rtol {tol:7.1e}  {t * 1e3:10.3f} ms  err {e:9.3g}  {note}")
    return out


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    repeats = int(args[0]) if args else 5
    print(f"reckon against scipy at matched accuracy, {time.strftime('%Y-%m-%d %H:%M')}, "
          f"numpy {np.__version__}, scipy {scipy.__version__}, best of {repeats}")
    tols = [1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8]
    table = {}
    table["Robertson"] = problem(
        "Robertson", robertson, np.array([1.0, 0.0, 0.0]), 1e5, (1e-6, 1e-10, lambda r: r * 1e-4),
        robertson_jac, None, tols, repeats, 2)
    table["Van der Pol"] = problem(
        f"Van der Pol, mu = {MU:g}", vdp, np.array([2.0, 0.0]), 3000.0, (1e-6, 1e-6, lambda r: r),
        vdp_jac, None, tols, repeats, 2)
    f, y0 = brusselator(500)
    m = reckon.Model(f, len(y0))
    table["Brusselator 1 000"] = problem(
        "Brusselator 1-D, 500 points", f, y0, 10.0, (1e-6, 1e-6, lambda r: r), None, m.sparsity(),
        tols[:7], repeats, 2, scipy_tols=tols[1:7])
    if "--big" in sys.argv:
        f, y0 = brusselator(50_000)
        m = reckon.Model(f, len(y0))
        table["Brusselator 10^5"] = problem(
            "Brusselator 1-D, 50 000 points", f, y0, 10.0, (1e-6, 1e-6, lambda r: r), None,
            m.sparsity(), [1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7], 1, 1, scipy_tols=[1e-5, 3e-6, 1e-6])
    print("\nsmallest scipy / reckon at matched accuracy:")
    for name, rows in table.items():
        for sm in ("BDF", "Radau"):
            r = [(t / tm, tol, e) for s, tol, e, t, _, tm in rows if s == sm]
            if r:
                lo = min(r)
                print(f"  {name:20} scipy {sm:6} {lo[0]:8.1f}× (at scipy rtol {lo[1]:.0e}, err {lo[2]:.3g}); "
                      f"over {len(r)} matched tolerances {min(x[0] for x in r):.1f}–{max(x[0] for x in r):.1f}×")


if __name__ == "__main__":
    main()

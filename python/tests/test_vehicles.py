"""reckon.vehicles.simulate and reckon.odometry against closed forms, and their errors."""

import doctest
import math

import numpy as np
import pytest

import reckon
from reckon import vehicles


def arc(x0, v, w, h):
    """The unicycle's exact arc, written out independently: a circle of radius v/ω."""
    x, y, th = x0
    if w == 0.0:
        return np.array([x + v * h * math.cos(th), y + v * h * math.sin(th), th])
    r = v / w
    return np.array([
        x + r * (math.sin(th + w * h) - math.sin(th)),
        y - r * (math.cos(th + w * h) - math.cos(th)),
        th + w * h,
    ])


def test_unicycle_constant_inputs_is_the_exact_arc():
    v, w = 1.5, 0.4
    t = np.linspace(0.0, 20.0, 41)
    r = vehicles.simulate(vehicles.Unicycle(), [0.0, 0.0, 0.0], t, [v, w])
    assert r.y.shape == (3, len(t)) and np.array_equal(r.t, t)
    want = np.array([[v / w * math.sin(w * s), v / w * (1 - math.cos(w * s)), w * s] for s in t]).T
    assert np.max(np.abs(r.y - want)) < 1e-13
    # one step per interval
    assert r.stats["accepted"] == len(t) - 1
    # an adaptive method lands on the same times, to its tolerance
    a = vehicles.simulate(vehicles.Unicycle(), [0.0, 0.0, 0.0], t, [v, w], method="RK45", rtol=1e-10, atol=1e-12)
    assert np.array_equal(a.t, t)
    assert 1e-14 < np.max(np.abs(a.y - want)) < 1e-8


def test_unicycle_piecewise_inputs_compose_arcs():
    rng = np.random.default_rng(7)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.1, 1.0, 30)])
    u = np.c_[rng.uniform(-1, 2, 30), rng.uniform(-1, 1, 30)]
    u[5, 1] = 0.0  # a straight interval
    x0 = np.array([1.0, -2.0, 0.3])
    r = vehicles.simulate(vehicles.Unicycle(), x0, t, u)
    want = [x0]
    for k in range(30):
        want.append(arc(want[-1], u[k, 0], u[k, 1], t[k + 1] - t[k]))
    assert np.max(np.abs(r.y - np.array(want).T)) < 1e-12
    # implicit Euler, one step per interval: x₁ = x₀ + h·f(x₁), θ₁ = θ₀ + hω exactly
    # (a step whose simplified Newton iteration does not converge is halved)
    ie = vehicles.simulate(vehicles.Unicycle(), x0, t, u, method="ImplicitEuler")
    assert ie.stats["accepted"] >= 30
    th = x0[2] + np.r_[0.0, np.cumsum(u[:, 1] * np.diff(t))]
    assert np.max(np.abs(ie.y[2] - th)) < 1e-13
    one = vehicles.simulate(vehicles.Unicycle(), x0, [0.0, 0.5], [1.5, 0.8], method="ImplicitEuler")
    assert one.stats["accepted"] == 1
    th1 = x0[2] + 0.4
    assert np.max(np.abs(one.y[:, 1] - [*(x0[:2] + 0.75 * np.array([math.cos(th1), math.sin(th1)])), th1])) < 1e-15
    # Euler with one step per interval: the start heading held (first order)
    e = vehicles.simulate(vehicles.Unicycle(), x0, t[:2], u[:1], method="Euler")
    h = t[1] - t[0]
    assert np.allclose(e.y[:, 1], x0 + h * np.array([u[0, 0] * math.cos(0.3), u[0, 0] * math.sin(0.3), u[0, 1]]),
                       atol=1e-15)


def test_bicycle_half_circle():
    l, a, v = 0.5, 0.3, 2.0
    rad = l / math.tan(a)
    r = vehicles.simulate(vehicles.Bicycle(l), [0, 0, 0], [0.0, math.pi * rad / v], [v, a])
    assert np.max(np.abs(r.y[:, -1] - [0.0, 2 * rad, math.pi])) < 1e-14


def test_carlike_closed_form_heading_and_rk45():
    car = vehicles.CarLike(2.5)
    x0, u = [1.0, 2.0, 0.3, 0.2], [5.0, -0.4]
    r = vehicles.simulate(car, x0, [0.0, 1.0, 2.0], [u, u])
    g1 = 0.2 - 0.4 * 2.0
    th1 = 0.3 - 5.0 / (2.5 * -0.4) * math.log(math.cos(g1) / math.cos(0.2))
    assert abs(r.y[3, -1] - g1) < 1e-15 and abs(r.y[2, -1] - th1) < 1e-14
    # the quadrature's positions against RK45 at a tight tolerance
    a = vehicles.simulate(car, x0, [0.0, 1.0, 2.0], [u, u], method="RK45", rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(a.y - r.y)) < 1e-9
    # the same one step at a time through flow()
    assert np.max(np.abs(car.flow(car.flow(x0, u, 1.0), u, 1.0) - r.y[:, -1])) < 1e-13


def test_body3d_and_diffdrive():
    b = vehicles.Body3D()
    assert np.allclose(b.rhs([0, 0, 0], [0, 0, math.pi, 1.0, 0.0, 0.5]), [-1.0, 0.0, 0.5], atol=1e-15)
    r = vehicles.simulate(b, [1, 1, -5], [0, 1.5, 2.5], [[0, 0, 0, 2, 0, 0], [0, 0, math.pi / 2, 1, 0, -1]])
    assert np.allclose(r.y[:, -1], [4.0, 2.0, -6.0], atol=1e-15)
    # wheel speeds: the unicycle with v = (r_r ω_r + r_l ω_l)/2, ω = (r_r ω_r − r_l ω_l)/b
    dd = vehicles.DiffDrive(0.05, 0.06, 0.4)
    t = [0.0, 0.7, 2.0]
    wl = np.array([[10.0, 12.0], [-3.0, 8.0]])
    v = 0.5 * (0.06 * wl[:, 1] + 0.05 * wl[:, 0])
    w = (0.06 * wl[:, 1] - 0.05 * wl[:, 0]) / 0.4
    a = vehicles.simulate(dd, [0, 0, 0.1], t, wl)
    b2 = vehicles.simulate(vehicles.Unicycle(), [0, 0, 0.1], t, np.c_[v, w])
    assert np.max(np.abs(a.y - b2.y)) < 1e-15


def test_unicycle_sensitivities_rotate_about_the_start():
    # θ₀ turns the whole path about its start: ∂x/∂θ₀ = −(y − y₀), ∂y/∂θ₀ = x − x₀
    rng = np.random.default_rng(5)
    t = np.cumsum(np.r_[0.0, rng.uniform(0.2, 1.0, 12)])
    u = np.c_[rng.uniform(0.5, 2, 12), rng.uniform(-1, 1, 12)]
    x0 = np.array([1.0, -2.0, 0.3])
    for method, tol in (("Exact", 1e-13), ("RK45", 1e-7)):
        r = vehicles.simulate(vehicles.Unicycle(), x0, t, u, method=method, sensitivities=True,
                              rtol=1e-10, atol=1e-12)
        assert r.dy_dx0.shape == (3, 3, len(t)) and r.dy_dp.shape == (3, 0, len(t))
        want = np.zeros((3, 3, len(t)))
        want[0, 0] = want[1, 1] = want[2, 2] = 1.0
        want[0, 2] = -(r.y[1] - x0[1])
        want[1, 2] = r.y[0] - x0[0]
        assert np.max(np.abs(r.dy_dx0 - want)) < tol, method
    with pytest.raises(reckon.InvalidInput, match="unicycle"):
        vehicles.simulate(vehicles.Bicycle(0.5), x0, t, np.c_[u[:, 0], 0.1 * u[:, 1]], sensitivities=True)


def test_diffdrive_parameter_sensitivities_against_central_differences():
    t = np.array([0.0, 1.0, 2.5, 4.0])
    w = np.array([[10.0, 12.0], [-3.0, 8.0], [6.0, 6.0]])
    p = np.array([0.05, 0.06, 0.4])
    r = vehicles.simulate(vehicles.DiffDrive(*p), [0, 0, 0.1], t, w, method="RK45", sensitivities=True,
                          rtol=1e-11, atol=1e-13)
    assert r.dy_dp.shape == (3, 3, 4)
    for j in range(3):
        h = 1e-6 * p[j]
        up, down = p.copy(), p.copy()
        up[j] += h
        down[j] -= h
        fd = (vehicles.simulate(vehicles.DiffDrive(*up), [0, 0, 0.1], t, w).y
              - vehicles.simulate(vehicles.DiffDrive(*down), [0, 0, 0.1], t, w).y) / (2 * h)
        assert np.max(np.abs(r.dy_dp[:, j, :] - fd)) < 1e-6 * np.max(np.abs(fd)), j


def test_threads_give_the_same_answers():
    from concurrent.futures import ThreadPoolExecutor

    t = np.linspace(0, 100, 2001)
    u = np.c_[np.ones(2000), np.sin(t[:-1])]
    one = vehicles.simulate(vehicles.Unicycle(), [0, 0, 0], t, u, method="RK45").y
    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda _: vehicles.simulate(vehicles.Unicycle(), [0, 0, 0], t, u, method="RK45").y,
                             range(8)))
    assert all(np.array_equal(one, r) for r in runs)


def test_simulate_bad_input():
    u = vehicles.Unicycle()
    with pytest.raises(reckon.InvalidInput, match="u"):
        vehicles.simulate(u, [0, 0, 0], [0, 1, 2], [[1, 0]])  # one row for two intervals
    with pytest.raises(reckon.InvalidInput) as e:
        vehicles.simulate(u, [0, 0, math.nan], [0, 1], [1, 0])
    assert e.value.what == "x0"
    with pytest.raises(reckon.InvalidInput) as e:
        vehicles.simulate(vehicles.Bicycle(-0.5), [0, 0, 0], [0, 1], [1, 0])
    assert e.value.what == "wheelbase"
    with pytest.raises(reckon.InvalidInput):
        vehicles.simulate(vehicles.DiffDrive(0.05, 0.0, 0.5), [0, 0, 0], [0, 1], [1, 0])
    with pytest.raises(reckon.InvalidInput, match="two times"):
        vehicles.simulate(u, [0, 0, 0], [], np.zeros((0, 2)))
    with pytest.raises(reckon.InvalidInput, match="increase"):
        vehicles.simulate(u, [0, 0, 0], [0, 2, 1], [[1, 0], [1, 0]])
    with pytest.raises(reckon.InvalidInput, match="x0"):
        vehicles.simulate(u, [0, 0], [0, 1], [1, 0])
    with pytest.raises(reckon.InvalidInput, match="method"):
        vehicles.simulate(u, [0, 0, 0], [0, 1], [1, 0], method="RK23")
    with pytest.raises(ValueError):  # InvalidInput is a ValueError
        vehicles.simulate(u, [0, 0, 0], [0, 1], [[1, math.inf]])
    with pytest.raises(TypeError):
        vehicles.simulate("unicycle", [0, 0, 0], [0, 1], [1, 0])
    # a car-like step whose steering crosses the pole γ = π/2 has no flow
    with pytest.raises(reckon.NonFinite):
        vehicles.simulate(vehicles.CarLike(2.5), [0, 0, 0, 1.5], [0, 0.1], [1.0, 1.0])
    with pytest.raises(reckon.InvalidInput, match="u"):
        u.flow([0, 0, 0], [1.0], 1.0)


def test_odometry_on_a_circle_and_a_line():
    d, b, n = 0.2, 0.5, 1000.0
    k = 50
    t = np.arange(k, dtype=float)
    nl, nr = 100.0, 130.0
    p = reckon.odometry(t, np.full(k, nl), np.full(k, nr), wheel_diameter=d, wheel_separation=b,
                        pulses_per_rev=n, update="exact")
    assert p.shape == (3, k)
    ds = 0.5 * (nl + nr) * math.pi * d / n
    dth = (nr - nl) * math.pi * d / n / b
    j = np.arange(1, k + 1)
    rad = ds / dth
    want = np.array([rad * np.sin(j * dth), rad * (1 - np.cos(j * dth)), j * dth])
    assert np.max(np.abs(p - want)) < 1e-13
    # midpoint: Δs along θ + Δθ/2, off the arc by O(Δθ²)·Δs per sample
    m = reckon.odometry(t, np.full(k, nl), np.full(k, nr), wheel_diameter=d, wheel_separation=b,
                        pulses_per_rev=n)
    chord = ds * (1 - 2 * math.sin(dth / 2) / dth)  # Δs − the chord 2R sin(Δθ/2), per sample
    assert abs(np.hypot(*m[:2, 0]) - np.hypot(*p[:2, 0]) - chord) < 1e-15
    assert np.allclose(m[2], p[2], atol=1e-14)
    # equal ticks: a straight line, every rule alike
    for rule in ("euler", "midpoint", "exact"):
        s = reckon.odometry([0.0, 1.0, 2.0], [10, 10, 10], [10, 10, 10], wheel_diameter=d,
                            wheel_separation=b, pulses_per_rev=n, update=rule)
        assert np.allclose(s, [[1, 2, 3], [0, 0, 0], [0, 0, 0]] * np.array([[10 * math.pi * d / n], [1], [1]]),
                           atol=1e-16)


def test_odometry_bad_input():
    kw = dict(wheel_diameter=0.2, wheel_separation=0.5, pulses_per_rev=1000)
    with pytest.raises(reckon.InvalidInput) as e:
        reckon.odometry([0, 1], [0, 1], [0, 1], **{**kw, "wheel_separation": -0.5})
    assert e.value.what == "wheel_separation"
    with pytest.raises(reckon.InvalidInput, match="not finite"):
        reckon.odometry([0, 1], [0, math.nan], [0, 1], **kw)
    with pytest.raises(reckon.InvalidInput, match="same non-zero length"):
        reckon.odometry([0, 1], [0, 1, 2], [0, 1], **kw)
    with pytest.raises(reckon.InvalidInput, match="same non-zero length"):
        reckon.odometry([], [], [], **kw)
    with pytest.raises(reckon.InvalidInput, match="does not increase"):
        reckon.odometry([0, 1, 1], [0, 1, 1], [0, 1, 1], **kw)
    with pytest.raises(reckon.InvalidInput, match="update"):
        reckon.odometry([0, 1], [0, 1], [0, 1], **kw, update="rk4")
    with pytest.raises(reckon.InvalidInput):
        reckon.odometry([[0, 1]], [0, 1], [0, 1], **kw)


def test_the_docstring_examples():
    for mod in (vehicles,):
        assert doctest.testmod(mod, raise_on_error=True).attempted > 5
    f = doctest.DocTestFinder().find(reckon.odometry)
    runner = doctest.DocTestRunner()
    for test in f:
        runner.run(test)
    assert runner.failures == 0 and runner.tries >= 3


def test_the_gil_is_released_while_simulate_runs():
    import threading
    import time

    def run(n):
        t = np.linspace(0, 5000, n + 1)
        u = np.c_[np.ones(n), 0.1 * np.sin(t[:-1])]
        done = []
        worker = threading.Thread(
            target=lambda: done.append(vehicles.simulate(vehicles.CarLike(), [0, 0, 0, 0], t, u)))
        start = time.perf_counter()
        worker.start()
        last, gap = time.perf_counter(), 0.0
        while worker.is_alive():  # this thread keeps running Python while the other integrates
            now = time.perf_counter()
            gap, last = max(gap, now - last), now
            time.sleep(0.001)
        worker.join()
        assert done and done[0].y.shape == (4, n + 1)
        return gap, time.perf_counter() - start

    # enough native work to see a stall (0.3 s), doubled on a machine fast enough to
    # finish sooner
    n = 500_000
    gap, total = run(n)
    while total <= 0.3 and n < 8_000_000:
        n *= 2
        gap, total = run(n)
    # with the GIL held, this loop would stall for the whole run
    assert total > 0.3 and gap < 0.5 * total, (n, gap, total)

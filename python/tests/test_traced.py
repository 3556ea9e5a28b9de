"""Models traced from Python (reckon.Model): the traced f and Jacobian against the Python
function (its values, central differences and complex steps), traced solves against the
callback mode, the untraceable bodies and their fallback, bad functions, and the GIL."""

import math
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest
import scipy.integrate as si

import reckon
from problems import close, lorenz, robertson, vdp

# ---------------------------------------------------------------- random bodies


def _random_body(rng, n, depth=4):
    """A random right-hand side built from the traceable operations: a function of
    (t, y) that runs on floats, complex numbers (for complex steps) and symbols."""

    def leaf():
        r = rng.random()
        if r < 0.6:
            i = int(rng.integers(n))
            return lambda t, y: y[i]
        if r < 0.8:
            c = float(rng.uniform(-2, 2))
            return lambda t, y: c
        return lambda t, y: t

    def node(d):
        if d == 0:
            return leaf()
        a, b = node(d - 1), node(d - 1)
        k = int(rng.integers(16))
        c = float(rng.uniform(0.5, 2))
        ops = [
            lambda t, y: a(t, y) + b(t, y),
            lambda t, y: a(t, y) - b(t, y),
            lambda t, y: a(t, y) * b(t, y),
            lambda t, y: a(t, y) / (1.5 + np.sin(b(t, y))),
            lambda t, y: -a(t, y),
            lambda t, y: a(t, y) ** 2,
            lambda t, y: a(t, y) ** 3 - c * a(t, y),
            lambda t, y: (1.0 + a(t, y) ** 2) ** 0.5,
            lambda t, y: (2.0 + np.cos(a(t, y))) ** c,
            lambda t, y: np.exp(np.sin(a(t, y))),
            lambda t, y: np.log(1.0 + a(t, y) ** 2),
            lambda t, y: np.tanh(a(t, y)) * b(t, y),
            lambda t, y: np.arctan(a(t, y)) + c,
            lambda t, y: reckon.cos(a(t, y)) * reckon.exp(-(b(t, y) ** 2)),
            lambda t, y: np.sqrt(2.0 + np.sinh(a(t, y) / 4.0) ** 2),
            lambda t, y: 1.0 / (2.0 + reckon.sin(a(t, y) * b(t, y))),
        ]
        return ops[k]

    comps = [node(int(rng.integers(1, depth + 1))) for _ in range(n)]
    return lambda t, y: [f(t, y) for f in comps]


def _central(fun, t, y, h=1e-5):
    n = len(y)
    J = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h * max(1.0, abs(y[j]))
        J[:, j] = (np.asarray(fun(t, y + e), float) - np.asarray(fun(t, y - e), float)) / (2 * e[j])
    return J


def _complex_step(fun, t, y, h=1e-30):
    n = len(y)
    J = np.empty((n, n))
    for j in range(n):
        z = y.astype(complex)
        z[j] += 1j * h
        J[:, j] = np.imag(np.asarray(fun(t, z), complex)) / h
    return J


@pytest.mark.parametrize("seed", range(12))
def test_random_bodies_traced_f_and_jacobian(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 6))
    fun = _random_body(rng, n)
    m = reckon.Model(fun, n)
    for _ in range(3):
        t = float(rng.uniform(-1, 1))
        y = rng.uniform(-1.5, 1.5, n)
        f = np.asarray(fun(t, y), float)
        close(m(t, y), f, 1e-13, 1e-13)
        J = m.jacobian(t, y)
        # exact to rounding: complex steps have no truncation error
        close(J, _complex_step(fun, t, y), 1e-11, 1e-11)
        # and central differences, to their own O(h²) error
        close(J, _central(fun, t, y), 1e-6, 1e-7)
        # the pattern holds every non-zero
        dense = np.asarray(m.sparsity().todense()) != 0
        assert np.all(dense | (J == 0))


def test_vdp_jacobian_printed():
    def f(t, y, mu):
        return [y[1], mu * (1 - y[0] ** 2) * y[1] - y[0]]

    m = reckon.Model(f, 2, params=(1000.0,))
    assert m.n == 2 and m.nnz == 3
    assert m.jacobian_text() == (
        "∂ẏ₀/∂y₁ = 1\n∂ẏ₁/∂y₀ = −1 − 2·y₀·y₁·mu\n∂ẏ₁/∂y₁ = mu·(1 − y₀²)\n"
    )
    assert m.rhs_text(1) == "y₁·mu·(1 − y₀²) − y₀"
    assert m.spy() == ".*\n**\n"
    assert "\\begin{pmatrix}" in m.latex() and "mu" in m.latex()
    assert m.mathml().startswith("<math") and m.mathml().endswith("</math>")
    close(m.jacobian(0.0, [2.0, 3.0]), vdp_jac_np(2.0, 3.0, 1000.0), 1e-15, 0)
    indptr, indices = m.pattern()
    assert list(indptr) == [0, 1, 3] and list(indices) == [1, 0, 1]


def vdp_jac_np(y0, y1, mu):
    return np.array([[0.0, 1.0], [-2.0 * mu * y0 * y1 - 1.0, mu * (1.0 - y0**2)]])


def test_symbols_with_numpy_arrays_and_scalars():
    A = np.array([[-2.0, 1.0, 0.0], [1.0, -2.0, 1.0], [0.0, 1.0, -2.0]])

    def f(t, y):
        return A @ y + np.float64(0.5) * np.sin(y) + y**2 / 4 + 2 ** y[0] - np.exp(t) * y

    m = reckon.Model(f, 3)
    y = np.array([0.3, -0.7, 1.1])
    close(m(0.4, y), f(0.4, y), 1e-14, 1e-14)
    close(m.jacobian(0.4, y), _complex_step(f, 0.4, y), 1e-13, 1e-13)
    assert "t" in m.text()  # ∂f/∂t is traced


# ---------------------------------------------------------------- solves


def _both(fun, span, y0, method, **kw):
    traced = reckon.solve_ivp(fun, span, y0, method=method, **kw)
    called = reckon.solve_ivp(fun, span, y0, method=method, trace=False, **kw)
    assert traced.traced and traced.trace_error is None and traced.jacobian in ("traced", None)
    assert not called.traced
    assert traced.success and called.success
    return traced, called


@pytest.mark.parametrize("method", ["BDF", "Rodas5P"])
def test_robertson_traced_equals_callback(method):
    traced, called = _both(robertson, (0, 40), [1.0, 0.0, 0.0], method, rtol=1e-8, atol=1e-12)
    # Hairer–Wanner's reference at t = 40
    ref = np.array([0.7158270687193e0, 0.9185534764529e-5, 0.2841637457458e0])
    close(traced.y[:, -1], ref, 1e-6, 1e-12)
    close(traced.y[:, -1], called.y[:, -1], 1e-6, 1e-12)
    assert traced.njev > 0 and traced.jacobian == "traced"


@pytest.mark.parametrize("method", ["BDF", "Rodas5P"])
def test_vdp_traced_equals_callback(method):
    traced, called = _both(vdp, (0, 3000), [2.0, 0.0], method, args=(1000.0,), rtol=1e-8, atol=1e-8)
    assert abs(traced.y[0, -1] - (-1.5106069)) < 1e-5  # scipy's Radau at rtol 1e-10
    close(traced.y[:, -1], called.y[:, -1], 1e-5, 1e-8)


def test_lorenz_traced_equals_callback():
    traced, called = _both(lorenz, (0, 2), [1.0, 1.0, 1.0], "RK45", rtol=1e-10, atol=1e-12)
    ref = si.solve_ivp(lorenz, (0, 2), [1.0, 1.0, 1.0], method="DOP853", rtol=1e-13, atol=1e-13)
    close(traced.y[:, -1], ref.y[:, -1], 1e-7, 1e-7)
    close(traced.y[:, -1], called.y[:, -1], 1e-7, 1e-7)
    assert traced.stats["fun_calls"] == 0  # never called back


def brusselator(N, alpha=1 / 50):
    """The 1-D Brusselator (Hairer–Wanner II, IV.10) on N grid points: 2N states."""
    c = alpha * (N + 1) ** 2

    def f(t, y):
        u, v = y[0::2], y[1::2]
        up = np.concatenate(([1.0], u, [1.0]))
        vp = np.concatenate(([3.0], v, [3.0]))
        du = 1 + u * u * v - 4 * u + c * (up[:-2] - 2 * u + up[2:])
        dv = 3 * u - u * u * v + c * (vp[:-2] - 2 * v + vp[2:])
        out = np.empty(2 * N, dtype=object if u.dtype == object else float)
        out[0::2], out[1::2] = du, dv
        return out

    x = np.arange(1, N + 1) / (N + 1)
    y0 = np.empty(2 * N)
    y0[0::2], y0[1::2] = 1 + np.sin(2 * np.pi * x), 3.0
    return f, y0


def test_brusselator_sparse_against_scipy():
    f, y0 = brusselator(100)
    m = reckon.Model(f, 200)
    # u_i and v_i read their two neighbours, themselves and the other field at i
    assert m.sparse and m.nnz == 8 * 100 - 4
    sol = reckon.solve_ivp(m, (0, 10), y0, method="BDF", rtol=1e-9, atol=1e-11)
    assert sol.success and sol.traced
    ref = si.solve_ivp(f, (0, 10), y0, method="BDF", rtol=1e-11, atol=1e-13, jac_sparsity=m.sparsity())
    close(sol.y[:, -1], ref.y[:, -1], 1e-6, 1e-8)


def test_time_dependent_model_with_rodas():
    # y' = −y + sin(t) · 10: Rodas5P needs ∂f/∂t, traced exactly
    def f(t, y):
        return [-y[0] + 10 * np.sin(t)]

    sol = reckon.solve_ivp(f, (0, 3), [1.0], method="Rodas5P", rtol=1e-10, atol=1e-12)
    exact = 5 * (np.sin(3) - np.cos(3)) + 6 * np.exp(-3)
    assert sol.traced and abs(sol.y[0, -1] - exact) < 1e-8


def test_traced_model_with_events_and_dense_output():
    def f(t, y):
        return [y[1], -9.81]

    def hit(t, y):
        return y[0]

    hit.terminal, hit.direction = True, -1
    sol = reckon.solve_ivp(f, (0, 10), [10.0, 0.0], events=hit, dense_output=True, rtol=1e-10, atol=1e-12)
    assert sol.traced and sol.status == 1
    assert abs(sol.t_events[0][0] - math.sqrt(2 * 10 / 9.81)) < 1e-8
    close(sol.sol(1.0), [10 - 9.81 / 2, -9.81], 1e-9, 1e-9)


# ---------------------------------------------------------------- untraceable


def branchy(t, y):
    return [-y[0] if y[0] > 0 else y[0]]


def mathy(t, y):
    return [math.sin(y[0])]


def float_array(t, y):
    out = np.zeros(1)
    out[0] = -y[0]
    return out


def floated(t, y):
    return [-float(y[0])]


@pytest.mark.parametrize(
    "fun, why",
    [(branchy, "comparison (>)"), (mathy, "float()"), (float_array, "float()"), (floated, "float()")],
)
def test_untraceable_raises_and_solve_falls_back(fun, why):
    with pytest.raises(reckon.Untraceable) as e:
        reckon.Model(fun, 1)
    assert why in e.value.reason and e.value.model == fun.__name__
    assert isinstance(e.value, reckon.Error)
    sol = reckon.solve_ivp(fun, (0, 1), [1.0], method="BDF", rtol=1e-10, atol=1e-12)
    assert not sol.traced and why in sol.trace_error
    assert sol.jacobian == "finite differences"
    # y' = −y, or y' = sin y: tan(y/2) = tan(1/2)·eᵗ
    exact = 2 * math.atan(math.tan(0.5) * math.e) if fun is mathy else math.exp(-1)
    assert abs(sol.y[0, -1] - exact) < 1e-8
    with pytest.raises(reckon.Untraceable):
        reckon.solve_ivp(fun, (0, 1), [1.0], trace=True)


def test_symbol_outside_its_trace():
    kept = []

    def f(t, y):
        kept.append(y[0])
        return [-y[0]]

    reckon.Model(f, 1)
    with pytest.raises(reckon.Untraceable, match="outside the trace"):
        kept[0] + 1.0


def test_bad_functions_raise():
    # wrong length: a ValueError from Model, and from solve_ivp (called back)
    with pytest.raises(ValueError, match="returned 2 values, expected 1"):
        reckon.Model(lambda t, y: [y[0], y[0]], 1)
    with pytest.raises(ValueError, match="returned 2 values, expected 1"):
        reckon.solve_ivp(lambda t, y: [y[0], y[0]], (0, 1), [1.0])

    # an exception: Untraceable naming it (the original as its cause); solve_ivp calls
    # the function back, which raises the original
    def boom(t, y):
        raise KeyError("boom")

    with pytest.raises(reckon.Untraceable, match="KeyError") as e:
        reckon.Model(boom, 1)
    assert isinstance(e.value.__cause__, KeyError)
    with pytest.raises(KeyError, match="boom"):
        reckon.solve_ivp(boom, (0, 1), [1.0])

    # a NaN constant cannot be traced; called back it is reckon.NonFinite
    nan = lambda t, y: [y[0] * float("nan")]  # noqa: E731
    with pytest.raises(reckon.Untraceable, match="non-finite"):
        reckon.Model(nan, 1)
    with pytest.raises(reckon.NonFinite):
        reckon.solve_ivp(nan, (0, 1), [1.0])

    # a traced f that becomes NaN on the way (√ of a negative state): reckon.NonFinite
    with pytest.raises(reckon.NonFinite):
        reckon.solve_ivp(lambda t, y: [-np.sqrt(y[0]) - 1.0], (0, 5), [1.0], method="BDF", trace=True)

    # a size that cannot be traced is refused up front, not an abort or a panic
    for n in (10**7 + 1, 10**12, 2**62, 2**70):
        with pytest.raises(reckon.InvalidInput, match="up to 10000000"):
            reckon.Model(lambda t, y: -y, n)
    for n in (0, -1, -(2**70)):
        with pytest.raises(reckon.InvalidInput, match="at least one state"):
            reckon.Model(lambda t, y: -y, n)
    with pytest.raises(reckon.InvalidInput, match="integer, got float"):
        reckon.Model(lambda t, y: -y, 2.0)
    assert reckon.Model(lambda t, y: -y, np.int64(2)).n == 2

    # a Model of another size, or with args
    m = reckon.Model(lambda t, y: -y, 2)
    with pytest.raises(ValueError):
        reckon.solve_ivp(m, (0, 1), [1.0])
    with pytest.raises(ValueError):
        reckon.solve_ivp(m, (0, 1), [1.0, 2.0], args=(1.0,))
    with pytest.raises(reckon.InvalidInput):
        m(0.0, [1.0])


# ---------------------------------------------------------------- the GIL


def test_gil_released_while_a_traced_model_integrates():
    f, y0 = brusselator(1000)  # ~0.1 s of native work (the banded LU made 400 states ~0.02 s)
    m = reckon.Model(f, 2000)
    window = {}

    def work():
        window["start"] = time.perf_counter()
        reckon.solve_ivp(m, (0, 10), y0, method="BDF", rtol=1e-10, atol=1e-12)
        window["end"] = time.perf_counter()

    th = threading.Thread(target=work)
    ticks = []
    th.start()
    while th.is_alive():
        ticks.append(time.perf_counter())
    th.join()
    inside = sum(window["start"] < s < window["end"] for s in ticks)
    # with the GIL held for the solve this loop could not run inside the window at all
    # (a few ticks at its edges); released, it runs throughout
    assert window["end"] - window["start"] > 0.02
    assert inside > 1000, (inside, window["end"] - window["start"])


def test_ctrl_c_stops_a_traced_solve():
    # the GIL is released while a traced model integrates; Python's signals are still
    # looked at, so SIGINT stops a run of ~10¹² steps with KeyboardInterrupt (in a child
    # process, so that a failure is a timeout here, not a hung suite)
    code = textwrap.dedent("""
        import os, signal, threading, time, reckon
        m = reckon.Model(lambda t, y: -y, 1)
        threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        t0 = time.perf_counter()
        try:
            reckon.solve_ivp(m, (0, 1e6), [1.0], max_step=1e-6, max_steps=10**13, t_eval=[1e6])
            print("finished")
        except KeyboardInterrupt:
            print("interrupted")
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.stdout.strip() == "interrupted", (r.stdout, r.stderr)

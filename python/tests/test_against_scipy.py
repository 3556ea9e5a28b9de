"""reckon.solve_ivp against scipy.integrate.solve_ivp run at tight tolerance.

Every comparison is at a tolerance that a wrong coefficient in a tableau, a wrong sign in
an event direction or an off-by-one in t_eval would exceed by orders of magnitude.
"""

import numpy as np
import pytest
import scipy.integrate as si

import reckon
from problems import (
    ARENSTORF_T,
    ARENSTORF_Y0,
    HIRES_REF,
    HIRES_T,
    HIRES_Y0,
    arenstorf,
    close,
    decay,
    hires,
    lorenz,
    oscillator,
    robertson,
    vdp,
    vdp_jac,
)

ADAPTIVE = ["RK45", "BDF", "Rodas5P", "Auto"]
STIFF = ["BDF", "Rodas5P", "Auto"]


@pytest.mark.parametrize("method", ADAPTIVE)
def test_exponential_decay_every_adaptive_method(method):
    t_eval = np.linspace(0.0, 4.0, 9)
    r = reckon.solve_ivp(decay, (0.0, 4.0), [2.0, -1.0], method=method, t_eval=t_eval, rtol=1e-9, atol=1e-12)
    s = si.solve_ivp(decay, (0.0, 4.0), [2.0, -1.0], method="DOP853", t_eval=t_eval, rtol=1e-13, atol=1e-14)
    assert r.success and r.status == 0
    np.testing.assert_array_equal(r.t, s.t)
    close(r.y, s.y, 1e-7, 1e-10)
    close(r.y, np.outer([2.0, -1.0], np.exp(-0.5 * t_eval)), 1e-7, 1e-10)


def test_harmonic_oscillator_dense_output():
    r = reckon.solve_ivp(oscillator, (0.0, 10.0), [1.0, 0.0], rtol=1e-10, atol=1e-12, dense_output=True)
    s = si.solve_ivp(oscillator, (0.0, 10.0), [1.0, 0.0], rtol=1e-10, atol=1e-12, dense_output=True)
    ts = np.linspace(0.0, 10.0, 101)
    exact = np.vstack([np.cos(ts), -np.sin(ts)])
    # between steps: RK45's 4th-order dense output at this tolerance
    close(r.sol(ts), exact, 0, 1e-8)
    close(r.sol(ts), s.sol(ts), 0, 2e-8)
    assert r.sol(2.5).shape == s.sol(2.5).shape == (2,)
    close(r.sol(2.5), [np.cos(2.5), -np.sin(2.5)], 0, 1e-8)
    assert r.sol(ts).shape == s.sol(ts).shape == (2, 101)
    # at the step ends the dense output is the solution
    close(r.sol(r.t), r.y, 0, 1e-13)
    assert r.sol.t_min == 0.0 and r.sol.t_max == 10.0
    np.testing.assert_array_equal(r.sol.ts, r.t)


def test_lorenz_short_span():
    t_eval = np.linspace(0.0, 2.0, 21)
    y0 = [1.0, 1.0, 1.0]
    r = reckon.solve_ivp(lorenz, (0.0, 2.0), y0, t_eval=t_eval, rtol=1e-11, atol=1e-11)
    s = si.solve_ivp(lorenz, (0.0, 2.0), y0, method="DOP853", t_eval=t_eval, rtol=1e-13, atol=1e-13)
    np.testing.assert_array_equal(r.t, s.t)
    close(r.y, s.y, 1e-7, 1e-8)


def test_lorenz_args():
    # scipy's args: passed after (t, y) to fun
    args = (16.0, 45.92, 4.0)
    r = reckon.solve_ivp(lorenz, (0.0, 1.0), [1.0, 2.0, 3.0], args=args, rtol=1e-11, atol=1e-11)
    s = si.solve_ivp(lorenz, (0.0, 1.0), [1.0, 2.0, 3.0], args=args, method="DOP853", rtol=1e-13, atol=1e-13)
    close(r.y[:, -1], s.y[:, -1], 1e-7, 1e-8)
    default = reckon.solve_ivp(lorenz, (0.0, 1.0), [1.0, 2.0, 3.0], rtol=1e-11, atol=1e-11)
    assert np.max(np.abs(default.y[:, -1] - r.y[:, -1])) > 1.0  # the args mattered


def test_arenstorf_orbit_closes():
    r = reckon.solve_ivp(arenstorf, (0.0, ARENSTORF_T), ARENSTORF_Y0, rtol=1e-10, atol=1e-12)
    s = si.solve_ivp(arenstorf, (0.0, ARENSTORF_T), ARENSTORF_Y0, method="DOP853", rtol=1e-13, atol=1e-13)
    close(r.y[:, -1], ARENSTORF_Y0, 0, 2e-6)
    close(r.y[:, -1], s.y[:, -1], 0, 2e-6)
    assert r.t[-1] == ARENSTORF_T


@pytest.fixture(scope="module")
def vdp_reference():
    t_eval = np.linspace(0.0, 3000.0, 7)
    s = si.solve_ivp(vdp, (0.0, 3000.0), [2.0, 0.0], method="Radau", t_eval=t_eval, args=(1000.0,),
                     jac=vdp_jac, rtol=1e-10, atol=1e-10)
    assert s.success
    return s


@pytest.mark.parametrize("method", STIFF)
@pytest.mark.parametrize("jac", [None, vdp_jac, "traced"], ids=["finite-differences", "jac", "traced"])
def test_van_der_pol_mu_1000(method, jac, vdp_reference):
    s = vdp_reference
    traced = jac == "traced"
    r = reckon.solve_ivp(vdp, (0.0, 3000.0), [2.0, 0.0], method=method, t_eval=s.t, args=(1000.0,),
                         jac=None if traced else jac, rtol=1e-8, atol=1e-8, trace=traced)
    assert r.traced == traced
    assert r.success
    np.testing.assert_array_equal(r.t, s.t)
    close(r.y, s.y, 1e-5, 1e-7)
    if method != "Auto" or r.switches:
        assert r.njev > 0 and r.nlu > 0
        assert r.jacobian == ("traced" if traced else "jac" if jac else "finite differences")
    # ~100× fewer right-hand sides than the explicit method would need
    assert r.nfev < 20_000


def test_van_der_pol_auto_switches():
    r = reckon.solve_ivp(vdp, (0.0, 3000.0), [2.0, 0.0], method="Auto", args=(1000.0,), rtol=1e-6, atol=1e-6)
    assert r.switches and r.switches[0]["to"] == "bdf"
    assert isinstance(r.switches[0]["t"], float) and "stiff" in r.switches[0]["reason"]


@pytest.fixture(scope="module")
def robertson_reference():
    t_eval = np.logspace(-5, 5, 11)
    s = si.solve_ivp(robertson, (0.0, 1e5), [1.0, 0.0, 0.0], method="Radau", t_eval=t_eval,
                     rtol=1e-10, atol=1e-14)
    assert s.success
    return s


@pytest.mark.parametrize("method", STIFF)
def test_robertson(method, robertson_reference):
    s = robertson_reference
    r = reckon.solve_ivp(robertson, (0.0, 1e5), [1.0, 0.0, 0.0], method=method, t_eval=s.t,
                         rtol=1e-8, atol=1e-12)
    np.testing.assert_array_equal(r.t, s.t)
    close(r.y, s.y, 1e-6, 1e-11)
    close(r.y.sum(axis=0), np.ones(11), 0, 1e-10)  # mass is conserved


@pytest.fixture(scope="module")
def robertson_4e10():
    s = si.solve_ivp(robertson, (0.0, 4e10), [1.0, 0.0, 0.0], method="Radau", rtol=1e-11, atol=1e-16)
    assert s.success
    return s.y[:, -1]


ROBERTSON_ATOL = [1e-8, 1e-12, 1e-8]


@pytest.mark.parametrize("method", ["Rodas5P", "ExponentialEuler", "BDF", "ImplicitEuler", "Auto"])
@pytest.mark.parametrize("rtol", [1e-2, 1e-3])
def test_robertson_to_4e10_with_finite_differences(method, rtol, robertson_4e10):
    # Robertson as scipy users write it: not traced, so the Jacobian is finite differences.
    # A difference step of √ε·max(|y_j|, 1) on y₂ ~ 1e-13 once made ∂f₃/∂y₂ 0.45 instead of
    # ~1e-5, and Rodas5P's y₁(4e10) 80× too large with status 0 (ExponentialEuler 150×),
    # in ~30× as many steps as with the exact Jacobian.
    kw = dict(method=method, rtol=rtol, atol=ROBERTSON_ATOL)
    fd = reckon.solve_ivp(robertson, (0.0, 4e10), [1.0, 0.0, 0.0], trace=False, **kw)
    exact = reckon.solve_ivp(robertson, (0.0, 4e10), [1.0, 0.0, 0.0], **kw)
    assert fd.jacobian == "finite differences" and exact.jacobian == "traced"
    assert fd.status == 0 and exact.status == 0
    # a loose answer, within a few tolerances of the reference in every component
    err = np.abs(fd.y[:, -1] - robertson_4e10) / (rtol * np.abs(robertson_4e10) + ROBERTSON_ATOL)
    assert np.all(err < 3.0), err
    # the differences' Jacobian is as good as the exact one for the step control
    assert fd.stats["accepted"] <= 1.1 * exact.stats["accepted"] + 2


def test_overflow_at_a_rejected_trial_is_a_loose_answer_not_an_error(vdp_reference):
    # Van der Pol μ = 1000 at rtol 0.1: a trial step overflows fun (−inf); the step is
    # rejected and retried shorter, as on the traced path, not blamed on fun
    ref = vdp_reference.y[:, -1]
    for trace in (False, True):
        for jac in ((None, vdp_jac) if not trace else (None,)):
            with np.errstate(over="ignore", invalid="ignore"):
                r = reckon.solve_ivp(vdp, (0.0, 3000.0), [2.0, 0.0], method="Rodas5P", args=(1000.0,),
                                     jac=jac, rtol=0.1, atol=1e-9, trace=trace)
            assert r.status == 0 and r.traced == trace
            assert abs(r.y[0, -1] - ref[0]) < 0.05, (trace, jac, r.y[:, -1], ref)


@pytest.mark.parametrize("method", STIFF)
def test_hires_against_the_test_set(method):
    r = reckon.solve_ivp(hires, (0.0, HIRES_T), HIRES_Y0, method=method, rtol=1e-9, atol=1e-12)
    close(r.y[:, -1], HIRES_REF, 1e-7, 0)
    s = si.solve_ivp(hires, (0.0, HIRES_T), HIRES_Y0, method="BDF", rtol=1e-9, atol=1e-12)
    close(r.y[:, -1], s.y[:, -1], 1e-5, 0)


def test_backward_in_time():
    r = reckon.solve_ivp(oscillator, (5.0, 0.0), [np.cos(5.0), -np.sin(5.0)], rtol=1e-10, atol=1e-12,
                         t_eval=[4.0, 2.0, 0.0], dense_output=True)
    s = si.solve_ivp(oscillator, (5.0, 0.0), [np.cos(5.0), -np.sin(5.0)], rtol=1e-10, atol=1e-12,
                     t_eval=[4.0, 2.0, 0.0])
    np.testing.assert_array_equal(r.t, s.t)
    close(r.y, s.y, 0, 1e-8)
    close(r.y[:, -1], [1.0, 0.0], 0, 1e-9)
    close(r.sol(1.0), [np.cos(1.0), -np.sin(1.0)], 0, 1e-8)


def test_time_dependent_right_hand_side():
    # y' = cos t·y: y = exp(sin t)
    f = lambda t, y: np.cos(t) * y  # noqa: E731
    for method in ADAPTIVE:
        r = reckon.solve_ivp(f, (0.0, 6.0), [1.0], method=method, rtol=1e-9, atol=1e-12)
        close(r.y[0, -1], np.exp(np.sin(6.0)), 1e-6, 0)


def test_default_tolerances_are_scipys():
    # rtol = 1e-3, atol = 1e-6 by default: the steps (and so the points) match scipy's RK45
    r = reckon.solve_ivp(lorenz, (0.0, 1.0), [1.0, 1.0, 1.0])
    s = si.solve_ivp(lorenz, (0.0, 1.0), [1.0, 1.0, 1.0])
    tight = reckon.solve_ivp(lorenz, (0.0, 1.0), [1.0, 1.0, 1.0], rtol=1e-3, atol=1e-6)
    np.testing.assert_array_equal(r.t, tight.t)
    assert abs(len(r.t) - len(s.t)) <= max(3, len(s.t) // 5)
    close(r.y[:, -1], s.y[:, -1], 1e-2, 1e-2)


def test_events_terminal_and_direction():
    # a ball thrown up at 10 m/s: the apex (v falling through 0) is recorded, landing stops
    def height(t, y):
        return y[0]

    height.terminal = True
    height.direction = -1

    def apex(t, y):
        return y[1]

    apex.direction = -1

    def rising(t, y):  # never fires: the velocity only falls
        return y[1]

    rising.direction = 1

    f = lambda t, y: [y[1], -9.81]  # noqa: E731
    r = reckon.solve_ivp(f, (0.0, 10.0), [0.0, 10.0], events=[height, apex, rising])
    s = si.solve_ivp(f, (0.0, 10.0), [0.0, 10.0], events=[height, apex, rising])
    assert r.status == s.status == 1
    assert r.message == s.message
    assert r.t[-1] == pytest.approx(20.0 / 9.81, rel=1e-12)
    close(r.t_events[0], [20.0 / 9.81], 1e-12, 0)
    close(r.t_events[1], [10.0 / 9.81], 1e-12, 0)
    close(r.y_events[1], [[100.0 / (2 * 9.81), 0.0]], 1e-12, 1e-12)
    for a, b in zip(r.t_events, s.t_events):
        close(a, b, 1e-9, 0)
    for a, b in zip(r.y_events, s.y_events):
        assert a.shape == b.shape
        close(a, b, 1e-9, 1e-9)


def test_nonterminal_events_count_every_crossing():
    # zeros of cos t on (0, 20): π/2 + kπ; rising ones (−cos goes up... here y0 = cos t) at 3π/2 + 2kπ
    def zero(t, y):
        return y[0]

    def up(t, y):
        return y[0]

    up.direction = 1
    r = reckon.solve_ivp(oscillator, (0.0, 20.0), [1.0, 0.0], events=[zero, up], rtol=1e-10, atol=1e-12)
    s = si.solve_ivp(oscillator, (0.0, 20.0), [1.0, 0.0], events=[zero, up], rtol=1e-10, atol=1e-12)
    k = np.arange(6)
    close(r.t_events[0], np.pi / 2 + k * np.pi, 1e-9, 0)
    close(r.t_events[1], 3 * np.pi / 2 + 2 * np.arange(3) * np.pi, 1e-9, 0)
    close(r.t_events[0], s.t_events[0], 1e-8, 0)
    close(r.t_events[1], s.t_events[1], 1e-8, 0)
    assert r.status == 0 and r.t[-1] == 20.0


@pytest.mark.parametrize("method", ["RK45", "BDF", "Rodas5P"])
def test_terminal_count_stops_at_the_nth_zero(method):
    # terminal = 3: the run stops at the third zero of cos t, 5π/2, as scipy's does
    def zero(t, y):
        return y[0]

    zero.terminal = 3
    r = reckon.solve_ivp(oscillator, (0.0, 20.0), [1.0, 0.0], method=method, events=zero, rtol=1e-10, atol=1e-12)
    s = si.solve_ivp(oscillator, (0.0, 20.0), [1.0, 0.0], events=zero, rtol=1e-10, atol=1e-12)
    want = np.pi / 2 + np.arange(3) * np.pi
    close(r.t_events[0], want, 1e-8, 0)
    close(s.t_events[0], want, 1e-8, 0)
    assert r.status == s.status == 1
    assert abs(r.t[-1] - 2.5 * np.pi) < 1e-8 and abs(s.t[-1] - 2.5 * np.pi) < 1e-8
    # not yet at the count: the run reaches the end with both zeros recorded
    zero.terminal = 9
    r = reckon.solve_ivp(oscillator, (0.0, 5.0), [1.0, 0.0], method=method, events=zero, rtol=1e-10, atol=1e-12)
    assert r.status == 0 and r.t[-1] == 5.0 and len(r.t_events[0]) == 2


def test_events_get_args_and_terminal_with_t_eval():
    def below(t, y, level):
        return y[0] - level

    below.terminal = True
    t_eval = np.linspace(0.0, 5.0, 11)
    r = reckon.solve_ivp(lambda t, y, level: -y, (0.0, 5.0), [1.0], events=below, args=(0.25,),
                         t_eval=t_eval, rtol=1e-10, atol=1e-12)
    s = si.solve_ivp(lambda t, y, level: -y, (0.0, 5.0), [1.0], events=below, args=(0.25,),
                     t_eval=t_eval, rtol=1e-10, atol=1e-12)
    assert r.status == s.status == 1
    close(r.t_events[0], [np.log(4.0)], 1e-9, 0)
    # only the output times reached, as scipy: not the stop point
    np.testing.assert_array_equal(r.t, s.t)
    np.testing.assert_array_equal(r.t, t_eval[t_eval <= np.log(4.0)])
    close(r.y, s.y, 1e-7, 0)


def test_constant_jacobian_and_exponential_euler_exact_on_linear():
    import scipy.linalg

    a = np.array([[-2.0, 1.0, 0.0], [1.0, -2.0, 1.0], [0.0, 1.0, -200.0]])
    y0 = np.array([1.0, 0.5, -1.0])
    exact = scipy.linalg.expm(2.0 * a) @ y0
    r = reckon.solve_ivp(lambda t, y: a @ y, (0.0, 2.0), y0, method="ExponentialEuler", jac=a)
    close(r.y[:, -1], exact, 1e-12, 1e-14)
    assert r.jacobian == "constant jac"
    for method in STIFF:
        q = reckon.solve_ivp(lambda t, y: a @ y, (0.0, 2.0), y0, method=method, jac=a, rtol=1e-9, atol=1e-12)
        close(q.y[:, -1], exact, 1e-6, 1e-11)


def test_euler_takes_first_step_as_its_fixed_step():
    r = reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method="Euler", first_step=0.1)
    close(r.y[0], 0.9 ** np.arange(11), 1e-14, 0)
    close(r.t, np.linspace(0.0, 1.0, 11), 1e-14, 1e-15)
    assert r.nfev == 10


def test_implicit_euler_fixed_and_adaptive():
    # fixed steps: y_{k+1} = y_k / (1 + h)
    r = reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method="ImplicitEuler", fixed_step=0.1)
    close(r.y[0], (1 / 1.1) ** np.arange(11), 1e-10, 0)
    r = reckon.solve_ivp(vdp, (0.0, 3000.0), [2.0, 0.0], method="ImplicitEuler", args=(1000.0,),
                         rtol=1e-3, atol=1e-3, t_eval=[3000.0])
    close(r.y[0, -1], -1.5106, 2e-2, 0)  # first order: a few digits


def test_lsoda_runs_auto():
    r = reckon.solve_ivp(vdp, (0.0, 100.0), [2.0, 0.0], method="LSODA", args=(1000.0,), rtol=1e-8, atol=1e-8)
    a = reckon.solve_ivp(vdp, (0.0, 100.0), [2.0, 0.0], method="Auto", args=(1000.0,), rtol=1e-8, atol=1e-8)
    assert r.method == "Auto"
    np.testing.assert_array_equal(r.y, a.y)


def test_vectorized_and_per_component_atol():
    def f(t, y):
        assert y.ndim == 2
        return np.vstack([y[1], -y[0]])

    r = reckon.solve_ivp(f, (0.0, 3.0), [1.0, 0.0], vectorized=True, rtol=1e-10, atol=[1e-12, 1e-12])
    close(r.y[:, -1], [np.cos(3.0), -np.sin(3.0)], 0, 1e-9)


@pytest.mark.parametrize("method", ["RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "ExponentialEuler"])
def test_dense_output_agrees_with_t_eval_for_every_method(method):
    # t_eval is evaluated from the same step polynomials that sol keeps: one run, both views
    mu = 10.0 if method in ("RK45", "ImplicitEuler", "ExponentialEuler") else 1000.0
    t_eval = np.linspace(0.0, 20.0, 41)
    # implicit Euler is first order and holds its global error near rtol: ~10× the steps per digit
    tol = 1e-3 if method == "ImplicitEuler" else 1e-6
    r = reckon.solve_ivp(vdp, (0.0, 20.0), [2.0, 0.0], method=method, args=(mu,), t_eval=t_eval,
                         dense_output=True, rtol=tol, atol=tol * 1e-2)
    assert r.success
    close(r.sol(t_eval), r.y, 1e-12, 1e-12)
    if method == "ImplicitEuler":
        return  # its accuracy: test_implicit_euler_fixed_and_adaptive
    s = si.solve_ivp(vdp, (0.0, 20.0), [2.0, 0.0], method="Radau", args=(mu,), t_eval=t_eval,
                     rtol=1e-10, atol=1e-10)
    loose = 2e-2 if method == "ExponentialEuler" else 1e-3
    close(r.y, s.y, loose, loose)


@pytest.mark.parametrize("method", ["BDF", "Rodas5P", "Auto", "ExponentialEuler"])
@pytest.mark.parametrize("jac", ["differences", "sparse"])
def test_heat_equation_decays_as_its_eigenmode(method, jac):
    # u_t = u_xx on (0, 1), u = 0 at both ends, N interior points: the sine mode is an
    # eigenvector of the discrete Laplacian, so u(t) = e^{λt}·u(0), λ = −(4/h²)·sin²(πh/2)
    import scipy.sparse

    n = 40
    h = 1.0 / (n + 1)
    x = np.arange(1, n + 1) * h
    lap = scipy.sparse.diags([np.ones(n - 1), -2 * np.ones(n), np.ones(n - 1)], [-1, 0, 1]) / h**2
    dense = lap.toarray()
    lam = -(4 / h**2) * np.sin(np.pi * h / 2) ** 2
    u0 = np.sin(np.pi * x)
    # ExponentialEuler is exact at its step ends, which can be far apart; between them its
    # dense output (and so t_eval) is a cubic Hermite interpolant, not held to the tolerance
    t_eval = None if method == "ExponentialEuler" else [0.05, 0.1, 0.2]
    r = reckon.solve_ivp(lambda t, u: dense @ u, (0.0, 0.2), u0, method=method, t_eval=t_eval,
                         jac=lap if jac == "sparse" else None, rtol=1e-8, atol=1e-12)
    assert r.success and r.t[-1] == 0.2
    close(r.y, np.outer(u0, np.exp(lam * r.t)), 1e-6 if t_eval else 1e-12, 1e-12)
    # without jac the function traces (dense @ u on symbols): the exact compiled Jacobian
    assert r.jacobian == ("constant jac" if jac == "sparse" else "traced")

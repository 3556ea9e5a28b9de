"""reckon.sensitivities and reckon.calibration against closed forms, independent
references (scipy, finite differences, synthetic data with known parameters), and their
errors."""

import doctest
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp as scipy_solve_ivp

import reckon
from reckon import _sensitivity, calibration


@pytest.mark.parametrize("method,tol", [("RK45", 1e-8), ("BDF", 1e-6), ("Rodas5P", 1e-7),
                                        ("ImplicitEuler", None)])
def test_decay_against_the_closed_form(method, tol):
    k, x0 = 0.5, 2.0
    t = np.linspace(0.25, 3.0, 12)
    if tol is None:  # first order: fixed steps, its own discrete derivatives
        h = 0.01
        r = reckon.sensitivities(lambda t, y, k: -k * y, (0, 3.0), [x0], [k], method=method, fixed_step=h)
        # x_j = x0 (1 + hk)^{-j}: ∂x/∂x0 = (1 + hk)^{-j}, ∂x/∂k = −j h x0 (1 + hk)^{-j-1}
        j = np.rint(r.t / h)
        assert np.max(np.abs(r.y[0] - x0 * (1 + h * k) ** -j)) < 1e-13
        assert np.max(np.abs(r.dy_dy0[0, 0] - (1 + h * k) ** -j)) < 1e-13
        assert np.max(np.abs(r.dy_dp[0, 0] + j * h * x0 * (1 + h * k) ** (-j - 1))) < 1e-12
        return
    r = reckon.sensitivities(lambda t, y, k: -k * y, (0, 3.0), [x0], [k], method=method, t_eval=t,
                             rtol=1e-10, atol=1e-12)
    assert np.array_equal(r.t, t) and r.y.shape == (1, 12)
    assert r.dy_dy0.shape == (1, 1, 12) and r.dy_dp.shape == (1, 1, 12)
    e = np.exp(-k * t)
    assert np.max(np.abs(r.y[0] - x0 * e)) < tol
    assert np.max(np.abs(r.dy_dy0[0, 0] - e)) < tol
    assert np.max(np.abs(r.dy_dp[0, 0] + t * x0 * e)) < 4 * tol
    assert r.params == ("k",)


def lotka(t, y, a, b, c, d):
    return [a * y[0] - b * y[0] * y[1], c * y[0] * y[1] - d * y[1]]


def test_lotka_volterra_against_central_differences_of_scipy():
    p = np.array([1.1, 0.4, 0.1, 0.4])
    y0 = np.array([10.0, 5.0])
    t = np.linspace(1.0, 10.0, 10)
    r = reckon.sensitivities(lotka, (0, 10.0), y0, p, t_eval=t, rtol=1e-11, atol=1e-12)
    ref = lambda y0, p: scipy_solve_ivp(lotka, (0, 10.0), y0, "DOP853", t_eval=t, args=tuple(p),
                                        rtol=1e-13, atol=1e-13).y
    assert np.max(np.abs(r.y - ref(y0, p)) / np.abs(r.y)) < 1e-8
    for j in range(4):
        h = 1e-5 * p[j]
        up, down = p.copy(), p.copy()
        up[j] += h
        down[j] -= h
        fd = (ref(y0, up) - ref(y0, down)) / (2 * h)
        scale = np.max(np.abs(fd))
        assert np.max(np.abs(r.dy_dp[:, j, :] - fd)) < 1e-5 * scale, j
    for j in range(2):
        h = 1e-5 * y0[j]
        up, down = y0.copy(), y0.copy()
        up[j] += h
        down[j] -= h
        fd = (ref(up, p) - ref(down, p)) / (2 * h)
        assert np.max(np.abs(r.dy_dy0[:, j, :] - fd)) < 1e-5 * np.max(np.abs(fd)), j
    # wrt="params": the same ∂y/∂p, without the ∂y/∂y0 columns
    q = reckon.sensitivities(lotka, (0, 10.0), y0, p, t_eval=t, rtol=1e-11, atol=1e-12, wrt="params")
    assert q.dy_dy0 is None and q.dy_dp.shape == (2, 4, 10)
    assert np.max(np.abs(q.dy_dp - r.dy_dp)) < 1e-6 * np.max(np.abs(r.dy_dp))


def test_sensitivities_bad_input():
    f = lambda t, y, k: -k * y
    with pytest.raises(reckon.Untraceable):
        reckon.sensitivities(lambda t, y, k: -k * y if y[0] > 0 else y, (0, 1), [1.0], [0.5])
    with pytest.raises(reckon.InvalidInput, match="returned 2 values"):
        reckon.sensitivities(lambda t, y, k: [-k * y[0], 0.0], (0, 1), [1.0], [0.5])
    with pytest.raises(reckon.InvalidInput) as e:
        reckon.sensitivities(f, (0, 1), [math.nan], [0.5])
    assert e.value.what == "y0"
    with pytest.raises(reckon.InvalidInput, match="params"):
        reckon.sensitivities(f, (0, 1), [1.0], [math.inf])
    with pytest.raises(reckon.InvalidInput, match="method"):
        reckon.sensitivities(f, (0, 1), [1.0], [0.5], method="Radau")
    with pytest.raises(reckon.InvalidInput, match="wrt"):
        reckon.sensitivities(lambda t, y: -y, (0, 1), [1.0], wrt="params")
    with pytest.raises(reckon.InvalidInput, match="y0"):
        reckon.sensitivities(f, (0, 1), [], [0.5])
    with pytest.raises(reckon.InvalidInput, match="t_span"):
        reckon.sensitivities(f, (0, 1, 2), [1.0], [0.5])
    with pytest.raises(reckon.InvalidInput, match="fixed_step"):
        reckon.sensitivities(f, (0, 1), [1.0], [0.5], method="Euler")
    # the state overflows: the typed error, not a crash
    with pytest.raises(reckon.Error):
        reckon.sensitivities(lambda t, y, k: k * y * y, (0, 10), [1.0], [1.0])


def test_least_squares_recovers_known_parameters():
    # y' = −k·y + c: y(t) = c/k + (y0 − c/k)·e^{−kt}
    k, c, y0 = 0.8, 0.3, 2.0
    t = np.linspace(0.2, 6.0, 30)
    exact = c / k + (y0 - c / k) * np.exp(-k * t)
    f = lambda t, y, k, c: -k * y + c
    fit = calibration.least_squares(f, t, exact, [0.3, 0.0], [y0], sigma=1e-3)
    assert fit.names == ("k", "c")
    assert np.max(np.abs(fit.params - [k, c])) < 1e-7
    assert fit.dof == 28 and fit.iterations >= 2
    # with noise of σ = 1e-3 (seed 1): within 4σ of the truth, and σ̂² ≈ 1
    rng = np.random.default_rng(1)
    noisy = exact + 1e-3 * rng.standard_normal(len(t))
    fit = calibration.least_squares(f, t, noisy, [0.3, 0.0], [y0], sigma=1e-3)
    assert np.all(np.abs(fit.params - [k, c]) < 4 * fit.std)
    assert np.all(fit.std < 2e-3) and 0.4 < fit.sigma2 < 1.8
    assert fit.covariance.shape == (2, 2) and fit.residuals.shape == (30,)
    # two components observed, one parameter: Lotka–Volterra's a
    p = (1.1, 0.4, 0.1, 0.4)
    tt = np.linspace(0.5, 5.0, 10)
    obs = scipy_solve_ivp(lotka, (0, 5.0), [10.0, 5.0], "DOP853", t_eval=tt, args=p, rtol=1e-13, atol=1e-13).y
    g = lambda t, y, a: lotka(t, y, a, *p[1:])
    fit = calibration.least_squares(g, tt, obs, [1.0], [10.0, 5.0], sigma=[1e-3, 1e-3])
    assert abs(fit.params[0] - 1.1) < 1e-7


def test_least_squares_bad_input():
    f = lambda t, y, k: -k * y
    t = np.linspace(0.5, 2, 4)
    with pytest.raises(reckon.InvalidInput, match="shape"):
        calibration.least_squares(f, t, np.ones(3), [1.0], [1.0])
    with pytest.raises(reckon.InvalidInput, match="σ"):
        calibration.least_squares(f, t, np.ones(4), [1.0], [1.0], sigma=-1.0)
    with pytest.raises(reckon.InvalidInput, match="increasing"):
        calibration.least_squares(f, t[::-1], np.ones(4), [1.0], [1.0])
    with pytest.raises(reckon.InvalidInput, match="components"):
        calibration.least_squares(f, t, np.ones(4), [1.0], [1.0], components=[1])
    with pytest.raises(reckon.InvalidInput, match="angles"):
        calibration.least_squares(f, t, np.ones(4), [1.0], [1.0], angles=[3])
    with pytest.raises(reckon.InvalidInput, match="p0"):
        calibration.least_squares(lambda t, y: -y, t, np.ones(4), [], [1.0])
    # data that cannot tell a parameter: y' = −(a + b)·y
    with pytest.raises(reckon.Unidentifiable):
        calibration.least_squares(lambda t, y, a, b: -(a + b) * y, t, np.exp(-t), [0.5, 0.4], [1.0])


def test_encoder_least_squares_recovers_the_geometry():
    from reckon import vehicles

    truth = np.array([0.0502, 0.0497, 0.412])  # r_l, r_r, b
    n_pulses = 1000.0
    t = np.linspace(0.0, 20.0, 401)
    dt = np.diff(t)
    rng = np.random.default_rng(2)
    speeds = np.c_[8 + 4 * np.sin(0.3 * t[:-1]), 8 + 4 * np.cos(0.2 * t[:-1])] + rng.uniform(-1, 1, (400, 2))
    ticks = speeds * dt[:, None] * n_pulses / (2 * np.pi)  # increments over (t[k-1], t[k]]
    left = np.r_[0.0, ticks[:, 0]]
    right = np.r_[0.0, ticks[:, 1]]
    pose_t = t[::20]
    truth_path = vehicles.simulate(vehicles.DiffDrive(*truth), [0.0, 0.0, 0.0], t, speeds)
    poses = truth_path.y[:, ::20]
    fit = calibration.encoder_least_squares(t, left, right, pose_t, poses, wheel_diameter=0.1,
                                            wheel_separation=0.4, pulses_per_rev=n_pulses,
                                            sigma=(1e-3, 1e-3, 1e-3))
    assert np.max(np.abs(fit.params - truth) / truth) < 1e-6
    assert len(fit.names) == 3 and fit.dof == 3 * 20 - 3
    with pytest.raises(reckon.InvalidInput, match="poses"):
        calibration.encoder_least_squares(t, left, right, pose_t, poses[:2], wheel_diameter=0.1,
                                          wheel_separation=0.4, pulses_per_rev=n_pulses)
    with pytest.raises(reckon.InvalidInput) as e:
        calibration.encoder_least_squares(t, left, right, pose_t, poses, wheel_diameter=0.1,
                                          wheel_separation=0.0, pulses_per_rev=n_pulses)
    assert e.value.what == "wheel_separation"


def umbmark_runs(alpha, beta, side, n, noise, rng):
    """Return errors of the first-order model: x_cw = y_cw = −2L(α + β), x_ccw = −y_ccw = 2L(β − α)."""
    cw = np.tile([-2 * side * (alpha + beta), -2 * side * (alpha + beta)], (n, 1))
    ccw = np.tile([2 * side * (beta - alpha), -2 * side * (beta - alpha)], (n, 1))
    return cw + noise * rng.standard_normal((n, 2)), ccw + noise * rng.standard_normal((n, 2))


def test_umbmark_recovers_alpha_and_beta():
    alpha, beta, side, b = 0.012, -0.004, 4.0, 0.5
    rng = np.random.default_rng(3)
    cw, ccw = umbmark_runs(alpha, beta, side, 5, 0.0, rng)
    fit = calibration.umbmark(cw, ccw, side, b)
    assert abs(fit.alpha - alpha) < 1e-15 and abs(fit.beta - beta) < 1e-15
    q = b * math.sin(beta / 2) / side
    assert abs(fit.e_d - (1 + q) / (1 - q)) < 1e-15
    assert abs(fit.e_b - (math.pi / 2) / (math.pi / 2 - alpha)) < 1e-15
    assert abs(fit.radius - side / 2 / math.sin(beta / 2)) < 1e-9
    dl, dr = fit.wheel_diameters(0.1)
    assert abs(dr / dl - fit.e_d) < 1e-15 and abs(dl + dr - 0.2) < 1e-16
    assert fit.wheelbase(0.5) == fit.e_b * 0.5
    assert np.allclose(fit.residuals, 0.0, atol=1e-16)
    # noisy runs (σ = 2 cm, 10 per direction): within 4 standard deviations
    cw, ccw = umbmark_runs(alpha, beta, side, 10, 0.02, rng)
    fit = calibration.umbmark(cw, ccw, side, b)
    truth = [(1 + q) / (1 - q), (math.pi / 2) / (math.pi / 2 - alpha)]
    assert np.all(np.abs([fit.e_d, fit.e_b] - np.array(truth)) < 4 * fit.std)
    assert np.all(fit.std > 0)


def test_umbmark_bad_input():
    ok = [[0.0, 0.0]]
    with pytest.raises(reckon.InvalidInput, match="at least one"):
        calibration.umbmark(np.zeros((0, 2)), ok, 4.0, 0.5)
    with pytest.raises(reckon.InvalidInput) as e:
        calibration.umbmark(ok, ok, -4.0, 0.5)
    assert e.value.what == "side"
    with pytest.raises(reckon.InvalidInput, match="not finite"):
        calibration.umbmark([[math.nan, 0.0]], ok, 4.0, 0.5)
    with pytest.raises(reckon.InvalidInput, match="shape"):
        calibration.umbmark([0.0, 0.0, 0.0], ok, 4.0, 0.5)
    with pytest.raises(reckon.Unidentifiable):
        calibration.umbmark([[-20.0, -20.0]], [[-20.0, 20.0]], 4.0, 0.5)  # α ≥ 90°


def oplus(a, b):
    s, c = math.sin(a[2]), math.cos(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])


def ominus(a):
    s, c = math.sin(a[2]), math.cos(a[2])
    return np.array([-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2]])


def sensor_motion(rl, rr, b, ell, wheels):
    """s = ⊖ℓ ⊕ o ⊕ ℓ with o the robot's exact arcs over the sub-samples (independent of reckon)."""
    o = np.zeros(3)
    for pl, pr in wheels:
        o = arc(o, 0.5 * (rl * pl + rr * pr), (rr * pr - rl * pl) / b, 1.0)
    return oplus(ominus(ell), oplus(o, ell))


def arc(x0, v, w, h):
    x, y, th = x0
    if w == 0.0:
        return np.array([x + v * h * math.cos(th), y + v * h * math.sin(th), th])
    return np.array([x + v / w * (math.sin(th + w * h) - math.sin(th)),
                     y - v / w * (math.cos(th + w * h) - math.cos(th)), th + w * h])


def test_censi_recovers_the_geometry_and_the_sensor_pose():
    rl, rr, b, ell = 0.05, 0.051, 0.4, np.array([0.1, -0.05, 0.3])
    rng = np.random.default_rng(11)
    wheels = [rng.uniform(-3, 6, (5, 2)) for _ in range(40)]
    sensor = np.array([sensor_motion(rl, rr, b, ell, w) for w in wheels])
    fit = calibration.censi(wheels, sensor, trim=(0.0, 0))
    assert abs(fit.r_l - rl) < 1e-12 and abs(fit.r_r - rr) < 1e-12 and abs(fit.b - b) < 1e-12
    assert np.max(np.abs(fit.sensor - ell)) < 1e-12
    assert abs(fit.j21 + rl / b) < 1e-12 and abs(fit.j22 - rr / b) < 1e-12
    assert len(fit.kept) == 40 and fit.covariance.shape == (8, 8)
    # a (K, k, 2) array works as well
    same = calibration.censi(np.array(wheels), sensor, trim=(0.0, 0))
    assert same.b == fit.b
    # scan-matcher noise: within 4 standard deviations
    noisy = sensor + rng.standard_normal(sensor.shape) * [0.002, 0.002, 0.001]
    fit = calibration.censi(wheels, noisy, trim=(0.0, 0))
    truth = np.array([rl, rr, b, *ell])
    est = np.array([fit.r_l, fit.r_r, fit.b, *fit.sensor])
    std = fit.std[[6, 7, 2, 3, 4, 5]]
    assert np.all(np.abs(est - truth) < 4 * std), (est - truth) / std
    assert fit.dof == 3 * 40 - 6


def test_censi_bad_input():
    w = [np.ones((2, 2))] * 2
    with pytest.raises(reckon.InvalidInput, match="at least 3"):
        calibration.censi(w, np.zeros((2, 3)))
    with pytest.raises(reckon.InvalidInput, match="intervals"):
        calibration.censi(w, np.zeros((3, 3)))
    with pytest.raises(reckon.InvalidInput, match="shape"):
        calibration.censi([np.ones((2, 3))] * 3, np.zeros((3, 3)))
    with pytest.raises(reckon.InvalidInput, match="trim"):
        calibration.censi([np.ones((2, 2))] * 3, np.zeros((3, 3)), trim=(0.7, 1))
    with pytest.raises(reckon.InvalidInput):
        calibration.censi([np.full((2, 2), math.nan)] * 3, np.zeros((3, 3)))
    # every interval drives the same way: J21, J22 cannot be told apart
    with pytest.raises(reckon.Unidentifiable):
        calibration.censi([np.ones((2, 2))] * 4, np.tile([0.1, 0.0, 0.0], (4, 1)), trim=(0.0, 0))


def test_the_docstring_examples():
    for mod in (calibration, _sensitivity):
        assert doctest.testmod(mod, raise_on_error=True).attempted >= 3

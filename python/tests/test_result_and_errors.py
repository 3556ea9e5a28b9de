"""The result's fields as scipy's; user-function faults and invalid input as exceptions."""

import pickle

import numpy as np
import pytest
import scipy.integrate as si

import reckon
from problems import close, oscillator, vdp

SHARED = ["t", "y", "sol", "t_events", "y_events", "nfev", "njev", "nlu", "status", "message", "success"]


def _kind(v):
    if isinstance(v, np.ndarray):
        return ("ndarray", v.dtype, v.ndim)
    if isinstance(v, list):
        return ("list", [_kind(x) for x in v])
    return type(v)


@pytest.mark.parametrize("with_events", [False, True])
@pytest.mark.parametrize("t_eval", [None, np.linspace(0.0, 4.0, 5)])
def test_fields_shapes_and_types_as_scipys(with_events, t_eval):
    def crossing(t, y):
        return y[0]

    def never(t, y):  # no zero: scipy's empty t_events / y_events shapes
        return 2.0 + y[0]

    events = [crossing, never] if with_events else None
    kw = dict(t_eval=t_eval, events=events, dense_output=True)
    r = reckon.solve_ivp(oscillator, (0.0, 4.0), [1.0, 0.0], **kw)
    s = si.solve_ivp(oscillator, (0.0, 4.0), [1.0, 0.0], **kw)
    for name in SHARED:
        assert name in r and hasattr(r, name), name
        if name == "sol":
            continue
        assert _kind(r[name]) == _kind(s[name]), name
    assert r.y.shape[0] == 2 and r.y.shape[1] == r.t.shape[0]
    if t_eval is not None:
        assert r.t.shape == s.t.shape == (5,)
    if with_events:
        for a, b in zip(r.t_events, s.t_events):
            assert a.shape == b.shape
        for a, b in zip(r.y_events, s.y_events):
            assert a.shape == b.shape  # (k, n), and (0,) when empty as scipy
        assert r.y_events[1].shape == (0,)
    else:
        assert r.t_events is None and r.y_events is None
    assert callable(r.sol)
    assert r.sol(1.0).shape == s.sol(1.0).shape
    assert r.sol([1.0, 2.0]).shape == s.sol([1.0, 2.0]).shape
    assert (r.status, r.success) == (s.status, s.success) == (0, True)
    assert r.message == s.message
    for k in ("rhs_evals", "jacobian_evals", "lu_decompositions", "newton_iterations", "accepted",
              "rejected", "fun_calls"):
        assert isinstance(r.stats[k], int)
    assert r.nfev == r.stats["rhs_evals"] and r.nfev > 0
    assert r.stiffness is None and r.switches == []


def test_dense_output_off_gives_no_sol():
    r = reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0])
    assert r.sol is None


def test_empty_t_eval():
    r = reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], t_eval=[])
    s = si.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], t_eval=[])
    assert len(s.t) == len(r.t) == 0  # scipy gives lists here; reckon arrays of no points
    assert r.t.shape == (0,) and r.y.shape == (2, 0)


def test_stiffness_is_reported_by_rk45():
    r = reckon.solve_ivp(vdp, (0.0, 30.0), [2.0, 0.0], args=(1000.0,), rtol=1e-6, atol=1e-6)
    assert r.success and r.stiffness is not None
    assert 0.0 < r.stiffness["t"] < 30.0 and r.stiffness["h_lambda"] > 3.0


class Boom(Exception):
    pass


def test_exception_in_fun_comes_out_as_itself():
    calls = []

    def f(t, y):
        calls.append(t)
        if t > 0.5:
            raise Boom("at t > 0.5")
        return -y

    for method in ["RK45", "BDF", "Rodas5P", "Auto", "ImplicitEuler", "ExponentialEuler"]:
        calls.clear()
        with pytest.raises(Boom, match="at t > 0.5"):
            # trace=False: the callback mode (traced, `t > 0.5` is refused and f is called back)
            reckon.solve_ivp(f, (0.0, 2.0), [1.0], method=method, trace=False)
        assert max(calls) > 0.5  # raised where it happened, then not called again
        assert sum(t > 0.5 for t in calls) == 1


def test_exception_in_jac_and_event():
    def bad_jac(t, y):
        raise KeyError("jac")

    with pytest.raises(KeyError, match="jac"):
        reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method="BDF", jac=bad_jac)

    def bad_event(t, y):
        if t > 0.3:
            raise RuntimeError("event broke")
        return y[0] - 10.0

    with pytest.raises(RuntimeError, match="event broke"):
        reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], events=bad_event)


def test_keyboard_interrupt_is_not_swallowed():
    def f(t, y):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        reckon.solve_ivp(f, (0.0, 1.0), [1.0])


def test_nan_from_fun_is_nonfinite_with_fields():
    def f(t, y):
        return [y[1], np.nan if t > 0.25 else -y[0]]

    with pytest.raises(reckon.NonFinite) as info:
        reckon.solve_ivp(f, (0.0, 1.0), [1.0, 0.0])
    e = info.value
    assert isinstance(e, reckon.Error) and isinstance(e, FloatingPointError)
    assert e.component == 1 and e.quantity == "derivative" and e.t > 0.25
    assert "nan" in str(e).lower() and "component 1" in str(e)

    with pytest.raises(reckon.NonFinite, match="inf"), np.errstate(divide="ignore"):
        reckon.solve_ivp(lambda t, y: y / 0.0, (0.0, 1.0), [1.0])


def test_none_from_fun_names_the_missing_return():
    def f(t, y):
        -y  # noqa: B018  (the return forgotten)

    for y0 in ([1.0], [1.0, 2.0]):
        with pytest.raises(ValueError, match="returned None"):
            reckon.solve_ivp(f, (0.0, 1.0), y0, trace=False)


def test_first_step_beyond_the_span_is_scipys_error():
    with pytest.raises(ValueError, match="exceeds bounds") as scipy_error:
        si.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], first_step=2.0)
    for method in ("RK45", "BDF", "Rodas5P"):
        with pytest.raises(ValueError, match="exceeds bounds") as info:
            reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method=method, first_step=2.0)
        assert str(info.value) == str(scipy_error.value)
    # backward, and a first step that fits
    with pytest.raises(ValueError, match="exceeds bounds"):
        reckon.solve_ivp(lambda t, y: -y, (1.0, 0.0), [1.0], first_step=1.5)
    assert reckon.solve_ivp(lambda t, y: -y, (1.0, 0.0), [1.0], first_step=0.5).success


@pytest.mark.parametrize("bad", [0, -1, 2**64, 2**70, 1.5, "10"])
def test_max_steps_is_a_count_named_in_the_error(bad):
    with pytest.raises(reckon.InvalidInput) as info:
        reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], max_steps=bad)
    assert info.value.what == "max_steps"


def test_a_dense_result_pickles_and_deep_copies():
    import copy

    r = reckon.solve_ivp(oscillator, (0.0, 3.0), [1.0, 0.0], dense_output=True, rtol=1e-8, atol=1e-10)
    for back in (pickle.loads(pickle.dumps(r)), copy.deepcopy(r)):
        ts = np.linspace(-0.5, 3.5, 41)
        np.testing.assert_array_equal(back.sol(ts), r.sol(ts))
        assert (back.sol.t_min, back.sol.t_max) == (r.sol.t_min, r.sol.t_max)
        np.testing.assert_array_equal(back.y, r.y)
    # a pickle is data from outside: a malformed one is refused, not a crash
    make, (n, lo, hi, fwd, segs) = r.sol.__reduce__()
    assert len(segs) > 1
    for bad in ((0, lo, hi, fwd, segs), (n, lo, hi, fwd, [(0.0, 0.1, 0.1, [1.0])]),
                (n, lo, hi, fwd, [(0.0, 0.1, 0.1, [])]), (n, lo, hi, not fwd, segs),
                (n, lo, hi, fwd, segs[::-1]), (n, hi + 1.0, hi, fwd, segs),
                (n, lo, hi, fwd, [(0.0, 0.1, 0.1, [1.0, float("nan")])])):
        with pytest.raises(reckon.InvalidInput, match="DenseOutput"):
            make(*bad)


def test_a_dense_jacobian_beyond_memory_is_refused_up_front():
    # called back (not traced), an implicit method needs dense n×n matrices: at 10⁵
    # states 240 GB, refused before any allocation (it aborted the process)
    y0 = np.ones(100_000)
    for method in ("BDF", "Rodas5P", "Auto"):
        with pytest.raises(reckon.InvalidInput, match="dense 100000×100000") as info:
            reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), y0, method=method, trace=False)
        assert info.value.what == "method" and "reckon.Model" in info.value.reason
    # the explicit methods need no Jacobian, and the traced model has the sparse path
    assert reckon.solve_ivp(lambda t, y: -y, (0.0, 1e-3), y0, method="RK45", trace=False).success


def test_nan_from_jac():
    with pytest.raises(reckon.NonFinite) as info:
        reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], method="Rodas5P", jac=lambda t, y: [[np.nan]])
    assert info.value.quantity == "Jacobian"


@pytest.mark.parametrize("bad", [[1.0, 2.0, 3.0], [1.0], np.zeros((2, 2)), "ab"])
def test_wrong_length_or_shape_from_fun(bad):
    with pytest.raises(ValueError, match=r"fun\(t, y\) returned"):
        reckon.solve_ivp(lambda t, y: bad, (0.0, 1.0), [1.0, 0.0])


def test_wrong_shape_from_jac():
    with pytest.raises(ValueError, match=r"jac returned an array of shape \(3, 3\), expected \(2, 2\)"):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], method="BDF", jac=np.eye(3))


def test_scalar_return_for_one_state_and_lists():
    r = reckon.solve_ivp(lambda t, y: -float(y[0]), (0.0, 1.0), [1.0], rtol=1e-10, atol=1e-12)
    close(r.y[0, -1], np.exp(-1.0), 1e-9, 0)


@pytest.mark.parametrize(
    "method, hint",
    [("Radau", "Rodas5P"), ("RK23", "RK45"), ("DOP853", "RK45"), ("Nope", "reckon offers RK45, BDF")],
)
def test_methods_reckon_does_not_have(method, hint):
    with pytest.raises(ValueError, match=hint):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], method=method)


def test_scipy_solver_class_as_method():
    r = reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], method=si.BDF)
    assert r.method == "BDF"
    with pytest.raises(ValueError, match="Rodas5P"):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], method=si.Radau)


def test_euler_needs_a_step():
    with pytest.raises(reckon.InvalidInput, match="first_step") as info:
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], method="Euler")
    assert isinstance(info.value, ValueError) and info.value.what == "first_step"


def test_invalid_input_is_typed():
    with pytest.raises(reckon.InvalidInput) as info:
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], atol=-1.0)
    assert info.value.what == "atol" and "non-negative" in info.value.reason
    with pytest.raises(ValueError, match="not within `t_span`"):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], t_eval=[0.5, 2.0])
    with pytest.raises(ValueError, match="not properly sorted"):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], t_eval=[0.5, 0.2])
    with pytest.raises(ValueError, match="1-dimensional"):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [[1.0, 0.0]])
    with pytest.raises(TypeError, match="args"):
        reckon.solve_ivp(vdp, (0.0, 1.0), [1.0, 0.0], args=1000.0)


def test_rtol_below_100_eps_is_raised_with_a_warning():
    with pytest.warns(UserWarning, match="rtol"):
        r = reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], rtol=1e-16, atol=1e-16)
    close(r.y[0, -1], np.exp(-1.0), 1e-12, 0)


def test_unknown_options_warn_as_scipy():
    with pytest.warns(UserWarning, match="`min_step`"):
        reckon.solve_ivp(oscillator, (0.0, 1.0), [1.0, 0.0], min_step=1e-3)


def test_integration_failure_is_status_minus_one_with_the_typed_error():
    r = reckon.solve_ivp(lambda t, y: -y, (0.0, 10.0), [1.0], rtol=1e-10, max_steps=5)
    assert r.status == -1 and not r.success
    assert isinstance(r.error, reckon.MaxSteps) and isinstance(r.error, reckon.Error)
    assert r.error.steps == 5 and 0.0 < r.error.t < 10.0
    assert r.message == str(r.error) and "step limit" in r.message
    # y' = y² from 1 blows up at t = 1
    r = reckon.solve_ivp(lambda t, y: y * y, (0.0, 2.0), [1.0], method="Rodas5P")
    assert r.status == -1 and isinstance(r.error, reckon.Error)
    assert r.error.t == pytest.approx(1.0, abs=1e-2)


def test_hierarchy_and_pickling():
    names = ["NonFinite", "NewtonDiverged", "SingularMatrix", "StepSizeUnderflow", "MaxSteps", "Untraceable",
             "NoDenseOutput", "InvalidInput", "PitchSingularity", "NotPositiveDefinite", "NoConvergence",
             "Unidentifiable", "SensitivityUnresolved", "FitFailed", "EnsembleMember", "EventNaN",
             "EventLocation"]
    for name in names:
        cls = getattr(reckon, name)
        assert issubclass(cls, reckon.Error) and cls.__name__ == name
    e = reckon.StepSizeUnderflow("underflow", t=1.5, h=1e-300)
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is reckon.StepSizeUnderflow and (back.t, back.h) == (1.5, 1e-300)
    assert str(back) == "underflow"
    with pytest.raises(TypeError):
        reckon.MaxSteps("x", nonsense=1)


def test_event_values_numpy_reads_as_one_number():
    def one(t, y):
        return np.array([y[0] - 0.5])

    r = reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], events=one, rtol=1e-10, atol=1e-12)
    close(r.t_events[0], [np.log(2.0)], 1e-9, 0)

    def two(t, y):
        return np.array([1.0, 2.0])

    with pytest.raises(ValueError, match=r"event function returned an array of shape \(2,\)"):
        reckon.solve_ivp(lambda t, y: -y, (0.0, 1.0), [1.0], events=two)


def test_failed_run_with_events_has_one_empty_array_per_event():
    def g(t, y):
        return y[0] - 3.0

    r = reckon.solve_ivp(lambda t, y: y * y, (0.0, 2.0), [1.0], method="BDF", events=[g, g])
    assert r.status == -1
    # y = 1/(1 − t) crosses 3 at t = 2/3, before the blow-up at 1; that hit is lost with
    # the rest of the run (the library returns no partial solution, docs/python.md)
    assert len(r.t_events) == len(r.y_events) == 2
    assert all(a.shape == (0,) for a in r.t_events + r.y_events)


def test_the_extension_is_abi3():
    # one wheel for every CPython >= 3.10 (pyo3's abi3-py310)
    assert reckon._reckon.__file__.endswith(".abi3.so") or reckon._reckon.__file__.endswith(".pyd")


@pytest.mark.parametrize("convert", [list, tuple, lambda v: np.asarray(v, dtype=np.float32),
                                     lambda v: np.asarray(v)[::1], lambda v: np.column_stack([v, v])[:, 0]])
def test_any_array_like_return_of_floats(convert):
    # lists, tuples, float32 and non-owning views are read as float64, as scipy's asarray does
    r = reckon.solve_ivp(lambda t, y: convert([y[1], -y[0]]), (0.0, 1.0), [1.0, 0.0], rtol=1e-6, atol=1e-9)
    close(r.y[:, -1], [np.cos(1.0), -np.sin(1.0)], 0, 1e-5)


def test_integer_lists_are_read_as_floats():
    r = reckon.solve_ivp(lambda t, y: [1, 2], (0.0, 1.0), [0, 0])
    close(r.y[:, -1], [1.0, 2.0], 1e-12, 1e-12)

//! Regression tests for the library defects of the reliability issue: each one asserts
//! the typed error or the right answer for an input that used to panic, hang or
//! return a wrong `Ok`.

use nalgebra::{DVector, Vector3, vector};
use reckon::methods::{Euler, Exact, ImplicitEuler, Rk45};
use reckon::vehicles::unicycle;
use reckon::{Controls, Error, Event, Options, Problem, model};
use std::cell::Cell;

/// Epoch timestamps: the same decay problem started at t0 = 0, 1.7e9 (seconds since
/// 1970) and 1.7e12 (milliseconds) gives the same answer with every adaptive method,
/// since steps are taken in time measured from t0.
#[test]
fn epoch_timestamps_integrate_like_t0_zero() {
    let f = model!(|_t, x: [S; 2]| vector![-x[0] * 10.0 + x[1], -x[1]]);
    let exact = |t: f64| {
        let b = (-t).exp();
        let a = (-10.0 * t).exp() + (b - (-10.0 * t).exp()) / 9.0;
        vector![a, b]
    };
    let opts = Options::default().rtol(1e-8).atol(1e-10);
    for t0 in [0.0, 1.7e9, 1.7e12, -1.7e12] {
        let p = Problem::new(&f, vector![1.0, 1.0], (t0, t0 + 2.0));
        let rk = p.solve(Rk45, &opts).unwrap();
        // adaptive implicit Euler, first order: at rtol 1e-4 (its error follows the
        // tolerance; 1e-8 would take millions of steps)
        let ie = p
            .solve(ImplicitEuler::default(), &Options::default().rtol(1e-4).atol(1e-6))
            .unwrap();
        assert_eq!(rk.last().0, t0 + 2.0);
        assert!((rk.last().1 - exact(2.0)).amax() < 1e-7, "rk45 at t0 = {t0}");
        assert!((ie.last().1 - exact(2.0)).amax() < 1e-4, "implicit Euler at t0 = {t0}");
        // same number of steps as from 0: the epoch costs nothing
        let p0 = Problem::new(&f, vector![1.0, 1.0], (0.0, 2.0));
        let rk0 = p0.solve(Rk45, &opts).unwrap();
        assert_eq!(rk.stats.accepted, rk0.stats.accepted, "t0 = {t0}");
    }
}

/// Control times one ulp apart: every method lands on both without a step-size underflow.
#[test]
fn control_times_a_few_ulps_apart() {
    let t1: f64 = 1.0;
    let t2 = f64::from_bits(t1.to_bits() + 2);
    let c = Controls::new(
        vec![0.0, t1, t2, 2.0],
        vec![vec![1.0, 0.0], vec![5.0, 3.0], vec![1.0, 0.0], vec![0.0, 0.0]],
    )
    .unwrap();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 2.0)).controls(c);
    let end = |r: reckon::Result<reckon::Solution<_>>| *r.unwrap().last().1;
    let ex = end(p.solve(Exact::new(unicycle::flow), &Options::default()));
    // the 2-ulp interval contributes nothing measurable: a straight 2 m line
    assert!((ex - vector![2.0, 0.0, 0.0]).amax() < 1e-14, "{ex}");
    for (name, x) in [
        ("euler", end(p.solve(Euler, &Options::default().fixed(0.1)))),
        (
            "implicit",
            end(p.solve(ImplicitEuler::default(), &Options::default().fixed(0.1))),
        ),
        ("rk45", end(p.solve(Rk45, &Options::default()))),
        (
            "implicit adaptive",
            end(p.solve(ImplicitEuler::default(), &Options::default())),
        ),
    ] {
        assert!((x - ex).amax() < 1e-12, "{name}: {x}");
    }
}

/// A log longer than the default step limit: the limit counts steps between stops.
#[test]
fn step_limit_scales_with_the_control_intervals() {
    let n = 250_000;
    let times: Vec<f64> = (0..n).map(|k| k as f64 * 0.01).collect();
    let values: Vec<Vec<f64>> = (0..n).map(|k| vec![1.0, if k % 2 == 0 { 0.1 } else { -0.1 }]).collect();
    let t_end = times[n - 1];
    let c = Controls::new(times, values).unwrap();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, t_end)).controls(c);
    let sol = p
        .solve(Exact::new(unicycle::flow), &Options::default().dense(false))
        .unwrap();
    assert_eq!(sol.stats.accepted as usize, n - 1);
    // alternating ±0.1 rad/s for 0.01 s: heading ends at 0.001 (n − 1 odd), x ≈ distance
    // every interval is the same arc: chord 0.01·sinc(0.0005) along heading 0.0005
    let chord = 0.01 * unicycle::sinc(0.0005);
    let m = (n - 1) as f64;
    assert!((sol.last().1[2] - 0.001).abs() < 1e-12);
    assert!((sol.last().1[0] / (m * chord * 0.0005f64.cos()) - 1.0).abs() < 1e-10);
    assert!((sol.last().1[1] / (m * chord * 0.0005f64.sin()) - 1.0).abs() < 1e-9);
    // one interval that needs more than the limit still reports it, typed
    let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    let r = Problem::new(&f, vector![1.0], (0.0, 1.0)).solve(Euler, &Options::default().fixed(1e-3).max_steps(100));
    assert!(matches!(r, Err(Error::MaxSteps { steps: 100, .. })), "{r:?}");
}

/// A `Dyn` model returning a longer or shorter derivative: a typed error from every
/// method, also when the length changes after the first call.
#[test]
fn dyn_model_of_the_wrong_length_is_a_typed_error() {
    let counter = Cell::new(0usize);
    let calls = &counter;
    let grow = model!(|_t, x: [S; Dyn]| {
        calls.set(calls.get() + 1);
        let n = if calls.get() > 3 { x.len() + 1 } else { x.len() };
        DVector::from_fn(n, |i, _| -x[i.min(x.len() - 1)].clone())
    });
    let shrink = model!(|_t, x: [S; Dyn]| DVector::from_fn(x.len() - 1, |i, _| -x[i].clone()));
    let x0 = DVector::from_vec(vec![1.0, 2.0]);
    let is_model_error = |r: &reckon::Result<reckon::Solution<nalgebra::Dyn>>| matches!(r, Err(Error::InvalidInput { what: "model", reason }) if reason.contains("components for a state of 2"));
    for sys_name in ["grow", "shrink"] {
        let run = |m: &str| {
            calls.set(0);
            let opts = Options::default();
            match (sys_name, m) {
                ("grow", "euler") => Problem::new(&grow, x0.clone(), (0.0, 1.0)).solve(Euler, &opts.fixed(0.1)),
                ("grow", "rk45") => Problem::new(&grow, x0.clone(), (0.0, 1.0)).solve(Rk45, &opts),
                ("grow", _) => Problem::new(&grow, x0.clone(), (0.0, 1.0)).solve(ImplicitEuler::default(), &opts),
                (_, "euler") => Problem::new(&shrink, x0.clone(), (0.0, 1.0)).solve(Euler, &opts.fixed(0.1)),
                (_, "rk45") => Problem::new(&shrink, x0.clone(), (0.0, 1.0)).solve(Rk45, &opts),
                _ => Problem::new(&shrink, x0.clone(), (0.0, 1.0)).solve(ImplicitEuler::default(), &opts),
            }
        };
        for m in ["euler", "rk45", "implicit"] {
            let r = run(m);
            assert!(is_model_error(&r), "{sys_name}/{m}: {:?}", r.map(|s| s.last().1.len()));
        }
    }
}

/// An exact flow that returns the wrong length: a typed error, the state never grows.
#[test]
fn dyn_flow_of_the_wrong_length_is_a_typed_error() {
    let f = model!(|_t, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| -x[i].clone()));
    let longer = |_t: f64, x: &DVector<f64>, _u: &[f64], h: f64| {
        let mut y = x * (-h).exp();
        y = y.push(0.0);
        y
    };
    let r = Problem::new(&f, DVector::from_vec(vec![1.0]), (0.0, 2.0))
        .solve(Exact::new(longer), &Options::default().fixed(0.5));
    assert!(
        matches!(&r, Err(Error::InvalidInput { what: "flow", reason }) if reason.contains("2 components for a state of 1")),
        "{r:?}"
    );
    let empty = |_t: f64, _x: &DVector<f64>, _u: &[f64], _h: f64| DVector::<f64>::zeros(0);
    let r =
        Problem::new(&f, DVector::from_vec(vec![1.0, 2.0]), (0.0, 2.0)).solve(Exact::new(empty), &Options::default());
    assert!(matches!(&r, Err(Error::InvalidInput { what: "flow", .. })), "{r:?}");
}

/// An event function that returns NaN: a typed error at the time, not a missed event.
#[test]
fn nan_event_function_is_an_error() {
    let f = model!(|_t, x: [S; 1]| vector![S::from(1.0) + x[0] * 0.0]);
    // g = 1 − x is NaN for x > 0.5 (sqrt of a negative number), so the zero at x = 1 is hidden
    let ev =
        Event::new(|_t, x: &nalgebra::SVector<f64, 1>| (0.5 - x[0]).sqrt() - 0.5f64.sqrt() + 1.0 - x[0]).terminal();
    let r = Problem::new(&f, vector![0.0], (0.0, 3.0))
        .event(ev)
        .solve(Rk45, &Options::default());
    match r {
        Err(Error::EventNaN { index: 0, t }) => assert!(t > 0.5 && t <= 3.0, "t = {t}"),
        other => panic!("expected EventNaN, got {other:?}"),
    }
    // NaN already at t0
    let ev = Event::new(|_t, _x: &nalgebra::SVector<f64, 1>| f64::NAN);
    let r = Problem::new(&f, vector![0.0], (0.0, 3.0))
        .event(ev)
        .solve(Euler, &Options::default().fixed(1.0));
    assert_eq!(r.unwrap_err(), Error::EventNaN { index: 0, t: 0.0 });
}

/// A pole of an event function is a sign change and is reported as a crossing: this is
/// documented behaviour (the function jumps through ±∞, it is never NaN).
#[test]
fn event_pole_is_a_crossing() {
    let f = model!(|_t, x: [S; 1]| vector![S::from(1.0) + x[0] * 0.0]);
    let ev = Event::new(|_t, x: &nalgebra::SVector<f64, 1>| 1.0 / (x[0] - 1.25));
    let sol = Problem::new(&f, vector![0.0], (0.0, 2.0))
        .event(ev)
        .solve(Rk45, &Options::default())
        .unwrap();
    let ts: Vec<f64> = sol.events.iter().map(|e| e.t).collect();
    assert_eq!(ts.len(), 1, "{ts:?}");
    assert!((ts[0] - 1.25).abs() < 1e-9, "{ts:?}");
}

/// Implicit Euler with a state whose ulp exceeds the step's increment: Newton's
/// correction cannot change the iterate, which is converged, not divergent.
#[test]
fn implicit_euler_below_the_state_ulp_converges() {
    let f = model!(|_t, x: [S; 1]| vector![x[0] * 1e-20]);
    for opts in [Options::default(), Options::default().fixed(0.1)] {
        let sol = Problem::new(&f, vector![1e12], (0.0, 1.0))
            .solve(ImplicitEuler::default(), &opts)
            .unwrap();
        // x(1) = 1e12·e^(1e-20) = 1e12 to rounding
        assert_eq!(sol.last().1[0], 1e12);
    }
}

/// Tolerances at the edge of floating point: a clean answer or a typed error, never a
/// non-finite error "at t = ∞" (pure absolute control, rtol = 0, reaches the step
/// machinery; a tiny non-zero rtol is refused up front).
#[test]
fn tiny_tolerances_give_a_typed_error_or_an_answer() {
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    for atol in [1e-160, 1e-300, 5e-324] {
        let p = Problem::new(&f, vector![1.0, 0.0], (0.0, 1.0));
        let opts = Options::default().rtol(0.0).atol(atol).max_steps(2000);
        for r in [p.solve(Rk45, &opts), p.solve(ImplicitEuler::default(), &opts)] {
            match r {
                Err(Error::StepSizeUnderflow { t, .. } | Error::MaxSteps { t, .. }) => {
                    assert!(t.is_finite() && (0.0..1.0).contains(&t), "atol {atol}: t = {t}")
                }
                other => panic!("atol {atol}: {:?}", other.map(|s| *s.last().1)),
            }
        }
    }
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    for tol in [1e-160, 1e-200, 1e-300, 5e-324] {
        for method in ["rk45", "implicit"] {
            let p = Problem::new(&f, vector![1.0, 0.0], (0.0, 1.0));
            let opts = Options::default().rtol(tol).atol(tol).max_steps(2000);
            let r = match method {
                "rk45" => p.solve(Rk45, &opts),
                _ => p.solve(ImplicitEuler::default(), &opts),
            };
            match r {
                Ok(sol) => assert!((sol.last().1[0] - 1f64.cos()).abs() < 1e-12),
                Err(Error::StepSizeUnderflow { t, .. } | Error::MaxSteps { t, .. }) => {
                    assert!(t.is_finite() && (0.0..1.0).contains(&t), "{method} {tol}: t = {t}")
                }
                // rtol below 10ε is refused up front, as it cannot be met
                Err(Error::InvalidInput { what: "rtol", .. }) => assert!(tol < reckon::problem::options::MIN_RTOL),
                Err(e) => panic!("{method} at tol {tol}: {e}"),
            }
        }
    }
}

/// Streaming: an open-ended problem fed one interval at a time with `set_inputs` and
/// `step_until` gives bit for bit the states of the same log solved as `Controls`.
#[test]
fn streaming_matches_controls_bit_for_bit() {
    let n = 2000;
    let times: Vec<f64> = (0..n).map(|k| 1.7e9 + k as f64 * 0.05).collect();
    let values: Vec<Vec<f64>> = (0..n)
        .map(|k| vec![1.0 + (k as f64 * 0.1).sin(), (k as f64 * 0.37).cos()])
        .collect();
    let c = Controls::new(times.clone(), values.clone()).unwrap();
    let x0 = vector![1.0, -2.0, 0.3];
    let span = (times[0], times[n - 1]);
    let whole = Problem::new(unicycle::model(), x0, span).controls(c);
    let open = Problem::new(unicycle::model(), x0, (times[0], f64::INFINITY)).inputs(values[0].clone());
    let check = |a: Vec<(f64, Vector3<f64>)>, b: Vec<(f64, Vector3<f64>)>, what: &str| {
        assert_eq!(a.len(), b.len(), "{what}");
        for (p, q) in a.iter().zip(&b) {
            assert_eq!(p.0.to_bits(), q.0.to_bits(), "{what}");
            assert_eq!(p.1, q.1, "{what} at t = {}", p.0);
        }
    };
    macro_rules! both {
        ($method:expr, $opts:expr, $what:expr) => {{
            let sol = whole.solve($method, &$opts).unwrap();
            let a: Vec<_> = sol.t.iter().copied().zip(sol.x.iter().copied()).collect();
            let mut it = open.integrator($method, &$opts).unwrap();
            let mut b = vec![(it.t(), *it.x())];
            for k in 1..n {
                if k > 1 {
                    it.set_inputs(&values[k - 1]).unwrap();
                }
                while !it.reached(times[k]) {
                    it.step_until(times[k]).unwrap();
                    b.push((it.t(), *it.x()));
                }
            }
            check(a, b, $what);
        }};
    }
    both!(Exact::new(unicycle::flow), Options::default().dense(false), "exact");
    both!(Euler, Options::default().fixed(0.02).dense(false), "euler");
    both!(Rk45, Options::default().rtol(1e-9).dense(false), "rk45");
    both!(ImplicitEuler::default(), Options::default().fixed(0.01), "implicit");
    // an open-ended span cannot be solved to its end
    assert!(matches!(
        open.solve(Euler, &Options::default().fixed(0.1)),
        Err(Error::InvalidInput { what: "span", .. })
    ));
}

/// Error messages print numbers briefly, never 309 digits.
#[test]
fn errors_print_numbers_briefly() {
    let f = model!(|_t, x: [S; 1]| vector![x[0] * 1e300]);
    let e = Problem::new(&f, vector![1e300], (1e308, 1.5e308))
        .solve(Euler, &Options::default().fixed(1e307))
        .unwrap_err();
    let msg = e.to_string();
    assert!(msg.len() < 80, "{msg}");
    assert!(msg.contains("1e308"), "{msg}");
    let e = Options::default().atol(1e-300).h_max(-1e300).validate().unwrap_err();
    assert!(e.to_string().len() < 60, "{e}");
}

/// The documented limit of the method: near the blow-up of `x' = x²` (exact
/// `x(0.999) = 1000`) every local error is amplified up to 10⁶ times. Per-step implicit
/// Euler returned 10 044.8 at the default tolerances with `Ok`; with tolerance
/// proportionality it is 10 % off at rtol 1e-4, 1 % at 1e-5 (where it needs more than
/// the default step limit: the typed error until the limit is raised); RK45 at the
/// defaults is already close.
#[test]
fn implicit_euler_near_a_blow_up_is_a_documented_limit() {
    let f = model!(|_t, x: [S; 1]| vector![x[0] * x[0]]);
    let p = Problem::new(&f, vector![1.0], (0.0, 0.999));
    let at = |o: &Options| p.solve(ImplicitEuler::default(), o).map(|s| s.last().1[0]);
    let loose = at(&Options::default().rtol(1e-4)).unwrap();
    assert!((loose / 1000.0 - 1.0).abs() < 0.12, "{loose}");
    let tighter = Options::default().rtol(1e-5);
    assert!(matches!(at(&tighter), Err(Error::MaxSteps { .. })));
    let tight = at(&tighter.max_steps(1_000_000)).unwrap();
    assert!((tight / 1000.0 - 1.0).abs() < 0.012, "{tight}");
    let per_step = p
        .solve(ImplicitEuler::default().proportional(false), &Options::default())
        .unwrap()
        .last()
        .1[0];
    assert!(per_step > 2000.0, "{per_step}");
    let rk = p.solve(Rk45, &Options::default()).unwrap().last().1[0];
    assert!((rk / 1000.0 - 1.0).abs() < 1e-3, "{rk}");
}

/// A `Dyn` model whose output becomes empty after the first call, under implicit Euler:
/// num-dual cannot build an empty Jacobian; the length error is reported, typed.
#[test]
fn dyn_model_emptied_under_newton_is_a_typed_error() {
    let counter = Cell::new(0usize);
    let calls = &counter;
    let f = model!(|_t, x: [S; Dyn]| {
        calls.set(calls.get() + 1);
        let n = if calls.get() > 1 { 0 } else { x.len() };
        DVector::from_fn(n, |i, _| -x[i].clone())
    });
    for opts in [Options::default(), Options::default().fixed(0.1)] {
        counter.set(0);
        let r = Problem::new(&f, DVector::from_vec(vec![1.0, 2.0]), (0.0, 1.0)).solve(ImplicitEuler::default(), &opts);
        assert!(
            matches!(&r, Err(Error::InvalidInput { what: "model", reason }) if reason.contains("0 components for a state of 2")),
            "{:?}",
            r.map(|s| s.last().0)
        );
    }
}

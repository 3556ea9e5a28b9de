//! Every error variant, provoked by a real bad input.

use nalgebra::{DVector, vector};
use reckon::error::Quantity;
use reckon::methods::{Euler, Exact, ImplicitEuler, Rk45};
use reckon::vehicles::unicycle;
use reckon::{Controls, Direction, Error, Event, Options, Problem, StepSize, model};

/// An rhs that returns NaN after t = 1: every method reports NonFinite at t ≈ 1.
#[test]
fn nan_after_t1_is_reported_where_it_happens() {
    let f = model!(|t, x: [S; 1]| vector![if t > 1.0 { S::from(f64::NAN) } else { -x[0] }]);
    let p = Problem::new(&f, vector![1.0], (0.0, 3.0));
    let check = |r: reckon::Result<reckon::Solution<_>>, what: &str, h: f64| match r {
        Err(Error::NonFinite {
            t,
            quantity: Quantity::Derivative,
            component: 0,
        }) => {
            assert!(t > 1.0 && t <= 1.0 + h, "{what}: reported at t = {t}")
        }
        other => panic!("{what}: expected NonFinite, got {:?}", other.map(|s| s.last().0)),
    };
    check(p.solve(Rk45, &Options::default()), "rk45", 0.5);
    check(
        p.solve(ImplicitEuler::default(), &Options::default().rtol(1e-3)),
        "implicit Euler",
        0.5,
    );
    check(p.solve(Euler, &Options::default().fixed(0.01)), "explicit Euler", 0.01);
    check(
        p.solve(ImplicitEuler::default(), &Options::default().fixed(0.01)),
        "implicit Euler fixed",
        0.01,
    );
    check(p.solve(Rk45, &Options::default().fixed(0.01)), "rk45 fixed", 0.01);
}

#[test]
fn state_overflow_is_non_finite_state() {
    let f = model!(|_t, x: [S; 1]| vector![x[0] * 0.0 + 1e307]);
    let r = Problem::new(&f, vector![1.7e308], (0.0, 2.0)).solve(Euler, &Options::default().fixed(1.0));
    assert_eq!(
        r.unwrap_err(),
        Error::NonFinite {
            t: 1.0,
            quantity: Quantity::State,
            component: 0
        }
    );
}

/// Components near `f64::MAX` whose sum overflows are still finite: no error on any path
/// (the drivers test a new state by its sum first, and each component only when the sum
/// is not finite), and the state comes out unchanged for `x' = 0`.
#[test]
fn finite_components_whose_sum_overflows_are_not_an_error() {
    let f = model!(|_t, x: [S; 3]| vector![x[0] * 0.0, x[1] * 0.0, x[2] * 0.0]);
    let x0 = vector![1.5e308, 1.5e308, -1.0];
    let p = Problem::new(&f, x0, (0.0, 2.0));
    for (name, sol) in [
        ("euler, lean fixed", p.solve(Euler, &Options::default().fixed(0.5))),
        ("rk45, lean adaptive", p.solve(Rk45, &Options::default())),
        (
            "rk45, dense (general path)",
            p.solve(Rk45, &Options::default().dense(true)),
        ),
    ] {
        let sol = sol.unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(*sol.last().1, x0, "{name}");
    }
}

#[test]
fn infinite_jacobian_is_non_finite_jacobian() {
    // f = −√x has f(0) = 0 but ∂f/∂x = −1/(2√x) = −∞ at 0
    let f = model!(|_t, x: [S; 1]| vector![-x[0].sqrt()]);
    let r = Problem::new(&f, vector![0.0], (0.0, 1.0)).solve(ImplicitEuler::default(), &Options::default().fixed(0.1));
    assert!(
        matches!(
            r,
            Err(Error::NonFinite {
                t: 0.0,
                quantity: Quantity::Jacobian,
                ..
            })
        ),
        "{r:?}"
    );
}

/// x' = x² blows up at t = 1; the implicit Euler equation x₁ = x₀ + h x₁² has no real
/// solution once 4h·x₀ > 1, so Newton fails for every sub-step the driver tries.
#[test]
fn newton_divergence_on_blow_up() {
    let f = model!(|_t, x: [S; 1]| vector![x[0] * x[0]]);
    let r = Problem::new(&f, vector![1.0], (0.0, 2.0)).solve(ImplicitEuler::default(), &Options::default().fixed(0.4));
    match r {
        Err(Error::NewtonDiverged {
            t,
            h,
            iterations,
            residual,
        }) => {
            assert!(t > 0.4 && t < 1.0, "t = {t}");
            assert!(h > 0.0 && h < 0.4 / 512.0, "h = {h}");
            assert!(iterations >= 1 && residual > 0.0);
        }
        other => panic!("expected NewtonDiverged, got {other:?}"),
    }
}

#[test]
fn singular_iteration_matrix_at_fixed_step() {
    // x' = 10x with h = 0.1: I − hJ = 1 − 1 = 0
    let f = model!(|_t, x: [S; 1]| vector![x[0] * 10.0]);
    let r = Problem::new(&f, vector![1.0], (0.0, 1.0)).solve(ImplicitEuler::default(), &Options::default().fixed(0.1));
    assert_eq!(r.unwrap_err(), Error::SingularMatrix { t: 0.0, h: 0.1 });
    // an adaptive run recovers by changing h
    let ok = Problem::new(&f, vector![1.0], (0.0, 0.5))
        .solve(ImplicitEuler::default(), &Options::default().rtol(1e-3).h0(0.1));
    assert!(ok.is_ok());
}

/// A span across most of the f64 range: the step from 0 to 10³⁰⁸ (`t − t0` = 2·10³⁰⁸)
/// and explicit Euler's grid point 18·10³⁰⁷ overflow to +∞, reported as a step-size
/// failure with that `h` (the fast path leaves times this large to the general path:
/// the same error with an event), never a NaN state.
#[test]
fn a_step_that_overflows_is_a_typed_error() {
    let c = Controls::new(vec![-1e308, 0.0, 1e308], vec![vec![0.0, 0.0]; 3]).unwrap();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (-1e308, 1.5e308)).controls(c.clone());
    let general = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (-1e308, 1.5e308))
        .controls(c)
        .event(Event::new(|_t, x: &nalgebra::Vector3<f64>| x[0] + 1e9));
    let euler = Options::default().fixed(1e307);
    for (e, g, t_fail) in [
        (
            p.solve(Exact::new(unicycle::flow), &Options::default()),
            general.solve(Exact::new(unicycle::flow), &Options::default()),
            0.0,
        ),
        (p.solve(Euler, &euler), general.solve(Euler, &euler), -1e308 + 1.7e308),
    ] {
        let (e, g) = (e.unwrap_err(), g.unwrap_err());
        assert_eq!(e, g);
        assert!(
            matches!(e, Error::StepSizeUnderflow { t, h } if h == f64::INFINITY && t == t_fail),
            "{e:?}"
        );
    }
}

#[test]
fn step_size_underflow_at_blow_up() {
    let f = model!(|_t, x: [S; 1]| vector![x[0] * x[0]]);
    let r = Problem::new(&f, vector![1.0], (0.0, 2.0)).solve(Rk45, &Options::default());
    match r {
        Err(Error::StepSizeUnderflow { t, h }) => {
            assert!((t - 1.0).abs() < 1e-6, "t = {t}");
            assert!(h.abs() < 1e-14, "h = {h}");
        }
        other => panic!("expected StepSizeUnderflow, got {other:?}"),
    }
}

#[test]
fn step_limit() {
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    let r = Problem::new(&f, vector![1.0, 0.0], (0.0, 100.0)).solve(Rk45, &Options::default().max_steps(10));
    match r {
        Err(Error::MaxSteps { t, steps: 10 }) => assert!(t > 0.0 && t < 100.0),
        other => panic!("expected MaxSteps, got {other:?}"),
    }
}

fn invalid(r: reckon::Result<impl std::fmt::Debug>) -> &'static str {
    match r {
        Err(Error::InvalidInput { what, reason }) => {
            assert!(!reason.is_empty());
            what
        }
        other => panic!("expected InvalidInput, got {other:?}"),
    }
}

#[test]
fn invalid_options_and_inputs() {
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    let x0 = vector![1.0, 0.0];
    let p = Problem::new(&f, x0, (0.0, 1.0));
    let d = Options::default();
    assert_eq!(invalid(p.solve(Rk45, &d.clone().rtol(-1e-6))), "rtol");
    assert_eq!(invalid(p.solve(Rk45, &d.clone().atol(f64::NAN))), "atol");
    assert_eq!(invalid(p.solve(Rk45, &d.clone().rtol(0.0).atol(0.0))), "atol");
    assert_eq!(invalid(p.solve(Rk45, &d.clone().rtol(vec![1e-6]))), "rtol");
    assert_eq!(invalid(p.solve(Euler, &d.clone().fixed(0.0))), "step");
    assert_eq!(invalid(p.solve(Euler, &d.clone().fixed(-0.1))), "step");
    assert_eq!(
        invalid(p.solve(Euler, &d.clone().step(StepSize::Fixed(f64::INFINITY)))),
        "step"
    );
    assert_eq!(invalid(p.solve(Euler, &d)), "step"); // adaptive without an estimate
    assert_eq!(invalid(p.solve(Rk45, &d.clone().h0(-1.0))), "h0");
    assert_eq!(invalid(p.solve(Rk45, &d.clone().h_max(0.0))), "h_max");
    assert_eq!(invalid(p.solve(Rk45, &d.clone().max_steps(0))), "max_steps");
    assert_eq!(
        invalid(p.solve(Rk45, &d.clone().breakpoints([f64::NAN]))),
        "breakpoints"
    );
    let empty = Problem::new(&f, x0, (1.0, 1.0));
    assert_eq!(invalid(empty.solve(Rk45, &d)), "span");
    let inf = Problem::new(&f, x0, (0.0, f64::INFINITY));
    assert_eq!(invalid(inf.solve(Rk45, &d)), "span");
    let nan0 = Problem::new(&f, vector![f64::NAN, 0.0], (0.0, 1.0));
    assert_eq!(invalid(nan0.solve(Rk45, &d)), "x0");
}

#[test]
fn dimension_and_control_mismatches() {
    // a dynamic model that returns the wrong number of components
    let g = model!(|_t, x: [S; Dyn]| DVector::from_element(x.len() + 1, S::from(0.0)));
    let p = Problem::new(&g, DVector::from_vec(vec![1.0, 2.0]), (0.0, 1.0));
    assert_eq!(invalid(p.solve(Rk45, &Options::default())), "model");
    let e = Problem::new(&g, DVector::from_vec(vec![]), (0.0, 1.0));
    assert_eq!(invalid(e.solve(Rk45, &Options::default())), "x0");
    // a model with inputs but no controls, and controls of the wrong width
    let u = unicycle::model();
    let x0 = vector![0.0, 0.0, 0.0];
    assert_eq!(
        invalid(Problem::new(&u, x0, (0.0, 1.0)).solve(Exact::new(unicycle::flow), &Options::default())),
        "controls"
    );
    let c1 = Controls::new(vec![0.0], vec![vec![1.0]]).unwrap();
    let p = Problem::new(&u, x0, (0.0, 1.0)).controls(c1);
    assert_eq!(invalid(p.solve(Rk45, &Options::default())), "controls");
    // the span starts before the first control sample
    let c2 = Controls::new(vec![0.5], vec![vec![1.0, 0.0]]).unwrap();
    let p = Problem::new(&u, x0, (0.0, 1.0)).controls(c2);
    assert_eq!(invalid(p.solve(Rk45, &Options::default())), "controls");
    // malformed controls
    assert!(Controls::new(vec![0.0, 0.0], vec![vec![1.0], vec![1.0]]).is_err());
    assert!(Controls::new(vec![0.0, 1.0], vec![vec![1.0], vec![1.0, 2.0]]).is_err());
    assert!(Controls::new(vec![0.0, 1.0], vec![vec![1.0]]).is_err());
    assert!(Controls::new(vec![], vec![]).is_err());
    assert!(Controls::new(vec![0.0], vec![vec![f64::INFINITY]]).is_err());
}

#[test]
fn event_that_cannot_be_located() {
    // g changes sign over the step but is NaN inside it: Brent cannot converge
    let f = model!(|_t, x: [S; 1]| vector![S::from(1.0) + x[0] * 0.0]);
    let ev = Event::new(|t: f64, _x: &nalgebra::SVector<f64, 1>| if t > 0.2 && t < 0.8 { f64::NAN } else { t - 0.5 })
        .direction(Direction::Rising);
    let p = Problem::new(&f, vector![0.0], (0.0, 1.0)).event(ev);
    let r = p.solve(Euler, &Options::default().fixed(1.0));
    assert!(matches!(r, Err(Error::EventLocation { index: 0, .. })), "{r:?}");
}

/// The stiff methods fail the same typed ways: Newton divergence at the smallest
/// sub-step (BDF; the same x' = x² blow-up), a singular iteration matrix at a fixed step
/// (BDF order 1: I − hJ; Rodas5P: I/(hγ) − J), and a step-size underflow at a blow-up
/// (adaptive, both).
#[test]
fn stiff_methods_fail_with_typed_errors() {
    use reckon::methods::{Bdf, Rodas5P};
    let sq = model!(|_t, x: [S; 1]| vector![x[0] * x[0]]);
    let r =
        Problem::new(&sq, vector![1.0], (0.0, 2.0)).solve(Bdf::bdf().fixed_order(1), &Options::default().fixed(0.4));
    match r {
        Err(Error::NewtonDiverged { t, h, .. }) => {
            assert!(t > 0.4 && t < 1.0, "t = {t}");
            assert!(h > 0.0 && h < 0.4 / 512.0, "h = {h}");
        }
        other => panic!("BDF: expected NewtonDiverged, got {other:?}"),
    }
    // x' = 10x with h = 0.1: I − hJ = 0 for BDF1 (plain BDF, α₁ = 1)
    let f = model!(|_t, x: [S; 1]| vector![x[0] * 10.0]);
    let r = Problem::new(&f, vector![1.0], (0.0, 1.0)).solve(Bdf::bdf().fixed_order(1), &Options::default().fixed(0.1));
    assert_eq!(r.unwrap_err(), Error::SingularMatrix { t: 0.0, h: 0.1 });
    // Rodas5P: I/(hγ) − J = 0 when J = 1/(hγ) to the last bit: x' = c·x, c = 1/(hγ)
    let h = 0.5;
    let c = 1.0 / (h * reckon::methods::rodas5p::GAMMA);
    let g = model!(|_t, x: [S; 1]| vector![x[0] * c]);
    let r = Problem::new(&g, vector![1.0], (0.0, 2.0 * h)).solve(Rodas5P, &Options::default().fixed(h));
    assert!(matches!(r, Err(Error::SingularMatrix { t, .. }) if t == 0.0), "{r:?}");
    // adaptive runs into the blow-up at t = 1: a typed error there, never a panic or ∞
    for r in [
        Problem::new(&sq, vector![1.0], (0.0, 2.0)).solve(Bdf::default(), &Options::default()),
        Problem::new(&sq, vector![1.0], (0.0, 2.0)).solve(Rodas5P, &Options::default()),
    ] {
        match r {
            Err(Error::StepSizeUnderflow { t, .. } | Error::NewtonDiverged { t, .. } | Error::NonFinite { t, .. }) => {
                assert!((t - 1.0).abs() < 1e-2, "t = {t}")
            }
            other => panic!("expected a typed failure at t = 1, got {:?}", other.map(|s| s.last().0)),
        }
    }
}

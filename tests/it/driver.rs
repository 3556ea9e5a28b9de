//! The driver: breakpoints, t_end, backward integration, events, stepping, dynamic systems.

use nalgebra::{DVector, SVector, vector};
use reckon::methods::{Euler, Exact, ImplicitEuler, Rk45};
use reckon::studies::problems::*;
use reckon::vehicles::unicycle;
use reckon::{Controls, Direction, Event, Options, Problem, model};

fn controls() -> Controls {
    // irregular control times that no step size divides
    let times = vec![0.0, 0.13, 0.5, 1.1, 1.7, 2.0, 2.9];
    let values = times
        .iter()
        .enumerate()
        .map(|(k, _)| vec![1.0 + 0.1 * k as f64, (-1f64).powi(k as i32) * 0.7])
        .collect();
    Controls::new(times, values).unwrap()
}

#[test]
fn breakpoints_and_t_end_are_hit_exactly() {
    let c = controls();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 2.9)).controls(c.clone());
    let extra = 0.77;
    let runs = [
        p.solve(Rk45, &Options::default().breakpoints([extra])).unwrap(),
        p.solve(
            ImplicitEuler::default(),
            &Options::default().rtol(1e-4).breakpoints([extra]),
        )
        .unwrap(),
        p.solve(Euler, &Options::default().fixed(0.1).breakpoints([extra]))
            .unwrap(),
        p.solve(Exact::new(unicycle::flow), &Options::default().breakpoints([extra]))
            .unwrap(),
    ];
    for sol in &runs {
        for b in c.times().iter().chain([&extra]) {
            assert!(sol.t.contains(b), "{}: breakpoint {b} not hit exactly", sol.method);
        }
        assert_eq!(sol.last().0, 2.9, "{}", sol.method);
        assert!(sol.t.windows(2).all(|w| w[1] > w[0]));
    }
    // the fixed grid is t0 + k·h, not an accumulated sum
    let grid = &runs[2].t;
    for k in 1..29 {
        let tk = k as f64 * 0.1;
        // a grid point within rounding of a breakpoint (17·0.1 = 1.7000000000000002) is the breakpoint
        let on_breakpoint = c.times().iter().any(|b| (b - tk).abs() < 1e-12 && grid.contains(b));
        assert!(grid.contains(&tk) || on_breakpoint, "grid point {tk} missing");
    }
    // the exact run takes one step per interval (plus the extra breakpoint)
    assert_eq!(runs[3].t.len(), c.times().len() + 1);
    // and RK45 at tight tolerance agrees with it everywhere it stopped
    let tight = p
        .solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12).breakpoints([extra]))
        .unwrap();
    let exact = &runs[3];
    for (t, x) in exact.t.iter().zip(&exact.x) {
        let k = tight.t.iter().position(|s| s == t).unwrap();
        assert!((tight.x[k] - x).amax() < 1e-10, "at t = {t}");
    }
}

#[test]
fn backward_integration_returns_to_start() {
    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 2.0));
    let fwd = p.solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12)).unwrap();
    let back = Problem::new(rotation_decay(), *fwd.last().1, (2.0, 0.0))
        .solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12).dense(true))
        .unwrap();
    assert_eq!(back.last().0, 0.0);
    assert!((back.last().1 - x0).amax() < 1e-10);
    assert!(back.t.windows(2).all(|w| w[1] < w[0]));
    // dense output backward
    let mid = back.at(1.234).unwrap();
    assert!((mid - rotation_decay_exact(1.234, &x0)).amax() < 1e-9);
    // fixed-step backward Euler lands on the grid 2 − k·h
    let ee = Problem::new(rotation_decay(), x0, (2.0, 0.0))
        .solve(Euler, &Options::default().fixed(0.25))
        .unwrap();
    assert_eq!(ee.t, (0..=8).map(|k| 2.0 - k as f64 * 0.25).collect::<Vec<_>>());
    // backward through control intervals uses the input of the interval being crossed
    let c = controls();
    let up = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 2.9)).controls(c.clone());
    let end = *up
        .solve(Exact::new(unicycle::flow), &Options::default())
        .unwrap()
        .last()
        .1;
    let down = Problem::new(unicycle::model(), end, (2.9, 0.0)).controls(c);
    for sol in [
        down.solve(Exact::new(unicycle::flow), &Options::default()).unwrap(),
        down.solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12)).unwrap(),
    ] {
        assert!(sol.last().1.amax() < 1e-10, "{}: {}", sol.method, sol.last().1);
    }
}

#[test]
fn events_are_located_on_dense_output() {
    // harmonic oscillator x = cos t: zeros at π/2 + kπ; falling at π/2, 5π/2
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    let zero = |_t: f64, x: &SVector<f64, 2>| x[0];
    let p = Problem::new(&f, vector![1.0, 0.0], (0.0, 10.0))
        .event(Event::new(zero))
        .event(Event::new(zero).direction(Direction::Falling));
    let sol = p.solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12)).unwrap();
    let pi = std::f64::consts::PI;
    let all: Vec<f64> = sol.events.iter().filter(|e| e.index == 0).map(|e| e.t).collect();
    let falling: Vec<f64> = sol.events.iter().filter(|e| e.index == 1).map(|e| e.t).collect();
    assert_eq!(all.len(), 3);
    for (k, t) in all.iter().enumerate() {
        assert!((t - (pi / 2.0 + k as f64 * pi)).abs() < 1e-9, "zero {k} at {t}");
    }
    assert_eq!(falling.len(), 2);
    assert!((falling[1] - 2.5 * pi).abs() < 1e-9);
    assert_eq!(sol.last().0, 10.0);
    // terminal: stops at the first rising zero, 3π/2, with x there
    let p = Problem::new(&f, vector![1.0, 0.0], (0.0, 10.0))
        .event(Event::new(zero).direction(Direction::Rising).terminal());
    let sol = p.solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12)).unwrap();
    assert!((sol.last().0 - 1.5 * pi).abs() < 1e-9);
    assert!(sol.last().1[0].abs() < 1e-9 && (sol.last().1[1] - 1.0).abs() < 1e-9);
    assert_eq!(sol.events.len(), 1);
}

#[test]
fn stepping_and_iterating_match_solve() {
    let p = Problem::new(van_der_pol(1.0), vector![2.0, 0.0], (0.0, 5.0));
    let opts = Options::default();
    let sol = p.solve(Rk45, &opts).unwrap();
    let steps: Vec<(f64, SVector<f64, 2>)> = p.integrator(Rk45, &opts).unwrap().map(|r| r.unwrap()).collect();
    assert_eq!(steps.len() + 1, sol.t.len());
    for (k, (t, x)) in steps.iter().enumerate() {
        assert_eq!(*t, sol.t[k + 1]);
        assert_eq!(*x, sol.x[k + 1]);
    }
    let mut it = p.integrator(Rk45, &opts).unwrap();
    let mut n = 0;
    while it.step().unwrap().is_some() {
        n += 1;
    }
    assert!(it.is_done() && it.step().unwrap().is_none());
    assert_eq!(n, steps.len());
    assert_eq!(it.stats(), sol.stats);
}

/// A 1-D Brusselator of 40 grid points (80 unknowns) as a `DVector`: implicit Euler uses
/// faer's LU; at a tight tolerance it agrees with RK45 to its own accuracy.
#[test]
fn dynamic_brusselator_with_faer_lu() {
    let n = 40;
    let p = Problem::new(brusselator(n), brusselator_y0(n), (0.0, 2.0));
    let rk = p.solve(Rk45, &Options::default().rtol(1e-10).atol(1e-10)).unwrap();
    let ie = p
        .solve(ImplicitEuler::default(), &Options::default().rtol(1e-3).atol(1e-3))
        .unwrap();
    let diff: DVector<f64> = ie.last().1 - rk.last().1;
    assert!(diff.amax() < 2e-2, "difference {}", diff.amax());
    assert!(ie.stats.lu_decompositions > 0 && ie.stats.jacobian_evals >= 1);
    // the system is stiff for RK45 (diffusion eigenvalue ≈ −4·α(n+1)² ≈ −134): more steps than needed for accuracy
    let fixed = p
        .solve(ImplicitEuler::default(), &Options::default().fixed(1e-3))
        .unwrap();
    let d2: DVector<f64> = fixed.last().1 - rk.last().1;
    assert!(d2.amax() < 5e-3, "fixed-step implicit Euler differs by {}", d2.amax());
}

/// Events while integrating backward: x = cos t from t = 10 down to 0 crosses zero at
/// 5π/2, 3π/2, π/2 (in that order).
#[test]
fn events_backward() {
    let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]);
    let x10 = vector![10f64.cos(), -10f64.sin()];
    let p = Problem::new(&f, x10, (10.0, 0.0)).event(Event::new(|_t, x: &SVector<f64, 2>| x[0]));
    let sol = p.solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12)).unwrap();
    let pi = std::f64::consts::PI;
    let ts: Vec<f64> = sol.events.iter().map(|e| e.t).collect();
    let expect = [2.5 * pi, 1.5 * pi, 0.5 * pi];
    assert_eq!(ts.len(), 3, "{ts:?}");
    for (t, e) in ts.iter().zip(expect) {
        assert!((t - e).abs() < 1e-9, "{t} vs {e}");
    }
    assert_eq!(sol.last().0, 0.0);
}

/// `solve` takes a lean loop when there is nothing to stop for but `t_end`: its steps
/// are bit for bit those of `step()` one at a time (forward, backward, from an epoch,
/// with rejections, for an explicit and an implicit adaptive method), and its counters
/// are the same.
#[test]
fn lean_solve_equals_stepping() {
    use reckon::methods::{ImplicitEuler, Rk45};
    let vdp = model!(|_t, y: [S; 2]| vector![y[1].clone(), (-y[0] * y[0] + 1.0) * y[1] * 5.0 - y[0]]);
    let mut rejected = 0;
    for (t0, t1) in [(0.0, 12.0), (12.0, 0.0), (1.7e9, 1.7e9 + 12.0)] {
        let p = Problem::new(&vdp, vector![2.0, 0.0], (t0, t1));
        // implicit Euler holds its local error to tol·rtol: a looser tol for the same work
        for (tol_rk, tol_ie) in [(1e-3, 1e-2), (1e-7, 1e-4)] {
            macro_rules! same {
                ($m:expr, $tol:expr) => {{
                    let tol = $tol;
                    let opts = Options::default()
                        .rtol(tol)
                        .atol(tol)
                        .dense(false)
                        .max_steps(1_000_000);
                    let sol = p.solve($m, &opts).unwrap();
                    let mut it = p.integrator($m, &opts).unwrap();
                    let mut t = vec![it.t()];
                    let mut x = vec![*it.x()];
                    while it.step().unwrap().is_some() {
                        t.push(it.t());
                        x.push(*it.x());
                    }
                    rejected += sol.stats.rejected;
                    assert_eq!(sol.t, t, "times, tol {tol}, span ({t0}, {t1})");
                    assert_eq!(sol.x, x, "states, tol {tol}, span ({t0}, {t1})");
                    assert_eq!(sol.stats, it.stats());
                    assert_eq!(*sol.t.last().unwrap(), t1);
                }};
            }
            same!(Rk45, tol_rk);
            same!(ImplicitEuler::default(), tol_ie);
        }
    }
    assert!(rejected > 10, "rejections exercised: {rejected}");
}

//! Vehicle models: exact flows against RK45, flow properties, the car-like midpoint
//! flow's order, and exact Jacobians (the car-like exact flow: tests/it/carlike_exact.rs).

use nalgebra::{Const, Matrix3, Matrix4, SMatrix, SVector, Vector3, Vector4, vector};
use proptest::prelude::*;
use reckon::methods::{Euler, Exact, Rk45};
use reckon::model::Flow;
use reckon::studies::fit_order;
use reckon::vehicles::{bicycle, body3d, carlike, unicycle};
use reckon::{Controls, Options, Problem, System};

/// `n` one-second-ish intervals of deterministic, varied inputs (including exact zeros).
fn controls(n: usize, width: usize, value: impl Fn(usize, usize) -> f64) -> Controls {
    let times: Vec<f64> = (0..=n).map(|k| k as f64 * 0.37).collect();
    let values = (0..=n).map(|k| (0..width).map(|j| value(k, j)).collect()).collect();
    Controls::new(times, values).unwrap()
}

fn exact_vs_rk45<const N: usize>(
    sys: impl System<Const<N>>,
    flow: impl Flow<Const<N>>,
    x0: SVector<f64, N>,
    c: Controls,
) {
    let t_end = *c.times().last().unwrap();
    let p = Problem::new(&sys, x0, (0.0, t_end)).controls(c.clone());
    let ex = p.solve(Exact::new(flow), &Options::default()).unwrap();
    assert_eq!(ex.t.len(), c.times().len(), "one exact step per interval");
    let rk = p.solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12)).unwrap();
    for (t, x) in ex.t.iter().zip(&ex.x) {
        let k =
            rk.t.iter()
                .position(|s| s == t)
                .expect("RK45 lands on every breakpoint");
        let e = (rk.x[k] - x).amax();
        assert!(e <= 1e-9, "t = {t}: exact {x} vs RK45 {} (error {e})", rk.x[k]);
    }
}

#[test]
fn unicycle_exact_flow_matches_rk45_over_120_intervals() {
    let c = controls(120, 2, |k, j| match (j, k % 7) {
        (1, 3) => 0.0, // straight segments: ω = 0 exactly
        (0, _) => 1.0 + 0.5 * (k as f64 * 0.7).sin(),
        _ => 1.2 * (k as f64 * 1.3).cos(),
    });
    exact_vs_rk45(unicycle::model(), unicycle::flow, vector![0.0, 0.0, 0.2], c);
}

#[test]
fn bicycle_exact_flow_matches_rk45_over_120_intervals() {
    let c = controls(120, 2, |k, j| match (j, k % 5) {
        (1, 2) => 0.0,
        (0, _) => 2.0,
        _ => 0.5 * (k as f64 * 0.9).sin(),
    });
    exact_vs_rk45(bicycle::model(0.5), bicycle::flow(0.5), vector![1.0, -1.0, 0.0], c);
}

#[test]
fn body3d_exact_flow_matches_rk45_over_120_intervals() {
    let c = controls(120, 6, |k, j| {
        let s = k as f64;
        [0.1 * s.sin(), 0.3 * (0.5 * s).cos(), 0.2 * s, 1.0, 0.1 * s.cos(), -0.05][j]
    });
    exact_vs_rk45(body3d::model(), body3d::flow, vector![0.0, 0.0, -10.0], c);
}

/// The midpoint-steering flow is second order: least-squares fit over 5 step sizes against
/// RK45 at 1e-12 (measured 2.00), while the exact flow on the same grids has no step-size
/// error.
#[test]
fn carlike_midpoint_flow_is_second_order() {
    let c = Controls::new(
        vec![0.0, 1.0, 2.0],
        vec![vec![5.0, 0.3], vec![4.0, -0.5], vec![0.0, 0.0]],
    )
    .unwrap();
    let p = Problem::new(carlike::model(2.5), vector![0.0, 0.0, 0.0, 0.05], (0.0, 2.0)).controls(c);
    let reference = *p
        .solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12))
        .unwrap()
        .last()
        .1;
    let hs = [0.1, 0.05, 0.025, 0.0125, 0.00625];
    let err = |sol: reckon::Solution<Const<4>>| (sol.last().1 - reference).amax();
    let mid: Vec<f64> = hs
        .iter()
        .map(|&h| {
            err(p
                .solve(Exact::new(carlike::midpoint_flow(2.5)), &Options::default().fixed(h))
                .unwrap())
        })
        .collect();
    let exact: Vec<f64> = hs
        .iter()
        .map(|&h| {
            err(p
                .solve(Exact::new(carlike::flow(2.5)), &Options::default().fixed(h))
                .unwrap())
        })
        .collect();
    let euler: Vec<f64> = hs
        .iter()
        .map(|&h| err(p.solve(Euler, &Options::default().fixed(h)).unwrap()))
        .collect();
    let (pm, pe) = (fit_order(&hs, &mid).unwrap(), fit_order(&hs, &euler).unwrap());
    assert!((pm - 2.0).abs() <= 0.1, "midpoint-steering order {pm}: {mid:?}");
    assert!(
        exact.iter().all(|&e| e <= 1e-11),
        "the exact flow has no step-size error: {exact:?}"
    );
    assert!((pe - 1.0).abs() <= 0.1, "Euler order {pe}: {euler:?}");
    assert!(
        mid[0] < euler[4],
        "the midpoint flow at h = 0.1 beats Euler at h = 0.00625"
    );
    // with ω = 0 both flows are the exact arc: against RK45 to 1e-9
    exact_vs_rk45(
        carlike::model(2.5),
        carlike::midpoint_flow(2.5),
        vector![0.0, 0.0, 0.0, 0.3],
        controls(100, 2, |k, j| if j == 0 { 3.0 + (k % 3) as f64 } else { 0.0 }),
    );
    exact_vs_rk45(
        carlike::model(2.5),
        carlike::flow(2.5),
        vector![0.0, 0.0, 0.0, 0.3],
        controls(100, 2, |k, j| if j == 0 { 3.0 + (k % 3) as f64 } else { 0.0 }),
    );
}

fn jac<const N: usize>(sys: &impl System<Const<N>>, x: SVector<f64, N>, u: &[f64]) -> SMatrix<f64, N, N> {
    let mut j = SMatrix::zeros();
    sys.jacobian(0.0, &x, u, &mut j);
    j
}

#[test]
fn vehicle_jacobians_are_exact() {
    let (th, v, a, l) = (0.4, 1.5, 0.2f64, 0.5);
    let j = jac(&bicycle::model(l), vector![0.0, 0.0, th], &[v, a]);
    let expect = Matrix3::new(0.0, 0.0, -v * th.sin(), 0.0, 0.0, v * th.cos(), 0.0, 0.0, 0.0);
    assert!((j - expect).amax() <= 1e-13 * expect.amax(), "bicycle\n{j}");
    let g = 0.3f64;
    let j = jac(&carlike::model(2.5), vector![0.0, 0.0, th, g], &[v, 0.1]);
    let sec2 = 1.0 / (g.cos() * g.cos());
    let expect = Matrix4::new(
        0.0,
        0.0,
        -v * th.sin(),
        0.0,
        0.0,
        0.0,
        v * th.cos(),
        0.0,
        0.0,
        0.0,
        0.0,
        v * sec2 / 2.5,
        0.0,
        0.0,
        0.0,
        0.0,
    );
    assert!((j - expect).amax() <= 1e-13 * expect.amax(), "car-like\n{j}");
    let j = jac(
        &body3d::model(),
        vector![1.0, 2.0, 3.0],
        &[0.1, 0.2, 0.3, 1.0, 0.0, 0.0],
    );
    assert_eq!(j, Matrix3::zeros());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn unicycle_flow_properties(
        x in -5.0f64..5.0, y in -5.0f64..5.0, th in -4.0f64..4.0,
        v in -3.0f64..3.0, w in -3.0f64..3.0, h1 in -2.0f64..2.0, h2 in -2.0f64..2.0,
    ) {
        let p = Vector3::new(x, y, th);
        let u = [v, w];
        let f = |p: &Vector3<f64>, h: f64| unicycle::flow(0.0, p, &u, h);
        prop_assert_eq!(f(&p, 0.0), p);
        let two = f(&f(&p, h1), h2);
        let one = f(&p, h1 + h2);
        prop_assert!((two - one).amax() < 1e-12, "semigroup: {} vs {}", two, one);
        let back = f(&f(&p, h1), -h1);
        prop_assert!((back - p).amax() < 1e-12, "reversibility: {} vs {}", back, p);
    }

    #[test]
    fn unicycle_flow_is_continuous_as_omega_vanishes(th in -4.0f64..4.0, v in -3.0f64..3.0, h in 0.01f64..3.0, e in -12.0f64..-3.0) {
        let p = Vector3::new(0.5, -0.5, th);
        let w = 10f64.powf(e);
        let straight = unicycle::flow(0.0, &p, &[v, 0.0], h);
        let curved = unicycle::flow(0.0, &p, &[v, w], h);
        // position deviates from the straight line by O(v·ω·h²), heading by ω·h
        let bound = (v.abs() * w * h * h).max(w * h) * 2.0 + 1e-14;
        prop_assert!((curved - straight).amax() <= bound, "ω = {w}: {} vs {}", curved, straight);
    }

    #[test]
    fn carlike_and_bicycle_flow_semigroup_with_zero_rate(
        th in -3.0f64..3.0, g in -0.6f64..0.6, v in -3.0f64..3.0, h1 in -1.0f64..1.0, h2 in -1.0f64..1.0,
    ) {
        let car = carlike::flow(2.5);
        let p = Vector4::new(0.0, 1.0, th, g);
        let u = [v, 0.0];
        let two = car(0.0, &car(0.0, &p, &u, h1), &u, h2);
        prop_assert!((two - car(0.0, &p, &u, h1 + h2)).amax() < 1e-12);
        let bike = bicycle::flow(0.5);
        let q = Vector3::new(0.0, 1.0, th);
        let ub = [v, g];
        let back = bike(0.0, &bike(0.0, &q, &ub, h1), &ub, -h1);
        prop_assert!((back - q).amax() < 1e-12);
    }
}

/// Inputs as a closure u(t) captured by the model: the kinematic bicycle with α = sin t
/// (L = 0.5, v = 2). No breakpoints are needed and DP5 keeps its fifth order.
#[test]
fn inputs_as_a_closure_of_time() {
    let steer = |t: f64| t.sin();
    let l = 0.5;
    let f =
        reckon::model!(|t, x: [S; 3]| vector![x[2].cos() * 2.0, x[2].sin() * 2.0, S::from(2.0 * steer(t).tan() / l)]);
    let p = Problem::new(&f, vector![0.0, 0.0, 0.0], (0.0, 3.0));
    // θ(t) = (v/L)∫tan(sin s) ds: check θ against an independent quadrature
    let sol = p.solve(Rk45, &Options::default().rtol(1e-12).atol(1e-12)).unwrap();
    let n = 200_000;
    let quad: f64 = (0..n)
        .map(|k| {
            let s = (k as f64 + 0.5) * 3.0 / n as f64;
            s.sin().tan()
        })
        .sum::<f64>()
        * 3.0
        / n as f64
        * 2.0
        / l;
    assert!(
        (sol.last().1[2] - quad).abs() < 1e-9,
        "θ(3) = {} vs quadrature {quad}",
        sol.last().1[2]
    );
    let reference = *sol.last().1;
    // every method works with the closure input, implicit Euler through its dual copy
    let hs = [1.0 / 64.0, 1.0 / 128.0, 1.0 / 256.0, 1.0 / 512.0];
    let err = |sol: reckon::Solution<Const<3>>| (sol.last().1 - reference).amax();
    let ee: Vec<f64> = hs
        .iter()
        .map(|&h| err(p.solve(Euler, &Options::default().fixed(h)).unwrap()))
        .collect();
    let ie: Vec<f64> = hs
        .iter()
        .map(|&h| {
            err(p
                .solve(
                    reckon::methods::ImplicitEuler::default(),
                    &Options::default().fixed(h).rtol(1e-10),
                )
                .unwrap())
        })
        .collect();
    for (name, e) in [("explicit Euler", &ee), ("implicit Euler", &ie)] {
        let order = fit_order(&hs, e).unwrap();
        assert!((order - 1.0).abs() <= 0.1, "{name} order {order}: {e:?}");
    }
    let dp = err(p.solve(Rk45, &Options::default().fixed(0.05)).unwrap());
    assert!(dp < 1e-9, "fixed-step DP5 error {dp}");
}

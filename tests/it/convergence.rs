//! Observed order by least-squares slope over ≥ 4 step sizes, against exact solutions.

use nalgebra::{Const, SVector, vector};
use reckon::methods::{Euler, Exact, ImplicitEuler, Method, Rk45};
use reckon::studies::fit_order;
use reckon::studies::problems::*;
use reckon::vehicles::unicycle;
use reckon::{Controls, Options, Problem, System};

fn final_error<const N: usize, S, M>(
    problem: &Problem<'_, Const<N>, S>,
    method: impl Fn() -> M,
    h: f64,
    exact: &SVector<f64, N>,
) -> f64
where
    S: System<Const<N>>,
    M: Method<Const<N>>,
{
    let opts = Options::default().fixed(h).rtol(1e-13).atol(1e-13);
    let sol = problem.solve(method(), &opts).unwrap();
    assert_eq!(sol.last().0, problem.t_end, "t_end must be hit exactly");
    (sol.last().1 - exact).amax()
}

fn order<const N: usize, S, M>(
    problem: &Problem<'_, Const<N>, S>,
    method: impl Fn() -> M,
    hs: &[f64],
    exact: &SVector<f64, N>,
) -> f64
where
    S: System<Const<N>>,
    M: Method<Const<N>>,
{
    let errs: Vec<f64> = hs.iter().map(|&h| final_error(problem, &method, h, exact)).collect();
    for e in &errs {
        assert!(*e > 1e3 * f64::EPSILON, "error {e} is in the round-off range: {errs:?}");
    }
    fit_order(hs, &errs).unwrap()
}

fn halvings(h0: f64, n: usize) -> Vec<f64> {
    (0..n).map(|k| h0 / 2f64.powi(k as i32)).collect()
}

fn assert_order(p: f64, theory: f64, what: &str) {
    assert!((p - theory).abs() <= 0.1, "{what}: observed order {p}, theory {theory}");
}

#[test]
fn rotation_decay_orders() {
    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 2.0));
    let exact = rotation_decay_exact(2.0, &x0);
    let hs = halvings(1.0 / 64.0, 5);
    assert_order(order(&p, || Euler, &hs, &exact), 1.0, "explicit Euler");
    assert_order(order(&p, ImplicitEuler::default, &hs, &exact), 1.0, "implicit Euler");
    assert_order(order(&p, Rk45::default, &halvings(0.2, 5), &exact), 5.0, "DP5");
}

#[test]
fn sin_u_orders() {
    let p = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    let exact = sin_u_exact(5.0, 0.5);
    let hs = halvings(1.0 / 64.0, 5);
    assert_order(order(&p, || Euler, &hs, &exact), 1.0, "explicit Euler");
    assert_order(order(&p, ImplicitEuler::default, &hs, &exact), 1.0, "implicit Euler");
    assert_order(order(&p, Rk45::default, &halvings(0.5, 5), &exact), 5.0, "DP5");
}

/// Held inputs over four one-second intervals; each method must reach its order on
/// every interval (no step crosses a breakpoint) against the exact arc.
#[test]
fn unicycle_held_inputs_orders() {
    let controls = Controls::new(
        vec![0.0, 1.0, 2.0, 3.0, 4.0],
        vec![
            vec![1.0, 0.8],
            vec![2.0, -0.5],
            vec![1.5, 0.0],
            vec![0.5, 2.0],
            vec![0.0, 0.0],
        ],
    )
    .unwrap();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.3], (0.0, 4.0)).controls(controls);
    let exact_sol = p.solve(Exact::new(unicycle::flow), &Options::default()).unwrap();
    assert_eq!(
        exact_sol.t,
        vec![0.0, 1.0, 2.0, 3.0, 4.0],
        "exact flow: one step per interval"
    );
    let exact = *exact_sol.last().1;
    // steps that do not divide the intervals: breakpoints must still be landed on
    let hs: Vec<f64> = halvings(0.3 / 8.0, 5);
    assert_order(order(&p, || Euler, &hs, &exact), 1.0, "explicit Euler");
    assert_order(order(&p, ImplicitEuler::default, &hs, &exact), 1.0, "implicit Euler");
    assert_order(order(&p, Rk45::default, &halvings(0.3, 4), &exact), 5.0, "DP5");
}

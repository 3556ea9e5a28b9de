//! One RK45 contender on one problem, `reps` times: run under
//! `valgrind --tool=callgrind` to compare instruction counts (stable on a shared,
//! noisy machine). `cargo run --release --example rk45_count -- lorenz reckon 1e-6 10`.
#![allow(clippy::excessive_precision)]

#[path = "../benches/handwritten.rs"]
mod handwritten;

use reckon::methods::Rk45;
use reckon::studies::problems::*;
use reckon::{Options, Problem, System};
use std::hint::black_box;

fn run<const N: usize>(
    who: &str,
    sys: impl System<nalgebra::Const<N>>,
    hand: impl Fn(f64, &[f64; N]) -> [f64; N] + Copy,
    x0: [f64; N],
    t_end: f64,
    tol: f64,
    reps: usize,
) -> u64 {
    let p = Problem::new(&sys, nalgebra::SVector::from(x0), (0.0, t_end));
    let opts = Options::default().rtol(tol).atol(tol).dense(false);
    let mut acc = 0;
    for _ in 0..reps {
        acc += match who {
            "reckon" => black_box(p.solve(Rk45, black_box(&opts)).unwrap().stats.accepted),
            _ => black_box(handwritten::dopri5(hand, 0.0, t_end, black_box(x0), tol).accepted),
        };
    }
    acc
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (prob, who, tol, reps) = (&a[1], &a[2], a[3].parse().unwrap(), a[4].parse().unwrap());
    // optional 5th argument: a shorter span (a one-step run measures the fixed setup cost)
    let span = |t: f64| a.get(5).map_or(t, |s| s.parse().unwrap());
    let steps = match prob.as_str() {
        "lorenz" => run(
            who,
            lorenz(),
            handwritten::lorenz,
            [1.0, 1.0, 1.0],
            span(20.0),
            tol,
            reps,
        ),
        "arenstorf" => run(
            who,
            arenstorf(),
            handwritten::arenstorf,
            ARENSTORF_Y0,
            span(ARENSTORF_T),
            tol,
            reps,
        ),
        _ => run(
            who,
            handwritten::van_der_pol_model(),
            handwritten::van_der_pol,
            [2.0, 0.0],
            span(20.0),
            tol,
            reps,
        ),
    };
    println!("{steps}");
}

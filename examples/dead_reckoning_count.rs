//! One dead-reckoning contender over a log of `n` held inputs, `reps` times: run under
//! `valgrind --tool=callgrind` to count instructions (stable on a shared, noisy machine).
//! The count per step is `(count(reps = 2) − count(reps = 1)) / n`, which cancels
//! building the log:
//!
//! ```text
//! cargo build --release --example dead_reckoning_count
//! valgrind --tool=callgrind target/release/examples/dead_reckoning_count unicycle solve 100000 2
//! ```
//!
//! Cases: `unicycle` and `bicycle` (`Exact`), `euler` (explicit Euler on the unicycle at
//! the log's step); contenders: `bare` (the loop of `benches/dead_reckoning.rs`) and
//! `solve` (`Problem::solve`, every state stored).
//!
//! Contender `time` times instead: bare loop and `solve` alternately (process CPU time,
//! `reps` rounds, one run each, the order alternating; `examples/common/cpu.rs`), and
//! prints the median (min–max) of each and of their ratio per round (the speed of `solve`
//! as a fraction of the bare loop's):
//! `cargo run --release --example dead_reckoning_count -- euler time 1000000 15`.

use nalgebra::{Vector3, vector};
use reckon::methods::{Euler, Exact};
use reckon::vehicles::{bicycle, unicycle};
use reckon::{Controls, Options, Problem, System};
use std::hint::black_box;

#[path = "common/cpu.rs"]
mod cpu;

const DT: f64 = 0.01;

fn bare(flow: impl Fn(f64, &Vector3<f64>, &[f64], f64) -> Vector3<f64>, t: &[f64], u: &[Vec<f64>]) -> Vector3<f64> {
    let n = t.len();
    let mut out = Vec::with_capacity(n + 1);
    let mut x = vector![0.0, 0.0, 0.0];
    out.push(x);
    let t_end = n as f64 * DT;
    for k in 0..n {
        let next = if k + 1 < n { t[k + 1] } else { t_end };
        x = flow(t[k], &x, &u[k], next - t[k]);
        out.push(x);
    }
    *black_box(&out).last().unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (case, who) = (
        args.get(1).map_or("unicycle", |s| s),
        args.get(2).map_or("solve", |s| s),
    );
    let n: usize = args
        .get(3)
        .map_or(100_000, |s| s.parse().expect("n: a count of intervals"));
    let reps: usize = args.get(4).map_or(1, |s| s.parse().expect("reps: a count of runs"));
    let t: Vec<f64> = (0..n).map(|k| k as f64 * DT).collect();
    let u: Vec<Vec<f64>> = (0..n)
        .map(|k| vec![1.0 + 0.5 * (k as f64 * 1e-3).sin(), 0.3 * (k as f64 * 7e-4).cos()])
        .collect();
    let span = (0.0, n as f64 * DT);
    let x0 = vector![0.0, 0.0, 0.0];
    let controls = Controls::new(t.clone(), u.clone()).unwrap();
    let model = unicycle::model();
    let uni = Problem::new(&model, x0, span).controls(controls.clone());
    let bi = Problem::new(bicycle::model(0.5), x0, span).controls(controls);
    let run_as = |who: &str| match (case, who) {
        ("unicycle", "bare") => bare(unicycle::flow, &t, &u),
        ("bicycle", "bare") => bare(bicycle::flow(0.5), &t, &u),
        ("euler", "bare") => bare(
            |_t, x: &Vector3<f64>, u: &[f64], h| {
                let mut dx = Vector3::zeros();
                model.rhs(0.0, x, u, &mut dx);
                x + dx * h
            },
            &t,
            &u,
        ),
        ("unicycle", "solve") => {
            *uni.solve(Exact::new(unicycle::flow), &Options::default())
                .unwrap()
                .last()
                .1
        }
        ("bicycle", "solve") => {
            *bi.solve(Exact::new(bicycle::flow(0.5)), &Options::default())
                .unwrap()
                .last()
                .1
        }
        ("euler", "solve") => *uni.solve(Euler, &Options::default().fixed(DT)).unwrap().last().1,
        _ => panic!("usage: dead_reckoning_count unicycle|bicycle|euler bare|solve [n]"),
    };
    if who == "time" {
        let mut cs = vec![
            cpu::Contender::new("bare", |k| {
                for _ in 0..k {
                    black_box(run_as("bare"));
                }
            }),
            cpu::Contender::new("solve", |k| {
                for _ in 0..k {
                    black_box(run_as("solve"));
                }
            }),
        ];
        let t = cpu::interleave(&mut cs, reps, 0.0);
        println!(
            "{case} {n}: bare {}, solve {}, bare ÷ solve {} (CPU time per run, median (min–max) of {reps} interleaved rounds)",
            cpu::fmt_time(&t[0]),
            cpu::fmt_time(&t[1]),
            cpu::fmt_ratio(&cpu::ratios(&t[0], &t[1]))
        );
        return;
    }
    let mut x = x0;
    for _ in 0..reps {
        x = run_as(who);
    }
    println!("{case} {who} {n}: x = {x:?}");
}

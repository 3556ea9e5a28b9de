//! One sensitivity contender, `reps` times: run under `valgrind --tool=callgrind` to
//! count instructions (stable on a shared, noisy machine). The count per solve is
//! `(count(reps = 2) − count(reps = 1))`, which cancels the setup:
//!
//! ```text
//! cargo build --release --example sensitivity_count
//! valgrind --tool=callgrind target/release/examples/sensitivity_count vdp params rk45 2
//! ```
//!
//! Problems: `vdp` (Van der Pol with μ = 1.5 as its parameter, `benches/sensitivity.rs`'s)
//! and `drive` (the differential drive with three geometry parameters over the wheel-speed
//! log); modes: `plain`, `params` (`Wrt::Params`) and `all` (`∂x/∂x₀` and `∂x/∂p`);
//! methods: `rk45` (rtol 1e-8, atol 1e-10) and `ie` (implicit Euler, rtol 1e-5, atol 1e-8).
//!
//! With mode `time` it times instead (process CPU time, `reps` interleaved rounds of plain,
//! all columns and params only, batches of about 10 ms; `examples/common/cpu.rs`) and
//! prints the times and the two ratios, median (min–max over the rounds):
//! `cargo run --release --example sensitivity_count -- vdp time rk45 21`.

use nalgebra::vector;
use reckon::calibration::lsq::diff_drive;
use reckon::methods::{ImplicitEuler, Rk45};
use reckon::sensitivity::{self, SensitivityOptions, Wrt};
use reckon::{Options, Problem, model};
use std::hint::black_box;

#[path = "common/cpu.rs"]
mod cpu;
#[path = "../tests/it/common/drives.rs"]
mod drives;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let arg = |i: usize, d: &'static str| a.get(i).map_or(d, |s| s.as_str()).to_string();
    let (prob, mode, method) = (arg(1, "vdp"), arg(2, "params"), arg(3, "rk45"));
    let reps: usize = arg(4, "1").parse().expect("reps: a count of solves");
    let o = if method == "rk45" {
        Options::default().rtol(1e-8).atol(1e-10)
    } else {
        Options::default().rtol(1e-5).atol(1e-8)
    };
    let dd = diff_drive(&[0.0502, 0.0497, 0.405]).unwrap();
    let drive = Problem::new(&dd, vector![0.0, 0.0, 0.0], (0.0, 60.0)).controls(drives::wheel_speed_log());
    let vdp = model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]]);
    let q = Problem::new(&vdp, vector![2.0, 0.0], (0.0, 10.0));
    let mut acc = 0u64;
    let sp = SensitivityOptions::default().wrt(Wrt::Params);
    let sa = SensitivityOptions::default();
    let so = if mode == "params" { &sp } else { &sa };
    macro_rules! time {
        ($p:expr, $m:expr) => {{
            let mut cs = vec![
                cpu::Contender::new("plain", |n| {
                    for _ in 0..n {
                        black_box($p.solve($m, black_box(&o)).unwrap().stats.accepted);
                    }
                }),
                cpu::Contender::new("all", |n| {
                    for _ in 0..n {
                        black_box(sensitivity::solve(&$p, $m, black_box(&o), &sa).unwrap().stats.accepted);
                    }
                }),
                cpu::Contender::new("params", |n| {
                    for _ in 0..n {
                        black_box(sensitivity::solve(&$p, $m, black_box(&o), &sp).unwrap().stats.accepted);
                    }
                }),
            ];
            let t = cpu::interleave(&mut cs, reps, 0.01);
            println!(
                "{prob} {method}: plain {}, all columns {} ({}×), params only {} ({}×); \
                 CPU time per solve, median (min–max) of {reps} interleaved rounds",
                cpu::fmt_time(&t[0]),
                cpu::fmt_time(&t[1]),
                cpu::fmt_ratio(&cpu::ratios(&t[1], &t[0])),
                cpu::fmt_time(&t[2]),
                cpu::fmt_ratio(&cpu::ratios(&t[2], &t[0])),
            );
        }};
    }
    if mode == "time" {
        match (prob.as_str(), method.as_str()) {
            ("drive", "rk45") => time!(drive, Rk45),
            ("drive", _) => time!(drive, ImplicitEuler::default()),
            (_, "rk45") => time!(q, Rk45),
            _ => time!(q, ImplicitEuler::default()),
        }
        black_box(acc);
        return;
    }
    macro_rules! run {
        ($p:expr) => {
            for _ in 0..reps {
                acc += match (mode.as_str(), method.as_str()) {
                    ("plain", "rk45") => $p.solve(Rk45, black_box(&o)).unwrap().stats.accepted,
                    ("plain", _) => {
                        $p.solve(ImplicitEuler::default(), black_box(&o))
                            .unwrap()
                            .stats
                            .accepted
                    }
                    (_, "rk45") => {
                        sensitivity::solve(&$p, Rk45, black_box(&o), so)
                            .unwrap()
                            .stats
                            .accepted
                    }
                    _ => {
                        sensitivity::solve(&$p, ImplicitEuler::default(), black_box(&o), so)
                            .unwrap()
                            .stats
                            .accepted
                    }
                };
            }
        };
    }
    match prob.as_str() {
        "drive" => run!(drive),
        _ => run!(q),
    }
    println!("{acc} accepted steps");
}

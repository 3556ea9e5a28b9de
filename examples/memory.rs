//! Peak memory of an RK45 run on the 1-D Brusselator (500 points, 1 000 states, t ∈ [0, 10])
//! under each `Options::save` mode: run one mode per process and read the peak resident
//! set (`VmHWM`, Linux). `cargo run --release --example memory -- default|steps|end|every100|at`.
//!
//! `default` is `Options::default()` at the same tolerances: every step, no dense output
//! (dense output is off unless asked for); `steps` is every step with `dense(true)`, the
//! default before dense output became opt-in.
//!
//! Measured 2 Dec 2026 (60 716 steps; peak RSS): `default` 469.5 MiB, `steps` 2 803 MiB,
//! `every100` 7.7 MiB, `at` (101 times) 3.7 MiB, `end` 2.9 MiB. Before dense output was
//! opt-in, `Options::default()` kept it: 2 803 MiB (with the book's initial amplitude,
//! 60 720 steps, the same to 0.1 MiB).

#[path = "common/rss.rs"]
mod rss;
use rss::peak_rss_mib;

use reckon::methods::Rk45;
use reckon::studies::problems::{brusselator, brusselator_y0};
use reckon::{Options, Problem, Save};

fn main() {
    let mode = std::env::args().nth(1).unwrap_or_else(|| "end".into());
    let n = 500;
    let x0 = brusselator_y0(n);
    let sys = brusselator(n);
    let p = Problem::new(&sys, x0, (0.0, 10.0));
    let (save, dense) = match mode.as_str() {
        "steps" => (Save::Steps, true),
        "every100" => (Save::Every(100), false),
        "at" => (Save::At((0..=100).map(|i| 0.1 * i as f64).collect()), false),
        _ => (Save::End, false),
    };
    let o = if mode == "default" {
        Options::default().rtol(1e-4).atol(1e-4)
    } else {
        Options::default().rtol(1e-4).atol(1e-4).dense(dense).save(save)
    };
    let s = p.solve(Rk45, &o).unwrap();
    println!(
        "{mode}: {} steps, {} kept, {:.1} MiB kept, peak RSS {:.1} MiB",
        s.stats.accepted,
        s.t.len(),
        s.kept_bytes() as f64 / (1 << 20) as f64,
        peak_rss_mib()
    );
}

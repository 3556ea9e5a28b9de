//! Issue 9 work–precision: the time to reach 3, 5 and 7 mixed significant digits at `t_end`
//! on Robertson (`t ∈ [0, 1e5]`), Van der Pol μ = 1000 (`[0, 2000]`, `y0 = (2, 0)`), OREGO
//! (`[0, 30]`, `y0 = (1, 2, 3)`) and HIRES (`[0, 321.8122]`), for reckon's ImplicitEuler,
//! Bdf and Rodas5P and diffsol 0.18's BDF (dense nalgebra matrices, `NalgebraLU`, the
//! same right-hand sides with hand-written Jacobian–vector products).
//!
//! One criterion group per (problem, digits) cell, the contenders side by side, each at its
//! own tolerance from the search in `examples/stiff_wp.rs` (table `TOLS` in
//! `benches/common/stiff.rs`; digits and tolerance pairing documented there). The work
//! counters and the digits reached of every contender are printed before each group.
//! A contender that does not reach a cell, or that takes longer than [`SLOW`] per solve
//! (implicit Euler at 5 digits on Van der Pol and at 7 on HIRES), is left out of the
//! timing and said so.

#[path = "common/stiff.rs"]
mod stiff;

use criterion::{BenchmarkGroup, Criterion, SamplingMode, criterion_group, criterion_main, measurement::WallTime};
use std::hint::black_box;
use std::time::{Duration, Instant};
use stiff::*;

/// Solves slower than this are reported, not timed by criterion.
const SLOW: f64 = 1.0;
const MAX_STEPS: usize = 20_000_000;

fn group<'a>(c: &'a mut Criterion, name: &str, slow: bool) -> BenchmarkGroup<'a, WallTime> {
    let mut g = c.benchmark_group(name);
    g.sample_size(if slow { 10 } else { 20 })
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    if slow {
        g.sampling_mode(SamplingMode::Flat);
    }
    g
}

fn cell<E>(c: &mut Criterion, case: Case, make: impl Fn(f64) -> DiffsolModel<E>)
where
    E: diffsol::OdeEquationsImplicit<
            M = diffsol::NalgebraMat<f64>,
            V = diffsol::NalgebraVec<f64>,
            T = f64,
            C = diffsol::NalgebraContext,
        >,
{
    for (l, level) in LEVELS.iter().enumerate() {
        let name = format!("stiff/{}/{}d", case.name(), level);
        // a first solve of each contender: its work, its digits, whether it is timed
        let mut timed = Vec::new();
        let mut slow = false;
        for who in WHO {
            let Some(k) = tol_index(case, who, l) else {
                eprintln!("{name:18} {:15} not reached", who.name());
                continue;
            };
            let t0 = Instant::now();
            let r = run(case, who, grid(k), MAX_STEPS).expect("the searched tolerance solves");
            let secs = t0.elapsed().as_secs_f64();
            eprintln!(
                "{name:18} {:15} rtol {:9.3e} digits {:5.2}  {r}{}",
                who.name(),
                grid(k),
                case.digits(&r.y),
                if secs > SLOW {
                    format!("  ({secs:.2} s: not timed)")
                } else {
                    String::new()
                }
            );
            if secs <= SLOW {
                slow |= secs > 0.05;
                timed.push((who, k));
            }
        }
        let mut g = group(c, &name, slow);
        for (who, k) in timed {
            let rtol = grid(k);
            let id = format!("{}@{rtol:.2e}", who.name());
            if who == Who::Diffsol {
                let model = make(rtol);
                g.bench_function(id, |b| b.iter(|| black_box(model.solve(MAX_STEPS).unwrap().steps)));
            } else {
                let o = reckon_options(case, rtol, MAX_STEPS);
                g.bench_function(id, |b| {
                    b.iter(|| black_box(reckon(case, who, black_box(&o)).unwrap().steps))
                });
            }
        }
        g.finish();
    }
}

fn stiff(c: &mut Criterion) {
    cell(c, Case::Rober, diffsol_rober);
    cell(c, Case::Vdpol, diffsol_vdpol);
    cell(c, Case::Orego, diffsol_orego);
    cell(c, Case::Hires, diffsol_hires);
}

criterion_group!(benches, stiff);
criterion_main!(benches);

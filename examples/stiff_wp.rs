//! Work–precision tolerance search for `benches/stiff.rs` (issue 9).
//!
//! `cargo run --release --example stiff_wp` sweeps `rtol = 10^(−k/4)` (k = 8..=52) for each
//! problem and contender, prints the mixed significant digits (Test Set mescd, see
//! `benches/common/stiff.rs`) and the work of every solve, and for each target 3/5/7 digits
//! the loosest grid point that reaches it *and* whose next tighter grid point reaches it
//! too (so a lucky cancellation at one tolerance is not taken). The result is the table
//! `TOLS` pasted into the bench.
//!
//! `cargo run --release --example stiff_wp -- time` times every cell of `TOLS` with the
//! contenders interleaved (each round runs each contender once, in rotated order, with
//! enough inner repetitions for ≥ 5 ms per measurement; 31 rounds, 3 for solves over a
//! second) and prints the median and minimum per solve as a markdown table; it is the
//! noise-robust companion of the criterion bench on a shared machine.
//!
//! `cargo run --release --example stiff_wp -- refs` recomputes the end-state references at
//! Robertson `t = 1e5` and OREGO `t = 30` with Rodas5P and Bdf at `rtol = 1e-12, 1e-13`.

#[path = "../benches/common/stiff.rs"]
mod stiff;

use reckon::Options;
use std::time::Instant;
use stiff::*;

const K_MIN: u32 = 8;
const K_MAX: u32 = 52;
/// A contender's sweep stops when one solve takes longer than this.
const MAX_SECONDS: f64 = 20.0;
const MAX_STEPS: usize = 20_000_000;

fn refs() {
    for case in [Case::Rober, Case::Orego] {
        for who in [Who::Rodas5P, Who::Bdf] {
            for rtol in [1e-12, 1e-13] {
                // atol far below every component (Robertson's y2 is 7e-8)
                let atol = if case == Case::Rober { 1e-22 } else { 1e-14 };
                let o = Options::default()
                    .rtol(rtol)
                    .atol(atol)
                    .dense(false)
                    .max_steps(MAX_STEPS);
                let r = reckon(case, who, &o).unwrap();
                println!("{} {} rtol {rtol:e}: {:?}  [{r}]", case.name(), who.name(), r.y);
            }
        }
        println!(
            "   in problems.rs: {:?} (mescd of it: {:.2})",
            case.reference(),
            case.digits(case.reference())
        );
    }
}

/// A contender of one cell: who, its rtol, one solve.
type Contender<'a> = (Who, f64, Box<dyn FnMut() -> Run + 'a>);

/// Median and minimum seconds per solve of each contender of one cell, interleaved.
fn interleaved(runs: &mut [Contender<'_>]) -> Vec<(f64, f64)> {
    let m = runs.len();
    let mut reps = vec![1usize; m];
    let mut rounds = 31;
    for (i, r) in runs.iter_mut().enumerate() {
        let t0 = Instant::now();
        (r.2)();
        let t = t0.elapsed().as_secs_f64();
        reps[i] = ((5e-3 / t).ceil() as usize).clamp(1, 100_000);
        if t > 1.0 {
            rounds = 3;
        }
    }
    let mut times = vec![Vec::new(); m];
    for round in 0..rounds {
        for j in 0..m {
            let i = (j + round) % m;
            let t0 = Instant::now();
            for _ in 0..reps[i] {
                std::hint::black_box((runs[i].2)());
            }
            times[i].push(t0.elapsed().as_secs_f64() / reps[i] as f64);
        }
    }
    times
        .into_iter()
        .map(|mut v| {
            v.sort_by(f64::total_cmp);
            (v[v.len() / 2], v[0])
        })
        .collect()
}

fn fmt_t(s: f64) -> String {
    if s >= 1.0 {
        format!("{s:.2} s")
    } else if s >= 1e-3 {
        format!("{:.3} ms", s * 1e3)
    } else {
        format!("{:.1} µs", s * 1e6)
    }
}

fn time_case<E>(case: Case, make: impl Fn(f64) -> DiffsolModel<E>)
where
    E: diffsol::OdeEquationsImplicit<
            M = diffsol::NalgebraMat<f64>,
            V = diffsol::NalgebraVec<f64>,
            T = f64,
            C = diffsol::NalgebraContext,
        >,
{
    for (l, level) in LEVELS.iter().enumerate() {
        let models: Vec<(Who, u32)> = WHO
            .iter()
            .filter_map(|&w| tol_index(case, w, l).map(|k| (w, k)))
            .collect();
        let ds = models.iter().find(|m| m.0 == Who::Diffsol).map(|m| make(grid(m.1)));
        let mut runs: Vec<Contender<'_>> = Vec::new();
        let mut work = Vec::new();
        for &(who, k) in &models {
            let rtol = grid(k);
            let r = run(case, who, rtol, MAX_STEPS).unwrap();
            eprintln!(
                "{} {level}d {:15} rtol {rtol:9.3e} digits {:5.2} {r}",
                case.name(),
                who.name(),
                case.digits(&r.y)
            );
            work.push(r);
            if who == Who::Diffsol {
                let m = ds.as_ref().unwrap();
                runs.push((who, rtol, Box::new(move || m.solve(MAX_STEPS).unwrap())));
            } else {
                let o = reckon_options(case, rtol, MAX_STEPS);
                runs.push((who, rtol, Box::new(move || reckon(case, who, &o).unwrap())));
            }
        }
        let t = interleaved(&mut runs);
        let mut row = format!("| {} | {level} |", case.name());
        let mut best: Option<(f64, f64)> = None;
        let mut dsol = None;
        for w in WHO {
            match runs.iter().position(|r| r.0 == w) {
                Some(i) => {
                    row += &format!(" {:.2e}, {}, {} |", runs[i].1, fmt_t(t[i].0), work[i].rhs);
                    eprintln!("   {:15} median {} min {}", w.name(), fmt_t(t[i].0), fmt_t(t[i].1));
                    if w == Who::Diffsol {
                        dsol = Some(t[i]);
                    } else {
                        best = Some(best.map_or(t[i], |b| (b.0.min(t[i].0), b.1.min(t[i].1))));
                    }
                }
                None => row += " not reached |",
            }
        }
        if let (Some(b), Some(d)) = (best, dsol) {
            row += &format!(" {:.2} (min {:.2}) |", b.0 / d.0, b.1 / d.1);
        }
        println!("{row}");
    }
}

fn main() {
    if std::env::args().nth(1).as_deref() == Some("refs") {
        refs();
        return;
    }
    if std::env::args().nth(1).as_deref() == Some("time") {
        println!(
            "| problem | digits | IE: rtol, median, rhs | Bdf: rtol, median, rhs | Rodas5P: rtol, median, rhs | diffsol BDF: rtol, median, rhs | best reckon ÷ diffsol |"
        );
        println!("|---|---|---|---|---|---|---|");
        time_case(Case::Rober, diffsol_rober);
        time_case(Case::Vdpol, diffsol_vdpol);
        time_case(Case::Orego, diffsol_orego);
        time_case(Case::Hires, diffsol_hires);
        return;
    }
    let only: Option<String> = std::env::args().nth(1);
    let mut table = Vec::new();
    for case in CASES {
        if only.as_deref().is_some_and(|o| o != case.name()) {
            continue;
        }
        for who in WHO {
            // (k, digits, seconds, run)
            let mut pts: Vec<(u32, f64, f64, Run)> = Vec::new();
            for k in K_MIN..=K_MAX {
                let rtol = grid(k);
                let t0 = Instant::now();
                let r = run(case, who, rtol, MAX_STEPS);
                let secs = t0.elapsed().as_secs_f64();
                let (d, r) = match r {
                    Ok(r) => (case.digits(&r.y), r),
                    Err(e) => {
                        println!(
                            "{:6} {:15} k {k:2} rtol {rtol:9.3e}: failed: {e}",
                            case.name(),
                            who.name()
                        );
                        (f64::NEG_INFINITY, Run::default())
                    }
                };
                println!(
                    "{:6} {:15} k {k:2} rtol {rtol:9.3e}: digits {d:6.2}  {secs:8.4}s  {r}",
                    case.name(),
                    who.name()
                );
                pts.push((k, d, secs, r));
                let n = pts.len();
                let done = n >= 2 && pts[n - 1].1 >= 7.0 && pts[n - 2].1 >= 7.0;
                if done || secs > MAX_SECONDS {
                    break;
                }
            }
            let mut ks = [None; 3];
            for (l, &level) in LEVELS.iter().enumerate() {
                ks[l] = pts
                    .windows(2)
                    .find(|w| w[0].1 >= level && w[1].1 >= level)
                    .map(|w| w[0].0);
                match ks[l] {
                    Some(k) => {
                        let p = pts.iter().find(|p| p.0 == k).unwrap();
                        println!(
                            "  -> {} {} {level} digits: k {k} rtol {:.3e} (digits {:.2}, {:.4}s)",
                            case.name(),
                            who.name(),
                            grid(k),
                            p.1,
                            p.2
                        );
                    }
                    None => println!("  -> {} {} {level} digits: not reached", case.name(), who.name()),
                }
            }
            table.push((case, who, ks));
        }
    }
    println!("\nconst TOLS: &[(Case, Who, [Option<u32>; 3])] = &[");
    for (case, who, ks) in table {
        println!("    (Case::{case:?}, Who::{who:?}, {ks:?}),");
    }
    println!("];");
}

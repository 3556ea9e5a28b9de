//! Issue 36: mass-matrix DAEs against diffsol 0.18's BDF with a mass matrix (dense
//! nalgebra, `NalgebraLU`), at matched accuracy: Robertson as an index-1 DAE on
//! `[0, 1e5]` (`M = diag(1, 1, 0)`, `atol = 1e-4·rtol`) and the Test Set's transistor
//! amplifier on `[0, 0.2]` (`M` dense of rank 5, `atol = rtol`).
//!
//! For each problem and each of diffsol's tolerances (1e-6, 1e-8) the digits diffsol
//! reaches at `t_end` (the Test Set's mescd) are measured first; each reckon method is
//! then run at the loosest tolerance of the grid `10^(−k/4)` that reaches at least as
//! many digits, and all contenders are timed side by side in one criterion group
//! (interleaved samples: criterion runs the functions of a group in turn). Work counters
//! and digits are printed before each group. Right-hand sides: reckon's `model!` closures
//! from `reckon::studies::problems`, diffsol the same formulas on slices with hand-written
//! Jacobian–vector products.

use criterion::{Criterion, criterion_group, criterion_main};
use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod, OdeSolverStopReason, Vector as _};
use nalgebra::SVector;
use reckon::methods::{Bdf, Rodas5P};
use reckon::studies::problems::{ROBERTSON_REF_1E5, TRANSAMP_REF_02, robertson_dae, transamp, transamp_mass};
use reckon::{Mass, Options, Problem, Save};
use std::hint::black_box;
use std::time::Duration;

#[derive(Clone, Copy, PartialEq)]
enum Case {
    Rober,
    Transamp,
}

impl Case {
    fn name(self) -> &'static str {
        match self {
            Case::Rober => "rober-dae",
            Case::Transamp => "transamp",
        }
    }
    fn t_end(self) -> f64 {
        match self {
            Case::Rober => 1e5,
            Case::Transamp => 0.2,
        }
    }
    fn atol_ratio(self) -> f64 {
        match self {
            Case::Rober => 1e-4,
            Case::Transamp => 1.0,
        }
    }
    fn reference(self) -> &'static [f64] {
        match self {
            Case::Rober => &ROBERTSON_REF_1E5,
            Case::Transamp => &TRANSAMP_REF_02,
        }
    }
    fn y0(self) -> Vec<f64> {
        match self {
            Case::Rober => vec![1.0, 0.0, 0.0],
            Case::Transamp => vec![0.0, 3.0, 3.0, 6.0, 3.0, 3.0, 6.0, 0.0],
        }
    }
    /// The Test Set's mixed significant digits at `t_end`.
    fn digits(self, y: &[f64]) -> f64 {
        let r = self.atol_ratio();
        let m = y
            .iter()
            .zip(self.reference())
            .map(|(y, r0)| (y - r0).abs() / (r + r0.abs()))
            .fold(0.0, f64::max);
        -m.max(1e-16).log10()
    }
}

/// One reckon solve: the end state and the accepted steps.
fn reckon_solve(case: Case, bdf: bool, rtol: f64) -> Result<(Vec<f64>, u64), String> {
    let o = Options::default()
        .rtol(rtol)
        .atol(case.atol_ratio() * rtol)
        .save(Save::End)
        .max_steps(10_000_000);
    let sol = match case {
        Case::Rober => {
            let p = Problem::new(
                robertson_dae(),
                SVector::<f64, 3>::from_column_slice(&case.y0()),
                (0.0, case.t_end()),
            )
            .mass(Mass::diagonal(vec![1.0, 1.0, 0.0]));
            if bdf {
                p.solve(Bdf::default(), &o)
            } else {
                p.solve(Rodas5P, &o)
            }
            .map(|s| (s.last().1.as_slice().to_vec(), s.stats.accepted))
        }
        Case::Transamp => {
            let p = Problem::new(
                transamp(),
                SVector::<f64, 8>::from_column_slice(&case.y0()),
                (0.0, case.t_end()),
            )
            .mass(Mass::dense(transamp_mass()));
            if bdf {
                p.solve(Bdf::default(), &o)
            } else {
                p.solve(Rodas5P, &o)
            }
            .map(|s| (s.last().1.as_slice().to_vec(), s.stats.accepted))
        }
    };
    sol.map_err(|e| e.to_string())
}

// diffsol's right-hand sides, mass products and Jacobian–vector products on slices

fn rober_f(x: &[f64], _p: &[f64], _t: f64, y: &mut [f64]) {
    y[0] = -0.04 * x[0] + 1e4 * x[1] * x[2];
    y[1] = 0.04 * x[0] - 1e4 * x[1] * x[2] - 3e7 * x[1] * x[1];
    y[2] = x[0] + x[1] + x[2] - 1.0;
}
fn rober_jv(x: &[f64], _p: &[f64], _t: f64, v: &[f64], y: &mut [f64]) {
    y[0] = -0.04 * v[0] + 1e4 * (x[2] * v[1] + x[1] * v[2]);
    y[1] = 0.04 * v[0] - 1e4 * (x[2] * v[1] + x[1] * v[2]) - 6e7 * x[1] * v[1];
    y[2] = v[0] + v[1] + v[2];
}
fn rober_mass(v: &[f64], _p: &[f64], _t: f64, beta: f64, y: &mut [f64]) {
    y[0] = v[0] + beta * y[0];
    y[1] = v[1] + beta * y[1];
    y[2] *= beta;
}

const UB: f64 = 6.0;
const UF: f64 = 0.026;
const ALPHA: f64 = 0.99;
const BETA: f64 = 1e-6;
const R0: f64 = 1000.0;
const R: f64 = 9000.0;
const W: f64 = 200.0 * std::f64::consts::PI;

fn amp_f(y: &[f64], _p: &[f64], t: f64, f: &mut [f64]) {
    let uet = 0.1 * (W * t).sin();
    let fac1 = BETA * (((y[1] - y[2]) / UF).exp() - 1.0);
    let fac2 = BETA * (((y[4] - y[5]) / UF).exp() - 1.0);
    f[0] = (y[0] - uet) / R0;
    f[1] = y[1] / R + (y[1] - UB) / R + (1.0 - ALPHA) * fac1;
    f[2] = y[2] / R - fac1;
    f[3] = (y[3] - UB) / R + ALPHA * fac1;
    f[4] = y[4] / R + (y[4] - UB) / R + (1.0 - ALPHA) * fac2;
    f[5] = y[5] / R - fac2;
    f[6] = (y[6] - UB) / R + ALPHA * fac2;
    f[7] = y[7] / R;
}
fn amp_jv(y: &[f64], _p: &[f64], _t: f64, v: &[f64], f: &mut [f64]) {
    let g1 = BETA / UF * ((y[1] - y[2]) / UF).exp();
    let g2 = BETA / UF * ((y[4] - y[5]) / UF).exp();
    let (d1, d2) = (v[1] - v[2], v[4] - v[5]);
    f[0] = v[0] / R0;
    f[1] = 2.0 * v[1] / R + (1.0 - ALPHA) * g1 * d1;
    f[2] = v[2] / R - g1 * d1;
    f[3] = v[3] / R + ALPHA * g1 * d1;
    f[4] = 2.0 * v[4] / R + (1.0 - ALPHA) * g2 * d2;
    f[5] = v[5] / R - g2 * d2;
    f[6] = v[6] / R + ALPHA * g2 * d2;
    f[7] = v[7] / R;
}
fn amp_mass(v: &[f64], _p: &[f64], _t: f64, beta: f64, y: &mut [f64]) {
    // transamp_mass() written out: the capacitors C_k = k·1e-6
    let (c1, c2, c3, c4, c5) = (1e-6, 2e-6, 3e-6, 4e-6, 5e-6);
    let mv = [
        -c1 * v[0] + c1 * v[1],
        c1 * v[0] - c1 * v[1],
        -c2 * v[2],
        -c3 * v[3] + c3 * v[4],
        c3 * v[3] - c3 * v[4],
        -c4 * v[5],
        -c5 * v[6] + c5 * v[7],
        c5 * v[6] - c5 * v[7],
    ];
    for i in 0..8 {
        y[i] = mv[i] + beta * y[i];
    }
}

// the transistor amplifier with M and f negated (Hairer–Wanner's sign; the same solution)
fn amp_f_neg(y: &[f64], p: &[f64], t: f64, f: &mut [f64]) {
    amp_f(y, p, t, f);
    f.iter_mut().for_each(|v| *v = -*v);
}
fn amp_jv_neg(y: &[f64], p: &[f64], t: f64, v: &[f64], f: &mut [f64]) {
    amp_jv(y, p, t, v, f);
    f.iter_mut().for_each(|v| *v = -*v);
}
fn amp_mass_neg(v: &[f64], p: &[f64], t: f64, beta: f64, y: &mut [f64]) {
    let mut mv = [0.0; 8];
    amp_mass(v, p, t, 0.0, &mut mv);
    for i in 0..8 {
        y[i] = -mv[i] + beta * y[i];
    }
}

/// One diffsol BDF solve to `t_end`: the end state and the steps. The transistor
/// amplifier is given in the Test Set's signs first and, when diffsol fails on them, with
/// `M` and `f` negated.
fn diffsol_solve(case: Case, rtol: f64) -> Result<(Vec<f64>, u64), String> {
    match (case, diffsol_solve_as(case, rtol, false)) {
        (Case::Transamp, Err(e)) => diffsol_solve_as(case, rtol, true).map_err(|e2| format!("{e}; negated: {e2}")),
        (_, r) => r,
    }
}

fn diffsol_solve_as(case: Case, rtol: f64, negated: bool) -> Result<(Vec<f64>, u64), String> {
    let y0 = case.y0();
    let n = y0.len();
    let atol = vec![case.atol_ratio() * rtol; n];
    macro_rules! run {
        ($f:expr, $jv:expr, $mass:expr) => {{
            let problem = OdeBuilder::<NalgebraMat<f64>>::new()
                .rtol(rtol)
                .atol(atol)
                .rhs_implicit($f, $jv)
                .mass($mass)
                .init(move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0), n)
                .build()
                .map_err(|e| e.to_string())?;
            let mut s = problem.bdf::<NalgebraLU<f64>>().map_err(|e| e.to_string())?;
            s.set_stop_time(case.t_end()).map_err(|e| e.to_string())?;
            loop {
                if let OdeSolverStopReason::TstopReached = s.step().map_err(|e| e.to_string())? {
                    break;
                }
            }
            Ok((s.state().y.clone_as_vec(), s.get_statistics().number_of_steps as u64))
        }};
    }
    match (case, negated) {
        (Case::Rober, _) => run!(rober_f, rober_jv, rober_mass),
        (Case::Transamp, false) => run!(amp_f, amp_jv, amp_mass),
        (Case::Transamp, true) => run!(amp_f_neg, amp_jv_neg, amp_mass_neg),
    }
}

/// The loosest `10^(−k/4)` at which reckon's method reaches `digits`.
fn matched_rtol(case: Case, bdf: bool, digits: f64) -> Option<f64> {
    (8..=52)
        .map(|k| 10f64.powf(-(k as f64) / 4.0))
        .find(|&rtol| reckon_solve(case, bdf, rtol).is_ok_and(|(y, _)| case.digits(&y) >= digits))
}

fn bench(c: &mut Criterion) {
    for case in [Case::Rober, Case::Transamp] {
        for d_rtol in [1e-6, 1e-8] {
            let name = format!("dae/{}/diffsol-rtol-{d_rtol:e}", case.name());
            let (y, steps) = match diffsol_solve(case, d_rtol) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("{name}: diffsol fails: {e}");
                    continue;
                }
            };
            let digits = case.digits(&y);
            eprintln!("{name}: diffsol {digits:.2} digits, {steps} steps");
            let mut g = c.benchmark_group(&name);
            g.sample_size(10)
                .warm_up_time(Duration::from_millis(300))
                .measurement_time(Duration::from_secs(2));
            g.bench_function("diffsol-bdf", |b| {
                b.iter(|| diffsol_solve(black_box(case), d_rtol).unwrap())
            });
            for (who, bdf) in [("reckon-bdf", true), ("reckon-rodas5p", false)] {
                match matched_rtol(case, bdf, digits) {
                    Some(rtol) => {
                        let (y, steps) = reckon_solve(case, bdf, rtol).unwrap();
                        eprintln!(
                            "{name}: {who} at rtol {rtol:.2e}: {:.2} digits, {steps} steps",
                            case.digits(&y)
                        );
                        g.bench_function(who, |b| b.iter(|| reckon_solve(black_box(case), bdf, rtol).unwrap()));
                    }
                    None => eprintln!("{name}: {who} does not reach {digits:.2} digits"),
                }
            }
            g.finish();
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! The sparse path of the implicit methods, measured on BRUSS 1-D (HNW ODE II §IV.1,
//! `tests/it/common/bruss.rs`: the body of `problems::brusselator` as a hand-written model
//! whose `sparse_jacobian` is the coloured num-dual evaluator, `coloured`, or the exact
//! non-zeros by hand, `hand`, a stand-in for a compiled one).
//!
//! `cargo run --release --example sparse_scaling -- MODE`:
//! - `scaling`: ImplicitEuler and BDF2 (`Bdf::fixed_order(2)`), 20 fixed steps of 0.005,
//!   and Bdf (adaptive, rtol = atol = 1e-6 on `[0, 0.1]`) at 10³, 10⁴, 10⁵, 10⁶ states, one process each: median wall
//!   time per step per state (the whole run, set-up included: symbolic analysis, first
//!   touch of the memory), the marginal cost per step per state ((solve to 0.4 − solve to
//!   0.1)/(extra steps), after a first solve) and peak RSS (`VmHWM`), with J coloured, by
//!   hand, and traced (the
//!   shipped `problems::brusselator`, whose time includes tracing and compiling its body).
//! - `versus`: 500 points (1 000 states) on `[0, 10]` at 5 mixed significant digits
//!   (`−log10 max|y − y_ref|/(1 + |y_ref|)`, reference Rodas5P and Bdf at 1e-11 agreeing):
//!   reckon's Bdf sparse (`problems::brusselator` under `Auto`: the traced, compiled J;
//!   coloured; hand) and dense (`problems::brusselator`'s num-dual dense J; the
//!   hand-written dense J), Rodas5P sparse, and diffsol 0.18's BDF with its faer sparse LU.
//! - `setup STATES`: the time to trace and compile `problems::brusselator`'s body alone.
//! - `crossover`: one factorisation + solve of `I − c·J`, faer dense LU vs
//!   [`SparseLu`](reckon::linalg::SparseLu), BRUSS pattern by size and random patterns by
//!   density (for `AUTO_MIN_STATES`, `AUTO_MAX_DENSITY`).
//!
//! Measured (2 cores, 2 Dec 2026, with native compiled Jacobians): `scaling`, 10³ → 10⁶
//! states, marginal ns/step/state, ImplicitEuler: hand 39.9 → 54.2 (1.36×), coloured 40.9 →
//! 56.3 (1.38×), traced 46.1 → 54.3 (1.18×); whole runs 1.2–1.7× (docs/performance.md).
//! Earlier (shared cores, before the marginal column):
//! `scaling`, 10³ → 10⁶ states, ns/step/state: ImplicitEuler hand J 70 → 119 (1.7×),
//! coloured 91 → 133 (1.45×); Bdf hand 95 → 163 (1.7×), coloured 108 → 159 (1.47×): the
//! growth is the working set leaving the caches (and the one-off COLAMD order and first
//! touch of ~600 MiB at 10⁶). Peak RSS at 10⁶: 617–761 MiB (traced: 1.7–1.8 GiB, of
//! which the trace of the body alone is 1.7 GiB and 8.6 s). `versus` at 5 digits: Bdf
//! dense/sparse 56–94×; diffsol's sparse BDF takes 0.9–2.8× reckon's sparse time (runs on
//! a loaded machine vary that much), and the traced J's trace + compile (3 ms) is in
//! every reckon solve. Re-measured after `problems::brusselator_y0` took the reference
//! values' amplitude ½ (two runs, 2 Dec 2026): Bdf at 1e-5 (5.5 digits) sparse hand
//! 8.5–13 ms, coloured 9.4–14 ms, traced 12.5–14 ms (the model now keeps its compiled J,
//! so only the first solve traces), dense hand 1.06–1.25 s, dense num-dual 0.97–0.98 s:
//! 70–125×; Rodas5P sparse at 5.6e-6 18–20 ms; diffsol at 1.8e-6 19–22 ms, 1.4–2.5×
//! reckon's sparse time; the reference pair agrees to 10.2 digits.

#[path = "common/rss.rs"]
mod rss;
use rss::peak_rss_mib;

#[path = "../tests/it/common/bruss.rs"]
mod bruss;

use bruss::{Bruss, Jac};
use nalgebra::{DMatrix, DVector};
use reckon::methods::{Bdf, ImplicitEuler, Rodas5P};
use reckon::studies::problems::{brusselator, brusselator_y0};
use reckon::{LinearSolver, Save};
use reckon::{Options, Problem};
use reckon::{jacobian::Pattern, linalg::SparseLu};
use std::time::Instant;

fn jac(s: &str) -> Jac {
    match s {
        "hand" => Jac::Hand,
        "none" => Jac::None,
        _ => Jac::Coloured,
    }
}

/// One case in this process: `one METHOD JAC STATES` (`JAC` = `traced`: the shipped
/// `problems::brusselator`, whose `model!` body the symbolic layer traces and compiles in
/// every solve). The median of `10⁶/STATES` solves (1 to 25).
fn one(method: &str, j: &str, states: usize) {
    let n = states / 2;
    if j == "traced" {
        run_one(&brusselator(n), method, j, states);
    } else {
        run_one(&Bruss::new(n, jac(j)), method, j, states);
    }
}

fn run_one<S: reckon::System<nalgebra::Dyn>>(sys: &S, method: &str, j: &str, states: usize) {
    let n = states / 2;
    let base = Options::default()
        .save(Save::End)
        .dense(false)
        .linear_solver(LinearSolver::Sparse);
    let solve = |t_end: f64| {
        let p = Problem::new(sys, brusselator_y0(n), (0.0, t_end));
        match method {
            "ie" => p.solve(ImplicitEuler::default(), &base.clone().fixed(0.005)),
            // BDF2 at the same fixed step: the same work in every step after the first two
            "bdf2" => p.solve(Bdf::default().fixed_order(2), &base.clone().fixed(0.005)),
            _ => p.solve(Bdf::default(), &base.clone().rtol(1e-6).atol(1e-6)),
        }
        .expect("solves")
    };
    let reps = (1_000_000 / states).clamp(1, 25);
    let (mut stats, mut stats2) = (None, None);
    let secs = time(reps, || stats = Some(solve(0.1).stats));
    // after the solve above (which traces a traced model: the model keeps its compiled
    // Jacobian), the same solve over four times the span against the solve over the span:
    // the difference is the cost of the extra steps alone, without the one-off set-up
    // (trace and compile, symbolic analysis, first touch of the memory)
    let short = time(reps, || {
        solve(0.1);
    });
    let secs2 = time(reps, || stats2 = Some(solve(0.4).stats));
    let secs = (secs, short);
    let s = stats.expect("ran");
    let s2 = stats2.expect("ran");
    let steps = (s.accepted + s.rejected) as f64;
    let steps2 = (s2.accepted + s2.rejected) as f64;
    println!(
        "| {method:4} | {j:8} | {states:>9} | {:>5} | {:>6} | {:>3} | {:>3} | {:>8.4} | {:>7.1} | {:>7.1} | {:>8.0} |",
        s.accepted + s.rejected,
        s.newton_iterations,
        s.jacobian_evals,
        s.lu_decompositions,
        secs.0,
        secs.0 / steps / states as f64 * 1e9,
        (secs2 - secs.1) / (steps2 - steps) / states as f64 * 1e9,
        peak_rss_mib()
    );
}

fn scaling() {
    println!(
        "| method | J | states | steps | Newton | J | LU | wall s | ns/step/state | marginal ns/step/state | peak RSS MiB |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let exe = std::env::current_exe().expect("own path");
    for method in ["ie", "bdf2", "bdf"] {
        for j in ["coloured", "hand", "traced"] {
            for states in [1_000usize, 10_000, 100_000, 1_000_000] {
                let out = std::process::Command::new(&exe)
                    .args(["one", method, j, &states.to_string()])
                    .output()
                    .expect("runs");
                print!("{}", String::from_utf8_lossy(&out.stdout));
            }
        }
    }
}

const N: usize = 500;
const T_END: f64 = 10.0;

fn digits(y: &DVector<f64>, r: &DVector<f64>) -> f64 {
    let m = y
        .iter()
        .zip(r.iter())
        .map(|(y, r)| (y - r).abs() / (1.0 + r.abs()))
        .fold(0.0, f64::max);
    -m.log10()
}

fn rtol_grid(k: u32) -> f64 {
    10f64.powf(-(k as f64) / 4.0)
}

/// A contender: solve at `rtol` (= atol), the end state.
type Solve<'a> = Box<dyn Fn(f64) -> DVector<f64> + 'a>;

/// The loosest grid tolerance reaching `target` digits (its tighter neighbour too), the
/// median wall time of 21 solves there (5 if one takes over 0.1 s) and the digits.
fn at_digits(name: &str, solve: &Solve<'_>, r: &DVector<f64>, target: f64) -> f64 {
    let mut k = 8; // 1e-2
    let d = |k| digits(&solve(rtol_grid(k)), r);
    while !(d(k) >= target && d(k + 1) >= target) {
        k += 1;
        assert!(k < 60, "{name}: does not reach {target} digits");
    }
    let t0 = Instant::now();
    std::hint::black_box(solve(rtol_grid(k)));
    let reps = if t0.elapsed().as_secs_f64() < 0.1 { 21 } else { 5 };
    let t = time(reps, || {
        std::hint::black_box(solve(rtol_grid(k)));
    });
    println!("| {name:34} | {:8.2e} | {:5.2} | {:9.4} |", rtol_grid(k), d(k), t);
    t
}

fn reckon_bdf<'a>(sys: &'a Bruss, linear: LinearSolver) -> Solve<'a> {
    Box::new(move |rtol| {
        let o = Options::default()
            .rtol(rtol)
            .atol(rtol)
            .save(Save::End)
            .dense(false)
            .linear_solver(linear);
        let sol = Problem::new(sys, brusselator_y0(N), (0.0, T_END))
            .solve(Bdf::default(), &o)
            .expect("solves");
        sol.last().1.clone()
    })
}

mod ds {
    use diffsol::{FaerSparseLU, FaerSparseMat, OdeBuilder, OdeSolverMethod, OdeSolverStopReason, Vector};
    use nalgebra::DVector;

    const C: f64 = 501.0 * 501.0 / 50.0;

    fn f(x: &[f64], y: &mut [f64]) {
        let n = x.len() / 2;
        for i in 0..n {
            let (u, v) = (x[2 * i], x[2 * i + 1]);
            let (ul, vl) = if i == 0 {
                (1.0, 3.0)
            } else {
                (x[2 * i - 2], x[2 * i - 1])
            };
            let (ur, vr) = if i + 1 == n {
                (1.0, 3.0)
            } else {
                (x[2 * i + 2], x[2 * i + 3])
            };
            let uuv = u * u * v;
            y[2 * i] = uuv - u * 4.0 + 1.0 + (ul + ur - u * 2.0) * C;
            y[2 * i + 1] = u * 3.0 - uuv + (vl + vr - v * 2.0) * C;
        }
    }
    fn jv(x: &[f64], w: &[f64], y: &mut [f64]) {
        let n = x.len() / 2;
        for i in 0..n {
            let (u, v) = (x[2 * i], x[2 * i + 1]);
            let (a, b) = (w[2 * i], w[2 * i + 1]);
            let (al, bl) = if i == 0 {
                (0.0, 0.0)
            } else {
                (w[2 * i - 2], w[2 * i - 1])
            };
            let (ar, br) = if i + 1 == n {
                (0.0, 0.0)
            } else {
                (w[2 * i + 2], w[2 * i + 3])
            };
            y[2 * i] = (2.0 * u * v - 4.0) * a + u * u * b + (al + ar - 2.0 * a) * C;
            y[2 * i + 1] = (3.0 - 2.0 * u * v) * a - u * u * b + (bl + br - 2.0 * b) * C;
        }
    }

    /// diffsol's BDF with `FaerSparseMat` (pattern found by NaN probing of `jv`, coloured
    /// Jacobian assembly) and `FaerSparseLU`.
    pub fn solve(rtol: f64, y0: &DVector<f64>, t_end: f64) -> DVector<f64> {
        let y0v: Vec<f64> = y0.iter().copied().collect();
        let n = y0v.len();
        let problem = OdeBuilder::<FaerSparseMat<f64>>::new()
            .rtol(rtol)
            .atol(vec![rtol; n])
            .rhs_implicit(
                |x: &[f64], _p: &[f64], _t: f64, y: &mut [f64]| f(x, y),
                |x: &[f64], _p: &[f64], _t: f64, v: &[f64], y: &mut [f64]| jv(x, v, y),
            )
            .init(move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0v), n)
            .build()
            .expect("diffsol problem");
        let mut s = problem.bdf::<FaerSparseLU<f64>>().expect("bdf");
        s.set_stop_time(t_end).expect("stop time");
        loop {
            if let OdeSolverStopReason::TstopReached = s.step().expect("step") {
                break;
            }
        }
        DVector::from_vec(s.state().y.clone_as_vec())
    }
}

fn versus() {
    let hand = Bruss::new(N, Jac::Hand);
    let coloured = Bruss::new(N, Jac::Coloured);
    let dense_hand = Bruss::new(N, Jac::None);
    // reference: Rodas5P and Bdf at 1e-11 (sparse, exact J)
    let o = Options::default().rtol(1e-11).atol(1e-11).save(Save::End).dense(false);
    let p = Problem::new(&hand, brusselator_y0(N), (0.0, T_END));
    let r1 = p.solve(Rodas5P, &o).expect("reference").last().1.clone();
    let r2 = p.solve(Bdf::default(), &o).expect("reference").last().1.clone();
    println!(
        "reference: Rodas5P and Bdf at 1e-11 agree to {:.2} digits",
        digits(&r1, &r2)
    );
    let r = r1;
    println!("| contender | rtol = atol | digits | median s |");
    println!("|---|---:|---:|---:|");
    let target = 5.0;
    let s_hand = at_digits(
        "reckon Bdf sparse (hand J)",
        &reckon_bdf(&hand, LinearSolver::Sparse),
        &r,
        target,
    );
    let s_col = at_digits(
        "reckon Bdf sparse (coloured J)",
        &reckon_bdf(&coloured, LinearSolver::Sparse),
        &r,
        target,
    );
    let d_hand = at_digits(
        "reckon Bdf dense (hand J)",
        &reckon_bdf(&dense_hand, LinearSolver::Dense),
        &r,
        target,
    );
    let sys = brusselator(N);
    let traced: Solve<'_> = Box::new(|rtol| {
        let o = Options::default().rtol(rtol).atol(rtol).save(Save::End).dense(false);
        Problem::new(&sys, brusselator_y0(N), (0.0, T_END))
            .solve(Bdf::default(), &o)
            .expect("solves")
            .last()
            .1
            .clone()
    });
    let s_tr = at_digits("reckon Bdf Auto (model!, traced J)", &traced, &r, target);
    let nd: Solve<'_> = Box::new(|rtol| {
        let o = Options::default()
            .rtol(rtol)
            .atol(rtol)
            .save(Save::End)
            .dense(false)
            .linear_solver(LinearSolver::Dense);
        Problem::new(&sys, brusselator_y0(N), (0.0, T_END))
            .solve(Bdf::default(), &o)
            .expect("solves")
            .last()
            .1
            .clone()
    });
    let d_nd = at_digits("reckon Bdf dense (model!, num-dual J)", &nd, &r, target);
    let rodas: Solve<'_> = Box::new(|rtol| {
        let o = Options::default()
            .rtol(rtol)
            .atol(rtol)
            .save(Save::End)
            .dense(false)
            .linear_solver(LinearSolver::Sparse);
        Problem::new(&hand, brusselator_y0(N), (0.0, T_END))
            .solve(Rodas5P, &o)
            .expect("solves")
            .last()
            .1
            .clone()
    });
    at_digits("reckon Rodas5P sparse (hand J)", &rodas, &r, target);
    let y0 = brusselator_y0(N);
    let dsol: Solve<'_> = Box::new(|rtol| ds::solve(rtol, &y0, T_END));
    let s_ds = at_digits("diffsol 0.18 BDF, FaerSparseLU", &dsol, &r, target);
    println!(
        "\ndense (model!) / sparse (model!, traced): {:.0}×; / sparse (coloured): {:.0}×; \
         dense (hand) / sparse (hand): {:.0}×; diffsol sparse / reckon sparse: traced {:.2}×, \
         hand {:.2}×, coloured {:.2}×",
        d_nd / s_tr,
        d_nd / s_col,
        d_hand / s_hand,
        s_ds / s_tr,
        s_ds / s_hand,
        s_ds / s_col
    );
}

/// Median seconds of `reps` calls.
fn time(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[reps / 2]
}

/// `M = I − c·A` for the entries `e` of a pattern: dense and sparse, factor + solve.
fn lu_pair(n: usize, e: &[(usize, usize)], reps: usize) -> (f64, f64) {
    let p = Pattern::from_entries(n, e).unwrap().with_diagonal();
    let vals: Vec<f64> = p
        .entries()
        .map(|(i, j)| {
            if i == j {
                4.0 + (i % 3) as f64
            } else {
                -0.5 - ((i + j) % 5) as f64 * 0.1
            }
        })
        .collect();
    let mut dense = DMatrix::zeros(n, n);
    for ((i, j), v) in p.entries().zip(&vals) {
        dense[(i, j)] = *v;
    }
    let b = DVector::from_element(n, 1.0);
    let td = time(reps, || {
        let view = faer::MatRef::from_column_major_slice(dense.as_slice(), n, n);
        let lu = view.partial_piv_lu();
        let mut x = b.clone();
        use faer::linalg::solvers::Solve;
        lu.solve_in_place(faer::MatMut::from_column_major_slice_mut(x.as_mut_slice(), n, 1));
        std::hint::black_box(x);
    });
    let mut lu = SparseLu::new(&p).expect("analysis");
    let ts = time(reps, || {
        assert_eq!(lu.factor(&vals), Ok(true));
        let mut x = b.clone();
        lu.solve_in_place(x.as_mut_slice()).unwrap();
        std::hint::black_box(x);
    });
    (td, ts)
}

fn crossover() {
    println!("BRUSS 1-D pattern (5 per column): one factor + solve of I − cJ");
    println!("| states | dense µs | sparse µs | dense/sparse |");
    println!("|---:|---:|---:|---:|");
    for states in [8usize, 16, 32, 64, 128, 256, 512, 1024] {
        let (td, ts) = lu_pair(states, &bruss::entries(states / 2), 51);
        println!("| {states} | {:.1} | {:.1} | {:.2} |", td * 1e6, ts * 1e6, td / ts);
    }
    for n in [64usize, 256] {
        println!("\nrandom patterns, {n} states: one factor + solve");
        println!("| density | dense µs | sparse µs | dense/sparse |");
        println!("|---:|---:|---:|---:|");
        for d in [0.01, 0.02, 0.05, 0.1, 0.2, 0.4] {
            let mut s: u64 = 12345;
            let mut e = Vec::new();
            for i in 0..n {
                for j in 0..n {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    if ((s >> 11) as f64) / ((1u64 << 53) as f64) < d {
                        e.push((i, j));
                    }
                }
            }
            let (td, ts) = lu_pair(n, &e, 21);
            println!("| {d} | {:.1} | {:.1} | {:.2} |", td * 1e6, ts * 1e6, td / ts);
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("one") => one(&args[2], &args[3], args[4].parse().expect("states")),
        Some("versus") => versus(),
        Some("crossover") => crossover(),
        Some("setup") => {
            // trace + compile of the shipped model's body alone
            let states: usize = args[2].parse().expect("states");
            let sys = brusselator(states / 2);
            let t0 = Instant::now();
            let j = reckon::System::sparse_jacobian(&sys, states).expect("traced");
            println!(
                "{states} states: trace + compile {:.3} s, nnz {}, peak RSS {:.0} MiB",
                t0.elapsed().as_secs_f64(),
                j.pattern().nnz(),
                peak_rss_mib()
            );
        }
        _ => scaling(),
    }
}

//! The performance figures of `docs/performance.md`, in process CPU time, every contender
//! of a table interleaved in one run (ABC, BCA, CAB, … rounds: see
//! `examples/common/cpu.rs`), with the median and the spread over the rounds of every time
//! and of every ratio (each round's ratio is of two batches timed next to each other).
//!
//! `cargo run --release --example perf -- SECTION [ROUNDS]`, SECTION one of
//! - `rk45` (21 rounds): reckon's `Rk45` against the hand-written loop
//!   (`benches/handwritten.rs`) and `ode_solvers` 0.6 on Lorenz, Arenstorf and Van der
//!   Pol μ = 1, tol 1e-4 … 1e-10, the same model code (as `benches/rk45.rs`);
//! - `stiff` (15 rounds): `Bdf`, `Rodas5P` (and `ImplicitEuler` where a solve takes
//!   under 50 ms) against diffsol 0.18's BDF at 3, 5 and 7 correct digits on Robertson,
//!   Van der Pol μ = 1000, OREGO and HIRES, each at the loosest rtol on the grid
//!   10^(−k/4) that reaches the digits with its tighter neighbour (searched here, as
//!   `examples/stiff_wp.rs` does);
//! - `sparse` (7 rounds): BRUSS 1-D with 500 points (1 000 states) on [0, 10] at 5
//!   digits: `Bdf` sparse (traced model kept, rebuilt per solve with the compiled-program
//!   cache warm and emptied, hand and coloured J), dense (hand J, num-dual), `Rodas5P`
//!   sparse, diffsol's sparse BDF (problem kept and rebuilt per solve);
//! - `jacobian` (21 rounds): one Jacobian evaluation, num-dual against the compiled
//!   symbolic Jacobian (native and interpreted), as `benches/jacobian.rs`;
//! - `small` (21 rounds): the model call (`model!` closure against a plain `fn`) and
//!   implicit Euler on Robertson with the autodiff against a hand-written Jacobian, as
//!   `benches/rk45.rs` and `benches/implicit.rs`;
//! - `all`: every section above.
//!
//! Not a test (`cargo test` only builds it): `all` takes about 2 minutes on 2 cores.
#![allow(clippy::excessive_precision)]

#[path = "../tests/it/common/bruss.rs"]
mod bruss;
#[path = "common/cpu.rs"]
mod cpu;
#[path = "../benches/handwritten.rs"]
mod handwritten;
#[path = "../benches/common/stiff.rs"]
mod stiff;

use cpu::*;
use nalgebra::{Const, DMatrix, DVector, Matrix3, SMatrix, SVector, Vector3, vector};
use reckon::methods::{Bdf, ImplicitEuler, Rk45, Rodas5P};
use reckon::{LinearSolver, Save};
use reckon::{Options, Problem, System, symbolic};
use std::hint::black_box;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let section = a.get(1).map_or("all", |s| s.as_str());
    let rounds = a.get(2).map(|s| s.parse::<usize>().expect("ROUNDS: a count"));
    let r = |d: usize| rounds.unwrap_or(d);
    match section {
        "rk45" => rk45(r(21)),
        "stiff" => stiff_section(r(15)),
        "sparse" => sparse(r(7)),
        "jacobian" => jacobian(r(21)),
        "small" => small(r(21)),
        "all" => {
            rk45(r(21));
            stiff_section(r(15));
            sparse(r(7));
            jacobian(r(21));
            small(r(21));
        }
        _ => panic!("usage: perf rk45|stiff|sparse|jacobian|small|all [ROUNDS]"),
    }
}

// ---------------------------------------------------------------------------------------
// RK45

mod os_run {
    use ode_solvers as os;

    /// ode_solvers given the same model code as the hand-written loop (the function item).
    struct Os<const N: usize, H>(H);

    impl<const N: usize, H: Fn(f64, &[f64; N]) -> [f64; N]> os::System<f64, os::SVector<f64, N>> for Os<N, H> {
        #[inline(always)]
        fn system(&self, t: f64, y: &os::SVector<f64, N>, dy: &mut os::SVector<f64, N>) {
            let r = (self.0)(t, &y.data.0[0]);
            dy.data.0[0] = r;
        }
    }

    pub fn run<const N: usize>(
        f: impl Fn(f64, &[f64; N]) -> [f64; N],
        x0: [f64; N],
        t_end: f64,
        tol: f64,
    ) -> (f64, u32) {
        let y0 = os::SVector::<f64, N>::from(x0);
        let mut s = os::Dopri5::from_param(
            Os(f),
            0.0,
            t_end,
            0.0,
            y0,
            tol,
            tol,
            0.9,
            0.04,
            0.2,
            10.0,
            t_end,
            0.0,
            100_000,
            1000,
            os::OutputType::Sparse,
        );
        let st = s.integrate().expect("ode_solvers failed");
        (s.y_out().last().map(|y| y[0]).unwrap_or(f64::NAN), st.num_eval)
    }
}

/// Per cell: (reckon ÷ hand, reckon ÷ ode_solvers) medians, appended to `cells`.
fn rk45_problem<const N: usize, H: Fn(f64, &[f64; N]) -> [f64; N] + Copy>(
    name: &str,
    sys: impl System<Const<N>>,
    hand: H,
    x0: [f64; N],
    t_end: f64,
    rounds: usize,
    cells: &mut Vec<(f64, f64)>,
) {
    let p = Problem::new(&sys, SVector::from(x0), (0.0, t_end));
    for tol in [1e-4, 1e-6, 1e-8, 1e-10] {
        let opts = Options::default().rtol(tol).atol(tol).dense(false);
        let r = p.solve(Rk45, &opts).unwrap();
        let h = handwritten::dopri5(hand, 0.0, t_end, x0, tol);
        let (_, os_evals) = os_run::run(hand, x0, t_end, tol);
        let mut cs = vec![
            Contender::new("reckon", |n| {
                for _ in 0..n {
                    black_box(p.solve(Rk45, black_box(&opts)).unwrap().stats.accepted);
                }
            }),
            Contender::new("hand", |n| {
                for _ in 0..n {
                    black_box(handwritten::dopri5(hand, 0.0, t_end, black_box(x0), tol).accepted);
                }
            }),
            Contender::new("ode_solvers", |n| {
                for _ in 0..n {
                    black_box(os_run::run(hand, black_box(x0), t_end, tol));
                }
            }),
        ];
        let t = interleave(&mut cs, rounds, 0.01);
        let (rh, ro) = (ratios(&t[0], &t[1]), ratios(&t[0], &t[2]));
        println!(
            "| {name} | {tol:.0e} | {} | {} | {} | {} | {} | {} / {} / {} |",
            fmt_time(&t[0]),
            fmt_time(&t[1]),
            fmt_time(&t[2]),
            fmt_ratio(&rh),
            fmt_ratio(&ro),
            r.stats.rhs_evals,
            h.evals,
            os_evals
        );
        cells.push((median(&rh), median(&ro)));
    }
}

fn rk45(rounds: usize) {
    println!("\n## rk45: {rounds} rounds, CPU time per solve, median (min–max over rounds)\n");
    println!(
        "| problem | tol | reckon | hand-written | ode_solvers | reckon ÷ hand | reckon ÷ ode_solvers | rhs evals reckon / hand / ode_solvers |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let mut cells = Vec::new();
    use reckon::studies::problems::*;
    rk45_problem(
        "Lorenz",
        lorenz(),
        handwritten::lorenz,
        [1.0, 1.0, 1.0],
        20.0,
        rounds,
        &mut cells,
    );
    rk45_problem(
        "Arenstorf",
        arenstorf(),
        handwritten::arenstorf,
        ARENSTORF_Y0,
        ARENSTORF_T,
        rounds,
        &mut cells,
    );
    rk45_problem(
        "Van der Pol μ = 1",
        handwritten::van_der_pol_model(),
        handwritten::van_der_pol,
        [2.0, 0.0],
        20.0,
        rounds,
        &mut cells,
    );
    let h: Vec<f64> = cells.iter().map(|c| c.0).collect();
    let o: Vec<f64> = cells.iter().map(|c| c.1).collect();
    let (hl, hh) = range(&h);
    let (ol, oh) = range(&o);
    println!(
        "\nper-cell medians: reckon ÷ hand geometric mean {:.3}, range {hl:.3}–{hh:.3}; \
         reckon ÷ ode_solvers geometric mean {:.3}, range {ol:.3}–{oh:.3}",
        geomean(&h),
        geomean(&o)
    );
}

// ---------------------------------------------------------------------------------------
// Stiff methods against diffsol at matched accuracy

use stiff::{Case, DiffsolModel, LEVELS, Who, grid, reckon_options, tol_index};

const MAX_STEPS: usize = 20_000_000;

/// The loosest grid index from `k0` whose point and its tighter neighbour reach `target`.
/// Implicit Euler's step cap in the tolerance search: first order, its tight cells take
/// millions of steps.
const IE_MAX_STEPS: usize = 2_000_000;

fn search(digits: &mut impl FnMut(u32) -> f64, k0: u32, target: f64) -> Option<u32> {
    let mut memo = std::collections::HashMap::new();
    let mut d = |k: u32| *memo.entry(k).or_insert_with(|| digits(k));
    (k0..56).find(|&k| d(k) >= target && d(k + 1) >= target)
}

fn stiff_cell<E>(case: Case, make: impl Fn(f64) -> DiffsolModel<E>, rounds: usize)
where
    E: diffsol::OdeEquationsImplicit<
            M = diffsol::NalgebraMat<f64>,
            V = diffsol::NalgebraVec<f64>,
            T = f64,
            C = diffsol::NalgebraContext,
        >,
{
    for (l, &level) in LEVELS.iter().enumerate() {
        // the tolerance of each contender
        let mut picks: Vec<(Who, u32)> = Vec::new();
        for who in [Who::Bdf, Who::Rodas5P, Who::Diffsol] {
            let mut dg =
                |k: u32| stiff::run(case, who, grid(k), MAX_STEPS).map_or(f64::NEG_INFINITY, |r| case.digits(&r.y));
            match search(&mut dg, 4, level) {
                Some(k) => picks.push((who, k)),
                None => eprintln!("{} {level}d {}: not reached", case.name(), who.name()),
            }
        }
        // implicit Euler: its own loosest rtol on the grid (with its tighter neighbour), at
        // most IE_MAX_STEPS per solve and no tighter once a solve fails; timed only if quick
        let mut ie_note = String::from("not reached");
        let mut ie_digits = std::collections::HashMap::new();
        let mut ie_run = |k: u32| {
            ie_digits
                .entry(k)
                .or_insert_with(|| {
                    stiff::run(case, Who::ImplicitEuler, grid(k), IE_MAX_STEPS)
                        .map(|r| case.digits(&r.y))
                        .map_err(|e| e.to_string())
                })
                .clone()
        };
        let mut ie_k = None;
        for k in 4..56 {
            match (ie_run(k), ie_run(k + 1)) {
                (Ok(a), Ok(b)) if a >= level && b >= level => {
                    ie_k = Some(k);
                    break;
                }
                (Err(e), _) | (_, Err(e)) => {
                    ie_note = format!(
                        "not reached within {IE_MAX_STEPS} steps from rtol {:.1e} ({e})",
                        grid(k)
                    );
                    break;
                }
                _ => {}
            }
        }
        if let Some(k) = ie_k {
            let t0 = cpu();
            let r = stiff::run(case, Who::ImplicitEuler, grid(k), IE_MAX_STEPS);
            let t = cpu() - t0;
            match r {
                Ok(_) if t < 0.05 => picks.insert(0, (Who::ImplicitEuler, k)),
                Ok(r) => {
                    ie_note = format!(
                        "{} (one solve) @ {:.1e}, {:.2} digits",
                        fmt_t(t),
                        grid(k),
                        case.digits(&r.y)
                    )
                }
                Err(e) => ie_note = format!("error: {e}"),
            }
        }
        let ds = picks.iter().find(|p| p.0 == Who::Diffsol).map(|p| make(grid(p.1)));
        let mut cs = Vec::new();
        let mut work = Vec::new();
        for &(who, k) in &picks {
            let rtol = grid(k);
            let r = stiff::run(case, who, rtol, MAX_STEPS).unwrap();
            eprintln!(
                "{} {level}d {:15} rtol {rtol:9.3e} (k {k:2}, TOLS {:?}) digits {:5.2}  {r}",
                case.name(),
                who.name(),
                tol_index(case, who, l),
                case.digits(&r.y)
            );
            work.push(r);
            if who == Who::Diffsol {
                let m = ds.as_ref().unwrap();
                cs.push(Contender::new(who.name(), move |n| {
                    for _ in 0..n {
                        black_box(m.solve(MAX_STEPS).unwrap().steps);
                    }
                }));
            } else {
                let o = reckon_options(case, rtol, MAX_STEPS);
                cs.push(Contender::new(who.name(), move |n| {
                    for _ in 0..n {
                        black_box(stiff::reckon(case, who, black_box(&o)).unwrap().steps);
                    }
                }));
            }
        }
        let t = interleave(&mut cs, rounds, 0.02);
        let col = |w: Who| picks.iter().position(|p| p.0 == w);
        let cell = |w: Who| match col(w) {
            Some(i) => format!("{} @ {:.1e}", fmt_time(&t[i]), grid(picks[i].1)),
            None if w == Who::ImplicitEuler => ie_note.clone(),
            None => "not reached".into(),
        };
        let vs = |w: Who| match (col(w), col(Who::Diffsol)) {
            (Some(i), Some(d)) => fmt_ratio(&ratios(&t[i], &t[d])),
            _ => "—".into(),
        };
        let best = match (col(Who::Bdf), col(Who::Rodas5P), col(Who::Diffsol)) {
            (Some(b), Some(r), Some(d)) => {
                let v: Vec<f64> = (0..t[d].len()).map(|k| t[b][k].min(t[r][k]) / t[d][k]).collect();
                fmt_ratio(&v)
            }
            _ => "—".into(),
        };
        println!(
            "| {} | {level} | {} | {} | {} | {} | {} | {} | {} |",
            case.name(),
            cell(Who::ImplicitEuler),
            cell(Who::Bdf),
            cell(Who::Rodas5P),
            cell(Who::Diffsol),
            best,
            vs(Who::Bdf),
            vs(Who::Rodas5P)
        );
        let w = |who: Who| {
            col(who).map_or(String::new(), |i| {
                let r = &work[i];
                format!(
                    "{} {} steps {} rhs {} jac {} lu; ",
                    who.name(),
                    r.steps,
                    r.rhs,
                    r.jac,
                    r.lu
                )
            })
        };
        eprintln!("   work: {}{}{}", w(Who::Bdf), w(Who::Rodas5P), w(Who::Diffsol));
    }
}

fn stiff_section(rounds: usize) {
    println!("\n## stiff: {rounds} rounds, CPU time per solve, median (min–max over rounds)\n");
    println!(
        "| problem | digits | `ImplicitEuler` | `Bdf` | `Rodas5P` | diffsol BDF | best ÷ diffsol | `Bdf` ÷ diffsol | `Rodas5P` ÷ diffsol |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    stiff_cell(Case::Rober, stiff::diffsol_rober, rounds);
    stiff_cell(Case::Vdpol, stiff::diffsol_vdpol, rounds);
    stiff_cell(Case::Orego, stiff::diffsol_orego, rounds);
    stiff_cell(Case::Hires, stiff::diffsol_hires, rounds);
}

// ---------------------------------------------------------------------------------------
// Sparse: BRUSS 1-D, 1 000 states

const N: usize = 500;
const T_END: f64 = 10.0;

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

    /// diffsol's problem with `FaerSparseMat` (pattern found by NaN probing of `jv`,
    /// coloured Jacobian assembly), as `examples/sparse_scaling.rs versus` builds it, and
    /// a closure that solves it with BDF and `FaerSparseLU` to `t_end`: the problem is
    /// built once, each call makes a solver.
    pub fn kept(rtol: f64, y0: &DVector<f64>, t_end: f64) -> impl Fn() -> DVector<f64> {
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
        move || {
            let mut s = problem.bdf::<FaerSparseLU<f64>>().expect("bdf");
            s.set_stop_time(t_end).expect("stop time");
            while !matches!(s.step().expect("step"), OdeSolverStopReason::TstopReached) {}
            DVector::from_vec(s.state().y.clone_as_vec())
        }
    }
}

fn bruss_digits(y: &DVector<f64>, r: &DVector<f64>) -> f64 {
    let m = y
        .iter()
        .zip(r.iter())
        .map(|(y, r)| (y - r).abs() / (1.0 + r.abs()))
        .fold(0.0, f64::max);
    -m.log10()
}

fn bruss_opts(rtol: f64, linear: LinearSolver) -> Options {
    Options::default()
        .rtol(rtol)
        .atol(rtol)
        .save(Save::End)
        .dense(false)
        .linear_solver(linear)
}

fn sparse(rounds: usize) {
    use bruss::{Bruss, Jac};
    use reckon::studies::problems::{brusselator, brusselator_y0};
    println!("\n## sparse: BRUSS 1-D, 1 000 states, [0, 10], 5 digits; {rounds} rounds, CPU time per solve\n");
    let y0 = brusselator_y0(N);
    let hand = Bruss::new(N, Jac::Hand);
    let coloured = Bruss::new(N, Jac::Coloured);
    let dense_hand = Bruss::new(N, Jac::None);
    let kept = brusselator(N);
    let o = bruss_opts(1e-11, LinearSolver::Sparse);
    let p = Problem::new(&hand, y0.clone(), (0.0, T_END));
    let r = p.solve(Rodas5P, &o).expect("reference").last().1.clone();
    let r2 = p.solve(Bdf::default(), &o).expect("reference").last().1.clone();
    println!(
        "reference: Rodas5P and Bdf at 1e-11 agree to {:.2} digits",
        bruss_digits(&r, &r2)
    );
    let target = 5.0;
    let bdf_at = |rtol: f64| {
        Problem::new(&kept, y0.clone(), (0.0, T_END))
            .solve(Bdf::default(), &bruss_opts(rtol, LinearSolver::Auto))
            .map_or(f64::NEG_INFINITY, |s| bruss_digits(s.last().1, &r))
    };
    let rodas_at = |rtol: f64| {
        Problem::new(&hand, y0.clone(), (0.0, T_END))
            .solve(Rodas5P, &bruss_opts(rtol, LinearSolver::Sparse))
            .map_or(f64::NEG_INFINITY, |s| bruss_digits(s.last().1, &r))
    };
    let ds_at = |rtol: f64| bruss_digits(&ds::kept(rtol, &y0, T_END)(), &r);
    let kb = search(&mut |k| bdf_at(grid(k)), 8, target).expect("Bdf reaches 5 digits");
    let kr = search(&mut |k| rodas_at(grid(k)), 8, target).expect("Rodas5P reaches 5 digits");
    let kd = search(&mut |k| ds_at(grid(k)), 8, target).expect("diffsol reaches 5 digits");
    let (tb, tr, td) = (grid(kb), grid(kr), grid(kd));
    println!(
        "rtol = atol: Bdf {tb:.2e} ({:.2} digits), Rodas5P {tr:.2e} ({:.2}), diffsol {td:.2e} ({:.2})",
        bdf_at(tb),
        rodas_at(tr),
        ds_at(td)
    );
    let ob = bruss_opts(tb, LinearSolver::Auto);
    let os = bruss_opts(tb, LinearSolver::Sparse);
    let od = bruss_opts(tb, LinearSolver::Dense);
    let or = bruss_opts(tr, LinearSolver::Sparse);
    let dsp = ds::kept(td, &y0, T_END);
    let solve = |sys: &dyn Fn() -> DVector<f64>| black_box(sys());
    let mut cs = vec![
        Contender::new("Bdf, sparse, traced `problems::brusselator` kept", |n| {
            for _ in 0..n {
                solve(&|| {
                    Problem::new(&kept, y0.clone(), (0.0, T_END))
                        .solve(Bdf::default(), &ob)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new(
            "Bdf, sparse, `problems::brusselator` rebuilt per solve (cache warm)",
            |n| {
                for _ in 0..n {
                    let m = brusselator(N);
                    solve(&|| {
                        Problem::new(&m, y0.clone(), (0.0, T_END))
                            .solve(Bdf::default(), &ob)
                            .unwrap()
                            .last()
                            .1
                            .clone()
                    });
                }
            },
        ),
        Contender::new("Bdf, sparse, rebuilt per solve, cache emptied first", |n| {
            for _ in 0..n {
                symbolic::clear_cache();
                let m = brusselator(N);
                solve(&|| {
                    Problem::new(&m, y0.clone(), (0.0, T_END))
                        .solve(Bdf::default(), &ob)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new("Bdf, sparse, J by hand", |n| {
            for _ in 0..n {
                solve(&|| {
                    Problem::new(&hand, y0.clone(), (0.0, T_END))
                        .solve(Bdf::default(), &os)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new("Bdf, sparse, coloured num-dual J", |n| {
            for _ in 0..n {
                solve(&|| {
                    Problem::new(&coloured, y0.clone(), (0.0, T_END))
                        .solve(Bdf::default(), &os)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new("Bdf, dense, `problems::brusselator` (num-dual J) kept", |n| {
            for _ in 0..n {
                solve(&|| {
                    Problem::new(&kept, y0.clone(), (0.0, T_END))
                        .solve(Bdf::default(), &od)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new("Bdf, dense, J by hand", |n| {
            for _ in 0..n {
                solve(&|| {
                    Problem::new(&dense_hand, y0.clone(), (0.0, T_END))
                        .solve(Bdf::default(), &od)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new("Rodas5P, sparse, J by hand", |n| {
            for _ in 0..n {
                solve(&|| {
                    Problem::new(&hand, y0.clone(), (0.0, T_END))
                        .solve(Rodas5P, &or)
                        .unwrap()
                        .last()
                        .1
                        .clone()
                });
            }
        }),
        Contender::new("diffsol 0.18 BDF, faer sparse LU, problem kept", |n| {
            for _ in 0..n {
                solve(&|| dsp());
            }
        }),
        Contender::new("diffsol 0.18 BDF, faer sparse LU, problem rebuilt per solve", |n| {
            for _ in 0..n {
                solve(&|| ds::kept(td, &y0, T_END)());
            }
        }),
    ];
    let names: Vec<String> = cs.iter().map(|c| c.name.clone()).collect();
    let t = interleave(&mut cs, rounds, 0.1);
    let rt = [tb, tb, tb, tb, tb, tb, tb, tr, td, td];
    println!("\n| contender | rtol = atol | CPU time per solve, median (min–max) |");
    println!("|---|---:|---:|");
    for (i, name) in names.iter().enumerate() {
        println!("| {name} | {:.1e} | {} |", rt[i], fmt_time(&t[i]));
    }
    println!();
    let ratio = |what: &str, a: usize, b: usize| println!("{what}: {}", fmt_ratio(&ratios(&t[a], &t[b])));
    ratio("dense num-dual ÷ sparse traced kept", 5, 0);
    ratio("dense num-dual ÷ sparse traced rebuilt (cache warm)", 5, 1);
    ratio("dense num-dual ÷ sparse traced rebuilt (cache emptied)", 5, 2);
    ratio("dense hand ÷ sparse hand", 6, 3);
    ratio("rebuilt (cache warm) ÷ kept", 1, 0);
    ratio("rebuilt (cache emptied) ÷ kept", 2, 0);
    ratio("diffsol kept ÷ Bdf traced kept", 8, 0);
    ratio("diffsol kept ÷ Bdf hand", 8, 3);
    ratio("diffsol rebuilt ÷ Bdf traced rebuilt (cache warm)", 9, 1);
    ratio("Rodas5P ÷ Bdf hand", 7, 3);
}

// ---------------------------------------------------------------------------------------
// Jacobian evaluation

fn jac_small<const M: usize>(name: &str, f: &impl System<Const<M>>, x: SVector<f64, M>, u: &[f64], rounds: usize) {
    let mut compiled = symbolic::trace(f, M).unwrap().compile_jacobian();
    let native = compiled.is_native();
    let mut interpreted = compiled.clone().interpreted();
    let mut jd = SMatrix::<f64, M, M>::zeros();
    let mut js = vec![0.0; M * M];
    let mut js2 = vec![0.0; M * M];
    let mut cs = vec![
        Contender::new("num-dual", |n| {
            for _ in 0..n {
                f.jacobian(0.0, black_box(&x), black_box(u), &mut jd);
                black_box(&jd);
            }
        }),
        Contender::new("symbolic", |n| {
            for _ in 0..n {
                compiled
                    .eval_dense(0.0, black_box(x.as_slice()), black_box(u), &mut js)
                    .unwrap();
                black_box(&js);
            }
        }),
        Contender::new("interpreted", |n| {
            for _ in 0..n {
                interpreted
                    .eval_dense(0.0, black_box(x.as_slice()), black_box(u), &mut js2)
                    .unwrap();
                black_box(&js2);
            }
        }),
    ];
    let t = interleave(&mut cs, rounds, 0.01);
    println!(
        "| {name} | {} | {} (native: {native}) | {} | {} |",
        fmt_time(&t[0]),
        fmt_time(&t[1]),
        fmt_ratio(&ratios(&t[1], &t[0])),
        fmt_time(&t[2])
    );
}

fn jacobian(rounds: usize) {
    use reckon::jacobian::SparseJacobian;
    use reckon::studies::problems::{brusselator, brusselator_y0, robertson};
    use reckon::vehicles::{carlike, unicycle};
    println!("\n## jacobian: {rounds} rounds, CPU time per evaluation, median (min–max)\n");
    println!("| model | num-dual | symbolic | symbolic ÷ num-dual | interpreted |");
    println!("|---|---|---|---|---|");
    jac_small(
        "unicycle (3 states), dense",
        &unicycle::model(),
        vector![1.0, 2.0, 0.7],
        &[1.3, 0.4],
        rounds,
    );
    jac_small(
        "car-like (4 states), dense",
        &carlike::model(2.5),
        vector![1.0, 2.0, 0.7, 0.1],
        &[1.3, 0.4],
        rounds,
    );
    jac_small(
        "Robertson (3 states), dense",
        &robertson(),
        vector![0.9, 2e-5, 0.1],
        &[],
        rounds,
    );
    let n = 500;
    let f = brusselator(n);
    let x: DVector<f64> = brusselator_y0(n);
    let mut compiled = symbolic::trace(&f, 2 * n).unwrap().compile_jacobian();
    let native = compiled.is_native();
    let mut interpreted = compiled.clone().interpreted();
    let mut compiled2 = compiled.clone();
    let mut jd = DMatrix::zeros(2 * n, 2 * n);
    let mut js = vec![0.0; 4 * n * n];
    let mut vals = vec![0.0; compiled.pattern().nnz()];
    let mut vals2 = vals.clone();
    let mut cs = vec![
        Contender::new("num-dual dense", |k| {
            for _ in 0..k {
                f.jacobian(0.0, black_box(&x), &[], &mut jd);
                black_box(&jd);
            }
        }),
        Contender::new("symbolic dense", |k| {
            for _ in 0..k {
                compiled.eval_dense(0.0, black_box(x.as_slice()), &[], &mut js).unwrap();
                black_box(&js);
            }
        }),
        Contender::new("symbolic csc", |k| {
            for _ in 0..k {
                compiled2.eval(0.0, black_box(x.as_slice()), &[], &mut vals).unwrap();
                black_box(&vals);
            }
        }),
        Contender::new("interpreted csc", |k| {
            for _ in 0..k {
                interpreted.eval(0.0, black_box(x.as_slice()), &[], &mut vals2).unwrap();
                black_box(&vals2);
            }
        }),
    ];
    let t = interleave(&mut cs, rounds, 0.02);
    println!(
        "| BRUSS 1-D, 500 points (1 000 states), dense | {} | {} (native: {native}) | {} | — |",
        fmt_time(&t[0]),
        fmt_time(&t[1]),
        fmt_ratio(&ratios(&t[1], &t[0]))
    );
    println!(
        "| the same into the CSC pattern | — | {} | num-dual dense ÷ this: {} | {} |",
        fmt_time(&t[2]),
        fmt_ratio(&ratios(&t[0], &t[2])),
        fmt_time(&t[3])
    );
}

// ---------------------------------------------------------------------------------------
// The model call; implicit Euler with the autodiff and a hand-written Jacobian

/// Robertson with its Jacobian written by hand (as `benches/implicit.rs`).
struct AnalyticRobertson;

impl System<Const<3>> for AnalyticRobertson {
    fn rhs(&self, _t: f64, y: &Vector3<f64>, _u: &[f64], dy: &mut Vector3<f64>) {
        *dy = vector![
            -0.04 * y[0] + 1e4 * y[1] * y[2],
            0.04 * y[0] - 3e7 * y[1] * y[1] - 1e4 * y[1] * y[2],
            3e7 * y[1] * y[1]
        ];
    }
    fn jacobian(&self, _t: f64, y: &Vector3<f64>, _u: &[f64], j: &mut Matrix3<f64>) {
        *j = Matrix3::new(
            -0.04,
            1e4 * y[2],
            1e4 * y[1],
            0.04,
            -6e7 * y[1] - 1e4 * y[2],
            -1e4 * y[1],
            0.0,
            6e7 * y[1],
            0.0,
        );
    }
}

fn small(rounds: usize) {
    use reckon::studies::problems::*;
    println!("\n## small: {rounds} rounds, CPU time, median (min–max)\n");
    // the model call
    let (ar, lo) = (arenstorf(), lorenz());
    let (xa, xl) = (arenstorf_y0(), lorenz_y0());
    let (mut da, mut dl) = (nalgebra::Vector4::zeros(), Vector3::zeros());
    let (mut oa, mut ol) = ([0.0; 4], [0.0; 3]);
    let mut cs = vec![
        Contender::new("arenstorf model!", |n| {
            for _ in 0..n {
                ar.rhs(0.0, black_box(&xa), &[], &mut da);
                black_box(&da);
            }
        }),
        Contender::new("arenstorf fn", |n| {
            for _ in 0..n {
                oa = handwritten::arenstorf(0.0, black_box(&ARENSTORF_Y0));
                black_box(&oa);
            }
        }),
        Contender::new("lorenz model!", |n| {
            for _ in 0..n {
                lo.rhs(0.0, black_box(&xl), &[], &mut dl);
                black_box(&dl);
            }
        }),
        Contender::new("lorenz fn", |n| {
            for _ in 0..n {
                ol = handwritten::lorenz(0.0, black_box(&[1.0, 1.0, 1.0]));
                black_box(&ol);
            }
        }),
    ];
    let t = interleave(&mut cs, rounds, 0.01);
    println!(
        "model call: Arenstorf model! {} vs fn {} (ratio {}); Lorenz model! {} vs fn {} (ratio {})",
        fmt_time(&t[0]),
        fmt_time(&t[1]),
        fmt_ratio(&ratios(&t[0], &t[1])),
        fmt_time(&t[2]),
        fmt_time(&t[3]),
        fmt_ratio(&ratios(&t[2], &t[3]))
    );
    // implicit Euler on Robertson
    let opts = Options::default().rtol(1e-4).atol(1e-8).dense(false);
    let y0 = vector![1.0, 0.0, 0.0];
    let auto = Problem::new(robertson(), y0, (0.0, 1e5));
    let hand = Problem::new(AnalyticRobertson, y0, (0.0, 1e5));
    let sa = auto.solve(ImplicitEuler::default(), &opts).unwrap().stats;
    let sh = hand.solve(ImplicitEuler::default(), &opts).unwrap().stats;
    println!(
        "implicit Euler, Robertson: autodiff {} steps {} J {} LU; hand {} steps {} J {} LU",
        sa.accepted, sa.jacobian_evals, sa.lu_decompositions, sh.accepted, sh.jacobian_evals, sh.lu_decompositions
    );
    let (fa, fh) = (robertson(), AnalyticRobertson);
    let y = vector![0.9, 2e-5, 0.1];
    let (mut j1, mut j2) = (Matrix3::zeros(), Matrix3::zeros());
    let mut cs = vec![
        Contender::new("ie autodiff", |n| {
            for _ in 0..n {
                black_box(
                    auto.solve(ImplicitEuler::default(), black_box(&opts))
                        .unwrap()
                        .stats
                        .accepted,
                );
            }
        }),
        Contender::new("ie hand", |n| {
            for _ in 0..n {
                black_box(
                    hand.solve(ImplicitEuler::default(), black_box(&opts))
                        .unwrap()
                        .stats
                        .accepted,
                );
            }
        }),
        Contender::new("J autodiff", |n| {
            for _ in 0..n {
                fa.jacobian(0.0, black_box(&y), &[], &mut j1);
                black_box(j1[(1, 1)]);
            }
        }),
        Contender::new("J hand", |n| {
            for _ in 0..n {
                fh.jacobian(0.0, black_box(&y), &[], &mut j2);
                black_box(j2[(1, 1)]);
            }
        }),
    ];
    let t = interleave(&mut cs, rounds, 0.01);
    println!(
        "implicit Euler, Robertson [0, 1e5], rtol 1e-4, atol 1e-8: autodiff J {} per solve, hand J {} (ratio {}); \
         one Jacobian: autodiff {}, hand {}",
        fmt_time(&t[0]),
        fmt_time(&t[1]),
        fmt_ratio(&ratios(&t[0], &t[1])),
        fmt_time(&t[2]),
        fmt_time(&t[3])
    );
}

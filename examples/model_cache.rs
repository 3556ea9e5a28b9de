//! What a model rebuilt for every solve costs against one kept across solves, with the
//! compiled-program cache (`reckon::symbolic::cache`): the 1-D Brusselator (`N` grid points,
//! `2N` states) solved by `Bdf` on the sparse path over `[0, 10]`, process CPU time,
//! kept and rebuilt solves interleaved (the order alternating every round), and once per
//! round a rebuilt solve with the cache emptied first (the cost every rebuild paid before).
//!
//! `cargo run --release --example model_cache -- [N = 500] [rounds = 15]`
//!
//! Measured at 1ef6177 (2 shared cores, load average ~5.8, 21 rounds, 1 000 states): rebuilt ÷
//! kept in the same round 0.928–1.179 (median 1.012) at rtol 1e-3 and 0.767–1.191 (median
//! 1.013) at 1e-6; kept 6.75–10.25 ms and 16.3–24.7 ms; rebuilt with the cache emptied
//! 81.7–127 ms and 89.7–137 ms; one `sparse_jacobian` request (the recording that keys the
//! cache, paid by kept and rebuilt models alike) 0.68–1.32 ms.

use reckon::methods::Bdf;
use reckon::studies::problems::{brusselator, brusselator_y0};
use reckon::{LinearSolver, Save};
use reckon::{Options, Problem, symbolic};

/// Process CPU time in seconds (all threads).
#[cfg(target_os = "linux")]
fn cpu() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_PROCESS_CPUTIME_ID: i32 = 2;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: `ts` is a valid `struct timespec` (two 64-bit fields on 64-bit Linux)
    let rc = unsafe { clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime failed");
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

#[cfg(not(target_os = "linux"))]
fn cpu() -> f64 {
    use std::sync::OnceLock;
    static T0: OnceLock<std::time::Instant> = OnceLock::new();
    T0.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

fn stats(v: &mut [f64]) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2], v[v.len() - 1])
}

/// [`brusselator`]'s body with `α` captured as a plain `f64` (folded into the trace).
fn bruss_captured(n: usize, alpha: f64) -> impl reckon::DualSystem<nalgebra::Dyn> {
    let c = (n as f64 + 1.0).powi(2) * alpha;
    reckon::model!(|_, y: [S; Dyn]| {
        let n = y.len() / 2;
        nalgebra::DVector::from_fn(2 * n, |k, _| {
            let i = k / 2;
            let (own, bc) = if k % 2 == 0 { (0, 1.0) } else { (1, 3.0) };
            let at = |j: usize| y[2 * j + own].clone();
            let left = if i == 0 { S::from(bc) } else { at(i - 1) };
            let right = if i + 1 == n { S::from(bc) } else { at(i + 1) };
            let (u, v) = (y[2 * i].clone(), y[2 * i + 1].clone());
            let diff = (left + right - at(i) * 2.0) * c;
            let uuv = u.clone() * u.clone() * v;
            if own == 0 {
                uuv - u * 4.0 + 1.0 + diff
            } else {
                u * 3.0 - uuv + diff
            }
        })
    })
}

/// The same body with `α` a parameter (an input of the compiled code).
fn bruss_param(alpha: f64) -> impl reckon::DualSystem<nalgebra::Dyn> {
    reckon::model!(|_, y: [S; Dyn], p: [S; 1] = [alpha]| {
        let n = y.len() / 2;
        let c = p[0].clone() * ((n as f64 + 1.0) * (n as f64 + 1.0));
        nalgebra::DVector::from_fn(2 * n, |k, _| {
            let i = k / 2;
            let (own, bc) = if k % 2 == 0 { (0, 1.0) } else { (1, 3.0) };
            let at = |j: usize| y[2 * j + own].clone();
            let left = if i == 0 { S::from(bc) } else { at(i - 1) };
            let right = if i + 1 == n { S::from(bc) } else { at(i + 1) };
            let (u, v) = (y[2 * i].clone(), y[2 * i + 1].clone());
            let diff = (left + right - at(i) * 2.0) * c.clone();
            let uuv = u.clone() * u.clone() * v;
            if own == 0 { uuv - u * 4.0 + 1.0 + diff } else { u * 3.0 - uuv + diff }
        })
    })
}

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(500);
    let rounds: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(15);
    let y0 = brusselator_y0(n);
    let kept = brusselator(n);
    println!(
        "1-D Brusselator, {} states, Bdf (sparse LU, symbolic Jacobian), t in [0, 10], {rounds} rounds",
        2 * n
    );
    for tol in [1e-3, 1e-6] {
        let o = Options::default()
            .save(Save::End)
            .dense(false)
            .rtol(tol)
            .atol(tol)
            .linear_solver(LinearSolver::Sparse);
        let solve = |sys: &dyn Fn(&Options) -> reckon::Result<reckon::Solution<nalgebra::Dyn>>| sys(&o).unwrap();
        let kept_solve = |o: &Options| Problem::new(&kept, y0.clone(), (0.0, 10.0)).solve(Bdf::default(), o);
        let rebuilt_solve = |o: &Options| {
            let f = brusselator(n);
            Problem::new(&f, y0.clone(), (0.0, 10.0)).solve(Bdf::default(), o)
        };
        // another α every solve (not a power of two, no coincidences): captured, a new graph
        // each time (traced, machine code reused); a parameter, the same graph (a hit)
        let alpha = |round: usize| 0.02 * (1.0 + 0.0137 * (round as f64 + 1.0));
        let captured_solve = |round: usize| {
            let f = bruss_captured(n, alpha(round));
            let t0 = cpu();
            let s = Problem::new(&f, y0.clone(), (0.0, 10.0))
                .solve(Bdf::default(), &o)
                .unwrap();
            (cpu() - t0, s.stats.accepted)
        };
        let param_solve = |round: usize| {
            let t0 = cpu();
            let f = bruss_param(alpha(round));
            let s = Problem::new(&f, y0.clone(), (0.0, 10.0))
                .solve(Bdf::default(), &o)
                .unwrap();
            (cpu() - t0, s.stats.accepted)
        };
        // warm-up: fills the cache, the allocator and the caches of the CPU
        let reference = solve(&kept_solve);
        let _ = solve(&rebuilt_solve);
        let before = symbolic::cache_stats();
        let _ = (captured_solve(rounds + 7), param_solve(rounds + 7));
        let (mut tk, mut tr, mut tc, mut ratio) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let (mut tcap, mut tpar, mut tq) = (Vec::new(), Vec::new(), Vec::new());
        for round in 0..rounds {
            let time = |f: &dyn Fn(&Options) -> reckon::Result<reckon::Solution<nalgebra::Dyn>>| {
                let t0 = cpu();
                let s = solve(f);
                let t = cpu() - t0;
                assert_eq!(s.last().1, reference.last().1, "a rebuilt model's answer differs");
                t
            };
            let (k, r) = if round % 2 == 0 {
                let k = time(&kept_solve);
                (k, time(&rebuilt_solve))
            } else {
                let r = time(&rebuilt_solve);
                (time(&kept_solve), r)
            };
            // the cost of one request alone: record the body, look up, copy
            let t0 = cpu();
            let _ = reckon::System::sparse_jacobian(&kept, 2 * n);
            tq.push(cpu() - t0);
            tcap.push(captured_solve(round).0);
            tpar.push(param_solve(round).0);
            symbolic::clear_cache();
            tc.push(time(&rebuilt_solve));
            // the parameterised body back in the cache (untimed)
            let _ = param_solve(rounds + 7);
            tk.push(k);
            tr.push(r);
            ratio.push(r / k);
        }
        let after = symbolic::cache_stats();
        let steps = reference.stats.accepted;
        let (k, r, c, q) = (stats(&mut tk), stats(&mut tr), stats(&mut tc), stats(&mut ratio));
        let (cap, par, req) = (stats(&mut tcap), stats(&mut tpar), stats(&mut tq));
        println!("rtol = atol = {tol:e} ({steps} steps), CPU ms per solve, min / median / max:");
        println!(
            "  kept                     {:8.2} {:8.2} {:8.2}",
            k.0 * 1e3,
            k.1 * 1e3,
            k.2 * 1e3
        );
        println!(
            "  rebuilt (cache)          {:8.2} {:8.2} {:8.2}",
            r.0 * 1e3,
            r.1 * 1e3,
            r.2 * 1e3
        );
        println!(
            "  rebuilt (cache emptied)  {:8.2} {:8.2} {:8.2}",
            c.0 * 1e3,
            c.1 * 1e3,
            c.2 * 1e3
        );
        println!(
            "  rebuilt, another captured α {:7.2} {:8.2} {:8.2}",
            cap.0 * 1e3,
            cap.1 * 1e3,
            cap.2 * 1e3
        );
        println!(
            "  rebuilt, another parameter α {:6.2} {:8.2} {:8.2}",
            par.0 * 1e3,
            par.1 * 1e3,
            par.2 * 1e3
        );
        println!(
            "  one sparse_jacobian request {:7.3} {:8.3} {:8.3}",
            req.0 * 1e3,
            req.1 * 1e3,
            req.2 * 1e3
        );
        println!("  rebuilt ÷ kept, same round {:6.3} {:6.3} {:6.3}", q.0, q.1, q.2);
        println!(
            "  cache: {} recordings, {} traces, {} hits, {} compiles, {} native-code hits",
            after.records - before.records,
            after.traces - before.traces,
            after.trace_hits - before.trace_hits,
            after.compiles - before.compiles,
            after.code_hits - before.code_hits
        );
    }
}

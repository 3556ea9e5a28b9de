//! Lie-group integrators on the free symmetric top (closed form): RKMK4 against RK45 on
//! the twelve ambient entries at matched accuracy, the cost of one group step of each
//! method, and the orthogonality drift over 10⁶ steps with and without the polar step.
//!
//! `cargo bench --bench lie`; the figures printed before the timings (errors, steps,
//! `f` calls, `‖RᵀR − I‖`) are what the timings are compared at.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix3, SVector, U12, Vector3, vector};
use reckon::lie::{Layout, So3};
use reckon::methods::{Cf4, LieEuler, Method, Rk45, Rkmk4};
use reckon::vehicles::rigid_body;
use reckon::{Options, Problem, Save, StepSize};
use std::hint::black_box;
use std::time::Duration;

const I1: f64 = 2.0;
const I3: f64 = 3.0;
const T: f64 = 20.0;

fn start() -> (So3, Vector3<f64>) {
    (So3::exp(&vector![0.3, -0.2, 0.5]), vector![0.6, -0.3, 1.0])
}

fn run<M: Method<U12>>(m: M, opts: &Options) -> (SVector<f64, 12>, reckon::Stats) {
    let (r0, w0) = start();
    let f = rigid_body::model([I1, I1, I3]);
    let sol = Problem::new(&f, rigid_body::state(&r0, &w0), (0.0, T))
        .solve(m, opts)
        .unwrap();
    (*sol.last().1, sol.stats)
}

fn error(x: &SVector<f64, 12>) -> f64 {
    let (r0, w0) = start();
    let (r_ex, w_ex) = rigid_body::symmetric_top(I1, I3, &r0, &w0, T);
    let (r, w) = rigid_body::split(x);
    (r.matrix() - r_ex.matrix()).amax().max((w - w_ex).amax())
}

fn orth(r: &Matrix3<f64>) -> f64 {
    (r.transpose() * r - Matrix3::identity()).amax()
}

fn adaptive(tol: f64) -> Options {
    Options::default().rtol(tol).atol(tol).save(Save::End)
}

/// The loosest tolerance in a sweep at which `make()` is at least as accurate as `target`.
fn matched<M: Method<U12>>(make: impl Fn() -> M, target: f64) -> f64 {
    let mut tol = 1e-4;
    while error(&run(make(), &adaptive(tol)).0) > target && tol > 1e-14 {
        tol /= 10f64.powf(0.125);
    }
    tol
}

fn lie(c: &mut Criterion) {
    let layout = rigid_body::layout;
    // RK45 at 1e-8 and RKMK4 at the tolerance (or fixed step) that matches its error
    let rk_opts = adaptive(1e-8);
    let (x, s) = run(Rk45, &rk_opts);
    let e_rk = error(&x);
    let (r, _) = rigid_body::split(&x);
    eprintln!(
        "rk45 at 1e-8: error {e_rk:.3e}, {} steps, {} f calls, ‖RᵀR − I‖ {:.2e}",
        s.accepted,
        s.rhs_evals,
        orth(&r.matrix())
    );
    let tol = matched(|| Rkmk4::new(layout()), e_rk);
    let mk_opts = adaptive(tol);
    let (x, s) = run(Rkmk4::new(layout()), &mk_opts);
    eprintln!(
        "rkmk4 adaptive at {tol:.3e}: error {:.3e}, {} steps, {} f calls",
        error(&x),
        s.accepted,
        s.rhs_evals
    );
    let mut n = 50;
    while error(
        &run(
            Rkmk4::new(layout()),
            &Options::default().fixed(T / n as f64).save(Save::End),
        )
        .0,
    ) > e_rk
    {
        n = n * 11 / 10;
    }
    let fixed_opts = Options::default().fixed(T / n as f64).save(Save::End);
    let (x, s) = run(Rkmk4::new(layout()), &fixed_opts);
    eprintln!(
        "rkmk4 fixed, {n} steps: error {:.3e}, {} f calls",
        error(&x),
        s.rhs_evals
    );
    let (x, s) = run(Cf4::new(layout()), &fixed_opts);
    eprintln!("cf4 fixed, {n} steps: error {:.3e}, {} f calls", error(&x), s.rhs_evals);

    // orthogonality over 10⁶ steps of the product of exact exponentials, without the
    // polar step the methods take, and through RKMK4 (with it)
    let (r0, w0) = start();
    let h = 1e-3;
    let mut r = r0.matrix();
    for k in 0..1_000_000 {
        let (_, w) = rigid_body::symmetric_top(I1, I3, &r0, &w0, k as f64 * h);
        r *= So3::exp(&(w * h)).matrix();
    }
    eprintln!(
        "1e6 products R·Exp(hω) without the polar step: ‖RᵀR − I‖ {:.2e}",
        orth(&r)
    );

    let mut g = c.benchmark_group("lie/rigid_body_matched_accuracy");
    g.bench_function("rk45", |b| b.iter(|| black_box(run(Rk45, &rk_opts))));
    g.bench_function("rkmk4_adaptive", |b| {
        b.iter(|| black_box(run(Rkmk4::new(layout()), &mk_opts)))
    });
    g.bench_function("rkmk4_fixed", |b| {
        b.iter(|| black_box(run(Rkmk4::new(layout()), &fixed_opts)))
    });
    g.bench_function("cf4_fixed", |b| {
        b.iter(|| black_box(run(Cf4::new(layout()), &fixed_opts)))
    });
    g.finish();

    // one step: 1000 fixed steps of h = T/1000 (divide the time by 1000)
    let thousand = Options::default().step(StepSize::Fixed(T / 1000.0)).save(Save::End);
    let mut g = c.benchmark_group("lie/1000_steps");
    g.bench_function("lie_euler", |b| {
        b.iter(|| black_box(run(LieEuler::new(layout()), &thousand)))
    });
    g.bench_function("rkmk4", |b| b.iter(|| black_box(run(Rkmk4::new(layout()), &thousand))));
    g.bench_function("cf4", |b| b.iter(|| black_box(run(Cf4::new(layout()), &thousand))));
    g.bench_function("rk45", |b| b.iter(|| black_box(run(Rk45, &thousand))));
    g.finish();

    // the group operations of one step
    let l = Layout::right().so3(0);
    let x = rigid_body::state(&r0, &w0);
    let u = rigid_body::state(&So3::exp(&vector![0.01, 0.02, -0.01]), &vector![0.0, 0.0, 0.0]);
    let mut u = u;
    u.as_mut_slice()[..9].fill(0.0);
    u.as_mut_slice()[..3].copy_from_slice(&[0.01, 0.02, -0.01]);
    let mut out = x;
    let mut g = c.benchmark_group("lie/so3_block");
    g.bench_function("exp_act", |b| {
        b.iter(|| l.exp_act(black_box(u.as_slice()), black_box(x.as_slice()), out.as_mut_slice()))
    });
    g.bench_function("dexp_inv", |b| {
        b.iter(|| l.dexp_inv(black_box(u.as_slice()), black_box(x.as_slice()), out.as_mut_slice()))
    });
    g.bench_function("algebra", |b| {
        b.iter(|| l.algebra(black_box(x.as_slice()), black_box(u.as_slice()), out.as_mut_slice()))
    });
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2))
        .sample_size(20)
}

criterion_group! {
    name = benches;
    config = config();
    targets = lie
}
criterion_main!(benches);

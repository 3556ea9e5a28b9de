//! Dead reckoning over a long control log: `Problem::solve` with the exact flow (and
//! explicit Euler at a fixed step) against a bare loop over the same flow and the same
//! inputs, every state stored by both (issue 13's baseline and target: ≥ 0.8×).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Vector3, vector};
use reckon::methods::{Euler, Exact};
use reckon::vehicles::{bicycle, unicycle};
use reckon::{Controls, Options, Problem, Save, System};
use std::hint::black_box;
use std::time::Duration;

const N: usize = 1_000_000;
const DT: f64 = 0.01;

/// `N` held inputs `(v, ω)` (or `(v, α)`), one per `DT`.
fn log() -> (Vec<f64>, Vec<Vec<f64>>) {
    let t: Vec<f64> = (0..N).map(|k| k as f64 * DT).collect();
    let u = (0..N)
        .map(|k| {
            let s = (k as f64 * 1e-3).sin();
            vec![1.0 + 0.5 * s, 0.3 * (k as f64 * 7e-4).cos()]
        })
        .collect();
    (t, u)
}

/// The bare loop: `x_{k+1} = φ(x_k, u_k, t_{k+1} − t_k)` (the driver's step between
/// control times), every state pushed.
fn bare(
    flow: impl Fn(f64, &Vector3<f64>, &[f64], f64) -> Vector3<f64>,
    t: &[f64],
    u: &[Vec<f64>],
) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(t.len() + 1);
    let mut x = vector![0.0, 0.0, 0.0];
    out.push(x);
    let t_end = N as f64 * DT;
    for k in 0..t.len() {
        let next = if k + 1 < t.len() { t[k + 1] } else { t_end };
        x = flow(t[k], &x, &u[k], next - t[k]);
        out.push(x);
    }
    out
}

fn bench(c: &mut Criterion) {
    let (t, u) = log();
    let controls = Controls::new(t.clone(), u.clone()).unwrap();
    let span = (0.0, N as f64 * DT);
    let uni = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], span).controls(controls.clone());
    let bi = Problem::new(bicycle::model(0.5), vector![0.0, 0.0, 0.0], span).controls(controls);
    let phi_b = bicycle::flow(0.5);
    let o = Options::default();
    let end = Options::default().save(Save::End);
    // the same numbers, bit for bit, before timing anything
    assert_eq!(
        *uni.solve(Exact::new(unicycle::flow), &o).unwrap().last().1,
        *bare(unicycle::flow, &t, &u).last().unwrap()
    );
    let model = unicycle::model();
    let euler = |_t: f64, x: &Vector3<f64>, u: &[f64], h: f64| {
        let mut dx = Vector3::zeros();
        model.rhs(0.0, x, u, &mut dx);
        x + dx * h
    };
    let mut g = c.benchmark_group("dead-reckoning/1e6-intervals");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    g.bench_function("unicycle/bare-loop", |b| {
        b.iter(|| black_box(bare(unicycle::flow, &t, &u).len()))
    });
    g.bench_function("unicycle/solve-exact", |b| {
        b.iter(|| black_box(uni.solve(Exact::new(unicycle::flow), &o).unwrap().t.len()))
    });
    g.bench_function("unicycle/solve-exact-end-only", |b| {
        b.iter(|| black_box(uni.solve(Exact::new(unicycle::flow), &end).unwrap().t.len()))
    });
    g.bench_function("bicycle/bare-loop", |b| {
        b.iter(|| black_box(bare(&phi_b, &t, &u).len()))
    });
    g.bench_function("bicycle/solve-exact", |b| {
        b.iter(|| black_box(bi.solve(Exact::new(bicycle::flow(0.5)), &o).unwrap().t.len()))
    });
    g.bench_function("unicycle/euler-bare-loop", |b| {
        b.iter(|| black_box(bare(euler, &t, &u).len()))
    });
    g.bench_function("unicycle/solve-explicit-euler", |b| {
        b.iter(|| black_box(uni.solve(Euler, &Options::default().fixed(DT)).unwrap().t.len()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

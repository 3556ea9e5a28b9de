//! The sparse path on BRUSS 1-D (`tests/it/common/bruss.rs`, exact non-zeros by hand and the
//! coloured num-dual evaluator): ImplicitEuler (20 fixed steps of 0.005) and Bdf (rtol =
//! atol = 1e-6 on `[0, 0.1]`) at 10³, 10⁴ and 10⁵ states, one solve per iteration, and
//! Bdf at 1 000 states sparse against dense (the hand-written dense Jacobian and faer's
//! dense LU). 10⁶ states and peak memory: `examples/sparse_scaling.rs`.

#[path = "../tests/it/common/bruss.rs"]
mod bruss;

use bruss::{Bruss, Jac};
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use reckon::methods::{Bdf, ImplicitEuler};
use reckon::studies::problems::brusselator_y0;
use reckon::{LinearSolver, Save};
use reckon::{Options, Problem};
use std::hint::black_box;
use std::time::Duration;

fn opts(linear: LinearSolver) -> Options {
    Options::default().save(Save::End).dense(false).linear_solver(linear)
}

fn scaling(c: &mut Criterion) {
    let mut g = c.benchmark_group("sparse/scaling");
    g.sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for (jac, name) in [(Jac::Hand, "hand"), (Jac::Coloured, "coloured")] {
        for states in [1_000usize, 10_000, 100_000] {
            let n = states / 2;
            let sys = Bruss::new(n, jac);
            let x0 = brusselator_y0(n);
            g.throughput(Throughput::Elements(states as u64));
            g.bench_with_input(BenchmarkId::new(format!("ie-{name}"), states), &states, |b, _| {
                b.iter(|| {
                    let p = Problem::new(&sys, x0.clone(), (0.0, 0.1));
                    black_box(p.solve(ImplicitEuler::default(), &opts(LinearSolver::Sparse).fixed(0.005)))
                })
            });
            g.bench_with_input(BenchmarkId::new(format!("bdf-{name}"), states), &states, |b, _| {
                b.iter(|| {
                    let p = Problem::new(&sys, x0.clone(), (0.0, 0.1));
                    black_box(p.solve(Bdf::default(), &opts(LinearSolver::Sparse).rtol(1e-6).atol(1e-6)))
                })
            });
        }
    }
    g.finish();
}

fn versus_dense(c: &mut Criterion) {
    let mut g = c.benchmark_group("sparse/bdf-1000-states");
    g.sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let n = 500;
    for (jac, linear, name) in [
        (Jac::Hand, LinearSolver::Sparse, "sparse-hand"),
        (Jac::Coloured, LinearSolver::Sparse, "sparse-coloured"),
        (Jac::None, LinearSolver::Dense, "dense-hand"),
    ] {
        let sys = Bruss::new(n, jac);
        g.bench_function(name, |b| {
            b.iter(|| {
                let p = Problem::new(&sys, brusselator_y0(n), (0.0, 1.0));
                black_box(p.solve(Bdf::default(), &opts(linear).rtol(1e-5).atol(1e-5)))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, scaling, versus_dense);
criterion_main!(benches);

//! Jacobian evaluation: the compiled symbolic Jacobian (traced from the `model!` body)
//! against num-dual's dual-number Jacobian of the same body, on the unicycle, the
//! car-like model, Robertson and the 1-D Brusselator with 500 points (1 000 states).
//! Both write the dense matrix; at 1 000 states the symbolic one also fills the CSC
//! values directly (what the sparse implicit path uses). "symbolic" runs the native code
//! (Cranelift) where the program is short enough, "symbolic-interpreted" the interpreter.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector, SMatrix, SVector, vector};
use reckon::jacobian::SparseJacobian;
use reckon::studies::problems::{brusselator, brusselator_y0, robertson};
use reckon::vehicles::{carlike, unicycle};
use reckon::{System, symbolic};
use std::hint::black_box;
use std::time::Duration;

fn small<const N: usize>(
    c: &mut Criterion,
    name: &str,
    f: &impl System<nalgebra::Const<N>>,
    x: SVector<f64, N>,
    u: &[f64],
) {
    let mut g = c.benchmark_group(format!("jacobian/{name}"));
    g.warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    let mut compiled = symbolic::trace(f, N).unwrap().compile_jacobian();
    let mut interpreted = compiled.clone().interpreted();
    let mut jd = SMatrix::<f64, N, N>::zeros();
    let mut js = vec![0.0; N * N];
    // interleaved: one contender, then the other, same inputs
    g.bench_function("num-dual", |b| {
        b.iter(|| {
            f.jacobian(0.0, black_box(&x), black_box(u), &mut jd);
            black_box(&jd);
        })
    });
    g.bench_function("symbolic", |b| {
        b.iter(|| {
            compiled
                .eval_dense(0.0, black_box(x.as_slice()), black_box(u), &mut js)
                .unwrap();
            black_box(&js);
        })
    });
    g.bench_function("symbolic-interpreted", |b| {
        b.iter(|| {
            interpreted
                .eval_dense(0.0, black_box(x.as_slice()), black_box(u), &mut js)
                .unwrap();
            black_box(&js);
        })
    });
    g.finish();
}

fn jacobians(c: &mut Criterion) {
    small(c, "unicycle", &unicycle::model(), vector![1.0, 2.0, 0.7], &[1.3, 0.4]);
    small(
        c,
        "carlike",
        &carlike::model(2.5),
        vector![1.0, 2.0, 0.7, 0.1],
        &[1.3, 0.4],
    );
    small(c, "robertson", &robertson(), vector![0.9, 2e-5, 0.1], &[]);

    let n = 500;
    let f = brusselator(n);
    let x: DVector<f64> = brusselator_y0(n);
    let mut g = c.benchmark_group("jacobian/bruss-1d-500");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let mut compiled = symbolic::trace(&f, 2 * n).unwrap().compile_jacobian();
    let mut jd = DMatrix::zeros(2 * n, 2 * n);
    let mut js = vec![0.0; 4 * n * n];
    let mut vals = vec![0.0; compiled.pattern().nnz()];
    g.bench_function(BenchmarkId::new("num-dual", "dense"), |b| {
        b.iter(|| {
            f.jacobian(0.0, black_box(&x), &[], &mut jd);
            black_box(&jd);
        })
    });
    g.bench_function(BenchmarkId::new("symbolic", "dense"), |b| {
        b.iter(|| {
            compiled.eval_dense(0.0, black_box(x.as_slice()), &[], &mut js).unwrap();
            black_box(&js);
        })
    });
    g.bench_function(BenchmarkId::new("symbolic", "csc"), |b| {
        b.iter(|| {
            compiled.eval(0.0, black_box(x.as_slice()), &[], &mut vals).unwrap();
            black_box(&vals);
        })
    });
    let mut interpreted = compiled.clone().interpreted();
    g.bench_function(BenchmarkId::new("symbolic-interpreted", "csc"), |b| {
        b.iter(|| {
            interpreted.eval(0.0, black_box(x.as_slice()), &[], &mut vals).unwrap();
            black_box(&vals);
        })
    });
    g.finish();
}

criterion_group!(benches, jacobians);
criterion_main!(benches);

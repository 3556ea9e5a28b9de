//! Implicit Euler on Robertson: the autodiff Jacobian vs a hand-written analytic one
//! (bench-only), same stepper, same tolerances.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Const, Matrix3, Vector3, vector};
use reckon::methods::ImplicitEuler;
use reckon::studies::problems::robertson;
use reckon::{Options, Problem, System};
use std::hint::black_box;
use std::time::Duration;

/// Robertson with its Jacobian written by hand.
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

fn implicit(c: &mut Criterion) {
    let opts = Options::default().rtol(1e-4).atol(1e-8).dense(false);
    let y0 = vector![1.0, 0.0, 0.0];
    let auto = Problem::new(robertson(), y0, (0.0, 1e5));
    let hand = Problem::new(AnalyticRobertson, y0, (0.0, 1e5));
    let sa = auto.solve(ImplicitEuler::default(), &opts).unwrap().stats;
    let sh = hand.solve(ImplicitEuler::default(), &opts).unwrap().stats;
    eprintln!("robertson autodiff {sa:?}\nrobertson analytic {sh:?}");
    let mut g = c.benchmark_group("implicit-euler/robertson");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2));
    g.bench_function("autodiff-jacobian", |b| {
        b.iter(|| {
            black_box(
                auto.solve(ImplicitEuler::default(), black_box(&opts))
                    .unwrap()
                    .stats
                    .accepted,
            )
        })
    });
    g.bench_function("analytic-jacobian", |b| {
        b.iter(|| {
            black_box(
                hand.solve(ImplicitEuler::default(), black_box(&opts))
                    .unwrap()
                    .stats
                    .accepted,
            )
        })
    });
    // the Jacobian evaluation itself, where autodiff is paid for
    let y = vector![0.9, 2e-5, 0.1];
    let (fa, fh) = (robertson(), AnalyticRobertson);
    let mut j = Matrix3::zeros();
    g.bench_function("jacobian-call/autodiff", |b| {
        b.iter(|| {
            fa.jacobian(0.0, black_box(&y), &[], &mut j);
            black_box(j[(1, 1)])
        })
    });
    g.bench_function("jacobian-call/analytic", |b| {
        b.iter(|| {
            fh.jacobian(0.0, black_box(&y), &[], &mut j);
            black_box(j[(1, 1)])
        })
    });
    g.finish();
}

criterion_group!(benches, implicit);
criterion_main!(benches);

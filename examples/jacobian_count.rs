//! Run one Jacobian evaluation `reps` times, for instruction counts under callgrind:
//! `valgrind --tool=callgrind target/release/examples/jacobian_count <model> <numdual|symbolic|interpreted> <reps>`
//! with model `unicycle`, `carlike` or `robertson`; per evaluation = (N(reps) − N(1))/(reps − 1).
use nalgebra::{SMatrix, SVector, vector};
use reckon::studies::problems::robertson;
use reckon::vehicles::{carlike, unicycle};
use reckon::{System, symbolic};
use std::hint::black_box;

fn run<const N: usize>(
    f: &impl System<nalgebra::Const<N>>,
    x: SVector<f64, N>,
    u: &[f64],
    how: &str,
    reps: usize,
) -> f64 {
    let mut acc = 0.0;
    if how == "numdual" {
        let mut j = SMatrix::<f64, N, N>::zeros();
        for _ in 0..reps {
            f.jacobian(0.0, black_box(&x), black_box(u), &mut j);
            acc += black_box(&j)[(0, N - 1)];
        }
    } else {
        let mut c = symbolic::trace(f, N).unwrap().compile_jacobian();
        if how == "interpreted" {
            c = c.interpreted();
        }
        let mut j = vec![0.0; N * N];
        for _ in 0..reps {
            c.eval_dense(0.0, black_box(x.as_slice()), black_box(u), &mut j)
                .unwrap();
            acc += black_box(&j)[N * (N - 1)];
        }
    }
    acc
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let reps: usize = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(1);
    let v = match a.get(1).map(String::as_str) {
        Some("carlike") => run(
            &carlike::model(2.5),
            vector![1.0, 2.0, 0.7, 0.1],
            &[1.3, 0.4],
            &a[2],
            reps,
        ),
        Some("robertson") => run(&robertson(), vector![0.9, 2e-5, 0.1], &[], &a[2], reps),
        _ => run(&unicycle::model(), vector![1.0, 2.0, 0.7], &[1.3, 0.4], &a[2], reps),
    };
    println!("{v}");
}

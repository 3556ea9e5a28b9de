//! The cost of forward sensitivities as a multiple of the plain solve, for RK45 and
//! implicit Euler: the differential drive with its three geometry parameters (`n = 3`,
//! `m = n + n_p = 6` sensitivity columns, target ≤ (1 + m)×) and Van der Pol with μ
//! (`n = 2`, `m = 3`, target ≤ 4×); and with `Wrt::Params`, `∂x/∂p` alone (`m = n_p`,
//! target ≤ (1 + n_p)×: 4× and 2×). Same model code, same options, plain and augmented
//! solves interleaved in one group.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::vector;
use reckon::calibration::lsq::diff_drive;
use reckon::methods::{ImplicitEuler, Rk45};
use reckon::sensitivity::{self, SensitivityOptions, Wrt};
use reckon::{Options, Problem, model};

#[path = "../tests/it/common/drives.rs"]
mod drives;
use std::hint::black_box;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let so = SensitivityOptions::default();
    let sp = SensitivityOptions::default().wrt(Wrt::Params);
    let dd = diff_drive(&[0.0502, 0.0497, 0.405]).unwrap();
    let p = Problem::new(&dd, vector![0.0, 0.0, 0.0], (0.0, 60.0)).controls(drives::wheel_speed_log());
    let vdp = model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]]);
    let q = Problem::new(&vdp, vector![2.0, 0.0], (0.0, 10.0));
    let rk = Options::default().rtol(1e-8).atol(1e-10);
    let ie = Options::default().rtol(1e-5).atol(1e-8);
    for (name, o) in [("rk45", &rk), ("implicit-euler", &ie)] {
        let mut g = c.benchmark_group(format!("sensitivity/{name}"));
        g.sample_size(20)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(2));
        macro_rules! pair {
            ($label:expr, $prob:expr, $method:expr) => {
                let plain = $prob.solve($method, o).unwrap();
                let sens = sensitivity::solve(&$prob, $method, o, &so).unwrap();
                eprintln!(
                    "{name} {}: plain {} steps {} f, sensitivities {} steps {} f",
                    $label, plain.stats.accepted, plain.stats.rhs_evals, sens.stats.accepted, sens.stats.rhs_evals
                );
                g.bench_function(format!("{}/plain", $label), |b| {
                    b.iter(|| black_box($prob.solve($method, black_box(o)).unwrap().stats.accepted))
                });
                g.bench_function(format!("{}/sensitivities", $label), |b| {
                    b.iter(|| {
                        black_box(
                            sensitivity::solve(&$prob, $method, black_box(o), &so)
                                .unwrap()
                                .stats
                                .accepted,
                        )
                    })
                });
                g.bench_function(format!("{}/params-only", $label), |b| {
                    b.iter(|| {
                        black_box(
                            sensitivity::solve(&$prob, $method, black_box(o), &sp)
                                .unwrap()
                                .stats
                                .accepted,
                        )
                    })
                });
            };
        }
        if name == "rk45" {
            pair!("diff-drive", p, Rk45);
            pair!("van-der-pol", q, Rk45);
        } else {
            pair!("diff-drive", p, ImplicitEuler::default());
            pair!("van-der-pol", q, ImplicitEuler::default());
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);

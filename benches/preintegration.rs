//! Issue 37: the cost of IMU preintegration per sample, on the four random IMU sequences
//! of `tests/golden/lie/gtsam_preintegration.json` (200 to 1 000 samples each, 1 900 in
//! all), integrated by `Preintegrated::integrate` (ΔR, Δv, Δp, the 9×9 covariance and
//! the five bias Jacobians, Forster et al. 2017). Its counterpart is
//! `docs/lie/gtsam_preintegration_cost.py`, which times GTSAM's C++ (through its Python
//! binding, the call overhead measured and subtracted) on the same samples; the ratio is
//! in docs/performance.md. `cargo bench --bench preintegration` prints ns per sample.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{Matrix3, Vector3};
use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
use serde_json::Value;
use std::hint::black_box;
use std::time::{Duration, Instant};

struct Case {
    params: PreintegrationParams,
    bias: Bias,
    samples: Vec<(Vector3<f64>, Vector3<f64>, f64)>,
}

fn v3(v: &Value) -> Vector3<f64> {
    Vector3::from_iterator(v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
}

fn cases() -> Vec<Case> {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/golden/lie/gtsam_preintegration.json"
    );
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    doc["cases"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let diag = |k: &str| Matrix3::from_diagonal(&v3(&c[k]).component_mul(&v3(&c[k])));
            let params = PreintegrationParams::with_gravity(v3(&c["gravity"]))
                .unwrap()
                .gyro(diag("gyro_sigma"))
                .unwrap()
                .accel(diag("accel_sigma"))
                .unwrap()
                .integration(diag("integration_sigma"))
                .unwrap();
            let b = &c["bias_hat"];
            let bias = Bias {
                gyro: v3(&b["gyro"]),
                accel: v3(&b["accel"]),
            };
            let samples = c["samples"]
                .as_array()
                .unwrap()
                .iter()
                .map(|s| (v3(&s["gyro"]), v3(&s["accel"]), s["dt"].as_f64().unwrap()))
                .collect();
            Case { params, bias, samples }
        })
        .collect()
}

/// Preintegrate every case; the sum of the Δv's, so nothing is optimised away.
fn run(cases: &[Case]) -> f64 {
    let mut sum = 0.0;
    for c in cases {
        let mut pim = Preintegrated::new(c.params, c.bias);
        for (w, a, dt) in &c.samples {
            pim.integrate(w, a, *dt).unwrap();
        }
        sum += pim.delta_v().sum() + pim.covariance()[(0, 0)];
    }
    sum
}

fn bench(c: &mut Criterion) {
    let cases = cases();
    let n: usize = cases.iter().map(|c| c.samples.len()).sum();
    // the best wall time per sample over 20 runs, the figure set beside GTSAM's
    let mut best = f64::INFINITY;
    for _ in 0..20 {
        let t = Instant::now();
        black_box(run(black_box(&cases)));
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!(
        "preintegration: {n} samples, best of 20: {:.1} ns per sample",
        best / n as f64 * 1e9
    );
    let mut g = c.benchmark_group("preintegration");
    g.throughput(Throughput::Elements(n as u64));
    g.measurement_time(Duration::from_secs(5));
    g.bench_function("reckon integrate", |b| b.iter(|| black_box(run(black_box(&cases)))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

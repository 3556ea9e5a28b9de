//! IMU dead reckoning: 2-D and 3-D strapdown against closed forms, bias drift laws,
//! bias correction, and the pitch singularity.

use nalgebra::{Vector3, Vector5, vector};
use reckon::Error;
use reckon::reckoning::drift::imu_bias_drift;
use reckon::reckoning::imu::*;
use reckon::vehicles::body3d::rotation;
use std::f64::consts::PI;

#[test]
fn planar_circle_from_gyro_and_centripetal_acceleration() {
    // v = 2 m/s on a circle of radius 4: ω = 0.5, body acceleration (0, v²/R) = (0, 1)
    let samples = vec![(0.0, 0.5, 0.0, 1.0), (4.0 * PI, 0.0, 0.0, 0.0)];
    let sol = dead_reckon_2d(&samples, Vector5::new(0.0, 0.0, 0.0, 2.0, 0.0), [0.0; 3]).unwrap();
    let end = sol.last().1;
    // after one full turn (2π/ω = 4π s) back at the start, velocity (2, 0)
    assert!(
        (end - Vector5::new(0.0, 0.0, 2.0 * PI, 2.0, 0.0)).amax() < 1e-8,
        "{end}"
    );
    // midway at (0, 8)
    let mid = sol.at(2.0 * PI).unwrap();
    assert!((mid[0]).abs() < 1e-8 && (mid[1] - 8.0).abs() < 1e-8, "{mid}");
}

#[test]
fn planar_biases_are_corrected_and_drift_when_not() {
    let b = [0.01, 0.05, 0.0];
    // stationary robot whose sensors read their biases
    let samples = vec![(0.0, b[0], b[1], b[2]), (10.0, 0.0, 0.0, 0.0)];
    let corrected = dead_reckon_2d(&samples, Vector5::zeros(), b).unwrap();
    assert!(corrected.last().1.amax() < 1e-12);
    let raw = dead_reckon_2d(&samples, Vector5::zeros(), [0.0; 3]).unwrap();
    // heading drifts b_ω t; the accelerometer bias, rotating with it, gives ≈ ½ b_a t²
    let end = raw.last().1;
    assert!((end[2] - 0.1).abs() < 1e-12);
    let w = b[0];
    // exact: x = b_a (1 − cos ωt)/ω², y = b_a (ωt − sin ωt)/ω²
    let t = 10.0f64;
    assert!((end[0] - b[1] * (1.0 - (w * t).cos()) / (w * w)).abs() < 1e-9);
    assert!((end[1] - b[1] * (w * t - (w * t).sin()) / (w * w)).abs() < 1e-9);
}

#[test]
fn strapdown_rotation_is_exact_and_constant_acceleration_integrates_exactly() {
    // spin about z at 1 rad/s for π s in 1000 steps: exactly half a turn
    let n = 1000;
    let s: Vec<ImuSample> = (0..=n)
        .map(|k| ImuSample {
            t: k as f64 * PI / n as f64,
            gyro: vector![0.0, 0.0, 1.0],
            accel: vector![0.0, 0.0, GRAVITY],
        })
        .collect();
    let out = strapdown(&s, Nav::level(), &Vector3::zeros(), &Vector3::zeros()).unwrap();
    let r = out.last().unwrap().1.r;
    assert!((r - rotation(0.0, 0.0, PI)).amax() < 1e-13);
    let orth = (r.transpose() * r - nalgebra::Matrix3::identity()).amax();
    assert!(orth < 1e-13, "stays orthonormal: {orth:e}");
    // accelerate forward at 0.5 m/s² (level, not rotating): p = ¼ t²
    let s: Vec<ImuSample> = (0..=100)
        .map(|k| ImuSample {
            t: k as f64 * 0.1,
            gyro: Vector3::zeros(),
            accel: vector![0.5, 0.0, GRAVITY],
        })
        .collect();
    let end = strapdown(&s, Nav::level(), &Vector3::zeros(), &Vector3::zeros())
        .unwrap()
        .last()
        .unwrap()
        .1;
    assert!((end.p - vector![25.0, 0.0, 0.0]).amax() < 1e-12);
    assert!((end.v - vector![5.0, 0.0, 0.0]).amax() < 1e-13);
}

/// Accelerometer bias: ½ b_a t² (exactly); gyro bias: g b_g t³/6 (small angle), and the
/// exact double integral g(t/b − sin(bt)/b²).
#[test]
fn imu_bias_drift_laws() {
    let (ba, bg) = (0.01, 1e-3);
    let rows = imu_bias_drift(ba, bg, &[10.0, 20.0, 30.0, 60.0], 0.01).unwrap();
    for r in &rows {
        assert!(
            (r.accel_simulated - r.accel_closed_form).abs() < 1e-9 * r.accel_closed_form,
            "{r:?}"
        );
        let exact = GRAVITY * (r.t / bg - (bg * r.t).sin() / (bg * bg));
        assert!((r.gyro_simulated / exact - 1.0).abs() < 1e-6, "{r:?} vs {exact}");
        assert!((r.gyro_simulated / r.gyro_closed_form - 1.0).abs() < 1e-3, "{r:?}");
    }
    // growth laws: ×2 in time → ×4 and ×8
    assert!((rows[1].accel_simulated / rows[0].accel_simulated - 4.0).abs() < 1e-9);
    assert!((rows[1].gyro_simulated / rows[0].gyro_simulated - 8.0).abs() < 1e-3);
}

#[test]
fn pitch_singularity_is_reported() {
    let r = rotation(0.3, PI / 2.0, 1.0);
    match euler_angles(&r, 12.5) {
        Err(Error::PitchSingularity { t, pitch }) => {
            assert_eq!(t, 12.5);
            assert!((pitch - PI / 2.0).abs() < 1e-6);
        }
        other => panic!("expected PitchSingularity, got {other:?}"),
    }
    assert!(euler_angles(&rotation(0.3, -PI / 2.0, 1.0), 0.0).is_err());
    let (a, b, c) = euler_angles(&rotation(0.3, 1.5, 1.0), 0.0).unwrap();
    assert!((a - 0.3).abs() < 1e-9 && (b - 1.5).abs() < 1e-12 && (c - 1.0).abs() < 1e-9);
}

/// White accelerometer noise σ_a at sample period dt integrates to a velocity random walk
/// σ_v(t) = σ_a·√(dt·t); over many seeds the spread of the final velocity matches it.
#[test]
fn imu_noise_is_seeded_and_integrates_to_a_random_walk() {
    let (dt, n, sa) = (0.01, 1000, 0.05);
    let truth: Vec<ImuSample> = (0..=n)
        .map(|k| ImuSample {
            t: k as f64 * dt,
            gyro: Vector3::zeros(),
            accel: vector![0.0, 0.0, GRAVITY],
        })
        .collect();
    let e = ImuErrors {
        accel_noise: sa,
        seed: 3,
        ..Default::default()
    };
    assert_eq!(corrupt(&truth, &e), corrupt(&truth, &e));
    assert_ne!(corrupt(&truth, &e), corrupt(&truth, &ImuErrors { seed: 4, ..e }));
    let runs = 400;
    let mut sum2 = 0.0;
    for seed in 0..runs {
        let s = corrupt(&truth, &ImuErrors { seed, ..e });
        let end = strapdown(&s, Nav::level(), &Vector3::zeros(), &Vector3::zeros())
            .unwrap()
            .last()
            .unwrap()
            .1;
        sum2 += end.v[0] * end.v[0];
    }
    let sigma = (sum2 / runs as f64).sqrt();
    // each sample's force is held over its interval: v = Σ f_k·dt over n intervals, σ·dt·√n
    let expect = sa * dt * (n as f64).sqrt();
    assert!((sigma / expect - 1.0).abs() < 0.15, "σ_v {sigma} vs {expect}");
}

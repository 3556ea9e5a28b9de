//! Drift studies against closed forms.

use nalgebra::Vector3;
use reckon::reckoning::drift::*;
use reckon::reckoning::encoder_sim::EncoderErrors;
use reckon::reckoning::encoders::DiffDrive;
use std::f64::consts::{FRAC_PI_2, PI};

fn robot() -> DiffDrive {
    DiffDrive::new(0.1, 0.5, 2048.0).unwrap()
}

#[test]
fn one_degree_heading_error_is_1_745_percent() {
    let rows = heading_error_drift(1f64.to_radians(), &[1.0, 2.0, 5.0, 10.0]);
    for r in &rows {
        assert!((r.lateral_percent().abs() - 1.7452406).abs() < 1e-6, "{r:?}");
    }
    assert!((rows[3].lateral.abs() - 0.17452406).abs() < 1e-7);
    assert!((rows[3].longitudinal - 10.0 * (1.0 - 1f64.to_radians().cos())).abs() < 1e-15);
}

/// A left wheel larger by ε curves the true path: lateral error ε·d²/(2B)(1 + O(ε)).
#[test]
fn wheel_diameter_mismatch_grows_quadratically() {
    let eps = 1e-3;
    let e = EncoderErrors {
        left_scale: 1.0 + eps,
        ..Default::default()
    };
    let rows = straight_drift(&robot(), &e, &[1.0, 2.0, 5.0, 10.0], 0.5, 0.01).unwrap();
    for r in &rows {
        let expect = eps * r.distance * r.distance / (2.0 * 0.5);
        assert!((r.lateral / expect - 1.0).abs() < 2e-3, "{r:?} vs {expect}");
    }
    assert!((rows[3].lateral / rows[0].lateral - 100.0).abs() < 0.5);
    // no error model: no drift
    let clean = straight_drift(&robot(), &EncoderErrors::default(), &[10.0], 0.5, 0.01).unwrap();
    assert!(clean[0].lateral.abs() < 1e-12 && clean[0].longitudinal.abs() < 1e-12);
}

/// With the wheelbase 1% longer than believed every on-the-spot turn falls short by the
/// factor 1/1.01; the true square is a chain of legs at headings k·α.
#[test]
fn umbmark_wheelbase_error_against_geometry() {
    let s = 1.01;
    let e = EncoderErrors {
        wheelbase_scale: s,
        ..Default::default()
    };
    let side = 4.0;
    let u = umbmark(&robot(), &e, side, 0.4, 0.5, 0.01).unwrap();
    let mut e_max: f64 = 0.0;
    for (err, sign) in [(u.ccw, 1.0), (u.cw, -1.0)] {
        let a = sign * FRAC_PI_2 / s;
        let truth = Vector3::new(
            side * (0..4).map(|k| (k as f64 * a).cos()).sum::<f64>(),
            side * (0..4).map(|k| (k as f64 * a).sin()).sum::<f64>(),
            4.0 * a,
        );
        let est = Vector3::new(0.0, 0.0, sign * 2.0 * PI);
        assert!((err - (truth - est)).amax() < 1e-9, "{err} vs {}", truth - est);
        e_max = e_max.max((truth - est).fixed_rows::<2>(0).norm());
    }
    assert!((u.e_max_syst() - e_max).abs() < 1e-9, "{}", u.e_max_syst());
    let clean = umbmark(&robot(), &EncoderErrors::default(), side, 0.4, 0.5, 0.01).unwrap();
    assert!(clean.e_max_syst() < 1e-12);
}

#[test]
fn drive_and_return_and_right_triangle() {
    let s = 1.02;
    let e = EncoderErrors {
        wheelbase_scale: s,
        ..Default::default()
    };
    let l = 5.0;
    let err = return_error(&robot(), &e, &drive_and_return(l, 0.5, 0.5), 0.01).unwrap();
    let b = PI / s;
    let truth = Vector3::new(l + l * b.cos(), l * b.sin(), b);
    assert!((err - (truth - Vector3::new(0.0, 0.0, PI))).amax() < 1e-9, "{err}");
    for cmds in [drive_and_return(l, 0.5, 0.5), right_triangle(3.0, 4.0, 0.5, 0.5)] {
        let clean = return_error(&robot(), &EncoderErrors::default(), &cmds, 0.01).unwrap();
        assert!(clean.amax() < 1e-12, "{clean}");
    }
    let tri = return_error(&robot(), &e, &right_triangle(3.0, 4.0, 0.5, 0.5), 0.01).unwrap();
    assert!(tri.fixed_rows::<2>(0).norm() > 0.05);
}

#[test]
fn random_errors_are_reproducible_and_grow() {
    let e = EncoderErrors {
        slip_sigma: 0.01,
        pulse_noise: 0.5,
        quantize: true,
        seed: 7,
        ..Default::default()
    };
    let a = straight_drift(&robot(), &e, &[1.0, 10.0], 0.5, 0.01).unwrap();
    let b = straight_drift(&robot(), &e, &[1.0, 10.0], 0.5, 0.01).unwrap();
    assert_eq!(a, b, "same seed, same run");
    let c = straight_drift(&robot(), &EncoderErrors { seed: 8, ..e }, &[1.0, 10.0], 0.5, 0.01).unwrap();
    assert_ne!(a, c);
    // slip makes the truth fall short: the estimate runs ahead, about σ·√(2/π) of the distance
    let mean_slip = 0.01 * (2.0 / PI).sqrt();
    assert!((a[1].longitudinal / 10.0 / mean_slip - 1.0).abs() < 0.2, "{:?}", a[1]);
}

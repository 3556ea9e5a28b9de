//! Encoder odometry: straight line, pure rotation, a circle, and the three update rules
//! against the exact arc.

use nalgebra::{Vector3, vector};
use reckon::reckoning::encoders::{DiffDrive, Update, advance, odometry};
use std::f64::consts::PI;

const RULES: [Update; 3] = [Update::Midpoint, Update::Exact, Update::Euler];

fn robot() -> DiffDrive {
    DiffDrive::new(0.1, 0.4, 500.0).unwrap() // 0.1π/500 m per pulse
}

#[test]
fn straight_line() {
    let r = robot();
    let samples: Vec<_> = (0..=100)
        .map(|k| {
            (
                k as f64 * 0.1,
                if k == 0 { 0.0 } else { 50.0 },
                if k == 0 { 0.0 } else { 50.0 },
            )
        })
        .collect();
    for rule in RULES {
        let path = odometry(&r, &samples, rule).unwrap();
        let end = path.last().unwrap().1;
        let d = 100.0 * 50.0 * r.distance_per_pulse();
        assert!((end - vector![d, 0.0, 0.0]).amax() < 1e-12, "{rule:?}: {end}");
    }
}

#[test]
fn pure_rotation() {
    let r = robot();
    // left back, right forward: Δθ = 2·n·k / B per sample, no translation
    let samples: Vec<_> = (1..=40).map(|k| (k as f64, -25.0, 25.0)).collect();
    let dth = 2.0 * 25.0 * r.distance_per_pulse() / 0.4;
    for rule in RULES {
        let end = odometry(&r, &samples, rule).unwrap().last().unwrap().1;
        assert!(end[0].abs() < 1e-15 && end[1].abs() < 1e-15, "{rule:?}: {end}");
        assert!((end[2] - 40.0 * dth).abs() < 1e-12, "θ is unwrapped: {}", end[2]);
    }
}

/// Constant wheel speeds drive a circle of radius R = (B/2)(n_r + n_l)/(n_r − n_l); the exact
/// rule closes it after one revolution, the others miss by their per-step error.
#[test]
fn circle_of_known_radius() {
    let r = robot();
    let (nl, nr) = (30.0, 50.0);
    let radius = 0.5 * 0.4 * (nr + nl) / (nr - nl);
    let (ds, dth) = r.increments(nl, nr);
    assert!((ds / dth - radius).abs() < 1e-12);
    let steps = (2.0 * PI / dth).round() as usize;
    // choose pulses so that `steps` samples make exactly one turn: rescale the robot's separation
    let b = (nr - nl) * r.distance_per_pulse() * steps as f64 / (2.0 * PI);
    let r = DiffDrive::new(0.1, b, 500.0).unwrap();
    let radius = 0.5 * b * (nr + nl) / (nr - nl);
    let samples: Vec<_> = (1..=steps).map(|k| (k as f64, nl, nr)).collect();
    let exact = odometry(&r, &samples, Update::Exact).unwrap();
    let end = exact.last().unwrap().1;
    assert!((end[2] - 2.0 * PI).abs() < 1e-12);
    assert!(
        end[0].abs() < 1e-12 && end[1].abs() < 1e-12,
        "exact rule closes the circle: {end}"
    );
    // every exact pose lies on the circle centred at (0, R)
    for (_, p) in &exact {
        assert!(((p[0].powi(2) + (p[1] - radius).powi(2)).sqrt() - radius).abs() < 1e-12);
    }
    // the other rules trace polygons that also close by symmetry, but off the circle:
    // compare whole paths with the exact one
    let dev = |rule| {
        let path = odometry(&r, &samples, rule).unwrap();
        path.iter()
            .zip(&exact)
            .map(|(a, b)| (a.1 - b.1).fixed_rows::<2>(0).norm())
            .fold(0.0, f64::max)
    };
    let (m, e) = (dev(Update::Midpoint), dev(Update::Euler));
    // chord vs arc: the midpoint polygon's vertices sit on radius ds/(2 sin(Δθ/2)) instead of ds/Δθ
    let dth = 2.0 * PI / steps as f64;
    let ds = radius * dth;
    let expect_m = 2.0 * (ds / (2.0 * (dth / 2.0).sin()) - radius) + 1e-12;
    assert!(
        m <= 1.01 * expect_m && m > 0.5 * (ds / (2.0 * (dth / 2.0).sin()) - radius),
        "midpoint deviation {m}"
    );
    assert!(e > 10.0 * m, "Euler deviation {e} vs midpoint {m}");
}

/// One step: |midpoint − arc| ≈ Δs·Δθ²/24 (second order), |Euler − arc| ≈ Δs·Δθ/2 (first order).
#[test]
fn update_rules_against_the_arc() {
    let p = Vector3::new(0.3, -0.2, 0.7);
    let ds = 1.0;
    for &dth in &[0.2, 0.1, 0.05, 0.025] {
        let arc = advance(&p, ds, dth, Update::Exact);
        let m = (advance(&p, ds, dth, Update::Midpoint) - arc).fixed_rows::<2>(0).norm();
        let e = (advance(&p, ds, dth, Update::Euler) - arc).fixed_rows::<2>(0).norm();
        assert!(
            (m / (ds * dth * dth / 24.0) - 1.0).abs() < 0.01,
            "midpoint error {m} at Δθ = {dth}"
        );
        assert!(
            (e / (ds * dth / 2.0) - 1.0).abs() < 0.02,
            "Euler error {e} at Δθ = {dth}"
        );
    }
}

#[test]
fn bad_samples_are_errors() {
    let r = robot();
    assert!(odometry(&r, &[(0.0, 0.0, 0.0), (0.0, 1.0, 1.0)], Update::Exact).is_err());
    assert!(odometry(&r, &[(0.0, f64::NAN, 0.0)], Update::Exact).is_err());
    assert!(DiffDrive::new(f64::INFINITY, 0.4, 500.0).is_err());
    assert!("sideways".parse::<Update>().is_err());
}

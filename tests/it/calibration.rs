//! UMBmark and Censi et al. calibration against injected geometry.

use nalgebra::{Vector2, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use reckon::Error;
use reckon::calibration::{censi, umbmark};
use reckon::reckoning::{drift, encoder_sim::EncoderErrors, encoders::DiffDrive};

fn xy(v: Vector3<f64>) -> Vector2<f64> {
    v.fixed_rows::<2>(0).into_owned()
}

/// Injected `E_d = 1.002`, `E_b = 1.01` on a 4 m square recovered to first order, and the
/// corrected robot's systematic error at least 10× smaller (Borenstein & Feng report ≥ 10×).
#[test]
fn umbmark_recovers_injected_errors_and_the_correction_cuts_the_error_tenfold() {
    let robot = DiffDrive::new(0.1, 0.5, 1000.0).unwrap();
    let (ed, eb) = (1.002, 1.01);
    let e = EncoderErrors {
        left_scale: 2.0 / (ed + 1.0),
        right_scale: 2.0 / (1.0 / ed + 1.0),
        wheelbase_scale: eb,
        ..Default::default()
    };
    let before = drift::umbmark(&robot, &e, 4.0, 0.5, 0.5, 0.01).unwrap();
    let fit = umbmark::calibrate(&[xy(before.cw)], &[xy(before.ccw)], 4.0, 0.5).unwrap();
    assert!((fit.e_d() - ed).abs() < 1e-4, "E_d = {}", fit.e_d());
    assert!((fit.e_b() - eb).abs() < 1e-3, "E_b = {}", fit.e_b());
    let after = drift::umbmark(&robot, &fit.residual_errors(&e), 4.0, 0.5, 0.5, 0.01).unwrap();
    let ratio = before.e_max_syst() / after.e_max_syst();
    eprintln!(
        "UMBmark: E_max,syst {} → {} m, reduction {ratio:.1}×",
        before.e_max_syst(),
        after.e_max_syst()
    );
    assert!(
        ratio >= 10.0,
        "reduction {ratio} ({} → {} m)",
        before.e_max_syst(),
        after.e_max_syst()
    );
}

fn truth() -> censi::Params {
    censi::Params {
        r_l: 0.05,
        r_r: 0.051,
        b: 0.4,
        sensor: Vector3::new(0.1, -0.05, 0.3),
    }
}

fn intervals(noise: Option<(u64, f64, f64)>) -> Vec<censi::Interval> {
    let p = truth();
    let mut rng = StdRng::seed_from_u64(noise.map_or(0, |n| n.0));
    let unit = Normal::new(0.0, 1.0).unwrap();
    (0..60)
        .map(|k| {
            let k = k as f64;
            let w = vec![[1.0 + 0.3 * (k * 0.7).sin(), 1.2 - 0.9 * (k * 0.45).cos()]; 5];
            let mut s = p.sensor_motion(&w);
            if let Some((_, sxy, sth)) = noise {
                s += Vector3::new(
                    sxy * unit.sample(&mut rng),
                    sxy * unit.sample(&mut rng),
                    sth * unit.sample(&mut rng),
                );
            }
            censi::Interval { wheels: w, sensor: s }
        })
        .collect()
}

#[test]
fn censi_recovers_noise_free_parameters_to_1e9() {
    let fit = censi::calibrate(&intervals(None), censi::Trim::default()).unwrap();
    let (p, t) = (fit.params, truth());
    for (got, want) in [(p.r_l, t.r_l), (p.r_r, t.r_r), (p.b, t.b)] {
        assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
    }
    assert!((p.sensor - t.sensor).amax() < 1e-9);
}

/// Over 20 noisy seeds the wheel base lies within 3 reported standard deviations at least
/// 18 times (each miss has probability 0.27 %: 3 or more misses in 20 has probability 1e-5).
#[test]
fn censi_estimates_lie_within_their_reported_covariance() {
    let mut misses = 0;
    for seed in 1..=20 {
        // Gaussian noise and no failed matches: nothing to trim (trimming would cut the tails)
        let fit = censi::calibrate(&intervals(Some((seed, 0.002, 0.001))), censi::Trim::NONE).unwrap();
        let i = fit
            .estimate
            .names
            .iter()
            .position(|n| *n == "b")
            .expect("b is estimated");
        let sd = fit.estimate.std_dev()[i];
        assert!(sd > 0.0 && sd < 0.05, "σ_b = {sd}");
        if (fit.params.b - truth().b).abs() > 3.0 * sd {
            misses += 1;
        }
    }
    assert!(misses <= 2, "{misses} of 20 outside 3σ");
}

/// Driving straight only says nothing about the wheel base: a typed error.
#[test]
fn censi_straight_driving_is_unidentifiable() {
    let p = truth();
    let data: Vec<censi::Interval> = (0..20)
        .map(|k| {
            let w = vec![[1.0 + 0.01 * k as f64, (1.0 + 0.01 * k as f64) * p.r_l / p.r_r]; 5];
            censi::Interval {
                sensor: p.sensor_motion(&w),
                wheels: w,
            }
        })
        .collect();
    assert!(matches!(
        censi::calibrate(&data, censi::Trim::default()),
        Err(Error::Unidentifiable { .. })
    ));
}

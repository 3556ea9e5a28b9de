//! Least-squares calibration of a differential drive's wheel radii and wheelbase.

use nalgebra::{DMatrix, DVector, Vector3, vector};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use reckon::calibration::lsq::{self, LsqOptions, Observations, diff_drive};
use reckon::methods::Rk45;
use reckon::{Controls, Error, Options, Problem, Save};

use crate::common::drives;

const TRUTH: [f64; 3] = [0.0502, 0.0497, 0.405];
const NOMINAL: [f64; 3] = [0.05, 0.05, 0.4];

fn times() -> Vec<f64> {
    (1..=120).map(|k| 0.5 * k as f64).collect()
}

fn truth_poses(controls: &Controls, p: &[f64], t: &[f64]) -> Vec<Vector3<f64>> {
    let f = diff_drive(p).unwrap();
    let sol = Problem::new(&f, vector![0.0, 0.0, 0.0], (0.0, *t.last().unwrap()))
        .controls(controls.clone())
        .solve(
            Rk45,
            &Options::default().rtol(1e-12).atol(1e-14).save(Save::At(t.to_vec())),
        )
        .unwrap();
    sol.x
}

fn observe(poses: &[Vector3<f64>], t: Vec<f64>, sigma: [f64; 3], seed: Option<u64>) -> Observations {
    let mut rng = StdRng::seed_from_u64(seed.unwrap_or(0));
    let n = Normal::new(0.0, 1.0).unwrap();
    let y = poses
        .iter()
        .map(|x| {
            (0..3)
                .map(|c| {
                    x[c] + if seed.is_some() {
                        sigma[c] * n.sample(&mut rng)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    Observations {
        t,
        y,
        components: vec![0, 1, 2],
        sigma: sigma.to_vec(),
        angles: vec![2],
    }
}

fn fit(obs: &Observations, controls: &Controls) -> reckon::Result<lsq::Fit> {
    lsq::fit(
        &|p: &[f64]| diff_drive(p),
        &NOMINAL,
        &vector![0.0, 0.0, 0.0],
        0.0,
        controls,
        obs,
        Rk45,
        &Options::default().rtol(1e-10).atol(1e-12),
        &LsqOptions::default(),
    )
}

#[test]
fn noise_free_log_gives_the_parameters_back() {
    let u = drives::wheel_speed_log();
    let t = times();
    let obs = observe(&truth_poses(&u, &TRUTH, &t), t, [0.005, 0.005, 0.002], None);
    let f = fit(&obs, &u).unwrap();
    for (got, want) in f.estimate.value.iter().zip(TRUTH) {
        assert!((got - want).abs() < 1e-8 * want, "{got} vs {want}");
    }
    assert!(f.iterations >= 2 && f.iterations < 30, "{} iterations", f.iterations);
}

/// Over 8 noisy logs: the reported covariance describes the scatter of the estimates
/// (each normalised error `eᵀ P⁻¹ e` is χ²₃: below 16.27 with probability 0.999, and the
/// mean of eight is within [0.5, 6] with probability above 0.999) and σ̂² ≈ 1.
#[test]
fn noisy_logs_recover_the_parameters_within_their_covariance() {
    let u = drives::wheel_speed_log();
    let t = times();
    let poses = truth_poses(&u, &TRUTH, &t);
    let mut nees = Vec::new();
    for seed in 1..=8 {
        let obs = observe(&poses, t.clone(), [0.005, 0.005, 0.002], Some(seed));
        let f = fit(&obs, &u).unwrap();
        let e = DVector::from_iterator(3, (0..3).map(|i| f.estimate.value[i] - TRUTH[i]));
        let pinv: DMatrix<f64> = f.estimate.covariance.clone().try_inverse().unwrap();
        let q = (e.transpose() * pinv * &e)[(0, 0)];
        assert!(q < 16.27, "seed {seed}: normalised error {q}");
        // 357 degrees of freedom: σ̂² has standard deviation √(2/357) = 0.075
        assert!(
            (f.estimate.sigma2 - 1.0).abs() < 0.3,
            "seed {seed}: σ̂² = {}",
            f.estimate.sigma2
        );
        // and the wheelbase is determined to better than a millimetre here
        assert!(f.estimate.std_dev()[2] < 1e-3, "σ_b = {}", f.estimate.std_dev()[2]);
        nees.push(q);
    }
    let mean = nees.iter().sum::<f64>() / nees.len() as f64;
    assert!((0.5..6.0).contains(&mean), "mean normalised error {mean}: {nees:?}");
}

/// Driving straight with equal wheel speeds leaves the wheelbase (and the radius split)
/// undetermined: a typed error, not a number.
#[test]
fn straight_driving_cannot_determine_the_wheelbase() {
    let u = Controls::new(vec![0.0], vec![vec![10.0, 10.0]]).unwrap();
    let t = times();
    let obs = observe(&truth_poses(&u, &TRUTH, &t), t, [0.005, 0.005, 0.002], Some(3));
    match fit(&obs, &u) {
        Err(Error::Unidentifiable { reason, .. }) => assert!(reason.contains("condition number"), "{reason}"),
        other => panic!("expected Unidentifiable, got {other:?}"),
    }
}

#[test]
fn malformed_observations_are_typed_errors() {
    let u = drives::wheel_speed_log();
    let t = times();
    let good = observe(&truth_poses(&u, &TRUTH, &t), t, [0.005, 0.005, 0.002], None);
    let mut bad = good.clone();
    bad.sigma[1] = 0.0;
    assert!(matches!(
        fit(&bad, &u),
        Err(Error::InvalidInput {
            what: "observations",
            ..
        })
    ));
    let mut bad = good.clone();
    bad.t.swap(3, 4);
    assert!(matches!(
        fit(&bad, &u),
        Err(Error::InvalidInput {
            what: "observations",
            ..
        })
    ));
    let mut bad = good.clone();
    bad.y[7][2] = f64::NAN;
    assert!(matches!(
        fit(&bad, &u),
        Err(Error::InvalidInput {
            what: "observations",
            ..
        })
    ));
    let mut bad = good;
    bad.components = vec![0, 1, 5];
    assert!(matches!(
        fit(&bad, &u),
        Err(Error::InvalidInput {
            what: "observations",
            ..
        })
    ));
}

/// From a simulated encoder log (`reckoning::errors::simulate`): injected wheel-diameter
/// and wheelbase errors recovered from the counts and the true poses.
#[test]
fn encoder_log_calibration_recovers_injected_geometry() {
    let robot = drives::square_robot();
    let run = drives::square_log();
    let poses: Vec<(f64, Vector3<f64>)> = run
        .samples
        .iter()
        .zip(&run.truth)
        .step_by(10)
        .map(|(s, p)| (s.0, *p))
        .collect();
    let f = lsq::fit_encoder_log(&run.samples, &robot, &poses, [0.005, 0.005, 0.002]).unwrap();
    let want = [0.05 * 1.004, 0.05 * 0.997, 0.5 * 1.02];
    for (got, want) in f.estimate.value.iter().zip(want) {
        assert!((got - want).abs() < 1e-7 * want, "{got} vs {want}");
    }
    assert_eq!(f.estimate.names[2], "wheel separation");
}

/// Issue 38 item 7: with σ = 10⁻⁵ the weighted residuals at the nominal start have
/// ‖r‖ ≈ 10⁶, where argmin's `GaussNewtonLS` stalled (its Armijo test compares a decrease
/// of ‖r‖ with the slope of ½‖r‖², so no step length passed above ‖r‖ = 10⁴) and returned
/// the start as converged. Levenberg–Marquardt moves to the truth.
#[test]
fn a_start_with_large_residuals_is_not_returned_as_the_optimum() {
    let u = drives::wheel_speed_log();
    let t = times();
    let obs = observe(&truth_poses(&u, &TRUTH, &t), t, [1e-5, 1e-5, 1e-5], None);
    let f = fit(&obs, &u).unwrap();
    for (got, want) in f.estimate.value.iter().zip(TRUTH) {
        assert!((got - want).abs() < 1e-8 * want, "{got} vs {want}");
    }
    assert!(f.iterations >= 2, "{} steps", f.iterations);
}

/// A fit that cannot move from its start (here every other parameter value fails to
/// build a model) is `FitFailed`, not the start with standard deviations.
#[test]
fn a_fit_that_cannot_move_is_an_error_not_the_start() {
    let build = |p: &[f64]| {
        if p[0] != 0.2 {
            return Err(Error::invalid("p", "the model exists at k = 0.2 only"));
        }
        reckon::model!(|_, x: [S; 1], u: [1], p: [S; 1] = [1.0]| vector![-(p[0] * x[0])]).with_params(p)
    };
    let t: Vec<f64> = (1..=10).map(|k| 0.3 * k as f64).collect();
    let obs = Observations {
        y: t.iter().map(|t| vec![(-0.7 * t).exp()]).collect(),
        t,
        components: vec![0],
        sigma: vec![1e-3],
        angles: vec![],
    };
    let u = Controls::new(vec![0.0], vec![vec![0.0]]).unwrap();
    let r = lsq::fit(
        &build,
        &[0.2],
        &vector![1.0],
        0.0,
        &u,
        &obs,
        Rk45,
        &Options::default().rtol(1e-10).atol(1e-12),
        &LsqOptions::default(),
    );
    match r {
        Err(Error::FitFailed { reason, .. }) => assert!(reason.contains("no step"), "{reason}"),
        other => panic!("expected FitFailed, got {other:?}"),
    }
}

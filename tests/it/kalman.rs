//! Kalman filter, EKF step Jacobians, and the underwater SLAM scenario.

use nalgebra::{DMatrix, DVector, Matrix1, Matrix2, Matrix3, SVector, Vector1, Vector2, Vector3, vector};
use num_dual::DualNum;
use reckon::kalman::slam::{run, synthetic};
use reckon::kalman::step::{Discretization, flow_jacobian, step_jacobian};
use reckon::kalman::{Kalman, confidence_ellipse, mahalanobis2};
use reckon::methods::{Euler, ImplicitEuler, Method, Rk45};
use reckon::vehicles::{body3d, carlike, unicycle};
use reckon::{Controls, Error, Options, Problem, System};

/// Velocity noise σ_v = 1 m/s per axis, dt = 0.1 s: after one hour σ = √(dt·t)·σ_v = 18.97 m.
#[test]
fn dead_reckoning_covariance_after_one_hour() {
    let (dt, sv): (f64, f64) = (0.1, 1.0);
    let mut k = Kalman::new(Vector2::zeros(), Matrix2::zeros());
    let q = Matrix2::identity() * (dt * sv).powi(2);
    for _ in 0..36_000 {
        k.predict(&Matrix2::identity(), &Vector2::new(0.1, 0.0), &q).unwrap();
    }
    let sigma = k.p[(0, 0)].sqrt();
    assert!((sigma - (dt * 3600.0f64).sqrt() * sv).abs() < 1e-9, "σ = {sigma}");
    assert!((sigma - 18.97).abs() < 0.005);
    assert!((k.x[0] - 3600.0).abs() < 1e-8);
}

#[test]
fn correction_matches_the_closed_form_and_joseph_keeps_symmetry() {
    // scalar: prior N(1, 4), measurement 3 with variance 1 → posterior mean 1 + 4/5·2, variance 4/5
    let mut k = Kalman::new(Vector1::new(1.0), Matrix1::new(4.0));
    let inn = k
        .correct(&Vector1::new(3.0), &Matrix1::new(1.0), &Matrix1::new(1.0))
        .unwrap();
    assert!((k.x[0] - 2.6).abs() < 1e-15 && (k.p[(0, 0)] - 0.8).abs() < 1e-15);
    assert!((inn.y[0] - 2.0).abs() < 1e-15 && (inn.s[(0, 0)] - 5.0).abs() < 1e-15);
    assert!((inn.nis() - 0.8).abs() < 1e-15);
    // 3-D, correlated prior, partial observation
    let p = Matrix3::new(2.0, 0.5, 0.1, 0.5, 1.0, 0.2, 0.1, 0.2, 3.0);
    let mut k = Kalman::new(Vector3::new(0.0, 1.0, 2.0), p);
    let c = nalgebra::Matrix2x3::new(1.0, 0.0, 1.0, 0.0, 1.0, 0.0);
    let r = Matrix2::new(0.5, 0.1, 0.1, 0.4);
    k.correct(&Vector2::new(1.0, 0.0), &c, &r).unwrap();
    // against the textbook form Γ⁺ = Γ − K C Γ
    let s = c * p * c.transpose() + r;
    let gain = p * c.transpose() * s.try_inverse().unwrap();
    let p_plus = p - gain * c * p;
    assert!((k.p - p_plus).amax() < 1e-14);
    assert_eq!(k.p, k.p.transpose());
    assert!(k.p.symmetric_eigen().eigenvalues.min() > 0.0);
}

#[test]
fn dimension_mismatches_are_errors() {
    let mut k = Kalman::new(DVector::zeros(3), DMatrix::identity(3, 3));
    assert!(
        k.predict(&DMatrix::identity(2, 2), &DVector::zeros(3), &DMatrix::zeros(3, 3))
            .is_err()
    );
    assert!(
        k.correct(&DVector::zeros(1), &DMatrix::zeros(1, 2), &DMatrix::identity(1, 1))
            .is_err()
    );
    assert!(
        k.correct(&DVector::zeros(2), &DMatrix::zeros(2, 3), &DMatrix::identity(1, 1))
            .is_err()
    );
    let mut sc = synthetic(1);
    sc.detections.push(reckon::kalman::slam::Detection {
        sample: 0,
        landmark: 99,
        range: 10.0,
    });
    assert!(run(&sc).is_err());
}

#[test]
fn singular_innovation_covariance_is_an_error() {
    let mut k = Kalman::new(Vector2::zeros(), Matrix2::zeros());
    let r = k.correct(
        &Vector1::new(1.0),
        &nalgebra::Matrix1x2::new(1.0, 0.0),
        &Matrix1::new(0.0),
    );
    assert_eq!(
        r.unwrap_err(),
        Error::NotPositiveDefinite {
            what: "innovation covariance S"
        }
    );
}

#[test]
fn confidence_ellipse_scale() {
    let a90 = (-2.0 * (0.1f64).ln()).sqrt();
    assert!((a90 - 2.1459660262893476).abs() < 1e-15);
    let p = Matrix2::new(3.0, 1.0, 1.0, 2.0);
    let (r1, r2, ang) = confidence_ellipse(&p, 0.9);
    // the ellipse's boundary point along its first axis has Mahalanobis² = a²
    let x = Vector2::new(r1 * ang.cos(), r1 * ang.sin());
    assert!((mahalanobis2(&x, &Vector2::zeros(), &p) - a90 * a90).abs() < 1e-12);
    assert!((r1 * r2 - a90 * a90 * p.determinant().sqrt()).abs() < 1e-12);
}

/// The f64 step map of a method, run through the integrator, for central differences.
fn step_f64<const N: usize, S: System<nalgebra::Const<N>>, M: Method<nalgebra::Const<N>>>(
    sys: &S,
    m: M,
    x: SVector<f64, N>,
    u: &[f64],
    h: f64,
) -> SVector<f64, N> {
    let c = Controls::new(vec![0.0], vec![u.to_vec()]).unwrap();
    let p = Problem::new(sys, x, (0.0, h)).controls(c);
    *p.solve(m, &Options::default().fixed(h).rtol(1e-13).atol(1e-15))
        .unwrap()
        .last()
        .1
}

fn central<const N: usize>(
    f: impl Fn(SVector<f64, N>) -> SVector<f64, N>,
    x: SVector<f64, N>,
) -> nalgebra::SMatrix<f64, N, N> {
    let mut j = nalgebra::SMatrix::<f64, N, N>::zeros();
    for c in 0..N {
        let d = 1e-6 * x[c].abs().max(1.0);
        let (mut a, mut b) = (x, x);
        a[c] += d;
        b[c] -= d;
        j.set_column(c, &((f(a) - f(b)) / (2.0 * d)));
    }
    j
}

/// A = ∂φ_h/∂x by autodiff through the step equals central differences of the f64 step
/// for every discretisation, on the car-like model.
#[test]
fn step_jacobians_match_central_differences() {
    let sys = carlike::model(2.5);
    let x = vector![1.0, -0.5, 0.7, 0.2];
    let u = [3.0, 0.4];
    let h = 0.2;
    type StepFn<'a> = Box<dyn Fn(SVector<f64, 4>) -> SVector<f64, 4> + 'a>;
    let cases: [(Discretization, StepFn); 3] = [
        (Discretization::Euler, Box::new(|x| step_f64(&sys, Euler, x, &u, h))),
        (Discretization::Rk45, Box::new(|x| step_f64(&sys, Rk45, x, &u, h))),
        (
            Discretization::ImplicitEuler,
            Box::new(|x| step_f64(&sys, ImplicitEuler::default(), x, &u, h)),
        ),
    ];
    for (disc, f) in cases {
        let (x1, a) = step_jacobian(&sys, disc, 0.0, &x, &u, h).unwrap();
        assert!((x1 - f(x)).amax() < 1e-12, "{disc:?}: step value");
        let fd = central(&f, x);
        assert!((a - fd).amax() < 1e-7, "{disc:?}: autodiff\n{a}\ncentral\n{fd}");
    }
    // the Euler step's Jacobian in closed form: I + h·J(x)
    let (_, a) = step_jacobian(&sys, Discretization::Euler, 0.0, &x, &u, h).unwrap();
    let mut j = nalgebra::Matrix4::zeros();
    sys.jacobian(0.0, &x, &u, &mut j);
    assert!((a - (nalgebra::Matrix4::identity() + j * h)).amax() < 1e-15);
}

/// The exact unicycle arc written over a generic scalar: its Jacobian is exact.
#[test]
fn exact_flow_jacobian() {
    let (v, w, h) = (2.0, 0.5, 0.3);
    let dth = w * h;
    let d = v * h * unicycle::sinc(0.5 * dth);
    let flow = |x: &SVector<num_dual::DualSVec64<3>, 3>| {
        let m = x[2] + 0.5 * dth;
        vector![x[0] + m.cos() * d, x[1] + m.sin() * d, x[2] + dth]
    };
    let x = vector![0.1, 0.2, 0.3];
    let (x1, a) = flow_jacobian(flow, &x);
    assert_eq!(x1, unicycle::flow(0.0, &x, &[v, w], h));
    let m = 0.3 + 0.5 * dth;
    assert!((a[(0, 2)] + d * m.sin()).abs() < 1e-15 && (a[(1, 2)] - d * m.cos()).abs() < 1e-15);
}

/// The synthetic underwater survey: every landmark is detected, every true landmark lies
/// inside its 99% confidence ellipse, and SLAM beats dead reckoning.
#[test]
fn underwater_slam_on_synthetic_data() {
    let sc = synthetic(42);
    assert!(sc.t.len() > 5000);
    for j in 0..sc.landmarks.len() {
        assert!(
            sc.detections.iter().any(|d| d.landmark == j),
            "landmark {j} never detected"
        );
    }
    let out = run(&sc).unwrap();
    let chi2_99 = -2.0 * (0.01f64).ln();
    for (j, ((m, p), truth)) in out.landmarks.iter().zip(&sc.landmarks).enumerate() {
        let d2 = mahalanobis2(truth, m, p);
        assert!(
            d2 <= chi2_99,
            "landmark {j}: Mahalanobis² {d2} > {chi2_99}; estimate {m} truth {truth}"
        );
        assert!((m - truth).norm() < 5.0, "landmark {j} off by {}", (m - truth).norm());
    }
    // the robot's estimate stays within 3σ of the truth per axis, at every sample
    for (s, (p, sig)) in out.positions.iter().zip(&out.position_sigma).enumerate() {
        let e = p - sc.truth[s];
        for i in 0..3 {
            assert!(
                e[i].abs() <= 4.0 * sig[i] + 1e-9,
                "sample {s} axis {i}: error {} σ {}",
                e[i],
                sig[i]
            );
        }
    }
    // dead reckoning alone (predictions only) for comparison
    let mut dr = sc.truth[0];
    for s in 0..sc.t.len() - 1 {
        let e = sc.euler[s];
        dr += body3d::rotation(e[0], e[1], e[2]) * sc.body_velocity[s] * sc.dt;
    }
    let slam_err = (out.positions.last().unwrap() - sc.truth.last().unwrap()).xy().norm();
    let dr_err = (dr - sc.truth.last().unwrap()).xy().norm();
    assert!(slam_err < dr_err, "SLAM {slam_err} vs dead reckoning {dr_err}");
    eprintln!("final horizontal error: SLAM {slam_err:.3} m, dead reckoning {dr_err:.3} m");
}

/// An EKF on a unicycle: noisy speed and turn-rate readings drive the prediction through
/// RK45 steps linearised by autodiff; position fixes every second correct it. The
/// normalised estimation error squared (NEES) averaged over the fixes is consistent
/// with its χ² expectation of 3.
#[test]
fn ekf_unicycle_with_position_fixes() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use reckon::kalman::step::ekf_predict;
    let mut nees_sum = 0.0;
    let mut count = 0;
    for seed in 0..20u64 {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let n = Normal::new(0.0, 1.0).unwrap();
        let (dt, sv, sw, sp) = (0.1, 0.1, 0.05, 0.5);
        let sys = unicycle::model();
        let mut truth = vector![0.0, 0.0, 0.0];
        let mut kf = Kalman::new(truth, Matrix3::identity() * 1e-6);
        // input noise (σ_v, σ_ω) maps into the state through B = ∂φ/∂u ≈ h·[cos θ, 0; sin θ, 0; 0, 1]
        for k in 0..600 {
            let t = k as f64 * dt;
            let (v, w) = (1.0 + 0.5 * (0.1 * t).sin(), 0.3 * (0.05 * t).cos());
            truth = unicycle::flow(t, &truth, &[v, w], dt);
            let (vm, wm) = (v + sv * n.sample(&mut rng), w + sw * n.sample(&mut rng));
            let th = kf.x[2];
            let b = nalgebra::Matrix3x2::new(dt * th.cos(), 0.0, dt * th.sin(), 0.0, 0.0, dt);
            let q = b * Matrix2::new(sv * sv, 0.0, 0.0, sw * sw) * b.transpose();
            ekf_predict(&mut kf, &sys, Discretization::Rk45, t, &[vm, wm], dt, &q).unwrap();
            if (k + 1) % 10 == 0 {
                let z = Vector2::new(truth[0] + sp * n.sample(&mut rng), truth[1] + sp * n.sample(&mut rng));
                let c = nalgebra::Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
                kf.correct(&z, &c, &(Matrix2::identity() * sp * sp)).unwrap();
                let e = kf.x - truth;
                nees_sum += e.dot(&(kf.p.try_inverse().unwrap() * e));
                count += 1;
            }
        }
    }
    let nees = nees_sum / count as f64;
    eprintln!("average NEES over {count} fixes: {nees:.3}");
    // 1200 fixes: the mean of χ²₃ has standard deviation √(6/1200) ≈ 0.07; allow for the
    // linearisation and the correlation between successive fixes
    assert!((nees - 3.0).abs() < 0.6, "average NEES {nees}");
}

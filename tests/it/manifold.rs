//! Uncertainty on the manifold (`kalman::manifold`) against Monte Carlo: a turning
//! unicycle whose heading becomes uncertain enough (σ_θ ≈ 0.4 rad) that its pose cloud is
//! a banana. 10⁵ poses are stepped exactly on SE(2) with noisy twists; the tangent-space
//! Gaussian (`g = ḡ·Exp(ξ)`) predicted with the same increments and noise describes the
//! cloud (average NEES within 5 % of 3), the EKF on `(x, y, θ)` with the same noise does
//! not. Then the same on SE(3) for a body on a noisy helix.

use nalgebra::{Matrix3, Matrix6, SMatrix, SVector, Vector3, Vector6, vector};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};
use reckon::kalman::manifold::{LieGroup, Se2Gaussian, Se3Gaussian, TangentGaussian};
use reckon::lie::{Se2, Se3};
use std::f64::consts::{PI, TAU};

/// Speed (m/s), turn rate (rad/s), step (s), steps.
const V: f64 = 1.0;
const W: f64 = 0.3;
const DT: f64 = 0.05;
const STEPS: usize = 200;
/// Per-step noise on the speed and the turn rate (standard deviations of `v`, `ω` held
/// over one step): σ_θ at the end is `SIGMA_W·DT·√STEPS` = 0.42 rad.
const SIGMA_V: f64 = 0.2;
const SIGMA_W: f64 = 0.6;
const MEMBERS: usize = 100_000;

/// The figures of one run: average NEES of the cloud against the tangent Gaussian and
/// against the vector EKF, and the fractions of the cloud inside each one's 95 % χ²₃
/// region (ε ≤ 7.8147).
#[derive(Debug)]
pub struct Figures {
    pub tangent_nees: f64,
    pub vector_nees: f64,
    pub tangent_inside_95: f64,
    pub vector_inside_95: f64,
    pub heading_sigma: f64,
}

fn wrap(a: f64) -> f64 {
    a - TAU * (a / TAU).round()
}

/// 10⁵ poses stepped exactly on SE(2) with noisy twists (speed and turn-rate σ's per
/// step), and the tangent Gaussian predicted with the same increments and noise.
pub fn cloud(sigma_v: f64, sigma_w: f64) -> (Vec<Se2>, Se2Gaussian) {
    let u = vector![V * DT, 0.0, W * DT];
    let q = Matrix3::from_diagonal(&vector![(sigma_v * DT).powi(2), 0.0, (sigma_w * DT).powi(2)]);
    // the cloud: exact SE(2) steps on noisy twists
    let mut rng = StdRng::seed_from_u64(37);
    let cloud: Vec<Se2> = (0..MEMBERS)
        .map(|_| {
            let mut g = Se2::identity();
            for _ in 0..STEPS {
                let (a, b): (f64, f64) = (StandardNormal.sample(&mut rng), StandardNormal.sample(&mut rng));
                let n = vector![sigma_v * DT * a, 0.0, sigma_w * DT * b];
                g = g.compose(&Se2::exp(&(u + n)));
            }
            g
        })
        .collect();

    // the tangent-space Gaussian
    let mut k = Se2Gaussian::new(Se2::identity(), Matrix3::zeros()).unwrap();
    for _ in 0..STEPS {
        k.predict(&u, &q).unwrap();
    }

    (cloud, k)
}

/// The Monte-Carlo cloud, the tangent Gaussian and the vector EKF after `STEPS` steps,
/// with the noise σ's times `scale`.
pub fn unicycle(scale: f64) -> Figures {
    let (sigma_v, sigma_w) = (SIGMA_V * scale, SIGMA_W * scale);
    let u = vector![V * DT, 0.0, W * DT];
    let q = Matrix3::from_diagonal(&vector![(sigma_v * DT).powi(2), 0.0, (sigma_w * DT).powi(2)]);

    let (cloud, k) = cloud(sigma_v, sigma_w);

    // the EKF on (x, y, θ): the mean by the same exact step; A = ∂f/∂x of
    // f(x, u) = pose(x)·Exp(u) is [[1, 0, −Δy], [0, 1, Δx], [0, 0, 1]] with (Δx, Δy) the
    // step's world displacement, and ∂f/∂u = diag(R(θ'), 1)·J_r(u) (the world-frame
    // derivative of pose·Exp(u)), so the step's noise is that times Q times its transpose.
    let (mut x, mut p) = (Vector3::zeros(), Matrix3::zeros());
    for _ in 0..STEPS {
        let g = Se2::new(x[2], x.fixed_rows::<2>(0).into_owned()).compose(&Se2::exp(&u));
        let next = vector![g.translation.x, g.translation.y, x[2] + u[2]];
        let a = Matrix3::new(1.0, 0.0, -(next[1] - x[1]), 0.0, 1.0, next[0] - x[0], 0.0, 0.0, 1.0);
        let r = g.rotation();
        let t = Matrix3::new(r[(0, 0)], r[(0, 1)], 0.0, r[(1, 0)], r[(1, 1)], 0.0, 0.0, 0.0, 1.0);
        let gu = t * Se2::right_jacobian(&u);
        p = a * p * a.transpose() + gu * q * gu.transpose();
        x = next;
    }
    // both means are the noise-free path
    assert!((k.mean.translation - x.fixed_rows::<2>(0)).norm() < 1e-12);
    assert!(wrap(k.mean.angle() - x[2]).abs() < 1e-12);

    let chi2_95 = 7.814727903251178;
    let pinv = p.try_inverse().unwrap();
    let (mut tn, mut vn, mut tin, mut vin) = (0.0, 0.0, 0usize, 0usize);
    for g in &cloud {
        let e = k.nees(g).unwrap();
        let d = vector![g.translation.x - x[0], g.translation.y - x[1], wrap(g.angle() - x[2])];
        let ev = d.dot(&(pinv * d));
        tn += e;
        vn += ev;
        tin += usize::from(e <= chi2_95);
        vin += usize::from(ev <= chi2_95);
    }
    let m = MEMBERS as f64;
    Figures {
        tangent_nees: tn / m,
        vector_nees: vn / m,
        tangent_inside_95: tin as f64 / m,
        vector_inside_95: vin as f64 / m,
        heading_sigma: k.cov[(2, 2)].sqrt(),
    }
}

/// One large increment `u` with noise σ's `sig` per component, 10⁵ members: the average
/// NEES of `Exp(u + n)` against `Exp(u)` with `P = J_r(u)·Q·J_r(u)ᵀ`. Far from the
/// identity `J_r(u)` is far from `I` (with `J_r = I` the NEES is off by a factor of
/// several), so this checks the noise term of the prediction, which the many small steps
/// above hardly exercise.
pub fn one_step<G: LieGroup<N>, const N: usize>(u: SVector<f64, N>, sig: SVector<f64, N>, seed: u64) -> f64 {
    let q = SMatrix::<f64, N, N>::from_diagonal(&sig.component_mul(&sig));
    let id = G::exp(&SVector::zeros());
    let mut k = TangentGaussian::new(id, SMatrix::zeros()).unwrap();
    k.predict(&u, &q).unwrap();
    let mut rng = StdRng::seed_from_u64(seed);
    let mut total = 0.0;
    for _ in 0..MEMBERS {
        let n = SVector::<f64, N>::from_fn(|i, _| sig[i] * Distribution::<f64>::sample(&StandardNormal, &mut rng));
        total += k.nees(&G::exp(&(u + n))).unwrap();
    }
    total / MEMBERS as f64
}

/// The correction's retraction and covariance reset, isolated: a prior `ḡ`, `P` (the
/// banana's), a measurement of the tangent error itself, `z = ξ + β`, `β ~ N(0, R)`
/// (`H = I`, linear, so the posterior in the prior's tangent is exactly
/// `N(m, P⁺)`, `P⁺ = (P⁻¹ + R⁻¹)⁻¹`, `m = P⁺R⁻¹z`, computed here in information form).
/// 10⁵ poses `ḡ·Exp(ξ_i)`, `ξ_i ~ N(m, P⁺)`, are the exact posterior; returns their
/// average NEES against the corrected Gaussian and against the same without the reset
/// `J_r(δξ)`, and the largest differences of the corrected mean's tangent from `m` and
/// of `P` from `J_r(m)·P⁺·J_r(m)ᵀ`.
pub fn reset(z: Vector3<f64>, r: Matrix3<f64>) -> (f64, f64, f64, f64) {
    let prior = unicycle_prior();
    let p0 = prior.cov;
    let mut k = prior;
    k.correct(&z, &Matrix3::identity(), &r).unwrap();
    let ri = r.try_inverse().unwrap();
    let p_plus = (p0.try_inverse().unwrap() + ri).try_inverse().unwrap();
    let m = p_plus * ri * z;
    let jr = Se2::right_jacobian(&m);
    let mean_err = (prior.error(&k.mean) - m).amax();
    let cov_err = (k.cov - jr * p_plus * jr.transpose()).amax() / k.cov.amax();
    let unreset = Se2Gaussian::new(k.mean, p_plus).unwrap();
    let l = p_plus.cholesky().unwrap().l();
    let mut rng = StdRng::seed_from_u64(7);
    let (mut e, mut e0) = (0.0, 0.0);
    for _ in 0..MEMBERS {
        let n = Vector3::from_fn(|_, _| Distribution::<f64>::sample(&StandardNormal, &mut rng));
        let g = prior.mean.compose(&Se2::exp(&(m + l * n)));
        e += k.nees(&g).unwrap();
        e0 += unreset.nees(&g).unwrap();
    }
    let n = MEMBERS as f64;
    (e / n, e0 / n, mean_err, cov_err)
}

/// The banana's predicted Gaussian (no sampling).
fn unicycle_prior() -> Se2Gaussian {
    let u = vector![V * DT, 0.0, W * DT];
    let q = Matrix3::from_diagonal(&vector![(SIGMA_V * DT).powi(2), 0.0, (SIGMA_W * DT).powi(2)]);
    let mut k = Se2Gaussian::new(Se2::identity(), Matrix3::zeros()).unwrap();
    for _ in 0..STEPS {
        k.predict(&u, &q).unwrap();
    }
    k
}

/// The average NEES of a cloud of 2·10⁴ bodies on a noisy helix against the SE(3)
/// tangent Gaussian, with the heading σ about z reaching ≈ 0.35 rad.
pub fn helix() -> f64 {
    let (steps, members, dt) = (100usize, 20_000usize, 0.05);
    let u = Vector6::new(0.02, 0.0, 0.4, 1.0, 0.0, 0.2) * dt;
    let sig = Vector6::new(0.15, 0.15, 0.7, 0.2, 0.05, 0.05) * dt;
    let q = Matrix6::from_diagonal(&sig.component_mul(&sig));
    let mut rng = StdRng::seed_from_u64(3737);
    let mut k = Se3Gaussian::new(Se3::identity(), Matrix6::zeros()).unwrap();
    for _ in 0..steps {
        k.predict(&u, &q).unwrap();
    }
    let mut total = 0.0;
    for _ in 0..members {
        let mut g = Se3::identity();
        for _ in 0..steps {
            let n = Vector6::from_fn(|i, _| sig[i] * Distribution::<f64>::sample(&StandardNormal, &mut rng));
            g = g.compose(&Se3::exp(&(u + n)));
        }
        total += k.nees(&g).unwrap();
    }
    total / members as f64
}

/// Measured (seeded, 2026-12-07): heading σ 0.424 rad; average NEES 3.192 against the
/// tangent Gaussian (93.3 % inside its 95 % region) and 4.093 against the vector EKF
/// (87.6 %). Neither is the χ²₃ band of 10⁵ samples (3 ± 0.031, four standard errors of
/// √(6/10⁵)): the tangent Gaussian is first order, and its excess is the second-order
/// term, which falls as σ² (0.192 at this noise, 0.042 at half, 0.005 at a quarter, the
/// next test); the bound is 8 % (3.25) on the tangent NEES and 30 % above 3 for the vector
/// EKF, with 36 % measured.
#[test]
fn tangent_gaussian_holds_the_banana_and_the_vector_ekf_does_not() {
    let start = std::time::Instant::now();
    let f = unicycle(1.0);
    eprintln!(
        "SE(2) unicycle, {MEMBERS} members, {STEPS} steps: {f:?} in {:?}",
        start.elapsed()
    );
    assert!((f.heading_sigma - SIGMA_W * DT * (STEPS as f64).sqrt()).abs() < 1e-12);
    assert!(f.heading_sigma > 0.4 && f.heading_sigma < PI / 4.0);
    assert!(
        f.tangent_nees > 3.0 && f.tangent_nees < 3.25,
        "tangent NEES {}",
        f.tangent_nees
    );
    assert!(f.tangent_inside_95 > 0.925, "{}", f.tangent_inside_95);
    assert!(f.vector_nees > 3.9, "vector NEES {}", f.vector_nees);
    assert!(f.vector_inside_95 < 0.89, "{}", f.vector_inside_95);
}

/// A quarter of the noise (heading σ 0.106 rad): the tangent Gaussian's NEES is inside
/// the χ²₃ band of 10⁵ samples, 3 ± 0.031 (measured 3.005, 95.05 % inside the 95 %
/// region), the vector EKF's still outside (measured 3.063).
#[test]
fn tangent_gaussian_is_in_the_chi2_band_at_small_noise() {
    let f = unicycle(0.25);
    eprintln!("SE(2) unicycle, noise / 4: {f:?}");
    assert!((f.heading_sigma - 0.25 * SIGMA_W * DT * (STEPS as f64).sqrt()).abs() < 1e-12);
    assert!((f.tangent_nees - 3.0).abs() < 0.031, "tangent NEES {}", f.tangent_nees);
    assert!((f.tangent_inside_95 - 0.95).abs() < 0.003, "{}", f.tangent_inside_95);
    assert!(f.vector_nees > 3.04, "vector NEES {}", f.vector_nees);
    assert!(f.vector_inside_95 < 0.947, "{}", f.vector_inside_95);
}

/// One large increment with small noise (σ = 0.02 on every component): the NEES is in
/// the χ² band (measured 3.0015 on SE(2), 6.0154 on SE(3); bands 3 ± 0.031 and
/// 6 ± 0.044). With `J_r(u)` replaced by `I` the SE(2) figure is 3.60.
#[test]
fn one_large_increment_through_the_right_jacobian() {
    let se2 = one_step::<Se2, 3>(vector![2.0, 0.5, 1.5], Vector3::repeat(0.02), 1);
    let se3 = one_step::<Se3, 6>(Vector6::new(0.5, -0.3, 1.2, 1.0, 2.0, -0.5), Vector6::repeat(0.02), 2);
    eprintln!("one step: SE(2) NEES {se2}, SE(3) NEES {se3}");
    assert!((se2 - 3.0).abs() < 0.031, "{se2}");
    assert!((se3 - 6.0).abs() < 0.044, "{se3}");
}

/// The correction against the exact posterior of a measurement linear in `ξ`
/// (`z = (2, 1, 0.6)`, `R = diag(0.04, 0.04, 0.01)` on the banana's prior): the mean and
/// covariance are the information-form ones retracted and moved by `J_r(m)` (to 10⁻¹²),
/// and the exact posterior's NEES is in the χ²₃ band (measured 3.0021); without the
/// reset it is 3.199.
#[test]
fn correction_retracts_and_resets_the_covariance() {
    let (with, without, mean_err, cov_err) = reset(
        vector![2.0, 1.0, 0.6],
        Matrix3::from_diagonal(&vector![0.04, 0.04, 0.01]),
    );
    eprintln!("correction: NEES {with} (without the reset {without}), mean {mean_err:e}, cov {cov_err:e}");
    assert!(mean_err < 1e-12 && cov_err < 1e-12, "{mean_err} {cov_err}");
    assert!((with - 3.0).abs() < 0.031, "{with}");
    assert!(without > 3.1, "{without}");
}

/// SE(3): 2·10⁴ bodies on a noisy helix, 100 steps, yaw σ 0.35 rad: average NEES 6.219
/// (χ²₆ band 6 ± 0.098): first order again, 3.7 % above; bound 5 %.
#[test]
fn se3_tangent_gaussian_matches_a_helix_cloud() {
    let start = std::time::Instant::now();
    let nees = helix();
    eprintln!("SE(3) helix: average NEES {nees} in {:?}", start.elapsed());
    assert!((nees - 6.0).abs() < 0.3, "{nees}");
}

//! Inertial dead reckoning in 2-D (gyro z, body accelerations) and 3-D (strapdown:
//! gyro rates as exact rotations, gravity removal, bias correction).
//!
//! Frames: world z up, gravity `g = (0, 0, −9.81)`; an accelerometer measures the
//! specific force `f = Rᵀ(a − g)`, so a level IMU at rest reads `(0, 0, +9.81)`.

use crate::error::{Error, Result};
use crate::methods::Rk45;
use crate::{Controls, Options, Problem, Solution};
use nalgebra::{Const, Matrix3, Vector3, Vector5};

/// Standard gravity (m/s²).
pub const GRAVITY: f64 = 9.81;

/// Planar IMU kinematics: state `(x, y, θ, v_x, v_y)` (world velocity), inputs
/// `(ω, a_x, a_y)` in the body frame: `θ' = ω`, `v' = R(θ)·a_b`, `p' = v`.
pub fn model_2d() -> impl crate::DualSystem<Const<5>> + Clone {
    crate::model!(|_t, s: [S; 5], u: [3]| {
        let (c, sn) = (s[2].cos(), s[2].sin());
        nalgebra::vector![s[3], s[4], S::from(u[0]), c * u[1] - sn * u[2], sn * u[1] + c * u[2]]
    })
}

/// Dead-reckon planar IMU samples `(t, ω, a_x, a_y)` (each held until the next; the last
/// sample's time is the end) from `x0`, after subtracting `bias = (b_ω, b_ax, b_ay)`.
/// Integrated with RK45 at 1e-10 so that the result is the exact consequence of the data,
/// keeping the dense output: [`Solution::at`](crate::Solution::at) gives the state at any time.
///
/// ```
/// use reckon::reckoning::imu::dead_reckon_2d;
/// use nalgebra::Vector5;
/// // constant forward acceleration 1 m/s² for 2 s: x = ½·1·2² = 2
/// let sol = dead_reckon_2d(&[(0.0, 0.0, 1.0, 0.0), (2.0, 0.0, 0.0, 0.0)], Vector5::zeros(), [0.0; 3]).unwrap();
/// assert!((sol.last().1[0] - 2.0).abs() < 1e-9);
/// assert!((sol.at(1.0).unwrap()[0] - 0.5).abs() < 1e-9); // x = ½·1·1² halfway
/// ```
pub fn dead_reckon_2d(
    samples: &[(f64, f64, f64, f64)],
    x0: Vector5<f64>,
    bias: [f64; 3],
) -> Result<Solution<Const<5>>> {
    if samples.len() < 2 {
        return Err(Error::invalid("samples", "at least two IMU samples are needed"));
    }
    let times = samples.iter().map(|s| s.0).collect();
    let values = samples
        .iter()
        .map(|s| vec![s.1 - bias[0], s.2 - bias[1], s.3 - bias[2]])
        .collect();
    let controls = Controls::new(times, values)?;
    let span = (samples[0].0, samples[samples.len() - 1].0);
    Problem::new(model_2d(), x0, span)
        .controls(controls)
        .solve(Rk45, &Options::default().rtol(1e-10).atol(1e-10).dense(true))
}

/// Strapdown navigation state: attitude `R` (body → world), velocity, position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nav {
    /// Attitude, body to world.
    pub r: Matrix3<f64>,
    /// World velocity.
    pub v: Vector3<f64>,
    /// World position.
    pub p: Vector3<f64>,
}

impl Nav {
    /// At rest, level, at the origin.
    pub fn level() -> Self {
        Nav {
            r: Matrix3::identity(),
            v: Vector3::zeros(),
            p: Vector3::zeros(),
        }
    }
}

/// `exp([θ]×)` by Rodrigues' formula: the exact rotation by the angle vector `θ = ω·Δt`.
///
/// ```
/// use reckon::reckoning::imu::rotation_exp;
/// use nalgebra::vector;
/// let r = rotation_exp(&vector![0.0, 0.0, std::f64::consts::FRAC_PI_2]);
/// assert!((r * vector![1.0, 0.0, 0.0] - vector![0.0, 1.0, 0.0]).norm() < 1e-15);
/// ```
pub fn rotation_exp(theta: &Vector3<f64>) -> Matrix3<f64> {
    let a = theta.norm();
    let k = theta.cross_matrix();
    // sin a / a and (1 − cos a)/a² = 2 sin²(a/2)/a² (no cancellation), by series near 0
    let (s, c) = if a < 1e-4 {
        let a2 = a * a;
        (1.0 - a2 / 6.0, 0.5 - a2 / 24.0)
    } else {
        let h = (0.5 * a).sin() / a;
        (a.sin() / a, 2.0 * h * h)
    };
    Matrix3::identity() + k * s + k * k * c
}

/// One strapdown step with gyro rates `ω` and specific force `f` held over `dt`:
/// `R₁ = R·exp([ω dt]×)` (exact, re-orthonormalised), world accelerations `a = R f + g` at both ends, and
/// `v₁ = v + ½(a₀ + a₁)dt`, `p₁ = p + v dt + (2a₀ + a₁)dt²/6` (exact when `a` is linear in t).
pub fn strapdown_step(nav: &Nav, gyro: &Vector3<f64>, accel: &Vector3<f64>, dt: f64) -> Nav {
    let g = Vector3::new(0.0, 0.0, -GRAVITY);
    let r1 = nav.r * rotation_exp(&(gyro * dt));
    // one Newton–Schulz step, R ← R(3I − RᵀR)/2, keeps R orthonormal to rounding over
    // long runs (the product of many exact rotations drifts by ~n·ε otherwise)
    let r1 = r1 * (Matrix3::identity() * 3.0 - r1.transpose() * r1) * 0.5;
    let a0 = nav.r * accel + g;
    let a1 = r1 * accel + g;
    Nav {
        r: r1,
        v: nav.v + (a0 + a1) * (0.5 * dt),
        p: nav.p + nav.v * dt + (a0 * 2.0 + a1) * (dt * dt / 6.0),
    }
}

/// A 3-D IMU sample: time, gyro rates (rad/s), specific force (m/s²), both in the body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuSample {
    /// Time (s).
    pub t: f64,
    /// Angular rate.
    pub gyro: Vector3<f64>,
    /// Specific force.
    pub accel: Vector3<f64>,
}

/// Strapdown dead reckoning: each sample holds until the next; biases are subtracted.
/// Returns the state after each sample interval, starting with `init` at the first time.
///
/// ```
/// use reckon::reckoning::imu::{strapdown, ImuSample, Nav, GRAVITY};
/// use nalgebra::{vector, Vector3};
/// // a level IMU at rest reads (0, 0, g): it stays put
/// let s: Vec<ImuSample> = (0..=100).map(|k| ImuSample { t: k as f64 * 0.01, gyro: Vector3::zeros(), accel: vector![0.0, 0.0, GRAVITY] }).collect();
/// let out = strapdown(&s, Nav::level(), &Vector3::zeros(), &Vector3::zeros()).unwrap();
/// assert!(out.last().unwrap().1.p.norm() < 1e-12);
/// ```
pub fn strapdown(
    samples: &[ImuSample],
    init: Nav,
    gyro_bias: &Vector3<f64>,
    accel_bias: &Vector3<f64>,
) -> Result<Vec<(f64, Nav)>> {
    let mut out = Vec::with_capacity(samples.len());
    let Some(first) = samples.first() else {
        return Err(Error::invalid("samples", "no IMU samples"));
    };
    let mut nav = init;
    out.push((first.t, nav));
    for w in samples.windows(2) {
        let dt = w[1].t - w[0].t;
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(Error::invalid(
                "samples",
                format!("time does not increase at t = {}", w[1].t),
            ));
        }
        nav = strapdown_step(&nav, &(w[0].gyro - gyro_bias), &(w[0].accel - accel_bias), dt);
        if !(nav.p.iter().chain(nav.v.iter()).all(|v| v.is_finite())) {
            return Err(Error::NonFinite {
                t: w[1].t,
                quantity: crate::error::Quantity::State,
                component: 0,
            });
        }
        out.push((w[1].t, nav));
    }
    Ok(out)
}

/// Roll, pitch, yaw `(φ, θ, ψ)` of `R = Rz(ψ)Ry(θ)Rx(φ)`, or
/// [`Error::PitchSingularity`] within 1e-6 rad of ±90° pitch, where roll and yaw
/// cannot be told apart.
///
/// ```
/// use reckon::vehicles::body3d::rotation;
/// use reckon::reckoning::imu::euler_angles;
/// let (r, p, y) = euler_angles(&rotation(0.1, -0.4, 2.0), 0.0).unwrap();
/// assert!((r - 0.1).abs() < 1e-14 && (p + 0.4).abs() < 1e-14 && (y - 2.0).abs() < 1e-14);
/// assert!(euler_angles(&rotation(0.1, std::f64::consts::FRAC_PI_2, 2.0), 3.0).is_err());
/// ```
pub fn euler_angles(r: &Matrix3<f64>, t: f64) -> Result<(f64, f64, f64)> {
    let sp = (-r[(2, 0)]).clamp(-1.0, 1.0);
    let pitch = sp.asin();
    let cp = (r[(0, 0)].powi(2) + r[(1, 0)].powi(2)).sqrt();
    if cp < 1e-6 {
        return Err(Error::PitchSingularity { t, pitch });
    }
    Ok((r[(2, 1)].atan2(r[(2, 2)]), pitch, r[(1, 0)].atan2(r[(0, 0)])))
}

/// IMU error model: constant biases and white noise, reproducible with a seed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuErrors {
    /// Gyro bias (rad/s).
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub accel_bias: Vector3<f64>,
    /// Gyro white-noise σ per sample (rad/s).
    pub gyro_noise: f64,
    /// Accelerometer white-noise σ per sample (m/s²).
    pub accel_noise: f64,
    /// Seed of the random generator.
    pub seed: u64,
}

impl Default for ImuErrors {
    fn default() -> Self {
        ImuErrors {
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
            gyro_noise: 0.0,
            accel_noise: 0.0,
            seed: 0,
        }
    }
}

/// Measured samples from true ones: `ω̃ = ω + b_g + n_g`, `f̃ = f + b_a + n_a`.
///
/// ```
/// use reckon::reckoning::imu::{corrupt, ImuErrors, ImuSample};
/// use nalgebra::{vector, Vector3};
/// let truth = [ImuSample { t: 0.0, gyro: Vector3::zeros(), accel: vector![0.0, 0.0, 9.81] }];
/// let e = ImuErrors { gyro_bias: vector![0.01, 0.0, 0.0], ..Default::default() };
/// assert_eq!(corrupt(&truth, &e)[0].gyro, vector![0.01, 0.0, 0.0]);
/// ```
pub fn corrupt(samples: &[ImuSample], e: &ImuErrors) -> Vec<ImuSample> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand::rngs::StdRng::seed_from_u64(e.seed);
    let n = Normal::new(0.0, 1.0).expect("unit normal");
    let mut noise = |s: f64| Vector3::new(n.sample(&mut rng), n.sample(&mut rng), n.sample(&mut rng)) * s;
    samples
        .iter()
        .map(|s| ImuSample {
            t: s.t,
            gyro: s.gyro + e.gyro_bias + noise(e.gyro_noise),
            accel: s.accel + e.accel_bias + noise(e.accel_noise),
        })
        .collect()
}

//! Landmark SLAM for an underwater robot, with a deterministic synthetic data set.
//!
//! The robot (z up; the sea floor is the plane `z = seabed_z`) measures its Euler angles
//! and body velocities every sample (dead reckoning, `p' = R(φ,θ,ψ)·v_body`), its depth
//! with a pressure sensor every sample, and at detection times the range `r` to one
//! landmark lying on the floor, seen by a starboard side-scan sonar (abeam, to the
//! right). With the measured depth the range gives the horizontal distance
//! `d = √(r² − (z − z_floor)²)`, and the robot's yaw turns it into the landmark's
//! position relative to the robot, `m − p_xy = Rz(ψ)·(0, −d)` — a linear observation
//! of the state `(p_x, p_y, p_z, m₁ₓ, m₁ᵧ, …, m_Kₓ, m_Kᵧ)`.

use super::Kalman;
use crate::error::Result;
use crate::vehicles::body3d::rotation;
use nalgebra::{DMatrix, DVector, Matrix2, Vector2, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

/// One sonar detection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detection {
    /// Sample index at which the landmark is abeam.
    pub sample: usize,
    /// Which landmark.
    pub landmark: usize,
    /// Measured range (m).
    pub range: f64,
}

/// A synthetic run: sensor data and ground truth.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Sample period (s).
    pub dt: f64,
    /// Sample times.
    pub t: Vec<f64>,
    /// Measured Euler angles (φ, θ, ψ) per sample.
    pub euler: Vec<Vector3<f64>>,
    /// Measured body velocities per sample (held until the next sample).
    pub body_velocity: Vec<Vector3<f64>>,
    /// Measured depth (z) per sample.
    pub depth: Vec<f64>,
    /// Sonar detections in time order.
    pub detections: Vec<Detection>,
    /// True positions per sample.
    pub truth: Vec<Vector3<f64>>,
    /// True landmark positions (on the floor).
    pub landmarks: Vec<Vector2<f64>>,
    /// Floor height z.
    pub seabed_z: f64,
    /// Body-velocity noise σ (m/s per axis).
    pub sigma_velocity: f64,
    /// Depth noise σ (m).
    pub sigma_depth: f64,
    /// Range noise σ (m).
    pub sigma_range: f64,
}

/// A lawn-mower survey over six landmarks: legs along ±x, 40 m apart, at 1.5 m/s and
/// 10 m depth over a floor at z = −25 m, with small roll/pitch oscillations; noise
/// σ_v = 0.05 m/s, σ_depth = 0.1 m, σ_range = 0.5 m; reproducible with `seed`.
pub fn synthetic(seed: u64) -> Scenario {
    let mut rng = StdRng::seed_from_u64(seed);
    let n01 = Normal::new(0.0, 1.0).expect("unit normal");
    let (dt, speed, leg, spacing, legs) = (0.1, 1.5, 300.0, 40.0, 5);
    let (sv, sd, sr) = (0.05, 0.1, 0.5);
    let seabed_z = -25.0;
    let landmarks = vec![
        Vector2::new(60.0, -15.0),
        Vector2::new(170.0, 22.0),
        Vector2::new(250.0, 63.0),
        Vector2::new(90.0, 95.0),
        Vector2::new(210.0, 140.0),
        Vector2::new(40.0, 130.0),
    ];
    // yaw profile: legs east/west joined by half-turns of radius spacing/2
    let turn_time = std::f64::consts::PI * 0.5 * spacing / speed;
    let leg_time = leg / speed;
    let total = legs as f64 * leg_time + (legs - 1) as f64 * turn_time;
    let n = (total / dt).round() as usize;
    let mut sc = Scenario {
        dt,
        t: Vec::with_capacity(n + 1),
        euler: Vec::with_capacity(n + 1),
        body_velocity: Vec::with_capacity(n + 1),
        depth: Vec::with_capacity(n + 1),
        detections: Vec::new(),
        truth: Vec::with_capacity(n + 1),
        landmarks,
        seabed_z,
        sigma_velocity: sv,
        sigma_depth: sd,
        sigma_range: sr,
    };
    let mut p = Vector3::new(0.0, 0.0, -10.0);
    let mut prev_along: Vec<Option<f64>> = vec![None; sc.landmarks.len()];
    for k in 0..=n {
        let t = k as f64 * dt;
        // which part of the path: leg i (straight) or turn i (yaw rate ±speed/(spacing/2))
        let period = leg_time + turn_time;
        let i = (t / period).floor();
        let s = t - i * period;
        let base = if (i as i64) % 2 == 0 { 0.0 } else { std::f64::consts::PI };
        let yaw = if s < leg_time {
            base
        } else {
            // left turn (counter-clockwise) after eastward legs, right turn after westward ones
            let sign = if (i as i64) % 2 == 0 { 1.0 } else { -1.0 };
            base + sign * (s - leg_time) * speed / (0.5 * spacing)
        };
        let roll = 0.03 * (0.21 * t).sin();
        let pitch = 0.02 * (0.13 * t).cos();
        let w = 0.05 * (0.05 * t).sin(); // gentle heave
        let v_true = Vector3::new(speed, 0.0, w);
        sc.t.push(t);
        sc.truth.push(p);
        sc.euler.push(Vector3::new(roll, pitch, yaw));
        sc.body_velocity
            .push(v_true + Vector3::new(n01.sample(&mut rng), n01.sample(&mut rng), n01.sample(&mut rng)) * sv);
        sc.depth.push(p[2] + sd * n01.sample(&mut rng));
        // detections: a landmark crossing the starboard beam (along-track offset changes sign)
        let (sy, cy) = yaw.sin_cos();
        for (j, m) in sc.landmarks.iter().enumerate() {
            let rel = m - p.xy();
            let along = cy * rel[0] + sy * rel[1];
            let across = -sy * rel[0] + cy * rel[1]; // left positive
            if let Some(prev) = prev_along[j]
                && prev > 0.0
                && along <= 0.0
                && across < -5.0
                && across > -60.0
            {
                let r = (Vector3::new(m[0], m[1], seabed_z) - p).norm();
                sc.detections.push(Detection {
                    sample: k,
                    landmark: j,
                    range: r + sr * n01.sample(&mut rng),
                });
            }
            prev_along[j] = Some(along);
        }
        // exact flow over the sample with held angles and body velocity
        p += rotation(roll, pitch, yaw) * v_true * dt;
    }
    sc
}

/// The filter's output.
#[derive(Debug, Clone)]
pub struct SlamResult {
    /// Estimated robot positions per sample.
    pub positions: Vec<Vector3<f64>>,
    /// Robot position covariance diagonals per sample.
    pub position_sigma: Vec<Vector3<f64>>,
    /// Landmark estimates and their 2×2 covariances at the end.
    pub landmarks: Vec<(Vector2<f64>, Matrix2<f64>)>,
    /// The final joint estimate.
    pub estimate: Kalman<nalgebra::Dyn>,
}

/// Kalman predict/correct over the whole run (initial position known to 0.1 m, landmarks
/// unknown: mean 0, σ = 1000 m).
pub fn run(sc: &Scenario) -> Result<SlamResult> {
    let k = sc.landmarks.len();
    let len = sc.t.len();
    if len == 0
        || [sc.euler.len(), sc.body_velocity.len(), sc.depth.len(), sc.truth.len()]
            .iter()
            .any(|&l| l != len)
    {
        return Err(crate::Error::invalid(
            "scenario",
            "time, angle, velocity, depth and truth series differ in length",
        ));
    }
    if let Some(d) = sc
        .detections
        .iter()
        .find(|d| d.landmark >= k || d.sample >= len || d.range.is_nan() || d.range < 0.0)
    {
        return Err(crate::Error::invalid(
            "scenario",
            format!("detection {d:?} names no landmark or sample"),
        ));
    }
    let n = 3 + 2 * k;
    let mut p0 = DMatrix::identity(n, n) * 1e6;
    for i in 0..3 {
        p0[(i, i)] = 0.01;
    }
    let mut x0 = DVector::zeros(n);
    x0.fixed_rows_mut::<3>(0).copy_from(&sc.truth[0]);
    let mut kf = Kalman::new(x0, p0);
    let a = DMatrix::identity(n, n);
    // the position is x' = R·v with the measured v held over a sample: its error, σ_v per
    // axis and sample, is a white velocity error of density σ_v²·dt (isotropic, so R drops
    // out), and Q_d over dt comes from Van Loan's integral of the continuous model
    // (= (σ_v·dt)² per axis); the landmarks do not move
    let q_pos = super::discretise_noise(
        &nalgebra::Matrix3::zeros(),
        &nalgebra::Matrix3::identity(),
        &(nalgebra::Matrix3::identity() * (sc.sigma_velocity * sc.sigma_velocity * sc.dt)),
        sc.dt,
    )?;
    let mut q = DMatrix::zeros(n, n);
    q.view_mut((0, 0), (3, 3)).copy_from(&q_pos);
    let mut c_depth = DMatrix::zeros(1, n);
    c_depth[(0, 2)] = 1.0;
    let r_depth = DMatrix::from_element(1, 1, sc.sigma_depth.powi(2));
    let mut out = SlamResult {
        positions: Vec::with_capacity(sc.t.len()),
        position_sigma: Vec::with_capacity(sc.t.len()),
        landmarks: Vec::new(),
        estimate: kf.clone(),
    };
    let mut next_detection = 0;
    for s in 0..sc.t.len() {
        // corrections at this sample: depth, then any detection
        kf.correct(&DVector::from_element(1, sc.depth[s]), &c_depth, &r_depth)?;
        while next_detection < sc.detections.len() && sc.detections[next_detection].sample == s {
            let d = sc.detections[next_detection];
            next_detection += 1;
            let dz = kf.x[2] - sc.seabed_z;
            let horizontal = (d.range * d.range - dz * dz).max(0.0).sqrt();
            let (sy, cy) = sc.euler[s][2].sin_cos();
            // the landmark crossed the beam within the last sample: it is behind the robot
            // by an along-track offset uniform on [0, v·dt] (mean v·dt/2, variance (v·dt)²/12);
            // starboard: body (−v·dt/2, −d) rotated by yaw
            let step = sc.body_velocity[s.saturating_sub(1)][0] * sc.dt;
            let (ab, cb) = (-0.5 * step, -horizontal);
            let rel = Vector2::new(cy * ab - sy * cb, sy * ab + cy * cb);
            let mut c = DMatrix::zeros(2, n);
            c[(0, 0)] = -1.0;
            c[(1, 1)] = -1.0;
            c[(0, 3 + 2 * d.landmark)] = 1.0;
            c[(1, 4 + 2 * d.landmark)] = 1.0;
            // range noise maps to the horizontal distance by r/d (and depth noise by dz/d)
            let g = d.range / horizontal.max(1e-9);
            let var = (g * sc.sigma_range).powi(2) + (dz / horizontal.max(1e-9) * sc.sigma_depth).powi(2);
            let dir = Vector2::new(sy, -cy);
            let along = Vector2::new(cy, sy);
            let var_along = step * step / 12.0;
            let r = DMatrix::from_fn(2, 2, |i, j| var * dir[i] * dir[j] + var_along * along[i] * along[j]);
            kf.correct(&DVector::from_column_slice(rel.as_slice()), &c, &r)?;
        }
        out.positions.push(kf.x.fixed_rows::<3>(0).into_owned());
        out.position_sigma.push(Vector3::new(
            kf.p[(0, 0)].sqrt(),
            kf.p[(1, 1)].sqrt(),
            kf.p[(2, 2)].sqrt(),
        ));
        // predict to the next sample with the measured angles and body velocity
        let e = sc.euler[s];
        let mut u = DVector::zeros(n);
        u.fixed_rows_mut::<3>(0)
            .copy_from(&(rotation(e[0], e[1], e[2]) * sc.body_velocity[s] * sc.dt));
        if s + 1 < sc.t.len() {
            kf.predict(&a, &u, &q)?;
        }
    }
    out.landmarks = (0..k)
        .map(|j| {
            let i = 3 + 2 * j;
            (
                Vector2::new(kf.x[i], kf.x[i + 1]),
                Matrix2::new(kf.p[(i, i)], kf.p[(i, i + 1)], kf.p[(i + 1, i)], kf.p[(i + 1, i + 1)]),
            )
        })
        .collect();
    out.estimate = kf;
    Ok(out)
}

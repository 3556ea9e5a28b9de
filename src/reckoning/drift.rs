//! Drift studies: how odometry error grows with distance and with manoeuvres, as tables.

use super::encoder_sim::{Command, EncoderErrors, simulate};
use super::encoders::{DiffDrive, Update, odometry};
use crate::error::Result;
use nalgebra::Vector3;
use std::f64::consts::FRAC_PI_2;

/// Error of the odometry estimate after driving a distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriftRow {
    /// Distance driven (m).
    pub distance: f64,
    /// Error along the intended direction of travel (m), estimate − truth.
    pub longitudinal: f64,
    /// Error across it (m), estimate − truth (left positive).
    pub lateral: f64,
}

impl DriftRow {
    /// Lateral error as a percentage of the distance.
    pub fn lateral_percent(&self) -> f64 {
        100.0 * self.lateral / self.distance
    }
    /// Longitudinal error as a percentage of the distance.
    pub fn longitudinal_percent(&self) -> f64 {
        100.0 * self.longitudinal / self.distance
    }
}

/// A straight drive whose true heading is off by `heading_error` (rad) while the
/// estimate believes 0: lateral error `d·sin δ`, longitudinal `d(1 − cos δ)`.
/// A 1° error gives 1.745% (0.1745 m after 10 m).
///
/// ```
/// use reckon::reckoning::drift::heading_error_drift;
/// let rows = heading_error_drift(1f64.to_radians(), &[10.0]);
/// assert!((rows[0].lateral.abs() - 0.17452).abs() < 1e-5);
/// assert!((rows[0].lateral_percent().abs() - 1.7452).abs() < 1e-4);
/// ```
pub fn heading_error_drift(heading_error: f64, distances: &[f64]) -> Vec<DriftRow> {
    distances
        .iter()
        .map(|&d| {
            // truth: x = d cos δ, y = d sin δ; estimate (d, 0)
            DriftRow {
                distance: d,
                longitudinal: d - d * heading_error.cos(),
                lateral: -d * heading_error.sin(),
            }
        })
        .collect()
}

/// Straight-line drift: drive at `speed` and report the error at each of `distances`
/// (e.g. 1, 2, 5, 10 m) under the error model `e`.
pub fn straight_drift(
    robot: &DiffDrive,
    e: &EncoderErrors,
    distances: &[f64],
    speed: f64,
    dt: f64,
) -> Result<Vec<DriftRow>> {
    let max = distances.iter().copied().fold(0.0, f64::max);
    let cmd = [Command {
        v: speed,
        omega: 0.0,
        duration: max / speed,
    }];
    let run = simulate(robot, e, &cmd, dt, Vector3::zeros());
    let est = odometry(robot, &run.samples, Update::Exact)?;
    let mut rows = Vec::new();
    for &d in distances {
        // first sample at or past distance d (by time: t = d / v)
        let k = run
            .samples
            .iter()
            .position(|s| s.0 * speed >= d - 1e-9)
            .unwrap_or(run.samples.len() - 1);
        let diff = est[k].1 - run.truth[k];
        rows.push(DriftRow {
            distance: d,
            longitudinal: diff[0],
            lateral: diff[1],
        });
    }
    Ok(rows)
}

/// Return-position error of a closed path: the estimate comes back to the start; the
/// truth does not. Returns `(truth − estimate)` at the end, `(Δx, Δy, Δθ)`.
pub fn return_error(robot: &DiffDrive, e: &EncoderErrors, commands: &[Command], dt: f64) -> Result<Vector3<f64>> {
    let run = simulate(robot, e, commands, dt, Vector3::zeros());
    let est = odometry(robot, &run.samples, Update::Exact)?;
    let end = |v: &[Vector3<f64>]| v[v.len() - 1];
    Ok(end(&run.truth) - est[est.len() - 1].1)
}

/// Drive `length` forward, turn 180° on the spot, drive back.
pub fn drive_and_return(length: f64, speed: f64, turn_rate: f64) -> Vec<Command> {
    vec![
        Command {
            v: speed,
            omega: 0.0,
            duration: length / speed,
        },
        Command {
            v: 0.0,
            omega: turn_rate,
            duration: std::f64::consts::PI / turn_rate,
        },
        Command {
            v: speed,
            omega: 0.0,
            duration: length / speed,
        },
    ]
}

/// A right triangle with legs `a` (forward) and `b` (after a 90° left turn), back along
/// the hypotenuse, turning on the spot.
pub fn right_triangle(a: f64, b: f64, speed: f64, turn_rate: f64) -> Vec<Command> {
    let c = (a * a + b * b).sqrt();
    let turn = |angle: f64| Command {
        v: 0.0,
        omega: turn_rate,
        duration: angle / turn_rate,
    };
    vec![
        Command {
            v: speed,
            omega: 0.0,
            duration: a / speed,
        },
        turn(FRAC_PI_2),
        Command {
            v: speed,
            omega: 0.0,
            duration: b / speed,
        },
        turn(std::f64::consts::PI - (a / c).acos()),
        Command {
            v: speed,
            omega: 0.0,
            duration: c / speed,
        },
        turn(std::f64::consts::PI - (b / c).acos()),
    ]
}

/// A square of side `side` with 90° on-the-spot turns, counter-clockwise (left turns)
/// or clockwise.
pub fn square(side: f64, clockwise: bool, speed: f64, turn_rate: f64) -> Vec<Command> {
    let w = if clockwise { -turn_rate } else { turn_rate };
    (0..4)
        .flat_map(|_| {
            [
                Command {
                    v: speed,
                    omega: 0.0,
                    duration: side / speed,
                },
                Command {
                    v: 0.0,
                    omega: w,
                    duration: FRAC_PI_2 / turn_rate,
                },
            ]
        })
        .collect()
}

/// UMBmark (Borenstein & Feng 1996): the bidirectional square test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Umbmark {
    /// Return error (truth − estimate) of the clockwise run.
    pub cw: Vector3<f64>,
    /// Return error of the counter-clockwise run.
    pub ccw: Vector3<f64>,
}

impl Umbmark {
    /// `E_max,syst = max(r_cw, r_ccw)`, the distances of the two return errors.
    pub fn e_max_syst(&self) -> f64 {
        self.cw
            .fixed_rows::<2>(0)
            .norm()
            .max(self.ccw.fixed_rows::<2>(0).norm())
    }
}

/// Run the bidirectional square of side `side` under the error model `e`.
pub fn umbmark(
    robot: &DiffDrive,
    e: &EncoderErrors,
    side: f64,
    speed: f64,
    turn_rate: f64,
    dt: f64,
) -> Result<Umbmark> {
    Ok(Umbmark {
        cw: return_error(robot, e, &square(side, true, speed, turn_rate), dt)?,
        ccw: return_error(robot, e, &square(side, false, speed, turn_rate), dt)?,
    })
}

/// Position error of a stationary, level IMU whose biases are not corrected.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImuDriftRow {
    /// Time since start (s).
    pub t: f64,
    /// Simulated horizontal position error from the accelerometer bias alone (m).
    pub accel_simulated: f64,
    /// Closed form `½·b_a·t²`.
    pub accel_closed_form: f64,
    /// Simulated horizontal position error from the gyro bias alone (m).
    pub gyro_simulated: f64,
    /// Closed form `g·b_g·t³/6` (small-angle: the tilt `b_g t` leaks gravity).
    pub gyro_closed_form: f64,
}

/// Simulate a stationary level IMU sampled every `dt` with an accelerometer bias `b_a`
/// (m/s², x axis) and, separately, a gyro bias `b_g` (rad/s, x axis), dead-reckon it by
/// strapdown, and report position errors at `times` next to the closed forms.
pub fn imu_bias_drift(b_a: f64, b_g: f64, times: &[f64], dt: f64) -> Result<Vec<ImuDriftRow>> {
    use super::imu::{GRAVITY, ImuSample, Nav, strapdown};
    let end = times.iter().copied().fold(0.0, f64::max);
    let n = (end / dt).round() as usize;
    let run = |gyro: Vector3<f64>, accel: Vector3<f64>| {
        let samples: Vec<ImuSample> = (0..=n)
            .map(|k| ImuSample {
                t: k as f64 * dt,
                gyro,
                accel,
            })
            .collect();
        strapdown(&samples, Nav::level(), &Vector3::zeros(), &Vector3::zeros())
    };
    let level = Vector3::new(0.0, 0.0, GRAVITY);
    let acc = run(Vector3::zeros(), level + Vector3::new(b_a, 0.0, 0.0))?;
    let gyr = run(Vector3::new(b_g, 0.0, 0.0), level)?;
    Ok(times
        .iter()
        .map(|&t| {
            let k = ((t / dt).round() as usize).min(n);
            ImuDriftRow {
                t,
                accel_simulated: acc[k].1.p.fixed_rows::<2>(0).norm(),
                accel_closed_form: 0.5 * b_a * t * t,
                gyro_simulated: gyr[k].1.p.fixed_rows::<2>(0).norm(),
                gyro_closed_form: GRAVITY * b_g * t.powi(3) / 6.0,
            }
        })
        .collect())
}

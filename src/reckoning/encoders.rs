//! Differential-drive odometry from wheel-encoder pulse increments.
//!
//! Per sample: wheel distances `d_l = n_l·πD/N`, `d_r = n_r·πD/N` (D wheel diameter,
//! N pulses per revolution), travelled distance `Δs = (d_l + d_r)/2`, heading change
//! `Δθ = (d_r − d_l)/B` (B wheel separation). The pose update is one of three rules.

use crate::error::{Error, Result};
use crate::vehicles::unicycle;
use nalgebra::Vector3;

/// How a pose is advanced by `(Δs, Δθ)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Update {
    /// `x += Δs·cos(θ + Δθ/2)`: heading at the middle of the step; differs from the arc by `O(Δθ²)·Δs`.
    #[default]
    Midpoint,
    /// The circular arc: `x += Δs·sinc(Δθ/2)·cos(θ + Δθ/2)`; exact when the wheel speeds are constant over the sample.
    Exact,
    /// `x += Δs·cos θ`: heading at the start; differs from the arc by `O(Δθ)·Δs`.
    Euler,
}

impl std::str::FromStr for Update {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "midpoint" => Ok(Update::Midpoint),
            "exact" => Ok(Update::Exact),
            "euler" => Ok(Update::Euler),
            other => Err(Error::invalid(
                "update",
                format!("'{other}' is not one of midpoint, exact, euler"),
            )),
        }
    }
}

/// A differential-drive robot's encoder geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffDrive {
    /// Wheel diameter D in metres.
    pub wheel_diameter: f64,
    /// Distance B between the wheel contact points in metres.
    pub wheel_separation: f64,
    /// Encoder pulses per wheel revolution N.
    pub pulses_per_rev: f64,
}

impl DiffDrive {
    /// Validated geometry: every value finite and positive, and the derived distance per
    /// pulse `πD/N` and curvature scale `1/B` finite and positive (so a separation of
    /// `1e-320` or a diameter that underflows the per-pulse distance is refused).
    ///
    /// ```
    /// use reckon::reckoning::encoders::DiffDrive;
    /// assert!(DiffDrive::new(0.1, 0.5, 1024.0).is_ok());
    /// assert!(DiffDrive::new(0.1, 0.0, 1024.0).is_err());
    /// assert!(DiffDrive::new(0.1, 1e-320, 1024.0).is_err()); // 1/B overflows
    /// assert!(DiffDrive::new(1e-300, 0.5, 1e300).is_err()); // πD/N underflows to 0
    /// // πD/N overflows because N is tiny: N is the value blamed
    /// let e = DiffDrive::new(0.1, 0.5, 1e-320).unwrap_err();
    /// assert!(matches!(e, reckon::Error::InvalidInput { what: "pulses_per_rev", .. }), "{e}");
    /// ```
    pub fn new(wheel_diameter: f64, wheel_separation: f64, pulses_per_rev: f64) -> Result<Self> {
        for (what, v) in [
            ("wheel_diameter", wheel_diameter),
            ("wheel_separation", wheel_separation),
            ("pulses_per_rev", pulses_per_rev),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(what, format!("must be finite and positive, got {v}")));
            }
        }
        let robot = DiffDrive {
            wheel_diameter,
            wheel_separation,
            pulses_per_rev,
        };
        let k = robot.distance_per_pulse();
        if !k.is_normal() {
            // blame the factor that drove πD/N out of range: N for an overflow (a tiny
            // count per revolution) or an underflow from a huge one, else D
            let blame = if (k.is_infinite() && pulses_per_rev < 1.0)
                || (k < 1.0 && pulses_per_rev > 1.0 && wheel_diameter >= 1.0)
            {
                "pulses_per_rev"
            } else {
                "wheel_diameter"
            };
            return Err(Error::invalid(
                blame,
                format!(
                    "the distance per pulse πD/N = π·{wheel_diameter:e}/{pulses_per_rev:e} = {k:e} m is not a usable positive number"
                ),
            ));
        }
        let inv_b = 1.0 / wheel_separation;
        if !inv_b.is_normal() {
            return Err(Error::invalid(
                "wheel_separation",
                format!("{wheel_separation:e} m is too small: 1/B = {inv_b:e}"),
            ));
        }
        Ok(robot)
    }

    /// Distance per pulse, `πD/N`.
    pub fn distance_per_pulse(&self) -> f64 {
        std::f64::consts::PI * self.wheel_diameter / self.pulses_per_rev
    }

    /// `(Δs, Δθ)` for pulse increments `(n_l, n_r)`.
    ///
    /// ```
    /// use reckon::reckoning::encoders::DiffDrive;
    /// let r = DiffDrive::new(0.1, 0.5, 100.0).unwrap();
    /// let (ds, dth) = r.increments(100.0, 100.0); // one revolution of each wheel
    /// assert!((ds - 0.1 * std::f64::consts::PI).abs() < 1e-15);
    /// assert_eq!(dth, 0.0);
    /// ```
    pub fn increments(&self, left: f64, right: f64) -> (f64, f64) {
        let k = self.distance_per_pulse();
        let (dl, dr) = (left * k, right * k);
        (0.5 * (dl + dr), (dr - dl) / self.wheel_separation)
    }
}

/// Advance `pose = (x, y, θ)` by `(Δs, Δθ)` with rule `rule`; θ stays unwrapped.
///
/// ```
/// use reckon::reckoning::encoders::{advance, Update};
/// use nalgebra::vector;
/// let p = advance(&vector![0.0, 0.0, 0.0], 1.0, 0.0, Update::Euler);
/// assert_eq!(p, vector![1.0, 0.0, 0.0]);
/// ```
pub fn advance(pose: &Vector3<f64>, ds: f64, dth: f64, rule: Update) -> Vector3<f64> {
    let th = pose[2];
    match rule {
        Update::Euler => pose + Vector3::new(ds * th.cos(), ds * th.sin(), dth),
        Update::Midpoint => {
            let m = th + 0.5 * dth;
            pose + Vector3::new(ds * m.cos(), ds * m.sin(), dth)
        }
        // the arc is the unicycle flow with v·h = Δs and ω·h = Δθ
        Update::Exact => unicycle::flow(0.0, pose, &[ds, dth], 1.0),
    }
}

/// Dead-reckon from `(t, n_l, n_r)` samples: the pose before the first sample's
/// increments is `(0, 0, 0)`; returns `(t, pose)` after each sample, or an error at the
/// first sample that is not finite, not later than the previous one, or whose pose
/// overflows.
///
/// ```
/// use reckon::reckoning::encoders::{odometry, DiffDrive, Update};
/// let r = DiffDrive::new(0.2, 0.5, 1000.0).unwrap();
/// let path = odometry(&r, &[(0.0, 0.0, 0.0), (1.0, 1000.0, 1000.0)], Update::Exact).unwrap();
/// assert!((path[1].1[0] - 0.2 * std::f64::consts::PI).abs() < 1e-15);
/// ```
pub fn odometry(robot: &DiffDrive, samples: &[(f64, f64, f64)], rule: Update) -> Result<Vec<(f64, Vector3<f64>)>> {
    let mut pose = Vector3::zeros();
    let mut out = Vec::with_capacity(samples.len());
    for (k, &(t, l, r)) in samples.iter().enumerate() {
        if !(t.is_finite() && l.is_finite() && r.is_finite()) {
            return Err(Error::invalid("samples", format!("sample {k} is not finite")));
        }
        if k > 0 && t <= samples[k - 1].0 {
            return Err(Error::invalid(
                "samples",
                format!("time does not increase at sample {k}: {t}"),
            ));
        }
        let (ds, dth) = robot.increments(l, r);
        pose = advance(&pose, ds, dth, rule);
        if pose.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "samples",
                format!("the pose after sample {k} is not finite (increments too large)"),
            ));
        }
        out.push((t, pose));
    }
    Ok(out)
}

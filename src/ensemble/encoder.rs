//! The encoder-robot ensemble: many noisy differential-drive robots driving the same
//! commands, each dead-reckoned from its own encoder counts; the statistics are those of
//! the odometry error `odometry − truth` at the end of command segments.

use super::{Layout, Member};
use crate::error::{Brief, Error, Result};
use crate::reckoning::encoder_sim::{Command, EncoderErrors, Simulator, samples_of};
use crate::reckoning::encoders::{DiffDrive, Update, advance};
use nalgebra::{Matrix3, SVector, Vector3};
use num_dual::{DualNum, DualSVec64};
use rand_distr::{Distribution, StandardNormal};

/// Column names of [`EncoderEnsemble::layout`]: the error in x, y and heading (the
/// moments), then the horizontal error's length `√(e_x² + e_y²)`.
pub const COLUMNS: [&str; 4] = ["ex", "ey", "etheta", "radial"];

/// The most encoder samples one member may drive: 10⁹, about 70 s of one core. A
/// sample period that needs more over the commands is refused by
/// [`EncoderEnsemble::new`].
pub const MAX_SAMPLES_PER_MEMBER: f64 = 1e9;

/// Noisy encoder robots (see the [module docs](self)). Each member draws its own wheel
/// diameters `left_scale·(1 + σ_d·N)`, `right_scale·(1 + σ_d·N)` and wheelbase
/// `wheelbase_scale·(1 + σ_b·N)` (when the σ are not zero), then drives every command
/// sampled every `dt` with the pulse noise, quantisation and slip of `errors`
/// ([`Simulator`]), starting at the origin; its odometry integrates the counted pulses
/// with the nominal geometry by `update`.
///
/// ```
/// use reckon::ensemble::{Ensemble, encoder::EncoderEnsemble};
/// use reckon::reckoning::{encoders::DiffDrive, encoder_sim::{Command, EncoderErrors}};
/// let robot = DiffDrive::new(0.1, 0.5, 1000.0).unwrap();
/// let errors = EncoderErrors { pulse_noise: 2.0, ..Default::default() };
/// let drive = EncoderEnsemble::new(robot, errors, vec![Command { v: 1.0, omega: 0.0, duration: 10.0 }], 0.01).unwrap();
/// let layout = drive.layout();
/// let stats = Ensemble::new(2000, 3).run(&layout, |m, rows| drive.member(m, rows)).unwrap();
/// let predicted = drive.predicted_covariance();
/// // the heading error after n samples: σ² = n·2(σ_p·k)²/b², linear in the noise
/// let k = robot.distance_per_pulse();
/// assert!((predicted[0][(2, 2)] / (1000.0 * 2.0 * (2.0 * k).powi(2) / 0.25) - 1.0).abs() < 1e-12);
/// assert!((stats.covariance(0)[(2, 2)] / predicted[0][(2, 2)] - 1.0).abs() < 0.1);
/// // the distance's error is biased short by the wandering heading (E cos δθ < 1): a
/// // second-order effect the linearised prediction leaves out
/// assert!(stats.mean(0)[0] < -3.0 * (predicted[0][(0, 0)] / 2000.0).sqrt());
/// ```
#[derive(Debug, Clone)]
pub struct EncoderEnsemble {
    /// Nominal geometry (what the odometry assumes).
    pub robot: DiffDrive,
    /// Error model shared by the members (`seed` is not used: each member has its own).
    pub errors: EncoderErrors,
    /// Relative spread `σ_d` of each wheel's diameter between members.
    pub diameter_sigma: f64,
    /// Relative spread `σ_b` of the wheelbase between members.
    pub wheelbase_sigma: f64,
    /// The commands every member drives.
    pub commands: Vec<Command>,
    /// Encoder sample period.
    pub dt: f64,
    /// Odometry update rule.
    pub update: Update,
    /// Save the end of every `save_every`-th command (and of the last).
    pub save_every: usize,
}

impl EncoderEnsemble {
    /// Validated: finite positive `dt`, finite commands with positive durations, finite
    /// non-negative error magnitudes; no spreads, [`Update::Exact`].
    pub fn new(robot: DiffDrive, errors: EncoderErrors, commands: Vec<Command>, dt: f64) -> Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::invalid("dt", format!("must be finite and positive, got {dt}")));
        }
        if commands.is_empty() {
            return Err(Error::invalid("commands", "none given"));
        }
        if let Some((i, c)) = commands
            .iter()
            .enumerate()
            .find(|(_, c)| !(c.v.is_finite() && c.omega.is_finite() && c.duration.is_finite() && c.duration > 0.0))
        {
            return Err(Error::invalid(
                "commands",
                format!("command {i} ({c:?}) needs finite v, ω and a positive duration"),
            ));
        }
        let e = &errors;
        for (what, v) in [
            ("left_scale", e.left_scale),
            ("right_scale", e.right_scale),
            ("wheelbase_scale", e.wheelbase_scale),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    "errors",
                    format!("{what} must be finite and positive, got {v}"),
                ));
            }
        }
        for (what, v) in [("slip_sigma", e.slip_sigma), ("pulse_noise", e.pulse_noise)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(
                    "errors",
                    format!("{what} must be finite and ≥ 0, got {v}"),
                ));
            }
        }
        let samples: f64 = commands.iter().map(|c| (c.duration / dt).round().max(1.0)).sum();
        if samples > MAX_SAMPLES_PER_MEMBER {
            return Err(Error::invalid(
                "dt",
                format!(
                    "{}: the commands ({} s) would take {} encoder samples per member; at most {}",
                    Brief(dt),
                    Brief(commands.iter().map(|c| c.duration).sum::<f64>()),
                    Brief(samples),
                    Brief(MAX_SAMPLES_PER_MEMBER)
                ),
            ));
        }
        Ok(EncoderEnsemble {
            robot,
            errors,
            diameter_sigma: 0.0,
            wheelbase_sigma: 0.0,
            commands,
            dt,
            update: Update::Exact,
            save_every: 1,
        })
    }

    /// Encoder samples each member drives: `Σ max(1, round(duration/dt))` over the
    /// commands (at most [`MAX_SAMPLES_PER_MEMBER`]).
    ///
    /// ```
    /// use reckon::ensemble::encoder::EncoderEnsemble;
    /// use reckon::reckoning::{encoders::DiffDrive, encoder_sim::{Command, EncoderErrors}};
    /// let robot = DiffDrive::new(0.1, 0.5, 1000.0).unwrap();
    /// let c = |duration| Command { v: 1.0, omega: 0.0, duration };
    /// let drive = EncoderEnsemble::new(robot, EncoderErrors::default(), vec![c(10.0), c(0.001)], 0.01).unwrap();
    /// assert_eq!(drive.samples_per_member(), 1001.0);
    /// // a sample period that would never finish is refused, with the limit
    /// let e = EncoderEnsemble::new(robot, EncoderErrors::default(), vec![c(20.0)], 1e-300).unwrap_err();
    /// assert!(e.to_string().contains("at most 1e9"), "{e}");
    /// ```
    pub fn samples_per_member(&self) -> f64 {
        self.commands.iter().map(|c| samples_of(c, self.dt).0 as f64).sum()
    }

    /// With between-member spreads of the wheel diameters and the wheelbase (relative σ).
    pub fn spreads(mut self, diameter_sigma: f64, wheelbase_sigma: f64) -> Result<Self> {
        for (what, v) in [("diameter_sigma", diameter_sigma), ("wheelbase_sigma", wheelbase_sigma)] {
            if !(v.is_finite() && (0.0..0.5).contains(&v)) {
                return Err(Error::invalid(
                    "spreads",
                    format!("{what} must be in [0, 0.5), got {v}"),
                ));
            }
        }
        self.diameter_sigma = diameter_sigma;
        self.wheelbase_sigma = wheelbase_sigma;
        Ok(self)
    }

    /// Saving the end of every `every`-th command (and of the last); at least 1.
    pub fn save_every(mut self, every: usize) -> Self {
        self.save_every = every.max(1);
        self
    }

    /// Whether the end of command `i` is saved (every `save_every`-th, and the last).
    pub fn saved(&self, i: usize) -> bool {
        (i + 1).is_multiple_of(self.save_every.max(1)) || i + 1 == self.commands.len()
    }

    /// The saved times (the ends of every `save_every`-th command, and of the last) and
    /// [`COLUMNS`], the first three with moments.
    pub fn layout(&self) -> Layout {
        let mut t = 0.0;
        let mut times = Vec::new();
        for (i, c) in self.commands.iter().enumerate() {
            t += c.duration;
            if self.saved(i) {
                times.push(t);
            }
        }
        Layout {
            times,
            names: COLUMNS.iter().map(|s| s.to_string()).collect(),
            moments: 3,
        }
    }

    /// Run member `m`, writing its error rows at the times of [`layout`](Self::layout)
    /// into `rows`.
    pub fn member(&self, m: &mut Member, rows: &mut [f64]) -> Result<()> {
        let rng = m.rng();
        let mut e = self.errors;
        if self.diameter_sigma > 0.0 {
            let (a, b): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
            e.left_scale *= 1.0 + self.diameter_sigma * a;
            e.right_scale *= 1.0 + self.diameter_sigma * b;
        }
        if self.wheelbase_sigma > 0.0 {
            let a: f64 = StandardNormal.sample(rng);
            e.wheelbase_scale *= 1.0 + self.wheelbase_sigma * a;
        }
        let mut sim = Simulator::new(&self.robot, &e, Vector3::zeros(), rng);
        let mut odo = Vector3::zeros();
        let mut out = rows.chunks_exact_mut(COLUMNS.len());
        let mut t = 0.0;
        for (i, c) in self.commands.iter().enumerate() {
            let (n, h) = samples_of(c, self.dt);
            for _ in 0..n {
                let (nl, nr) = sim.sample(c.v, c.omega, h);
                let (ds, dth) = self.robot.increments(nl, nr);
                odo = advance(&odo, ds, dth, self.update);
            }
            t += c.duration;
            if self.saved(i) {
                let err = odo - sim.pose;
                if let Some(k) = err.iter().position(|v| !v.is_finite()) {
                    return Err(Error::NonFinite {
                        quantity: crate::error::Quantity::State,
                        component: k,
                        t,
                    });
                }
                if let Some(row) = out.next() {
                    row.copy_from_slice(&[err[0], err[1], err[2], err[0].hypot(err[1])]);
                }
            }
        }
        Ok(())
    }

    /// The covariance of the odometry error that the pulse noise alone causes: `P ← F·P·Fᵀ + G·Q·Gᵀ` per sample, `Q = (σ_p·k)²·I` on the
    /// wheel travels (`k` metres per pulse), with `F` and `G` the Jacobians of the update
    /// rule with respect to the pose and to the two wheel travels, by automatic
    /// differentiation, along the commanded path — the EKF's covariance prediction, at
    /// the times of [`layout`](Self::layout). Slip, quantisation and the systematic
    /// errors are not white noise and are not in it.
    pub fn predicted_covariance(&self) -> Vec<Matrix3<f64>> {
        let k = self.robot.distance_per_pulse();
        let b = self.robot.wheel_separation;
        let q = (self.errors.pulse_noise * k).powi(2);
        let mut p = Matrix3::zeros();
        let mut pose = Vector3::zeros();
        let mut out = Vec::new();
        for (i, c) in self.commands.iter().enumerate() {
            let (n, h) = samples_of(c, self.dt);
            let dl = (c.v - 0.5 * c.omega * b) * h;
            let dr = (c.v + 0.5 * c.omega * b) * h;
            for _ in 0..n {
                let z = SVector::<f64, 5>::new(pose[0], pose[1], pose[2], dl, dr);
                let rule = self.update;
                let (next, j) = num_dual::jacobian(|z: SVector<DualSVec64<5>, 5>| update_generic(&z, b, rule), &z);
                let f = j.fixed_columns::<3>(0).into_owned();
                let g = j.fixed_columns::<2>(3).into_owned();
                p = f * p * f.transpose() + g * g.transpose() * q;
                pose = next;
            }
            if self.saved(i) {
                out.push(p);
            }
        }
        out
    }
}

/// The odometry update of `(x, y, θ, d_l, d_r)` over any scalar (for its Jacobian).
fn update_generic<T: DualNum<Primitive = f64> + Copy>(z: &SVector<T, 5>, b: f64, rule: Update) -> SVector<T, 3> {
    let ds = (z[3] + z[4]) * 0.5;
    let dth = (z[4] - z[3]) / b;
    let th = z[2];
    let (d, m) = match rule {
        Update::Euler => (ds, th),
        Update::Midpoint => (ds, th + dth * 0.5),
        Update::Exact => {
            let a = dth * 0.5;
            let sinc = if a.re().abs() < 1e-4 {
                let a2 = a * a;
                T::one() - a2 / 6.0 * (T::one() - a2 / 20.0)
            } else {
                a.sin() / a
            };
            (ds * sinc, th + a)
        }
    };
    let (s, c) = m.sin_cos();
    SVector::<T, 3>::new(z[0] + d * c, z[1] + d * s, th + dth)
}

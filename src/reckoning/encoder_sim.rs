//! Encoder error models and simulated encoder data, reproducible with a seed.
//!
//! The robot drives commanded `(v, ω)` segments with its *nominal* geometry: the
//! controller turns the wheels by the angles that would give wheel travels
//! `d_l,r = (v ∓ ωB/2)·dt`, and the encoders count those angles. The ground then moves
//! according to the *true* geometry (wheel diameters, wheelbase) less any slip. Odometry
//! from the counts with the nominal geometry believes the nominal path; the difference
//! is the odometry error (Borenstein & Feng's model behind UMBmark).

use super::encoders::{DiffDrive, Update, advance};
use nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

/// Systematic and random encoder errors. `EncoderErrors::default()` is error-free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderErrors {
    /// True left wheel diameter ÷ nominal (e.g. 1.001).
    pub left_scale: f64,
    /// True right wheel diameter ÷ nominal.
    pub right_scale: f64,
    /// True wheelbase ÷ nominal.
    pub wheelbase_scale: f64,
    /// Count whole pulses only (remainders carry over to the next sample).
    pub quantize: bool,
    /// Standard deviation of the fraction of each wheel's travel lost to slip (|N(0, σ)|).
    pub slip_sigma: f64,
    /// Standard deviation of white noise added to each pulse count.
    pub pulse_noise: f64,
    /// Seed of the random generator.
    pub seed: u64,
}

impl Default for EncoderErrors {
    fn default() -> Self {
        EncoderErrors {
            left_scale: 1.0,
            right_scale: 1.0,
            wheelbase_scale: 1.0,
            quantize: false,
            slip_sigma: 0.0,
            pulse_noise: 0.0,
            seed: 0,
        }
    }
}

/// One commanded segment: speed `v`, turn rate `ω`, duration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Forward speed in m/s.
    pub v: f64,
    /// Turn rate in rad/s.
    pub omega: f64,
    /// Duration in s.
    pub duration: f64,
}

/// Simulated run: encoder samples and the true poses at the same times.
#[derive(Debug, Clone)]
pub struct EncoderRun {
    /// `(t, n_l, n_r)` pulse increments per sample (first sample at t = 0 with no motion).
    pub samples: Vec<(f64, f64, f64)>,
    /// True pose after each sample.
    pub truth: Vec<Vector3<f64>>,
}

/// Simulate encoder counts and true motion for `commands` sampled every `dt`, starting
/// at the true pose `start`.
///
/// ```
/// use reckon::reckoning::encoders::DiffDrive;
/// use reckon::reckoning::encoder_sim::{simulate, Command, EncoderErrors};
/// let r = DiffDrive::new(0.1, 0.5, 1000.0).unwrap();
/// let run = simulate(&r, &EncoderErrors::default(), &[Command { v: 1.0, omega: 0.0, duration: 2.0 }], 0.01, [0.0; 3].into());
/// assert!((run.truth.last().unwrap()[0] - 2.0).abs() < 1e-12);
/// ```
pub fn simulate(
    robot: &DiffDrive,
    e: &EncoderErrors,
    commands: &[Command],
    dt: f64,
    start: Vector3<f64>,
) -> EncoderRun {
    let mut sim = Simulator::new(robot, e, start, StdRng::seed_from_u64(e.seed));
    let mut t_seg = 0.0;
    let mut run = EncoderRun {
        samples: vec![(0.0, 0.0, 0.0)],
        truth: vec![start],
    };
    for c in commands {
        let (n, h) = samples_of(c, dt);
        for j in 1..=n {
            let (nl, nr) = sim.sample(c.v, c.omega, h);
            run.samples.push((t_seg + j as f64 * h, nl, nr));
            run.truth.push(sim.pose);
        }
        t_seg += c.duration;
    }
    run
}

/// Samples of a command at period `dt`: `n = max(1, round(duration/dt))` of length
/// `h = duration/n`.
pub fn samples_of(c: &Command, dt: f64) -> (u64, f64) {
    let n = (c.duration / dt).round().max(1.0) as u64;
    (n, c.duration / n as f64)
}

/// The encoder robot one sample at a time: [`simulate`] without storing, for long runs
/// and ensembles. Each sample draws from the generator given: the left then right pulse
/// noise if `pulse_noise ≠ 0`, then the left then right slip if `slip_sigma ≠ 0`. The
/// generator is owned or borrowed (`&mut StdRng`: an ensemble member's own,
/// [`Member::rng`](crate::ensemble::Member::rng)).
#[derive(Debug, Clone)]
pub struct Simulator<'a, R: rand::Rng = StdRng> {
    robot: &'a DiffDrive,
    e: &'a EncoderErrors,
    rng: R,
    unit: Normal<f64>,
    carry: (f64, f64),
    /// The true pose.
    pub pose: Vector3<f64>,
}

impl<'a, R: rand::Rng> Simulator<'a, R> {
    /// At true pose `start`, drawing noise from `rng` (`e.seed` is not used).
    pub fn new(robot: &'a DiffDrive, e: &'a EncoderErrors, start: Vector3<f64>, rng: R) -> Self {
        Simulator {
            robot,
            e,
            rng,
            unit: Normal::new(0.0, 1.0).expect("unit normal"),
            carry: (0.0, 0.0),
            pose: start,
        }
    }

    /// Drive `(v, ω)` for `h`: returns the counted pulses `(n_l, n_r)` and moves the true pose.
    pub fn sample(&mut self, v: f64, omega: f64, h: f64) -> (f64, f64) {
        let (e, k, b) = (self.e, self.robot.distance_per_pulse(), self.robot.wheel_separation);
        // commanded wheel travel with the nominal geometry → wheel rotation in pulses
        let pl = (v - 0.5 * omega * b) * h / k;
        let pr = (v + 0.5 * omega * b) * h / k;
        // counted pulses: noise, then quantisation with carried remainder
        let (mut nl, mut nr) = (pl, pr);
        if e.pulse_noise != 0.0 {
            nl += e.pulse_noise * self.unit.sample(&mut self.rng);
            nr += e.pulse_noise * self.unit.sample(&mut self.rng);
        }
        if e.quantize {
            let (ql, qr) = ((nl + self.carry.0).trunc(), (nr + self.carry.1).trunc());
            self.carry.0 += nl - ql;
            self.carry.1 += nr - qr;
            (nl, nr) = (ql, qr);
        }
        // true ground travel: true diameters, slip
        let (mut dl, mut dr) = (pl * k * e.left_scale, pr * k * e.right_scale);
        if e.slip_sigma != 0.0 {
            dl *= 1.0 - (e.slip_sigma * self.unit.sample(&mut self.rng)).abs();
            dr *= 1.0 - (e.slip_sigma * self.unit.sample(&mut self.rng)).abs();
        }
        self.pose = advance(
            &self.pose,
            0.5 * (dl + dr),
            (dr - dl) / (b * e.wheelbase_scale),
            Update::Exact,
        );
        (nl, nr)
    }
}

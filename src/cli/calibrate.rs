//! `reckon calibrate`: a differential drive's wheel radii and wheel base from an encoder
//! log and measured poses, by least squares through the model (`lsq`) or by Censi et
//! al.'s two-step method on the intervals between poses (`censi`).

use super::csvio::{RowWriter, check_not_input, num, read_table};
use crate::calibration::{censi, lsq};
use crate::reckoning::encoders::{Update, advance};
use clap::{Parser, ValueEnum};
use nalgebra::Vector3;
use std::error::Error;
use std::path::PathBuf;

/// How the parameters are estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Gauss–Newton (argmin) through the model with wheel radii and wheel base as
    /// parameters, the residuals' Jacobian from the sensitivities; every pose after the
    /// first is an observation.
    Lsq,
    /// Censi et al. 2013: each interval between consecutive poses gives a displacement
    /// (the poses are the sensor's, so its pose on the robot is estimated too).
    Censi,
    /// Borenstein & Feng's UMBmark: the poses come in pairs, the measured start and end
    /// of each square run (clockwise or counter-clockwise, told by the odometry's turn);
    /// gives E_d and E_b from the return errors.
    Umbmark,
}

/// Arguments of `reckon calibrate`.
#[derive(Debug, Parser)]
#[command(
    after_help = "The encoders CSV is read as by `reckon odometry` (header t,left,right; \
pulse increments since the previous row). The poses CSV has header t,x,y,theta (metres, \
radians, the same clock). The first pose at or after the first encoder row is the start; \
the corrected odometry is dead-reckoned from it with the calibrated geometry (exact arcs) \
and written as t,x,y,theta. With --method umbmark the poses are two rows per run, its \
measured start and end; each run is dead-reckoned from its start, its return error \
(truth − odometry, in the frame of the start pose) enters Borenstein & Feng's formulas \
with the side length L = the run's odometry path length / 4, and a run whose odometry \
does not turn about ±360° is an error."
)]
pub struct CalibrateArgs {
    /// Encoders CSV: header t,left,right (pulse increments).
    #[arg(long)]
    pub encoders: PathBuf,
    /// Poses CSV: header t,x,y,theta.
    #[arg(long)]
    pub poses: PathBuf,
    /// Estimation method.
    #[arg(long, value_enum, default_value_t = Method::Lsq)]
    pub method: Method,
    /// The nominal geometry (the starting point).
    #[command(flatten)]
    pub geometry: super::odometry::Geometry,
    /// Standard deviation of the poses' x and y (m), for lsq; finite and positive.
    #[arg(long, default_value_t = 0.01, allow_hyphen_values = true)]
    pub sigma_xy: f64,
    /// Standard deviation of the poses' heading (rad), for lsq; finite and positive.
    #[arg(long, default_value_t = 0.01, allow_hyphen_values = true)]
    pub sigma_theta: f64,
    /// Corrected odometry CSV (default: standard output; the parameters go to stderr then).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Run the command.
pub fn run(args: &CalibrateArgs) -> Result<(), Box<dyn Error>> {
    let robot = args.geometry.robot()?;
    for (flag, v) in [("--sigma-xy", args.sigma_xy), ("--sigma-theta", args.sigma_theta)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("{flag} must be finite and positive, got {}", num(v)).into());
        }
    }
    check_not_input(args.out.as_deref(), &args.encoders)?;
    check_not_input(args.out.as_deref(), &args.poses)?;
    let enc = read_table(&args.encoders, &["t", "left", "right"])?;
    if let Some(e) = enc.error {
        return Err(e.into());
    }
    let pos = read_table(&args.poses, &["t", "x", "y", "theta"])?;
    if let Some(e) = pos.error {
        return Err(e.into());
    }
    let samples: Vec<(f64, f64, f64)> = enc.rows.iter().map(|(_, r)| (r[0], r[1], r[2])).collect();
    let poses: Vec<(f64, Vector3<f64>)> = pos
        .rows
        .iter()
        .map(|(_, r)| (r[0], Vector3::new(r[1], r[2], r[3])))
        .collect();
    if samples.len() < 2 || poses.len() < 2 {
        return Err("calibrate needs at least two encoder rows and two poses".into());
    }
    let (r_l, r_r, b, report) = match args.method {
        Method::Lsq => {
            let f = lsq::fit_encoder_log(
                &samples,
                &robot,
                &poses,
                [args.sigma_xy, args.sigma_xy, args.sigma_theta],
            )?;
            let mut text = lines(&f.estimate, " m");
            text.push(format!(
                "sigma^2 = {} ({} Gauss-Newton iterations)",
                num(f.estimate.sigma2),
                f.iterations
            ));
            let v = &f.estimate.value;
            (v[0], v[1], v[2], text)
        }
        Method::Censi => {
            let data = censi_intervals(&samples, &poses, robot.pulses_per_rev)?;
            let f = censi::calibrate(&data, censi::Trim::default())?;
            let text = lines(&f.estimate, "");
            (f.params.r_l, f.params.r_r, f.params.b, text)
        }
        Method::Umbmark => {
            let f = umbmark_runs(&samples, &poses, &robot)?;
            let mut text = lines(&f.estimate, "");
            let (dl, dr) = f.wheel_diameters(robot.wheel_diameter);
            let b = f.wheelbase(robot.wheel_separation);
            text.push(format!(
                "E_max,syst = {} m; corrected: D_L = {} m, D_R = {} m, b = {} m",
                num(f.e_max_syst()),
                num(dl),
                num(dr),
                num(b)
            ));
            (0.5 * dl, 0.5 * dr, b, text)
        }
    };
    let mut err = std::io::stderr();
    let mut to_stdout = std::io::stdout();
    let sink: &mut dyn std::io::Write = if args.out.is_some() { &mut to_stdout } else { &mut err };
    for line in &report {
        writeln!(sink, "{line}")?;
    }
    // the corrected odometry from the first pose on
    let mut out = RowWriter::open(args.out.as_deref())?;
    out.line("t,x,y,theta")?;
    let (t0, mut pose) = poses[0];
    let k = std::f64::consts::TAU / robot.pulses_per_rev;
    out.row(t0, pose.as_slice())?;
    for &(t, nl, nr) in samples.iter().filter(|s| s.0 > t0) {
        let (dl, dr) = (nl * k * r_l, nr * k * r_r);
        pose = advance(&pose, 0.5 * (dl + dr), (dr - dl) / b, Update::Exact);
        out.row(t, pose.as_slice())?;
    }
    Ok(out.flush()?)
}

/// `name = value ± σ unit`, one line per parameter.
fn lines(e: &crate::calibration::Estimate, unit: &str) -> Vec<String> {
    let sd = e.std_dev();
    (0..e.value.len())
        .map(|i| format!("{} = {} ± {}{unit}", e.names[i], num(e.value[i]), num(sd[i])))
        .collect()
}

/// UMBmark from a log: runs between pose pairs, their return errors in the start frame.
fn umbmark_runs(
    samples: &[(f64, f64, f64)],
    poses: &[(f64, Vector3<f64>)],
    robot: &crate::reckoning::encoders::DiffDrive,
) -> Result<crate::calibration::umbmark::UmbmarkFit, Box<dyn Error>> {
    if !poses.len().is_multiple_of(2) {
        return Err(format!(
            "umbmark: the poses come in pairs (start and end of each run), got {} rows",
            poses.len()
        )
        .into());
    }
    let (mut cw, mut ccw, mut sides) = (Vec::new(), Vec::new(), Vec::new());
    for (i, pair) in poses.chunks_exact(2).enumerate() {
        let ((ta, a), (tb, end)) = (pair[0], pair[1]);
        let mut odo = a;
        let mut path = 0.0;
        for s in samples.iter().filter(|s| s.0 > ta && s.0 <= tb) {
            let (ds, dth) = robot.increments(s.1, s.2);
            odo = advance(&odo, ds, dth, Update::Exact);
            path += ds.abs();
        }
        let turn = odo[2] - a[2];
        if !(turn.abs() > 1.5 * std::f64::consts::PI && turn.abs() < 2.5 * std::f64::consts::PI) {
            return Err(format!(
                "umbmark: run {} (t = {} to {}) turns {}° by odometry; a UMBmark run is a square, ±360°",
                i + 1,
                num(ta),
                num(tb),
                num(turn.to_degrees())
            )
            .into());
        }
        let (s, c) = a[2].sin_cos();
        let d = end.xy() - odo.xy();
        let eps = nalgebra::Vector2::new(c * d[0] + s * d[1], -s * d[0] + c * d[1]);
        if turn > 0.0 {
            ccw.push(eps)
        } else {
            cw.push(eps)
        }
        sides.push(path / 4.0);
    }
    let side = sides.iter().sum::<f64>() / sides.len() as f64;
    Ok(crate::calibration::umbmark::calibrate(
        &cw,
        &ccw,
        side,
        robot.wheel_separation,
    )?)
}

/// Intervals between consecutive poses: the wheel rotations of the encoder rows inside,
/// and the relative pose `⊖p_k ⊕ p_{k+1}`.
fn censi_intervals(
    samples: &[(f64, f64, f64)],
    poses: &[(f64, Vector3<f64>)],
    ppr: f64,
) -> Result<Vec<censi::Interval>, Box<dyn Error>> {
    let k = 2.0 * std::f64::consts::PI / ppr;
    let mut out = Vec::new();
    for w in poses.windows(2) {
        let ((ta, a), (tb, bp)) = (w[0], w[1]);
        let wheels: Vec<[f64; 2]> = samples
            .iter()
            .filter(|s| s.0 > ta && s.0 <= tb)
            .map(|s| [s.1 * k, s.2 * k])
            .collect();
        if wheels.is_empty() {
            continue;
        }
        let (s, c) = a[2].sin_cos();
        let d = bp - a;
        let rel = Vector3::new(
            c * d[0] + s * d[1],
            -s * d[0] + c * d[1],
            crate::models::wrap_angle(d[2]),
        );
        out.push(censi::Interval { wheels, sensor: rel });
    }
    Ok(out)
}

//! `reckon calibrate`: a differential drive's wheel diameters and wheel base from an
//! encoder log and measured poses, by least squares through the model (`lsq`), by Censi et
//! al.'s two-step method on the intervals between poses or on interval data (`censi`),
//! or from UMBmark square runs (`umbmark`).

use super::csvio::{InputError, RowReader, RowWriter, check_not_input, num};
use clap::{Parser, ValueEnum};
use nalgebra::Vector3;
use reckon::calibration::{Estimate, censi, lsq};
use reckon::reckoning::encoders::{DiffDrive, Update, advance};
use std::error::Error;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// How the parameters are estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Levenberg–Marquardt through the model with wheel radii and wheel base as
    /// parameters, the residuals' Jacobian from the sensitivities; every pose after the
    /// first is an observation of the robot's own pose (the axle centre's).
    Lsq,
    /// Censi et al. 2013: each interval between consecutive poses (or each row of
    /// --intervals) gives a displacement of a sensor whose pose on the robot is
    /// estimated too; no nominal geometry is needed.
    Censi,
    /// Borenstein & Feng's UMBmark: the poses come in pairs, the measured start and end
    /// of each square run (clockwise or counter-clockwise, told by the odometry's turn);
    /// gives E_d and E_b from the return errors.
    Umbmark,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Lsq => "lsq",
            Method::Censi => "censi",
            Method::Umbmark => "umbmark",
        }
    }
}

/// How the wheels are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Report {
    /// Wheel diameters (as robot configurations and Censi et al.'s tables give them).
    Diameters,
    /// Wheel radii.
    Radii,
}

/// Most interval rows `--intervals` reads (they are held in memory).
pub const MAX_INTERVALS: u64 = 1_000_000;
/// Most encoder rows `calibrate` reads (the whole log is held in memory).
pub const MAX_ENCODER_ROWS: u64 = 10_000_000;
/// Most pose rows `calibrate` reads.
pub const MAX_POSE_ROWS: u64 = 1_000_000;

/// Arguments of `reckon calibrate`.
#[derive(Debug, Parser)]
#[command(after_help = "Inputs. A continuous log: --encoders CSV (header t,left,right; pulse \
increments since the previous row, as `reckon odometry` reads) and --poses CSV (header \
t,x,y,theta; metres, radians, the same clock). Or, for censi only, --intervals CSV: one \
interval per row, header dt,left,right,dx,dy,dtheta, with the wheel rotations over the \
interval in radians (left, right), its duration in seconds (dt > 0) and the sensor's \
displacement measured over it in the sensor's frame at the interval's start (dx, dy in \
metres, dtheta in radians), the form calibration data sets come in; the header \
dt,left_speed,right_speed,dx,dy,dtheta gives average wheel speeds in rad/s instead \
(rotation = speed x dt, the form of Censi et al.'s tuple files: T, phi_l, phi_r, sm). At \
most 1000000 intervals, 10000000 encoder rows and 1000000 poses are read.\n\n\
Geometry flags only where the method uses them: lsq and umbmark need --wheel-diameter, \
--wheel-separation and --pulses-per-rev (the nominal geometry lsq starts from and \
umbmark corrects); censi needs only --pulses-per-rev with an encoder log and nothing \
with --intervals, and refuses the others. --sigma-xy and --sigma-theta are lsq's, \
--trim is censi's.\n\n\
Outputs. The parameters with standard deviations, wheels as diameters unless --report \
radii. With a log, the corrected odometry dead-reckoned from the first pose at or after \
the first encoder row with the calibrated geometry (exact arcs), as t,x,y,theta, to --out \
(parameters on stdout) or to stdout (parameters on stderr). With --intervals, the \
parameters on stdout, and with --out each interval's residual at the estimate as \
line,kept,r_theta,r_x,r_y (line: the interval's line in the file; kept: 0 if trimmed).\n\n\
censi trims outliers (failed scan matches) as the reference solver does: --trim \
FRACTION[,ROUNDS], default 0.01,4 (calibration::censi::Trim::default(): 4 rounds, each \
dropping the 1 % of kept intervals with the largest normalised residual, then \
re-estimating); --trim 0 keeps every interval.\n\n\
With --method umbmark the poses are two rows per run, its measured start and end; each \
run is dead-reckoned from its start, its return error (truth - odometry, in the frame of \
the start pose) enters Borenstein & Feng's formulas with the side length L = the run's \
odometry path length / 4, and a run whose odometry does not turn about ±360° is an error.")]
pub struct CalibrateArgs {
    /// Encoders CSV: header t,left,right (pulse increments).
    #[arg(long)]
    pub encoders: Option<PathBuf>,
    /// Poses CSV: header t,x,y,theta.
    #[arg(long)]
    pub poses: Option<PathBuf>,
    /// Interval CSV (censi): header dt,left,right,dx,dy,dtheta (see below).
    #[arg(long, conflicts_with_all = ["encoders", "poses"])]
    pub intervals: Option<PathBuf>,
    /// Estimation method [default: censi with --intervals, else lsq].
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Nominal wheel diameter in metres (lsq, umbmark).
    #[arg(long, allow_hyphen_values = true)]
    pub wheel_diameter: Option<f64>,
    /// Nominal distance between the wheels in metres (lsq, umbmark).
    #[arg(long, allow_hyphen_values = true)]
    pub wheel_separation: Option<f64>,
    /// Encoder pulses per wheel revolution (every method with --encoders).
    #[arg(long, allow_hyphen_values = true)]
    pub pulses_per_rev: Option<f64>,
    /// Standard deviation of the poses' x and y (m), lsq only [default: 0.01].
    #[arg(long, allow_hyphen_values = true)]
    pub sigma_xy: Option<f64>,
    /// Standard deviation of the poses' heading (rad), lsq only [default: 0.01].
    #[arg(long, allow_hyphen_values = true)]
    pub sigma_theta: Option<f64>,
    /// censi's outlier trimming, FRACTION[,ROUNDS] [default: 0.01,4; 0 keeps every interval].
    #[arg(long, value_name = "FRACTION[,ROUNDS]", allow_hyphen_values = true)]
    pub trim: Option<String>,
    /// Report the wheels as diameters or radii.
    #[arg(long, value_enum, default_value_t = Report::Diameters)]
    pub report: Report,
    /// Output CSV: the corrected odometry, or with --intervals each interval's residual
    /// (default: standard output for the odometry, none for the residuals).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `--trim FRACTION[,ROUNDS]`: the fraction in `[0, 0.5)`, rounds a whole number from 0 to
/// 1000 (default 4).
///
/// ```
/// use reckon::calibration::censi::Trim;
/// use reckon_cli::calibrate::parse_trim;
/// assert_eq!(parse_trim("0.01,4"), Ok(Trim::default()));
/// assert_eq!(parse_trim("0.05"), Ok(Trim { fraction: 0.05, rounds: 4 }));
/// assert_eq!(parse_trim("0"), Ok(Trim { fraction: 0.0, rounds: 4 }));
/// assert!(parse_trim("0.5").unwrap_err().contains("[0, 0.5)"));
/// assert!(parse_trim("0.1,-1").unwrap_err().contains("rounds"));
/// ```
pub fn parse_trim(text: &str) -> Result<censi::Trim, String> {
    let (f, r) = match text.split_once(',') {
        Some((f, r)) => (f.trim(), Some(r.trim())),
        None => (text.trim(), None),
    };
    let fraction: f64 = f.parse().map_err(|_| {
        format!(
            "--trim: the fraction '{}' is not a number",
            super::csvio::brief(f.as_bytes())
        )
    })?;
    if !(fraction.is_finite() && (0.0..0.5).contains(&fraction)) {
        return Err(format!(
            "--trim: the fraction must be in [0, 0.5), got {}",
            num(fraction)
        ));
    }
    let rounds = match r {
        None => censi::Trim::default().rounds,
        Some(r) => match r.parse::<i128>() {
            Ok(v) => super::whole::<usize>("--trim rounds", v, 0..=1000)?,
            Err(_) => {
                return Err(format!(
                    "--trim: the rounds '{}' are not a whole number",
                    super::csvio::brief(r.as_bytes())
                ));
            }
        },
    };
    Ok(censi::Trim { fraction, rounds })
}

/// What a method reads, checked against the flags given.
enum Input<'a> {
    Log { encoders: &'a Path, poses: &'a Path },
    Intervals(&'a Path),
}

/// The method, its input and the flags it may not be given, or one line saying which flag
/// is missing or not used.
fn plan(args: &CalibrateArgs) -> Result<(Method, Input<'_>), String> {
    let method = args.method.unwrap_or(if args.intervals.is_some() {
        Method::Censi
    } else {
        Method::Lsq
    });
    let m = method.name();
    let input = match (&args.intervals, &args.encoders, &args.poses) {
        (Some(i), _, _) if method == Method::Censi => Input::Intervals(i),
        (Some(_), _, _) => {
            return Err(format!(
                "--intervals is the input of --method censi; --method {m} needs a continuous log: --encoders and --poses"
            ));
        }
        (None, Some(e), Some(p)) => Input::Log { encoders: e, poses: p },
        (None, e, _) => {
            let missing = if e.is_none() { "--encoders" } else { "--poses" };
            let alt = if method == Method::Censi {
                " (or --intervals)"
            } else {
                ""
            };
            return Err(format!("--method {m} needs {missing}{alt}"));
        }
    };
    let geometry = [
        ("--wheel-diameter", args.wheel_diameter.is_some()),
        ("--wheel-separation", args.wheel_separation.is_some()),
        ("--pulses-per-rev", args.pulses_per_rev.is_some()),
    ];
    for (flag, given) in geometry {
        let needed = match (method, &input) {
            (Method::Lsq | Method::Umbmark, _) => true,
            (Method::Censi, Input::Log { .. }) => flag == "--pulses-per-rev",
            (Method::Censi, Input::Intervals(_)) => false,
        };
        if needed && !given {
            let why = match method {
                Method::Lsq => "the nominal geometry the fit starts from",
                Method::Umbmark => "the nominal geometry UMBmark corrects",
                Method::Censi => "to turn the encoder pulses into wheel rotations",
            };
            return Err(format!("--method {m} needs {flag} ({why})"));
        }
        if given && !needed {
            let why = match input {
                Input::Intervals(_) => {
                    "it estimates the geometry with no starting point, and the intervals' wheel rotations are in radians"
                }
                Input::Log { .. } => "it estimates the geometry with no starting point",
            };
            return Err(format!("--method censi does not use {flag}: {why}"));
        }
    }
    for (flag, given) in [
        ("--sigma-xy", args.sigma_xy.is_some()),
        ("--sigma-theta", args.sigma_theta.is_some()),
    ] {
        if given && method != Method::Lsq {
            return Err(format!(
                "{flag} is for --method lsq (the poses' noise in its residuals)"
            ));
        }
    }
    if args.trim.is_some() && method != Method::Censi {
        return Err(format!("--trim is for --method censi, not --method {m}"));
    }
    Ok((method, input))
}

/// Read all rows of `path` (at most `max`), as the command's CSV errors name them.
fn read_all(rdr: RowReader<std::fs::File>, max: u64, what: &str) -> Result<Vec<(u64, Vec<f64>)>, InputError> {
    let mut rdr = rdr;
    let mut rows = Vec::new();
    while let Some(v) = rdr.next_row()? {
        if rows.len() as u64 == max {
            return Err(rdr.error(format!(
                "more than {max} {what}: calibrate holds them all in memory; split the file"
            )));
        }
        let v = v.to_vec();
        rows.push((rdr.line(), v));
    }
    Ok(rows)
}

/// The interval columns: wheel rotations (rad) or average wheel speeds (rad/s).
const ROTATIONS: [&str; 6] = ["dt", "left", "right", "dx", "dy", "dtheta"];
const SPEEDS: [&str; 6] = ["dt", "left_speed", "right_speed", "dx", "dy", "dtheta"];

/// The intervals of an interval CSV with their lines, validated row by row: `dt > 0`,
/// every value finite, the rotations `speed·dt` finite.
fn read_intervals(path: &Path) -> Result<(Vec<censi::Interval>, Vec<u64>), InputError> {
    let (rdr, speeds) = match RowReader::open(path, &ROTATIONS) {
        Ok(r) => (r, false),
        // a file that cannot be read is that error; a header without the columns names
        // both forms
        Err(e) if e.line.is_none() => return Err(e),
        Err(e) => match RowReader::open(path, &SPEEDS) {
            Ok(r) => (r, true),
            Err(_) => {
                return Err(InputError {
                    message: format!(
                        "{}; or dt,left_speed,right_speed,dx,dy,dtheta with wheel speeds in rad/s",
                        e.message
                    ),
                    ..e
                });
            }
        },
    };
    let mut rdr = rdr.untimed();
    let (mut data, mut lines) = (Vec::new(), Vec::new());
    while let Some(v) = rdr.next_row()? {
        let [dt, l, r, dx, dy, dth] = [v[0], v[1], v[2], v[3], v[4], v[5]];
        if dt <= 0.0 {
            return Err(rdr.error(format!(
                "column 'dt': an interval lasts a positive time, got {}",
                num(dt)
            )));
        }
        if lines.len() as u64 == MAX_INTERVALS {
            return Err(rdr.error(format!(
                "more than {MAX_INTERVALS} intervals: calibrate holds them all in memory; split the file"
            )));
        }
        let (wl, wr) = if speeds { (l * dt, r * dt) } else { (l, r) };
        for (col, w) in [(SPEEDS[1], wl), (SPEEDS[2], wr)] {
            if !w.is_finite() {
                return Err(rdr.error(format!(
                    "column '{col}': the rotation speed × dt = {} overflows",
                    num(w)
                )));
            }
        }
        data.push(censi::Interval {
            wheels: vec![[wl, wr]],
            sensor: Vector3::new(dx, dy, dth),
        });
        lines.push(rdr.line());
    }
    Ok((data, lines))
}

/// Run the command.
pub fn run(args: &CalibrateArgs) -> Result<(), Box<dyn Error>> {
    let (method, input) = plan(args)?;
    let sigma_xy = args.sigma_xy.unwrap_or(0.01);
    let sigma_theta = args.sigma_theta.unwrap_or(0.01);
    for (flag, v) in [("--sigma-xy", sigma_xy), ("--sigma-theta", sigma_theta)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("{flag} must be finite and positive, got {}", num(v)).into());
        }
    }
    let trim = match &args.trim {
        Some(t) => parse_trim(t)?,
        None => censi::Trim::default(),
    };
    let (encoders, poses) = match input {
        Input::Intervals(path) => {
            check_not_input(args.out.as_deref(), path)?;
            return censi_from_intervals(path, trim, args);
        }
        Input::Log { encoders, poses } => (encoders, poses),
    };
    check_not_input(args.out.as_deref(), encoders)?;
    check_not_input(args.out.as_deref(), poses)?;
    let ppr = args.pulses_per_rev.expect("checked by plan");
    let robot = match (args.wheel_diameter, args.wheel_separation) {
        (Some(d), Some(b)) => Some(DiffDrive::new(d, b, ppr)?),
        _ => {
            let rad = std::f64::consts::TAU / ppr;
            if !(ppr.is_finite() && ppr > 0.0 && rad.is_normal()) {
                return Err(format!(
                    "--pulses-per-rev must be finite and positive with 2π/N a usable number, got {}",
                    num(ppr)
                )
                .into());
            }
            None
        }
    };
    let samples: Vec<(f64, f64, f64)> = read_all(
        RowReader::open(encoders, &["t", "left", "right"])?,
        MAX_ENCODER_ROWS,
        "encoder rows",
    )?
    .into_iter()
    .map(|(_, r)| (r[0], r[1], r[2]))
    .collect();
    let poses: Vec<(f64, Vector3<f64>)> = read_all(
        RowReader::open(poses, &["t", "x", "y", "theta"])?,
        MAX_POSE_ROWS,
        "poses",
    )?
    .into_iter()
    .map(|(_, r)| (r[0], Vector3::new(r[1], r[2], r[3])))
    .collect();
    if samples.len() < 2 || poses.len() < 2 {
        return Err("calibrate needs at least two encoder rows and two poses".into());
    }
    let wheels = |r_l: f64, r_r: f64, sd: Option<(f64, f64)>| wheel_lines(args.report, r_l, r_r, sd);
    let (r_l, r_r, b, report) = match method {
        Method::Lsq => {
            let robot = robot.expect("checked by plan");
            let f = lsq::fit_encoder_log(&samples, &robot, &poses, [sigma_xy, sigma_xy, sigma_theta])?;
            let v = &f.estimate.value;
            let sd = f.estimate.std_dev();
            let mut text = wheels(v[0], v[1], Some((sd[0], sd[1])));
            text.push(line("wheel separation", v[2], Some(sd[2]), " m"));
            text.push(format!(
                "sigma^2 = {} ({} Levenberg-Marquardt steps; near 1 when --sigma-xy and --sigma-theta describe the poses)",
                num(f.estimate.sigma2),
                f.iterations
            ));
            (v[0], v[1], v[2], text)
        }
        Method::Censi => {
            let data = censi_intervals(&samples, &poses, ppr)?;
            let f = censi::calibrate(&data, trim)?;
            let text = censi_lines(&f, data.len(), trim, args.report);
            (f.params.r_l, f.params.r_r, f.params.b, text)
        }
        Method::Umbmark => {
            let robot = robot.expect("checked by plan");
            let f = umbmark_runs(&samples, &poses, &robot)?;
            let mut text = all_lines(&f.estimate, "");
            let (dl, dr) = f.wheel_diameters(robot.wheel_diameter);
            let b = f.wheelbase(robot.wheel_separation);
            text.push(format!("E_max,syst = {} m; corrected:", num(f.e_max_syst())));
            text.extend(wheels(0.5 * dl, 0.5 * dr, None));
            text.push(line("wheel separation", b, None, " m"));
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
    let k = std::f64::consts::TAU / ppr;
    out.row(t0, pose.as_slice())?;
    for &(t, nl, nr) in samples.iter().filter(|s| s.0 > t0) {
        let (dl, dr) = (nl * k * r_l, nr * k * r_r);
        pose = advance(&pose, 0.5 * (dl + dr), (dr - dl) / b, Update::Exact);
        out.row(t, pose.as_slice())?;
    }
    Ok(out.flush()?)
}

/// `censi` on an interval file: the parameters on stdout, the residuals to `--out`.
fn censi_from_intervals(path: &Path, trim: censi::Trim, args: &CalibrateArgs) -> Result<(), Box<dyn Error>> {
    let (data, lines) = read_intervals(path)?;
    let f = censi::calibrate(&data, trim)?;
    let mut stdout = std::io::stdout().lock();
    for l in censi_lines(&f, data.len(), trim, args.report) {
        writeln!(stdout, "{l}")?;
    }
    stdout.flush()?;
    if let Some(out) = &args.out {
        let mut w = RowWriter::open(Some(out))?;
        w.line("line,kept,r_theta,r_x,r_y")?;
        let mut kept = vec![false; data.len()];
        for &k in &f.kept {
            kept[k] = true;
        }
        for (k, r) in censi::interval_residuals(&data, &f).iter().enumerate() {
            w.row(lines[k] as f64, &[if kept[k] { 1.0 } else { 0.0 }, r[0], r[1], r[2]])?;
        }
        w.flush()?;
    }
    Ok(())
}

/// `name = value ± σ unit` (without `± σ` when there is none).
fn line(name: &str, v: f64, sd: Option<f64>, unit: &str) -> String {
    match sd {
        Some(s) => format!("{name} = {} ± {}{unit}", num(v), num(s)),
        None => format!("{name} = {}{unit}", num(v)),
    }
}

/// The wheels as asked: diameters `2r ± 2σ` or radii.
fn wheel_lines(report: Report, r_l: f64, r_r: f64, sd: Option<(f64, f64)>) -> Vec<String> {
    let (k, word) = match report {
        Report::Diameters => (2.0, "diameter"),
        Report::Radii => (1.0, "radius"),
    };
    vec![
        line(&format!("left wheel {word}"), k * r_l, sd.map(|s| k * s.0), " m"),
        line(&format!("right wheel {word}"), k * r_r, sd.map(|s| k * s.1), " m"),
    ]
}

/// Every parameter of an estimate, `name = value ± σ unit`.
fn all_lines(e: &Estimate, unit: &str) -> Vec<String> {
    let sd = e.std_dev();
    (0..e.value.len())
        .map(|i| line(&e.names[i], e.value[i], Some(sd[i]), unit))
        .collect()
}

/// censi's report: the wheels, the wheel base and the sensor pose with their standard
/// deviations, then J21, J22 and what trimming kept.
fn censi_lines(f: &censi::CensiFit, n: usize, trim: censi::Trim, report: Report) -> Vec<String> {
    let sd = f.estimate.std_dev();
    let (v, e) = (&f.estimate.value, &f.estimate);
    let at = |name: &str| e.names.iter().position(|n| n == name).expect("censi's parameter names");
    let (il, ir) = (at("r_L"), at("r_R"));
    let mut text = wheel_lines(report, v[il], v[ir], Some((sd[il], sd[ir])));
    for (name, key, unit) in [
        ("wheel separation", "b", " m"),
        ("sensor x", "l_x", " m"),
        ("sensor y", "l_y", " m"),
        ("sensor theta", "l_theta", " rad"),
        ("J21", "J21", ""),
        ("J22", "J22", ""),
    ] {
        let i = at(key);
        text.push(line(name, v[i], Some(sd[i]), unit));
    }
    let how = if trim.fraction == 0.0 || trim.rounds == 0 {
        "no trimming".to_string()
    } else {
        format!(
            "trimmed {} % per round, {} rounds",
            num(100.0 * trim.fraction),
            trim.rounds
        )
    };
    text.push(format!(
        "kept {} of {n} intervals ({how}); scan matcher sigma_theta = {} rad, sigma_xy = {} m",
        f.kept.len(),
        num(f.sigma2_theta.sqrt()),
        num(f.sigma2_xy.sqrt())
    ));
    text
}

/// UMBmark from a log: runs between pose pairs, their return errors in the start frame.
fn umbmark_runs(
    samples: &[(f64, f64, f64)],
    poses: &[(f64, Vector3<f64>)],
    robot: &DiffDrive,
) -> Result<reckon::calibration::umbmark::UmbmarkFit, Box<dyn Error>> {
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
        for s in rows_between(samples, ta, tb) {
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
    Ok(reckon::calibration::umbmark::calibrate(
        &cw,
        &ccw,
        side,
        robot.wheel_separation,
    )?)
}

/// The encoder rows with `ta < t ≤ tb` (the rows are in increasing time: a binary search,
/// so that many poses over a long log cost `O(poses·log rows)`, not `O(poses·rows)`).
fn rows_between(samples: &[(f64, f64, f64)], ta: f64, tb: f64) -> &[(f64, f64, f64)] {
    let a = samples.partition_point(|s| s.0 <= ta);
    let b = samples.partition_point(|s| s.0 <= tb).max(a);
    &samples[a..b]
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
        let wheels: Vec<[f64; 2]> = rows_between(samples, ta, tb)
            .iter()
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
            reckon::vehicles::wrap_angle(d[2]),
        );
        out.push(censi::Interval { wheels, sensor: rel });
    }
    Ok(out)
}

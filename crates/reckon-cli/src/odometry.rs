//! `reckon odometry`: dead-reckon a differential-drive robot from wheel-encoder counts,
//! streamed row by row (constant memory for a log of any length).

use super::csvio::{RowWriter, Rows, check_not_input, num};
use reckon::reckoning::encoders::{DiffDrive, Update, advance};
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// What the left and right columns hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Counts {
    /// pulses since the previous row (the pose after the first row includes its pulses)
    #[default]
    Increments,
    /// running pulse counts as most encoder drivers log them; the first row is the
    /// reference: the pose there is (0, 0, 0)
    Cumulative,
}

/// Arguments of `reckon odometry`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
With --counts increments (the default), a one-line warning is printed on stderr when the \
counts look cumulative. The test looks at the first 1000 rows (at least 10): each wheel's \
column changes direction (rises after falling or falls after rising) at most once per 50 \
rows (at least once allowed), and for at least one wheel the median change between \
consecutive rows is positive and at most a tenth of the median count. Running counts \
read as increments give a wildly wrong path: rerun with --counts cumulative if they are \
(noise-free increments of a robot that accelerates through the whole window can trip it).")]
pub struct OdometryArgs {
    /// Encoders CSV: header t,left,right (other columns are ignored); pulse increments
    /// since the previous sample, or running counts with --counts cumulative.
    #[arg(long)]
    pub encoders: PathBuf,
    /// The robot's encoder geometry.
    #[command(flatten)]
    pub geometry: Geometry,
    /// What the left and right columns hold.
    #[arg(long, value_enum, default_value_t = Counts::Increments)]
    pub counts: Counts,
    /// Pose update rule.
    #[arg(long, default_value = "midpoint", value_parser = ["midpoint", "exact", "euler"])]
    pub update: String,
    /// Output CSV (default: standard output); may not be the encoders file.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// A differential drive's encoder geometry on the command line (`reckon odometry`, and the
/// nominal values `reckon calibrate` starts from).
#[derive(Debug, clap::Args)]
pub struct Geometry {
    /// Wheel diameter in metres.
    #[arg(long, allow_hyphen_values = true)]
    pub wheel_diameter: f64,
    /// Distance between the wheels in metres.
    #[arg(long, allow_hyphen_values = true)]
    pub wheel_separation: f64,
    /// Encoder pulses per wheel revolution.
    #[arg(long, allow_hyphen_values = true)]
    pub pulses_per_rev: f64,
}

impl Geometry {
    /// The validated geometry ([`DiffDrive::new`]).
    pub fn robot(&self) -> reckon::Result<DiffDrive> {
        DiffDrive::new(self.wheel_diameter, self.wheel_separation, self.pulses_per_rev)
    }
}

/// Rows the cumulative-counts heuristic looks at.
const WINDOW: usize = 1000;
/// Fewest rows on which the heuristic gives a verdict.
const MIN_ROWS: usize = 10;

/// Whether `(left, right)` samples look like running counts rather than increments:
/// each column changes direction at most once per 50 rows (at least once allowed), and for
/// at least one column the median change between rows is positive and at most a tenth of
/// the median magnitude (see the command's help); fewer than 10 rows never look cumulative.
///
/// ```
/// use reckon_cli::odometry::looks_cumulative;
/// // running counts from a non-zero start: straight, then the left wheel backs up
/// let mut cumulative: Vec<(f64, f64)> = (0..40).map(|k| (500.0 + 90.0 * k as f64, 800.0 + 91.0 * k as f64)).collect();
/// cumulative.extend((1..20).map(|k| (4010.0 - 50.0 * k as f64, 4349.0 + 50.0 * k as f64)));
/// assert!(looks_cumulative(&cumulative));
/// // increments of the same motion, with a pulse of jitter
/// let increments: Vec<(f64, f64)> = (0..60).map(|k| (90.0 + (k % 3) as f64, 91.0 - (k % 2) as f64)).collect();
/// assert!(!looks_cumulative(&increments));
/// ```
pub fn looks_cumulative(samples: &[(f64, f64)]) -> bool {
    let n = samples.len();
    if n < MIN_ROWS {
        return false;
    }
    let allowed = (n / 50).max(1);
    let column = |pick: fn(&(f64, f64)) -> f64| -> (bool, bool) {
        let v: Vec<f64> = samples.iter().map(pick).collect();
        let d: Vec<f64> = v.windows(2).map(|w| w[1] - w[0]).collect();
        let moves: Vec<bool> = d.iter().filter(|x| **x != 0.0).map(|x| *x > 0.0).collect();
        let reversals = moves.windows(2).filter(|w| w[0] != w[1]).count();
        let step = median(d.iter().map(|x| x.abs()).collect());
        let size = median(v.iter().map(|x| x.abs()).collect());
        (reversals <= allowed, step > 0.0 && step <= 0.1 * size)
    };
    let (l, r) = (column(|s| s.0), column(|s| s.1));
    l.0 && r.0 && (l.1 || r.1)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Run the command: one output row per input row, the pose after that row (increments:
/// the pose before the first row is (0, 0, 0); cumulative: the pose at the first row is
/// (0, 0, 0)); rows before a bad one are written, then the error naming its line.
pub fn run(args: &OdometryArgs) -> Result<(), Box<dyn Error>> {
    let robot = args.geometry.robot()?;
    let rule: Update = args.update.parse()?;
    let mut rdr = Rows::open(&args.encoders, &["t", "left", "right"])?;
    check_not_input(args.out.as_deref(), &args.encoders)?;
    let mut out = RowWriter::open(args.out.as_deref())?;
    out.line("t,x,y,theta")?;
    let result = integrate(args, &robot, rule, &mut rdr, &mut out);
    // everything computed is written; the first error (a row, a step or a write) is reported
    let written = out.flush();
    result?;
    Ok(written?)
}

fn integrate(
    args: &OdometryArgs,
    robot: &DiffDrive,
    rule: Update,
    rdr: &mut Rows,
    out: &mut RowWriter,
) -> Result<(), Box<dyn Error>> {
    let mut pose = nalgebra::Vector3::zeros();
    let mut previous: Option<(f64, f64)> = None;
    let mut window: Vec<(f64, f64)> = Vec::new();
    let mut judged = args.counts == Counts::Cumulative;
    let verdict = |window: &mut Vec<(f64, f64)>, judged: &mut bool| {
        if !*judged {
            *judged = true;
            if looks_cumulative(window) {
                // a closed stderr must not panic: the warning is then lost
                let _ = writeln!(
                    std::io::stderr(),
                    "reckon: warning: {}: the left/right columns look like running counts \
                     (monotone, changes small against the values), not increments: if so, use --counts cumulative",
                    args.encoders.display()
                );
            }
            *window = Vec::new();
        }
    };
    loop {
        let row = match rdr.next_row() {
            Ok(Some(row)) => row,
            Ok(None) => break,
            Err(e) => {
                verdict(&mut window, &mut judged);
                return Err(e.into());
            }
        };
        let (t, left, right) = (row[0], row[1], row[2]);
        let (n_l, n_r) = match args.counts {
            Counts::Increments => {
                if !judged {
                    window.push((left, right));
                    if window.len() == WINDOW {
                        verdict(&mut window, &mut judged);
                    }
                }
                (left, right)
            }
            Counts::Cumulative => {
                let d = match previous {
                    None => (0.0, 0.0),
                    Some((l0, r0)) => (left - l0, right - r0),
                };
                previous = Some((left, right));
                d
            }
        };
        let (ds, dth) = robot.increments(n_l, n_r);
        pose = advance(&pose, ds, dth, rule);
        if let Some(i) = pose.iter().position(|v| !v.is_finite()) {
            return Err(rdr
                .error(format!(
                    "the pose is not finite ({} = {}): pulses {}, {} overflow with this geometry",
                    ["x", "y", "theta"][i],
                    num(pose[i]),
                    num(n_l),
                    num(n_r)
                ))
                .into());
        }
        out.row(t, pose.as_slice())?;
    }
    verdict(&mut window, &mut judged);
    Ok(())
}

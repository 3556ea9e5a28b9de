//! `reckon preintegrate`: IMU preintegration (Forster et al. 2017, as GTSAM's
//! `PreintegratedImuMeasurementsManifold`) of a gyro and accelerometer log, cut into
//! keyframe windows, one output row per window: `ΔR` (rotation vector), `Δv`, `Δp`, the
//! 9×9 covariance of `[δφ, δv, δp]` and the bias Jacobians
//! ([`reckon::reckoning::preintegration::Preintegrated`]).
//!
//! The log is read twice: once to check every row and find its span (so that a bad row
//! or an absurd `--every` is refused before anything is written), then to integrate; it
//! must therefore be a file, not a pipe.

use super::csvio::{InputError, RowReader, RowWriter, check_not_input, num};
use nalgebra::{Matrix3, Vector3};
use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The most windows one run may produce.
pub const MAX_WINDOWS: f64 = 1e6;

/// The columns of the IMU log, in this order.
pub const COLUMNS: [&str; 7] = ["t", "gx", "gy", "gz", "ax", "ay", "az"];

/// Which way gravity points along the world z axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Gravity {
    /// world z up: `g = (0, 0, −g)` (GTSAM's `MakeSharedU`)
    #[default]
    Up,
    /// world z down (NED): `g = (0, 0, g)` (GTSAM's `MakeSharedD`)
    Down,
}

/// Arguments of `reckon preintegrate`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Each sample (gx,gy,gz in rad/s, ax,ay,az specific force in m/s²) is held until the next \
one's time. A window ends at the first sample at or after its nominal end t_first + k·every \
(within 10⁻⁹·every), so windows start and end on samples; a shorter last window covers the \
rest of the log. Without --every the whole log is one window. Output per window: t0,t1, \
the rotation vector of ΔR, Δv, Δp (body frame at t0, gravity not included), the 9 variances \
of [δφ, δv, δp] and the bias Jacobians row-major; --json gives the full covariance.")]
pub struct PreintegrateArgs {
    /// IMU CSV: header t,gx,gy,gz,ax,ay,az (other columns are ignored); time increasing.
    #[arg(long)]
    pub imu: PathBuf,
    /// Gyro white-noise density σ_g in rad/s/√Hz: one value for all axes or x,y,z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, required = true)]
    pub gyro_noise: Vec<f64>,
    /// Accelerometer white-noise density σ_a in m/s²/√Hz: one value or x,y,z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, required = true)]
    pub accel_noise: Vec<f64>,
    /// Integration (position) noise density, the square root of GTSAM's
    /// integrationCovariance: one value or x,y,z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0")]
    pub integration_noise: Vec<f64>,
    /// Gyro bias estimate b_g (rad/s), subtracted from every gyro sample: x,y,z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0,0,0")]
    pub gyro_bias: Vec<f64>,
    /// Accelerometer bias estimate b_a (m/s²), subtracted from every sample: x,y,z.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_value = "0,0,0")]
    pub accel_bias: Vec<f64>,
    /// World z axis up or down (gravity is along it).
    #[arg(long, value_enum, default_value_t = Gravity::Up)]
    pub gravity: Gravity,
    /// Gravity's magnitude in m/s².
    #[arg(long, default_value_t = 9.81, allow_hyphen_values = true)]
    pub g: f64,
    /// Window length in seconds (keyframe spacing); default: one window over the log.
    #[arg(long, allow_hyphen_values = true)]
    pub every: Option<f64>,
    /// Print JSON (one object with a `windows` array) instead of CSV.
    #[arg(long)]
    pub json: bool,
    /// Output file (default: standard output); may not be the IMU file.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `flag`'s three values: one value is repeated on every axis when `scalar_ok`.
fn three(flag: &str, v: &[f64], scalar_ok: bool) -> Result<Vector3<f64>, String> {
    let v = match (v.len(), scalar_ok) {
        (1, true) => Vector3::repeat(v[0]),
        (3, _) => Vector3::new(v[0], v[1], v[2]),
        (n, true) => return Err(format!("{flag} takes one value or three (x,y,z), got {n}")),
        (n, false) => return Err(format!("{flag} takes three values (x,y,z), got {n}")),
    };
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(format!("{flag} must be finite, got {}", num(*x)));
    }
    Ok(v)
}

/// A noise density flag as the covariance density `diag(σ²)`; σ finite and non-negative.
fn density(flag: &str, v: &[f64]) -> Result<Matrix3<f64>, String> {
    let s = three(flag, v, true)?;
    if let Some(x) = s.iter().find(|x| **x < 0.0) {
        return Err(format!("{flag} must be finite and non-negative, got {}", num(*x)));
    }
    Ok(Matrix3::from_diagonal(&s.component_mul(&s)))
}

impl PreintegrateArgs {
    /// The validated parameters and bias estimate; one line naming the flag otherwise.
    pub fn params(&self) -> Result<(PreintegrationParams, Bias), String> {
        if !(self.g.is_finite() && self.g >= 0.0) {
            return Err(format!(
                "--g must be finite and non-negative (use --gravity down for NED), got {}",
                num(self.g)
            ));
        }
        let base = match self.gravity {
            Gravity::Up => PreintegrationParams::up(self.g),
            Gravity::Down => PreintegrationParams::down(self.g),
        };
        let (gyro, accel, integration) = (
            density("--gyro-noise", &self.gyro_noise)?,
            density("--accel-noise", &self.accel_noise)?,
            density("--integration-noise", &self.integration_noise)?,
        );
        let params = base
            .and_then(|p| p.gyro(gyro))
            .and_then(|p| p.accel(accel))
            .and_then(|p| p.integration(integration))
            .map_err(|e| e.to_string())?;
        let bias = Bias {
            gyro: three("--gyro-bias", &self.gyro_bias, false)?,
            accel: three("--accel-bias", &self.accel_bias, false)?,
        };
        Ok((params, bias))
    }
}

/// `--every`, checked against the log's span `[t_first, t_last]`: finite, positive, and at
/// most `⌈(t_last − t_first)/every⌉ ≤ 10⁶` windows.
///
/// ```
/// use reckon_cli::preintegrate::check_every;
/// assert!(check_every(0.1, 0.0, 60.0).is_ok());
/// assert_eq!(check_every(0.0, 0.0, 1.0).unwrap_err(), "--every must be finite and positive, got 0");
/// assert!(check_every(1e-6, 0.0, 2.0).unwrap_err().contains("more than the limit of 10⁶"));
/// ```
pub fn check_every(every: f64, t_first: f64, t_last: f64) -> Result<(), String> {
    if !(every.is_finite() && every > 0.0) {
        return Err(format!("--every must be finite and positive, got {}", num(every)));
    }
    let windows = ((t_last - t_first) / every).ceil();
    if windows.is_nan() || windows > MAX_WINDOWS {
        return Err(format!(
            "--every {} cuts the log's {} s into {} windows, more than the limit of 10⁶",
            num(every),
            num(t_last - t_first),
            num(windows)
        ));
    }
    Ok(())
}

/// One output row's numbers after `t0`: `t1`, rotation vector, `Δv`, `Δp`, the nine
/// variances and the five bias Jacobians row-major (63 numbers).
pub fn csv_values(t1: f64, pim: &Preintegrated) -> Vec<f64> {
    let mut v = Vec::with_capacity(64);
    v.push(t1);
    v.extend_from_slice(pim.delta_r().log().as_slice());
    v.extend_from_slice(pim.delta_v().as_slice());
    v.extend_from_slice(pim.delta_p().as_slice());
    let c = pim.covariance();
    v.extend((0..9).map(|i| c[(i, i)]));
    for m in jacobians(pim) {
        v.extend((0..3).flat_map(|i| (0..3).map(move |j| m[(i, j)])));
    }
    v
}

/// The bias Jacobians in output order: `∂ΔR/∂b_g, ∂Δv/∂b_g, ∂Δv/∂b_a, ∂Δp/∂b_g, ∂Δp/∂b_a`.
fn jacobians(pim: &Preintegrated) -> [Matrix3<f64>; 5] {
    let j = pim.bias_jacobians();
    [
        j.d_rotation_d_gyro,
        j.d_velocity_d_gyro,
        j.d_velocity_d_accel,
        j.d_position_d_gyro,
        j.d_position_d_accel,
    ]
}

/// The CSV header: 65 columns, `t0,t1`, `ΔR`'s rotation vector, `Δv`, `Δp`, the nine
/// variances, the five 3×3 bias Jacobians row-major.
///
/// ```
/// let h = reckon_cli::preintegrate::header();
/// let cols: Vec<&str> = h.split(',').collect();
/// assert_eq!(cols.len(), 65);
/// assert_eq!((cols[2], cols[19], cols[64]), ("rx", "var_pz", "dp_dba_22"));
/// ```
pub fn header() -> String {
    let mut h: Vec<String> = ["t0", "t1", "rx", "ry", "rz", "dvx", "dvy", "dvz", "dpx", "dpy", "dpz"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    for n in ["phix", "phiy", "phiz", "vx", "vy", "vz", "px", "py", "pz"] {
        h.push(format!("var_{n}"));
    }
    for name in ["dR_dbg", "dv_dbg", "dv_dba", "dp_dbg", "dp_dba"] {
        for i in 0..3 {
            for j in 0..3 {
                h.push(format!("{name}_{i}{j}"));
            }
        }
    }
    h.join(",")
}

fn rows3(m: &Matrix3<f64>) -> serde_json::Value {
    serde_json::json!((0..3).map(|i| [m[(i, 0)], m[(i, 1)], m[(i, 2)]]).collect::<Vec<_>>())
}

/// One window as a JSON object.
pub fn json_window(t0: f64, t1: f64, pim: &Preintegrated) -> serde_json::Value {
    let c = pim.covariance();
    let cov: Vec<Vec<f64>> = (0..9).map(|i| (0..9).map(|j| c[(i, j)]).collect()).collect();
    let j = jacobians(pim);
    serde_json::json!({
        "t0": t0,
        "t1": t1,
        "rotation_vector": pim.delta_r().log().as_slice(),
        "delta_v": pim.delta_v().as_slice(),
        "delta_p": pim.delta_p().as_slice(),
        "covariance": cov,
        "d_rotation_d_gyro_bias": rows3(&j[0]),
        "d_velocity_d_gyro_bias": rows3(&j[1]),
        "d_velocity_d_accel_bias": rows3(&j[2]),
        "d_position_d_gyro_bias": rows3(&j[3]),
        "d_position_d_accel_bias": rows3(&j[4]),
    })
}

/// Where the windows go: CSV rows or a streamed JSON array.
enum Sink {
    Csv(RowWriter),
    Json { out: Box<dyn Write>, first: bool },
}

impl Sink {
    fn open(path: Option<&Path>, json: bool) -> Result<Self, Box<dyn Error>> {
        if json {
            let mut out: Box<dyn Write> = match path {
                Some(p) => Box::new(std::io::BufWriter::new(
                    std::fs::File::create(p).map_err(|e| format!("cannot write {}: {e}", p.display()))?,
                )),
                None => Box::new(std::io::BufWriter::new(std::io::stdout())),
            };
            write!(out, "{{\"windows\":[")?;
            Ok(Sink::Json { out, first: true })
        } else {
            let mut w = RowWriter::open(path)?;
            w.line(&header())?;
            Ok(Sink::Csv(w))
        }
    }

    fn window(&mut self, t0: f64, t1: f64, pim: &Preintegrated) -> Result<(), Box<dyn Error>> {
        match self {
            Sink::Csv(w) => w.row(t0, &csv_values(t1, pim))?,
            Sink::Json { out, first } => {
                if !*first {
                    write!(out, ",")?;
                }
                *first = false;
                write!(out, "\n{}", serde_json::to_string(&json_window(t0, t1, pim))?)?;
            }
        }
        Ok(())
    }

    fn finish(&mut self) -> std::io::Result<()> {
        match self {
            Sink::Csv(w) => w.flush(),
            Sink::Json { out, .. } => {
                writeln!(out, "\n]}}")?;
                out.flush()
            }
        }
    }
}

/// The log's first and last times and its number of rows; the first bad row is an error.
fn scan(path: &Path) -> Result<(f64, f64, u64), InputError> {
    let mut rdr = RowReader::open(path, &COLUMNS)?;
    let (mut first, mut last) = (0.0, 0.0);
    while let Some(row) = rdr.next_row()? {
        last = row[0];
        if rdr.rows() == 1 {
            first = last;
        }
    }
    let n = rdr.rows();
    if n < 2 {
        return Err(InputError {
            file: rdr.file().to_string(),
            line: None,
            message: format!(
                "{n} IMU sample{}: at least two are needed (the last one's time ends the log)",
                if n == 1 { "" } else { "s" }
            ),
        });
    }
    Ok((first, last, n))
}

/// Run the command.
pub fn run(args: &PreintegrateArgs) -> Result<(), Box<dyn Error>> {
    let (params, bias) = args.params()?;
    let (t_first, t_last, n) = scan(&args.imu)?;
    if let Some(h) = args.every {
        check_every(h, t_first, t_last)?;
    }
    check_not_input(args.out.as_deref(), &args.imu)?;
    let mut sink = Sink::open(args.out.as_deref(), args.json)?;
    let result = integrate(args, params, bias, t_first, n, &mut sink);
    let written = sink.finish();
    result?;
    Ok(written?)
}

fn integrate(
    args: &PreintegrateArgs,
    params: PreintegrationParams,
    bias: Bias,
    t_first: f64,
    n: u64,
    sink: &mut Sink,
) -> Result<(), Box<dyn Error>> {
    let mut rdr = RowReader::open(&args.imu, &COLUMNS)?;
    let mut pim = Preintegrated::new(params, bias);
    // the previous sample (t, gyro, accel) and the current window's start
    let mut prev: Option<(f64, Vector3<f64>, Vector3<f64>)> = None;
    let mut t0 = t_first;
    // the nominal end of the current window
    let next_end = |t: f64, h: f64| t_first + (((t - t_first) / h + 1e-9).floor() + 1.0) * h;
    let mut end = args.every.map(|h| next_end(t_first, h));
    while let Some(row) = rdr.next_row()? {
        let t = row[0];
        let gyro = Vector3::new(row[1], row[2], row[3]);
        let accel = Vector3::new(row[4], row[5], row[6]);
        if let Some((tp, g, a)) = prev {
            pim.integrate(&g, &a, t - tp)
                .map_err(|e| rdr.error(format!("integrating from t = {} to {}: {e}", num(tp), num(t))))?;
            let close = match (end, args.every) {
                (Some(e), Some(h)) => t >= e - 1e-9 * h,
                _ => rdr.rows() == n,
            };
            if close {
                check_finite(&rdr, &pim)?;
                sink.window(t0, t, &pim)?;
                pim = Preintegrated::new(params, bias);
                t0 = t;
                end = args.every.map(|h| next_end(t, h));
            }
        }
        prev = Some((t, gyro, accel));
    }
    if rdr.rows() != n {
        return Err(rdr
            .error(format!("the file changed while read: {n} rows, then {}", rdr.rows()))
            .into());
    }
    if pim.delta_t() > 0.0 {
        // the rest of the log after the last full window
        check_finite(&rdr, &pim)?;
        sink.window(t0, prev.map_or(t0, |p| p.0), &pim)?;
    }
    Ok(())
}

/// The window's increments and covariance must be finite (samples of 10³⁰⁰ overflow).
fn check_finite<R: std::io::Read>(rdr: &RowReader<R>, pim: &Preintegrated) -> Result<(), InputError> {
    let finite = csv_values(0.0, pim).iter().all(|x| x.is_finite()) && pim.covariance().iter().all(|x| x.is_finite());
    if finite {
        Ok(())
    } else {
        Err(rdr.error("the window's increments or covariance overflow (not finite): samples too large".into()))
    }
}

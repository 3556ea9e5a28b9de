//! The `reckon` command, as a library module so that tests and fuzz targets can drive
//! it in-process. Not part of the stable API.
#![allow(missing_docs)]

pub mod calibrate;
pub mod csvio;
pub mod demo;
pub mod ensemble;
pub mod jacobian;
pub mod odometry;
pub mod plot;
pub mod preintegrate;
pub mod registry;
pub mod report;
pub mod simulate;
pub mod studies;

use clap::{Parser, Subcommand};
use std::ffi::OsString;

/// A whole-number flag's value, read by clap as `i128` (with `allow_hyphen_values`, so
/// that `-1` reaches this check instead of being taken for a flag) and checked here
/// against `range`: one line naming the flag and the range otherwise.
///
/// ```
/// use reckon_cli::whole;
/// assert_eq!(whole::<u64>("--members", 12, 1..=i128::from(u64::MAX)), Ok(12));
/// let e = whole::<u64>("--members", -1, 1..=i128::from(u64::MAX)).unwrap_err();
/// assert_eq!(e, "--members must be a whole number from 1 to 18446744073709551615, got -1");
/// ```
pub fn whole<T: TryFrom<i128>>(flag: &str, v: i128, range: std::ops::RangeInclusive<i128>) -> Result<T, String> {
    let bad = || {
        format!(
            "{flag} must be a whole number from {} to {}, got {v}",
            range.start(),
            range.end()
        )
    };
    if !range.contains(&v) {
        return Err(bad());
    }
    T::try_from(v).map_err(|_| bad())
}

/// Integrate ordinary differential equations and dead-reckon vehicles.
#[derive(Parser)]
#[command(name = "reckon", version, about)]
pub struct Args {
    #[command(subcommand)]
    pub command: Command,
}

/// Arguments of `reckon demo`.
#[derive(clap::Args)]
pub struct DemoArgs {
    /// Folder for the HTML report and its SVG figures.
    #[arg(long, default_value = "report")]
    pub out: std::path::PathBuf,
    /// Shorter studies (for tests and quick looks).
    #[arg(long)]
    pub fast: bool,
}

#[derive(Subcommand)]
pub enum Command {
    /// Every method on built-in problems (printed tables), then the report: vehicle
    /// scenarios, SLAM, UMBmark, IMU drift, convergence and stiffness studies, pitfalls.
    Demo(DemoArgs),
    /// Simulate a vehicle model driven by a controls CSV; write t,x,y,theta[,steer].
    Simulate(simulate::SimulateArgs),
    /// Dead-reckon a differential-drive robot from encoder pulse increments.
    Odometry(odometry::OdometryArgs),
    /// Observed order of convergence over a sequence of fixed steps.
    Convergence(studies::ConvergenceArgs),
    /// Step-size behaviour, stiffness ratio, stability regions and the Dahlquist threshold.
    Stiffness(studies::StiffnessArgs),
    /// Correct digits (and max-norm error) against rhs evaluations and wall time over a
    /// tolerance sweep.
    WorkPrecision(studies::WorkPrecisionArgs),
    /// A model's right-hand side and Jacobian, traced from its body and printed
    /// symbolically (text, LaTeX, MathML, Rust or JSON with the sparsity pattern).
    Jacobian(jacobian::JacobianArgs),
    /// Calibrate a differential drive's wheel radii and wheel base from an encoder log
    /// and measured poses (least squares through the model, or Censi et al. 2013).
    Calibrate(calibrate::CalibrateArgs),
    /// Monte-Carlo ensemble of noisy encoder robots on every core (`--shard K/N` for
    /// batch schedulers, `ensemble merge` to combine shards exactly).
    Ensemble(Box<ensemble::EnsembleCmd>),
    /// IMU preintegration (Forster et al. 2017) of a gyro/accelerometer log in keyframe
    /// windows: ΔR, Δv, Δp, their 9×9 covariance and the bias Jacobians per window.
    Preintegrate(preintegrate::PreintegrateArgs),
}

/// Parse `argv` (program name first) and run the command. `Err` carries clap's own
/// error (help, version, usage) or the command's one-line failure.
pub fn run<I, T>(argv: I) -> Result<(), Box<dyn std::error::Error>>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let args = Args::try_parse_from(argv)?;
    dispatch(args)
}

/// Run a parsed command.
pub fn dispatch(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    match args.command {
        Command::Demo(a) => {
            use std::io::Write;
            // write errors (a closed pipe, a full disk) end the command with one message
            let mut out = studies::Stdout::lock();
            demo::run(&mut out)?;
            out.flush()?;
            let n = report::run(&a.out, a.fast)?;
            writeln!(out, "\nwrote {} ({n} figures)", a.out.join("index.html").display())?;
            out.flush()?;
            Ok(())
        }
        Command::Simulate(a) => simulate::run(&a),
        Command::Odometry(a) => odometry::run(&a),
        Command::Convergence(a) => studies::convergence(&a),
        Command::Stiffness(a) => studies::stiffness(&a),
        Command::WorkPrecision(a) => studies::work_precision(&a),
        Command::Jacobian(a) => jacobian::run(&a),
        Command::Calibrate(a) => calibrate::run(&a),
        Command::Ensemble(a) => ensemble::run(&a),
        Command::Preintegrate(a) => preintegrate::run(&a),
    }
}

//! `reckon odometry`: dead-reckon a differential-drive robot from encoder increments.

use super::csvio::{open_output, read_table, write_row};
use crate::reckoning::encoders::{DiffDrive, Update, advance};
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `reckon odometry`.
#[derive(Debug, clap::Args)]
pub struct OdometryArgs {
    /// Encoders CSV: header t,left,right with pulse increments since the previous sample.
    #[arg(long)]
    pub encoders: PathBuf,
    /// Wheel diameter in metres.
    #[arg(long, allow_negative_numbers = true)]
    pub wheel_diameter: f64,
    /// Distance between the wheels in metres.
    #[arg(long, allow_negative_numbers = true)]
    pub wheel_separation: f64,
    /// Encoder pulses per wheel revolution.
    #[arg(long, allow_negative_numbers = true)]
    pub pulses_per_rev: f64,
    /// Pose update rule.
    #[arg(long, default_value = "midpoint", value_parser = ["midpoint", "exact", "euler"])]
    pub update: String,
    /// Output CSV (default: standard output).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Run the command: one output row per input row, the pose after that row's increments
/// (the pose before the first row is (0, 0, 0)); rows before a bad one are written.
pub fn run(args: &OdometryArgs) -> Result<(), Box<dyn Error>> {
    let robot = DiffDrive::new(args.wheel_diameter, args.wheel_separation, args.pulses_per_rev)?;
    let rule: Update = args.update.parse()?;
    let table = read_table(&args.encoders, &["t", "left", "right"])?;
    let mut out = open_output(args.out.as_deref())?;
    writeln!(out, "t,x,y,theta")?;
    let mut pose = nalgebra::Vector3::zeros();
    for (_, row) in &table.rows {
        let (ds, dth) = robot.increments(row[1], row[2]);
        pose = advance(&pose, ds, dth, rule);
        write_row(&mut out, row[0], pose.as_slice())?;
    }
    out.flush()?;
    match table.error {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

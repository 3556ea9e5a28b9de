//! `reckon ensemble`: many noisy encoder robots driving a controls log on every core,
//! the odometry error's statistics per saved time; `--shard K/N` and `ensemble merge`
//! spread one ensemble over machines and combine the parts exactly.

use super::csvio::{InputError, RowWriter, check_not_input, num, read_table};
use crate::ensemble::encoder::{COLUMNS, EncoderEnsemble};
use crate::ensemble::{Ensemble, Shard, Statistics};
use crate::reckoning::encoders::Update;
use crate::reckoning::errors::{Command, EncoderErrors};
use std::error::Error;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// Models the command knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EnsembleModel {
    /// a differential-drive robot (the unicycle driven by wheel encoders); controls t,v,omega
    Unicycle,
}

/// `reckon ensemble` and `reckon ensemble merge`.
#[derive(Debug, clap::Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = "\
Each member drives the controls (each row's v, omega hold until the next row's t; the last \
row's t is the end) with the robot's true geometry and noise, sampled every --dt, and \
dead-reckons its own encoder counts with the nominal geometry. Per saved time (the end of \
every --save-every-th row interval, and of the last) the output CSV has the odometry error \
(odometry − truth): count, mean and standard deviation of ex, ey, etheta, their \
covariances, and quantiles of the radial error √(ex² + ey²) (relative accuracy 0.4 %). \
Member i uses the seed splitmix64(seed + (i+1)·0x9E3779B97F4A7C15): the statistics are \
the same bits for any number of threads and any split into shards. With --shard K/N only \
members K, K+N, … run; write their --stats and combine the N files with `reckon ensemble \
merge`, which gives exactly what one run of all members gives."
)]
pub struct EnsembleCmd {
    #[command(subcommand)]
    pub merge: Option<EnsembleSub>,
    #[command(flatten)]
    pub run: EnsembleArgs,
}

#[derive(Debug, clap::Subcommand)]
pub enum EnsembleSub {
    /// Combine the --stats files of shards of one ensemble (exactly).
    Merge(MergeArgs),
}

/// Arguments of `reckon ensemble merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shards' --stats files.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Write the merged statistics (mergeable JSON) here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Summary CSV (default: standard output).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Arguments of `reckon ensemble`.
#[derive(Debug, clap::Args)]
pub struct EnsembleArgs {
    /// Vehicle model (required without `merge`).
    #[arg(long, value_enum)]
    pub model: Option<EnsembleModel>,
    /// Controls CSV: header t,v,omega (other columns are ignored; required without `merge`).
    #[arg(long)]
    pub controls: Option<PathBuf>,
    /// Members in the whole ensemble (required without `merge`).
    #[arg(long)]
    pub members: Option<u64>,
    /// Master seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Wheel diameter in metres (the nominal geometry the odometry assumes; required
    /// without `merge`).
    #[arg(long, allow_hyphen_values = true)]
    pub wheel_diameter: Option<f64>,
    /// Distance between the wheels in metres (required without `merge`).
    #[arg(long, allow_hyphen_values = true)]
    pub wheel_separation: Option<f64>,
    /// Encoder pulses per wheel revolution (required without `merge`).
    #[arg(long, allow_hyphen_values = true)]
    pub pulses_per_rev: Option<f64>,
    /// The encoder errors.
    #[command(flatten)]
    pub errors: ErrorFlags,
    /// Encoder sample period (s).
    #[arg(long, default_value_t = 0.01, allow_hyphen_values = true)]
    pub dt: f64,
    /// Odometry update rule.
    #[arg(long, default_value = "exact", value_parser = ["midpoint", "exact", "euler"])]
    pub update: String,
    /// Save every K-th row interval's end (default: at most 200 saved times).
    #[arg(long)]
    pub save_every: Option<usize>,
    /// Run only members K, K+N, K+2N, … (K from 0).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Worker threads (default: one per core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write the mergeable statistics (JSON) here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Summary CSV (default: standard output).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// The encoder error model on the command line (Borenstein & Feng's systematic errors,
/// slip and pulse noise, and between-member spreads).
#[derive(Debug, clap::Args)]
pub struct ErrorFlags {
    /// True left wheel diameter ÷ nominal.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub left_scale: f64,
    /// True right wheel diameter ÷ nominal.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub right_scale: f64,
    /// True wheelbase ÷ nominal.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub wheelbase_scale: f64,
    /// σ of the fraction of each wheel's travel lost to slip per sample (|N(0, σ)|).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub slip: f64,
    /// σ of white noise on each pulse count (pulses per sample).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub pulse_noise: f64,
    /// Count whole pulses only.
    #[arg(long)]
    pub quantize: bool,
    /// Relative σ of each wheel's diameter between members.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub diameter_sigma: f64,
    /// Relative σ of the wheelbase between members.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub wheelbase_sigma: f64,
}

/// Run `reckon ensemble [merge]`.
pub fn run(cmd: &EnsembleCmd) -> Result<(), Box<dyn Error>> {
    match &cmd.merge {
        Some(EnsembleSub::Merge(m)) => merge(m),
        None => run_members(&cmd.run),
    }
}

fn commands(path: &Path) -> Result<Vec<Command>, Box<dyn Error>> {
    let table = read_table(path, &["t", "v", "omega"])?;
    if let Some(e) = table.error {
        return Err(e.into());
    }
    let rows = &table.rows;
    let file = path.display();
    if rows.len() < 2 {
        return Err(format!("{file}: at least two rows are needed (the last row's t is the end time)").into());
    }
    let mut out = Vec::with_capacity(rows.len() - 1);
    for w in rows.windows(2) {
        let ((_, a), (line, b)) = (&w[0], &w[1]);
        if b[0].partial_cmp(&a[0]) != Some(std::cmp::Ordering::Greater) {
            return Err(InputError {
                file: file.to_string(),
                line: Some(*line),
                message: format!("t = {} does not increase (previous row: {})", num(b[0]), num(a[0])),
            }
            .into());
        }
        out.push(Command {
            v: a[1],
            omega: a[2],
            duration: b[0] - a[0],
        });
    }
    Ok(out)
}

/// FNV-1a of the bytes: identifies the controls file in the job description.
fn fingerprint(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ *b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn run_members(a: &EnsembleArgs) -> Result<(), Box<dyn Error>> {
    let missing = |what: &str| format!("{what} is required (or use `reckon ensemble merge`)");
    let (model, controls, members) = (a.model.is_some(), a.controls.as_ref(), a.members);
    let geometry = (a.wheel_diameter, a.wheel_separation, a.pulses_per_rev);
    let (true, Some(controls), Some(members), (Some(d), Some(b), Some(ppr))) = (model, controls, members, geometry)
    else {
        let what = [
            (model, "--model"),
            (controls.is_some(), "--controls"),
            (members.is_some(), "--members"),
            (geometry.0.is_some(), "--wheel-diameter"),
            (geometry.1.is_some(), "--wheel-separation"),
            (geometry.2.is_some(), "--pulses-per-rev"),
        ]
        .iter()
        .find(|(given, _)| !given)
        .map_or("--model", |(_, name)| name);
        return Err(missing(what).into());
    };
    let robot = crate::reckoning::encoders::DiffDrive::new(d, b, ppr)?;
    let update: Update = a.update.parse()?;
    let shard: Shard = match &a.shard {
        Some(s) => s.parse()?,
        None => Shard::ALL,
    };
    for out in [&a.out, &a.stats].into_iter().flatten() {
        check_not_input(Some(out), controls)?;
    }
    let cmds = commands(controls)?;
    let e = &a.errors;
    let errors = EncoderErrors {
        left_scale: e.left_scale,
        right_scale: e.right_scale,
        wheelbase_scale: e.wheelbase_scale,
        quantize: e.quantize,
        slip_sigma: e.slip,
        pulse_noise: e.pulse_noise,
        seed: 0,
    };
    let every = a.save_every.unwrap_or(cmds.len().div_ceil(200)).max(1);
    let mut drive = EncoderEnsemble::new(robot, errors, cmds, a.dt)?
        .spreads(e.diameter_sigma, e.wheelbase_sigma)?
        .save_every(every);
    drive.update = update;
    let bytes = std::fs::read(controls).map_err(|err| format!("{}: {err}", controls.display()))?;
    let job = format!(
        "model unicycle; controls {:016x}; dt {}; update {}; geometry {} {} {}; errors {:?}; spreads {} {}; every {}",
        fingerprint(&bytes),
        num(a.dt),
        a.update,
        num(robot.wheel_diameter),
        num(robot.wheel_separation),
        num(robot.pulses_per_rev),
        errors,
        num(e.diameter_sigma),
        num(e.wheelbase_sigma),
        every
    );
    let mut runner = Ensemble::new(members, a.seed)
        .shard(shard)
        .progress(std::io::stderr().is_terminal())
        .job(job);
    runner.threads = a.threads;
    let layout = drive.layout();
    let stats = runner.run(&layout, |m, rows| drive.member(m, rows))?;
    write_outputs(&stats, a.stats.as_deref(), a.out.as_deref())
}

fn merge(m: &MergeArgs) -> Result<(), Box<dyn Error>> {
    let mut all: Option<Statistics> = None;
    for path in &m.shards {
        for out in [&m.out, &m.stats].into_iter().flatten() {
            check_not_input(Some(out), path)?;
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let s: Statistics = serde_json::from_str(&text).map_err(|e| {
            format!(
                "{}: not ensemble statistics (reckon ensemble --stats): {e}",
                path.display()
            )
        })?;
        match &mut all {
            None => all = Some(s),
            Some(acc) => acc.merge(&s).map_err(|e| format!("{}: {e}", path.display()))?,
        }
    }
    let all = all.ok_or("ensemble merge: no files")?;
    if !all.is_complete() {
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "reckon: warning: {} of {} shards merged: the statistics cover only their members",
            all.shards.len(),
            all.shard_count
        );
    }
    write_outputs(&all, m.stats.as_deref(), m.out.as_deref())
}

/// Quantiles of the radial error in the summary.
const QUANTILES: [f64; 4] = [0.5, 0.9, 0.95, 0.99];

fn write_outputs(stats: &Statistics, json: Option<&Path>, out: Option<&Path>) -> Result<(), Box<dyn Error>> {
    if let Some(p) = json {
        let text = serde_json::to_string(stats)?;
        std::fs::write(p, text).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    let mut w = RowWriter::open(out)?;
    let header: Vec<String> = [
        "members",
        "mean_ex",
        "mean_ey",
        "mean_etheta",
        "sd_ex",
        "sd_ey",
        "sd_etheta",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain(
        ["cov_ex_ey", "cov_ex_etheta", "cov_ey_etheta"]
            .iter()
            .map(|s| s.to_string()),
    )
    .chain(QUANTILES.iter().map(|q| format!("radial_p{}", (q * 100.0).round())))
    .collect();
    w.line(&format!("t,{}", header.join(",")))?;
    let radial = COLUMNS.len() - 1;
    for (k, t) in stats.layout.times.iter().enumerate() {
        let (mean, cov) = (stats.mean(k), stats.covariance(k));
        let mut row = vec![stats.snapshots[k].moments.count() as f64];
        row.extend(mean.iter());
        row.extend((0..3).map(|i| cov[(i, i)].sqrt()));
        row.extend([cov[(0, 1)], cov[(0, 2)], cov[(1, 2)]]);
        row.extend(
            QUANTILES
                .iter()
                .map(|q| stats.quantile(k, radial, *q).unwrap_or(f64::NAN)),
        );
        w.row(*t, &row)?;
    }
    Ok(w.flush()?)
}

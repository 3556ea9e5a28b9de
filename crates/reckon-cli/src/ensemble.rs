//! `reckon ensemble`: many noisy encoder robots driving a controls log on every core,
//! the odometry error's statistics per saved time; `--shard K/N` and `ensemble merge`
//! spread one ensemble over machines and combine the parts exactly.

use super::csvio::{InputError, RowWriter, check_distinct_outputs, check_not_input, num, read_table};
use super::whole;
use reckon::ensemble::encoder::{COLUMNS, EncoderEnsemble};
use reckon::ensemble::{Ensemble, Shard, Statistics};
use reckon::error::Brief;
use reckon::reckoning::encoder_sim::{Command, EncoderErrors};
use reckon::reckoning::encoders::Update;
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
merge`, which gives exactly what one run of all members gives. The summary's t are the \
controls' own times. Statistics undefined for so few members (everything with none, \
standard deviations and covariances with one) are empty cells, with a warning; statistics \
that f64 cannot hold are an error, and nothing is written. A run is refused up front when \
a member would drive more than 10⁹ samples or the run more than 10¹² (about 20 core-hours; \
split it with --shard). `ensemble merge` checks every file against the invariants a run \
keeps (shards below the shard count and each once, the members counted matching the \
shards claimed, one snapshot per saved time, sums an f64 run can reach) and refuses a file \
that breaks one, naming the file and the field."
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
    /// Members in the whole ensemble, at least 1 (required without `merge`).
    #[arg(long, allow_hyphen_values = true)]
    pub members: Option<i128>,
    /// Master seed, 0 to 2⁶⁴ − 1.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub seed: i128,
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
    /// Save every K-th row interval's end, K ≥ 1 (default: at most 200 saved times).
    #[arg(long, allow_hyphen_values = true)]
    pub save_every: Option<i128>,
    /// Run only members K, K+N, K+2N, … (K from 0).
    #[arg(long, value_name = "K/N", allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// Worker threads, 1 to 1024 (default: one per core).
    #[arg(long, allow_hyphen_values = true)]
    pub threads: Option<i128>,
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

/// The commands of a controls file and the time at the end of each (its next row's `t`,
/// on the file's clock).
fn commands(path: &Path) -> Result<(Vec<Command>, Vec<f64>), Box<dyn Error>> {
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
    let ends = rows[1..].iter().map(|(_, r)| r[0]).collect();
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
    Ok((out, ends))
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
    let members: u64 = whole("--members", members, 1..=i128::from(u64::MAX))?;
    let seed: u64 = whole("--seed", a.seed, 0..=i128::from(u64::MAX))?;
    let threads: Option<usize> = a
        .threads
        .map(|n| whole("--threads", n, 1..=reckon::ensemble::MAX_THREADS as i128))
        .transpose()?;
    let save_every: Option<usize> = a
        .save_every
        .map(|n| whole("--save-every", n, 1..=usize::MAX as i128))
        .transpose()?;
    let robot = reckon::reckoning::encoders::DiffDrive::new(d, b, ppr)?;
    let update: Update = a.update.parse()?;
    let shard: Shard = match &a.shard {
        Some(s) => s.parse()?,
        None => Shard::ALL,
    };
    for out in [&a.out, &a.stats].into_iter().flatten() {
        check_not_input(Some(out), controls)?;
    }
    if let (Some(json), Some(out)) = (&a.stats, &a.out) {
        check_distinct_outputs(("--stats", json), ("--out", out))?;
    }
    let (cmds, ends) = commands(controls)?;
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
    let every = save_every.unwrap_or(cmds.len().div_ceil(200).max(1));
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
    // the work of this run, refused up front when it could not finish
    let samples = drive.samples_per_member();
    let work = shard.len(members) as f64 * samples;
    if work > MAX_RUN_SAMPLES {
        return Err(format!(
            "--members {members}{} with --dt {}: {} members × {} encoder samples = {} samples in this run; at most {} (split the ensemble with --shard K/N, or take a longer --dt)",
            if shard == Shard::ALL { String::new() } else { format!(" --shard {}/{}", shard.index, shard.count) },
            Brief(a.dt),
            shard.len(members),
            Brief(samples),
            Brief(work),
            Brief(MAX_RUN_SAMPLES)
        )
        .into());
    }
    let mut runner = Ensemble::new(members, seed).shard(shard).job(job);
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(shard.len(members));
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} members  {elapsed} (eta {eta})")
                .expect("a valid template"),
        );
        b
    });
    if let Some(b) = &bar {
        let b = b.clone();
        runner = runner.on_progress(reckon::ensemble::Progress::new(move |done, _| b.set_position(done)));
    }
    runner.threads = threads;
    // saved times on the controls' clock: the exact t of the rows that end saved intervals
    let mut layout = drive.layout();
    layout.times = (0..ends.len()).filter(|i| drive.saved(*i)).map(|i| ends[i]).collect();
    let stats = runner.run(&layout, |m, rows| drive.member(m, rows));
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let stats = stats?;
    write_outputs(&stats, a.stats.as_deref(), a.out.as_deref())
}

fn merge(m: &MergeArgs) -> Result<(), Box<dyn Error>> {
    if let (Some(json), Some(out)) = (&m.stats, &m.out) {
        check_distinct_outputs(("--stats", json), ("--out", out))?;
    }
    let mut all: Option<Statistics> = None;
    for path in &m.shards {
        for out in [&m.out, &m.stats].into_iter().flatten() {
            check_not_input(Some(out), path)?;
        }
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let s = Statistics::from_json(&text).map_err(|e| {
            format!(
                "{}: not ensemble statistics as `reckon ensemble --stats` writes them: {e}",
                path.display()
            )
        })?;
        if s.layout.names != COLUMNS || s.layout.moments != 3 {
            return Err(format!(
                "{}: statistics of columns {:?} ({} with moments), not those of `reckon ensemble` ({COLUMNS:?}, 3 with moments)",
                path.display(),
                s.layout.names,
                s.layout.moments
            )
            .into());
        }
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

/// Encoder samples one `reckon ensemble` run may drive in all (members of the shard ×
/// samples per member): 10¹², about 20 core-hours at the 70 ns a sample takes (the
/// README's 20 000 members × 4 000 samples in 5.6 s on one thread). More is refused
/// before anything runs; shards split the work.
pub const MAX_RUN_SAMPLES: f64 = 1e12;

/// Quantiles of the radial error in the summary.
const QUANTILES: [f64; 4] = [0.5, 0.9, 0.95, 0.99];

/// One summary row: `t` and the statistics (`None`: undefined).
type SummaryRow = (f64, Vec<Option<f64>>);

/// The summary's cells at each saved time: `t`, then [`header`]'s statistics; `None` for
/// what is undefined (every statistic with no member, the standard deviations and
/// covariances with one). A defined statistic that is not finite (the errors' squares
/// beyond the range of f64) is an error naming the column and the time.
fn summary(stats: &Statistics) -> Result<Vec<SummaryRow>, String> {
    let names = header();
    let radial = COLUMNS.len() - 1;
    let mut rows = Vec::with_capacity(stats.layout.times.len());
    for (k, t) in stats.layout.times.iter().enumerate() {
        let n = stats.snapshots[k].moments.count();
        let (mean, cov) = (stats.mean(k), stats.covariance(k));
        let mut row = vec![Some(n as f64)];
        let some = |v: f64, ok: bool| ok.then_some(v);
        row.extend(mean.iter().map(|v| some(*v, n >= 1)));
        row.extend((0..3).map(|i| some(cov[(i, i)].sqrt(), n >= 2)));
        row.extend([cov[(0, 1)], cov[(0, 2)], cov[(1, 2)]].map(|v| some(v, n >= 2)));
        row.extend(QUANTILES.iter().map(|q| stats.quantile(k, radial, *q)));
        if let Some((i, v)) = row
            .iter()
            .enumerate()
            .find_map(|(i, v)| v.filter(|v| !v.is_finite()).map(|v| (i, v)))
        {
            let m = &stats.snapshots[k].moments;
            let largest = (0..3)
                .map(|c| m.min()[c].abs().max(m.max()[c].abs()))
                .fold(0.0, f64::max);
            return Err(format!(
                "{} at t = {} is {} (the errors reach {}: their squares overflow f64, so the statistics cannot be represented)",
                names[i],
                Brief(*t),
                Brief(v),
                Brief(largest)
            ));
        }
        rows.push((*t, row));
    }
    Ok(rows)
}

/// The summary's columns after `t`.
fn header() -> Vec<String> {
    [
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
    .collect()
}

/// Write the mergeable statistics and the summary CSV. Nothing is written when a
/// statistic cannot be represented; cells undefined for so few members are left empty,
/// with a warning on standard error.
fn write_outputs(stats: &Statistics, json: Option<&Path>, out: Option<&Path>) -> Result<(), Box<dyn Error>> {
    let rows = summary(stats)?;
    if let Some(p) = json {
        let text = serde_json::to_string(stats)?;
        std::fs::write(p, text).map_err(|e| format!("{}: {e}", p.display()))?;
    }
    let n = stats.count();
    if n < 2 {
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "reckon: warning: {n} member{} counted: {} undefined for n < 2 (the cells are left empty)",
            if n == 1 { "" } else { "s" },
            if n == 0 {
                "every statistic is"
            } else {
                "the standard deviations and covariances are"
            }
        );
    }
    let mut w = RowWriter::open(out)?;
    w.line(&format!("t,{}", header().join(",")))?;
    for (t, row) in rows {
        let cells: Vec<String> = row.iter().map(|v| v.map(num).unwrap_or_default()).collect();
        w.line(&format!("{},{}", num(t), cells.join(",")))?;
    }
    Ok(w.flush()?)
}

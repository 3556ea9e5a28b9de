//! Bodies of the fuzz targets, shared by `fuzz/fuzz_targets/*.rs` (libFuzzer) and by
//! `crates/reckon-cli/tests/it/fuzz_replay.rs` (which replays `fuzz/regressions/<target>/*` under `cargo test`).
//!
//! Every entry point takes raw bytes and must never panic: a typed error (`Err`) from the
//! library or the command is fine, a panic is a finding. Inputs are decoded with
//! `arbitrary::Unstructured`, so a saved crash file replays the same case everywhere.
#![allow(dead_code)]

use arbitrary::{Result, Unstructured};
use reckon::methods::{Auto, Bdf, Euler, Exact, ExponentialEuler, ImplicitEuler, Method, NewtonOptions, Rk45, Rodas5P};
use reckon::model::Flow;
use reckon::nalgebra::allocator::Allocator;
use reckon::nalgebra::{DVector, DefaultAllocator, Dim, Dyn, OVector, SVector, U1, Vector1, Vector2};
use reckon::problem::options::Tolerance;
use reckon::sensitivity::{self, Sensitivities, SensitivityOptions, Wrt};
use reckon::{Controls, Direction, DualSystem, Event, Options, Problem, StepSize, model};
use reckon::{LinearSolver, Save};
use std::cell::Cell;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Largest input file the targets write (keeps one execution short).
pub const MAX_FILE: usize = 2048;

// ---------------------------------------------------------------------------------------
// scratch space

static SCRATCH_ID: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static SCRATCH: PathBuf = {
        let d = std::env::temp_dir().join(format!(
            "reckon-fuzz-{}-{}",
            std::process::id(),
            SCRATCH_ID.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&d).expect("cannot create the fuzz scratch folder");
        d
    };
}

/// A folder private to this process and thread, reused by every execution.
pub fn scratch() -> PathBuf {
    SCRATCH.with(|d| d.clone())
}

/// Remove this thread's scratch folder (the replay test calls it at the end).
pub fn remove_scratch() {
    let _ = std::fs::remove_dir_all(scratch());
}

fn write_file(path: &Path, bytes: &[u8]) {
    std::fs::write(path, &bytes[..bytes.len().min(MAX_FILE)]).expect("cannot write a fuzz input file");
}

static TRACE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Print the decoded case of every input to stderr before running it (off by default;
/// `crates/reckon-cli/tests/it/fuzz_replay.rs`'s `show` test turns it on).
pub fn set_trace(on: bool) {
    TRACE.store(on, Ordering::Relaxed);
}

fn trace(what: impl FnOnce() -> String) {
    if TRACE.load(Ordering::Relaxed) {
        eprintln!("{}", what());
    }
}

fn run_cli(argv: Vec<OsString>) {
    trace(|| format!("argv: {argv:?}"));
    // Err is a typed failure (clap usage error or the command's one-line message): fine.
    let _ = reckon_cli::run(argv);
}

// ---------------------------------------------------------------------------------------
// csv_inputs: arbitrary bytes as a controls or encoders CSV

const MODELS: [&str; 3] = ["unicycle", "bicycle", "carlike"];
const METHODS: [&str; 4] = ["euler", "implicit-euler", "rk45", "exact"];
const UPDATES: [&str; 3] = ["midpoint", "exact", "euler"];
/// (wheel diameter, wheel separation, pulses per revolution) of `reckon odometry`.
const ROBOTS: [(&str, &str, &str); 4] = [
    ("0.1", "0.5", "1024"),
    ("0.2", "0.3", "4096"),
    ("1e-9", "1e-9", "1"),
    ("1e300", "1e-300", "0.5"),
];

/// First byte: command and its settings; the rest (at most [`MAX_FILE`] bytes): the CSV.
///
/// bit 0: 0 simulate, 1 odometry; simulate: bits 1-2 model, bits 3-4 method;
/// odometry: bits 1-2 update rule, bits 3-4 robot geometry.
pub fn csv_inputs(data: &[u8]) {
    let Some((&sel, body)) = data.split_first() else {
        return;
    };
    let dir = scratch();
    let input = dir.join("input.csv");
    let out = dir.join("out.csv");
    write_file(&input, body);
    let pick = |shift: u8, n: usize| ((sel >> shift) & 3) as usize % n;
    let mut argv: Vec<OsString> = vec!["reckon".into()];
    if sel & 1 == 0 {
        argv.extend(
            [
                "simulate",
                "--model",
                MODELS[pick(1, 3)],
                "--method",
                METHODS[pick(3, 4)],
                "--controls",
            ]
            .map(OsString::from),
        );
    } else {
        let (d, s, p) = ROBOTS[pick(3, 4)];
        argv.extend(
            [
                "odometry",
                "--update",
                UPDATES[pick(1, 3)],
                "--wheel-diameter",
                d,
                "--wheel-separation",
                s,
                "--pulses-per-rev",
                p,
                "--encoders",
            ]
            .map(OsString::from),
        );
    }
    argv.push(input.into());
    argv.push("--out".into());
    argv.push(out.into());
    run_cli(argv);
}

// ---------------------------------------------------------------------------------------
// number generators

/// Values that break numerical code: zeros, signs, extremes, NaN, epoch-sized times.
const SPECIAL: [f64; 30] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    2.0,
    10.0,
    -10.0,
    100.0,
    1e-3,
    1e-6,
    1e-9,
    1e-12,
    1e-300,
    -1e-300,
    1e300,
    -1e300,
    1.7e9,
    -1.7e9,
    1.7e9 + 0.25,
    f64::EPSILON,
    f64::MIN_POSITIVE,
    5e-324,
    f64::MAX,
    f64::MIN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::NAN,
    std::f64::consts::PI,
    1e6,
];

fn float(u: &mut Unstructured) -> Result<f64> {
    Ok(match u.int_in_range(0u8..=3)? {
        0 => *u.choose(&SPECIAL)?,
        1 => u.arbitrary::<f64>()?,
        2 => f64::from(u.int_in_range(-64i32..=64)?) / 8.0,
        _ => {
            let e = u.int_in_range(-320i32..=310)?;
            let s = if u.arbitrary::<bool>()? { -1.0 } else { 1.0 };
            s * 10f64.powi(e)
        }
    })
}

/// A finite float, mostly of moderate size (for times and values that should be valid).
fn moderate(u: &mut Unstructured) -> Result<f64> {
    Ok(match u.int_in_range(0u8..=4)? {
        0 => *u.choose(&SPECIAL[..20])?,
        1 => {
            let e = u.int_in_range(-12i32..=12)?;
            let s = if u.arbitrary::<bool>()? { -1.0 } else { 1.0 };
            s * 10f64.powi(e)
        }
        _ => f64::from(u.int_in_range(-64i32..=64)?) / 8.0,
    })
}

/// A number as command-line text: special values, arbitrary floats, words that are not numbers.
fn num_text(u: &mut Unstructured) -> Result<String> {
    Ok(match u.int_in_range(0u8..=9)? {
        0 => u
            .choose(&["nan", "inf", "-inf", "", " ", "1e", "0x10", "1,5", "+1", "-0"])?
            .to_string(),
        1 => short_string(u)?,
        2 => u.int_in_range(0u64..=u64::MAX)?.to_string(),
        3 => format!("{:e}", float(u)?),
        _ => float(u)?.to_string(),
    })
}

fn list_text(u: &mut Unstructured) -> Result<String> {
    let n = u.int_in_range(0usize..=5)?;
    let mut items = Vec::with_capacity(n);
    for _ in 0..n {
        items.push(num_text(u)?);
    }
    Ok(items.join(","))
}

fn count_text(u: &mut Unstructured) -> Result<String> {
    Ok(match u.int_in_range(0u8..=4)? {
        0 => u
            .choose(&["0", "1", "2", "3", "-1", "1000000", "18446744073709551615", "1e3", ""])?
            .to_string(),
        1 => short_string(u)?,
        2 => u.arbitrary::<u64>()?.to_string(),
        _ => u.int_in_range(0u32..=50)?.to_string(),
    })
}

fn short_string(u: &mut Unstructured) -> Result<String> {
    let n = u.int_in_range(0usize..=16)?;
    let mut s = String::with_capacity(n);
    for _ in 0..n {
        s.push(u.arbitrary::<char>()?);
    }
    Ok(s)
}

fn one_of(u: &mut Unstructured, words: &[&str]) -> Result<String> {
    if u.ratio(1u8, 8)? {
        short_string(u)
    } else {
        Ok(u.choose(words)?.to_string())
    }
}

fn list_of(u: &mut Unstructured, words: &[&str]) -> Result<String> {
    let n = u.int_in_range(0usize..=5)?;
    let mut items = Vec::with_capacity(n);
    for _ in 0..n {
        items.push(one_of(u, words)?);
    }
    Ok(items.join(","))
}

// ---------------------------------------------------------------------------------------
// cli_args: argument vectors from the real flag set of each command

/// The study problems the commands know: the registry's own list, its first twelve
/// (later additions are left out so that the saved regression inputs replay exactly as
/// they were recorded).
const PROBLEMS: [&str; 12] = {
    let n = reckon_cli::registry::NAMES;
    [n[0], n[1], n[2], n[3], n[4], n[5], n[6], n[7], n[8], n[9], n[10], n[11]]
};
const STUDY_METHODS: [&str; 4] = ["euler", "implicit-euler", "rk45", "exact"];

/// An input file: fuzzer bytes, or a CSV with a plausible header and generated rows.
fn input_file(u: &mut Unstructured, headers: &[&str]) -> Result<Vec<u8>> {
    if u.ratio(1u8, 4)? {
        let n = u.int_in_range(0usize..=MAX_FILE)?;
        return Ok(u.bytes(n)?.to_vec());
    }
    let header = one_of(u, headers)?;
    let cols = header.split(',').count().max(1);
    let mut text = format!("{header}\n");
    let rows = u.int_in_range(0usize..=8)?;
    let mut t = moderate(u)?;
    for _ in 0..rows {
        text.push_str(&t.to_string());
        for _ in 1..cols {
            text.push(',');
            let v = if u.ratio(1u8, 6)? { float(u)? } else { moderate(u)? };
            text.push_str(&v.to_string());
        }
        text.push('\n');
        t += if u.ratio(1u8, 8)? {
            float(u)?
        } else {
            moderate(u)?.abs()
        };
    }
    Ok(text.into_bytes())
}

/// Flags of one command: `(flag, required, value)`; `None` value: a switch.
type FlagGen = fn(&mut Unstructured, &Path) -> Result<Option<String>>;

fn flags_of(cmd: &str) -> Vec<(&'static str, bool, FlagGen)> {
    let problem: FlagGen = |u, _| Ok(Some(one_of(u, &PROBLEMS)?));
    let json: FlagGen = |_, _| Ok(None);
    let num: FlagGen = |u, _| Ok(Some(num_text(u)?));
    let list: FlagGen = |u, _| Ok(Some(list_text(u)?));
    let count: FlagGen = |u, _| Ok(Some(count_text(u)?));
    let methods: FlagGen = |u, _| Ok(Some(list_of(u, &STUDY_METHODS)?));
    let file: FlagGen = |_, p| Ok(Some(p.display().to_string()));
    match cmd {
        "simulate" => vec![
            ("--model", true, |u, _| Ok(Some(one_of(u, &MODELS)?))),
            ("--method", true, |u, _| Ok(Some(one_of(u, &METHODS)?))),
            ("--controls", true, file),
            ("--dt", false, num),
            ("--rtol", false, num),
            ("--atol", false, num),
            ("--param", false, |u, _| {
                Ok(Some(format!("{}={}", one_of(u, &["wheelbase", "mass"])?, num_text(u)?)))
            }),
            ("--param", false, |u, _| {
                Ok(Some(one_of(u, &["wheelbase=1", "wheelbase", "=2"])?))
            }),
            ("--x0", false, list),
        ],
        "odometry" => vec![
            ("--encoders", true, file),
            ("--wheel-diameter", true, num),
            ("--wheel-separation", true, num),
            ("--pulses-per-rev", true, num),
            ("--update", false, |u, _| Ok(Some(one_of(u, &UPDATES)?))),
        ],
        "convergence" => vec![
            ("--problem", true, problem),
            ("--json", false, json),
            ("--methods", false, methods),
            ("--steps", false, list),
        ],
        "stiffness" => vec![
            ("--problem", true, problem),
            ("--json", false, json),
            ("--rtol", false, num),
            ("--atol", false, num),
            ("--max-steps", false, count),
        ],
        "calibrate" => vec![
            ("--encoders", false, file),
            ("--poses", false, |_, p| {
                Ok(Some(p.with_file_name("poses.csv").display().to_string()))
            }),
            ("--intervals", false, |u, p| {
                Ok(u.ratio(1u8, 2)?.then(|| p.display().to_string()))
            }),
            ("--method", false, |u, _| {
                Ok(Some(one_of(u, &["lsq", "censi", "umbmark"])?))
            }),
            ("--wheel-diameter", false, num),
            ("--wheel-separation", false, num),
            ("--pulses-per-rev", false, num),
            ("--sigma-xy", false, num),
            ("--sigma-theta", false, num),
            ("--trim", false, |u, _| {
                Ok(Some(match u.int_in_range(0u8..=2)? {
                    0 => num_text(u)?,
                    1 => format!("{},{}", num_text(u)?, count_text(u)?),
                    _ => list_text(u)?,
                }))
            }),
            ("--report", false, |u, _| Ok(Some(one_of(u, &["diameters", "radii"])?))),
        ],
        "ensemble" => vec![
            ("--model", true, |u, _| Ok(Some(one_of(u, &["unicycle"])?))),
            ("--controls", true, file),
            ("--members", true, |u, _| Ok(Some(bounded_count(u, 16)?))),
            ("--seed", false, count),
            ("--wheel-diameter", true, num),
            ("--wheel-separation", true, num),
            ("--pulses-per-rev", true, num),
            ("--left-scale", false, num),
            ("--right-scale", false, num),
            ("--wheelbase-scale", false, num),
            ("--slip", false, num),
            ("--pulse-noise", false, num),
            ("--quantize", false, json),
            ("--diameter-sigma", false, num),
            ("--wheelbase-sigma", false, num),
            ("--dt", false, |u, _| Ok(Some(sample_period(u)?))),
            ("--update", false, |u, _| Ok(Some(one_of(u, &UPDATES)?))),
            ("--save-every", false, count),
            ("--shard", false, |u, _| {
                Ok(Some(if u.ratio(1u8, 4)? {
                    one_of(
                        u,
                        &["0/0", "1/1", "/", "0/", "-1/2", "2/2", "0/18446744073709551616", "a/b"],
                    )?
                } else {
                    format!("{}/{}", count_text(u)?, count_text(u)?)
                }))
            }),
            ("--threads", false, |u, _| {
                Ok(Some(one_of(
                    u,
                    &["1", "1", "2", "0", "-1", "1025", "18446744073709551617", "x"],
                )?))
            }),
            ("--stats", false, |_, p| {
                Ok(Some(p.with_file_name("stats.json").display().to_string()))
            }),
        ],
        "jacobian" => vec![
            ("--model", false, |u, _| {
                Ok(Some(one_of(u, &["unicycle", "bicycle", "carlike", "body3d"])?))
            }),
            ("--problem", false, |u, _| {
                Ok(Some(if u.ratio(1u8, 3)? {
                    format!("brusselator:{}", bounded_count(u, 2000)?)
                } else {
                    one_of(
                        u,
                        &[
                            "robertson",
                            "vdp",
                            "orego",
                            "hires",
                            "lorenz",
                            "arenstorf",
                            "stiff-cosine",
                            "rotation-decay",
                            "sin-u",
                            "brusselator",
                            "brusselator:",
                            "brusselator:0",
                            "brusselator:1",
                            "brusselator:-1",
                            "brusselator:1e3",
                            "brusselator:500001",
                            "brusselator:1000000000000",
                        ],
                    )?
                }))
            }),
            ("--wheelbase", false, num),
            ("--format", false, |u, _| {
                Ok(Some(one_of(u, &["text", "latex", "mathml", "rust", "json"])?))
            }),
        ],
        _ => vec![
            ("--problem", true, problem),
            ("--json", false, json),
            ("--methods", false, methods),
            ("--tolerances", true, list),
            ("--steps", false, list),
            ("--runs", false, count),
        ],
    }
}

/// Not one of these may come from the fuzzer: the target chooses every path itself.
fn names_a_path(token: &str) -> bool {
    ["--out", "--controls", "--encoders", "--poses", "--intervals", "--stats"]
        .iter()
        .any(|f| token.starts_with(f))
}

/// A count that is valid and small (at most `max`) or one that must be refused (zero,
/// negative, beyond every limit, not a number): never a valid count that would make one
/// execution long.
fn bounded_count(u: &mut Unstructured, max: u32) -> Result<String> {
    Ok(if u.ratio(1u8, 4)? {
        u.choose(&[
            "0",
            "-1",
            "",
            "x",
            "1e3",
            "1000000000000000000000",
            "18446744073709551616",
            "170141183460469231731687303715884105728",
            "-170141183460469231731687303715884105729",
        ])?
        .to_string()
    } else {
        u.int_in_range(1..=max)?.to_string()
    })
}

/// `--dt` of `reckon ensemble`: a valid period of at least 0.01 s (with the controls'
/// spans of at most a few seconds: a few thousand samples a member), or one that must be
/// refused.
fn sample_period(u: &mut Unstructured) -> Result<String> {
    Ok(if u.ratio(1u8, 3)? {
        u.choose(&[
            "0", "-0", "-0.01", "nan", "inf", "-inf", "1e-300", "5e-324", "1e-12", "", "x",
        ])?
        .to_string()
    } else {
        (f64::from(u.int_in_range(1u32..=1000)?) / 100.0).to_string()
    })
}

/// A controls CSV for `reckon ensemble`: header `t,v,omega` (or a wrong one), at most
/// six rows a few seconds apart, now and then a cell that is not a valid number or a time
/// so late that the run must be refused.
fn ensemble_controls(u: &mut Unstructured) -> Result<Vec<u8>> {
    let header = one_of(u, &["t,v,omega", "t,v,omega,extra", "t,omega,v", "t,v", "v,t,omega"])?;
    let cols = header.split(',').count().max(1);
    let mut text = format!("{header}\n");
    let rows = u.int_in_range(0usize..=6)?;
    let mut t = f64::from(u.int_in_range(-8i32..=8)?) / 4.0;
    for _ in 0..rows {
        let cell = |u: &mut Unstructured, v: f64| -> Result<String> {
            Ok(if u.ratio(1u8, 12)? {
                u.choose(&["", "nan", "inf", "-inf", "1e300", "1e20", "-1", "x", "1e999", "0x1"])?
                    .to_string()
            } else {
                v.to_string()
            })
        };
        text.push_str(&cell(u, t)?);
        for _ in 1..cols {
            text.push(',');
            let v = f64::from(u.int_in_range(-64i32..=64)?) / 16.0;
            text.push_str(&cell(u, v)?);
        }
        text.push('\n');
        t += f64::from(u.int_in_range(-1i32..=16)?) / 4.0;
    }
    Ok(text.into_bytes())
}

// ---------------------------------------------------------------------------------------
// ensemble merge: real shard files, mutated

/// Real `--stats` files of `reckon ensemble --shard K/N`, made once per process in the
/// scratch folder: two jobs of two and three shards, and a one-shard job of one member.
fn real_shards() -> &'static [Vec<u8>] {
    static SHARDS: std::sync::OnceLock<Vec<Vec<u8>>> = std::sync::OnceLock::new();
    SHARDS.get_or_init(|| {
        let dir = scratch().join("shards");
        std::fs::create_dir_all(&dir).expect("cannot create the shard folder");
        let controls = dir.join("controls.csv");
        std::fs::write(&controls, "t,v,omega\n0,1,0.1\n1,1,-0.2\n2,0.5,0\n").expect("cannot write controls");
        let mut out = Vec::new();
        for (members, shards, seed, noise) in [(5, 2, "0", "0.5"), (7, 3, "42", "0"), (1, 1, "7", "1")] {
            for k in 0..shards {
                let stats = dir.join(format!("s{members}-{k}.json"));
                let argv: Vec<OsString> = [
                    "reckon",
                    "ensemble",
                    "--model",
                    "unicycle",
                    "--controls",
                    &controls.display().to_string(),
                    "--members",
                    &members.to_string(),
                    "--seed",
                    seed,
                    "--wheel-diameter",
                    "0.1",
                    "--wheel-separation",
                    "0.5",
                    "--pulses-per-rev",
                    "1024",
                    "--pulse-noise",
                    noise,
                    "--slip",
                    "0.01",
                    "--dt",
                    "0.1",
                    "--threads",
                    "1",
                    "--shard",
                    &format!("{k}/{shards}"),
                    "--stats",
                    &stats.display().to_string(),
                    "--out",
                    &dir.join("summary.csv").display().to_string(),
                ]
                .into_iter()
                .map(OsString::from)
                .collect();
                reckon_cli::run(argv).expect("a real shard");
                out.push(std::fs::read(&stats).expect("the shard's stats"));
            }
        }
        out
    })
}

/// Numbers a shard file can be given in place of one of its own.
const EXTREME_NUMBERS: [&str; 22] = [
    "0",
    "-0",
    "1",
    "-1",
    "2",
    "1e999",
    "-1e999",
    "1e-400",
    "1.7976931348623157e308",
    "5e-324",
    "4294967295",
    "4294967296",
    "9007199254740993",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775809",
    "1e18",
    "100000000000",
    "0.5",
    "-2.5",
    "NaN",
    "1e300",
];

/// Every leaf (and every array and object) of a JSON document, as a JSON pointer.
fn pointers(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                pointers(x, format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")), out);
            }
        }
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                pointers(x, format!("{at}/{i}"), out);
            }
        }
        _ => {}
    }
    out.push(at);
}

/// One real shard file with up to four edits: a field set to an extreme number (also ones
/// JSON's parser must refuse), to another type, removed, an array element repeated or
/// dropped, two fields swapped; or the text truncated, a byte changed, bytes inserted.
fn mutated_shard(u: &mut Unstructured) -> Result<Vec<u8>> {
    let base = u.choose(real_shards())?.clone();
    let edits = u.int_in_range(0u8..=4)?;
    if edits == 0 {
        return Ok(base);
    }
    let Ok(mut doc) = serde_json::from_slice::<serde_json::Value>(&base) else {
        return Ok(base);
    };
    let mut raw = Vec::new();
    let mut text_edits = Vec::new();
    for _ in 0..edits {
        let mut ptrs = Vec::new();
        pointers(&doc, String::new(), &mut ptrs);
        // fields by name more often than by position: the header fields matter most
        let ptr = if u.ratio(1u8, 2)? {
            let named: Vec<&String> = ptrs
                .iter()
                .filter(|p| {
                    !p.contains("/snapshots/") || p.ends_with("/n") || p.ends_with("/dim") || p.ends_with("/zero")
                })
                .collect();
            u.choose(&named)?.to_string()
        } else {
            u.choose(&ptrs)?.clone()
        };
        match u.int_in_range(0u8..=8)? {
            0..=2 => {
                // a raw number token, spliced in after serialisation
                let token = *u.choose(&EXTREME_NUMBERS)?;
                let mark = format!("@@raw{}@@", raw.len());
                raw.push((format!("\"{mark}\""), token.to_string()));
                if let Some(v) = doc.pointer_mut(&ptr) {
                    *v = serde_json::Value::String(mark);
                }
            }
            3 => {
                let other = match u.int_in_range(0u8..=5)? {
                    0 => serde_json::Value::Null,
                    1 => serde_json::Value::Bool(u.arbitrary()?),
                    2 => serde_json::Value::String(short_string(u)?),
                    3 => serde_json::json!([]),
                    4 => serde_json::json!({}),
                    _ => serde_json::json!(u.arbitrary::<i64>()?),
                };
                if let Some(v) = doc.pointer_mut(&ptr) {
                    *v = other;
                }
            }
            4 => remove(&mut doc, &ptr),
            5 => {
                // repeat an array element, or grow the array with a copy of its last
                if let Some(serde_json::Value::Array(a)) = doc.pointer_mut(&ptr) {
                    if let Some(last) = a.last().cloned() {
                        let times = u.int_in_range(1usize..=3)?;
                        a.extend(std::iter::repeat_n(last, times));
                    }
                } else if let Some((parent, _)) = ptr.rsplit_once('/')
                    && let Some(serde_json::Value::Array(a)) = doc.pointer_mut(parent)
                    && let Some(first) = a.first().cloned()
                {
                    a.push(first);
                }
            }
            6 => {
                let other = u.choose(&ptrs)?.clone();
                let (a, b) = (doc.pointer(&ptr).cloned(), doc.pointer(&other).cloned());
                if let (Some(a), Some(b)) = (a, b)
                    && !ptr.starts_with(&other)
                    && !other.starts_with(&ptr)
                {
                    *doc.pointer_mut(&ptr).expect("present") = b;
                    *doc.pointer_mut(&other).expect("present") = a;
                }
            }
            _ => text_edits.push((u.int_in_range(0u8..=2)?, u.arbitrary::<u32>()?, u.arbitrary::<u8>()?)),
        }
    }
    let mut text = serde_json::to_string(&doc).expect("JSON to text");
    for (mark, token) in &raw {
        text = text.replacen(mark.as_str(), token, 1);
    }
    let mut bytes = text.into_bytes();
    for (kind, at, byte) in text_edits {
        if bytes.is_empty() {
            break;
        }
        let at = at as usize % bytes.len();
        match kind {
            0 => bytes.truncate(at),
            1 => bytes[at] = byte,
            _ => bytes.insert(at, byte),
        }
    }
    Ok(bytes)
}

/// Remove the value at `ptr` from its object or array.
fn remove(doc: &mut serde_json::Value, ptr: &str) {
    let Some((parent, key)) = ptr.rsplit_once('/') else {
        return;
    };
    match doc.pointer_mut(parent) {
        Some(serde_json::Value::Object(m)) => {
            m.remove(&key.replace("~1", "/").replace("~0", "~"));
        }
        Some(serde_json::Value::Array(a)) => {
            if let Ok(i) = key.parse::<usize>()
                && i < a.len()
            {
                a.remove(i);
            }
        }
        _ => {}
    }
}

/// `reckon ensemble merge` over zero to four mutated real shard files (the same file
/// twice now and then), with `--stats` and `--out` in the scratch folder.
fn merge_argv(u: &mut Unstructured, dir: &Path) -> Result<Vec<OsString>> {
    let mut argv: Vec<OsString> = vec!["reckon".into(), "ensemble".into(), "merge".into()];
    let count = u.int_in_range(0usize..=4)?;
    let mut paths: Vec<PathBuf> = Vec::new();
    for i in 0..count {
        if !paths.is_empty() && u.ratio(1u8, 8)? {
            let again = u.choose(&paths)?.clone();
            paths.push(again);
            continue;
        }
        let bytes = mutated_shard(u)?;
        let path = dir.join(format!("shard{i}.json"));
        std::fs::write(&path, &bytes).expect("cannot write a shard");
        trace(|| {
            format!(
                "{}: {}",
                path.display(),
                String::from_utf8_lossy(&bytes[..bytes.len().min(600)])
            )
        });
        paths.push(path);
    }
    argv.extend(paths.into_iter().map(OsString::from));
    if u.arbitrary()? {
        argv.push("--stats".into());
        argv.push(dir.join("merged.json").into());
    }
    if u.ratio(1u8, 8)? {
        // a stray flag (never a path: merge reads its positional arguments)
        let token = one_of(u, &["--help", "--json", "--members", "-x", "--"])?;
        if token.starts_with('-') && !names_a_path(&token) {
            let at = u.int_in_range(3..=argv.len())?;
            argv.insert(at, token.into());
        }
    }
    argv.push("--out".into());
    argv.push(dir.join("summary.csv").into());
    Ok(argv)
}

/// The commands of the first version of the target.
const COMMANDS_V1: [&str; 5] = ["simulate", "odometry", "convergence", "stiffness", "work-precision"];
/// Every command but `demo` (too slow); `ensemble merge` is its own entry.
const COMMANDS: [&str; 9] = [
    "simulate",
    "odometry",
    "convergence",
    "stiffness",
    "work-precision",
    "calibrate",
    "ensemble",
    "ensemble merge",
    "jacobian",
];

/// A command (`demo` excluded: too slow), its flags with generated values, input files
/// and always `--out` inside the scratch folder.
pub fn cli_args(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let Ok(argv) = cli_argv(&mut u, &COMMANDS) else {
        return;
    };
    run_cli(argv);
}

/// The first version of `cli_args` (five commands), for the inputs recorded with it
/// (`fuzz/regressions/cli_args_v1/`): the same decoding, so they replay the same case.
pub fn cli_args_v1(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let Ok(argv) = cli_argv(&mut u, &COMMANDS_V1) else {
        return;
    };
    run_cli(argv);
}

fn cli_argv(u: &mut Unstructured, commands: &[&'static str]) -> Result<Vec<OsString>> {
    let dir = scratch();
    let cmd = *u.choose(commands)?;
    if cmd == "ensemble merge" {
        return merge_argv(u, &dir);
    }
    let input = dir.join("input.csv");
    let headers: &[&str] = match cmd {
        "simulate" => &["t,v,omega", "t,v,steer", "t,v,steer_rate", "t,v", "v,t,omega,extra"],
        "calibrate" if u.ratio(1u8, 3)? => &[
            "dt,left,right,dx,dy,dtheta",
            "dt,left_speed,right_speed,dx,dy,dtheta",
            "dt,left,right,dx,dy",
        ],
        _ => &["t,left,right", "t,right,left", "t,left"],
    };
    let file = match cmd {
        "ensemble" => ensemble_controls(u)?,
        "jacobian" => Vec::new(),
        _ => input_file(u, headers)?,
    };
    write_file(&input, &file);
    trace(|| {
        let text = String::from_utf8_lossy(&file[..file.len().min(400)]).into_owned();
        format!("input file ({} bytes): {text:?}", file.len())
    });
    if cmd == "calibrate" {
        // the poses: the same clock as the encoder log
        let poses = input_file(u, &["t,x,y,theta", "t,y,x,theta", "t,x,y"])?;
        write_file(&input.with_file_name("poses.csv"), &poses);
        trace(|| format!("poses: {:?}", String::from_utf8_lossy(&poses[..poses.len().min(400)])));
    }
    let mut argv: Vec<OsString> = vec!["reckon".into(), cmd.into()];
    for (flag, required, value) in flags_of(cmd) {
        let present = if required { !u.ratio(1u8, 16)? } else { u.ratio(1u8, 2)? };
        if !present {
            continue;
        }
        match value(u, &input)? {
            None => argv.push(flag.into()),
            Some(v) if u.ratio(1u8, 4)? => argv.push(format!("{flag}={v}").into()),
            Some(v) => {
                argv.push(flag.into());
                argv.push(v.into());
            }
        }
    }
    // now and then a stray token (never one that names a path)
    if u.ratio(1u8, 8)? {
        let token = one_of(
            u,
            &["--help", "--version", "-h", "--", "--json", "--steps", "-x", "--x0"],
        )?;
        if !names_a_path(&token) {
            let at = u.int_in_range(2..=argv.len())?;
            argv.insert(at, token.into());
        }
    }
    if cmd != "jacobian" {
        argv.push("--out".into());
        argv.push(
            match cmd {
                "simulate" | "odometry" | "calibrate" | "ensemble" => dir.join("out.csv"),
                _ => dir.join("study"),
            }
            .into(),
        );
    }
    Ok(argv)
}

// ---------------------------------------------------------------------------------------
// solve: Problem::solve / the Integrator with arbitrary options, spans, models, events

fn tolerance(u: &mut Unstructured) -> Result<Tolerance> {
    Ok(if u.ratio(3u8, 4)? {
        Tolerance::Scalar(if u.ratio(1u8, 2)? {
            float(u)?
        } else {
            10f64.powi(-u.int_in_range(2i32..=14)?)
        })
    } else {
        let n = u.int_in_range(0usize..=5)?;
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            v.push(float(u)?);
        }
        Tolerance::PerComponent(v)
    })
}

fn options(u: &mut Unstructured) -> Result<Options> {
    let mut o = Options::default().rtol(tolerance(u)?).atol(tolerance(u)?);
    if u.ratio(1u8, 3)? {
        o = o.step(StepSize::Fixed(float(u)?));
    }
    if u.ratio(1u8, 4)? {
        o = o.h0(float(u)?);
    }
    if u.ratio(1u8, 4)? {
        o = o.h_max(float(u)?);
    }
    // capped so that one execution stays short
    o = o.max_steps(u.int_in_range(0usize..=10_000)?);
    let nb = u.int_in_range(0usize..=6)?;
    let mut b = Vec::with_capacity(nb);
    for _ in 0..nb {
        b.push(if u.ratio(1u8, 2)? { float(u)? } else { moderate(u)? });
    }
    o = o.breakpoints(b).dense(u.arbitrary()?);
    o = o.stiffness_check(if u.ratio(1u8, 4)? {
        None
    } else {
        Some(u.int_in_range(0usize..=1500)?)
    });
    o.max_step_failures = u.int_in_range(0usize..=20)?;
    Ok(o)
}

fn controls(u: &mut Unstructured, width: usize) -> Result<Option<Controls>> {
    let n = u.int_in_range(0usize..=6)?;
    // mostly the width the model reads, sometimes not
    let w = if u.ratio(1u8, 8)? {
        u.int_in_range(0usize..=3)?
    } else {
        width
    };
    let mut t = if u.ratio(1u8, 4)? { float(u)? } else { moderate(u)? };
    let (mut times, mut values) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for _ in 0..n {
        times.push(t);
        let mut row = Vec::with_capacity(w);
        for _ in 0..w {
            row.push(if u.ratio(1u8, 8)? { float(u)? } else { moderate(u)? });
        }
        values.push(row);
        t += if u.ratio(1u8, 8)? {
            float(u)?
        } else {
            moderate(u)?.abs()
        };
    }
    Ok(Controls::new(times, values).ok())
}

fn first<D: Dim>(x: &OVector<f64, D>) -> f64
where
    DefaultAllocator: Allocator<D>,
{
    if x.is_empty() { 0.0 } else { x[0] }
}

fn event<'a, D: Dim>(u: &mut Unstructured) -> Result<Event<'a, D>>
where
    DefaultAllocator: Allocator<D>,
{
    let c = if u.ratio(1u8, 3)? { float(u)? } else { moderate(u)? };
    let kind = u.int_in_range(0u8..=7)?;
    let g = move |t: f64, x: &OVector<f64, D>| -> f64 {
        match kind {
            0 => first(x) - c,
            1 => t - c,
            2 => f64::NAN,
            3 if first(x) > c => f64::NAN,
            3 => first(x) - c,
            4 => (t * c).sin(),
            5 => 0.0,
            6 => c,
            _ if first(x) > c => f64::INFINITY,
            _ => -1.0,
        }
    };
    trace(|| format!("event kind {kind} with c = {c}"));
    let mut e = Event::new(g).direction(*u.choose(&[Direction::Either, Direction::Rising, Direction::Falling])?);
    if u.arbitrary()? {
        e = e.terminal();
    }
    Ok(e)
}

fn state<D: Dim>(u: &mut Unstructured, dim: D) -> Result<OVector<f64, D>>
where
    DefaultAllocator: Allocator<D>,
{
    let mut x = OVector::<f64, D>::zeros_generic(dim, reckon::nalgebra::U1);
    for v in x.iter_mut() {
        *v = if u.ratio(1u8, 6)? { float(u)? } else { moderate(u)? };
    }
    Ok(x)
}

/// Which method, and how to drive the integrator.
struct Plan {
    method: u8,
    newton: NewtonOptions,
    drive: u8,
    probes: [f64; 3],
}

fn plan(u: &mut Unstructured) -> Result<Plan> {
    Ok(Plan {
        method: u.int_in_range(0u8..=4)?,
        newton: NewtonOptions {
            max_iters: u.int_in_range(0usize..=12)?,
            tol: if u.arbitrary()? { Some(float(u)?) } else { None },
        },
        drive: u.int_in_range(0u8..=2)?,
        probes: [float(u)?, moderate(u)?, moderate(u)?],
    })
}

/// Attach events and controls, then run the chosen method. `legacy`: the decoding of the
/// first version of this target (methods 0–4 only, no extension), which the inputs in
/// `fuzz/regressions/solve_v1/` were recorded with.
#[allow(clippy::too_many_arguments)]
fn solve_problem<D, S, F, X>(
    u: &mut Unstructured,
    sys: S,
    x0: OVector<f64, D>,
    inputs: usize,
    flow: F,
    span: (f64, f64),
    opts: &Options,
    plan: &Plan,
    legacy: bool,
    exact_sens: X,
) -> Result<()>
where
    D: reckon::linalg::LuDim,
    S: DualSystem<D>,
    F: Flow<D>,
    X: FnOnce(&Problem<'_, D, S>, &Options, &SensitivityOptions),
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    trace(|| format!("x0 = {:?}, span = {span:?}", x0.as_slice()));
    let n = x0.len();
    let mut p = Problem::new(sys, x0, span);
    let with_controls = if inputs > 0 {
        !u.ratio(1u8, 16)?
    } else {
        u.ratio(1u8, 8)?
    };
    if with_controls && let Some(c) = controls(u, inputs)? {
        trace(|| format!("{c:?}"));
        p = p.controls(c);
    }
    for _ in 0..u.int_in_range(0u8..=2)? {
        p = p.event(event(u)?);
    }
    if legacy {
        run_method(&p, plan.method, flow, opts, plan);
        return Ok(());
    }
    // the extension: options the first version did not set, and the newer methods
    let opts = &more_options(u, opts.clone(), n)?;
    let method = u.int_in_range(0u8..=9)?;
    trace(|| format!("extended: method {method}, {opts:?}"));
    match method {
        0..=4 => run_method(&p, method, flow, opts, plan),
        5 => {
            let b = bdf(u, n)?;
            trace(|| {
                format!(
                    "bdf: ndf {}, max order {}, newton {:?}",
                    b.is_ndf(),
                    b.max_order,
                    b.newton
                )
            });
            drive(&p, b, opts, plan)
        }
        6 => drive(&p, Rodas5P, &capped(opts, n, 300), plan),
        7 => {
            let mut a = Auto::default();
            if u.arbitrary()? {
                a.implicit = bdf(u, n)?;
            }
            drive(&p, a, opts, plan)
        }
        8 => drive(&p, ExponentialEuler, &capped(opts, n, 150), plan),
        _ => sensitivities(u, &p, n, opts, plan, exact_sens)?,
    }
    Ok(())
}

fn run_method<D, S, F>(p: &Problem<'_, D, S>, method: u8, flow: F, opts: &Options, plan: &Plan)
where
    D: reckon::linalg::LuDim,
    S: reckon::System<D>,
    F: Flow<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    match method {
        0 => drive(p, Euler, opts, plan),
        1 => drive(p, ImplicitEuler::default(), opts, plan),
        2 => drive(p, ImplicitEuler::new(plan.newton), opts, plan),
        3 => drive(p, Rk45, opts, plan),
        _ => drive(p, Exact::new(flow), opts, plan),
    }
}

/// Options the first version of the target left at their defaults: the linear solver
/// (dense, sparse, chosen), what is saved, how many components the error estimate
/// covers; and a step cap by model size, so that one execution stays short.
fn more_options(u: &mut Unstructured, mut o: Options, n: usize) -> Result<Options> {
    o = o.linear_solver(*u.choose(&[LinearSolver::Auto, LinearSolver::Dense, LinearSolver::Sparse])?);
    match u.int_in_range(0u8..=4)? {
        0 | 1 => {}
        2 => o = o.save(Save::Every(u.int_in_range(0usize..=5)?)),
        3 => o = o.save(Save::End),
        _ => {
            let k = u.int_in_range(0usize..=5)?;
            let mut at = Vec::with_capacity(k);
            for _ in 0..k {
                at.push(if u.ratio(1u8, 4)? { float(u)? } else { moderate(u)? });
            }
            o = o.save(Save::At(at));
        }
    }
    if u.ratio(1u8, 4)? {
        o = o.error_components(u.int_in_range(0usize..=n + 2)?);
    }
    Ok(capped(&o, n, if n > 16 { 1000 } else { 10_000 }))
}

/// `o` with at most `large` steps for a model of more than 16 states.
fn capped(o: &Options, n: usize, large: usize) -> Options {
    let mut o = o.clone();
    if n > 16 {
        o.max_steps = o.max_steps.min(large);
    }
    o
}

/// BDF or NDF, with an order limit, a fixed order or a start history (of the wrong length
/// now and then), and Newton settings.
fn bdf<D>(u: &mut Unstructured, n: usize) -> Result<Bdf>
where
    D: reckon::linalg::LuDim,
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    let mut b = if u.arbitrary()? { Bdf::default() } else { Bdf::bdf() };
    match u.int_in_range(0u8..=3)? {
        0 => {}
        1 => b = b.max_order(u.int_in_range(0usize..=7)?),
        2 => b = b.fixed_order(u.int_in_range(0usize..=7)?),
        _ => {
            let k = u.int_in_range(0usize..=6)?;
            let mut past = Vec::with_capacity(k);
            for _ in 0..k {
                // a dynamic state may be handed a history of another length
                let len = if D::try_to_usize().is_none() && u.ratio(1u8, 6)? {
                    (n + 1).saturating_sub(u.int_in_range(0usize..=2)?)
                } else {
                    n
                };
                past.push(state(u, D::from_usize(len))?);
            }
            b = b.history(past);
        }
    }
    if u.ratio(1u8, 4)? {
        b.newton = NewtonOptions {
            max_iters: u.int_in_range(0usize..=12)?,
            tol: if u.arbitrary()? { Some(float(u)?) } else { None },
        };
    }
    Ok(b)
}

/// `sensitivity::solve` through every method (at `Dyn`, as the augmented system needs),
/// with or without the sensitivities in the error control, for `x₀` and `p` or `p` alone;
/// `exact_sens` runs `Exact` with a dual flow where the model has one.
fn sensitivities<D, S, X>(
    u: &mut Unstructured,
    p: &Problem<'_, D, S>,
    n: usize,
    opts: &Options,
    plan: &Plan,
    exact_sens: X,
) -> Result<()>
where
    D: reckon::linalg::LuDim,
    S: DualSystem<D>,
    X: FnOnce(&Problem<'_, D, S>, &Options, &SensitivityOptions),
    DefaultAllocator: Allocator<D> + Allocator<D, D> + Allocator<U1, D>,
{
    let mut so = SensitivityOptions::default().error_control(u.arbitrary()?);
    if u.ratio(1u8, 3)? || n > 8 {
        // n > 8: the augmented system of `n·(1 + n + n_p)` states would be slow
        so = so.wrt(Wrt::Params);
    }
    let np = p.system.n_params();
    let columns = if so.wrt == Wrt::Params { np } else { n + np };
    // the augmented system has n·(1 + columns) states: at most 2 000 steps, 300 above 8
    // states (exponential Euler's two exponentials a step made 8 406 steps take 7 s)
    let mut opts = opts.clone();
    opts.max_steps = opts.max_steps.min(if n * (1 + columns) > 8 { 300 } else { 2000 });
    let method = u.int_in_range(0u8..=8)?;
    trace(|| format!("sensitivities: method {method}, {so:?}"));
    match method {
        0 => probe_sens(sensitivity::solve(p, Euler, &opts, &so)),
        1 => probe_sens(sensitivity::solve(p, ImplicitEuler::default(), &opts, &so)),
        2 => probe_sens(sensitivity::solve(p, ImplicitEuler::new(plan.newton), &opts, &so)),
        3 => probe_sens(sensitivity::solve(p, Rk45, &opts, &so)),
        4 => probe_sens(sensitivity::solve(p, Bdf::default(), &opts, &so)),
        5 => probe_sens(sensitivity::solve(p, Rodas5P, &opts, &so)),
        6 => probe_sens(sensitivity::solve(p, ExponentialEuler, &opts, &so)),
        7 => probe_sens(sensitivity::solve(p, Auto::default(), &opts, &so)),
        _ => exact_sens(p, &opts, &so),
    }
    Ok(())
}

/// Read what a sensitivity solve returned: every accessor at the first saved times and
/// the last.
fn probe_sens<D: Dim>(r: reckon::Result<Sensitivities<D>>)
where
    DefaultAllocator: Allocator<D>,
{
    let Ok(s) = r else { return };
    let len = s.t.len();
    for k in (0..len.min(3)).chain(len.checked_sub(1)) {
        let m = s.s(k);
        let (rows, cols) = m.shape();
        let _ = (s.wrt_x0(k), s.wrt_params(k));
        if rows > 0 && s.n_params > 0 && cols > 0 {
            let _ = s.dx_dp(k, rows - 1, s.n_params - 1);
        }
    }
    if len > 0 {
        let _ = (s.last_x(), s.last_s());
    }
}

/// `solve()` then dense probes, or `step()` to the end (and once more after an error),
/// or the iterator.
fn drive<D: Dim, S: reckon::System<D>, M: Method<D>>(p: &Problem<'_, D, S>, method: M, opts: &Options, plan: &Plan)
where
    DefaultAllocator: Allocator<D>,
{
    match plan.drive {
        0 => {
            if let Ok(sol) = p.solve(method, opts) {
                let _ = sol.last();
                for t in plan.probes.iter().copied().chain(sol.t.iter().copied().take(3)) {
                    let _ = sol.at(t);
                }
                for s in sol.dense_segments().iter().take(3) {
                    let _ = s.eval(s.t0);
                }
            }
        }
        1 => {
            let Ok(mut it) = p.integrator(method, opts) else { return };
            loop {
                match it.step() {
                    Ok(Some(_)) => {}
                    Ok(None) => break,
                    Err(_) => {
                        let _ = it.step();
                        break;
                    }
                }
            }
            let _ = (
                it.t(),
                it.x(),
                it.stats(),
                it.stiffness(),
                it.is_done(),
                it.proposed_step(),
            );
        }
        _ => {
            let Ok(it) = p.integrator(method, opts) else { return };
            for r in it {
                if r.is_err() {
                    break;
                }
            }
        }
    }
}

/// Length of a dynamic model's output: `n`, or `n + delta` once `wrong` holds.
fn out_len(n: usize, delta: i8, wrong: bool) -> usize {
    if wrong {
        n.saturating_add_signed(isize::from(delta))
    } else {
        n
    }
}

/// Models: 0 linear decay, 1 Van der Pol, 2 unicycle with inputs, 3 dynamic linear,
/// 4 dynamic with a state-dependent output length, 5 dynamic with a call-count-dependent
/// output length (and an exact flow that may return the wrong length too), 6 Van der Pol
/// with a parameter block and a traced time, 7 BRUSS 1-D (`problems::brusselator`, traced:
/// the compiled sparse Jacobian from 64 states), 8 a dynamic model with a state branch
/// (untraceable: the coloured sparse Jacobian).
pub fn solve(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let _ = solve_case(&mut u, false);
}

/// The first version of `solve` (methods explicit and implicit Euler, RK45 and exact,
/// models 0–5), for the inputs recorded with it (`fuzz/regressions/solve_v1/`).
pub fn solve_v1(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let _ = solve_case(&mut u, true);
}

/// No `Exact` method with a dual flow for this model.
fn no_exact<D: Dim, S>(_: &Problem<'_, D, S>, _: &Options, _: &SensitivityOptions)
where
    DefaultAllocator: Allocator<D>,
{
}

fn solve_case(u: &mut Unstructured, legacy: bool) -> Result<()> {
    let opts = options(u)?;
    let plan = plan(u)?;
    let span = if u.ratio(1u8, 3)? {
        (float(u)?, float(u)?)
    } else {
        let t0 = moderate(u)?;
        (t0, t0 + moderate(u)?)
    };
    let u = &mut *u;
    let k = moderate(u)?;
    let model = u.int_in_range(0u8..=if legacy { 5 } else { 8 })?;
    trace(|| {
        format!(
            "{opts:?}\nmethod {} ({:?}), drive {}, probes {:?}\nmodel {model}, k = {k}",
            plan.method, plan.newton, plan.drive, plan.probes
        )
    });
    match model {
        0 => {
            let f = model!(|_t, x: [S; 1]| Vector1::new(x[0] * k));
            let flow = move |_t: f64, x: &Vector1<f64>, _u: &[f64], h: f64| x * (k * h).exp();
            let x0 = state(u, reckon::nalgebra::Const::<1>)?;
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
        }
        1 => {
            let f = model!(|_t, y: [S; 2]| Vector2::new(y[1], (-y[0] * y[0] + 1.0) * y[1] * k - y[0]));
            // not the exact flow (there is none): one explicit Euler step, a valid `Flow` all the same
            let flow = move |_t: f64, y: &Vector2<f64>, _u: &[f64], h: f64| {
                y + Vector2::new(y[1], (1.0 - y[0] * y[0]) * y[1] * k - y[0]) * h
            };
            let x0 = state(u, reckon::nalgebra::Const::<2>)?;
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
        }
        2 => {
            let f = reckon::vehicles::unicycle::model();
            let x0: SVector<f64, 3> = state(u, reckon::nalgebra::Const::<3>)?;
            let exact = |p: &Problem<'_, _, _>, o: &Options, so: &SensitivityOptions| {
                probe_sens(sensitivity::solve(
                    p,
                    Exact::new(reckon::vehicles::unicycle::ExactFlow),
                    o,
                    so,
                ))
            };
            solve_problem(
                u,
                &f,
                x0,
                2,
                reckon::vehicles::unicycle::flow,
                span,
                &opts,
                &plan,
                legacy,
                exact,
            )
        }
        6 if u.arbitrary()? => {
            let params = [moderate(u)?, if u.ratio(1u8, 8)? { float(u)? } else { moderate(u)? }];
            trace(|| format!("params {params:?}"));
            let Ok(f) = model!(|_, y: [S; 2], p: [S; 2] = [1.0, 1.0]| Vector2::new(
                y[1],
                p[0] * (1.0 - y[0] * y[0]) * y[1] - y[0] * p[1]
            ))
            .with_params(&params) else {
                return Ok(());
            };
            let flow = move |_t: f64, y: &Vector2<f64>, _u: &[f64], h: f64| y * (-h).exp();
            let x0 = state(u, reckon::nalgebra::Const::<2>)?;
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
        }
        6 => {
            // a traced time: the exact ∂f/∂t for Rodas5P and exponential Euler
            let f = model!(|t: S, y: [S; 2]| Vector2::new(y[1], (1.0 - y[0] * y[0]) * y[1] * k - y[0] + t.sin()));
            let flow = move |_t: f64, y: &Vector2<f64>, _u: &[f64], h: f64| y * (-h).exp();
            let x0 = state(u, reckon::nalgebra::Const::<2>)?;
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
        }
        7 => {
            let nb = u.int_in_range(0usize..=40)?;
            let f = reckon::studies::problems::brusselator(nb);
            let x0 = if u.ratio(1u8, 2)? {
                DVector::from_fn(
                    2 * nb,
                    |i, _| if i % 2 == 0 { 1.0 + (i as f64).sin() * 0.5 } else { 3.0 },
                )
            } else {
                state(u, Dyn(2 * nb))?
            };
            trace(|| format!("brusselator with {nb} points"));
            let flow = |_t: f64, x: &DVector<f64>, _u: &[f64], _h: f64| x.clone();
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
        }
        8 => {
            let n = u.int_in_range(0usize..=80)?;
            #[allow(clippy::cmp_owned)] // S = f64 in one copy
            let f = model!(|_t, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| {
                let v = x[i].clone();
                let left = if i > 0 { x[i - 1].clone() } else { S::from(0.0) };
                (if v > S::from(0.0) { -v.clone() } else { v * 2.0 }) + left * k
            }));
            let x0 = state(u, Dyn(n))?;
            trace(|| format!("branchy dynamic model, n = {n}"));
            let flow = |_t: f64, x: &DVector<f64>, _u: &[f64], _h: f64| x.clone();
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
        }
        m => {
            let n = u.int_in_range(0usize..=4)?;
            let delta = *u.choose(&[-1i8, 1, 2, -3])?;
            let threshold = moderate(u)?;
            let after = u.int_in_range(0usize..=40)?;
            let calls = Cell::new(0usize);
            let flow_calls = Cell::new(0usize);
            let calls = &calls;
            let flow_calls = &flow_calls;
            let x0 = state(u, reckon::nalgebra::Dyn(n))?;
            trace(|| format!("dyn: n = {n}, delta = {delta}, threshold = {threshold}, after = {after}"));
            let flow = move |_t: f64, x: &DVector<f64>, _u: &[f64], h: f64| -> DVector<f64> {
                flow_calls.set(flow_calls.get() + 1);
                let len = out_len(x.len(), delta, m == 5 && flow_calls.get() > after);
                DVector::from_fn(len, |i, _| if i < x.len() { x[i] * (k * h).exp() } else { 1.0 })
            };
            match m {
                3 => {
                    let f = model!(|_t, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].clone() * k));
                    solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
                }
                4 => {
                    let f = model!(|_t, x: [S; Dyn]| {
                        use reckon::num_dual::DualStruct as _;
                        let wrong = !x.is_empty() && x[0].re() > threshold;
                        let len = out_len(x.len(), delta, wrong);
                        DVector::from_fn(len, |i, _| if i < x.len() { x[i].clone() * k } else { S::from(1.0) })
                    });
                    solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
                }
                _ => {
                    let f = model!(|_t, x: [S; Dyn]| {
                        calls.set(calls.get() + 1);
                        let len = out_len(x.len(), delta, calls.get() > after);
                        DVector::from_fn(len, |i, _| if i < x.len() { x[i].clone() * k } else { S::from(1.0) })
                    });
                    solve_problem(u, &f, x0, 0, flow, span, &opts, &plan, legacy, no_exact)
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// trace: model bodies from fuzzer bytes, the traced Jacobian against num-dual's

/// An expression over the states `x₀…x₂`, the inputs `u₀, u₁`, the parameters `p₀, p₁`
/// and the time, the body of one component of a traced `model!`.
#[derive(Debug, Clone)]
pub enum Tree {
    /// `x[i]`
    X(usize),
    /// `u[k]`
    U(usize),
    /// `p[k]`
    P(usize),
    /// `t`
    T,
    /// A constant.
    C(f64),
    /// `a + b`
    Add(Box<Tree>, Box<Tree>),
    /// `a − b`
    Sub(Box<Tree>, Box<Tree>),
    /// `a · b`
    Mul(Box<Tree>, Box<Tree>),
    /// `a / b`
    Div(Box<Tree>, Box<Tree>),
    /// `aⁿ`
    Powi(Box<Tree>, i32),
    /// A function of one argument ([`FUNCS`]).
    F(u8, Box<Tree>),
    /// `min(a, b)` by a comparison: a branch on the state when `a` or `b` depends on it.
    Min(Box<Tree>, Box<Tree>),
    /// `max(a, b)`, the same.
    Max(Box<Tree>, Box<Tree>),
    /// `if c > 0 { a } else { b }`.
    If(Box<Tree>, Box<Tree>, Box<Tree>),
}

/// The functions of [`Tree::F`].
pub const FUNCS: [&str; 9] = ["−", "sqrt", "exp", "ln", "sin", "cos", "tanh", "abs", "recip"];

fn tree(u: &mut Unstructured, budget: &mut u32, depth: u32) -> Result<Tree> {
    let leaf = *budget == 0 || depth >= 8 || u.ratio(1u8, 3)?;
    if leaf {
        return Ok(match u.int_in_range(0u8..=6)? {
            0..=2 => Tree::X(u.int_in_range(0usize..=2)?),
            3 => Tree::U(u.int_in_range(0usize..=1)?),
            4 => Tree::P(u.int_in_range(0usize..=1)?),
            5 => Tree::T,
            _ => Tree::C(if u.ratio(1u8, 4)? { float(u)? } else { moderate(u)? }),
        });
    }
    *budget -= 1;
    let mut sub = |u: &mut Unstructured| -> Result<Box<Tree>> { Ok(Box::new(tree(u, budget, depth + 1)?)) };
    Ok(match u.int_in_range(0u8..=10)? {
        0 => Tree::Add(sub(u)?, sub(u)?),
        1 => Tree::Sub(sub(u)?, sub(u)?),
        2 | 3 => Tree::Mul(sub(u)?, sub(u)?),
        4 => Tree::Div(sub(u)?, sub(u)?),
        5 => {
            let a = sub(u)?;
            Tree::Powi(a, u.int_in_range(-4i32..=6)?)
        }
        6..=8 => {
            let k = u.int_in_range(0u8..=(FUNCS.len() - 1) as u8)?;
            Tree::F(k, sub(u)?)
        }
        9 => {
            if u.arbitrary()? {
                Tree::Min(sub(u)?, sub(u)?)
            } else {
                Tree::Max(sub(u)?, sub(u)?)
            }
        }
        _ => Tree::If(sub(u)?, sub(u)?, sub(u)?),
    })
}

impl Tree {
    /// Whether the expression branches (`min`, `max`, `if`).
    fn branches(&self) -> bool {
        match self {
            Tree::X(_) | Tree::U(_) | Tree::P(_) | Tree::T | Tree::C(_) => false,
            Tree::Add(a, b) | Tree::Sub(a, b) | Tree::Mul(a, b) | Tree::Div(a, b) => a.branches() || b.branches(),
            Tree::Powi(a, _) | Tree::F(_, a) => a.branches(),
            Tree::Min(..) | Tree::Max(..) | Tree::If(..) => true,
        }
    }

    /// The value in `f64`, and whether every intermediate value stayed in
    /// `[1e-100, 1e100]` (or was zero) and no `tanh` had an argument beyond 300, where
    /// num-dual's `tanh′` (a difference of squares of `cosh` and `sinh`) is documented to
    /// be NaN (guide §1, "Special points").
    fn value(&self, x: &[f64], u: &[f64], p: &[f64], t: f64, tame: &mut bool) -> f64 {
        let v = match self {
            Tree::X(i) => x[*i],
            Tree::U(k) => u[*k],
            Tree::P(k) => p[*k],
            Tree::T => t,
            Tree::C(c) => *c,
            Tree::Add(a, b) => a.value(x, u, p, t, tame) + b.value(x, u, p, t, tame),
            Tree::Sub(a, b) => a.value(x, u, p, t, tame) - b.value(x, u, p, t, tame),
            Tree::Mul(a, b) => a.value(x, u, p, t, tame) * b.value(x, u, p, t, tame),
            Tree::Div(a, b) => a.value(x, u, p, t, tame) / b.value(x, u, p, t, tame),
            Tree::Powi(a, n) => a.value(x, u, p, t, tame).powi(*n),
            Tree::F(k, a) => {
                let a = a.value(x, u, p, t, tame);
                match FUNCS[usize::from(*k)] {
                    "−" => -a,
                    "sqrt" => a.sqrt(),
                    "exp" => a.exp(),
                    "ln" => a.ln(),
                    "sin" => a.sin(),
                    "cos" => a.cos(),
                    "tanh" => {
                        if a.abs() > 300.0 {
                            *tame = false;
                        }
                        a.tanh()
                    }
                    "abs" => a.abs(),
                    _ => a.recip(),
                }
            }
            Tree::Min(a, b) => {
                let (a, b) = (a.value(x, u, p, t, tame), b.value(x, u, p, t, tame));
                if a < b { a } else { b }
            }
            Tree::Max(a, b) => {
                let (a, b) = (a.value(x, u, p, t, tame), b.value(x, u, p, t, tame));
                if a > b { a } else { b }
            }
            Tree::If(c, a, b) => {
                if c.value(x, u, p, t, tame) > 0.0 {
                    a.value(x, u, p, t, tame)
                } else {
                    b.value(x, u, p, t, tame)
                }
            }
        };
        if v != 0.0 && !(1e-100..=1e100).contains(&v.abs()) {
            *tame = false;
        }
        v
    }
}

impl Tree {
    /// The value and, for each state `xⱼ`, a bound on the magnitudes of the terms that
    /// forward differentiation adds up for `∂/∂xⱼ` (the terms of every sum and product
    /// rule, in absolute value). Two correct evaluations of the derivative that add the
    /// same terms in another order or by another formula (num-dual's, the trace's) differ
    /// by a few ε times this bound, not times the derivative: `(1/x + x)·x` at `x = 1e-12`
    /// has the derivative `2x` from terms of size `1/x = 1e12`, where the two were seen
    /// 1.2e-4 apart (both correct to ε·1e12).
    fn magnitudes(&self, x: &[f64], u: &[f64], p: &[f64], t: f64) -> (f64, [f64; 3]) {
        // a term that is zero stays zero, whatever its factor (0·∞ is no bound)
        let times = |m: f64, k: f64| if m == 0.0 { 0.0 } else { m * k };
        let add = |a: [f64; 3], b: [f64; 3], ka: f64, kb: f64| [0, 1, 2].map(|j| times(a[j], ka) + times(b[j], kb));
        match self {
            Tree::X(i) => {
                let mut m = [0.0; 3];
                m[*i] = 1.0;
                (x[*i], m)
            }
            Tree::U(k) => (u[*k], [0.0; 3]),
            Tree::P(k) => (p[*k], [0.0; 3]),
            Tree::T => (t, [0.0; 3]),
            Tree::C(c) => (*c, [0.0; 3]),
            Tree::Add(a, b) | Tree::Sub(a, b) => {
                let ((va, ma), (vb, mb)) = (a.magnitudes(x, u, p, t), b.magnitudes(x, u, p, t));
                (
                    if matches!(self, Tree::Add(..)) {
                        va + vb
                    } else {
                        va - vb
                    },
                    add(ma, mb, 1.0, 1.0),
                )
            }
            Tree::Mul(a, b) => {
                let ((va, ma), (vb, mb)) = (a.magnitudes(x, u, p, t), b.magnitudes(x, u, p, t));
                (va * vb, add(ma, mb, vb.abs(), va.abs()))
            }
            Tree::Div(a, b) => {
                let ((va, ma), (vb, mb)) = (a.magnitudes(x, u, p, t), b.magnitudes(x, u, p, t));
                (va / vb, add(ma, mb, 1.0 / vb.abs(), va.abs() / (vb * vb)))
            }
            Tree::Powi(a, n) => {
                let (va, ma) = a.magnitudes(x, u, p, t);
                let k = if *n == 0 {
                    0.0
                } else {
                    f64::from(n.abs()) * va.abs().powi(n - 1)
                };
                (va.powi(*n), ma.map(|m| times(m, k)))
            }
            Tree::F(f, a) => {
                let (va, ma) = a.magnitudes(x, u, p, t);
                let (v, k) = match FUNCS[usize::from(*f)] {
                    "−" => (-va, 1.0),
                    "sqrt" => (va.sqrt(), 0.5 / va.abs().sqrt()),
                    "exp" => (va.exp(), va.exp()),
                    "ln" => (va.ln(), 1.0 / va.abs()),
                    "sin" => (va.sin(), 1.0),
                    "cos" => (va.cos(), 1.0),
                    // num-dual's tanh′ is (cosh² − sinh²)/cosh²: its error is ε, not ε·sech²
                    "tanh" => (va.tanh(), 1.0),
                    "abs" => (va.abs(), 1.0),
                    _ => (va.recip(), 1.0 / (va * va)),
                };
                (v, ma.map(|m| times(m, k)))
            }
            Tree::Min(a, b) | Tree::Max(a, b) => {
                let ((va, ma), (vb, mb)) = (a.magnitudes(x, u, p, t), b.magnitudes(x, u, p, t));
                let first = if matches!(self, Tree::Min(..)) {
                    va < vb
                } else {
                    va > vb
                };
                if first { (va, ma) } else { (vb, mb) }
            }
            Tree::If(c, a, b) => {
                if c.magnitudes(x, u, p, t).0 > 0.0 {
                    a.magnitudes(x, u, p, t)
                } else {
                    b.magnitudes(x, u, p, t)
                }
            }
        }
    }
}

/// The expression at any scalar of the model body (`f64`, a dual number, the tracing
/// `Sym`): the same operations in the same order as [`Tree::value`].
#[allow(clippy::cmp_owned)] // S = f64 in one copy
fn eval_tree<S: reckon::num_dual::DualNum<Primitive = f64> + Copy>(e: &Tree, x: &[S], u: &[S], p: &[S], t: S) -> S {
    match e {
        Tree::X(i) => x[*i],
        Tree::U(k) => u[*k],
        Tree::P(k) => p[*k],
        Tree::T => t,
        Tree::C(c) => S::from(*c),
        Tree::Add(a, b) => eval_tree(a, x, u, p, t) + eval_tree(b, x, u, p, t),
        Tree::Sub(a, b) => eval_tree(a, x, u, p, t) - eval_tree(b, x, u, p, t),
        Tree::Mul(a, b) => eval_tree(a, x, u, p, t) * eval_tree(b, x, u, p, t),
        Tree::Div(a, b) => eval_tree(a, x, u, p, t) / eval_tree(b, x, u, p, t),
        Tree::Powi(a, n) => eval_tree(a, x, u, p, t).powi(*n),
        Tree::F(k, a) => {
            let a = eval_tree(a, x, u, p, t);
            match FUNCS[usize::from(*k)] {
                "−" => -a,
                "sqrt" => a.sqrt(),
                "exp" => a.exp(),
                "ln" => a.ln(),
                "sin" => a.sin(),
                "cos" => a.cos(),
                "tanh" => a.tanh(),
                "abs" => a.abs(),
                _ => a.recip(),
            }
        }
        Tree::Min(a, b) => {
            let (a, b) = (eval_tree(a, x, u, p, t), eval_tree(b, x, u, p, t));
            if a < b { a } else { b }
        }
        Tree::Max(a, b) => {
            let (a, b) = (eval_tree(a, x, u, p, t), eval_tree(b, x, u, p, t));
            if a > b { a } else { b }
        }
        Tree::If(c, a, b) => {
            if eval_tree(c, x, u, p, t) > S::from(0.0) {
                eval_tree(a, x, u, p, t)
            } else {
                eval_tree(b, x, u, p, t)
            }
        }
    }
}

/// A point: mostly moderate values, now and then a special one (zeros of either sign,
/// extremes, NaN).
fn point_value(u: &mut Unstructured) -> Result<f64> {
    if u.ratio(1u8, 6)? { float(u) } else { moderate(u) }
}

/// Three expressions from the bytes become the body of a
/// `model!(|t: S, x: [S; 3], u: [2], p: [S; 2] = …| …)`, traced with `symbolic::trace`
/// and compared at a point with num-dual's Jacobian (`System::jacobian`): the compiled
/// program (native code with the `jit` feature) and the interpreter give the same bits,
/// the sparse (CSC) values are the dense matrix's, the symbolic expressions evaluate to
/// the compiled values, and the traced values and Jacobian agree with the body's and
/// num-dual's to a relative tolerance, or are both non-finite. A typed error is fine; a
/// panic or a disagreement is a finding (the target panics with the numbers).
pub fn trace_target(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let _ = trace_case(&mut u);
}

fn trace_case(u: &mut Unstructured) -> Result<()> {
    use reckon::nalgebra::Vector3;
    let mut budget = 24u32;
    let es = [
        tree(u, &mut budget, 0)?,
        tree(u, &mut budget, 0)?,
        tree(u, &mut budget, 0)?,
    ];
    let params = [point_value(u)?, point_value(u)?];
    let x = [point_value(u)?, point_value(u)?, point_value(u)?];
    let inputs = [point_value(u)?, point_value(u)?];
    let t = point_value(u)?;
    trace(|| format!("bodies {es:#?}\nparams {params:?}, x {x:?}, u {inputs:?}, t {t}"));
    let es = &es;
    if u.arbitrary()? {
        // a traced time; the parameters as constants of the body
        let [p0, p1] = params;
        let f = model!(|t: S, x: [S; 3], u: [2]| {
            let u = [S::from(u[0]), S::from(u[1])];
            let (x, p) = ([x[0], x[1], x[2]], [S::from(p0), S::from(p1)]);
            Vector3::new(
                eval_tree(&es[0], &x, &u, &p, t),
                eval_tree(&es[1], &x, &u, &p, t),
                eval_tree(&es[2], &x, &u, &p, t),
            )
        });
        check_trace(&f, es, params, x, inputs, t)
    } else {
        // a parameter block (leaves of the trace); the time a constant of the body
        let tc = t;
        let Ok(f) = model!(|_, x: [S; 3], u: [2], p: [S; 2] = [1.0, 1.0]| {
            let u = [S::from(u[0]), S::from(u[1])];
            let (x, p) = ([x[0], x[1], x[2]], [p[0], p[1]]);
            Vector3::new(
                eval_tree(&es[0], &x, &u, &p, S::from(tc)),
                eval_tree(&es[1], &x, &u, &p, S::from(tc)),
                eval_tree(&es[2], &x, &u, &p, S::from(tc)),
            )
        })
        .with_params(&params) else {
            return Ok(());
        };
        check_trace(&f, es, params, x, inputs, t)
    }
}

/// The comparisons of [`trace_target`] for one traced model.
fn check_trace(
    f: &impl reckon::System<reckon::nalgebra::Const<3>>,
    es: &[Tree; 3],
    params: [f64; 2],
    x: [f64; 3],
    inputs: [f64; 2],
    t: f64,
) -> Result<()> {
    use reckon::jacobian::SparseJacobian as _;
    use reckon::nalgebra::{Matrix3, Vector3};
    let traced = reckon::symbolic::trace(f, 3);
    let branches = es.iter().any(Tree::branches);
    let tr = match traced {
        Ok(tr) => tr,
        Err(e) => {
            trace(|| format!("refused: {e}"));
            // a body without a branch has no comparison to be refused for
            if let reckon::Error::Untraceable { reason, .. } = &e {
                assert!(
                    branches || !reason.contains("comparison"),
                    "a body without a branch refused for a comparison: {e}"
                );
            }
            return Ok(());
        }
    };
    // the printed forms must not panic
    let _ = (tr.text(), tr.latex(), tr.mathml(), tr.rust(), tr.json(), tr.pattern());
    let xv = Vector3::from(x);
    let mut fx = Vector3::zeros();
    f.rhs(t, &xv, &inputs, &mut fx);
    let mut jd = Matrix3::zeros();
    f.jacobian(t, &xv, &inputs, &mut jd);
    let mut tame = true;
    for e in es {
        e.value(&x, &inputs, &params, t, &mut tame);
    }
    for v in [t].iter().chain(&x).chain(&inputs).chain(&params) {
        if *v != 0.0 && !(1e-100..=1e100).contains(&v.abs()) {
            tame = false;
        }
    }

    // compiled (native when available) against interpreted, dense against sparse
    let mut compiled = tr.compile_jacobian();
    let mut interpreted = compiled.clone().interpreted();
    let mut js = vec![f64::NAN; 9];
    let mut ji = vec![f64::NAN; 9];
    if compiled.eval_dense(t, &x, &inputs, &mut js).is_err() || interpreted.eval_dense(t, &x, &inputs, &mut ji).is_err()
    {
        return Ok(());
    }
    let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    for k in 0..9 {
        assert!(
            same(js[k], ji[k]),
            "entry ({}, {}): compiled {:e}, interpreted {:e}",
            k % 3,
            k / 3,
            js[k],
            ji[k]
        );
    }
    let nnz = compiled.pattern().nnz();
    let mut v = vec![f64::NAN; nnz];
    if compiled.eval(t, &x, &inputs, &mut v).is_ok() {
        let entries: Vec<(usize, usize)> = compiled.pattern().entries().collect();
        for ((i, j), val) in entries.into_iter().zip(&v) {
            assert!(
                same(*val, js[i + 3 * j]),
                "CSC value at ({i}, {j}): {val:e}, dense {:e}",
                js[i + 3 * j]
            );
        }
    }
    // entries outside the pattern are zero in the traced Jacobian
    for (i, j, e) in tr.jacobian() {
        let s = e.eval(t, &x, &inputs);
        let c = js[i + 3 * j];
        assert!(
            same(s, c) || (s - c).abs() <= 1e-12 * s.abs().max(c.abs()) || (!s.is_finite() && !c.is_finite()),
            "∂f{i}/∂x{j} = {e}: expression {s:e}, compiled {c:e}"
        );
    }

    // against the body and num-dual, where the comparison means something: the body's
    // values finite, every intermediate value of moderate size (no overflow that one
    // formula meets and the other not), and J well-conditioned at the point
    if !tame || !fx.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    for i in 0..3 {
        let s = tr.rhs(i).eval(t, &x, &inputs);
        assert!(
            (s - fx[i]).abs() <= 1e-9 * (1.0 + fx[i].abs()),
            "f{i}: traced {s:e}, body {:e}",
            fx[i]
        );
    }
    // J a relative 1e-9 away in every component: where J changes faster than that, two
    // correct evaluations differ by more than rounding (kinks, cancellation)
    let limit = 1e-6;
    let row = |m: &Matrix3<f64>, i: usize| (0..3).map(|j| m[(i, j)].abs()).fold(0.0f64, f64::max);
    for sign in [1.0, -1.0] {
        let xp = xv.map(|v| v + sign * 1e-9 * v.abs().max(1e-3));
        let mut jp = Matrix3::zeros();
        f.jacobian(t, &xp, &inputs, &mut jp);
        for i in 0..3 {
            for j in 0..3 {
                let (a, b) = (jp[(i, j)], jd[(i, j)]);
                if !(a.is_finite() && b.is_finite()) || (a - b).abs() > limit * (1.0 + row(&jd, i)) {
                    return Ok(());
                }
            }
        }
    }
    for i in 0..3 {
        let scale = 1.0 + row(&jd, i);
        // the time as the body sees it: traced, or a constant of the body (same value)
        let (_, terms) = es[i].magnitudes(&x, &inputs, &params, t);
        for j in 0..3 {
            let (a, b) = (js[i + 3 * j], jd[(i, j)]);
            let agree = if a.is_finite() && b.is_finite() {
                // no bound on the terms (∞ or NaN: a factor ∞ times a term ∞·0): no test
                let tol = 1e-8 * scale + 1024.0 * f64::EPSILON * terms[j];
                a == b || tol.is_nan() || (a - b).abs() <= tol
            } else {
                !a.is_finite() && !b.is_finite()
            };
            assert!(
                agree,
                "∂f{i}/∂x{j} at t = {t:e}, x = {x:?}, u = {inputs:?}, p = {params:?}: traced {a:e}, num-dual {b:e}\nbody: {:?}",
                es[i]
            );
        }
    }
    Ok(())
}

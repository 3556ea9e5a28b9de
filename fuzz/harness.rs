//! Bodies of the fuzz targets, shared by `fuzz/fuzz_targets/*.rs` (libFuzzer) and by
//! `tests/fuzz_replay.rs` (which replays `fuzz/regressions/<target>/*` under `cargo test`).
//!
//! Every entry point takes raw bytes and must never panic: a typed error (`Err`) from the
//! library or the command is fine, a panic is a finding. Inputs are decoded with
//! `arbitrary::Unstructured`, so a saved crash file replays the same case everywhere.
#![allow(dead_code)]

use arbitrary::{Result, Unstructured};
use reckon::control::Tolerance;
use reckon::methods::{Dopri5, Exact, ExplicitEuler, Flow, ImplicitEuler, Method, NewtonOptions};
use reckon::nalgebra::allocator::Allocator;
use reckon::nalgebra::{DVector, DefaultAllocator, Dim, OVector, SVector, Vector1, Vector2};
use reckon::{Controls, Direction, Event, Options, Problem, StepSize, System, model};
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
/// `tests/fuzz_replay.rs`'s `show` test turns it on).
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
    let _ = reckon::cli::run(argv);
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
    let n = reckon::cli::registry::NAMES;
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
    ["--out", "--controls", "--encoders"]
        .iter()
        .any(|f| token.starts_with(f))
}

/// A command (`demo` excluded: too slow), its flags with generated values, an input file
/// and always `--out` inside the scratch folder.
pub fn cli_args(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let Ok(argv) = cli_argv(&mut u) else {
        return;
    };
    run_cli(argv);
}

fn cli_argv(u: &mut Unstructured) -> Result<Vec<OsString>> {
    let dir = scratch();
    let cmd = *u.choose(&["simulate", "odometry", "convergence", "stiffness", "work-precision"])?;
    let input = dir.join("input.csv");
    let headers: &[&str] = match cmd {
        "simulate" => &["t,v,omega", "t,v,steer", "t,v,steer_rate", "t,v", "v,t,omega,extra"],
        _ => &["t,left,right", "t,right,left", "t,left"],
    };
    let file = input_file(u, headers)?;
    write_file(&input, &file);
    trace(|| {
        let text = String::from_utf8_lossy(&file[..file.len().min(400)]).into_owned();
        format!("input file ({} bytes): {text:?}", file.len())
    });
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
    argv.push("--out".into());
    argv.push(
        match cmd {
            "simulate" | "odometry" => dir.join("out.csv"),
            _ => dir.join("study"),
        }
        .into(),
    );
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

/// Attach events and controls, then run the chosen method.
#[allow(clippy::too_many_arguments)]
fn solve_problem<D, S, F>(
    u: &mut Unstructured,
    sys: S,
    x0: OVector<f64, D>,
    inputs: usize,
    flow: F,
    span: (f64, f64),
    opts: &Options,
    plan: &Plan,
) -> Result<()>
where
    D: reckon::linalg::LuDim,
    S: System<D>,
    F: Flow<D>,
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
    ImplicitEuler<D>: Method<D>,
    Dopri5<D>: Method<D>,
{
    trace(|| format!("x0 = {:?}, span = {span:?}", x0.as_slice()));
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
    match plan.method {
        0 => drive(&p, ExplicitEuler, opts, plan),
        1 => drive(&p, ImplicitEuler::default(), opts, plan),
        2 => drive(&p, ImplicitEuler::new(plan.newton), opts, plan),
        3 => drive(&p, Dopri5::default(), opts, plan),
        _ => drive(&p, Exact::new(flow), opts, plan),
    }
    Ok(())
}

/// `solve()` then dense probes, or `step()` to the end (and once more after an error),
/// or the iterator.
fn drive<D: Dim, S: System<D>, M: Method<D>>(p: &Problem<'_, D, S>, method: M, opts: &Options, plan: &Plan)
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
/// output length (and an exact flow that may return the wrong length too).
pub fn solve(data: &[u8]) {
    let mut u = Unstructured::new(data);
    let _ = solve_case(&mut u);
}

fn solve_case(u: &mut Unstructured) -> Result<()> {
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
    let model = u.int_in_range(0u8..=5)?;
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
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan)
        }
        1 => {
            let f = model!(|_t, y: [S; 2]| Vector2::new(y[1], (-y[0] * y[0] + 1.0) * y[1] * k - y[0]));
            // not the exact flow (there is none): one explicit Euler step, a valid `Flow` all the same
            let flow = move |_t: f64, y: &Vector2<f64>, _u: &[f64], h: f64| {
                y + Vector2::new(y[1], (1.0 - y[0] * y[0]) * y[1] * k - y[0]) * h
            };
            let x0 = state(u, reckon::nalgebra::Const::<2>)?;
            solve_problem(u, &f, x0, 0, flow, span, &opts, &plan)
        }
        2 => {
            let f = reckon::models::unicycle::model();
            let x0: SVector<f64, 3> = state(u, reckon::nalgebra::Const::<3>)?;
            solve_problem(u, &f, x0, 2, reckon::models::unicycle::flow, span, &opts, &plan)
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
                    solve_problem(u, &f, x0, 0, flow, span, &opts, &plan)
                }
                4 => {
                    let f = model!(|_t, x: [S; Dyn]| {
                        use reckon::num_dual::DualStruct as _;
                        let wrong = !x.is_empty() && x[0].re() > threshold;
                        let len = out_len(x.len(), delta, wrong);
                        DVector::from_fn(len, |i, _| if i < x.len() { x[i].clone() * k } else { S::from(1.0) })
                    });
                    solve_problem(u, &f, x0, 0, flow, span, &opts, &plan)
                }
                _ => {
                    let f = model!(|_t, x: [S; Dyn]| {
                        calls.set(calls.get() + 1);
                        let len = out_len(x.len(), delta, calls.get() > after);
                        DVector::from_fn(len, |i, _| if i < x.len() { x[i].clone() * k } else { S::from(1.0) })
                    });
                    solve_problem(u, &f, x0, 0, flow, span, &opts, &plan)
                }
            }
        }
    }
}

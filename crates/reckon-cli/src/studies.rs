//! `reckon convergence`, `reckon stiffness`, `reckon work-precision`: CSV, SVG, a
//! printed summary, `--json` for machines, a progress bar for long runs.

use super::plot::{Plot, Series, Style, write_svg};
use super::registry::{History, lookup};
use indicatif::{ProgressBar, ProgressStyle};
use reckon::studies::MethodKind;
use reckon::studies::stability::{StabilityOf, boundary, euler_threshold, real_axis_limit};
use std::error::Error;
use std::io::Write;
use std::path::{Path, PathBuf};

type Res<T = ()> = Result<T, Box<dyn Error>>;

/// Locked standard output whose write errors say what failed: a closed pipe or a full
/// disk ends the command with one message and a non-zero exit, never a panic.
pub struct Stdout(std::io::StdoutLock<'static>);

impl Stdout {
    pub fn lock() -> Self {
        Stdout(std::io::stdout().lock())
    }
}

impl Default for Stdout {
    fn default() -> Self {
        Self::lock()
    }
}

fn tag(e: std::io::Error) -> std::io::Error {
    std::io::Error::new(e.kind(), format!("cannot write to standard output: {e}"))
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf).map_err(tag)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush().map_err(tag)
    }
}

/// The largest `reckon convergence --max-steps`: 10⁹ steps per run.
pub const MAX_CONVERGENCE_STEPS: i128 = 1_000_000_000;

/// Arguments shared by the study commands.
#[derive(Debug, clap::Args)]
pub struct Common {
    /// Problem name (rotation-decay, lti, dahlquist, sin-u, stiff-cosine, arenstorf, lorenz,
    /// unicycle, bicycle, carlike, van-der-pol, robertson, orego, hires, brusselator, or
    /// brusselator:N with N from 1 to 500000 grid points, 2N states).
    #[arg(long)]
    pub problem: String,
    /// Output folder for CSV and SVG files.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Print a machine-readable JSON summary instead of the table (fields in docs/studies.md).
    #[arg(long)]
    pub json: bool,
}

/// `reckon convergence`.
#[derive(Debug, clap::Args)]
pub struct ConvergenceArgs {
    #[command(flatten)]
    pub common: Common,
    /// Methods, comma separated (euler, implicit-euler, rk45, exponential-euler, rodas5p,
    /// exact).
    #[arg(long, value_delimiter = ',', default_value = "euler,implicit-euler,rk45")]
    pub methods: Vec<String>,
    /// Fixed step sizes, comma separated (default: five halvings suited to the problem).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub steps: Option<Vec<f64>>,
    /// Cap on the steps of one run, 1 to 10⁹: a step size that needs more over the
    /// problem's span is refused before anything runs.
    #[arg(long, default_value_t = reckon::studies::convergence::DEFAULT_MAX_STEPS as i128, allow_hyphen_values = true)]
    pub max_steps: i128,
}

/// `reckon stiffness`.
#[derive(Debug, clap::Args)]
pub struct StiffnessArgs {
    #[command(flatten)]
    pub common: Common,
    /// Relative tolerance of the adaptive runs.
    #[arg(long, default_value_t = 1e-4, allow_hyphen_values = true)]
    pub rtol: f64,
    /// Absolute tolerance of the adaptive runs.
    #[arg(long, default_value_t = 1e-7, allow_hyphen_values = true)]
    pub atol: f64,
    /// Step limit per run, 1 to 10⁷ (RK45 on a stiff problem stops here, and says so;
    /// each run keeps its step-size history, so the limit bounds memory).
    #[arg(long, default_value_t = 200_000, allow_hyphen_values = true)]
    pub max_steps: i128,
}

/// `reckon work-precision`.
#[derive(Debug, clap::Args)]
pub struct WorkPrecisionArgs {
    #[command(flatten)]
    pub common: Common,
    /// Methods, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "implicit-euler,rk45")]
    pub methods: Vec<String>,
    /// Tolerances of the adaptive methods, comma separated: rtol, and atol = rtol (robertson:
    /// atol = 1e-4·rtol, the Test Set convention).
    #[arg(long, value_delimiter = ',', required = true, allow_hyphen_values = true)]
    pub tolerances: Vec<f64>,
    /// Fixed steps for explicit Euler, comma separated.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub steps: Option<Vec<f64>>,
    /// Timing repetitions (the fastest counts), 1 to 1000.
    #[arg(long, default_value_t = 3, allow_hyphen_values = true)]
    pub runs: i128,
}

fn methods(names: &[String]) -> Res<Vec<MethodKind>> {
    if names.is_empty() || names.iter().all(|n| n.trim().is_empty()) {
        return Err("no method given".into());
    }
    // a method named twice runs once (fuzzed lists repeated a 1.4 s study five times)
    Ok(distinct(
        &names.iter().map(|n| n.parse()).collect::<Result<Vec<_>, _>>()?,
    ))
}

/// The entries of `v` in their first order, each once.
fn distinct<T: PartialEq + Clone>(v: &[T]) -> Vec<T> {
    let mut out: Vec<T> = Vec::with_capacity(v.len());
    for x in v {
        if !out.contains(x) {
            out.push(x.clone());
        }
    }
    out
}

fn positive(what: &str, v: &[f64]) -> Res {
    if v.is_empty() {
        return Err(format!("the {what} list is empty").into());
    }
    if let Some(bad) = v.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
        return Err(format!("{what} must be positive and finite, got {bad}").into());
    }
    Ok(())
}

/// Create the output folder and prove it is writable before any work is done.
pub fn prepare(dir: &Path) -> Res {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create output folder {}: {e}", dir.display()))?;
    let probe = dir.join(".reckon-write-test");
    std::fs::write(&probe, b"").map_err(|e| format!("cannot write to output folder {}: {e}", dir.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}

fn progress(n: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(n);
    if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len} {elapsed}") {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(what.to_string());
    pb
}

fn write_csv(path: &Path, header: &str, rows: impl IntoIterator<Item = String>) -> Res {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).map_err(|e| format!("cannot write {}: {e}", path.display()))?,
    );
    writeln!(f, "{header}")?;
    for r in rows {
        writeln!(f, "{r}")?;
    }
    f.flush()?;
    Ok(())
}

fn fmt_order(o: Option<f64>) -> String {
    o.map(|v| format!("{v:.3}")).unwrap_or_else(|| "-".into())
}

fn fit_cell(f: &reckon::studies::convergence::ConvergenceFit, o: Option<f64>) -> String {
    match (o, f.theory) {
        (Some(v), _) => format!("{v:.3}"),
        (None, Some(_)) => "not asymptotic".into(),
        (None, None) => "-".into(),
    }
}

pub fn convergence(a: &ConvergenceArgs) -> Res {
    let ms = methods(&a.methods)?;
    let p = lookup(&a.common.problem)?;
    if let Some(steps) = &a.steps {
        positive("step", steps)?;
    }
    let max_steps: u64 = super::whole("--max-steps", a.max_steps, 1..=MAX_CONVERGENCE_STEPS)?;
    let plan: Vec<(MethodKind, Vec<f64>)> = ms
        .iter()
        .map(|m| (*m, distinct(&a.steps.clone().unwrap_or_else(|| p.default_steps(*m)))))
        .collect();
    // a refused study writes no file
    for (m, steps) in &plan {
        p.check_convergence(&[*m], steps, max_steps).map_err(|e| {
            let hint = if e.to_string().contains("cap of") {
                "; raise --max-steps to run it"
            } else {
                ""
            };
            format!("{} on {}: {e}{hint}", m.name(), p.name())
        })?;
    }
    prepare(&a.common.out)?;
    let pb = progress(ms.len() as u64, "convergence");
    let mut study = reckon::studies::convergence::Convergence {
        rows: vec![],
        fits: vec![],
    };
    // a method that fails (e.g. Newton on a problem it cannot handle at these steps)
    // does not stop the others; the first failure is reported after the files are written
    let mut failure: Option<String> = None;
    for (m, steps) in &plan {
        match p.convergence(&[*m], steps, max_steps) {
            Ok(s) => {
                study.rows.extend(s.rows);
                study.fits.extend(s.fits);
            }
            Err(e) => {
                failure.get_or_insert(format!("{} failed on {}: {e}", m.name(), p.name()));
            }
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    if study.rows.is_empty() {
        // nothing was measured: no empty table, no empty figure
        return Err(failure.unwrap_or_else(|| "nothing was computed".into()).into());
    }
    let dir = &a.common.out;
    write_csv(
        &dir.join("convergence.csv"),
        "method,h,steps,rhs_evals,final_error,max_error",
        study.rows.iter().map(|r| {
            format!(
                "{},{},{},{},{},{}",
                r.method.name(),
                r.h,
                r.steps,
                r.rhs_evals,
                r.final_error,
                r.max_error
            )
        }),
    )?;
    let mut plot = Plot::new(
        format!("Convergence: {}", p.name()),
        "step size h (s)",
        "max-norm error at t_end",
    )
    .log_log();
    for f in &study.fits {
        let pts: Vec<(f64, f64)> = study
            .rows
            .iter()
            .filter(|r| r.method == f.method)
            .map(|r| (r.h, r.final_error))
            .collect();
        let label = match (f.order_final, f.theory) {
            (Some(o), _) => format!("{} (slope {o:.3})", f.method.name()),
            (None, Some(_)) => format!("{} (not asymptotic)", f.method.name()),
            (None, None) => f.method.name().to_string(),
        };
        plot = plot.with(Series::new(label, pts, Style::LinePoints));
    }
    write_svg(&plot, &dir.join("convergence.svg"), (800, 560))?;
    let mut out = Stdout::lock();
    if a.common.json {
        let v = serde_json::json!({
            "problem": p.name(), "description": p.describe(), "rows": study.rows, "fits": study.fits,
            "files": ["convergence.csv", "convergence.svg"],
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        writeln!(out, "{}: {}", p.name(), p.describe())?;
        writeln!(
            out,
            "{:<16} {:>14} {:>14} {:>8}",
            "method", "order (final)", "order (max)", "theory"
        )?;
        for f in &study.fits {
            writeln!(
                out,
                "{:<16} {:>14} {:>14} {:>8}",
                f.method.name(),
                fit_cell(f, f.order_final),
                fit_cell(f, f.order_max),
                fmt_order(f.theory)
            )?;
        }
        for f in study.fits.iter().filter(|f| f.theory.is_some()) {
            if let Some(why) = &f.reason {
                writeln!(out, "{}: not asymptotic, no order fitted: {why}", f.method.name())?;
            }
        }
        writeln!(out, "wrote {}/convergence.csv and convergence.svg", dir.display())?;
    }
    out.flush()?;
    match failure {
        Some(f) => Err(f.into()),
        None => Ok(()),
    }
}

/// Stability-region boundaries of the three methods and the Dahlquist threshold table.
pub fn stability_files(dir: &Path) -> Res<Vec<(f64, f64, f64)>> {
    let methods = [
        (StabilityOf::Euler, "explicit Euler |1 + z| = 1"),
        (
            StabilityOf::ImplicitEuler,
            "implicit Euler |1/(1 - z)| = 1 (stable outside)",
        ),
        (StabilityOf::Rk45, "DP5 |R(z)| = 1 (stable inside)"),
    ];
    let mut plot = Plot::new("Linear stability regions |R(hλ)| ≤ 1", "Re(hλ)", "Im(hλ)").equal();
    let mut csv = Vec::new();
    for (m, label) in methods {
        let segs = boundary(m, (-4.5, 2.5), (-4.4, 4.4), 281);
        for s in &segs {
            csv.push(format!("{m:?},{},{},{},{}", s[0].0, s[0].1, s[1].0, s[1].1));
        }
        plot = plot.with(Series::new(
            label,
            segs.iter().flat_map(|s| [s[0], s[1]]).collect(),
            Style::Segments,
        ));
    }
    write_svg(&plot, &dir.join("stability_regions.svg"), (760, 640))?;
    write_csv(&dir.join("stability_boundary.csv"), "method,x0,y0,x1,y1", csv)?;
    let mut rows = Vec::new();
    for lambda in [-1.0, -10.0, -100.0, -1000.0] {
        rows.push((lambda, euler_threshold(lambda, 400)?, 2.0 / f64::abs(lambda)));
    }
    write_csv(
        &dir.join("dahlquist_threshold.csv"),
        "lambda,located_h,theory_2_over_abs_lambda,relative_difference",
        rows.iter().map(|(l, h, t)| format!("{l},{h},{t},{}", h / t - 1.0)),
    )?;
    Ok(rows)
}

pub fn history_plot(title: &str, hist: &[History]) -> Plot {
    let mut plot = Plot::new(title, "t (s)", "accepted step size h (s)")
        .log_y()
        .legend_at(super::plot::Legend::Lower);
    for h in hist {
        let label = match &h.stopped_by {
            Some(_) => format!("{} ({} steps, stopped at t = {:.3})", h.method, h.accepted, h.reached),
            None => format!("{} ({} steps)", h.method, h.accepted),
        };
        plot = plot.with(Series::new(
            label,
            h.t.iter().copied().zip(h.h.iter().copied()).collect(),
            Style::Line,
        ));
    }
    plot
}

fn ordinal(k: usize) -> String {
    if k == 1 { String::new() } else { format!("{k}-th ") }
}

pub fn stiffness(a: &StiffnessArgs) -> Res {
    let p = lookup(&a.common.problem)?;
    positive("rtol", &[a.rtol])?;
    positive("atol", &[a.atol])?;
    let max_steps: usize = super::whole("--max-steps", a.max_steps, 1..=10_000_000)?;
    prepare(&a.common.out)?;
    let dir = &a.common.out;
    let pb = progress(3, "stiffness");
    let hist = p.histories(a.rtol, a.atol, max_steps);
    pb.inc(1);
    // the implicit-Euler history ran at the same tolerances: its step count
    let ie_steps = hist
        .iter()
        .find(|h| {
            h.method == reckon::methods::Method::<nalgebra::Dyn>::name(&reckon::methods::ImplicitEuler::default())
                && h.stopped_by.is_none()
        })
        .map(|h| h.accepted as usize);
    let run = p.stiffness_points(a.rtol, a.atol, ie_steps)?;
    let pts = &run.points;
    pb.inc(1);
    let dahl = stability_files(dir)?;
    pb.inc(1);
    pb.finish_and_clear();
    write_csv(
        &dir.join("step_sizes.csv"),
        "method,t,h",
        hist.iter()
            .flat_map(|h| h.t.iter().zip(&h.h).map(move |(t, s)| format!("{},{t},{s}", h.method))),
    )?;
    write_svg(
        &history_plot(&format!("Step sizes: {}", p.name()), &hist),
        &dir.join("step_sizes.svg"),
        (860, 560),
    )?;
    write_csv(
        &dir.join("stiffness.csv"),
        "t,spectral_radius,stiffness_ratio,h_accuracy,h_stability,stiffness_index",
        pts.iter().map(|q| {
            format!(
                "{},{},{},{},{},{}",
                q.t, q.spectral_radius, q.ratio, q.h_accuracy, q.h_stability, q.index
            )
        }),
    )?;
    let plot = Plot::new(
        format!("Stiffness along the solution: {}", p.name()),
        "t (s)",
        "autodiff Jacobian along the implicit-Euler solution",
    )
    .log_y()
    .with(Series::new(
        "stiffness index ρ(J)·h_accuracy/3.31",
        pts.iter().map(|q| (q.t, q.index)).collect(),
        Style::Line,
    ))
    .with(Series::new(
        "spectral radius ρ(J) (1/s)",
        pts.iter().map(|q| (q.t, q.spectral_radius)).collect(),
        Style::Line,
    ));
    write_svg(&plot, &dir.join("stiffness.svg"), (860, 560))?;
    let max_ratio = pts
        .iter()
        .map(|q| q.ratio)
        .filter(|r| r.is_finite())
        .fold(1.0, f64::max);
    let index = reckon::studies::stiffness::summarize(pts);
    let estimate = if run.sparse {
        format!(
            "sparse: ρ(J) by Arnoldi with Gershgorin's bound, min|λ| by Arnoldi on J⁻¹ (sparse LU), at every {}implicit-Euler step ({} points)",
            ordinal(run.every),
            pts.len()
        )
    } else {
        format!(
            "dense: all eigenvalues by QR at every implicit-Euler step ({} points)",
            pts.len()
        )
    };
    let mut out = Stdout::lock();
    if a.common.json {
        let v = serde_json::json!({
            "problem": p.name(), "description": p.describe(), "histories": hist,
            "stiffness_index": index,
            "max_stiffness_ratio": max_ratio,
            "stiffness_estimate": if run.sparse { "sparse" } else { "dense" },
            "stiffness_every": run.every,
            "stiffness_points": pts.len(),
            "dp5_real_axis_limit": real_axis_limit(StabilityOf::Rk45),
            "euler_threshold": dahl.iter().map(|(l, h, t)| serde_json::json!({"lambda": l, "located": h, "theory": t})).collect::<Vec<_>>(),
            "files": ["step_sizes.csv", "step_sizes.svg", "stiffness.csv", "stiffness.svg", "stability_regions.svg", "stability_boundary.csv", "dahlquist_threshold.csv"],
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        writeln!(out, "{}: {}", p.name(), p.describe())?;
        for h in &hist {
            write!(
                out,
                "{:<15} accepted {:>8} rejected {:>6} rhs evals {:>9}",
                h.method, h.accepted, h.rejected, h.rhs_evals
            )?;
            if let Some(t) = h.stiff_at {
                write!(out, "  stiffness detected at t = {t:.4}")?;
            }
            if let Some(e) = &h.stopped_by {
                write!(out, "  stopped: {e}")?;
            }
            writeln!(out)?;
        }
        writeln!(
            out,
            "stiffness index (step accuracy needs / step DP5's stability allows): time-weighted median {:.3e}, max {:.3e}; above 1 (stiff) over {:.1} % of the span",
            index.median,
            index.max,
            100.0 * index.stiff_fraction
        )?;
        if run.sparse {
            writeln!(out, "largest eigenvalue ratio ρ(J)/min|λ|: {max_ratio:.3e}")?;
        } else {
            writeln!(out, "largest eigenvalue ratio max|Re λ|/min|Re λ|: {max_ratio:.3e}")?;
        }
        writeln!(out, "eigenvalues {estimate}")?;
        for (l, h, t) in &dahl {
            writeln!(
                out,
                "explicit Euler on λ = {l}: unstable above h = {h:.6} (theory 2/|λ| = {t:.6})"
            )?;
        }
        writeln!(
            out,
            "wrote step_sizes, stiffness, stability_regions (CSV and SVG) in {}",
            dir.display()
        )?;
    }
    out.flush()?;
    Ok(())
}

/// Error at the end time (or, with `digits`, correct digits: the Test Set's mescd, on a
/// linear axis) against rhs evaluations (or wall time), one line per method.
pub fn work_precision_plot(
    title: &str,
    x_label: &str,
    methods: &[MethodKind],
    pts: &[reckon::studies::work_precision::WorkPoint],
    by_time: bool,
    digits: bool,
) -> Plot {
    let mut plot = if digits {
        let mut p = Plot::new(title, x_label, "correct digits at t_end (mescd)");
        p.log_x = true;
        p
    } else {
        Plot::new(title, x_label, "max-norm error at t_end").log_log()
    };
    for m in methods {
        let s: Vec<(f64, f64)> = pts
            .iter()
            .filter(|w| w.method == *m)
            .map(|w| {
                (
                    if by_time { w.seconds } else { w.rhs_evals as f64 },
                    if digits { w.digits } else { w.error },
                )
            })
            .collect();
        plot = plot.with(Series::new(m.name(), s, Style::LinePoints));
    }
    plot
}

pub fn work_precision(a: &WorkPrecisionArgs) -> Res {
    let ms = methods(&a.methods)?;
    let runs: usize = super::whole("--runs", a.runs, 1..=1000)?;
    positive("tolerance", &a.tolerances)?;
    if let Some(bad) = a.tolerances.iter().find(|t| **t >= 1.0) {
        return Err(format!(
            "tolerance must be below 1 (a relative tolerance of 1 asks for no correct digit), got {bad}"
        )
        .into());
    }
    // a tolerance or step given twice is one setting (the same run twice only doubles the
    // time: a fuzzed list repeated a 1.4 s failing setting eight times)
    let tolerances = distinct(&a.tolerances);
    let steps = distinct(&a.steps.clone().unwrap_or_else(|| vec![1e-2, 1e-3, 1e-4]));
    positive("step", &steps)?;
    let p = lookup(&a.common.problem)?;
    prepare(&a.common.out)?;
    // one run per (method, setting), so that a failing setting (e.g. a step-size
    // underflow at a loose tolerance) is reported without losing the others
    let settings = |m: &MethodKind| {
        if *m == MethodKind::Euler {
            steps.len()
        } else {
            tolerances.len()
        }
    };
    let pb = progress(ms.iter().map(|m| settings(m) as u64).sum(), "work-precision");
    let mut pts = Vec::new();
    let mut failure: Option<String> = None;
    for m in &ms {
        for k in 0..settings(m) {
            let (tols, hs) = if *m == MethodKind::Euler {
                (&tolerances[..1], &steps[k..=k])
            } else {
                (&tolerances[k..=k], &steps[..0])
            };
            match p.work_precision(&[*m], tols, hs, runs) {
                Ok(w) => pts.extend(w),
                Err(e) => {
                    let setting = if *m == MethodKind::Euler { hs[0] } else { tols[0] };
                    failure.get_or_insert(format!("{} at {setting:e} failed on {}: {e}", m.name(), p.name()));
                }
            }
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    if pts.is_empty() {
        // nothing was measured: no empty table, no empty figure
        return Err(failure.unwrap_or_else(|| "nothing was computed".into()).into());
    }
    let dir = &a.common.out;
    write_csv(
        &dir.join("work_precision.csv"),
        "method,setting,error,rhs_evals,steps,seconds,digits",
        pts.iter().map(|w| {
            format!(
                "{},{},{},{},{},{},{}",
                w.method.name(),
                w.setting,
                w.error,
                w.rhs_evals,
                w.steps,
                w.seconds,
                w.digits
            )
        }),
    )?;
    // correct digits (mescd), not the absolute max-norm error: an error of 1e-10 is
    // no accuracy at all for Robertson's y₂ ≈ 8·10⁻¹⁴ at t = 10¹¹ (an exact run's
    // infinite digits are left out of the figure; the CSV has them)
    for (file, xl, pick) in [
        ("digits_vs_rhs_evals.svg", "rhs evaluations", 0),
        ("digits_vs_time.svg", "wall time (s)", 1),
    ] {
        let plot = work_precision_plot(&format!("Work–precision: {}", p.name()), xl, &ms, &pts, pick == 1, true);
        write_svg(&plot, &dir.join(file), (800, 560))?;
    }
    let mut out = Stdout::lock();
    if a.common.json {
        let v = serde_json::json!({
            "problem": p.name(), "description": p.describe(), "points": pts,
            "files": ["work_precision.csv", "digits_vs_rhs_evals.svg", "digits_vs_time.svg"],
        });
        writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
    } else {
        writeln!(out, "{}: {}", p.name(), p.describe())?;
        writeln!(
            out,
            "{:<16} {:>10} {:>7} {:>12} {:>11} {:>10}",
            "method", "setting", "digits", "error", "rhs evals", "ms"
        )?;
        for w in &pts {
            writeln!(
                out,
                "{:<16} {:>10.1e} {:>7.2} {:>12.3e} {:>11} {:>10.3}",
                w.method.name(),
                w.setting,
                w.digits,
                w.error,
                w.rhs_evals,
                w.seconds * 1e3
            )?;
        }
        writeln!(
            out,
            "(digits: the Test Set's mescd, -log10 max_i |y_i - r_i|/(atol/rtol + |r_i|); error: max-norm at t_end)"
        )?;
        writeln!(
            out,
            "wrote work_precision.csv, digits_vs_rhs_evals.svg, digits_vs_time.svg in {}",
            dir.display()
        )?;
    }
    out.flush()?;
    match failure {
        Some(f) => Err(f.into()),
        None => Ok(()),
    }
}

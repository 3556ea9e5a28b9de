//! `reckon jacobian`: a vehicle model's or a test problem's right-hand side and
//! Jacobian, traced from its `model!` body and printed symbolically.

use reckon::studies::problems;
use reckon::symbolic::{self, Traced};
use reckon::vehicles::{bicycle, body3d, carlike, unicycle};
use std::io::Write;

/// How to print.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// `f` and every non-zero `∂fᵢ/∂xⱼ`, `∂fᵢ/∂uₖ`, `∂fᵢ/∂t`, one per line.
    Text,
    /// What `text` prints (`f`, `∂f/∂x`, `∂f/∂u`, `∂f/∂t`) as LaTeX pmatrices (at most 200 states).
    Latex,
    /// What `text` prints as one MathML `<math>` element (matrices in stretchy fences; at
    /// most 200 states).
    Mathml,
    /// Rust source of `rhs` and `jacobian` functions.
    Rust,
    /// Everything, with the CSC sparsity pattern, as JSON.
    Json,
}

/// Arguments of `reckon jacobian`.
#[derive(Debug, clap::Args)]
#[command(group(clap::ArgGroup::new("which").required(true).args(["model", "problem"])))]
pub struct JacobianArgs {
    /// Vehicle model: unicycle, bicycle, carlike or body3d.
    #[arg(long)]
    pub model: Option<String>,
    /// Test problem: robertson, vdp (μ = 1000), orego, hires, lorenz, arenstorf,
    /// stiff-cosine, rotation-decay, sin-u, or brusselator:N (N from 1 to 500000 grid
    /// points, 2N states).
    #[arg(long)]
    pub problem: Option<String>,
    /// Wheelbase of the bicycle (default 0.5) and car-like (default 2.5) models.
    #[arg(long, allow_hyphen_values = true)]
    pub wheelbase: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
}

fn traced(a: &JacobianArgs) -> Result<Traced, String> {
    let e = |r: reckon::Result<Traced>| r.map_err(|e| e.to_string());
    let wheelbase = |default: f64| -> Result<f64, String> {
        match a.wheelbase {
            None => Ok(default),
            Some(l) if l.is_finite() && l > 0.0 && (1.0 / l).is_finite() => Ok(l),
            Some(l) => Err(format!(
                "--wheelbase must be finite and positive with 1/L finite (L ≥ {:e}), got {l:e}",
                1.0 / f64::MAX
            )),
        }
    };
    if let Some(m) = &a.model {
        if a.wheelbase.is_some() && !matches!(m.as_str(), "bicycle" | "carlike") {
            return Err(format!("--wheelbase applies to bicycle and carlike, not {m}"));
        }
        return match m.as_str() {
            "unicycle" => {
                e(symbolic::trace(&unicycle::model(), 3)).map(|t| t.with_names(&["x", "y", "θ"], &["v", "ω"]))
            }
            "bicycle" => e(symbolic::trace(&bicycle::model(wheelbase(0.5)?), 3))
                .map(|t| t.with_names(&["x", "y", "θ"], &["v", "α"])),
            "carlike" => e(symbolic::trace(&carlike::model(wheelbase(2.5)?), 4))
                .map(|t| t.with_names(&["x", "y", "θ", "γ"], &["v", "ω"])),
            "body3d" => e(symbolic::trace(&body3d::model(), 3))
                .map(|t| t.with_names(&["x", "y", "z"], &["φ", "θ", "ψ", "v_x", "v_y", "v_z"])),
            other => Err(format!(
                "unknown model '{other}' (known: unicycle, bicycle, carlike, body3d)"
            )),
        };
    }
    if a.wheelbase.is_some() {
        return Err("--wheelbase applies to --model bicycle and carlike".into());
    }
    let p = a.problem.as_deref().unwrap_or_default();
    if let Some(n) = super::registry::brusselator_size(p) {
        let n = n?;
        return e(symbolic::trace(&problems::brusselator(n), 2 * n));
    }
    match p {
        "robertson" => e(symbolic::trace(&problems::robertson(), 3)),
        "vdp" | "van-der-pol" => e(symbolic::trace(&problems::van_der_pol(1000.0), 2)),
        "orego" => e(symbolic::trace(&problems::orego(), 3)),
        "hires" => e(symbolic::trace(&problems::hires(), 8)),
        "lorenz" => e(symbolic::trace(&problems::lorenz(), 3)),
        "arenstorf" => e(symbolic::trace(&problems::arenstorf(), 4)),
        "stiff-cosine" => e(symbolic::trace(&problems::stiff_cosine(), 1)),
        "rotation-decay" => e(symbolic::trace(&problems::rotation_decay(), 2)),
        "sin-u" => e(symbolic::trace(&problems::sin_u(), 1)),
        other => Err(format!(
            "unknown problem '{other}' (known: robertson, vdp, orego, hires, lorenz, arenstorf, \
             stiff-cosine, rotation-decay, sin-u, brusselator:N)"
        )),
    }
}

/// Most states `--format latex` and `--format mathml` print: they write `∂f/∂x` as a dense
/// `n × n` matrix, zeros included, so their output and memory grow as `n²` (BRUSS with
/// 2 000 points, 4 000 states, took 1.8 GB and seconds as MathML; with 500 000 points it
/// would take terabytes). `text`, `rust` and `json` print the non-zeros only.
pub const MAX_DENSE_STATES: usize = 200;

fn dense_format_fits(format: Format, states: usize) -> Result<(), String> {
    if matches!(format, Format::Latex | Format::Mathml) && states > MAX_DENSE_STATES {
        return Err(format!(
            "--format {} prints ∂f/∂x as a dense matrix, for at most {MAX_DENSE_STATES} states; this model has {states} (--format text, rust or json print the non-zeros only)",
            if format == Format::Latex { "latex" } else { "mathml" }
        ));
    }
    Ok(())
}

/// Print the traced model in the chosen format.
pub fn run(a: &JacobianArgs) -> Result<(), Box<dyn std::error::Error>> {
    // refused before tracing when the size is known from the name
    if let Some(Ok(n)) = a.problem.as_deref().and_then(super::registry::brusselator_size) {
        dense_format_fits(a.format, n.saturating_mul(2))?;
    }
    let tr = traced(a)?;
    dense_format_fits(a.format, tr.n())?;
    let mut out = super::studies::Stdout::lock();
    match a.format {
        Format::Text => write!(out, "{}", tr.text())?,
        Format::Latex => writeln!(out, "{}", tr.latex())?,
        Format::Mathml => writeln!(out, "{}", tr.mathml())?,
        Format::Rust => write!(out, "{}", tr.rust())?,
        Format::Json => writeln!(out, "{}", serde_json::to_string_pretty(&tr.json())?)?,
    }
    out.flush()?;
    Ok(())
}

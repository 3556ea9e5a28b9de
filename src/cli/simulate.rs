//! `reckon simulate`: a vehicle model driven by a controls CSV, with any method.

use super::csvio::{open_output, read_table, write_row};
use crate::methods::{Dopri5, Exact, ExplicitEuler, Flow, ImplicitEuler, Method};
use crate::models::{bicycle, carlike, unicycle};
use crate::{Controls, Options, Problem, System};
use nalgebra::{Const, SVector};
use std::error::Error;
use std::io::Write;
use std::path::PathBuf;

/// Vehicle models the command knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModelName {
    /// state x,y,theta; controls t,v,omega
    Unicycle,
    /// state x,y,theta; controls t,v,steer; parameter wheelbase (default 0.5)
    Bicycle,
    /// state x,y,theta,steer; controls t,v,steer_rate; parameter wheelbase (default 2.5)
    Carlike,
}

/// Integration methods the command knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodName {
    /// explicit Euler, fixed step
    Euler,
    /// implicit Euler (Newton with the autodiff Jacobian), fixed step
    ImplicitEuler,
    /// adaptive Dormand–Prince 5(4)
    Rk45,
    /// the model's exact flow, one step per control interval (--dt: a finer grid)
    Exact,
}

/// Arguments of `reckon simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Vehicle model.
    #[arg(long, value_enum)]
    pub model: ModelName,
    /// Controls CSV: header t,<inputs>; each row's inputs hold until the next row's t;
    /// the last row's t is the end time.
    #[arg(long)]
    pub controls: PathBuf,
    /// Integration method.
    #[arg(long, value_enum)]
    pub method: MethodName,
    /// Fixed step of euler and implicit-euler (default: one step per control interval);
    /// largest step of rk45.
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f64>,
    /// Relative tolerance (rk45; Newton's scale for implicit-euler).
    #[arg(long, default_value_t = 1e-6, allow_negative_numbers = true)]
    pub rtol: f64,
    /// Absolute tolerance.
    #[arg(long, default_value_t = 1e-9, allow_negative_numbers = true)]
    pub atol: f64,
    /// Model parameter NAME=VALUE (wheelbase).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Initial state, comma separated (x,y,theta[,steer]); default all zero.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub x0: Option<Vec<f64>>,
    /// Output CSV (default: standard output).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

fn parse_params(model: ModelName, params: &[String]) -> Result<f64, Box<dyn Error>> {
    let mut wheelbase = match model {
        ModelName::Carlike => 2.5,
        _ => 0.5,
    };
    for p in params {
        let (name, value) = p
            .split_once('=')
            .ok_or_else(|| format!("--param '{p}' is not NAME=VALUE"))?;
        let v: f64 = value
            .trim()
            .parse()
            .map_err(|_| format!("--param {name}: '{value}' is not a number"))?;
        match (name.trim(), model) {
            ("wheelbase", ModelName::Bicycle | ModelName::Carlike) => {
                if !(v.is_finite() && v > 0.0) {
                    return Err(format!("--param wheelbase must be finite and positive, got {v}").into());
                }
                wheelbase = v;
            }
            (n, m) => return Err(format!("--param: the {m:?} model has no parameter '{n}'").into()),
        }
    }
    Ok(wheelbase)
}

/// Run the command; rows computed before an error are written before it is returned.
pub fn run(args: &SimulateArgs) -> Result<(), Box<dyn Error>> {
    let wheelbase = parse_params(args.model, &args.params)?;
    if let Some(dt) = args.dt {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(format!("--dt must be finite and positive, got {dt}").into());
        }
        if args.method == MethodName::Exact {
            return Err("--dt does not apply to the exact method: it takes one step per control interval".into());
        }
    }
    let inputs: &[&str] = match args.model {
        ModelName::Unicycle => &["t", "v", "omega"],
        ModelName::Bicycle => &["t", "v", "steer"],
        ModelName::Carlike => &["t", "v", "steer_rate"],
    };
    let table = read_table(&args.controls, inputs)?;
    let mut out = open_output(args.out.as_deref())?;
    let result = if table.rows.len() < 2 {
        match &table.error {
            Some(_) => Ok(()),
            None => Err(format!(
                "{}: at least two rows are needed (the last row's t is the end time)",
                args.controls.display()
            )
            .into()),
        }
    } else {
        let times = table.rows.iter().map(|r| r.1[0]).collect();
        let values = table.rows.iter().map(|r| r.1[1..].to_vec()).collect();
        let controls = Controls::new(times, values)?;
        match args.model {
            ModelName::Unicycle => model_run(
                args,
                unicycle::model(),
                unicycle::flow,
                controls,
                &mut out,
                "t,x,y,theta",
            ),
            ModelName::Bicycle => model_run(
                args,
                bicycle::model(wheelbase),
                bicycle::flow(wheelbase),
                controls,
                &mut out,
                "t,x,y,theta",
            ),
            ModelName::Carlike => model_run(
                args,
                carlike::model(wheelbase),
                carlike::flow(wheelbase),
                controls,
                &mut out,
                "t,x,y,theta,steer",
            ),
        }
    };
    out.flush()?;
    result?;
    match table.error {
        Some(e) => Err(e.into()),
        None => Ok(()),
    }
}

fn model_run<const N: usize>(
    args: &SimulateArgs,
    sys: impl System<Const<N>>,
    flow: impl Flow<Const<N>>,
    controls: Controls,
    out: &mut dyn Write,
    header: &str,
) -> Result<(), Box<dyn Error>>
where
    Const<N>: crate::linalg::LuDim,
{
    let x0 = match &args.x0 {
        None => SVector::<f64, N>::zeros(),
        Some(v) if v.len() == N => SVector::<f64, N>::from_column_slice(v),
        Some(v) => {
            return Err(format!(
                "--x0 has {} values, the {:?} state has {N} ({header})",
                v.len(),
                args.model
            )
            .into());
        }
    };
    let t0 = controls.times()[0];
    let t_end = *controls.times().last().unwrap_or(&t0);
    let problem = Problem::new(&sys, x0, (t0, t_end)).controls(controls);
    let base = Options::default().rtol(args.rtol).atol(args.atol).dense(false);
    let span = t_end - t0;
    writeln!(out, "{header}")?;
    match args.method {
        MethodName::Euler => stream(&problem, ExplicitEuler, &base.fixed(args.dt.unwrap_or(span)), out),
        MethodName::ImplicitEuler => stream(
            &problem,
            ImplicitEuler::default(),
            &base.fixed(args.dt.unwrap_or(span)),
            out,
        ),
        MethodName::Rk45 => stream(
            &problem,
            Dopri5::default(),
            &base.h_max(args.dt.unwrap_or(f64::INFINITY)),
            out,
        ),
        MethodName::Exact => stream(&problem, Exact::new(flow), &base, out),
    }
}

/// Write the start and every step as it is taken.
fn stream<const N: usize, S: System<Const<N>>, M: Method<Const<N>>>(
    problem: &Problem<'_, Const<N>, S>,
    method: M,
    opts: &Options,
    out: &mut dyn Write,
) -> Result<(), Box<dyn Error>> {
    let mut it = problem.integrator(method, opts)?;
    write_row(out, it.t(), it.x().as_slice())?;
    while let Some(t) = it.step()? {
        write_row(out, t, it.x().as_slice())?;
    }
    Ok(())
}

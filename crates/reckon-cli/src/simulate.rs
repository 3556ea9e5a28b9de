//! `reckon simulate`: a vehicle model driven by a controls CSV, with any method.

use super::csvio::{RowWriter, Rows, check_not_input, num};
use nalgebra::{Const, SVector};
use reckon::methods::{Auto, Bdf, Euler, Exact, ImplicitEuler, Method, Rk45, Rodas5P};
use reckon::model::Flow;
use reckon::vehicles::{bicycle, carlike, unicycle};
use reckon::{Options, Problem, System};
use std::error::Error;
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
    /// adaptive variable-order BDF/NDF 1–5 (stiff)
    Bdf,
    /// adaptive Rosenbrock Rodas5P (stiff, exact Jacobian)
    Rodas5p,
    /// rk45 switching to bdf while the model is stiff
    Auto,
    /// the model's exact flow, one step per control interval (--dt: a finer grid)
    Exact,
}

/// Arguments of `reckon simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    /// Vehicle model.
    #[arg(long, value_enum)]
    pub model: ModelName,
    /// Controls CSV: header t,<inputs> (other columns are ignored; every row has as many
    /// fields as the header); each row's inputs hold until the next row's t; the last
    /// row's t is the end time. Read and integrated row by row: a log of any length runs
    /// in constant memory.
    #[arg(long)]
    pub controls: PathBuf,
    /// Integration method.
    #[arg(long, value_enum)]
    pub method: MethodName,
    /// Fixed step of euler, implicit-euler and exact (default: one step per control
    /// interval); largest step of rk45, bdf, rodas5p and auto.
    #[arg(long, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Relative tolerance (adaptive methods; Newton's scale for implicit-euler).
    #[arg(long, default_value_t = 1e-6, allow_hyphen_values = true)]
    pub rtol: f64,
    /// Absolute tolerance.
    #[arg(long, default_value_t = 1e-9, allow_hyphen_values = true)]
    pub atol: f64,
    /// Model parameter NAME=VALUE (wheelbase).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Initial state, comma separated (x,y,theta[,steer]); default all zero.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub x0: Option<Vec<f64>>,
    /// Largest number of step attempts between two consecutive control rows (so the
    /// limit scales with the length of the log), at least 1.
    #[arg(long, default_value_t = 100_000, allow_hyphen_values = true)]
    pub max_steps: i128,
    /// Output CSV (default: standard output); may not be the controls file.
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

/// Run the command, streaming: each row of the controls is read, the interval it opens is
/// integrated and its steps written, then the row is dropped. Rows computed before an
/// error are written before it is returned; the first error that happens (a bad row or an
/// interval that fails to integrate) is the one reported.
pub fn run(args: &SimulateArgs) -> Result<(), Box<dyn Error>> {
    let wheelbase = parse_params(args.model, &args.params)?;
    super::whole::<usize>("--max-steps", args.max_steps, 1..=usize::MAX as i128)?;
    if let Some(dt) = args.dt
        && !(dt.is_finite() && dt > 0.0)
    {
        return Err(format!("--dt must be finite and positive, got {}", num(dt)).into());
    }
    let inputs: &[&str] = match args.model {
        ModelName::Unicycle => &["t", "v", "omega"],
        ModelName::Bicycle => &["t", "v", "steer"],
        ModelName::Carlike => &["t", "v", "steer_rate"],
    };
    let mut rdr = Rows::open(&args.controls, inputs)?;
    check_not_input(args.out.as_deref(), &args.controls)?;
    let mut out = RowWriter::open(args.out.as_deref())?;
    let result = match args.model {
        ModelName::Unicycle => model_run(
            args,
            unicycle::model(),
            unicycle::flow,
            &mut rdr,
            &mut out,
            "t,x,y,theta",
        ),
        ModelName::Bicycle => model_run(
            args,
            bicycle::model(wheelbase),
            bicycle::flow(wheelbase),
            &mut rdr,
            &mut out,
            "t,x,y,theta",
        ),
        ModelName::Carlike => model_run(
            args,
            carlike::model(wheelbase),
            carlike::flow(wheelbase),
            &mut rdr,
            &mut out,
            "t,x,y,theta,steer",
        ),
    };
    // everything computed is written; the first error (a row, a step or a write) is reported
    let written = out.flush();
    result?;
    Ok(written?)
}

type ControlRows = Rows;

fn model_run<const N: usize>(
    args: &SimulateArgs,
    sys: impl System<Const<N>>,
    flow: impl Flow<Const<N>>,
    rdr: &mut ControlRows,
    out: &mut RowWriter,
    header: &str,
) -> Result<(), Box<dyn Error>>
where
    Const<N>: reckon::linalg::LuDim,
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
    let file = rdr.file().to_string();
    let too_short = || format!("{file}: at least two rows are needed (the last row's t is the end time)");
    let first = match rdr.next_row()? {
        Some(row) => row.to_vec(),
        None => return Err(too_short().into()),
    };
    let next = match rdr.next_row()? {
        Some(row) => row.to_vec(),
        None => return Err(too_short().into()),
    };
    let problem = Problem::new(&sys, x0, (first[0], f64::INFINITY)).inputs(first[1..].to_vec());
    let base = Options::default()
        .rtol(args.rtol)
        .atol(args.atol)
        .dense(false)
        .max_steps(usize::try_from(args.max_steps).unwrap_or(usize::MAX));
    // without --dt the fixed-step methods take one step per control interval
    let fixed = base.clone().fixed(args.dt.unwrap_or(f64::MAX));
    base.validate()?;
    if let Some(dt) = args.dt {
        base.clone().fixed(dt).validate()?;
    }
    out.line(header)?;
    let adaptive = base.clone().h_max(args.dt.unwrap_or(f64::INFINITY));
    match args.method {
        MethodName::Euler => stream(&problem, Euler, &fixed, rdr, next, out),
        MethodName::ImplicitEuler => stream(&problem, ImplicitEuler::default(), &fixed, rdr, next, out),
        MethodName::Rk45 => stream(&problem, Rk45, &adaptive, rdr, next, out),
        MethodName::Bdf => stream(&problem, Bdf::default(), &adaptive, rdr, next, out),
        MethodName::Rodas5p => stream(&problem, Rodas5P, &adaptive, rdr, next, out),
        MethodName::Auto => stream(&problem, Auto::default(), &adaptive, rdr, next, out),
        MethodName::Exact => {
            let opts = match args.dt {
                Some(dt) => base.fixed(dt),
                None => base,
            };
            stream(&problem, Exact::new(flow), &opts, rdr, next, out)
        }
    }
}

/// Write the start, then for each control row: integrate up to its time, writing every
/// step, and switch to its inputs once the row after it has been read.
fn stream<const N: usize, S: System<Const<N>>, M: Method<Const<N>>>(
    problem: &Problem<'_, Const<N>, S>,
    method: M,
    opts: &Options,
    rdr: &mut ControlRows,
    mut next: Vec<f64>,
    out: &mut RowWriter,
) -> Result<(), Box<dyn Error>> {
    let mut it = problem.integrator(method, opts)?;
    out.row(it.t(), it.x().as_slice())?;
    let mut after = next.clone();
    loop {
        let t_next = next[0];
        while !it.reached(t_next) {
            match it.step_until(t_next) {
                Ok(Some(t)) => out.row(t, it.x().as_slice())?,
                Ok(None) => break,
                Err(e) => {
                    return Err(rdr.error(format!("integrating up to t = {}: {e}", num(t_next))).into());
                }
            }
        }
        match rdr.next_row()? {
            None => return Ok(()),
            Some(row) => after.copy_from_slice(row),
        }
        // the row just reached starts the next interval
        it.set_inputs(&next[1..])
            .map_err(|e| rdr.error(format!("the inputs of the previous row: {e}")))?;
        std::mem::swap(&mut next, &mut after);
    }
}

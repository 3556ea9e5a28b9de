//! Studies of the methods themselves: observed order of convergence, stability regions
//! and stiffness, work–precision. Each returns plain tables; the `reckon` command turns
//! them into CSV, SVG and HTML.

pub mod convergence;
pub mod problems;
pub mod stability;
pub mod stiffness;
pub mod work_precision;

use crate::error::{Error, Result};
use crate::linalg::LuDim;
use crate::methods::{Auto, Bdf, Euler, Exact, ExponentialEuler, ImplicitEuler, Method, Rk45, Rodas5P};
use crate::model::Flow;
use crate::{Options, Problem, Solution, Stats, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Least-squares slope of `log e` against `log h`: the observed order `p` in `e ≈ C·hᵖ`
/// (PETSc `PetscConvEstGetConvRate`). Returns `None` for fewer than two points or any
/// non-positive value.
///
/// ```
/// let hs = [0.1, 0.05, 0.025, 0.0125];
/// let es: Vec<f64> = hs.iter().map(|h: &f64| 3.0 * h.powi(2)).collect();
/// let p = reckon::studies::fit_order(&hs, &es).unwrap();
/// assert!((p - 2.0).abs() < 1e-12);
/// ```
pub fn fit_order(h: &[f64], e: &[f64]) -> Option<f64> {
    if h.len() != e.len() || h.len() < 2 || h.iter().chain(e).any(|v| !(*v > 0.0 && v.is_finite())) {
        return None;
    }
    let n = h.len() as f64;
    let xs: Vec<f64> = h.iter().map(|v| v.ln()).collect();
    let ys: Vec<f64> = e.iter().map(|v| v.ln()).collect();
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// A method chosen by name at run time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodKind {
    /// Explicit Euler.
    Euler,
    /// Implicit Euler.
    ImplicitEuler,
    /// Dormand–Prince 5(4).
    Rk45,
    /// The problem's exact flow.
    Exact,
    /// Variable-order BDF/NDF (adaptive runs only).
    Bdf,
    /// Rosenbrock method Rodas5P.
    Rodas5P,
    /// Rk45 ⇄ BDF by stiffness detection (adaptive runs only).
    Auto,
    /// Exponential Rosenbrock–Euler.
    ExponentialEuler,
}

impl MethodKind {
    /// All methods, in table order.
    pub const ALL: [MethodKind; 8] = [
        MethodKind::Euler,
        MethodKind::ImplicitEuler,
        MethodKind::Rk45,
        MethodKind::Exact,
        MethodKind::Bdf,
        MethodKind::Rodas5P,
        MethodKind::Auto,
        MethodKind::ExponentialEuler,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            MethodKind::Euler => "euler",
            MethodKind::ImplicitEuler => "implicit-euler",
            MethodKind::Rk45 => "rk45",
            MethodKind::Exact => "exact",
            MethodKind::Bdf => "bdf",
            MethodKind::Rodas5P => "rodas5p",
            MethodKind::Auto => "auto",
            MethodKind::ExponentialEuler => "exponential-euler",
        }
    }

    /// Whether the method has a fixed order at a fixed step (variable-order BDF and the
    /// switching Auto do not: they belong in adaptive studies).
    pub fn fixed_step_order(self) -> bool {
        !matches!(self, MethodKind::Bdf | MethodKind::Auto)
    }

    /// The classical order (`None` for the exact flow).
    pub fn order(self) -> Option<f64> {
        match self {
            MethodKind::Euler | MethodKind::ImplicitEuler => Some(1.0),
            MethodKind::ExponentialEuler => Some(2.0),
            MethodKind::Rk45 | MethodKind::Rodas5P => Some(5.0),
            MethodKind::Exact | MethodKind::Bdf | MethodKind::Auto => None,
        }
    }
}

impl std::str::FromStr for MethodKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        MethodKind::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = MethodKind::ALL.iter().map(|m| m.name()).collect();
                Error::invalid("method", format!("'{s}' is not one of {}", names.join(", ")))
            })
    }
}

/// A closed-form flow behind a reference, for run-time dispatch.
pub struct DynFlow<'a, D: Dim>(pub &'a dyn Flow<D>)
where
    DefaultAllocator: Allocator<D>;

impl<D: Dim> Flow<D> for DynFlow<'_, D>
where
    DefaultAllocator: Allocator<D>,
{
    fn flow(&self, t: f64, x: &OVector<f64, D>, u: &[f64], h: f64, out: &mut OVector<f64, D>) {
        self.0.flow(t, x, u, h, out)
    }
}

/// Solve `problem` with the method named by `kind`; `flow` is required for `Exact`.
pub fn solve_with<D: LuDim, S: System<D>>(
    problem: &Problem<'_, D, S>,
    kind: MethodKind,
    opts: &Options,
    flow: Option<&dyn Flow<D>>,
) -> Result<Solution<D>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    match kind {
        MethodKind::Euler => problem.solve(Euler, opts),
        MethodKind::ImplicitEuler => problem.solve(ImplicitEuler::default(), opts),
        MethodKind::Rk45 => problem.solve(Rk45, opts),
        MethodKind::Bdf => problem.solve(Bdf::default(), opts),
        MethodKind::Rodas5P => problem.solve(Rodas5P, opts),
        MethodKind::Auto => problem.solve(Auto::default(), opts),
        MethodKind::ExponentialEuler => problem.solve(ExponentialEuler, opts),
        MethodKind::Exact => match flow {
            Some(f) => problem.solve(Exact::new(DynFlow(f)), opts),
            None => Err(Error::invalid("method", "this problem has no exact flow")),
        },
    }
}

fn drive_method<D: Dim, S: System<D>, M: Method<D>>(
    problem: &Problem<'_, D, S>,
    method: M,
    opts: &Options,
    visit: &mut dyn FnMut(f64, &OVector<f64, D>),
) -> Result<(OVector<f64, D>, Stats)>
where
    DefaultAllocator: Allocator<D>,
{
    let mut it = problem.integrator(method, opts)?;
    visit(it.t(), it.x());
    while let Some(t) = it.step()? {
        visit(t, it.x());
    }
    Ok((it.x().clone(), it.stats()))
}

/// Integrate `problem` with the method named by `kind` one step at a time, calling
/// `visit(t, x)` at the start and after every accepted step, and return the final state
/// and the work counters. Nothing is stored: memory stays constant however many steps the run takes
/// (the studies use it instead of [`solve_with`] for long fixed-step runs).
///
/// ```
/// use reckon::studies::{drive, MethodKind};
/// use reckon::{model, Options, Problem};
/// use nalgebra::vector;
/// let f = model!(|_t, x: [S; 1]| vector![x[0]]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// let mut visits = 0;
/// let (x, stats) = drive(&p, MethodKind::Euler, &Options::default().fixed(0.25), None, &mut |_t, _x| visits += 1).unwrap();
/// assert_eq!((stats.accepted, visits), (4, 5));
/// assert_eq!(x[0], 1.25f64.powi(4));
/// ```
pub fn drive<D: LuDim, S: System<D>>(
    problem: &Problem<'_, D, S>,
    kind: MethodKind,
    opts: &Options,
    flow: Option<&dyn Flow<D>>,
    visit: &mut dyn FnMut(f64, &OVector<f64, D>),
) -> Result<(OVector<f64, D>, Stats)>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    match kind {
        MethodKind::Euler => drive_method(problem, Euler, opts, visit),
        MethodKind::ImplicitEuler => drive_method(problem, ImplicitEuler::default(), opts, visit),
        MethodKind::Rk45 => drive_method(problem, Rk45, opts, visit),
        MethodKind::Bdf => drive_method(problem, Bdf::default(), opts, visit),
        MethodKind::Rodas5P => drive_method(problem, Rodas5P, opts, visit),
        MethodKind::Auto => drive_method(problem, Auto::default(), opts, visit),
        MethodKind::ExponentialEuler => drive_method(problem, ExponentialEuler, opts, visit),
        MethodKind::Exact => match flow {
            Some(f) => drive_method(problem, Exact::new(DynFlow(f)), opts, visit),
            None => Err(Error::invalid("method", "this problem has no exact flow")),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::U1;

    fn name<M: Method<U1>>(m: M) -> &'static str {
        m.name()
    }

    /// One name per method: the type's `name()` (tables, errors, switches) is the
    /// command's name, and every name parses back.
    #[test]
    fn one_name_per_method() {
        let identity = |_t: f64, x: &OVector<f64, U1>, _u: &[f64], _h: f64| *x;
        for k in MethodKind::ALL {
            let got = match k {
                MethodKind::Euler => name(Euler),
                MethodKind::ImplicitEuler => name(ImplicitEuler::default()),
                MethodKind::Rk45 => name(Rk45),
                MethodKind::Exact => name(Exact::new(identity)),
                MethodKind::Bdf => name(Bdf::default()),
                MethodKind::Rodas5P => name(Rodas5P),
                MethodKind::Auto => name(Auto::default()),
                MethodKind::ExponentialEuler => name(ExponentialEuler),
            };
            assert_eq!(got, k.name());
            assert_eq!(k.name().parse::<MethodKind>().unwrap(), k);
        }
        let e = "dopri5".parse::<MethodKind>().unwrap_err().to_string();
        assert!(e.contains("exponential-euler") && e.contains("rodas5p"), "{e}");
    }
}

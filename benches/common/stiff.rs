//! Shared by `benches/stiff.rs` and `examples/stiff_wp.rs` (included with `#[path]`): the
//! four Test Set problems of issue 9, the digits measure, and one runner per contender
//! (reckon's ImplicitEuler, Bdf, Rodas5P and diffsol 0.18's BDF on dense nalgebra).
//!
//! **Digits** are the Test Set's mixed significant digits `mescd = −log10 max_i |y_i −
//! ref_i| / (atol_i/rtol_i + |ref_i|)` at `t_end`, with the Test Set's tolerance pairing:
//! ROBER `atol = 1e-4·rtol`, the others `atol = rtol`. Every contender is run with that
//! pairing, so the solver's own error control and the measure agree.
#![allow(dead_code)]

use diffsol::{
    NalgebraContext, NalgebraLU, NalgebraMat, NalgebraVec, OdeBuilder, OdeEquations, OdeEquationsImplicit,
    OdeSolverMethod, OdeSolverProblem, OdeSolverStopReason, Vector as _,
};
use nalgebra::{Const, SVector};
use reckon::linalg::LuDim;
use reckon::methods::{Bdf, ImplicitEuler, Rodas5P};
use reckon::studies::problems::*;
use reckon::{Options, Problem, System};
use std::cell::Cell;
use std::rc::Rc;

/// One of the four problems.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Case {
    /// Robertson, `t ∈ [0, 1e5]`.
    Rober,
    /// Van der Pol μ = 1000 from `(2, 0)`, `t ∈ [0, 2000]`.
    Vdpol,
    /// OREGO from `(1, 2, 3)`, `t ∈ [0, 30]`.
    Orego,
    /// HIRES, `t ∈ [0, 321.8122]`.
    Hires,
}

pub const CASES: [Case; 4] = [Case::Rober, Case::Vdpol, Case::Orego, Case::Hires];

/// The contenders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Who {
    ImplicitEuler,
    Bdf,
    Rodas5P,
    Diffsol,
}

pub const WHO: [Who; 4] = [Who::ImplicitEuler, Who::Bdf, Who::Rodas5P, Who::Diffsol];

impl Who {
    pub fn name(self) -> &'static str {
        match self {
            Who::ImplicitEuler => "reckon-ie",
            Who::Bdf => "reckon-bdf",
            Who::Rodas5P => "reckon-rodas5p",
            Who::Diffsol => "diffsol-bdf",
        }
    }
}

impl Case {
    pub fn name(self) -> &'static str {
        match self {
            Case::Rober => "rober",
            Case::Vdpol => "vdpol",
            Case::Orego => "orego",
            Case::Hires => "hires",
        }
    }
    pub fn t_end(self) -> f64 {
        match self {
            Case::Rober => 1e5,
            Case::Vdpol => 2000.0,
            Case::Orego => 30.0,
            Case::Hires => HIRES_T,
        }
    }
    pub fn y0(self) -> Vec<f64> {
        match self {
            Case::Rober => vec![1.0, 0.0, 0.0],
            Case::Vdpol => vec![2.0, 0.0],
            Case::Orego => vec![1.0, 2.0, 3.0],
            Case::Hires => hires_y0().as_slice().to_vec(),
        }
    }
    pub fn reference(self) -> &'static [f64] {
        match self {
            Case::Rober => &ROBERTSON_REF_1E5,
            Case::Vdpol => &VDPOLM_REF_2000,
            Case::Orego => &OREGO_REF_30,
            Case::Hires => &HIRES_REF,
        }
    }
    /// `atol/rtol` of the Test Set convention.
    pub fn atol_ratio(self) -> f64 {
        if self == Case::Rober { 1e-4 } else { 1.0 }
    }
    /// Mixed significant digits of `y` at `t_end` (see the module doc).
    pub fn digits(self, y: &[f64]) -> f64 {
        let r = self.reference();
        let c = self.atol_ratio();
        let m = y
            .iter()
            .zip(r)
            .map(|(y, r)| {
                let e = (y - r).abs() / (c + r.abs());
                if e.is_nan() { f64::INFINITY } else { e }
            })
            .fold(0.0, f64::max);
        -m.log10()
    }
}

/// End state and work counters of one solve.
#[derive(Clone, Debug, Default)]
pub struct Run {
    pub y: Vec<f64>,
    pub rhs: u64,
    /// Jacobian evaluations (diffsol: Jacobian–vector products ÷ n, it builds dense `J`
    /// column by column).
    pub jac: u64,
    /// LU factorisations (diffsol: its linear-solver setups, each one `J` + LU).
    pub lu: u64,
    pub steps: u64,
    pub rejected: u64,
    pub newton: u64,
}

impl std::fmt::Display for Run {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "steps {:>7} rej {:>5} rhs {:>8} jac {:>6} lu {:>6} newton {:>8}",
            self.steps, self.rejected, self.rhs, self.jac, self.lu, self.newton
        )
    }
}

fn reckon_run<const N: usize, S: System<Const<N>>>(
    f: S,
    y0: &[f64],
    t_end: f64,
    who: Who,
    o: &Options,
) -> Result<Run, String>
where
    Const<N>: LuDim,
{
    let p = Problem::new(f, SVector::<f64, N>::from_column_slice(y0), (0.0, t_end));
    let sol = match who {
        Who::ImplicitEuler => p.solve(ImplicitEuler::default(), o),
        Who::Bdf => p.solve(Bdf::default(), o),
        Who::Rodas5P => p.solve(Rodas5P, o),
        Who::Diffsol => unreachable!("not a reckon method"),
    }
    .map_err(|e| e.to_string())?;
    let s = sol.stats;
    Ok(Run {
        y: sol.last().1.as_slice().to_vec(),
        rhs: s.rhs_evals,
        jac: s.jacobian_evals,
        lu: s.lu_decompositions,
        steps: s.accepted,
        rejected: s.rejected,
        newton: s.newton_iterations,
    })
}

/// Options of one reckon solve: the Test Set tolerance pairing, the lean (non-dense) path.
pub fn reckon_options(case: Case, rtol: f64, max_steps: usize) -> Options {
    Options::default()
        .rtol(rtol)
        .atol(case.atol_ratio() * rtol)
        .dense(false)
        .max_steps(max_steps)
}

/// Solve `case` with one of reckon's methods.
pub fn reckon(case: Case, who: Who, o: &Options) -> Result<Run, String> {
    let y0 = case.y0();
    let t = case.t_end();
    match case {
        Case::Rober => reckon_run(robertson(), &y0, t, who, o),
        Case::Vdpol => reckon_run(van_der_pol(1000.0), &y0, t, who, o),
        Case::Orego => reckon_run(orego(), &y0, t, who, o),
        Case::Hires => reckon_run(hires(), &y0, t, who, o),
    }
}

// ---------------------------------------------------------------------------------------
// diffsol: the same right-hand sides, written on slices, with hand-written Jacobian–vector
// products (diffsol assembles the dense Jacobian from them).

fn rober_f(x: &[f64], y: &mut [f64]) {
    y[0] = -0.04 * x[0] + 1e4 * x[1] * x[2];
    y[1] = 0.04 * x[0] - 1e4 * x[1] * x[2] - 3e7 * x[1] * x[1];
    y[2] = 3e7 * x[1] * x[1];
}
fn rober_jv(x: &[f64], v: &[f64], y: &mut [f64]) {
    y[0] = -0.04 * v[0] + 1e4 * (v[1] * x[2] + x[1] * v[2]);
    y[1] = 0.04 * v[0] - 1e4 * (v[1] * x[2] + x[1] * v[2]) - 6e7 * x[1] * v[1];
    y[2] = 6e7 * x[1] * v[1];
}
const MU: f64 = 1000.0;
fn vdp_f(x: &[f64], y: &mut [f64]) {
    y[0] = x[1];
    y[1] = MU * (1.0 - x[0] * x[0]) * x[1] - x[0];
}
fn vdp_jv(x: &[f64], v: &[f64], y: &mut [f64]) {
    y[0] = v[1];
    y[1] = (-2.0 * MU * x[0] * x[1] - 1.0) * v[0] + MU * (1.0 - x[0] * x[0]) * v[1];
}
const OS: f64 = 77.27;
const OQ: f64 = 8.375e-6;
const OW: f64 = 0.161;
fn orego_f(x: &[f64], y: &mut [f64]) {
    y[0] = OS * (x[1] + x[0] * (1.0 - OQ * x[0] - x[1]));
    y[1] = (x[2] - (1.0 + x[0]) * x[1]) / OS;
    y[2] = OW * (x[0] - x[2]);
}
fn orego_jv(x: &[f64], v: &[f64], y: &mut [f64]) {
    y[0] = OS * ((1.0 - 2.0 * OQ * x[0] - x[1]) * v[0] + (1.0 - x[0]) * v[1]);
    y[1] = (-x[1] * v[0] - (1.0 + x[0]) * v[1] + v[2]) / OS;
    y[2] = OW * (v[0] - v[2]);
}
fn hires_f(x: &[f64], y: &mut [f64]) {
    y[0] = -1.71 * x[0] + 0.43 * x[1] + 8.32 * x[2] + 0.0007;
    y[1] = 1.71 * x[0] - 8.75 * x[1];
    y[2] = -10.03 * x[2] + 0.43 * x[3] + 0.035 * x[4];
    y[3] = 8.32 * x[1] + 1.71 * x[2] - 1.12 * x[3];
    y[4] = -1.745 * x[4] + 0.43 * (x[5] + x[6]);
    y[5] = -280.0 * x[5] * x[7] + 0.69 * x[3] + 1.71 * x[4] - 0.43 * x[5] + 0.69 * x[6];
    y[6] = 280.0 * x[5] * x[7] - 1.81 * x[6];
    y[7] = -y[6];
}
fn hires_jv(x: &[f64], v: &[f64], y: &mut [f64]) {
    y[0] = -1.71 * v[0] + 0.43 * v[1] + 8.32 * v[2];
    y[1] = 1.71 * v[0] - 8.75 * v[1];
    y[2] = -10.03 * v[2] + 0.43 * v[3] + 0.035 * v[4];
    y[3] = 8.32 * v[1] + 1.71 * v[2] - 1.12 * v[3];
    y[4] = -1.745 * v[4] + 0.43 * (v[5] + v[6]);
    let r = 280.0 * (v[5] * x[7] + x[5] * v[7]);
    y[5] = -r + 0.69 * v[3] + 1.71 * v[4] - 0.43 * v[5] + 0.69 * v[6];
    y[6] = r - 1.81 * v[6];
    y[7] = -y[6];
}

/// A diffsol problem with counters on its closures.
pub struct DiffsolModel<E: OdeEquations> {
    pub problem: OdeSolverProblem<E>,
    pub case: Case,
    rhs_calls: Rc<Cell<u64>>,
    jv_calls: Rc<Cell<u64>>,
}

fn build<F, G>(
    case: Case,
    rtol: f64,
    f: F,
    jv: G,
) -> DiffsolModel<impl OdeEquationsImplicit<M = NalgebraMat<f64>, V = NalgebraVec<f64>, T = f64, C = NalgebraContext>>
where
    F: Fn(&[f64], &mut [f64]) + 'static,
    G: Fn(&[f64], &[f64], &mut [f64]) + 'static,
{
    let y0 = case.y0();
    let n = y0.len();
    let rhs_calls = Rc::new(Cell::new(0u64));
    let jv_calls = Rc::new(Cell::new(0u64));
    let (rc, jc) = (rhs_calls.clone(), jv_calls.clone());
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .rtol(rtol)
        .atol(vec![case.atol_ratio() * rtol; n])
        .rhs_implicit(
            move |x: &[f64], _p: &[f64], _t: f64, y: &mut [f64]| {
                rc.set(rc.get() + 1);
                f(x, y)
            },
            move |x: &[f64], _p: &[f64], _t: f64, v: &[f64], y: &mut [f64]| {
                jc.set(jc.get() + 1);
                jv(x, v, y)
            },
        )
        .init(move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0), n)
        .build()
        .expect("diffsol problem");
    DiffsolModel {
        problem,
        case,
        rhs_calls,
        jv_calls,
    }
}

/// The four diffsol models (each its own closure types, so each call is static).
pub fn diffsol_rober(
    rtol: f64,
) -> DiffsolModel<impl OdeEquationsImplicit<M = NalgebraMat<f64>, V = NalgebraVec<f64>, T = f64, C = NalgebraContext>> {
    build(Case::Rober, rtol, rober_f, rober_jv)
}
pub fn diffsol_vdpol(
    rtol: f64,
) -> DiffsolModel<impl OdeEquationsImplicit<M = NalgebraMat<f64>, V = NalgebraVec<f64>, T = f64, C = NalgebraContext>> {
    build(Case::Vdpol, rtol, vdp_f, vdp_jv)
}
pub fn diffsol_orego(
    rtol: f64,
) -> DiffsolModel<impl OdeEquationsImplicit<M = NalgebraMat<f64>, V = NalgebraVec<f64>, T = f64, C = NalgebraContext>> {
    build(Case::Orego, rtol, orego_f, orego_jv)
}
pub fn diffsol_hires(
    rtol: f64,
) -> DiffsolModel<impl OdeEquationsImplicit<M = NalgebraMat<f64>, V = NalgebraVec<f64>, T = f64, C = NalgebraContext>> {
    build(Case::Hires, rtol, hires_f, hires_jv)
}

impl<E> DiffsolModel<E>
where
    E: OdeEquationsImplicit<M = NalgebraMat<f64>, V = NalgebraVec<f64>, T = f64, C = NalgebraContext>,
{
    /// One BDF solve from `t = 0` to `t_end`, stepping with a stop time (no output
    /// storage); `max_steps` caps the work.
    pub fn solve(&self, max_steps: usize) -> Result<Run, String> {
        let (r0, j0) = (self.rhs_calls.get(), self.jv_calls.get());
        let mut s = self.problem.bdf::<NalgebraLU<f64>>().map_err(|e| e.to_string())?;
        s.set_stop_time(self.case.t_end()).map_err(|e| e.to_string())?;
        let mut k = 0usize;
        loop {
            match s.step().map_err(|e| e.to_string())? {
                OdeSolverStopReason::TstopReached => break,
                _ => {
                    k += 1;
                    if k > max_steps {
                        return Err(format!("more than {max_steps} steps"));
                    }
                }
            }
        }
        let st = s.get_statistics();
        let n = self.case.y0().len() as u64;
        Ok(Run {
            y: s.state().y.clone_as_vec(),
            rhs: self.rhs_calls.get() - r0,
            jac: (self.jv_calls.get() - j0) / n,
            lu: st.number_of_linear_solver_setups as u64,
            steps: st.number_of_steps as u64,
            rejected: (st.number_of_error_test_failures + st.number_of_nonlinear_solver_fails) as u64,
            newton: st.number_of_nonlinear_solver_iterations as u64,
        })
    }
}

/// Solve `case` with diffsol at `rtol` (builds the problem: not for timing loops).
pub fn diffsol(case: Case, rtol: f64, max_steps: usize) -> Result<Run, String> {
    match case {
        Case::Rober => diffsol_rober(rtol).solve(max_steps),
        Case::Vdpol => diffsol_vdpol(rtol).solve(max_steps),
        Case::Orego => diffsol_orego(rtol).solve(max_steps),
        Case::Hires => diffsol_hires(rtol).solve(max_steps),
    }
}

/// Any contender at `rtol`.
pub fn run(case: Case, who: Who, rtol: f64, max_steps: usize) -> Result<Run, String> {
    match who {
        Who::Diffsol => diffsol(case, rtol, max_steps),
        _ => reckon(case, who, &reckon_options(case, rtol, max_steps)),
    }
}

/// `rtol = 10^(−k/4)`.
pub fn grid(k: u32) -> f64 {
    10f64.powf(-(k as f64) / 4.0)
}

/// Digit targets of the work–precision cells.
pub const LEVELS: [f64; 3] = [3.0, 5.0, 7.0];

/// Grid index `k` (`rtol = 10^(−k/4)`) per (problem, contender) for 3, 5, 7 digits, from
/// `cargo run --release --example stiff_wp` (the loosest grid point that reaches the
/// digits with its next tighter neighbour reaching them too); `None`: not reached within
/// the search's budget.
pub const TOLS: &[(Case, Who, [Option<u32>; 3])] = &[
    (Case::Rober, Who::ImplicitEuler, [Some(24), Some(40), None]),
    (Case::Rober, Who::Bdf, [Some(11), Some(21), Some(32)]),
    (Case::Rober, Who::Rodas5P, [Some(8), Some(16), Some(26)]),
    (Case::Rober, Who::Diffsol, [Some(11), Some(21), Some(32)]),
    (Case::Vdpol, Who::ImplicitEuler, [Some(26), Some(42), None]),
    (Case::Vdpol, Who::Bdf, [Some(17), Some(25), Some(34)]),
    (Case::Vdpol, Who::Rodas5P, [Some(13), Some(19), Some(27)]),
    (Case::Vdpol, Who::Diffsol, [Some(15), Some(24), Some(36)]),
    (Case::Orego, Who::ImplicitEuler, [Some(24), Some(40), None]),
    (Case::Orego, Who::Bdf, [Some(13), Some(21), Some(29)]),
    (Case::Orego, Who::Rodas5P, [Some(11), Some(16), Some(25)]),
    (Case::Orego, Who::Diffsol, [Some(15), Some(24), Some(34)]),
    (Case::Hires, Who::ImplicitEuler, [Some(19), Some(34), Some(50)]),
    (Case::Hires, Who::Bdf, [Some(15), Some(23), Some(30)]),
    (Case::Hires, Who::Rodas5P, [Some(17), Some(20), Some(28)]),
    (Case::Hires, Who::Diffsol, [Some(13), Some(22), Some(32)]),
];

/// The grid index of a cell, if the contender reaches it.
pub fn tol_index(case: Case, who: Who, level: usize) -> Option<u32> {
    TOLS.iter().find(|t| t.0 == case && t.1 == who).and_then(|t| t.2[level])
}

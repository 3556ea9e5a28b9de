//! `reckon demo`: every method on built-in problems with known answers, the stiff
//! methods (`Bdf`, `Rodas5P`, `Auto`, `ExponentialEuler`) on the stiff problems.

use nalgebra::{Const, SVector, vector};
use reckon::methods::{Auto, Bdf, Euler, Exact, ExponentialEuler, ImplicitEuler, Method, Rk45, Rodas5P};
use reckon::studies::problems::*;
use reckon::vehicles::unicycle;
use reckon::{Controls, Options, Problem, System};
use std::io::Write;
use std::time::Instant;

type Res = Result<(), Box<dyn std::error::Error>>;

/// RK45's step limit on the stiff problems: enough to show that its step is pinned by
/// stability (Van der Pol μ = 1000 would take 1 161 264 steps at tol 1e-6), not so many
/// that it dominates the demo's time.
pub const RK45_STIFF_CAP: usize = 100_000;

/// Correct digits at the end, the Test Set's mixed significant digits:
/// `−log10 max_i |y_i − r_i| / (a + |r_i|)` with `a` = atol/rtol (1, Robertson 1e-4).
///
/// ```
/// use nalgebra::vector;
/// use reckon_cli::demo::digits;
/// // 1.7 against 1.7000017: six digits relative to 1 + 1.7
/// let d = digits(&vector![1.7000017], &vector![1.7], 1.0);
/// assert!((d - (-(1.7e-6f64 / 2.7).log10())).abs() < 1e-6);
/// assert_eq!(digits(&vector![2.0], &vector![2.0], 1.0), f64::INFINITY);
/// ```
pub fn digits<const N: usize>(y: &SVector<f64, N>, reference: &SVector<f64, N>, a: f64) -> f64 {
    -(0..N)
        .map(|i| (y[i] - reference[i]).abs() / (a + reference[i].abs()))
        .fold(0.0, f64::max)
        .log10()
}

/// One problem's rows: the problem, its reference end state and the digits' `a`.
struct Table<'a, 'p, const N: usize, S: System<Const<N>>> {
    out: &'a mut dyn Write,
    problem: &'a Problem<'p, Const<N>, S>,
    exact: SVector<f64, N>,
    a: f64,
}

impl<const N: usize, S: System<Const<N>>> Table<'_, '_, N, S> {
    fn row<M: Method<Const<N>>>(&mut self, method: M, setting: &str, opts: &Options) -> Res {
        let out = &mut *self.out;
        let name = method.name();
        let start = Instant::now();
        // step by step, so that a run that stops on an error keeps DOPRI5's stiffness verdict
        let mut it = match self.problem.integrator(method, opts) {
            Ok(it) => it,
            Err(e) => {
                writeln!(out, "  {name:<17} {setting:<14} failed: {e}")?;
                return Ok(());
            }
        };
        let r = loop {
            match it.step() {
                Ok(Some(_)) => {}
                Ok(None) => break Ok(()),
                Err(e) => break Err(e),
            }
        };
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let stiff = it
            .stiffness()
            .map(|st| format!("stiff at t={:.3}", st.t))
            .unwrap_or_default();
        let s = it.stats();
        let (err, dig, note) = match r {
            Ok(()) => {
                let err = (it.x() - self.exact).amax();
                let d = digits(it.x(), &self.exact, self.a);
                (format!("{err:.2e}"), format!("{d:.1}"), stiff)
            }
            // a run stopped by its step limit: its work so far, and where it stopped
            Err(reckon::Error::MaxSteps { t, steps }) => (
                "-".into(),
                "-".into(),
                format!("stopped by the cap of {steps} steps at t={t:.4}; {stiff}"),
            ),
            Err(e) => {
                writeln!(out, "  {name:<17} {setting:<14} failed: {e}  {stiff}")?;
                return Ok(());
            }
        };
        writeln!(
            out,
            "  {name:<17} {setting:<14} {err:>10} {dig:>6} {:>9} {:>6} {:>10} {:>5} {:>7} {ms:>9.2}  {note}",
            s.accepted, s.rejected, s.rhs_evals, s.jacobian_evals, s.lu_decompositions
        )?;
        Ok(())
    }
}

fn table<'a, 'p, const N: usize, S: System<Const<N>>>(
    out: &'a mut dyn Write,
    title: &str,
    problem: &'a Problem<'p, Const<N>, S>,
    exact: SVector<f64, N>,
    a: f64,
) -> Result<Table<'a, 'p, N, S>, Box<dyn std::error::Error>> {
    writeln!(out, "\n{title}")?;
    writeln!(
        out,
        "  {:<17} {:<14} {:>10} {:>6} {:>9} {:>6} {:>10} {:>5} {:>7} {:>9}",
        "method", "setting", "max error", "digits", "accepted", "rej", "rhs evals", "J", "LU", "time ms"
    )?;
    Ok(Table { out, problem, exact, a })
}

/// The whole demo, written to `out`.
pub fn run(out: &mut dyn Write) -> Res {
    writeln!(
        out,
        "reckon demo: every method on problems with exact or published answers"
    )?;
    writeln!(
        out,
        "(error = max over components at the final time; digits = −log10 max_i |y_i − r_i|/(a + |r_i|), \
         the Test Set's mescd, a = 1 (Robertson 1e-4); tol = t: rtol = atol = t unless said)"
    )?;
    let tight = |tol: f64| Options::default().rtol(tol).atol(tol);
    let fixed = |h: f64| Options::default().fixed(h);

    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 5.0));
    let mut t = table(
        out,
        "rotation–decay x' = [[-0.5, -2], [2, -0.5]] x, x0 = (1, 0.5), t in [0, 5] (exact: matrix exponential)",
        &p,
        rotation_decay_exact(5.0, &x0),
        1.0,
    )?;
    t.row(Euler, "h = 0.01", &fixed(0.01))?;
    t.row(Euler, "h = 0.001", &fixed(0.001))?;
    t.row(ImplicitEuler::default(), "h = 0.01", &fixed(0.01))?;
    t.row(ImplicitEuler::default(), "tol = 1e-3", &tight(1e-3))?;
    t.row(Rk45, "h = 0.1", &fixed(0.1))?;
    t.row(Rk45, "tol = 1e-6", &tight(1e-6))?;
    t.row(Rk45, "tol = 1e-10", &tight(1e-10))?;
    // linear: exponential Euler's one step is the matrix exponential
    t.row(ExponentialEuler, "h = 5", &fixed(5.0))?;

    let p = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    let mut t = table(
        out,
        "u' = sin u, u0 = 0.5, t in [0, 5] (exact: 2 atan(e^t tan(u0/2)))",
        &p,
        sin_u_exact(5.0, 0.5),
        1.0,
    )?;
    t.row(Euler, "h = 0.01", &fixed(0.01))?;
    t.row(ImplicitEuler::default(), "h = 0.01", &fixed(0.01))?;
    t.row(Rk45, "h = 0.1", &fixed(0.1))?;
    t.row(Rk45, "tol = 1e-10", &tight(1e-10))?;

    let p = Problem::new(stiff_cosine(), vector![1.0], (0.0, 2.0));
    let mut t = table(
        out,
        "stiff x' = -1000(x - cos t) - sin t, x0 = 1, t in [0, 2] (exact: cos t)",
        &p,
        vector![2f64.cos()],
        1.0,
    )?;
    t.row(Euler, "h = 0.0019", &fixed(0.0019))?;
    t.row(Euler, "h = 0.0021", &fixed(0.0021))?;
    t.row(ImplicitEuler::default(), "h = 0.1", &fixed(0.1))?;
    t.row(ImplicitEuler::default(), "tol = 1e-3", &tight(1e-3))?;
    t.row(Rk45, "tol = 1e-6", &tight(1e-6))?;
    t.row(Bdf::default(), "tol = 1e-6", &tight(1e-6))?;
    t.row(Rodas5P, "tol = 1e-6", &tight(1e-6))?;
    t.row(Auto::default(), "tol = 1e-6", &tight(1e-6))?;
    t.row(ExponentialEuler, "tol = 1e-6", &tight(1e-6))?;

    let y0 = arenstorf_y0();
    let p = Problem::new(arenstorf(), y0, (0.0, ARENSTORF_T));
    let mut t = table(out, "Arenstorf orbit, one period (exact: returns to y0)", &p, y0, 1.0)?;
    for tol in [1e-6, 1e-8, 1e-10, 1e-12] {
        t.row(Rk45, &format!("tol = {tol:e}"), &tight(tol))?;
    }

    let controls = unicycle_scenario()?;
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 10.0)).controls(controls);
    let exact_sol = p.solve(Exact::new(unicycle::flow), &Options::default())?;
    let ex = *exact_sol.last().1;
    let mut t = table(
        out,
        &format!(
            "unicycle, held (v, ω) over 5 intervals, t in [0, 10]; exact end pose ({:.6}, {:.6}, {:.6})",
            ex[0], ex[1], ex[2]
        ),
        &p,
        ex,
        1.0,
    )?;
    t.row(Exact::new(unicycle::flow), "per interval", &Options::default())?;
    t.row(Euler, "h = 0.1", &fixed(0.1))?;
    t.row(Euler, "h = 0.01", &fixed(0.01))?;
    t.row(ImplicitEuler::default(), "h = 0.01", &fixed(0.01))?;
    t.row(Rk45, "h = 0.1", &fixed(0.1))?;
    t.row(Rk45, "tol = 1e-10", &tight(1e-10))?;
    t.row(ExponentialEuler, "h = 0.1", &fixed(0.1))?;

    // the stiff problems: every stiff method, RK45 with a step cap
    let capped = |o: Options| o.max_steps(RK45_STIFF_CAP);
    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
    let mut t = table(
        out,
        "Van der Pol μ = 1000, y0 = (2, 0), t in [0, 2000] (Test Set VDPOLM reference (1.706167732170469, −8.928097010248125e-4))",
        &p,
        SVector::from(VDPOLM_REF_2000),
        1.0,
    )?;
    t.row(ImplicitEuler::default(), "tol = 1e-2", &tight(1e-2))?;
    t.row(ImplicitEuler::default(), "tol = 1e-3", &tight(1e-3))?;
    for tol in [1e-4, 1e-6, 1e-8] {
        let setting = format!("tol = {tol:e}");
        t.row(Bdf::default(), &setting, &tight(tol))?;
        t.row(Rodas5P, &setting, &tight(tol))?;
        t.row(Auto::default(), &setting, &tight(tol))?;
    }
    t.row(ExponentialEuler, "tol = 1e-4", &tight(1e-4))?;
    t.row(Rk45, "tol = 1e-6", &capped(tight(1e-6)))?;

    let p = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e11));
    let mut t = table(
        out,
        "Robertson, y0 = (1, 0, 0), t in [0, 1e11] (Test Set ROBER reference; atol = 1e-4·rtol)",
        &p,
        SVector::from(ROBERTSON_REF_1E11),
        1e-4,
    )?;
    let rober = |tol: f64| Options::default().rtol(tol).atol(1e-4 * tol);
    t.row(ImplicitEuler::default(), "rtol = 1e-2", &rober(1e-2))?;
    for tol in [1e-4, 1e-6, 1e-8] {
        let setting = format!("rtol = {tol:e}");
        t.row(Bdf::default(), &setting, &rober(tol))?;
        t.row(Rodas5P, &setting, &rober(tol))?;
        t.row(Auto::default(), &setting, &rober(tol))?;
    }
    t.row(ExponentialEuler, "rtol = 1e-4", &rober(1e-4))?;
    t.row(Rk45, "rtol = 1e-4", &capped(rober(1e-4)))?;

    let p = Problem::new(hires(), hires_y0(), (0.0, HIRES_T));
    let mut t = table(
        out,
        "HIRES, t in [0, 321.8122] (Test Set reference)",
        &p,
        SVector::from(HIRES_REF),
        1.0,
    )?;
    t.row(ImplicitEuler::default(), "tol = 1e-3", &tight(1e-3))?;
    for tol in [1e-4, 1e-6, 1e-8] {
        let setting = format!("tol = {tol:e}");
        t.row(Bdf::default(), &setting, &tight(tol))?;
        t.row(Rodas5P, &setting, &tight(tol))?;
        t.row(Auto::default(), &setting, &tight(tol))?;
    }
    t.row(ExponentialEuler, "tol = 1e-4", &tight(1e-4))?;
    t.row(Rk45, "tol = 1e-6", &capped(tight(1e-6)))?;
    writeln!(
        t.out,
        "\nRK45's step on the stiff problems is pinned by stability (|hλ| ≤ 3.3), not accuracy: on Van der Pol and \
         Robertson it stops at its cap of {RK45_STIFF_CAP} steps (Van der Pol would need 1 161 264 at tol 1e-6), \
         where BDF and Rodas5P take hundreds; on HIRES, mildly stiff, it takes 50 times BDF's steps."
    )?;
    Ok(())
}

/// The unicycle scenario shared by the demo table and the report: straight, left arc,
/// straight (ω = 0 exactly), right arc, slow left arc, over 10 s.
pub fn unicycle_scenario() -> Result<Controls, reckon::Error> {
    Controls::new(
        vec![0.0, 2.0, 4.5, 6.0, 8.0, 10.0],
        vec![
            vec![1.0, 0.0],
            vec![1.5, 0.6],
            vec![2.0, 0.0],
            vec![1.0, -0.9],
            vec![0.5, 0.3],
            vec![0.0, 0.0],
        ],
    )
}

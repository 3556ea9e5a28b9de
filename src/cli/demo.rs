//! `reckon demo`: every method on built-in problems with known answers.

use crate::methods::{Dopri5, Exact, ExplicitEuler, ImplicitEuler, Method};
use crate::models::unicycle;
use crate::problems::*;
use crate::{Controls, Options, Problem, System};
use nalgebra::{Const, SVector, vector};
use std::io::Write;
use std::time::Instant;

type Res = Result<(), Box<dyn std::error::Error>>;

fn row<const N: usize, S: System<Const<N>>, M: Method<Const<N>>>(
    out: &mut dyn Write,
    problem: &Problem<'_, Const<N>, S>,
    method: M,
    setting: &str,
    opts: &Options,
    exact: &SVector<f64, N>,
) -> Res {
    let name = method.name();
    let start = Instant::now();
    // step by step, so that a run that stops on an error keeps DOPRI5's stiffness verdict
    let mut it = match problem.integrator(method, opts) {
        Ok(it) => it,
        Err(e) => {
            writeln!(out, "  {name:<15} {setting:<14} failed: {e}")?;
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
    match r {
        Ok(()) => {
            let err = (it.x() - exact).amax();
            let s = it.stats();
            writeln!(
                out,
                "  {name:<15} {setting:<14} {err:>10.2e} {:>9} {:>6} {:>10} {:>5} {:>7} {ms:>9.2}  {stiff}",
                s.accepted, s.rejected, s.rhs_evals, s.jacobian_evals, s.lu_decompositions
            )?;
        }
        Err(e) => writeln!(out, "  {name:<15} {setting:<14} failed: {e}  {stiff}")?,
    }
    Ok(())
}

fn header(out: &mut dyn Write, title: &str) -> Res {
    writeln!(out, "\n{title}")?;
    writeln!(
        out,
        "  {:<15} {:<14} {:>10} {:>9} {:>6} {:>10} {:>5} {:>7} {:>9}",
        "method", "setting", "max error", "accepted", "rej", "rhs evals", "J", "LU", "time ms"
    )?;
    Ok(())
}

/// The whole demo, written to `out`.
pub fn run(out: &mut dyn Write) -> Res {
    writeln!(
        out,
        "reckon demo: every method on problems with exact or published answers"
    )?;
    writeln!(out, "(error = max over components at the final time)")?;
    let tight = |tol: f64| Options::default().rtol(tol).atol(tol);
    let fixed = |h: f64| Options::default().fixed(h);

    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 5.0));
    let ex = rotation_decay_exact(5.0, &x0);
    header(
        out,
        "rotation–decay x' = [[-0.5, -2], [2, -0.5]] x, x0 = (1, 0.5), t in [0, 5] (exact: matrix exponential)",
    )?;
    row(out, &p, ExplicitEuler, "h = 0.01", &fixed(0.01), &ex)?;
    row(out, &p, ExplicitEuler, "h = 0.001", &fixed(0.001), &ex)?;
    row(out, &p, ImplicitEuler::default(), "h = 0.01", &fixed(0.01), &ex)?;
    row(out, &p, ImplicitEuler::default(), "tol = 1e-6", &tight(1e-6), &ex)?;
    row(out, &p, Dopri5::default(), "h = 0.1", &fixed(0.1), &ex)?;
    row(out, &p, Dopri5::default(), "tol = 1e-6", &tight(1e-6), &ex)?;
    row(out, &p, Dopri5::default(), "tol = 1e-10", &tight(1e-10), &ex)?;

    let p = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    let ex = sin_u_exact(5.0, 0.5);
    header(out, "u' = sin u, u0 = 0.5, t in [0, 5] (exact: 2 atan(e^t tan(u0/2)))")?;
    row(out, &p, ExplicitEuler, "h = 0.01", &fixed(0.01), &ex)?;
    row(out, &p, ImplicitEuler::default(), "h = 0.01", &fixed(0.01), &ex)?;
    row(out, &p, Dopri5::default(), "h = 0.1", &fixed(0.1), &ex)?;
    row(out, &p, Dopri5::default(), "tol = 1e-10", &tight(1e-10), &ex)?;

    let p = Problem::new(stiff_cosine(), vector![1.0], (0.0, 2.0));
    let ex = vector![2f64.cos()];
    header(
        out,
        "stiff x' = -1000(x - cos t) - sin t, x0 = 1, t in [0, 2] (exact: cos t)",
    )?;
    row(out, &p, ExplicitEuler, "h = 0.0019", &fixed(0.0019), &ex)?;
    row(out, &p, ExplicitEuler, "h = 0.0021", &fixed(0.0021), &ex)?;
    row(out, &p, ImplicitEuler::default(), "h = 0.1", &fixed(0.1), &ex)?;
    row(out, &p, ImplicitEuler::default(), "tol = 1e-6", &tight(1e-6), &ex)?;
    row(out, &p, Dopri5::default(), "tol = 1e-6", &tight(1e-6), &ex)?;

    let y0 = arenstorf_y0();
    let p = Problem::new(arenstorf(), y0, (0.0, ARENSTORF_T));
    header(out, "Arenstorf orbit, one period (exact: returns to y0)")?;
    for tol in [1e-6, 1e-8, 1e-10, 1e-12] {
        row(out, &p, Dopri5::default(), &format!("tol = {tol:e}"), &tight(tol), &y0)?;
    }

    let controls = unicycle_scenario()?;
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 10.0)).controls(controls);
    let exact_sol = p.solve(Exact::new(unicycle::flow), &Options::default())?;
    let ex = *exact_sol.last().1;
    header(
        out,
        &format!(
            "unicycle, held (v, ω) over 5 intervals, t in [0, 10]; exact end pose ({:.6}, {:.6}, {:.6})",
            ex[0], ex[1], ex[2]
        ),
    )?;
    row(
        out,
        &p,
        Exact::new(unicycle::flow),
        "per interval",
        &Options::default(),
        &ex,
    )?;
    row(out, &p, ExplicitEuler, "h = 0.1", &fixed(0.1), &ex)?;
    row(out, &p, ExplicitEuler, "h = 0.01", &fixed(0.01), &ex)?;
    row(out, &p, ImplicitEuler::default(), "h = 0.01", &fixed(0.01), &ex)?;
    row(out, &p, Dopri5::default(), "h = 0.1", &fixed(0.1), &ex)?;
    row(out, &p, Dopri5::default(), "tol = 1e-10", &tight(1e-10), &ex)?;

    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
    let ex = vector![1.706167732170469, -0.8928097010248125e-3];
    header(
        out,
        "Van der Pol μ = 1000, y0 = (2, 0), t in [0, 2000] (Test Set VDPOLM reference)",
    )?;
    row(
        out,
        &p,
        ImplicitEuler::default(),
        "tol = 1e-4",
        &tight(1e-4).atol(1e-7),
        &ex,
    )?;
    row(
        out,
        &p,
        ImplicitEuler::default(),
        "tol = 1e-6",
        &tight(1e-6).atol(1e-9),
        &ex,
    )?;
    row(
        out,
        &p,
        Dopri5::default(),
        "tol = 1e-6",
        &tight(1e-6).atol(1e-9).max_steps(10_000_000),
        &ex,
    )?;
    writeln!(
        out,
        "\nRK45's step on Van der Pol is pinned by stability (|hλ| ≤ 3.3), not accuracy: see its step count and the stiffness note."
    )?;
    Ok(())
}

/// The unicycle scenario shared by the demo table and the report: straight, left arc,
/// straight (ω = 0 exactly), right arc, slow left arc, over 10 s.
pub fn unicycle_scenario() -> Result<Controls, crate::Error> {
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

//! The convergence study: observed orders on log–log axes.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    r.section("Convergence study", "Observed order by least squares on log–log over fixed step sizes, against the exact solution: the unicycle arc with held inputs (nonlinear), and a damped spring driven by a held force (linear, x' = Ax + Bu), whose exact solution is the zero-order-hold flow. Exponential Euler integrates the model linearised at each step exactly, so it is second order on the unicycle and exact to rounding on the linear model at every step size.");
    let p = lookup("unicycle")?;
    let mut plot = Plot::new(
        "Error against step size (unicycle and linear spring, held inputs)",
        "step size h (s)",
        "max-norm error at t_end",
    )
    .log_log();
    let mut rows = Vec::new();
    for m in [
        MethodKind::Euler,
        MethodKind::ImplicitEuler,
        MethodKind::ExponentialEuler,
        MethodKind::Rk45,
    ] {
        let steps = p.default_steps(m);
        let s = p.convergence(&[m], &steps, reckon::studies::convergence::DEFAULT_MAX_STEPS)?;
        let fit = &s.fits[0];
        let order = match fit.order_final {
            Some(o) => format!("{o:.3}"),
            None => "not asymptotic".to_string(),
        };
        plot = plot.with(Series::new(
            format!("{} (slope {order})", m.name()),
            s.rows.iter().map(|r| (r.h, r.final_error)).collect(),
            Style::LinePoints,
        ));
        rows.push(vec![
            m.name().to_string(),
            "unicycle".to_string(),
            order,
            format!("{}", fit.theory.unwrap_or(f64::NAN)),
        ]);
    }
    let lti = lookup("lti")?;
    let steps = lti.default_steps(MethodKind::ExponentialEuler);
    let s = lti.convergence(
        &[MethodKind::ExponentialEuler],
        &steps,
        reckon::studies::convergence::DEFAULT_MAX_STEPS,
    )?;
    let worst = s.rows.iter().map(|r| r.final_error).fold(0.0, f64::max);
    // a zero error has no place on a log axis: those points are left out of the line
    plot = plot.with(Series::new(
        format!("exponential-euler, linear spring (≤ {worst:.1e}: exact)"),
        s.rows
            .iter()
            .filter(|r| r.final_error > 0.0)
            .map(|r| (r.h, r.final_error))
            .collect(),
        Style::LinePoints,
    ));
    rows.push(vec![
        "exponential-euler".to_string(),
        "linear spring".to_string(),
        format!("exact: error ≤ {worst:.1e} at every h"),
        "exact".to_string(),
    ]);
    r.figure(dir, "convergence.svg", &plot, "Fitted slopes next to the theory; on the linear model exponential Euler's error is rounding at every step size.")?;
    r.table(&["method", "problem", "observed order", "theory"], &rows);
    r.end();
    Ok(())
}

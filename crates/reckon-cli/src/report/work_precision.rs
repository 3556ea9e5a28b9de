//! Work–precision on the Arenstorf orbit, then the stiff methods on the Test Set problems.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path, fast: bool) -> Res {
    r.section("Work–precision", "Error at the end of the Arenstorf orbit against rhs evaluations and wall time, RK45 over tolerances 1e-4…1e-10 and implicit Euler over 1e-2…1e-4: its error stays of the orbit's size (1.4–2.3) up to 0.46 million rhs evaluations, since a first-order method cannot follow the close approaches to the primaries, while the fifth-order method reaches small errors at a fraction of that work: for a smooth non-stiff problem it wins by orders of magnitude.");
    let ar = lookup("arenstorf")?;
    let tols: Vec<f64> = if fast {
        vec![1e-4, 1e-6]
    } else {
        vec![1e-4, 1e-6, 1e-8, 1e-10]
    };
    let mut pts = ar.work_precision(&[MethodKind::Rk45], &tols, &[], 1)?;
    // implicit Euler's local error is held to tol·rtol: 1e-4 takes 0.46 M rhs evaluations
    let ie_tols = [1e-2, 1e-3, 1e-4];
    pts.extend(ar.work_precision(
        &[MethodKind::ImplicitEuler],
        &ie_tols[..if fast { 2 } else { 3 }],
        &[],
        1,
    )?);
    for (file, xl, by_time) in [
        ("work_precision_evals.svg", "rhs evaluations", false),
        ("work_precision_time.svg", "wall time (s)", true),
    ] {
        let methods = [MethodKind::Rk45, MethodKind::ImplicitEuler];
        let plot =
            crate::studies::work_precision_plot("Work–precision: Arenstorf orbit", xl, &methods, &pts, by_time, false);
        r.figure(dir, file, &plot, "Each point is one tolerance.")?;
    }
    r.end();
    Ok(())
}

/// Work–precision of the stiff methods on Robertson, Van der Pol μ = 1000 and OREGO.
pub(super) fn stiff_work_precision(r: &mut Report, dir: &Path, fast: bool) -> Res {
    r.section(
        "Stiff work–precision",
        "Correct digits at the end against the published Test Set end states, against rhs evaluations and wall time, for BDF (variable-order NDF 1–5), Rodas5P and Auto over rtol 1e-4…1e-8 and for implicit Euler (atol = rtol; Robertson atol = 1e-4·rtol, the Test Set's convention). Digits are the Test Set's mixed significant digits mescd = −log₁₀ max<sub>i</sub> |y<sub>i</sub> − r<sub>i</sub>| / (atol/rtol + |r<sub>i</sub>|): relative digits in every component larger than atol/rtol, so that Robertson's y₁ ≈ 2·10⁻⁸ and y₂ ≈ 8·10⁻¹⁴ at t = 10¹¹ do not make every run look accurate to 10⁻⁸…10⁻¹⁴, as an absolute error would. Implicit Euler, first order, runs at rtol 1e-2 and 1e-3 only: its local error is held to tol·rtol so that its digits follow the tolerance, and at 1e-4 it takes 0.5–1.8 million rhs evaluations on these problems, where BDF and Rodas5P take a few thousand.",
    );
    let methods = [
        MethodKind::ImplicitEuler,
        MethodKind::Bdf,
        MethodKind::Rodas5P,
        MethodKind::Auto,
    ];
    let tols: Vec<f64> = if fast {
        vec![1e-4, 1e-6]
    } else {
        vec![1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
    };
    let mut rows = Vec::new();
    for (name, title) in [
        ("robertson", "Robertson, t ∈ [0, 1e11]"),
        ("van-der-pol", "Van der Pol μ = 1000, t ∈ [0, 2000]"),
        ("orego", "OREGO, t ∈ [0, 360]"),
    ] {
        let p = lookup(name)?;
        let mut pts = Vec::new();
        for m in methods {
            // implicit Euler at 1e-4 takes 0.49 M (Robertson), 0.99 M (Van der Pol) and
            // 1.8 M (OREGO) rhs evaluations: 1e-2 and 1e-3 show its slope
            let ie_tols = [1e-2, 1e-3];
            let ts = if m == MethodKind::ImplicitEuler {
                &ie_tols[..]
            } else {
                &tols[..]
            };
            pts.extend(p.work_precision(&[m], ts, &[], if fast { 1 } else { 3 })?);
        }
        for (suffix, xl, by_time) in [("evals", "rhs evaluations", false), ("time", "wall time (s)", true)] {
            let plot = crate::studies::work_precision_plot(
                &format!("Work–precision: {title}"),
                xl,
                &methods,
                &pts,
                by_time,
                true,
            );
            r.figure(
                dir,
                &format!("stiff_wp_{}_{suffix}.svg", slug(name)),
                &plot,
                "Each point is one tolerance; upper left is better.",
            )?;
        }
        for w in pts.iter().filter(|w| w.setting == 1e-6) {
            // the problem's name only: its span is in the figures' titles
            rows.push(vec![
                title.split(',').next().unwrap_or(title).to_string(),
                w.method.name().to_string(),
                format!("{:.2}", w.digits),
                format!("{:.2e}", w.error),
                format!("{}", w.steps),
                format!("{}", w.rhs_evals),
                format!("{:.3}", w.seconds * 1e3),
            ]);
        }
    }
    r.table(
        &[
            "problem (rtol 1e-6)",
            "method",
            "digits",
            "max error",
            "steps",
            "rhs evals",
            "ms",
        ],
        &rows,
    );
    r.end();
    Ok(())
}

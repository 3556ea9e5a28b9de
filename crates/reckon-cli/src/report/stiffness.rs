//! The stiffness study on Van der Pol μ = 1000 and the stability regions.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path, fast: bool) -> Res {
    r.section("Stiffness and step size", "Van der Pol with μ = 1000: RK45's step is pinned by its stability boundary (|hλ| ≤ 3.3 on the real axis) on the slow branches, where accuracy alone would allow large steps; the stiff methods (implicit Euler, BDF, Rodas5P) are stable at any step and theirs follows the solution; Auto runs RK45 until DOPRI5's stiffness test fires, BDF on the slow branches, and RK45 again in the fast jumps. The stability regions and the explicit-Euler threshold 2/|λ|, located by actual runs, complete the picture.");
    let vdp = lookup("van-der-pol")?;
    let hist = vdp.histories(1e-4, 1e-7, if fast { 20_000 } else { 400_000 });
    r.figure(
        dir,
        "step_sizes.svg",
        &history_plot("Step sizes on Van der Pol μ = 1000", &hist),
        "RK45 (stopped at its step limit) against implicit Euler, BDF, Rodas5P and Auto, all at rtol 1e-4, atol 1e-7.",
    )?;
    let dahl = stability_files(dir)?;
    // redrawn over a window that contains every boundary whole (DP5's region reaches
    // |Im z| = 3.85), replacing the SVG of stability_files
    r.figure(
        dir,
        "stability_regions.svg",
        &stability_plot(),
        "Boundaries |R(hλ)| = 1: explicit Euler (disk around −1), DP5 (stable inside the main region and its two small islands near the imaginary axis), implicit Euler (stable outside the disk around +1).",
    )?;
    r.table(
        &["λ", "located threshold h", "2/|λ|", "relative difference"],
        &dahl
            .iter()
            .map(|(l, h, t)| {
                vec![
                    format!("{l}"),
                    format!("{h:.8}"),
                    format!("{t:.8}"),
                    format!("{:.1e}", h / t - 1.0),
                ]
            })
            .collect::<Vec<_>>(),
    );
    r.end();
    Ok(())
}

/// The stability-region boundaries on a window that contains each of them whole.
fn stability_plot() -> Plot {
    use reckon::studies::stability::{StabilityOf, boundary};
    let mut plot = Plot::new("Linear stability regions |R(hλ)| ≤ 1", "Re(hλ)", "Im(hλ)").equal();
    for (m, label) in [
        (StabilityOf::Euler, "explicit Euler |1 + z| = 1"),
        (StabilityOf::ImplicitEuler, "implicit Euler |1/(1 − z)| = 1"),
        (StabilityOf::Rk45, "DP5 (RK45) |R(z)| = 1"),
    ] {
        let segs = boundary(m, (-4.5, 2.5), (-4.4, 4.4), 281);
        plot = plot.with(Series::new(
            label,
            segs.iter().flat_map(|s| [s[0], s[1]]).collect(),
            Style::Segments,
        ));
    }
    plot
}

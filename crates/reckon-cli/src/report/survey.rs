//! Underwater landmark SLAM on the synthetic survey, with 90 % confidence ellipses.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    let sc = slam::synthetic(42);
    let out = slam::run(&sc)?;
    r.section("Underwater landmark SLAM (synthetic survey)", "Dead reckoning from Euler angles and body velocities, depth every sample, side-scan sonar ranges at detection times; one Kalman filter over robot position and six landmark positions. Ellipses are the 90% confidence regions (a = √(−2 ln 0.1) = 2.146).");
    let mut plot = Plot::new("SLAM: trajectory, landmarks and 90% ellipses", "x (m)", "y (m)")
        .equal()
        .with(Series::new(
            "true path",
            sc.truth.iter().step_by(10).map(|p| (p[0], p[1])).collect(),
            Style::Line,
        ))
        .with(Series::new(
            "estimated path",
            out.positions.iter().step_by(10).map(|p| (p[0], p[1])).collect(),
            Style::Line,
        ))
        .with(Series::new(
            "true landmarks",
            sc.landmarks.iter().map(|m| (m[0], m[1])).collect(),
            Style::Points,
        ));
    // the 90% ellipses are a metre or two across on a survey of a few hundred metres:
    // drawn ENLARGED here (the factor is in the legend and the caption), and at true
    // scale, centred on each estimate's error, in the next figure
    const ENLARGE: f64 = 10.0;
    let chi2 = -2.0 * (1.0f64 - 0.9).ln();
    let mut ellipses = Vec::new();
    let mut zoom = Plot::new(
        "SLAM: 90% ellipses at true scale, centred on each landmark's estimate error",
        "estimate − truth, x (m)",
        "estimate − truth, y (m)",
    )
    .equal();
    let mut rows = Vec::new();
    let mut inside = 0;
    for (j, ((m, p), truth)) in out.landmarks.iter().zip(&sc.landmarks).enumerate() {
        let (a, b, ang) = confidence_ellipse(p, 0.9);
        let big = ellipse((m[0], m[1]), ENLARGE * a, ENLARGE * b, ang);
        ellipses.extend(big.windows(2).flat_map(|w| [w[0], w[1]]));
        let e = m - truth;
        zoom = zoom.with(
            Series::new(format!("landmark {j}"), ellipse((e[0], e[1]), a, b, ang), Style::Line)
                .with_markers(vec![(e[0], e[1])]),
        );
        let d2 = reckon::kalman::mahalanobis2(truth, m, p);
        if d2 <= chi2 {
            inside += 1;
        }
        rows.push(vec![
            j.to_string(),
            format!("({:.2}, {:.2})", truth[0], truth[1]),
            format!("({:.2}, {:.2})", m[0], m[1]),
            format!("{:.3}", (m - truth).norm()),
            format!("{:.3} × {:.3}", a, b),
            format!("{:.2} ({})", d2, if d2 <= chi2 { "inside" } else { "outside" }),
        ]);
    }
    zoom = zoom.with(Series::new("truth (the origin)", vec![(0.0, 0.0)], Style::Points));
    plot = plot
        .with(Series::new(
            "estimated landmarks",
            out.landmarks.iter().map(|(m, _)| (m[0], m[1])).collect(),
            Style::Points,
        ))
        .with(Series::new(
            format!("90% ellipses, drawn {ENLARGE}× enlarged"),
            ellipses,
            Style::Segments,
        ));
    let n = out.landmarks.len();
    r.figure(
        dir,
        "slam.svg",
        &plot,
        &format!("The estimate stays close to the truth. The 90% confidence ellipses of the landmark estimates are drawn {ENLARGE}× enlarged about each estimate so that they can be seen at this scale (true semi-axes in the table); {inside} of the {n} true landmarks lie inside their (true-size) 90% ellipse."),
    )?;
    r.figure(
        dir,
        "slam_ellipses.svg",
        &zoom,
        &format!("The same 90% ellipses at true scale, each centred on its landmark's estimation error (estimate − truth, the dot), so that the truth is the origin: the origin lies inside {inside} of the {n} ellipses (squared Mahalanobis distance ≤ −2 ln 0.1 = {chi2:.3}, last column of the table)."),
    )?;
    r.table(
        &[
            "landmark",
            "truth (m)",
            "estimate (m)",
            "error (m)",
            "90% semi-axes (m)",
            "truth's d² (≤ 4.605 inside)",
        ],
        &rows,
    );
    let dr_err = {
        let mut d = sc.truth[0];
        for s in 0..sc.t.len() - 1 {
            let e = sc.euler[s];
            d += reckon::vehicles::body3d::rotation(e[0], e[1], e[2]) * sc.body_velocity[s] * sc.dt;
        }
        (d - sc.truth[sc.truth.len() - 1]).xy().norm()
    };
    let slam_err = (out.positions[out.positions.len() - 1] - sc.truth[sc.truth.len() - 1])
        .xy()
        .norm();
    let _ = write!(
        r.html,
        "<p>Final horizontal error: SLAM {slam_err:.3} m, dead reckoning alone {dr_err:.3} m.</p>"
    );
    r.end();
    Ok(())
}

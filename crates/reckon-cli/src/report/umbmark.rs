//! UMBmark: the bidirectional square, the calibration from it and the corrected robot.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    let robot = square_robot()?;
    let e = EncoderErrors {
        left_scale: 1.002,
        wheelbase_scale: 1.01,
        ..Default::default()
    };
    r.section("UMBmark: the bidirectional square", "A 4 m square driven clockwise and counter-clockwise with a 0.2% wheel-diameter mismatch and a 1% wheelbase error. Odometry believes it returned to the start; the true path (solid) ends elsewhere, and the two directions separate the two systematic errors (Borenstein &amp; Feng).");
    let mut plot = Plot::new("UMBmark: true paths and odometry", "x (m)", "y (m)").equal();
    let mut rows = Vec::new();
    // one colour per direction; the truth a wide pale line, odometry a thin dashed one
    // on top, so that neither hides the other where they run together
    for (k, (cw, name, short)) in [(false, "counter-clockwise", "ccw"), (true, "clockwise", "cw")]
        .into_iter()
        .enumerate()
    {
        let run = simulate(&robot, &e, &square(4.0, cw, 0.4, 0.5), 0.01, Vector3::zeros());
        let est = odometry(&robot, &run.samples, Update::Exact)?;
        let end = run.truth[run.truth.len() - 1];
        plot = plot
            .with(
                Series::new(
                    format!("{short}: truth"),
                    run.truth
                        .iter()
                        .step_by(20)
                        .map(|p| (p[0], p[1]))
                        .chain([(end[0], end[1])])
                        .collect(),
                    Style::Line,
                )
                .group(k)
                .width(5)
                .opacity(0.45),
            )
            .with(
                Series::new(
                    format!("{short}: odometry"),
                    est.iter().step_by(20).map(|p| (p.1[0], p.1[1])).collect(),
                    Style::Line,
                )
                .group(k)
                .dashed(7, 4),
            )
            .with(Series::new(format!("{short}: true end"), vec![(end[0], end[1])], Style::Points).group(k));
        rows.push(vec![
            name.to_string(),
            format!("({:.3}, {:.3})", end[0], end[1]),
            format!("{:.3}", end.xy().norm()),
        ]);
    }
    // drawn last, as a ring: the clockwise run's true end sits just inside it
    plot = plot.with(
        Series::new("start", vec![(0.0, 0.0)], Style::Points)
            .group(6)
            .marker(8, true),
    );
    r.figure(
        dir,
        "umbmark.svg",
        &plot,
        &format!("True paths (wide, pale) and odometry (dashed) for both directions, counter-clockwise (ccw) and clockwise (cw). The ring is the start, where odometry believes both runs end; the dots are each run's true return point: {} m from the start counter-clockwise, {} m clockwise (inside the ring at this scale).", rows[0][2], rows[1][2]),
    )?;
    r.table(&["direction", "true end (m)", "return error (m)"], &rows);
    // calibration from these two runs, then the corrected robot driven again
    let before = reckon::reckoning::drift::umbmark(&robot, &e, 4.0, 0.4, 0.5, 0.01)?;
    let xy = |v: Vector3<f64>| nalgebra::Vector2::new(v[0], v[1]);
    let fit = reckon::calibration::umbmark::calibrate(&[xy(before.cw)], &[xy(before.ccw)], 4.0, 0.5)?;
    let after = reckon::reckoning::drift::umbmark(&robot, &fit.residual_errors(&e), 4.0, 0.4, 0.5, 0.01)?;
    let _ = write!(
        r.html,
        "<p>Calibrated from these two runs (<code>calibration::umbmark</code>): E<sub>d</sub> = {:.5}, E<sub>b</sub> = {:.5} \
         (injected: the left wheel 0.2 % large, so D<sub>R</sub>/D<sub>L</sub> = 1/1.002 = 0.99800, and the wheelbase 1 % long, 1.01000; the formulas are first order). The robot driven \
         again with the corrected diameters and wheelbase:</p>",
        fit.e_d(),
        fit.e_b()
    );
    let row = |name: &str, u: &reckon::reckoning::drift::Umbmark| {
        vec![
            name.to_string(),
            format!("{:.4}", u.e_max_syst()),
            format!("{:.4}", xy(u.cw).norm()),
            format!("{:.4}", xy(u.ccw).norm()),
        ]
    };
    r.table(
        &["", "E<sub>max,syst</sub> (m)", "cw return (m)", "ccw return (m)"],
        &[row("before", &before), row("after", &after)],
    );
    let _ = write!(
        r.html,
        "<p>The correction cuts E<sub>max,syst</sub> {:.0}× (Borenstein &amp; Feng report at least 10×).</p>",
        before.e_max_syst() / after.e_max_syst()
    );
    r.end();
    Ok(())
}

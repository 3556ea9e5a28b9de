//! Odometry drift against distance: heading and scale errors, straight runs.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    r.section("Odometry drift against distance", "Straight runs of 1, 2, 5 and 10 m: a 1° heading error gives 1.745% lateral drift (0.1745 m after 10 m); a 0.1% wheel-diameter mismatch curves the path, so its lateral error grows with the square of the distance; slip and pulse noise (seeded) add a random part.");
    let robot = square_robot()?;
    let ds = [1.0, 2.0, 5.0, 10.0];
    let heading = reckon::reckoning::drift::heading_error_drift(1f64.to_radians(), &ds);
    let sys_err = EncoderErrors {
        left_scale: 1.001,
        ..Default::default()
    };
    let diam = reckon::reckoning::drift::straight_drift(&robot, &sys_err, &ds, 0.5, 0.01)?;
    let rnd_err = EncoderErrors {
        slip_sigma: 0.005,
        pulse_noise: 0.5,
        quantize: true,
        seed: 11,
        ..Default::default()
    };
    let rnd = reckon::reckoning::drift::straight_drift(&robot, &rnd_err, &ds, 0.5, 0.01)?;
    let plot = Plot::new(
        "Lateral drift as a percentage of distance",
        "distance driven (m)",
        "|lateral error| / distance (%)",
    )
    .legend_at(crate::plot::Legend::Middle)
    .with(Series::new(
        "1° heading error",
        heading
            .iter()
            .map(|r| (r.distance, r.lateral_percent().abs()))
            .collect(),
        Style::LinePoints,
    ))
    .with(Series::new(
        "left wheel 0.1% larger",
        diam.iter().map(|r| (r.distance, r.lateral_percent().abs())).collect(),
        Style::LinePoints,
    ))
    .with(Series::new(
        "slip 0.5% + pulse noise (seed 11)",
        rnd.iter().map(|r| (r.distance, r.lateral_percent().abs())).collect(),
        Style::LinePoints,
    ));
    r.figure(
        dir,
        "drift_distance.svg",
        &plot,
        "Constant percentage for a heading error, linear growth of the percentage for a diameter mismatch.",
    )?;
    r.table(
        &[
            "distance (m)",
            "heading 1°: lateral (m)",
            "diameter: lateral (m)",
            "random: lateral (m)",
            "random: longitudinal (m)",
        ],
        &(0..4)
            .map(|k| {
                vec![
                    format!("{}", ds[k]),
                    format!("{:.4}", heading[k].lateral.abs()),
                    format!("{:.4}", diam[k].lateral.abs()),
                    format!("{:.4}", rnd[k].lateral.abs()),
                    format!("{:.4}", rnd[k].longitudinal.abs()),
                ]
            })
            .collect::<Vec<_>>(),
    );
    r.end();
    Ok(())
}

//! IMU drift: an uncorrected accelerometer bias and gyro bias at rest.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    let rows = imu_bias_drift(0.01, 1e-3, &(1..=12).map(|k| k as f64 * 5.0).collect::<Vec<_>>(), 0.01)?;
    r.section("IMU drift", "A level IMU at rest with an uncorrected accelerometer bias b_a = 0.01 m/s² (error ½·b_a·t²) or gyro bias b_g = 1e-3 rad/s (the tilt b_g·t leaks gravity: g·b_g·t³/6), dead-reckoned by strapdown with exact rotations.");
    let plot = Plot::new(
        "IMU position error against time",
        "t (s)",
        "horizontal position error (m)",
    )
    .log_log()
    .with(Series::new(
        "accelerometer bias: simulated",
        rows.iter().map(|r| (r.t, r.accel_simulated)).collect(),
        Style::Points,
    ))
    .with(Series::new(
        "½·b_a·t²",
        rows.iter().map(|r| (r.t, r.accel_closed_form)).collect(),
        Style::Line,
    ))
    .with(Series::new(
        "gyro bias: simulated",
        rows.iter().map(|r| (r.t, r.gyro_simulated)).collect(),
        Style::Points,
    ))
    .with(Series::new(
        "g·b_g·t³/6",
        rows.iter().map(|r| (r.t, r.gyro_closed_form)).collect(),
        Style::Line,
    ));
    r.figure(
        dir,
        "imu_drift.svg",
        &plot,
        "Slopes 2 and 3 on log–log axes: simulation and closed forms agree.",
    )?;
    r.end();
    Ok(())
}

//! Writes the synthetic interval data set of `docs/calibration.md` (default
//! `docs/data/censi-intervals.csv`): 400 intervals of a small robot with a known geometry,
//! scan-matching noise and 2.5 % failed matches, from `calibration::censi::synthetic(2013,
//! 400)`, the same numbers on every machine. The truth is printed.
//!
//! ```sh
//! cargo run --example censi_dataset [-- PATH]
//! reckon calibrate --intervals docs/data/censi-intervals.csv
//! ```
//!
//! The data set is made by this program and is as free to redistribute as the rest of
//! reckon.

use reckon::calibration::censi::synthetic;

fn main() -> std::io::Result<()> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/data/censi-intervals.csv".into());
    let set = synthetic(2013, 400);
    std::fs::write(&path, set.to_csv())?;
    let t = set.truth;
    println!(
        "wrote {path}: {} intervals, {} failed scan matches (rows {:?})",
        set.intervals.len(),
        set.outliers.len(),
        set.outliers.iter().map(|k| k + 2).collect::<Vec<_>>()
    );
    println!(
        "truth: left wheel diameter {} m, right wheel diameter {} m, wheel separation {} m, sensor ({}, {}) m, {} rad",
        2.0 * t.r_l,
        2.0 * t.r_r,
        t.b,
        t.sensor[0],
        t.sensor[1],
        t.sensor[2]
    );
    println!(
        "scan matcher noise: sigma_xy = {} m, sigma_theta = {} rad",
        set.sigma_xy, set.sigma_theta
    );
    Ok(())
}

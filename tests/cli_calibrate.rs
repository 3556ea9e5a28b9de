//! `reckon calibrate` on a simulated encoder log with known geometry errors.

#[path = "common/drives.rs"]
mod drives;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

fn logs(tag: &str) -> (PathBuf, PathBuf) {
    let d = std::env::temp_dir().join(format!("reckon-calibrate-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let run = drives::square_log();
    let (mut enc, mut pos) = (String::from("t,left,right\n"), String::from("t,x,y,theta\n"));
    for (k, (s, p)) in run.samples.iter().zip(&run.truth).enumerate() {
        writeln!(enc, "{:?},{:?},{:?}", s.0, s.1, s.2).unwrap();
        if k % 10 == 0 {
            writeln!(pos, "{:?},{:?},{:?},{:?}", s.0, p[0], p[1], p[2]).unwrap();
        }
    }
    let (a, b) = (d.join("enc.csv"), d.join("poses.csv"));
    std::fs::write(&a, enc).unwrap();
    std::fs::write(&b, pos).unwrap();
    (a, b)
}

fn calibrate(method: &str, enc: &Path, poses: &Path, out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args([
            "calibrate",
            "--method",
            method,
            "--wheel-diameter",
            "0.1",
            "--wheel-separation",
            "0.5",
        ])
        .args([
            "--pulses-per-rev",
            "2048",
            "--encoders",
            enc.to_str().unwrap(),
            "--poses",
        ])
        .args([poses.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap()
}

/// The printed value of `name` (`name = value ± sd …`).
fn value(text: &str, name: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.starts_with(name))
        .unwrap_or_else(|| panic!("{name} in {text}"));
    line.split(['=', '±']).nth(1).unwrap().trim().parse().unwrap()
}

#[test]
fn lsq_and_censi_recover_the_geometry_and_write_corrected_odometry() {
    let (enc, poses) = logs("ok");
    for (method, b_name) in [("lsq", "wheel separation"), ("censi", "b")] {
        let out = enc.with_file_name(format!("corrected-{method}.csv"));
        let o = calibrate(method, &enc, &poses, &out);
        assert!(o.status.success(), "{method}: {}", String::from_utf8_lossy(&o.stderr));
        let text = String::from_utf8(o.stdout).unwrap();
        let b = value(&text, &format!("{b_name} "));
        assert!((b - 0.51).abs() < 1e-6, "{method}: b = {b}\n{text}");
        // the corrected odometry passes through the measured poses
        let parse = |l: &str| -> Vec<f64> { l.split(',').map(|v| v.parse().unwrap()).collect() };
        let csv = std::fs::read_to_string(&out).unwrap();
        let odo: Vec<Vec<f64>> = csv.lines().skip(1).map(parse).collect();
        let truth: Vec<Vec<f64>> = std::fs::read_to_string(&poses)
            .unwrap()
            .lines()
            .skip(1)
            .map(parse)
            .collect();
        let last = truth.last().unwrap();
        let row = odo
            .iter()
            .find(|r| r[0] == last[0])
            .expect("a row at the last pose's time");
        let miss = (row[1] - last[1]).hypot(row[2] - last[2]);
        assert!(miss < 1e-4, "{method}: corrected odometry ends {miss} m from the truth");
    }
}

#[test]
fn malformed_poses_name_the_line() {
    let (enc, poses) = logs("bad");
    let mut text = std::fs::read_to_string(&poses).unwrap();
    text.push_str("99.0,1.0,oops,0.0\n");
    std::fs::write(&poses, text).unwrap();
    let out = enc.with_file_name("never.csv");
    let o = calibrate("lsq", &enc, &poses, &out);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("line") && err.lines().count() == 1, "{err}");
}

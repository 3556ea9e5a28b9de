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

/// UMBmark from a log: a clockwise and a counter-clockwise 4 m square with a 0.2 %
/// diameter and a 1 % wheelbase error, one encoder log, the start and end pose of each
/// run; the command's E_d, E_b equal the library's on the same return errors.
#[test]
fn umbmark_from_a_log_matches_the_library() {
    use nalgebra::{Vector2, Vector3};
    use reckon::reckoning::drift::square;
    use reckon::reckoning::encoders::{DiffDrive, Update, odometry};
    use reckon::reckoning::errors::{EncoderErrors, simulate};
    let robot = DiffDrive::new(0.1, 0.5, 2048.0).unwrap();
    let e = EncoderErrors {
        left_scale: 1.002,
        wheelbase_scale: 1.01,
        ..Default::default()
    };
    let d = std::env::temp_dir().join(format!("reckon-calibrate-{}-umbmark", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let (mut enc, mut pos) = (String::from("t,left,right\n"), String::from("t,x,y,theta\n"));
    let (mut cw, mut ccw) = (Vec::new(), Vec::new());
    let mut t0 = 0.0;
    for clockwise in [true, false] {
        let run = simulate(&robot, &e, &square(4.0, clockwise, 0.4, 0.5), 0.01, Vector3::zeros());
        let odo = odometry(&robot, &run.samples, Update::Exact).unwrap();
        let err = run.truth.last().unwrap() - odo.last().unwrap().1;
        if clockwise {
            cw.push(Vector2::new(err[0], err[1]))
        } else {
            ccw.push(Vector2::new(err[0], err[1]))
        }
        for s in &run.samples[1..] {
            writeln!(enc, "{:?},{:?},{:?}", t0 + s.0, s.1, s.2).unwrap();
        }
        let end = run.truth.last().unwrap();
        writeln!(pos, "{t0:?},0,0,0").unwrap();
        writeln!(
            pos,
            "{:?},{:?},{:?},{:?}",
            t0 + run.samples.last().unwrap().0,
            end[0],
            end[1],
            end[2]
        )
        .unwrap();
        t0 += run.samples.last().unwrap().0 + 1.0;
    }
    let (a, b) = (d.join("enc.csv"), d.join("poses.csv"));
    std::fs::write(&a, enc).unwrap();
    std::fs::write(&b, &pos).unwrap();
    let out = d.join("corrected.csv");
    let o = calibrate("umbmark", &a, &b, &out);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    // the library on the same return errors; the side is the odometry's path / 4 (the
    // legs, as the turns are on the spot): 4 m
    let fit = reckon::calibration::umbmark::calibrate(&cw, &ccw, 4.0, 0.5).unwrap();
    let (ed, eb) = (value(&text, "E_d"), value(&text, "E_b"));
    assert!((ed - fit.e_d()).abs() < 1e-9 && (eb - fit.e_b()).abs() < 1e-9, "{text}");
    // and it is the injected error to first order: D_R/D_L = 1/1.002, E_b = 1.01
    assert!((ed - 1.0 / 1.002).abs() < 1e-4 && (eb - 1.01).abs() < 2e-3, "{text}");
    assert!(text.contains("E_max,syst"));
    // a run that is not a square is refused with its number
    let mut bad = pos.lines().take(3).collect::<Vec<_>>().join("\n");
    bad.push_str("\n60.0,0,0,0\n61.0,0,0,0\n");
    std::fs::write(&b, bad).unwrap();
    let o = calibrate("umbmark", &a, &b, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("run 2") && err.contains("square"),
        "{err}"
    );
}

//! `reckon calibrate` on a simulated encoder log with known geometry errors.

#[path = "../../../../tests/it/common/drives.rs"]
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

/// `reckon calibrate --method METHOD` on a log, with the geometry flags the method uses
/// (censi: only the pulses per revolution).
fn calibrate(method: &str, enc: &Path, poses: &Path, out: &Path) -> std::process::Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_reckon"));
    c.args(["calibrate", "--method", method]);
    if method != "censi" {
        c.args(["--wheel-diameter", "0.1", "--wheel-separation", "0.5"]);
    }
    c.args([
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

/// `reckon ARGS…` (strings), its output.
fn reckon(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_reckon")).args(args).output().unwrap()
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
    for method in ["lsq", "censi"] {
        let out = enc.with_file_name(format!("corrected-{method}.csv"));
        let o = calibrate(method, &enc, &poses, &out);
        assert!(o.status.success(), "{method}: {}", String::from_utf8_lossy(&o.stderr));
        let text = String::from_utf8(o.stdout).unwrap();
        let b = value(&text, "wheel separation ");
        // diameters by default: the log's wheels are 0.1 m · 1.004 and · 0.997
        let (dl, dr) = (
            value(&text, "left wheel diameter "),
            value(&text, "right wheel diameter "),
        );
        assert!(
            (dl - 0.1004).abs() < 1e-6 && (dr - 0.0997).abs() < 1e-6,
            "{method}: {text}"
        );
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
    use reckon::reckoning::encoder_sim::{EncoderErrors, simulate};
    use reckon::reckoning::encoders::{DiffDrive, Update, odometry};
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

/// The interval data set of `docs/calibration.md`.
const DATASET: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/data/censi-intervals.csv");

/// `(value, σ)` of the printed line `name = value ± σ unit`.
fn value_sd(text: &str, name: &str) -> (f64, f64) {
    let line = text
        .lines()
        .find(|l| l.starts_with(name))
        .unwrap_or_else(|| panic!("{name} in {text}"));
    let mut parts = line.split(['=', '±']).skip(1);
    let v = parts.next().unwrap().trim().parse().unwrap();
    let sd = parts
        .next()
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    (v, sd)
}

/// The committed data set is what `examples/censi_dataset.rs` writes (the library's
/// `censi::synthetic(2013, 400)`), to rounding: the docs cannot drift from the generator.
#[test]
fn the_docs_data_set_is_the_generators_output() {
    let committed = std::fs::read_to_string(DATASET).unwrap();
    let made = reckon::calibration::censi::synthetic(2013, 400).to_csv();
    let (a, b): (Vec<&str>, Vec<&str>) = (committed.lines().collect(), made.lines().collect());
    assert_eq!(a.len(), b.len());
    assert_eq!(a[0], b[0]);
    for (x, y) in a[1..].iter().zip(&b[1..]) {
        for (u, v) in x.split(',').zip(y.split(',')) {
            let (u, v): (f64, f64) = (u.parse().unwrap(), v.parse().unwrap());
            assert!((u - v).abs() <= 1e-12 * v.abs().max(1e-3), "{x} vs {y}");
        }
    }
}

/// Issue 38 item 7: censi on interval data recovers the known truth, every parameter
/// within 3 of its reported standard deviations, with the default trimming (the reference
/// solver's); without trimming the failed scan matches pull the sensor's pose away.
#[test]
fn censi_on_interval_data_recovers_the_truth_within_its_sigma() {
    let set = reckon::calibration::censi::synthetic(2013, 400);
    let t = set.truth;
    let truth = [
        ("left wheel diameter ", 2.0 * t.r_l),
        ("right wheel diameter ", 2.0 * t.r_r),
        ("wheel separation ", t.b),
        ("sensor x ", t.sensor[0]),
        ("sensor y ", t.sensor[1]),
        ("sensor theta ", t.sensor[2]),
    ];
    let o = reckon(&["calibrate", "--intervals", DATASET]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let mut worst: f64 = 0.0;
    for (name, want) in truth {
        let (v, sd) = value_sd(&text, name);
        assert!(sd > 0.0 && sd < 0.01, "{name}: σ = {sd}\n{text}");
        let z = (v - want).abs() / sd;
        assert!(z <= 3.0, "{name}: {v} ± {sd}, truth {want} ({z:.2} σ)\n{text}");
        worst = worst.max(z);
    }
    eprintln!("censi on the docs' data set: largest |error|/σ = {worst:.2}");
    // the failed matches are trimmed: 4 rounds of ceil(1 % of the kept)
    assert!(
        text.contains("kept 384 of 400 intervals (trimmed 1 % per round, 4 rounds)"),
        "{text}"
    );
    // the same with the rows as average wheel speeds (the reference solver's tuples)
    let d = std::env::temp_dir().join(format!("reckon-calibrate-{}-speeds", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let mut speeds = String::from("dt,left_speed,right_speed,dx,dy,dtheta\n");
    for row in std::fs::read_to_string(DATASET).unwrap().lines().skip(1) {
        let v: Vec<f64> = row.split(',').map(|x| x.parse().unwrap()).collect();
        writeln!(
            speeds,
            "{:?},{:?},{:?},{:?},{:?},{:?}",
            v[0],
            v[1] / v[0],
            v[2] / v[0],
            v[3],
            v[4],
            v[5]
        )
        .unwrap();
    }
    let sp = d.join("speeds.csv");
    std::fs::write(&sp, speeds).unwrap();
    let o = reckon(&["calibrate", "--intervals", sp.to_str().unwrap(), "--report", "radii"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let radii = String::from_utf8(o.stdout).unwrap();
    let (r, _) = value_sd(&radii, "left wheel radius ");
    let (dia, _) = value_sd(&text, "left wheel diameter ");
    assert!((2.0 * r - dia).abs() < 1e-12, "{radii}");
    // no trimming: the failed matches inflate every σ about tenfold and move the
    // estimate by many of the trimmed estimate's σ
    let o = reckon(&["calibrate", "--intervals", DATASET, "--trim", "0"]);
    let raw = String::from_utf8(o.stdout).unwrap();
    assert!(raw.contains("kept 400 of 400 intervals (no trimming)"), "{raw}");
    let mut off: f64 = 0.0;
    for (name, want) in truth {
        let ((v, sd_raw), (_, sd)) = (value_sd(&raw, name), value_sd(&text, name));
        assert!(sd_raw > 5.0 * sd, "{name}: σ {sd_raw} untrimmed, {sd} trimmed");
        off = off.max((v - want).abs() / sd);
    }
    assert!(
        off > 10.0,
        "without trimming the largest error is only {off:.2} trimmed σ\n{raw}"
    );
    // --out: one residual row per interval, the trimmed ones marked 0
    let res = d.join("residuals.csv");
    let o = reckon(&["calibrate", "--intervals", DATASET, "--out", res.to_str().unwrap()]);
    assert!(o.status.success());
    let rows: Vec<Vec<f64>> = std::fs::read_to_string(&res)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 400);
    assert_eq!(rows.iter().filter(|r| r[1] == 0.0).count(), 16);
    for &k in &set.outliers {
        assert_eq!((rows[k][0], rows[k][1]), ((k + 2) as f64, 0.0), "failed match {k} kept");
    }
}

/// Interval files are data from outside: each defect is one line naming the file, the
/// line and the column, never a panic and never a silent number.
#[test]
fn hostile_interval_files_are_refused_by_line_and_column() {
    let d = std::env::temp_dir().join(format!("reckon-calibrate-{}-hostile", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let good = "0.8,1.5,2.5,0.05,0.002,0.1\n".repeat(3) + "0.7,-3,3,0.001,0.0,0.9\n0.9,4,3,0.1,-0.01,-0.3\n";
    let cases: [(&str, String, &str); 8] = [
        (
            "header",
            "dt,l,r,dx,dy,dtheta\n0.8,1,2,0,0,0\n".into(),
            "line 1: missing column 'left'",
        ),
        (
            "dt",
            format!("dt,left,right,dx,dy,dtheta\n{good}0,1,1,0,0,0\n"),
            "line 7: column 'dt': an interval lasts a positive time, got 0",
        ),
        (
            "nan",
            format!("dt,left,right,dx,dy,dtheta\n{good}0.5,NaN,1,0,0,0\n"),
            "line 7: column 'left': NaN is not finite",
        ),
        (
            "inf",
            format!("dt,left,right,dx,dy,dtheta\n0.5,1,1,0,0,inf\n{good}"),
            "line 2: column 'dtheta': inf is not finite",
        ),
        (
            "text",
            format!("dt,left,right,dx,dy,dtheta\n{good}0.5,1,1,oops,0,0\n"),
            "line 7: column 'dx': 'oops' is not a number",
        ),
        (
            "fields",
            format!("dt,left,right,dx,dy,dtheta\n{good}0.5,1,1,0,0\n"),
            "line 7: 5 fields, the header has 6",
        ),
        (
            "overflow",
            "dt,left_speed,right_speed,dx,dy,dtheta\n1e300,1e300,1,0,0,0\n".into(),
            "column 'left_speed': the rotation speed × dt = inf overflows",
        ),
        (
            "few",
            "dt,left,right,dx,dy,dtheta\n0.8,1,2,0,0,0\n".into(),
            "need at least 3 intervals",
        ),
    ];
    for (tag, text, want) in cases {
        let p = d.join(format!("{tag}.csv"));
        std::fs::write(&p, text).unwrap();
        let o = reckon(&["calibrate", "--intervals", p.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && o.stdout.is_empty(), "{tag}: {err}");
        assert!(err.contains(want), "{tag}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{tag}: {err}");
        if tag != "few" {
            assert!(err.contains(&format!("{tag}.csv")), "{tag}: {err}");
        }
    }
    // a file that cannot be read says so, and only that
    let o = reckon(&["calibrate", "--intervals", d.join("absent.csv").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("absent.csv: cannot read") && !err.contains("left_speed"),
        "{err}"
    );
    // the same rows as a continuous drive of one wheel ratio: nothing to separate b from
    let p = d.join("straight.csv");
    std::fs::write(
        &p,
        "dt,left,right,dx,dy,dtheta\n".to_string() + &"1,2,2,0.07,0,0\n".repeat(5),
    )
    .unwrap();
    let o = reckon(&["calibrate", "--intervals", p.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("cannot be determined"), "{err}");
}

/// Geometry and tuning flags only where the method uses them; a missing one is named.
#[test]
fn flags_only_where_the_method_uses_them() {
    let (enc, poses) = logs("flags");
    let (e, p) = (enc.to_str().unwrap(), poses.to_str().unwrap());
    let cases: [(Vec<&str>, &str); 9] = [
        (
            vec!["--intervals", DATASET, "--wheel-diameter", "0.07"],
            "--method censi does not use --wheel-diameter",
        ),
        (
            vec!["--intervals", DATASET, "--pulses-per-rev", "2048"],
            "--method censi does not use --pulses-per-rev",
        ),
        (
            vec![
                "--method",
                "censi",
                "--encoders",
                e,
                "--poses",
                p,
                "--wheel-separation",
                "0.5",
                "--pulses-per-rev",
                "2048",
            ],
            "--method censi does not use --wheel-separation",
        ),
        (
            vec!["--method", "censi", "--encoders", e, "--poses", p],
            "--method censi needs --pulses-per-rev",
        ),
        (
            vec!["--encoders", e, "--poses", p, "--pulses-per-rev", "2048"],
            "--method lsq needs --wheel-diameter",
        ),
        (
            vec!["--method", "lsq", "--intervals", DATASET],
            "--intervals is the input of --method censi",
        ),
        (
            vec!["--intervals", DATASET, "--sigma-xy", "0.01"],
            "--sigma-xy is for --method lsq",
        ),
        (
            vec![
                "--method",
                "umbmark",
                "--encoders",
                e,
                "--poses",
                p,
                "--wheel-diameter",
                "0.1",
                "--wheel-separation",
                "0.5",
                "--pulses-per-rev",
                "2048",
                "--trim",
                "0.01",
            ],
            "--trim is for --method censi",
        ),
        (
            vec!["--intervals", DATASET, "--trim", "0.5,2"],
            "--trim: the fraction must be in [0, 0.5), got 0.5",
        ),
    ];
    for (args, want) in cases {
        let o = reckon(&[&["calibrate"][..], &args].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(want), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    }
    // censi on the log needs no nominal geometry at all
    let out = enc.with_file_name("censi-flags.csv");
    let o = reckon(&[
        "calibrate",
        "--method",
        "censi",
        "--encoders",
        e,
        "--poses",
        p,
        "--pulses-per-rev",
        "2048",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Issue 38 item 7: from a start whose weighted residual norm is above 10⁴ (here 1 mm
/// poses, a nominal geometry 2 % off), lsq moves to the truth instead of returning the
/// start with ± values (argmin's line search stalled at step length 0 there).
#[test]
fn lsq_moves_from_a_start_with_large_residuals() {
    let (enc, poses) = logs("tight");
    let out = enc.with_file_name("tight.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args([
            "calibrate",
            "--wheel-diameter",
            "0.1",
            "--wheel-separation",
            "0.5",
            "--pulses-per-rev",
            "2048",
        ])
        .args([
            "--sigma-xy",
            "0.0001",
            "--sigma-theta",
            "0.0001",
            "--encoders",
            enc.to_str().unwrap(),
        ])
        .args(["--poses", poses.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let b = value(&text, "wheel separation ");
    assert!((b - 0.51).abs() < 1e-6, "b = {b}\n{text}");
}

/// Two reports agree: the same lines, words equal and numbers equal to 10⁻⁹ relatively
/// (so that a last-bit difference of a platform's `sin` does not fail the docs).
fn same_report(doc: &str, run: &str) -> Result<(), String> {
    let (a, b): (Vec<&str>, Vec<&str>) = (doc.lines().collect(), run.lines().collect());
    if a.len() != b.len() {
        return Err(format!("{} lines documented, {} printed", a.len(), b.len()));
    }
    for (x, y) in a.iter().zip(&b) {
        let (u, v): (Vec<&str>, Vec<&str>) = (x.split_whitespace().collect(), y.split_whitespace().collect());
        let same = u.len() == v.len()
            && u.iter().zip(&v).all(|(p, q)| {
                let num = |s: &str| s.trim_end_matches([',', ';']).parse::<f64>().ok();
                match (num(p), num(q)) {
                    (Some(p), Some(q)) => (p - q).abs() <= 1e-9 * q.abs(),
                    _ => p == q,
                }
            });
        if !same {
            return Err(format!("documented: {x}\nprinted:    {y}"));
        }
    }
    Ok(())
}

/// `docs/calibration.md` shows the command's output on the shipped data set: the blocks
/// after its `calibrate-output` markers are what the command prints today.
#[test]
fn the_calibration_page_shows_the_commands_output() {
    let page = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../docs/calibration.md")).unwrap();
    let block = |tag: &str| -> String {
        let marker = format!("<!-- calibrate-output: {tag} -->");
        let at = page.find(&marker).unwrap_or_else(|| panic!("{marker}"));
        let rest = &page[at..];
        let start = rest.find("```text\n").unwrap() + "```text\n".len();
        let end = rest[start..].find("```").unwrap();
        rest[start..start + end].to_string()
    };
    for (tag, extra) in [("default", &[][..]), ("untrimmed", &["--trim", "0"][..])] {
        let o = reckon(&[&["calibrate", "--intervals", DATASET][..], extra].concat());
        assert!(o.status.success());
        let run = String::from_utf8(o.stdout).unwrap();
        if let Err(e) = same_report(&block(tag), &run) {
            panic!("docs/calibration.md, block '{tag}', differs from the command:\n{e}");
        }
    }
}

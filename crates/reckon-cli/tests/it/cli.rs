//! The `reckon simulate` and `reckon odometry` contract: round trips and every bad input.

use nalgebra::vector;
use reckon::methods::{Exact, Rk45};
use reckon::reckoning::encoders::{DiffDrive, Update, odometry};
use reckon::vehicles::{bicycle, carlike, unicycle};
use reckon::{Controls, Options, Problem};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("reckon-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn file(name: &str, text: &str) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn reckon(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_reckon")).args(args).output().unwrap()
}

fn rows(out: &[u8]) -> (String, Vec<Vec<f64>>) {
    let text = String::from_utf8(out.to_vec()).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("").to_string();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

const UNICYCLE: &str = "t,v,omega\n0,1,0\n1,1,0.5\n2.5,2,-0.3\n4,0,0\n";

#[test]
fn simulate_exact_round_trips_bit_for_bit() {
    let c = file("u.csv", UNICYCLE);
    let o = reckon(&[
        "simulate",
        "--model",
        "unicycle",
        "--controls",
        p(&c),
        "--method",
        "exact",
        "--x0",
        "1,-2,0.5",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (header, got) = rows(&o.stdout);
    assert_eq!(header, "t,x,y,theta");
    let controls = Controls::new(
        vec![0.0, 1.0, 2.5, 4.0],
        vec![vec![1.0, 0.0], vec![1.0, 0.5], vec![2.0, -0.3], vec![0.0, 0.0]],
    )
    .unwrap();
    let sol = Problem::new(unicycle::model(), vector![1.0, -2.0, 0.5], (0.0, 4.0))
        .controls(controls)
        .solve(Exact::new(unicycle::flow), &Options::default())
        .unwrap();
    assert_eq!(got.len(), sol.t.len());
    for (row, (t, x)) in got.iter().zip(sol.t.iter().zip(&sol.x)) {
        assert_eq!(row[0].to_bits(), t.to_bits());
        for i in 0..3 {
            assert_eq!(
                row[i + 1].to_bits(),
                x[i].to_bits(),
                "value printed so that it round-trips"
            );
        }
    }
}

#[test]
fn simulate_rows_at_start_steps_and_breakpoints() {
    let c = file("u2.csv", UNICYCLE);
    for (method, dt) in [
        ("euler", Some("0.4")),
        ("implicit-euler", Some("0.4")),
        ("rk45", Some("0.3")),
        ("euler", None),
    ] {
        let mut args = vec![
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            p(&c),
            "--method",
            method,
        ];
        if let Some(dt) = dt {
            args.extend(["--dt", dt]);
        }
        let o = reckon(&args);
        assert!(o.status.success(), "{method}: {}", String::from_utf8_lossy(&o.stderr));
        let (_, got) = rows(&o.stdout);
        let ts: Vec<f64> = got.iter().map(|r| r[0]).collect();
        assert_eq!(ts[0], 0.0);
        assert_eq!(*ts.last().unwrap(), 4.0);
        for b in [1.0, 2.5] {
            assert!(ts.contains(&b), "{method}: breakpoint {b} missing from {ts:?}");
        }
        match (method, dt) {
            ("euler", None) => assert_eq!(ts, vec![0.0, 1.0, 2.5, 4.0], "default: one step per interval"),
            ("euler", Some(_)) => assert!(ts.contains(&0.8) && ts.contains(&3.6)),
            ("rk45", _) => assert!(
                ts.windows(2).all(|w| w[1] - w[0] <= 0.3 + 1e-12),
                "--dt is rk45's max step"
            ),
            _ => {}
        }
    }
    // rk45 at its default tolerance agrees with the exact arc
    let o = reckon(&[
        "simulate",
        "--model",
        "unicycle",
        "--controls",
        p(&c),
        "--method",
        "rk45",
        "--rtol",
        "1e-10",
        "--atol",
        "1e-10",
    ]);
    let (_, rk) = rows(&o.stdout);
    let o = reckon(&[
        "simulate",
        "--model",
        "unicycle",
        "--controls",
        p(&c),
        "--method",
        "exact",
    ]);
    let (_, ex) = rows(&o.stdout);
    let (a, b) = (rk.last().unwrap(), ex.last().unwrap());
    for i in 1..4 {
        assert!((a[i] - b[i]).abs() < 1e-8);
    }
}

#[test]
fn simulate_bicycle_and_carlike_with_parameters() {
    let c = file("b.csv", "t,v,steer\n0,2,0.3\n1.5,2,0\n3,0,0\n");
    let o = reckon(&[
        "simulate",
        "--model",
        "bicycle",
        "--controls",
        p(&c),
        "--method",
        "exact",
        "--param",
        "wheelbase=0.8",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, got) = rows(&o.stdout);
    let controls = Controls::new(
        vec![0.0, 1.5, 3.0],
        vec![vec![2.0, 0.3], vec![2.0, 0.0], vec![0.0, 0.0]],
    )
    .unwrap();
    let sol = Problem::new(bicycle::model(0.8), vector![0.0, 0.0, 0.0], (0.0, 3.0))
        .controls(controls)
        .solve(Exact::new(bicycle::flow(0.8)), &Options::default())
        .unwrap();
    assert_eq!(got.last().unwrap()[1].to_bits(), sol.last().1[0].to_bits());
    let c = file("c.csv", "t,v,steer_rate\n0,5,0.2\n2,5,-0.2\n4,0,0\n");
    let o = reckon(&[
        "simulate",
        "--model",
        "carlike",
        "--controls",
        p(&c),
        "--method",
        "rk45",
        "--rtol",
        "1e-10",
        "--atol",
        "1e-10",
    ]);
    let (header, got) = rows(&o.stdout);
    assert_eq!(header, "t,x,y,theta,steer");
    let controls = Controls::new(
        vec![0.0, 2.0, 4.0],
        vec![vec![5.0, 0.2], vec![5.0, -0.2], vec![0.0, 0.0]],
    )
    .unwrap();
    let sol = Problem::new(carlike::model(2.5), vector![0.0, 0.0, 0.0, 0.0], (0.0, 4.0))
        .controls(controls)
        .solve(Rk45, &Options::default().rtol(1e-10).atol(1e-10).dense(false))
        .unwrap();
    let last = got.last().unwrap();
    for i in 0..4 {
        assert_eq!(last[i + 1].to_bits(), sol.last().1[i].to_bits());
    }
    assert!((last[4] - 0.0).abs() < 1e-12, "steer returns to 0: {}", last[4]);
}

#[test]
fn odometry_round_trip() {
    let e = file(
        "e.csv",
        "t,left,right\n0,0,0\n0.1,100,120\n0.2,100,80\n0.3,-50,50\n0.4,200,200\n",
    );
    let robot = DiffDrive::new(0.1, 0.4, 1024.0).unwrap();
    let samples = [
        (0.0, 0.0, 0.0),
        (0.1, 100.0, 120.0),
        (0.2, 100.0, 80.0),
        (0.3, -50.0, 50.0),
        (0.4, 200.0, 200.0),
    ];
    for (name, rule) in [
        ("midpoint", Update::Midpoint),
        ("exact", Update::Exact),
        ("euler", Update::Euler),
    ] {
        let o = reckon(&[
            "odometry",
            "--encoders",
            p(&e),
            "--wheel-diameter",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--pulses-per-rev",
            "1024",
            "--update",
            name,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (header, got) = rows(&o.stdout);
        assert_eq!(header, "t,x,y,theta");
        let lib = odometry(&robot, &samples, rule).unwrap();
        assert_eq!(got[0], vec![0.0, 0.0, 0.0, 0.0], "starts at the pose (0, 0, 0)");
        for (row, (t, pose)) in got.iter().zip(&lib) {
            assert_eq!(row[0], *t);
            for i in 0..3 {
                assert_eq!(row[i + 1].to_bits(), pose[i].to_bits());
            }
        }
    }
}

/// One clear message on stderr, a non-zero exit, and rows before the error written.
fn fails_with(o: &Output, needle: &str) {
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(needle), "stderr {err:?} should mention {needle:?}");
    assert_eq!(err.trim().lines().count(), 1, "one message: {err:?}");
}

/// As `fails_with`, returning the CSV rows written before the error.
fn fails(o: &Output, needle: &str) -> Vec<Vec<f64>> {
    fails_with(o, needle);
    if o.stdout.is_empty() {
        Vec::new()
    } else {
        rows(&o.stdout).1
    }
}

#[test]
fn bad_simulate_inputs() {
    let sim = |controls: &Path, extra: &[&str]| {
        let mut a = vec![
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            p(controls),
            "--method",
            "exact",
        ];
        a.extend_from_slice(extra);
        reckon(&a)
    };
    // malformed row, named by line; rows before it are simulated and written
    let c = file("bad1.csv", "t,v,omega\n0,1,0\n1,1,0.5\n2,abc,1\n3,0,0\n");
    let got = fails(&sim(&c, &[]), "line 4");
    assert_eq!(got.iter().map(|r| r[0]).collect::<Vec<_>>(), vec![0.0, 1.0]);
    // wrong field count
    let c = file("bad2.csv", "t,v,omega\n0,1,0\n1,1\n");
    fails(&sim(&c, &[]), "line 3");
    // time not increasing
    let c = file("bad3.csv", "t,v,omega\n0,1,0\n1,1,0.5\n1,1,0.5\n");
    fails(&sim(&c, &[]), "time does not increase");
    // non-finite value
    let c = file("bad4.csv", "t,v,omega\n0,1,0\n1,inf,0.5\n2,0,0\n");
    fails(&sim(&c, &[]), "not finite");
    // missing column
    let c = file("bad5.csv", "t,v\n0,1\n1,1\n");
    fails(&sim(&c, &[]), "missing column 'omega'");
    // one row only
    let c = file("bad6.csv", "t,v,omega\n0,1,0\n");
    fails(&sim(&c, &[]), "at least two rows");
    // bad options
    let c = file("ok.csv", UNICYCLE);
    fails(&sim(&c, &["--x0", "1,2"]), "--x0 has 2 values");
    fails(&sim(&c, &["--param", "wheelbase=1"]), "no parameter 'wheelbase'");
    // --dt refines the exact flow's grid: more rows, the same arcs to rounding
    let fine = sim(&c, &["--dt", "0.1"]);
    assert!(fine.status.success(), "{}", String::from_utf8_lossy(&fine.stderr));
    let (_, fine) = rows(&fine.stdout);
    let (_, coarse) = rows(&sim(&c, &[]).stdout);
    assert_eq!(coarse.len(), 4);
    assert_eq!(
        fine.len(),
        41,
        "0, 0.1, …, 4 with the breakpoints 1 and 2.5 on the grid"
    );
    for row in &coarse {
        let f = fine.iter().find(|r| r[0] == row[0]).unwrap();
        for i in 1..4 {
            assert!((f[i] - row[i]).abs() < 1e-13, "{f:?} vs {row:?}");
        }
    }
    fails(
        &reckon(&[
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            p(&c),
            "--method",
            "euler",
            "--dt",
            "-1",
        ]),
        "--dt",
    );
    fails(
        &reckon(&[
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            "/nonexistent.csv",
            "--method",
            "euler",
        ]),
        "cannot read",
    );
    // unknown model or method: clap's own message and exit code 2
    let o = reckon(&["simulate", "--model", "sled", "--controls", p(&c), "--method", "euler"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("invalid value 'sled'"));
    let o = reckon(&[
        "simulate",
        "--model",
        "unicycle",
        "--controls",
        p(&c),
        "--method",
        "rk4",
    ]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn bad_odometry_inputs() {
    let run = |e: &Path| {
        reckon(&[
            "odometry",
            "--encoders",
            p(e),
            "--wheel-diameter",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--pulses-per-rev",
            "1024",
        ])
    };
    let e = file("oe1.csv", "t,left,right\n0,0,0\n0.1,10,10\n0.2,x,10\n0.3,1,1\n");
    let got = fails(&run(&e), "line 4");
    assert_eq!(got.len(), 2, "the two good rows are written");
    let e = file("oe2.csv", "t,left,right\n0,0,0\n0.1,10,10\n0.05,1,1\n");
    assert_eq!(fails(&run(&e), "time does not increase").len(), 2);
    let e = file("oe3.csv", "t,left\n0,0\n");
    fails(&run(&e), "missing column 'right'");
    let e = file("oe4.csv", "t,left,right\n0,0,NaN\n");
    fails(&run(&e), "not finite");
    let e = file("oe5.csv", "t,left,right\n0,0,0\n");
    let o = reckon(&[
        "odometry",
        "--encoders",
        p(&e),
        "--wheel-diameter",
        "0.1",
        "--wheel-separation",
        "-0.4",
        "--pulses-per-rev",
        "1024",
    ]);
    fails(&o, "wheel_separation");
}

/// `reckon demo --fast` builds the report; every image it references exists and parses as SVG.
#[test]
fn demo_builds_the_report() {
    let out = dir().join("report");
    let o = reckon(&["demo", "--fast", "--out", p(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // the tables show the stiff methods on the stiff problems, with their correct digits
    let tables = String::from_utf8(o.stdout).unwrap();
    for problem in ["Van der Pol μ = 1000, y0", "Robertson, y0", "HIRES, t in"] {
        let start = tables
            .find(problem)
            .unwrap_or_else(|| panic!("no {problem} table:\n{tables}"));
        let section = &tables[start..];
        let section = &section[..section[1..].find("\n\n").map_or(section.len(), |e| e + 1)];
        // issue 33's standard: at least −log10(rtol) − 2 correct digits
        for (method, setting) in [
            ("bdf", "1e-6"),
            ("rodas5p", "1e-6"),
            ("auto", "1e-6"),
            ("bdf", "1e-8"),
            ("rodas5p", "1e-8"),
            ("auto", "1e-8"),
            ("exponential-euler", "1e-4"),
        ] {
            // method, setting (3 words), max error, digits, accepted, …
            let row = section
                .lines()
                .find(|l| {
                    let c: Vec<&str> = l.split_whitespace().collect();
                    c.len() > 6 && c[0] == method && c[3] == setting
                })
                .unwrap_or_else(|| panic!("{problem}: no {method} at {setting}:\n{section}"));
            let cells: Vec<&str> = row.split_whitespace().collect();
            let digits: f64 = cells[5].parse().unwrap();
            let need = -setting.parse::<f64>().unwrap().log10() - 2.0;
            assert!(digits >= need, "{problem}: {row}");
            let steps: u64 = cells[6].parse().unwrap();
            assert!(steps > 0 && steps < 5000, "{problem}: {row}");
        }
        // RK45 is shown, capped where it is pinned by stability
        assert!(section.lines().any(|l| l.trim_start().starts_with("rk45")), "{section}");
    }
    assert!(tables.contains("stopped by the cap of 100000 steps"), "{tables}");
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let imgs: Vec<&str> = html
        .split("<img src=\"")
        .skip(1)
        .map(|s| &s[..s.find('"').unwrap()])
        .collect();
    assert!(imgs.len() >= 15, "{} images", imgs.len());
    for img in &imgs {
        let text = std::fs::read_to_string(out.join(img)).unwrap_or_else(|e| panic!("{img}: {e}"));
        let doc = roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{img} is not XML: {e}"));
        assert_eq!(doc.root_element().tag_name().name(), "svg", "{img}");
        assert!(
            doc.descendants()
                .filter(|n| n.has_tag_name("polyline") || n.has_tag_name("circle") || n.has_tag_name("path"))
                .count()
                > 0,
            "{img} draws nothing"
        );
    }
    for section in [
        "Kinematic bicycle",
        "Unicycle",
        "Car-like",
        "SLAM",
        "UMBmark",
        "IMU drift",
        "Convergence study",
        "Stiffness",
        "textbook",
    ] {
        assert!(html.contains(section), "report lacks {section}");
    }
}

fn study(args: &[&str]) -> Output {
    let mut a = args.to_vec();
    let out = dir().join(format!("study-{}", args.join("-").replace(['/', ','], "_")));
    a.extend(["--out", out.to_str().unwrap()]);
    reckon(&a)
}

#[test]
fn study_commands_write_files_and_json() {
    // a method named twice is one study (a fuzzed list repeated one five times)
    let o = study(&[
        "convergence",
        "--problem",
        "sin-u",
        "--methods",
        "euler,rk45,euler",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["fits"].as_array().unwrap().len(), 2, "{v}");
    for fit in v["fits"].as_array().unwrap() {
        let (p, th) = (fit["order_final"].as_f64().unwrap(), fit["theory"].as_f64().unwrap());
        assert!((p - th).abs() <= 0.1, "{fit}");
    }
    let o = study(&["stiffness", "--problem", "stiff-cosine", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for row in v["euler_threshold"].as_array().unwrap() {
        let (h, t) = (row["located"].as_f64().unwrap(), row["theory"].as_f64().unwrap());
        assert!((h / t - 1.0).abs() < 0.01);
    }
    let o = study(&[
        "work-precision",
        "--problem",
        "rotation-decay",
        "--methods",
        "rk45,rk45",
        "--tolerances",
        "1e-4,1e-8,1e-4",
        "--runs",
        "1",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let pts = v["points"].as_array().unwrap();
    // a method or a tolerance given twice is one setting
    assert_eq!(pts.len(), 2);
    assert!(pts[1]["error"].as_f64().unwrap() < pts[0]["error"].as_f64().unwrap());
}

/// Issue 38 item 8: work-precision plots correct digits (mescd), so that Robertson at
/// t = 10¹¹ (y₂ ≈ 8·10⁻¹⁴) reads by its relative accuracy; the table prints them too.
#[test]
fn work_precision_plots_correct_digits() {
    let args = [
        "work-precision",
        "--problem",
        "robertson",
        "--methods",
        "bdf,rodas5p",
        "--tolerances",
        "1e-4,1e-7",
        "--runs",
        "1",
    ];
    let o = study(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("digits_vs_rhs_evals.svg, digits_vs_time.svg"), "{text}");
    let out = dir().join(format!("study-{}", args.join("-").replace(['/', ','], "_")));
    for f in ["digits_vs_rhs_evals.svg", "digits_vs_time.svg"] {
        let svg = std::fs::read_to_string(out.join(f)).unwrap();
        assert!(svg.contains("correct digits at t_end (mescd)"), "{f}");
    }
    assert!(!out.join("error_vs_rhs_evals.svg").exists());
    // rows: method, setting, digits, error, …: a tighter tolerance gains digits, and the
    // absolute error says nothing of them (every run's is below 1e-6 here)
    for m in ["bdf", "rodas5p"] {
        let rows: Vec<Vec<f64>> = text
            .lines()
            .filter(|l| l.starts_with(m))
            .map(|l| l.split_whitespace().skip(1).map(|v| v.parse().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), 2, "{text}");
        // more digits at the tighter tolerance, and at least −log10(rtol) − 2 (issue 33)
        assert!(
            rows[1][1] > rows[0][1] + 1.0,
            "{m}: digits {} then {}",
            rows[0][1],
            rows[1][1]
        );
        assert!(rows[0][1] >= 2.0 && rows[1][1] >= 5.0, "{m}: {rows:?}");
        assert!(rows[0][2] < 1e-6, "{m}: max error {}", rows[0][2]);
    }
}

#[test]
fn bad_study_inputs() {
    fails(
        &study(&["convergence", "--problem", "pendulum"]),
        "unknown problem 'pendulum'",
    );
    fails(
        &study(&["convergence", "--problem", "sin-u", "--methods", "rk4"]),
        "'rk4' is not one of",
    );
    fails(
        &study(&["convergence", "--problem", "sin-u", "--steps", "0.1,-0.05"]),
        "step must be positive",
    );
    fails(
        &study(&["convergence", "--problem", "sin-u", "--steps", "0.1,0"]),
        "step must be positive",
    );
    // an empty tolerance list: clap's parse error (exit 2) names the option
    let o = study(&["work-precision", "--problem", "sin-u", "--tolerances", ""]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--tolerances"));
    let o = study(&["work-precision", "--problem", "sin-u"]);
    assert_eq!(o.status.code(), Some(2), "the tolerance list is required");
    fails_with(&study(&["convergence", "--problem", "robertson"]), "stiff");
    // an output folder that cannot be written: a path below a regular file
    let f = file("not-a-dir", "x");
    let o = reckon(&["convergence", "--problem", "sin-u", "--out", &format!("{}/sub", p(&f))]);
    fails_with(&o, "cannot create output folder");
    let o = reckon(&["demo", "--fast", "--out", &format!("{}/sub", p(&f))]);
    assert!(!o.status.success());
}

fn odo(e: &Path, extra: &[&str]) -> Output {
    let mut a = vec![
        "odometry",
        "--encoders",
        p(e),
        "--wheel-diameter",
        "0.1",
        "--wheel-separation",
        "0.4",
        "--pulses-per-rev",
        "1024",
    ];
    a.extend_from_slice(extra);
    reckon(&a)
}

fn sim_exact(c: &Path, extra: &[&str]) -> Output {
    let mut a = vec![
        "simulate",
        "--model",
        "unicycle",
        "--controls",
        p(c),
        "--method",
        "exact",
    ];
    a.extend_from_slice(extra);
    reckon(&a)
}

/// Issue 7.3: `1,1,5,0` under `t,v,omega` is a decimal comma, not v = 1, ω = 5.
#[test]
fn extra_fields_are_an_error_naming_the_line() {
    let c = file("comma.csv", "t,v,omega\n0,1,0\n1,1,5,0\n2,0,0\n");
    let got = fails(
        &sim_exact(&c, &[]),
        "line 3: 4 fields, the header has 3; a decimal comma?",
    );
    assert!(got.is_empty(), "no interval before the bad row: {got:?}");
    // one interval integrated before the bad row: its rows are written
    let c = file("comma2.csv", "t,v,omega\n0,1,0\n1,1,0\n2,1,5,0\n3,0,0\n");
    let got = fails(&sim_exact(&c, &[]), "line 4: 4 fields, the header has 3");
    assert_eq!(got, vec![vec![0.0, 0.0, 0.0, 0.0], vec![1.0, 1.0, 0.0, 0.0]]);
    // too few fields too (not a decimal comma)
    let c = file("short.csv", "t,v,omega\n0,1,0\n1,1\n");
    fails(&sim_exact(&c, &[]), "line 3: 2 fields, the header has 3");
    let e = file("comma3.csv", "t,left,right\n0,0,0\n0.1,10,1,5\n");
    let got = fails(&odo(&e, &[]), "line 3: 4 fields, the header has 3; a decimal comma?");
    assert_eq!(got, vec![vec![0.0, 0.0, 0.0, 0.0]]);
}

/// Issue 7.6: counts or geometry that overflow are an error naming the line, never NaN/inf.
#[test]
fn odometry_overflow_is_an_error() {
    // 1e308 pulses of 2π m each overflow; the rows before are written
    let e = file(
        "huge.csv",
        "t,left,right\n0,0,0\n0.1,10,10\n0.2,1e308,-1e308\n0.3,1,1\n",
    );
    let geometry = |sep: &'static str| {
        [
            "--wheel-diameter",
            "2",
            "--wheel-separation",
            sep,
            "--pulses-per-rev",
            "1",
        ]
    };
    let with = |e: &Path, sep: &'static str, extra: &[&str]| {
        let mut a = vec!["odometry", "--encoders", p(e)];
        a.extend(geometry(sep));
        a.extend_from_slice(extra);
        reckon(&a)
    };
    let got = fails(&with(&e, "0.4", &[]), "line 4: the pose is not finite (x = NaN)");
    assert_eq!(got.len(), 2, "the rows before are written");
    assert!(got.iter().flatten().all(|v| v.is_finite()));
    // the heading overflows through a tiny (but invertible) separation
    let e = file("huge2.csv", "t,left,right\n0,0,0\n0.1,-1e300,1e300\n");
    fails(
        &with(&e, "1e-10", &["--update", "euler"]),
        "line 3: the pose is not finite (theta = inf)",
    );
    // running counts whose difference overflows
    let e = file("huge3.csv", "t,left,right\n0,-1e308,0\n0.1,1e308,0\n");
    let got = fails(
        &with(&e, "0.4", &["--counts", "cumulative"]),
        "line 3: the pose is not finite",
    );
    assert_eq!(got, vec![vec![0.0, 0.0, 0.0, 0.0]]);
    // a separation whose inverse overflows
    let o = reckon(&[
        "odometry",
        "--encoders",
        p(&e),
        "--wheel-diameter",
        "0.1",
        "--wheel-separation",
        "1e-320",
        "--pulses-per-rev",
        "1024",
    ]);
    fails_with(&o, "wheel_separation: 1e-320 m is too small");
    assert!(o.stdout.is_empty(), "nothing written");
    // a per-pulse distance that underflows to 0
    let o = reckon(&[
        "odometry",
        "--encoders",
        p(&e),
        "--wheel-diameter",
        "1e-300",
        "--wheel-separation",
        "0.4",
        "--pulses-per-rev",
        "1e300",
    ]);
    fails_with(&o, "distance per pulse");
    // the library refuses the same inputs
    let robot = DiffDrive::new(0.1, 0.4, 1024.0).unwrap();
    let robot_big = DiffDrive::new(2.0, 0.4, 1.0).unwrap();
    assert!(odometry(&robot, &[(0.0, 0.0, 0.0), (1.0, 1e308, -1e308)], Update::Midpoint).is_ok());
    let err = odometry(&robot_big, &[(0.0, 0.0, 0.0), (1.0, 1e308, -1e308)], Update::Midpoint).unwrap_err();
    assert!(err.to_string().contains("after sample 1 is not finite"), "{err}");
    assert!(DiffDrive::new(0.1, 1e-320, 1024.0).is_err());
}

/// Issue 7.9: errors stay on one short line and print numbers briefly.
#[test]
fn errors_are_short() {
    // an unterminated quote swallows the rest of the file: the echo is cut at 40 characters
    let mut text = String::from("t,v,omega\n0,1,0\n1,1,\"0.5\n");
    for k in 2..2000 {
        text.push_str(&format!("{k},1,0.5\n"));
    }
    let c = file("quote.csv", &text);
    let o = sim_exact(&c, &[]);
    fails_with(
        &o,
        "line 3: column 'omega': '0.5\\n2,1,0.5\\n3,1,0.5\\n4,1,0.5\\n5,1,0.5\\n6,1,…' is not a number (an unterminated quote?)",
    );
    assert!(o.stderr.len() < 200, "{}", String::from_utf8_lossy(&o.stderr));
    // a non-number is echoed briefly too
    let c = file("long.csv", &format!("t,v,omega\n0,1,0\n1,{},0\n", "9x".repeat(500)));
    let o = sim_exact(&c, &[]);
    fails_with(&o, &format!("column 'v': '{}…' is not a number", "9x".repeat(20)));
    assert!(o.stderr.len() < 200);
    // numbers in messages: 1e308, not 309 digits
    let c = file("big.csv", "t,v,omega\n1e308,1,0\n1e307,1,0\n");
    let o = sim_exact(&c, &[]);
    fails_with(&o, "line 3: time does not increase: 1e+307 after 1e+308");
    let e = file("big2.csv", "t,left,right\n0,0,0\n0.1,1e308,-1e308\n");
    let o = reckon(&[
        "odometry",
        "--encoders",
        p(&e),
        "--wheel-diameter",
        "2",
        "--wheel-separation",
        "0.4",
        "--pulses-per-rev",
        "1",
    ]);
    fails_with(&o, "pulses 1e+308, -1e+308 overflow with this geometry");
}

/// Issue 7.9: `--out` naming the input refuses before touching it.
#[test]
fn out_equal_to_input_is_refused() {
    let c = file("same.csv", UNICYCLE);
    let alias = format!("{}/./same.csv", p(&dir()));
    let o = sim_exact(&c, &["--out", &alias]);
    fails_with(&o, "is the input file");
    assert_eq!(std::fs::read_to_string(&c).unwrap(), UNICYCLE, "input untouched");
    let e = file("same-enc.csv", "t,left,right\n0,0,0\n0.1,1,1\n");
    let link = dir().join("same-enc-link.csv");
    let _ = std::fs::remove_file(&link);
    std::fs::hard_link(&e, &link).unwrap();
    let o = odo(&e, &["--out", p(&link)]);
    fails_with(&o, "is the input file");
    assert_eq!(std::fs::read_to_string(&e).unwrap(), "t,left,right\n0,0,0\n0.1,1,1\n");
}

/// Issue 7.9: `--dt -inf` reaches the check instead of being read as the flags -i -n -f.
#[test]
fn non_finite_options_are_clear_errors() {
    let c = file("dt.csv", UNICYCLE);
    for (dt, shown) in [
        ("-inf", "-inf"),
        ("inf", "inf"),
        ("nan", "NaN"),
        ("-1e400", "-inf"),
        ("0", "0"),
    ] {
        let o = reckon(&[
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            p(&c),
            "--method",
            "euler",
            "--dt",
            dt,
        ]);
        fails_with(&o, &format!("--dt must be finite and positive, got {shown}"));
        assert!(o.stdout.is_empty());
    }
    for (flag, v) in [("--rtol", "-inf"), ("--atol", "nan")] {
        let o = sim_exact(&c, &[flag, v]);
        fails_with(&o, &format!("invalid {}: must be finite and non-negative", &flag[2..]));
    }
    let e = file("dt-enc.csv", "t,left,right\n0,0,0\n");
    let o = reckon(&[
        "odometry",
        "--encoders",
        p(&e),
        "--wheel-diameter",
        "-inf",
        "--wheel-separation",
        "0.4",
        "--pulses-per-rev",
        "1024",
    ]);
    fails_with(&o, "wheel_diameter: must be finite and positive, got -inf");
}

/// The README's example log: 1 m straight, then a 90° turn in place (left wheel back).
#[test]
fn shipped_encoder_example() {
    let e = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/enc.csv");
    let o = odo(&e, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        o.stderr.is_empty(),
        "no warning: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (_, got) = rows(&o.stdout);
    let last = got.last().unwrap();
    let k = std::f64::consts::PI * 0.1 / 1024.0;
    // net pulses: left 3259 − 1024, right 3259 + 1024 → Δθ = 2048·k/0.4 = π/2
    assert!((last[3] - std::f64::consts::FRAC_PI_2).abs() < 1e-13, "{last:?}");
    // the straight leg has a pulse of jitter between the wheels: ~1 m ahead, ~0 aside
    assert!((last[1] - 3259.0 * k).abs() < 1e-4, "{last:?}");
    assert!(last[2].abs() < 1e-3, "{last:?}");
}

fn cumulative_of(increments: &str, offset: (i64, i64)) -> String {
    let mut out = String::from("t,left,right\n");
    let (mut l, mut r) = offset;
    for (k, line) in increments.lines().skip(1).enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        if k > 0 {
            l += f[1].parse::<i64>().unwrap();
            r += f[2].parse::<i64>().unwrap();
        }
        out.push_str(&format!("{},{l},{r}\n", f[0]));
    }
    out
}

/// Issue 8.5: running counts and increments give the same pose; mistaking running counts
/// for increments triggers the warning.
#[test]
fn odometry_cumulative_counts() {
    let inc_text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/enc.csv")).unwrap();
    assert!(
        inc_text.lines().nth(1).unwrap().ends_with(",0,0"),
        "first row: no pulses"
    );
    let inc = file("inc.csv", &inc_text);
    let cum = file("cum.csv", &cumulative_of(&inc_text, (123_456, -77_000)));
    let a = odo(&inc, &[]);
    let b = odo(&cum, &["--counts", "cumulative"]);
    assert!(a.status.success() && b.status.success());
    assert!(b.stderr.is_empty(), "{}", String::from_utf8_lossy(&b.stderr));
    let (ra, rb) = (rows(&a.stdout).1, rows(&b.stdout).1);
    assert_eq!(ra.len(), rb.len());
    for (x, y) in ra.iter().zip(&rb) {
        for i in 0..4 {
            assert_eq!(x[i].to_bits(), y[i].to_bits(), "{x:?} vs {y:?}");
        }
    }
    // read as increments, the running counts are warned about (and give a wild path)
    let c = odo(&cum, &[]);
    assert!(c.status.success());
    let err = String::from_utf8_lossy(&c.stderr);
    assert!(
        err.contains("look like running counts") && err.contains("--counts cumulative"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1);
    // running counts from zero, both wheels forward (an arc): warned too
    let arc: String = (0..200).fold(String::from("t,left,right\n"), |s, k| {
        s + &format!("{},{},{}\n", k as f64 * 0.01, 40 * k + k % 3, 60 * k)
    });
    let c = odo(&file("arc.csv", &arc), &[]);
    assert!(String::from_utf8_lossy(&c.stderr).contains("look like running counts"));
    // the same arc's increments with a pulse of jitter: no warning
    let arc_inc: String = (0..200).fold(String::from("t,left,right\n"), |s, k| {
        s + &format!("{},{},{}\n", k as f64 * 0.01, 40 + k % 3, 60 - k % 2)
    });
    let c = odo(&file("arc-inc.csv", &arc_inc), &[]);
    assert!(c.stderr.is_empty(), "{}", String::from_utf8_lossy(&c.stderr));
}

/// Issue 7.1: a log longer than the old whole-run step limit (100 000) streams through, and
/// its rows match the library's `Problem::solve` bit for bit.
#[test]
fn long_log_streams_and_matches_the_library() {
    let n = 120_000;
    let mut text = String::from("t,v,omega\n");
    let (mut times, mut values) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let t = 1.7e9 + k as f64 * 0.01; // epoch seconds
        let (v, w) = (1.0 + (k % 7) as f64 * 0.1, 0.3 * ((k % 1000) as f64 / 500.0 - 1.0));
        text.push_str(&format!("{t},{v},{w}\n"));
        times.push(t);
        values.push(vec![v, w]);
    }
    let c = file("long.csv", &text);
    let out = dir().join("long-out.csv");
    let o = sim_exact(&c, &["--out", p(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (header, got) = rows(&std::fs::read(&out).unwrap());
    assert_eq!(header, "t,x,y,theta");
    let t_end = *times.last().unwrap();
    let sol = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (times[0], t_end))
        .controls(Controls::new(times, values).unwrap())
        .solve(Exact::new(unicycle::flow), &Options::default().dense(false))
        .unwrap();
    assert_eq!(got.len(), n);
    assert_eq!(sol.t.len(), n);
    for (row, (t, x)) in got.iter().zip(sol.t.iter().zip(&sol.x)) {
        assert_eq!(row[0].to_bits(), t.to_bits());
        for i in 0..3 {
            assert_eq!(row[i + 1].to_bits(), x[i].to_bits(), "t = {t}");
        }
    }
}

/// Issue 7.1: `--max-steps` limits the attempts per control interval; rows before the
/// failing interval are written and the error names the row that ends it.
#[test]
fn max_steps_per_interval() {
    let c = file("steps.csv", "t,v,omega\n0,1,0\n1,1,0.5\n11,1,0\n12,0,0\n");
    let euler = |extra: &[&str]| {
        let mut a = vec![
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            p(&c),
            "--method",
            "euler",
            "--dt",
            "0.1",
        ];
        a.extend_from_slice(extra);
        reckon(&a)
    };
    // 10 steps fit the first interval, the second needs 100
    let got = fails(
        &euler(&["--max-steps", "50"]),
        "line 4: integrating up to t = 11: step limit of 50 steps",
    );
    assert_eq!(
        got.len(),
        1 + 10 + 50,
        "start, the first interval, then the attempts that fit"
    );
    assert_eq!(got[10][0], 1.0);
    let o = euler(&["--max-steps", "100"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(rows(&o.stdout).1.len(), 1 + 10 + 100 + 10);
    fails_with(
        &euler(&["--max-steps", "0"]),
        "--max-steps must be a whole number from 1",
    );
    assert!(
        euler(&["--max-steps", "0"]).stdout.is_empty(),
        "refused before any output"
    );
}

/// Issue 7.9: the first error that happens is reported: an interval that fails before a
/// bad row, or a bad row before the interval that would fail.
#[test]
fn first_error_is_reported() {
    let run = |c: &Path| {
        reckon(&[
            "simulate",
            "--model",
            "unicycle",
            "--controls",
            p(c),
            "--method",
            "euler",
            "--dt",
            "0.1",
            "--max-steps",
            "20",
        ])
    };
    let c = file("first1.csv", "t,v,omega\n0,1,0\n5,1,0\n6,abc,0\n");
    fails(&run(&c), "line 3: integrating up to t = 5: step limit of 20 steps");
    let c = file("first2.csv", "t,v,omega\n0,1,0\n1,1,0\n2,abc,0\n5,1,0\n");
    let got = fails(&run(&c), "line 4: column 'v': 'abc' is not a number");
    assert_eq!(
        got.last().unwrap()[0],
        1.0,
        "the interval before the bad row is written"
    );
}

/// A write error is reported once, clearly (here: a full disk).
#[test]
fn write_errors_are_reported() {
    if !Path::new("/dev/full").exists() {
        return;
    }
    let mut text = String::from("t,v,omega\n");
    for k in 0..20_000 {
        text.push_str(&format!("{k},1,0.1\n"));
    }
    let c = file("full.csv", &text);
    fails_with(&sim_exact(&c, &["--out", "/dev/full"]), "No space left on device");
    let e = file("full-enc.csv", "t,left,right\n0,0,0\n1,1,1\n");
    fails_with(&odo(&e, &["--out", "/dev/full"]), "No space left on device");
}

#[test]
fn jacobian_prints_the_traced_model_in_every_format() {
    let out = reckon(&["jacobian", "--model", "unicycle"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("∂ẋ/∂θ = −v·sin(θ)\n∂ẏ/∂θ = v·cos(θ)\n"), "{text}");
    let out = reckon(&[
        "jacobian",
        "--model",
        "carlike",
        "--wheelbase",
        "2",
        "--format",
        "latex",
    ]);
    let latex = String::from_utf8(out.stdout).unwrap();
    // the same parts as the text: f, ∂f/∂x and ∂f/∂u
    assert!(latex.starts_with("\\begin{aligned}\n\\frac{d}{dt}"), "{latex}");
    for part in [
        "\\frac{\\partial f}{\\partial x} &= \\begin{pmatrix}",
        "\\frac{\\partial f}{\\partial u} &= \\begin{pmatrix}",
    ] {
        assert!(latex.contains(part), "{latex}");
    }
    assert!(latex.contains("\\tan \\gamma"), "{latex}");
    let out = reckon(&["jacobian", "--model", "body3d", "--format", "mathml"]);
    assert!(out.status.success());
    let m = String::from_utf8(out.stdout).unwrap();
    roxmltree::Document::parse(m.trim()).expect("well-formed MathML");
    let out = reckon(&["jacobian", "--problem", "robertson", "--format", "rust"]);
    let rust = String::from_utf8(out.stdout).unwrap();
    assert!(
        rust.contains("pub fn jacobian(t: f64, x: &[f64], u: &[f64], jac: &mut [f64]) {"),
        "{rust}"
    );
    // JSON with the BRUSS pattern: 8N − 4 non-zeros, CSC arrays
    let out = reckon(&["jacobian", "--problem", "brusselator:10", "--format", "json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["pattern"]["nnz"], 76);
    assert_eq!(v["pattern"]["col_ptr"].as_array().unwrap().len(), 21);
    assert_eq!(v["jacobian"].as_array().unwrap().len(), 76);
    assert_eq!(v["jacobian"][0]["row"], 0);
}

#[test]
fn jacobian_refuses_bad_arguments_with_one_line() {
    for args in [
        &["jacobian"][..],
        &["jacobian", "--model", "boat"],
        &["jacobian", "--problem", "brusselator:0"],
        &["jacobian", "--problem", "brusselator:x"],
        &["jacobian", "--model", "unicycle", "--wheelbase", "2"],
        &["jacobian", "--model", "bicycle", "--wheelbase", "-1"],
        &["jacobian", "--model", "unicycle", "--problem", "robertson"],
    ] {
        let out = reckon(args);
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(!err.trim().is_empty() && !err.contains("panicked"), "{args:?}: {err}");
    }
}

/// Issue 38.6 and 38.2: a negative or zero count reaches the flag's own check (not clap's
/// "unexpected argument '-1'"), the right flag is blamed, and a problem too large to fit
/// is refused with the limit.
#[test]
fn flags_get_their_own_messages_and_limits() {
    let c = file("flags.csv", UNICYCLE);
    let e = file("flags-enc.csv", "t,left,right\n0,0,0\n0.1,1,1\n");
    let poses = file("flags-poses.csv", "t,x,y,theta\n0,0,0,0\n0.1,0,0,0\n");
    let out = dir().join("flags-out");
    let o = dir().join("flags-o");
    let (out, o) = (p(&out), p(&o));
    let geometry = ["--wheel-diameter", "0.1", "--wheel-separation", "0.4"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec![
                "convergence",
                "--problem",
                "dahlquist",
                "--out",
                out,
                "--steps",
                "-1,0.1",
            ],
            "step must be positive and finite, got -1",
        ),
        (
            vec![
                "convergence",
                "--problem",
                "dahlquist",
                "--out",
                out,
                "--max-steps",
                "-1",
            ],
            "--max-steps must be a whole number from 1 to 1000000000, got -1",
        ),
        (
            vec!["stiffness", "--problem", "dahlquist", "--out", out, "--max-steps", "-1"],
            "--max-steps must be a whole number from 1 to 10000000, got -1",
        ),
        (
            vec![
                "work-precision",
                "--problem",
                "dahlquist",
                "--out",
                out,
                "--tolerances",
                "-1,1e-3",
            ],
            "tolerance must be positive and finite, got -1",
        ),
        (
            vec![
                "work-precision",
                "--problem",
                "dahlquist",
                "--out",
                out,
                "--tolerances",
                "1e-3,5.9e18",
            ],
            "tolerance must be below 1 (a relative tolerance of 1 asks for no correct digit), got 5900000000000000000",
        ),
        (
            vec![
                "work-precision",
                "--problem",
                "dahlquist",
                "--out",
                out,
                "--tolerances",
                "1e-3",
                "--runs",
                "-1",
            ],
            "--runs must be a whole number from 1 to 1000, got -1",
        ),
        (
            vec![
                "simulate",
                "--model",
                "unicycle",
                "--controls",
                p(&c),
                "--method",
                "euler",
                "--max-steps",
                "-1",
            ],
            "--max-steps must be a whole number from 1",
        ),
        (
            vec![
                "simulate",
                "--model",
                "unicycle",
                "--controls",
                p(&c),
                "--method",
                "euler",
                "--max-steps",
                "0",
            ],
            "--max-steps must be a whole number from 1",
        ),
        (
            [
                &["odometry", "--encoders", p(&e)][..],
                &geometry,
                &["--pulses-per-rev", "1e-320"],
            ]
            .concat(),
            "invalid pulses_per_rev: the distance per pulse",
        ),
        (
            [
                &["calibrate", "--encoders", p(&e), "--poses", p(&poses), "--out", o][..],
                &geometry,
                &["--pulses-per-rev", "1000", "--sigma-xy", "0"],
            ]
            .concat(),
            "--sigma-xy must be finite and positive, got 0",
        ),
        (
            [
                &["calibrate", "--encoders", p(&e), "--poses", p(&poses), "--out", o][..],
                &geometry,
                &["--pulses-per-rev", "1000", "--sigma-theta", "-1"],
            ]
            .concat(),
            "--sigma-theta must be finite and positive, got -1",
        ),
        (
            vec!["jacobian", "--model", "bicycle", "--wheelbase", "-1"],
            "--wheelbase must be finite and positive with 1/L finite",
        ),
        (
            vec!["jacobian", "--model", "bicycle", "--wheelbase", "1e-320"],
            "--wheelbase must be finite and positive with 1/L finite",
        ),
        (
            vec!["jacobian", "--problem", "brusselator:5000000"],
            "brusselator:N needs N from 1 to 500000 grid points",
        ),
        (
            vec!["stiffness", "--problem", "brusselator:500001", "--out", out],
            "brusselator:N needs N from 1 to 500000 grid points",
        ),
        // issue 38 item 12 (found by the cli_args fuzz target): LaTeX and MathML print
        // ∂f/∂x as a dense matrix, n² cells (1.8 GB for 4 000 states): refused up front
        (
            vec!["jacobian", "--problem", "brusselator:101", "--format", "mathml"],
            "--format mathml prints ∂f/∂x as a dense matrix, for at most 200 states; this model has 202",
        ),
        (
            vec!["jacobian", "--problem", "brusselator:500000", "--format", "latex"],
            "--format latex prints ∂f/∂x as a dense matrix, for at most 200 states; this model has 1000000",
        ),
    ];
    for (args, needle) in cases {
        let o = reckon(&args);
        fails_with(&o, needle);
        assert!(o.stdout.is_empty(), "{args:?}");
    }
    // the smallest wheelbase whose inverse is finite is traced
    let o = reckon(&["jacobian", "--model", "bicycle", "--wheelbase", "1e-300"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("∂θ̇/∂v = 9.999999999999999e299·tan(α)") && !text.contains("inf"),
        "{text}"
    );
}

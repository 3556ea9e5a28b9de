//! The command's golden outputs (the demo's tables with the time column blanked,
//! `simulate`, `odometry`, a `jacobian` print), in the repository's `tests/golden/`;
//! re-bless with `RECKON_BLESS=1 cargo test --release -p reckon-cli --test it golden::`.

use crate::golden_file::golden;
use std::fmt::Write;
use std::path::PathBuf;
use std::process::Command;

fn reckon_in(dir: &std::path::Path, args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_reckon"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "reckon {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

fn scratch(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("golden").join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The demo's tables with the time column blanked (the only column a run may change).
#[test]
fn demo_tables() {
    let text = reckon_in(&scratch("demo"), &["demo", "--fast"]);
    let mut out = String::new();
    let mut col = None;
    for l in text.lines() {
        if let Some(i) = l.find("time ms") {
            col = Some(i + "time ms".len());
        } else if l.trim().is_empty() {
            col = None;
        } else if let Some(end) = col {
            let (head, tail) = l.split_at(end.min(l.len()));
            let keep = head.trim_end().rsplit_once(' ').map_or(head, |(h, _)| h).trim_end();
            writeln!(out, "{keep} <time>{tail}").unwrap();
            continue;
        }
        writeln!(out, "{l}").unwrap();
    }
    golden("demo", &out);
}

#[test]
fn simulate_and_odometry_outputs() {
    let d = scratch("cli");
    std::fs::write(
        d.join("uni.csv"),
        "t,v,omega\n0,1,0\n2,1.5,0.6\n4.5,2,0\n6,1,-0.9\n8,0.5,0.3\n10,0,0\n",
    )
    .unwrap();
    std::fs::write(d.join("bike.csv"), "t,v,steer\n0,1,0.1\n1.5,2,-0.2\n3,1,0.3\n5,0,0\n").unwrap();
    std::fs::write(
        d.join("car.csv"),
        "t,v,steer_rate\n0,3,0.05\n2,3,-0.1\n4,2,0.05\n6,0,0\n",
    )
    .unwrap();
    let mut enc = String::from("t,left,right\n");
    for k in 0..50 {
        writeln!(enc, "{},{},{}", k as f64 * 0.1, 100 + k % 7, 104 + (k * 3) % 11).unwrap();
    }
    std::fs::write(d.join("enc.csv"), enc).unwrap();
    let mut out = String::new();
    for (model, csv, method) in [
        ("unicycle", "uni.csv", "exact"),
        ("unicycle", "uni.csv", "rk45"),
        ("bicycle", "bike.csv", "euler"),
        ("bicycle", "bike.csv", "implicit-euler"),
        ("carlike", "car.csv", "bdf"),
        ("carlike", "car.csv", "rodas5p"),
        ("carlike", "car.csv", "auto"),
    ] {
        let args = [
            "simulate",
            "--model",
            model,
            "--controls",
            csv,
            "--method",
            method,
            "--dt",
            "0.25",
        ];
        writeln!(out, "$ reckon {}\n{}", args.join(" "), reckon_in(&d, &args)).unwrap();
    }
    for update in ["midpoint", "euler", "exact"] {
        let args = [
            "odometry",
            "--encoders",
            "enc.csv",
            "--wheel-diameter",
            "0.1",
            "--wheel-separation",
            "0.4",
            "--pulses-per-rev",
            "2048",
            "--update",
            update,
        ];
        writeln!(out, "$ reckon {}\n{}", args.join(" "), reckon_in(&d, &args)).unwrap();
    }
    golden("simulate_odometry", &out);
}

#[test]
fn jacobian_prints() {
    let d = scratch("jacobian");
    let mut out = String::new();
    for args in [
        &["jacobian", "--model", "carlike"][..],
        &["jacobian", "--problem", "robertson"],
        &["jacobian", "--problem", "hires", "--format", "rust"],
        &["jacobian", "--problem", "brusselator:3", "--format", "json"],
    ] {
        writeln!(out, "$ reckon {}\n{}", args.join(" "), reckon_in(&d, args)).unwrap();
    }
    golden("jacobian", &out);
}

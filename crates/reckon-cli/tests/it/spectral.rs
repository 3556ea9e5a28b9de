//! `reckon stiffness` on the sparse path (the spectral study itself: `tests/it/spectral.rs`).

use std::process::{Command, Output};

fn reckon(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_reckon")).args(args).output().unwrap()
}

#[test]
fn cli_stiffness_brusselator_2000_runs_sparse() {
    let dir = std::env::temp_dir().join(format!("reckon-spectral-{}", std::process::id()));
    let out = reckon(&[
        "stiffness",
        "--problem",
        "brusselator:2000",
        "--out",
        dir.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("brusselator:2000") && stdout.contains("4000 unknowns"));
    assert!(stdout.contains("eigenvalues sparse"), "{stdout}");
    let csv = std::fs::read_to_string(dir.join("stiffness.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t,spectral_radius,stiffness_ratio,h_accuracy,h_stability,stiffness_index"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert!((20..=50).contains(&rows.len()), "{} points", rows.len());
    // c = 2001²/50: ρ(J) ≈ 4c within the reaction terms, |λ| ≤ Gershgorin ≈ 4c + 10
    let four_c = 4.0 * 2001.0f64.powi(2) / 50.0;
    for r in &rows {
        assert!((r[1] / four_c - 1.0).abs() < 1e-3, "ρ = {}", r[1]);
        assert!(r[2] > 1.0 && r[2].is_finite());
        assert!((r[4] - 3.3065678926349467 / r[1]).abs() < 1e-12 * r[4]);
        assert!((r[5] - r[1] * r[3] / 3.3065678926349467).abs() < 1e-9 * r[5]);
    }
    assert!(rows.windows(2).all(|w| w[0][0] < w[1][0]));
    // stiff: the implicit steps are hundreds of times RK45's stability limit
    assert!(rows.iter().skip(1).all(|r| r[5] > 100.0));
    for f in ["stiffness.svg", "step_sizes.csv", "step_sizes.svg"] {
        assert!(dir.join(f).exists(), "{f}");
    }
    // RK45's history is capped: it stops at its step limit, early
    assert!(
        stdout.contains("rk45") && stdout.contains("step limit of 1000 steps"),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cli_bad_brusselator_size_is_one_line() {
    for bad in [
        "brusselator:0",
        "brusselator:abc",
        "brusselator:",
        "brusselator:500001",
        "brusselator:5000000",
        "brusselator:-3",
    ] {
        let out = reckon(&["stiffness", "--problem", bad, "--out", "/nonexistent/never-written"]);
        assert!(!out.status.success(), "{bad}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{bad}: {err}");
        assert!(
            err.contains("brusselator:N needs N from 1 to 500000 grid points"),
            "{bad}: {err}"
        );
        assert!(out.stdout.is_empty());
    }
}

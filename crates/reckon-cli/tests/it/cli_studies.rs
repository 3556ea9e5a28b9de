//! The study commands (`convergence`, `stiffness`, `work-precision`) and `demo` as a user
//! runs them: failing standard output, refused runs, verdicts that say what was measured.

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir()
        .join(format!("reckon-cli-studies-{}", std::process::id()))
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn reckon(args: &[&str], stdout: Stdio) -> Output {
    Command::new(env!("CARGO_BIN_EXE_reckon"))
        .args(args)
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
        .wait_with_output()
        .unwrap()
}

fn run(args: &[&str]) -> Output {
    reckon(args, Stdio::piped())
}

/// Exit 1 and one line on stderr that contains `needle`, no panic.
fn fails_with(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line expected: {err}");
    assert!(err.contains(needle), "{err:?} lacks {needle:?}");
}

fn json(o: &Output) -> serde_json::Value {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn commands(out: &str) -> Vec<Vec<String>> {
    let v = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    vec![
        v(&["convergence", "--problem", "dahlquist", "--out", out]),
        v(&["convergence", "--problem", "dahlquist", "--json", "--out", out]),
        v(&["stiffness", "--problem", "stiff-cosine", "--out", out]),
        v(&[
            "work-precision",
            "--problem",
            "dahlquist",
            "--tolerances",
            "1e-4,1e-6",
            "--runs",
            "1",
            "--out",
            out,
        ]),
        v(&["demo", "--fast", "--out", out]),
    ]
}

/// A full disk on standard output: exit 1 with one message, never a panic (exit 101).
#[test]
fn full_disk_on_stdout_is_one_clear_error() {
    let out = dir("full");
    for args in commands(out.to_str().unwrap()) {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
        let o = reckon(&args, Stdio::from(full));
        fails_with(&o, "cannot write to standard output: No space left on device");
    }
}

/// A reader that has gone away (`reckon convergence ... | true`): exit 1 with one
/// message, never a panic.
#[test]
fn closed_pipe_on_stdout_is_one_clear_error() {
    let out = dir("pipe");
    for args in commands(out.to_str().unwrap()) {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        let o = reckon(&args, Stdio::from(writer));
        fails_with(&o, "cannot write to standard output: Broken pipe");
    }
}

/// A refused convergence study writes no file (not even an empty table or figure) and
/// says why; a step that would need billions of steps is refused at once.
#[test]
fn refused_convergence_writes_nothing() {
    let cases: [(&[&str], &str); 5] = [
        (&["--problem", "van-der-pol"], "stiff"),
        (&["--problem", "robertson"], "stiff"),
        (
            &["--problem", "dahlquist", "--steps", "0.01"],
            "at least two step sizes",
        ),
        (
            &["--problem", "dahlquist", "--steps", "1e-9,5e-10"],
            "needs 5.000e9 steps",
        ),
        (
            &["--problem", "dahlquist", "--steps", "2e-3,1e-3", "--max-steps", "4999"],
            "raise --max-steps",
        ),
    ];
    for (k, (args, needle)) in cases.iter().enumerate() {
        let out = dir(&format!("refused-{k}"));
        let mut a = vec!["convergence"];
        a.extend_from_slice(args);
        a.extend(["--out", out.to_str().unwrap()]);
        let o = run(&a);
        fails_with(&o, needle);
        assert!(o.stdout.is_empty(), "{args:?}");
        assert!(!out.exists(), "{args:?} created {}", out.display());
    }
    // 1e-3 needs exactly 5000 steps over [0, 5]: within a cap of 5000
    let out = dir("cap-ok");
    let v = json(&run(&[
        "convergence",
        "--problem",
        "dahlquist",
        "--methods",
        "euler",
        "--steps",
        "2e-3,1e-3",
        "--max-steps",
        "5000",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert_eq!(v["rows"][1]["steps"], 5000);
}

/// Arenstorf with the default steps: every explicit-Euler step gives an error of the
/// size of the orbit, so no order is reported; RK45's default steps are asymptotic.
#[test]
fn convergence_that_measures_nothing_says_so() {
    let out = dir("arenstorf");
    let o = run(&[
        "convergence",
        "--problem",
        "arenstorf",
        "--methods",
        "euler,rk45",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("euler: not asymptotic, no order fitted: errors up to"),
        "{text}"
    );
    assert!(text.contains("of the size of the solution"), "{text}");
    let v = json(&run(&[
        "convergence",
        "--problem",
        "arenstorf",
        "--methods",
        "euler,rk45",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]));
    let fits = v["fits"].as_array().unwrap();
    assert_eq!(fits[0]["method"], "euler");
    assert_eq!(fits[0]["asymptotic"], false);
    assert!(fits[0]["order_final"].is_null() && fits[0]["order_max"].is_null());
    // the orbit's size is max |y| = 2.0 (the velocity at the start)
    let rows = v["rows"].as_array().unwrap();
    assert!(
        rows.iter()
            .filter(|r| r["method"] == "euler")
            .all(|r| r["final_error"].as_f64().unwrap() > 0.2)
    );
    assert_eq!(fits[1]["asymptotic"], true, "{}", fits[1]);
    let p = fits[1]["order_final"].as_f64().unwrap();
    assert!(p > 4.3 && p < 5.5, "rk45 order {p}");
}

/// The stiffness study on the 40-unknown Brusselator finishes (it hung in nalgebra's
/// eigenvalue iteration) and finds it not stiff at the default tolerances; the stiff
/// cosine (λ = −1000) is stiff over its whole span, Dahlquist's x' = −2x nowhere.
#[test]
fn stiffness_index_from_the_command() {
    let index = |problem: &str| {
        let out = dir(&format!("stiff-{problem}"));
        let v = json(&run(&[
            "stiffness",
            "--problem",
            problem,
            "--json",
            "--out",
            out.to_str().unwrap(),
        ]));
        assert!(out.join("stiffness.csv").exists() && out.join("stiffness.svg").exists());
        v["stiffness_index"].clone()
    };
    let b = index("brusselator");
    assert!(
        b["max"].as_f64().unwrap() < 1.0 && b["stiff_fraction"].as_f64().unwrap() == 0.0,
        "{b}"
    );
    let s = index("stiff-cosine");
    // ρ(J) = 1000 and implicit Euler's steps at rtol 1e-4 are ≥ 0.01 s: index ≥ 3
    assert!(s["median"].as_f64().unwrap() > 10.0, "{s}");
    assert!(s["stiff_fraction"].as_f64().unwrap() > 0.99, "{s}");
    let d = index("dahlquist");
    // ρ(J) = 2 and steps ≤ 0.03 s: index ≤ 2·0.03/3.3 ≈ 0.02
    assert!(d["max"].as_f64().unwrap() < 0.05, "{d}");
}

/// RK45 stopped by its step limit on Van der Pol still reports where DOPRI5's stiffness
/// test fired.
#[test]
fn stiffness_verdict_survives_the_step_limit() {
    let out = dir("vdp");
    let v = json(&run(&[
        "stiffness",
        "--problem",
        "van-der-pol",
        "--max-steps",
        "20000",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]));
    let rk = &v["histories"][0];
    assert_eq!(rk["method"], "rk45");
    assert!(
        rk["stopped_by"].as_str().unwrap().contains("step limit of 20000"),
        "{rk}"
    );
    let at = rk["stiff_at"].as_f64().unwrap();
    assert!(at > 0.0 && at <= rk["reached"].as_f64().unwrap());
    let text = String::from_utf8(
        run(&[
            "stiffness",
            "--problem",
            "van-der-pol",
            "--max-steps",
            "20000",
            "--out",
            out.to_str().unwrap(),
        ])
        .stdout,
    )
    .unwrap();
    assert!(
        text.contains("stiffness detected at t = ") && text.contains("stopped: step limit"),
        "{text}"
    );
}

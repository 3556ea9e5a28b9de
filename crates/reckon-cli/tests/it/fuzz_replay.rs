//! Replays every saved fuzz input under `fuzz/regressions/<target>/` through the same
//! harness the fuzz targets run (`fuzz/harness.rs`): a panic fails the test, a typed
//! error is fine. Inputs of defects not yet fixed wait in `fuzz/regressions/pending/`,
//! which is not replayed. See `fuzz/README.md`.

#[path = "../../../../fuzz/harness.rs"]
mod harness;

use std::path::Path;

fn replay(target: &str, run: fn(&[u8])) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/regressions")
        .join(target);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no inputs in {}", dir.display());
    let mut panicked = Vec::new();
    for f in &files {
        let data = std::fs::read(f).expect("readable input");
        if std::panic::catch_unwind(|| run(&data)).is_err() {
            panicked.push(f.display().to_string());
        }
    }
    harness::remove_scratch();
    assert!(
        panicked.is_empty(),
        "{} of {} {target} inputs panicked:\n{}",
        panicked.len(),
        files.len(),
        panicked.join("\n")
    );
}

#[test]
fn csv_inputs_regressions_do_not_panic() {
    replay("csv_inputs", harness::csv_inputs);
}

#[test]
fn cli_args_regressions_do_not_panic() {
    replay("cli_args", harness::cli_args);
}

#[test]
fn solve_regressions_do_not_panic() {
    replay("solve", harness::solve);
}

/// Inputs recorded with the first version of `cli_args` (five commands), replayed with
/// its decoding.
#[test]
fn cli_args_v1_regressions_do_not_panic() {
    replay("cli_args_v1", harness::cli_args_v1);
}

/// Inputs recorded with the first version of `solve` (four methods and exact, six
/// models), replayed with its decoding.
#[test]
fn solve_v1_regressions_do_not_panic() {
    replay("solve_v1", harness::solve_v1);
}

#[test]
fn trace_regressions_do_not_panic() {
    replay("trace", harness::trace_target);
}

/// Print the case an input decodes to, then run it:
/// `FUZZ_SHOW=cli_args:fuzz/regressions/cli_args/<file> cargo test --release -p reckon-cli --test it fuzz_replay:: -- --ignored show --nocapture`.
#[test]
#[ignore = "a tool for reading fuzz inputs: set FUZZ_SHOW=<target>:<file>"]
fn show() {
    let Ok(spec) = std::env::var("FUZZ_SHOW") else {
        return;
    };
    let (target, file) = spec.split_once(':').expect("FUZZ_SHOW=<target>:<file>");
    let data = std::fs::read(file).expect("readable input");
    harness::set_trace(true);
    match target {
        "csv_inputs" => harness::csv_inputs(&data),
        "cli_args" => harness::cli_args(&data),
        "solve" => harness::solve(&data),
        "solve_v1" => harness::solve_v1(&data),
        "cli_args_v1" => harness::cli_args_v1(&data),
        "trace" => harness::trace_target(&data),
        other => panic!("unknown target {other}"),
    }
    harness::remove_scratch();
}

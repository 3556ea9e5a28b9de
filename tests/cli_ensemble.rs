//! `reckon ensemble`: shards merged equal one run bit for bit; values; errors.

use reckon::ensemble::Statistics;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("reckon-ensemble-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn reckon(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_reckon")).args(args).output().unwrap()
}

fn ensemble(controls: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "ensemble",
        "--model",
        "unicycle",
        "--controls",
        controls.to_str().unwrap(),
        "--wheel-diameter",
        "0.1",
        "--wheel-separation",
        "0.5",
        "--pulses-per-rev",
        "1000",
    ];
    args.extend_from_slice(extra);
    reckon(&args)
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn read_stats(p: &Path) -> Statistics {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

#[test]
fn merged_shards_equal_the_whole_run_bit_for_bit() {
    let d = dir("merge");
    let controls = d.join("c.csv");
    std::fs::write(&controls, "t,v,omega\n0,0.5,0\n4,0.3,0.4\n8,0.5,-0.2\n12,0,0\n").unwrap();
    let s = |name: &str| d.join(name).to_str().unwrap().to_string();
    let noise = [
        "--members",
        "900",
        "--seed",
        "42",
        "--pulse-noise",
        "1",
        "--slip",
        "0.002",
        "--diameter-sigma",
        "0.001",
    ];
    let mut whole = noise.to_vec();
    let (all_json, all_csv) = (s("all.json"), s("all.csv"));
    whole.extend(["--threads", "2", "--stats", &all_json, "--out", &all_csv]);
    ok(&ensemble(&controls, &whole));
    let mut parts = Vec::new();
    for k in 0..3 {
        let (shard, file, threads) = (
            format!("{k}/3"),
            s(&format!("s{k}.json")),
            if k == 1 { "2" } else { "1" },
        );
        let mut a = noise.to_vec();
        a.extend([
            "--shard",
            &shard,
            "--threads",
            threads,
            "--stats",
            &file,
            "--out",
            "/dev/null",
        ]);
        ok(&ensemble(&controls, &a));
        parts.push(file);
    }
    let merged_csv = s("merged.csv");
    let merged_json = s("merged.json");
    ok(&reckon(&[
        "ensemble",
        "merge",
        &parts[2],
        &parts[0],
        &parts[1],
        "--out",
        &merged_csv,
        "--stats",
        &merged_json,
    ]));
    let (a, b) = (std::fs::read(&all_csv).unwrap(), std::fs::read(&merged_csv).unwrap());
    assert_eq!(a, b, "summaries differ");
    let (whole, merged) = (read_stats(Path::new(&all_json)), read_stats(Path::new(&merged_json)));
    assert_eq!(whole.snapshots, merged.snapshots);
    assert_eq!(merged.shards, vec![0, 1, 2]);
    // the summary: one row per control interval, 900 members, t of the row ends
    let text = String::from_utf8(a).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 3);
    assert_eq!(rows.iter().map(|r| r[0]).collect::<Vec<_>>(), vec![4.0, 8.0, 12.0]);
    assert!(rows.iter().all(|r| r[1] == 900.0));
    assert!(text.starts_with("t,members,mean_ex,mean_ey,mean_etheta,sd_ex,sd_ey,sd_etheta,cov_ex_ey,"));
    // merging a shard twice, or a shard of another ensemble, is refused
    let twice = reckon(&["ensemble", "merge", &parts[0], &parts[0]]);
    assert!(!twice.status.success());
    assert!(String::from_utf8_lossy(&twice.stderr).contains("counted twice"));
    let mut other = noise.to_vec();
    let other_file = s("other.json");
    other[3] = "43";
    other.extend(["--shard", "1/3", "--stats", &other_file, "--out", "/dev/null"]);
    ok(&ensemble(&controls, &other));
    let mixed = reckon(&["ensemble", "merge", &parts[0], &other_file]);
    assert!(!mixed.status.success());
    assert!(String::from_utf8_lossy(&mixed.stderr).contains("not of one ensemble"));
    // two of three shards: written, with a warning
    let partial = reckon(&["ensemble", "merge", &parts[0], &parts[1]]);
    ok(&partial);
    assert!(String::from_utf8_lossy(&partial.stderr).contains("2 of 3 shards"));
}

#[test]
fn the_heading_spread_matches_the_pulse_noise_in_closed_form() {
    // straight at 1 m/s for 10 s, 100 Hz, σ = 2 pulses: var θ = n·2(σk)²/b²
    let d = dir("values");
    let controls = d.join("c.csv");
    std::fs::write(&controls, "t,v,omega\n0,1,0\n10,0,0\n").unwrap();
    let o = ensemble(&controls, &["--members", "4000", "--seed", "1", "--pulse-noise", "2"]);
    ok(&o);
    let text = String::from_utf8(o.stdout).unwrap();
    let row: Vec<f64> = text
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let k = std::f64::consts::PI * 0.1 / 1000.0;
    let sd = (1000.0 * 2.0 * (2.0 * k).powi(2) / 0.25f64).sqrt();
    assert!((row[7] / sd - 1.0).abs() < 0.05, "sd θ {} vs {sd}", row[7]);
    // no systematic heading error: the mean within 4 standard errors of 0
    assert!(row[4].abs() < 4.0 * sd / 4000f64.sqrt());
    // the radial quantiles increase
    assert!(row[11] < row[12] && row[12] < row[13] && row[13] < row[14]);
}

#[test]
fn bad_input_gets_one_clear_message() {
    let d = dir("errors");
    let bad = d.join("bad.csv");
    std::fs::write(&bad, "t,v,omega\n0,1,0\n1,1,x\n").unwrap();
    let o = ensemble(&bad, &["--members", "10"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("line 3") && err.contains("'x'"),
        "{err}"
    );
    let back = d.join("back.csv");
    std::fs::write(&back, "t,v,omega\n0,1,0\n2,1,0\n1,0,0\n").unwrap();
    let o = ensemble(&back, &["--members", "10"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("line 4") && err.contains("does not increase"),
        "{err}"
    );
    let good = d.join("good.csv");
    std::fs::write(&good, "t,v,omega\n0,1,0\n2,0,0\n").unwrap();
    for (extra, needle) in [
        (vec!["--members", "10", "--shard", "3/3"], "shard"),
        (vec!["--members", "10", "--shard", "x"], "K/N"),
        (vec!["--members", "0"], "at least one member"),
        (vec!["--members", "10", "--dt", "-1"], "dt"),
        (vec!["--members", "10", "--pulse-noise", "nan"], "pulse_noise"),
        (vec!["--members", "10", "--diameter-sigma", "0.7"], "diameter_sigma"),
    ] {
        let o = ensemble(&good, &extra);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    let o = reckon(&["ensemble", "--controls", good.to_str().unwrap()]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("--model is required"));
    let not_json = d.join("x.json");
    std::fs::write(&not_json, "{}").unwrap();
    let o = reckon(&["ensemble", "merge", not_json.to_str().unwrap()]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("not ensemble statistics"));
}

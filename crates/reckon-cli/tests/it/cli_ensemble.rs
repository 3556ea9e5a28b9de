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
        (vec!["--members", "0"], "--members must be a whole number from 1"),
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

/// One line on standard error naming `needle`, a non-zero exit, nothing on stdout.
fn refused(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "accepted; stderr {err}");
    assert!(err.contains(needle), "stderr {err:?} should mention {needle:?}");
    assert_eq!(err.trim().lines().count(), 1, "one line: {err:?}");
    assert!(o.stdout.is_empty(), "{}", String::from_utf8_lossy(&o.stdout));
}

fn three_shards(d: &Path, members: &str) -> Vec<String> {
    let controls = d.join("c.csv");
    std::fs::write(&controls, "t,v,omega\n0,0.5,0\n4,0.3,0.4\n8,0,0\n").unwrap();
    (0..3)
        .map(|k| {
            let file = d.join(format!("s{k}.json")).to_str().unwrap().to_string();
            let shard = format!("{k}/3");
            let a = [
                "--members",
                members,
                "--pulse-noise",
                "1",
                "--shard",
                &shard,
                "--stats",
                &file,
                "--out",
                "/dev/null",
            ];
            let o = ensemble(&controls, &a);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            file
        })
        .collect()
}

/// Issue 38.1: every damaged or edited shard file of the report is refused with one line
/// naming the file and the field, at once (no panic, no 17 GB allocation, no minute-long
/// run, no silent partial merge).
#[test]
fn edited_shard_files_are_refused_naming_the_file_and_the_field() {
    let d = dir("edited");
    let parts = three_shards(&d, "30");
    let text = std::fs::read_to_string(&parts[0]).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut w = v.clone();
        f(&mut w);
        w
    };
    let sum = serde_json::json!({"negative": false, "lo": 2147483647, "limbs": [1], "special": [0, 0, 0]});
    let long =
        serde_json::json!({"negative": false, "lo": 1, "limbs": vec![4294967295u32; 200_000], "special": [0, 0, 0]});
    let cases: Vec<(&str, serde_json::Value, &str)> = vec![
        (
            "emptied",
            edit(&|w| w["snapshots"] = serde_json::json!([])),
            "snapshots: 0 for 2 saved times",
        ),
        (
            "dim",
            edit(&|w| w["snapshots"][1]["moments"]["dim"] = 2.into()),
            "snapshots[1].moments.s1: 3 sums for dimension 2",
        ),
        (
            "whole",
            edit(&|w| w["shards"] = serde_json::json!([0, 1, 2])),
            "snapshots[0].moments.n: 10 members counted, but shards [0, 1, 2] of 3 hold 30",
        ),
        (
            "beyond",
            edit(&|w| w["shards"] = serde_json::json!([7])),
            "shards: 7 is not a shard of 3",
        ),
        ("none", edit(&|w| w["shard_count"] = 0.into()), "shard_count: 0"),
        (
            "repeated",
            edit(&|w| w["shards"] = serde_json::json!([0, 0])),
            "shards: 0 then 0",
        ),
        (
            "lo",
            edit(&|w| w["snapshots"][0]["moments"]["s2"][4] = sum.clone()),
            "snapshots[0].moments.s2[4]: invalid exact sum: lo = 2147483647",
        ),
        (
            "limbs",
            edit(&|w| w["snapshots"][1]["moments"]["s1"][0] = long.clone()),
            "snapshots[1].moments.s1[0]: invalid exact sum: lo = 1 with 200000 limbs",
        ),
        (
            "count",
            edit(&|w| w["snapshots"][0]["moments"]["n"] = 11.into()),
            "snapshots[0].moments",
        ),
        (
            "sketch",
            edit(&|w| w["snapshots"][0]["sketches"][3]["zero"] = 5.into()),
            "snapshots[0].sketches[3]",
        ),
        (
            "key",
            edit(&|w| w["snapshots"][0]["sketches"][3]["positive"]["4294967295"] = 1.into()),
            "snapshots[0].sketches[3].positive: bucket key 4294967295",
        ),
        (
            "mean",
            edit(&|w| {
                w["snapshots"][0]["moments"]["s1"][0] =
                    serde_json::json!({"negative": false, "lo": 40, "limbs": [7], "special": [0, 0, 0]})
            }),
            "snapshots[0].moments.s1[0]: the mean",
        ),
        (
            "min",
            edit(&|w| w["snapshots"][0]["moments"]["min"] = serde_json::json!([null, 0, 0])),
            "min: null is not a number",
        ),
        ("members", edit(&|w| w["members"] = 0.into()), "members: 0"),
        ("layout", edit(&|w| w["layout"]["moments"] = 9.into()), "layout"),
    ];
    for (tag, value, needle) in cases {
        let file = d.join(format!("{tag}.json"));
        std::fs::write(&file, serde_json::to_string(&value).unwrap()).unwrap();
        let start = std::time::Instant::now();
        let o = reckon(&["ensemble", "merge", file.to_str().unwrap(), &parts[1], &parts[2]]);
        refused(&o, needle);
        assert!(
            String::from_utf8_lossy(&o.stderr).contains(&format!("{tag}.json")),
            "{tag}: no file named"
        );
        assert!(start.elapsed().as_secs() < 10, "{tag}: {:?}", start.elapsed());
    }
    // a shard merged twice, under another name: refused
    let copy = d.join("copy.json");
    std::fs::copy(&parts[1], &copy).unwrap();
    let o = reckon(&[
        "ensemble",
        "merge",
        &parts[0],
        &parts[1],
        copy.to_str().unwrap(),
        &parts[2],
    ]);
    refused(&o, "shard 1/3 is counted twice");
    // statistics of another layout (a library run) are not the command's
    let layout = reckon::ensemble::Layout::new(vec![1.0], vec!["x".into()], 1).unwrap();
    let lib = reckon::ensemble::Ensemble::new(3, 0)
        .run(&layout, |m, row| {
            row[0] = m.index as f64;
            Ok(())
        })
        .unwrap();
    let other = d.join("library.json");
    std::fs::write(&other, serde_json::to_string(&lib).unwrap()).unwrap();
    refused(
        &reckon(&["ensemble", "merge", other.to_str().unwrap()]),
        "not those of `reckon ensemble`",
    );
    // the untouched files still merge, to all 30 members
    let o = reckon(&["ensemble", "merge", &parts[2], &parts[0], &parts[1]]);
    assert!(
        o.status.success() && o.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.lines().skip(1).all(|l| l.split(',').nth(1) == Some("30")),
        "{text}"
    );
}

/// Issue 38.3: the summary's `t` are the controls' own times (here stamped in
/// milliseconds since 1970), as `simulate` and `odometry` keep them.
#[test]
fn the_summary_keeps_the_controls_clock() {
    let d = dir("clock");
    let controls = d.join("c.csv");
    std::fs::write(
        &controls,
        "t,v,omega\n1700000000000,0.5,0\n1700000001000,0.3,0.1\n1700000002500.25,0.2,0\n1700000004000,0,0\n",
    )
    .unwrap();
    let json = d.join("s.json");
    let o = ensemble(
        &controls,
        &[
            "--members",
            "20",
            "--pulse-noise",
            "1",
            "--dt",
            "1",
            "--stats",
            json.to_str().unwrap(),
        ],
    );
    ok(&o);
    let text = String::from_utf8(o.stdout).unwrap();
    let t: Vec<&str> = text.lines().skip(1).map(|l| l.split(',').next().unwrap()).collect();
    assert_eq!(t, ["1700000001000", "1700000002500.25", "1700000004000"]);
    assert_eq!(
        read_stats(&json).layout.times,
        [1700000001000.0, 1700000002500.25, 1700000004000.0]
    );
    // merge writes the same times
    let m = reckon(&["ensemble", "merge", json.to_str().unwrap()]);
    ok(&m);
    assert_eq!(String::from_utf8(m.stdout).unwrap(), text);
}

/// Issue 38.4: `--stats` and `--out` naming one file (directly, through another path or
/// a hard link) are refused before anything is written.
#[test]
fn stats_and_out_may_not_name_one_file() {
    let d = dir("same");
    let parts = three_shards(&d, "6");
    let controls = d.join("c.csv");
    let same = d.join("same.out");
    let other = d.join("sub").join("..").join("same.out");
    std::fs::create_dir_all(d.join("sub")).unwrap();
    for (a, b) in [(&same, &same), (&same, &other)] {
        let o = ensemble(
            &controls,
            &[
                "--members",
                "6",
                "--stats",
                a.to_str().unwrap(),
                "--out",
                b.to_str().unwrap(),
            ],
        );
        refused(&o, "--stats and --out both name");
        assert!(!same.exists(), "written before the refusal");
        let o = reckon(&[
            "ensemble",
            "merge",
            &parts[0],
            "--stats",
            a.to_str().unwrap(),
            "--out",
            b.to_str().unwrap(),
        ]);
        refused(&o, "--stats and --out both name");
        assert!(!same.exists());
    }
    std::fs::write(&same, "keep").unwrap();
    let link = d.join("link.out");
    let _ = std::fs::remove_file(&link);
    std::fs::hard_link(&same, &link).unwrap();
    let o = reckon(&[
        "ensemble",
        "merge",
        &parts[0],
        "--stats",
        same.to_str().unwrap(),
        "--out",
        link.to_str().unwrap(),
    ]);
    refused(&o, "--stats and --out both name");
    assert_eq!(std::fs::read_to_string(&same).unwrap(), "keep");
    // /dev/null twice is fine
    ok(&reckon(&[
        "ensemble",
        "merge",
        &parts[0],
        "--stats",
        "/dev/null",
        "--out",
        "/dev/null",
    ]));
}

/// Issue 38.5: statistics that f64 cannot hold are refused (naming the column and the
/// time), never written as NaN; those undefined for n < 2 are empty cells with a warning.
#[test]
fn unrepresentable_statistics_are_refused_and_undefined_ones_left_empty() {
    let d = dir("finite");
    let huge = d.join("huge.csv");
    std::fs::write(&huge, "t,v,omega\n0,0.5,0\n10,1e300,0.1\n20,0,0\n").unwrap();
    let json = d.join("huge.json");
    let o = ensemble(
        &huge,
        &[
            "--members",
            "5",
            "--pulse-noise",
            "1",
            "--dt",
            "1",
            "--stats",
            json.to_str().unwrap(),
        ],
    );
    refused(&o, "sd_ex at t = 20 is NaN (the errors reach");
    assert!(!json.exists(), "statistics written before the refusal");
    // one member: means and quantiles, empty standard deviations and covariances
    let c = d.join("c.csv");
    std::fs::write(&c, "t,v,omega\n0,1,0\n10,0,0\n").unwrap();
    let o = ensemble(&c, &["--members", "1", "--pulse-noise", "1"]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("1 member counted: the standard deviations and covariances are undefined for n < 2"),
        "{err}"
    );
    let text = String::from_utf8(o.stdout).unwrap();
    let cells: Vec<&str> = text.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(cells.len(), 15);
    assert_eq!(cells[..2], ["10", "1"]);
    assert!(
        cells[2..5].iter().all(|c| c.parse::<f64>().unwrap().is_finite()),
        "{text}"
    );
    assert!(cells[5..11].iter().all(|c| c.is_empty()), "{text}");
    assert!(cells[11..].iter().all(|c| c.parse::<f64>().unwrap() > 0.0), "{text}");
    assert!(!text.contains("NaN"));
    // an empty shard: its statistics merge; its own summary says why it is empty
    let json = d.join("empty.json");
    let o = ensemble(
        &c,
        &["--members", "2", "--shard", "2/3", "--stats", json.to_str().unwrap()],
    );
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("0 members counted: every statistic is undefined"));
    assert_eq!(
        String::from_utf8(o.stdout).unwrap().lines().nth(1).unwrap(),
        format!("10,0{}", ",".repeat(13))
    );
    assert_eq!(read_stats(&json).count(), 0);
}

/// Issue 38.2 and 38.6: work that cannot finish is refused up front with the limit;
/// negative and zero counts get the flag's own message, not clap's "unexpected argument".
#[test]
fn flags_are_checked_by_their_own_rules_and_limits() {
    let d = dir("flags");
    let c = d.join("c.csv");
    std::fs::write(&c, "t,v,omega\n0,1,0\n20,0,0\n").unwrap();
    for (extra, needle) in [
        (
            vec!["--members", "-1"],
            "--members must be a whole number from 1 to 18446744073709551615, got -1",
        ),
        (
            vec!["--members", "5", "--threads", "-1"],
            "--threads must be a whole number from 1 to 1024, got -1",
        ),
        (
            vec!["--members", "5", "--threads", "0"],
            "--threads must be a whole number from 1 to 1024, got 0",
        ),
        (
            vec!["--members", "5", "--threads", "100000"],
            "--threads must be a whole number from 1 to 1024, got 100000",
        ),
        (
            vec!["--members", "5", "--seed", "-1"],
            "--seed must be a whole number from 0 to 18446744073709551615, got -1",
        ),
        (
            vec!["--members", "5", "--save-every", "-1"],
            "--save-every must be a whole number from 1",
        ),
        (
            vec!["--members", "5", "--save-every", "0"],
            "--save-every must be a whole number from 1",
        ),
        (vec!["--members", "5", "--shard", "-1/2"], "'-1/2' is not K/N"),
        (
            vec!["--members", "5", "--dt", "1e-300"],
            "invalid dt: 1e-300: the commands (20 s) would take 1.9999999999999999e301 encoder samples per member; at most 1e9",
        ),
        (
            vec!["--members", "100000000", "--dt", "0.001"],
            "100000000 members × 20000 encoder samples = 2e12 samples in this run; at most 1e12",
        ),
    ] {
        let o = ensemble(&c, &extra);
        refused(&o, needle);
    }
}

/// Three shards of a small ensemble, written in-process; their JSON.
fn shard_files(d: &Path) -> Vec<serde_json::Value> {
    let controls = d.join("c.csv");
    std::fs::write(&controls, "t,v,omega\n0,0.5,0\n1,0.3,0.4\n2,0,0\n").unwrap();
    (0..3)
        .map(|k| {
            let file = d.join(format!("valid{k}.json"));
            let shard = format!("{k}/3");
            reckon_cli::run([
                "reckon",
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
                "--members",
                "11",
                "--pulse-noise",
                "1",
                "--dt",
                "0.05",
                "--shard",
                &shard,
                "--stats",
                file.to_str().unwrap(),
                "--out",
                d.join("valid.csv").to_str().unwrap(),
            ])
            .unwrap();
            serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap()
        })
        .collect()
}

/// Numbers a hostile file might hold.
const HOSTILE: [f64; 16] = [
    0.0,
    1.0,
    -1.0,
    2.0,
    3.0,
    7.0,
    0.5,
    2147483647.0,
    -2147483648.0,
    4294967295.0,
    9007199254740992.0,
    18446744073709551615.0,
    1e308,
    -1e308,
    1e-320,
    3e9,
];

fn hostile(choice: u64) -> serde_json::Value {
    use serde_json::Value;
    let x = HOSTILE[choice as usize % HOSTILE.len()];
    match choice as usize % HOSTILE.len() {
        // exact integers where the file holds integers (u64::MAX, i32 limits)
        11 => Value::from(u64::MAX),
        7 => Value::from(i32::MAX),
        8 => Value::from(i32::MIN),
        9 => Value::from(u32::MAX),
        _ if x.fract() == 0.0 && x.abs() < 1e15 => Value::from(x as i64),
        _ => Value::from(x),
    }
}

/// Every node of `v` by its path of object keys and array indices.
fn paths(v: &serde_json::Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    out.push(at.clone());
    match v {
        serde_json::Value::Object(m) => {
            for (k, c) in m {
                at.push(k.clone());
                paths(c, at, out);
                at.pop();
            }
        }
        serde_json::Value::Array(a) => {
            for (i, c) in a.iter().enumerate() {
                at.push(i.to_string());
                paths(c, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn node<'a>(v: &'a mut serde_json::Value, path: &[String]) -> &'a mut serde_json::Value {
    path.iter().fold(v, |v, k| match v {
        serde_json::Value::Object(m) => m.get_mut(k).unwrap(),
        serde_json::Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
        _ => unreachable!(),
    })
}

/// Mutation `op` at node number `which` with value `choice`: a number changed (to a
/// hostile one or by ±1), an array emptied or extended, a field removed or renamed (map
/// keys are the sketches' buckets), a value replaced by another type.
fn mutate(v: &mut serde_json::Value, which: u64, op: u8, choice: u64) {
    use serde_json::Value;
    let mut all = Vec::new();
    paths(v, &mut Vec::new(), &mut all);
    let path = all[which as usize % all.len()].clone();
    match op % 7 {
        0 => *node(v, &path) = hostile(choice),
        1 => {
            let n = node(v, &path);
            if let Some(x) = n.as_u64() {
                *n = Value::from(if choice.is_multiple_of(2) {
                    x.wrapping_add(1)
                } else {
                    x.wrapping_sub(1)
                });
            } else if let Some(x) = n.as_i64() {
                *n = Value::from(x + if choice.is_multiple_of(2) { 1 } else { -1 });
            } else if let Some(x) = n.as_f64() {
                *n = Value::from(x * (1.0 + 1e-3 * (choice % 7) as f64) + 1.0);
            }
        }
        2 => {
            if let Value::Array(a) = node(v, &path) {
                a.clear();
            }
        }
        3 => {
            if let Value::Array(a) = node(v, &path) {
                let extra = a.last().cloned().unwrap_or_else(|| hostile(choice));
                for _ in 0..=choice % 3 {
                    a.push(extra.clone());
                }
            }
        }
        4 => {
            if let Some((last, parent)) = path.split_last()
                && let Value::Object(m) = node(v, parent)
            {
                m.remove(last);
            }
        }
        5 => {
            if let Some((last, parent)) = path.split_last()
                && let Value::Object(m) = node(v, parent)
                && let Some(c) = m.remove(last)
            {
                let key = match hostile(choice) {
                    Value::Number(n) => n.to_string(),
                    _ => "0".into(),
                };
                m.insert(key, c);
            }
        }
        _ => {
            *node(v, &path) = match choice % 4 {
                0 => Value::Null,
                1 => Value::from("inf"),
                2 => Value::from(true),
                _ => serde_json::json!({}),
            }
        }
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(400))]

    /// A shard file damaged at random is refused (an `Err` from the command: one line
    /// naming the file) or merged into statistics that pass every check and count
    /// exactly the members of the shards they claim, all of them when they claim to be
    /// complete; never a panic, an abort or an allocation the size of a stored number.
    #[test]
    fn a_damaged_shard_file_is_refused_or_merged_honestly(
        mutations in proptest::collection::vec((proptest::prelude::any::<u64>(), 0u8..7, proptest::prelude::any::<u64>()), 1..4),
        target in 0usize..3,
        order in 0usize..6,
    ) {
        use std::sync::OnceLock;
        static VALID: OnceLock<(PathBuf, Vec<serde_json::Value>)> = OnceLock::new();
        let (d, valid) = VALID.get_or_init(|| {
            let d = dir("mutated");
            let v = shard_files(&d);
            (d, v)
        });
        let mut files = valid.clone();
        for (which, op, choice) in &mutations {
            mutate(&mut files[target], *which, *op, *choice);
        }
        let tag = format!("{:?}", std::thread::current().id()).replace(|c: char| !c.is_ascii_alphanumeric(), "");
        let names: Vec<PathBuf> = (0..3).map(|k| d.join(format!("{tag}-m{k}.json"))).collect();
        for (f, v) in names.iter().zip(&files) {
            std::fs::write(f, serde_json::to_string(v).unwrap()).unwrap();
        }
        let orders = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
        let (out_json, out_csv) = (d.join(format!("{tag}-out.json")), d.join(format!("{tag}-out.csv")));
        let mut argv: Vec<String> = vec!["reckon".into(), "ensemble".into(), "merge".into()];
        argv.extend(orders[order].iter().map(|k| names[*k].to_str().unwrap().to_string()));
        argv.extend(["--stats".into(), out_json.to_str().unwrap().into(), "--out".into(), out_csv.to_str().unwrap().into()]);
        match reckon_cli::run(&argv) {
            Err(e) => {
                let msg = e.to_string();
                proptest::prop_assert_eq!(msg.lines().count(), 1, "{}", msg);
                // a file that cannot be read as statistics is named with the field
                if msg.contains("statistics") {
                    proptest::prop_assert!(msg.contains("-m") && msg.contains(".json"), "no file named: {}", msg);
                }
            }
            Ok(()) => {
                let merged = Statistics::from_json(&std::fs::read_to_string(&out_json).unwrap());
                proptest::prop_assert!(merged.is_ok(), "{:?}", merged);
                let merged = merged.unwrap();
                let hold: u64 = merged
                    .shards
                    .iter()
                    .map(|k| reckon::ensemble::Shard::new(*k, merged.shard_count).unwrap().len(merged.members))
                    .sum();
                proptest::prop_assert_eq!(merged.count(), hold);
                if merged.is_complete() {
                    proptest::prop_assert_eq!(merged.count(), merged.members);
                }
                let csv = std::fs::read_to_string(&out_csv).unwrap();
                proptest::prop_assert_eq!(csv.lines().count(), merged.layout.times.len() + 1);
            }
        }
    }
}

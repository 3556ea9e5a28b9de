//! Soak test of the streaming commands: writes a long controls log and a long encoder log
//! (10⁷ rows by default) to temporary files, runs `reckon simulate --method exact --model
//! unicycle` and `reckon odometry` on them (each in a child process that calls
//! `reckon_cli::run`, with `--out` to a file), and prints rows per second of wall time and
//! of CPU time and the peak resident memory of each run (targets: under 50 MiB, at
//! least 5 million rows/s for simulate).
//!
//! ```sh
//! cargo run --release --example soak            # 10⁷ rows
//! cargo run --release --example soak -- 1000000 # fewer
//! ```

use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("--child") {
        return child(args[2..].to_vec());
    }
    let rows: u64 = match std::env::args().nth(1) {
        Some(a) => a.parse()?,
        None => 10_000_000,
    };
    let dir = std::env::temp_dir().join(format!("reckon-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let controls = dir.join("controls.csv");
    let encoders = dir.join("encoders.csv");
    let out = dir.join("out.csv");

    // a 100 Hz log with epoch-like start 0 and varying turn rate
    let mut w = BufWriter::new(std::fs::File::create(&controls)?);
    writeln!(w, "t,v,omega")?;
    for k in 0..rows {
        let omega = 0.3 * ((k % 1000) as f64 / 500.0 - 1.0);
        writeln!(w, "{},{},{}", k as f64 * 0.01, 1.0 + (k % 7) as f64 * 0.1, omega)?;
    }
    w.flush()?;
    drop(w);
    let mut w = BufWriter::new(std::fs::File::create(&encoders)?);
    writeln!(w, "t,left,right")?;
    for k in 0..rows {
        writeln!(w, "{},{},{}", k as f64 * 0.01, 100 + k % 5, 103 + k % 3)?;
    }
    w.flush()?;
    drop(w);
    let size = |p: &Path| std::fs::metadata(p).map(|m| m.len() as f64 / 1e6).unwrap_or(0.0);
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "load average {} on {} cores",
        load.split_whitespace().next().unwrap_or("?"),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    println!(
        "{rows} rows: controls {:.0} MB, encoders {:.0} MB",
        size(&controls),
        size(&encoders)
    );

    let s = |p: &Path| p.to_str().unwrap().to_string();
    let runs: [(&str, Vec<String>); 2] = [
        (
            "simulate --model unicycle --method exact",
            vec![
                "reckon".into(),
                "simulate".into(),
                "--model".into(),
                "unicycle".into(),
                "--method".into(),
                "exact".into(),
                "--controls".into(),
                s(&controls),
                "--out".into(),
                s(&out),
            ],
        ),
        (
            "odometry",
            vec![
                "reckon".into(),
                "odometry".into(),
                "--encoders".into(),
                s(&encoders),
                "--wheel-diameter".into(),
                "0.1".into(),
                "--wheel-separation".into(),
                "0.4".into(),
                "--pulses-per-rev".into(),
                "1024".into(),
                "--out".into(),
                s(&out),
            ],
        ),
    ];
    // each command runs in a child process (this program with `--child`), so that its peak
    // RSS is its own
    let mut failed = false;
    for (name, argv) in runs {
        let start = Instant::now();
        let child = std::process::Command::new(std::env::current_exe()?)
            .arg("--child")
            .args(&argv)
            .output()?;
        let secs = start.elapsed().as_secs_f64();
        let report = String::from_utf8_lossy(&child.stdout);
        let mut fields = report.split_whitespace().map(|v| v.parse::<f64>().unwrap_or(f64::NAN));
        let peak = fields.next().unwrap_or(f64::NAN);
        let cpu = fields.next().unwrap_or(f64::NAN);
        let err = String::from_utf8_lossy(&child.stderr);
        println!(
            "reckon {name}: {secs:.2} s, {:.2} M rows/s ({cpu:.2} CPU-s on all threads: {:.2} M rows per CPU-s), peak RSS {:.1} MiB, output {:.0} MB{}",
            rows as f64 / secs / 1e6,
            rows as f64 / cpu / 1e6,
            peak / 1024.0,
            size(&out),
            if child.status.success() {
                String::new()
            } else {
                format!(", FAILED: {}", err.trim())
            }
        );
        failed |= !child.status.success();
    }
    std::fs::remove_dir_all(&dir)?;
    if failed {
        return Err("a run failed".into());
    }
    Ok(())
}

/// The child: run one command in-process, print its peak RSS in KiB and its CPU time in
/// seconds on stdout.
fn child(argv: Vec<String>) -> Result<(), Box<dyn std::error::Error>> {
    let r = reckon_cli::run(argv);
    println!("{} {}", peak_kib(), cpu_seconds());
    r
}

/// User plus system time of this process (`/proc/self/stat`, in clock ticks of 1/100 s).
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            // fields after the command name, which is in parentheses
            let rest = s.rsplit_once(')')?.1;
            let f: Vec<&str> = rest.split_whitespace().collect();
            let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
            Some(ticks / 100.0)
        })
        .unwrap_or(f64::NAN)
}

/// Peak resident set size (`VmHWM`) in KiB, 0 where /proc is not available.
fn peak_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1).and_then(|v| v.parse().ok()))
        })
        .unwrap_or(0)
}

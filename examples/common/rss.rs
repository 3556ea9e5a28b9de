//! Shared by the examples that measure memory (included with `#[path]`).

/// This process's peak resident set size in MiB (`VmHWM` of `/proc/self/status`; NaN where
/// that file does not exist).
pub fn peak_rss_mib() -> f64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

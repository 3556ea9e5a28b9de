//! Process CPU time and an interleaved timing loop, shared by the timing examples
//! (`examples/perf.rs`, `sensitivity_count`, `dead_reckoning_count`).
#![allow(dead_code)]

/// Process CPU time in seconds (user + system, all threads): what the solve costs the
/// machine, not the wall clock, which moves with the other jobs on a shared machine.
#[cfg(target_os = "linux")]
pub fn cpu() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_PROCESS_CPUTIME_ID: i32 = 2;
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: `ts` is a valid `struct timespec` (two 64-bit fields on 64-bit Linux)
    let rc = unsafe { clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime failed");
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

/// Elsewhere: the wall clock (the figures in `docs/performance.md` are Linux CPU time).
#[cfg(not(target_os = "linux"))]
pub fn cpu() -> f64 {
    use std::sync::OnceLock;
    static T0: OnceLock<std::time::Instant> = OnceLock::new();
    T0.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

/// One contender: a name and a closure that runs the measured work `reps` times.
pub struct Contender<'a> {
    pub name: String,
    pub run: Box<dyn FnMut(usize) + 'a>,
}

impl<'a> Contender<'a> {
    pub fn new(name: impl Into<String>, run: impl FnMut(usize) + 'a) -> Self {
        Contender {
            name: name.into(),
            run: Box::new(run),
        }
    }
}

/// CPU seconds per call of each contender in each round: `t[c][r]`.
///
/// Every contender runs once untimed (warm-up, and its batch size: as many calls as fill
/// about `sample` seconds). Then `rounds` rounds, each timing one batch of every
/// contender, the order rotated by one each round (ABC, BCA, CAB, …), so contenders
/// alternate in time and none is always first after another's caches.
pub fn interleave(cs: &mut [Contender<'_>], rounds: usize, sample: f64) -> Vec<Vec<f64>> {
    let reps: Vec<usize> = cs
        .iter_mut()
        .map(|c| {
            let t0 = cpu();
            (c.run)(1);
            let t = (cpu() - t0).max(1e-9);
            ((sample / t).round() as usize).clamp(1, 10_000_000)
        })
        .collect();
    let n = cs.len();
    let mut t = vec![Vec::with_capacity(rounds); n];
    for r in 0..rounds {
        for i in 0..n {
            let c = (i + r) % n;
            let t0 = cpu();
            (cs[c].run)(reps[c]);
            t[c].push((cpu() - t0) / reps[c] as f64);
        }
    }
    t
}

/// Sorted copy.
fn sorted(v: &[f64]) -> Vec<f64> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s
}

/// Median.
pub fn median(v: &[f64]) -> f64 {
    let s = sorted(v);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// (min, max).
pub fn range(v: &[f64]) -> (f64, f64) {
    let s = sorted(v);
    (s[0], s[s.len() - 1])
}

/// Interquartile range (the 25th and 75th percentiles, by the nearest rank).
pub fn iqr(v: &[f64]) -> (f64, f64) {
    let s = sorted(v);
    let q = |p: f64| s[((p * (s.len() - 1) as f64).round()) as usize];
    (q(0.25), q(0.75))
}

/// Round-by-round ratios `a[r] / b[r]` (the two timed next to each other).
pub fn ratios(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(a, b)| a / b).collect()
}

/// `median (min–max)` of a ratio.
pub fn fmt_ratio(v: &[f64]) -> String {
    let (lo, hi) = range(v);
    format!("{:.3} ({:.3}–{:.3})", median(v), lo, hi)
}

/// A time with its unit, 3 significant digits.
pub fn fmt_t(s: f64) -> String {
    let (v, u) = if s >= 1.0 {
        (s, "s")
    } else if s >= 1e-3 {
        (s * 1e3, "ms")
    } else if s >= 1e-6 {
        (s * 1e6, "µs")
    } else {
        (s * 1e9, "ns")
    };
    let d = if v >= 100.0 {
        0
    } else if v >= 10.0 {
        1
    } else {
        2
    };
    format!("{v:.d$} {u}")
}

/// `median (min–max)` of a time.
pub fn fmt_time(v: &[f64]) -> String {
    let (lo, hi) = range(v);
    format!("{} ({}–{})", fmt_t(median(v)), fmt_t(lo), fmt_t(hi))
}

/// Geometric mean.
pub fn geomean(v: &[f64]) -> f64 {
    (v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp()
}

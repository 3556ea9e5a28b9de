//! Monte-Carlo ensembles on every core: many members of one problem (initial states,
//! parameter draws, noise seeds), statistics kept as members finish.
//!
//! Member `i` gets the seed `splitmix64(master + (i + 1)·γ)` ([`member_seed`]), so what it
//! computes depends only on the master seed and its index. The statistics
//! ([`Statistics`]: per saved time, the exact moments of [`Moments`] and quantile
//! [`Sketch`]es) are sums of integers and of exactly added floating-point terms, so the
//! result is **bit-identical for any number of threads, any order of completion and any
//! split into shards** ([`Shard`], [`Statistics::merge`]); memory is per thread and per
//! saved time, not per member.
//!
//! ```
//! use reckon::ensemble::{Ensemble, Layout};
//! use rand::Rng;
//! // x(1) = x₀·e for x' = x, x₀ ~ U(0, 1): mean e/2, variance e²/12
//! let layout = Layout::new(vec![1.0], vec!["x".into()], 1).unwrap();
//! let stats = Ensemble::new(20_000, 7)
//!     .run(&layout, |member, row| {
//!         let x0: f64 = member.rng().random();
//!         row[0] = x0 * 1f64.exp();
//!         Ok(())
//!     })
//!     .unwrap();
//! let e = 1f64.exp();
//! assert!((stats.mean(0)[0] - e / 2.0).abs() < 4.0 * e / (12f64 * 20_000.0).sqrt());
//! // the same statistics, bit for bit, on one thread
//! let one = Ensemble::new(20_000, 7).threads(1).run(&layout, |member, row| {
//!     let x0: f64 = member.rng().random();
//!     row[0] = x0 * 1f64.exp();
//!     Ok(())
//! });
//! assert_eq!(one.unwrap(), stats);
//! ```

pub mod encoder;
pub mod exact_sum;
pub mod quantile_sketch;
pub mod stats;

pub use exact_sum::ExactSum;
pub use quantile_sketch::Sketch;
pub use stats::{Moments, Snapshot};

use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};

/// The `i`-th output of a SplitMix64 generator started at `master`:
/// `z = master + (i + 1)·0x9E3779B97F4A7C15`, then Stafford's mix 13.
///
/// ```
/// use reckon::ensemble::member_seed;
/// // the first output of SplitMix64 seeded with 1234567 (Vigna's reference code)
/// assert_eq!(member_seed(1234567, 0), 6457827717110365317);
/// assert_ne!(member_seed(1, 0), member_seed(1, 1));
/// ```
pub fn member_seed(master: u64, index: u64) -> u64 {
    let mut z = master.wrapping_add(index.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// One member: its index in the whole ensemble, its seed ([`member_seed`]) and its
/// random generator, which lives as long as the member: every draw of the member comes
/// from one stream, so two draws are two different random numbers.
///
/// ```
/// use reckon::ensemble::{Member, member_seed};
/// use rand::Rng;
/// let mut m = Member::new(3, member_seed(7, 3));
/// let a: f64 = m.rng().random();
/// let b: f64 = m.rng().random();
/// assert_ne!(a, b); // the second draw continues the stream
/// // a member made again from the same index and seed draws the same numbers
/// let mut again = Member::new(3, member_seed(7, 3));
/// assert_eq!(again.rng().random::<f64>(), a);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Member {
    /// Index in `0..members`.
    pub index: u64,
    /// Seed derived from the master seed and the index.
    pub seed: u64,
    /// The generator, made at the first draw.
    rng: Option<StdRng>,
}

impl Member {
    /// Member `index` with seed `seed` (its generator not yet drawn from).
    pub fn new(index: u64, seed: u64) -> Self {
        Member { index, seed, rng: None }
    }

    /// The member's random generator (`StdRng`, ChaCha12, seeded with the member's seed
    /// at the first call): the same generator at every call, so successive draws
    /// continue one stream. Everything random in a member should come from here; what it
    /// draws then depends only on the master seed and the index, not on the threads or
    /// shards.
    pub fn rng(&mut self) -> &mut StdRng {
        let seed = self.seed;
        self.rng.get_or_insert_with(|| StdRng::seed_from_u64(seed))
    }
}

/// Members `index, index + count, index + 2·count, …` of the ensemble (`K/N` with `K` in
/// `0..N`): shards `0/N … (N−1)/N` together are the whole ensemble.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// `K`.
    pub index: u64,
    /// `N`.
    pub count: u64,
}

impl Shard {
    /// The whole ensemble (`0/1`).
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Shard `index` of `count`.
    pub fn new(index: u64, count: u64) -> Result<Shard> {
        if count == 0 || index >= count {
            return Err(Error::invalid(
                "shard",
                format!("{index}/{count}: need 0 ≤ K < N (shards are numbered from 0)"),
            ));
        }
        Ok(Shard { index, count })
    }

    /// How many of `members` this shard runs.
    pub fn len(&self, members: u64) -> u64 {
        if members > self.index {
            (members - self.index).div_ceil(self.count)
        } else {
            0
        }
    }

    /// Whether the shard runs no member of `members`.
    pub fn is_empty(&self, members: u64) -> bool {
        self.len(members) == 0
    }
}

impl std::str::FromStr for Shard {
    type Err = Error;
    fn from_str(s: &str) -> Result<Shard> {
        let bad = || Error::invalid("shard", format!("'{s}' is not K/N (for example 0/4)"));
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        Shard::new(
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        )
    }
}

/// What each member reports: a row of `names.len()` values at each of `times`, the first
/// `moments` of which enter the mean and covariance; every column gets a quantile sketch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "LayoutFile")]
pub struct Layout {
    /// The saved times.
    pub times: Vec<f64>,
    /// Column names.
    pub names: Vec<String>,
    /// Leading columns with mean and covariance.
    pub moments: usize,
}

impl Layout {
    /// Validated: finite times, `moments ≤ names.len()`, at least one column.
    pub fn new(times: Vec<f64>, names: Vec<String>, moments: usize) -> Result<Layout> {
        if names.is_empty() || moments > names.len() {
            return Err(Error::invalid(
                "layout",
                format!("{moments} moment columns of {} columns", names.len()),
            ));
        }
        if let Some(t) = times.iter().find(|t| !t.is_finite()) {
            return Err(Error::invalid("layout", format!("saved time {t} is not finite")));
        }
        Ok(Layout { times, names, moments })
    }

    fn width(&self) -> usize {
        self.names.len()
    }
}

/// [`Layout`] as stored, before [`Layout::new`]'s checks.
#[derive(Deserialize)]
struct LayoutFile {
    times: Vec<f64>,
    names: Vec<String>,
    moments: usize,
}

impl TryFrom<LayoutFile> for Layout {
    type Error = Error;
    fn try_from(f: LayoutFile) -> Result<Layout> {
        Layout::new(f.times, f.names, f.moments)
    }
}

/// An ensemble's statistics: per saved time a [`Snapshot`]; which members they cover
/// (the ensemble size, master seed and shards) and a free-form `job` description that
/// must match for [`Statistics::merge`].
///
/// Read from a file (serde, or [`Statistics::from_json`]), they are checked against
/// [`Statistics::validate`]'s invariants before they exist: a damaged or edited file is
/// refused with the field it got wrong, never merged into a wrong or partial answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "StatisticsFile")]
pub struct Statistics {
    /// What each member reported.
    pub layout: Layout,
    /// Members in the whole ensemble.
    pub members: u64,
    /// Master seed.
    pub seed: u64,
    /// Shard count `N` of the shards covered.
    pub shard_count: u64,
    /// The shard indices `K` covered, ascending.
    pub shards: Vec<u64>,
    /// What was run (the command line's model and options, set by the caller).
    pub job: String,
    /// One per saved time.
    pub snapshots: Vec<Snapshot>,
}

/// [`Statistics`] as stored, before [`Statistics::validate`].
#[derive(Deserialize)]
struct StatisticsFile {
    layout: Layout,
    members: u64,
    seed: u64,
    shard_count: u64,
    shards: Vec<u64>,
    job: String,
    snapshots: Vec<stats::SnapshotFile>,
}

impl TryFrom<StatisticsFile> for Statistics {
    type Error = Error;
    fn try_from(f: StatisticsFile) -> Result<Statistics> {
        let snapshots = f
            .snapshots
            .into_iter()
            .enumerate()
            .map(|(k, s)| {
                s.into_snapshot()
                    .map_err(|e| Error::invalid("statistics", format!("snapshots[{k}].{e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        let s = Statistics {
            layout: f.layout,
            members: f.members,
            seed: f.seed,
            shard_count: f.shard_count,
            shards: f.shards,
            job: f.job,
            snapshots,
        };
        s.validate()?;
        Ok(s)
    }
}

impl Statistics {
    /// Statistics from the JSON that serde writes (`reckon ensemble --stats`), checked
    /// ([`validate`](Self::validate)): [`Error::InvalidInput`] naming the field for
    /// anything else.
    ///
    /// ```
    /// use reckon::ensemble::{Ensemble, Layout, Shard, Statistics};
    /// let layout = Layout::new(vec![1.0], vec!["x".into()], 1).unwrap();
    /// let part = Ensemble::new(10, 1).shard(Shard::new(0, 2).unwrap()).run(&layout, |m, row| {
    ///     row[0] = m.index as f64;
    ///     Ok(())
    /// }).unwrap();
    /// let text = serde_json::to_string(&part).unwrap();
    /// assert_eq!(Statistics::from_json(&text).unwrap(), part);
    /// // the same counts presented as both shards: refused, naming the field
    /// let lie = text.replace(r#""shards":[0]"#, r#""shards":[0,1]"#);
    /// let e = Statistics::from_json(&lie).unwrap_err().to_string();
    /// assert!(e.contains("snapshots[0].moments.n: 5 members counted, but shards [0, 1] of 2 hold 10"), "{e}");
    /// ```
    pub fn from_json(text: &str) -> Result<Statistics> {
        serde_json::from_str(text).map_err(|e| match e.classify() {
            serde_json::error::Category::Data => {
                // a message from our own checks, or a missing or mistyped field
                let msg = e.to_string();
                Error::invalid(
                    "statistics",
                    msg.strip_prefix("invalid statistics: ").unwrap_or(&msg).to_string(),
                )
            }
            _ => Error::invalid("statistics", format!("not JSON ({e})")),
        })
    }

    /// Check the invariants every run and merge keeps: a valid [`Layout`]; at least one
    /// member; shard count `N ≥ 1` and shard indices ascending, distinct and below `N`;
    /// one snapshot per saved time with moments of the layout's moment columns and a
    /// sketch per column (each passing [`Snapshot::check`]); and at every saved time
    /// exactly the members of the shards covered counted, by the moments and by every
    /// sketch. `Err` ([`Error::InvalidInput`]) names the field.
    pub fn validate(&self) -> Result<()> {
        let bad = |reason: String| Err(Error::invalid("statistics", reason));
        let l = &self.layout;
        if let Err(e) = Layout::new(l.times.clone(), l.names.clone(), l.moments) {
            return bad(format!("layout: {e}"));
        }
        if self.members == 0 {
            return bad("members: 0 (an ensemble has at least one member)".into());
        }
        let n = self.shard_count;
        if n == 0 {
            return bad("shard_count: 0 (at least 1)".into());
        }
        if self.shards.is_empty() {
            return bad("shards: none".into());
        }
        if let Some(k) = self.shards.iter().find(|k| **k >= n) {
            return bad(format!("shards: {k} is not a shard of {n} (0 to {})", n - 1));
        }
        if let Some(w) = self.shards.windows(2).find(|w| w[0] >= w[1]) {
            return bad(format!("shards: {} then {} (each shard once, ascending)", w[0], w[1]));
        }
        let expected: u64 = self
            .shards
            .iter()
            .map(|k| Shard { index: *k, count: n }.len(self.members))
            .sum();
        if self.snapshots.len() != l.times.len() {
            return bad(format!(
                "snapshots: {} for {} saved times",
                self.snapshots.len(),
                l.times.len()
            ));
        }
        for (k, s) in self.snapshots.iter().enumerate() {
            if s.moments.dim() != l.moments {
                return bad(format!(
                    "snapshots[{k}].moments.dim: {}, but the layout has {} moment columns",
                    s.moments.dim(),
                    l.moments
                ));
            }
            if s.sketches.len() != l.names.len() {
                return bad(format!(
                    "snapshots[{k}].sketches: {} for {} columns",
                    s.sketches.len(),
                    l.names.len()
                ));
            }
            if let Err(e) = s.check() {
                return bad(format!("snapshots[{k}].{e}"));
            }
            if s.moments.count() != expected {
                return bad(format!(
                    "snapshots[{k}].moments.n: {} members counted, but shards {:?} of {n} hold {expected}",
                    s.moments.count(),
                    self.shards
                ));
            }
            if let Some(i) = s.sketches.iter().position(|q| q.count() != expected) {
                return bad(format!(
                    "snapshots[{k}].sketches[{i}]: {} values, but shards {:?} of {n} hold {expected} members",
                    s.sketches[i].count(),
                    self.shards
                ));
            }
        }
        Ok(())
    }

    fn empty(layout: &Layout) -> Vec<Snapshot> {
        layout
            .times
            .iter()
            .map(|_| Snapshot::new(layout.moments, layout.width()))
            .collect()
    }

    /// Members counted.
    pub fn count(&self) -> u64 {
        self.snapshots.first().map_or(0, |s| s.moments.count())
    }

    /// Mean of the moment columns at saved time `k`.
    pub fn mean(&self, k: usize) -> DVector<f64> {
        self.snapshots[k].moments.mean()
    }

    /// Covariance of the moment columns at saved time `k`.
    pub fn covariance(&self, k: usize) -> DMatrix<f64> {
        self.snapshots[k].moments.covariance()
    }

    /// Quantile `q` of column `column` at saved time `k`.
    pub fn quantile(&self, k: usize, column: usize, q: f64) -> Option<f64> {
        self.snapshots[k].sketches[column].quantile(q)
    }

    /// Add the statistics of other shards of the same ensemble: the result is exactly
    /// the statistics of the union (bit for bit what one run over those members gives).
    /// Refused if either side fails [`validate`](Self::validate), if the layout, job,
    /// size, seed or shard count differ, or if a shard is in both.
    pub fn merge(&mut self, other: &Statistics) -> Result<()> {
        self.validate()?;
        other.validate()?;
        let same = self.layout == other.layout
            && self.job == other.job
            && self.members == other.members
            && self.seed == other.seed
            && self.shard_count == other.shard_count;
        if !same {
            return Err(Error::invalid(
                "shards",
                format!(
                    "not of one ensemble: {} members, seed {}, {} shards, job '{}' vs {} members, seed {}, {} shards, job '{}'{}",
                    self.members,
                    self.seed,
                    self.shard_count,
                    self.job,
                    other.members,
                    other.seed,
                    other.shard_count,
                    other.job,
                    if self.layout != other.layout {
                        " (and different saved times or columns)"
                    } else {
                        ""
                    }
                ),
            ));
        }
        if let Some(k) = other.shards.iter().find(|k| self.shards.contains(k)) {
            return Err(Error::invalid(
                "shards",
                format!("shard {k}/{} is counted twice", self.shard_count),
            ));
        }
        let mut merged = self.snapshots.clone();
        for (a, b) in merged.iter_mut().zip(&other.snapshots) {
            a.merge(b)?;
        }
        self.snapshots = merged;
        self.shards.extend(&other.shards);
        self.shards.sort_unstable();
        Ok(())
    }

    /// Whether every shard of the ensemble is counted.
    pub fn is_complete(&self) -> bool {
        self.shards.len() as u64 == self.shard_count
    }
}

/// The most worker threads an ensemble runs on ([`Ensemble::threads`]): each has its
/// own stack and accumulators, and more threads than cores only add their cost.
pub const MAX_THREADS: usize = 1024;

/// A callback told `(done, total)` each time a member of the shard finishes, from the
/// worker threads (so it must be `Send + Sync`); `done` counts up to `total`. The command
/// draws its progress bar with one; a service can report to its client.
///
/// ```
/// use reckon::ensemble::{Ensemble, Layout, Progress};
/// use std::sync::atomic::{AtomicU64, Ordering};
/// use std::sync::Arc;
///
/// let seen = Arc::new(AtomicU64::new(0));
/// let s = seen.clone();
/// let layout = Layout::new(vec![0.0], vec!["x".into()], 1).unwrap();
/// let e = Ensemble::new(10, 1).on_progress(Progress::new(move |done, total| {
///     assert!(done <= total && total == 10);
///     s.fetch_max(done, Ordering::Relaxed);
/// }));
/// e.run(&layout, |_, rows| { rows[0] = 1.0; Ok(()) }).unwrap();
/// assert_eq!(seen.load(Ordering::Relaxed), 10);
/// ```
#[derive(Clone)]
pub struct Progress(std::sync::Arc<dyn Fn(u64, u64) + Send + Sync>);

impl Progress {
    /// Wrap `f(done, total)`.
    pub fn new(f: impl Fn(u64, u64) + Send + Sync + 'static) -> Self {
        Progress(std::sync::Arc::new(f))
    }
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress(..)")
    }
}

/// Two callbacks are equal when they are the same one.
impl PartialEq for Progress {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

/// How to run an ensemble: size, master seed, shard, threads, progress callback.
#[derive(Debug, Clone, PartialEq)]
pub struct Ensemble {
    /// Members in the whole ensemble.
    pub members: u64,
    /// Master seed.
    pub seed: u64,
    /// Which members this run takes.
    pub shard: Shard,
    /// Worker threads (`None`: rayon's global pool, one per core).
    pub threads: Option<usize>,
    /// Told about every finished member ([`Progress`]).
    pub progress: Option<Progress>,
    /// Recorded in the statistics, compared by [`Statistics::merge`].
    pub job: String,
}

impl Ensemble {
    /// `members` members from master seed `seed`, all of them, on every core.
    pub fn new(members: u64, seed: u64) -> Self {
        Ensemble {
            members,
            seed,
            shard: Shard::ALL,
            threads: None,
            progress: None,
            job: String::new(),
        }
    }

    /// Run only shard `shard`.
    pub fn shard(mut self, shard: Shard) -> Self {
        self.shard = shard;
        self
    }

    /// Use `n` worker threads (1 to [`MAX_THREADS`]; others are refused by `run`).
    pub fn threads(mut self, n: usize) -> Self {
        self.threads = Some(n);
        self
    }

    /// Report every finished member to `p`.
    pub fn on_progress(mut self, p: Progress) -> Self {
        self.progress = Some(p);
        self
    }

    /// Describe the job (checked when shards are merged).
    pub fn job(mut self, job: impl Into<String>) -> Self {
        self.job = job.into();
        self
    }

    /// Run every member of the shard: `member(m, rows)` fills `rows` (the saved times one
    /// after the other, `layout.names.len()` values each) or fails; `m` is the member,
    /// with its own generator ([`Member::rng`]). A member that fails,
    /// or reports a NaN, ends the run with [`Error::EnsembleMember`] for the lowest such
    /// index (members above it may be skipped, members below it all run), so the error
    /// too is the same for any number of threads.
    pub fn run<F>(&self, layout: &Layout, member: F) -> Result<Statistics>
    where
        F: Fn(&mut Member, &mut [f64]) -> Result<()> + Sync,
    {
        if self.members == 0 {
            return Err(Error::invalid("members", "an ensemble needs at least one member"));
        }
        Shard::new(self.shard.index, self.shard.count)?;
        if let Some(n) = self.threads
            && !(1..=MAX_THREADS).contains(&n)
        {
            return Err(Error::invalid(
                "threads",
                format!("{n}: need 1 to {MAX_THREADS} worker threads"),
            ));
        }
        let work = || self.run_here(layout, &member);
        let snapshots = match self.threads {
            None => work()?,
            Some(n) => rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| Error::invalid("threads", e.to_string()))?
                .install(work)?,
        };
        Ok(Statistics {
            layout: layout.clone(),
            members: self.members,
            seed: self.seed,
            shard_count: self.shard.count,
            shards: vec![self.shard.index],
            job: self.job.clone(),
            snapshots,
        })
    }

    fn run_here<F>(&self, layout: &Layout, member: &F) -> Result<Vec<Snapshot>>
    where
        F: Fn(&mut Member, &mut [f64]) -> Result<()> + Sync,
    {
        let count = self.shard.len(self.members);
        let width = layout.width();
        let size = width * layout.times.len();
        let first_failure = AtomicU64::new(u64::MAX);
        let finished = AtomicU64::new(0);
        let tick = || {
            if let Some(p) = &self.progress {
                (p.0)(finished.fetch_add(1, Ordering::Relaxed) + 1, count);
            }
        };
        struct Acc {
            snapshots: Vec<Snapshot>,
            rows: Vec<f64>,
            failure: Option<(u64, u64, Error)>,
        }
        let fresh = || Acc {
            snapshots: Statistics::empty(layout),
            rows: vec![0.0; size],
            failure: None,
        };
        let count = usize::try_from(count)
            .map_err(|_| Error::invalid("members", format!("{count} members per shard is too many")))?;
        let done = (0..count)
            .into_par_iter()
            // a few pieces per thread: each piece has its own accumulators, merged at the end
            .with_min_len((count / (8 * rayon::current_num_threads())).max(16))
            .fold(fresh, |mut acc, j| {
                let index = self.shard.index + j as u64 * self.shard.count;
                if index > first_failure.load(Ordering::Relaxed) {
                    return acc;
                }
                let mut m = Member::new(index, member_seed(self.seed, index));
                acc.rows.fill(0.0);
                let outcome =
                    member(&mut m, &mut acc.rows).and_then(|()| match acc.rows.iter().position(|v| v.is_nan()) {
                        Some(p) => Err(Error::invalid(
                            "member output",
                            format!(
                                "'{}' at t = {} is NaN",
                                layout.names[p % width],
                                crate::error::Brief(layout.times[p / width])
                            ),
                        )),
                        None => Ok(()),
                    });
                match outcome {
                    Ok(()) => {
                        for (s, row) in acc.snapshots.iter_mut().zip(acc.rows.chunks_exact(width)) {
                            s.add(row);
                        }
                    }
                    Err(e) => {
                        first_failure.fetch_min(index, Ordering::Relaxed);
                        if acc.failure.as_ref().is_none_or(|f| index < f.0) {
                            acc.failure = Some((index, m.seed, e));
                        }
                    }
                }
                tick();
                acc
            })
            .reduce(fresh, |mut a, b| {
                for (x, y) in a.snapshots.iter_mut().zip(&b.snapshots) {
                    // the same layout on both sides, at most the shard's members counted
                    x.merge(y).expect("snapshots of one layout merge");
                }
                match (&a.failure, b.failure) {
                    (Some(f), Some(g)) if g.0 < f.0 => a.failure = Some(g),
                    (None, g) => a.failure = g,
                    _ => {}
                }
                a
            });
        match done.failure {
            Some((index, seed, e)) => Err(Error::EnsembleMember {
                index,
                seed,
                reason: Box::new(e),
            }),
            None => Ok(done.snapshots),
        }
    }

    /// Run an ODE ensemble: `solve(m)` returns member `m`'s solution (drawing its random
    /// inputs from [`Member::rng`]) saved at exactly the
    /// layout's times ([`Save::At`](crate::Save::At), which must include `t0` if it is a
    /// saved time); its states are the rows (`layout.names.len()` must be the state
    /// dimension).
    ///
    /// ```
    /// use reckon::ensemble::{Ensemble, Layout};
    /// use reckon::{model, methods::Rk45, Options, Problem, Save};
    /// use nalgebra::vector;
    /// use rand_distr::{Distribution, Normal};
    /// // x' = −x, x₀ ~ N(1, 0.1²): x(1) ~ N(e⁻¹, (0.1·e⁻¹)²)
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let layout = Layout::new(vec![1.0], vec!["x".into()], 1).unwrap();
    /// let opts = Options::default().rtol(1e-10).atol(1e-12).save(Save::At(vec![1.0]));
    /// let stats = Ensemble::new(4000, 1)
    ///     .solve(&layout, |m| {
    ///         let x0 = Normal::new(1.0, 0.1).unwrap().sample(m.rng());
    ///         Problem::new(&f, vector![x0], (0.0, 1.0)).solve(Rk45, &opts)
    ///     })
    ///     .unwrap();
    /// let sd = stats.covariance(0)[(0, 0)].sqrt();
    /// assert!((sd / (0.1 * (-1f64).exp()) - 1.0).abs() < 0.05);
    /// ```
    pub fn solve<D, F>(&self, layout: &Layout, solve: F) -> Result<Statistics>
    where
        D: nalgebra::Dim,
        nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D>,
        F: Fn(&mut Member) -> Result<crate::Solution<D>> + Sync,
    {
        let width = layout.width();
        self.run(layout, |m, rows| {
            let sol = solve(m)?;
            if sol.t != layout.times {
                return Err(Error::invalid(
                    "member solution",
                    format!(
                        "saved at {} times, not at the layout's {} (use Save::At with the layout's times)",
                        sol.t.len(),
                        layout.times.len()
                    ),
                ));
            }
            for (row, x) in rows.chunks_exact_mut(width).zip(&sol.x) {
                if x.len() != width {
                    return Err(Error::invalid(
                        "member solution",
                        format!("state dimension {} but {width} columns", x.len()),
                    ));
                }
                row.copy_from_slice(x.as_slice());
            }
            Ok(())
        })
    }
}

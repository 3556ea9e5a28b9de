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
pub mod exact;
pub mod sketch;
pub mod stats;

pub use exact::ExactSum;
pub use sketch::Sketch;
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

/// One member: its index in the whole ensemble and its seed ([`member_seed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Member {
    /// Index in `0..members`.
    pub index: u64,
    /// Seed derived from the master seed and the index.
    pub seed: u64,
}

impl Member {
    /// A random generator seeded with the member's seed (`StdRng`, ChaCha12).
    pub fn rng(&self) -> StdRng {
        StdRng::seed_from_u64(self.seed)
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

/// An ensemble's statistics: per saved time a [`Snapshot`]; which members they cover
/// (the ensemble size, master seed and shards) and a free-form `job` description that
/// must match for [`Statistics::merge`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

impl Statistics {
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
    /// Refused if the layout, job, size, seed or shard count differ, or a shard appears
    /// twice.
    pub fn merge(&mut self, other: &Statistics) -> Result<()> {
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
        for (a, b) in self.snapshots.iter_mut().zip(&other.snapshots) {
            a.merge(b);
        }
        self.shards.extend(&other.shards);
        self.shards.sort_unstable();
        Ok(())
    }

    /// Whether every shard of the ensemble is counted.
    pub fn is_complete(&self) -> bool {
        self.shards.len() as u64 == self.shard_count
    }
}

/// How to run an ensemble: size, master seed, shard, threads, progress bar.
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
    /// Draw a progress bar on standard error when it is a terminal.
    pub progress: bool,
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
            progress: false,
            job: String::new(),
        }
    }

    /// Run only shard `shard`.
    pub fn shard(mut self, shard: Shard) -> Self {
        self.shard = shard;
        self
    }

    /// Use `n` worker threads.
    pub fn threads(mut self, n: usize) -> Self {
        self.threads = Some(n);
        self
    }

    /// Show a progress bar (on a terminal).
    pub fn progress(mut self, on: bool) -> Self {
        self.progress = on;
        self
    }

    /// Describe the job (checked when shards are merged).
    pub fn job(mut self, job: impl Into<String>) -> Self {
        self.job = job.into();
        self
    }

    /// Run every member of the shard: `member(m, rows)` fills `rows` (the saved times one
    /// after the other, `layout.names.len()` values each) or fails. A member that fails,
    /// or reports a NaN, ends the run with [`Error::EnsembleMember`] for the lowest such
    /// index (members above it may be skipped, members below it all run), so the error
    /// too is the same for any number of threads.
    pub fn run<F>(&self, layout: &Layout, member: F) -> Result<Statistics>
    where
        F: Fn(&Member, &mut [f64]) -> Result<()> + Sync,
    {
        if self.members == 0 {
            return Err(Error::invalid("members", "an ensemble needs at least one member"));
        }
        Shard::new(self.shard.index, self.shard.count)?;
        if self.threads == Some(0) {
            return Err(Error::invalid("threads", "need at least one thread"));
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
        F: Fn(&Member, &mut [f64]) -> Result<()> + Sync,
    {
        let count = self.shard.len(self.members);
        let width = layout.width();
        let size = width * layout.times.len();
        let first_failure = AtomicU64::new(u64::MAX);
        let bar = if self.progress {
            let b = indicatif::ProgressBar::new(count);
            b.set_style(
                indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} members  {elapsed} (eta {eta})")
                    .expect("a valid template"),
            );
            b
        } else {
            indicatif::ProgressBar::hidden()
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
                let m = Member {
                    index,
                    seed: member_seed(self.seed, index),
                };
                acc.rows.fill(0.0);
                let outcome = member(&m, &mut acc.rows).and_then(|()| match acc.rows.iter().position(|v| v.is_nan()) {
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
                bar.inc(1);
                acc
            })
            .reduce(fresh, |mut a, b| {
                for (x, y) in a.snapshots.iter_mut().zip(&b.snapshots) {
                    x.merge(y);
                }
                match (&a.failure, b.failure) {
                    (Some(f), Some(g)) if g.0 < f.0 => a.failure = Some(g),
                    (None, g) => a.failure = g,
                    _ => {}
                }
                a
            });
        bar.finish_and_clear();
        match done.failure {
            Some((index, seed, e)) => Err(Error::EnsembleMember {
                index,
                seed,
                reason: Box::new(e),
            }),
            None => Ok(done.snapshots),
        }
    }

    /// Run an ODE ensemble: `solve(m)` returns member `m`'s solution saved at exactly the
    /// layout's times ([`Save::At`](crate::Save::At), which must include `t0` if it is a
    /// saved time); its states are the rows (`layout.names.len()` must be the state
    /// dimension).
    ///
    /// ```
    /// use reckon::ensemble::{Ensemble, Layout};
    /// use reckon::{model, methods::Dopri5, Options, Problem, Save};
    /// use nalgebra::vector;
    /// use rand_distr::{Distribution, Normal};
    /// // x' = −x, x₀ ~ N(1, 0.1²): x(1) ~ N(e⁻¹, (0.1·e⁻¹)²)
    /// let f = model!(|_t, x: [S; 1]| vector![-x[0]]);
    /// let layout = Layout::new(vec![1.0], vec!["x".into()], 1).unwrap();
    /// let opts = Options::default().rtol(1e-10).atol(1e-12).save(Save::At(vec![1.0]));
    /// let stats = Ensemble::new(4000, 1)
    ///     .solve(&layout, |m| {
    ///         let x0 = Normal::new(1.0, 0.1).unwrap().sample(&mut m.rng());
    ///         Problem::new(&f, vector![x0], (0.0, 1.0)).solve(Dopri5::default(), &opts)
    ///     })
    ///     .unwrap();
    /// let sd = stats.covariance(0)[(0, 0)].sqrt();
    /// assert!((sd / (0.1 * (-1f64).exp()) - 1.0).abs() < 0.05);
    /// ```
    pub fn solve<D, F>(&self, layout: &Layout, solve: F) -> Result<Statistics>
    where
        D: nalgebra::Dim,
        nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D>,
        F: Fn(&Member) -> Result<crate::Solution<D>> + Sync,
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

//! Monte-Carlo ensembles from Python: the encoder-robot ensemble of
//! `reckon::ensemble::encoder` run on every core with the GIL released, and its
//! [`Statistics`] (exact, mergeable, JSON) as `reckon.Statistics`.
//!
//! Member `i` of an ensemble of master seed `s` draws from `splitmix64(s + (i+1)·γ)`
//! only, so a shard `K/N` (members `K, K+N, …`) gives the same bytes wherever and
//! however often it runs, and the merge of shards `0/N … (N−1)/N` is bit for bit the
//! statistics of the whole: what `reckon.dask` builds on.

use crate::errors;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::{PyIndexError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use rand_distr::{Distribution, StandardNormal};
use reckon::Problem;
use reckon::ensemble::encoder::EncoderEnsemble;
use reckon::ensemble::{Ensemble, Layout, Shard, Statistics as Stats};
use reckon::linalg::LuDim;
use reckon::nalgebra::allocator::Allocator;
use reckon::nalgebra::{Const, DefaultAllocator, Dyn, OVector};
use reckon::reckoning::encoder_sim::{Command, EncoderErrors};
use reckon::reckoning::encoders::{DiffDrive, Update};

/// Encoder samples one call may drive in all (members of the shard × samples per
/// member), as `reckon ensemble`: 10¹², about 20 core-hours. More is refused up front.
const MAX_RUN_SAMPLES: f64 = 1e12;

/// The model of `reckon.EncoderEnsemble`, as the Python class passes it: a dict of its
/// arguments, already shaped (`commands` rows of `(v, ω, duration)`, numbers as floats).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct Spec {
    commands: Vec<(f64, f64, f64)>,
    dt: f64,
    wheel_diameter: f64,
    wheel_separation: f64,
    pulses_per_rev: f64,
    left_scale: f64,
    right_scale: f64,
    wheelbase_scale: f64,
    slip: f64,
    pulse_noise: f64,
    quantize: bool,
    diameter_sigma: f64,
    wheelbase_sigma: f64,
    update: String,
    /// `None`: at most 200 saved times.
    save_every: Option<usize>,
}

/// FNV-1a over the bits of the commands: identifies them in the job description.
fn fingerprint(commands: &[(f64, f64, f64)]) -> u64 {
    commands
        .iter()
        .flat_map(|(v, w, d)| [v.to_bits(), w.to_bits(), d.to_bits()])
        .flat_map(u64::to_le_bytes)
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
        })
}

impl Spec {
    /// The validated ensemble and its job description (every input that changes a
    /// member's result, floats in round-trip form): shards merge only with equal jobs.
    fn build(&self) -> reckon::Result<(EncoderEnsemble, String)> {
        let Spec {
            commands: cmds,
            dt,
            wheel_diameter: d,
            wheel_separation: b,
            pulses_per_rev: ppr,
            diameter_sigma: dsig,
            wheelbase_sigma: bsig,
            save_every: every,
            ..
        } = self;
        let robot = DiffDrive::new(*d, *b, *ppr)?;
        let update: Update = self.update.parse()?;
        let errors = EncoderErrors {
            left_scale: self.left_scale,
            right_scale: self.right_scale,
            wheelbase_scale: self.wheelbase_scale,
            quantize: self.quantize,
            slip_sigma: self.slip,
            pulse_noise: self.pulse_noise,
            seed: 0,
        };
        let commands: Vec<Command> = cmds
            .iter()
            .map(|&(v, omega, duration)| Command { v, omega, duration })
            .collect();
        if *every == Some(0) {
            return Err(reckon::Error::invalid("save_every", "0: need at least 1"));
        }
        let every = every.unwrap_or(commands.len().div_ceil(200).max(1));
        let mut drive = EncoderEnsemble::new(robot, errors, commands, *dt)?
            .spreads(*dsig, *bsig)?
            .save_every(every);
        drive.update = update;
        let job = format!(
            "model unicycle (Python); commands {:016x} ({} rows); dt {dt:?}; update {update:?}; \
             geometry {d:?} {b:?} {ppr:?}; errors {errors:?}; spreads {dsig:?} {bsig:?}; every {every}",
            fingerprint(cmds),
            cmds.len(),
        );
        Ok((drive, job))
    }
}

/// `(job, saved times, encoder samples per member)` of a model, or `reckon.InvalidInput`.
#[pyfunction]
pub(crate) fn encoder_plan(py: Python<'_>, spec: Spec) -> PyResult<(String, Vec<f64>, f64)> {
    let (drive, job) = spec.build().map_err(|e| errors::to_py(py, &e))?;
    Ok((job, drive.layout().times, drive.samples_per_member()))
}

/// Run shard `shard = (K, N)` of `members` members from master seed `seed` on `threads`
/// threads (`None`: one per core), with the GIL released.
#[pyfunction]
#[pyo3(signature = (spec, members, seed, shard, threads))]
pub(crate) fn encoder_run(
    py: Python<'_>,
    spec: Spec,
    members: u64,
    seed: u64,
    shard: (u64, u64),
    threads: Option<usize>,
) -> PyResult<Statistics> {
    let run = || -> reckon::Result<Stats> {
        let (drive, job) = spec.build()?;
        let shard = Shard::new(shard.0, shard.1)?;
        if members == 0 {
            return Err(reckon::Error::invalid(
                "members",
                "0: an ensemble needs at least one member",
            ));
        }
        let work = shard.len(members) as f64 * drive.samples_per_member();
        if work > MAX_RUN_SAMPLES {
            return Err(reckon::Error::invalid(
                "members",
                format!(
                    "{} members of shard {}/{} × {} encoder samples = {work:e} samples in one call; at most {MAX_RUN_SAMPLES:e} (use more shards or a longer dt)",
                    shard.len(members),
                    shard.index,
                    shard.count,
                    drive.samples_per_member()
                ),
            ));
        }
        let mut runner = Ensemble::new(members, seed).shard(shard).job(job);
        runner.threads = threads;
        let layout = drive.layout();
        py.detach(|| runner.run(&layout, |m, rows| drive.member(m, rows)))
    };
    run()
        .map(|inner| Statistics { inner })
        .map_err(|e| errors::to_py(py, &e))
}

/// An ensemble's statistics, per saved time: the exact count, mean and covariance of the
/// moment columns (`ex`, `ey`, `etheta` for the encoder ensemble) and quantile sketches of
/// every column (relative accuracy 0.4 %). `merge` combines other shards of the same
/// ensemble exactly; `to_json` / `from_json` carry them between processes.
#[pyclass(module = "reckon", name = "Statistics", frozen, eq)]
#[derive(PartialEq)]
pub(crate) struct Statistics {
    inner: Stats,
}

impl Statistics {
    /// Saved time `k` (negative counts from the end, as Python's indices).
    fn time_index(&self, k: i64) -> PyResult<usize> {
        let n = self.inner.layout.times.len() as i64;
        let i = if k < 0 { k + n } else { k };
        if (0..n).contains(&i) {
            Ok(i as usize)
        } else {
            Err(PyIndexError::new_err(format!("saved time {k} of {n} (0 to {})", n - 1)))
        }
    }
}

#[pymethods]
impl Statistics {
    /// The statistics as JSON (what `reckon ensemble --stats` writes): exact sums, so
    /// `Statistics.from_json(s.to_json()) == s`.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner).map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// Statistics from JSON, checked against the invariants every run keeps (shards each
    /// once and below the shard count, members counted matching the shards, one snapshot
    /// per saved time…): `reckon.InvalidInput` naming the field otherwise.
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Statistics> {
        Stats::from_json(text)
            .map(|inner| Statistics { inner })
            .map_err(|e| errors::to_py(py, &e))
    }

    /// The statistics of the union of these shards and `other`'s, bit for bit what one
    /// run over those members gives (neither operand changes). `reckon.InvalidInput`
    /// (`what = "shards"`) when they are not of one ensemble (members, seed, shard count,
    /// job, saved times) or share a shard: a shard counted twice would be a wrong answer.
    fn merge(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<Statistics> {
        let other = other.cast::<Statistics>().map_err(|_| {
            PyTypeError::new_err(format!(
                "merge takes reckon.Statistics, not {}",
                other.get_type().name().map(|n| n.to_string()).unwrap_or_default()
            ))
        })?;
        let mut merged = self.inner.clone();
        merged.merge(&other.get().inner).map_err(|e| errors::to_py(py, &e))?;
        Ok(Statistics { inner: merged })
    }

    /// Members counted.
    #[getter]
    fn count(&self) -> u64 {
        self.inner.count()
    }

    /// Members in the whole ensemble.
    #[getter]
    fn members(&self) -> u64 {
        self.inner.members
    }

    /// Master seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.inner.seed
    }

    /// `N` of the shards `K/N` counted.
    #[getter]
    fn shard_count(&self) -> u64 {
        self.inner.shard_count
    }

    /// The shards `K` counted, ascending.
    #[getter]
    fn shards(&self) -> Vec<u64> {
        self.inner.shards.clone()
    }

    /// Whether every shard is counted.
    #[getter]
    fn complete(&self) -> bool {
        self.inner.is_complete()
    }

    /// What was run (compared by `merge`).
    #[getter]
    fn job(&self) -> String {
        self.inner.job.clone()
    }

    /// The saved times.
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.layout.times)
    }

    /// Column names; the first `moments` have a mean and covariance.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner.layout.names.clone()
    }

    /// How many leading columns have a mean and covariance.
    #[getter]
    fn moments(&self) -> usize {
        self.inner.layout.moments
    }

    /// Mean `Σx / n` of the moment columns at saved time `k` (shape `(moments,)`).
    fn mean<'py>(&self, py: Python<'py>, k: i64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let k = self.time_index(k)?;
        Ok(PyArray1::from_slice(py, self.inner.mean(k).as_slice()))
    }

    /// Unbiased covariance `(n·Σxxᵀ − Σx·Σxᵀ) / (n(n−1))` of the moment columns at saved
    /// time `k` (shape `(moments, moments)`; NaN with fewer than two members).
    fn covariance<'py>(&self, py: Python<'py>, k: i64) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let k = self.time_index(k)?;
        let c = self.inner.covariance(k);
        let rows: Vec<Vec<f64>> = c.row_iter().map(|r| r.iter().copied().collect()).collect();
        Ok(PyArray2::from_vec2(py, &rows)?)
    }

    /// Quantile `q` (0 ≤ q ≤ 1) of `column` (an index or a name) at saved time `k`, to a
    /// relative 0.4 %; `None` when nothing was counted.
    fn quantile(&self, py: Python<'_>, k: i64, column: &Bound<'_, PyAny>, q: f64) -> PyResult<Option<f64>> {
        let k = self.time_index(k)?;
        let names = &self.inner.layout.names;
        let c = if let Ok(name) = column.extract::<String>() {
            names
                .iter()
                .position(|n| *n == name)
                .ok_or_else(|| errors::invalid(py, "column", format!("'{name}' is not one of {names:?}")))?
        } else {
            let i: i64 = column.extract()?;
            if !(0..names.len() as i64).contains(&i) {
                return Err(PyIndexError::new_err(format!(
                    "column {i} of {} (0 to {})",
                    names.len(),
                    names.len() - 1
                )));
            }
            i as usize
        };
        if !(0.0..=1.0).contains(&q) {
            return Err(errors::invalid(py, "q", format!("{q}: need 0 ≤ q ≤ 1")));
        }
        Ok(self.inner.quantile(k, c, q))
    }

    /// Pickled as its JSON (checked again when read).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let rebuild = py.import("reckon")?.getattr("_statistics_from_json")?;
        Ok((rebuild, (self.to_json()?,)))
    }

    fn __repr__(&self) -> String {
        let s = &self.inner;
        format!(
            "Statistics({} of {} members, seed {}, shards {:?} of {}, {} saved times, columns {:?})",
            s.count(),
            s.members,
            s.seed,
            s.shards,
            s.shard_count,
            s.layout.times.len(),
            s.layout.names
        )
    }
}

/// Members of a traced-model ensemble one call may integrate in all, times the saved
/// times: the rows the statistics take (10¹¹, hours of work). More is refused up front.
const MAX_RUN_ROWS: f64 = 1e11;

/// Run shard `shard = (K, N)` of `members` members of the traced `model` (state `z` of
/// `mean.len()` components, the first `n` reported) from master seed `seed`, on
/// `threads` threads (`None`: one per core) with the GIL released. Member `i` starts at
/// `z₀ = mean + F·ξ`, `F` the row-major `factor` (`F·Fᵀ` the covariance) and `ξ` the
/// first `mean.len()` standard normals of its generator, and is integrated from `t0` to
/// `t1` by `method`, saved at `times`; its rows are `z(tₖ)[..n]`.
#[pyfunction]
#[pyo3(signature = (model, n, mean, factor, t0, t1, times, method, rtol, atol, first_step, max_step, max_steps, members, seed, shard, threads, job))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn model_run(
    py: Python<'_>,
    model: Bound<'_, crate::traced::Model>,
    n: usize,
    mean: Vec<f64>,
    factor: Vec<f64>,
    t0: f64,
    t1: f64,
    times: Vec<f64>,
    method: &str,
    rtol: Vec<f64>,
    atol: Vec<f64>,
    first_step: Option<f64>,
    max_step: f64,
    max_steps: Option<usize>,
    members: u64,
    seed: u64,
    shard: (u64, u64),
    threads: Option<usize>,
    job: String,
) -> PyResult<Statistics> {
    let m = model.get();
    let big = mean.len();
    let check = || -> reckon::Result<()> {
        if big != m.n || n == 0 || n > big || factor.len() != big * big {
            return Err(reckon::Error::invalid(
                "ensemble",
                format!(
                    "{big} initial values, {} factor entries and {n} reported states for a model of {} states",
                    factor.len(),
                    m.n
                ),
            ));
        }
        if let Some(v) = mean.iter().chain(&factor).find(|v| !v.is_finite()) {
            return Err(reckon::Error::invalid(
                "ensemble",
                format!("{v} in the mean or covariance factor"),
            ));
        }
        if members == 0 {
            return Err(reckon::Error::invalid(
                "members",
                "0: an ensemble needs at least one member",
            ));
        }
        let shard = Shard::new(shard.0, shard.1)?;
        let rows = shard.len(members) as f64 * times.len() as f64;
        if rows > MAX_RUN_ROWS {
            return Err(reckon::Error::invalid(
                "members",
                format!(
                    "{} members of shard {}/{} × {} saved times = {rows:e} rows in one call; at most {MAX_RUN_ROWS:e} (use more shards)",
                    shard.len(members),
                    shard.index,
                    shard.count,
                    times.len()
                ),
            ));
        }
        Ok(())
    };
    check().map_err(|e| errors::to_py(py, &e))?;
    let opts = crate::options(
        py,
        method,
        rtol,
        atol,
        first_step,
        max_step,
        None,
        Some(times.clone()),
        false,
        max_steps,
    )?;
    let layout = Layout::new(times, (0..n).map(|i| format!("y{i}")).collect(), n).map_err(|e| errors::to_py(py, &e))?;
    let mut runner = Ensemble::new(members, seed)
        .shard(Shard::new(shard.0, shard.1).map_err(|e| errors::to_py(py, &e))?)
        .job(job);
    runner.threads = threads;
    let plan = Plan {
        model: m,
        n,
        mean: &mean,
        factor: &factor,
        span: (t0, t1),
        method,
        opts: &opts,
    };
    // small models on fixed-size states, as `solve_traced` (stack vectors, a stack LU)
    macro_rules! fixed {
        ($($k:literal)*) => {
            match big {
                $($k => py.detach(|| plan.run::<Const<$k>>(&runner, &layout)),)*
                _ => py.detach(|| plan.run::<Dyn>(&runner, &layout)),
            }
        };
    }
    fixed!(1 2 3 4 5 6 7 8)
        .map(|inner| Statistics { inner })
        .map_err(|e| errors::to_py(py, &e))
}

/// One traced-model ensemble: what every member shares.
struct Plan<'a> {
    model: &'a crate::traced::Model,
    n: usize,
    mean: &'a [f64],
    factor: &'a [f64],
    span: (f64, f64),
    method: &'a str,
    opts: &'a reckon::Options,
}

impl Plan<'_> {
    fn run<D: LuDim>(&self, runner: &Ensemble, layout: &Layout) -> reckon::Result<Stats>
    where
        DefaultAllocator: Allocator<D> + Allocator<D, D>,
    {
        let big = self.mean.len();
        let n = self.n;
        runner.run(layout, |member, rows| {
            let xi: Vec<f64> = (0..big).map(|_| StandardNormal.sample(member.rng())).collect();
            let z0 = (0..big).map(|i| {
                let row = &self.factor[i * big..(i + 1) * big];
                row.iter().zip(&xi).fold(self.mean[i], |acc, (f, x)| acc + f * x)
            });
            let sys = crate::traced::TracedSystem::new(self.model);
            let x0 = OVector::<f64, D>::from_iterator_generic(D::from_usize(big), Const::<1>, z0);
            let sol = crate::run(Problem::new(&sys, x0, self.span), self.method, self.opts)?;
            if sol.t != layout.times {
                return Err(reckon::Error::invalid(
                    "member solution",
                    format!(
                        "saved at {} times, not at the {} of t_eval (stopped at t = {})",
                        sol.t.len(),
                        layout.times.len(),
                        sol.t.last().copied().unwrap_or(self.span.0)
                    ),
                ));
            }
            for (row, x) in rows.chunks_exact_mut(n).zip(&sol.x) {
                row.copy_from_slice(&x.as_slice()[..n]);
            }
            Ok(())
        })
    }
}

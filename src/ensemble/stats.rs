//! Streaming, mergeable, order-independent statistics: exact first and second moments,
//! extremes, and quantile sketches, per saved time.

use super::exact::{ExactSum, fast_two_sum, two_sum};
use super::sketch::Sketch;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Count, mean, covariance and extremes of vectors of dimension `d`, from the exact sums
/// `Σ xᵢ` and `Σ xᵢxⱼ` ([`ExactSum`]): any split of the members between threads or
/// shards, merged in any order, gives the same bits.
///
/// The mean is `Σxᵢ / n` (to about 2⁻¹⁰⁴, then rounded) and the covariance is the
/// unbiased `(n·Σxᵢxⱼ − Σxᵢ·Σxⱼ) / (n·(n − 1))` with the numerator computed exactly in
/// integer arithmetic and rounded once, so a spread of 1e-3 around a mean of 1e9 keeps
/// all its digits (the textbook one-pass formula in f64 keeps none).
///
/// ```
/// use reckon::ensemble::Moments;
/// let mut m = Moments::new(1);
/// for x in [1e9 + 1e-3, 1e9 - 1e-3, 1e9 + 2e-3, 1e9 - 2e-3] {
///     m.add(&[x]);
/// }
/// assert_eq!(m.mean()[0], 1e9);
/// // the stored values are 1e9 ± 0.0010000228881836 and ± 0.0019999980926514
/// let d = [1e9 + 1e-3 - 1e9, 1e9 + 2e-3 - 1e9];
/// let var = 2.0 * (d[0] * d[0] + d[1] * d[1]) / 3.0;
/// assert!((m.covariance()[(0, 0)] - var).abs() < 1e-15 * var);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Moments {
    n: u64,
    dim: usize,
    /// `Σ xᵢ`.
    s1: Vec<ExactSum>,
    /// `Σ xᵢxⱼ`, `i ≤ j`, row by row.
    s2: Vec<ExactSum>,
    min: Vec<f64>,
    max: Vec<f64>,
}

impl Moments {
    /// No samples yet, dimension `dim`.
    pub fn new(dim: usize) -> Self {
        Moments {
            n: 0,
            dim,
            s1: vec![ExactSum::default(); dim],
            s2: vec![ExactSum::default(); dim * (dim + 1) / 2],
            min: vec![f64::INFINITY; dim],
            max: vec![f64::NEG_INFINITY; dim],
        }
    }

    /// Count one sample (its first `dim` values).
    pub fn add(&mut self, x: &[f64]) {
        let mut k = 0;
        for i in 0..self.dim {
            self.s1[i].add(x[i]);
            for j in i..self.dim {
                self.s2[k].add_product(x[i], x[j]);
                k += 1;
            }
            if x[i].total_cmp(&self.min[i]).is_lt() {
                self.min[i] = x[i];
            }
            if x[i].total_cmp(&self.max[i]).is_gt() {
                self.max[i] = x[i];
            }
        }
        self.n += 1;
    }

    /// Add another set of samples (same dimension).
    pub fn merge(&mut self, other: &Moments) {
        assert_eq!(self.dim, other.dim, "merging moments of different dimensions");
        for (a, b) in self.s1.iter_mut().zip(&other.s1) {
            a.merge(b);
        }
        for (a, b) in self.s2.iter_mut().zip(&other.s2) {
            a.merge(b);
        }
        for i in 0..self.dim {
            if other.min[i].total_cmp(&self.min[i]).is_lt() {
                self.min[i] = other.min[i];
            }
            if other.max[i].total_cmp(&self.max[i]).is_gt() {
                self.max[i] = other.max[i];
            }
        }
        self.n += other.n;
    }

    /// Number of samples.
    pub fn count(&self) -> u64 {
        self.n
    }

    /// Dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Smallest value seen of each component (`+∞` before any sample).
    pub fn min(&self) -> &[f64] {
        &self.min
    }

    /// Largest value seen of each component.
    pub fn max(&self) -> &[f64] {
        &self.max
    }

    fn mean_dd(&self, i: usize) -> (f64, f64) {
        dd_div(self.s1[i].value_dd(), self.n as f64)
    }

    /// The sample mean (NaN components before any sample).
    pub fn mean(&self) -> DVector<f64> {
        DVector::from_fn(self.dim, |i, _| {
            let (h, l) = self.mean_dd(i);
            h + l
        })
    }

    /// The unbiased sample covariance (NaN with fewer than two samples).
    pub fn covariance(&self) -> DMatrix<f64> {
        let mut c = DMatrix::from_element(self.dim, self.dim, f64::NAN);
        if self.n < 2 {
            return c;
        }
        let mut k = 0;
        for i in 0..self.dim {
            for j in i..self.dim {
                let v = super::exact::covariance(&self.s2[k], &self.s1[i], &self.s1[j], self.n);
                c[(i, j)] = v;
                c[(j, i)] = v;
                k += 1;
            }
        }
        c
    }
}

impl Moments {
    /// The mean normalised estimation error squared over the samples, taken as errors of
    /// a filter whose covariance is `p`: `(1/n)·Σ eᵢᵀ p⁻¹ eᵢ = tr(p⁻¹·M)` with the raw
    /// second moment `M = (1/n)·Σ eᵢeᵢᵀ = C·(n − 1)/n + ē·ēᵀ`. For a consistent filter
    /// `n·NEES ~ χ²` with `n·d` degrees of freedom ([`chi2_interval`]).
    pub fn mean_nees(&self, p: &DMatrix<f64>) -> Result<f64> {
        let n = self.n as f64;
        let mean = self.mean();
        let raw = self.covariance() * ((n - 1.0) / n) + &mean * mean.transpose();
        let chol = p.clone().cholesky().ok_or(Error::NotPositiveDefinite {
            what: "the filter covariance",
        })?;
        Ok(chol.solve(&raw).trace())
    }
}

/// The two-sided interval of a χ² variable with `k` degrees of freedom holding
/// probability `Φ(z) − Φ(−z)` (z = 1.96: 95 %), by the Wilson–Hilferty cube-root
/// normal approximation `k·(1 − 2/(9k) ± z·√(2/(9k)))³` (relative error below 1e-3 for
/// k ≥ 30).
///
/// ```
/// use reckon::ensemble::stats::chi2_interval;
/// let (lo, hi) = chi2_interval(100.0, 1.959964);
/// assert!((lo - 74.2219).abs() < 0.05 && (hi - 129.5612).abs() < 0.05);
/// ```
pub fn chi2_interval(k: f64, z: f64) -> (f64, f64) {
    let c = 2.0 / (9.0 * k);
    let q = |s: f64| k * (1.0 - c + s * z * c.sqrt()).max(0.0).powi(3);
    (q(-1.0), q(1.0))
}

/// `(a.0 + a.1) / d` in double-double.
fn dd_div(a: (f64, f64), d: f64) -> (f64, f64) {
    let q1 = a.0 / d;
    if !q1.is_finite() {
        return (q1, 0.0);
    }
    // remainder a − q1·d exactly (q1·d = p + e), then the second quotient digit
    let p = q1 * d;
    let e = q1.mul_add(d, -p);
    let (s, f) = two_sum(a.0, -p);
    let r = s + (f - e + a.1);
    fast_two_sum(q1, r / d)
}

/// The statistics of one saved time: [`Moments`] of the first `dim` columns and a
/// [`Sketch`] of every column.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Exact moments of the leading columns.
    pub moments: Moments,
    /// One quantile sketch per column.
    pub sketches: Vec<Sketch>,
}

impl Snapshot {
    /// Empty, for `columns` values of which the first `dim` enter the moments.
    pub fn new(dim: usize, columns: usize) -> Self {
        Snapshot {
            moments: Moments::new(dim),
            sketches: vec![Sketch::default(); columns],
        }
    }

    /// Count one member's row.
    pub fn add(&mut self, row: &[f64]) {
        self.moments.add(row);
        for (s, v) in self.sketches.iter_mut().zip(row) {
            s.add(*v);
        }
    }

    /// Add another snapshot's counts.
    pub fn merge(&mut self, other: &Snapshot) {
        self.moments.merge(&other.moments);
        for (a, b) in self.sketches.iter_mut().zip(&other.sketches) {
            a.merge(b);
        }
    }
}

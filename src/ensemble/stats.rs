//! Streaming, mergeable, order-independent statistics: exact first and second moments,
//! extremes, and quantile sketches, per saved time.

use super::exact_sum::{ExactSum, StoredSum, fast_two_sum, two_sum};
use super::quantile_sketch::{Sketch, SketchFile};
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
#[serde(try_from = "MomentsFile")]
pub struct Moments {
    n: u64,
    dim: usize,
    /// `Σ xᵢ`.
    s1: Vec<ExactSum>,
    /// `Σ xᵢxⱼ`, `i ≤ j`, row by row.
    s2: Vec<ExactSum>,
    #[serde(serialize_with = "extremes::serialize")]
    min: Vec<f64>,
    #[serde(serialize_with = "extremes::serialize")]
    max: Vec<f64>,
}

/// [`Moments`] as stored, before [`Moments::check`]; the sums' limb windows are checked
/// as they are read ([`ExactSum::from_stored`]), each error naming its field.
#[derive(Deserialize)]
pub(crate) struct MomentsFile {
    n: u64,
    dim: usize,
    s1: Vec<StoredSum>,
    s2: Vec<StoredSum>,
    #[serde(deserialize_with = "extremes::min")]
    min: Vec<f64>,
    #[serde(deserialize_with = "extremes::max")]
    max: Vec<f64>,
}

impl MomentsFile {
    /// The moments, or why not (naming the field).
    pub(crate) fn into_moments(self) -> std::result::Result<Moments, String> {
        let sums = |name: &str, v: Vec<StoredSum>| {
            v.iter()
                .enumerate()
                .map(|(i, s)| ExactSum::from_stored(s).map_err(|e| format!("{name}[{i}]: {e}")))
                .collect::<std::result::Result<Vec<_>, _>>()
        };
        let m = Moments {
            n: self.n,
            dim: self.dim,
            s1: sums("s1", self.s1)?,
            s2: sums("s2", self.s2)?,
            min: self.min,
            max: self.max,
        };
        m.check()?;
        Ok(m)
    }
}

impl TryFrom<MomentsFile> for Moments {
    type Error = Error;
    fn try_from(f: MomentsFile) -> Result<Moments> {
        f.into_moments().map_err(|reason| Error::invalid("moments", reason))
    }
}

/// Extremes as JSON: finite values as numbers, `±∞` (the extremes before any sample) and
/// NaN as the strings `"inf"`, `"-inf"`, `"NaN"` (JSON has no such numbers).
mod extremes {
    use serde::de::Error as _;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    #[serde(untagged)]
    enum Value {
        Number(f64),
        Word(String),
    }

    pub fn serialize<S: Serializer>(v: &[f64], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(v.iter().map(|x| match *x {
            x if x.is_finite() => Value::Number(x),
            f64::INFINITY => Value::Word("inf".into()),
            f64::NEG_INFINITY => Value::Word("-inf".into()),
            _ => Value::Word("NaN".into()),
        }))
    }

    /// The `min` field.
    pub fn min<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        read(d, "min")
    }

    /// The `max` field.
    pub fn max<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        read(d, "max")
    }

    fn read<'de, D: Deserializer<'de>>(d: D, field: &str) -> Result<Vec<f64>, D::Error> {
        Vec::<Option<Value>>::deserialize(d)?
            .into_iter()
            .map(|v| match v {
                Some(Value::Number(x)) => Ok(x),
                Some(Value::Word(w)) => match w.as_str() {
                    "inf" => Ok(f64::INFINITY),
                    "-inf" => Ok(f64::NEG_INFINITY),
                    "NaN" => Ok(f64::NAN),
                    _ => Err(D::Error::custom(format!(
                        "{field}: '{w}' is not a number (nor \"inf\", \"-inf\", \"NaN\")"
                    ))),
                },
                None => Err(D::Error::custom(format!(
                    "{field}: null is not a number (infinities are written \"inf\", \"-inf\")"
                ))),
            })
            .collect()
    }
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

    /// Add another set of samples of the same dimension ([`Error::InvalidInput`] for
    /// another dimension, or when the count would pass 2⁶⁴).
    pub fn merge(&mut self, other: &Moments) -> Result<()> {
        if self.dim != other.dim {
            return Err(Error::invalid(
                "moments",
                format!("merging dimension {} into dimension {}", other.dim, self.dim),
            ));
        }
        let n = self
            .n
            .checked_add(other.n)
            .ok_or_else(|| Error::invalid("moments", "the sample count passes 2⁶⁴"))?;
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
        self.n = n;
        Ok(())
    }

    /// Whether these are moments that adding samples can make (`Err` names the field):
    /// `dim` sums `Σxᵢ`, `dim·(dim + 1)/2` sums `Σxᵢxⱼ`, `dim` extremes; no more
    /// non-finite terms in a sum than samples; before any sample, zero sums and the
    /// extremes `+∞`, `−∞`; after, `min ≤ max` and a finite mean between them.
    ///
    /// ```
    /// use reckon::ensemble::Moments;
    /// let mut m = Moments::new(2);
    /// m.add(&[1.0, 2.0]);
    /// assert!(m.check().is_ok());
    /// let mut text = serde_json::to_string(&m).unwrap();
    /// text = text.replace(r#""dim":2"#, r#""dim":3"#);
    /// let e = serde_json::from_str::<Moments>(&text).unwrap_err().to_string();
    /// assert!(e.contains("s1: 2 sums for dimension 3"), "{e}");
    /// ```
    pub fn check(&self) -> std::result::Result<(), String> {
        let d = self.dim;
        let pairs = d
            .checked_add(1)
            .and_then(|d1| d1.checked_mul(d))
            .map(|p| p / 2)
            .ok_or_else(|| format!("dim: {d} is too large"))?;
        for (name, len, want) in [("s1", self.s1.len(), d), ("s2", self.s2.len(), pairs)] {
            if len != want {
                return Err(format!("{name}: {len} sums for dimension {d} (need {want})"));
            }
        }
        for (name, len) in [("min", self.min.len()), ("max", self.max.len())] {
            if len != d {
                return Err(format!("{name}: {len} values for dimension {d}"));
            }
        }
        let n = self.n;
        for (name, sums) in [("s1", &self.s1), ("s2", &self.s2)] {
            for (i, s) in sums.iter().enumerate() {
                let special = s.special().iter().map(|c| u64::from(*c)).sum::<u64>();
                if special > n {
                    return Err(format!("{name}[{i}]: {special} non-finite terms in {n} samples"));
                }
                if n == 0 && !s.is_zero() {
                    return Err(format!("{name}[{i}]: not zero with no samples"));
                }
            }
        }
        for i in 0..d {
            let (lo, hi) = (self.min[i], self.max[i]);
            if n == 0 {
                if lo != f64::INFINITY || hi != f64::NEG_INFINITY {
                    return Err(format!(
                        "min[{i}], max[{i}]: {lo}, {hi} with no samples (need inf, -inf)"
                    ));
                }
                continue;
            }
            if lo.total_cmp(&hi).is_gt() {
                return Err(format!("min[{i}] = {lo} is above max[{i}] = {hi}"));
            }
            // the non-finite terms of Σxᵢ are those the extremes show
            let [plus, minus, nan] = self.s1[i].special().map(|c| c > 0);
            let any_nan = lo.is_nan() || hi.is_nan();
            if plus != (hi == f64::INFINITY || (plus && hi.is_nan()))
                || minus != (lo == f64::NEG_INFINITY || (minus && lo.is_nan()))
                || nan != any_nan
            {
                return Err(format!(
                    "s1[{i}].special: {:?} (+∞, −∞, NaN terms) with min {lo} and max {hi}",
                    self.s1[i].special()
                ));
            }
            if self.s1[i].special() == [0; 3] {
                let mean = self.mean_of(i);
                if mean.is_finite() && !(lo <= mean && mean <= hi) {
                    return Err(format!("s1[{i}]: the mean {mean} is outside [min, max] = [{lo}, {hi}]"));
                }
            }
        }
        // |Σxᵢ| ≤ n·Mᵢ and |Σxᵢxⱼ| ≤ n·Mᵢ·Mⱼ with Mᵢ = max |xᵢ| (a little slack for the
        // rounding of the bound and the product terms that underflow), Σxᵢ² ≥ 0
        if n > 0 {
            let m: Vec<f64> = (0..d).map(|i| self.min[i].abs().max(self.max[i].abs())).collect();
            let nf = n as f64;
            let beyond = |v: f64, bound: f64| bound.is_finite() && v.abs() > bound * (1.0 + 1e-9) + nf * 1e-290;
            let mut k = 0;
            for i in 0..d {
                if self.s1[i].special() == [0; 3] && beyond(self.s1[i].value(), nf * m[i]) {
                    return Err(format!(
                        "s1[{i}]: the sum {} is beyond n·max|x| = {}",
                        self.s1[i].value(),
                        nf * m[i]
                    ));
                }
                for j in i..d {
                    let s = &self.s2[k];
                    let finite = self.s1[i].special() == [0; 3] && self.s1[j].special() == [0; 3];
                    if finite && (m[i] * m[j]).is_finite() && s.special() != [0; 3] {
                        return Err(format!(
                            "s2[{k}].special: {:?} non-finite products of values within ±{} and ±{}",
                            s.special(),
                            m[i],
                            m[j]
                        ));
                    }
                    if s.special() == [0; 3] {
                        let v = s.value();
                        if beyond(v, nf * m[i] * m[j]) || (i == j && v < 0.0) {
                            return Err(format!(
                                "s2[{k}]: the sum of products {v} is not within ±n·max|xᵢ|·max|xⱼ| = {}{}",
                                nf * m[i] * m[j],
                                if i == j { " (and ≥ 0)" } else { "" }
                            ));
                        }
                    }
                    k += 1;
                }
            }
            // a mean that overflows needs values near the top of the range
            for (i, mi) in m.iter().enumerate() {
                if self.s1[i].special() == [0; 3] && !self.mean_of(i).is_finite() && *mi < f64::MAX / nf {
                    return Err(format!("s1[{i}]: the mean is not finite, but no value exceeds {mi}"));
                }
            }
        }
        Ok(())
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

    fn mean_of(&self, i: usize) -> f64 {
        let (h, l) = self.mean_dd(i);
        h + l
    }

    /// The sample mean (NaN components before any sample).
    pub fn mean(&self) -> DVector<f64> {
        DVector::from_fn(self.dim, |i, _| self.mean_of(i))
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
                let v = super::exact_sum::covariance(&self.s2[k], &self.s1[i], &self.s1[j], self.n);
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
#[serde(try_from = "SnapshotFile")]
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

    /// Add another snapshot's counts (refused for another number of columns or moments).
    pub fn merge(&mut self, other: &Snapshot) -> Result<()> {
        if self.sketches.len() != other.sketches.len() {
            return Err(Error::invalid(
                "snapshot",
                format!("merging {} columns into {}", other.sketches.len(), self.sketches.len()),
            ));
        }
        self.moments.merge(&other.moments)?;
        for (a, b) in self.sketches.iter_mut().zip(&other.sketches) {
            a.merge(b);
        }
        Ok(())
    }

    /// Whether this is a snapshot that adding rows can make (`Err` names the field): its
    /// [`Moments`] and [`Sketch`]es pass their checks, at least as many sketches as moment
    /// columns, and no sketch counts more values than the moments count samples (fewer
    /// when rows held NaN, which a sketch ignores).
    pub fn check(&self) -> std::result::Result<(), String> {
        self.moments.check().map_err(|e| format!("moments.{e}"))?;
        let (n, dim) = (self.moments.count(), self.moments.dim());
        if self.sketches.len() < dim {
            return Err(format!("sketches: {} for {dim} moment columns", self.sketches.len()));
        }
        for (i, s) in self.sketches.iter().enumerate() {
            s.check().map_err(|e| format!("sketches[{i}].{e}"))?;
            if s.count() > n {
                return Err(format!("sketches[{i}]: {} values for {n} samples", s.count()));
            }
        }
        Ok(())
    }
}

/// [`Snapshot`] as stored, before its checks.
#[derive(Deserialize)]
pub(crate) struct SnapshotFile {
    moments: MomentsFile,
    sketches: Vec<SketchFile>,
}

impl SnapshotFile {
    /// The snapshot, or why not (naming the field).
    pub(crate) fn into_snapshot(self) -> std::result::Result<Snapshot, String> {
        let s = Snapshot {
            moments: self.moments.into_moments().map_err(|e| format!("moments.{e}"))?,
            sketches: self
                .sketches
                .into_iter()
                .enumerate()
                .map(|(i, f)| f.into_sketch().map_err(|e| format!("sketches[{i}].{e}")))
                .collect::<std::result::Result<_, _>>()?,
        };
        s.check()?;
        Ok(s)
    }
}

impl TryFrom<SnapshotFile> for Snapshot {
    type Error = Error;
    fn try_from(f: SnapshotFile) -> Result<Snapshot> {
        f.into_snapshot().map_err(|reason| Error::invalid("snapshot", reason))
    }
}

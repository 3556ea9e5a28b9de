//! A mergeable quantile sketch with relative accuracy `2⁻⁸` (log-linear buckets).
//!
//! A finite `x ≠ 0` falls in the bucket of its sign, its binary exponent and the top
//! [`MANTISSA_BITS`] bits of its significand — the key is simply the top bits of
//! `|x|.to_bits()`, so it is the same on every machine (no `ln`, as DDSketch uses, whose
//! last bit may differ between libm versions and move a value across a bucket edge). A
//! bucket `[a, a·(1 + 2⁻⁷))` is reported by its midpoint, within `2⁻⁸ = 0.39 %` of every
//! value in it. Counts are integers, so merging sketches is exact and order-free; memory
//! grows with the range of magnitudes seen (128 buckets per octave), not with the count.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Significand bits in a bucket key.
pub const MANTISSA_BITS: u32 = 7;
/// The relative accuracy of a reported quantile: `2^−(MANTISSA_BITS+1)`.
pub const RELATIVE_ACCURACY: f64 = 1.0 / (1u64 << (MANTISSA_BITS + 1)) as f64;

/// Quantiles of a stream of values to relative accuracy [`RELATIVE_ACCURACY`] (see the
/// [module docs](self)): `q` is answered by the bucket holding the sample of rank
/// `⌊q·(n − 1)⌋` (zero-based, ascending), so the answer `v` satisfies
/// `|v − x₍ᵣ₎| ≤ 2⁻⁸·|x₍ᵣ₎|`.
///
/// ```
/// use reckon::ensemble::Sketch;
/// let mut s = Sketch::default();
/// for k in 1..=1000 {
///     s.add(k as f64);
/// }
/// let median = s.quantile(0.5).unwrap(); // the sample of rank 499 is 500
/// assert!((median - 500.0).abs() <= 500.0 / 256.0);
/// assert_eq!(s.count(), 1000);
/// ```
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "SketchFile")]
pub struct Sketch {
    /// Counts of positive values by key.
    positive: BTreeMap<u32, u64>,
    /// Counts of negative values by the key of their magnitude.
    negative: BTreeMap<u32, u64>,
    /// Zeros and subnormals (|x| < 2⁻¹⁰²²), reported as 0.
    zero: u64,
}

/// A sketch as stored, before [`Sketch::check`].
#[derive(Deserialize)]
pub(crate) struct SketchFile {
    positive: BTreeMap<u32, u64>,
    negative: BTreeMap<u32, u64>,
    zero: u64,
}

impl SketchFile {
    /// The sketch, or why not (naming the field).
    pub(crate) fn into_sketch(self) -> Result<Sketch, String> {
        let s = Sketch {
            positive: self.positive,
            negative: self.negative,
            zero: self.zero,
        };
        s.check()?;
        Ok(s)
    }
}

impl TryFrom<SketchFile> for Sketch {
    type Error = crate::Error;
    fn try_from(f: SketchFile) -> crate::Result<Sketch> {
        f.into_sketch()
            .map_err(|reason| crate::Error::invalid("sketch", reason))
    }
}

/// The key of the smallest normal magnitude, `2⁻¹⁰²²`.
const KEY_MIN: u32 = (f64::MIN_POSITIVE.to_bits() >> (52 - MANTISSA_BITS)) as u32;
/// The key of `∞` (the top bucket).
const KEY_MAX: u32 = (f64::INFINITY.to_bits() >> (52 - MANTISSA_BITS)) as u32;

fn key(m: f64) -> u32 {
    (m.to_bits() >> (52 - MANTISSA_BITS)) as u32
}

fn midpoint(key: u32) -> f64 {
    let lower = f64::from_bits((key as u64) << (52 - MANTISSA_BITS));
    let upper = f64::from_bits(((key as u64) + 1) << (52 - MANTISSA_BITS));
    if upper.is_finite() {
        0.5 * lower + 0.5 * upper
    } else {
        lower
    }
}

impl Sketch {
    /// Count `x` (NaN is not a value and is ignored; `±∞` land in the top buckets).
    pub fn add(&mut self, x: f64) {
        if x.is_nan() {
            return;
        }
        let m = x.abs();
        if m < f64::MIN_POSITIVE {
            self.zero += 1;
        } else if x > 0.0 {
            *self.positive.entry(key(m)).or_insert(0) += 1;
        } else {
            *self.negative.entry(key(m)).or_insert(0) += 1;
        }
    }

    /// Add another sketch's counts.
    pub fn merge(&mut self, other: &Sketch) {
        for (k, c) in &other.positive {
            *self.positive.entry(*k).or_insert(0) += c;
        }
        for (k, c) in &other.negative {
            *self.negative.entry(*k).or_insert(0) += c;
        }
        self.zero += other.zero;
    }

    /// Number of values counted.
    pub fn count(&self) -> u64 {
        self.zero + self.positive.values().sum::<u64>() + self.negative.values().sum::<u64>()
    }

    /// The `q`-quantile (`0 ≤ q ≤ 1`), `None` if nothing was counted or `q` is outside.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        let n = self.count();
        if n == 0 || !(0.0..=1.0).contains(&q) {
            return None;
        }
        let rank = (q * (n - 1) as f64).floor() as u64;
        let mut seen = 0u64;
        for (k, c) in self.negative.iter().rev() {
            seen += c;
            if seen > rank {
                return Some(-midpoint(*k));
            }
        }
        seen += self.zero;
        if seen > rank {
            return Some(0.0);
        }
        for (k, c) in &self.positive {
            seen += c;
            if seen > rank {
                return Some(midpoint(*k));
            }
        }
        None
    }

    /// Whether the sketch is one that adding values can make: every key that of a normal
    /// magnitude or `∞`, and the total count within `u64`. `Err` names the field.
    ///
    /// ```
    /// use reckon::ensemble::Sketch;
    /// let mut s = Sketch::default();
    /// s.add(3.0);
    /// assert!(s.check().is_ok());
    /// let bad: Result<Sketch, _> = serde_json::from_str(r#"{"positive":{"4294967295":1},"negative":{},"zero":0}"#);
    /// assert!(bad.unwrap_err().to_string().contains("positive"));
    /// ```
    pub fn check(&self) -> Result<(), String> {
        for (name, map) in [("positive", &self.positive), ("negative", &self.negative)] {
            if let Some(k) = map.keys().find(|k| !(KEY_MIN..=KEY_MAX).contains(*k)) {
                return Err(format!(
                    "{name}: bucket key {k} is not one of a value (keys {KEY_MIN} to {KEY_MAX})"
                ));
            }
        }
        self.positive
            .values()
            .chain(self.negative.values())
            .try_fold(self.zero, |a, c| a.checked_add(*c))
            .ok_or_else(|| "the counts add up beyond 2⁶⁴".to_string())?;
        Ok(())
    }

    /// Number of buckets in use (the sketch's memory is about 24 bytes each).
    pub fn buckets(&self) -> usize {
        self.positive.len() + self.negative.len() + usize::from(self.zero > 0)
    }
}

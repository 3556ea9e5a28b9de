//! An exact, order-independent sum of `f64` values (a long fixed-point accumulator).
//!
//! `Σ xᵢ` is kept as a signed integer multiple of `2⁻¹¹²⁰` spread over 32-bit limbs held
//! in `i64`s (31 bits of headroom for carries), so adding is exact and the sum does not
//! depend on the order of the terms or on how they were split between threads, shards or
//! machines. Products are added exactly too ([`ExactSum::add_product`]: `a·b = p + e`
//! with `e = fma(a, b, −p)`), which makes second moments exact.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Bits per limb.
const BITS: u32 = 32;
/// Limb `i` weighs `2^(32·(i + BASE))`: every finite f64 (the smallest subnormal is
/// 2⁻¹⁰⁷⁴) is an integer multiple of `2^(32·BASE) = 2⁻¹¹²⁰`.
const BASE: i32 = -35;
/// Limbs an exact sum of f64 terms can occupy: `0..LIMBS`. The lowest bit of the
/// smallest subnormal is in limb 1; a sum of at most 2⁶⁵ terms (products add two each)
/// below 2¹⁰²⁴ is below 2¹⁰⁸⁹ = 2^(32·68.03 − 1120), so its top limb is at most 69.
pub const LIMBS: i32 = 70;
/// Adds between two carry normalisations: each add moves a limb by less than 2³², so a
/// limb stays below 2⁶¹ + 2³² and the sum of two accumulators' limbs ([`ExactSum::merge`])
/// cannot overflow an `i64`.
const HEADROOM: u32 = 1 << 29;

/// `Σ xᵢ` exactly (see the [module docs](self)); `±∞` and NaN terms are counted apart
/// and make the result `±∞`/NaN as IEEE addition would.
///
/// ```
/// use reckon::ensemble::ExactSum;
/// let mut s = ExactSum::default();
/// for x in [1e100, 1.0, -1e100] {
///     s.add(x);
/// }
/// assert_eq!(s.value(), 1.0); // summed left to right in f64: 0
/// let mut t = ExactSum::default();
/// t.add(0.1);
/// t.add(0.2);
/// t.add(-0.3);
/// assert_eq!(t.value(), 2f64.powi(-55)); // 0.1 + 0.2 − 0.3 of the stored doubles, exactly
/// ```
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(into = "StoredSum", try_from = "StoredSum")]
pub struct ExactSum {
    /// Index (in limbs of 32 bits, from `BASE`) of `limbs[0]`.
    lo: i32,
    limbs: Vec<i64>,
    /// Adds since the last normalisation.
    pending: u32,
    /// `+∞`, `−∞` and NaN terms.
    special: [u32; 3],
}

impl ExactSum {
    /// Add `x` exactly.
    pub fn add(&mut self, x: f64) {
        if !x.is_finite() {
            let k = if x.is_nan() {
                2
            } else if x > 0.0 {
                0
            } else {
                1
            };
            self.special[k] = self.special[k].saturating_add(1);
            return;
        }
        if x == 0.0 {
            return;
        }
        let bits = x.to_bits();
        let exp = ((bits >> 52) & 0x7ff) as i32;
        let frac = bits & ((1u64 << 52) - 1);
        // x = ±m·2^(e) with integer m < 2^53
        let (m, e) = if exp == 0 {
            (frac, -1074)
        } else {
            (frac | (1 << 52), exp - 1075)
        };
        let shifted = e - BASE * BITS as i32; // ≥ 0 for every finite f64
        let (q, r) = (shifted.div_euclid(BITS as i32), shifted.rem_euclid(BITS as i32));
        let wide = (m as u128) << r; // < 2^85: three limbs
        let neg = x < 0.0;
        for k in 0..3 {
            let chunk = ((wide >> (BITS * k)) & 0xffff_ffff) as i64;
            if chunk != 0 {
                let slot = self.slot(q + k as i32);
                self.limbs[slot] += if neg { -chunk } else { chunk };
            }
        }
        self.pending += 1;
        if self.pending >= HEADROOM {
            self.normalise();
        }
    }

    /// Add `a·b` exactly (the rounded product and its rounding error, `fma(a, b, −a·b)`;
    /// exact unless the error term underflows, below about 2⁻⁹⁶⁹ in magnitude).
    pub fn add_product(&mut self, a: f64, b: f64) {
        let p = a * b;
        self.add(p);
        if p.is_finite() {
            self.add(a.mul_add(b, -p));
        }
    }

    /// Add another sum exactly.
    pub fn merge(&mut self, other: &ExactSum) {
        for (k, v) in other.limbs.iter().enumerate() {
            if *v != 0 {
                let slot = self.slot(other.lo + k as i32);
                self.limbs[slot] += v;
            }
        }
        for k in 0..3 {
            self.special[k] = self.special[k].saturating_add(other.special[k]);
        }
        self.pending += other.pending.max(1);
        // both sides hold limbs below 2^62 in magnitude: the sum fits, then carry
        self.normalise();
    }

    /// Index into `limbs` of absolute limb `i`, growing the window as needed.
    fn slot(&mut self, i: i32) -> usize {
        if self.limbs.is_empty() {
            self.lo = i;
            self.limbs.push(0);
        }
        if i < self.lo {
            let grow = (self.lo - i) as usize;
            self.limbs.splice(0..0, std::iter::repeat_n(0, grow));
            self.lo = i;
        }
        let k = (i - self.lo) as usize;
        if k >= self.limbs.len() {
            self.limbs.resize(k + 1, 0);
        }
        k
    }

    /// Propagate carries: every limb but the top one in `[0, 2³²)`.
    fn normalise(&mut self) {
        let mut carry = 0i64;
        for v in self.limbs.iter_mut() {
            let s = *v + carry;
            carry = s >> BITS;
            *v = s - (carry << BITS);
        }
        while carry != 0 && carry != -1 {
            let s = carry;
            carry = s >> BITS;
            self.limbs.push(s - (carry << BITS));
        }
        if carry == -1 {
            // the top limb takes the sign: value = Σ limbs·2^… − 2^(32·len)
            if let Some(t) = self.limbs.last_mut() {
                *t -= 1 << BITS;
            }
        }
        self.pending = 0;
    }

    /// The exact value as sign and magnitude limbs (least significant first, no zero
    /// limbs at either end) with the index of the lowest: unique for each value.
    fn canonical(&self) -> (bool, i32, Vec<u32>) {
        let mut c = self.clone();
        c.normalise();
        let neg = c.limbs.last().is_some_and(|t| *t < 0);
        if neg {
            for v in c.limbs.iter_mut() {
                *v = -*v;
            }
            c.normalise();
        }
        let mut lo = c.lo;
        let mut mag: Vec<u32> = c.limbs.iter().map(|v| *v as u32).collect();
        debug_assert!(c.limbs.iter().all(|v| (0..1 << BITS).contains(v)));
        while mag.last() == Some(&0) {
            mag.pop();
        }
        let zeros = mag.iter().take_while(|v| **v == 0).count();
        mag.drain(..zeros);
        lo += zeros as i32;
        (neg && !mag.is_empty(), lo, mag)
    }

    /// The sum as a double-double `hi + lo` (about 106 significant bits; the top limbs
    /// summed with error-free transformations), or the IEEE result of the special terms.
    pub fn value_dd(&self) -> (f64, f64) {
        match self.special {
            [_, _, n] if n > 0 => return (f64::NAN, 0.0),
            [p, m, _] if p > 0 && m > 0 => return (f64::NAN, 0.0),
            [p, _, _] if p > 0 => return (f64::INFINITY, 0.0),
            [_, m, _] if m > 0 => return (f64::NEG_INFINITY, 0.0),
            _ => {}
        }
        let (neg, lo, mag) = self.canonical();
        let (mut hi, mut low) = (0.0f64, 0.0f64);
        // the four most significant limbs carry 97+ bits beyond the leading one
        let take = mag.len().saturating_sub(5);
        for (k, v) in mag.iter().enumerate().skip(take).rev() {
            let scale = (BITS as i32) * (lo + k as i32 + BASE);
            let term = scaled(*v as f64, scale);
            if !(term.is_finite() && (hi + term).is_finite()) {
                let inf = if neg { f64::NEG_INFINITY } else { f64::INFINITY };
                return (inf, 0.0);
            }
            let (s, e) = two_sum(hi, term);
            let (h, l) = fast_two_sum(s, low + e);
            hi = h;
            low = l;
        }
        if neg { (-hi, -low) } else { (hi, low) }
    }

    /// The sum rounded to `f64` (`±∞` if it is beyond the range).
    pub fn value(&self) -> f64 {
        let (hi, lo) = self.value_dd();
        hi + lo
    }

    /// A canonical, exact representation for storage (see [`ExactSum::from_stored`]).
    pub fn to_stored(&self) -> StoredSum {
        let (neg, lo, limbs) = self.canonical();
        StoredSum {
            negative: neg,
            lo,
            limbs,
            special: self.special,
        }
    }

    /// The sum a [`StoredSum`] describes; refused ([`Error::InvalidInput`] naming the
    /// field) unless its limbs lie in the window a sum of `f64` terms can reach, limbs
    /// `0..`[`LIMBS`] (a stored `lo` far outside would otherwise grow the accumulator to
    /// gigabytes at the next merge).
    ///
    /// ```
    /// use reckon::ensemble::exact_sum::{ExactSum, StoredSum};
    /// let mut s = ExactSum::default();
    /// s.add(-2.5);
    /// assert_eq!(ExactSum::from_stored(&s.to_stored()).unwrap().value(), -2.5);
    /// let far = StoredSum { negative: false, lo: i32::MAX, limbs: vec![1], special: [0; 3] };
    /// assert!(ExactSum::from_stored(&far).unwrap_err().to_string().contains("lo"));
    /// ```
    pub fn from_stored(s: &StoredSum) -> Result<ExactSum> {
        let top = i64::from(s.lo) + s.limbs.len() as i64;
        if s.lo < 0 || top > i64::from(LIMBS) {
            return Err(Error::invalid(
                "exact sum",
                format!(
                    "lo = {} with {} limbs: a sum of f64 values occupies limbs 0 to {}",
                    s.lo,
                    s.limbs.len(),
                    LIMBS - 1
                ),
            ));
        }
        let sign = if s.negative { -1 } else { 1 };
        Ok(ExactSum {
            lo: s.lo,
            limbs: s.limbs.iter().map(|v| sign * *v as i64).collect(),
            pending: 1,
            special: s.special,
        })
    }

    /// Numbers of `+∞`, `−∞` and NaN terms added.
    pub fn special(&self) -> [u32; 3] {
        self.special
    }

    /// Whether the sum is exactly zero with no special terms.
    pub fn is_zero(&self) -> bool {
        self.special == [0; 3] && self.canonical().2.is_empty()
    }
}

impl From<ExactSum> for StoredSum {
    fn from(s: ExactSum) -> StoredSum {
        s.to_stored()
    }
}

impl TryFrom<StoredSum> for ExactSum {
    type Error = Error;
    fn try_from(s: StoredSum) -> Result<ExactSum> {
        ExactSum::from_stored(&s)
    }
}

/// Equal exact values compare equal whatever their history.
impl PartialEq for ExactSum {
    fn eq(&self, other: &Self) -> bool {
        self.to_stored() == other.to_stored()
    }
}

/// [`ExactSum`] in canonical form: sign, magnitude limbs of 32 bits (least significant
/// first) starting at limb `lo`, counts of `+∞`, `−∞` and NaN terms.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StoredSum {
    /// Whether the value is negative.
    pub negative: bool,
    /// Index of the first limb (limb `i` weighs `2^(32·(i − 35))`).
    pub lo: i32,
    /// Magnitude limbs, least significant first.
    pub limbs: Vec<u32>,
    /// Numbers of `+∞`, `−∞` and NaN terms.
    pub special: [u32; 3],
}

/// `v·2^e` for a 32-bit integer `v`, without overflow in intermediate powers.
fn scaled(v: f64, e: i32) -> f64 {
    let mut x = v;
    let mut e = e;
    while e > 1000 {
        x *= 2f64.powi(1000);
        e -= 1000;
    }
    while e < -1000 {
        x *= 2f64.powi(-1000);
        e += 1000;
    }
    x * 2f64.powi(e)
}

/// `a + b = s + e` exactly (Knuth).
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `a + b = s + e` exactly when `|a| ≥ |b|` (Dekker).
pub(crate) fn fast_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

/// A signed integer times `2^(32·lo)`, for the exact covariance numerator.
#[derive(Debug, Clone)]
struct Big {
    neg: bool,
    lo: i64,
    mag: Vec<u32>,
}

impl Big {
    fn of(s: &ExactSum) -> Big {
        let (neg, lo, mag) = s.canonical();
        Big {
            neg,
            lo: lo as i64 + BASE as i64,
            mag,
        }
    }

    fn mul(&self, o: &Big) -> Big {
        let mut out = vec![0u64; self.mag.len() + o.mag.len() + 1];
        for (i, a) in self.mag.iter().enumerate() {
            let mut carry = 0u64;
            for (j, b) in o.mag.iter().enumerate() {
                let t = out[i + j] + (*a as u64) * (*b as u64) + carry;
                out[i + j] = t & 0xffff_ffff;
                carry = t >> 32;
            }
            let mut k = i + o.mag.len();
            while carry != 0 {
                let t = out[k] + carry;
                out[k] = t & 0xffff_ffff;
                carry = t >> 32;
                k += 1;
            }
        }
        Big {
            neg: self.neg != o.neg,
            lo: self.lo + o.lo,
            mag: out.into_iter().map(|v| v as u32).collect(),
        }
    }

    fn small(n: u64) -> Big {
        Big {
            neg: false,
            lo: 0,
            mag: vec![n as u32, (n >> 32) as u32],
        }
    }

    /// `self − o` (both aligned to the lower `lo`).
    fn sub(&self, o: &Big) -> Big {
        let lo = self.lo.min(o.lo);
        let width = (self.lo + self.mag.len() as i64).max(o.lo + o.mag.len() as i64) - lo + 1;
        let spread = |b: &Big, sign: i64| {
            let mut v = vec![0i64; width as usize];
            for (k, m) in b.mag.iter().enumerate() {
                v[(b.lo - lo) as usize + k] = sign * (*m as i64);
            }
            v
        };
        let a = spread(self, if self.neg { -1 } else { 1 });
        let b = spread(o, if o.neg { 1 } else { -1 });
        let mut sum: Vec<i64> = a.iter().zip(&b).map(|(x, y)| x + y).collect();
        // carry to base 2³², the top limb signed
        let mut carry = 0i64;
        for v in sum.iter_mut() {
            let s = *v + carry;
            carry = s >> 32;
            *v = s - (carry << 32);
        }
        let neg = carry < 0;
        if neg {
            // two's complement of the whole: negate and carry again
            let mut c = 0i64;
            for v in sum.iter_mut() {
                let s = -*v + c;
                c = s >> 32;
                *v = s - (c << 32);
            }
        }
        Big {
            neg,
            lo,
            mag: sum.into_iter().map(|v| v as u32).collect(),
        }
    }

    /// `(f, e)` with `self ≈ f·2^e`, `f` from the top limbs (≈ 106 bits).
    fn scaled_parts(&self) -> (f64, i64) {
        let top = match self.mag.iter().rposition(|v| *v != 0) {
            Some(t) => t,
            None => return (0.0, 0),
        };
        let (mut hi, mut low) = (0.0f64, 0.0f64);
        let first = top.saturating_sub(4);
        for k in (first..=top).rev() {
            let term = self.mag[k] as f64 * 2f64.powi(32 * (k as i32 - top as i32));
            let (s, e) = two_sum(hi, term);
            (hi, low) = fast_two_sum(s, low + e);
        }
        let f = hi + low;
        (if self.neg { -f } else { f }, 32 * (self.lo + top as i64))
    }
}

/// `(n·Σxᵢxⱼ − Σxᵢ·Σxⱼ) / (n·(n − 1))` with the numerator computed exactly (integer
/// arithmetic on the accumulators) and rounded once: the unbiased covariance to a few
/// ulps, whatever the offset of the data from zero.
pub(crate) fn covariance(s2: &ExactSum, s1i: &ExactSum, s1j: &ExactSum, n: u64) -> f64 {
    if s2.special != [0; 3] || s1i.special != [0; 3] || s1j.special != [0; 3] {
        return f64::NAN;
    }
    let r = Big::of(s2).mul(&Big::small(n)).sub(&Big::of(s1i).mul(&Big::of(s1j)));
    let (f, e) = r.scaled_parts();
    let nf = n as f64;
    scaled(f / nf / (nf - 1.0), e.clamp(-4000, 4000) as i32)
}

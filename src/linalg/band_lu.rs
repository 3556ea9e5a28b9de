//! LU with partial pivoting of a banded matrix (LAPACK's `dgbtf2`/`dgbtrs`), for sparse
//! patterns whose non-zeros lie in a narrow band: the 1-D discretisations of PDEs by
//! the method of lines, chains of compartments, anything tridiagonal or pentadiagonal.

use crate::jacobian::Pattern;

/// `A = P·L·U` of an `n × n` matrix with `kl` sub- and `ku` super-diagonals, in LAPACK's
/// band storage; `b ← A⁻¹·b` in place.
///
/// With partial pivoting `U` gains up to `kl` more super-diagonals, so a column holds
/// `2·kl + ku + 1` values: factoring costs at most `2n·kl·(kl + ku + 1)` flops and a
/// solve `2n·(2·kl + ku + 1)`, against a general sparse LU's symbolic analysis, fill
/// and indirect indexing. It is the factorisation CVODE's `CVBand` and LSODA's banded
/// mode use; [`Band::of`] decides when a [`Pattern`] is narrow enough for it.
///
/// [`factor`](Self::factor) reads the matrix as the values of a CSC pattern
/// (the one [`new`](Self::new) was made for) and returns `false` for a zero or
/// non-finite pivot or a non-finite value, as the dense and sparse LUs do.
///
/// ```
/// use reckon::{jacobian::Pattern, linalg::BandLu};
/// // the tridiagonal [[2, 1, 0], [1, 2, 1], [0, 1, 2]] in CSC order
/// let p = Pattern::from_entries(3, &[(0, 0), (1, 0), (0, 1), (1, 1), (2, 1), (1, 2), (2, 2)]).unwrap();
/// let mut lu = BandLu::new(&p).unwrap();
/// assert_eq!((lu.band().lower, lu.band().upper), (1, 1));
/// assert!(lu.factor(&[2.0, 1.0, 1.0, 2.0, 1.0, 1.0, 2.0]));
/// let mut b = [3.0, 4.0, 3.0]; // A·(1, 1, 1)
/// lu.solve_in_place(&mut b);
/// assert!(b.iter().all(|v| (v - 1.0).abs() < 1e-15));
/// assert!(!lu.factor(&[1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0])); // singular: rows 0 and 1 equal
/// ```
#[derive(Debug, Clone)]
pub struct BandLu {
    n: usize,
    band: Band,
    /// Column-major band storage, `ld = 2·kl + ku + 1` values per column: `A(i, j)` at
    /// `j·ld + kl + ku + i − j`; after `factor`, `U`'s rows divided by their pivots
    /// above the diagonal (the pivots themselves on it) and `L`'s multipliers below.
    ab: Vec<f64>,
    /// Where each CSC value of the pattern goes in `ab`.
    at: Vec<usize>,
    pivots: Vec<usize>,
    /// `1/U(j, j)`.
    inv_pivot: Vec<f64>,
    factored: bool,
}

/// The lower and upper bandwidths of a pattern: `A(i, j) = 0` for `i − j > lower` or
/// `j − i > upper`.
///
/// ```
/// use reckon::{jacobian::Pattern, linalg::Band};
/// let p = Pattern::from_entries(4, &[(0, 0), (2, 0), (1, 1), (0, 3), (3, 3)]).unwrap();
/// assert_eq!(Band::of(&p), Band { lower: 2, upper: 3 });
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Band {
    /// Sub-diagonals.
    pub lower: usize,
    /// Super-diagonals.
    pub upper: usize,
}

impl Band {
    /// The bandwidths of `p`'s non-zeros.
    pub fn of(p: &Pattern) -> Band {
        let (mut lower, mut upper) = (0, 0);
        for (i, j) in p.entries() {
            lower = lower.max(i.saturating_sub(j));
            upper = upper.max(j.saturating_sub(i));
        }
        Band { lower, upper }
    }

    /// Whether a banded LU suits `p` better than a general sparse one: the band is at
    /// most [`Band::MAX_WIDTH`] wide and mostly filled, `n·(kl + 1)·(kl + ku + 1) ≤
    /// 8·nnz` (the banded factorisation's work against the non-zeros a sparse LU keeps).
    pub fn suits(p: &Pattern) -> bool {
        let b = Band::of(p);
        b.lower + b.upper <= Self::MAX_WIDTH
            && p.n().saturating_mul(b.lower + 1).saturating_mul(b.lower + b.upper + 1) <= 8 * p.nnz()
    }

    /// The widest band, `kl + ku`, that [`suits`](Self::suits) accepts.
    pub const MAX_WIDTH: usize = 32;
}

impl BandLu {
    /// Band storage for matrices with `pattern`'s non-zeros; `None` when the band
    /// storage (`n·(2·kl + ku + 1)` values) would not fit in memory.
    pub fn new(pattern: &Pattern) -> Option<Self> {
        let n = pattern.n();
        let band = Band::of(pattern);
        let (kl, ku) = (band.lower, band.upper);
        let ld = 2 * kl + ku + 1;
        let len = n.checked_mul(ld)?;
        let mut ab = Vec::new();
        ab.try_reserve_exact(len).ok()?;
        ab.resize(len, 0.0);
        let at = pattern.entries().map(|(i, j)| j * ld + kl + ku + i - j).collect();
        Some(BandLu {
            n,
            band,
            ab,
            at,
            pivots: vec![0; n],
            inv_pivot: vec![0.0; n],
            factored: false,
        })
    }

    /// The bandwidths of the pattern.
    pub fn band(&self) -> Band {
        self.band
    }

    /// Matrix size `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Whether the last [`factor`](Self::factor) succeeded.
    pub fn is_factored(&self) -> bool {
        self.factored
    }

    /// Forget the factorisation.
    pub fn forget(&mut self) {
        self.factored = false;
    }

    /// Factor the matrix whose non-zeros are `values` (in the pattern's CSC order);
    /// `false` when it is singular (a zero pivot) or holds a non-finite value or pivot.
    ///
    /// # Panics
    /// When `values` does not have one value per non-zero of the pattern.
    pub fn factor(&mut self, values: &[f64]) -> bool {
        assert_eq!(values.len(), self.at.len(), "BandLu::factor: one value per non-zero");
        self.factored = false;
        if super::any_non_finite(values) {
            return false;
        }
        self.ab.fill(0.0);
        for (&k, &v) in self.at.iter().zip(values) {
            self.ab[k] = v;
        }
        self.factored = self.factor_in_place();
        self.factored
    }

    /// `dgbtf2`: Gaussian elimination with partial pivoting on the band.
    fn factor_in_place(&mut self) -> bool {
        let (n, kl, ku) = (self.n, self.band.lower, self.band.upper);
        let kv = kl + ku;
        let ld = 2 * kl + ku + 1;
        let ab = &mut self.ab;
        // the last column the eliminations so far reach
        let mut ju = 0;
        for j in 0..n {
            let km = kl.min(n - 1 - j);
            // pivot: the largest of A(j..=j+km, j)
            let col = j * ld + kv;
            let mut p = 0;
            let mut big = ab[col].abs();
            for i in 1..=km {
                let v = ab[col + i].abs();
                if v > big {
                    big = v;
                    p = i;
                }
            }
            self.pivots[j] = j + p;
            if big == 0.0 {
                return false;
            }
            ju = ju.max((j + ku + p).min(n - 1));
            // rows j and j + p over columns j..=ju (a row moves by ld − 1 per column)
            if p != 0 {
                for c in 0..=ju - j {
                    ab.swap(col + p + c * (ld - 1), col + c * (ld - 1));
                }
            }
            if km > 0 {
                let r = 1.0 / ab[col];
                for i in 1..=km {
                    ab[col + i] *= r;
                }
                // A(j+1..=j+km, j+1..=ju) −= l·u
                for c in 1..=ju - j {
                    let uj = ab[col + c * (ld - 1)];
                    if uj != 0.0 {
                        let dst = col + c * (ld - 1);
                        for i in 1..=km {
                            ab[dst + i] -= ab[col + i] * uj;
                        }
                    }
                }
            }
        }
        for j in 0..n {
            self.inv_pivot[j] = 1.0 / ab[j * ld + kv];
        }
        // U's rows divided by their pivots (the solve's U' = diag(1/u)·U, unit diagonal)
        for j in 1..n {
            let col = j * ld + kv;
            for i in j.saturating_sub(kv)..j {
                ab[col + i - j] *= self.inv_pivot[i];
            }
        }
        // a pivot that overflowed to ∞ or a NaN from ∞ − ∞ shows on the diagonal of U
        // (OR-folds over every value, which the compiler vectorises, not tests per value)
        !self.inv_pivot.iter().fold(false, |bad, r| bad | (*r == 0.0))
            && !super::any_non_finite(&self.inv_pivot)
            && !super::any_non_finite(ab)
    }

    /// `b ← A⁻¹·b` (`dgbtrs`); `false` (and `b` untouched) when there is no
    /// factorisation or `b` does not have `n` entries.
    pub fn solve_in_place(&self, b: &mut [f64]) -> bool {
        if !self.factored || b.len() != self.n {
            return false;
        }
        if self.n == 0 {
            return true;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("fma") {
            // SAFETY: the CPU has FMA (checked above)
            unsafe { self.sweeps_fma(b) };
            return true;
        }
        self.sweeps(b);
        true
    }

    /// [`sweeps`](Self::sweeps) compiled with FMA instructions (the same results: `mul_add`
    /// is fused either way, in hardware here, in software in the portable build).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "fma")]
    unsafe fn sweeps_fma(&self, b: &mut [f64]) {
        self.sweeps(b)
    }

    /// The two triangular sweeps of [`solve_in_place`](Self::solve_in_place) on `b` of
    /// length `n ≥ 1`.
    ///
    /// Both are chains through every row (the band couples each row to the next), so
    /// their time is the latency of one row's update. For bands of up to 8 the rows the
    /// current unknown still updates are carried in registers (a window that moves one
    /// row per step, the row entering it read once from `b`), so that the chain is one
    /// fused multiply-subtraction per row and never waits on a store; `U` is kept with a
    /// unit diagonal (its rows divided by their pivots). Every row receives its updates
    /// in the same order either way, so the windowed and the plain sweeps agree bit for
    /// bit.
    #[inline(always)]
    fn sweeps(&self, b: &mut [f64]) {
        let (kl, ku) = (self.band.lower, self.band.upper);
        let ld = 2 * kl + ku + 1;
        match kl {
            0 => {}
            1 => lower::<1>(&self.ab, ld, ku, &self.pivots, b),
            2 => lower::<2>(&self.ab, ld, ku, &self.pivots, b),
            3 => lower::<3>(&self.ab, ld, ku, &self.pivots, b),
            4 => lower::<4>(&self.ab, ld, ku, &self.pivots, b),
            _ => lower_plain(&self.ab, ld, kl, ku, &self.pivots, b),
        }
        // U = diag(u)·U', U' unit upper with kv super-diagonals: U'·x = diag(1/u)·y
        for (r, &inv) in b.iter_mut().zip(&self.inv_pivot) {
            *r *= inv;
        }
        match kl + ku {
            0 => {}
            1 => upper::<1>(&self.ab, ld, b),
            2 => upper::<2>(&self.ab, ld, b),
            3 => upper::<3>(&self.ab, ld, b),
            4 => upper::<4>(&self.ab, ld, b),
            5 => upper::<5>(&self.ab, ld, b),
            6 => upper::<6>(&self.ab, ld, b),
            7 => upper::<7>(&self.ab, ld, b),
            8 => upper::<8>(&self.ab, ld, b),
            kv => upper_plain(&self.ab, ld, kv, b),
        }
    }
}

/// `L`'s sweep (the row swaps and multipliers in the order they were made) for `kl = K`,
/// rows `j + 1 ..= j + K` in the window `w`.
#[inline(always)]
fn lower<const K: usize>(ab: &[f64], ld: usize, ku: usize, pivots: &[usize], b: &mut [f64]) {
    let n = b.len();
    let kv = K + ku;
    let row = |i: usize| if i < n { b[i] } else { 0.0 };
    let mut w: [f64; K] = std::array::from_fn(|i| row(i + 1));
    let mut cur = b[0];
    for j in 0..n - 1 {
        let p = pivots[j];
        if p != j {
            // p − j − 1 < K: a register swap, unrolled
            for (i, v) in w.iter_mut().enumerate() {
                if p == j + 1 + i {
                    std::mem::swap(&mut cur, v);
                }
            }
        }
        b[j] = cur;
        // the multipliers of column j; below row n − 1 they are the band's zeros
        let at = j * ld + kv + 1;
        let l: &[f64; K] = ab[at..at + K].try_into().expect("K multipliers");
        let mut next = [0.0; K];
        for i in 0..K {
            next[i] = (-l[i]).mul_add(cur, w[i]);
        }
        cur = next[0];
        // the window moves down one row (built element by element: it stays in registers)
        let entering = if j + 1 + K < n { b[j + 1 + K] } else { 0.0 };
        w = std::array::from_fn(|i| if i + 1 < K { next[i + 1] } else { entering });
    }
    b[n - 1] = cur;
}

/// `L`'s sweep for any `kl`, the rows below in `b`.
#[inline(always)]
fn lower_plain(ab: &[f64], ld: usize, kl: usize, ku: usize, pivots: &[usize], b: &mut [f64]) {
    let n = b.len();
    let kv = kl + ku;
    let mut cur = b[0];
    for j in 0..n - 1 {
        let p = pivots[j];
        if p != j {
            std::mem::swap(&mut cur, &mut b[p]);
        }
        b[j] = cur;
        let lm = kl.min(n - 1 - j);
        let l = &ab[j * ld + kv + 1..j * ld + kv + 1 + lm];
        let next = (-l[0]).mul_add(cur, b[j + 1]);
        for (r, &m) in b[j + 2..j + 1 + lm].iter_mut().zip(&l[1..]) {
            *r = (-m).mul_add(cur, *r);
        }
        cur = next;
    }
    b[n - 1] = cur;
}

/// `U'·x = y` from the last row up for `kl + ku = K`, rows `j − 1, …, j − K` in the
/// window `w`.
#[inline(always)]
fn upper<const K: usize>(ab: &[f64], ld: usize, b: &mut [f64]) {
    let n = b.len();
    let mut w: [f64; K] = std::array::from_fn(|i| if i + 1 < n { b[n - 2 - i] } else { 0.0 });
    let mut x = b[n - 1];
    for j in (1..n).rev() {
        b[j] = x;
        // U'(j − 1 − i, j) at col − 1 − i; above row 0 they are the band's zeros
        let col = j * ld + K;
        let u: &[f64; K] = ab[col - K..col].try_into().expect("K entries of U'");
        let mut next = [0.0; K];
        for i in 0..K {
            next[i] = (-u[K - 1 - i]).mul_add(x, w[i]);
        }
        x = next[0];
        // the window moves up one row (built element by element: it stays in registers)
        let entering = if j > K { b[j - 1 - K] } else { 0.0 };
        w = std::array::from_fn(|i| if i + 1 < K { next[i + 1] } else { entering });
    }
    b[0] = x;
}

/// `U'·x = y` for any `kv`, the rows above in `b`.
#[inline(always)]
fn upper_plain(ab: &[f64], ld: usize, kv: usize, b: &mut [f64]) {
    let n = b.len();
    let mut next = b[n - 1];
    for j in (1..n).rev() {
        let xj = next;
        b[j] = xj;
        let col = j * ld + kv;
        // the row above first: it is the next unknown
        next = (-ab[col - 1]).mul_add(xj, b[j - 1]);
        let top = j.saturating_sub(kv);
        let u = &ab[col - (j - top)..col - 1];
        for (r, &m) in b[top..j - 1].iter_mut().zip(u) {
            *r = (-m).mul_add(xj, *r);
        }
    }
    b[0] = next;
}

#[cfg(test)]
mod tests {
    use super::{Band, BandLu};
    use crate::jacobian::Pattern;
    use nalgebra::{DMatrix, DVector};

    /// Uniform numbers in [−1, 1) from a seeded LCG.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        }
    }

    /// Every entry of an `n × n` band with `kl` sub- and `ku` super-diagonals.
    fn full_band(n: usize, kl: usize, ku: usize) -> Pattern {
        let mut entries = Vec::new();
        for j in 0..n {
            for i in j.saturating_sub(ku)..(j + kl + 1).min(n) {
                entries.push((i, j));
            }
        }
        Pattern::from_entries(n, &entries).unwrap()
    }

    /// A random banded matrix (with sub- and super-diagonals: zeros on the diagonal, so pivoting
    /// is needed) solved against nalgebra's dense LU.
    #[test]
    fn matches_dense_lu_with_pivoting() {
        let mut rnd = uniform(7);
        for &(n, kl, ku) in &[
            (1usize, 0usize, 0usize),
            (6, 0, 0),
            (7, 0, 2),
            (9, 3, 0),
            (30, 2, 2),
            (40, 1, 5),
            (25, 6, 1),
            // windows longer than the matrix, the widest window, and past it
            (2, 1, 1),
            (3, 2, 2),
            (5, 4, 0),
            (30, 4, 4),
            (20, 5, 4),
        ] {
            let p = full_band(n, kl, ku);
            assert_eq!(Band::of(&p), Band { lower: kl, upper: ku });
            let vals: Vec<f64> = p
                .entries()
                .map(|(i, j)| {
                    if i == j && kl > 0 && ku > 0 && i % 3 == 0 {
                        0.0
                    } else {
                        rnd()
                    }
                })
                .collect();
            let mut a = DMatrix::zeros(n, n);
            for ((i, j), v) in p.entries().zip(&vals) {
                a[(i, j)] = *v;
            }
            let x = DVector::from_fn(n, |i, _| 1.0 + i as f64 * 0.25);
            let b = &a * &x;
            let mut lu = BandLu::new(&p).unwrap();
            assert!(lu.factor(&vals), "n {n} kl {kl} ku {ku}");
            let mut y = b.as_slice().to_vec();
            assert!(lu.solve_in_place(&mut y));
            let y = DVector::from_vec(y);
            // backward stable: the residual is rounding of ‖A‖·‖y‖
            let norm_a = a.row_iter().map(|r| r.abs().sum()).fold(0.0, f64::max);
            let res = (&a * &y - &b).amax();
            assert!(
                res <= 1e-14 * norm_a * y.amax(),
                "n {n} kl {kl} ku {ku}: residual {res:e}"
            );
            // and as close to x as the dense LU's solution is (these random matrices are
            // conditioned up to ~1e7)
            let dense = a.clone().lu().solve(&b).unwrap();
            let (e_band, e_dense) = ((&y - &x).amax(), (&dense - &x).amax());
            assert!(
                e_band <= 10.0 * e_dense + 1e-13 * x.amax(),
                "n {n} kl {kl} ku {ku}: {e_band:e} against {e_dense:e}"
            );
        }
    }

    /// The sweeps with their window in registers give the plain sweeps' bits.
    #[test]
    fn windowed_sweeps_equal_the_plain_ones() {
        let mut rnd = uniform(11);
        for &(n, kl, ku) in &[
            (2usize, 1usize, 1usize),
            (3, 2, 2),
            (50, 1, 1),
            (50, 2, 2),
            (41, 4, 3),
            (33, 3, 5),
            (9, 2, 6),
        ] {
            let p = full_band(n, kl, ku);
            // small diagonals: rows are swapped
            let vals: Vec<f64> = p
                .entries()
                .map(|(i, j)| if i == j { 0.1 * rnd() } else { rnd() })
                .collect();
            let mut lu = BandLu::new(&p).unwrap();
            assert!(lu.factor(&vals));
            assert!(lu.pivots.iter().enumerate().any(|(j, &p)| p != j), "n {n}: no row swap");
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut windowed = b.clone();
            assert!(lu.solve_in_place(&mut windowed));
            let mut plain = b;
            let Band { lower: kl, upper: ku } = lu.band();
            let ld = 2 * kl + ku + 1;
            super::lower_plain(&lu.ab, ld, kl, ku, &lu.pivots, &mut plain);
            for (r, &inv) in plain.iter_mut().zip(&lu.inv_pivot) {
                *r *= inv;
            }
            super::upper_plain(&lu.ab, ld, kl + ku, &mut plain);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&windowed), bits(&plain), "n {n} kl {kl} ku {ku}");
        }
    }

    #[test]
    fn singular_and_non_finite_are_refused() {
        let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (0, 1), (1, 1)]).unwrap();
        let mut lu = BandLu::new(&p).unwrap();
        assert!(!lu.factor(&[1.0, 2.0, 2.0, 4.0]));
        assert!(!lu.solve_in_place(&mut [1.0, 1.0]));
        assert!(!lu.factor(&[1.0, f64::NAN, 0.0, 1.0]));
        assert!(!lu.factor(&[1.0, 0.0, f64::NEG_INFINITY, 1.0]));
        // finite values whose elimination overflows: U(1, 1) = 1e308 + 1e308 = ∞
        assert!(!lu.factor(&[1.0, -1.0, 1e308, 1e308]));
        assert!(lu.factor(&[1.0, -1.0, 1e307, 1e307]));
        assert!(lu.factor(&[0.0, 2.0, 1.0, 0.0])); // needs the row swap
        let mut b = [4.0, 2.0]; // [[0, 1], [2, 0]]·(1, 4)
        assert!(lu.solve_in_place(&mut b));
        assert_eq!(b, [1.0, 4.0]);
        assert!(!lu.solve_in_place(&mut [1.0]));
    }

    #[test]
    fn suits_narrow_filled_bands_only() {
        let tri: Vec<_> = (0..100)
            .flat_map(|i: usize| (i.saturating_sub(1)..(i + 2).min(100)).map(move |j| (i, j)))
            .collect();
        assert!(Band::suits(&Pattern::from_entries(100, &tri).unwrap()));
        // a diagonal plus one far corner: band 99 wide, almost empty
        let mut far: Vec<_> = (0..100).map(|i| (i, i)).collect();
        far.push((99, 0));
        assert!(!Band::suits(&Pattern::from_entries(100, &far).unwrap()));
        // 2-D five-point stencil on a 20 × 20 grid: band 20, 5 of 41 filled
        let g = 20;
        let mut five = Vec::new();
        for i in 0..g * g {
            five.push((i, i));
            for j in [i + 1, i + g] {
                if j < g * g {
                    five.push((i, j));
                    five.push((j, i));
                }
            }
        }
        assert!(!Band::suits(&Pattern::from_entries(g * g, &five).unwrap()));
    }
}

//! Step-size control: tolerances, the weighted RMS error norm, Hairer's PI
//! controller and Hairer's initial step (HNW ODE I §II.4, `dopri5.f` DOPCOR/HINIT).

use crate::error::Result;
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// Tolerances expanded to the state dimension.
#[derive(Debug, Clone)]
pub struct Weights<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Relative tolerance per component.
    pub rtol: OVector<f64, D>,
    /// Absolute tolerance per component.
    pub atol: OVector<f64, D>,
    /// How many leading components enter the error estimate ([`Options::error_components`](crate::Options::error_components));
    /// the rest are integrated but not controlled.
    pub controlled: usize,
    /// The error of the components that are not controlled, of the last estimate
    /// ([`uncontrolled`](Self::uncontrolled)): watched, not used for the steps.
    rest: std::cell::Cell<f64>,
    /// When the uncontrolled components are the columns of a sensitivity matrix, each
    /// `controlled` long: each column's scale `p̄` (the magnitude of what it is the
    /// derivative with respect to).
    columns: Option<Vec<f64>>,
}

impl<D: Dim> Weights<D>
where
    DefaultAllocator: Allocator<D>,
{
    /// Tolerances per component, the first `controlled` of them in the error estimate.
    pub fn new(rtol: OVector<f64, D>, atol: OVector<f64, D>, controlled: usize) -> Self {
        Weights {
            rtol,
            atol,
            controlled,
            rest: std::cell::Cell::new(0.0),
            columns: None,
        }
    }

    /// The loose-tolerance transform of Hairer–Wanner's RADAU5: every `rtol_i` above 1e-3
    /// becomes `r_i = 0.1·rtol_i^{2/3}` (continuous at 1e-3, where both are 1e-3; 0.0215 at
    /// 0.1, 4.6e-3 at 1e-2), and its `atol_i` is scaled by `r_i/rtol_i` with it; tighter
    /// components are unchanged.
    ///
    /// Held to the tolerance step by step, a stiff method's global error is the local
    /// error amplified by the problem; at `rtol` 0.1 the local error is large enough to
    /// move the phase of a limit cycle by a whole spike (OREGO: implicit Euler 4.8 digits
    /// short at `rtol` 0.1, [`Auto`](crate::methods::Auto) 1.6 short at 3.2e-2).
    /// [`Method::tightens_loose_tolerances`](crate::methods::Method::tightens_loose_tolerances)
    /// says which methods the driver applies it for.
    ///
    /// ```
    /// use reckon::methods::step_size::Weights;
    /// use nalgebra::vector;
    /// let mut w = Weights::new(vector![1e-1, 1e-3, 1e-6], vector![1e-2, 1e-3, 1e-9], 3);
    /// w.tighten_loose();
    /// assert!((w.rtol[0] - 0.1 * 0.1f64.powf(2.0 / 3.0)).abs() < 1e-15);
    /// assert!((w.atol[0] - 1e-2 * w.rtol[0] / 0.1).abs() < 1e-15);
    /// assert_eq!((w.rtol[1], w.atol[1]), (1e-3, 1e-3));
    /// assert_eq!((w.rtol[2], w.atol[2]), (1e-6, 1e-9));
    /// ```
    pub fn tighten_loose(&mut self) {
        for (r, a) in self.rtol.iter_mut().zip(self.atol.iter_mut()) {
            if *r > 1e-3 {
                let t = 0.1 * r.powf(2.0 / 3.0);
                *a *= t / *r;
                *r = t;
            }
        }
    }

    /// Treat the uncontrolled components as the columns of a sensitivity matrix, column
    /// `k` the derivative with respect to a quantity of magnitude `scales[k]`
    /// ([`uncontrolled`](Self::uncontrolled)).
    pub(crate) fn set_columns(&mut self, scales: Vec<f64>) {
        self.columns = Some(scales);
    }

    /// RMS norm `sqrt(1/m Σ_{i<m} (e_i / (atol_i + rtol_i·max(|x0_i|, |x1_i|)))²)` over the
    /// `m =` [`controlled`](Self::controlled) leading components. The error of the other
    /// components is kept as [`uncontrolled`](Self::uncontrolled).
    ///
    /// ```
    /// use reckon::methods::step_size::Weights;
    /// use nalgebra::vector;
    /// let w = Weights::new(vector![0.0, 0.0, 0.0], vector![1.0, 2.0, 1.0], 2);
    /// let e = w.norm(&vector![3.0, 8.0, 1e9], &vector![0.0, 0.0, 0.0], &vector![0.0, 0.0, 0.0]);
    /// assert!((e - (12.5f64).sqrt()).abs() < 1e-15); // sqrt((9 + 16)/2): the third is not controlled
    /// assert_eq!(w.uncontrolled(), 1e9); // but watched: 1e9 against atol 1 (its magnitude is 0)
    /// ```
    #[inline]
    pub fn norm(&self, e: &OVector<f64, D>, x0: &OVector<f64, D>, x1: &OVector<f64, D>) -> f64 {
        let m = self.controlled.min(e.len());
        let mut s = 0.0;
        for i in 0..m {
            let sk = (self.atol[i] + self.rtol[i] * x0[i].abs().max(x1[i].abs())).max(f64::MIN_POSITIVE);
            let r = e[i] / sk;
            s += r * r;
        }
        if m < e.len() {
            self.rest_from(|i| e[i], x0.as_slice(), x1.as_slice());
        }
        (s / m.max(1) as f64).sqrt()
    }

    /// Set [`uncontrolled`](Self::uncontrolled) from the error estimate `e(i)` of the
    /// components past [`controlled`](Self::controlled) (`x0`, `x1`: the whole state at
    /// the step's ends).
    pub(crate) fn rest_from(&self, e: impl Fn(usize) -> f64, x0: &[f64], x1: &[f64]) {
        let (m, n) = (self.controlled.min(x0.len()), x0.len());
        if n == m {
            self.rest.set(0.0);
            return;
        }
        let big = (m..n).fold(0.0f64, |a, i| a.max(x0[i].abs()).max(x1[i].abs()));
        let mut s = 0.0;
        for i in m..n {
            let floor = match &self.columns {
                Some(scales) if m > 0 => {
                    let (row, col) = ((i - m) % m, (i - m) / m);
                    let x = x0[row].abs().max(x1[row].abs());
                    (x + self.atol[row]) / scales.get(col).copied().unwrap_or(1.0)
                }
                _ => self.atol[i],
            };
            let r = e(i) / (big + floor).max(f64::MIN_POSITIVE);
            s += r * r;
        }
        self.rest.set((s / (n - m) as f64).sqrt());
    }

    /// The local error estimate of the components that are not controlled, relative to
    /// their largest magnitude `M` (of any of them, at either end of the step): the RMS
    /// of `e_i / (M + a_i)`, from the last attempt of a method that estimates it (0 when
    /// all are controlled, before any estimate, and for methods without one). One
    /// magnitude for all of them because they are the columns of a sensitivity matrix
    /// (an entry near 0 among entries near 600 is accurate at 600's scale), and no
    /// `rtol`: the watch is for answers wrong by orders of magnitude, not for accuracy
    /// (the driver refuses a step above [`crate::sensitivity::UNRESOLVED`]). The floor
    /// `a_i` is `atol_i`; for the columns of `S` it is `(|x_r| + atol_r)/p̄_k` (row `r`,
    /// column `k`), the natural size of `∂x_r/∂q_k` for a quantity `q_k` of magnitude
    /// `p̄_k` (CVODES scales sensitivity tolerances by `p̄` the same way), so that `S`
    /// near 0 at the start of a run (parameter columns start at 0) is not judged
    /// against itself.
    ///
    /// ```
    /// use reckon::methods::step_size::Weights;
    /// use nalgebra::vector;
    /// let w = Weights::new(vector![1e-6, 1e-6, 1e-6], vector![1e-9, 1e-9, 1e-9], 1);
    /// // the last two are a column of S, near 600 and near 0; errors 6 and 0
    /// w.norm(&vector![0.0, 6.0, 0.0], &vector![1.0, 600.0, 0.0], &vector![1.0, 600.0, 1e-3]);
    /// assert!((w.uncontrolled() - 0.01 / 2f64.sqrt()).abs() < 1e-12); // 1 % of 600, RMS over 2
    /// ```
    pub fn uncontrolled(&self) -> f64 {
        self.rest.get()
    }

    /// Raise [`uncontrolled`](Self::uncontrolled) to `v` (a second estimate of the same
    /// relative error; the larger counts).
    pub(crate) fn raise_uncontrolled(&self, v: f64) {
        if v > self.rest.get() {
            self.rest.set(v);
        }
    }

    /// Forget the last [`uncontrolled`](Self::uncontrolled) estimate.
    pub(crate) fn clear_uncontrolled(&self) {
        self.rest.set(0.0);
    }

    /// Scale of component `i` at state `x`: `atol_i + rtol_i·|x_i|` (at least the
    /// smallest normal number, so that pure relative control of a zero component is not 0/0).
    #[inline]
    pub fn scale(&self, i: usize, x: f64) -> f64 {
        clamped_scale(self.atol[i], self.rtol[i], x)
    }

    /// Every component's [`scale`](Self::scale) at `x` times `factor`, into `out`
    /// (one pass; `factor = 1` gives the scales themselves).
    #[inline]
    pub(crate) fn scales(&self, x: &[f64], factor: f64, out: &mut [f64]) {
        let (atol, rtol) = (self.atol.as_slice(), self.rtol.as_slice());
        for (((s, &x), &a), &r) in out.iter_mut().zip(x).zip(atol).zip(rtol) {
            *s = clamped_scale(a, r, x) * factor;
        }
    }
}

/// `max(a + r·|x|, MIN_POSITIVE)` (NaN gives `MIN_POSITIVE` too), as one `maxsd`.
#[inline(always)]
fn clamped_scale(a: f64, r: f64, x: f64) -> f64 {
    let s = a + r * x.abs();
    if s > f64::MIN_POSITIVE { s } else { f64::MIN_POSITIVE }
}

/// `Σ (k·v_i / s_i)²` in four interleaved partial sums (term `i` into sum `i mod 4`),
/// added as `(σ₀ + σ₁) + (σ₂ + σ₃)`: four independent chains of additions instead of
/// one, the same value as the plain sum in order for up to three terms.
#[inline]
pub(crate) fn sum_sq(k: f64, v: &[f64], s: &[f64]) -> f64 {
    let n = v.len().min(s.len());
    let (v, s) = (&v[..n], &s[..n]);
    let mut acc = [0.0f64; 4];
    let (vc, sc) = (v.chunks_exact(4), s.chunks_exact(4));
    let (vr, sr) = (vc.remainder(), sc.remainder());
    for (v, s) in vc.zip(sc) {
        for j in 0..4 {
            let r = k * v[j] / s[j];
            acc[j] += r * r;
        }
    }
    for (j, (&v, &s)) in vr.iter().zip(sr).enumerate() {
        let r = k * v / s;
        acc[j] += r * r;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// `ln 1e-4`: `dopri5.f` keeps `err_old ≥ 1e-4`.
const LN_ERR_MIN: f64 = -9.210340371976182;

/// Hairer's PI ("Lund-stabilised") controller from `dopri5.f`:
/// `h_new = h·min(max_factor, max(min_factor, safety·err^(−α)·err_old^β))`,
/// `α = 1/(q+1) − 0.75β` for an error estimator of order `q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Controller {
    /// Safety factor (0.9).
    pub safety: f64,
    /// Smallest step ratio (0.2).
    pub min_factor: f64,
    /// Largest step ratio (10).
    pub max_factor: f64,
    /// PI memory exponent β (0.04 for DP5; 0 gives a plain I controller).
    pub beta: f64,
    /// Exponent α applied to the current error.
    pub alpha: f64,
    /// Keep the step (factor 1) when the proposed factor falls in this range, so that
    /// implicit methods can reuse their factorisation (RADAU5 uses [1, 1.2]).
    pub hold: Option<(f64, f64)>,
    /// `ln(err_old)`, the logarithm of the last accepted error (at least ln 1e-4).
    ln_err_old: f64,
}

impl Controller {
    /// Hairer's defaults for an error estimator of order `q` with PI exponent `beta`.
    ///
    /// ```
    /// let mut c = reckon::methods::step_size::Controller::new(4, 0.04);
    /// assert!((c.alpha - 0.17).abs() < 1e-15); // 1/5 − 0.75·0.04
    /// // first accepted step: err_old = 1e-4, factor = 0.9·err^−0.17·(1e-4)^0.04
    /// let f = c.accept(0.5);
    /// assert!((f - 0.9 * 0.5f64.powf(-0.17) * 1e-4f64.powf(0.04)).abs() < 1e-14);
    /// // second: err_old = 0.5
    /// let f = c.accept(0.25);
    /// assert!((f - 0.9 * 0.25f64.powf(-0.17) * 0.5f64.powf(0.04)).abs() < 1e-14);
    /// ```
    pub fn new(q: u32, beta: f64) -> Self {
        Controller {
            safety: 0.9,
            min_factor: 0.2,
            max_factor: 10.0,
            beta,
            alpha: 1.0 / (q as f64 + 1.0) - 0.75 * beta,
            hold: None,
            ln_err_old: LN_ERR_MIN,
        }
    }
    /// Forget the last accepted error, as at the start of a run (after a reset of the
    /// state, the error history says nothing of the steps ahead).
    pub fn restart(&mut self) {
        self.ln_err_old = LN_ERR_MIN;
    }

    /// Keep `h` when the proposed factor lies in `[lo, hi]`.
    pub fn with_hold(mut self, lo: f64, hi: f64) -> Self {
        self.hold = Some((lo, hi));
        self
    }

    /// Factor for the next step after an accepted step with error `err ≤ 1`.
    ///
    /// `err^α / err_old^β` is evaluated as `exp(α·ln err − β·ln err_old)` with the
    /// logarithm of `err_old` kept from the last step: one `ln` and one `exp` per step
    /// instead of two `powf` (each of which is an `ln` and an `exp` inside).
    #[inline]
    pub fn accept(&mut self, err: f64) -> f64 {
        let ln_err = err.ln();
        let fac = (self.alpha * ln_err - self.beta * self.ln_err_old).exp() / self.safety;
        let fac = fac.clamp(1.0 / self.max_factor, 1.0 / self.min_factor);
        self.ln_err_old = ln_err.max(LN_ERR_MIN);
        match self.hold {
            Some((lo, hi)) if (lo..=hi).contains(&(1.0 / fac)) => 1.0,
            _ => 1.0 / fac,
        }
    }

    /// Factor for the retry after a rejected step with error `err > 1`.
    #[inline]
    pub fn reject(&self, err: f64) -> f64 {
        let fac = err.powf(self.alpha) / self.safety;
        1.0 / fac.min(1.0 / self.min_factor)
    }
}

/// Hairer's initial step (HINIT): `h₀ = 0.01·‖x₀‖/‖f₀‖`, one explicit Euler
/// probe for the second derivative, then `h = min(100|h₀|, (0.01/max(‖f'‖,‖f₀‖))^(1/iord), h_max)`.
/// Norms are the unscaled Euclidean sums of `dopri5.f` (not RMS, see REFERENCES §4.4).
/// `f1` receives `f(t0 + h₀, x0 + h₀ f0)`; `probe` is scratch.
#[allow(clippy::too_many_arguments)]
pub fn initial_step<D: Dim>(
    w: &Weights<D>,
    x0: &OVector<f64, D>,
    f0: &OVector<f64, D>,
    iord: u32,
    h_max: f64,
    dir: f64,
    probe: &mut OVector<f64, D>,
    mut f1: impl FnMut(f64, &OVector<f64, D>) -> Result<OVector<f64, D>>,
) -> Result<f64>
where
    DefaultAllocator: Allocator<D>,
{
    let n = w.controlled.min(x0.len());
    let (mut dnf, mut dny) = (0.0, 0.0);
    for i in 0..n {
        let sk = w.scale(i, x0[i]);
        dnf += (f0[i] / sk).powi(2);
        dny += (x0[i] / sk).powi(2);
    }
    // (tolerances near 1e-160 overflow the squares: fall back as for a zero norm)
    let mut h = if dnf <= 1e-10 || dny <= 1e-10 || !(dny / dnf).is_finite() {
        1e-6
    } else {
        0.01 * (dny / dnf).sqrt()
    };
    h = h.min(h_max);
    probe.copy_from(x0);
    probe.axpy(dir * h, f0, 1.0);
    let f1 = f1(dir * h, probe)?;
    let mut der2 = 0.0;
    for i in 0..n {
        der2 += ((f1[i] - f0[i]) / w.scale(i, x0[i])).powi(2);
    }
    let der2 = der2.sqrt() / h;
    let der12 = der2.abs().max(dnf.sqrt());
    let h1 = if der12 <= 1e-15 {
        (h * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(1.0 / iord as f64)
    };
    Ok((100.0 * h).min(h1).min(h_max))
}

#[cfg(test)]
mod tests {
    use super::sum_sq;

    /// The plain sum in order, the value `sum_sq` replaced.
    fn in_order(k: f64, v: &[f64], s: &[f64]) -> f64 {
        v.iter().zip(s).fold(0.0, |acc, (&v, &s)| {
            let r = k * v / s;
            acc + r * r
        })
    }

    #[test]
    fn sum_sq_is_the_plain_sum_up_to_three_terms_and_rounding_past() {
        let v: Vec<f64> = (0..103)
            .map(|i| (i as f64 * 0.37).sin() * 10f64.powi(i % 7 - 3))
            .collect();
        let s: Vec<f64> = (0..103).map(|i| 1e-6 + 1e-3 * (i as f64 * 0.11).cos().abs()).collect();
        for n in 0..=3 {
            assert_eq!(
                sum_sq(0.7, &v[..n], &s[..n]).to_bits(),
                in_order(0.7, &v[..n], &s[..n]).to_bits()
            );
        }
        for n in [4, 5, 6, 7, 8, 9, 64, 103] {
            let (a, b) = (sum_sq(1.3, &v[..n], &s[..n]), in_order(1.3, &v[..n], &s[..n]));
            // the sums of the same non-negative terms in two orders: n·ε apart at most
            assert!((a - b).abs() <= n as f64 * f64::EPSILON * b, "n = {n}: {a} vs {b}");
            assert!(a > 0.0);
        }
        // exactly: four terms (1/1)², (2/1)², (3/1)², (4/2)² with k = 1 → (1 + 4) + (9 + 4)
        assert_eq!(sum_sq(1.0, &[1.0, 2.0, 3.0, 4.0], &[1.0, 1.0, 1.0, 2.0]), 18.0);
        // k scales every term: k = 2 quadruples the sum
        assert_eq!(sum_sq(2.0, &[1.0, 2.0, 3.0, 4.0, 5.0], &[1.0; 5]), 4.0 * 55.0);
        // a NaN or ∞ term is not lost in a partial sum
        assert!(sum_sq(1.0, &[1.0, 2.0, 3.0, 4.0, f64::NAN], &[1.0; 5]).is_nan());
        assert_eq!(
            sum_sq(1.0, &[1.0, f64::INFINITY, 3.0, 4.0, 5.0], &[1.0; 5]),
            f64::INFINITY
        );
    }
}

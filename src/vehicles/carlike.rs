//! Car-like vehicle with a steering state: `(x, y, θ, γ)`, inputs `(v, ω)` with `ω` the
//! steering rate, wheelbase `L`: `θ' = v·tan γ / L`, `γ' = ω`.
//!
//! Two flows over a step with `(v, ω)` held:
//! - [`flow`], the exact flow: steering and heading in closed form, positions by adaptive
//!   Gauss–Kronrod quadrature to about `1e-14` of the path length (exact to ≤ `1e-12`);
//! - [`midpoint_flow`], the cheaper second-order midpoint-steering flow.
//!
//! The model is singular where `cos γ = 0` (`γ = ±π/2`, the wheels across the car): a
//! step whose steering angle reaches or crosses such a pole has no flow, and [`flow`]
//! returns NaN for `(x, y, θ)` there, which the driver reports as a non-finite state.

use super::unicycle;
use nalgebra::{Const, Vector3, Vector4};

/// `x' = v cos θ`, `y' = v sin θ`, `θ' = v·tan γ / L`, `γ' = ω` with `u = (v, ω)` held.
///
/// ```
/// use reckon::{vehicles::carlike, System};
/// use nalgebra::vector;
/// let mut dx = vector![0.0, 0.0, 0.0, 0.0];
/// carlike::model(2.5).rhs(0.0, &vector![0.0, 0.0, 0.0, 0.1], &[5.0, 0.2], &mut dx);
/// assert!((dx - vector![5.0, 0.0, 5.0 * 0.1f64.tan() / 2.5, 0.2]).norm() < 1e-15);
/// ```
pub fn model(wheelbase: f64) -> impl crate::DualSystem<Const<4>> + Clone {
    let l = wheelbase;
    crate::model!(|_t, x: [S; 4], u: [2]| nalgebra::vector![
        x[2].cos() * u[0],
        x[2].sin() * u[0],
        x[3].tan() * (u[0] / l),
        S::from(u[1])
    ])
}

/// Below this `|ω·h|` the steering-rate term of the heading, at most
/// `(v·h/L)·sec²γ₀·|ωh|/2 ≤ 1e-118·v·h/L` (since `sec²γ₀ < 3e32` for any `f64` angle), is
/// far below double-precision resolution, and the step is the `ω = 0` arc.
const TINY_TURN: f64 = 1e-150;

/// Quadrature tolerance per unit length of the step: a panel is accepted when its
/// Gauss–Kronrod error estimate is at most `QUAD_TOL·|panel|`.
const QUAD_TOL: f64 = 1e-14;

/// Panels the adaptive quadrature may evaluate in one step before giving up (NaN).
const MAX_PANELS: usize = 1 << 16;

/// The exact flow over a step `h` with `(v, ω)` held, to ≤ `1e-12` for any step length.
///
/// - **Steering** in closed form: `γ(s) = γ₀ + ωs`.
/// - **Heading** in closed form: `θ(s) = θ₀ + (v/L)∫₀ˢ tan γ = θ₀ − (v/(Lω))·ln(cos γ(s)/cos γ₀)`,
///   evaluated as `−(v/(Lω))·ln_1p(z)` with `z = cos γ(s)/cos γ₀ − 1 = −2·sin(γ₀ + ωs/2)·sin(ωs/2)/cos γ₀`,
///   a product with no cancellation, so the form keeps full relative precision as `ω → 0`
///   (at `ω = 10⁻¹²` it agrees with the `ω = 0` arc to `O(ω)`, not to `1e-4` as the
///   plain logarithm would).
/// - **Positions** `x(h) = x₀ + v∫₀ʰ cos θ`, `y(h) = y₀ + v∫₀ʰ sin θ` by adaptive G7K15
///   Gauss–Kronrod quadrature of `(cos(θ − θ₀), sin(θ − θ₀))` (rotated by `θ₀` after, so a
///   large unwrapped `θ₀` costs no digits): a panel is bisected until `|K15 − G7| ≤ 1e-14·|panel|`
///   or, where the integrand's own rounding noise is larger (near `γ = ±π/2`, where
///   `θ' = v·tan γ / L` makes an ulp of `s` an error of `ε·s·θ'` in `θ`), until it is at that
///   noise. So `(x, y)` are within `1e-14·|v·h|` plus that rounding noise integrated over the
///   step (the K15 value kept is far more accurate than the G7 value the estimate bounds),
///   whatever the step length, the steering rate, or how close `γ` comes to `±π/2`:
///   measured against 40-digit references, positions to 1e-16 with `γ` ending 2.7e-8 from
///   the pole (`tan γ = 3.7e7`) and on a 60-s step turning 86 rad. The heading is exact to
///   its own rounding condition (an ulp of `ω·h` moves it by `(v/L)·|tan γ₁|·h·ε`).
/// - `|ω·h| ≤ 1e-150` (including `ω = 0`): the exact arc of the kinematic bicycle
///   ([`bicycle::flow`](super::bicycle::flow)) with `α = γ₀`; the steering-rate term
///   dropped there is below `1e-118·v·h/L`.
/// - `v = 0`: the car stands still while the wheels turn: `(x₀, y₀, θ₀, γ₀ + ωh)`.
///
/// **Singularities.** The model itself is singular at `cos γ = 0`. If `γ(s)` reaches or
/// crosses an odd multiple of `π/2` within the step (detected as `|ωh| ≥ π` or
/// `cos γ₀·cos γ₁ ≤ 0`) and `v ≠ 0`, `x`, `y` and `θ` are NaN (`γ₁` is still returned), and
/// the driver reports a non-finite state. A step whose heading turns through so many
/// radians that 65 536 quadrature panels do not reach the tolerance (about 10⁵ rad in one
/// step) also gives NaN: shorten the step (`Options::fixed`). Missing inputs give NaN.
///
/// ```
/// use reckon::vehicles::carlike;
/// use nalgebra::vector;
/// let phi = carlike::flow(2.5);
/// let (x0, u) = (vector![1.0, 2.0, 0.3, 0.2], [5.0, -0.4]);
/// let x = phi(0.0, &x0, &u, 2.0);
/// // closed-form steering and heading
/// let g1: f64 = 0.2 - 0.4 * 2.0;
/// let th1 = 0.3 - 5.0 / (2.5 * -0.4) * (g1.cos() / 0.2f64.cos()).ln();
/// assert!((x[3] - g1).abs() < 1e-15 && (x[2] - th1).abs() < 1e-14);
/// // exact: two steps of 1 s land on the same pose as one step of 2 s
/// let two = phi(1.0, &phi(0.0, &x0, &u, 1.0), &u, 1.0);
/// assert!((two - x).amax() < 1e-13);
/// // a step across the pole γ = π/2 is singular: NaN, reported by the driver
/// assert!(phi(0.0, &vector![0.0, 0.0, 0.0, 1.5], &[1.0, 1.0], 0.1)[0].is_nan());
/// ```
pub fn flow(wheelbase: f64) -> impl Fn(f64, &Vector4<f64>, &[f64], f64) -> Vector4<f64> + Clone {
    move |t, x, u, h| {
        let v = u.first().copied().unwrap_or(f64::NAN);
        let w = u.get(1).copied().unwrap_or(f64::NAN);
        let g0 = x[3];
        let g1 = g0 + w * h;
        if v == 0.0 {
            return Vector4::new(x[0], x[1], x[2], g1);
        }
        if (w * h).abs() <= TINY_TURN {
            let p = unicycle::flow(t, &Vector3::new(x[0], x[1], x[2]), &[v, v * g0.tan() / wheelbase], h);
            return Vector4::new(p[0], p[1], p[2], g1);
        }
        // NaN inputs fall through here too: every comparison below is false
        let c0 = g0.cos();
        if (w * h).abs() >= std::f64::consts::PI || c0 * g1.cos() <= 0.0 {
            return Vector4::new(f64::NAN, f64::NAN, f64::NAN, g1);
        }
        // heading change φ(s) = θ(s) − θ₀ = −(v/(Lω))·ln_1p(z(s))
        let k = -v / (wheelbase * w);
        let z = |s: f64| {
            let d = w * s;
            -2.0 * (g0 + 0.5 * d).sin() * (0.5 * d).sin() / c0
        };
        let phi = |s: f64| k * z(s).ln_1p();
        // (cos φ, sin φ) and the rounding error of φ in units of ε: of the node s
        // (s·φ'(s), large near the pole where φ' = v·tan γ / L blows up), of ln_1p
        // near z = −1 (k·z/(1 + z)) and of φ itself
        let rate = v / wheelbase;
        let integrand = |s: f64| {
            let zs = z(s);
            let ph = k * zs.ln_1p();
            let (sn, cs) = ph.sin_cos();
            let noise = ph.abs() + (s * rate * (g0 + w * s).tan()).abs() + (k * zs / (1.0 + zs)).abs();
            ([cs, sn], noise)
        };
        let [ic, is] = integrate(&integrand, h).unwrap_or([f64::NAN; 2]);
        let (s0, co0) = x[2].sin_cos();
        Vector4::new(
            x[0] + v * (co0 * ic - s0 * is),
            x[1] + v * (s0 * ic + co0 * is),
            x[2] + phi(h),
            g1,
        )
    }
}

/// The second-order midpoint-steering flow: over a step `h` the steering angle is held at
/// its midpoint value `γ_m = γ + ½ωh` and `(x, y, θ)` follow the exact unicycle arc with
/// `ω_θ = v·tan γ_m / L`; `γ₁ = γ + ωh` exactly.
///
/// **Order 2**, not exact: `θ₁ − θ₀ = (v/L)∫tan γ(s) ds` and the midpoint rule integrates
/// it with local error `(v/L)·h³/24·(tan γ)''`, so the global error is `O(h²)` (measured
/// order 2.00 by least squares over h = 0.1 … 0.00625 against RK45, `tests/it/vehicles.rs`).
/// With one step per 2-s control interval on the report's scenario it ends about 1.4 m
/// from the true pose. It equals [`flow`] when `ω = 0`. Use it where a cheap
/// approximation on short steps is enough; [`flow`] is the exact one.
///
/// ```
/// use reckon::vehicles::carlike;
/// use nalgebra::vector;
/// let phi = carlike::midpoint_flow(2.5);
/// // no steering rate: a circle of radius L / tan γ
/// let (l, g, v) = (2.5, 0.2f64, 4.0);
/// let r = l / g.tan();
/// let x = phi(0.0, &vector![0.0, 0.0, 0.0, g], &[v, 0.0], std::f64::consts::PI * r / v);
/// assert!((x - vector![0.0, 2.0 * r, std::f64::consts::PI, g]).amax() < 1e-13);
/// // with a steering rate θ is off by about (v/L)·h³/24·(tan γ)'' per step: 0.0172 rad here
/// let x0 = vector![0.0, 0.0, 0.0, 0.1];
/// let u = [5.0, 0.5];
/// let (mid, exact) = (phi(0.0, &x0, &u, 1.0), carlike::flow(2.5)(0.0, &x0, &u, 1.0));
/// let gm = 0.1f64 + 0.25;
/// let lead = 5.0 / 2.5 / 24.0 * 2.0 * gm.tan() / gm.cos().powi(2) * 0.25;
/// assert!((exact[2] - mid[2] - lead).abs() < 0.1 * lead);
/// ```
pub fn midpoint_flow(wheelbase: f64) -> impl Fn(f64, &Vector4<f64>, &[f64], f64) -> Vector4<f64> + Clone {
    move |t, x, u, h| {
        let v = u.first().copied().unwrap_or(f64::NAN);
        let w = u.get(1).copied().unwrap_or(f64::NAN);
        let gm = x[3] + 0.5 * w * h;
        let p = unicycle::flow(t, &Vector3::new(x[0], x[1], x[2]), &[v, v * gm.tan() / wheelbase], h);
        Vector4::new(p[0], p[1], p[2], x[3] + w * h)
    }
}

/// Kronrod abscissae of the 15-point rule on `[−1, 1]` (non-negative half, descending);
/// the odd-indexed ones are the 7-point Gauss–Legendre nodes. QUADPACK's `qk15` values
/// (given there to 33 digits, which integrate every monomial up to degree 23 (Kronrod) and
/// 13 (Gauss) to 1e-27 in 40-digit arithmetic) correctly rounded to `f64`.
const XGK: [f64; 8] = [
    0.9914553711208126,
    0.9491079123427585,
    0.8648644233597691,
    0.7415311855993945,
    0.5860872354676911,
    0.4058451513773972,
    0.20778495500789848,
    0.0,
];
/// Kronrod weights for [`XGK`].
const WGK: [f64; 8] = [
    0.022935322010529224,
    0.06309209262997856,
    0.10479001032225019,
    0.14065325971552592,
    0.1690047266392679,
    0.19035057806478542,
    0.20443294007529889,
    0.20948214108472782,
];
/// Gauss weights for `XGK[1], XGK[3], XGK[5], XGK[7]`.
const WG: [f64; 4] = [
    0.1294849661688697,
    0.27970539148927664,
    0.3818300505051189,
    0.4179591836734694,
];

/// Rounding error of one integrand evaluation, in units of `f64::EPSILON` times the
/// noise magnitude the integrand reports (a few roundings in `ln_1p`, `sin`, products).
const NOISE_ULPS: f64 = 8.0;

/// The integrand of [`integrate`]: `s ↦ (f(s), n(s))`, a 2-vector value and the size `n` of
/// its rounding error in units of `f64::EPSILON` (0 for an integrand exact to rounding).
type Integrand<'a> = dyn Fn(f64) -> ([f64; 2], f64) + 'a;

/// One G7K15 panel of a 2-vector integrand over `[a, b]` (either order): the Kronrod
/// value, the estimate `max |K15 − G7|` of the Gauss value's error, and the part of that
/// difference rounding noise alone can make, `NOISE_ULPS·ε·|r|·Σ(w_K + w_G)·n(s_i)`.
fn gk15(f: &Integrand<'_>, a: f64, b: f64) -> ([f64; 2], f64, f64) {
    let (c, r) = (0.5 * (a + b), 0.5 * (b - a));
    let mut k = [0.0; 2];
    let mut g = [0.0; 2];
    let mut noise = 0.0;
    for (i, (&xi, &wk)) in XGK.iter().zip(&WGK).enumerate() {
        let wg = if i % 2 == 1 { WG[i / 2] } else { 0.0 };
        let (fs, ns) = if xi == 0.0 {
            f(c)
        } else {
            let ((lo, nl), (hi, nh)) = (f(c - r * xi), f(c + r * xi));
            ([lo[0] + hi[0], lo[1] + hi[1]], nl + nh)
        };
        for j in 0..2 {
            k[j] += wk * fs[j];
            g[j] += wg * fs[j];
        }
        noise += (wk + wg) * ns;
    }
    let (e0, e1) = (((k[0] - g[0]) * r).abs(), ((k[1] - g[1]) * r).abs());
    // NaN in either component must fail the panel (`f64::max` would drop it)
    let err = if e0.is_nan() || e1.is_nan() {
        f64::NAN
    } else {
        e0.max(e1)
    };
    ([k[0] * r, k[1] * r], err, NOISE_ULPS * f64::EPSILON * r.abs() * noise)
}

/// `∫₀ʰ f` for a smooth 2-vector integrand by recursive bisection of G7K15 panels until
/// each panel's estimate is at most `QUAD_TOL·|panel|` or at the level its rounding noise
/// can make (so the total error is below `QUAD_TOL·|h|` plus the integrand's rounding
/// noise integrated over the step); `None` if that takes more than `MAX_PANELS` panels,
/// a panel can no longer be halved in `f64`, or the integrand is not finite.
fn integrate(f: &Integrand<'_>, h: f64) -> Option<[f64; 2]> {
    fn panel(f: &Integrand<'_>, a: f64, b: f64, budget: &mut usize) -> Option<[f64; 2]> {
        *budget = budget.checked_sub(1)?;
        let (k, err, floor) = gk15(f, a, b);
        if err <= (QUAD_TOL * (b - a).abs()).max(floor) {
            return Some(k);
        }
        let m = 0.5 * (a + b);
        if !err.is_finite() || m == a || m == b {
            return None;
        }
        let (l, r) = (panel(f, a, m, budget)?, panel(f, m, b, budget)?);
        Some([l[0] + r[0], l[1] + r[1]])
    }
    if h == 0.0 {
        return Some([0.0; 2]);
    }
    let mut budget = MAX_PANELS;
    panel(f, 0.0, h, &mut budget)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn both(g: impl Fn(f64) -> f64) -> impl Fn(f64) -> ([f64; 2], f64) {
        move |s| ([g(s), 0.0], 0.0)
    }

    #[test]
    fn gauss_kronrod_nodes_integrate_polynomials_exactly() {
        // K15 is exact to degree 23, G7 to degree 13, on [−1, 1]
        for p in 0..=23 {
            let f = |s: f64| ([s.powi(p), 0.0], 0.0);
            let (k, err, _) = gk15(&f, -1.0, 1.0);
            let exact = if p % 2 == 0 { 2.0 / (p as f64 + 1.0) } else { 0.0 };
            assert!((k[0] - exact).abs() <= 4e-16, "K15, degree {p}: {} vs {exact}", k[0]);
            if p <= 13 {
                assert!(err <= 4e-16, "G7, degree {p}: |K − G| = {err}");
            }
        }
        // weights sum to the interval length
        let (k, _, _) = gk15(&|_| ([1.0, 1.0], 0.0), 0.0, 3.0);
        assert!((k[0] - 3.0).abs() <= 1e-15 && (k[1] - 3.0).abs() <= 1e-15);
    }

    #[test]
    fn adaptive_quadrature_integrates_known_integrals_to_1e_15() {
        type Case = (&'static str, Box<dyn Fn(f64) -> f64>, f64, f64);
        let cases: [Case; 6] = [
            ("exp on [0, 1]", Box::new(f64::exp), 1.0, std::f64::consts::E - 1.0),
            ("cos on [0, π/2]", Box::new(f64::cos), std::f64::consts::FRAC_PI_2, 1.0),
            (
                "1/(1 + 25 s²) on [0, 1] (Runge)",
                Box::new(|s: f64| 1.0 / (1.0 + 25.0 * s * s)),
                1.0,
                5f64.atan() / 5.0,
            ),
            (
                "cos(40 s) on [0, 10] (oscillatory)",
                Box::new(|s: f64| (40.0 * s).cos()),
                10.0,
                400f64.sin() / 40.0,
            ),
            (
                "√s on [0, 1] (endpoint singularity)",
                Box::new(f64::sqrt),
                1.0,
                2.0 / 3.0,
            ),
            (
                "e^s backwards on [0, −2]",
                Box::new(f64::exp),
                -2.0,
                (-2f64).exp() - 1.0,
            ),
        ];
        for (name, g, h, exact) in cases {
            let got = integrate(&both(g), h).unwrap()[0];
            assert!(
                (got - exact).abs() <= 1e-15 * exact.abs().max(1.0),
                "{name}: {got} vs {exact} (error {:e})",
                got - exact
            );
        }
        // a non-integrable integrand fails instead of returning a wrong number, also when
        // only one component is bad
        assert!(integrate(&both(|s: f64| 1.0 / s), 1.0).is_none());
        assert!(integrate(&|s: f64| ([1.0, 1.0 / s], 0.0), 1.0).is_none());
        assert!(integrate(&|s: f64| ([if s > 0.5 { f64::NAN } else { 1.0 }, 0.0], 0.0), 1.0).is_none());
    }
}

//! Linear stability: `x' = λx` gives `x₁ = R(hλ)·x₀`; a method is stable at `z = hλ`
//! when `|R(z)| ≤ 1`.

use crate::error::{Error, Result};
use crate::methods::Euler;
use crate::{Options, Problem};
use nalgebra::vector;
use num_complex::Complex64;

/// Methods with a stability function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum StabilityOf {
    /// `R(z) = 1 + z`: the disk of radius 1 around −1.
    Euler,
    /// `R(z) = 1/(1 − z)`: everything outside the disk of radius 1 around +1.
    ImplicitEuler,
    /// `R(z) = Σ_{k≤5} z^k/k! + z⁶/600` (Dormand–Prince 5).
    Rk45,
}

/// The stability function `R(z)`.
///
/// ```
/// use reckon::studies::stability::{amplification, StabilityOf};
/// use num_complex::Complex64;
/// assert_eq!(amplification(StabilityOf::Euler, Complex64::new(-2.0, 0.0)).norm(), 1.0);
/// assert_eq!(amplification(StabilityOf::ImplicitEuler, Complex64::new(-1.0, 0.0)).re, 0.5);
/// ```
pub fn amplification(m: StabilityOf, z: Complex64) -> Complex64 {
    let one = Complex64::new(1.0, 0.0);
    match m {
        StabilityOf::Euler => one + z,
        StabilityOf::ImplicitEuler => one / (one - z),
        StabilityOf::Rk45 => {
            // Horner: 1 + z(1 + z(1/2 + z(1/6 + z(1/24 + z(1/120 + z/600)))))
            let c = [1.0, 1.0, 0.5, 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0, 1.0 / 600.0];
            c.iter().rev().fold(Complex64::new(0.0, 0.0), |acc, &ck| acc * z + ck)
        }
    }
}

/// Where the stability boundary crosses the negative real axis, by bisection on
/// `|R(x)| = 1` (Euler −2, DP5 −3.3066; implicit Euler has none: `-∞`).
///
/// ```
/// use reckon::studies::stability::{real_axis_limit, StabilityOf};
/// assert!((real_axis_limit(StabilityOf::Rk45) + 3.3065678926349467).abs() < 1e-12);
/// ```
pub fn real_axis_limit(m: StabilityOf) -> f64 {
    if m == StabilityOf::ImplicitEuler {
        return f64::NEG_INFINITY;
    }
    let g = |x: f64| amplification(m, Complex64::new(x, 0.0)).norm() - 1.0;
    let (mut lo, mut hi) = (-10.0, -1e-3); // g(lo) > 0 (unstable), g(hi) < 0 (stable)
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if g(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// Boundary `|R(z)| = 1` inside a window, as line segments from marching squares on an
/// `n × n` grid (for plotting the stability region).
pub fn boundary(m: StabilityOf, re: (f64, f64), im: (f64, f64), n: usize) -> Vec<[(f64, f64); 2]> {
    let n = n.max(2);
    let x = |i: usize| re.0 + (re.1 - re.0) * i as f64 / (n - 1) as f64;
    let y = |j: usize| im.0 + (im.1 - im.0) * j as f64 / (n - 1) as f64;
    let g: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            (0..n)
                .map(|j| amplification(m, Complex64::new(x(i), y(j))).norm() - 1.0)
                .collect()
        })
        .collect();
    let mut segs = Vec::new();
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            // corners counter-clockwise; points where g changes sign on each edge
            let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            let mut pts = Vec::with_capacity(4);
            for e in 0..4 {
                let (a, b) = (corners[e], corners[(e + 1) % 4]);
                let (ga, gb) = (g[a.0][a.1], g[b.0][b.1]);
                if (ga <= 0.0) != (gb <= 0.0) {
                    let s = ga / (ga - gb);
                    pts.push((x(a.0) + s * (x(b.0) - x(a.0)), y(a.1) + s * (y(b.1) - y(a.1))));
                }
            }
            for pair in pts.chunks_exact(2) {
                segs.push([pair[0], pair[1]]);
            }
        }
    }
    segs
}

/// Locate explicit Euler's instability threshold on `x' = λx` (λ < 0) numerically: the
/// step `h` above which `n` steps make `|x|` grow, found by bisection on actual runs of
/// the integrator. Theory: `h* = 2/|λ|`.
///
/// ```
/// use reckon::studies::stability::euler_threshold;
/// let h = euler_threshold(-50.0, 200).unwrap();
/// assert!((h - 2.0 / 50.0).abs() < 0.01 * 2.0 / 50.0);
/// ```
pub fn euler_threshold(lambda: f64, n: usize) -> Result<f64> {
    if !(lambda < 0.0 && lambda.is_finite()) {
        return Err(Error::invalid(
            "lambda",
            format!("must be negative and finite, got {lambda}"),
        ));
    }
    let f = crate::model!(|_t, x: [S; 1]| vector![x[0] * lambda]);
    let grows = |h: f64| -> Result<bool> {
        let p = Problem::new(&f, vector![1.0], (0.0, n as f64 * h));
        let sol = p.solve(Euler, &Options::default().fixed(h).dense(false))?;
        Ok(sol.last().1[0].abs() > 1.0)
    };
    let (mut lo, mut hi) = (1e-6 / lambda.abs(), 10.0 / lambda.abs());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if grows(mid)? { hi = mid } else { lo = mid }
    }
    Ok(0.5 * (lo + hi))
}

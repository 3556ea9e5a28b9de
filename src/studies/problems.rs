//! Standard test problems with exact solutions or published reference values
//! (Hairer–Nørsett–Wanner; the Bari Test Set; see `docs/guide.md`).

use nalgebra::{Const, Dyn, Matrix2, Vector1, Vector2, Vector3, Vector4, vector};

/// Rotation–decay `x' = A x`, `A = [[−a, −ω], [ω, −a]]` with `a = 0.5`, `ω = 2`.
pub fn rotation_decay() -> impl crate::DualSystem<Const<2>> + Clone {
    crate::model!(|_t, x: [S; 2]| vector![x[0] * -0.5 - x[1] * 2.0, x[0] * 2.0 - x[1] * 0.5])
}

/// Exact solution of [`rotation_decay`]: `x(t) = e^{−at} R(ωt) x₀`.
pub fn rotation_decay_exact(t: f64, x0: &Vector2<f64>) -> Vector2<f64> {
    let (s, c) = (2.0 * t).sin_cos();
    Matrix2::new(c, -s, s, c) * x0 * (-0.5 * t).exp()
}

/// `u' = sin u`.
pub fn sin_u() -> impl crate::DualSystem<Const<1>> + Clone {
    crate::model!(|_t, x: [S; 1]| vector![x[0].sin()])
}

/// Exact solution of [`sin_u`]: `u(t) = 2 atan(eᵗ tan(u₀/2))` for `|u₀| < π`.
pub fn sin_u_exact(t: f64, u0: f64) -> Vector1<f64> {
    Vector1::new(2.0 * (t.exp() * (0.5 * u0).tan()).atan())
}

/// The stiff scalar problem `x' = −1000(x − cos t) − sin t`; `x = cos t` when `x(0) = 1`.
pub fn stiff_cosine() -> impl crate::DualSystem<Const<1>> + Clone {
    crate::model!(|t: S, x: [S; 1]| vector![(x[0] - t.cos()) * -1000.0 - t.sin()])
}

/// Arenstorf orbit parameter μ.
pub const ARENSTORF_MU: f64 = 0.012277471;
/// Arenstorf initial state `(y1, y2, y1', y2')`, digits as published.
#[allow(clippy::excessive_precision)]
pub const ARENSTORF_Y0: [f64; 4] = [0.994, 0.0, 0.0, -2.00158510637908252240537862224];
/// Arenstorf period, digits as published.
#[allow(clippy::excessive_precision)]
pub const ARENSTORF_T: f64 = 17.0652165601579625588917206249;

/// The Arenstorf orbit of the restricted three-body problem (HNW ODE I §II.0).
pub fn arenstorf() -> impl crate::DualSystem<Const<4>> + Clone {
    crate::model!(|_, y: [S; 4]| {
        let mu = ARENSTORF_MU;
        let mu1 = 1.0 - mu;
        // r³ as r²·√(r²): exact to rounding and far cheaper than powf(1.5)
        let r1 = (y[0] + mu).powi(2) + y[1].powi(2);
        let r2 = (y[0] - mu1).powi(2) + y[1].powi(2);
        let d1 = r1.clone() * r1.sqrt();
        let d2 = r2.clone() * r2.sqrt();
        vector![
            y[2],
            y[3],
            y[0] + y[3] * 2.0 - (y[0] + mu) * mu1 / d1 - (y[0] - mu1) * mu / d2,
            y[1] - y[2] * 2.0 - y[1] * mu1 / d1 - y[1] * mu / d2
        ]
    })
}

/// Arenstorf initial state as a vector.
pub fn arenstorf_y0() -> Vector4<f64> {
    Vector4::from(ARENSTORF_Y0)
}

/// Van der Pol in μ form: `y1' = y2`, `y2' = μ(1 − y1²)y2 − y1`.
pub fn van_der_pol(mu: f64) -> impl crate::DualSystem<Const<2>> + Clone {
    crate::model!(|_, y: [S; 2]| vector![y[1], (-y[0] * y[0] + 1.0) * y[1] * mu - y[0]])
}

/// Robertson's chemical kinetics, `k = (0.04, 3e7, 1e4)`, `y0 = (1, 0, 0)`.
pub fn robertson() -> impl crate::DualSystem<Const<3>> + Clone {
    crate::model!(|_, y: [S; 3]| vector![
        y[0] * -0.04 + y[1] * y[2] * 1e4,
        y[0] * 0.04 - y[1] * y[1] * 3e7 - y[1] * y[2] * 1e4,
        y[1] * y[1] * 3e7
    ])
}

/// OREGO, the Oregonator (Test Set `orego.f`): `y1' = s(y2 + y1(1 − q·y1 − y2))`,
/// `y2' = (y3 − (1 + y1)·y2)/s`, `y3' = w(y1 − y3)` with `s = 77.27`, `q = 8.375e-6`,
/// `w = 0.161`, `y0 = (1, 2, 3)`; reference at `t = 360` in [`OREGO_REF_360`].
pub fn orego() -> impl crate::DualSystem<Const<3>> + Clone {
    const S_: f64 = 77.27;
    const Q: f64 = 8.375e-6;
    const W: f64 = 0.161;
    crate::model!(|_, y: [S; 3]| vector![
        (y[1].clone() + y[0].clone() * (-y[0].clone() * Q - y[1].clone() + 1.0)) * S_,
        (y[2].clone() - (y[0].clone() + 1.0) * y[1].clone()) * (1.0 / S_),
        (y[0].clone() - y[2].clone()) * W
    ])
}

/// OREGO's state at `t = 360` (Test Set `orego.f`; the report's table agrees to 12.8 digits).
pub const OREGO_REF_360: [f64; 3] = [1.000814870318523, 1228.178521549917, 132.0554942846706];

/// E5 (Hairer–Wanner IV, Test Set `e5.f`), badly scaled chemical kinetics:
/// `p₁ = a·y1`, `p₂ = b·y1·y3`, `p₃ = c·m·y2·y3`, `p₄ = c·y4`,
/// `y' = (−p₁ − p₂, f₂, f₂ − f₄, f₄)` with `f₂ = p₁ − p₃`, `f₄ = p₂ − p₄`, `a = 7.89e-10`,
/// `b = 1.1e7`, `c = 1.13e3`, `m = 1e6`, `y0 = (1.76e-3, 0, 0, 0)`; the Test Set's `atol`
/// is 1.7e-24. Reference at `t = 1e5` in [`E5_REF_1E5`].
///
/// `y3' = f₂ − f₄` is evaluated as the Test Set's `feval` (and Hairer's `FE5`) does, not
/// expanded to `p₁ − p₂ − p₃ + p₄`: `p₂ ≈ p₄ ≈ 1.8e-10` while `y3 ≈ 2e-12`, and the expanded
/// sum's rounding (~eps·p₂ per unit time) drifts the invariant `y2 − y3 − y4 = 0` by
/// ~1e-20 over [0, 1e5]; every method then stops at 8–9 correct digits (measured
/// 2026-12-07, `examples/tolerance_sweep.rs`).
pub fn e5() -> impl crate::DualSystem<Const<4>> + Clone {
    const A: f64 = 7.89e-10;
    const B: f64 = 1.1e7;
    const C: f64 = 1.13e3;
    const M: f64 = 1e6;
    crate::model!(|_, y: [S; 4]| {
        let p1 = y[0].clone() * A;
        let p2 = y[0].clone() * y[2].clone() * B;
        let p3 = y[1].clone() * y[2].clone() * (C * M);
        let p4 = y[3].clone() * C;
        let f2 = p1.clone() - p3;
        let f4 = p2.clone() - p4;
        vector![-p1 - p2, f2.clone(), f2 - f4.clone(), f4]
    })
}

/// E5's state at `t = 1e5`, good to 15–16 significant digits: 7-stage Radau IIA (order
/// 13) in 32-digit mpmath arithmetic with full Newton on a graded mesh, 1 600 steps; 800
/// steps, another mesh at 40 digits and the 5-stage method at 3 200 steps agree with it
/// to 1e-16 (`docs/data/e5/`). scipy's Radau at rtol 1e-13 is 0.7–2.2e-10 off.
pub const E5_REF_1E5: [f64; 4] = [
    7.481320822429222e-06,
    2.373478156120598e-12,
    2.212358668958166e-12,
    1.611194871624311e-13,
];

/// HIRES, "high irradiance responses" of photomorphogenesis (Test Set `hires.f`), 8 states,
/// `y0 = (1, 0, 0, 0, 0, 0, 0, 0.0057)`; reference at `t = 321.8122` in [`HIRES_REF`].
pub fn hires() -> impl crate::DualSystem<Const<8>> + Clone {
    crate::model!(|_, y: [S; 8]| vector![
        y[0].clone() * -1.71 + y[1].clone() * 0.43 + y[2].clone() * 8.32 + 0.0007,
        y[0].clone() * 1.71 - y[1].clone() * 8.75,
        y[2].clone() * -10.03 + y[3].clone() * 0.43 + y[4].clone() * 0.035,
        y[1].clone() * 8.32 + y[2].clone() * 1.71 - y[3].clone() * 1.12,
        y[4].clone() * -1.745 + (y[5].clone() + y[6].clone()) * 0.43,
        -(y[5].clone() * y[7].clone() * 280.0) + y[3].clone() * 0.69 + y[4].clone() * 1.71 - y[5].clone() * 0.43
            + y[6].clone() * 0.69,
        y[5].clone() * y[7].clone() * 280.0 - y[6].clone() * 1.81,
        -(y[5].clone() * y[7].clone() * 280.0) + y[6].clone() * 1.81
    ])
}

/// HIRES initial state.
pub fn hires_y0() -> nalgebra::SVector<f64, 8> {
    nalgebra::SVector::<f64, 8>::from([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0057])
}

/// HIRES end time of the Test Set.
pub const HIRES_T: f64 = 321.8122;

/// HIRES state at [`HIRES_T`] (Test Set Table II.1.1).
pub const HIRES_REF: [f64; 8] = [
    7.371312573325668e-4,
    1.442485726316185e-4,
    5.888729740967575e-5,
    1.175651343283149e-3,
    2.386356198831331e-3,
    6.238968252742796e-3,
    2.849998395185769e-3,
    2.850001604814231e-3,
];

/// Robertson's state at `t = 1e11` (Test Set `rober.f`).
pub const ROBERTSON_REF_1E11: [f64; 3] = [2.083340149701255e-8, 8.333360770334713e-14, 0.999_999_979_166_505];

/// Robertson's state at `t = 1e5` from `y0 = (1, 0, 0)` (issue 9's work–precision end point):
/// scipy 1.17 `Radau` at `rtol = 1e-13`, `atol = 1e-24` with the exact Jacobian (it agrees
/// with its own `rtol = 1e-12` run to 14.4 significant digits). Independently, reckon's
/// [`Rodas5P`](crate::methods::Rodas5P) at `rtol = 1e-13`, `atol = 1e-22` agrees to 12.4
/// significant digits in every component and [`Bdf`](crate::methods::Bdf) to 11.1
/// (`examples/stiff_wp.rs refs`).
pub const ROBERTSON_REF_1E5: [f64; 3] = [1.786592114209994e-2, 7.274751468436521e-8, 0.982_134_006_110_384_5];

/// OREGO's state at `t = 30` from `y0 = (1, 2, 3)` (issue 9's work–precision end point):
/// scipy 1.17 `Radau` at `rtol = 1e-13`, `atol = 1e-14` with the exact Jacobian (it agrees
/// with its own `rtol = 1e-12` run to 14.0 significant digits). Independently, reckon's
/// [`Rodas5P`](crate::methods::Rodas5P) at `rtol = 1e-13`, `atol = 1e-14` agrees to 12.7
/// significant digits in every component and [`Bdf`](crate::methods::Bdf) to 11.5
/// (`examples/stiff_wp.rs refs`).
pub const OREGO_REF_30: [f64; 3] = [1.0006614671804968, 1512.7789373482335, 10358.543127672505];

/// Van der Pol μ = 1000 from `(2, 0)` at `t = 2000` (Test Set `vdpolm.f`).
pub const VDPOLM_REF_2000: [f64; 2] = [1.706167732170469, -0.8928097010248125e-3];

/// Lorenz with σ = 10, ρ = 28, β = 8/3.
pub fn lorenz() -> impl crate::DualSystem<Const<3>> + Clone {
    crate::model!(|_, y: [S; 3]| vector![
        (y[1] - y[0]) * 10.0,
        y[0] * (-y[2] + 28.0) - y[1],
        y[0] * y[1] - y[2] * (8.0 / 3.0)
    ])
}

/// Initial state `(1, 1, 1)` for [`lorenz`].
pub fn lorenz_y0() -> Vector3<f64> {
    Vector3::new(1.0, 1.0, 1.0)
}

/// The 1-D Brusselator with `n` grid points (HNW ODE II §IV.1, (1.6′), BRUSS; A = 1,
/// B = 3, α = 1/50): state `(u₁, v₁, …, u_n, v_n)`,
/// `u_i' = 1 + u_i²v_i − 4u_i + α(n+1)²(u_{i−1} − 2u_i + u_{i+1})`,
/// `v_i' = 3u_i − u_i²v_i + α(n+1)²(v_{i−1} − 2v_i + v_{i+1})`, boundary values
/// `u₀ = u_{n+1} = 1`, `v₀ = v_{n+1} = 3`, on `t ∈ [0, 10]` from [`brusselator_y0`].
///
/// ```
/// use reckon::{studies::problems::{brusselator, brusselator_y0}, System};
/// let (f, y0) = (brusselator(3), brusselator_y0(3));
/// let mut d = y0.clone();
/// f.rhs(0.0, &y0, &[], &mut d);
/// // v₂ = 3 between v₁ = v₃ = 3: no diffusion, v₂' = 3u₂ − 3u₂² at u₂ = 1 (sin π = 0)
/// assert!((y0[2] - 1.0).abs() < 1e-15 && d[3].abs() < 1e-13);
/// ```
pub fn brusselator(n: usize) -> impl crate::DualSystem<Dyn> + Clone {
    let c = (n as f64 + 1.0).powi(2) / 50.0;
    crate::model!(|_, y: [S; Dyn]| {
        let n = y.len() / 2;
        nalgebra::DVector::from_fn(2 * n, |k, _| {
            let i = k / 2;
            let (own, bc) = if k % 2 == 0 { (0, 1.0) } else { (1, 3.0) };
            let at = |j: usize| y[2 * j + own].clone();
            let left = if i == 0 { S::from(bc) } else { at(i - 1) };
            let right = if i + 1 == n { S::from(bc) } else { at(i + 1) };
            let (u, v) = (y[2 * i].clone(), y[2 * i + 1].clone());
            let diff = (left + right - at(i) * 2.0) * c;
            let uuv = u.clone() * u.clone() * v;
            if own == 0 {
                uuv - u * 4.0 + 1.0 + diff
            } else {
                u * 3.0 - uuv + diff
            }
        })
    })
}

/// [`brusselator`]'s initial state in the convention of the widely used reference
/// values: `u_i = 1 + ½·sin(2πx_i)`, `v_i = 3`, `x_i = i/(n+1)`.
///
/// HNW ODE II §IV.1 (1.6′) prints `u_i = 1 + sin(2πx_i)` (amplitude 1, kept as
/// [`brusselator_y0_book`]), but the reference values that are widely copied for BRUSS
/// were computed with amplitude ½ (the shared `REFERENCES.md`, note 3); reckon follows
/// them, so that its end state can be checked against published and independently
/// computed numbers (`tests/it/sparse.rs` holds scipy Radau's at `t = 10`, see
/// `docs/references.md`).
///
/// ```
/// let y0 = reckon::studies::problems::brusselator_y0(3); // x = ¼, ½, ¾
/// assert_eq!(y0.len(), 6);
/// assert!((y0[0] - 1.5).abs() < 1e-15 && (y0[4] - 0.5).abs() < 1e-15);
/// assert_eq!((y0[1], y0[3], y0[5]), (3.0, 3.0, 3.0));
/// ```
pub fn brusselator_y0(n: usize) -> nalgebra::DVector<f64> {
    brusselator_y0_amplitude(n, 0.5)
}

/// [`brusselator`]'s initial state as HNW ODE II §IV.1 (1.6′) prints it:
/// `u_i = 1 + sin(2πx_i)`, `v_i = 3`, `x_i = i/(n+1)` (amplitude 1, which
/// DiffEqProblemLibrary's `prob_ode_brusselator_1d` copies, "Page 6"). The widely copied
/// reference values use amplitude ½ instead ([`brusselator_y0`]); this one is kept for
/// comparison with the book's text and with codes that follow it.
///
/// ```
/// let y0 = reckon::studies::problems::brusselator_y0_book(3); // x = ¼, ½, ¾
/// assert!((y0[0] - 2.0).abs() < 1e-15 && y0[4].abs() < 1e-15);
/// assert_eq!(y0[1], 3.0);
/// ```
pub fn brusselator_y0_book(n: usize) -> nalgebra::DVector<f64> {
    brusselator_y0_amplitude(n, 1.0)
}

/// `u_i = 1 + a·sin(2πx_i)`, `v_i = 3`, `x_i = i/(n+1)`, interleaved `(u₁, v₁, …)`.
fn brusselator_y0_amplitude(n: usize, a: f64) -> nalgebra::DVector<f64> {
    nalgebra::DVector::from_fn(2 * n, |k, _| {
        let x = (k / 2 + 1) as f64 / (n as f64 + 1.0);
        if k % 2 == 0 {
            1.0 + a * (2.0 * std::f64::consts::PI * x).sin()
        } else {
            3.0
        }
    })
}

/// The 2-D Brusselator of the DifferentialEquations.jl benchmarks on an `n × n` periodic
/// grid (`2n²` states): with `x_i = i/(n−1)`, `y_j = j/(n−1)` (`i, j = 0..n`, Julia's
/// `range(0, 1, length = n)`, so `x = 0` and `x = 1` are distinct points joined by the
/// periodic wrap), `Δ = 1/(n−1)` and `A = 3.4`, `B = 1`, `α = 10`,
///
/// `u' = B + u²v − (A + 1)u + (α/Δ²)(u_{i−1,j} + u_{i+1,j} + u_{i,j−1} + u_{i,j+1} − 4u) + f(x, y, t)`,
/// `v' = A·u − u²v + (α/Δ²)(v_{i−1,j} + v_{i+1,j} + v_{i,j−1} + v_{i,j+1} − 4v)`,
///
/// indices modulo `n`, forcing `f = 5` where `(x − 0.3)² + (y − 0.6)² ≤ 0.1²` and
/// `t ≥ 1.1` (0 elsewhere); span `[0, 11.5]`, initial state [`brusselator_2d_y0`]. The state
/// is Julia's `vec` of an `n × n × 2` array: `u_{ij}` at `i + n·j`, `v_{ij}` at
/// `n² + i + n·j`. The forcing switches on at `t = 1.1`: give it as a breakpoint
/// (`Options::breakpoints([1.1])`) so that no step straddles it.
///
/// Source: SciMLBenchmarks.jl `benchmarks/StiffODE/Bruss.jmd` (`brusselator_2d_loop`,
/// `p = (3.4, 1.0, 10.0, step(xyd))`, span `(0, 11.5)`), the same as DiffEqDocs' "Solving
/// Large Stiff Equations" and DiffEqGPU.jl `docs/src/examples/bruss.md`, whose printed
/// `f(u₀, 0)` values at `n = 32` the tests check.
///
/// ```
/// use reckon::{studies::problems::{brusselator_2d, brusselator_2d_y0}, System};
/// let (f, y0) = (brusselator_2d(32), brusselator_2d_y0(32));
/// let mut du = y0.clone();
/// f.rhs(0.0, &y0, &[], &mut du);
/// assert!((du[33] - 802.9807693762164).abs() < 1e-9); // DiffEqGPU.jl: du[34] (1-based)
/// f.rhs(1.3, &y0, &[], &mut du);
/// assert!((du[520] - -318.1677459142322).abs() < 1e-9); // inside the forcing disc: +5
/// ```
pub fn brusselator_2d(n: usize) -> impl crate::DualSystem<Dyn> + Clone {
    let dx = 1.0 / (n as f64 - 1.0);
    let alpha = 10.0 / (dx * dx);
    crate::model!(|t, y: [S; Dyn]| {
        let nn = n * n;
        nalgebra::DVector::from_fn(y.len(), |k, _| {
            let (s, ij) = (k / nn, k % nn);
            let (i, j) = (ij % n, ij / n);
            let at = |i: usize, j: usize| y[i + n * j + nn * s].clone();
            let (ip, im) = ((i + 1) % n, (i + n - 1) % n);
            let (jp, jm) = ((j + 1) % n, (j + n - 1) % n);
            let lap = (at(im, j) + at(ip, j) + at(i, jp) + at(i, jm) - at(i, j) * 4.0) * alpha;
            let (u, v) = (y[ij].clone(), y[nn + ij].clone());
            let uuv = u.clone() * u.clone() * v;
            if s == 0 {
                let (x, yy) = (i as f64 * dx, j as f64 * dx);
                let inside = (x - 0.3) * (x - 0.3) + (yy - 0.6) * (yy - 0.6) <= 0.1 * 0.1;
                let forcing = if inside && t >= 1.1 { 5.0 } else { 0.0 };
                lap + uuv - u * 4.4 + 1.0 + forcing
            } else {
                lap + u * 3.4 - uuv
            }
        })
    })
}

/// [`brusselator_2d`]'s initial state: `u = 22·(y(1 − y))^{3/2}`, `v = 27·(x(1 − x))^{3/2}`
/// at `(x_i, y_j)`, `u_{ij}` at `i + n·j`, `v_{ij}` at `n² + i + n·j`.
///
/// ```
/// // n = 3: x, y ∈ {0, ½, 1}; at (x₁, y₁) = (½, ½) both are 22·(¼)^{3/2} = 2.75, 27/8
/// let y0 = reckon::studies::problems::brusselator_2d_y0(3);
/// assert_eq!(y0.len(), 18);
/// assert!((y0[4] - 2.75).abs() < 1e-15 && (y0[9 + 4] - 27.0 / 8.0).abs() < 1e-15);
/// assert_eq!(y0[0], 0.0); // u at y = 0
/// ```
pub fn brusselator_2d_y0(n: usize) -> nalgebra::DVector<f64> {
    let dx = 1.0 / (n as f64 - 1.0);
    nalgebra::DVector::from_fn(2 * n * n, |k, _| {
        let (s, ij) = (k / (n * n), k % (n * n));
        let (x, y) = ((ij % n) as f64 * dx, (ij / n) as f64 * dx);
        if s == 0 {
            22.0 * (y * (1.0 - y)).powf(1.5)
        } else {
            27.0 * (x * (1.0 - x)).powf(1.5)
        }
    })
}

const AK_K1: f64 = 18.7;
const AK_K2: f64 = 0.58;
const AK_K3: f64 = 0.09;
const AK_K4: f64 = 0.42;
const AK_KBIG: f64 = 34.4;
const AK_KLA: f64 = 3.3;
/// The Akzo Nobel problem's `Ks`.
pub const AK_KS: f64 = 115.83;
const AK_PO2: f64 = 0.9;
const AK_HEN: f64 = 737.0;

/// The chemical Akzo Nobel problem (Test Set `chemakzo.F` rev 1.2), an index-1 DAE with
/// `M = diag(1, 1, 1, 1, 1, 0)`: six components, the last algebraic
/// (`0 = Ks·y₁·y₄ − y₆`), on [0, 180] from [`chemakzo_y0`].
pub fn chemakzo() -> impl crate::DualSystem<Const<6>> + Clone {
    const K2K: f64 = AK_K2 / AK_KBIG;
    const PH: f64 = AK_PO2 / AK_HEN;
    crate::model!(|_t, y: [S; 6]| {
        let sqy2 = y[1].clone().sqrt();
        let r1 = S::from(AK_K1) * y[0].clone() * y[0].clone() * y[0].clone() * y[0].clone() * sqy2.clone();
        let r2 = S::from(AK_K2) * y[2].clone() * y[3].clone();
        let r3 = S::from(K2K) * y[0].clone() * y[4].clone();
        let r4 = S::from(AK_K3) * y[0].clone() * y[3].clone() * y[3].clone();
        let r5 = S::from(AK_K4) * (y[5].clone() * y[5].clone()) * sqy2;
        let fin = S::from(AK_KLA) * (S::from(PH) - y[1].clone());
        vector![
            -2.0 * r1.clone() + r2.clone() - r3.clone() - r4.clone(),
            -0.5 * r1.clone() - r4.clone() - 0.5 * r5.clone() + fin,
            r1.clone() - r2.clone() + r3.clone(),
            -r2.clone() + r3.clone() - 2.0 * r4,
            r2 - r3 + r5,
            S::from(AK_KS) * y[0].clone() * y[3].clone() - y[5].clone()
        ]
    })
}
/// [`chemakzo`] at `t = 180` (`chemakzo.F`: PSIDE at rtol = atol = 1e-19).
pub const CHEMAKZO_REF_180: [f64; 6] = [
    0.1150794920661702,
    0.1203831471567715e-2,
    0.1611562887407974,
    0.3656156421249283e-3,
    0.1708010885264404e-1,
    0.4873531310307455e-2,
];
/// [`chemakzo`]'s consistent start (`y₆ = Ks·y₁·y₄` in the same rounding as `f`).
pub fn chemakzo_y0() -> nalgebra::SVector<f64, 6> {
    vector![0.444, 0.00123, 0.0, 0.007, 0.0, AK_KS * 0.444 * 0.007]
}

const TA_UB: f64 = 6.0;
const TA_UF: f64 = 0.026;
const TA_ALPHA: f64 = 0.99;
const TA_OMA: f64 = 1.0 - TA_ALPHA;
const TA_BETA: f64 = 1e-6;
const TA_R0: f64 = 1000.0;
const TA_R: f64 = 9000.0;
const TA_W: f64 = 200.0 * std::f64::consts::PI;

/// The transistor amplifier (Test Set `transamp.F` rev 1.3), an index-1 DAE with
/// [`transamp_mass`]: eight node voltages, `M` of rank 5 (the capacitors), on [0, 0.2]
/// driven by `U_e(t) = 0.1·sin(200πt)`, from `y₀ = (0, 3, 3, 6, 3, 3, 6, 0)`.
pub fn transamp() -> impl crate::DualSystem<Const<8>> + Clone {
    crate::model!(|t: S, y: [S; 8]| {
        let uet = (t * TA_W).sin() * 0.1;
        let fac1 = (((y[1].clone() - y[2].clone()) / TA_UF).exp() - 1.0) * TA_BETA;
        let fac2 = (((y[4].clone() - y[5].clone()) / TA_UF).exp() - 1.0) * TA_BETA;
        vector![
            (y[0].clone() - uet) / TA_R0,
            y[1].clone() / TA_R + (y[1].clone() - TA_UB) / TA_R + fac1.clone() * TA_OMA,
            y[2].clone() / TA_R - fac1.clone(),
            (y[3].clone() - TA_UB) / TA_R + fac1 * TA_ALPHA,
            y[4].clone() / TA_R + (y[4].clone() - TA_UB) / TA_R + fac2.clone() * TA_OMA,
            y[5].clone() / TA_R - fac2.clone(),
            (y[6].clone() - TA_UB) / TA_R + fac2 * TA_ALPHA,
            y[7].clone() / TA_R
        ]
    })
}
/// [`transamp`]'s mass matrix (the Test Set's signs: `M·y' = f`).
pub fn transamp_mass() -> nalgebra::DMatrix<f64> {
    let (c1, c2, c3, c4, c5) = (1e-6, 2e-6, 3e-6, 4e-6, 5e-6);
    #[rustfmt::skip]
    let m = nalgebra::DMatrix::from_row_slice(8, 8, &[
        -c1,  c1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
         c1, -c1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, -c2, 0.0, 0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, -c3,  c3, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0,  c3, -c3, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, -c4, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -c5,  c5,
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0,  c5, -c5,
    ]);
    m
}
/// [`transamp`] at `t = 0.2` (`transamp.F`: PSIDE at rtol = atol = 1e-14).
pub const TRANSAMP_REF_02: [f64; 8] = [
    -0.5562145012262709e-2,
    0.3006522471903042e1,
    0.2849958788608128e1,
    0.2926422536206241e1,
    0.2704617865010554e1,
    0.2761837778393145e1,
    0.4770927631616772e1,
    0.1236995868091548e1,
];

/// Robertson with the conservation law as its third equation, `0 = y₁ + y₂ + y₃ − 1`
/// (`M = diag(1, 1, 0)`); its solution is [`robertson`]'s.
pub fn robertson_dae() -> impl crate::DualSystem<Const<3>> + Clone {
    crate::model!(|_t, y: [S; 3]| vector![
        -0.04 * y[0].clone() + y[1].clone() * y[2].clone() * 1.0e4,
        0.04 * y[0].clone() - y[1].clone() * y[2].clone() * 1.0e4 - y[1].clone() * y[1].clone() * 3.0e7,
        y[0].clone() + y[1].clone() + y[2].clone() - 1.0
    ])
}

//! Exponential Rosenbrock–Euler: order 2 on nonlinear problems, exact on linear ones at any
//! step, stable on stiff ones, and an adaptive mode whose error follows the tolerance.

use nalgebra::{Const, SVector, vector};
use reckon::methods::{Euler, ExponentialEuler};
use reckon::studies::fit_order;
use reckon::studies::problems::*;
use reckon::{Lti, Options, Problem, System, model};

fn end_error<const N: usize, S: System<Const<N>>>(
    p: &Problem<'_, Const<N>, S>,
    h: f64,
    exact: &SVector<f64, N>,
) -> f64 {
    let sol = p.solve(ExponentialEuler, &Options::default().fixed(h)).unwrap();
    assert_eq!(sol.last().0, p.t_end);
    (sol.last().1 - exact).amax()
}

#[test]
fn second_order_on_nonlinear_problems() {
    // u' = sin u (autonomous), fixed steps 0.1 … 0.00625, order by least squares
    let p = Problem::new(sin_u(), vector![1.0], (0.0, 2.0));
    let exact = sin_u_exact(2.0, 1.0);
    let hs: Vec<f64> = (0..5).map(|k| 0.1 / 2f64.powi(k)).collect();
    let errs: Vec<f64> = hs.iter().map(|&h| end_error(&p, h, &exact)).collect();
    let order = fit_order(&hs, &errs).unwrap();
    println!("sin u: {errs:?} order {order}");
    assert!((order - 2.0).abs() <= 0.1, "observed order {order}");
    // non-autonomous, through ∂f/∂t: x' = −2t·x² has x = 1/(1 + t²) from x(0) = 1 (∂f/∂t from the dual body)
    let f = model!(|t: S, x: [S; 1]| vector![x[0] * x[0] * t * -2.0]);
    let q = Problem::new(&f, vector![1.0], (0.0, 2.0));
    let exact = vector![1.0 / 5.0];
    let errs: Vec<f64> = hs.iter().map(|&h| end_error(&q, h, &exact)).collect();
    let order = fit_order(&hs, &errs).unwrap();
    println!("-2t x²: {errs:?} order {order}");
    assert!((order - 2.0).abs() <= 0.1, "observed order {order}");
}

#[test]
fn exact_on_linear_models_at_any_step() {
    // rotation–decay x' = A x: one step of any length is the exact flow
    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 6.0));
    let exact = rotation_decay_exact(6.0, &x0);
    // (absolute, |x₀| ≈ 1; 120 steps of 0.05 add up 120 roundings, still below 1e-13)
    for h in [6.0, 1.5, 0.1, 0.05] {
        let e = end_error(&p, h, &exact);
        assert!(e <= 1e-13, "h = {h}: {e:e}");
    }
    // an LTI model with a held input, stiff (λ = −1e4), h far beyond explicit stability
    let lti = Lti::new(
        nalgebra::Matrix2::new(-1e4, 1.0, 0.0, -1.0),
        nalgebra::Vector2::new(1.0, 1.0),
    )
    .unwrap();
    let p = Problem::new(&lti, vector![1.0, 1.0], (0.0, 2.0)).inputs(vec![3.0]);
    // x₂ = 3 − 2e^{−t}; x₁ = e^{−λt} + 6(1 − e^{−λt})/λ − 2(e^{−t} − e^{−λt})/(λ − 1), λ = 1e4
    let (l, t) = (1e4f64, 2.0f64);
    let want = vector![
        (-l * t).exp() + 6.0 * (1.0 - (-l * t).exp()) / l - 2.0 * ((-t).exp() - (-l * t).exp()) / (l - 1.0),
        3.0 - 2.0 * (-t).exp()
    ];
    for h in [2.0, 0.5, 0.05] {
        let sol = p.solve(ExponentialEuler, &Options::default().fixed(h)).unwrap();
        let e = (sol.last().1 - want).amax() / want.amax();
        assert!(e <= 1e-13, "h = {h}: {e:e}");
    }
    // adaptive: the estimate vanishes on a linear model, so the steps grow freely
    let sol = p
        .solve(ExponentialEuler, &Options::default().rtol(1e-10).atol(1e-12))
        .unwrap();
    assert!((sol.last().1 - want).amax() / want.amax() <= 1e-13);
    assert!(sol.stats.accepted <= 8, "{} steps", sol.stats.accepted);
}

#[test]
fn stable_on_the_stiff_cosine_problem() {
    // x' = −1000(x − cos t) − sin t, x = cos t: h = 0.1 is 50× explicit Euler's limit
    let p = Problem::new(stiff_cosine(), vector![1.0], (0.0, 10.0));
    let sol = p.solve(ExponentialEuler, &Options::default().fixed(0.1)).unwrap();
    assert_eq!(sol.stats.accepted, 100);
    let worst = sol
        .t
        .iter()
        .zip(&sol.x)
        .map(|(t, x)| (x[0] - t.cos()).abs())
        .fold(0.0, f64::max);
    println!("stiff cosine at h = 0.1: max error {worst:e}");
    // stable, and as accurate as the linearisation in t allows: the forcing
    // g = 1000 cos t − sin t is taken linear over a step, so x lags by about
    // h²·|g''|/(2·1000) ≤ 5e-3 (without ∂f/∂t it would be h·|g'|/1000 ≈ 0.1)
    assert!(worst < 5.1e-3, "max error {worst:e}");
    // explicit Euler at the same step blows up
    let e = p.solve(Euler, &Options::default().fixed(0.1));
    assert!(e.is_err() || e.unwrap().last().1[0].abs() > 1e10);
}

#[test]
fn adaptive_error_follows_the_tolerance() {
    // Van der Pol (μ = 1) has no closed form: a tight RK45 run is the reference. The
    // controller keeps the estimated local error per step at the tolerance, so a method
    // of order 2 has a global error ∝ tol^{2/3} (the steps scale like tol^{1/3}): the
    // fitted exponent checks the estimate's order and its scale together
    let p = Problem::new(van_der_pol(1.0), vector![2.0, 0.0], (0.0, 5.0));
    let reference = *p
        .solve(reckon::methods::Rk45, &Options::default().rtol(1e-13).atol(1e-13))
        .unwrap()
        .last()
        .1;
    let tols = [1e-5, 1e-6, 1e-7, 1e-8, 1e-9];
    let mut errs = Vec::new();
    let mut steps = Vec::new();
    for tol in tols {
        let sol = p
            .solve(ExponentialEuler, &Options::default().rtol(tol).atol(tol))
            .unwrap();
        let e = (sol.last().1 - reference).amax();
        println!(
            "tol {tol:e}: error {e:e}, {} steps, {} rejected",
            sol.stats.accepted, sol.stats.rejected
        );
        assert_eq!(sol.method, "exponential-euler");
        errs.push(e);
        steps.push(1.0 / sol.stats.accepted as f64);
    }
    let slope = fit_order(&tols, &errs).unwrap();
    let h_slope = fit_order(&tols, &steps).unwrap();
    println!("error ∝ tol^{slope:.3}, mean step ∝ tol^{h_slope:.3}");
    assert!((slope - 2.0 / 3.0).abs() <= 0.1, "error ∝ tol^{slope}");
    assert!((h_slope - 1.0 / 3.0).abs() <= 0.05, "step ∝ tol^{h_slope}");
}

#[test]
fn dense_output_is_hermite_between_the_steps() {
    // between two accepted steps the cubic Hermite interpolant adds at most h⁴·|x⁗|/384
    // to the error at the ends (|x⁗| ≤ 2 here)
    let p = Problem::new(sin_u(), vector![1.0], (0.0, 2.0));
    let sol = p
        .solve(ExponentialEuler, &Options::default().rtol(1e-6).atol(1e-6).dense(true))
        .unwrap();
    let err = |t: f64, x: f64| (x - sin_u_exact(t, 1.0)[0]).abs();
    for k in 1..80 {
        let t = k as f64 * 0.025;
        let x = sol.at(t).unwrap()[0];
        let i = sol.t.iter().position(|&s| s >= t).unwrap().max(1);
        let (t0, t1) = (sol.t[i - 1], sol.t[i]);
        let ends = err(t0, sol.x[i - 1][0]).max(err(t1, sol.x[i][0]));
        let h = t1 - t0;
        assert!(
            err(t, x) <= ends * 1.01 + h.powi(4) * 2.0 / 384.0,
            "t = {t}: {:e} vs ends {ends:e}",
            err(t, x)
        );
    }
}

/// Issue 38 item 12 (the `solve` fuzz target): nalgebra's `exp` takes part of its
/// squaring count from `‖|A|²⁷‖₁`, which overflowed for a large or non-normal matrix;
/// the count became `∞ as u64` and `expm` never returned (exponential Euler on a state
/// of 2e23 hung). Now a matrix above `MAX_NORM` (52 squarings: no digit left) is a typed
/// error, a non-normal one is scaled until the count is finite, and anything nalgebra
/// handled is nalgebra's result bit for bit.
#[test]
fn exponential_of_a_huge_matrix_returns() {
    use reckon::linalg::expm::{MAX_NORM, expm};
    for m in [
        nalgebra::DMatrix::from_row_slice(2, 2, &[-1e200, 0.0, 0.0, -1.0]),
        nalgebra::DMatrix::from_row_slice(2, 2, &[0.0, -1e300, 1e300, 0.0]),
        nalgebra::DMatrix::from_row_slice(2, 2, &[-MAX_NORM * 2.0, 0.0, 0.0, 0.0]),
        nalgebra::DMatrix::from_row_slice(2, 2, &[f64::MAX, f64::MAX, f64::MAX, f64::MAX]),
    ] {
        assert!(
            matches!(expm(&m), Err(reckon::Error::InvalidInput { what: "matrix", .. })),
            "{m}"
        );
    }
    let s = nalgebra::DMatrix::from_row_slice(2, 2, &[-3.0, 1.0, 0.5, -2.0]);
    assert_eq!(expm(&s).unwrap(), s.exp());
    // 35 squarings: e⁻¹ keeps about 5 digits next to e^{−10¹¹} = 0
    let d = nalgebra::DMatrix::from_row_slice(2, 2, &[-1e11, 0.0, 0.0, -1.0]);
    let e = expm(&d).unwrap();
    assert!(e[(0, 0)] == 0.0 && (e[(1, 1)] - (-1f64).exp()).abs() < 1e-4, "{e}");
    assert_eq!(e, d.exp());
    // nilpotent, but |A| has spectral radius 2·10¹²: nalgebra's own exp never returned
    // (‖|A|²⁷‖₁ overflows). It ends now; e^A = I + A is so ill-conditioned here that
    // scaling and squaring amplifies the Padé step's rounding (nalgebra gives NaN at
    // a = 10⁹), so the test asks that it end with a finite matrix or the typed error.
    for a in [1e9, 1e12, 1e15] {
        let n = nalgebra::DMatrix::from_row_slice(2, 2, &[a, a, -a, -a]);
        match expm(&n) {
            Ok(e) => assert!(e.iter().all(|v| v.is_finite()), "{e}"),
            Err(err) => assert!(matches!(err, reckon::Error::InvalidInput { what: "matrix", .. })),
        }
    }
    // the case the fuzzer found: it ends (with an error or not) instead of hanging
    let f = reckon::model!(|_, y: [S; 2], p: [S; 2] = [2.625, -1e-300]| nalgebra::Vector2::new(
        y[1],
        p[0] * (1.0 - y[0] * y[0]) * y[1] - y[0] * p[1]
    ));
    let p = reckon::Problem::new(
        &f,
        nalgebra::Vector2::new(-2.2402100702601873e23, 10.0),
        (1e-7, 5.5000001),
    );
    let o = reckon::Options::default().rtol(0.0).atol(1e-6).max_steps(8406);
    let _ = p.solve(reckon::methods::ExponentialEuler, &o);
}

/// A long exponential (or exact) step across a fast transient has exact ends and a
/// polynomial between them that is not: 40-point heat equation, two sine modes (one
/// decaying at −6.6·10³), exponential Euler at rtol 1e-8 took steps up to 0.4 with the
/// ends exact to 1e-13, and the cubic Hermite interpolant put `x(0.25)` 0.5 % off. Now
/// the interpolant's miss at the method's own midpoint joins the estimate whenever the
/// dense output is used, and output times, dense values and the ends all meet the
/// tolerance; the run without output times keeps its long steps.
#[test]
fn output_times_between_long_steps_meet_the_tolerance() {
    use reckon::Save;
    use reckon::methods::Exact;
    const N: usize = 40;
    let dx = 1.0 / (N + 1) as f64;
    let mut a = nalgebra::SMatrix::<f64, N, N>::zeros();
    for i in 0..N {
        a[(i, i)] = -2.0 / (dx * dx);
        if i > 0 {
            a[(i, i - 1)] = 1.0 / (dx * dx);
        }
        if i + 1 < N {
            a[(i, i + 1)] = 1.0 / (dx * dx);
        }
    }
    let lti = Lti::new(a, SVector::<f64, N>::zeros()).unwrap();
    // sin(kπx_i) is an eigenvector with λ_k = −4 sin²(kπdx/2)/dx²
    let modes = [(1usize, 1.0), (30usize, 0.5)];
    let exact = |t: f64| {
        SVector::<f64, N>::from_fn(|i, _| {
            let xi = (i + 1) as f64 * dx;
            modes
                .iter()
                .map(|&(k, c)| {
                    let kf = k as f64 * std::f64::consts::PI;
                    let lam = -4.0 * (kf * dx / 2.0).sin().powi(2) / (dx * dx);
                    c * (lam * t).exp() * (kf * xi).sin()
                })
                .sum()
        })
    };
    let held = reckon::Controls::new(vec![0.0], vec![vec![0.0]]).unwrap();
    let p = Problem::new(&lti, exact(0.0), (0.0, 1.0)).controls(held);
    let times: Vec<f64> = (1..=40).map(|k| k as f64 * 0.025).collect();
    let o = Options::default().rtol(1e-8).atol(1e-10);
    // without output times: few long steps, exact ends
    let lean = p.solve(ExponentialEuler, &o).unwrap();
    let lean_end = (lean.last().1 - exact(1.0)).amax();
    println!("no output times: {} steps, end error {lean_end:e}", lean.stats.accepted);
    assert!(lean_end < 1e-12);
    let tol = |x: &SVector<f64, N>, t: f64| (x - exact(t)).amax() / exact(t).amax();
    for (name, sol) in [
        (
            "exponential-euler",
            p.solve(ExponentialEuler, &o.clone().save(Save::At(times.clone())).dense(true)),
        ),
        (
            "exact",
            p.solve(
                Exact::new(lti.flow()),
                &o.clone().save(Save::At(times.clone())).dense(true),
            ),
        ),
    ] {
        let sol = sol.unwrap();
        assert_eq!(sol.t, times);
        let worst = sol.t.iter().zip(&sol.x).map(|(&t, x)| tol(x, t)).fold(0.0, f64::max);
        // dense values midway between output times too
        let between = (0..40)
            .map(|k| (k as f64 + 0.5) * 0.025)
            .map(|t| tol(&sol.at(t).unwrap(), t))
            .fold(0.0, f64::max);
        println!(
            "{name}: {} steps, worst relative error at output times {worst:e}, between {between:e}",
            sol.stats.accepted
        );
        assert!(worst < 1e-7 && between < 1e-7, "{name}: {worst:e}, {between:e}");
    }
    // loose tolerances give loose answers between the steps, never wrong ones: within
    // ten times rtol (relative to the largest component) at 1e-1 … 1e-3
    for rtol in [1e-1, 1e-2, 1e-3] {
        let o = Options::default()
            .rtol(rtol)
            .atol(rtol * 1e-2)
            .save(Save::At(times.clone()))
            .dense(true);
        for (name, sol) in [
            ("exponential-euler", p.solve(ExponentialEuler, &o)),
            ("exact", p.solve(Exact::new(lti.flow()), &o)),
        ] {
            let sol = sol.unwrap();
            let worst = sol.t.iter().zip(&sol.x).map(|(&t, x)| tol(x, t)).fold(0.0, f64::max);
            let between = (0..40)
                .map(|k| (k as f64 + 0.5) * 0.025)
                .map(|t| tol(&sol.at(t).unwrap(), t))
                .fold(0.0, f64::max);
            println!(
                "rtol {rtol:e}, {name}: {} steps, worst relative error {worst:e}, between {between:e}",
                sol.stats.accepted
            );
            assert!(
                worst < 10.0 * rtol && between < 10.0 * rtol,
                "rtol {rtol:e}, {name}: {worst:e}, {between:e}"
            );
        }
    }
}

/// An exact flow's one long step around a turn: the unicycle at v = 1, ω = π for 2 s
/// is a full circle of diameter 2/π. Output times on it come from the quartic through
/// the flow's midpoint, on steps short enough for the tolerance.
#[test]
fn exact_flow_output_times_follow_the_circle() {
    use reckon::methods::Exact;
    use reckon::vehicles::unicycle;
    use reckon::{Controls, Save};
    let w = std::f64::consts::PI;
    let c = Controls::new(vec![0.0], vec![vec![1.0, w]]).unwrap();
    let times: Vec<f64> = (1..=20).map(|k| k as f64 * 0.1).collect();
    let sol = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.0], (0.0, 2.0))
        .controls(c)
        .solve(
            Exact::new(unicycle::flow),
            &Options::default().rtol(1e-9).atol(1e-9).save(Save::At(times.clone())),
        )
        .unwrap();
    let mut worst = 0.0f64;
    for (&t, x) in sol.t.iter().zip(&sol.x) {
        let want = [(w * t).sin() / w, (1.0 - (w * t).cos()) / w, w * t];
        for i in 0..3 {
            worst = worst.max((x[i] - want[i]).abs());
        }
    }
    println!("{} steps, worst error {worst:e}", sol.stats.accepted);
    assert!(worst < 1e-8, "{worst:e}");
}

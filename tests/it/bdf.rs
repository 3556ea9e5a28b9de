//! BDF/NDF: observed orders at fixed order and step from exact starting values, published
//! end states (Test Set mescd), dense output, backward integration, restarts at input
//! jumps, and typed failures.

use nalgebra::{SVector, Vector1, Vector2, vector};
use reckon::methods::{Bdf, ImplicitEuler, Rk45};
use reckon::studies::problems::*;
use reckon::{Controls, Error, Options, Problem, System, model};

/// Least-squares slope of log(err) against log(h).
fn slope(h: &[f64], e: &[f64]) -> f64 {
    let n = h.len() as f64;
    let (x, y): (Vec<f64>, Vec<f64>) = h.iter().zip(e).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

/// Fixed order `k`, fixed step `h = T/n`, history `x(−h), …, x(−k·h)` from the exact solution.
fn order_of<const N: usize, S: System<nalgebra::Const<N>>>(
    f: &S,
    exact: impl Fn(f64) -> SVector<f64, N>,
    t_end: f64,
    k: usize,
    steps: &[usize],
    ndf: bool,
) -> (f64, Vec<f64>)
where
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    let mut hs = Vec::new();
    let mut es = Vec::new();
    for &n in steps {
        let h = t_end / n as f64;
        let past = (1..=k).map(|j| exact(-(j as f64) * h)).collect();
        let m = if ndf { Bdf::ndf() } else { Bdf::bdf() }.fixed_order(k).history(past);
        let sol = Problem::new(f, exact(0.0), (0.0, t_end))
            // Newton converged far below the truncation error (its tolerance scales with rtol)
            .solve(m, &Options::default().fixed(h).rtol(1e-12).atol(1e-14))
            .unwrap();
        assert_eq!(sol.t.len(), n + 1);
        let e = (sol.last().1 - exact(t_end)).amax();
        assert!(e > 1e3 * f64::EPSILON, "order {k}, n = {n}: error {e} is at rounding");
        hs.push(h);
        es.push(e);
    }
    (slope(&hs, &es), es)
}

#[test]
fn fixed_order_k_converges_at_order_k_on_a_linear_system() {
    let f = rotation_decay();
    let x0 = vector![1.0, 0.0];
    for ndf in [true, false] {
        for k in 1..=5 {
            let steps: &[usize] = match k {
                1 | 2 => &[100, 200, 400, 800],
                _ => &[40, 80, 160, 320],
            };
            let (p, es) = order_of(&f, |t| rotation_decay_exact(t, &x0), 2.0, k, steps, ndf);
            println!("ndf {ndf}, order {k}: observed {p:.3}");
            assert!(
                (p - k as f64).abs() <= 0.1,
                "ndf {ndf}, order {k}: observed {p:.3}, errors {es:?}"
            );
        }
    }
}

#[test]
fn fixed_order_k_converges_at_order_k_on_sin_u() {
    let f = sin_u();
    for k in 1..=5 {
        let steps: &[usize] = match k {
            1 | 2 => &[100, 200, 400, 800],
            3 => &[40, 80, 160, 320],
            _ => &[20, 40, 80, 160],
        };
        let (p, es) = order_of(&f, |t| sin_u_exact(t, 1.0), 3.0, k, steps, true);
        assert!((p - k as f64).abs() <= 0.1, "order {k}: observed {p:.3}, errors {es:?}");
    }
}

#[test]
fn plain_bdf_order_1_is_implicit_euler() {
    let f = van_der_pol(5.0);
    let p = Problem::new(&f, vector![2.0, 0.0], (0.0, 3.0));
    let o = Options::default().fixed(0.01);
    let a = p.solve(Bdf::bdf().fixed_order(1), &o).unwrap();
    let b = p.solve(ImplicitEuler::default(), &o).unwrap();
    // the same equation solved by the same Newton to its tolerance: agreement to well
    // below the O(h) error (the iterates differ only in the predictor)
    let d = (a.last().1 - b.last().1).amax();
    assert!(d < 1e-6, "BDF1 vs implicit Euler: {d}");
    // and NDF1 is a different formula (κ₁ = −0.185): it does not coincide
    let c = p.solve(Bdf::ndf().fixed_order(1), &o).unwrap();
    assert!((c.last().1 - b.last().1).amax() > 1e-4);
}

/// Test Set mixed significant digits: `−log10 max_i |y_i − ref_i| / (atol_i/rtol_i + |ref_i|)`.
fn mescd<const N: usize>(y: &SVector<f64, N>, r: &[f64; N], atol_over_rtol: f64) -> f64 {
    let m = (0..N)
        .map(|i| (y[i] - r[i]).abs() / (atol_over_rtol + r[i].abs()))
        .fold(0.0, f64::max);
    -m.log10()
}

fn scd<const N: usize>(y: &SVector<f64, N>, r: &[f64; N]) -> f64 {
    let m = (0..N).map(|i| ((y[i] - r[i]) / r[i]).abs()).fold(0.0, f64::max);
    -m.log10()
}

#[test]
fn test_set_end_states() {
    // (rtol, required mescd per problem: ROBER, VDPOLM, OREGO, HIRES)
    // Issue 9 asks 4.5 at rtol 1e-6 and 7 at 1e-10. With scipy's controller (proposals
    // aiming at 0.9^{k+1} of the tolerance, h held for k + 1 steps) reckon reached VDPOLM
    // 4.32 and OREGO 4.15 at 1e-6, as scipy 1.x's BDF does (4.38, 4.16): their end error
    // is the one-signed sum of the local errors of the long steps on the slow branches.
    // Aiming at 1/6 of the tolerance and shrinking h as soon as the estimate asks (see
    // Bdf) gives, measured: 1e-6: 6.83 4.86 4.85 5.56 (was 5.42 4.32 4.15 4.99);
    // 1e-10: 9.81 8.37 7.99 9.15 (was 9.38 7.90 7.57 8.72), with fewer f evaluations.
    let cases = [(1e-6, [5.5, 4.6, 4.6, 5.2]), (1e-10, [9.4, 8.0, 7.7, 8.8])];
    for (rtol, need) in cases {
        let o = |atol: f64| Options::default().rtol(rtol).atol(atol).max_steps(1_000_000);
        let s = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e11))
            .solve(Bdf::default(), &o(1e-4 * rtol))
            .unwrap();
        let y = s.last().1;
        let m = mescd(y, &ROBERTSON_REF_1E11, 1e-4);
        println!(
            "ROBER rtol {rtol}: mescd {m:.2} scd {:.2} {:?}",
            scd(y, &ROBERTSON_REF_1E11),
            s.stats
        );
        assert!(m >= need[0], "ROBER rtol {rtol}: mescd {m}");
        assert!((y.sum() - 1.0).abs() < 1e-12, "invariant {}", y.sum() - 1.0);

        let s = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0))
            .solve(Bdf::default(), &o(rtol))
            .unwrap();
        let y = s.last().1;
        let m = mescd(y, &VDPOLM_REF_2000, 1.0);
        println!(
            "VDPOLM rtol {rtol}: mescd {m:.2} scd {:.2} {:?}",
            scd(y, &VDPOLM_REF_2000),
            s.stats
        );
        assert!(m >= need[1], "VDPOLM rtol {rtol}: mescd {m}");

        let s = Problem::new(orego(), vector![1.0, 2.0, 3.0], (0.0, 360.0))
            .solve(Bdf::default(), &o(rtol))
            .unwrap();
        let y = s.last().1;
        let m = mescd(y, &OREGO_REF_360, 1.0);
        println!(
            "OREGO rtol {rtol}: mescd {m:.2} scd {:.2} {:?}",
            scd(y, &OREGO_REF_360),
            s.stats
        );
        assert!(m >= need[2], "OREGO rtol {rtol}: mescd {m}");

        let s = Problem::new(hires(), hires_y0(), (0.0, HIRES_T))
            .solve(Bdf::default(), &o(rtol))
            .unwrap();
        let y = s.last().1;
        let m = mescd(y, &HIRES_REF, 1.0);
        println!(
            "HIRES rtol {rtol}: mescd {m:.2} scd {:.2} {:?}",
            scd(y, &HIRES_REF),
            s.stats
        );
        assert!(m >= need[3], "HIRES rtol {rtol}: mescd {m}");
    }
}

#[test]
fn far_fewer_evaluations_than_implicit_euler_on_robertson() {
    let p = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e5));
    let o = Options::default().rtol(1e-6).atol(1e-10).max_steps(10_000_000);
    let b = p.solve(Bdf::default(), &o).unwrap();
    let e = p.solve(ImplicitEuler::default(), &o).unwrap();
    assert!(
        b.stats.rhs_evals * 10 < e.stats.rhs_evals,
        "BDF {:?} vs implicit Euler {:?}",
        b.stats,
        e.stats
    );
}

#[test]
fn dense_output_between_steps() {
    // rotation–decay: exact solution known everywhere
    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 6.0));
    let sol = p
        .solve(Bdf::default(), &Options::default().rtol(1e-8).atol(1e-10).dense(true))
        .unwrap();
    let (mut ends, mut mid, mut linear, mut local) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for i in 1..sol.t.len() {
        ends = ends.max((sol.x[i] - rotation_decay_exact(sol.t[i], &x0)).amax());
        let tm = 0.5 * (sol.t[i - 1] + sol.t[i]);
        let exact = rotation_decay_exact(tm, &x0);
        let y = sol.at(tm).unwrap();
        mid = mid.max((y - exact).amax());
        // against the exact flow from this step's start: the interpolation error alone
        // (plus one step's local error), free of the global error carried in
        local = local.max((y - rotation_decay_exact(tm - sol.t[i - 1], &sol.x[i - 1])).amax());
        linear = linear.max(((sol.x[i - 1] + sol.x[i]) * 0.5 - exact).amax());
    }
    println!(
        "ends {ends:.3e} mid {mid:.3e} local {local:.3e} linear {linear:.3e} steps {}",
        sol.t.len()
    );
    // the interpolant is as accurate between steps as the solution at them, and far
    // better than chords
    assert!(mid < 2.0 * ends && ends < 1e-6, "ends {ends}, midpoints {mid}");
    assert!(local < 1e-8, "interpolation error at midpoints {local} (rtol 1e-8)");
    assert!(linear > 100.0 * mid, "linear {linear} vs dense {mid}");

    // Van der Pol μ = 10 at rtol 1e-8: scipy's BDF takes 588 steps with a largest error
    // 3.3e-4 at its step ends (phase error on the fast branches), as reckon's did with
    // scipy's controller (583 steps, 3.7e-4, 1787 f); aiming at 1/6 of the tolerance it
    // takes 688 steps for 7.9e-5 in 1466 f; held tolerance-proportional below 1e-6, 788
    // steps for 3.8e-5. The dense output adds nothing to it
    let f = van_der_pol(10.0);
    let p = Problem::new(&f, vector![2.0, 0.0], (0.0, 12.0));
    let sol = p
        .solve(Bdf::default(), &Options::default().rtol(1e-8).atol(1e-8).dense(true))
        .unwrap();
    let r = p
        .solve(Rk45, &Options::default().rtol(1e-13).atol(1e-13).dense(true))
        .unwrap();
    let (mut ends, mut mid) = (0.0f64, 0.0f64);
    for i in 1..sol.t.len() {
        ends = ends.max((sol.x[i] - r.at(sol.t[i]).unwrap()).amax());
        let tm = 0.5 * (sol.t[i - 1] + sol.t[i]);
        mid = mid.max((sol.at(tm).unwrap() - r.at(tm).unwrap()).amax());
    }
    println!("VdP: ends {ends:.3e} mid {mid:.3e} steps {}", sol.t.len());
    assert!((700..900).contains(&sol.t.len()), "{} steps", sol.t.len());
    assert!(ends < 2e-4 && mid < 1.5 * ends, "ends {ends}, midpoints {mid}");
}

#[test]
fn backward_integration_and_input_jumps() {
    // x' = −x backward from t = 2 to 0: x(0) = x(2)·e²
    let f = model!(|_, x: [S; 1]| vector![-x[0]]);
    let s = Problem::new(&f, Vector1::new(1.0), (2.0, 0.0))
        .solve(Bdf::default(), &Options::default().rtol(1e-9).atol(1e-12))
        .unwrap();
    assert!(
        (s.last().1[0] - 2f64.exp()).abs() < 1e-6 * 2f64.exp(),
        "{}",
        s.last().1[0]
    );
    // x' = −10(x − u) with u switching 1 → 3 at t = 1: exact x = u + (x₁ − u)e^{−10(t−1)}
    let g = model!(|_, x: [S; 1], u: [1]| vector![(x[0] - u[0]) * -10.0]);
    let c = Controls::new(vec![0.0, 1.0], vec![vec![1.0], vec![3.0]]).unwrap();
    let s = Problem::new(&g, Vector1::new(1.0), (0.0, 2.0))
        .controls(c)
        .solve(Bdf::default(), &Options::default().rtol(1e-9).atol(1e-12))
        .unwrap();
    let exact = 3.0 - 2.0 * (-10.0f64).exp();
    assert!((s.last().1[0] - exact).abs() < 1e-6, "{} vs {exact}", s.last().1[0]);
    assert!(s.t.contains(&1.0), "lands on the input jump");
}

#[test]
fn typed_errors() {
    // blow-up: x' = x² from 1 reaches ∞ at t = 1
    let f = model!(|_, x: [S; 1]| vector![x[0] * x[0]]);
    let e = Problem::new(&f, Vector1::new(1.0), (0.0, 2.0))
        .solve(Bdf::default(), &Options::default())
        .unwrap_err();
    assert!(
        matches!(e, Error::StepSizeUnderflow { t, .. } | Error::NewtonDiverged { t, .. } | Error::NonFinite { t, .. } if (t - 1.0).abs() < 1e-2),
        "{e:?}"
    );
    // a model that is NaN at the start is reported as such
    let g = model!(|_, x: [S; 2]| vector![x[0].sqrt(), x[1].clone()]);
    let e = Problem::new(&g, Vector2::new(-1.0, 0.0), (0.0, 1.0))
        .solve(Bdf::default(), &Options::default())
        .unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e:?}");
}

/// Events are located on BDF's dense output; Rodas5P and Auto the same.
#[test]
fn events_on_the_stiff_methods() {
    use reckon::methods::{Auto, Rodas5P};
    use reckon::{Direction, Event};
    // x' = −(x − cos t)·50: x follows cos t closely; x = 0 first near t = π/2 + 1/50
    let f = model!(|t: S, x: [S; 1]| vector![(x[0] - t.cos()) * -50.0]);
    let p = |m: &str| {
        let zero = Event::new(|_t, x: &nalgebra::SVector<f64, 1>| x[0])
            .direction(Direction::Falling)
            .terminal();
        let prob = Problem::new(&f, Vector1::new(1.0), (0.0, 5.0)).event(zero);
        let o = Options::default().rtol(1e-10).atol(1e-12);
        match m {
            "bdf" => prob.solve(Bdf::default(), &o),
            "rodas5p" => prob.solve(Rodas5P, &o),
            _ => prob.solve(Auto::default(), &o),
        }
        .unwrap()
    };
    // exact: x = (2500 cos t + 50 sin t)/2501 + (1/2501)e^{−50t}; its zero by bisection
    let exact = |t: f64| (2500.0 * t.cos() + 50.0 * t.sin()) / 2501.0 + (-50.0 * t).exp() / 2501.0;
    let (mut a, mut b) = (1.5, 1.7);
    for _ in 0..100 {
        let m = 0.5 * (a + b);
        if exact(m) > 0.0 { a = m } else { b = m }
    }
    for m in ["bdf", "rodas5p", "auto"] {
        let s = p(m);
        let t = s.last().0;
        assert_eq!(s.events.len(), 1, "{m}");
        assert!((t - a).abs() < 1e-7, "{m}: event at {t}, exact {a}");
    }
}

/// Issue 38 item 12 (the `solve` fuzz target): a start history whose values are not the
/// state's length is a typed error, not a panic in the difference table.
#[test]
fn history_of_another_length_is_refused() {
    let f = model!(|_t, x: [S; Dyn]| x.map(|v| -v));
    let x0 = nalgebra::DVector::from_vec(vec![1.0, 2.0]);
    let p = Problem::new(&f, x0.clone(), (0.0, 1.0));
    for bad in [
        vec![x0.clone(), nalgebra::DVector::from_vec(vec![1.0])],
        vec![nalgebra::DVector::zeros(3)],
    ] {
        let e = p.solve(Bdf::default().history(bad), &Options::default()).unwrap_err();
        assert!(matches!(e, Error::InvalidInput { what: "history", .. }), "{e}");
    }
    assert!(p.solve(Bdf::default().history(vec![x0]), &Options::default()).is_ok());
}

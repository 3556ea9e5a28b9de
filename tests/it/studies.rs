//! The study API: observed orders, stability, stiffness and work–precision.

use nalgebra::vector;
use num_complex::Complex64;
use reckon::model::Flow;
use reckon::studies::MethodKind::{self, *};
use reckon::studies::convergence::convergence;
use reckon::studies::problems::*;
use reckon::studies::stability::*;
use reckon::studies::stiffness::{step_history, stiffness_along};
use reckon::studies::work_precision::work_precision;
use reckon::vehicles::unicycle;
use reckon::{Controls, Options, Problem};

fn check(study: &reckon::studies::convergence::Convergence) {
    for fit in &study.fits {
        let theory = fit.theory.unwrap();
        let p = fit.order_final.unwrap();
        assert!(
            (p - theory).abs() <= 0.1,
            "{:?}: observed {p}, theory {theory}",
            fit.method
        );
    }
}

#[test]
fn observed_orders_match_theory() {
    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 2.0));
    let exact = move |t: f64| rotation_decay_exact(t, &x0);
    let h1 = [1.0 / 64.0, 1.0 / 128.0, 1.0 / 256.0, 1.0 / 512.0];
    check(&convergence(&p, &[Euler, ImplicitEuler], &h1, &exact, None, 1_000_000).unwrap());
    check(&convergence(&p, &[Rk45], &[0.2, 0.1, 0.05, 0.025], &exact, None, 1_000_000).unwrap());
    let p = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    let exact = |t: f64| sin_u_exact(t, 0.5);
    check(&convergence(&p, &[Euler, ImplicitEuler], &h1, &exact, None, 1_000_000).unwrap());
    let s = convergence(&p, &[Rk45], &[0.5, 0.25, 0.125, 0.0625], &exact, None, 1_000_000).unwrap();
    check(&s);
    assert_eq!(s.rows.len(), 4);
    assert!(s.rows.windows(2).all(|w| w[1].final_error < w[0].final_error));
}

#[test]
fn vehicle_convergence_against_the_exact_flow() {
    let c = Controls::new(
        vec![0.0, 1.0, 2.0],
        vec![vec![1.0, 0.8], vec![2.0, -0.5], vec![0.0, 0.0]],
    )
    .unwrap();
    let p = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.3], (0.0, 2.0)).controls(c.clone());
    let exact = |t: f64| {
        if t == 0.0 {
            return vector![0.0, 0.0, 0.3];
        }
        let q = Problem::new(unicycle::model(), vector![0.0, 0.0, 0.3], (0.0, t)).controls(c.clone());
        *q.solve(reckon::methods::Exact::new(unicycle::flow), &Options::default())
            .unwrap()
            .last()
            .1
    };
    let flow: &dyn Flow<nalgebra::Const<3>> = &unicycle::flow;
    let s = convergence(
        &p,
        &[Euler, Exact],
        &[0.05, 0.025, 0.0125, 0.00625],
        &exact,
        Some(flow),
        1_000_000,
    )
    .unwrap();
    let e = &s.fits[0];
    assert!((e.order_final.unwrap() - 1.0).abs() <= 0.1);
    // the exact flow's error is rounding only, at every step size
    assert!(s.rows.iter().filter(|r| r.method == Exact).all(|r| r.max_error < 1e-14));
}

#[test]
fn stability_regions() {
    assert!((real_axis_limit(StabilityOf::Euler) + 2.0).abs() < 1e-12);
    assert!((real_axis_limit(StabilityOf::Rk45) + 3.3065678926349467).abs() < 1e-12);
    assert_eq!(real_axis_limit(StabilityOf::ImplicitEuler), f64::NEG_INFINITY);
    for m in [StabilityOf::Euler, StabilityOf::ImplicitEuler, StabilityOf::Rk45] {
        let segs = boundary(m, (-4.0, 2.5), (-3.5, 3.5), 161);
        assert!(segs.len() > 50, "{m:?}");
        for s in &segs {
            for &(x, y) in s {
                let r = amplification(m, Complex64::new(x, y)).norm();
                assert!((r - 1.0).abs() < 0.05, "{m:?}: |R({x}, {y})| = {r}");
            }
        }
    }
    // Euler's boundary is the circle |z + 1| = 1
    for s in boundary(StabilityOf::Euler, (-2.5, 0.5), (-1.5, 1.5), 201) {
        let (x, y) = s[0];
        assert!((((x + 1.0).powi(2) + y * y).sqrt() - 1.0).abs() < 1e-3);
    }
}

/// The explicit Euler threshold located by actual runs is within 1% of 2/|λ|.
#[test]
fn euler_threshold_within_one_percent() {
    for lambda in [-1.0, -10.0, -1000.0, -0.37] {
        let h = euler_threshold(lambda, 400).unwrap();
        let theory = 2.0 / lambda.abs();
        assert!((h / theory - 1.0).abs() < 0.01, "λ = {lambda}: {h} vs {theory}");
    }
    assert!(euler_threshold(1.0, 10).is_err());
}

/// On Van der Pol μ = 1000 RK45's steps sit at the stability limit: h·ρ(J) stays near
/// DP5's boundary 3.3 on the slow branch, while implicit Euler's steps are far larger.
#[test]
fn rk45_step_pinned_by_stability() {
    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 300.0));
    let opts = Options::default().rtol(1e-3).atol(1e-6);
    let rk = p
        .solve(reckon::methods::Rk45, &opts.clone().max_steps(1_000_000))
        .unwrap();
    let ie = p.solve(reckon::methods::ImplicitEuler::default(), &opts).unwrap();
    let hr = step_history(&rk);
    let hi = step_history(&ie);
    let median = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    assert!(
        hr.h.len() > 100 * hi.h.len(),
        "RK45 {} steps vs implicit Euler {}",
        hr.h.len(),
        hi.h.len()
    );
    assert!(
        max(&hi.h) > 1000.0 * max(&hr.h),
        "largest steps: IE {} vs RK45 {}",
        max(&hi.h),
        max(&hr.h)
    );
    let pts = stiffness_along(&van_der_pol(1000.0), &rk, &[], 1).unwrap();
    let hl: Vec<f64> = pts
        .iter()
        .zip(&hr.h)
        .skip(100)
        .map(|(p, h)| p.spectral_radius * h)
        .collect();
    let m = median(&hl);
    assert!(m > 1.5 && m < 3.4, "median h·ρ(J) = {m}");
    assert!(pts.iter().skip(100).all(|p| p.ratio > 1e3 || p.ratio == 1.0));
}

#[test]
fn work_precision_sweep() {
    let x0 = vector![1.0, 0.5];
    let p = Problem::new(rotation_decay(), x0, (0.0, 5.0));
    let reference = rotation_decay_exact(5.0, &x0);
    let mut pts = work_precision(
        &p,
        &[Rk45, Euler],
        &[1e-4, 1e-6, 1e-8],
        &[1e-2, 1e-3],
        &reference,
        None,
        1,
    )
    .unwrap();
    // implicit Euler's digits follow the tolerance at ~10× the steps per digit: looser
    pts.extend(work_precision(&p, &[ImplicitEuler], &[1e-2, 1e-3, 1e-4], &[], &reference, None, 1).unwrap());
    let of = |m: MethodKind| pts.iter().filter(|w| w.method == m).collect::<Vec<_>>();
    for m in [Rk45, ImplicitEuler] {
        let v = of(m);
        assert_eq!(v.len(), 3);
        assert!(
            v.windows(2)
                .all(|w| w[1].error < w[0].error && w[1].rhs_evals > w[0].rhs_evals),
            "{m:?}"
        );
    }
    assert_eq!(of(Euler).len(), 2);
    assert!(work_precision(&p, &[Rk45], &[], &[], &reference, None, 1).is_err());
}

/// Eigenvalues against closed forms: the second-difference matrix tridiag(1, −2, 1) of
/// size 40 has λ_k = −2 + 2cos(kπ/41); a non-normal similarity transform of 2×2
/// rotation blocks keeps a ± bi.
#[test]
fn eigenvalues_match_closed_forms() {
    use nalgebra::DMatrix;
    use reckon::studies::stiffness::eigenvalues;
    let n = 40;
    let t = DMatrix::from_fn(n, n, |i, j| match i.abs_diff(j) {
        0 => -2.0,
        1 => 1.0,
        _ => 0.0,
    });
    let mut ev = eigenvalues(0.0, &t).unwrap();
    ev.sort_by(|a, b| a.re.total_cmp(&b.re));
    let mut exact: Vec<f64> = (1..=n)
        .map(|k| -2.0 + 2.0 * (k as f64 * std::f64::consts::PI / (n + 1) as f64).cos())
        .collect();
    exact.sort_by(f64::total_cmp);
    for (l, e) in ev.iter().zip(&exact) {
        assert!((l.re - e).abs() < 1e-12 && l.im.abs() < 1e-12, "{l} vs {e}");
    }
    // blocks (a, b) = (−1, 3), (−50, 0.5), (−2000, 10); S unit upper triangular
    let blocks = [(-1.0, 3.0), (-50.0, 0.5), (-2000.0, 10.0)];
    let mut b = DMatrix::zeros(6, 6);
    for (k, (a, w)) in blocks.iter().enumerate() {
        b[(2 * k, 2 * k)] = *a;
        b[(2 * k + 1, 2 * k + 1)] = *a;
        b[(2 * k, 2 * k + 1)] = -w;
        b[(2 * k + 1, 2 * k)] = *w;
    }
    let s = DMatrix::from_fn(6, 6, |i, j| {
        if i == j {
            1.0
        } else if j > i {
            0.3 * (i + 2 * j) as f64
        } else {
            0.0
        }
    });
    let m = &s * b * s.clone().try_inverse().unwrap();
    let ev = eigenvalues(0.0, &m).unwrap();
    for (a, w) in blocks {
        for sign in [1.0, -1.0] {
            let d = ev
                .iter()
                .map(|l| (l - Complex64::new(a, sign * w)).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(d < 1e-9 * a.abs().max(1.0), "{a} ± {w}i missing: {ev:?}");
        }
    }
    // a non-finite Jacobian is a typed error naming the row-major component
    let mut bad = DMatrix::<f64>::zeros(2, 2);
    bad[(1, 0)] = f64::INFINITY;
    assert_eq!(
        eigenvalues(0.5, &bad).unwrap_err(),
        reckon::Error::NonFinite {
            t: 0.5,
            quantity: reckon::error::Quantity::Jacobian,
            component: 2
        }
    );
}

/// The 40-unknown Brusselator, where nalgebra's unbounded iteration never returned at
/// t ≈ 0.074: every point of the implicit-Euler run has eigenvalues whose sum is the
/// Jacobian's trace.
#[test]
fn brusselator_stiffness_finishes() {
    use reckon::System;
    let n = 20;
    let sys = brusselator(n);
    let p = Problem::new(sys.clone(), brusselator_y0(n), (0.0, 10.0));
    let sol = p
        .solve(
            reckon::methods::ImplicitEuler::default(),
            &Options::default().rtol(1e-4).atol(1e-7).dense(false),
        )
        .unwrap();
    let pts = stiffness_along(&sys, &sol, &[], 1).unwrap();
    assert_eq!(pts.len(), sol.t.len() - 1);
    assert!(pts.iter().any(|q| (q.t - 0.074).abs() < 0.01));
    for k in [0, pts.len() / 3, pts.len() - 1] {
        let x = &sol.x[k];
        let mut j = nalgebra::DMatrix::zeros(2 * n, 2 * n);
        sys.jacobian(sol.t[k], x, &[], &mut j);
        let ev = reckon::studies::stiffness::eigenvalues(sol.t[k], &j).unwrap();
        let sum: f64 = ev.iter().map(|l| l.re).sum();
        assert!(
            (sum - j.trace()).abs() < 1e-10 * j.trace().abs(),
            "{sum} vs {}",
            j.trace()
        );
        assert!((pts[k].spectral_radius - ev.iter().map(|l| l.norm()).fold(0.0, f64::max)).abs() == 0.0);
    }
}

/// A Jacobian that turns non-finite along the solution is a typed error at that time.
#[test]
fn stiffness_along_non_finite_jacobian() {
    let down = reckon::model!(|_t, x: [S; 1]| vector![x[0] * 0.0 - 1.0]);
    let p = Problem::new(&down, vector![1.0], (0.0, 2.0));
    let sol = p
        .solve(reckon::methods::Euler, &Options::default().fixed(0.25))
        .unwrap();
    // ∂√x/∂x = 1/(2√x) is ∞ where the solution reaches 0, at t = 1
    let root = reckon::model!(|_t, x: [S; 1]| vector![x[0].sqrt()]);
    let e = stiffness_along(&root, &sol, &[], 1).unwrap_err();
    assert!(
        matches!(e, reckon::Error::NonFinite { t, quantity: reckon::error::Quantity::Jacobian, .. } if t == 1.0),
        "{e:?}"
    );
}

/// The stiffness index ρ(J)·h/3.3066 along implicit-Euler runs (per-step error control,
/// as the stiffness study runs it): ρ is exactly 1000 for the
/// stiff cosine (λ = −1000) and 2 for x' = −2x, so the index is the closed form of the
/// step at every point; the first is stiff over its whole span, the second nowhere, and
/// Van der Pol μ = 1000 on its slow branches (most of the span).
#[test]
fn stiffness_index_shows_stiffness() {
    use reckon::methods::ImplicitEuler;
    use reckon::studies::stiffness::{DP5_LIMIT, summarize};
    let opts = Options::default().rtol(1e-4).atol(1e-7).dense(false);
    let p = Problem::new(stiff_cosine(), vector![1.0], (0.0, 2.0));
    let sol = p.solve(ImplicitEuler::default().proportional(false), &opts).unwrap();
    let pts = stiffness_along(&stiff_cosine(), &sol, &[], 1).unwrap();
    for (q, w) in pts.iter().zip(sol.t.windows(2)) {
        assert!((q.spectral_radius - 1000.0).abs() < 1e-9);
        assert_eq!(q.ratio, 1.0, "the eigenvalue ratio cannot see scalar stiffness");
        assert_eq!(q.h_accuracy, w[1] - w[0]);
        assert!((q.index - 1000.0 * q.h_accuracy / DP5_LIMIT).abs() < 1e-9 * q.index);
    }
    let s = summarize(&pts);
    assert!(s.median > 10.0 && s.stiff_fraction > 0.99, "{s:?}");

    let two = reckon::model!(|_t, x: [S; 1]| vector![x[0] * -2.0]);
    let p = Problem::new(&two, vector![1.0], (0.0, 5.0));
    let sol = p.solve(ImplicitEuler::default().proportional(false), &opts).unwrap();
    let pts = stiffness_along(&two, &sol, &[], 1).unwrap();
    assert!(pts.iter().all(|q| (q.spectral_radius - 2.0).abs() < 1e-12));
    let s = summarize(&pts);
    assert!(s.max < 0.05 && s.stiff_fraction == 0.0, "{s:?}");

    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
    let sol = p.solve(ImplicitEuler::default().proportional(false), &opts).unwrap();
    let s = summarize(&stiffness_along(&van_der_pol(1000.0), &sol, &[], 1).unwrap());
    assert!(s.median > 1e3 && s.stiff_fraction > 0.9, "{s:?}");
}

/// Fits outside the asymptotic range give no order: at rounding level the errors stop
/// decreasing; with steps as large as the solution's time scale the errors are of the
/// solution's size.
#[test]
fn not_asymptotic_fits_give_no_order() {
    let two = reckon::model!(|_t, x: [S; 1]| vector![x[0] * -2.0]);
    let p = Problem::new(&two, vector![1.0], (0.0, 5.0));
    let exact = |t: f64| vector![(-2.0 * t).exp()];
    let s = convergence(&p, &[Rk45], &[2e-4, 1e-4, 5e-5], &exact, None, 1_000_000).unwrap();
    let f = &s.fits[0];
    assert!(!f.asymptotic && f.order_final.is_none(), "{f:?} {:?}", s.rows);
    assert!(f.reason.as_deref().unwrap().contains("do not decrease"), "{f:?}");
    assert!(s.rows.iter().all(|r| r.final_error < 1e-15));
    // Euler with h = 0.8, 0.4: x₁ = 1 − 2h = −0.6 against e^(−1.6) = 0.2
    let s = convergence(&p, &[Euler], &[0.8, 0.4], &exact, None, 1_000_000).unwrap();
    let f = &s.fits[0];
    assert!(!f.asymptotic && f.order_max.is_none(), "{f:?}");
    assert!(f.reason.as_deref().unwrap().contains("size of the solution"), "{f:?}");
    assert!(
        (s.rows[0].max_error - (0.6 + (-1.6f64).exp())).abs() < 1e-12,
        "{:?}",
        s.rows[0]
    );
}

/// A step that would need billions of steps is refused before any run, with a typed
/// error (it used to grow memory without bound).
#[test]
fn convergence_refuses_steps_beyond_the_cap() {
    let two = reckon::model!(|_t, x: [S; 1]| vector![x[0] * -2.0]);
    let p = Problem::new(&two, vector![1.0], (0.0, 5.0));
    let exact = |t: f64| vector![(-2.0 * t).exp()];
    let e = convergence(&p, &[Euler], &[1e-9, 5e-10], &exact, None, 10_000_000).unwrap_err();
    assert!(
        matches!(&e, reckon::Error::InvalidInput { what: "steps", reason } if reason.contains("5.000e9")),
        "{e}"
    );
    let e = convergence(&p, &[Euler], &[0.1], &exact, None, 10_000_000).unwrap_err();
    assert!(matches!(e, reckon::Error::InvalidInput { what: "steps", .. }));
}

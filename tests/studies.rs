//! The study API: observed orders, stability, stiffness and work–precision.

use nalgebra::vector;
use num_complex::Complex64;
use reckon::methods::{Dopri5, Flow};
use reckon::models::unicycle;
use reckon::problems::*;
use reckon::studies::MethodKind::{self, *};
use reckon::studies::convergence::convergence;
use reckon::studies::stability::*;
use reckon::studies::stiffness::{step_history, stiffness_along};
use reckon::studies::work_precision::work_precision;
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
    assert!((real_axis_limit(StabilityOf::ExplicitEuler) + 2.0).abs() < 1e-12);
    assert!((real_axis_limit(StabilityOf::Dopri5) + 3.3065678926349467).abs() < 1e-12);
    assert_eq!(real_axis_limit(StabilityOf::ImplicitEuler), f64::NEG_INFINITY);
    for m in [
        StabilityOf::ExplicitEuler,
        StabilityOf::ImplicitEuler,
        StabilityOf::Dopri5,
    ] {
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
    for s in boundary(StabilityOf::ExplicitEuler, (-2.5, 0.5), (-1.5, 1.5), 201) {
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
    let rk = p.solve(Dopri5::default(), &opts.clone().max_steps(1_000_000)).unwrap();
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
    let pts = work_precision(
        &p,
        &[Rk45, ImplicitEuler, Euler],
        &[1e-4, 1e-6, 1e-8],
        &[1e-2, 1e-3],
        &reference,
        None,
        1,
    )
    .unwrap();
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

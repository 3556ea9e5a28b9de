//! Auto: DOPRI5 while non-stiff, BDF while stiff, every switch recorded.

use nalgebra::{Vector1, vector};
use reckon::methods::{Auto, Bdf, Rk45};
use reckon::studies::problems::*;
use reckon::{Controls, Options, Problem, model};

/// Van der Pol μ = 1000 on [0, 2000] (Test Set VDPOLM): stiff on the slow branches,
/// non-stiff in the fast jumps.
#[test]
fn van_der_pol_switches_to_bdf_and_beats_dopri5_tenfold() {
    let p = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 2000.0));
    let o = Options::default().rtol(1e-6).atol(1e-6).max_steps(100_000_000);
    let auto = p.solve(Auto::default(), &o).unwrap();
    let rk = p.solve(Rk45, &o).unwrap();
    println!(
        "auto {:?} switches {} first {:?}\nrk45 {:?}",
        auto.stats,
        auto.switches.len(),
        &auto.switches[..auto.switches.len().min(6)],
        rk.stats
    );
    // DOPRI5's own test fires within 15 steps of the start: the first slow branch
    // lasts until t ≈ 807, and the switch comes far inside it
    let first = auto.switches[0];
    assert_eq!(first.to, "bdf");
    assert!(first.t < 1.0, "switched to BDF at t = {}", first.t);
    assert!(
        auto.stats.accepted * 10 < rk.stats.accepted,
        "auto {} steps vs rk45 {}",
        auto.stats.accepted,
        rk.stats.accepted
    );
    // it comes back to DOPRI5 in the fast jumps (y1 ≈ ±2 → ∓1 at t ≈ 807, 1615) and goes
    // stiff again after each
    assert!(auto.switches.iter().any(|s| s.to == "rk45"), "{:?}", auto.switches);
    for w in auto.switches.windows(2) {
        assert!(w[0].t < w[1].t && w[0].to != w[1].to, "{:?}", auto.switches);
    }
    // accuracy: the Test Set reference end state
    let y = auto.last().1;
    let err = (0..2)
        .map(|i| (y[i] - VDPOLM_REF_2000[i]).abs() / (1.0 + VDPOLM_REF_2000[i].abs()))
        .fold(0.0, f64::max);
    assert!(err < 1e-3, "end state {y:?} vs reference: {err}");
}

/// A problem that never gets stiff is DOPRI5 throughout, step for step.
#[test]
fn non_stiff_problem_never_switches() {
    let p = Problem::new(arenstorf(), arenstorf_y0(), (0.0, ARENSTORF_T));
    let o = Options::default().rtol(1e-9).atol(1e-9);
    let auto = p.solve(Auto::default(), &o).unwrap();
    let rk = p.solve(Rk45, &o).unwrap();
    assert!(auto.switches.is_empty(), "{:?}", auto.switches);
    assert_eq!(auto.t, rk.t);
    assert_eq!(auto.last().1, rk.last().1);
}

/// Robertson on [0, 1e5]: stiff after the initial transient; Auto ends on BDF with an
/// answer as good as BDF's own.
#[test]
fn robertson_ends_on_bdf() {
    let p = Problem::new(robertson(), vector![1.0, 0.0, 0.0], (0.0, 1e5));
    let o = Options::default().rtol(1e-6).atol(1e-10).max_steps(10_000_000);
    let auto = p.solve(Auto::default(), &o).unwrap();
    let bdf = p.solve(Bdf::default(), &o).unwrap();
    assert_eq!(auto.switches.last().map(|s| s.to), Some("bdf"), "{:?}", auto.switches);
    let d = (auto.last().1 - bdf.last().1).amax();
    assert!(d < 1e-5, "auto vs bdf {d}");
    assert!(
        auto.stats.accepted < 2 * bdf.stats.accepted + 100,
        "{:?} vs {:?}",
        auto.stats,
        bdf.stats
    );
    assert!((auto.last().1.sum() - 1.0).abs() < 1e-12);
}

/// Dense output follows the active method, and input jumps keep working across modes.
#[test]
fn dense_output_and_breakpoints_across_a_switch() {
    // x' = −1000(x − u): stiff; u jumps 1 → 2 at t = 1
    let f = model!(|_, x: [S; 1], u: [1]| vector![(x[0] - u[0]) * -1000.0]);
    let c = Controls::new(vec![0.0, 1.0], vec![vec![1.0], vec![2.0]]).unwrap();
    let p = Problem::new(&f, Vector1::new(0.0), (0.0, 2.0)).controls(c);
    let sol = p
        .solve(Auto::default(), &Options::default().rtol(1e-8).atol(1e-10).dense(true))
        .unwrap();
    assert_eq!(sol.switches.first().map(|s| s.to), Some("bdf"));
    assert!(sol.t.contains(&1.0));
    // exact: x = u + (x(t_k) − u)e^{−1000(t − t_k)}; far from the jumps x ≈ u
    for (t, want) in [(0.5, 1.0), (0.9, 1.0), (1.5, 2.0), (1.95, 2.0)] {
        let y = sol.at(t).unwrap()[0];
        assert!((y - want).abs() < 1e-6, "x({t}) = {y}");
    }
    let y = sol.at(1.001).unwrap()[0];
    let exact = 2.0 - (-1.0f64).exp();
    assert!((y - exact).abs() < 1e-4, "x(1.001) = {y} vs {exact}");
}

/// Cost, not only stiffness: y' = −λ(t)(y − sin t) + cos t with λ = 1 + 10⁴·e^{−(t−5)²}
/// (exact y = sin t) is stiff only in the middle of [0, 10]. At rtol 1e-7 DOPRI5 alone
/// needs 34 604 `f` calls, BDF alone 584 (`examples/auto_cost.rs`); Auto goes to BDF
/// before DOPRI5's step reaches its stability boundary, because BDF's estimated cost per
/// unit time is lower, comes back once λ has decayed, and says why each time.
#[test]
fn auto_switches_by_estimated_cost_and_records_why() {
    use reckon::SwitchReason;
    let mid = model!(|t, y: [S; 1]| vector![
        (y[0].clone() - t.sin()) * -(1.0 + 1e4 * (-(t - 5.0) * (t - 5.0)).exp()) + t.cos()
    ]);
    let p = Problem::new(&mid, vector![0.0], (0.0, 10.0));
    let o = Options::default().rtol(1e-7).atol(1e-7).max_steps(1_000_000);
    let auto = p.solve(Auto::default(), &o).unwrap();
    let bdf = p.solve(Bdf::default(), &o).unwrap();
    let rk = p.solve(Rk45, &o).unwrap();
    assert!((auto.last().1[0] - 10f64.sin()).abs() < 1e-5, "{}", auto.last().1[0]);
    let sw = &auto.switches;
    assert_eq!(sw.len(), 2, "{sw:?}");
    assert_eq!((sw[0].to, sw[1].to), ("bdf", "rk45"));
    // into BDF where λ is some hundreds (t ≈ 2.9), before DOPRI5 is held by stability
    assert!((2.5..3.5).contains(&sw[0].t), "{sw:?}");
    assert!(
        matches!(sw[0].reason, SwitchReason::Cost { from, to } if to * 2.0 < from),
        "{sw:?}"
    );
    // back once λ has decayed again
    assert!((7.0..9.5).contains(&sw[1].t), "{sw:?}");
    assert!(
        matches!(sw[1].reason, SwitchReason::Cost { from, to } if to * 2.0 < from),
        "{sw:?}"
    );
    assert!(
        auto.stats.rhs_evals * 20 < rk.stats.rhs_evals,
        "{} vs {}",
        auto.stats.rhs_evals,
        rk.stats.rhs_evals
    );
    assert!(
        auto.stats.rhs_evals < 2 * bdf.stats.rhs_evals,
        "{} vs {}",
        auto.stats.rhs_evals,
        bdf.stats.rhs_evals
    );
    // a switch for stiffness carries Hairer's estimate above the threshold
    let vdp = Problem::new(van_der_pol(1000.0), vector![2.0, 0.0], (0.0, 100.0))
        .solve(Auto::default(), &Options::default().rtol(1e-6).atol(1e-6))
        .unwrap();
    assert!(
        matches!(vdp.switches[0].reason, SwitchReason::Stiff { h_lambda } if h_lambda > reckon::methods::auto::STIFF_H_LAMBDA),
        "{:?}",
        vdp.switches
    );
}

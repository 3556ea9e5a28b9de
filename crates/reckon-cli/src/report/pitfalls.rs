//! Where textbook versions of these computations go wrong, each measured.

use super::vehicles::{bicycle_controls, flow_curve, xy};
use super::{Report, Res};
use crate::plot::{Plot, Series, Style};
use nalgebra::Vector3;
use reckon::methods::{Euler, Exact};
use reckon::vehicles::{bicycle, unicycle};
use reckon::{Options, Problem};
use std::path::Path;

/// The pitfalls of textbook versions, each measured.
pub(super) fn pitfalls(r: &mut Report, dir: &Path) -> Res {
    // (a) "implicit Euler" by one fixed-point iteration instead of Newton
    let lam = -1000.0;
    let h = 0.01;
    let (mut newton, mut fixed_point) = (1.0f64, 1.0f64);
    let mut rows_np = Vec::new();
    let mut rows_fp = Vec::new();
    for k in 0..30 {
        let t1 = (k + 1) as f64 * h;
        let f = |t: f64, x: f64| lam * (x - t.cos()) - t.sin();
        // x1 = x0 + h f(t1, x0 + h f(t0, x0)): a predictor–corrector, explicit in disguise
        let pred = fixed_point + h * f(t1 - h, fixed_point);
        fixed_point += h * f(t1, pred);
        // true implicit Euler for this linear problem: x1 = (x0 + h(−λ cos t1 − sin t1))/(1 − hλ)
        newton = (newton + h * (-lam * t1.cos() - t1.sin())) / (1.0 - h * lam);
        rows_np.push((t1, (newton - t1.cos()).abs().max(1e-16)));
        rows_fp.push((t1, (fixed_point - t1.cos()).abs().max(1e-16)));
    }
    let plot = Plot::new(
        "Implicit Euler: Newton vs one fixed-point iteration (x' = −1000(x − cos t) − sin t, h = 0.01)",
        "t (s)",
        "|x − cos t|",
    )
    .log_y()
    .with(Series::new(
        "implicit Euler solved by Newton",
        rows_np,
        Style::LinePoints,
    ))
    .with(Series::new(
        "'implicit' Euler with one fixed-point iteration",
        rows_fp,
        Style::LinePoints,
    ));
    r.figure(dir, "pitfall_fixed_point.svg", &plot, "A so-called implicit Euler step that evaluates f at an explicit predictor is an explicit two-stage method: its amplification factor at hλ = −10 is 1 + hλ + (hλ)² = 91, so it explodes where the Newton-solved step (factor 1/(1 − hλ) = 1/11) is stable.")?;
    // (b) tiny-angle guard in the unicycle arc
    let x0 = Vector3::new(0.0, 0.0, 0.0);
    let (v, h) = (2.0, 5.0);
    let guarded = |w: f64| {
        if w.abs() < 1e-3 {
            Vector3::new(v * h, 0.0, w * h) // straight line below the threshold
        } else {
            Vector3::new(v / w * (w * h).sin(), v / w * (1.0 - (w * h).cos()), w * h)
        }
    };
    let pts: Vec<(f64, f64, f64)> = (1..=80)
        .map(|k| {
            let w = 10f64.powf(-5.0 + 3.0 * k as f64 / 80.0);
            let exact = unicycle::flow(0.0, &x0, &[v, w], h);
            let naive_v_over_w = Vector3::new(v / w * (w * h).sin(), v / w * (1.0 - (w * h).cos()), w * h);
            (
                w,
                (guarded(w) - exact).norm().max(1e-17),
                (naive_v_over_w - exact).norm().max(1e-17),
            )
        })
        .collect();
    let plot = Plot::new(
        "Unicycle arc: guard threshold vs the sinc form (v = 2, h = 5 s)",
        "ω (rad/s)",
        "position error vs the sinc form (m)",
    )
    .log_log()
    .with(Series::new(
        "straight line below |ω| = 1e-3",
        pts.iter().map(|p| (p.0, p.1)).collect(),
        Style::Line,
    ))
    .with(Series::new(
        "v/ω formula (no guard)",
        pts.iter().map(|p| (p.0, p.2)).collect(),
        Style::Line,
    ));
    r.figure(dir, "pitfall_small_angle.svg", &plot, "A guard that switches to a straight line below a threshold is off by v·ω·h²/2 just under it (here up to 2.5 cm); the v/ω formula loses digits to cancellation as ω → 0. The sinc form d = v·h·sinc(ωh/2) has neither problem.")?;
    // (c) inputs indexed by step number instead of time
    let c = bicycle_controls(3.0, false)?;
    let p = Problem::new(bicycle::model(0.5), Vector3::zeros(), (0.0, 3.0)).controls(c.clone());
    let exact = p.solve(Exact::new(bicycle::flow(0.5)), &Options::default())?;
    let dt = 0.05;
    let mut x = Vector3::zeros();
    let mut wrong = vec![(0.0, 0.0)];
    for k in 0..60 {
        let u = c.values(k).unwrap_or_default(); // u[k] for step k: runs the schedule twice as fast
        x = bicycle::flow(0.5)(0.0, &x, u, dt);
        wrong.push((x[0], x[1]));
    }
    let right = p.solve(Euler, &Options::default().fixed(dt))?;
    let plot = Plot::new(
        "Inputs indexed by step number (bicycle, α = sin t sampled at T = 0.1, steps of 0.05)",
        "x (m)",
        "y (m)",
    )
    .equal()
    .with(
        Series::new(
            "exact flow",
            flow_curve(&bicycle::flow(0.5), &exact, &c, 20)
                .iter()
                .map(|(_, x)| (x[0], x[1]))
                .collect(),
            Style::Line,
        )
        .with_markers(xy(&exact)),
    )
    .with(Series::new("u[k] at step k (wrong)", wrong, Style::Line))
    .with(Series::new(
        "u(t) held by time, Euler h = 0.05",
        xy(&right),
        Style::Line,
    ));
    r.figure(dir, "pitfall_step_index.svg", &plot, "With a step half the control period, reading the input by step number plays the steering schedule at double speed; reading it by time (what reckon's breakpoints do) follows it.")?;
    Ok(())
}

//! Hybrid systems and DAEs: a bouncing ball (events that reset the state) against its
//! closed form, and the Test Set's index-1 DAEs (mass matrices) against their references.

use super::*;
use nalgebra::SVector;
use reckon::methods::{Bdf, Rodas5P};
use reckon::studies::problems::{CHEMAKZO_REF_180, TRANSAMP_REF_02, chemakzo, chemakzo_y0, transamp, transamp_mass};
use reckon::{Direction, Event, Mass, Save};

const G: f64 = 9.81;
const E: f64 = 0.8;
const H0: f64 = 10.0;
const BOUNCES: usize = 12;

/// The k-th impact time (k ≥ 1) of the ball dropped from `H0`: `t₁ + Σ_{j<k} 2eʲv₁/g`.
fn impact(k: usize) -> f64 {
    let t1 = (2.0 * H0 / G).sqrt();
    t1 + (1..k).map(|j| 2.0 * E.powi(j as i32) * t1).sum::<f64>()
}

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    r.section(
        "Hybrid systems: a bouncing ball",
        "A ball dropped from 10 m bounces with restitution e = 0.8: an event on the height (falling through zero) resets the velocity to −e·v. The method restarts at each bounce (its carried stage or history dropped, the first step chosen again) and the solution keeps the state before and after each impact. The k-th impact is at t₁(1 + 2e + … + 2e^(k−1)), t₁ = √(2h₀/g), and each bounce keeps e² = 64 % of the energy. Below, RK45 at rtol 1e-10 with dense output, and every impact time against the closed form.",
    );
    let f = reckon::model!(|_t, x: [S; 2]| vector![x[1].clone(), S::from(-G)]);
    let ground = Event::new(|_t, x: &SVector<f64, 2>| x[0])
        .direction(Direction::Falling)
        .reset(|_t, x| vector![x[0], -E * x[1]]);
    let t_end = impact(BOUNCES) + 0.2;
    let o = Options::default().rtol(1e-10).atol(1e-12).dense(true);
    let sol = Problem::new(&f, vector![H0, 0.0], (0.0, t_end))
        .event(ground)
        .solve(Rk45, &o)?;
    let curve: Vec<(f64, f64)> = (0..=1200)
        .map(|k| {
            let t = t_end * k as f64 / 1200.0;
            sol.at(t).map(|x| (t, x[0]))
        })
        .collect::<Result<_, _>>()?;
    let impacts: Vec<(f64, f64)> = (1..=BOUNCES).map(|k| (impact(k), 0.0)).collect();
    let plot = Plot::new("A bouncing ball, e = 0.8", "t (s)", "height (m)")
        .with(Series::new("RK45, rtol 1e-10 (dense output)", curve, Style::Line))
        .with(Series::new("closed-form impact times", impacts, Style::Points));
    r.figure(
        dir,
        "hybrid_ball.svg",
        &plot,
        "The height between impacts from the dense output; the impacts the closed form predicts as points on the floor.",
    )?;
    let hits: Vec<_> = sol.events.iter().collect();
    let mut rows = Vec::new();
    for (k, h) in hits.iter().enumerate().take(BOUNCES) {
        let v_in = h.x[1];
        let v_out = h.x_after.as_ref().map_or(f64::NAN, |x| x[1]);
        rows.push(vec![
            format!("{}", k + 1),
            format!("{:.12}", h.t),
            format!("{:.1e}", (h.t - impact(k + 1)).abs()),
            format!("{:.6}", 0.5 * v_out * v_out / (0.5 * v_in * v_in)),
        ]);
    }
    r.table(
        &["impact", "t (s)", "|t − closed form| (s)", "energy after / before"],
        &rows,
    );
    r.end();

    r.section(
        "Differential-algebraic equations: a mass matrix",
        "M·x' = f(t, x) with a constant, singular M (an index-1 DAE) in Bdf and Rodas5P, on two problems of the Test Set for IVP Solvers: the chemical Akzo Nobel problem (6 components, one algebraic) and the transistor amplifier (8 node voltages, M of rank 5). Digits are the Test Set's mixed significant digits at the end point against its published reference (atol = rtol).",
    );
    let mut rows = Vec::new();
    for rtol in [1e-4, 1e-6, 1e-8] {
        let o = Options::default()
            .rtol(rtol)
            .atol(rtol)
            .save(Save::End)
            .max_steps(1_000_000);
        let akzo = Problem::new(chemakzo(), chemakzo_y0(), (0.0, 180.0))
            .mass(Mass::diagonal(vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0]));
        let y0 = vector![0.0, 3.0, 3.0, 6.0, 3.0, 3.0, 6.0, 0.0];
        let amp = Problem::new(transamp(), y0, (0.0, 0.2)).mass(Mass::dense(transamp_mass()));
        let a_bdf = akzo.solve(Bdf::default(), &o)?;
        let a_ros = akzo.solve(Rodas5P, &o)?;
        let t_bdf = amp.solve(Bdf::default(), &o)?;
        let t_ros = amp.solve(Rodas5P, &o)?;
        let cell = |y: &[f64], r: &[f64], steps: u64| format!("{:.2} ({steps})", mescd(y, r));
        rows.push(vec![
            format!("{rtol:e}"),
            cell(a_bdf.last().1.as_slice(), &CHEMAKZO_REF_180, a_bdf.stats.accepted),
            cell(a_ros.last().1.as_slice(), &CHEMAKZO_REF_180, a_ros.stats.accepted),
            cell(t_bdf.last().1.as_slice(), &TRANSAMP_REF_02, t_bdf.stats.accepted),
            cell(t_ros.last().1.as_slice(), &TRANSAMP_REF_02, t_ros.stats.accepted),
        ]);
    }
    r.table(
        &[
            "rtol",
            "chemakzo Bdf: digits (steps)",
            "chemakzo Rodas5P",
            "transamp Bdf",
            "transamp Rodas5P",
        ],
        &rows,
    );
    r.end();
    Ok(())
}

/// The Test Set's mixed significant digits with atol = rtol.
fn mescd(y: &[f64], r: &[f64]) -> f64 {
    let m = y
        .iter()
        .zip(r)
        .map(|(y, r)| (y - r).abs() / (1.0 + r.abs()))
        .fold(0.0, f64::max);
    -m.max(1e-16).log10()
}

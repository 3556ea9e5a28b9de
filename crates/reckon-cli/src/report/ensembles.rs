//! The report's "filter against the truth" section: Monte-Carlo ensembles of a noisy
//! encoder robot, of the underwater vehicle of the SLAM scenario, and of the one-hour
//! random walk behind the 18.97 m figure, each against the Kalman/EKF covariance.

use super::{Report, Res};
use crate::plot::{Plot, Series, Style};
use nalgebra::{DMatrix, Matrix2, Matrix3, Vector2, Vector3};
use rand_distr::{Distribution, StandardNormal};
use reckon::ensemble::encoder::EncoderEnsemble;
use reckon::ensemble::stats::chi2_interval;
use reckon::ensemble::{Ensemble, Layout, Statistics};
use reckon::kalman::{Kalman, confidence_ellipse, slam};
use reckon::reckoning::encoder_sim::{Command, EncoderErrors};
use reckon::reckoning::encoders::DiffDrive;
use reckon::vehicles::body3d::rotation;
use std::fmt::Write as _;
use std::path::Path;

/// z for a two-sided 95 % interval.
const Z95: f64 = 1.959964;

fn ellipse(p: &Matrix2<f64>, level: f64) -> Vec<(f64, f64)> {
    let (a, b, ang) = confidence_ellipse(p, level);
    super::ellipse((0.0, 0.0), a, b, ang)
}

fn block2(c: &DMatrix<f64>) -> Matrix2<f64> {
    Matrix2::new(c[(0, 0)], c[(0, 1)], c[(1, 0)], c[(1, 1)])
}

fn nees_series(stats: &Statistics, predicted: &[DMatrix<f64>]) -> Res<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    for (k, p) in predicted.iter().enumerate() {
        out.push((stats.layout.times[k], stats.snapshots[k].moments.mean_nees(p)?));
    }
    Ok(out)
}

pub(super) fn section(r: &mut Report, dir: &Path, fast: bool) -> Res {
    let members: u64 = if fast { 1000 } else { 10_000 };
    r.section(
        "The filter against the truth: Monte-Carlo ensembles",
        &format!(
            "{members} members per ensemble, run on every core by <code>reckon::ensemble</code> (the statistics are the same bits for any number of threads: exact sums, member seeds from the master seed and the index). Each member's estimation error (estimate − truth) is compared with the covariance P the filter predicts: the 95% ellipses, and the mean NEES (1/N)·Σ eᵀP⁻¹e, which for a consistent filter lies in the χ² band of N·d degrees of freedom (d = 3 here)."
        ),
    );
    let (lo, hi) = chi2_interval(3.0 * members as f64, Z95);
    let (band_lo, band_hi) = (lo / members as f64, hi / members as f64);

    // 1. the encoder robot
    let robot = DiffDrive::new(0.1, 0.5, 1000.0)?;
    let errors = EncoderErrors {
        pulse_noise: 1.0,
        ..Default::default()
    };
    let commands: Vec<Command> = (0..40)
        .map(|k| Command {
            v: 0.5,
            omega: [0.0, 0.3, 0.0, -0.3][k / 10],
            duration: 1.0,
        })
        .collect();
    let drive = EncoderEnsemble::new(robot, errors, commands, 0.01)?;
    let layout = drive.layout();
    let enc = Ensemble::new(members, 2026).run(&layout, |m, rows| drive.member(m, rows))?;
    let enc_p: Vec<DMatrix<f64>> = drive
        .predicted_covariance()
        .iter()
        .map(|p| DMatrix::from_column_slice(3, 3, p.as_slice()))
        .collect();
    let mut plot = Plot::new(
        "Encoder robot: 95% ellipses of the position error, ensemble vs EKF",
        "error x (m)",
        "error y (m)",
    )
    .equal();
    let mut rows = Vec::new();
    for (g, t) in [10usize, 20, 30, 40].into_iter().enumerate() {
        let k = t - 1;
        let (emp, pred) = (block2(&enc.covariance(k)), block2(&enc_p[k]));
        // one colour per time: the ensemble a wide pale line, the EKF a thin dashed line
        // of the same colour on top, so that where they agree both stay visible
        plot = plot
            .with(
                Series::new(format!("t = {t} s: ensemble"), ellipse(&emp, 0.95), Style::Line)
                    .group(g)
                    .width(6)
                    .opacity(0.4),
            )
            .with(
                Series::new(format!("t = {t} s: EKF"), ellipse(&pred, 0.95), Style::Line)
                    .group(g)
                    .dashed(6, 4),
            );
        let c = enc.covariance(k);
        let mean = enc.mean(k);
        rows.push(vec![
            format!("{t}"),
            format!("{:.2} / {:.2}", 1e3 * c[(0, 0)].sqrt(), 1e3 * enc_p[k][(0, 0)].sqrt()),
            format!("{:.2} / {:.2}", 1e3 * c[(1, 1)].sqrt(), 1e3 * enc_p[k][(1, 1)].sqrt()),
            format!(
                "{:.2} / {:.2}",
                c[(2, 2)].sqrt().to_degrees(),
                enc_p[k][(2, 2)].sqrt().to_degrees()
            ),
            format!("{:.2}, {:.2}", 1e3 * mean[0], 1e3 * mean[1]),
            format!("{:.3}", enc.snapshots[k].moments.mean_nees(&enc_p[k])?),
        ]);
    }
    let _ = write!(
        r.html,
        "<h3>A noisy encoder robot</h3><p>D = 0.1 m, b = 0.5 m, 1000 pulses per revolution, 100 Hz, white noise of 1 pulse (σ) on each count; 10 s straight at 0.5 m/s, 10 s turning left at 0.3 rad/s, 10 s straight, 10 s turning right. Odometry integrates the counts with exact arcs; the EKF predicts P ← F·P·Fᵀ + G·Q·Gᵀ with F and G the update's Jacobians (automatic differentiation) along the commanded path.</p>"
    );
    r.figure(
        dir,
        "ensemble_encoder_ellipses.svg",
        &plot,
        "One colour per time. Wide pale lines: the 95% ellipses of the ensemble's sample covariance; dashed lines: the EKF's at the same time. The heading error turns into lateral error, so the ellipses grow across the direction of travel and turn with it.",
    )?;
    r.table(
        &[
            "t (s)",
            "σ<sub>x</sub> (mm) ens. / EKF",
            "σ<sub>y</sub> (mm) ens. / EKF",
            "σ<sub>θ</sub> (°) ens. / EKF",
            "mean error x, y (mm)",
            "NEES",
        ],
        &rows,
    );

    // 2. the underwater vehicle: the SLAM scenario's dead reckoning with depth
    let sc = slam::synthetic(42);
    let (sv, sd, dt) = (sc.sigma_velocity, sc.sigma_depth, sc.dt);
    let len = sc.t.len();
    let rot: Vec<Matrix3<f64>> = sc.euler.iter().map(|e| rotation(e[0], e[1], e[2])).collect();
    // the filter's covariance and gains are data-independent (linear, known attitude)
    let mut kf = Kalman::new(Vector3::zeros(), Matrix3::identity() * 0.01);
    let q = Matrix3::identity() * (sv * dt).powi(2);
    let c = nalgebra::Matrix1x3::new(0.0, 0.0, 1.0);
    let r_depth = nalgebra::Matrix1::new(sd * sd);
    let every = 600; // a minute
    let mut gains = Vec::with_capacity(len);
    let mut saved_p = Vec::new();
    let mut saved_t = Vec::new();
    for s in 0..len {
        let p = kf.p;
        let s_inn = (c * p * c.transpose())[(0, 0)] + sd * sd;
        gains.push(p * c.transpose() / s_inn);
        kf.correct(&nalgebra::Vector1::new(0.0), &c, &r_depth)?;
        if (s + 1) % every == 0 || s + 1 == len {
            saved_p.push(DMatrix::from_column_slice(3, 3, kf.p.as_slice()));
            saved_t.push(sc.t[s]);
        }
        kf.predict(&Matrix3::identity(), &Vector3::zeros(), &q)?;
    }
    let auv_layout = Layout::new(saved_t.clone(), vec!["ex".into(), "ey".into(), "ez".into()], 3)?;
    let auv = Ensemble::new(members, 42).run(&auv_layout, |m, rows| {
        let rng = m.rng();
        let mut n = || -> f64 { StandardNormal.sample(rng) };
        // initial error ~ N(0, 0.01·I), as the filter assumes
        let mut e = Vector3::new(n(), n(), n()) * 0.1;
        let mut out = rows.chunks_exact_mut(3);
        for s in 0..len {
            // depth correction: innovation −C·e + σ_d·ν
            let innovation = -e[2] + sd * n();
            e += gains[s] * innovation;
            if ((s + 1) % every == 0 || s + 1 == len)
                && let Some(row) = out.next()
            {
                row.copy_from_slice(e.as_slice());
            }
            // prediction with the measured body velocity: error += R·(σ_v·n)·dt
            e += rot[s] * Vector3::new(n(), n(), n()) * (sv * dt);
        }
        Ok(())
    })?;
    let mut sig = Plot::new(
        "Underwater vehicle: position error σ, ensemble vs Kalman filter",
        "t (s)",
        "σ (m)",
    );
    let pick = |i: usize, from_stats: bool| -> Vec<(f64, f64)> {
        saved_t
            .iter()
            .enumerate()
            .map(|(k, t)| {
                let v = if from_stats {
                    auv.covariance(k)[(i, i)]
                } else {
                    saved_p[k][(i, i)]
                };
                (*t, v.sqrt())
            })
            .collect()
    };
    // horizontal in one colour, vertical in another: the ensemble lines, the filter dots
    sig = sig
        .with(Series::new("σx ensemble", pick(0, true), Style::Line).group(0))
        .with(
            Series::new("σy ensemble", pick(1, true), Style::Line)
                .group(0)
                .dashed(7, 4),
        )
        .with(Series::new("σx = σy Kalman", pick(0, false), Style::Points).group(0))
        .with(Series::new("σz ensemble", pick(2, true), Style::Line).group(1))
        .with(Series::new("σz Kalman", pick(2, false), Style::Points).group(1));
    let _ = write!(
        r.html,
        "<h3>The underwater vehicle of the SLAM scenario</h3><p>The survey above without the sonar: dead reckoning from the measured attitude and body velocities (σ<sub>v</sub> = {sv} m/s per axis, {dt} s samples) and a depth fix every sample (σ = {sd} m), {:.0} s. The Kalman filter over the position is the SLAM filter's robot block before its first landmark (P₀ = 0.01 m²·I). Each member draws its own velocity, depth and initial errors. (The full SLAM filter, 15 states, costs 0.1 s a run: {members} members would take many minutes, so the landmarks are left out.)</p>",
        sc.t[len - 1]
    );
    r.figure(
        dir,
        "ensemble_auv_sigma.svg",
        &sig,
        "Horizontally the error is a random walk, σ = √(P₀ + t·dt)·σ<sub>v</sub>; the depth sensor holds σ<sub>z</sub> near its steady state. Lines: the ensemble (σ<sub>x</sub> solid, σ<sub>y</sub> dashed); dots: the filter; one colour for the horizontal, another for the vertical.",
    )?;
    let mut nees = Plot::new(
        "Mean NEES over time (d = 3) with its 95% χ² band",
        "time / length of the run",
        "mean NEES",
    );
    let enc_nees = nees_series(&enc, &enc_p)?;
    let auv_nees = nees_series(&auv, &saved_p)?;
    // time as a fraction of each run, so that both fit one axis
    let frac = |s: &[(f64, f64)]| -> Vec<(f64, f64)> {
        let end = s.last().map_or(1.0, |p| p.0);
        s.iter().map(|(t, v)| (t / end, *v)).collect()
    };
    nees = nees
        .with(Series::new("encoder robot (40 s)", frac(&enc_nees), Style::LinePoints))
        .with(Series::new(
            format!("underwater vehicle ({:.0} s)", sc.t[len - 1]),
            frac(&auv_nees),
            Style::LinePoints,
        ))
        .with(Series::new(
            format!("95% band, N = {members}"),
            vec![(0.0, band_lo), (1.0, band_lo), (0.0, band_hi), (1.0, band_hi)],
            Style::Segments,
        ));
    let inside = |s: &[(f64, f64)]| s.iter().filter(|(_, v)| *v > band_lo && *v < band_hi).count();
    r.figure(
        dir,
        "ensemble_nees.svg",
        &nees,
        &format!(
            "The mean NEES of both ensembles against the band [{band_lo:.3}, {band_hi:.3}] in which a consistent filter's lies 95% of the time (χ² with 3N degrees of freedom, divided by N). Encoder robot: {} of {} saved times inside; underwater vehicle: {} of {} (the times of one run share its members, so they are not independent trials).",
            inside(&enc_nees),
            enc_nees.len(),
            inside(&auv_nees),
            auv_nees.len()
        ),
    )?;

    // 3. the one-hour random walk: σ_v = 1 m/s per axis, dt = 0.1 s
    let (sv, dt, steps) = (1.0f64, 0.1f64, 36_000usize);
    let hours: Vec<f64> = (1..=6).map(|k| k as f64 * 600.0).collect();
    let walk_layout = Layout::new(hours.clone(), vec!["x".into(), "y".into()], 2)?;
    let walk = Ensemble::new(members, 3600).run(&walk_layout, |m, rows| {
        let rng = m.rng();
        let mut p = Vector2::new(0.0, 0.0);
        let mut out = rows.chunks_exact_mut(2);
        for s in 1..=steps {
            let (a, b): (f64, f64) = (StandardNormal.sample(rng), StandardNormal.sample(rng));
            p += Vector2::new(0.1 + sv * a, sv * b) * dt;
            if s % 6000 == 0
                && let Some(row) = out.next()
            {
                row.copy_from_slice(p.as_slice());
            }
        }
        Ok(())
    })?;
    let mut k = Kalman::new(Vector2::zeros(), Matrix2::zeros());
    let q = Matrix2::identity() * (dt * sv).powi(2);
    let mut rows = Vec::new();
    for (i, t) in hours.iter().enumerate() {
        for _ in 0..6000 {
            k.predict(&Matrix2::identity(), &Vector2::new(0.1 * dt, 0.0), &q)?;
        }
        let c = walk.covariance(i);
        rows.push(vec![
            format!("{:.0}", t / 60.0),
            format!("{:.3}", (dt * t).sqrt() * sv),
            format!("{:.3}", k.p[(0, 0)].sqrt()),
            format!("{:.3}", c[(0, 0)].sqrt()),
            format!("{:.3}", c[(1, 1)].sqrt()),
        ]);
    }
    let c = walk.covariance(hours.len() - 1);
    let se = 18.97 / (2.0 * (members as f64 - 1.0)).sqrt();
    let _ = write!(
        r.html,
        "<h3>The one-hour figure by simulation</h3><p>A vehicle dead-reckoned from velocities with white noise σ<sub>v</sub> = 1 m/s per axis, sampled every 0.1 s: after one hour the position's σ is √(dt·t)·σ<sub>v</sub> = √360 = 18.97 m per axis (the Kalman prediction gives the same). Simulated with {members} members of 36 000 steps: σ<sub>x</sub> = {:.2} m, σ<sub>y</sub> = {:.2} m after one hour (a σ estimated from {members} samples has a standard error of σ/√(2(N−1)) = {se:.2} m).</p>",
        c[(0, 0)].sqrt(),
        c[(1, 1)].sqrt()
    );
    r.table(
        &[
            "minutes",
            "σ formula (m)",
            "σ Kalman (m)",
            "σx ensemble (m)",
            "σy ensemble (m)",
        ],
        &rows,
    );
    r.end();
    Ok(())
}

//! `reckon demo`: the classic dead-reckoning scenarios with every method, a convergence
//! and a stiffness study, and the pitfalls of textbook versions, as `report/index.html`.
//! Next to the page and its SVG figures, `figures.json` records where each figure's legend
//! and plotted points landed (SVG pixels, [`super::plot::Layout`]): the legend covers none.

use super::plot::{FIGURE, Layout, Plot, Series, Style, write_svg};
use super::registry::lookup;
use super::studies::{history_plot, prepare, stability_files};
use crate::kalman::confidence_ellipse;
use crate::kalman::slam;
use crate::methods::{Dopri5, Exact, ExplicitEuler, Flow, ImplicitEuler};
use crate::models::{bicycle, carlike, unicycle};
use crate::reckoning::drift::{imu_bias_drift, square};
use crate::reckoning::encoders::{DiffDrive, Update, odometry};
use crate::reckoning::errors::{EncoderErrors, simulate};
use crate::studies::MethodKind;
use crate::{Controls, Options, Problem, Solution, System};
use nalgebra::{SVector, Vector3, vector};
use std::error::Error;
use std::fmt::Write as _;
use std::path::Path;

type Res<T = ()> = Result<T, Box<dyn Error>>;

mod ensembles;
mod pitfalls;
mod symbolic;
use pitfalls::pitfalls;

struct Report {
    html: String,
    figures: usize,
    /// Where each figure's legend and points landed (written to `figures.json`).
    layouts: Vec<Layout>,
}

impl Report {
    fn section(&mut self, title: &str, text: &str) {
        let _ = write!(self.html, "<section><h2>{title}</h2><p>{text}</p>");
    }
    fn figure(&mut self, dir: &Path, file: &str, plot: &Plot, caption: &str) -> Res {
        self.layouts.push(write_svg(plot, &dir.join(file), FIGURE)?);
        self.figures += 1;
        let _ = write!(
            self.html,
            "<figure><a href=\"{file}\"><img src=\"{file}\" alt=\"{}\"></a><figcaption>{caption}</figcaption></figure>",
            plot.title
        );
        Ok(())
    }
    fn table(&mut self, header: &[&str], rows: &[Vec<String>]) {
        let _ = write!(self.html, "<div class=\"scroll\"><table><tr>");
        for h in header {
            let _ = write!(self.html, "<th>{h}</th>");
        }
        let _ = write!(self.html, "</tr>");
        for r in rows {
            let _ = write!(self.html, "<tr>");
            for c in r {
                let _ = write!(self.html, "<td>{c}</td>");
            }
            let _ = write!(self.html, "</tr>");
        }
        let _ = write!(self.html, "</table></div>");
    }
    fn end(&mut self) {
        self.html.push_str("</section>");
    }
}

/// 91 points of the ellipse with centre `c`, semi-axes `a`, `b`, the first turned by `ang`.
fn ellipse(c: (f64, f64), a: f64, b: f64, ang: f64) -> Vec<(f64, f64)> {
    (0..=90)
        .map(|k| {
            let s = k as f64 / 90.0 * std::f64::consts::TAU;
            let (u, w) = (a * s.cos(), b * s.sin());
            (c.0 + u * ang.cos() - w * ang.sin(), c.1 + u * ang.sin() + w * ang.cos())
        })
        .collect()
}

fn xy<const N: usize>(sol: &Solution<nalgebra::Const<N>>) -> Vec<(f64, f64)> {
    sol.x.iter().map(|x| (x[0], x[1])).collect()
}

fn err_row<const N: usize>(name: &str, sol: &Solution<nalgebra::Const<N>>, exact: &SVector<f64, N>) -> Vec<String> {
    vec![
        name.to_string(),
        format!("{:.3e}", (sol.last().1 - exact).fixed_rows::<2>(0).norm()),
        sol.stats.accepted.to_string(),
        sol.stats.rhs_evals.to_string(),
    ]
}

/// A vehicle scenario: initial state, held inputs, fixed step of the Euler methods.
struct Scenario<const N: usize> {
    x0: SVector<f64, N>,
    controls: Controls,
    dt: f64,
}

/// Scenario: a vehicle with held inputs, every method against the exact (or best) flow.
fn vehicle_section<const N: usize>(
    r: &mut Report,
    dir: &Path,
    name: &str,
    sys: impl System<nalgebra::Const<N>>,
    flow: impl Flow<nalgebra::Const<N>> + Clone,
    sc: Scenario<N>,
) -> Res
where
    nalgebra::Const<N>: crate::linalg::LuDim,
{
    let Scenario { x0, controls, dt } = sc;
    let t_end = *controls.times().last().unwrap_or(&0.0);
    let p = Problem::new(&sys, x0, (0.0, t_end)).controls(controls.clone());
    let exact = p.solve(Exact::new(flow.clone()), &Options::default())?;
    let ex_end = *exact.last().1;
    let euler = p.solve(ExplicitEuler, &Options::default().fixed(dt))?;
    let ie = p.solve(ImplicitEuler::default(), &Options::default().fixed(dt))?;
    let rk = p.solve(Dopri5::default(), &Options::default().rtol(1e-6).atol(1e-9).dense(true))?;
    // the exact flow evaluated inside every interval (it is exact for any step), and
    // RK45 from its dense output: both drawn as the curves they are, not as chords
    let exact_curve = flow_curve(&flow, &exact, &controls, 40);
    let rk_curve = dense_curve(&rk, 600)?;
    let plot = Plot::new(format!("{name}: x–y trajectory"), "x (m)", "y (m)")
        .equal()
        .with(
            Series::new(
                "exact flow (dots: control times)",
                exact_curve.iter().map(|(_, x)| (x[0], x[1])).collect(),
                Style::Line,
            )
            .with_markers(xy(&exact)),
        )
        .with(Series::new(format!("explicit Euler h = {dt}"), xy(&euler), Style::Line))
        .with(Series::new(format!("implicit Euler h = {dt}"), xy(&ie), Style::Line))
        .with(Series::new(
            format!("RK45 tol 1e-6 ({} steps)", rk.stats.accepted),
            rk_curve.iter().map(|(_, x)| (x[0], x[1])).collect(),
            Style::Line,
        ));
    let file = format!("{}_xy.svg", slug(name));
    r.figure(
        dir,
        &file,
        &plot,
        &format!("{name}: the methods against the exact flow (black; dots at the control times). The Euler methods are drawn through their step ends (their dense output is linear), RK45 from its 4th-order dense output."),
    )?;
    let theta = Plot::new(format!("{name}: heading θ(t) (unwrapped)"), "t (s)", "θ (rad)")
        .with(
            Series::new(
                "exact flow",
                exact_curve.iter().map(|(t, x)| (*t, x[2])).collect(),
                Style::Line,
            )
            .with_markers(exact.t.iter().zip(&exact.x).map(|(t, x)| (*t, x[2])).collect()),
        )
        .with(Series::new(
            format!("explicit Euler h = {dt}"),
            euler.t.iter().zip(&euler.x).map(|(t, x)| (*t, x[2])).collect(),
            Style::Line,
        ))
        .with(Series::new(
            "RK45 tol 1e-6",
            rk_curve.iter().map(|(t, x)| (*t, x[2])).collect(),
            Style::Line,
        ));
    r.figure(
        dir,
        &format!("{}_theta.svg", slug(name)),
        &theta,
        "Heading against time.",
    )?;
    r.table(
        &["method", "end position error (m)", "steps", "rhs evals"],
        &[
            {
                let mut row = err_row("exact flow", &exact, &ex_end);
                row[1] = "reference".to_string();
                row
            },
            err_row(&format!("explicit Euler h = {dt}"), &euler, &ex_end),
            err_row(&format!("implicit Euler h = {dt}"), &ie, &ex_end),
            err_row("RK45 tol 1e-6", &rk, &ex_end),
        ],
    );
    Ok(())
}

/// The exact flow inside every step of `sol` (one step per control interval), `per_step`
/// points per step: `(t, x)`.
fn flow_curve<const N: usize>(
    flow: &impl Flow<nalgebra::Const<N>>,
    sol: &Solution<nalgebra::Const<N>>,
    controls: &Controls,
    per_step: usize,
) -> Vec<(f64, SVector<f64, N>)> {
    let mut out = vec![(sol.t[0], sol.x[0])];
    let times = controls.times();
    for i in 0..sol.t.len().saturating_sub(1) {
        let (t0, h) = (sol.t[i], sol.t[i + 1] - sol.t[i]);
        // the input held on [t0, t1): the last control time at or before t0
        let k = times.iter().rposition(|&tc| tc <= t0).unwrap_or(0);
        let u = controls.values(k).unwrap_or_default();
        for j in 1..=per_step {
            let s = h * j as f64 / per_step as f64;
            let mut x = SVector::<f64, N>::zeros();
            flow.flow(t0, &sol.x[i], u, s, &mut x);
            out.push((t0 + s, x));
        }
    }
    out
}

/// `sol` on `n` + 1 equally spaced times and at its step ends, from its dense output.
fn dense_curve<const N: usize>(sol: &Solution<nalgebra::Const<N>>, n: usize) -> Res<Vec<(f64, SVector<f64, N>)>> {
    let (t0, t1) = (sol.t[0], *sol.t.last().unwrap_or(&sol.t[0]));
    let mut ts: Vec<f64> = (0..=n).map(|k| t0 + (t1 - t0) * k as f64 / n as f64).collect();
    ts.extend(&sol.t);
    ts.sort_by(f64::total_cmp);
    ts.dedup();
    ts.into_iter().map(|t| Ok((t, sol.at(t)?))).collect()
}

/// Stair steering sampled every T = 0.1 s, or α = sin t sampled the same way.
fn bicycle_controls(t_end: f64, stair: bool) -> Res<Controls> {
    let n = (t_end / 0.1).round() as usize;
    let times: Vec<f64> = (0..=n).map(|k| k as f64 * 0.1).collect();
    let values = times
        .iter()
        .map(|&t| {
            let a = if stair {
                0.1 * ((t / 1.0).floor() - 1.0).clamp(-1.0, 2.0)
            } else {
                t.sin()
            };
            vec![2.0, a]
        })
        .collect();
    Ok(Controls::new(times, values)?)
}

/// Write the report into `dir` (and print the demo tables); `fast` shortens the studies.
pub fn run(dir: &Path, fast: bool) -> Res<usize> {
    prepare(dir)?;
    let mut r = Report {
        html: String::new(),
        figures: 0,
        layouts: Vec::new(),
    };
    r.html.push_str("<!doctype html><html><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>reckon report</title><style>*{box-sizing:border-box}body{font-family:sans-serif;max-width:900px;margin:0 auto;padding:1.5em 1em;line-height:1.45;overflow-wrap:break-word}figure{margin:1.2em 0}img{display:block;max-width:100%;height:auto;border:1px solid #ddd}.scroll{overflow-x:auto;-webkit-overflow-scrolling:touch;margin:1em 0}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right;white-space:nowrap}td:first-child,th:first-child{white-space:normal;min-width:7em;max-width:11em;text-align:left}math{font-family:\"STIX Two Math\",\"Latin Modern Math\",\"Cambria Math\",\"DejaVu Math TeX Gyre\",\"Noto Sans Math\",math}figcaption{color:#444;font-size:90%}@media (max-width:600px){body{padding:1em 0.75em}h1{font-size:1.6em}h2{font-size:1.25em}}</style></head><body><h1>reckon report</h1><p>Every method on the classic dead-reckoning scenarios, a convergence and a stiffness study, and where the textbook versions of these computations go wrong. Generated by <code>reckon demo</code>.</p>");

    // bicycle: stair steering and α = sin t, L = 0.5, v = 2, T = 0.1, 3 s and 15 s
    for (stair, t_end) in [(true, 3.0), (false, 3.0), (false, if fast { 6.0 } else { 15.0 })] {
        let title = format!(
            "Kinematic bicycle, {} steering, {t_end} s",
            if stair { "stair" } else { "α = sin t" }
        );
        r.section(&title, "L = 0.5 m, v = 2 m/s, inputs sampled every T = 0.1 s and held. The exact flow is the unicycle arc with ω = v·tan α / L, exact for any step; Euler is first order; implicit Euler uses Newton with the autodiff Jacobian; RK45 lands on every control time.");
        vehicle_section(
            &mut r,
            dir,
            &title,
            bicycle::model(0.5),
            bicycle::flow(0.5),
            Scenario {
                x0: Vector3::zeros(),
                controls: bicycle_controls(t_end, stair)?,
                dt: 0.1,
            },
        )?;
        r.end();
    }
    // unicycle and car-like
    let uc = super::demo::unicycle_scenario()?;
    r.section(
        "Unicycle with held inputs",
        "Five held segments of 2, 2.5, 1.5, 2 and 2 s: straight, left arc, straight (ω = 0 exactly), right arc, slow left arc. The exact flow is the sinc-form arc.",
    );
    vehicle_section(
        &mut r,
        dir,
        "Unicycle",
        unicycle::model(),
        unicycle::flow,
        Scenario {
            x0: Vector3::zeros(),
            controls: uc,
            dt: 0.1,
        },
    )?;
    r.end();
    let cc = Controls::new(
        vec![0.0, 2.0, 4.0, 6.0],
        vec![vec![5.0, 0.2], vec![5.0, -0.3], vec![4.0, 0.1], vec![0.0, 0.0]],
    )?;
    r.section("Car-like vehicle with steering rate", "L = 2.5 m; the steering angle γ is a state driven by the held steering rate. The exact flow is exact to 1e-12 for any step: γ(s) = γ₀ + ωs and the heading θ(s) = θ₀ − (v/(Lω))·ln(cos γ(s)/cos γ₀) in closed form, the positions by Gauss–Kronrod quadrature of v·cos θ and v·sin θ; it is the reference of the table.");
    vehicle_section(
        &mut r,
        dir,
        "Car-like",
        carlike::model(2.5),
        carlike::flow(2.5),
        Scenario {
            x0: vector![0.0, 0.0, 0.0, 0.0],
            controls: cc,
            dt: 0.1,
        },
    )?;
    r.end();

    // SLAM
    let sc = slam::synthetic(42);
    let out = slam::run(&sc)?;
    r.section("Underwater landmark SLAM (synthetic survey)", "Dead reckoning from Euler angles and body velocities, depth every sample, side-scan sonar ranges at detection times; one Kalman filter over robot position and six landmark positions. Ellipses are the 90% confidence regions (a = √(−2 ln 0.1) = 2.146).");
    let mut plot = Plot::new("SLAM: trajectory, landmarks and 90% ellipses", "x (m)", "y (m)")
        .equal()
        .with(Series::new(
            "true path",
            sc.truth.iter().step_by(10).map(|p| (p[0], p[1])).collect(),
            Style::Line,
        ))
        .with(Series::new(
            "estimated path",
            out.positions.iter().step_by(10).map(|p| (p[0], p[1])).collect(),
            Style::Line,
        ))
        .with(Series::new(
            "true landmarks",
            sc.landmarks.iter().map(|m| (m[0], m[1])).collect(),
            Style::Points,
        ));
    // the 90% ellipses are a metre or two across on a survey of a few hundred metres:
    // drawn ENLARGED here (the factor is in the legend and the caption), and at true
    // scale, centred on each estimate's error, in the next figure
    const ENLARGE: f64 = 10.0;
    let chi2 = -2.0 * (1.0f64 - 0.9).ln();
    let mut ellipses = Vec::new();
    let mut zoom = Plot::new(
        "SLAM: 90% ellipses at true scale, centred on each landmark's estimate error",
        "estimate − truth, x (m)",
        "estimate − truth, y (m)",
    )
    .equal();
    let mut rows = Vec::new();
    let mut inside = 0;
    for (j, ((m, p), truth)) in out.landmarks.iter().zip(&sc.landmarks).enumerate() {
        let (a, b, ang) = confidence_ellipse(p, 0.9);
        let big = ellipse((m[0], m[1]), ENLARGE * a, ENLARGE * b, ang);
        ellipses.extend(big.windows(2).flat_map(|w| [w[0], w[1]]));
        let e = m - truth;
        zoom = zoom.with(
            Series::new(format!("landmark {j}"), ellipse((e[0], e[1]), a, b, ang), Style::Line)
                .with_markers(vec![(e[0], e[1])]),
        );
        let d2 = crate::kalman::mahalanobis2(truth, m, p);
        if d2 <= chi2 {
            inside += 1;
        }
        rows.push(vec![
            j.to_string(),
            format!("({:.2}, {:.2})", truth[0], truth[1]),
            format!("({:.2}, {:.2})", m[0], m[1]),
            format!("{:.3}", (m - truth).norm()),
            format!("{:.3} × {:.3}", a, b),
            format!("{:.2} ({})", d2, if d2 <= chi2 { "inside" } else { "outside" }),
        ]);
    }
    zoom = zoom.with(Series::new("truth (the origin)", vec![(0.0, 0.0)], Style::Points));
    plot = plot
        .with(Series::new(
            "estimated landmarks",
            out.landmarks.iter().map(|(m, _)| (m[0], m[1])).collect(),
            Style::Points,
        ))
        .with(Series::new(
            format!("90% ellipses, drawn {ENLARGE}× enlarged"),
            ellipses,
            Style::Segments,
        ));
    let n = out.landmarks.len();
    r.figure(
        dir,
        "slam.svg",
        &plot,
        &format!("The estimate stays close to the truth. The 90% confidence ellipses of the landmark estimates are drawn {ENLARGE}× enlarged about each estimate so that they can be seen at this scale (true semi-axes in the table); {inside} of the {n} true landmarks lie inside their (true-size) 90% ellipse."),
    )?;
    r.figure(
        dir,
        "slam_ellipses.svg",
        &zoom,
        &format!("The same 90% ellipses at true scale, each centred on its landmark's estimation error (estimate − truth, the dot), so that the truth is the origin: the origin lies inside {inside} of the {n} ellipses (squared Mahalanobis distance ≤ −2 ln 0.1 = {chi2:.3}, last column of the table)."),
    )?;
    r.table(
        &[
            "landmark",
            "truth (m)",
            "estimate (m)",
            "error (m)",
            "90% semi-axes (m)",
            "truth's d² (≤ 4.605 inside)",
        ],
        &rows,
    );
    let dr_err = {
        let mut d = sc.truth[0];
        for s in 0..sc.t.len() - 1 {
            let e = sc.euler[s];
            d += crate::models::body3d::rotation(e[0], e[1], e[2]) * sc.body_velocity[s] * sc.dt;
        }
        (d - sc.truth[sc.truth.len() - 1]).xy().norm()
    };
    let slam_err = (out.positions[out.positions.len() - 1] - sc.truth[sc.truth.len() - 1])
        .xy()
        .norm();
    let _ = write!(
        r.html,
        "<p>Final horizontal error: SLAM {slam_err:.3} m, dead reckoning alone {dr_err:.3} m.</p>"
    );
    r.end();

    // UMBmark
    let robot = DiffDrive::new(0.1, 0.5, 2048.0)?;
    let e = EncoderErrors {
        left_scale: 1.002,
        wheelbase_scale: 1.01,
        ..Default::default()
    };
    r.section("UMBmark: the bidirectional square", "A 4 m square driven clockwise and counter-clockwise with a 0.2% wheel-diameter mismatch and a 1% wheelbase error. Odometry believes it returned to the start; the true path (solid) ends elsewhere, and the two directions separate the two systematic errors (Borenstein &amp; Feng).");
    let mut plot = Plot::new("UMBmark: true paths and odometry", "x (m)", "y (m)").equal();
    let mut rows = Vec::new();
    // one colour per direction; the truth a wide pale line, odometry a thin dashed one
    // on top, so that neither hides the other where they run together
    for (k, (cw, name, short)) in [(false, "counter-clockwise", "ccw"), (true, "clockwise", "cw")]
        .into_iter()
        .enumerate()
    {
        let run = simulate(&robot, &e, &square(4.0, cw, 0.4, 0.5), 0.01, Vector3::zeros());
        let est = odometry(&robot, &run.samples, Update::Exact)?;
        let end = run.truth[run.truth.len() - 1];
        plot = plot
            .with(
                Series::new(
                    format!("{short}: truth"),
                    run.truth
                        .iter()
                        .step_by(20)
                        .map(|p| (p[0], p[1]))
                        .chain([(end[0], end[1])])
                        .collect(),
                    Style::Line,
                )
                .group(k)
                .width(5)
                .opacity(0.45),
            )
            .with(
                Series::new(
                    format!("{short}: odometry"),
                    est.iter().step_by(20).map(|p| (p.1[0], p.1[1])).collect(),
                    Style::Line,
                )
                .group(k)
                .dashed(7, 4),
            )
            .with(Series::new(format!("{short}: true end"), vec![(end[0], end[1])], Style::Points).group(k));
        rows.push(vec![
            name.to_string(),
            format!("({:.3}, {:.3})", end[0], end[1]),
            format!("{:.3}", end.xy().norm()),
        ]);
    }
    // drawn last, as a ring: the clockwise run's true end sits just inside it
    plot = plot.with(
        Series::new("start", vec![(0.0, 0.0)], Style::Points)
            .group(6)
            .marker(8, true),
    );
    r.figure(
        dir,
        "umbmark.svg",
        &plot,
        &format!("True paths (wide, pale) and odometry (dashed) for both directions, counter-clockwise (ccw) and clockwise (cw). The ring is the start, where odometry believes both runs end; the dots are each run's true return point: {} m from the start counter-clockwise, {} m clockwise (inside the ring at this scale).", rows[0][2], rows[1][2]),
    )?;
    r.table(&["direction", "true end (m)", "return error (m)"], &rows);
    // calibration from these two runs, then the corrected robot driven again
    let before = crate::reckoning::drift::umbmark(&robot, &e, 4.0, 0.4, 0.5, 0.01)?;
    let xy = |v: Vector3<f64>| nalgebra::Vector2::new(v[0], v[1]);
    let fit = crate::calibration::umbmark::calibrate(&[xy(before.cw)], &[xy(before.ccw)], 4.0, 0.5)?;
    let after = crate::reckoning::drift::umbmark(&robot, &fit.residual_errors(&e), 4.0, 0.4, 0.5, 0.01)?;
    let _ = write!(
        r.html,
        "<p>Calibrated from these two runs (<code>calibration::umbmark</code>): E<sub>d</sub> = {:.5}, E<sub>b</sub> = {:.5} \
         (injected: the left wheel 0.2 % large, so D<sub>R</sub>/D<sub>L</sub> = 1/1.002 = 0.99800, and the wheelbase 1 % long, 1.01000; the formulas are first order). The robot driven \
         again with the corrected diameters and wheelbase:</p>",
        fit.e_d(),
        fit.e_b()
    );
    let row = |name: &str, u: &crate::reckoning::drift::Umbmark| {
        vec![
            name.to_string(),
            format!("{:.4}", u.e_max_syst()),
            format!("{:.4}", xy(u.cw).norm()),
            format!("{:.4}", xy(u.ccw).norm()),
        ]
    };
    r.table(
        &["", "E<sub>max,syst</sub> (m)", "cw return (m)", "ccw return (m)"],
        &[row("before", &before), row("after", &after)],
    );
    let _ = write!(
        r.html,
        "<p>The correction cuts E<sub>max,syst</sub> {:.0}× (Borenstein &amp; Feng report at least 10×).</p>",
        before.e_max_syst() / after.e_max_syst()
    );
    r.end();

    ensembles::section(&mut r, dir, fast)?;

    // drift against distance
    r.section("Odometry drift against distance", "Straight runs of 1, 2, 5 and 10 m: a 1° heading error gives 1.745% lateral drift (0.1745 m after 10 m); a 0.1% wheel-diameter mismatch curves the path, so its lateral error grows with the square of the distance; slip and pulse noise (seeded) add a random part.");
    let ds = [1.0, 2.0, 5.0, 10.0];
    let heading = crate::reckoning::drift::heading_error_drift(1f64.to_radians(), &ds);
    let sys_err = EncoderErrors {
        left_scale: 1.001,
        ..Default::default()
    };
    let diam = crate::reckoning::drift::straight_drift(&robot, &sys_err, &ds, 0.5, 0.01)?;
    let rnd_err = EncoderErrors {
        slip_sigma: 0.005,
        pulse_noise: 0.5,
        quantize: true,
        seed: 11,
        ..Default::default()
    };
    let rnd = crate::reckoning::drift::straight_drift(&robot, &rnd_err, &ds, 0.5, 0.01)?;
    let plot = Plot::new(
        "Lateral drift as a percentage of distance",
        "distance driven (m)",
        "|lateral error| / distance (%)",
    )
    .legend_at(super::plot::Legend::Middle)
    .with(Series::new(
        "1° heading error",
        heading
            .iter()
            .map(|r| (r.distance, r.lateral_percent().abs()))
            .collect(),
        Style::LinePoints,
    ))
    .with(Series::new(
        "left wheel 0.1% larger",
        diam.iter().map(|r| (r.distance, r.lateral_percent().abs())).collect(),
        Style::LinePoints,
    ))
    .with(Series::new(
        "slip 0.5% + pulse noise (seed 11)",
        rnd.iter().map(|r| (r.distance, r.lateral_percent().abs())).collect(),
        Style::LinePoints,
    ));
    r.figure(
        dir,
        "drift_distance.svg",
        &plot,
        "Constant percentage for a heading error, linear growth of the percentage for a diameter mismatch.",
    )?;
    r.table(
        &[
            "distance (m)",
            "heading 1°: lateral (m)",
            "diameter: lateral (m)",
            "random: lateral (m)",
            "random: longitudinal (m)",
        ],
        &(0..4)
            .map(|k| {
                vec![
                    format!("{}", ds[k]),
                    format!("{:.4}", heading[k].lateral.abs()),
                    format!("{:.4}", diam[k].lateral.abs()),
                    format!("{:.4}", rnd[k].lateral.abs()),
                    format!("{:.4}", rnd[k].longitudinal.abs()),
                ]
            })
            .collect::<Vec<_>>(),
    );
    r.end();

    // IMU drift
    let rows = imu_bias_drift(0.01, 1e-3, &(1..=12).map(|k| k as f64 * 5.0).collect::<Vec<_>>(), 0.01)?;
    r.section("IMU drift", "A level IMU at rest with an uncorrected accelerometer bias b_a = 0.01 m/s² (error ½·b_a·t²) or gyro bias b_g = 1e-3 rad/s (the tilt b_g·t leaks gravity: g·b_g·t³/6), dead-reckoned by strapdown with exact rotations.");
    let plot = Plot::new(
        "IMU position error against time",
        "t (s)",
        "horizontal position error (m)",
    )
    .log_log()
    .with(Series::new(
        "accelerometer bias: simulated",
        rows.iter().map(|r| (r.t, r.accel_simulated)).collect(),
        Style::Points,
    ))
    .with(Series::new(
        "½·b_a·t²",
        rows.iter().map(|r| (r.t, r.accel_closed_form)).collect(),
        Style::Line,
    ))
    .with(Series::new(
        "gyro bias: simulated",
        rows.iter().map(|r| (r.t, r.gyro_simulated)).collect(),
        Style::Points,
    ))
    .with(Series::new(
        "g·b_g·t³/6",
        rows.iter().map(|r| (r.t, r.gyro_closed_form)).collect(),
        Style::Line,
    ));
    r.figure(
        dir,
        "imu_drift.svg",
        &plot,
        "Slopes 2 and 3 on log–log axes: simulation and closed forms agree.",
    )?;
    r.end();

    // convergence study
    r.section("Convergence study", "Observed order by least squares on log–log over fixed step sizes, against the exact solution: the unicycle arc with held inputs (nonlinear), and a damped spring driven by a held force (linear, x' = Ax + Bu), whose exact solution is the zero-order-hold flow. Exponential Euler integrates the model linearised at each step exactly, so it is second order on the unicycle and exact to rounding on the linear model at every step size.");
    let p = lookup("unicycle")?;
    let mut plot = Plot::new(
        "Error against step size (unicycle and linear spring, held inputs)",
        "step size h (s)",
        "max-norm error at t_end",
    )
    .log_log();
    let mut rows = Vec::new();
    for m in [
        MethodKind::Euler,
        MethodKind::ImplicitEuler,
        MethodKind::ExponentialEuler,
        MethodKind::Rk45,
    ] {
        let steps = p.default_steps(m);
        let s = p.convergence(&[m], &steps, crate::studies::convergence::DEFAULT_MAX_STEPS)?;
        let fit = &s.fits[0];
        let order = match fit.order_final {
            Some(o) => format!("{o:.3}"),
            None => "not asymptotic".to_string(),
        };
        plot = plot.with(Series::new(
            format!("{} (slope {order})", m.name()),
            s.rows.iter().map(|r| (r.h, r.final_error)).collect(),
            Style::LinePoints,
        ));
        rows.push(vec![
            m.name().to_string(),
            "unicycle".to_string(),
            order,
            format!("{}", fit.theory.unwrap_or(f64::NAN)),
        ]);
    }
    let lti = lookup("lti")?;
    let steps = lti.default_steps(MethodKind::ExponentialEuler);
    let s = lti.convergence(
        &[MethodKind::ExponentialEuler],
        &steps,
        crate::studies::convergence::DEFAULT_MAX_STEPS,
    )?;
    let worst = s.rows.iter().map(|r| r.final_error).fold(0.0, f64::max);
    // a zero error has no place on a log axis: those points are left out of the line
    plot = plot.with(Series::new(
        format!("exponential-euler, linear spring (≤ {worst:.1e}: exact)"),
        s.rows
            .iter()
            .filter(|r| r.final_error > 0.0)
            .map(|r| (r.h, r.final_error))
            .collect(),
        Style::LinePoints,
    ));
    rows.push(vec![
        "exponential-euler".to_string(),
        "linear spring".to_string(),
        format!("exact: error ≤ {worst:.1e} at every h"),
        "exact".to_string(),
    ]);
    r.figure(dir, "convergence.svg", &plot, "Fitted slopes next to the theory; on the linear model exponential Euler's error is rounding at every step size.")?;
    r.table(&["method", "problem", "observed order", "theory"], &rows);
    r.end();

    // stiffness study
    r.section("Stiffness and step size", "Van der Pol with μ = 1000: RK45's step is pinned by its stability boundary (|hλ| ≤ 3.3 on the real axis) on the slow branches, where accuracy alone would allow large steps; the stiff methods (implicit Euler, BDF, Rodas5P) are stable at any step and theirs follows the solution; Auto runs RK45 until DOPRI5's stiffness test fires, BDF on the slow branches, and RK45 again in the fast jumps. The stability regions and the explicit-Euler threshold 2/|λ|, located by actual runs, complete the picture.");
    let vdp = lookup("van-der-pol")?;
    let hist = vdp.histories(1e-4, 1e-7, if fast { 20_000 } else { 400_000 });
    r.figure(
        dir,
        "step_sizes.svg",
        &history_plot("Step sizes on Van der Pol μ = 1000", &hist),
        "RK45 (stopped at its step limit) against implicit Euler, BDF, Rodas5P and Auto, all at rtol 1e-4, atol 1e-7.",
    )?;
    let dahl = stability_files(dir)?;
    // redrawn over a window that contains every boundary whole (DP5's region reaches
    // |Im z| = 3.85), replacing the SVG of stability_files
    r.figure(
        dir,
        "stability_regions.svg",
        &stability_plot(),
        "Boundaries |R(hλ)| = 1: explicit Euler (disk around −1), DP5 (stable inside the main region and its two small islands near the imaginary axis), implicit Euler (stable outside the disk around +1).",
    )?;
    r.table(
        &["λ", "located threshold h", "2/|λ|", "relative difference"],
        &dahl
            .iter()
            .map(|(l, h, t)| {
                vec![
                    format!("{l}"),
                    format!("{h:.8}"),
                    format!("{t:.8}"),
                    format!("{:.1e}", h / t - 1.0),
                ]
            })
            .collect::<Vec<_>>(),
    );
    r.end();

    // work–precision
    r.section("Work–precision", "Error at the end of the Arenstorf orbit against rhs evaluations and wall time, RK45 over tolerances 1e-4…1e-10 and implicit Euler over 1e-2…1e-4: its error stays of the orbit's size (1.4–2.3) up to 0.46 million rhs evaluations, since a first-order method cannot follow the close approaches to the primaries, while the fifth-order method reaches small errors at a fraction of that work: for a smooth non-stiff problem it wins by orders of magnitude.");
    let ar = lookup("arenstorf")?;
    let tols: Vec<f64> = if fast {
        vec![1e-4, 1e-6]
    } else {
        vec![1e-4, 1e-6, 1e-8, 1e-10]
    };
    let mut pts = ar.work_precision(&[MethodKind::Rk45], &tols, &[], 1)?;
    // implicit Euler's local error is held to tol·rtol: 1e-4 takes 0.46 M rhs evaluations
    let ie_tols = [1e-2, 1e-3, 1e-4];
    pts.extend(ar.work_precision(
        &[MethodKind::ImplicitEuler],
        &ie_tols[..if fast { 2 } else { 3 }],
        &[],
        1,
    )?);
    for (file, xl, by_time) in [
        ("work_precision_evals.svg", "rhs evaluations", false),
        ("work_precision_time.svg", "wall time (s)", true),
    ] {
        let methods = [MethodKind::Rk45, MethodKind::ImplicitEuler];
        let plot =
            super::studies::work_precision_plot("Work–precision: Arenstorf orbit", xl, &methods, &pts, by_time, false);
        r.figure(dir, file, &plot, "Each point is one tolerance.")?;
    }
    r.end();

    stiff_work_precision(&mut r, dir, fast)?;

    symbolic::section(&mut r, dir)?;

    r.section(
        "Where textbook versions go wrong",
        "Three common shortcuts, measured against what reckon does.",
    );
    pitfalls(&mut r, dir)?;
    r.end();
    r.html.push_str("</body></html>\n");
    std::fs::write(dir.join("figures.json"), serde_json::to_string(&r.layouts)?)
        .map_err(|e| format!("cannot write {}: {e}", dir.join("figures.json").display()))?;
    std::fs::write(dir.join("index.html"), &r.html)
        .map_err(|e| format!("cannot write {}: {e}", dir.join("index.html").display()))?;
    Ok(r.figures)
}

/// Work–precision of the stiff methods on Robertson, Van der Pol μ = 1000 and OREGO.
fn stiff_work_precision(r: &mut Report, dir: &Path, fast: bool) -> Res {
    r.section(
        "Stiff work–precision",
        "Correct digits at the end against the published Test Set end states, against rhs evaluations and wall time, for BDF (variable-order NDF 1–5), Rodas5P and Auto over rtol 1e-4…1e-8 and for implicit Euler (atol = rtol; Robertson atol = 1e-4·rtol, the Test Set's convention). Digits are the Test Set's mixed significant digits mescd = −log₁₀ max<sub>i</sub> |y<sub>i</sub> − r<sub>i</sub>| / (atol/rtol + |r<sub>i</sub>|): relative digits in every component larger than atol/rtol, so that Robertson's y₁ ≈ 2·10⁻⁸ and y₂ ≈ 8·10⁻¹⁴ at t = 10¹¹ do not make every run look accurate to 10⁻⁸…10⁻¹⁴, as an absolute error would. Implicit Euler, first order, runs at rtol 1e-2 and 1e-3 only: its local error is held to tol·rtol so that its digits follow the tolerance, and at 1e-4 it takes 0.5–1.8 million rhs evaluations on these problems, where BDF and Rodas5P take a few thousand.",
    );
    let methods = [
        MethodKind::ImplicitEuler,
        MethodKind::Bdf,
        MethodKind::Rodas5P,
        MethodKind::Auto,
    ];
    let tols: Vec<f64> = if fast {
        vec![1e-4, 1e-6]
    } else {
        vec![1e-4, 1e-5, 1e-6, 1e-7, 1e-8]
    };
    let mut rows = Vec::new();
    for (name, title) in [
        ("robertson", "Robertson, t ∈ [0, 1e11]"),
        ("van-der-pol", "Van der Pol μ = 1000, t ∈ [0, 2000]"),
        ("orego", "OREGO, t ∈ [0, 360]"),
    ] {
        let p = lookup(name)?;
        let mut pts = Vec::new();
        for m in methods {
            // implicit Euler at 1e-4 takes 0.49 M (Robertson), 0.99 M (Van der Pol) and
            // 1.8 M (OREGO) rhs evaluations: 1e-2 and 1e-3 show its slope
            let ie_tols = [1e-2, 1e-3];
            let ts = if m == MethodKind::ImplicitEuler {
                &ie_tols[..]
            } else {
                &tols[..]
            };
            pts.extend(p.work_precision(&[m], ts, &[], if fast { 1 } else { 3 })?);
        }
        for (suffix, xl, by_time) in [("evals", "rhs evaluations", false), ("time", "wall time (s)", true)] {
            let plot = super::studies::work_precision_plot(
                &format!("Work–precision: {title}"),
                xl,
                &methods,
                &pts,
                by_time,
                true,
            );
            r.figure(
                dir,
                &format!("stiff_wp_{}_{suffix}.svg", slug(name)),
                &plot,
                "Each point is one tolerance; upper left is better.",
            )?;
        }
        for w in pts.iter().filter(|w| w.setting == 1e-6) {
            // the problem's name only: its span is in the figures' titles
            rows.push(vec![
                title.split(',').next().unwrap_or(title).to_string(),
                w.method.name().to_string(),
                format!("{:.2}", w.digits),
                format!("{:.2e}", w.error),
                format!("{}", w.steps),
                format!("{}", w.rhs_evals),
                format!("{:.3}", w.seconds * 1e3),
            ]);
        }
    }
    r.table(
        &[
            "problem (rtol 1e-6)",
            "method",
            "digits",
            "max error",
            "steps",
            "rhs evals",
            "ms",
        ],
        &rows,
    );
    r.end();
    Ok(())
}

/// The stability-region boundaries on a window that contains each of them whole.
fn stability_plot() -> Plot {
    use crate::studies::stability::{StabilityOf, boundary};
    let mut plot = Plot::new("Linear stability regions |R(hλ)| ≤ 1", "Re(hλ)", "Im(hλ)").equal();
    for (m, label) in [
        (StabilityOf::ExplicitEuler, "explicit Euler |1 + z| = 1"),
        (StabilityOf::ImplicitEuler, "implicit Euler |1/(1 − z)| = 1"),
        (StabilityOf::Dopri5, "DP5 (RK45) |R(z)| = 1"),
    ] {
        let segs = boundary(m, (-4.5, 2.5), (-4.4, 4.4), 281);
        plot = plot.with(Series::new(
            label,
            segs.iter().flat_map(|s| [s[0], s[1]]).collect(),
            Style::Segments,
        ));
    }
    plot
}

/// A file-name-safe version of a title: ASCII letters and digits, words joined by '-'.
fn slug(s: &str) -> String {
    let mut out = String::new();
    for w in s.split(|c: char| !c.is_ascii_alphanumeric()).filter(|w| !w.is_empty()) {
        if !out.is_empty() {
            out.push('-');
        }
        out.push_str(&w.to_ascii_lowercase());
    }
    out
}

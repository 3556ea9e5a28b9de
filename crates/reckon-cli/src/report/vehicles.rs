//! The vehicle sections: the kinematic bicycle (stair and sine steering), the unicycle and the car-like vehicle, every method against the exact flow.

use super::*;

pub(super) fn section(r: &mut Report, dir: &Path, fast: bool) -> Res {
    // bicycle: stair steering and α = sin t, L = 0.5, v = 2, T = 0.1, 3 s and 15 s
    for (stair, t_end) in [(true, 3.0), (false, 3.0), (false, if fast { 6.0 } else { 15.0 })] {
        let title = format!(
            "Kinematic bicycle, {} steering, {t_end} s",
            if stair { "stair" } else { "α = sin t" }
        );
        r.section(&title, "L = 0.5 m, v = 2 m/s, inputs sampled every T = 0.1 s and held. The exact flow is the unicycle arc with ω = v·tan α / L, exact for any step; Euler is first order; implicit Euler uses Newton with the autodiff Jacobian; RK45 lands on every control time.");
        vehicle_section(
            r,
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
    let uc = crate::demo::unicycle_scenario()?;
    r.section(
        "Unicycle with held inputs",
        "Five held segments of 2, 2.5, 1.5, 2 and 2 s: straight, left arc, straight (ω = 0 exactly), right arc, slow left arc. The exact flow is the sinc-form arc.",
    );
    vehicle_section(
        r,
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
        r,
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
    Ok(())
}

pub(super) fn xy<const N: usize>(sol: &Solution<nalgebra::Const<N>>) -> Vec<(f64, f64)> {
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
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    let Scenario { x0, controls, dt } = sc;
    let t_end = *controls.times().last().unwrap_or(&0.0);
    let p = Problem::new(&sys, x0, (0.0, t_end)).controls(controls.clone());
    let exact = p.solve(Exact::new(flow.clone()), &Options::default())?;
    let ex_end = *exact.last().1;
    let euler = p.solve(Euler, &Options::default().fixed(dt))?;
    let ie = p.solve(ImplicitEuler::default(), &Options::default().fixed(dt))?;
    let rk = p.solve(Rk45, &Options::default().rtol(1e-6).atol(1e-9).dense(true))?;
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
pub(super) fn flow_curve<const N: usize>(
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
pub(super) fn bicycle_controls(t_end: f64, stair: bool) -> Res<Controls> {
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

//! Auto against its two methods alone, at tight and loose tolerances: `f` evaluations,
//! Jacobians, LUs, process CPU time and mixed significant digits, with every switch and
//! its reason. `cargo run --release --example auto_cost`
use nalgebra::{SVector, vector};
use reckon::methods::{Auto, Bdf, Rk45};
use reckon::studies::problems::*;
use reckon::{DualSystem, Options, Problem, Solution};
use std::time::Instant;

fn mescd<const N: usize>(y: &SVector<f64, N>, r: &[f64; N], atol: f64, rtol: f64) -> f64 {
    -(0..N)
        .map(|i| (y[i] - r[i]).abs() / (atol / rtol + r[i].abs()))
        .fold(0.0, f64::max)
        .log10()
}

fn row<const N: usize>(
    name: &str,
    m: &str,
    rtol: f64,
    atol: f64,
    r: &[f64; N],
    run: impl Fn() -> reckon::Result<Solution<nalgebra::Const<N>>>,
) {
    let t0 = Instant::now();
    let mut reps = 0;
    let mut out = None;
    while reps < 3 || t0.elapsed().as_secs_f64() < 0.3 {
        out = Some(run());
        reps += 1;
        if reps > 1000 {
            break;
        }
    }
    let dt = t0.elapsed().as_secs_f64() / reps as f64;
    match out.unwrap() {
        Ok(s) => {
            let sw: Vec<String> = s
                .switches
                .iter()
                .map(|w| format!("{:.3e}→{} ({})", w.t, w.to, w.reason))
                .collect();
            println!(
                "{name:8} rtol {rtol:7.1e} {m:7} digits {:5.2} f {:8} jac {:5} lu {:6} acc {:7} {:9.3} ms  {}",
                mescd(s.last().1, r, atol, rtol),
                s.stats.rhs_evals,
                s.stats.jacobian_evals,
                s.stats.lu_decompositions,
                s.stats.accepted,
                dt * 1e3,
                sw.join(" ")
            )
        }
        Err(e) => println!("{name:8} rtol {rtol:7.1e} {m:7} error {e}"),
    }
}

fn all<const N: usize, F: DualSystem<nalgebra::Const<N>> + Clone>(
    name: &str,
    f: F,
    y0: SVector<f64, N>,
    t1: f64,
    r: [f64; N],
    atol_rel: f64,
    rtols: &[f64],
) where
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    for &rtol in rtols {
        let o = Options::default().rtol(rtol).atol(rtol * atol_rel).max_steps(5_000_000);
        let p = Problem::new(f.clone(), y0, (0.0, t1));
        row(name, "dopri5", rtol, rtol * atol_rel, &r, || p.solve(Rk45, &o));
        row(name, "bdf", rtol, rtol * atol_rel, &r, || p.solve(Bdf::default(), &o));
        row(name, "auto", rtol, rtol * atol_rel, &r, || p.solve(Auto::default(), &o));
    }
}

fn main() {
    let rtols = [1e-3, 1e-6, 1e-9];
    all("hires", hires(), hires_y0(), HIRES_T, HIRES_REF, 1.0, &rtols);
    // stiff only in the middle: λ(t) = 1 + 10⁴·exp(−(t − 5)²), exact y = sin t
    let mid = reckon::model!(|t, y: [S; 1]| vector![
        (y[0].clone() - t.sin()) * -(1.0 + 1e4 * (-(t - 5.0) * (t - 5.0)).exp()) + t.cos()
    ]);
    all(
        "middle",
        mid,
        vector![0.0],
        10.0,
        [10f64.sin()],
        1.0,
        &[1e-4, 1e-7, 1e-10],
    );
    all(
        "vdpol",
        van_der_pol(1000.0),
        vector![2.0, 0.0],
        2000.0,
        VDPOLM_REF_2000,
        1.0,
        &rtols,
    );
    all(
        "orego",
        orego(),
        vector![1.0, 2.0, 3.0],
        360.0,
        OREGO_REF_360,
        1.0,
        &rtols,
    );
    // not stiff: Auto should stay with DOPRI5 (reference: DOPRI5 at rtol 1e-13)
    let p = Problem::new(lorenz(), lorenz_y0(), (0.0, 2.0));
    let tight = Options::default().rtol(1e-13).atol(1e-13).max_steps(5_000_000);
    let r = p.solve(Rk45, &tight).unwrap();
    let r = *r.last().1;
    all("lorenz", lorenz(), lorenz_y0(), 2.0, [r[0], r[1], r[2]], 1.0, &rtols);
}

//! The report's symbolic section: each vehicle model's Jacobians traced from its
//! `model!` body (MathML), checked entry by entry against the derivation by hand, and
//! the sparsity pattern of the 1-D Brusselator as a spy plot.

use super::{Report, Res};
use crate::plot::{Plot, Series, Style};
use rand::{Rng, SeedableRng, rngs::StdRng};
use reckon::symbolic::{self, Traced};
use reckon::vehicles::{bicycle, body3d, carlike, unicycle};
use std::path::Path;

/// A hand-derived entry: its formula as a reader writes it and its value at `(x, u)`.
type Hand = (&'static str, fn(&[f64], &[f64]) -> f64);

/// A model's section: title, trace, state and input counts, hand-derived entries.
type Entry<'a> = (&'a str, Traced, usize, usize, &'a [(usize, usize, Hand)]);

/// `(label, traced entry in MathML, hand formula, max relative difference)` for every
/// entry of `∂f/∂x` and `∂f/∂u`; an entry the trace has and the hand list lacks (or the
/// other way round) is a row with "missing".
fn rows(tr: &Traced, n: usize, m: usize, hand: &[(usize, usize, Hand)]) -> Vec<Vec<String>> {
    let names = tr.names().clone();
    let label = |i: usize, j: usize| {
        let wrt = if j < n { names.state(j) } else { names.input(j - n) };
        format!("∂f<sub>{}</sub>/∂{wrt}", names.state(i))
    };
    let mut rng = StdRng::seed_from_u64(5);
    let points: Vec<(Vec<f64>, Vec<f64>)> = (0..20)
        .map(|_| {
            let x = (0..n).map(|_| rng.random_range(-1.2..1.2)).collect();
            let u = (0..m).map(|_| rng.random_range(-1.2..1.2)).collect();
            (x, u)
        })
        .collect();
    let traced: Vec<(usize, usize, reckon::symbolic::Expr<'_>)> = tr
        .jacobian()
        .chain(tr.input_jacobian().map(|(i, k, e)| (i, n + k, e)))
        .collect();
    let mut out = Vec::new();
    for &(i, j, (formula, f)) in hand {
        let math = |s: String| format!("<math>{s}</math>");
        match traced.iter().find(|e| e.0 == i && e.1 == j) {
            Some((_, _, e)) => {
                let diff = points
                    .iter()
                    .map(|(x, u)| {
                        let (a, b) = (e.eval(0.0, x, u), f(x, u));
                        (a - b).abs() / b.abs().max(1e-300)
                    })
                    // a NaN anywhere is shown, not dropped by `max`
                    .fold(
                        0.0f64,
                        |m, d| if d.is_nan() || m.is_nan() { f64::NAN } else { m.max(d) },
                    );
                out.push(vec![
                    label(i, j),
                    math(e.mathml()),
                    formula.to_string(),
                    format!("{diff:.1e}"),
                ]);
            }
            None => out.push(vec![label(i, j), "missing".into(), formula.to_string(), "–".into()]),
        }
    }
    for (i, j, e) in &traced {
        if !hand.iter().any(|h| h.0 == *i && h.1 == *j) {
            out.push(vec![
                label(*i, *j),
                format!("<math>{}</math>", e.mathml()),
                "missing (0)".into(),
                "–".into(),
            ]);
        }
    }
    out
}

/// `∂(R v)/∂φ`, `∂/∂θ` or `∂/∂ψ` (`which` = 0, 1, 2) with `u = (φ, θ, ψ, v)`, by hand:
/// `R = Rz(ψ)·Ry(θ)·Rx(φ)` with the one factor replaced by its derivative.
fn d_rot(u: &[f64], which: usize) -> nalgebra::Vector3<f64> {
    use nalgebra::Matrix3;
    let (sf, cf) = u[0].sin_cos();
    let (st, ct) = u[1].sin_cos();
    let (sp, cp) = u[2].sin_cos();
    let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, cf, -sf, 0.0, sf, cf);
    let ry = Matrix3::new(ct, 0.0, st, 0.0, 1.0, 0.0, -st, 0.0, ct);
    let rz = Matrix3::new(cp, -sp, 0.0, sp, cp, 0.0, 0.0, 0.0, 1.0);
    let drx = Matrix3::new(0.0, 0.0, 0.0, 0.0, -sf, -cf, 0.0, cf, -sf);
    let dry = Matrix3::new(-st, 0.0, ct, 0.0, 0.0, 0.0, -ct, 0.0, -st);
    let drz = Matrix3::new(-sp, -cp, 0.0, cp, -sp, 0.0, 0.0, 0.0, 0.0);
    let v = nalgebra::Vector3::new(u[3], u[4], u[5]);
    match which {
        0 => rz * ry * drx * v,
        1 => rz * dry * rx * v,
        _ => drz * ry * rx * v,
    }
}

pub(super) fn section(r: &mut Report, dir: &Path) -> Res {
    r.section(
        "Symbolic Jacobians",
        "Each vehicle model's Jacobians ∂f/∂x and ∂f/∂u, traced from the same <code>model!</code> body the integrators run \
         (<code>reckon::symbolic</code>; <code>reckon jacobian --model NAME --format text|latex|mathml|rust|json</code> prints them), \
         next to the derivation by hand. The last column is the largest relative difference between the two at 20 random \
         states and inputs; every entry the trace leaves out is a structural zero.",
    );
    let (lb, lc) = (0.5, 2.5);
    let uni: Vec<(usize, usize, Hand)> = vec![
        (0, 2, ("−v sin θ", |x, u| -u[0] * x[2].sin())),
        (1, 2, ("v cos θ", |x, u| u[0] * x[2].cos())),
        (0, 3, ("cos θ", |x, _| x[2].cos())),
        (1, 3, ("sin θ", |x, _| x[2].sin())),
        (2, 4, ("1", |_, _| 1.0)),
    ];
    let bic: Vec<(usize, usize, Hand)> = vec![
        (0, 2, ("−v sin θ", |x, u| -u[0] * x[2].sin())),
        (1, 2, ("v cos θ", |x, u| u[0] * x[2].cos())),
        (0, 3, ("cos θ", |x, _| x[2].cos())),
        (1, 3, ("sin θ", |x, _| x[2].sin())),
        (2, 3, ("tan α / L", |_, u| u[1].tan() / 0.5)),
        (2, 4, ("v / (L cos² α)", |_, u| u[0] / (0.5 * u[1].cos().powi(2)))),
    ];
    let car: Vec<(usize, usize, Hand)> = vec![
        (0, 2, ("−v sin θ", |x, u| -u[0] * x[2].sin())),
        (1, 2, ("v cos θ", |x, u| u[0] * x[2].cos())),
        (2, 3, ("v / (L cos² γ)", |x, u| u[0] / (2.5 * x[3].cos().powi(2)))),
        (0, 4, ("cos θ", |x, _| x[2].cos())),
        (1, 4, ("sin θ", |x, _| x[2].sin())),
        (2, 4, ("tan γ / L", |x, _| x[3].tan() / 2.5)),
        (3, 5, ("1", |_, _| 1.0)),
    ];
    let body: Vec<(usize, usize, Hand)> = vec![
        (0, 6, ("R₁₁ = cψ cθ", |_, u| body3d::rotation(u[0], u[1], u[2])[(0, 0)])),
        (
            0,
            7,
            ("R₁₂ = cψ sθ sφ − sψ cφ", |_, u| {
                body3d::rotation(u[0], u[1], u[2])[(0, 1)]
            }),
        ),
        (
            0,
            8,
            ("R₁₃ = cψ sθ cφ + sψ sφ", |_, u| {
                body3d::rotation(u[0], u[1], u[2])[(0, 2)]
            }),
        ),
        (1, 6, ("R₂₁ = sψ cθ", |_, u| body3d::rotation(u[0], u[1], u[2])[(1, 0)])),
        (
            1,
            7,
            ("R₂₂ = sψ sθ sφ + cψ cφ", |_, u| {
                body3d::rotation(u[0], u[1], u[2])[(1, 1)]
            }),
        ),
        (
            1,
            8,
            ("R₂₃ = sψ sθ cφ − cψ sφ", |_, u| {
                body3d::rotation(u[0], u[1], u[2])[(1, 2)]
            }),
        ),
        (2, 6, ("R₃₁ = −sθ", |_, u| body3d::rotation(u[0], u[1], u[2])[(2, 0)])),
        (2, 7, ("R₃₂ = cθ sφ", |_, u| body3d::rotation(u[0], u[1], u[2])[(2, 1)])),
        (2, 8, ("R₃₃ = cθ cφ", |_, u| body3d::rotation(u[0], u[1], u[2])[(2, 2)])),
    ];
    // ∂(R v)/∂angle by the product rule on R = Rz(ψ)·Ry(θ)·Rx(φ), one factor differentiated
    let body_angles: Vec<(usize, usize, Hand)> = vec![
        (0, 3, ("(Rz Ry Rx′ v)₁", |_, u| d_rot(u, 0)[0])),
        (1, 3, ("(Rz Ry Rx′ v)₂", |_, u| d_rot(u, 0)[1])),
        (2, 3, ("(Rz Ry Rx′ v)₃", |_, u| d_rot(u, 0)[2])),
        (0, 4, ("(Rz Ry′ Rx v)₁", |_, u| d_rot(u, 1)[0])),
        (1, 4, ("(Rz Ry′ Rx v)₂", |_, u| d_rot(u, 1)[1])),
        (2, 4, ("(Rz Ry′ Rx v)₃", |_, u| d_rot(u, 1)[2])),
        (0, 5, ("(Rz′ Ry Rx v)₁", |_, u| d_rot(u, 2)[0])),
        (1, 5, ("(Rz′ Ry Rx v)₂", |_, u| d_rot(u, 2)[1])),
    ];
    let body: Vec<(usize, usize, Hand)> = body.into_iter().chain(body_angles).collect();
    let models: [Entry<'_>; 4] = [
        (
            "Unicycle (x, y, θ; v, ω)",
            symbolic::trace(&unicycle::model(), 3)?.with_names(&["x", "y", "θ"], &["v", "ω"]),
            3,
            2,
            &uni,
        ),
        (
            "Kinematic bicycle, L = 0.5 (x, y, θ; v, α)",
            symbolic::trace(&bicycle::model(lb), 3)?.with_names(&["x", "y", "θ"], &["v", "α"]),
            3,
            2,
            &bic,
        ),
        (
            "Car-like with steering rate, L = 2.5 (x, y, θ, γ; v, ω)",
            symbolic::trace(&carlike::model(lc), 4)?.with_names(&["x", "y", "θ", "γ"], &["v", "ω"]),
            4,
            2,
            &car,
        ),
        (
            "3-D body-velocity vehicle (x, y, z; φ, θ, ψ, v_x, v_y, v_z): ṗ = R(φ, θ, ψ)·v, so ∂f/∂p = 0 and ∂f/∂v = R",
            symbolic::trace(&body3d::model(), 3)?.with_names(&["x", "y", "z"], &["φ", "θ", "ψ", "v_x", "v_y", "v_z"]),
            3,
            6,
            &body,
        ),
    ];
    for (title, tr, n, m, hand) in &models {
        r.html.push_str(&format!("<h3>{title}</h3>"));
        if tr.jacobian().next().is_some() {
            r.html.push_str(&format!("<div class=\"scroll\">{}</div>", tr.mathml()));
        }
        r.table(
            &["entry", "traced", "by hand", "max rel. diff"],
            &rows(tr, *n, *m, hand),
        );
    }

    // the Brusselator's pattern
    let n = 20;
    let tr = symbolic::trace(&reckon::studies::problems::brusselator(n), 2 * n)?;
    let p = tr.pattern();
    // row 1 at the top, as a matrix is written: a flipped y axis, not negative rows
    let pts: Vec<(f64, f64)> = p.entries().map(|(i, j)| (j as f64 + 1.0, i as f64 + 1.0)).collect();
    let plot = Plot::new(
        format!(
            "Sparsity of ∂f/∂x: 1-D Brusselator, {n} points ({} states, {} non-zeros)",
            2 * n,
            p.nnz()
        ),
        "column j (state)",
        "row i (component of f)",
    )
    .equal()
    .flip_y()
    .with(Series::new("non-zero", pts, Style::Points));
    r.figure(
        dir,
        "brusselator_spy.svg",
        &plot,
        "Detected by the trace: u_i couples to u_{i±1}, u_i and v_i, v_i to v_{i±1}, u_i and v_i (states interleaved u₁, v₁, u₂, …): \
         four non-zeros per row, 8N − 4 in all (3 996 at the 500 points of the benchmark). The implicit methods factor I − hγJ \
         with this pattern (sparse LU) instead of the dense n × n matrix.",
    )?;
    r.end();
    Ok(())
}

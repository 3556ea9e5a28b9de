//! Golden results, pinned bit for bit before the redesign moved any code: every method
//! on a few problems (end state, `Stats`, saved points); the command's goldens (the
//! demo's tables, `simulate`, `odometry`, a `jacobian` print) are in
//! `crates/reckon-cli/tests/it/golden.rs`. A move that changes no arithmetic leaves every
//! file in `tests/golden/` as it is; a change that means to move a result re-blesses them
//! with `RECKON_BLESS=1 cargo test --release --test it golden::` and says why in its commit.
//!
//! Floats are written with `{:?}`, Rust's shortest representation that reads back to
//! the same bits, so equal text is equal bits.

use crate::common::golden::golden;
use nalgebra::{SVector, vector};
use reckon::methods::{Auto, Bdf, Euler, Exact, ExponentialEuler, ImplicitEuler, Method, Rk45, Rodas5P};
use reckon::studies::problems::*;
use reckon::vehicles::unicycle;
use reckon::{Controls, DualSystem, Options, Problem};
use std::fmt::Write;

/// One line per run: the method, the setting, the saved points, `Stats` and the end state.
fn line<D, S, M>(out: &mut String, label: &str, p: &Problem<'_, D, S>, m: M, o: &Options)
where
    D: nalgebra::Dim,
    S: reckon::System<D>,
    M: Method<D>,
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D>,
{
    match p.solve(m, o) {
        Ok(s) => {
            let (t, x) = s.last();
            let x: Vec<f64> = x.iter().copied().collect();
            writeln!(out, "{label}: points {} t {t:?} x {x:?}\n  {:?}", s.t.len(), s.stats).unwrap();
        }
        Err(e) => writeln!(out, "{label}: error {e}").unwrap(),
    }
}

/// The four stiff methods at three tolerances on one problem.
fn stiff<const N: usize, F>(out: &mut String, name: &str, f: F, y0: SVector<f64, N>, t1: f64, atol: f64)
where
    F: DualSystem<nalgebra::Const<N>> + Clone,
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    let p = Problem::new(f, y0, (0.0, t1));
    for rtol in [1e-2, 1e-5, 1e-8] {
        let o = Options::default().rtol(rtol).atol(atol * rtol).max_steps(400_000);
        line(out, &format!("{name} bdf {rtol:e}"), &p, Bdf::default(), &o);
        line(out, &format!("{name} bdf-plain {rtol:e}"), &p, Bdf::bdf(), &o);
        line(out, &format!("{name} rodas5p {rtol:e}"), &p, Rodas5P, &o);
        line(out, &format!("{name} auto {rtol:e}"), &p, Auto::default(), &o);
        line(
            out,
            &format!("{name} exponential-euler {rtol:e}"),
            &p,
            ExponentialEuler,
            &o,
        );
        if rtol > 1e-4 {
            line(
                out,
                &format!("{name} implicit-euler {rtol:e}"),
                &p,
                ImplicitEuler::default(),
                &o,
            );
        }
    }
}

#[test]
fn every_method_on_the_test_problems() {
    let mut out = String::new();
    // explicit methods, fixed and adaptive
    let rd = Problem::new(rotation_decay(), vector![1.0, 0.5], (0.0, 5.0));
    line(
        &mut out,
        "rotation-decay euler h 1e-2",
        &rd,
        Euler,
        &Options::default().fixed(1e-2),
    );
    line(
        &mut out,
        "rotation-decay implicit-euler h 1e-2",
        &rd,
        ImplicitEuler::default(),
        &Options::default().fixed(1e-2),
    );
    line(
        &mut out,
        "rotation-decay rk45 h 0.1",
        &rd,
        Rk45,
        &Options::default().fixed(0.1),
    );
    line(
        &mut out,
        "rotation-decay exponential-euler h 0.5",
        &rd,
        ExponentialEuler,
        &Options::default().fixed(0.5),
    );
    let ar = Problem::new(arenstorf(), arenstorf_y0(), (0.0, ARENSTORF_T));
    for rtol in [1e-3, 1e-6, 1e-10] {
        let o = Options::default().rtol(rtol).atol(rtol);
        line(&mut out, &format!("arenstorf rk45 {rtol:e}"), &ar, Rk45, &o);
    }
    let lz = Problem::new(lorenz(), lorenz_y0(), (0.0, 20.0));
    line(
        &mut out,
        "lorenz rk45 1e-8 dense",
        &lz,
        Rk45,
        &Options::default().rtol(1e-8).dense(true),
    );
    let su = Problem::new(sin_u(), vector![0.5], (0.0, 5.0));
    line(
        &mut out,
        "sin-u implicit-euler 1e-3",
        &su,
        ImplicitEuler::default(),
        &Options::default().rtol(1e-3),
    );
    line(
        &mut out,
        "sin-u implicit-euler per-step 1e-3",
        &su,
        ImplicitEuler::default().proportional(false),
        &Options::default().rtol(1e-3),
    );
    // the exact flow of a vehicle with held inputs, and the integrators on the same log
    let controls = Controls::new(
        vec![0.0, 2.0, 4.5, 6.0, 8.0, 10.0],
        vec![
            vec![1.0, 0.0],
            vec![1.5, 0.6],
            vec![2.0, 0.0],
            vec![1.0, -0.9],
            vec![0.5, 0.3],
            vec![0.0, 0.0],
        ],
    )
    .unwrap();
    let uni = unicycle::model();
    let up = Problem::new(&uni, vector![0.0, 0.0, 0.0], (0.0, 10.0)).controls(controls);
    line(
        &mut out,
        "unicycle exact",
        &up,
        Exact::new(unicycle::flow),
        &Options::default(),
    );
    line(
        &mut out,
        "unicycle rk45 1e-10",
        &up,
        Rk45,
        &Options::default().rtol(1e-10),
    );
    line(&mut out, "unicycle bdf 1e-6", &up, Bdf::default(), &Options::default());
    // stiff test problems
    stiff(&mut out, "robertson", robertson(), vector![1.0, 0.0, 0.0], 1e11, 1e-4);
    stiff(&mut out, "vdpolm", van_der_pol(1000.0), vector![2.0, 0.0], 2000.0, 1.0);
    stiff(&mut out, "orego", orego(), vector![1.0, 2.0, 3.0], 360.0, 1.0);
    stiff(&mut out, "hires", hires(), hires_y0(), HIRES_T, 1.0);
    stiff(
        &mut out,
        "e5",
        e5(),
        vector![1.76e-3, 0.0, 0.0, 0.0],
        1e5,
        1.7e-24 / 1e-6,
    );
    // the sparse path: 200-state Brusselator, traced Jacobian, sparse LU
    let br = Problem::new(brusselator(100), brusselator_y0(100), (0.0, 10.0));
    let o = Options::default()
        .rtol(1e-6)
        .atol(1e-6)
        .save(reckon::problem::options::Save::End);
    line::<nalgebra::Dyn, _, _>(&mut out, "brusselator-100 bdf sparse 1e-6", &br, Bdf::default(), &o);
    line::<nalgebra::Dyn, _, _>(&mut out, "brusselator-100 rodas5p sparse 1e-6", &br, Rodas5P, &o);
    golden("methods", &out);
}

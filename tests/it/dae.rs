//! Mass-matrix DAEs `M·x' = f(t, x)` of index 1 with `Bdf` and `Rodas5P`, against the
//! Test Set for IVP Solvers' published references (Mazzia & Magherini, Bari; the Fortran
//! problem files `chemakzo.F` rev 1.2 and `transamp.F` rev 1.3, `rober.F` for t = 1e11),
//! and against the ODEs the DAEs are written from.

use nalgebra::{DMatrix, SVector, vector};
use reckon::methods::{Bdf, Method, Rk45, Rodas5P};
use reckon::studies::problems::{
    AK_KS, CHEMAKZO_REF_180 as AKZO_REF_180, ROBERTSON_REF_1E5, ROBERTSON_REF_1E11, TRANSAMP_REF_02, chemakzo,
    chemakzo_y0 as akzo_y0, robertson, robertson_dae, transamp, transamp_mass,
};
use reckon::{Error, LinearSolver, Mass, Options, Problem, Save, model};

/// Test Set mixed significant digits at the end point (`report.f`, `getscd`):
/// `−log10 max_i |y_i − ref_i| / (atol/rtol + |ref_i|)`.
fn mescd<const N: usize>(y: &SVector<f64, N>, r: &[f64; N], atol_over_rtol: f64) -> f64 {
    let m = (0..N)
        .map(|i| (y[i] - r[i]).abs() / (atol_over_rtol + r[i].abs()))
        .fold(0.0, f64::max);
    -m.max(1e-16).log10()
}

fn run<const N: usize, M: Method<nalgebra::Const<N>>>(
    f: &impl reckon::DualSystem<nalgebra::Const<N>>,
    mass: Mass,
    y0: SVector<f64, N>,
    t_end: f64,
    m: M,
    o: &Options,
) -> reckon::Solution<nalgebra::Const<N>> {
    Problem::new(f, y0, (0.0, t_end)).mass(mass).solve(m, o).unwrap()
}

/// The Test Set's index-1 problems to ≥ 5 correct digits (mescd, atol = rtol) at rtol
/// 1e-6 and ≥ 7 at 1e-9, with `Bdf` and `Rodas5P`.
#[test]
fn test_set_chemakzo_and_transamp() {
    let akzo = chemakzo();
    let amp = transamp();
    for (rtol, need) in [(1e-6, 5.0), (1e-9, 7.0)] {
        let o = Options::default()
            .rtol(rtol)
            .atol(rtol)
            .save(Save::End)
            .max_steps(1_000_000);
        for name in ["bdf", "rodas5p"] {
            let mass = Mass::diagonal(vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
            let s = match name {
                "bdf" => run(&akzo, mass, akzo_y0(), 180.0, Bdf::default(), &o),
                _ => run(&akzo, mass, akzo_y0(), 180.0, Rodas5P, &o),
            };
            let m = mescd(s.last().1, &AKZO_REF_180, 1.0);
            println!("chemakzo {name} rtol {rtol:e}: mescd {m:.2}, {:?}", s.stats);
            assert!(m >= need, "chemakzo {name} rtol {rtol:e}: mescd {m:.2}");
            assert!(s.x0_corrected.is_none(), "the Test Set's y0 is consistent");
            let mass = Mass::dense(transamp_mass());
            let y0 = vector![0.0, 3.0, 3.0, 6.0, 3.0, 3.0, 6.0, 0.0];
            let s = match name {
                "bdf" => run(&amp, mass, y0, 0.2, Bdf::default(), &o),
                _ => run(&amp, mass, y0, 0.2, Rodas5P, &o),
            };
            let m = mescd(s.last().1, &TRANSAMP_REF_02, 1.0);
            println!("transamp {name} rtol {rtol:e}: mescd {m:.2}, {:?}", s.stats);
            assert!(m >= need, "transamp {name} rtol {rtol:e}: mescd {m:.2}");
        }
    }
}

/// Robertson as an index-1 DAE reaches the ODE's references at t = 1e5 and 1e11, and holds
/// the conservation law to rounding; the DAE and the ODE agree to the tolerance.
#[test]
fn robertson_as_a_dae() {
    let dae = robertson_dae();
    let mass = || Mass::diagonal(vec![1.0, 1.0, 0.0]);
    let y0 = vector![1.0, 0.0, 0.0];
    for (t_end, reference) in [(1e5, ROBERTSON_REF_1E5), (1e11, ROBERTSON_REF_1E11)] {
        for rtol in [1e-6, 1e-9] {
            let o = Options::default()
                .rtol(rtol)
                .atol(1e-4 * rtol)
                .save(Save::End)
                .max_steps(1_000_000);
            for (name, s) in [
                ("bdf", run(&dae, mass(), y0, t_end, Bdf::default(), &o)),
                ("rodas5p", run(&dae, mass(), y0, t_end, Rodas5P, &o)),
                (
                    "bdf sparse",
                    run(
                        &dae,
                        mass(),
                        y0,
                        t_end,
                        Bdf::default(),
                        &o.clone().linear_solver(LinearSolver::Sparse),
                    ),
                ),
            ] {
                let y = s.last().1;
                let m = mescd(y, &reference, 1e-4);
                println!(
                    "robertson DAE to {t_end:e}, {name} rtol {rtol:e}: mescd {m:.2}, {:?}",
                    s.stats
                );
                // the ODE's own runs (tests/it/bdf.rs) reach 5.5 at 1e-6 and 9.4 at 1e-10
                assert!(
                    m >= -rtol.log10() - 1.0,
                    "{name} to {t_end:e} rtol {rtol:e}: mescd {m:.2}"
                );
                assert!(
                    (y.sum() - 1.0).abs() < 1e-14,
                    "{name}: conservation {:e}",
                    y.sum() - 1.0
                );
            }
        }
    }
    // against the ODE at the same tolerance, along the way (Save::At)
    let ts: Vec<f64> = (0..12).map(|k| 10f64.powi(k - 4)).collect();
    let o = Options::default().rtol(1e-8).atol(1e-14).save(Save::At(ts));
    let a = Problem::new(&dae, y0, (0.0, 1e7))
        .mass(mass())
        .solve(Bdf::default(), &o)
        .unwrap();
    let b = Problem::new(robertson(), y0, (0.0, 1e7)).solve(Rodas5P, &o).unwrap();
    for (xa, xb) in a.x.iter().zip(&b.x) {
        for i in 0..3 {
            let err = (xa[i] - xb[i]).abs() / (1e-6 + xb[i].abs());
            assert!(err < 1e-5, "{xa} against {xb}");
        }
    }
}

/// The pendulum of length 1 in Cartesian coordinates, index 1: `x' = u, y' = v,
/// u' = −λx, v' = −λy − g, 0 = u² + v² − g·y − λ(x² + y²)`, against the ODE in the
/// angle, `θ'' = −g·sin θ` (x = sin θ, y = −cos θ).
#[test]
fn pendulum_index_1_against_the_angle() {
    const G: f64 = 9.81;
    let f = model!(|_t, z: [S; 5]| vector![
        z[2].clone(),
        z[3].clone(),
        -z[4].clone() * z[0].clone(),
        -z[4].clone() * z[1].clone() - G,
        z[2].clone() * z[2].clone() + z[3].clone() * z[3].clone()
            - z[1].clone() * G
            - z[4].clone() * (z[0].clone() * z[0].clone() + z[1].clone() * z[1].clone())
    ]);
    let angle = model!(|_t, a: [S; 2]| vector![a[1].clone(), -a[0].clone().sin() * G]);
    let th0: f64 = 0.8;
    // at rest: λ = −g·y/(x² + y²) = g·cos θ₀ (consistent); given as 0, to be corrected
    let z0 = vector![th0.sin(), -th0.cos(), 0.0, 0.0, 0.0];
    let o = Options::default()
        .rtol(1e-10)
        .atol(1e-12)
        .save(Save::At(vec![1.0, 2.0, 3.0]));
    let reference = Problem::new(&angle, vector![th0, 0.0], (0.0, 3.0))
        .solve(Rk45, &o)
        .unwrap();
    for (name, s) in [
        (
            "bdf",
            Problem::new(&f, z0, (0.0, 3.0))
                .mass(Mass::diagonal(vec![1.0, 1.0, 1.0, 1.0, 0.0]))
                .solve(Bdf::default(), &o)
                .unwrap(),
        ),
        (
            "rodas5p",
            Problem::new(&f, z0, (0.0, 3.0))
                .mass(Mass::diagonal(vec![1.0, 1.0, 1.0, 1.0, 0.0]))
                .solve(Rodas5P, &o)
                .unwrap(),
        ),
    ] {
        let x0 = s.x0_corrected.expect("λ corrected");
        assert!((x0[4] - G * th0.cos()).abs() < 1e-12, "{name}: λ₀ = {}", x0[4]);
        assert_eq!(
            x0.fixed_rows::<4>(0),
            z0.fixed_rows::<4>(0),
            "{name}: differential part kept"
        );
        for (z, a) in s.x.iter().zip(&reference.x) {
            let (x, y) = (a[0].sin(), -a[0].cos());
            let err = (z[0] - x).abs().max((z[1] - y).abs());
            println!("{name}: position error {err:.1e}");
            assert!(err < 1e-6, "{name}: {err:e}");
        }
    }
}

/// Inconsistent initial values: the algebraic components are corrected (and the solution
/// says so), or, where no correction exists, a typed error; an explicit method or a
/// mass of the wrong size is refused.
#[test]
fn inconsistent_starts_and_refusals() {
    let akzo = chemakzo();
    let mut y0 = akzo_y0();
    y0[5] = 0.36; // the rounded value some ports use: off by 3.6e-7
    let o = Options::default().rtol(1e-9).atol(1e-9).save(Save::End);
    let s = Problem::new(&akzo, y0, (0.0, 180.0))
        .mass(Mass::diagonal(vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0]))
        .solve(Rodas5P, &o)
        .unwrap();
    let c = s.x0_corrected.expect("corrected");
    assert!((c[5] - AK_KS * 0.444 * 0.007).abs() < 1e-15, "{}", c[5]);
    assert_eq!(c.fixed_rows::<5>(0), y0.fixed_rows::<5>(0));
    assert!(mescd(s.last().1, &AKZO_REF_180, 1.0) >= 7.0);
    // 0 = y₂² + 1 has no real solution
    let f = model!(|_t, y: [S; 2]| vector![-y[0].clone(), y[1].clone() * y[1].clone() + 1.0]);
    let e = Problem::new(&f, vector![1.0, 0.0], (0.0, 1.0))
        .mass(Mass::diagonal(vec![1.0, 0.0]))
        .solve(Bdf::default(), &Options::default())
        .unwrap_err();
    assert!(matches!(e, Error::Inconsistent { .. }), "{e}");
    // explicit methods take no mass matrix
    let e = Problem::new(&akzo, akzo_y0(), (0.0, 1.0))
        .mass(Mass::diagonal(vec![1.0, 1.0, 1.0, 1.0, 1.0, 0.0]))
        .solve(Rk45, &Options::default())
        .unwrap_err();
    assert!(e.to_string().contains("mass"), "{e}");
    // sizes and values are checked
    for bad in [
        Mass::diagonal(vec![1.0; 5]),
        Mass::dense(DMatrix::identity(5, 5)),
        Mass::diagonal(vec![1.0, 1.0, f64::NAN, 1.0, 1.0, 0.0]),
    ] {
        let e = Problem::new(&akzo, akzo_y0(), (0.0, 1.0))
            .mass(bad)
            .solve(Bdf::default(), &Options::default())
            .unwrap_err();
        assert!(
            matches!(e, Error::InvalidInput { .. }) && e.to_string().contains("mass"),
            "{e}"
        );
    }
    // the identity is an ODE: the same answer as without it
    let f = model!(|_t, y: [S; 1]| vector![-y[0].clone()]);
    let a = Problem::new(&f, vector![1.0], (0.0, 2.0))
        .mass(Mass::diagonal(vec![1.0]))
        .solve(Rodas5P, &Options::default().rtol(1e-10))
        .unwrap();
    assert!((a.last().1[0] - (-2.0f64).exp()).abs() < 1e-9);
    // a scaled mass: 2y' = −y decays as e^(−t/2)
    let b = Problem::new(&f, vector![1.0], (0.0, 2.0))
        .mass(Mass::dense(DMatrix::from_element(1, 1, 2.0)))
        .solve(Bdf::default(), &Options::default().rtol(1e-10).atol(1e-12))
        .unwrap();
    assert!((b.last().1[0] - (-1.0f64).exp()).abs() < 1e-8, "{}", b.last().1[0]);
}

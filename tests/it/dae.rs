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

/// The linear finite-element mass matrix `h/6·tridiag(1, 4, 1)` of `n` interior nodes on
/// [0, 1], assembled element by element (repeats summed by `Mass::sparse`), and its
/// triplets.
fn fem_mass_triplets(n: usize) -> Vec<(usize, usize, f64)> {
    let h = 1.0 / (n as f64 + 1.0);
    let mut t = Vec::new();
    // element e joins nodes e and e + 1 of 0..=n+1; interior node i is index i − 1
    for e in 0..=n {
        let nodes = [e, e + 1];
        for (a, &p) in nodes.iter().enumerate() {
            for (b, &q) in nodes.iter().enumerate() {
                if (1..=n).contains(&p) && (1..=n).contains(&q) {
                    t.push((p - 1, q - 1, h / 6.0 * if a == b { 2.0 } else { 1.0 }));
                }
            }
        }
    }
    t
}

/// `f(u) = −K·u`, `K = 1/h·tridiag(−1, 2, −1)` (Dirichlet 0 at both ends).
fn heat_stiffness(n: usize) -> impl reckon::DualSystem<nalgebra::Dyn> + Clone {
    let inv_h = n as f64 + 1.0;
    model!(|_t, u: [S; Dyn]| {
        let n = u.len();
        nalgebra::DVector::from_fn(n, |i, _| {
            let l = if i == 0 { S::from(0.0) } else { u[i - 1].clone() };
            let r = if i + 1 == n { S::from(0.0) } else { u[i + 1].clone() };
            (l + r - u[i].clone() * 2.0) * inv_h
        })
    })
}

/// Mode `k` at the nodes, `sin(kπx_i)`, and its generalised eigenvalue of `(K, M)`,
/// `λ = (6/h²)(1 − cos kπh)/(2 + cos kπh)`.
fn heat_mode(n: usize, k: usize) -> (nalgebra::DVector<f64>, f64) {
    let h = 1.0 / (n as f64 + 1.0);
    let th = k as f64 * std::f64::consts::PI * h;
    let u0 = nalgebra::DVector::from_fn(n, |i, _| (th * (i + 1) as f64).sin());
    (u0, 6.0 / (h * h) * (1.0 - th.cos()) / (2.0 + th.cos()))
}

/// The 1-D heat equation with linear finite elements, `M·u' = −K·u` with the consistent
/// mass `M = h/6·tridiag(1, 4, 1)` as `Mass::sparse`: a mode `sin(kπx)` decays exactly as
/// `exp(−λt)`, λ the generalised eigenvalue. With `Bdf` and `Rodas5P`, on the sparse path
/// (2 500 nodes: the slow mode to t = 0.1 and the mode k = n/3, whose λ a lumped or
/// otherwise wrong `M` changes by 20 %, to t = 1/λ) and the dense path (50 nodes, where
/// λ₁ differs from π² by 3e-4: a wrong `M` there shows), and `Mass::sparse` against
/// `Mass::dense` of the same matrix on the dense path (the same steps, the same answer to
/// rounding).
#[test]
fn heat_equation_with_a_sparse_fem_mass() {
    let o = Options::default().rtol(1e-9).atol(1e-12).save(Save::End);
    for (n, solver, modes) in [
        (2500, LinearSolver::Sparse, vec![1, 2500 / 3]),
        (50, LinearSolver::Dense, vec![1, 17]),
    ] {
        let f = heat_stiffness(n);
        let mass = Mass::sparse(n, &fem_mass_triplets(n)).unwrap();
        assert!(!mass.is_singular());
        for k in modes {
            let (u0, lambda) = heat_mode(n, k);
            let t_end = if k == 1 { 0.1 } else { 1.0 / lambda };
            let o = o.clone().linear_solver(solver);
            for name in ["bdf", "rodas5p"] {
                let p = Problem::new(&f, u0.clone(), (0.0, t_end)).mass(mass.clone());
                let s = match name {
                    "bdf" => p.solve(Bdf::default(), &o),
                    _ => p.solve(Rodas5P, &o),
                }
                .unwrap();
                let exact = &u0 * (-lambda * t_end).exp();
                let err = (s.last().1 - &exact).amax() / exact.amax();
                println!(
                    "heat n {n} mode {k} (λ = {lambda:.6e}) {name} {solver:?}: relative error {err:.2e}, {:?}",
                    s.stats
                );
                assert!(err < 2e-7, "n {n} mode {k} {name}: {err:e}");
                assert!(s.x0_corrected.is_none());
            }
        }
        if n > 100 {
            continue;
        }
        // Mass::sparse and Mass::dense of the same matrix on the dense path
        let mut dense = DMatrix::zeros(n, n);
        for (i, j, v) in fem_mass_triplets(n) {
            dense[(i, j)] += v;
        }
        let (u0, _) = heat_mode(n, 1);
        let o = o.clone().linear_solver(LinearSolver::Dense);
        for name in ["bdf", "rodas5p"] {
            let run = |m: Mass| {
                let p = Problem::new(&f, u0.clone(), (0.0, 0.1)).mass(m);
                match name {
                    "bdf" => p.solve(Bdf::default(), &o),
                    _ => p.solve(Rodas5P, &o),
                }
                .unwrap()
            };
            let (a, b) = (run(mass.clone()), run(Mass::dense(dense.clone())));
            let d = (a.last().1 - b.last().1).amax();
            println!("heat n {n} {name}: sparse against dense M {d:.1e}");
            assert_eq!(a.stats.accepted, b.stats.accepted, "{name}");
            assert!(d < 1e-14, "{name}: {d:e}");
        }
    }
}

/// Index-1 DAEs with a sparse singular `M`: Robertson (`M = diag(1, 1, 0)` as
/// `Mass::sparse`, zero third row and column) gives the diagonal kind's answer and the
/// published reference, dense and sparse; the transistor amplifier's `M` (singular with no
/// zero row: null spaces from an SVD) as `Mass::sparse` gives `Mass::dense`'s answer and
/// ≥ 5 digits of the Test Set's reference at rtol 1e-6 (the products are summed row by
/// row in the dense kind's order: the same steps, the same answer).
#[test]
fn sparse_singular_mass_against_diagonal_and_dense() {
    let dae = robertson_dae();
    let y0 = vector![1.0, 0.0, 0.0];
    let sparse = Mass::sparse(3, &[(0, 0, 1.0), (1, 1, 1.0)]).unwrap();
    assert!(sparse.is_singular());
    let o = Options::default().rtol(1e-8).atol(1e-12).save(Save::End);
    for solver in [LinearSolver::Dense, LinearSolver::Sparse] {
        let o = o.clone().linear_solver(solver);
        for name in ["bdf", "rodas5p"] {
            let go = |m: Mass| match name {
                "bdf" => run(&dae, m, y0, 1e5, Bdf::default(), &o),
                _ => run(&dae, m, y0, 1e5, Rodas5P, &o),
            };
            let (a, b) = (go(sparse.clone()), go(Mass::diagonal(vec![1.0, 1.0, 0.0])));
            let m = mescd(a.last().1, &ROBERTSON_REF_1E5, 1e-4);
            let d = (a.last().1 - b.last().1).amax();
            println!("robertson sparse M {name} {solver:?}: mescd {m:.2}, against diagonal {d:.1e}");
            assert!(m >= 7.0, "{name} {solver:?}: mescd {m:.2}");
            assert!(d <= 1e-15, "{name} {solver:?}: {d:e}");
            assert_eq!(a.stats.accepted, b.stats.accepted);
        }
    }
    let amp = transamp();
    let dm = transamp_mass();
    let t: Vec<(usize, usize, f64)> = (0..8)
        .flat_map(|i| (0..8).map(move |j| (i, j)))
        .filter(|&(i, j)| dm[(i, j)] != 0.0)
        .map(|(i, j)| (i, j, dm[(i, j)]))
        .collect();
    let sm = Mass::sparse(8, &t).unwrap();
    assert!(sm.is_singular());
    let o = Options::default().rtol(1e-6).atol(1e-6).save(Save::End);
    let y0 = vector![0.0, 3.0, 3.0, 6.0, 3.0, 3.0, 6.0, 0.0];
    for name in ["bdf", "rodas5p"] {
        let go = |m: Mass| match name {
            "bdf" => run(&amp, m, y0, 0.2, Bdf::default(), &o),
            _ => run(&amp, m, y0, 0.2, Rodas5P, &o),
        };
        let (a, b) = (go(sm.clone()), go(Mass::dense(dm.clone())));
        let m = mescd(a.last().1, &TRANSAMP_REF_02, 1.0);
        let d = (a.last().1 - b.last().1).amax();
        println!("transamp sparse M {name}: mescd {m:.2}, against dense M {d:.1e}");
        assert!(m >= 5.0, "{name}: mescd {m:.2}");
        assert!(d <= 1e-15, "{name}: {d:e}");
        assert_eq!(a.stats.accepted, b.stats.accepted, "{name}");
    }
}

/// A chain of 1 500 algebraic constraints above the dense limit (3 000 states, traced
/// sparse Jacobian): `x_i' = −x_i`, `0 = y_i − y_{i−1}/2 − x_i²` with `M` the identity on
/// the `x` and zero rows and columns on the `y`, started at `y = 0` (inconsistent): the
/// start is corrected to `y_i = a²(2 − 2^{1−i})` and the end is `x_i = a·e^{−t}`,
/// `y_i = a²e^{−2t}(2 − 2^{1−i})`, with `Mass::sparse` and `Mass::diagonal`, `Bdf` and
/// `Rodas5P`. A singular `M` there without that structure (a zero row whose column is not
/// zero) is a typed error, not a silent skip.
#[test]
fn algebraic_chain_above_the_dense_limit() {
    let m = 1500;
    let a = 0.7;
    let f = model!(|_t, z: [S; Dyn]| {
        let m = z.len() / 2;
        nalgebra::DVector::from_fn(2 * m, |k, _| {
            let i = k / 2;
            if k % 2 == 0 {
                -z[2 * i].clone()
            } else {
                let prev = if i == 0 {
                    S::from(0.0)
                } else {
                    z[2 * i - 1].clone() * 0.5
                };
                z[2 * i + 1].clone() - prev - z[2 * i].clone() * z[2 * i].clone()
            }
        })
    });
    let z0 = nalgebra::DVector::from_fn(2 * m, |k, _| if k % 2 == 0 { a } else { 0.0 });
    let y_of = |i: usize, t: f64| a * a * (-2.0 * t).exp() * (2.0 - 2f64.powi(1 - i as i32));
    let t_end = 1.0;
    let o = Options::default()
        .rtol(1e-9)
        .atol(1e-12)
        .save(Save::End)
        .linear_solver(LinearSolver::Sparse);
    let masses = [
        Mass::sparse(2 * m, &(0..m).map(|i| (2 * i, 2 * i, 1.0)).collect::<Vec<_>>()).unwrap(),
        Mass::diagonal((0..2 * m).map(|k| if k % 2 == 0 { 1.0 } else { 0.0 }).collect()),
    ];
    for mass in masses {
        for name in ["bdf", "rodas5p"] {
            let p = Problem::new(&f, z0.clone(), (0.0, t_end)).mass(mass.clone());
            let s = match name {
                "bdf" => p.solve(Bdf::default(), &o),
                _ => p.solve(Rodas5P, &o),
            }
            .unwrap();
            let c = s.x0_corrected.as_ref().expect("y corrected");
            let mut start = 0.0f64;
            let mut end = 0.0f64;
            let z = s.last().1;
            for i in 0..m {
                assert_eq!(c[2 * i], a, "x kept");
                start = start.max((c[2 * i + 1] - y_of(i + 1, 0.0)).abs());
                end = end
                    .max((z[2 * i] - a * (-t_end).exp()).abs())
                    .max((z[2 * i + 1] - y_of(i + 1, t_end)).abs());
            }
            println!(
                "chain of {m} ({} M) {name}: start error {start:.1e}, end error {end:.1e}, {:?}",
                if mass.is_diagonal() { "diagonal" } else { "sparse" },
                s.stats
            );
            assert!(start < 1e-14, "{name}: {start:e}");
            assert!(end < 1e-8, "{name}: {end:e}");
        }
    }
    // x_i' + y_i' = −x_i: row y_i of M is zero, its column is not
    let t: Vec<(usize, usize, f64)> = (0..m)
        .flat_map(|i| [(2 * i, 2 * i, 1.0), (2 * i, 2 * i + 1, 1.0)])
        .collect();
    let e = Problem::new(&f, z0.clone(), (0.0, t_end))
        .mass(Mass::sparse(2 * m, &t).unwrap())
        .solve(Bdf::default(), &o)
        .unwrap_err();
    assert!(
        matches!(e, Error::InvalidInput { .. }) && e.to_string().contains("zero rows and columns"),
        "{e}"
    );
}

/// `Mass::sparse` and `Mass::sparse_csc` refuse bad input with typed errors; a sparse `M`
/// of the wrong size for the problem, and a dense `M` on the sparse path, are refused
/// when solving.
#[test]
fn sparse_mass_bad_input() {
    let msg = |r: Result<Mass, Error>| {
        let e = r.unwrap_err();
        assert!(matches!(e, Error::InvalidInput { .. }), "{e}");
        e.to_string()
    };
    assert_eq!(
        msg(Mass::sparse(3, &[(0, 0, 1.0), (3, 1, 1.0)])),
        "invalid mass: entry (3, 1) is outside the 3 × 3 matrix"
    );
    assert_eq!(
        msg(Mass::sparse(3, &[(0, 0, f64::NAN)])),
        "invalid mass: entry (0, 0) is NaN"
    );
    assert_eq!(
        msg(Mass::sparse(2, &[(0, 0, f64::MAX), (0, 0, f64::MAX)])),
        "invalid mass: entry (0, 0) sums to inf"
    );
    assert_eq!(
        msg(Mass::sparse_csc(3, 2, &[0, 1, 2], &[0, 1], &[1.0, 1.0])),
        "invalid mass: 3×2 is not square"
    );
    assert!(msg(Mass::sparse_csc(2, 2, &[0, 1], &[0], &[1.0])).contains("do not describe 2 columns"));
    assert!(msg(Mass::sparse_csc(2, 2, &[0, 1, 2], &[0, 2], &[1.0, 1.0])).contains("outside"));
    // repeats summed, zeros dropped
    assert_eq!(
        Mass::sparse(2, &[(1, 1, 2.0), (0, 0, 1.0), (1, 1, -2.0)]).unwrap(),
        Mass::sparse(2, &[(0, 0, 1.0)]).unwrap()
    );
    let akzo = chemakzo();
    let five = Mass::sparse(5, &(0..5).map(|i| (i, i, 1.0)).collect::<Vec<_>>()).unwrap();
    let e = Problem::new(&akzo, akzo_y0(), (0.0, 1.0))
        .mass(five)
        .solve(Bdf::default(), &Options::default())
        .unwrap_err();
    assert_eq!(e.to_string(), "invalid mass: 5×5 for a state of 6");
    let e = Problem::new(&akzo, akzo_y0(), (0.0, 1.0))
        .mass(Mass::dense(DMatrix::identity(6, 6)))
        .solve(Bdf::default(), &Options::default().linear_solver(LinearSolver::Sparse))
        .unwrap_err();
    assert!(e.to_string().contains("Mass::sparse"), "{e}");
}

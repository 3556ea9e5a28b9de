//! The sparse linear-algebra path of the implicit methods: faer's sparse LU against the
//! dense one, sparse against dense runs of ImplicitEuler, Bdf and Rodas5P on BRUSS 1-D
//! (500 points), the choice (`Options::linear_solver`), column colouring, and the shipped
//! 2-D Brusselator against its published right-hand side.

use crate::common::bruss;

use bruss::{Bruss, Jac};
use nalgebra::{DMatrix, DVector, Dyn};
use proptest::prelude::*;
use reckon::jacobian::colour::{Coloured, Colouring, detect_pattern};
use reckon::jacobian::{Pattern, SparseJacobian};
use reckon::linalg::SparseLu;
use reckon::methods::{Bdf, ImplicitEuler, Method, Rodas5P};
use reckon::num_dual::DualDVec64;
use reckon::studies::problems::{brusselator, brusselator_2d, brusselator_2d_y0, brusselator_y0, brusselator_y0_book};
use reckon::{Error, Options, Problem, System};
use reckon::{LinearSolver, Save};

/// A random `n × n` pattern with the diagonal and about `density·n²` off-diagonal
/// entries, values with `|a_ii| > Σ_{j≠i} |a_ij|` (rows), from a seed.
fn dominant(n: usize, density: f64, seed: u64) -> (Pattern, Vec<f64>, DMatrix<f64>) {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((s >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let mut a = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in 0..n {
            if i != j && next() < density {
                a[(i, j)] = 2.0 * next() - 1.0;
            }
        }
    }
    for i in 0..n {
        let off: f64 = (0..n).filter(|&j| j != i).map(|j| f64::abs(a[(i, j)])).sum();
        a[(i, i)] = (1.0 + off + next()) * if next() < 0.5 { -1.0 } else { 1.0 };
    }
    let e: Vec<_> = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .filter(|&(i, j)| a[(i, j)] != 0.0)
        .collect();
    let p = Pattern::from_entries(n, &e).unwrap();
    let v = p.entries().map(|(i, j)| a[(i, j)]).collect();
    (p, v, a)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// `A⁻¹b` by the sparse LU equals the dense LU's to 1e-12 (relative, max norm).
    #[test]
    fn sparse_lu_solves_like_dense(n in 1usize..80, density in 0.0f64..0.3, seed in any::<u64>()) {
        let (p, v, a) = dominant(n, density, seed);
        let mut lu = SparseLu::new(&p).unwrap();
        prop_assert_eq!(lu.factor(&v), Ok(true));
        let b = DVector::from_fn(n, |i, _| (i as f64 * 0.7).sin() + 0.5);
        let mut x = b.clone();
        lu.solve_in_place(x.as_mut_slice()).unwrap();
        let y = a.clone().lu().solve(&b).unwrap();
        let err = (&x - &y).amax() / y.amax();
        prop_assert!(err < 1e-12, "n {n}: relative difference {err:e}");
        // and refactoring new values in the same pattern
        let v2: Vec<f64> = v.iter().map(|x| x * 1.5).collect();
        prop_assert_eq!(lu.factor(&v2), Ok(true));
        let mut x2 = b.clone();
        lu.solve_in_place(x2.as_mut_slice()).unwrap();
        let err2 = (&x2 * 1.5 - &y).amax() / y.amax();
        prop_assert!(err2 < 1e-12, "refactor: {err2:e}");
    }
}

/// A singular matrix in a pattern, or a non-finite value, fails the factorisation.
#[test]
fn singular_and_non_finite_fail() {
    // [[1, 2], [2, 4]]: rank 1
    let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (0, 1), (1, 1)]).unwrap();
    let mut lu = SparseLu::new(&p).unwrap();
    assert_eq!(lu.factor(&[1.0, 2.0, 2.0, 4.0]), Ok(false));
    assert_eq!(lu.factor(&[1.0, f64::NAN, 0.0, 1.0]), Ok(false));
    assert_eq!(lu.factor(&[1.0, 2.0, 0.0, 1.0]), Ok(true));
    // a structurally singular one: an empty row
    let q = Pattern::from_entries(3, &[(0, 0), (0, 1), (2, 2), (0, 2)]).unwrap();
    let mut lu = SparseLu::new(&q).unwrap();
    assert_eq!(lu.factor(&[1.0, 1.0, 1.0, 1.0]), Ok(false));
}

const N: usize = 500;

/// BRUSS 1-D with N = 500 (1 000 states) from `problems::brusselator_y0` (`u_i = 1 +
/// ½ sin 2πx_i`, `v_i = 3`, `x_i = i/501`, α = 1/50, boundary `u = 1`, `v = 3`): `(i, u_i,
/// v_i)` at `t = 10` for 15 of the 500 grid points (1-based `i`).
///
/// Provenance: scipy 1.17.1 (numpy 2.4.6) `solve_ivp(method="Radau", rtol=1e-13,
/// atol=1e-13, jac=<the exact sparse Jacobian>)`, 5 490 steps, written out with Python's
/// `repr` (17 significant digits); the script is in `docs/references.md`. Its own
/// `rtol = 1e-12` run agrees to 1.3e-13 absolute in every one of the 1 000 components
/// (`1e-11`: 9.8e-13). Independently, reckon's Rodas5P (sparse path) at `rtol = atol =
/// 1e-12` agrees to 4.1e-12 and Bdf to 3.9e-11. With the book's amplitude 1
/// (`brusselator_y0_book`) the end state differs from these by up to 0.16.
const BRUSS_REF_10: [(usize, f64, f64); 15] = [
    (1, 0.99491970023176, 3.005348906814994),
    (25, 0.8752626365016727, 3.1310118289054856),
    (50, 0.7624421042573137, 3.2476771212435427),
    (100, 0.5945985839972461, 3.4111564561836825),
    (125, 0.5395823579001645, 3.458657216774458),
    (167, 0.4805801227604506, 3.5023137733654686),
    (200, 0.4556261707552648, 3.517524904943899),
    (250, 0.4426841526680765, 3.5266692395908974),
    (300, 0.45522902728006165, 3.5257427386021054),
    (333, 0.479865808089968, 3.5145883024867643),
    (375, 0.5383042574594811, 3.473474126030007),
    (400, 0.5928316594749825, 3.4259329496367514),
    (450, 0.7591717305358049, 3.259308758422515),
    (475, 0.8710345806036083, 3.139894947798231),
    (500, 0.9949443665673287, 3.0054979997475813),
];

/// The largest absolute difference of `x` from [`BRUSS_REF_10`] at its grid points.
fn ref_error(x: &DVector<f64>) -> f64 {
    BRUSS_REF_10
        .iter()
        .map(|&(i, u, v)| (x[2 * (i - 1)] - u).abs().max((x[2 * (i - 1) + 1] - v).abs()))
        .fold(0.0, f64::max)
}

fn run<M: Method<Dyn>>(method: M, linear: LinearSolver, rtol: f64, t_end: f64) -> (DVector<f64>, reckon::Stats, Bruss) {
    let sys = Bruss::new(N, Jac::Coloured);
    let o = Options::default()
        .rtol(rtol)
        .atol(rtol)
        .save(Save::End)
        .dense(false)
        .linear_solver(linear);
    let sol = Problem::new(&sys, brusselator_y0(N), (0.0, t_end))
        .solve(method, &o)
        .unwrap();
    let (x, stats) = (sol.last().1.clone(), sol.stats);
    (x, stats, sys)
}

fn same(
    name: &str,
    make: impl Fn() -> (DVector<f64>, reckon::Stats, Bruss),
    dense: impl Fn() -> (DVector<f64>, reckon::Stats, Bruss),
) -> (DVector<f64>, DVector<f64>) {
    let (xs, ss, bs) = make();
    let (xd, sd, bd) = dense();
    let err = (&xs - &xd).amax() / xd.amax();
    println!("{name}: sparse {ss:?}\n{name}: dense  {sd:?}\n{name}: relative difference {err:.1e}");
    assert!(err < 1e-10, "{name}: sparse and dense differ by {err:e}");
    assert_eq!(ss.accepted, sd.accepted, "{name}: the same steps");
    // the paths were the ones asked for
    assert_eq!(bs.dense_calls.get(), 0, "{name}: the sparse run made no dense J");
    assert_eq!(bs.sparse_calls.get(), ss.jacobian_evals as usize);
    assert_eq!(bd.sparse_calls.get(), 0, "{name}: the dense run made no sparse J");
    assert_eq!(bd.dense_calls.get(), sd.jacobian_evals as usize);
    (xs, xd)
}

/// Both paths' end states are as far from the scipy Radau reference as each other (the
/// same to 1e-10 of the state's size) and within `bound` of it.
fn near_reference(name: &str, (xs, xd): (DVector<f64>, DVector<f64>), bound: f64) {
    let (es, ed) = (ref_error(&xs), ref_error(&xd));
    println!("{name}: error against scipy Radau: sparse {es:.3e}, dense {ed:.3e}");
    assert!(
        es < bound && ed < bound,
        "{name}: sparse {es:e}, dense {ed:e} (bound {bound:e})"
    );
    assert!(
        (es - ed).abs() < 1e-10 * xd.amax(),
        "{name}: sparse {es:e}, dense {ed:e}"
    );
}

/// BRUSS 1-D, 500 points (1 000 states): the sparse path (coloured J, faer sparse LU)
/// and the dense one (hand-written J, faer dense LU) take the same steps to the same
/// state, 1e-10 relative.
#[test]
fn implicit_euler_sparse_equals_dense() {
    let r = |l| move || run(ImplicitEuler::default(), l, 1e-3, 10.0);
    same("implicit-euler", r(LinearSolver::Sparse), r(LinearSolver::Dense));
}

#[test]
fn bdf_sparse_equals_dense() {
    let r = |l| move || run(Bdf::default(), l, 1e-6, 10.0);
    near_reference(
        "bdf",
        same("bdf", r(LinearSolver::Sparse), r(LinearSolver::Dense)),
        1e-4,
    );
}

#[test]
fn rodas5p_sparse_equals_dense() {
    let r = |l| move || run(Rodas5P, l, 1e-6, 10.0);
    near_reference(
        "rodas5p",
        same("rodas5p", r(LinearSolver::Sparse), r(LinearSolver::Dense)),
        1e-4,
    );
}

/// `Auto` takes the sparse path for 1 000 states with 5 non-zeros per column, and does
/// not even ask a 20-state model for its sparse Jacobian.
#[test]
fn auto_chooses_by_size_and_density() {
    let (_, s, b) = run(Bdf::default(), LinearSolver::Auto, 1e-4, 0.1);
    assert_eq!(b.made.get(), 1);
    assert_eq!(b.dense_calls.get(), 0);
    assert_eq!(b.sparse_calls.get(), s.jacobian_evals as usize);
    let small = Bruss::new(10, Jac::Coloured);
    let o = Options::default().save(Save::End);
    Problem::new(&small, brusselator_y0(10), (0.0, 0.1))
        .solve(Bdf::default(), &o)
        .unwrap();
    assert_eq!(small.made.get(), 0);
    assert!(small.dense_calls.get() > 0);
}

/// Forcing `Sparse` on a model without a sparse Jacobian (a hand-written `System`) is a
/// typed error that says why; `Auto` and `Dense` run such a model densely. A `model!`
/// whose `DVector` body branches on the state cannot be traced but is coloured: its
/// detected pattern takes the sparse path and gives the dense path's answer.
#[test]
fn forced_sparse_without_sparse_jacobian_is_refused() {
    let o = Options::default().linear_solver(LinearSolver::Sparse);
    let none = Bruss::new(40, Jac::None);
    let p = Problem::new(&none, brusselator_y0(40), (0.0, 1.0));
    #[allow(clippy::cmp_owned)] // S = f64 in one copy
    let branchy = reckon::model!(|_, x: [S; Dyn]| x.map(|v| if v > S::from(0.0) { -v.clone() } else { v * 2.0 }));
    let q = Problem::new(&branchy, DVector::from_element(80, 1.0), (0.0, 1.0));
    assert!(matches!(
        reckon::symbolic::trace(&branchy, 80),
        Err(Error::Untraceable { .. })
    ));
    let coloured = branchy.sparse_jacobian(80).expect("coloured");
    assert_eq!(coloured.pattern().nnz(), 80, "a diagonal Jacobian");
    let ys = q.solve(Bdf::default(), &o).unwrap().last().1[0];
    assert!((ys - (-1.0f64).exp()).abs() < 1e-4, "{ys}");
    for e in [
        p.solve(Bdf::default(), &o).unwrap_err(),
        p.solve(ImplicitEuler::default(), &o).unwrap_err(),
        p.solve(Rodas5P, &o).unwrap_err(),
    ] {
        match e {
            Error::InvalidInput { what, reason } => {
                assert_eq!(what, "linear_solver");
                assert!(reason.contains("sparse Jacobian"), "{reason}");
            }
            e => panic!("{e:?}"),
        }
    }
    for l in [LinearSolver::Auto, LinearSolver::Dense] {
        let o = Options::default().linear_solver(l);
        assert!(p.solve(Bdf::default(), &o).is_ok());
        let y = q.solve(Bdf::default(), &o).unwrap().last().1[0];
        assert!((y - (-1.0f64).exp()).abs() < 1e-4, "{y}");
    }
}

/// `problems::brusselator` is a traced `model!`: its compiled sparse Jacobian (the
/// symbolic layer's) takes the sparse path under `Auto` and agrees with the dense run.
#[test]
fn traced_model_takes_the_sparse_path() {
    let sys = brusselator(N);
    let o = Options::default().rtol(1e-6).atol(1e-6).save(Save::End).dense(false);
    let p = Problem::new(&sys, brusselator_y0(N), (0.0, 10.0));
    let mut j = sys.sparse_jacobian(2 * N).expect("traced");
    assert_eq!(j.pattern(), &bruss::pattern(N));
    let y = brusselator_y0(N).map(|v| v * 0.9 + 0.05);
    let mut v = vec![0.0; j.pattern().nnz()];
    j.eval(0.0, y.as_slice(), &[], &mut v).unwrap();
    let mut w = vec![0.0; v.len()];
    Bruss::new(N, Jac::Hand)
        .sparse_jacobian(2 * N)
        .unwrap()
        .eval(0.0, y.as_slice(), &[], &mut w)
        .unwrap();
    let worst = v.iter().zip(&w).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(worst <= 1e-14 * 2.0e4, "compiled vs hand {worst:e}");
    // a spy on the dense Jacobian: the Auto run never calls it
    struct Spy<M>(M, std::cell::Cell<usize>);
    impl<M: System<Dyn>> System<Dyn> for Spy<M> {
        fn rhs(&self, t: f64, x: &DVector<f64>, u: &[f64], dx: &mut DVector<f64>) {
            self.0.rhs(t, x, u, dx)
        }
        fn jacobian(&self, t: f64, x: &DVector<f64>, u: &[f64], j: &mut DMatrix<f64>) {
            self.1.set(self.1.get() + 1);
            self.0.jacobian(t, x, u, j)
        }
        fn sparse_jacobian(&self, n: usize) -> Option<Box<dyn SparseJacobian + '_>> {
            self.0.sparse_jacobian(n)
        }
    }
    let spy = Spy(brusselator(N), Default::default());
    let auto = Problem::new(&spy, brusselator_y0(N), (0.0, 10.0))
        .solve(Bdf::default(), &o)
        .unwrap();
    assert_eq!(spy.1.get(), 0, "Auto took the sparse path");
    assert!(auto.stats.jacobian_evals > 0);
    let dense = p
        .solve(Bdf::default(), &o.clone().linear_solver(LinearSolver::Dense))
        .unwrap();
    let err = (auto.last().1 - dense.last().1).amax() / dense.last().1.amax();
    assert!(err < 1e-10, "{err:e}");
    assert_eq!(auto.stats.accepted, dense.stats.accepted);
    // the 2-D Brusselator branches on its (plain-f64) time, so it is not traced but
    // coloured: its pattern is the one detected from the dual body at y0, and it is
    // exactly the 5-point stencil of each species plus the u–v coupling at each point
    let m = 8;
    let f8 = brusselator_2d(m);
    match reckon::symbolic::trace(&f8, 2 * m * m) {
        Err(Error::Untraceable { reason, .. }) => assert!(reason.contains("reads its time"), "{reason}"),
        other => panic!("{other:?}"),
    }
    let g = |t: f64, x: &DVector<DualDVec64>, u: &[f64]| reckon::DualSystem::rhs_dual(&f8, t, x, u);
    let detected = detect_pattern(&g, 0.0, &brusselator_2d_y0(m), &[]);
    let coloured = f8.sparse_jacobian(2 * m * m).expect("coloured");
    assert_eq!(coloured.pattern(), &detected);
    let nn = m * m;
    let mut e = Vec::new();
    for s in 0..2 {
        for j in 0..m {
            for i in 0..m {
                let row = s * nn + i + m * j;
                let at = |i: usize, j: usize| s * nn + i + m * j;
                e.extend([
                    (row, at(i, j)),
                    (row, at((i + 1) % m, j)),
                    (row, at((i + m - 1) % m, j)),
                    (row, at(i, (j + 1) % m)),
                    (row, at(i, (j + m - 1) % m)),
                    (row, (1 - s) * nn + i + m * j),
                ]);
            }
        }
    }
    assert_eq!(
        coloured.pattern(),
        &reckon::jacobian::Pattern::from_entries(2 * nn, &e).unwrap()
    );
}

/// Greedy colouring of BRUSS 1-D's interleaved `(u_i, v_i)` pattern: 4 colours at every
/// size from 4 points on, the optimum (a row holds 4 entries, which need 4 colours), in
/// the period `0 1 2 3 1 0 3 2` over 4 states; the coloured Jacobian equals num-dual's
/// dense one, and the pattern detected from the body is the hand-written one.
#[test]
fn colouring_of_bruss_and_exact_values() {
    for n in [4, 5, 50, 500] {
        let c = Colouring::greedy(&bruss::pattern(n));
        assert_eq!(c.count(), 4, "n = {n}");
        let period = [0, 1, 2, 3, 1, 0, 3, 2];
        assert!(c.colours().iter().enumerate().all(|(k, &col)| col == period[k % 8]));

        // no two columns of one colour share a row
        let p = bruss::pattern(n);
        for i in 0..2 * n {
            let mut seen = std::collections::HashSet::new();
            for (r, col) in p.entries() {
                if r == i {
                    assert!(seen.insert(c.colours()[col]));
                }
            }
        }
    }
    let n = 500;
    let c = (n as f64 + 1.0).powi(2) / 50.0;
    let g = move |_t: f64, x: &DVector<DualDVec64>, _u: &[f64]| bruss::body(x, c);
    let mut jac = Coloured::new(bruss::pattern(n), g);
    let y = brusselator_y0(n).map(|v| v * 0.9 + 0.05);
    let mut values = vec![0.0; jac.pattern().nnz()];
    jac.eval(0.0, y.as_slice(), &[], &mut values).unwrap();
    let mut dense = DMatrix::zeros(2 * n, 2 * n);
    brusselator(n).jacobian(0.0, &y, &[], &mut dense);
    let scale = dense.amax();
    let mut worst: f64 = 0.0;
    for ((i, j), v) in jac.pattern().entries().zip(&values) {
        worst = worst.max((v - dense[(i, j)]).abs());
        dense[(i, j)] = 0.0;
    }
    assert!(worst <= 1e-14 * scale, "coloured vs dense {:e}", worst / scale);
    assert_eq!(dense.amax(), 0.0, "every non-zero is in the pattern");
    // the detected pattern is the hand-written one
    assert_eq!(detect_pattern(&g, 0.0, &brusselator_y0(60), &[]), bruss::pattern(60));
}

/// The shipped 2-D Brusselator reproduces the right-hand side printed in DiffEqGPU.jl's
/// `docs/src/examples/bruss.md` at `n = 32` (Julia's 1-based indices), with the forcing
/// on at `t = 1.3` in the disc only; its pattern is sparse, 12 entries per `u` row.
#[test]
fn brusselator_2d_matches_published_rhs() {
    let n = 32;
    let (f, y0) = (brusselator_2d(n), brusselator_2d_y0(n));
    let mut du = y0.clone();
    f.rhs(0.0, &y0, &[], &mut du);
    let published = [
        (34, 802.9807693762164),
        (1058, 985.3120721709204),
        (2000, -403.5817880634729),
        (2048, 1431.1460373522068),
        (521, -323.1677459142322),
    ];
    for (k, v) in published {
        assert!(
            (du[k - 1] - v).abs() <= 1e-12 * v.abs(),
            "du[{k}] = {} vs {v}",
            du[k - 1]
        );
    }
    let mut du2 = y0.clone();
    f.rhs(1.3, &y0, &[], &mut du2);
    assert!((du2[520] - -318.1677459142322).abs() <= 1e-12 * 318.2);
    assert_eq!(
        (&du2 - &du).iter().filter(|d| **d != 0.0).count(),
        30,
        "grid points in the disc"
    );
    assert!((&du2 - &du).iter().all(|d| *d == 0.0 || *d == 5.0));
    // pattern: u_ij reads u at its 5-point stencil and v_ij; v_ij the same
    let m = 8;
    let f8 = brusselator_2d(m);
    let g = |t: f64, x: &DVector<DualDVec64>, u: &[f64]| reckon::DualSystem::rhs_dual(&f8, t, x, u);
    let p = detect_pattern(&g, 0.0, &brusselator_2d_y0(m), &[]);
    assert_eq!(p.nnz(), 6 * 2 * m * m);
    assert!(p.density() < 0.05);
}

/// The implicit methods stay `Send + Sync` with the sparse variant inside.
#[test]
fn methods_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    use reckon::methods::{Auto, auto::AutoStepper, bdf::BdfStepper};
    use reckon::methods::{implicit_euler::ImplicitEulerStepper, rodas5p::Rodas5PStepper};
    check::<ImplicitEuler>();
    check::<Bdf>();
    check::<Rodas5P>();
    check::<Auto>();
    check::<ImplicitEulerStepper<Dyn>>();
    check::<BdfStepper<Dyn>>();
    check::<Rodas5PStepper<Dyn>>();
    check::<AutoStepper<Dyn>>();
    check::<SparseLu>();
}

/// `Auto` (DOPRI5 ↔ BDF on `h·‖J‖∞`, the norm taken from the sparse values on the sparse
/// path) makes the same switches at the same steps on both paths.
#[test]
fn auto_method_switches_alike_on_both_paths() {
    let sys = Bruss::new(100, Jac::Hand);
    let p = Problem::new(&sys, brusselator_y0(100), (0.0, 10.0));
    let o = Options::default().rtol(1e-5).atol(1e-5).save(Save::End).dense(false);
    let s = p
        .solve(
            reckon::methods::Auto::default(),
            &o.clone().linear_solver(LinearSolver::Sparse),
        )
        .unwrap();
    let d = p
        .solve(reckon::methods::Auto::default(), &o.linear_solver(LinearSolver::Dense))
        .unwrap();
    assert!(!s.switches.is_empty(), "BRUSS is stiff: Auto switches to BDF");
    assert_eq!(s.switches, d.switches);
    assert_eq!(s.stats.accepted, d.stats.accepted);
    let err = (s.last().1 - d.last().1).amax() / d.last().1.amax();
    assert!(err < 1e-10, "{err:e}");
}

/// `problems::brusselator` is HNW's BRUSS (ODE II §IV.1, (1.6′)): `x_i = i/(N+1)`,
/// α = 1/50 with the boundary values `u = 1, v = 3`; `brusselator_y0` is the reference
/// values' `u_i(0) = 1 + ½ sin(2πx_i)`, `v_i(0) = 3`, and `brusselator_y0_book` the
/// book's printed amplitude 1.
#[test]
fn brusselator_1d_setup_and_initial_values() {
    let n = 500;
    let (y0, book) = (brusselator_y0(n), brusselator_y0_book(n));
    let x = |i: usize| i as f64 / (n as f64 + 1.0);
    let s = |i: usize| (2.0 * std::f64::consts::PI * x(i)).sin();
    for i in [1usize, 125, 250, 500] {
        assert!((y0[2 * (i - 1)] - (1.0 + 0.5 * s(i))).abs() < 1e-15);
        assert!((book[2 * (i - 1)] - (1.0 + s(i))).abs() < 1e-15);
        assert_eq!((y0[2 * (i - 1) + 1], book[2 * (i - 1) + 1]), (3.0, 3.0));
    }
    // u₁₂₅ = 1 + ½·sin(2π·125/501), the grid point nearest x = ¼ (Python's math.sin)
    assert!((y0[2 * 124] - 1.499_997_542_440_987_3).abs() < 1e-15, "{}", y0[2 * 124]);
    let mut f = y0.clone();
    brusselator(n).rhs(0.0, &y0, &[], &mut f);
    let (u1, u2) = (y0[0], y0[2]);
    let alpha = 1.0 / 50.0 * (n as f64 + 1.0).powi(2);
    let expect = 1.0 + u1 * u1 * 3.0 - 4.0 * u1 + alpha * (1.0 - 2.0 * u1 + u2);
    // the diffusion terms (≈ 5 000 × 4) cancel to a small number: rounding is relative to them
    let scale = alpha * (1.0 + 2.0 * u1.abs() + u2.abs());
    assert!((f[0] - expect).abs() < 1e-14 * scale, "{} vs {expect}", f[0]);
}

/// The shipped traced `problems::brusselator` from `brusselator_y0` reaches scipy Radau's
/// end state ([`BRUSS_REF_10`]) at `t = 10`: on the sparse path (`Auto`: the compiled
/// J, faer's sparse LU) and the dense one (`LinearSolver::Dense`) alike, to well within
/// 100× the tolerance at `rtol = atol = 1e-8` (measured: 6e-8 to 8e-8), and Rodas5P to
/// 1e-9 at 1e-11. The book's amplitude is 0.16 away: a wrong initial value, coefficient
/// or boundary value fails this.
#[test]
fn brusselator_end_state_matches_scipy_radau() {
    let sys = brusselator(N);
    let p = Problem::new(&sys, brusselator_y0(N), (0.0, 10.0));
    let o = Options::default().rtol(1e-8).atol(1e-8).save(Save::End);
    for (name, sparse, dense) in [
        (
            "bdf",
            p.solve(Bdf::default(), &o).unwrap(),
            p.solve(Bdf::default(), &o.clone().linear_solver(LinearSolver::Dense))
                .unwrap(),
        ),
        (
            "rodas5p",
            p.solve(Rodas5P, &o).unwrap(),
            p.solve(Rodas5P, &o.clone().linear_solver(LinearSolver::Dense)).unwrap(),
        ),
    ] {
        assert_eq!(sparse.stats.accepted, dense.stats.accepted, "{name}: the same steps");
        near_reference(name, (sparse.last().1.clone(), dense.last().1.clone()), 1e-6);
    }
    let tight = p
        .solve(Rodas5P, &Options::default().rtol(1e-11).atol(1e-11).save(Save::End))
        .unwrap();
    let e = ref_error(tight.last().1);
    println!("rodas5p at 1e-11: {e:.3e}");
    assert!(e < 1e-9, "{e:e}");
    let book = Problem::new(&sys, brusselator_y0_book(N), (0.0, 10.0))
        .solve(Rodas5P, &o)
        .unwrap();
    assert!(ref_error(book.last().1) > 0.1, "the book's amplitude ends elsewhere");
}

/// A traced model compiles its sparse Jacobian once: later solves of the same size reuse
/// it (bit-for-bit the same answer), another size traces again.
#[test]
fn the_compiled_jacobian_is_traced_once_per_size() {
    // a diffusion chain x_i' = x_{i−1} − 2x_i + x_{i+1} − x_i³ (zero boundaries)
    let f = reckon::model!(|_, x: [S; Dyn]| {
        let n = x.len();
        DVector::from_fn(n, |i, _| {
            let l = if i == 0 { S::from(0.0) } else { x[i - 1].clone() };
            let r = if i + 1 == n { S::from(0.0) } else { x[i + 1].clone() };
            l + r - x[i].clone() * 2.0 - x[i].powi(3)
        })
    });
    let o = Options::default().rtol(1e-6).atol(1e-8).save(Save::End);
    let solve = |n: usize| {
        Problem::new(&f, DVector::from_fn(n, |i, _| (i as f64 * 0.1).sin()), (0.0, 1.0))
            .solve(Bdf::default(), &o)
            .unwrap()
    };
    assert_eq!(f.traces(), 0);
    let a = solve(100);
    assert_eq!(f.traces(), 1, "Auto took the sparse path and traced");
    let b = solve(100);
    assert_eq!(f.traces(), 1, "the second solve reused the compiled Jacobian");
    assert_eq!(a.last().1, b.last().1);
    let _ = solve(120);
    assert_eq!(f.traces(), 2, "another size traces again");
}

/// Issue 38: the public constructors refuse bad input with a typed error, not a panic.
#[test]
fn wrong_lengths_and_indices_are_typed_errors() {
    let e = Pattern::from_entries(3, &[(0, 0), (1, 3)]).unwrap_err();
    assert!(matches!(e, reckon::Error::InvalidInput { what: "pattern", .. }), "{e}");
    assert!(e.to_string().contains("(1, 3) is outside the 3 × 3 matrix"), "{e}");
    assert!(Pattern::from_entries(0, &[(0, 0)]).is_err());
    let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (1, 1)]).unwrap();
    let mut lu = SparseLu::new(&p).unwrap();
    for bad in [&[][..], &[1.0, 2.0], &[1.0, 2.0, 3.0, 4.0]] {
        let e = lu.factor(bad).unwrap_err();
        assert!(matches!(e, reckon::Error::InvalidInput { what: "values", .. }), "{e}");
        assert!(
            e.to_string()
                .contains(&format!("{} values for a pattern of 3 non-zeros", bad.len()))
        );
        assert!(!lu.is_factored());
    }
    // still usable after the refusals: [[2, 0], [1, 4]]·(1, 1) = (2, 5)
    assert_eq!(lu.factor(&[2.0, 1.0, 4.0]), Ok(true));
    let mut b = [2.0, 5.0];
    lu.solve_in_place(&mut b).unwrap();
    assert_eq!(b, [1.0, 1.0]);
}

/// Issue 38 item 10: the public sparse and dense linear-algebra entry points refuse a
/// right-hand side, a value buffer or an index that does not fit with a typed error,
/// never a panic, and stay usable after it.
#[test]
fn public_solves_and_evaluators_refuse_bad_lengths_with_typed_errors() {
    use reckon::linalg::{DynLu, Lu};
    let invalid = |e: &Error, what: &str| matches!(e, Error::InvalidInput { what: w, .. } if *w == what);
    // SparseLu: before a factorisation, then too short and too long
    let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (1, 1)]).unwrap();
    let mut lu = SparseLu::new(&p).unwrap();
    let mut b = [2.0, 5.0];
    let e = lu.solve_in_place(&mut b).unwrap_err();
    assert!(invalid(&e, "factorisation"), "{e}");
    assert_eq!(b, [2.0, 5.0]);
    assert_eq!(lu.factor(&[2.0, 1.0, 4.0]), Ok(true));
    for bad in [&mut [][..], &mut [1.0][..], &mut [1.0, 2.0, 3.0][..]] {
        let before = bad.to_vec();
        let e = lu.solve_in_place(bad).unwrap_err();
        assert!(invalid(&e, "rhs"), "{e}");
        assert!(
            e.to_string()
                .contains(&format!("{} entries for a 2 × 2 matrix", before.len())),
            "{e}"
        );
        assert_eq!(bad, &before[..]);
    }
    lu.solve_in_place(&mut b).unwrap();
    assert_eq!(b, [1.0, 1.0]);
    // the dense LU of dynamic size
    let d = DynLu::factor(&DMatrix::from_row_slice(2, 2, &[2.0, 0.0, 1.0, 4.0])).unwrap();
    let e = d.solve_in_place(&mut DVector::from_vec(vec![1.0; 3])).unwrap_err();
    assert!(invalid(&e, "rhs"), "{e}");
    let mut x = DVector::from_vec(vec![2.0, 5.0]);
    d.solve_in_place(&mut x).unwrap();
    assert_eq!(x.as_slice(), &[1.0, 1.0]);
    assert!(DynLu::factor(&DMatrix::zeros(2, 3)).is_none());
    // patterns: indices outside the matrix
    assert_eq!(p.position(2, 0), None);
    assert_eq!(p.position(0, 2), None);
    assert_eq!(p.position(usize::MAX, usize::MAX), None);
    assert!(invalid(&Pattern::dense(usize::MAX).unwrap_err(), "pattern"));
    assert!(invalid(&Pattern::from_entries(2, &[(0, 7)]).unwrap_err(), "pattern"));
    // evaluators: a value buffer that is not nnz long
    let g = |_t: f64, x: &DVector<DualDVec64>, _u: &[f64]| DVector::from_fn(2, |i, _| x[i].clone() * x[1 - i].clone());
    let mut coloured = Coloured::new(Pattern::dense(2).unwrap(), g);
    let e = coloured.eval(0.0, &[1.0, 2.0], &[], &mut [0.0; 3]).unwrap_err();
    assert!(invalid(&e, "values"), "{e}");
    let mut v = [0.0; 4];
    coloured.eval(0.0, &[1.0, 2.0], &[], &mut v).unwrap();
    assert_eq!(v, [2.0, 2.0, 1.0, 1.0]);
    let f = reckon::model!(|_, x: [S; 2]| nalgebra::vector![x[0] * x[1], x[1].sin()]);
    let mut compiled = reckon::symbolic::trace(&f, 2).unwrap().compile_jacobian();
    for mut c in [compiled.clone(), compiled.clone().interpreted()] {
        let e = c.eval(0.0, &[1.0, 2.0], &[], &mut [0.0; 9]).unwrap_err();
        assert!(invalid(&e, "values"), "{e}");
        let e = c.eval_dense(0.0, &[1.0, 2.0], &[], &mut [0.0; 3]).unwrap_err();
        assert!(invalid(&e, "jac"), "{e}");
    }
    let mut dense = [0.0; 4];
    compiled.eval_dense(0.0, &[1.0, 2.0], &[], &mut dense).unwrap();
    assert_eq!(dense, [2.0, 0.0, 1.0, 2.0f64.cos()]);
}

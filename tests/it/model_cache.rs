//! The compiled-program cache (`reckon::symbolic::cache`, issue 33 item 6) and the traces it
//! rests on (issue 38 item 10): a model rebuilt with the same structure neither traces nor
//! compiles and gives the same bits; another parameter value through the cache gives
//! num-dual's Jacobian for that value; a captured `Cell` is read afresh; parameterised
//! models trace; a body that names a plain-f64 `t` is refused.

use nalgebra::{DMatrix, DVector, Dyn, vector};
use reckon::jacobian::SparseJacobian;
use reckon::methods::{Bdf, Rodas5P};
use reckon::symbolic::TraceCounts;
use reckon::{Error, Options, Problem, System, model, symbolic};
use reckon::{LinearSolver, Save};
use std::cell::Cell;

fn counts(records: usize, traces: usize, compiles: usize) -> TraceCounts {
    TraceCounts {
        records,
        traces,
        compiles,
    }
}

/// `J` from the sparse evaluator, as a dense matrix.
fn sparse_dense(jac: &mut dyn SparseJacobian, t: f64, x: &[f64]) -> DMatrix<f64> {
    let p = jac.pattern().clone();
    let mut v = vec![0.0; p.nnz()];
    jac.eval(t, x, &[], &mut v).unwrap();
    let mut m = DMatrix::zeros(p.n(), p.n());
    for (k, (i, j)) in p.entries().enumerate() {
        m[(i, j)] = v[k];
    }
    m
}

/// `J` from num-dual.
fn dual_dense<S: System<Dyn>>(f: &S, t: f64, x: &DVector<f64>) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(x.len(), x.len());
    f.jacobian(t, x, &[], &mut j);
    j
}

/// The largest `|a − b| / max(|b|, 1e-300)` over the entries.
fn max_rel(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    a.iter()
        .zip(b.iter())
        .map(|(x, y)| {
            if x == y {
                0.0
            } else {
                (x - y).abs() / y.abs().max(1e-300)
            }
        })
        .fold(0.0, f64::max)
}

/// A reaction–diffusion chain `x_i' = d(x_{i−1} − 2x_i + x_{i+1}) − k·x_i³ + s` with the
/// coefficients captured as plain `f64`s (folded into the trace as constants).
fn chain(d: f64, k: f64, s: f64) -> impl System<Dyn> {
    model!(|_, x: [S; Dyn]| {
        let n = x.len();
        DVector::from_fn(n, |i, _| {
            let l = if i == 0 { S::from(0.0) } else { x[i - 1].clone() };
            let r = if i + 1 == n { S::from(0.0) } else { x[i + 1].clone() };
            (l + r - x[i].clone() * 2.0) * d - x[i].powi(3) * k + s
        })
    })
}

#[test]
fn a_rebuilt_model_neither_traces_nor_compiles_and_gives_the_same_bits() {
    // coefficients no other test uses: the first build finds nothing in the cache
    let (d, k, s) = (0.731_215_9, 1.414_007_3, 0.012_345_9);
    let n = 120;
    let x0 = DVector::from_fn(n, |i, _| (i as f64 * 0.1).sin());
    let o = Options::default()
        .rtol(1e-6)
        .atol(1e-8)
        .save(Save::End)
        .linear_solver(LinearSolver::Sparse);
    let first = chain(d, k, s);
    let a = Problem::new(&first, x0.clone(), (0.0, 1.0))
        .solve(Bdf::default(), &o)
        .unwrap();
    assert_eq!(first.trace_counts().records, 1);
    assert_eq!(first.trace_counts().traces, 1, "the first build traces");
    // the second build: recorded (the key) but not differentiated nor compiled
    let second = chain(d, k, s);
    let b = Problem::new(&second, x0.clone(), (0.0, 1.0))
        .solve(Bdf::default(), &o)
        .unwrap();
    assert_eq!(second.trace_counts(), counts(1, 0, 0));
    assert_eq!(a.last().1, b.last().1, "bit for bit the first build's answer");
    assert_eq!(a.stats, b.stats);
    // and its Jacobian bit for bit the first's, and num-dual's to rounding
    let x = DVector::from_fn(n, |i, _| 0.3 + 0.01 * i as f64);
    let ja = sparse_dense(&mut *first.sparse_jacobian(n).unwrap(), 0.0, x.as_slice());
    let jb = sparse_dense(&mut *second.sparse_jacobian(n).unwrap(), 0.0, x.as_slice());
    assert_eq!(ja, jb);
    assert!(max_rel(&jb, &dual_dense(&second, 0.0, &x)) <= 1e-14);
    // a kept model solved again does not trace either
    let c = Problem::new(&first, x0, (0.0, 1.0)).solve(Bdf::default(), &o).unwrap();
    assert_eq!((first.trace_counts().records, first.trace_counts().traces), (3, 1));
    assert_eq!(a.last().1, c.last().1);
}

#[test]
fn another_captured_value_traces_again_but_reuses_the_machine_code() {
    // same shape, other constants: a new graph (differentiated again, the right values)
    // whose program has the first's shape, so no Cranelift compile (values that fold alike:
    // no power of two, no value that coincides with another constant)
    let n = 90;
    let first = chain(0.731, 1.37, 0.113);
    let _ = first.sparse_jacobian(n).unwrap();
    let other = chain(0.913, 2.71, 0.379);
    let mut j = other.sparse_jacobian(n).unwrap();
    assert_eq!(other.trace_counts(), counts(1, 1, 0));
    let x = DVector::from_fn(n, |i, _| 1.0 - 0.004 * i as f64);
    let got = sparse_dense(&mut *j, 0.0, x.as_slice());
    assert!(max_rel(&got, &dual_dense(&other, 0.0, &x)) <= 1e-14);
    assert!((got[(0, 0)] - (-2.0 * 0.913 - 3.0 * 2.71 * x[0] * x[0])).abs() < 1e-14);
    assert_eq!(got[(1, 0)], 0.913);
    // a value that folds otherwise (k = 2: 2·(3·x²) becomes 6·x²) is another shape, compiled
    let folded = chain(0.913, 2.0, 0.379);
    let _ = folded.sparse_jacobian(n).unwrap();
    assert_eq!(folded.trace_counts().traces, 1);
}

/// The Brusselator with its coefficients `A`, `B`, `α` as a parameter block.
fn bruss_params(p: [f64; 3]) -> impl reckon::DualSystem<Dyn> {
    model!(|_, y: [S; Dyn], p: [S; 3] = p| {
        let n = y.len() / 2;
        let c = p[2].clone() * ((n as f64 + 1.0) * (n as f64 + 1.0));
        DVector::from_fn(2 * n, |k, _| {
            let i = k / 2;
            let own = k % 2;
            let bc = if own == 0 { p[0].clone() } else { p[1].clone() / p[0].clone() };
            let at = |j: usize| y[2 * j + own].clone();
            let left = if i == 0 { bc.clone() } else { at(i - 1) };
            let right = if i + 1 == n { bc } else { at(i + 1) };
            let (u, v) = (y[2 * i].clone(), y[2 * i + 1].clone());
            let diff = (left + right - at(i) * 2.0) * c.clone();
            let uuv = u.clone() * u.clone() * v;
            if own == 0 {
                uuv - u.clone() * (p[1].clone() + 1.0) + p[0].clone() + diff
            } else {
                u * p[1].clone() - uuv + diff
            }
        })
    })
}

#[test]
fn another_parameter_value_through_the_cache_gives_num_duals_jacobian() {
    let n = 40; // 80 states
    let y = DVector::from_fn(2 * n, |k, _| 1.0 + 0.5 * ((k as f64) * 0.37).sin());
    let first = bruss_params([1.0, 3.0, 0.02]);
    let _ = first.sparse_jacobian(2 * n).unwrap();
    for p in [[1.5, 2.5, 0.03], [0.7, 4.25, 0.011], [2.0, 3.0, 1e-5]] {
        let g = bruss_params(p);
        let mut j = g.sparse_jacobian(2 * n).unwrap();
        assert_eq!(g.trace_counts(), counts(1, 0, 0), "p = {p:?}");
        let got = sparse_dense(&mut *j, 0.0, y.as_slice());
        let want = dual_dense(&g, 0.0, &y);
        let e = max_rel(&got, &want);
        assert!(e <= 1e-14, "p = {p:?}: {e:e}");
        // ∂u₀'/∂u₀ = 2u₀v₀ − (B + 1) − 2α(n+1)² exactly as num-dual computes it
        assert_eq!(got[(0, 0)], want[(0, 0)]);
        assert!((got[(0, 0)] - (2.0 * y[0] * y[1] - (p[1] + 1.0) - 2.0 * p[2] * 41.0 * 41.0)).abs() < 1e-12);
    }
}

#[test]
fn set_params_between_solves_reaches_the_compiled_jacobian() {
    let mut f = model!(|_, x: [S; Dyn], p: [S; 1] = [1.0]| {
        DVector::from_fn(x.len(), |i, _| -(p[0].clone() * x[i].clone()) * x[i].clone())
    });
    let x0 = DVector::from_element(70, 1.0);
    let o = Options::default().save(Save::End).linear_solver(LinearSolver::Sparse);
    for k in [1.0, 4.0] {
        f.set_params(&[k]).unwrap();
        let s = Problem::new(&f, x0.clone(), (0.0, 1.0))
            .solve(Bdf::default(), &o)
            .unwrap();
        // x' = −k x², x(0) = 1: x(1) = 1/(1 + k)
        assert!(
            (s.last().1[0] - 1.0 / (1.0 + k)).abs() < 1e-4,
            "k = {k}: {}",
            s.last().1[0]
        );
        let mut j = f.sparse_jacobian(70).unwrap();
        let got = sparse_dense(&mut *j, 0.0, &[0.5; 70]);
        assert_eq!(got[(3, 3)], -2.0 * k * 0.5);
    }
    assert_eq!(f.trace_counts().traces, 1, "one trace serves both parameter values");
}

#[test]
fn a_captured_cell_is_read_afresh_never_stale() {
    // issue 38: J[0,0] must follow the Cell, not keep its value at the first trace
    let k = Cell::new(3.0);
    let kr = &k;
    let f = model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].clone() * -kr.get() - x[i].powi(2) * 0.005));
    let n = 80;
    let x = DVector::from_element(n, 1.0);
    let j1 = sparse_dense(&mut *f.sparse_jacobian(n).unwrap(), 0.0, x.as_slice());
    assert!((j1[(0, 0)] + 3.01).abs() < 1e-14, "{}", j1[(0, 0)]);
    let compiled = f.trace_counts().compiles;
    k.set(3000.0);
    let j2 = sparse_dense(&mut *f.sparse_jacobian(n).unwrap(), 0.0, x.as_slice());
    let want = dual_dense(&f, 0.0, &x);
    assert!((want[(0, 0)] + 3000.01).abs() < 1e-11, "{}", want[(0, 0)]);
    assert!((j2[(0, 0)] + 3000.01).abs() < 1e-11, "stale: {}", j2[(0, 0)]);
    assert!(max_rel(&j2, &want) <= 1e-14);
    assert_eq!(
        f.trace_counts().traces,
        2,
        "the changed value is a new graph: traced again"
    );
    assert_eq!(
        f.trace_counts().compiles,
        compiled,
        "its program has the first's shape: no new compile"
    );
    // and a stiff solve after the change uses the fresh Jacobian: as many steps as a model
    // built with 3000 from the start
    let o = Options::default().rtol(1e-6).atol(1e-9).save(Save::End);
    let x0 = DVector::from_element(n, 1.0);
    let changed = Problem::new(&f, x0.clone(), (0.0, 1.0)).solve(Rodas5P, &o).unwrap();
    let fresh_k = Cell::new(3000.0);
    let fr = &fresh_k;
    let fresh =
        model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].clone() * -fr.get() - x[i].powi(2) * 0.005));
    let reference = Problem::new(&fresh, x0, (0.0, 1.0)).solve(Rodas5P, &o).unwrap();
    assert_eq!(changed.stats.accepted, reference.stats.accepted);
    assert_eq!(changed.last().1, reference.last().1);
}

#[test]
fn a_parameterised_model_traces_and_gets_the_compiled_sparse_jacobian() {
    let f = model!(|_, x: [S; 2], p: [S; 2] = [2.0, 0.5]| vector![
        -(p[0] * x[0]) + x[1] * p[1],
        x[0] * x[1] * p[1]
    ]);
    let tr = symbolic::trace(&f, 2).unwrap();
    assert_eq!(tr.params(), &[2.0, 0.5]);
    assert_eq!(
        tr.jacobian_text(),
        "∂ẋ₀/∂x₀ = −p₀\n∂ẋ₀/∂x₁ = p₁\n∂ẋ₁/∂x₀ = x₁·p₁\n∂ẋ₁/∂x₁ = x₀·p₁\n"
    );
    assert!(tr.rust().contains("pub const P: [f64; 2] = [2.0, 0.5];"));
    let mut j = f.sparse_jacobian(2).unwrap();
    let mut v = vec![0.0; 4];
    j.eval(0.0, &[3.0, 4.0], &[], &mut v).unwrap();
    // CSC: (0,0), (1,0), (0,1), (1,1)
    assert_eq!(v, vec![-2.0, 4.0 * 0.5, 0.5, 3.0 * 0.5]);
    // a Dyn model with a parameter block takes the sparse path in a solve
    let g = model!(|_, x: [S; Dyn], p: [S; 1] = [0.25]| DVector::from_fn(x.len(), |i, _| {
        -(p[0].clone() * x[i].clone())
    }));
    let s = Problem::new(&g, DVector::from_element(100, 1.0), (0.0, 2.0))
        .solve(Bdf::default(), &Options::default().save(Save::End))
        .unwrap();
    assert!(g.trace_counts().records >= 1, "Auto asked for the sparse Jacobian");
    assert!((s.last().1[0] - (-0.5f64).exp()).abs() < 1e-5);
}

/// The plain-`t` branches issue 38 lists: each gives the same answer at `t = ±∞` and was
/// traced with one branch; now each is refused, and the model still solves with num-dual.
#[test]
fn a_body_that_names_a_plain_t_is_refused() {
    fn refused<S: System<nalgebra::Const<1>>>(f: &S, case: &str) {
        match symbolic::trace(f, 1) {
            Err(Error::Untraceable { reason, .. }) => assert!(reason.contains("reads its time"), "{case}: {reason}"),
            other => panic!("{case}: expected Untraceable, got {other:?}"),
        }
        assert!(f.sparse_jacobian(1).is_none(), "{case}");
        let mut j = nalgebra::Matrix1::zeros();
        f.jacobian(0.5, &vector![1.0], &[], &mut j);
        assert_eq!(j[(0, 0)], -100.0, "{case}: num-dual at t = 0.5");
    }
    let window = model!(|t, x: [S; 1]| vector![if t > 0.0 && t < 5.0 { x[0] * -100.0 } else { -x[0] }]);
    refused(&window, "t > 0 && t < 5");
    let abs = model!(|t, x: [S; 1]| vector![if t.abs() < 5.0 { x[0] * -100.0 } else { -x[0] }]);
    refused(&abs, "|t| < 5");
    let finite = model!(|t, x: [S; 1]| vector![if t.is_finite() { x[0] * -100.0 } else { -x[0] }]);
    refused(&finite, "t finite");
    let periodic = model!(|t, x: [S; 1]| vector![if t % 2.0 < 1.0 { x[0] * -100.0 } else { -x[0] }]);
    refused(&periodic, "t mod 2 < 1");
    // a time named otherwise, and in a nested macro call, is found too
    let named = model!(|time, x: [S; 1]| vector![if time < 5.0 { x[0] * -100.0 } else { -x[0] }]);
    refused(&named, "time < 5");
    // with a parameter block as well
    let with_p = model!(|t, x: [S; 1], p: [S; 1] = [100.0]| vector![if t < 5.0 { -(p[0] * x[0]) } else { -x[0] }]);
    assert!(matches!(symbolic::trace(&with_p, 1), Err(Error::Untraceable { .. })));
    // a Dyn body falls back to num-dual's coloured sparse Jacobian: −100 at t = 1
    let dynamic = model!(
        |t, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| if t > 0.0 && t < 5.0 {
            x[i].clone() * -100.0
        } else {
            -x[i].clone()
        })
    );
    let j = sparse_dense(&mut *dynamic.sparse_jacobian(70).unwrap(), 1.0, &[1.0; 70]);
    assert_eq!(j[(5, 5)], -100.0);
    assert_eq!(dynamic.trace_counts().records, 0, "refused before it is recorded");
    // a plain time the body never names is no obstacle, nor is `_`
    let unused = model!(|_t, x: [S; 1]| vector![-x[0]]);
    assert_eq!(symbolic::trace(&unused, 1).unwrap().jacobian_text(), "∂ẋ₀/∂x₀ = −1\n");
}

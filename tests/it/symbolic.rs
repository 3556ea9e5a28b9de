//! Symbolic Jacobians traced from the same `model!` bodies: equal to num-dual's for every
//! model and problem in the crate and for random expression bodies; printed forms pinned;
//! sparsity patterns exact; untraceable bodies refused with the typed error.

use nalgebra::{DMatrix, DVector, OMatrix, SVector, vector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng, rngs::StdRng};
use reckon::jacobian::{Pattern, SparseJacobian};
use reckon::num_dual::DualNum;
use reckon::studies::problems::*;
use reckon::vehicles::{bicycle, body3d, carlike, unicycle};
use reckon::{Error, System, model, symbolic};

/// `max |a − b| ≤ tol·max(|b|, tiny)` over the matrix.
fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol * scale)
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The compiled symbolic Jacobian against num-dual's at `points` random states.
fn check_fixed<const N: usize>(name: &str, f: &impl System<nalgebra::Const<N>>, inputs: usize, seed: u64)
where
    nalgebra::Const<N>: nalgebra::DimMin<nalgebra::Const<N>>,
{
    let tr = symbolic::trace(f, N).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut compiled = tr.compile_jacobian();
    assert_eq!(compiled.is_native(), cfg!(feature = "jit"), "{name}");
    let mut interpreted = compiled.clone().interpreted();
    assert!(!interpreted.is_native());
    let mut rng = StdRng::seed_from_u64(seed);
    for _ in 0..20 {
        let x = SVector::<f64, N>::from_fn(|_, _| rng.random_range(0.1..1.5));
        let u: Vec<f64> = (0..inputs).map(|_| rng.random_range(-1.0..1.0)).collect();
        let t = rng.random_range(0.0..3.0);
        let mut jd = OMatrix::<f64, nalgebra::Const<N>, nalgebra::Const<N>>::zeros();
        f.jacobian(t, &x, &u, &mut jd);
        let mut js = vec![f64::NAN; N * N];
        compiled.eval_dense(t, x.as_slice(), &u, &mut js).unwrap();
        assert!(
            close(&js, jd.as_slice(), 1e-14),
            "{name} at x = {x:?}, u = {u:?}:\nsymbolic {js:?}\nnum-dual {jd}"
        );
        // native code and the interpreter agree bit for bit
        let mut ji = vec![f64::NAN; N * N];
        interpreted.eval_dense(t, x.as_slice(), &u, &mut ji).unwrap();
        assert_eq!(bits(&js), bits(&ji), "{name}: native and interpreted differ");
        // and through the sparse interface
        let mut v = vec![0.0; compiled.pattern().nnz()];
        compiled.eval(t, x.as_slice(), &u, &mut v).unwrap();
        let mut vi = vec![0.0; v.len()];
        interpreted.eval(t, x.as_slice(), &u, &mut vi).unwrap();
        assert_eq!(bits(&v), bits(&vi), "{name}: native and interpreted CSC values differ");
        for ((i, j), val) in compiled.pattern().entries().zip(&v) {
            assert_eq!(
                *val,
                js[i + N * j],
                "{name}: sparse and dense values differ at ({i}, {j})"
            );
        }
    }
}

#[test]
fn every_model_and_problem_matches_num_dual() {
    check_fixed("unicycle", &unicycle::model(), 2, 1);
    check_fixed("bicycle", &bicycle::model(0.5), 2, 2);
    check_fixed("carlike", &carlike::model(2.5), 2, 3);
    check_fixed("body3d", &body3d::model(), 6, 4);
    check_fixed("imu 2-D", &reckon::reckoning::imu::model_2d(), 3, 5);
    check_fixed("rotation–decay", &rotation_decay(), 0, 6);
    check_fixed("sin u", &sin_u(), 0, 7);
    check_fixed("stiff cosine", &stiff_cosine(), 0, 8);
    check_fixed("Arenstorf", &arenstorf(), 0, 9);
    check_fixed("Van der Pol", &van_der_pol(1000.0), 0, 10);
    check_fixed("Robertson", &robertson(), 0, 11);
    check_fixed("OREGO", &orego(), 0, 12);
    check_fixed("HIRES", &hires(), 0, 13);
    check_fixed("Lorenz", &lorenz(), 0, 14);
}

#[test]
fn brusselator_matches_num_dual_and_is_pentadiagonal() {
    let n = 50;
    let f = brusselator(n);
    let tr = symbolic::trace(&f, 2 * n).unwrap();
    let mut compiled = tr.compile_jacobian();
    let mut rng = StdRng::seed_from_u64(21);
    let x = DVector::from_fn(2 * n, |_, _| rng.random_range(0.5..3.5));
    let mut jd = DMatrix::zeros(2 * n, 2 * n);
    f.jacobian(0.0, &x, &[], &mut jd);
    let mut js = vec![0.0; 4 * n * n];
    compiled.eval_dense(0.0, x.as_slice(), &[], &mut js).unwrap();
    assert!(close(&js, jd.as_slice(), 1e-14));
    // 100 states: native code writes the CSC values, which are scattered into the matrix
    let mut ji = vec![0.0; 4 * n * n];
    compiled
        .clone()
        .interpreted()
        .eval_dense(0.0, x.as_slice(), &[], &mut ji)
        .unwrap();
    assert_eq!(bits(&js), bits(&ji));
    // u_i couples to u_{i−1}, u_i, v_i, u_{i+1}; v_i to v_{i−1}, u_i, v_i, v_{i+1}
    let mut e = Vec::new();
    for i in 0..n {
        let (u, v) = (2 * i, 2 * i + 1);
        e.extend([(u, u), (u, v), (v, u), (v, v)]);
        if i > 0 {
            e.extend([(u, u - 2), (v, v - 2)]);
        }
        if i + 1 < n {
            e.extend([(u, u + 2), (v, v + 2)]);
        }
    }
    assert_eq!(tr.pattern(), Pattern::from_entries(2 * n, &e).unwrap());
    // at 500 points: the 3 996 non-zeros of the published count
    assert_eq!(symbolic::trace(&brusselator(500), 1000).unwrap().pattern().nnz(), 3996);
}

#[test]
fn unicycle_and_bicycle_print_their_hand_derivations() {
    let u = symbolic::trace(&unicycle::model(), 3)
        .unwrap()
        .with_names(&["x", "y", "θ"], &["v", "ω"]);
    assert_eq!(u.jacobian_text(), "∂ẋ/∂θ = −v·sin(θ)\n∂ẏ/∂θ = v·cos(θ)\n");
    assert_eq!(
        u.text(),
        "ẋ = v·cos(θ)\nẏ = v·sin(θ)\nθ̇ = ω\n\
         ∂ẋ/∂θ = −v·sin(θ)\n∂ẏ/∂θ = v·cos(θ)\n\
         ∂ẋ/∂v = cos(θ)\n∂ẏ/∂v = sin(θ)\n∂θ̇/∂ω = 1\n"
    );
    assert_eq!(
        u.latex(),
        "\\begin{aligned}\n\
         \\frac{d}{dt} \\begin{pmatrix}\nx \\\\\ny \\\\\n\\theta\n\\end{pmatrix} &= \\begin{pmatrix}\n\
         v \\, \\cos \\theta \\\\\nv \\, \\sin \\theta \\\\\n\\omega\n\\end{pmatrix} \\\\\n\
         \\frac{\\partial f}{\\partial x} &= \\begin{pmatrix}\n\
         0 & 0 & -v \\, \\sin \\theta \\\\\n0 & 0 & v \\, \\cos \\theta \\\\\n0 & 0 & 0\n\\end{pmatrix} \\\\\n\
         \\frac{\\partial f}{\\partial u} &= \\begin{pmatrix}\n\
         \\cos \\theta & 0 \\\\\n\\sin \\theta & 0 \\\\\n0 & 1\n\\end{pmatrix}\n\\end{aligned}"
    );
    // default names
    let d = symbolic::trace(&unicycle::model(), 3).unwrap();
    assert_eq!(d.jacobian_text(), "∂ẋ₀/∂x₂ = −u₀·sin(x₂)\n∂ẋ₁/∂x₂ = u₀·cos(x₂)\n");

    let b = symbolic::trace(&bicycle::model(0.5), 3)
        .unwrap()
        .with_names(&["x", "y", "θ"], &["v", "α"]);
    assert_eq!(b.jacobian_text(), "∂ẋ/∂θ = −v·sin(θ)\n∂ẏ/∂θ = v·cos(θ)\n");
    // θ' = v·tan α / L: the inputs' Jacobian has the steering derivative (1 + tan²α)·v/L
    let du: Vec<String> = b.input_jacobian().map(|(i, k, e)| format!("{i}{k}: {e}")).collect();
    assert_eq!(
        du,
        ["00: cos(θ)", "10: sin(θ)", "20: 2·tan(α)", "21: 2·v·(tan(α)² + 1)"]
    );
}

#[test]
fn mathml_is_well_formed_and_names_the_entries() {
    let u = symbolic::trace(&unicycle::model(), 3)
        .unwrap()
        .with_names(&["x", "y", "θ"], &["v", "ω"]);
    let m = u.mathml();
    let doc = roxmltree::Document::parse(&m).expect("well-formed XML");
    assert_eq!(doc.root_element().tag_name().name(), "math");
    // one equation per part (f, ∂f/∂x, ∂f/∂u), then the matrices: states and f (3 × 1),
    // ∂f/∂x (3 × 3), ∂f/∂u (3 × 2)
    let tables: Vec<_> = doc.descendants().filter(|n| n.has_tag_name("mtable")).collect();
    let shape = |t: &roxmltree::Node| {
        let rows: Vec<_> = t.children().filter(|n| n.has_tag_name("mtr")).collect();
        (rows.len(), rows[0].children().filter(|n| n.has_tag_name("mtd")).count())
    };
    let shapes: Vec<(usize, usize)> = tables.iter().map(shape).collect();
    assert_eq!(shapes, [(3, 1), (3, 1), (3, 1), (3, 3), (3, 2)]);
    assert!(m.contains("<mi>θ</mi>") && m.contains("<mi>sin</mi>") && m.contains("<mi>v</mi>"));
    // every matrix's fences stretch, and the element names a math font for them
    let fences: Vec<_> = doc
        .descendants()
        .filter(|n| n.has_tag_name("mo") && matches!(n.text(), Some("(") | Some(")")))
        .collect();
    assert!(fences.len() >= 8);
    assert!(fences.iter().all(|f| f.attribute("stretchy") == Some("true")));
    let style = doc.root_element().attribute("style").unwrap();
    assert!(
        style.contains("'STIX Two Math'") && style.contains("'DejaVu Math TeX Gyre'"),
        "{style}"
    );
}

/// `text`, `latex` and `mathml` print the same parts: every entry of `f`, `∂f/∂x`,
/// `∂f/∂u` and `∂f/∂t` that the text has is in the other two.
#[test]
fn text_latex_and_mathml_print_the_same_parts() {
    let tm = model!(|t: S, x: [S; 2], u: [1]| vector![x[1] * t, -x[0] * u[0]]);
    let traced = [
        symbolic::trace(&unicycle::model(), 3)
            .unwrap()
            .with_names(&["x", "y", "θ"], &["v", "ω"]),
        symbolic::trace(&bicycle::model(0.5), 3).unwrap(),
        symbolic::trace(&body3d::model(), 3).unwrap(),
        symbolic::trace(&tm, 2).unwrap(),
    ];
    for tr in &traced {
        let (text, latex, mathml) = (tr.text(), tr.latex(), tr.mathml());
        let mut entries: Vec<symbolic::Expr<'_>> = (0..tr.n()).map(|i| tr.rhs(i)).collect();
        entries.extend(tr.jacobian().map(|e| e.2));
        entries.extend(tr.input_jacobian().map(|e| e.2));
        entries.extend(tr.time_derivative().map(|e| e.1));
        assert_eq!(text.lines().count(), entries.len());
        for e in entries {
            assert!(text.contains(&e.to_string()), "{e} not in the text");
            assert!(latex.contains(&e.latex()), "{} not in\n{latex}", e.latex());
            assert!(mathml.contains(&e.mathml()), "{} not in\n{mathml}", e.mathml());
        }
        assert_eq!(latex.contains("\\partial u"), tr.inputs() > 0);
        assert_eq!(latex.contains("\\partial t"), tr.time_derivative().next().is_some());
        assert_eq!(
            mathml.contains("<mo>∂</mo><mi>t</mi>"),
            tr.time_derivative().next().is_some()
        );
    }
}

/// Products print in a normal form for a reader: numeric factors folded into one leading
/// coefficient, states before inputs before the rest, repeated factors as powers.
#[test]
fn products_print_normalised() {
    let vdp = symbolic::trace(&van_der_pol(1000.0), 2).unwrap();
    let t = vdp.text();
    assert!(t.contains("∂ẋ₁/∂x₀ = −1 − 2000·x₀·x₁\n"), "{t}");
    assert!(t.contains("ẋ₁ = 1000·x₁·(1 − x₀²) − x₀\n"), "{t}");
    let rob = symbolic::trace(&robertson(), 3).unwrap().text();
    assert!(rob.contains("ẋ₂ = 30000000·x₁²\n"), "{rob}");
    assert!(rob.contains("∂ẋ₁/∂x₁ = −60000000·x₁ − 10000·x₂\n"), "{rob}");
    // a negative term of a sum is subtracted, in every format
    let orego = symbolic::trace(&orego(), 3).unwrap();
    assert!(!orego.text().contains("+ −"), "{}", orego.text());
    assert!(!orego.latex().contains("+ -"), "{}", orego.latex());
    let f = model!(|_t, x: [S; 2]| vector![x[1] * 3.0 * x[0] * (-2.0), -(x[0] * x[0] * x[1])]);
    let tr = symbolic::trace(&f, 2).unwrap();
    assert_eq!(tr.rhs(0).to_string(), "−6·x₀·x₁");
    assert_eq!(tr.rhs(1).to_string(), "−x₀²·x₁");
    assert_eq!(tr.rhs(0).latex(), "-6 \\, x_{0} \\, x_{1}");
    // and the values are the model's
    assert_eq!(tr.rhs(0).eval(0.0, &[1.5, 2.0], &[]), -18.0);
}

mod generated {
    include!("generated/unicycle.rs");
}

#[test]
fn rust_source_is_the_checked_in_file_and_evaluates_to_the_same_matrix() {
    let tr = symbolic::trace(&unicycle::model(), 3).unwrap();
    assert_eq!(
        tr.rust(),
        include_str!("generated/unicycle.rs"),
        "regenerate tests/it/generated/unicycle.rs"
    );
    let (x, u) = ([1.0, 2.0, 0.7], [1.3, 0.4]);
    let mut jac = [0.0; 9];
    generated::jacobian(0.0, &x, &u, &mut jac);
    let mut want = [f64::NAN; 9];
    tr.compile_jacobian().eval_dense(0.0, &x, &u, &mut want).unwrap();
    assert_eq!(jac, want);
    let mut dx = [0.0; 3];
    generated::rhs(0.0, &x, &u, &mut dx);
    let mut f = vector![0.0, 0.0, 0.0];
    unicycle::model().rhs(0.0, &vector![1.0, 2.0, 0.7], &u, &mut f);
    assert_eq!(dx, [f[0], f[1], f[2]]);
}

#[test]
fn time_derivative_is_symbolic_for_a_typed_time() {
    let tr = symbolic::trace(&stiff_cosine(), 1).unwrap();
    let dt: Vec<String> = tr.time_derivative().map(|(_, e)| e.to_string()).collect();
    assert_eq!(dt, ["−1000·sin(t) − cos(t)"]);
    let (_, e) = tr.time_derivative().next().unwrap();
    let t: f64 = 0.3;
    assert!((e.eval(t, &[0.2], &[]) - (-1000.0 * t.sin() - t.cos())).abs() < 1e-12);
}

#[test]
fn state_dependent_branch_is_the_typed_error_naming_the_model() {
    fn saturating() -> impl System<nalgebra::Const<1>> {
        model!(|_, x: [S; 1]| vector![if x[0] > S::from(1.0) {
            S::from(1.0)
        } else {
            x[0].clone()
        }])
    }
    match symbolic::trace(&saturating(), 1) {
        Err(Error::Untraceable { model, reason }) => {
            assert!(model.ends_with("saturating"), "{model}");
            assert!(reason.contains("comparison"), "{reason}");
        }
        other => panic!("expected Untraceable, got {other:?}"),
    }
    // it still integrates, with num-dual's Jacobian
    let mut j = nalgebra::Matrix1::zeros();
    saturating().jacobian(0.0, &vector![0.5], &[], &mut j);
    assert_eq!(j[(0, 0)], 1.0);
    assert!(saturating().sparse_jacobian(1).is_none());
    // a plain-f64 time the body computes with, or branches on, is refused too
    let plain = model!(|t, x: [S; 1]| vector![x[0] * t]);
    assert!(matches!(symbolic::trace(&plain, 1), Err(Error::Untraceable { .. })));
    let switched = model!(|t, x: [S; 1]| vector![if t > 1.0 { x[0].clone() * 2.0 } else { x[0].clone() }]);
    match symbolic::trace(&switched, 1) {
        Err(Error::Untraceable { reason, .. }) => assert!(reason.contains("reads its time"), "{reason}"),
        other => panic!("expected Untraceable, got {other:?}"),
    }
    // a plain time the body never reads is no obstacle
    let unused = model!(|_t, x: [S; 1]| vector![-x[0].clone()]);
    assert_eq!(symbolic::trace(&unused, 1).unwrap().jacobian_text(), "∂ẋ₀/∂x₀ = −1\n");
    // a hand-written System has nothing to trace
    struct Hand;
    impl System<nalgebra::Const<1>> for Hand {
        fn rhs(&self, _: f64, x: &SVector<f64, 1>, _: &[f64], dx: &mut SVector<f64, 1>) {
            *dx = -x;
        }
        fn jacobian(&self, _: f64, _: &SVector<f64, 1>, _: &[f64], j: &mut nalgebra::Matrix1<f64>) {
            j[(0, 0)] = -1.0;
        }
    }
    assert!(matches!(symbolic::trace(&Hand, 1), Err(Error::Untraceable { .. })));
}

/// A random expression over three variables, evaluated at any scalar: the body of a
/// `model!` whose every operation is traced.
#[derive(Debug, Clone)]
enum E {
    X(usize),
    C(f64),
    Add(Box<E>, Box<E>),
    Sub(Box<E>, Box<E>),
    Mul(Box<E>, Box<E>),
    /// `a / (1 + b²)`: a quotient with no pole
    Div(Box<E>, Box<E>),
    F(u8, Box<E>),
    Powi(Box<E>, i32),
    Atan2(Box<E>, Box<E>),
}

fn eval<S: DualNum<Primitive = f64>>(e: &E, x: &[S]) -> S {
    match e {
        E::X(i) => x[*i].clone(),
        E::C(c) => S::from(*c),
        E::Add(a, b) => eval(a, x) + eval(b, x),
        E::Sub(a, b) => eval(a, x) - eval(b, x),
        E::Mul(a, b) => eval(a, x) * eval(b, x),
        E::Div(a, b) => eval(a, x) / (eval(b, x).powi(2) + 1.0),
        E::Powi(a, n) => eval(a, x).powi(*n),
        E::Atan2(a, b) => eval(a, x).atan2(eval(b, x)),
        E::F(k, a) => {
            let a = eval(a, x);
            // each function on an argument inside its domain and away from where it is
            // ill-conditioned (asin, acos at ±1: `1 − t²` cancels in any evaluation order;
            // ln_1p(tanh a) at a ≈ −5: `1 + tanh a` cancels, seen 2.8e-12 apart, hence ½·tanh)
            match k % 16 {
                0 => a.sin(),
                1 => a.cos(),
                2 => a.tanh().tan(),
                3 => (a.tanh() * 0.5).exp(),
                4 => (a.powi(2) + 1.0).ln(),
                5 => (a.powi(2) + 0.5).sqrt(),
                6 => a.cbrt(),
                7 => a.abs(),
                8 => (a.tanh() * 0.9).asin(),
                9 => (a.tanh() * 0.9).acos(),
                10 => a.atan(),
                11 => a.tanh().sinh(),
                12 => a.tanh().cosh(),
                13 => (a.powi(2) + 1.0).acosh() + a.asinh(),
                14 => (a.tanh() * 0.9).atanh(),
                _ => a.tanh().exp_m1() + (a.tanh() * 0.5).ln_1p() + a.powi(2).powf(0.75),
            }
        }
    }
}

/// Whether some `atan2(a, b)` in `e` is evaluated at a zero `a` with `b < 0`: on its
/// branch cut, where the value is ±π by the sign of that zero. The tracer's algebra
/// (`a − a = 0`, `0·a = 0`) does not keep the sign of a zero (`(x − x)·(−0.27)` is −0 in
/// IEEE arithmetic and +0 traced), so there the two values differ by 2π (seen at
/// `atan2((x₀ − x₀)·(x₁/x₀ − x₁), −1.2)`); nor is there a derivative to compare.
fn on_branch_cut(e: &E, x: &[f64]) -> bool {
    match e {
        E::X(_) | E::C(_) => false,
        E::Add(a, b) | E::Sub(a, b) | E::Mul(a, b) | E::Div(a, b) => on_branch_cut(a, x) || on_branch_cut(b, x),
        E::F(_, a) | E::Powi(a, _) => on_branch_cut(a, x),
        E::Atan2(a, b) => {
            (eval::<f64>(a, x) == 0.0 && eval::<f64>(b, x) < 0.0) || on_branch_cut(a, x) || on_branch_cut(b, x)
        }
    }
}

fn expr() -> impl Strategy<Value = E> {
    let leaf = prop_oneof![(0..3usize).prop_map(E::X), (-2.0..2.0f64).prop_map(E::C)];
    leaf.prop_recursive(5, 40, 2, |inner| {
        prop_oneof![
            (inner.clone(), inner.clone()).prop_map(|(a, b)| E::Add(Box::new(a), Box::new(b))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| E::Sub(Box::new(a), Box::new(b))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| E::Mul(Box::new(a), Box::new(b))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| E::Div(Box::new(a), Box::new(b))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| E::Atan2(Box::new(a), Box::new(b))),
            (any::<u8>(), inner.clone()).prop_map(|(k, a)| E::F(k, Box::new(a))),
            (inner, -3..4i32).prop_map(|(a, n)| E::Powi(Box::new(a), n)),
        ]
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn random_bodies_differentiate_like_num_dual(
        es in proptest::collection::vec(expr(), 3),
        x in proptest::collection::vec(0.2..1.7f64, 3),
    ) {
        let es = &es;
        let f = model!(|_, y: [S; 3]| vector![eval(&es[0], y.as_slice()), eval(&es[1], y.as_slice()), eval(&es[2], y.as_slice())]);
        let xv = vector![x[0], x[1], x[2]];
        let mut jd = nalgebra::Matrix3::zeros();
        f.jacobian(0.0, &xv, &[], &mut jd);
        let mut fx = vector![0.0, 0.0, 0.0];
        f.rhs(0.0, &xv, &[], &mut fx);
        // a point where the body itself overflows or saturates is no test of its derivative
        prop_assume!(jd.iter().chain(fx.iter()).all(|v| v.is_finite() && v.abs() < 1e8));
        // nor a point on atan2's branch cut (see `on_branch_cut`)
        prop_assume!(!es.iter().any(|e| on_branch_cut(e, &x)));
        // nor is a point where J itself is ill-conditioned: two correct evaluations there
        // differ by about ε·κ·|J|, κ = |x·∂J/∂x| / |J| (seen: sin of ((1.43 − x)·x)⁻³ ≈ 2e5,
        // 4e-10 apart in a row of 6e6). J at x·(1 + 1e-9) estimates κ; points where ε·κ
        // exceeds 1e-13 (a tenth of the bound below) are skipped.
        let mut jp = nalgebra::Matrix3::zeros();
        f.jacobian(0.0, &xv.map(|v| v * (1.0 + 1e-9)), &[], &mut jp);
        let limit = 1e-9 * (1e-13 / f64::EPSILON);
        prop_assume!((0..9).all(|k| {
            let row = (0..3).map(|j| jd[(k % 3, j)].abs()).fold(0.0f64, f64::max);
            (jp[k] - jd[k]).abs() <= limit * (1.0 + row)
        }));
        let tr = symbolic::trace(&f, 3).unwrap();
        let mut js = vec![0.0; 9];
        let mut c = tr.compile_jacobian();
        c.eval_dense(0.0, &x, &[], &mut js).unwrap();
        let mut ji = vec![0.0; 9];
        c.interpreted().eval_dense(0.0, &x, &[], &mut ji).unwrap();
        prop_assert_eq!(bits(&js), bits(&ji), "native and interpreted differ");
        // Relative to the row's largest entry: an entry that is zero by cancellation (the
        // derivative of `atan2(c/x₂, x₀/x₂)` in x₂ is 0) is computed from chain-rule terms
        // of the row's size, and the two ways of writing it round differently (seen:
        // 2.3e-12 against num-dual's exact 0 in a row of size 1e4).
        for (k, (&a, &b)) in js.iter().zip(jd.as_slice()).enumerate() {
            let row = (0..3).map(|j| jd[(k % 3, j)].abs()).fold(0.0f64, f64::max);
            prop_assert!((a - b).abs() <= 1e-12 * (1.0 + row), "entry {}: symbolic {} num-dual {} (row scale {})", k, a, b, row);
        }
        // the values, too
        for i in 0..3 {
            let v = tr.rhs(i).eval(0.0, &x, &[]);
            prop_assert!((v - fx[i]).abs() <= 1e-12 * (1.0 + fx[i].abs()));
        }
    }
}

#[test]
fn hash_consing_shares_the_values_subexpressions_with_the_derivatives() {
    // f = sin(x₀)·x₁: ∂f/∂x₁ is the node sin(x₀) of f itself
    let f = model!(|_, x: [S; 2]| vector![x[0].sin() * x[1], x[0].sin() * x[1]]);
    let tr = symbolic::trace(&f, 2).unwrap();
    assert_eq!(tr.rhs(0), tr.rhs(1));
    let d = tr.jacobian_entry(0, 1).unwrap();
    assert_eq!(d.to_string(), "sin(x₀)");
}

#[test]
fn body3d_angle_derivatives_match_the_product_rule_by_hand() {
    // ∂(R v)/∂ψ with R = Rz(ψ)·Ry(θ)·Rx(φ): Rz differentiated
    let tr = symbolic::trace(&body3d::model(), 3).unwrap();
    let u = [0.3, -0.4, 1.1, 2.0, -0.5, 0.7];
    let (sf, cf) = u[0].sin_cos();
    let (st, ct) = u[1].sin_cos();
    let (sp, cp) = u[2].sin_cos();
    let rx = nalgebra::Matrix3::new(1.0, 0.0, 0.0, 0.0, cf, -sf, 0.0, sf, cf);
    let ry = nalgebra::Matrix3::new(ct, 0.0, st, 0.0, 1.0, 0.0, -st, 0.0, ct);
    let drz = nalgebra::Matrix3::new(-sp, -cp, 0.0, cp, -sp, 0.0, 0.0, 0.0, 0.0);
    let want = drz * ry * rx * vector![u[3], u[4], u[5]];
    let got: Vec<(usize, f64)> = tr
        .input_jacobian()
        .filter(|&(_, k, _)| k == 2)
        .map(|(i, _, e)| (i, e.eval(0.0, &[0.0; 3], &u)))
        .collect();
    assert_eq!(got.len(), 2, "ż does not depend on ψ");
    for (i, v) in got {
        assert!((v - want[i]).abs() < 1e-15, "row {i}: {v} against {}", want[i]);
        assert!(v.abs() > 0.1);
    }
}

/// Issue 38.5: a constant that folding makes non-finite (∂(v·tan α / L)/∂v = tan α / L
/// with 1/L = ∞ for L = 1e-320) is refused like a non-finite constant of the body, not
/// printed as `inf·tan(α)`.
#[test]
fn a_folded_non_finite_constant_is_refused() {
    match symbolic::trace(&bicycle::model(1e-320), 3) {
        Err(Error::Untraceable { reason, .. }) => {
            assert!(reason.contains("folding its constants gives inf"), "{reason}")
        }
        Err(e) => panic!("expected Untraceable, got {e}"),
        Ok(t) => panic!("traced: {}", t.text()),
    }
    let f = model!(|_t, x: [S; 1]| vector![x[0] / 1e-320]);
    assert!(matches!(symbolic::trace(&f, 1), Err(Error::Untraceable { .. })));
    // a small wheelbase whose inverse is finite still traces
    let tr = symbolic::trace(&bicycle::model(1e-300), 3).unwrap();
    assert!(
        tr.text().contains("∂ẋ₂/∂u₀ = 9.999999999999999e299·tan(u₁)") && !tr.text().contains("inf"),
        "{}",
        tr.text()
    );
}

/// What the traced Jacobian and num-dual's give at a special point (issue 38 item 10).
#[derive(Debug, Clone, Copy)]
enum Convention {
    /// Both give this value.
    Both(f64),
    /// The derivative is infinite or undefined: both give a non-finite number (±∞ or NaN;
    /// not always the same one), which every solve refuses as `NonFinite { Jacobian }`.
    NonFinite,
    /// The body's own value is NaN here (`0/0`, `0·∞`): the trace keeps its algebraic
    /// simplification (`a/a = 1`, `0·a = 0`), num-dual computes NaN. No solve gets to the
    /// Jacobian: `f` is NaN first.
    ValueIsNan { traced: f64 },
    /// num-dual's formula is not finite where the derivative is: the traced value is the
    /// true one (num-dual's arithmetic on the user's body is num-dual's own).
    NumDualNan { traced: f64 },
}

/// One special point of a one-state body, checked against its convention: the traced
/// Jacobian (native and interpreted, which agree bit for bit), num-dual's, and `f` itself.
fn special_point(name: &str, f: &impl System<nalgebra::Const<1>>, x: f64, c: Convention) {
    let tr = symbolic::trace(f, 1).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut compiled = tr.compile_jacobian();
    let (mut js, mut ji) = ([f64::NAN; 1], [f64::NAN; 1]);
    compiled.eval_dense(0.0, &[x], &[], &mut js).unwrap();
    compiled
        .clone()
        .interpreted()
        .eval_dense(0.0, &[x], &[], &mut ji)
        .unwrap();
    assert_eq!(
        js[0].to_bits(),
        ji[0].to_bits(),
        "{name}: native {} vs interpreted {}",
        js[0],
        ji[0]
    );
    let mut jd = nalgebra::Matrix1::zeros();
    f.jacobian(0.0, &vector![x], &[], &mut jd);
    let mut fx = vector![0.0];
    f.rhs(0.0, &vector![x], &[], &mut fx);
    let (traced, dual) = (js[0], jd[(0, 0)]);
    let ok = match c {
        Convention::Both(v) => traced == v && dual == v,
        Convention::NonFinite => !traced.is_finite() && !dual.is_finite(),
        Convention::ValueIsNan { traced: t } => fx[0].is_nan() && traced == t && dual.is_nan(),
        Convention::NumDualNan { traced: t } => fx[0].is_finite() && traced == t && dual.is_nan(),
    };
    assert!(
        ok,
        "{name} at x = {x:e}: traced {traced:e}, num-dual {dual:e}, f = {:e}; expected {c:?}",
        fx[0]
    );
}

/// Issue 38 item 10: the traced Jacobian and num-dual's at kinks and special points, one
/// documented convention each (guide §1, "Special points"): equal values where the
/// derivative is finite (`|x|` at ±0 by the sign bit, as num-dual), non-finite on both
/// sides where it is infinite or undefined, and the two documented cases where they
/// cannot agree because num-dual's own formula breaks down.
#[test]
fn special_points_follow_one_convention_in_both_jacobians() {
    use Convention::*;
    let abs = model!(|_, x: [S; 1]| vector![x[0].abs()]);
    special_point("|x|", &abs, 0.0, Both(1.0));
    special_point("|x|", &abs, -0.0, Both(-1.0));
    special_point("|x|", &abs, -2.5, Both(-1.0));
    special_point("|x|", &abs, 2.5, Both(1.0));
    let neg_abs = model!(|_, x: [S; 1]| vector![(-x[0]).abs()]);
    special_point("|−x|", &neg_abs, 0.0, Both(1.0));
    special_point("|−x|", &neg_abs, -0.0, Both(-1.0));
    let sgn = model!(|_, x: [S; 1]| vector![x[0].signum() * 3.0]);
    special_point("3·signum(x)", &sgn, 0.0, Both(0.0));
    special_point("3·signum(x)", &sgn, -0.0, Both(0.0));
    let sqrt = model!(|_, x: [S; 1]| vector![x[0].sqrt()]);
    special_point("√x", &sqrt, 0.0, NonFinite);
    special_point("√x", &sqrt, 4.0, Both(0.25));
    let cbrt = model!(|_, x: [S; 1]| vector![x[0].cbrt()]);
    special_point("∛x", &cbrt, 0.0, NonFinite);
    let half = model!(|_, x: [S; 1]| vector![x[0].powf(0.5)]);
    special_point("x^0.5", &half, 0.0, NonFinite);
    let recip = model!(|_, x: [S; 1]| vector![x[0].recip()]);
    special_point("1/x", &recip, 0.0, NonFinite);
    let inv2 = model!(|_, x: [S; 1]| vector![x[0].powi(-2)]);
    special_point("x⁻²", &inv2, 0.0, NonFinite);
    let ln = model!(|_, x: [S; 1]| vector![x[0].ln()]);
    special_point("ln x", &ln, 0.0, NonFinite);
    let asin = model!(|_, x: [S; 1]| vector![x[0].asin()]);
    special_point("asin x", &asin, 1.0, NonFinite);
    let acosh = model!(|_, x: [S; 1]| vector![x[0].acosh()]);
    special_point("acosh x", &acosh, 1.0, NonFinite);
    let exp = model!(|_, x: [S; 1]| vector![x[0].exp()]);
    special_point("eˣ", &exp, 710.0, NonFinite);
    let atan2 = model!(|_, x: [S; 1]| vector![x[0].atan2(x[0] * 2.0)]);
    special_point("atan2(x, 2x)", &atan2, 0.0, NonFinite);
    let sq = model!(|_, x: [S; 1]| vector![x[0] * x[0]]);
    special_point("x·x", &sq, 0.0, Both(0.0));
    let cube = model!(|_, x: [S; 1]| vector![x[0].powi(3)]);
    special_point("x³", &cube, 0.0, Both(0.0));
    let cubef = model!(|_, x: [S; 1]| vector![x[0].powf(3.0)]);
    special_point("x^3.0", &cubef, 0.0, Both(0.0));
    let ratio = model!(|_, x: [S; 1]| vector![x[0] / x[0]]);
    special_point("x/x", &ratio, 1.5, Both(0.0));
    special_point("x/x", &ratio, 0.0, ValueIsNan { traced: 0.0 });
    let zero_ln = model!(|_, x: [S; 1]| vector![0.0 * x[0].ln()]);
    special_point("0·ln x", &zero_ln, 0.0, ValueIsNan { traced: 0.0 });
    special_point("0·ln x", &zero_ln, 2.0, Both(0.0));
    // num-dual's tanh is sinh/cosh: its quotient rule takes cosh² − sinh², which is
    // ∞ − ∞ once cosh² overflows (|x| > 355); the traced 1/cosh² is 0, the true sech²
    let tanh = model!(|_, x: [S; 1]| vector![x[0].tanh()]);
    special_point("tanh x", &tanh, 400.0, NumDualNan { traced: 0.0 });
    special_point("tanh x", &tanh, -400.0, NumDualNan { traced: 0.0 });
    // below that both are within 2e-16 of sech² (num-dual's difference cancels)
    let (mut jd, mut js) = (nalgebra::Matrix1::zeros(), [0.0]);
    tanh.jacobian(0.0, &vector![20.0], &[], &mut jd);
    symbolic::trace(&tanh, 1)
        .unwrap()
        .compile_jacobian()
        .eval_dense(0.0, &[20.0], &[], &mut js)
        .unwrap();
    let sech2 = 1.0 / 20f64.cosh().powi(2);
    assert!(
        (js[0] - sech2).abs() <= 1e-30 && (jd[(0, 0)] - sech2).abs() <= 2e-16,
        "{js:?} {jd}"
    );
    // num-dual's powf is a^(p−3)·a³ (value) and p·a^(p−3)·a² (derivative): 0·∞ at a = 0 for
    // p < 3, NaN where x^1.5 and its derivative are 0
    let p15 = model!(|_, x: [S; 1]| vector![x[0].powf(1.5)]);
    special_point("x^1.5", &p15, 0.0, NumDualNan { traced: 0.0 });
    special_point("x^1.5", &p15, 4.0, Both(3.0));
}

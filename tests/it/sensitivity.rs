//! Forward sensitivities: against closed forms, the discrete propagators of the methods,
//! and central differences of whole solves.
//!
//! Implicit Euler runs here with per-step error control (`proportional(false)`): what
//! is tested is its sensitivity scheme, at tolerances where the default proportional
//! control would take millions of steps.

use nalgebra::{DMatrix, Dyn, Matrix, Matrix2, SVector, Storage, Vector2, vector};
use reckon::methods::{Auto, Bdf, Euler, Exact, ImplicitEuler, Rk45, Rodas5P};
use reckon::sensitivity::{self, Augment, Sensitivities, SensitivityOptions, Wrt};
use reckon::vehicles::unicycle;
use reckon::{Controls, DualSystem, Error, Event, Options, Problem, Save, model};

use crate::common::drives;

fn sens<S: DualSystem<nalgebra::Const<N>>, M: Augment<nalgebra::Const<N>>, const N: usize>(
    p: &Problem<'_, nalgebra::Const<N>, S>,
    m: M,
    o: &Options,
) -> Sensitivities<nalgebra::Const<N>> {
    sensitivity::solve(p, m, o, &SensitivityOptions::default()).unwrap()
}

/// `A = [[−1, 1], [0, −2]]`: `e^{At} = [[e^{−t}, e^{−t} − e^{−2t}], [0, e^{−2t}]]`.
fn expm(t: f64) -> Matrix2<f64> {
    let (a, b) = ((-t).exp(), (-2.0 * t).exp());
    Matrix2::new(a, a - b, 0.0, b)
}

fn linear() -> impl DualSystem<nalgebra::Const<2>> {
    model!(|_, x: [S; 2]| vector![-x[0] + x[1], -2.0 * x[1]])
}

fn max_rel<A, B>(a: &Matrix<f64, Dyn, Dyn, A>, b: &Matrix<f64, Dyn, Dyn, B>) -> f64
where
    A: Storage<f64, Dyn, Dyn>,
    B: Storage<f64, Dyn, Dyn>,
{
    (a - b).amax() / b.amax()
}

#[test]
fn linear_system_gives_the_matrix_exponential() {
    let f = linear();
    let p = Problem::new(&f, vector![1.0, 3.0], (0.0, 2.0));
    let tight = Options::default().rtol(1e-13).atol(1e-15);
    let exact = DMatrix::from_column_slice(2, 2, expm(2.0).as_slice());
    for (name, s) in [
        ("dopri5", sens(&p, Rk45, &tight)),
        ("rodas5p", sens(&p, Rodas5P, &tight)),
        (
            "bdf",
            sens(&p, Bdf::default(), &Options::default().rtol(1e-12).atol(1e-14)),
        ),
        ("auto", sens(&p, Auto::default(), &tight)),
    ] {
        let k = s.t.len() - 1;
        let e = max_rel(&s.wrt_x0(k), &exact);
        assert!(e < 1e-10, "{name}: S differs from e^(At) by {e:e}");
        assert_eq!(s.wrt_params(k).ncols(), 0);
    }
}

/// For a linear model every method's step is linear in `x`, so the computed solution is
/// `x_N = S_N x₀` exactly: the discrete sensitivity is the method's own propagator.
/// Adaptive implicit Euler is the exception, by design: its `S` comes from the staggered
/// scheme, the exact derivative of the implicit Euler map `(I − hA)⁻¹` on the steps taken,
/// while its `x` is Newton's iterate (a stale LU leaves it within the Newton tolerance of
/// that map's image), so there `S` is checked against the product of the `(I − h_kA)⁻¹`.
#[test]
fn linear_system_sensitivity_is_the_discrete_propagator_for_every_method() {
    let f = linear();
    let x0 = vector![1.0, 3.0];
    let p = Problem::new(&f, x0, (0.0, 2.0));
    let fixed = Options::default().fixed(0.1);
    let adaptive = Options::default().rtol(1e-6).atol(1e-9);
    let runs: Vec<(&str, Sensitivities<_>)> = vec![
        ("explicit euler, fixed", sens(&p, Euler, &fixed)),
        ("dopri5, fixed", sens(&p, Rk45, &fixed)),
        ("dopri5, adaptive", sens(&p, Rk45, &adaptive)),
        (
            "implicit euler, fixed",
            sens(&p, ImplicitEuler::default().proportional(false), &fixed),
        ),
        (
            "implicit euler, adaptive",
            sens(&p, ImplicitEuler::default().proportional(false), &adaptive),
        ),
        ("bdf, fixed", sens(&p, Bdf::default(), &fixed)),
        ("bdf, adaptive", sens(&p, Bdf::default(), &adaptive)),
        ("rodas5p, fixed", sens(&p, Rodas5P, &fixed)),
        ("rodas5p, adaptive", sens(&p, Rodas5P, &adaptive)),
    ];
    let a = Matrix2::new(-1.0, 1.0, 0.0, -2.0);
    for (name, s) in &runs {
        if *name == "implicit euler, adaptive" {
            let mut prop = Matrix2::identity();
            for k in 1..s.t.len() {
                let h = s.t[k] - s.t[k - 1];
                prop = (Matrix2::identity() - a * h).try_inverse().unwrap() * prop;
                let e = max_rel(&s.wrt_x0(k), &DMatrix::from_column_slice(2, 2, prop.as_slice()));
                // rounding over the steps (h from the saved times, a few ulp per step)
                assert!(
                    e < 1e-12,
                    "{name}: S differs from Π(I − hA)⁻¹ by {e:e} at t = {}",
                    s.t[k]
                );
            }
            // and x is the plain solve's, step for step, bit for bit
            let plain = p
                .solve(ImplicitEuler::default().proportional(false), &adaptive)
                .unwrap();
            assert_eq!((&plain.t, &plain.x), (&s.t, &s.x), "{name}: x is not the plain solve's");
            continue;
        }
        for k in 0..s.t.len() {
            let sx = s.wrt_x0(k) * nalgebra::DVector::from_column_slice(x0.as_slice());
            let e = (sx - nalgebra::DVector::from_column_slice(s.x[k].as_slice())).amax();
            assert!(e < 1e-13, "{name}: S·x0 differs from x by {e:e} at t = {}", s.t[k]);
        }
    }
    // the fixed-step propagators in closed form: (I + hA)^20 and (I − hA)^−20
    let ee = (Matrix2::identity() + a * 0.1).pow(20);
    let ie = (Matrix2::identity() - a * 0.1).try_inverse().unwrap().pow(20);
    let last = |s: &Sensitivities<_>| s.wrt_x0(s.t.len() - 1);
    assert!(max_rel(&last(&runs[0].1), &DMatrix::from_column_slice(2, 2, ee.as_slice())) < 1e-14);
    assert!(max_rel(&last(&runs[3].1), &DMatrix::from_column_slice(2, 2, ie.as_slice())) < 1e-12);
}

/// Van der Pol with μ a parameter: `x' = y`, `y' = μ(1 − x²)y − x`.
fn vdp() -> impl DualSystem<nalgebra::Const<2>> + Clone {
    model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]])
}

/// `∂x(t_end)/∂(x₀, μ)` by central differences of whole plain solves.
fn central<M: reckon::methods::Method<nalgebra::Const<2>>>(
    method: impl Fn() -> M,
    o: &Options,
    x0: Vector2<f64>,
    mu: f64,
) -> DMatrix<f64> {
    let solve = |x0: Vector2<f64>, mu: f64| -> Vector2<f64> {
        let f = model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]])
            .with_params(&[mu])
            .unwrap();
        *Problem::new(&f, x0, (0.0, 2.0)).solve(method(), o).unwrap().last().1
    };
    let d = 1e-6;
    let mut c = DMatrix::zeros(2, 3);
    for j in 0..3 {
        let (mut xp, mut xm, mut mp, mut mm) = (x0, x0, mu, mu);
        if j < 2 {
            xp[j] += d;
            xm[j] -= d;
        } else {
            mp += d;
            mm -= d;
        }
        let col = (solve(xp, mp) - solve(xm, mm)) / (2.0 * d);
        c.set_column(j, &col);
    }
    c
}

#[test]
fn sensitivities_equal_central_differences_of_the_whole_solve() {
    let f = vdp();
    let x0 = vector![2.0, 0.0];
    let p = Problem::new(&f, x0, (0.0, 2.0));
    // (tight tolerances: the Newton iterations of the implicit methods must not put their
    // own noise into the differences)
    let fixed = Options::default().fixed(0.01).rtol(1e-12).atol(1e-14);
    let adaptive = Options::default().rtol(1e-10).atol(1e-12);
    macro_rules! check {
        ($name:expr, $method:expr, $o:expr) => {{
            let s = sens(&p, $method, $o);
            assert_eq!(s.n_params, 1);
            let got = s.last_s().into_owned();
            let want = central(|| $method, $o, x0, 1.5);
            let e = max_rel(&got, &want);
            assert!(
                e < 1e-6,
                "{}: sensitivities differ from central differences by {e:e}\n{got}{want}",
                $name
            );
        }};
    }
    check!("explicit euler, fixed", Euler, &fixed);
    check!("dopri5, fixed", Rk45, &fixed);
    check!("dopri5, adaptive", Rk45, &adaptive);
    check!(
        "implicit euler, fixed",
        ImplicitEuler::default().proportional(false),
        &fixed
    );
    // the derivative of the computed solution with the steps the solver took: central
    // differences of solves that replay those steps (breakpoints at the step ends, Newton
    // converged tightly), for the one-step adaptive methods
    macro_rules! replay {
        ($name:expr, $method:expr, $o:expr) => {{
            let s = sens(&p, $method, $o);
            let inner = s.t[1..s.t.len() - 1].to_vec();
            let steps = Options::default().fixed(2.0).breakpoints(inner).rtol(1e-12).atol(1e-14);
            let want = central(|| $method, &steps, x0, 1.5);
            let e = max_rel(&s.last_s(), &want);
            assert!(e < 1e-6, "{} (steps replayed): {e:e}", $name);
            s.t.len()
        }};
    }
    let n = replay!(
        "implicit euler, adaptive",
        ImplicitEuler::default().proportional(false),
        &Options::default().rtol(1e-6).atol(1e-8)
    );
    assert!(n > 100, "{n} steps");
    replay!("dopri5, adaptive", Rk45, &Options::default().rtol(1e-6).atol(1e-8));
    replay!("rodas5p, adaptive", Rodas5P, &Options::default().rtol(1e-6).atol(1e-8));
    // with free steps a first-order method's steps depend on μ and x₀ at the level of its
    // global error, which a derivative through the steps taken leaves out: at rtol 1e-9
    // the two differ by about 1e-4 (measured 1.4e-4)
    let s = sens(
        &p,
        ImplicitEuler::default().proportional(false),
        &Options::default().rtol(1e-9).atol(1e-11),
    );
    let free = central(
        || ImplicitEuler::default().proportional(false),
        &Options::default().rtol(1e-9).atol(1e-11),
        x0,
        1.5,
    );
    let e = max_rel(&s.last_s(), &free);
    assert!(e > 1e-6 && e < 1e-3, "implicit euler, free steps: {e:e}");
    check!("bdf, fixed", Bdf::default(), &fixed);
    check!("bdf, adaptive", Bdf::default(), &adaptive);
    check!("rodas5p, fixed", Rodas5P, &fixed);
    check!("rodas5p, adaptive", Rodas5P, &adaptive);
    check!("auto, adaptive", Auto::default(), &adaptive);
}

#[test]
fn x_part_is_the_plain_solve_bit_for_bit_for_explicit_methods() {
    let f = vdp();
    let p = Problem::new(&f, vector![2.0, 0.0], (0.0, 2.0));
    let o = Options::default().rtol(1e-8).atol(1e-10);
    let plain = p.solve(Rk45, &o).unwrap();
    let s = sens(&p, Rk45, &o);
    assert_eq!(plain.t, s.t);
    assert_eq!(plain.x, s.x);
    // with the sensitivities in the error control the steps change (more of them here)
    let c = sensitivity::solve(&p, Rk45, &o, &SensitivityOptions::default().error_control(true)).unwrap();
    assert!(c.t.len() > s.t.len(), "{} vs {}", c.t.len(), s.t.len());
    assert!(max_rel(&c.last_s(), &s.last_s()) < 1e-6);
}

/// The unicycle's exact flow: `∂(x, y, θ)/∂(x₀, y₀, θ₀) = [[1, 0, −(y − y₀)], [0, 1, x − x₀], [0, 0, 1]]`
/// for any held inputs, and RK45 agrees.
#[test]
fn unicycle_exact_flow_sensitivities_are_analytic() {
    let controls = Controls::new(
        vec![0.0, 1.0, 2.5, 4.0],
        vec![vec![1.0, 0.3], vec![2.0, -0.5], vec![0.5, 0.0], vec![1.0, 1.0]],
    )
    .unwrap();
    let x0 = vector![1.0, -2.0, 0.4];
    let p = Problem::new(unicycle::model(), x0, (0.0, 5.0)).controls(controls);
    let ex = sens(&p, Exact::new(unicycle::ExactFlow), &Options::default());
    let rk = sens(&p, Rk45, &Options::default().rtol(1e-12).atol(1e-14));
    for s in [&ex, &rk] {
        let k = s.t.len() - 1;
        let x = s.x[k];
        let want = DMatrix::from_row_slice(
            3,
            3,
            &[1.0, 0.0, -(x[1] - x0[1]), 0.0, 1.0, x[0] - x0[0], 0.0, 0.0, 1.0],
        );
        let e = (s.wrt_x0(k) - want).amax();
        assert!(
            e < if s.method == "exact" { 1e-14 } else { 1e-9 },
            "{}: {e:e}",
            s.method
        );
    }
    // one step per control interval, and the same x as the plain exact solve
    let plain = p.solve(Exact::new(unicycle::flow), &Options::default()).unwrap();
    assert_eq!(ex.t, vec![0.0, 1.0, 2.5, 4.0, 5.0]);
    assert_eq!(ex.x, plain.x);
}

#[test]
fn closed_form_parameter_sensitivity() {
    // x' = −k x: ∂x/∂k = −t x₀ e^{−kt}, at every saved time
    let f = model!(|_, x: [S; 1], p: [S; 1] = [0.5]| vector![-(p[0] * x[0])]);
    let p = Problem::new(&f, vector![2.0], (0.0, 3.0));
    for s in [
        sens(&p, Rk45, &Options::default().rtol(1e-12).atol(1e-14)),
        sens(&p, Rodas5P, &Options::default().rtol(1e-12).atol(1e-14)),
    ] {
        for k in 0..s.t.len() {
            let t = s.t[k];
            let want = -t * 2.0 * (-0.5 * t).exp();
            assert!((s.wrt_params(k)[(0, 0)] - want).abs() < 1e-10, "{}: t = {t}", s.method);
        }
    }
}

#[test]
fn bad_requests_are_typed_errors() {
    let f = vdp();
    // a terminal event's stop time has a sensitivity of its own, not applied: refused
    let ev = Event::new(|_t, x: &SVector<f64, 2>| x[0]).terminal();
    let p = Problem::new(&f, vector![2.0, 0.0], (0.0, 2.0)).event(ev);
    let e = sensitivity::solve(&p, Rk45, &Options::default(), &SensitivityOptions::default()).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "events", .. }), "{e}");
    // exact flows know nothing of a model's parameters
    let g = model!(|_, x: [S; 3], u: [2], p: [S; 1] = [1.0]| vector![
        x[2].cos() * u[0] * p[0],
        x[2].sin() * u[0],
        S::from(u[1])
    ]);
    let q = Problem::new(&g, vector![0.0, 0.0, 0.0], (0.0, 1.0)).inputs(vec![1.0, 0.0]);
    let e = sensitivity::solve(
        &q,
        Exact::new(unicycle::ExactFlow),
        &Options::default(),
        &SensitivityOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "method", .. }), "{e}");
    assert!(matches!(
        model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]])
            .with_params(&[1.0, 2.0]),
        Err(Error::InvalidInput { what: "params", .. })
    ));
    assert!(matches!(
        model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]])
            .with_params(&[f64::NAN]),
        Err(Error::InvalidInput { what: "params", .. })
    ));
    // a non-finite derivative met by the sensitivity solve is reported where it happens
    // (x' = p·x², x₀ = 1: x = 1/(1 − t) blows up at t = 1)
    let h = model!(|_, x: [S; 1], p: [S; 1] = [1.0]| vector![p[0] * x[0] * x[0]]);
    let r = Problem::new(&h, vector![1.0], (0.0, 2.0));
    let e = sensitivity::solve(&r, Rk45, &Options::default(), &SensitivityOptions::default()).unwrap_err();
    assert!(
        matches!(e, Error::StepSizeUnderflow { t, .. } | Error::NonFinite { t, .. } if (t - 1.0).abs() < 1e-3),
        "{e}"
    );
}

#[test]
fn dynamic_state_with_parameters() {
    // x_i' = −p_i x_i for a DVector state: ∂x_i/∂p_i = −t x_i(0) e^{−p_i t}
    let f = model!(|_, x: [S; Dyn], p: [S; 2] = [0.5, 2.0]| nalgebra::DVector::from_fn(2, |i, _| -(p[i].clone()
        * x[i].clone())));
    let x0 = nalgebra::DVector::from_vec(vec![1.0, 3.0]);
    let p = Problem::new(&f, x0, (0.0, 1.0));
    let s = sensitivity::solve(
        &p,
        Rk45,
        &Options::default().rtol(1e-12).atol(1e-14),
        &SensitivityOptions::default(),
    )
    .unwrap();
    let k = s.t.len() - 1;
    let dp = s.wrt_params(k);
    assert!((dp[(0, 0)] + (-0.5f64).exp()).abs() < 1e-10);
    assert!((dp[(1, 1)] + 3.0 * (-2.0f64).exp()).abs() < 1e-10);
    assert!(dp[(0, 1)].abs() < 1e-15 && dp[(1, 0)].abs() < 1e-15);
    // implicit Euler's staggered scheme at Dyn (faer's LU), fixed h = 0.01: the discrete
    // map x_N = x₀/(1 + p·h)^N has ∂x_N/∂p = −N·h·x₀/(1 + p·h)^(N+1) and ∂x_N/∂x₀ = (1 + p·h)^−N
    let s = sensitivity::solve(
        &p,
        ImplicitEuler::default().proportional(false),
        &Options::default().fixed(0.01),
        &SensitivityOptions::default(),
    )
    .unwrap();
    let k = s.t.len() - 1;
    assert_eq!(k, 100);
    for (i, (x0, pi)) in [(1.0, 0.5), (3.0, 2.0)].into_iter().enumerate() {
        let q: f64 = 1.0 + pi * 0.01;
        let dxdp = -100.0 * 0.01 * x0 / q.powi(101);
        assert!(
            (s.dx_dp(k, i, i) - dxdp).abs() < 1e-13 * dxdp.abs(),
            "{i}: {} vs {dxdp}",
            s.dx_dp(k, i, i)
        );
        assert!((s.wrt_x0(k)[(i, i)] - q.powi(-100)).abs() < 1e-13);
        assert_eq!(s.dx_dp(k, i, 1 - i), 0.0);
    }
}

#[test]
fn parameters_only() {
    // Wrt::Params carries ∂x/∂p alone (S(t₀) = 0): the same columns as Wrt::All, bit for bit
    // for explicit methods (each dual direction is computed on its own, the steps are
    // those of x), to the Newton tolerance for implicit ones, and the same x
    let f = vdp();
    let p = Problem::new(&f, vector![2.0, 0.0], (0.0, 4.0));
    let only = SensitivityOptions::default().wrt(Wrt::Params);
    let o = Options::default().rtol(1e-9).atol(1e-11);
    let a = sensitivity::solve(&p, Rk45, &o, &SensitivityOptions::default()).unwrap();
    let b = sensitivity::solve(&p, Rk45, &o, &only).unwrap();
    assert_eq!((b.s(0).nrows(), b.s(0).ncols()), (2, 1));
    assert_eq!(b.wrt_x0(0).ncols(), 0);
    assert_eq!(b.wrt_params(0), DMatrix::zeros(2, 1));
    assert_eq!(a.t, b.t);
    assert_eq!(a.x, b.x);
    for k in 0..a.t.len() {
        assert_eq!(a.wrt_params(k), b.wrt_params(k), "t = {}", a.t[k]);
        assert_eq!(a.dx_dp(k, 1, 0), b.dx_dp(k, 1, 0));
    }
    // and against central differences of whole solves in μ
    let k = b.t.len() - 1;
    let d = 1e-5;
    let end = |mu: f64| {
        let g = model!(|_, x: [S; 2], p: [S; 1] = [1.5]| vector![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]])
            .with_params(&[mu])
            .unwrap();
        let q = Problem::new(&g, vector![2.0, 0.0], (0.0, 4.0));
        *q.solve(Rk45, &Options::default().rtol(1e-12).atol(1e-14))
            .unwrap()
            .last()
            .1
    };
    let fd = (end(1.5 + d) - end(1.5 - d)) / (2.0 * d);
    for i in 0..2 {
        assert!(
            (b.dx_dp(k, i, 0) - fd[i]).abs() < 1e-5 * fd.amax(),
            "{i}: {} vs {}",
            b.dx_dp(k, i, 0),
            fd[i]
        );
    }
    // implicit Euler's staggered scheme solves each column on its own with the same LU
    // at the same x: bit for bit too
    let ie = Options::default().rtol(1e-6).atol(1e-9);
    let a = sensitivity::solve(
        &p,
        ImplicitEuler::default().proportional(false),
        &ie,
        &SensitivityOptions::default(),
    )
    .unwrap();
    let b = sensitivity::solve(&p, ImplicitEuler::default().proportional(false), &ie, &only).unwrap();
    assert_eq!((&a.t, &a.x), (&b.t, &b.x));
    for k in 0..a.t.len() {
        assert_eq!(a.wrt_params(k), b.wrt_params(k), "t = {}", a.t[k]);
    }
    // a model without parameters has nothing to differentiate by
    let q = Problem::new(linear(), vector![1.0, 1.0], (0.0, 1.0));
    let e = sensitivity::solve(&q, Rk45, &o, &only).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "wrt", .. }), "{e}");
}

/// `∂x(t_end)/∂(x₀, geometry)` of the differential drive by central differences of
/// `end(x₀, geometry)` (steps 1e-6 in `x₀`, 1e-6 relative in the geometry).
fn drive_central(
    end: impl Fn(SVector<f64, 3>, &[f64]) -> SVector<f64, 3>,
    x0: SVector<f64, 3>,
    geometry: [f64; 3],
) -> DMatrix<f64> {
    let mut want = DMatrix::zeros(3, 6);
    for j in 0..6 {
        let d = if j < 3 { 1e-6 } else { 1e-6 * geometry[j - 3] };
        let (mut xp, mut xm, mut gp, mut gm) = (x0, x0, geometry, geometry);
        if j < 3 {
            xp[j] += d;
            xm[j] -= d;
        } else {
            gp[j - 3] += d;
            gm[j - 3] -= d;
        }
        want.set_column(j, &((end(xp, &gp) - end(xm, &gm)) / (2.0 * d)));
    }
    want
}

/// Implicit Euler's staggered direct scheme on a driven model with parameters (the
/// differential drive's wheel radii and track over a wheel-speed log, inputs switching at
/// every control time): `x` and the steps are the plain solve's, bit for bit; `S` is the
/// derivative of the computed solution with those steps (central differences of solves
/// that replay them, Newton converged tightly); at output times it is the step's linear
/// interpolant, as `x` is; `Save::End` keeps the same last `S`; and with `S` in the error
/// control the augmented system is integrated instead (other steps, close `S`).
#[test]
fn implicit_euler_staggered_scheme_on_a_driven_model() {
    use reckon::calibration::lsq::diff_drive;
    let geometry = [0.0502, 0.0497, 0.405];
    let dd = diff_drive(&geometry).unwrap();
    let log = drives::wheel_speed_log();
    let span = (0.0, 20.0);
    let x0 = vector![0.1, -0.2, 0.3];
    let p = Problem::new(&dd, x0, span).controls(log.clone());
    let o = Options::default().rtol(1e-6).atol(1e-9);
    let s = sens(&p, ImplicitEuler::default().proportional(false), &o);
    let plain = p.solve(ImplicitEuler::default().proportional(false), &o).unwrap();
    assert_eq!((&plain.t, &plain.x), (&s.t, &s.x));
    assert!(s.t.len() > 50, "{} steps", s.t.len());
    assert_eq!((s.s(0).nrows(), s.s(0).ncols()), (3, 6));
    // replay the steps: every step end a breakpoint, one fixed step per interval
    let inner = s.t[1..s.t.len() - 1].to_vec();
    let replay = Options::default()
        .fixed(100.0)
        .breakpoints(inner)
        .rtol(1e-12)
        .atol(1e-14);
    let end = |x0: SVector<f64, 3>, g: &[f64]| -> SVector<f64, 3> {
        let m = diff_drive(g).unwrap();
        *Problem::new(&m, x0, span)
            .controls(log.clone())
            .solve(ImplicitEuler::default().proportional(false), &replay)
            .unwrap()
            .last()
            .1
    };
    let want = drive_central(end, x0, geometry);
    let got = s.last_s();
    let e = max_rel(&got, &want);
    assert!(
        e < 1e-6,
        "staggered S differs from replayed central differences by {e:e}\n{got}{want}"
    );
    // output times: the linear interpolant of the neighbouring steps' S
    let at: Vec<f64> = (1..40).map(|k| 0.5 * k as f64 - 0.013).collect();
    let si = sensitivity::solve(
        &p,
        ImplicitEuler::default().proportional(false),
        &o.clone().save(Save::At(at.clone())),
        &SensitivityOptions::default(),
    )
    .unwrap();
    assert_eq!(si.t, at);
    for (k, &ta) in at.iter().enumerate() {
        let j = s.t.partition_point(|&t| t < ta);
        let theta = (ta - s.t[j - 1]) / (s.t[j] - s.t[j - 1]);
        let lin = s.s(j - 1) + (s.s(j) - s.s(j - 1)) * theta;
        let e = (si.s(k) - &lin).amax() / lin.amax();
        assert!(e < 1e-12, "t = {ta}: {e:e}");
    }
    // the end alone: the same last S
    let se = sensitivity::solve(
        &p,
        ImplicitEuler::default().proportional(false),
        &o.clone().save(Save::End),
        &SensitivityOptions::default(),
    )
    .unwrap();
    assert_eq!(se.t, vec![0.0, 20.0]);
    assert_eq!(se.last_s(), s.last_s());
    // S in the error control: the augmented system, its own steps
    let c = sensitivity::solve(
        &p,
        ImplicitEuler::default().proportional(false),
        &o,
        &SensitivityOptions::default().error_control(true),
    )
    .unwrap();
    assert_ne!(c.t.len(), s.t.len());
    let e = max_rel(&c.last_s(), &got);
    assert!(e < 1e-2, "error-controlled S vs staggered: {e:e}");
}

/// RK45's staggered direct scheme on a driven model with parameters (inputs switching
/// every 2 s, so `k₁` is evaluated afresh after each switch): `x`, the times and the
/// steps are the plain solve's bit for bit, at every step and at output times (the same
/// CONTD5 polynomial); `S` equals the augmented system integrated on the same steps
/// (replayed as breakpoints, one fixed step each) and central differences of those
/// replayed solves; each accepted step costs six dual evaluations (plus a fresh `K₁`
/// after a switch), a rejected one none.
#[test]
fn dopri5_staggered_scheme_on_a_driven_model() {
    use reckon::calibration::lsq::diff_drive;
    let geometry = [0.0502, 0.0497, 0.405];
    let dd = diff_drive(&geometry).unwrap();
    let log = drives::wheel_speed_log();
    let span = (0.0, 20.0);
    let x0 = vector![0.1, -0.2, 0.3];
    let p = Problem::new(&dd, x0, span).controls(log.clone());
    let o = Options::default().rtol(1e-7).atol(1e-9);
    let s = sens(&p, Rk45, &o);
    let plain = p.solve(Rk45, &o).unwrap();
    assert_eq!((&plain.t, &plain.x), (&s.t, &s.x));
    assert_eq!(
        (s.stats.accepted, s.stats.rejected),
        (plain.stats.accepted, plain.stats.rejected)
    );
    let acc = s.stats.accepted;
    assert!(
        acc > 30 && plain.stats.rejected > 0,
        "{acc} steps, {} rejected",
        plain.stats.rejected
    );
    // tangents: 6 per accepted step, plus K₁ at t₀ and after each of the 9 switches
    assert_eq!(s.stats.rhs_evals - plain.stats.rhs_evals, 6 * acc + 10);
    assert_eq!((s.s(0).nrows(), s.s(0).ncols()), (3, 6));
    // the augmented system on the same steps
    let inner = s.t[1..s.t.len() - 1].to_vec();
    let replay = Options::default().fixed(100.0).breakpoints(inner);
    let ctl = SensitivityOptions::default().error_control(true);
    let aug = sensitivity::solve(&p, Rk45, &replay, &ctl).unwrap();
    assert_eq!(aug.t, s.t);
    for k in 0..s.t.len() {
        let e = max_rel(&s.s(k), &aug.s(k));
        assert!(e < 1e-12, "t = {}: staggered vs augmented {e:e}", s.t[k]);
    }
    // and the derivative of those replayed solves, by central differences
    let end = |x0: SVector<f64, 3>, g: &[f64]| -> SVector<f64, 3> {
        let m = diff_drive(g).unwrap();
        *Problem::new(&m, x0, span)
            .controls(log.clone())
            .solve(Rk45, &replay)
            .unwrap()
            .last()
            .1
    };
    let want = drive_central(end, x0, geometry);
    let e = max_rel(&s.last_s(), &want);
    assert!(e < 1e-7, "staggered S vs central differences {e:e}");
    // output times: x as the plain solve's dense output, S as the augmented one's
    let at: Vec<f64> = (1..40).map(|k| 0.5 * k as f64 - 0.013).collect();
    let o_at = o.clone().save(Save::At(at.clone()));
    let si = sensitivity::solve(&p, Rk45, &o_at, &SensitivityOptions::default()).unwrap();
    let pi = p.solve(Rk45, &o_at).unwrap();
    assert_eq!((&si.t, &si.x), (&pi.t, &pi.x));
    let ai = sensitivity::solve(&p, Rk45, &replay.clone().save(Save::At(at.clone())), &ctl).unwrap();
    for (k, ta) in at.iter().enumerate() {
        let e = max_rel(&si.s(k), &ai.s(k));
        assert!(e < 1e-12, "t = {ta}: interpolated S {e:e}");
    }
    // the end alone and every 4th step: the same S as every step
    let se = sensitivity::solve(&p, Rk45, &o.clone().save(Save::End), &SensitivityOptions::default()).unwrap();
    assert_eq!((se.t.len(), se.last_s()), (2, s.last_s()));
    let s4 = sensitivity::solve(
        &p,
        Rk45,
        &o.clone().save(Save::Every(4)),
        &SensitivityOptions::default(),
    )
    .unwrap();
    for (k, t) in s4.t.iter().enumerate() {
        let j = s.t.iter().position(|u| u == t).unwrap();
        assert_eq!(s4.s(k), s.s(j));
    }
}

/// `DualSystem::tangent` for `S = ∂x/∂p` alone (`m = n_p` columns): a fixed-size model
/// evaluates its copy of the body at `n_p` directions, a `Dyn` one its dual body at
/// exactly `m`; both equal the closed form `J·S + ∂f/∂p`, and bit for bit the parameter
/// columns of the full-width tangent with `S = [0 | S_p]`.
#[test]
fn parameter_tangent_at_n_p_directions() {
    // f = (p₀x₀x₁ + u₀, sin(p₁x₀) − x₁²)
    let fixed = model!(|_, x: [S; 2], u: [1], p: [S; 2] = [0.7, -1.3]| vector![
        p[0] * x[0] * x[1] + S::from(u[0]),
        (p[1] * x[0]).sin() - x[1] * x[1]
    ]);
    let dynamic = model!(|_, x: [S; Dyn], u: [1], p: [S; 2] = [0.7, -1.3]| nalgebra::DVector::from_vec(vec![
        p[0].clone() * x[0].clone() * x[1].clone() + S::from(u[0]),
        (p[1].clone() * x[0].clone()).sin() - x[1].clone() * x[1].clone()
    ]));
    let (x, u): ([f64; 2], [f64; 1]) = ([0.4, -2.1], [0.3]);
    let (p0, p1): (f64, f64) = (0.7, -1.3);
    // S_p, 2 × 2 column-major
    let sp = [0.25, -1.5, 2.0, 0.125];
    let jac = [[p0 * x[1], p0 * x[0]], [p1 * (p1 * x[0]).cos(), -2.0 * x[1]]];
    let dfdp = [[x[0] * x[1], 0.0], [0.0, x[0] * (p1 * x[0]).cos()]];
    let want: Vec<f64> = (0..2)
        .flat_map(|k| (0..2).map(move |i| jac[i][0] * sp[2 * k] + jac[i][1] * sp[2 * k + 1] + dfdp[i][k]))
        .collect();
    // the full width: S = [0 | S_p], 4 columns
    let mut wide_s = vec![0.0; 4];
    wide_s.extend_from_slice(&sp);
    let (mut a, mut b, mut c, mut d) = (vec![0.0; 4], vec![0.0; 8], vec![0.0; 4], vec![0.0; 8]);
    fixed.tangent(0.0, &vector![x[0], x[1]], &u, &sp, 2, &mut a);
    fixed.tangent(0.0, &vector![x[0], x[1]], &u, &wide_s, 4, &mut b);
    let xd = nalgebra::DVector::from_vec(x.to_vec());
    dynamic.tangent(0.0, &xd, &u, &sp, 2, &mut c);
    dynamic.tangent(0.0, &xd, &u, &wide_s, 4, &mut d);
    for e in 0..4 {
        assert!(
            (a[e] - want[e]).abs() < 1e-15 * want[e].abs().max(1.0),
            "{e}: {} vs {}",
            a[e],
            want[e]
        );
    }
    assert_eq!(a, b[4..]);
    assert_eq!(c, d[4..]);
    assert_eq!(a, c);
    // the x₀ columns of the wide tangent are J·0 = 0
    assert_eq!(b[..4], [0.0; 4]);
}

/// Issue 38 item 10: x' = 710·x from x₀ = 0 keeps x ≡ 0, so the steps chosen for x grow
/// without bound while S = ∂x/∂x₀ = e^{710t} (e¹⁰⁶⁵ at t = 1.5 overflows). With S outside
/// the error control (the default) RK45 returned Ok with S = 4.6·10³⁷ and implicit Euler
/// Ok with 4.5·10⁻⁸ (BDF 4·10⁻⁶, Rodas5P 2.8, exponential Euler 2.8·10¹⁹¹). Now every
/// adaptive method watches S's own error estimate and refuses with the typed error; with
/// `error_control(true)` the steps follow S until it overflows, a non-finite error.
#[test]
fn sensitivities_that_the_steps_do_not_resolve_are_an_error_not_a_number() {
    use reckon::methods::ExponentialEuler;
    let f = model!(|_, x: [S; 1]| vector![710.0 * x[0]]);
    let p = Problem::new(&f, vector![0.0], (0.0, 1.5));
    let o = Options::default();
    let off = SensitivityOptions::default();
    let on = SensitivityOptions::default().error_control(true);
    fn check(name: &str, r: reckon::Result<Sensitivities<nalgebra::Const<1>>>, want: fn(&Error) -> bool) {
        match r {
            Ok(s) => panic!("{name}: Ok with S = {:e}", s.last_s()[(0, 0)]),
            Err(e) => assert!(want(&e), "{name}: {e}"),
        }
    }
    let unresolved = |e: &Error| matches!(e, Error::SensitivityUnresolved { ratio, .. } if *ratio > 0.1);
    check("rk45", sensitivity::solve(&p, Rk45, &o, &off), unresolved);
    check(
        "implicit euler",
        sensitivity::solve(&p, ImplicitEuler::default().proportional(false), &o, &off),
        unresolved,
    );
    check("bdf", sensitivity::solve(&p, Bdf::default(), &o, &off), unresolved);
    check("rodas5p", sensitivity::solve(&p, Rodas5P, &o, &off), unresolved);
    check("auto", sensitivity::solve(&p, Auto::default(), &o, &off), unresolved);
    // exponential Euler is exact on a linear model: its S overflows, a non-finite state
    // (its φ functions no longer round e^{631} to 1 when the forcing is large)
    let overflow = |e: &Error| matches!(e, Error::NonFinite { .. } | Error::StepSizeUnderflow { .. });
    check(
        "exponential euler",
        sensitivity::solve(&p, ExponentialEuler, &o, &off),
        overflow,
    );
    // S in the error control: S is followed until it overflows
    let stops = |e: &Error| {
        matches!(
            e,
            Error::NonFinite { .. } | Error::MaxSteps { .. } | Error::StepSizeUnderflow { .. }
        )
    };
    check("rk45, S controlled", sensitivity::solve(&p, Rk45, &o, &on), stops);
    check("rodas5p, S controlled", sensitivity::solve(&p, Rodas5P, &o, &on), stops);
    // a span the steps can resolve: S = e^{710·0.01} to the tolerance, with error control
    let q = Problem::new(&f, vector![0.0], (0.0, 0.01));
    let s = sensitivity::solve(&q, Rk45, &Options::default().rtol(1e-8), &on).unwrap();
    let want = (7.1f64).exp();
    assert!(
        (s.last_s()[(0, 0)] / want - 1.0).abs() < 1e-6,
        "{:e} vs {want:e}",
        s.last_s()[(0, 0)]
    );
    // and without it: S rides on steps chosen for x ≡ 0, refused as well
    assert!(matches!(
        sensitivity::solve(&q, Rk45, &Options::default().rtol(1e-8), &off),
        Err(Error::SensitivityUnresolved { .. })
    ));
}

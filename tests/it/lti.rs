//! Linear time-invariant models: the zero-order-hold flow against closed forms, RK45 and
//! an eigen-decomposition reference; Van Loan's discrete noise.

use nalgebra::{DMatrix, DVector, Dyn, Matrix1, Matrix2, Vector1, Vector2, vector};
use proptest::prelude::*;
use reckon::kalman::{Kalman, discretise_noise};
use reckon::methods::{Exact, Rk45};
use reckon::model::Flow;
use reckon::sensitivity::{self, SensitivityOptions};
use reckon::{Controls, Error, Lti, Options, Problem};

fn double_integrator() -> Lti<nalgebra::Const<2>> {
    Lti::new(Matrix2::new(0.0, 1.0, 0.0, 0.0), Vector2::new(0.0, 1.0)).unwrap()
}

#[test]
fn double_integrator_closed_forms() {
    let lti = double_integrator();
    for h in [1e-3, 0.1, 0.7, 3.0, 40.0] {
        let (phi, gamma) = lti.discretise(h).unwrap();
        let want_phi = Matrix2::new(1.0, h, 0.0, 1.0);
        let want_gamma = [h * h / 2.0, h];
        let scale = 1f64.max(h * h);
        assert!((phi - want_phi).amax() <= 1e-14 * scale, "h = {h}: Φ = {phi}");
        assert!(
            (gamma[(0, 0)] - want_gamma[0]).abs() <= 1e-14 * scale,
            "h = {h}: Γ = {gamma}"
        );
        assert!(
            (gamma[(1, 0)] - want_gamma[1]).abs() <= 1e-14 * scale,
            "h = {h}: Γ = {gamma}"
        );
        // white acceleration of density q: Q_d = q·[[h³/3, h²/2], [h²/2, h]]
        let q = 0.3;
        let qd = discretise_noise(lti.a(), &Vector2::new(0.0, 1.0), &Matrix1::new(q), h).unwrap();
        let want = Matrix2::new(h.powi(3) / 3.0, h * h / 2.0, h * h / 2.0, h) * q;
        for (got, w) in qd.iter().zip(want.iter()) {
            assert!(
                (got - w).abs() <= 1e-14 * w.abs().max(1.0),
                "h = {h}: Q_d = {qd}, want {want}"
            );
        }
    }
}

#[test]
fn exact_solve_with_controls_lands_every_breakpoint() {
    // accelerate 1 m/s² for 2 s, coast 1 s, brake −2 m/s² for 1 s
    let lti = double_integrator();
    let c = Controls::new(vec![0.0, 2.0, 3.0], vec![vec![1.0], vec![0.0], vec![-2.0]]).unwrap();
    let sol = Problem::new(&lti, vector![0.0, 0.0], (0.0, 4.0))
        .controls(c)
        .solve(Exact::new(lti.flow()), &Options::default())
        .unwrap();
    assert_eq!(sol.t, vec![0.0, 2.0, 3.0, 4.0]);
    let want = [[0.0, 0.0], [2.0, 2.0], [4.0, 2.0], [5.0, 0.0]];
    for (x, w) in sol.x.iter().zip(want) {
        assert!(
            (x[0] - w[0]).abs() < 1e-14 && (x[1] - w[1]).abs() < 1e-15,
            "{x} vs {w:?}"
        );
    }
    // a fixed grid finer than the log: the same end state to rounding
    let c = Controls::new(vec![0.0, 2.0, 3.0], vec![vec![1.0], vec![0.0], vec![-2.0]]).unwrap();
    let fine = Problem::new(&lti, vector![0.0, 0.0], (0.0, 4.0))
        .controls(c)
        .solve(Exact::new(lti.flow()), &Options::default().fixed(0.01))
        .unwrap();
    assert_eq!(fine.stats.accepted, 400);
    assert!((fine.last().1 - vector![5.0, 0.0]).amax() < 1e-12);
}

#[test]
fn flow_properties() {
    let a = Matrix2::new(-0.3, 2.0, -2.0, -0.1);
    let lti = Lti::new(a, Matrix2::new(1.0, 0.0, 0.5, 1.0)).unwrap();
    let (x, u) = (vector![1.0, -2.0], [0.7, -0.2]);
    let flow = lti.flow();
    let mut out = x;
    // φ₀ = id, exactly
    flow.flow(0.0, &x, &u, 0.0, &mut out);
    assert_eq!(out, x);
    // φ_{h₁+h₂} = φ_{h₂} ∘ φ_{h₁} with u held
    for (h1, h2) in [(0.1, 0.25), (1.0, 2.5), (0.013, 7.0)] {
        let (mut a1, mut a12, mut b) = (x, x, x);
        flow.flow(0.0, &x, &u, h1, &mut a1);
        flow.flow(h1, &a1, &u, h2, &mut a12);
        flow.flow(0.0, &x, &u, h1 + h2, &mut b);
        assert!(
            (a12 - b).amax() <= 1e-14 * b.amax().max(1.0),
            "{h1} + {h2}: {a12} vs {b}"
        );
    }
    // and it is the flow of x' = A x + B u: matches RK45 at tight tolerance
    let p = Problem::new(&lti, x, (0.0, 3.0)).inputs(u.to_vec());
    let rk = p.solve(Rk45, &Options::default().rtol(1e-13).atol(1e-15)).unwrap();
    flow.flow(0.0, &x, &u, 3.0, &mut out);
    assert!(
        (rk.last().1 - out).amax() < 1e-11 * out.amax(),
        "{} vs {out}",
        rk.last().1
    );
}

#[test]
fn sensitivities_of_the_exact_flow_are_the_transition_matrix() {
    let a = Matrix2::new(-1.0, 1.0, 0.0, -2.0);
    let lti = Lti::new(a, Vector2::new(1.0, 1.0)).unwrap();
    let p = Problem::new(&lti, vector![1.0, 2.0], (0.0, 1.5)).inputs(vec![0.5]);
    let s = sensitivity::solve(
        &p,
        Exact::new(lti.flow()),
        &Options::default(),
        &SensitivityOptions::default(),
    )
    .unwrap();
    let k = s.t.len() - 1;
    let t = 1.5f64;
    let (e1, e2) = ((-t).exp(), (-2.0 * t).exp());
    let want = DMatrix::from_row_slice(2, 2, &[e1, e1 - e2, 0.0, e2]);
    assert!((s.wrt_x0(k) - want).amax() < 1e-15, "{}", s.wrt_x0(k));
}

#[test]
fn dynamic_size_and_bad_input() {
    let a = DMatrix::from_row_slice(3, 3, &[-1.0, 0.0, 0.0, 1.0, -2.0, 0.0, 0.0, 1.0, -3.0]);
    let b = DMatrix::from_column_slice(3, 1, &[1.0, 0.0, 0.0]);
    let lti = Lti::<Dyn>::new(a.clone(), b.clone()).unwrap();
    let p = Problem::new(&lti, DVector::from_vec(vec![0.0, 0.0, 0.0]), (0.0, 2.0)).inputs(vec![1.0]);
    let ex = p.solve(Exact::new(lti.flow()), &Options::default()).unwrap();
    let rk = p.solve(Rk45, &Options::default().rtol(1e-13).atol(1e-15)).unwrap();
    assert!((ex.last().1 - rk.last().1).amax() < 1e-12);
    // x₁' = −x₁ + 1 from 0: 1 − e^{−t}
    assert!((ex.last().1[0] - (-(-2.0f64).exp_m1())).abs() < 1e-15);
    // shapes that do not match, non-finite entries, a non-finite step
    let e = Lti::<Dyn>::new(a.clone(), DMatrix::zeros(2, 1)).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "lti", .. }), "{e}");
    let e = Lti::<Dyn>::new(DMatrix::zeros(3, 2), b.clone()).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "lti", .. }), "{e}");
    let e = Lti::new(Matrix1::new(f64::NAN), Vector1::new(1.0)).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "lti", .. }), "{e}");
    assert!(matches!(
        lti.discretise(f64::INFINITY),
        Err(Error::InvalidInput { what: "h", .. })
    ));
    // an exponential that overflows is an error, not a silent infinity
    let grow = Lti::new(Matrix1::new(1000.0), Vector1::new(0.0)).unwrap();
    assert!(matches!(
        grow.discretise(10.0),
        Err(Error::InvalidInput { what: "matrix", .. })
    ));
    let e = Problem::new(&grow, vector![1.0], (0.0, 10.0))
        .inputs(vec![0.0])
        .solve(Exact::new(grow.flow()), &Options::default())
        .unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }), "{e}");
    // discretise_noise checks its sizes and step
    let g = DMatrix::identity(3, 3);
    let e = discretise_noise(&a, &g, &DMatrix::identity(2, 2), 0.1).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "noise", .. }), "{e}");
    let e = discretise_noise(&a, &g, &DMatrix::identity(3, 3), -0.1).unwrap_err();
    assert!(matches!(e, Error::InvalidInput { what: "h", .. }), "{e}");
}

#[test]
fn van_loan_matches_the_integral_for_a_stiff_system() {
    // diagonal A: Q_d[i][j] = q_ij (e^{(a_i + a_j) h} − 1)/(a_i + a_j), even where e^{−Ah}
    // overflows (h = 2: e^{6000}). The bound is the exponential's own conditioning: the
    // relative condition number of e^{Ah} is about ‖A‖·h (here up to 6000), and scaling
    // and squaring loses that much (Higham 2005), for e^{Ah} itself as for Q_d.
    let a = DMatrix::from_diagonal(&DVector::from_vec(vec![-0.5, -40.0, -3000.0]));
    let q = DMatrix::from_row_slice(3, 3, &[2.0, 0.3, 0.1, 0.3, 1.0, 0.2, 0.1, 0.2, 0.5]);
    for h in [1e-4, 0.01, 0.5, 2.0] {
        let qd = discretise_noise(&a, &DMatrix::identity(3, 3), &q, h).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let s = a[(i, i)] + a[(j, j)];
                let want = q[(i, j)] * (s * h).exp_m1() / s;
                let bound = 4.0 * f64::EPSILON * (3000.0 * h).max(1.0);
                let r = (qd[(i, j)] - want).abs() / want.abs();
                println!("h = {h} ({i}, {j}): relative error {r:.2e}, bound {bound:.2e}");
                assert!(r <= bound, "h = {h} ({i}, {j}): {} vs {want}", qd[(i, j)]);
            }
        }
    }
}

#[test]
fn one_hour_figure_from_the_continuous_model() {
    // velocity measured every dt = 0.1 s with σ_v = 1 m/s per axis: a white velocity
    // error of density q = σ_v²·dt on x' = v; Q_d over dt from Van Loan, 36 000 predictions
    let (dt, sv) = (0.1f64, 1.0f64);
    let a = Matrix2::zeros();
    let q = Matrix2::identity() * (sv * sv * dt);
    let qd = discretise_noise(&a, &Matrix2::identity(), &q, dt).unwrap();
    let (phi, _) = Lti::new(a, Matrix2::identity()).unwrap().discretise(dt).unwrap();
    let mut k = Kalman::new(Vector2::zeros(), Matrix2::zeros());
    for _ in 0..36_000 {
        k.predict(&phi, &Vector2::new(0.1, 0.0), &qd).unwrap();
    }
    let sigma = k.p[(0, 0)].sqrt();
    assert!((sigma - 360f64.sqrt()).abs() < 1e-9, "σ = {sigma}");
    assert!((sigma - 18.97).abs() < 0.005);
    // and in one step of an hour
    let qh = discretise_noise(&a, &Matrix2::identity(), &q, 3600.0).unwrap();
    assert!((qh[(0, 0)].sqrt() - 360f64.sqrt()).abs() < 1e-12 && qh[(0, 1)] == 0.0);
}

/// Run-averaged NEES of a constant-velocity Kalman filter (position measured every `h`
/// with σ = 1, white acceleration of density `q`) against a truth simulated on its own:
/// 200 sub-steps per interval, each with a held acceleration `N(0, q/δ)` integrated
/// exactly, so the truth's process noise converges to `∫ e^{As} G q Gᵀ e^{Aᵀs} ds`
/// without using it. Returns the mean NEES at each of the `steps` corrections.
fn constant_velocity_nees(qd: &Matrix2<f64>, q: f64, h: f64, runs: usize, steps: usize) -> Vec<f64> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let (phi, _) = double_integrator().discretise(h).unwrap();
    let (sub, c, r) = (200, nalgebra::Matrix1x2::new(1.0, 0.0), Matrix1::new(1.0));
    let delta = h / sub as f64;
    let mut nees = vec![0.0; steps];
    for run in 0..runs {
        let mut rng = rand::rngs::StdRng::seed_from_u64(0xc0ffee + run as u64);
        let mut n = || -> f64 { StandardNormal.sample(&mut rng) };
        let p0 = Matrix2::identity();
        let mut truth = Vector2::new(n(), n());
        let mut kf = Kalman::new(Vector2::zeros(), p0);
        for nk in nees.iter_mut() {
            for _ in 0..sub {
                let acc = n() * (q / delta).sqrt();
                truth = Vector2::new(
                    truth[0] + truth[1] * delta + acc * delta * delta / 2.0,
                    truth[1] + acc * delta,
                );
            }
            kf.predict(&phi, &Vector2::zeros(), qd).unwrap();
            kf.correct(&Vector1::new(truth[0] + n()), &c, &r).unwrap();
            let e = truth - kf.x;
            *nk += (e.transpose() * kf.p.try_inverse().unwrap() * e)[(0, 0)] / runs as f64;
        }
    }
    nees
}

#[test]
fn constant_velocity_filter_is_consistent_with_van_loan_noise() {
    let (q, h, runs, steps) = (0.5, 1.0, 2000, 30);
    let a = Matrix2::new(0.0, 1.0, 0.0, 0.0);
    let qd = discretise_noise(&a, &Vector2::new(0.0, 1.0), &Matrix1::new(q), h).unwrap();
    // the run average of a χ²₂ NEES times `runs` is χ² with 2·runs degrees of freedom;
    // 99.9 % two-sided band at each step
    let (lo, hi) = reckon::ensemble::stats::chi2_interval(2.0 * runs as f64, 3.2905);
    let (lo, hi) = (lo / runs as f64, hi / runs as f64);
    let good = constant_velocity_nees(&qd, q, h, runs, steps);
    for (k, v) in good.iter().enumerate() {
        assert!(*v > lo && *v < hi, "step {k}: NEES {v} outside [{lo}, {hi}]");
    }
    // the Euler approximation G q Gᵀ h drops the h³/3 position variance and the h²/2
    // correlation (their difference is indefinite): the filter is inconsistent, here
    // too cautious, with the NEES below the band
    let euler = Matrix2::new(0.0, 0.0, 0.0, q * h);
    let bad = constant_velocity_nees(&euler, q, h, runs, steps);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    eprintln!(
        "NEES Van Loan {:.3}, Euler {:.3}, band [{lo:.3}, {hi:.3}]",
        mean(&good),
        mean(&bad)
    );
    assert!(bad.iter().skip(3).all(|v| *v < lo), "{bad:?}");
}

/// `A = V·Λ·V⁻¹` with a well-conditioned, non-normal `V` and a block-diagonal `Λ`:
/// real eigenvalues `−10^e`, and (for `n ≥ 2`) one complex pair; the reference
/// solution with a held `u` comes from the blocks of `Λ` in closed form.
struct Case {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    v: DMatrix<f64>,
    vinv: DMatrix<f64>,
    lam: Vec<f64>,
    pair: Option<(f64, f64)>,
    lam_max: f64,
}

fn case(n: usize, exps: &[f64], mix: &[f64], pair: (f64, f64), bs: &[f64]) -> Case {
    let mut v = DMatrix::identity(n, n);
    for i in 0..n {
        for j in 0..n {
            v[(i, j)] += 0.4 * mix[i * 8 + j] / n as f64;
        }
    }
    let vinv = v.clone().try_inverse().unwrap();
    let lam: Vec<f64> = exps.iter().take(n).map(|e| -(10f64.powf(*e))).collect();
    let mut l = DMatrix::from_diagonal(&DVector::from_vec(lam.clone()));
    let pair = (n >= 2).then(|| (-(10f64.powf(pair.0)), 10f64.powf(pair.1)));
    if let Some((re, im)) = pair {
        l[(0, 0)] = re;
        l[(1, 1)] = re;
        l[(0, 1)] = -im;
        l[(1, 0)] = im;
    }
    let lam_max = (0..n)
        .map(|i| match pair {
            Some((re, im)) if i < 2 => re.hypot(im),
            _ => -lam[i],
        })
        .fold(0.0, f64::max);
    let a = &v * l * &vinv;
    let b = DMatrix::from_column_slice(n, 2, &bs[..2 * n]);
    Case {
        a,
        b,
        v,
        vinv,
        lam,
        pair,
        lam_max,
    }
}

/// `x(t) = V·(e^{Λt}·V⁻¹x₀ + Λ⁻¹(e^{Λt} − I)·V⁻¹B u)` block by block.
fn reference(c: &Case, x0: &DVector<f64>, u: &[f64], t: f64) -> DVector<f64> {
    let n = x0.len();
    let y0 = &c.vinv * x0;
    let g = &c.vinv * &c.b * DVector::from_column_slice(u);
    let mut y = DVector::zeros(n);
    let start = if let Some((re, im)) = c.pair {
        // block [[re, −im], [im, re]]: e^{Λt} = e^{re t} R(im t); Λ⁻¹(e^{Λt} − I) via the complex number
        let z = num_complex::Complex64::new(re, im);
        let ez = (z * t).exp();
        let w = (ez - 1.0) / z;
        let rot = |c: num_complex::Complex64, v: [f64; 2]| [c.re * v[0] - c.im * v[1], c.im * v[0] + c.re * v[1]];
        let a = rot(ez, [y0[0], y0[1]]);
        let b = rot(w, [g[0], g[1]]);
        y[0] = a[0] + b[0];
        y[1] = a[1] + b[1];
        2
    } else {
        0
    };
    for i in start..n {
        let l = c.lam[i];
        y[i] = (l * t).exp() * y0[i] + (l * t).exp_m1() / l * g[i];
    }
    &c.v * y
}

fn rel(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    /// Random stable `A` up to 8×8, eigenvalue magnitudes over 6 decades (1e-3 … 1e3):
    /// the exact flow agrees with RK45 at rtol 1e-13 to 1e-10 relative, with the
    /// eigen-decomposition reference to 1e-12, and stays exact (1e-11) at steps 100× the
    /// explicit stability limit, where RK45 would need 100 steps per step.
    #[test]
    fn random_stable_systems(
        n in 1usize..=8,
        exps in prop::collection::vec(-3.0f64..3.0, 8),
        mix in prop::collection::vec(-1.0f64..1.0, 64),
        pair in (-3.0f64..2.0, -1.0f64..2.5),
        bs in prop::collection::vec(-1.0f64..1.0, 16),
        x0s in prop::collection::vec(-1.0f64..1.0, 8),
    ) {
        let c = case(n, &exps, &mix, pair, &bs);
        let lti = Lti::<Dyn>::new(c.a.clone(), c.b.clone()).unwrap();
        let x0 = DVector::from_column_slice(&x0s[..n]);
        let u = [0.8, -0.3];
        let p = Problem::new(&lti, x0.clone(), (0.0, 1.0)).inputs(u.to_vec());
        let ex = p.solve(Exact::new(lti.flow()), &Options::default()).unwrap();
        prop_assert_eq!(ex.stats.accepted, 1);
        let want = reference(&c, &x0, &u, 1.0);
        prop_assert!(rel(ex.last().1, &want) < 1e-12, "vs reference: {:e}", rel(ex.last().1, &want));
        let rk = p.solve(Rk45, &Options::default().rtol(1e-13).atol(1e-16)).unwrap();
        prop_assert!(rel(ex.last().1, rk.last().1) < 1e-10, "vs RK45: {:e}", rel(ex.last().1, rk.last().1));
        // 100× RK45's stability limit (|hλ| ≈ 3.3 on the negative axis), 20 steps
        let h = 100.0 * 3.3 / c.lam_max;
        let q = Problem::new(&lti, x0.clone(), (0.0, 20.0 * h)).inputs(u.to_vec());
        let big = q.solve(Exact::new(lti.flow()), &Options::default().fixed(h)).unwrap();
        prop_assert_eq!(big.stats.accepted, 20);
        let want = reference(&c, &x0, &u, 20.0 * h);
        prop_assert!(rel(big.last().1, &want) < 1e-11, "h = {h:e}: {:e}", rel(big.last().1, &want));
    }
}

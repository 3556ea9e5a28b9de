//! Lie groups and IMU preintegration: group identities on random elements (proptest),
//! the Jacobians against central differences of `exp`/`log` and against their defining
//! series `Σ (±ad)ⁿ/(n+1)!`, `exp` against the matrix exponential, all near 0, at the
//! Taylor switch and near π; preintegration against GTSAM's reference values
//! (`tests/golden/lie/gtsam_preintegration.json`, made by
//! `docs/lie/gtsam_preintegration.py`), against closed forms and against reckon's own
//! strapdown integration.

use nalgebra::{Matrix2, Matrix3, Matrix4, Matrix6, SMatrix, Vector3, Vector6, vector};
use proptest::prelude::*;
use reckon::lie::{Se2, Se3, So3, hat};
use reckon::reckoning::imu::{ImuSample, Nav, strapdown};
use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
use std::f64::consts::PI;

// ---------------------------------------------------------------- references

/// Rotation angles checked explicitly: 0, near 0, both sides of the series switches at
/// 10⁻² and 0.1, ordinary, and near π.
const ANGLES: [f64; 13] = [
    0.0,
    1e-12,
    1e-9,
    1e-5,
    0.0099999,
    0.0100001,
    0.0999999,
    0.1000001,
    0.3,
    1.0,
    2.5,
    PI - 1e-3,
    PI - 1e-7,
];

/// `exp(M)` by scaling and squaring a 30-term Taylor series: independent of the closed forms.
fn expm<const N: usize>(m: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    let norm = m.amax() * N as f64;
    let k = if norm > 0.25 {
        (norm / 0.25).log2().ceil() as i32
    } else {
        0
    };
    let a = m / 2f64.powi(k);
    let (mut term, mut sum) = (SMatrix::<f64, N, N>::identity(), SMatrix::<f64, N, N>::identity());
    for n in 1..30 {
        term = term * a / n as f64;
        sum += term;
    }
    for _ in 0..k {
        sum = sum * sum;
    }
    sum
}

/// `Σ_{n≥0} adⁿ/(n+1)!`: the left Jacobian for `ad_ξ`, the right one for `−ad_ξ`.
fn jacobian_series<const N: usize>(ad: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    let (mut term, mut sum) = (SMatrix::<f64, N, N>::identity(), SMatrix::<f64, N, N>::identity());
    for n in 1..60 {
        term = term * ad / (n + 1) as f64;
        sum += term;
    }
    sum
}

/// se(3) adjoint in (φ, ρ) order: `[[Φ, 0], [P, Φ]]`.
fn ad3(xi: &Vector6<f64>) -> Matrix6<f64> {
    let (f, p) = (
        hat(&xi.fixed_rows::<3>(0).into_owned()),
        hat(&xi.fixed_rows::<3>(3).into_owned()),
    );
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&f);
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&p);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&f);
    m
}

/// se(2) adjoint in (ρ, θ) order: `[[θJ, (ρ_y, −ρ_x)ᵀ], [0, 0]]`.
fn ad2(xi: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -xi[2], xi[1], xi[2], 0.0, -xi[0], 0.0, 0.0, 0.0)
}

fn se3_hat(xi: &Vector6<f64>) -> Matrix4<f64> {
    let mut m = Matrix4::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&hat(&xi.fixed_rows::<3>(0).into_owned()));
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&xi.fixed_rows::<3>(3));
    m
}

fn se2_hat(xi: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -xi[2], xi[0], xi[2], 0.0, xi[1], 0.0, 0.0, 0.0)
}

/// Central differences of `δ ↦ f(δ)` at 0, column by column.
fn central<const N: usize>(h: f64, f: impl Fn(&SMatrix<f64, N, 1>) -> SMatrix<f64, N, 1>) -> SMatrix<f64, N, N> {
    let mut j = SMatrix::<f64, N, N>::zeros();
    for k in 0..N {
        let mut e = SMatrix::<f64, N, 1>::zeros();
        e[k] = h;
        j.set_column(k, &((f(&e) - f(&-e)) / (2.0 * h)));
    }
    j
}

/// A vector of length `len` along the unit vector of `dir`.
fn along3(dir: &Vector3<f64>, len: f64) -> Vector3<f64> {
    dir.normalize() * len
}

// ---------------------------------------------------------------- SO(3)

/// Every identity of SO(3) at `φ`; `tol` for those that hold to rounding.
fn check_so3(phi: &Vector3<f64>, tol: f64) {
    let r = So3::exp(phi);
    // exp against the matrix exponential
    assert!((r.matrix() - expm(&hat(phi))).amax() < tol, "exp at {phi}");
    // orthonormal
    assert!((r.matrix().transpose() * r.matrix() - Matrix3::identity()).amax() < 1e-14);
    // exp(log g) = g for every φ, log(exp φ) = φ inside |φ| < π
    assert!((So3::exp(&r.log()).matrix() - r.matrix()).amax() < tol);
    if phi.norm() < PI {
        assert!(
            (r.log() - phi).norm() < tol * phi.norm().max(1.0),
            "log(exp) at {phi}: {}",
            r.log() - phi
        );
    }
    // Jacobians against their series, then against central differences of exp
    let (jr, jl) = (So3::right_jacobian(phi), So3::left_jacobian(phi));
    assert!((jr - jacobian_series(&-hat(phi))).amax() < tol, "J_r series at {phi}");
    assert!((jl - jacobian_series(&hat(phi))).amax() < tol, "J_l series at {phi}");
    let h = 1e-6;
    let jr_fd = central(h, |d| (r.inverse() * So3::exp(&(phi + d))).log());
    let jl_fd = central(h, |d| (So3::exp(&(phi + d)) * r.inverse()).log());
    assert!(
        (jr - jr_fd).amax() < 1e-8,
        "J_r vs differences at {phi}: {:e}",
        (jr - jr_fd).amax()
    );
    assert!(
        (jl - jl_fd).amax() < 1e-8,
        "J_l vs differences at {phi}: {:e}",
        (jl - jl_fd).amax()
    );
    // inverses
    assert!((So3::right_jacobian_inv(phi) * jr - Matrix3::identity()).amax() < tol);
    assert!((So3::left_jacobian_inv(phi) * jl - Matrix3::identity()).amax() < tol);
}

#[test]
fn so3_near_zero_at_the_switch_and_near_pi() {
    let dirs = [vector![1.0, 0.0, 0.0], vector![0.3, -0.5, 0.8], vector![-1.0, 2.0, 0.5]];
    for d in &dirs {
        for len in ANGLES {
            check_so3(&along3(d, len), 1e-13);
        }
    }
    // log at π − 1e-7 keeps the angle: the quaternion path divides by no small number
    let phi = along3(&dirs[1], PI - 1e-7);
    let err = (So3::exp(&phi).log() - phi).norm();
    assert!(err < 1e-14, "{err:e}");
    // at exactly π, log returns ±π·u
    let l = So3::exp(&along3(&dirs[2], PI)).log();
    assert!((l.norm() - PI).abs() < 1e-14 && (l.normalize().cross(&dirs[2].normalize())).norm() < 1e-14);
}

#[test]
fn so3_jacobian_inverses_are_derivatives_of_log() {
    // Log(Exp(φ)·Exp(δ)) ≈ φ + J_r⁻¹(φ)·δ and Log(Exp(δ)·Exp(φ)) ≈ φ + J_l⁻¹(φ)·δ
    for phi in [vector![0.1, 0.2, -0.3], vector![1.0, -2.0, 1.5], vector![0.0, 0.0, 3.0]] {
        let r = So3::exp(&phi);
        let fd = central(1e-6, |d| (r * So3::exp(d)).log());
        assert!((fd - So3::right_jacobian_inv(&phi)).amax() < 1e-8);
        let fd = central(1e-6, |d| (So3::exp(d) * r).log());
        assert!((fd - So3::left_jacobian_inv(&phi)).amax() < 1e-8);
    }
}

#[test]
fn so3_from_matrix_rejects_what_is_not_a_rotation() {
    let r = So3::exp(&vector![0.3, 0.1, -0.2]).matrix();
    assert!(So3::from_matrix(r).is_ok());
    assert!(So3::from_matrix(r * 1.001).is_err());
    assert!(So3::from_matrix(-r).is_err());
    let mut nan = r;
    nan[(0, 0)] = f64::NAN;
    assert!(So3::from_matrix(nan).is_err());
}

// ---------------------------------------------------------------- SE(3)

fn check_se3(xi: &Vector6<f64>, tol: f64) {
    let g = Se3::exp(xi);
    assert!(
        (g.matrix() - expm(&se3_hat(xi))).amax() < tol * xi.norm().max(1.0),
        "exp at {xi}"
    );
    assert!((Se3::exp(&g.log()).matrix() - g.matrix()).amax() < tol * xi.norm().max(1.0));
    if xi.fixed_rows::<3>(0).norm() < PI {
        assert!(
            (g.log() - xi).norm() < tol * xi.norm().max(1.0),
            "log(exp) at {xi}: {:e}",
            (g.log() - xi).norm()
        );
    }
    let (jr, jl) = (Se3::right_jacobian(xi), Se3::left_jacobian(xi));
    assert!(
        (jr - jacobian_series(&-ad3(xi))).amax() < tol * xi.norm().max(1.0),
        "J_r series at {xi}"
    );
    assert!(
        (jl - jacobian_series(&ad3(xi))).amax() < tol * xi.norm().max(1.0),
        "J_l series at {xi}"
    );
    let h = 1e-6;
    let jr_fd = central(h, |d| (g.inverse() * Se3::exp(&(xi + d))).log());
    let jl_fd = central(h, |d| (Se3::exp(&(xi + d)) * g.inverse()).log());
    let scale = xi.norm().max(1.0);
    assert!(
        (jr - jr_fd).amax() < 1e-8 * scale,
        "J_r vs differences at {xi}: {:e}",
        (jr - jr_fd).amax()
    );
    assert!(
        (jl - jl_fd).amax() < 1e-8 * scale,
        "J_l vs differences at {xi}: {:e}",
        (jl - jl_fd).amax()
    );
    assert!((Se3::right_jacobian_inv(xi) * jr - Matrix6::identity()).amax() < tol * scale);
    assert!((Se3::left_jacobian_inv(xi) * jl - Matrix6::identity()).amax() < tol * scale);
}

fn six(phi: &Vector3<f64>, rho: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(phi[0], phi[1], phi[2], rho[0], rho[1], rho[2])
}

#[test]
fn se3_near_zero_at_the_switch_and_near_pi() {
    let rho = vector![0.7, -1.2, 2.0];
    for d in [vector![1.0, 0.0, 0.0], vector![0.3, -0.5, 0.8]] {
        for len in ANGLES {
            check_se3(&six(&along3(&d, len), &rho), 1e-13);
            check_se3(&six(&along3(&d, len), &(rho * 1e-9)), 1e-13);
        }
    }
}

#[test]
fn se3_q_block_on_both_sides_of_the_series_switch_matches_the_series_jacobian() {
    // just below and above θ = 0.1, where c₂ and c₃ change branch, Q is the lower-left
    // block of Σ adⁿ/(n+1)! to rounding (c₂, c₃ in closed form are 6e-13 off at 0.1)
    let (rho, d) = (vector![1.0, 2.0, 3.0], vector![0.6, 0.0, 0.8]);
    for len in [0.1 - 1e-12, 0.1 + 1e-12, 0.01 - 1e-12, 0.01 + 1e-12] {
        let phi = along3(&d, len);
        let series = jacobian_series(&ad3(&six(&phi, &rho)))
            .fixed_view::<3, 3>(3, 0)
            .into_owned();
        let e = (Se3::q_block(&phi, &rho) - series).amax();
        // the series branch to rounding; the closed forms just above 0.1 within 3e-14
        assert!(e < if len < 0.1 { 2e-15 } else { 5e-14 }, "at {len}: {e:e}");
    }
}

#[test]
fn se3_matches_gtsam_pose3_conventions() {
    // Pose3::Expmap((ω, v)) with ω = (0, 0, π/2), v = (1, 0, 0): R = Rz(π/2),
    // t = J_l(ω)·v = (sin θ/θ, (1 − cos θ)/θ, 0) = (2/π, 2/π, 0)
    let g = Se3::exp(&vector![0.0, 0.0, PI / 2.0, 1.0, 0.0, 0.0]);
    assert!((g.translation - vector![2.0 / PI, 2.0 / PI, 0.0]).norm() < 1e-15);
    // AdjointMap = [[R, 0], [[t]×R, R]]
    let ad = g.adjoint();
    let r = g.rotation.matrix();
    assert!((ad.fixed_view::<3, 3>(3, 0) - hat(&g.translation) * r).amax() < 1e-15);
    assert_eq!(ad.fixed_view::<3, 3>(0, 3), Matrix3::zeros());
}

// ---------------------------------------------------------------- SE(2)

fn check_se2(xi: &Vector3<f64>, tol: f64) {
    let g = Se2::exp(xi);
    let scale = xi.norm().max(1.0);
    assert!((g.matrix() - expm(&se2_hat(xi))).amax() < tol * scale, "exp at {xi}");
    assert!((Se2::exp(&g.log()).matrix() - g.matrix()).amax() < tol * scale);
    if xi[2].abs() < PI {
        assert!((g.log() - xi).norm() < tol * scale, "log(exp) at {xi}");
    }
    let (jr, jl) = (Se2::right_jacobian(xi), Se2::left_jacobian(xi));
    assert!(
        (jr - jacobian_series(&-ad2(xi))).amax() < tol * scale,
        "J_r series at {xi}"
    );
    assert!(
        (jl - jacobian_series(&ad2(xi))).amax() < tol * scale,
        "J_l series at {xi}"
    );
    let h = 1e-6;
    let jr_fd = central(h, |d| (g.inverse() * Se2::exp(&(xi + d))).log());
    let jl_fd = central(h, |d| (Se2::exp(&(xi + d)) * g.inverse()).log());
    assert!((jr - jr_fd).amax() < 1e-8 * scale, "J_r vs differences at {xi}");
    assert!((jl - jl_fd).amax() < 1e-8 * scale, "J_l vs differences at {xi}");
    assert!((Se2::right_jacobian_inv(xi) * jr - Matrix3::identity()).amax() < tol * scale);
    assert!((Se2::left_jacobian_inv(xi) * jl - Matrix3::identity()).amax() < tol * scale);
}

#[test]
fn se2_near_zero_at_the_switch_and_near_pi() {
    for (x, y) in [(0.7, -1.2), (1e-9, 2e-9), (0.0, 0.0)] {
        for th in ANGLES {
            check_se2(&vector![x, y, th], 1e-13);
            check_se2(&vector![x, y, -th], 1e-13);
        }
    }
}

#[test]
fn se2_matches_gtsam_pose2_conventions() {
    // Pose2::AdjointMap = [[c, −s, y], [s, c, −x], [0, 0, 1]]
    let g = Se2::new(0.3, vector![2.0, -1.0]);
    let (s, c) = 0.3f64.sin_cos();
    let expected = Matrix3::new(c, -s, -1.0, s, c, -2.0, 0.0, 0.0, 1.0);
    assert!((g.adjoint() - expected).amax() < 1e-15);
    // exp(ρ, θ) is the unicycle arc: radius v/ω about (0, v/ω)
    let e = Se2::exp(&vector![2.0, 0.0, 1.0]);
    assert!((e.translation - vector![2.0 * 1f64.sin(), 2.0 * (1.0 - 1f64.cos())]).norm() < 1e-15);
    assert_eq!(e.angle(), 1.0);
    assert_eq!(
        e.rotation(),
        Matrix2::new(1f64.cos(), -1f64.sin(), 1f64.sin(), 1f64.cos())
    );
}

// ---------------------------------------------------------------- proptest

fn vec3(r: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-r..r, -r..r, -r..r).prop_map(|(a, b, c)| vector![a, b, c])
}

proptest! {
    #[test]
    fn so3_identities_on_random_elements(phi in vec3(1.8), psi in vec3(1.0), big in vec3(10.0)) {
        prop_assume!(phi.norm() < PI - 1e-3);
        check_so3(&phi, 1e-13);
        // exp(log g) = g beyond the injectivity radius
        let g = So3::exp(&big);
        prop_assert!((So3::exp(&g.log()).matrix() - g.matrix()).amax() < 1e-13);
        prop_assert!(g.log().norm() <= PI + 1e-15);
        // Ad against conjugation
        let conj = g * So3::exp(&psi) * g.inverse();
        prop_assert!((conj.matrix() - So3::exp(&(g.adjoint() * psi)).matrix()).amax() < 1e-14);
        // action is the matrix product
        prop_assert!((g.act(&psi) - g.matrix() * psi).norm() < 1e-15);
    }

    #[test]
    fn se3_identities_on_random_elements(phi in vec3(1.8), rho in vec3(5.0), psi in vec3(1.0), v in vec3(2.0), big in vec3(10.0), p in vec3(3.0)) {
        prop_assume!(phi.norm() < PI - 1e-3);
        let xi = six(&phi, &rho);
        check_se3(&xi, 1e-13);
        let g = Se3::exp(&six(&big, &rho));
        prop_assert!((Se3::exp(&g.log()).matrix() - g.matrix()).amax() < 1e-12);
        let eta = six(&psi, &v);
        let conj = g * Se3::exp(&eta) * g.inverse();
        prop_assert!((conj.matrix() - Se3::exp(&(g.adjoint() * eta)).matrix()).amax() < 1e-12);
        // composition and action agree with the 4×4 matrices
        let h = Se3::exp(&eta);
        prop_assert!(((g * h).matrix() - g.matrix() * h.matrix()).amax() < 1e-13);
        let ph = g.matrix() * nalgebra::Vector4::new(p[0], p[1], p[2], 1.0);
        prop_assert!((g.act(&p) - ph.fixed_rows::<3>(0)).norm() < 1e-13);
        prop_assert!((g.inverse().matrix() - g.matrix().try_inverse().unwrap()).amax() < 1e-13);
    }

    #[test]
    fn se2_identities_on_random_elements(x in -5.0..5.0, y in -5.0..5.0, th in -3.1..3.1, a in -1.0..1.0, b in -1.0..1.0, c in -1.0..1.0, big in -20.0..20.0) {
        let xi = vector![x, y, th];
        check_se2(&xi, 1e-13);
        let g = Se2::exp(&vector![x, y, big]);
        prop_assert!((Se2::exp(&g.log()).matrix() - g.matrix()).amax() < 1e-12);
        let eta = vector![a, b, c];
        let conj = g * Se2::exp(&eta) * g.inverse();
        prop_assert!((conj.matrix() - Se2::exp(&(g.adjoint() * eta)).matrix()).amax() < 1e-13);
        let h = Se2::exp(&eta);
        prop_assert!(((g * h).matrix() - g.matrix() * h.matrix()).amax() < 1e-13);
        prop_assert!((g.inverse().matrix() - g.matrix().try_inverse().unwrap()).amax() < 1e-13);
    }
}

// ---------------------------------------------------------------- preintegration

/// Max over entries of |a − b| / max|b|.
fn rel<const R: usize, const C: usize>(a: &SMatrix<f64, R, C>, b: &SMatrix<f64, R, C>) -> f64 {
    (a - b).amax() / b.amax()
}

mod golden {
    use nalgebra::{Matrix3, SMatrix, Vector3};
    use serde_json::Value;

    pub fn v3(v: &Value) -> Vector3<f64> {
        Vector3::from_iterator(v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()))
    }

    pub fn mat<const N: usize>(v: &Value) -> SMatrix<f64, N, N> {
        let rows = v.as_array().unwrap();
        SMatrix::<f64, N, N>::from_fn(|i, j| rows[i][j].as_f64().unwrap())
    }

    pub fn m3(v: &Value) -> Matrix3<f64> {
        mat::<3>(v)
    }

    pub fn load() -> Value {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/golden/lie/gtsam_preintegration.json"
        );
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    }
}

#[test]
fn preintegration_matches_gtsam_manifold_preintegration() {
    use golden::*;
    let doc = load();
    assert_eq!(doc["gtsam_version"], "4.3.0");
    let cases = doc["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 4);
    let (mut inc, mut cov, mut jac, mut pred, mut tangent) = (0f64, 0f64, 0f64, 0f64, f64::INFINITY);
    for c in cases {
        let diag = |k: &str| Matrix3::from_diagonal(&v3(&c[k]).component_mul(&v3(&c[k])));
        let params = PreintegrationParams::with_gravity(v3(&c["gravity"]))
            .unwrap()
            .gyro(diag("gyro_sigma"))
            .unwrap()
            .accel(diag("accel_sigma"))
            .unwrap()
            .integration(diag("integration_sigma"))
            .unwrap();
        let bias = |b: &serde_json::Value| Bias {
            gyro: v3(&b["gyro"]),
            accel: v3(&b["accel"]),
        };
        let mut pim = Preintegrated::new(params, bias(&c["bias_hat"]));
        for s in c["samples"].as_array().unwrap() {
            pim.integrate(&v3(&s["gyro"]), &v3(&s["accel"]), s["dt"].as_f64().unwrap())
                .unwrap();
        }
        assert!((pim.delta_t() - c["delta_t"].as_f64().unwrap()).abs() < 1e-12);
        let e = (pim.delta_r().matrix() - m3(&c["delta_R"]))
            .amax()
            .max((pim.delta_p() - v3(&c["delta_p"])).amax())
            .max((pim.delta_v() - v3(&c["delta_v"])).amax());
        inc = inc.max(e);
        // the tangent-space default class is a different discretisation
        tangent = tangent.min((pim.delta_r().matrix() - m3(&c["tangent_default_class"]["delta_R"])).amax());

        // covariance, block by block
        let ours = pim.covariance_gtsam();
        let theirs = mat::<9>(&c["cov_gtsam"]);
        for bi in 0..3 {
            for bj in 0..3 {
                let a = ours.fixed_view::<3, 3>(3 * bi, 3 * bj).into_owned();
                let b = theirs.fixed_view::<3, 3>(3 * bi, 3 * bj).into_owned();
                cov = cov.max(rel(&a, &b));
            }
        }
        let j = pim.bias_jacobians();
        let bj = &c["bias_jacobians"];
        for (a, k) in [
            (j.d_rotation_d_gyro, "dR_dbg"),
            (j.d_position_d_accel, "dp_dba"),
            (j.d_position_d_gyro, "dp_dbg"),
            (j.d_velocity_d_accel, "dv_dba"),
            (j.d_velocity_d_gyro, "dv_dbg"),
        ] {
            jac = jac.max(rel(&a, &m3(&bj[k])));
        }
        let p = &c["predict"];
        let nav = Nav {
            r: m3(&p["R_i"]),
            v: v3(&p["v_i"]),
            p: v3(&p["p_i"]),
        };
        let out = pim.predict(&nav, &bias(&p["bias_i"]));
        pred = pred
            .max((out.r - m3(&p["R_j"])).amax())
            .max((out.p - v3(&p["p_j"])).amax())
            .max((out.v - v3(&p["v_j"])).amax());
    }
    eprintln!(
        "vs GTSAM 4.3.0: increments {inc:.1e}, covariance {cov:.1e} rel, bias Jacobians {jac:.1e} rel, predict {pred:.1e}; tangent class ≥ {tangent:.1e} away"
    );
    assert!(inc < 1e-9, "increments {inc:e}");
    assert!(cov < 1e-6, "covariance {cov:e}");
    assert!(jac < 1e-6, "bias Jacobians {jac:e}");
    assert!(pred < 1e-9, "predict {pred:e}");
    assert!(
        tangent > 1e-7,
        "the reference is the manifold class, not the tangent one"
    );
}

fn params(sg: f64, sa: f64, si: f64) -> PreintegrationParams {
    PreintegrationParams::up(9.81)
        .unwrap()
        .gyro(Matrix3::identity() * sg * sg)
        .unwrap()
        .accel(Matrix3::identity() * sa * sa)
        .unwrap()
        .integration(Matrix3::identity() * si * si)
        .unwrap()
}

#[test]
fn preintegration_covariance_of_a_still_imu_is_the_random_walk() {
    // free fall, no rotation (f = 0, so tilt errors do not enter δv): each sample adds
    // σ²/dt·(dt, ½dt²) through B_a, so over n samples
    // Σ_vv = σ²Δt, Σ_pv = σ²Δt²/2, Σ_pp = σ²(Δt³/3 − Δt·dt²/12), Σ_φφ = σ_g²Δt (exact sums)
    let (sg, sa, n, dt) = (1e-3, 2e-2, 250, 0.004);
    let mut pim = Preintegrated::new(params(sg, sa, 0.0), Bias::default());
    for _ in 0..n {
        pim.integrate(&Vector3::zeros(), &Vector3::zeros(), dt).unwrap();
    }
    let (t, s) = (n as f64 * dt, pim.covariance());
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    for i in 0..3 {
        assert!(close(s[(i, i)], sg * sg * t));
        assert!(close(s[(3 + i, 3 + i)], sa * sa * t));
        assert!(close(s[(6 + i, 3 + i)], sa * sa * t * t / 2.0));
        assert!(close(
            s[(6 + i, 6 + i)],
            sa * sa * (t * t * t / 3.0 - t * dt * dt / 12.0)
        ));
    }
    // integration covariance adds Σ_int·Δt to the position block
    let mut with = Preintegrated::new(params(sg, sa, 1e-3), Bias::default());
    for _ in 0..n {
        with.integrate(&Vector3::zeros(), &Vector3::zeros(), dt).unwrap();
    }
    assert!(((with.covariance() - s)[(7, 7)] - 1e-6 * t).abs() < 1e-18);
}

/// A coning, accelerating motion sampled at `n` points over 2 s.
fn smooth_samples(n: usize) -> Vec<ImuSample> {
    (0..=n)
        .map(|k| {
            let t = 2.0 * k as f64 / n as f64;
            ImuSample {
                t,
                gyro: vector![0.4 * (3.0 * t).sin(), 0.3 * (2.0 * t).cos(), 0.8],
                accel: vector![1.0 + 0.5 * (3.0 * t).sin(), 0.3 * t.cos(), 9.81 + 0.2 * t.sin()],
            }
        })
        .collect()
}

#[test]
fn preintegration_predicts_what_strapdown_integrates() {
    let nav0 = Nav {
        r: So3::exp(&vector![0.1, -0.2, 0.7]).matrix(),
        v: vector![1.0, 0.5, -0.2],
        p: vector![3.0, -1.0, 2.0],
    };
    let zero = Vector3::zeros();
    let mut errs = Vec::new();
    for n in [1000, 10000] {
        let s = smooth_samples(n);
        let pim = Preintegrated::from_samples(params(1e-3, 1e-2, 0.0), Bias::default(), &s).unwrap();
        let pred = pim.predict(&nav0, &Bias::default());
        let sd = strapdown(&s, nav0, &zero, &zero).unwrap().last().unwrap().1;
        // the rotation is the same product of exact steps
        assert!((pred.r - sd.r).amax() < 1e-12, "{:e}", (pred.r - sd.r).amax());
        // position and velocity: Forster holds ΔR over each step, strapdown averages the
        // two ends, so they part by O(dt)
        errs.push((pred.p - sd.p).norm().max((pred.v - sd.v).norm()));
    }
    let order = (errs[0] / errs[1]).log10();
    eprintln!(
        "preintegration vs strapdown: {:.2e} (n = 1000), {:.2e} (n = 10000), order {order:.3}",
        errs[0], errs[1]
    );
    assert!((order - 1.0).abs() < 0.05, "first order in dt: {order}");
    assert!(errs[1] < 4e-4, "{:e}", errs[1]);
}

#[test]
fn bias_correction_is_first_order_in_the_bias_change() {
    // re-integrating at b̂ + δb against the corrected increments: the error is O(|δb|²)
    let s = smooth_samples(500);
    let p = params(1e-3, 1e-2, 0.0);
    let pim = Preintegrated::from_samples(p, Bias::default(), &s).unwrap();
    let mut errs = Vec::new();
    for scale in [1e-2, 1e-3] {
        let b = Bias {
            gyro: vector![0.5, -0.3, 0.2] * scale,
            accel: vector![1.0, 2.0, -1.5] * scale,
        };
        let again = Preintegrated::from_samples(p, b, &s).unwrap();
        let (dr, dv, dp) = pim.corrected(&b);
        let e = (dr.inverse() * again.delta_r())
            .log()
            .norm()
            .max((dv - again.delta_v()).norm())
            .max((dp - again.delta_p()).norm());
        // and the first-order term itself is large: the Jacobians matter
        let e0 = (pim.delta_p() - again.delta_p()).norm();
        assert!(e < 0.1 * e0, "{e:e} vs {e0:e}");
        eprintln!("bias change ×{scale}: remainder {e:.2e}, first-order change {e0:.2e}");
        errs.push(e);
    }
    let order = (errs[0] / errs[1]).log10();
    assert!((order - 2.0).abs() < 0.05, "second-order remainder: {order}");
}

#[test]
fn preintegration_rejects_bad_samples() {
    let mut pim = Preintegrated::new(params(1e-3, 1e-2, 0.0), Bias::default());
    assert!(pim.integrate(&Vector3::zeros(), &Vector3::zeros(), -0.1).is_err());
    assert!(pim.integrate(&Vector3::zeros(), &Vector3::zeros(), f64::NAN).is_err());
    assert!(
        pim.integrate(&vector![f64::INFINITY, 0.0, 0.0], &Vector3::zeros(), 0.1)
            .is_err()
    );
    assert_eq!(pim.delta_t(), 0.0);
    let one = [ImuSample {
        t: 0.0,
        gyro: Vector3::zeros(),
        accel: Vector3::zeros(),
    }];
    assert!(Preintegrated::from_samples(params(1e-3, 1e-2, 0.0), Bias::default(), &one).is_err());
    let back = [one[0], ImuSample { t: -1.0, ..one[0] }];
    assert!(Preintegrated::from_samples(params(1e-3, 1e-2, 0.0), Bias::default(), &back).is_err());
    let asym = Matrix3::new(1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
    assert!(PreintegrationParams::up(9.81).unwrap().accel(asym).is_err());
}

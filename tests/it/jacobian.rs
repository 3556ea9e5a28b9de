//! Exact Jacobians by automatic differentiation: equal to analytic ones for every model
//! in the crate, and to central differences for random closures.

use nalgebra::{DMatrix, DVector, Matrix1, Matrix2, Matrix3, Matrix4, SMatrix, SVector, vector};
use proptest::prelude::*;
use reckon::studies::problems::*;
use reckon::vehicles::unicycle;
use reckon::{System, model};

fn autodiff<const N: usize>(
    f: &impl System<nalgebra::Const<N>>,
    t: f64,
    x: SVector<f64, N>,
    u: &[f64],
) -> SMatrix<f64, N, N> {
    let mut j = SMatrix::zeros();
    f.jacobian(t, &x, u, &mut j);
    j
}

fn assert_close<const N: usize>(a: &SMatrix<f64, N, N>, b: &SMatrix<f64, N, N>, what: &str) {
    let scale = b.amax().max(1e-300);
    assert!((a - b).amax() <= 1e-13 * scale, "{what}: autodiff\n{a}\nanalytic\n{b}");
}

#[test]
fn unicycle_jacobian() {
    let (th, v) = (0.7, 1.3);
    let j = autodiff(&unicycle::model(), 0.0, vector![1.0, 2.0, th], &[v, 0.4]);
    let a = Matrix3::new(0.0, 0.0, -v * th.sin(), 0.0, 0.0, v * th.cos(), 0.0, 0.0, 0.0);
    assert_close(&j, &a, "unicycle");
}

#[test]
fn problem_jacobians() {
    assert_close(
        &autodiff(&rotation_decay(), 0.0, vector![0.3, -0.2], &[]),
        &Matrix2::new(-0.5, -2.0, 2.0, -0.5),
        "rotation–decay",
    );
    assert_close(
        &autodiff(&sin_u(), 0.0, vector![0.9], &[]),
        &Matrix1::new(0.9f64.cos()),
        "sin u",
    );
    assert_close(
        &autodiff(&stiff_cosine(), 2.0, vector![0.1], &[]),
        &Matrix1::new(-1000.0),
        "stiff cosine",
    );
    let (y1, y2, mu) = (1.4, -0.3, 1000.0);
    let vdp = Matrix2::new(0.0, 1.0, -2.0 * mu * y1 * y2 - 1.0, mu * (1.0 - y1 * y1));
    assert_close(
        &autodiff(&van_der_pol(mu), 0.0, vector![y1, y2], &[]),
        &vdp,
        "Van der Pol",
    );
    let y = vector![0.9, 2e-5, 0.1];
    let rob = Matrix3::new(
        -0.04,
        1e4 * y[2],
        1e4 * y[1],
        0.04,
        -6e7 * y[1] - 1e4 * y[2],
        -1e4 * y[1],
        0.0,
        6e7 * y[1],
        0.0,
    );
    assert_close(&autodiff(&robertson(), 0.0, y, &[]), &rob, "Robertson");
    let y = vector![1.0, 2.0, 3.0];
    let lor = Matrix3::new(-10.0, 10.0, 0.0, 28.0 - y[2], -1.0, -y[0], y[1], y[0], -8.0 / 3.0);
    assert_close(&autodiff(&lorenz(), 0.0, y, &[]), &lor, "Lorenz");
    let y = vector![0.5, 0.1, -0.2, 1.1];
    let (mu, mu1) = (ARENSTORF_MU, 1.0 - ARENSTORF_MU);
    let r1 = ((y[0] + mu).powi(2) + y[1].powi(2)).sqrt();
    let r2 = ((y[0] - mu1).powi(2) + y[1].powi(2)).sqrt();
    // ∂/∂y of −m (y − c)/r³ terms: −m (I/r³ − 3 (y−c)(y−c)ᵀ/r⁵)
    let (ax, ay, bx, by) = (y[0] + mu, y[1], y[0] - mu1, y[1]);
    let j11 = 1.0
        - mu1 * (1.0 / r1.powi(3) - 3.0 * ax * ax / r1.powi(5))
        - mu * (1.0 / r2.powi(3) - 3.0 * bx * bx / r2.powi(5));
    let j12 = mu1 * 3.0 * ax * ay / r1.powi(5) + mu * 3.0 * bx * by / r2.powi(5);
    let j22 = 1.0
        - mu1 * (1.0 / r1.powi(3) - 3.0 * ay * ay / r1.powi(5))
        - mu * (1.0 / r2.powi(3) - 3.0 * by * by / r2.powi(5));
    let aren = Matrix4::new(
        0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, j11, j12, 0.0, 2.0, j12, j22, -2.0, 0.0,
    );
    assert_close(&autodiff(&arenstorf(), 0.0, y, &[]), &aren, "Arenstorf");
}

#[test]
fn brusselator_jacobian_is_exact_and_dynamic() {
    let n = 5;
    let f = brusselator(n);
    let y = brusselator_y0(n).map(|v| v * 0.9 + 0.05);
    let mut j = DMatrix::zeros(2 * n, 2 * n);
    f.jacobian(0.0, &y, &[], &mut j);
    let c = (n as f64 + 1.0).powi(2) / 50.0;
    let mut a = DMatrix::zeros(2 * n, 2 * n);
    for i in 0..n {
        let (u, v) = (y[2 * i], y[2 * i + 1]);
        let (iu, iv) = (2 * i, 2 * i + 1);
        a[(iu, iu)] = 2.0 * u * v - 4.0 - 2.0 * c;
        a[(iu, iv)] = u * u;
        a[(iv, iu)] = 3.0 - 2.0 * u * v;
        a[(iv, iv)] = -u * u - 2.0 * c;
        if i > 0 {
            a[(iu, iu - 2)] = c;
            a[(iv, iv - 2)] = c;
        }
        if i + 1 < n {
            a[(iu, iu + 2)] = c;
            a[(iv, iv + 2)] = c;
        }
    }
    assert!((&j - &a).amax() <= 1e-13 * a.amax(), "Brusselator\n{j}\n{a}");
}

/// Central differences with step `δ = ε^{1/3}·max(1, |x_j|)`: truncation and rounding both ~ε^{2/3}.
fn central<const N: usize>(f: &impl System<nalgebra::Const<N>>, x: SVector<f64, N>) -> SMatrix<f64, N, N> {
    let mut j = SMatrix::<f64, N, N>::zeros();
    let (mut fp, mut fm) = (SVector::<f64, N>::zeros(), SVector::<f64, N>::zeros());
    for c in 0..N {
        let d = f64::EPSILON.cbrt() * x[c].abs().max(1.0);
        let (mut xp, mut xm) = (x, x);
        xp[c] += d;
        xm[c] -= d;
        f.rhs(0.3, &xp, &[], &mut fp);
        f.rhs(0.3, &xm, &[], &mut fm);
        j.set_column(c, &((fp - fm) / (xp[c] - xm[c])));
    }
    j
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn random_closures_match_central_differences(
        a in -3.0f64..3.0, b in -2.0f64..2.0, c in 0.1f64..2.0, d in -1.0f64..1.0,
        x0 in -1.5f64..1.5, x1 in -1.5f64..1.5, x2 in -1.5f64..1.5,
    ) {
        let f = model!(|t, x: [S; 3]| vector![
            (x[0] * b + x[1] * x[2]).sin() * a + x[2] * t,
            (x[0] * x[0] * c).exp() * d - x[1].powi(3) + (x[2] * x[2] + 1.0).sqrt(),
            (x[1] * c).atan() * x[0] - (x[2] / (x[0] * x[0] + 1.0)) * b
        ]);
        let x = vector![x0, x1, x2];
        let jad = autodiff(&f, 0.3, x, &[]);
        let jfd = central(&f, x);
        let scale = jad.amax().max(1.0);
        prop_assert!((jad - jfd).amax() <= 1e-7 * scale, "autodiff\n{}\ncentral\n{}", jad, jfd);
    }

    #[test]
    fn dynamic_closures_match_fixed_ones(a in -2.0f64..2.0, x0 in -1.0f64..1.0, x1 in -1.0f64..1.0) {
        let fs = model!(|_t, x: [S; 2]| vector![(x[0] * x[1]).cos() * a, x[0].exp() - x[1] * a]);
        let fd = model!(|_t, x: [S; Dyn]| DVector::from_vec(vec![
            (x[0].clone() * x[1].clone()).cos() * a,
            x[0].clone().exp() - x[1].clone() * a
        ]));
        let js = autodiff(&fs, 0.0, vector![x0, x1], &[]);
        let mut jd = DMatrix::zeros(2, 2);
        fd.jacobian(0.0, &DVector::from_vec(vec![x0, x1]), &[], &mut jd);
        for r in 0..2 { for k in 0..2 { prop_assert_eq!(js[(r, k)], jd[(r, k)]); } }
    }
}

//! `model!` bodies with `f64` literals on the left of `+ - * /` (`2.0 * x[0]`): the
//! macro lifts them so that the dual copy compiles, and the values are bit for bit
//! those of the same body written with the literals on the right.

use nalgebra::{DMatrix, DVector, Matrix1, Matrix2, Matrix3, SVector, Vector1, vector};
use reckon::{System, dvector, model};

const STATES: [[f64; 2]; 5] = [[2.0, 0.0], [-0.3, 1.7], [1e-3, -4.5], [0.1, 0.2], [-7.25, 3.0e5]];

fn rhs<D: nalgebra::Dim, M: System<D>>(m: &M, t: f64, x: &nalgebra::OVector<f64, D>, u: &[f64]) -> Vec<f64>
where
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D>,
{
    let mut dx = x.clone();
    m.rhs(t, x, u, &mut dx);
    dx.iter().copied().collect()
}

#[test]
fn fixed_state_literals_on_the_left_are_bit_identical() {
    let left = model!(|_t, x: [S; 2]| vector![
        2.0 * x[0] + 1.0 - x[1],
        -3.0 * x[0] + 2.0 / x[0] - 0.5 * x[1] * x[1] + 1e-3 * x[0] / 7.0
    ]);
    let right = model!(|_t, x: [S; 2]| vector![
        x[0] * 2.0 + 1.0 - x[1],
        x[0] * -3.0 + S::from(2.0) / x[0] - x[1] * 0.5 * x[1] + x[0] * 1e-3 / 7.0
    ]);
    for s in STATES {
        let x = vector![s[0], s[1]];
        let (l, r) = (rhs(&left, 0.0, &x, &[]), rhs(&right, 0.0, &x, &[]));
        assert_eq!(l, r, "at {x:?}");
        assert_eq!(l[0], 2.0 * s[0] + 1.0 - s[1]);
        let (mut jl, mut jr) = (Matrix2::zeros(), Matrix2::zeros());
        left.jacobian(0.0, &x, &[], &mut jl);
        right.jacobian(0.0, &x, &[], &mut jr);
        assert_eq!(jl, jr, "at {x:?}");
        let exact = Matrix2::new(2.0, -1.0, -3.0 - 2.0 / (s[0] * s[0]) + 1e-3 / 7.0, -s[1]);
        for (a, b) in jl.iter().zip(exact.iter()) {
            assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0), "{jl} vs {exact} at {x:?}");
        }
    }
}

#[test]
fn van_der_pol_written_naturally() {
    let mu = 1.5;
    let natural = model!(|_t, x: [S; 2]| vector![x[1], (1.0 - x[0] * x[0]) * x[1] * mu - x[0]]);
    let lifted_by_hand = model!(|_t, x: [S; 2]| vector![x[1], (S::from(1.0) - x[0] * x[0]) * x[1] * mu - x[0]]);
    for s in STATES {
        let x = vector![s[0], s[1]];
        let dx = rhs(&natural, 0.0, &x, &[]);
        assert_eq!(dx, rhs(&lifted_by_hand, 0.0, &x, &[]));
        assert_eq!(dx[1], (1.0 - s[0] * s[0]) * s[1] * mu - s[0]);
        let mut j = Matrix2::zeros();
        natural.jacobian(0.0, &x, &[], &mut j);
        let exact = Matrix2::new(0.0, 1.0, -2.0 * mu * s[0] * s[1] - 1.0, mu * (1.0 - s[0] * s[0]));
        for (a, b) in j.iter().zip(exact.iter()) {
            assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0), "{j} vs {exact} at {x:?}");
        }
    }
}

#[test]
fn dynamic_state_with_integer_arithmetic_untouched() {
    // `2 * n` and `i + 1` stay integer expressions; only float literals are lifted
    let left = model!(|_t, x: [S; Dyn]| {
        let n = x.len();
        DVector::from_fn(n, |i, _| {
            2.0 * x[(i + 2 * n - 1) % n].clone() - 0.25 * x[i].clone() * x[i].clone()
        })
    });
    let right = model!(|_t, x: [S; Dyn]| {
        let n = x.len();
        DVector::from_fn(n, |i, _| {
            x[(i + 2 * n - 1) % n].clone() * 2.0 - x[i].clone() * 0.25 * x[i].clone()
        })
    });
    let mapped = model!(|_t, x: [S; Dyn]| x.map(|v| 1.0 - 3.0 * v));
    for s in STATES {
        let x = dvector![s[0], s[1], s[0] - s[1]];
        assert_eq!(rhs(&left, 0.0, &x, &[]), rhs(&right, 0.0, &x, &[]));
        let (mut jl, mut jr) = (DMatrix::zeros(3, 3), DMatrix::zeros(3, 3));
        left.jacobian(0.0, &x, &[], &mut jl);
        right.jacobian(0.0, &x, &[], &mut jr);
        assert_eq!(jl, jr);
        let exact = DMatrix::from_fn(3, 3, |i, j| {
            (if j == (i + 2) % 3 { 2.0 } else { 0.0 }) - if i == j { 0.5 * x[i] } else { 0.0 }
        });
        assert!((&jl - &exact).amax() <= 1e-15 * exact.amax(), "{jl} vs {exact}");
        let dm = rhs(&mapped, 0.0, &x, &[]);
        assert_eq!(dm, x.iter().map(|v| 1.0 - 3.0 * v).collect::<Vec<_>>());
        let mut jm = DMatrix::zeros(3, 3);
        mapped.jacobian(0.0, &x, &[], &mut jm);
        assert_eq!(jm, DMatrix::from_diagonal_element(3, 3, -3.0));
    }
}

#[test]
fn held_inputs() {
    let left = model!(|_t, x: [S; 3], u: [2]| vector![
        0.5 * x[2].cos() * u[0],
        1.0 - x[1] * u[1],
        2.0 * x[0] - S::from(u[1])
    ]);
    let right = model!(|_t, x: [S; 3], u: [2]| vector![
        x[2].cos() * 0.5 * u[0],
        -(x[1] * u[1]) + 1.0,
        x[0] * 2.0 - S::from(u[1])
    ]);
    for s in STATES {
        let x = vector![s[0], s[1], s[1] - s[0]];
        let u = [s[1], -s[0]];
        assert_eq!(rhs(&left, 0.0, &x, &u), rhs(&right, 0.0, &x, &u));
        let mut j = Matrix3::zeros();
        left.jacobian(0.0, &x, &u, &mut j);
        let mut exact = Matrix3::zeros();
        exact[(0, 2)] = -0.5 * x[2].sin() * u[0];
        exact[(1, 1)] = -u[1];
        exact[(2, 0)] = 2.0;
        for (a, b) in j.iter().zip(exact.iter()) {
            assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0), "{j} vs {exact}");
        }
    }
}

#[test]
fn typed_time_derivative_is_exact() {
    let left = model!(|t: S, x: [S; 1]| vector![2.0 * t * x[0] + 0.5 / t - 3.0 * x[0]]);
    let right = model!(|t: S, x: [S; 1]| vector![t * 2.0 * x[0] + S::from(0.5) / t - x[0] * 3.0]);
    for (t, x0) in [(0.5, 2.0), (3.0, -1.25), (1e-2, 7.0)] {
        let x = Vector1::new(x0);
        assert_eq!(rhs(&left, t, &x, &[]), rhs(&right, t, &x, &[]));
        assert_eq!(rhs(&left, t, &x, &[])[0], 2.0 * t * x0 + 0.5 / t - 3.0 * x0);
        let (mut dl, mut dr) = (Vector1::zeros(), Vector1::zeros());
        assert!(left.time_derivative(t, &x, &[], &mut dl));
        assert!(right.time_derivative(t, &x, &[], &mut dr));
        assert_eq!(dl, dr);
        let exact = 2.0 * x0 - 0.5 / (t * t);
        assert!((dl[0] - exact).abs() <= 1e-15 * exact.abs(), "{} vs {exact}", dl[0]);
        let mut j = Matrix1::zeros();
        left.jacobian(t, &x, &[], &mut j);
        assert!((j[(0, 0)] - (2.0 * t - 3.0)).abs() <= 1e-15 * (2.0 * t - 3.0).abs());
    }
}

#[test]
fn plain_f64_subexpressions_stay_f64() {
    let f = model!(|_t, x: [S; 2]| {
        let k: f64 = 1.0 - 0.5; // Lhs(1.0) - 0.5 is an f64
        let m = nalgebra::Matrix2::new(0.0, 1.0, -1.0, 0.0);
        let y: SVector<S, 2> = 2.0 * m.map(S::from) * x;
        vector![y[0] * k, y[1] + x[0] * (4.0f64.sqrt() - 2.0)]
    });
    let x = vector![1.5, -2.0];
    assert_eq!(rhs(&f, 0.0, &x, &[]), vec![2.0 * -2.0 * 0.5, -2.0 * 1.5]);
    let mut j = Matrix2::zeros();
    f.jacobian(0.0, &x, &[], &mut j);
    assert_eq!(j, Matrix2::new(0.0, 1.0, -2.0, 0.0));
}

#[test]
fn precedence_and_spellings() {
    // every line is its own Rust f64 value: the lift changes types, never the parse
    let f = model!(|_t, x: [S; 3]| {
        let q = ((1.0, 0.5),);
        // const contexts are left as written (Lhs's operators are not const)
        const K: f64 = 2.0 * 0.25;
        static L: [f64; 2] = [1.0 - 0.5, 0.0];
        const fn twice(v: f64) -> f64 {
            2.0 * v
        }
        let k = const { 3.0 * 0.5 } * K * L[0] * twice(0.25);
        let c = if 1.0 < 2.0 * 0.75 { 1.0 - 0.5 } else { 2.0 - 1.0 - 0.25 };
        let g = || {
            if c < 1.0 {
                return 4.0 / x[2] - 1.0 + x[0] * 2.0f64.sqrt();
            }
            x[0] * 0.0
        };
        vector![
            1.0 - 2.0 * x[0] - 3.0 / x[1] + 1e-3 * x[2] + 2f64 * x[0] - 2.5_f64 * x[1],
            x[0] * -2.0 * x[1] + -2.0 * -x[2] + x[0] * q.0.1 + x[1] * (2.0 + 1.0) - 0.5 * x[2] * c,
            g() * k
        ]
    });
    for s in STATES {
        let (a, b, c) = (s[0], s[1] + 0.5, s[1] * 0.5 - 1.0);
        let x = vector![a, b, c];
        let dx = rhs(&f, 0.0, &x, &[]);
        assert_eq!(dx[0], 1.0 - 2.0 * a - 3.0 / b + 1e-3 * c + 2f64 * a - 2.5_f64 * b);
        assert_eq!(
            dx[1],
            a * -2.0 * b + -2.0 * -c + a * 0.5 + b * (2.0 + 1.0) - 0.5 * c * 0.5
        );
        let k = 1.5 * 0.5 * 0.5 * 0.5;
        assert_eq!(dx[2], (4.0 / c - 1.0 + a * 2.0f64.sqrt()) * k);
        let mut j = Matrix3::zeros();
        f.jacobian(0.0, &x, &[], &mut j);
        let exact = Matrix3::new(
            0.0,
            3.0 / (b * b) - 2.5,
            1e-3,
            -2.0 * b + 0.5,
            -2.0 * a + 3.0,
            2.0 - 0.25,
            2.0f64.sqrt() * k,
            0.0,
            -4.0 / (c * c) * k,
        );
        for (u, v) in j.iter().zip(exact.iter()) {
            assert!((u - v).abs() <= 1e-15 * v.abs().max(1.0), "{j} vs {exact} at {x:?}");
        }
    }
}

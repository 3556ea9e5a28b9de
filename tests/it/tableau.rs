//! Dormand–Prince 5(4): tableau identities, order conditions, dense output weights.
#![allow(clippy::needless_range_loop)] // index notation mirrors the order conditions

use reckon::methods::rk45::tableau::{A, B, B_HAT, C, D, E};

const TOL: f64 = 1e-15;

fn a(i: usize, j: usize) -> f64 {
    if j < 6 { A[i][j] } else { 0.0 }
}
/// (A·v)_i
fn av(v: &[f64; 7]) -> [f64; 7] {
    let mut r = [0.0; 7];
    for (i, ri) in r.iter_mut().enumerate() {
        *ri = (0..7).map(|j| a(i, j) * v[j]).sum();
    }
    r
}
fn mul(u: &[f64; 7], v: &[f64; 7]) -> [f64; 7] {
    std::array::from_fn(|i| u[i] * v[i])
}
fn dot(b: &[f64; 7], v: &[f64; 7]) -> f64 {
    (0..7).map(|i| b[i] * v[i]).sum()
}

/// The order conditions of all rooted trees up to order 5 as (Φ vector, 1/γ, order).
fn conditions() -> Vec<([f64; 7], f64, usize)> {
    let one = [1.0; 7];
    let c = C;
    let c2 = mul(&c, &c);
    let c3 = mul(&c2, &c);
    let c4 = mul(&c3, &c);
    let ac = av(&c);
    let ac2 = av(&c2);
    let aac = av(&ac);
    vec![
        (one, 1.0, 1),
        (c, 1.0 / 2.0, 2),
        (c2, 1.0 / 3.0, 3),
        (ac, 1.0 / 6.0, 3),
        (c3, 1.0 / 4.0, 4),
        (mul(&c, &ac), 1.0 / 8.0, 4),
        (ac2, 1.0 / 12.0, 4),
        (aac, 1.0 / 24.0, 4),
        (c4, 1.0 / 5.0, 5),
        (mul(&c2, &ac), 1.0 / 10.0, 5),
        (mul(&ac, &ac), 1.0 / 20.0, 5),
        (mul(&c, &ac2), 1.0 / 15.0, 5),
        (mul(&c, &aac), 1.0 / 30.0, 5),
        (av(&c3), 1.0 / 20.0, 5),
        (av(&mul(&c, &ac)), 1.0 / 40.0, 5),
        (av(&ac2), 1.0 / 60.0, 5),
        (av(&aac), 1.0 / 120.0, 5),
    ]
}

#[test]
fn rows_of_a_sum_to_c() {
    for i in 0..7 {
        let s: f64 = (0..7).map(|j| a(i, j)).sum();
        assert!((s - C[i]).abs() < TOL, "row {i}: {s} vs c = {}", C[i]);
    }
}

#[test]
fn fsal_and_error_weights() {
    for j in 0..6 {
        assert_eq!(A[6][j], B[j], "last row of A must equal b (FSAL)");
    }
    assert_eq!(B[6], 0.0);
    for j in 0..7 {
        assert!((E[j] - (B[j] - B_HAT[j])).abs() < TOL, "e = b − b̂ at {j}");
    }
    assert!((B.iter().sum::<f64>() - 1.0).abs() < TOL);
    assert!((B_HAT.iter().sum::<f64>() - 1.0).abs() < TOL);
    assert!(E.iter().sum::<f64>().abs() < TOL);
}

#[test]
fn fifth_order_weights_satisfy_all_17_conditions() {
    let conds = conditions();
    assert_eq!(conds.len(), 17);
    for (k, (phi, gamma, p)) in conds.iter().enumerate() {
        let r = dot(&B, phi) - gamma;
        assert!(r.abs() < 1e-14, "b fails condition {k} (order {p}) by {r}");
    }
}

#[test]
fn embedded_weights_have_order_exactly_four() {
    let conds = conditions();
    let mut failed5 = 0;
    for (phi, gamma, p) in &conds {
        let r = dot(&B_HAT, phi) - gamma;
        if *p <= 4 {
            assert!(r.abs() < 1e-14, "b̂ fails an order-{p} condition by {r}");
        } else if r.abs() > 1e-10 {
            failed5 += 1;
        }
    }
    assert_eq!(failed5, 9, "b̂ must fail 9 of the 9 order-5 conditions");
}

/// Stability function of DP5: R(z) = Σ_{k≤5} z^k/k! + z⁶/600.
#[test]
fn stability_polynomial() {
    // R(z) = 1 + z bᵀ(I − zA)⁻¹ 1, expanded: coefficient of z^{k+1} is bᵀ A^k 1
    let mut v = [1.0; 7];
    let expected = [1.0, 0.5, 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0, 1.0 / 600.0, 0.0];
    for (k, e) in expected.iter().enumerate() {
        let coeff = dot(&B, &v);
        assert!((coeff - e).abs() < 1e-15, "z^{} coefficient {coeff} vs {e}", k + 1);
        v = av(&v);
    }
}

/// Dense weights b_i(θ) = θ + ... from Hairer's CONTD5 form, as the integrator stores them.
fn dense_weights(theta: f64) -> [f64; 7] {
    // x(θ) = y0 + h Σ b_i(θ) k_i with r2 = Σ b_j k_j, r3 = k1 − r2, r4 = r2 − k7 − r3, r5 = Σ d_j k_j
    // x = y0 + θ r2 + θ(1−θ) r3 + θ²(1−θ) r4 + θ²(1−θ)² r5
    let (t, s) = (theta, 1.0 - theta);
    std::array::from_fn(|j| {
        let k1 = if j == 0 { 1.0 } else { 0.0 };
        let k7 = if j == 6 { 1.0 } else { 0.0 };
        let r2 = B[j];
        let r3 = k1 - r2;
        let r4 = r2 - k7 - r3;
        let r5 = D[j];
        t * r2 + t * s * r3 + t * t * s * r4 + t * t * s * s * r5
    })
}

#[test]
fn dense_output_has_continuous_order_four() {
    for &theta in &[0.0, 0.1, 0.37, 0.5, 0.8, 1.0] {
        let bt = dense_weights(theta);
        for (phi, gamma, p) in conditions().iter().filter(|c| c.2 <= 4) {
            // continuous condition: Σ b_i(θ) Φ_i = θ^p · γ⁻¹
            let r = dot(&bt, phi) - theta.powi(*p as i32) * gamma;
            assert!(r.abs() < 1e-14, "θ = {theta}: order-{p} dense condition off by {r}");
        }
    }
    let b1 = dense_weights(1.0);
    for j in 0..7 {
        assert!((b1[j] - B[j]).abs() < 1e-15);
    }
    // published first polynomial: b_1(θ) = θ − 8048581381/2820520608 θ² + …
    let t = 0.3f64;
    let p1 = t - 8048581381.0 / 2820520608.0 * t * t + 8663915743.0 / 2820520608.0 * t.powi(3)
        - 12715105075.0 / 11282082432.0 * t.powi(4);
    assert!((dense_weights(t)[0] - p1).abs() < 1e-15);
}

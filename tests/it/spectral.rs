//! The sparse spectral estimate of the stiffness study (`studies::spectral`) against
//! closed forms and dense eigenvalues, its iteration cap, and its iteration cap
//! (`reckon stiffness --problem brusselator:N`: `crates/reckon-cli/tests/it/spectral.rs`).

use nalgebra::DMatrix;
use reckon::error::Quantity;
use reckon::jacobian::Pattern;
use reckon::linalg::arnoldi::{SpectralOptions, dominant, gershgorin, sparse_spectrum};
use reckon::methods::ImplicitEuler;
use reckon::studies::problems::{brusselator, brusselator_y0};
use reckon::studies::stiffness::{eigenvalues, stiffness_along, stiffness_along_sparse};
use reckon::{Error, Options, Problem, System};
use std::f64::consts::PI;

fn tight() -> SpectralOptions {
    SpectralOptions {
        tol: 1e-12,
        ..Default::default()
    }
}

/// The 1-D Laplacian on N interior points of (0, 1), `(N+1)²·tridiag(1, −2, 1)`.
fn laplacian(n: usize) -> (Pattern, Vec<f64>) {
    let mut e = Vec::new();
    for i in 0..n {
        e.push((i, i));
        if i + 1 < n {
            e.push((i + 1, i));
            e.push((i, i + 1));
        }
    }
    let p = Pattern::from_entries(n, &e).unwrap();
    let s = (n as f64 + 1.0).powi(2);
    let v = p.entries().map(|(r, c)| if r == c { -2.0 * s } else { s }).collect();
    (p, v)
}

#[test]
fn laplacian_extremes_match_the_closed_form() {
    // λ_k = −4 sin²(kπ/(2(N+1)))·(N+1)², k = 1..N. The top of the spectrum is clustered
    // (relative gap 3π²/(4(N+1)²)): N = 100 with a full Krylov basis is exact to rounding;
    // N = 1000 with 150 vectors and restarts meets tol = 1e-7 (an error of ρ below the
    // residual, symmetric J). The bottom is well separated (λ₂/λ₁ ≈ 4): tight at both.
    for (n, o, tol_rho) in [
        (
            100,
            SpectralOptions {
                krylov: 100,
                tol: 1e-12,
                max_restarts: 5,
            },
            1e-12,
        ),
        (
            1000,
            SpectralOptions {
                krylov: 150,
                tol: 1e-7,
                max_restarts: 200,
            },
            1e-7,
        ),
    ] {
        let (p, v) = laplacian(n);
        let m = n as f64 + 1.0;
        let lam = |k: usize| -4.0 * (k as f64 * PI / (2.0 * m)).sin().powi(2) * m * m;
        let s = sparse_spectrum(0.0, &p, &v, &o).unwrap();
        assert!(
            (s.spectral_radius / lam(n).abs() - 1.0).abs() < tol_rho,
            "N = {n}: ρ {} vs {}",
            s.spectral_radius,
            lam(n).abs()
        );
        assert!(s.largest.im.abs() < 1e-9 * s.spectral_radius);
        // Gershgorin: 2(N+1)² + 2(N+1)², a rigorous bound above ρ
        assert_eq!(s.gershgorin, 4.0 * m * m);
        assert!(s.gershgorin >= s.spectral_radius);
        assert!((s.smallest.re / lam(1) - 1.0).abs() < 1e-10, "N = {n}: {}", s.smallest);
        assert!(s.smallest.im.abs() < 1e-9 * lam(1).abs());
        assert!((s.ratio / (lam(n) / lam(1)) - 1.0).abs() < tol_rho + 1e-10);
    }
}

#[test]
fn diagonal_and_complex_pairs() {
    // diag(−1, …, −400) with a rotation block of eigenvalues −3 ± 500i on top: ρ = |−3 + 500i|
    let n = 402;
    let mut e: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
    e.push((400, 401));
    e.push((401, 400));
    let p = Pattern::from_entries(n, &e).unwrap();
    let v: Vec<f64> = p
        .entries()
        .map(|(r, c)| match (r, c) {
            (400, 401) => -500.0,
            (401, 400) => 500.0,
            (r, _) if r >= 400 => -3.0,
            (r, _) => -((r + 1) as f64),
        })
        .collect();
    let s = sparse_spectrum(0.0, &p, &v, &tight()).unwrap();
    let rho = (9.0f64 + 250_000.0).sqrt();
    assert!((s.spectral_radius / rho - 1.0).abs() < 1e-10, "{}", s.spectral_radius);
    assert!((s.largest.re + 3.0).abs() < 1e-6 && (s.largest.im.abs() - 500.0).abs() < 1e-6);
    assert!((s.smallest.re + 1.0).abs() < 1e-10 && s.smallest.im.abs() < 1e-10);
    assert_eq!(gershgorin(&p, &v), 503.0);
}

#[test]
fn sparse_and_dense_agree_on_brusselator_50() {
    // 100 states along an implicit-Euler solution: ρ and the stiffness index to 1e-9 with a
    // tight tolerance, to 1e-4 with the default one; the magnitude ratio ρ/min|λ| against
    // the dense eigenvalues' to 1e-8
    let n = 50;
    let p = Problem::new(brusselator(n), brusselator_y0(n), (0.0, 10.0));
    let sol = p
        .solve(ImplicitEuler::default(), &Options::default().rtol(1e-4).atol(1e-7))
        .unwrap();
    let every = sol.t.len() / 8;
    let dense = stiffness_along(&p.system, &sol, &[], every).unwrap();
    let sparse = stiffness_along_sparse(&p.system, &sol, &[], every, &tight()).unwrap();
    let loose = stiffness_along_sparse(&p.system, &sol, &[], every, &SpectralOptions::default()).unwrap();
    assert_eq!(dense.len(), sparse.len());
    assert!(dense.len() >= 8);
    for ((d, s), l) in dense.iter().zip(&sparse).zip(&loose) {
        assert_eq!((d.t, d.h_accuracy), (s.t, s.h_accuracy));
        assert!(
            (s.spectral_radius / d.spectral_radius - 1.0).abs() < 1e-9,
            "t = {}",
            d.t
        );
        assert!((s.index / d.index - 1.0).abs() < 1e-9);
        assert!((s.h_stability / d.h_stability - 1.0).abs() < 1e-9);
        assert!((l.spectral_radius / d.spectral_radius - 1.0).abs() < 1e-4);
        // the dense magnitude ratio at the same point
        let k = sol.t.iter().position(|&t| t == d.t).unwrap();
        let mut j = DMatrix::zeros(2 * n, 2 * n);
        p.system.jacobian(d.t, &sol.x[k], &[], &mut j);
        let ev = eigenvalues(d.t, &j).unwrap();
        let (lo, hi) = ev.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), z| {
            (lo.min(z.norm()), hi.max(z.norm()))
        });
        assert!(
            (s.ratio / (hi / lo) - 1.0).abs() < 1e-8,
            "t = {}: {} vs {}",
            d.t,
            s.ratio,
            hi / lo
        );
    }
}

#[test]
fn iteration_cap_is_a_typed_error() {
    // the cyclic shift of 2000 entries: its eigenvalues are the 2000th roots of unity, none
    // dominant, so the Ritz values never settle
    let n = 2000;
    let mut shift = |x: &[f64], y: &mut [f64]| {
        for i in 0..n {
            y[(i + 1) % n] = x[i];
        }
    };
    let o = SpectralOptions {
        krylov: 20,
        tol: 1e-8,
        max_restarts: 30,
    };
    let e = dominant(n, &mut shift, &o, None, "spectral radius", 1.25).unwrap_err();
    assert_eq!(
        e,
        Error::NoConvergence {
            what: "spectral radius",
            t: 1.25
        }
    );
    // and through sparse_spectrum, on the shift as a sparse matrix scaled so that
    // Gershgorin's bound (2) is far from ρ = 1
    let p = Pattern::from_entries(n, &(0..n).map(|i| ((i + 1) % n, i)).collect::<Vec<_>>()).unwrap();
    let mut v = vec![1.0; n];
    v[0] = 2.0;
    let e = sparse_spectrum(0.5, &p, &v, &o).unwrap_err();
    assert!(matches!(e, Error::NoConvergence { what: "spectral radius", t } if t == 0.5));
    // bad options and a non-finite Jacobian are refused, not iterated
    let bad = SpectralOptions { tol: 0.0, ..o };
    assert!(matches!(
        sparse_spectrum(0.0, &p, &v, &bad),
        Err(Error::InvalidInput { .. })
    ));
    v[5] = f64::NAN;
    let e = sparse_spectrum(0.0, &p, &v, &o).unwrap_err();
    // entry 5 is in column 5, row 6: row-major index 6·n + 5
    assert_eq!(
        e,
        Error::NonFinite {
            t: 0.0,
            quantity: Quantity::Jacobian,
            component: 6 * n + 5
        }
    );
}

#[test]
fn singular_jacobian_has_an_infinite_ratio() {
    // [[-1, 1], [1, -1]] ⊕ diag(−2, …): singular (eigenvalue 0), ρ = 2·150 at the end
    let n = 300;
    let mut e: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
    e.extend([(0, 1), (1, 0)]);
    let p = Pattern::from_entries(n, &e).unwrap();
    let v: Vec<f64> = p
        .entries()
        .map(|(r, c)| match (r, c) {
            (0, 1) | (1, 0) => 1.0,
            (0, 0) | (1, 1) => -1.0,
            (r, _) => -(r as f64),
        })
        .collect();
    let s = sparse_spectrum(0.0, &p, &v, &tight()).unwrap();
    assert!((s.spectral_radius - 299.0).abs() < 1e-8);
    assert_eq!(s.ratio, f64::INFINITY);
    assert_eq!(s.smallest.norm(), 0.0);
}

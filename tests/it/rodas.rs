//! Rodas5P: tableau order conditions, stability, observed orders, published end states
//! (Test Set mescd), dense output, and the model's exact ∂f/∂t.

use nalgebra::{Complex, SMatrix, SVector, Vector2, vector};
use reckon::methods::rodas5p::{A, C, C_T, D_T, GAMMA, STAGES};
use reckon::methods::{Rk45, Rodas5P};
use reckon::studies::problems::*;
use reckon::{Options, Problem, System, model};

type M8 = SMatrix<f64, 8, 8>;
type V8 = SVector<f64, 8>;

/// The classical (untransformed) Rosenbrock coefficients: `Γ = (I/γ − C)⁻¹`, `α = aΓ`,
/// `b = mΓ` (m = weights of the transformed form), `B = α + Γ`.
struct Classical {
    alpha: M8,
    gamma: M8,
    beta: M8,
    b: V8,
    b_hat: V8,
}

fn classical() -> Classical {
    let mut ginv = M8::zeros();
    let mut a = M8::zeros();
    for i in 0..STAGES {
        ginv[(i, i)] = 1.0 / GAMMA;
        for j in 0..i {
            ginv[(i, j)] = -C[i][j];
            a[(i, j)] = A[i][j];
        }
    }
    let gamma = ginv.try_inverse().unwrap();
    let alpha = a * gamma;
    // x₁ = U_8 + k_8 = x₀ + Σ a_8j k_j + k_8; the embedded solution is U_8
    let mut m = V8::zeros();
    for j in 0..7 {
        m[j] = A[7][j];
    }
    let mut m_hat = m;
    m[7] = 1.0;
    m_hat[7] = 0.0;
    let b = gamma.transpose() * m;
    let b_hat = gamma.transpose() * m_hat;
    Classical {
        beta: alpha + gamma,
        alpha,
        gamma,
        b,
        b_hat,
    }
}

/// A rooted tree as the list of its children.
#[derive(Clone, Debug)]
struct Tree(Vec<Tree>);

impl Tree {
    fn order(&self) -> usize {
        1 + self.0.iter().map(Tree::order).sum::<usize>()
    }
    /// `γ(t) = |t| Π γ(children)`.
    fn density(&self) -> f64 {
        self.order() as f64 * self.0.iter().map(Tree::density).product::<f64>()
    }
    /// Stage weights: leaves 1; a vertex with one son `B·Φ(son)` (B with the diagonal γ);
    /// more sons `Π_s α·Φ(son_s)` (Hairer–Wanner IV.7).
    fn phi(&self, k: &Classical) -> V8 {
        match self.0.len() {
            0 => V8::repeat(1.0),
            1 => k.beta * self.0[0].phi(k),
            _ => self
                .0
                .iter()
                .fold(V8::repeat(1.0), |acc, s| acc.component_mul(&(k.alpha * s.phi(k)))),
        }
    }
}

/// All rooted trees of each order 1..=max (by non-decreasing multisets of smaller trees).
fn trees(max: usize) -> Vec<Vec<Tree>> {
    let mut all: Vec<(usize, Tree)> = vec![(1, Tree(vec![]))];
    let mut by_order = vec![vec![], vec![Tree(vec![])]];
    for n in 2..=max {
        let mut out = vec![];
        // children: indices into `all` in non-decreasing order with orders summing to n−1
        fn rec(all: &[(usize, Tree)], start: usize, left: usize, cur: &mut Vec<usize>, out: &mut Vec<Tree>) {
            if left == 0 {
                out.push(Tree(cur.iter().map(|&i| all[i].1.clone()).collect()));
                return;
            }
            for i in start..all.len() {
                if all[i].0 <= left {
                    cur.push(i);
                    rec(all, i, left - all[i].0, cur, out);
                    cur.pop();
                }
            }
        }
        rec(&all, 0, n - 1, &mut vec![], &mut out);
        for t in &out {
            all.push((n, t.clone()));
        }
        by_order.push(out);
    }
    by_order
}

/// Largest residual `|b·Φ(t) − 1/γ(t)|` over the trees of one order.
fn residual(k: &Classical, b: &V8, trees: &[Tree]) -> f64 {
    trees
        .iter()
        .map(|t| (b.dot(&t.phi(k)) - 1.0 / t.density()).abs())
        .fold(0.0, f64::max)
}

#[test]
fn tableau_order_conditions_stiff_accuracy_and_stability() {
    let k = classical();
    let tr = trees(6);
    assert_eq!(tr.iter().map(Vec::len).collect::<Vec<_>>(), vec![0, 1, 1, 2, 4, 9, 20]);
    // α strictly lower triangular, its row sums are the stage times, Γ's row sums are d_i
    for i in 0..STAGES {
        assert!((i..STAGES).all(|j| k.alpha[(i, j)].abs() < 1e-13), "α row {i}");
        let ci: f64 = k.alpha.row(i).sum();
        assert!((ci - C_T[i]).abs() < 1e-13, "c_{i} = {ci} vs {}", C_T[i]);
        let di: f64 = k.gamma.row(i).sum();
        assert!((di - D_T[i]).abs() < 1e-12, "d_{i} = {di} vs {}", D_T[i]);
    }
    // main method: order 5 (all 17 trees), not 6
    for (p, ts) in tr.iter().enumerate().skip(1).take(5) {
        let r = residual(&k, &k.b, ts);
        println!("order {p}: {} trees, max residual {r:.1e}", ts.len());
        assert!(r < 1e-12, "order-{p} condition residual {r:e}");
    }
    let r6 = residual(&k, &k.b, &tr[6]);
    println!("order 6: max residual {r6:.1e}");
    assert!(r6 > 1e-4, "order-6 conditions hold too? {r6:e}");
    // embedded: order 4, not 5
    for (p, ts) in tr.iter().enumerate().skip(1).take(4) {
        let r = residual(&k, &k.b_hat, ts);
        assert!(r < 1e-12, "embedded order-{p} residual {r:e}");
    }
    let r5 = residual(&k, &k.b_hat, &tr[5]);
    println!("embedded order 5: max residual {r5:.1e}");
    assert!(r5 > 1e-4, "embedded is order 5? {r5:e}");
    // stiffly accurate: b is the last row of B (x₁ is the last stage's value)
    for j in 0..STAGES {
        assert!((k.b[j] - k.beta[(7, j)]).abs() < 1e-12, "b_{j} = {} vs β_8{j}", k.b[j]);
    }
    // R(z) = 1 + z bᵀ(I − zB)⁻¹1: R(∞) = 1 − bᵀB⁻¹1 = 0 (L-stable with A-stability)
    let r_inf = 1.0 - k.b.dot(&(k.beta.try_inverse().unwrap() * V8::repeat(1.0)));
    println!("R(∞) = {r_inf:.1e}");
    assert!(r_inf.abs() < 1e-12, "R(∞) = {r_inf:e}");
    let r = |z: Complex<f64>| {
        let m = SMatrix::<Complex<f64>, 8, 8>::identity() - k.beta.map(|v| Complex::new(v, 0.0)) * z;
        let y = m
            .lu()
            .solve(&SVector::<Complex<f64>, 8>::repeat(Complex::new(1.0, 0.0)))
            .unwrap();
        Complex::new(1.0, 0.0) + z * k.b.map(|v| Complex::new(v, 0.0)).dot(&y)
    };
    // agrees with e^z for small z to O(z⁶)
    let z = Complex::new(-0.01, 0.02);
    assert!(
        (r(z) - z.exp()).norm() < 1e-11 * 1e0,
        "R(z) − e^z = {}",
        (r(z) - z.exp()).norm()
    );
    let mut worst: f64 = 0.0;
    for e in -30..=60 {
        let y = 10f64.powf(e as f64 / 10.0);
        worst = worst.max(r(Complex::new(0.0, y)).norm());
        for ang in 1..=8 {
            let phi = std::f64::consts::FRAC_PI_2 + ang as f64 * std::f64::consts::PI / 18.0;
            worst = worst.max(r(Complex::from_polar(y, phi)).norm());
        }
    }
    println!("max |R(z)| on iℝ and left half-plane samples: {worst:.15}");
    assert!(worst <= 1.0 + 1e-12, "|R| = {worst}");
    assert!(r(Complex::new(-1e8, 0.0)).norm() < 1e-6);
}

/// Least-squares slope of log(err) against log(h).
fn slope(h: &[f64], e: &[f64]) -> f64 {
    let n = h.len() as f64;
    let (x, y): (Vec<f64>, Vec<f64>) = h.iter().zip(e).map(|(h, e)| (h.ln(), e.ln())).unzip();
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

fn observed_order<const N: usize, S: System<nalgebra::Const<N>>>(
    f: S,
    x0: SVector<f64, N>,
    t_end: f64,
    steps: &[usize],
    exact: SVector<f64, N>,
) -> (f64, Vec<f64>)
where
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    let p = Problem::new(f, x0, (0.0, t_end));
    let hs: Vec<f64> = steps.iter().map(|&n| t_end / n as f64).collect();
    let errs: Vec<f64> = hs
        .iter()
        .map(|&h| {
            let sol = p.solve(Rodas5P, &Options::default().fixed(h)).unwrap();
            assert!((sol.last().0 - t_end).abs() < 1e-12);
            (sol.last().1 - exact).amax()
        })
        .collect();
    (slope(&hs, &errs), errs)
}

/// Rodas5P's stability function matches `e^z` to one order more than the method
/// (`bᵀB⁵1 = 1/720`, checked below), so on a linear constant-coefficient system the
/// observed order is 6; nonlinear and non-autonomous problems show the order 5.
#[test]
fn observed_order_at_fixed_steps() {
    let k = classical();
    let mut v = V8::repeat(1.0);
    for _ in 0..5 {
        v = k.beta * v;
    }
    assert!((k.b.dot(&v) - 1.0 / 720.0).abs() < 1e-15, "bᵀB⁵1 = {}", k.b.dot(&v));
    let x0 = Vector2::new(1.0, 0.5);
    let (p, e) = observed_order(
        rotation_decay(),
        x0,
        2.0,
        &[10, 20, 40, 80],
        rotation_decay_exact(2.0, &x0),
    );
    println!("linear autonomous: order {p:.3}, errors {e:?}");
    assert!((p - 6.0).abs() < 0.1, "linear: {p}");
    assert!(e[3] > 1e-13);
    let (p, e) = observed_order(sin_u(), vector![2.0], 4.0, &[16, 32, 64, 128], sin_u_exact(4.0, 2.0));
    println!("sin u: order {p:.3}, errors {e:?}");
    assert!((p - 5.0).abs() < 0.1, "sin u: {p}");
    assert!(e[3] > 1e-13);
    // linear, forced (non-autonomous, written with t: S): x'' + x = cos 2t, x(0) = 1, x'(0) = 0
    let forced = model!(|t: S, x: [S; 2]| vector![x[1].clone(), -x[0].clone() + (t * 2.0).cos()]);
    let te: f64 = 4.0;
    let exact = vector![
        4.0 / 3.0 * te.cos() - (2.0 * te).cos() / 3.0,
        -4.0 / 3.0 * te.sin() + 2.0 / 3.0 * (2.0 * te).sin()
    ];
    let (p, e) = observed_order(&forced, vector![1.0, 0.0], te, &[10, 20, 40, 80], exact);
    println!("linear forced (t: S): order {p:.3}, errors {e:?}");
    assert!((p - 5.0).abs() < 0.1, "linear forced: {p}");
    assert!(e[3] > 1e-13);
    // nonlinear in t (t: S): x = (e^{sin t}, e^{−t²})
    let f = model!(|t: S, x: [S; 2]| vector![x[0] * t.cos(), x[1] * t * -2.0]);
    let t_end: f64 = 2.0;
    let exact = vector![t_end.sin().exp(), (-t_end * t_end).exp()];
    let (p, e) = observed_order(&f, vector![1.0, 1.0], t_end, &[10, 20, 40, 80], exact);
    println!("non-autonomous (t: S): order {p:.3}, errors {e:?}");
    assert!((p - 5.0).abs() < 0.1, "non-autonomous: {p}");
    assert!(e[3] > 1e-13);
    // the same body with a plain f64 t: ∂f/∂t by forward difference (≈ 8 digits)
    let g = model!(|t, x: [S; 2]| vector![x[0] * t.cos(), x[1] * t * -2.0]);
    let (pg, eg) = observed_order(&g, vector![1.0, 1.0], t_end, &[10, 20, 40, 80], exact);
    println!("non-autonomous (plain t, forward difference): order {pg:.3}, errors {eg:?}");
}

/// The embedded method (x̂ = U_8 = x₁ − k_8) on its own, by a scalar Rosenbrock loop over
/// the crate's published coefficients on `u' = sin u`: global order 4 (u(0) = 1, t ∈ [0, 1]);
/// the same loop keeping `x₁` gives 5 (u(0) = 2, t ∈ [0, 4], as the driver test).
#[test]
fn embedded_method_is_order_four() {
    let run = |t_end: f64, n: usize, embedded: bool| {
        let u0: f64 = if embedded { 1.0 } else { 2.0 };
        let h = t_end / n as f64;
        let mut x = u0;
        for _ in 0..n {
            let w = 1.0 / (h * GAMMA) - x.cos();
            let mut k = [0.0; STAGES];
            let mut u = x;
            for s in 0..STAGES {
                u = x + (0..s).map(|j| A[s][j] * k[j]).sum::<f64>();
                let rhs = u.sin() + (0..s).map(|j| C[s][j] / h * k[j]).sum::<f64>();
                k[s] = rhs / w;
            }
            x = if embedded { u } else { u + k[7] };
        }
        (x - sin_u_exact(t_end, u0)[0]).abs()
    };
    let ns = [16, 32, 64, 128];
    let hs: Vec<f64> = ns.iter().map(|&n| 1.0 / n as f64).collect();
    let emb: Vec<f64> = ns.iter().map(|&n| run(1.0, n, true)).collect();
    let main: Vec<f64> = ns.iter().map(|&n| run(4.0, n, false)).collect();
    let hm: Vec<f64> = hs.iter().map(|h| 4.0 * h).collect();
    let (pe, pm) = (slope(&hs, &emb), slope(&hm, &main));
    println!("global: embedded order {pe:.3} {emb:?}; main {pm:.3} {main:?}");
    assert!((pe - 4.0).abs() < 0.1, "embedded {pe}");
    assert!((pm - 5.0).abs() < 0.1, "main {pm}");
}

#[test]
fn time_derivative_from_the_model() {
    let typed = model!(|t: S, x: [S; 2]| vector![x[0] * t.sin(), x[1] * t * t]);
    let mut d = vector![9.0, 9.0];
    assert!(typed.time_derivative(0.3, &vector![2.0, 3.0], &[], &mut d));
    assert!(
        (d[0] - 2.0 * 0.3f64.cos()).abs() < 1e-15 && (d[1] - 3.0 * 0.6).abs() < 1e-15,
        "{d}"
    );
    // the value and Jacobian copies see the same t
    let mut f = vector![0.0, 0.0];
    typed.rhs(0.3, &vector![2.0, 3.0], &[], &mut f);
    assert!((f - vector![2.0 * 0.3f64.sin(), 3.0 * 0.09]).amax() < 1e-15, "{f}");
    let mut j = nalgebra::Matrix2::zeros();
    typed.jacobian(0.3, &vector![2.0, 3.0], &[], &mut j);
    assert_eq!(j, nalgebra::Matrix2::new(0.3f64.sin(), 0.0, 0.0, 0.09));
    // through &T, with inputs
    let with_u = model!(|t: S, x: [S; 1], u: [1]| vector![x[0] * t * u[0]]);
    let mut d1 = vector![0.0];
    fn through<S: System<nalgebra::U1>>(s: S, d: &mut nalgebra::Vector1<f64>) -> bool {
        s.time_derivative(5.0, &vector![2.0], &[4.0], d)
    }
    assert!(through(&with_u, &mut d1));
    assert_eq!(d1[0], 8.0);
    // Dyn
    let dy = model!(|t: S, x: [S; Dyn]| x.map(|v| v * t.exp()));
    let mut dd = nalgebra::DVector::from_element(2, 7.0);
    assert!(dy.time_derivative(0.0, &nalgebra::DVector::from_vec(vec![1.0, 2.0]), &[], &mut dd));
    assert_eq!(dd.as_slice(), &[1.0, 2.0]);
    // `_`: autonomous, exactly zero
    let auto = model!(|_, x: [S; 1]| vector![x[0].sin()]);
    let mut z = vector![5.0];
    assert!(auto.time_derivative(1.0, &vector![1.0], &[], &mut z));
    assert_eq!(z[0], 0.0);
    // plain t: not available
    let plain = model!(|t, x: [S; 1]| vector![x[0] * t]);
    assert!(!plain.time_derivative(1.0, &vector![1.0], &[], &mut z));
}

/// `mescd = −log10 max_i |y_i − yref_i| / (atol_i/rtol_i + |yref_i|)` and
/// `scd = −log10 max_i |y_i − yref_i|/|yref_i|` (Test Set report.f).
fn digits<const N: usize>(y: &SVector<f64, N>, yref: &[f64; N], atol: f64, rtol: f64) -> (f64, f64) {
    let mut m: f64 = 0.0;
    let mut s: f64 = 0.0;
    for i in 0..N {
        let e = (y[i] - yref[i]).abs();
        m = m.max(e / (atol / rtol + yref[i].abs()));
        s = s.max(e / yref[i].abs());
    }
    (-m.log10(), -s.log10())
}

fn published<const N: usize, S: System<nalgebra::Const<N>>>(
    name: &str,
    f: S,
    y0: SVector<f64, N>,
    t_end: f64,
    yref: &[f64; N],
    atol_over_rtol: f64,
) where
    nalgebra::Const<N>: reckon::linalg::LuDim,
{
    for (rtol, need) in [(1e-6, 4.5), (1e-10, 7.0)] {
        let atol = atol_over_rtol * rtol;
        let opts = Options::default()
            .rtol(rtol)
            .atol(atol)
            .dense(false)
            .max_steps(1_000_000);
        let sol = Problem::new(&f, y0, (0.0, t_end)).solve(Rodas5P, &opts).unwrap();
        let (mescd, scd) = digits(sol.last().1, yref, atol, rtol);
        let s = sol.stats;
        println!(
            "{name} rtol {rtol:.0e} atol {atol:.0e}: mescd {mescd:.2} scd {scd:.2}; steps {} (+{} rejected), f {}, J {}, LU {}",
            s.accepted, s.rejected, s.rhs_evals, s.jacobian_evals, s.lu_decompositions
        );
        assert!(mescd >= need, "{name} at rtol {rtol:e}: mescd {mescd}");
    }
}

#[test]
fn robertson_published_end_state() {
    published(
        "ROBER t=1e11",
        robertson(),
        vector![1.0, 0.0, 0.0],
        1e11,
        &ROBERTSON_REF_1E11,
        1e-4,
    );
}

#[test]
fn vdpolm_published_end_state() {
    published(
        "VDPOLM t=2000",
        van_der_pol(1000.0),
        vector![2.0, 0.0],
        2000.0,
        &VDPOLM_REF_2000,
        1.0,
    );
}

#[test]
fn orego_published_end_state() {
    published(
        "OREGO t=360",
        orego(),
        vector![1.0, 2.0, 3.0],
        360.0,
        &OREGO_REF_360,
        1.0,
    );
}

#[test]
fn hires_published_end_state() {
    published("HIRES", hires(), hires_y0(), HIRES_T, &HIRES_REF, 1.0);
}

/// Dense output between steps is as accurate as the step ends: Van der Pol μ = 5 at
/// rtol 1e-7 against a Rk45 solution at rtol 1e-13.
#[test]
fn dense_output_matches_tight_solution() {
    let p = Problem::new(van_der_pol(5.0), vector![2.0, 0.0], (0.0, 10.0));
    let tight = p
        .solve(Rk45, &Options::default().rtol(1e-13).atol(1e-13).dense(true))
        .unwrap();
    let sol = p
        .solve(Rodas5P, &Options::default().rtol(1e-7).atol(1e-9).dense(true))
        .unwrap();
    assert_eq!(sol.dense_segments().len(), sol.t.len() - 1);
    let grid = sol
        .t
        .iter()
        .zip(&sol.x)
        .map(|(&t, x)| (x - tight.at(t).unwrap()).amax())
        .fold(0.0, f64::max);
    let mut between: f64 = 0.0;
    let mut linear: f64 = 0.0;
    for w in sol.t.windows(2).zip(sol.x.windows(2)) {
        let ((t0, t1), (x0, x1)) = ((w.0[0], w.0[1]), (&w.1[0], &w.1[1]));
        for th in [0.25, 0.5, 0.75] {
            let t = t0 + th * (t1 - t0);
            let r = tight.at(t).unwrap();
            between = between.max((sol.at(t).unwrap() - r).amax());
            linear = linear.max((x0 * (1.0 - th) + x1 * th - r).amax());
        }
    }
    println!("dense: error at step ends {grid:.2e}, between steps {between:.2e}, linear interpolation {linear:.2e}");
    assert!(between < 3.0 * grid.max(1e-9), "between {between:e} vs grid {grid:e}");
    assert!(linear > 100.0 * between);
}

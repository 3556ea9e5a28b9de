//! Uncertainty on the manifold: a turning unicycle's pose cloud (a "banana") against the
//! tangent-space Gaussian on SE(2) and the EKF on the vector (x, y, θ).

use super::*;
use nalgebra::{Matrix3, Vector2};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};
use reckon::kalman::manifold::{LieGroup, Se2Gaussian};
use reckon::lie::Se2;

const V: f64 = 1.0;
const W: f64 = 0.3;
const DT: f64 = 0.05;
const STEPS: usize = 200;
const SIGMA_V: f64 = 0.2;
const SIGMA_W: f64 = 0.6;
/// χ²₂ at 95 %: the radius² of the 95 % ellipse of a 2-D Gaussian.
const CHI2_2_95: f64 = 5.991464547107979;
/// χ²₃ at 95 %.
const CHI2_3_95: f64 = 7.814727903251178;

pub(super) fn section(r: &mut Report, dir: &Path, fast: bool) -> Res {
    let members = if fast { 20_000 } else { 100_000 };
    r.section(
        "Uncertainty on the manifold: the banana",
        &format!("A unicycle drives 10 m at 1 m/s turning at 0.3 rad/s, with noise on its speed (σ 0.2 m/s) and turn rate (σ 0.6 rad/s) held over each 0.05 s step: its heading ends 0.42 rad uncertain and its position cloud bends into a banana. {members} poses stepped exactly on SE(2) with noisy twists, against two Gaussians propagated with the same increments and noise: the tangent-space one, g = ḡ·Exp(ξ), ξ ~ N(0, P) (<code>reckon::kalman::manifold</code>), and the EKF on the vector (x, y, θ). The tangent Gaussian's 95 % region mapped through Exp follows the cloud; the vector EKF's ellipse cannot bend."),
    );
    let u = vector![V * DT, 0.0, W * DT];
    let q = Matrix3::from_diagonal(&vector![(SIGMA_V * DT).powi(2), 0.0, (SIGMA_W * DT).powi(2)]);
    let mut rng = StdRng::seed_from_u64(37);
    let cloud: Vec<Se2> = (0..members)
        .map(|_| {
            let mut g = Se2::identity();
            for _ in 0..STEPS {
                let (a, b): (f64, f64) = (StandardNormal.sample(&mut rng), StandardNormal.sample(&mut rng));
                g = g.compose(&<Se2 as LieGroup<3>>::exp(
                    &(u + vector![SIGMA_V * DT * a, 0.0, SIGMA_W * DT * b]),
                ));
            }
            g
        })
        .collect();
    // the tangent Gaussian
    let mut tg = Se2Gaussian::new(Se2::identity(), Matrix3::zeros())?;
    // the vector EKF on (x, y, θ): x ← x + v·dt·cos θ, …, with the same noise on v and ω
    let (mut x, mut p) = (vector![0.0f64, 0.0, 0.0], Matrix3::<f64>::zeros());
    for _ in 0..STEPS {
        tg.predict(&u, &q)?;
        let th = x[2];
        let a = Matrix3::new(1.0, 0.0, -V * DT * th.sin(), 0.0, 1.0, V * DT * th.cos(), 0.0, 0.0, 1.0);
        let b = nalgebra::Matrix3x2::new(DT * th.cos(), 0.0, DT * th.sin(), 0.0, 0.0, DT);
        let qv = nalgebra::Matrix2::from_diagonal(&vector![SIGMA_V * SIGMA_V, SIGMA_W * SIGMA_W]);
        x += vector![V * DT * th.cos(), V * DT * th.sin(), W * DT];
        p = a * p * a.transpose() + b * qv * b.transpose();
    }
    // NEES of the cloud against each
    let p_inv = p.try_inverse().ok_or("the vector EKF's covariance is singular")?;
    let (mut n_tan, mut n_vec, mut in_tan, mut in_vec) = (0.0, 0.0, 0usize, 0usize);
    for g in &cloud {
        let e = tg.nees(g)?;
        let d = vector![g.translation[0] - x[0], g.translation[1] - x[1], wrap(g.angle() - x[2])];
        let ev = (d.transpose() * p_inv * d)[0];
        n_tan += e;
        n_vec += ev;
        in_tan += usize::from(e <= CHI2_3_95);
        in_vec += usize::from(ev <= CHI2_3_95);
    }
    let m = members as f64;
    // the figure: a thinned cloud, the EKF's 95 % position ellipse, the tangent region's
    // outline (the 95 % ellipse of ξ in the plane of P's two largest axes, through Exp)
    let shown: Vec<(f64, f64)> = cloud
        .iter()
        .step_by(members / 2000)
        .map(|g| (g.translation[0], g.translation[1]))
        .collect();
    let pxy = p.fixed_view::<2, 2>(0, 0).into_owned();
    let eig = pxy.symmetric_eigen();
    let ekf: Vec<(f64, f64)> = (0..=180)
        .map(|k| {
            let phi = k as f64 / 180.0 * std::f64::consts::TAU;
            let v = eig.eigenvectors
                * Vector2::new(
                    eig.eigenvalues[0].max(0.0).sqrt() * phi.cos(),
                    eig.eigenvalues[1].max(0.0).sqrt() * phi.sin(),
                )
                * CHI2_2_95.sqrt();
            (x[0] + v[0], x[1] + v[1])
        })
        .collect();
    let te = tg.cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| te.eigenvalues[b].total_cmp(&te.eigenvalues[a]));
    let (i, j) = (order[0], order[1]);
    let tangent: Vec<(f64, f64)> = (0..=180)
        .map(|k| {
            let phi = k as f64 / 180.0 * std::f64::consts::TAU;
            let xi = (te.eigenvectors.column(i) * te.eigenvalues[i].sqrt() * phi.cos()
                + te.eigenvectors.column(j) * te.eigenvalues[j].sqrt() * phi.sin())
                * CHI2_2_95.sqrt();
            let g = tg.mean.compose(&<Se2 as LieGroup<3>>::exp(&xi));
            (g.translation[0], g.translation[1])
        })
        .collect();
    let plot = Plot::new("Pose cloud after 10 m of turning", "x (m)", "y (m)")
        .equal()
        .with(
            Series::new(format!("Monte-Carlo poses (2 000 of {members})"), shown, Style::Points)
                .marker(1, false)
                .opacity(0.35),
        )
        .with(Series::new("vector EKF: 95 % ellipse", ekf, Style::Line))
        .with(Series::new(
            "tangent Gaussian: 95 % region through Exp",
            tangent,
            Style::Line,
        ));
    r.figure(
        dir,
        "manifold_banana.svg",
        &plot,
        "The cloud bends along the arc; the tangent region bends with it, the vector ellipse cuts across it.",
    )?;
    r.table(
        &[
            "Gaussian",
            "average NEES (3 if consistent)",
            "poses inside its 95 % region",
        ],
        &[
            vec![
                "tangent space, SE(2)".into(),
                format!("{:.3}", n_tan / m),
                format!("{:.1} %", 100.0 * in_tan as f64 / m),
            ],
            vec![
                "vector EKF, (x, y, θ)".into(),
                format!("{:.3}", n_vec / m),
                format!("{:.1} %", 100.0 * in_vec as f64 / m),
            ],
        ],
    );
    r.end();
    Ok(())
}

fn wrap(a: f64) -> f64 {
    a - std::f64::consts::TAU * (a / std::f64::consts::TAU).round()
}

//! Simultaneous calibration of odometry and sensor pose (Censi, Franchi, Marchionni &
//! Oriolo 2013, "Simultaneous calibration of odometry and sensor parameters for mobile
//! robots", IEEE T-RO 29(2)).
//!
//! Notation of the paper. A differential drive with wheel radii `r_L, r_R` and wheel
//! base `b` moves with `ω = J21·ω_L + J22·ω_R`, `v = J11·ω_L + J12·ω_R`, where
//! `J11 = r_L/2`, `J12 = r_R/2`, `J21 = −r_L/b`, `J22 = r_R/b`. An exteroceptive sensor
//! sits at the pose `ℓ = (ℓ_x, ℓ_y, ℓ_θ)` in the robot frame. Interval `k` has the wheel
//! rotations (radians, per sub-sample) and the sensor's displacement `s^k` measured by
//! scan matching; the robot's own displacement is `o^k` and `s^k = ⊖ℓ ⊕ o^k ⊕ ℓ`.
//!
//! Step 1 is linear least squares for `(J21, J22)` from `s^k_θ = J21·Φ^k_L + J22·Φ^k_R`
//! (`Φ` the wheel rotation over the interval). Step 2: with `J21, J22` fixed, the robot's
//! translation is `o^k_{x,y} = b·c^k` (`c^k` integrates `½(−J21·ω_L + J22·ω_R)` along the
//! heading from `J21, J22`; exact arcs per sub-sample), and `o ⊕ ℓ = ℓ ⊕ s` reads
//! `L_k φ = 0`, linear in `φ = (b, ℓ_x, ℓ_y, cos ℓ_θ, sin ℓ_θ)`:
//! `L_k = [[c_x, cos o_θ − 1, −sin o_θ, −s_x, s_y], [c_y, sin o_θ, cos o_θ − 1, −s_y, −s_x]]`.
//! The constrained quadratic `min φᵀMφ, M = Σ L_kᵀL_k`, s.t. `φ₄² + φ₅² = 1` is solved in
//! closed form: `(M + λW)φ = 0` with `W = diag(0, 0, 0, 1, 1)`, where
//! `det(M + λW) = 0` is a quadratic in `λ`; `φ` is the null vector of `M + λW` for the
//! root with the smaller cost, scaled to the constraint and signed so that `b > 0`.
//! Then `r_L = −b·J21`, `r_R = b·J22`.

use super::Estimate;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, Matrix2, Matrix5, SMatrix, Vector2, Vector3};

/// One calibration interval: wheel rotations per sub-sample and the measured sensor
/// displacement over the whole interval.
#[derive(Debug, Clone, PartialEq)]
pub struct Interval {
    /// `[Δφ_L, Δφ_R]` (rad) for each sub-sample, in order; the wheel speeds are taken as
    /// constant within a sub-sample.
    pub wheels: Vec<[f64; 2]>,
    /// Sensor displacement `s^k = (s_x, s_y, s_θ)` in the sensor frame at the start.
    pub sensor: Vector3<f64>,
}

/// The calibrated quantities in the paper's notation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    /// Left wheel radius `r_L` (m).
    pub r_l: f64,
    /// Right wheel radius `r_R` (m).
    pub r_r: f64,
    /// Wheel base `b` (m).
    pub b: f64,
    /// Sensor pose `ℓ = (ℓ_x, ℓ_y, ℓ_θ)` in the robot frame.
    pub sensor: Vector3<f64>,
}

/// `a ⊕ b`: the pose `b` (in `a`'s frame) composed onto `a`.
fn oplus(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let (s, c) = a[2].sin_cos();
    Vector3::new(a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])
}

/// `⊖a`, the inverse pose.
fn ominus(a: &Vector3<f64>) -> Vector3<f64> {
    let (s, c) = a[2].sin_cos();
    Vector3::new(-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])
}

use crate::vehicles::unicycle::sinc;

/// Robot displacement per unit wheel base: `(c_x, c_y, o_θ)` from `J21, J22`.
fn unit_odometry(j21: f64, j22: f64, wheels: &[[f64; 2]]) -> Vector3<f64> {
    let mut p = Vector3::<f64>::zeros();
    for &[pl, pr] in wheels {
        let dth = j21 * pl + j22 * pr;
        let ds = 0.5 * (-j21 * pl + j22 * pr);
        let m = p[2] + 0.5 * dth;
        let k = ds * sinc(0.5 * dth);
        p += Vector3::new(k * m.cos(), k * m.sin(), dth);
    }
    p
}

impl Params {
    /// `J21 = −r_L/b`, `J22 = r_R/b`.
    ///
    /// ```
    /// use reckon::calibration::censi::Params;
    /// let p = Params { r_l: 0.05, r_r: 0.06, b: 0.5, sensor: [0.0; 3].into() };
    /// assert_eq!(p.j21_j22(), (-0.1, 0.12));
    /// ```
    pub fn j21_j22(&self) -> (f64, f64) {
        (-self.r_l / self.b, self.r_r / self.b)
    }

    /// The robot's displacement `o = (o_x, o_y, o_θ)` over the wheel rotations `wheels`:
    /// exact arcs with `Δθ = J21·Δφ_L + J22·Δφ_R`, `Δs = (r_L·Δφ_L + r_R·Δφ_R)/2` per sub-sample.
    ///
    /// ```
    /// use reckon::calibration::censi::Params;
    /// let p = Params { r_l: 0.05, r_r: 0.05, b: 0.5, sensor: [0.0; 3].into() };
    /// let o = p.robot_motion(&[[10.0, 10.0]]);
    /// assert!((o[0] - 0.5).abs() < 1e-15 && o[1] == 0.0 && o[2] == 0.0);
    /// ```
    pub fn robot_motion(&self, wheels: &[[f64; 2]]) -> Vector3<f64> {
        let (j21, j22) = self.j21_j22();
        let u = unit_odometry(j21, j22, wheels);
        Vector3::new(self.b * u[0], self.b * u[1], u[2])
    }

    /// The sensor's displacement `s = ⊖ℓ ⊕ o ⊕ ℓ` over the wheel rotations `wheels`.
    ///
    /// ```
    /// use reckon::calibration::censi::Params;
    /// // a sensor 0.2 m ahead of the axle; a quarter turn on the spot moves it on a circle
    /// let p = Params { r_l: 0.05, r_r: 0.05, b: 0.5, sensor: [0.2, 0.0, 0.0].into() };
    /// let phi = std::f64::consts::FRAC_PI_2 * 0.5 / 0.05 / 2.0; // each wheel rolls b·π/4
    /// let s = p.sensor_motion(&[[-phi, phi]]);
    /// assert!((s[0] + 0.2).abs() < 1e-15 && (s[1] - 0.2).abs() < 1e-15);
    /// assert!((s[2] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    /// ```
    pub fn sensor_motion(&self, wheels: &[[f64; 2]]) -> Vector3<f64> {
        let o = self.robot_motion(wheels);
        oplus(&ominus(&self.sensor), &oplus(&o, &self.sensor))
    }
}

/// Outlier trimming: `rounds` times, drop the `fraction` of the kept intervals (rounded
/// up) with the largest normalised residual `r_θ²/σ̂_θ² + ‖r_xy‖²/σ̂_xy²` and re-estimate.
///
/// The default is the reference solver's (Censi et al.'s `solver2` as its experiments
/// run it: `-outliers_iterations 4`, 1 % per round): `fraction = 0.01`, `rounds = 4`.
/// Scan matching fails now and then (a few intervals in a hundred), and one failed match
/// moves the sensor's estimated position by several standard deviations; data without
/// such failures lose a few percent of their intervals to it and nothing else.
/// [`Trim::NONE`] keeps every interval.
///
/// ```
/// use reckon::calibration::censi::Trim;
/// assert_eq!(Trim::default(), Trim { fraction: 0.01, rounds: 4 });
/// assert_eq!(Trim::NONE.rounds, 0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trim {
    /// Fraction of the kept intervals dropped per round, in `[0, 0.5)`.
    pub fraction: f64,
    /// Number of rounds.
    pub rounds: usize,
}

impl Trim {
    /// No trimming: every interval is kept.
    pub const NONE: Trim = Trim {
        fraction: 0.0,
        rounds: 0,
    };
    /// The reference solver's outlier rejection, 1 % per round for 4 rounds (the default).
    pub const REFERENCE: Trim = Trim {
        fraction: 0.01,
        rounds: 4,
    };
}

impl Default for Trim {
    fn default() -> Self {
        Trim::REFERENCE
    }
}

/// The result of [`calibrate`].
#[derive(Debug, Clone, PartialEq)]
pub struct CensiFit {
    /// `J21, J22, b, l_x, l_y, l_theta, r_L, r_R` with their covariance (rank 6: the
    /// radii are functions of the first three). Residuals `(r_θ, r_x, r_y)` per kept
    /// interval, in order: `r_θ = s_θ − J21·Φ_L − J22·Φ_R` (rad) and `(r_x, r_y) = L_k φ`
    /// (m); `dof = 3·kept − 6`, `σ̂²` mixes the two units (use the block values below).
    pub estimate: Estimate,
    /// The same values as [`Params`].
    pub params: Params,
    /// Indices of the intervals kept after trimming, in order.
    pub kept: Vec<usize>,
    /// `σ̂_θ² = Σ r_θ²/(kept − 2)`.
    pub sigma2_theta: f64,
    /// `σ̂_xy² = Σ (r_x² + r_y²)/(2·kept − 4)`.
    pub sigma2_xy: f64,
}

struct Solved {
    p: [f64; 6],
    rt: Vec<f64>,
    rxy: Vec<Vector2<f64>>,
}

fn l_rows(u: &Vector3<f64>, s: &Vector3<f64>) -> SMatrix<f64, 2, 5> {
    let (so, co) = u[2].sin_cos();
    SMatrix::<f64, 2, 5>::from_row_slice(&[u[0], co - 1.0, -so, -s[0], s[1], u[1], so, co - 1.0, -s[1], -s[0]])
}

fn minor(m: &Matrix5<f64>, keep: &[usize]) -> f64 {
    DMatrix::from_fn(keep.len(), keep.len(), |i, j| m[(keep[i], keep[j])]).determinant()
}

fn solve(data: &[Interval], kept: &[usize]) -> Result<Solved> {
    // step 1: J21, J22
    let mut n = Matrix2::zeros();
    let mut rhs = Vector2::zeros();
    let phis: Vec<Vector2<f64>> = kept
        .iter()
        .map(|&k| {
            data[k]
                .wheels
                .iter()
                .fold(Vector2::zeros(), |a, w| a + Vector2::new(w[0], w[1]))
        })
        .collect();
    for (phi, &k) in phis.iter().zip(kept) {
        n += phi * phi.transpose();
        rhs += phi * data[k].sensor[2];
    }
    let eig = n.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if !(hi > 0.0 && lo > 1e-10 * hi) {
        return Err(Error::Unidentifiable {
            parameter: "J21, J22 (so r_L, r_R and b)".into(),
            reason: format!(
                "the intervals' wheel rotations (Φ_L, Φ_R) are proportional to one another (eigenvalues of ΣΦΦᵀ {lo:e}, {hi:e}): drive with different ratios of the wheel speeds, e.g. straight and turning"
            ),
        });
    }
    let j = n.try_inverse().expect("positive definite 2×2") * rhs;
    let (j21, j22) = (j[0], j[1]);
    // step 2: M, the quadratic in λ
    let us: Vec<Vector3<f64>> = kept.iter().map(|&k| unit_odometry(j21, j22, &data[k].wheels)).collect();
    let mut m = Matrix5::zeros();
    for (u, &k) in us.iter().zip(kept) {
        let l = l_rows(u, &data[k].sensor);
        m += l.transpose() * l;
    }
    let m3 = m.fixed_view::<3, 3>(0, 0).into_owned();
    let e3 = m3.symmetric_eigenvalues();
    if !(e3.max() > 0.0 && e3.min() > 1e-12 * e3.max()) {
        return Err(Error::Unidentifiable {
            parameter: "b, l_x, l_y".into(),
            reason: format!(
                "the robot's rotations over the intervals do not separate the wheel base from the sensor offset (eigenvalues {:e} … {:e}): the intervals need rotations of different sizes",
                e3.min(),
                e3.max()
            ),
        });
    }
    let c2 = minor(&m, &[0, 1, 2]);
    let c1 = minor(&m, &[0, 1, 2, 3]) + minor(&m, &[0, 1, 2, 4]);
    let c0 = m.determinant();
    let disc = (c1 * c1 - 4.0 * c2 * c0).max(0.0);
    let q = -0.5 * (c1 + c1.signum() * disc.sqrt());
    let mut roots = vec![q / c2];
    if q != 0.0 {
        roots.push(c0 / q);
    }
    let mut best: Option<(f64, nalgebra::Vector5<f64>)> = None;
    for lam in roots {
        if !lam.is_finite() {
            continue;
        }
        let mut k = m;
        k[(3, 3)] += lam;
        k[(4, 4)] += lam;
        let svd = k.svd(false, true);
        let vt = svd.v_t.expect("v_t");
        let i = svd.singular_values.imin();
        let mut v: nalgebra::Vector5<f64> = vt.row(i).transpose();
        let norm = v[3].hypot(v[4]);
        if norm == 0.0 {
            continue;
        }
        v /= norm;
        let cost = (v.transpose() * m * v)[0];
        if best.as_ref().is_none_or(|(c, _)| cost < *c) {
            best = Some((cost, v));
        }
    }
    let (_, mut phi) = best.ok_or_else(|| Error::Unidentifiable {
        parameter: "b, l_x, l_y, l_theta".into(),
        reason: "the constrained quadratic has no usable root".into(),
    })?;
    if phi[0] < 0.0 {
        phi = -phi;
    }
    if phi[0].is_nan() || phi[0] <= 0.0 {
        return Err(Error::Unidentifiable {
            parameter: "b".into(),
            reason: "the estimated wheel base is zero".into(),
        });
    }
    let p = [j21, j22, phi[0], phi[1], phi[2], phi[4].atan2(phi[3])];
    let (rt, rxy) = residuals(data, kept, &p);
    Ok(Solved { p, rt, rxy })
}

/// θ and translation residuals at the parameters `p = (J21, J22, b, ℓ_x, ℓ_y, ℓ_θ)`.
fn residuals(data: &[Interval], kept: &[usize], p: &[f64; 6]) -> (Vec<f64>, Vec<Vector2<f64>>) {
    let mut rt = Vec::with_capacity(kept.len());
    let mut rxy = Vec::with_capacity(kept.len());
    let (sl, cl) = p[5].sin_cos();
    let phi = nalgebra::Vector5::new(p[2], p[3], p[4], cl, sl);
    for &k in kept {
        let d = &data[k];
        let u = unit_odometry(p[0], p[1], &d.wheels);
        let tot = d.wheels.iter().fold([0.0, 0.0], |a, w| [a[0] + w[0], a[1] + w[1]]);
        rt.push(d.sensor[2] - p[0] * tot[0] - p[1] * tot[1]);
        rxy.push(l_rows(&u, &d.sensor) * phi);
    }
    (rt, rxy)
}

/// Censi et al.'s two-step calibration of `J21, J22`, `b` and the sensor pose `ℓ` from
/// `data` (formulas in the [module](self) docs), with optional outlier trimming.
///
/// Covariance (linearised from the residuals): step 1 is linear, so
/// `Σ_J = σ̂_θ²(AᵀA)⁻¹` with `A` the rows `(Φ_L, Φ_R)`. Step 2's estimate
/// `ψ = (b, ℓ_x, ℓ_y, ℓ_θ)` minimises `Σ‖r_k(ψ, J)‖²`; to first order
/// `δψ = −H⁻¹J_ψᵀ(ε + J_J·δJ)`, `H = J_ψᵀJ_ψ`, so
/// `Σ_ψ = σ̂_xy²H⁻¹ + KΣ_JKᵀ`, `Σ_ψJ = −KΣ_J`, `K = H⁻¹J_ψᵀJ_J` (`J_ψ` exact, `J_J` by
/// central differences), then to `r_L = −b·J21`, `r_R = b·J22` by their gradients.
/// The scan matcher's errors in `(s_x, s_y)` and in `s_θ` are taken as independent and
/// white, as in the paper.
///
/// Errors: fewer than 3 intervals, a non-finite value, or wheel rotations that cannot
/// determine `J21, J22` or `b, ℓ` ([`Error::Unidentifiable`]).
///
/// ```
/// use reckon::calibration::censi::{calibrate, Interval, Params, Trim};
/// let truth = Params { r_l: 0.05, r_r: 0.051, b: 0.4, sensor: [0.1, -0.05, 0.3].into() };
/// let data: Vec<Interval> = (0..10)
///     .map(|k| {
///         let w = [[1.0 + 0.3 * k as f64, 2.0 - 0.25 * k as f64]; 5].to_vec();
///         Interval { sensor: truth.sensor_motion(&w), wheels: w }
///     })
///     .collect();
/// let fit = calibrate(&data, Trim::default()).unwrap();
/// assert!((fit.params.b - 0.4).abs() < 1e-12 && (fit.params.r_r - 0.051).abs() < 1e-12);
/// assert!((fit.params.sensor - truth.sensor).amax() < 1e-12);
/// ```
pub fn calibrate(data: &[Interval], trim: Trim) -> Result<CensiFit> {
    if data.len() < 3 {
        return Err(Error::invalid(
            "intervals",
            format!("need at least 3 intervals, got {}", data.len()),
        ));
    }
    if !(trim.fraction.is_finite() && (0.0..0.5).contains(&trim.fraction)) {
        return Err(Error::invalid(
            "trim",
            format!("the fraction must be in [0, 0.5), got {}", trim.fraction),
        ));
    }
    for (k, d) in data.iter().enumerate() {
        if d.wheels.is_empty() {
            return Err(Error::invalid(
                "intervals",
                format!("interval {k} has no wheel samples"),
            ));
        }
        if d.sensor.iter().chain(d.wheels.iter().flatten()).any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "intervals",
                format!("interval {k} has a non-finite value"),
            ));
        }
    }
    let mut kept: Vec<usize> = (0..data.len()).collect();
    let mut s = solve(data, &kept)?;
    for _ in 0..trim.rounds {
        let drop = (trim.fraction * kept.len() as f64).ceil() as usize;
        if drop == 0 || kept.len() - drop < 3 {
            break;
        }
        let (s2t, s2xy) = block_sigmas(&s);
        let score: Vec<f64> = (0..kept.len())
            .map(|i| {
                s.rt[i] * s.rt[i] / s2t.max(f64::MIN_POSITIVE) + s.rxy[i].norm_squared() / s2xy.max(f64::MIN_POSITIVE)
            })
            .collect();
        let mut order: Vec<usize> = (0..kept.len()).collect();
        order.sort_by(|&a, &b| score[b].total_cmp(&score[a]));
        let mut out = order[..drop].to_vec();
        out.sort_unstable();
        kept = kept
            .iter()
            .enumerate()
            .filter(|(i, _)| out.binary_search(i).is_err())
            .map(|(_, &k)| k)
            .collect();
        s = solve(data, &kept)?;
    }
    let (s2t, s2xy) = block_sigmas(&s);
    let cov6 = covariance(data, &kept, &s, s2t, s2xy);
    let [j21, j22, b, lx, ly, lth] = s.p;
    let mut t = DMatrix::zeros(8, 6);
    for i in 0..6 {
        t[(i, i)] = 1.0;
    }
    // r_L = −b·J21, r_R = b·J22
    t[(6, 0)] = -b;
    t[(6, 2)] = -j21;
    t[(7, 1)] = b;
    t[(7, 2)] = j22;
    let cov8 = &t * cov6 * t.transpose();
    let params = Params {
        r_l: -b * j21,
        r_r: b * j22,
        b,
        sensor: Vector3::new(lx, ly, lth),
    };
    let residuals: Vec<f64> = s.rt.iter().zip(&s.rxy).flat_map(|(t, xy)| [*t, xy[0], xy[1]]).collect();
    let dof = residuals.len() - 6;
    let sigma2 = residuals.iter().map(|r| r * r).sum::<f64>() / dof as f64;
    if !(s.p.iter().chain(cov8.iter()).all(|v| v.is_finite()) && sigma2.is_finite()) {
        return Err(Error::invalid(
            "intervals",
            "the estimate or its covariance is not finite: the data's magnitudes overflow the sums of squares",
        ));
    }
    Ok(CensiFit {
        estimate: Estimate {
            names: ["J21", "J22", "b", "l_x", "l_y", "l_theta", "r_L", "r_R"]
                .map(String::from)
                .to_vec(),
            value: vec![j21, j22, b, lx, ly, lth, params.r_l, params.r_r],
            covariance: cov8,
            residuals,
            dof,
            sigma2,
        },
        params,
        kept,
        sigma2_theta: s2t,
        sigma2_xy: s2xy,
    })
}

/// The residuals `(r_θ, r_x, r_y)` of every interval of `data` (kept or trimmed) at the
/// parameters of `fit`, in the units of [`CensiFit::estimate`]'s residuals (rad, m): what
/// an interval disagrees with the fit by, so that the trimmed ones can be looked at.
///
/// ```
/// use reckon::calibration::censi::{calibrate, interval_residuals, synthetic, Trim};
/// let set = synthetic(7, 200);
/// let fit = calibrate(&set.intervals, Trim::default()).unwrap();
/// let r = interval_residuals(&set.intervals, &fit);
/// // the failed scan matches are the intervals that disagree most, and are trimmed
/// for &k in &set.outliers {
///     assert!(!fit.kept.contains(&k) && r[k][1].hypot(r[k][2]) > 10.0 * set.sigma_xy);
/// }
/// ```
pub fn interval_residuals(data: &[Interval], fit: &CensiFit) -> Vec<[f64; 3]> {
    let v = &fit.estimate.value;
    let p = [v[0], v[1], v[2], v[3], v[4], v[5]];
    let all: Vec<usize> = (0..data.len()).collect();
    let (rt, rxy) = residuals(data, &all, &p);
    rt.iter().zip(&rxy).map(|(t, xy)| [*t, xy[0], xy[1]]).collect()
}

/// A synthetic calibration data set with a known truth ([`synthetic`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Synthetic {
    /// The parameters the data were made with.
    pub truth: Params,
    /// One interval per row, each a single sub-sample (constant wheel speeds).
    pub intervals: Vec<Interval>,
    /// Each interval's duration (s).
    pub dt: Vec<f64>,
    /// Indices of the intervals whose sensor displacement is a failed scan match.
    pub outliers: Vec<usize>,
    /// Standard deviation of the scan matcher's `s_x`, `s_y` (m).
    pub sigma_xy: f64,
    /// Standard deviation of the scan matcher's `s_θ` (rad).
    pub sigma_theta: f64,
}

/// SplitMix64 (Steele, Lea & Flood 2014): uniform numbers in `[0, 1)` from the top 53 bits.
struct SplitMix(u64);

impl SplitMix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A standard normal number by Box–Muller (one of the pair; `1 − u` keeps the logarithm's
/// argument in `(0, 1]`).
fn normal(uniform: &mut impl FnMut() -> f64) -> f64 {
    let (u, v) = (1.0 - uniform(), uniform());
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// `n` calibration intervals of a small indoor robot with a known geometry, reproducible
/// from `seed` on every machine (its own SplitMix64 generator and Box–Muller normals, so
/// the numbers do not depend on a random-number crate's version).
///
/// Truth: wheel diameters 0.0720 m (left) and 0.0716 m (right), wheel base 0.235 m, a
/// laser 0.08 m ahead of the axle centre, 0.012 m to the right, turned 0.05 rad to the
/// left. Each interval lasts 0.6…1.0 s at constant wheel speeds: 35 % turn on the spot
/// (±2…6 rad/s), 45 % arcs (each wheel 1…8 rad/s), 20 % nearly straight (3…8 rad/s, the
/// wheels within ±3 %). The sensor's displacement is the exact one plus scan-matching
/// noise, σ_xy = 1 mm and σ_θ = 2 mrad; 2.5 % of the intervals are failed matches, off by
/// 3…15 cm in a random direction and 0.05…0.3 rad.
///
/// ```
/// use reckon::calibration::censi::synthetic;
/// let a = synthetic(1, 50);
/// assert_eq!(a, synthetic(1, 50));
/// assert_eq!((a.intervals.len(), a.truth.b), (50, 0.235));
/// assert!(a.intervals.iter().all(|i| i.wheels.len() == 1));
/// ```
pub fn synthetic(seed: u64, n: usize) -> Synthetic {
    let truth = Params {
        r_l: 0.036,
        r_r: 0.0358,
        b: 0.235,
        sensor: Vector3::new(0.08, -0.012, 0.05),
    };
    let (sigma_xy, sigma_theta) = (0.001, 0.002);
    let mut rng = SplitMix(seed);
    let mut uniform = || rng.uniform();
    let (mut intervals, mut dt, mut outliers) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::new());
    for k in 0..n {
        let d = 0.6 + 0.4 * uniform();
        let kind = uniform();
        let sign = if uniform() < 0.5 { -1.0 } else { 1.0 };
        let (wl, wr) = if kind < 0.35 {
            let w = 2.0 + 4.0 * uniform();
            (-sign * w, sign * w)
        } else if kind < 0.8 {
            (1.0 + 7.0 * uniform(), 1.0 + 7.0 * uniform())
        } else {
            let w = 3.0 + 5.0 * uniform();
            (w, w * (1.0 + 0.03 * (2.0 * uniform() - 1.0)))
        };
        let wheels = vec![[wl * d, wr * d]];
        let mut s = truth.sensor_motion(&wheels);
        let e = [normal(&mut uniform), normal(&mut uniform), normal(&mut uniform)];
        s += Vector3::new(sigma_xy * e[0], sigma_xy * e[1], sigma_theta * e[2]);
        if uniform() < 0.025 {
            let (m, a) = (0.03 + 0.12 * uniform(), std::f64::consts::TAU * uniform());
            let turn = if uniform() < 0.5 { -1.0 } else { 1.0 } * (0.05 + 0.25 * uniform());
            s += Vector3::new(m * a.cos(), m * a.sin(), turn);
            outliers.push(k);
        }
        intervals.push(Interval { wheels, sensor: s });
        dt.push(d);
    }
    Synthetic {
        truth,
        intervals,
        dt,
        outliers,
        sigma_xy,
        sigma_theta,
    }
}

impl Synthetic {
    /// The data set as an interval CSV for `reckon calibrate --intervals`: header
    /// `dt,left,right,dx,dy,dtheta`, one row per interval (wheel rotations in rad, the
    /// sensor displacement in m and rad), numbers in Rust's shortest round-trip form.
    ///
    /// ```
    /// use reckon::calibration::censi::synthetic;
    /// let csv = synthetic(1, 3).to_csv();
    /// assert!(csv.starts_with("dt,left,right,dx,dy,dtheta\n"));
    /// assert_eq!(csv.lines().count(), 4);
    /// ```
    pub fn to_csv(&self) -> String {
        use std::fmt::Write as _;
        let mut out = String::from("dt,left,right,dx,dy,dtheta\n");
        for (i, dt) in self.intervals.iter().zip(&self.dt) {
            let w = i.wheels.iter().fold([0.0, 0.0], |a, w| [a[0] + w[0], a[1] + w[1]]);
            let s = i.sensor;
            // (writing to a String cannot fail)
            let _ = writeln!(out, "{dt},{},{},{},{},{}", w[0], w[1], s[0], s[1], s[2]);
        }
        out
    }
}

fn block_sigmas(s: &Solved) -> (f64, f64) {
    let n = s.rt.len() as f64;
    (
        s.rt.iter().map(|r| r * r).sum::<f64>() / (n - 2.0),
        s.rxy.iter().map(|r| r.norm_squared()).sum::<f64>() / (2.0 * n - 4.0),
    )
}

fn covariance(data: &[Interval], kept: &[usize], s: &Solved, s2t: f64, s2xy: f64) -> DMatrix<f64> {
    let nk = kept.len();
    let p = s.p;
    // step 1
    let mut n = Matrix2::zeros();
    for &k in kept {
        let phi = data[k]
            .wheels
            .iter()
            .fold(Vector2::zeros(), |a, w| a + Vector2::new(w[0], w[1]));
        n += phi * phi.transpose();
    }
    let cov_j = n.try_inverse().expect("checked in solve") * s2t;
    // step 2: J_ψ exact, J_J by central differences
    let (sl, cl) = p[5].sin_cos();
    let mut jpsi = DMatrix::zeros(2 * nk, 4);
    for (i, &k) in kept.iter().enumerate() {
        let u = unit_odometry(p[0], p[1], &data[k].wheels);
        let l = l_rows(&u, &data[k].sensor);
        for r in 0..2 {
            jpsi[(2 * i + r, 0)] = l[(r, 0)];
            jpsi[(2 * i + r, 1)] = l[(r, 1)];
            jpsi[(2 * i + r, 2)] = l[(r, 2)];
            jpsi[(2 * i + r, 3)] = -sl * l[(r, 3)] + cl * l[(r, 4)];
        }
    }
    let mut jj = DMatrix::zeros(2 * nk, 2);
    for c in 0..2 {
        let h = 1e-6 * p[c].abs().max(1e-12);
        let (mut pp, mut pm) = (p, p);
        pp[c] += h;
        pm[c] -= h;
        let (_, rp) = residuals(data, kept, &pp);
        let (_, rm) = residuals(data, kept, &pm);
        for i in 0..nk {
            let d = (rp[i] - rm[i]) / (2.0 * h);
            jj[(2 * i, c)] = d[0];
            jj[(2 * i + 1, c)] = d[1];
        }
    }
    let h = jpsi.transpose() * &jpsi;
    let hinv = h
        .clone()
        .try_inverse()
        .unwrap_or_else(|| h.pseudo_inverse(1e-300).expect("pseudo-inverse"));
    let k = &hinv * jpsi.transpose() * jj;
    let cj = DMatrix::from_fn(2, 2, |i, j| cov_j[(i, j)]);
    let cpsi = &hinv * s2xy + &k * &cj * k.transpose();
    let cross = -(&k * &cj);
    let mut cov = DMatrix::zeros(6, 6);
    cov.view_mut((0, 0), (2, 2)).copy_from(&cj);
    cov.view_mut((2, 2), (4, 4)).copy_from(&cpsi);
    cov.view_mut((2, 0), (4, 2)).copy_from(&cross);
    cov.view_mut((0, 2), (2, 4)).copy_from(&cross.transpose());
    cov
}

//! UMBmark calibration (Borenstein & Feng 1996, "Measurement and correction of
//! systematic odometry errors in mobile robots", IEEE T-RA 12(6)).
//!
//! **Conventions.** Each run starts at the origin heading along +x (θ = 0) and drives a
//! square of side `L` with on-the-spot 90° turns: left turns for the counter-clockwise
//! (ccw) run, right turns for the clockwise (cw) run, back to where the odometry believes
//! the start is. The return error is `ε = (x, y) = truth − odometry` at the end (the
//! paper's `ε = x_abs − x_calc`), as [`crate::reckoning::drift::return_error`] gives it.
//! `α > 0` is an under-turn of every 90° turn (wheelbase too large, `E_b > 1`), `β > 0`
//! a left-curving straight leg (right wheel larger, `E_d = D_R/D_L > 1`).
//!
//! To first order in `α, β` the centres of gravity of the return errors are
//! `x_cw = y_cw = −2L(α + β)`, `x_ccw = −y_ccw = 2L(β − α)`, which gives the paper's
//! `α = (x_cw + x_ccw)/(−4L) = (y_cw − y_ccw)/(−4L)` and
//! `β = (x_cw − x_ccw)/(−4L) = (y_cw + y_ccw)/(−4L)` (in radians; the paper writes
//! them in degrees with a factor 180/π). [`calibrate`] takes the mean of the x and the y
//! form of each, which is the least-squares fit of `(α, β)` to the four coordinates
//! (the two columns are orthogonal), and returns the four coordinates' residuals.

use super::Estimate;
use crate::error::{Error, Result};
use crate::reckoning::encoder_sim::EncoderErrors;
use nalgebra::{DMatrix, Matrix2, Vector2};
use std::f64::consts::FRAC_PI_2;

/// The result of a UMBmark calibration.
///
/// ```
/// use reckon::calibration::umbmark::calibrate;
/// use nalgebra::Vector2;
/// // a pure wheelbase error: α = 0.01 rad ⇒ x_cw = y_cw = x_ccw = −y_ccw = −2Lα
/// let (l, a) = (4.0, 0.01);
/// let fit = calibrate(&[Vector2::new(-2.0 * l * a, -2.0 * l * a)], &[Vector2::new(-2.0 * l * a, 2.0 * l * a)], l, 0.5).unwrap();
/// assert!((fit.alpha - a).abs() < 1e-15 && fit.beta.abs() < 1e-15);
/// assert!((fit.e_b() - FRAC_PI_2 / (FRAC_PI_2 - a)).abs() < 1e-14);
/// assert_eq!(fit.e_d(), 1.0);
/// # use std::f64::consts::FRAC_PI_2;
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct UmbmarkFit {
    /// `E_d` and `E_b` with their covariance; residuals are the four centre-of-gravity
    /// coordinates `(x_cw, y_cw, x_ccw, y_ccw)` minus the first-order model's.
    pub estimate: Estimate,
    /// Turn error `α` (rad): every 90° turn turns `π/2 − α`.
    pub alpha: f64,
    /// Leg curvature error `β` (rad): every straight leg turns left by `β`.
    pub beta: f64,
    /// `R = (L/2)/sin(β/2)`, the radius of the curved legs (m); `+∞` when `β = 0`.
    pub radius: f64,
    /// Centre of gravity of the clockwise return errors `(x_c.g.,cw, y_c.g.,cw)`.
    pub cg_cw: Vector2<f64>,
    /// Centre of gravity of the counter-clockwise return errors.
    pub cg_ccw: Vector2<f64>,
}

impl UmbmarkFit {
    /// `E_d = D_R/D_L = (R + b/2)/(R − b/2)`.
    ///
    /// ```
    /// # use reckon::calibration::umbmark::calibrate;
    /// # use nalgebra::Vector2;
    /// let fit = calibrate(&[Vector2::new(0.0, 0.0)], &[Vector2::new(0.0, 0.0)], 4.0, 0.5).unwrap();
    /// assert_eq!((fit.e_d(), fit.e_b()), (1.0, 1.0));
    /// ```
    pub fn e_d(&self) -> f64 {
        self.estimate.value[0]
    }

    /// `E_b = (π/2)/(π/2 − α)`, the actual wheelbase ÷ nominal.
    ///
    /// ```
    /// # use reckon::calibration::umbmark::calibrate;
    /// # use nalgebra::Vector2;
    /// let fit = calibrate(&[Vector2::new(-0.08, -0.08)], &[Vector2::new(-0.08, 0.08)], 4.0, 0.5).unwrap();
    /// assert!((fit.e_b() - 1.0 / (1.0 - 0.01 / std::f64::consts::FRAC_PI_2)).abs() < 1e-14);
    /// ```
    pub fn e_b(&self) -> f64 {
        self.estimate.value[1]
    }

    /// Corrected wheel diameters `D_L = 2/(E_d + 1)·D`, `D_R = 2/(1/E_d + 1)·D` (their mean
    /// stays the nominal `D`).
    ///
    /// ```
    /// # use reckon::calibration::umbmark::calibrate;
    /// # use nalgebra::Vector2;
    /// let mut fit = calibrate(&[Vector2::new(0.0, 0.0)], &[Vector2::new(0.0, 0.0)], 4.0, 0.5).unwrap();
    /// fit.estimate.value[0] = 1.002;
    /// let (dl, dr) = fit.wheel_diameters(0.1);
    /// assert!((dr / dl - 1.002).abs() < 1e-15 && (dl + dr - 0.2).abs() < 1e-16);
    /// ```
    pub fn wheel_diameters(&self, nominal: f64) -> (f64, f64) {
        let ed = self.e_d();
        (2.0 / (ed + 1.0) * nominal, 2.0 / (1.0 / ed + 1.0) * nominal)
    }

    /// Corrected wheelbase `b_actual = E_b·b_nominal`.
    ///
    /// ```
    /// # use reckon::calibration::umbmark::calibrate;
    /// # use nalgebra::Vector2;
    /// let fit = calibrate(&[Vector2::new(0.0, 0.0)], &[Vector2::new(0.0, 0.0)], 4.0, 0.5).unwrap();
    /// assert_eq!(fit.wheelbase(0.5), 0.5);
    /// ```
    pub fn wheelbase(&self, nominal: f64) -> f64 {
        self.e_b() * nominal
    }

    /// `E_max,syst = max(|c.g._cw|, |c.g._ccw|)`, the paper's measure of systematic error.
    ///
    /// ```
    /// # use reckon::calibration::umbmark::calibrate;
    /// # use nalgebra::Vector2;
    /// let fit = calibrate(&[Vector2::new(0.3, 0.4)], &[Vector2::new(0.0, 0.1)], 4.0, 0.5).unwrap();
    /// assert!((fit.e_max_syst() - 0.5).abs() < 1e-15);
    /// ```
    pub fn e_max_syst(&self) -> f64 {
        self.cg_cw.norm().max(self.cg_ccw.norm())
    }

    /// The errors left after the correction, for simulating the corrected robot: a robot
    /// whose controller and odometry use `D_L, D_R, b_actual` from this fit and whose true
    /// geometry is `truth` behaves as the nominal robot with the scales
    /// `left_scale/(D_L/D)`, `right_scale/(D_R/D)`, `wheelbase_scale/E_b`.
    ///
    /// ```
    /// # use reckon::calibration::umbmark::calibrate;
    /// # use nalgebra::Vector2;
    /// use reckon::reckoning::encoder_sim::EncoderErrors;
    /// let fit = calibrate(&[Vector2::new(0.0, 0.0)], &[Vector2::new(0.0, 0.0)], 4.0, 0.5).unwrap();
    /// let e = EncoderErrors { wheelbase_scale: 1.01, ..Default::default() };
    /// assert_eq!(fit.residual_errors(&e).wheelbase_scale, 1.01);
    /// ```
    pub fn residual_errors(&self, truth: &EncoderErrors) -> EncoderErrors {
        let (cl, cr) = self.wheel_diameters(1.0);
        EncoderErrors {
            left_scale: truth.left_scale / cl,
            right_scale: truth.right_scale / cr,
            wheelbase_scale: truth.wheelbase_scale / self.e_b(),
            ..*truth
        }
    }
}

/// Sample mean and covariance of the mean (`S/n`, `S` the sample covariance with `n − 1`).
fn centre(runs: &[Vector2<f64>]) -> (Vector2<f64>, Option<Matrix2<f64>>) {
    let n = runs.len() as f64;
    let mean = runs.iter().sum::<Vector2<f64>>() / n;
    if runs.len() < 2 {
        return (mean, None);
    }
    let s = runs
        .iter()
        .map(|r| (r - mean) * (r - mean).transpose())
        .sum::<Matrix2<f64>>()
        / (n - 1.0);
    (mean, Some(s / n))
}

/// UMBmark: `E_d`, `E_b` from the return errors `ε = truth − odometry` of clockwise runs
/// `cw` and counter-clockwise runs `ccw` of a square of side `side` (m), for a robot of
/// nominal wheelbase `wheelbase` (m), conventions as in the [module](self) docs:
///
/// `α = (x_cw + x_ccw)/(−4L)`, `β = (x_cw − x_ccw)/(−4L)` (each averaged with its y form),
/// `R = (L/2)/sin(β/2)`, `E_d = (R + b/2)/(R − b/2)`, `E_b = (π/2)/(π/2 − α)`.
///
/// Covariance: with at least two runs per direction, each centre of gravity's covariance
/// is its runs' sample covariance ÷ n; otherwise both are `σ̂²·I` with `σ̂²` from the
/// two-degree-of-freedom fit's residuals. It is propagated linearly to `(α, β)` and then
/// to first order (`∂E_b/∂α = (π/2)/(π/2 − α)²`, `∂E_d/∂β`) to `(E_d, E_b)`.
/// The formulas are first order in `α, β`: the recovered factors carry errors of the
/// relative size of `α` and `β`.
///
/// ```
/// use reckon::calibration::umbmark::calibrate;
/// use reckon::reckoning::{drift::umbmark, encoders::DiffDrive, encoder_sim::EncoderErrors};
/// let robot = DiffDrive::new(0.1, 0.5, 1000.0).unwrap();
/// let (ed, eb) = (1.002, 1.01);
/// let e = EncoderErrors { left_scale: 2.0 / (ed + 1.0), right_scale: 2.0 / (1.0 / ed + 1.0), wheelbase_scale: eb, ..Default::default() };
/// let u = umbmark(&robot, &e, 4.0, 0.5, 0.5, 0.01).unwrap();
/// let xy = |v: nalgebra::Vector3<f64>| v.fixed_rows::<2>(0).into_owned();
/// let fit = calibrate(&[xy(u.cw)], &[xy(u.ccw)], 4.0, 0.5).unwrap();
/// assert!((fit.e_d() - ed).abs() < 1e-4 && (fit.e_b() - eb).abs() < 1e-3);
/// ```
pub fn calibrate(cw: &[Vector2<f64>], ccw: &[Vector2<f64>], side: f64, wheelbase: f64) -> Result<UmbmarkFit> {
    if cw.is_empty() || ccw.is_empty() {
        return Err(Error::invalid(
            "runs",
            "UMBmark needs at least one clockwise and one counter-clockwise run",
        ));
    }
    for (what, v) in [("side", side), ("wheelbase", wheelbase)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::invalid(what, format!("must be finite and positive, got {v}")));
        }
    }
    if let Some(k) = cw
        .iter()
        .chain(ccw)
        .position(|r| !(r[0].is_finite() && r[1].is_finite()))
    {
        return Err(Error::invalid("runs", format!("return error {k} is not finite")));
    }
    let (gcw, scw) = centre(cw);
    let (gccw, sccw) = centre(ccw);
    let l = side;
    let z = [gcw[0], gcw[1], gccw[0], gccw[1]];
    let ga = [-1.0, -1.0, -1.0, 1.0].map(|c| c / (8.0 * l));
    let gb = [-1.0, -1.0, 1.0, -1.0].map(|c| c / (8.0 * l));
    let dot = |g: &[f64; 4]| g.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>();
    let (alpha, beta) = (dot(&ga), dot(&gb));
    let model = [
        -2.0 * l * (alpha + beta),
        -2.0 * l * (alpha + beta),
        2.0 * l * (beta - alpha),
        -2.0 * l * (beta - alpha),
    ];
    let residuals: Vec<f64> = z.iter().zip(&model).map(|(a, b)| a - b).collect();
    if alpha >= FRAC_PI_2 {
        return Err(Error::Unidentifiable {
            parameter: "E_b".into(),
            reason: format!(
                "the turn error α = {alpha} rad is not below 90°: the return errors are too large for UMBmark's first-order model"
            ),
        });
    }
    // E_d = (R + b/2)/(R − b/2) = (1 + q)/(1 − q) with q = b/(2R) = b·sin(β/2)/L
    let q = wheelbase * (0.5 * beta).sin() / l;
    if q.abs() >= 1.0 {
        return Err(Error::Unidentifiable {
            parameter: "E_d".into(),
            reason: format!("the curved legs' radius R = (L/2)/sin(β/2) is not larger than b/2 (β = {beta} rad)"),
        });
    }
    let e_d = (1.0 + q) / (1.0 - q);
    let e_b = FRAC_PI_2 / (FRAC_PI_2 - alpha);
    let radius = if beta == 0.0 {
        f64::INFINITY
    } else {
        0.5 * l / (0.5 * beta).sin()
    };
    // covariance of z = (x_cw, y_cw, x_ccw, y_ccw)
    let mut cz = DMatrix::zeros(4, 4);
    match (scw, sccw) {
        (Some(a), Some(b)) => {
            cz.view_mut((0, 0), (2, 2)).copy_from(&a);
            cz.view_mut((2, 2), (2, 2)).copy_from(&b);
        }
        _ => {
            let s2 = residuals.iter().map(|r| r * r).sum::<f64>() / 2.0;
            cz.fill_diagonal(s2);
        }
    }
    let g = DMatrix::from_row_slice(2, 4, &[ga, gb].concat());
    let cab = &g * cz * g.transpose();
    let de_d = 2.0 / ((1.0 - q) * (1.0 - q)) * wheelbase * (0.5 * beta).cos() / (2.0 * l);
    let de_b = FRAC_PI_2 / ((FRAC_PI_2 - alpha) * (FRAC_PI_2 - alpha));
    // (E_d, E_b) from (α, β)
    let d = DMatrix::from_row_slice(2, 2, &[0.0, de_d, de_b, 0.0]);
    let covariance = &d * cab * d.transpose();
    Ok(UmbmarkFit {
        estimate: Estimate::new(vec!["E_d", "E_b"], vec![e_d, e_b], covariance, residuals),
        alpha,
        beta,
        radius,
        cg_cw: gcw,
        cg_ccw: gccw,
    })
}

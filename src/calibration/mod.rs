//! Odometry calibration: parameters estimated from test drives, each returned as an
//! [`Estimate`] (values, covariance, residuals).
//!
//! - [`umbmark`]: Borenstein & Feng's bidirectional square test (1996): the correction
//!   factors `E_d` (wheel diameter ratio) and `E_b` (wheelbase) from the return errors of
//!   clockwise and counter-clockwise squares.
//! - [`censi`]: Censi, Franchi, Marchionni & Oriolo (2013): wheel radii, wheel base and
//!   the pose of an exteroceptive sensor from intervals of wheel rotations and measured
//!   sensor displacements.

pub mod censi;
pub mod lsq;
pub mod umbmark;

use nalgebra::DMatrix;

/// A calibrated parameter vector `p̂` with its covariance `Σ_p̂` and the residuals `r` of
/// the fit, `σ̂² = ‖r‖²/dof` with `dof = (number of residuals) − (number of parameters)`.
///
/// ```
/// use reckon::calibration::Estimate;
/// use nalgebra::DMatrix;
/// let cov = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![4.0, 9.0]));
/// let e = Estimate::new(vec!["a", "b"], vec![1.0, 2.0], cov, vec![0.5, -0.5, 1.0]);
/// assert_eq!(e.std_dev(), vec![2.0, 3.0]);
/// assert_eq!(e.dof, 1);
/// assert!((e.sigma2 - 1.5).abs() < 1e-15);
/// assert_eq!(e.get("b"), Some((2.0, 3.0)));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// Parameter names, in the order of `value` and of the covariance's rows.
    pub names: Vec<String>,
    /// Estimated values `p̂`.
    pub value: Vec<f64>,
    /// Covariance `Σ_p̂` (`names.len()` square).
    pub covariance: DMatrix<f64>,
    /// Residuals of the fit (what each method documents them to be).
    pub residuals: Vec<f64>,
    /// Degrees of freedom: residuals − parameters (0 when there are not more residuals).
    pub dof: usize,
    /// `σ̂² = ‖r‖²/dof` (0 when `dof = 0`).
    pub sigma2: f64,
}

impl Estimate {
    /// An estimate with `dof = len(r) − len(p̂)` (saturating) and `σ̂² = ‖r‖²/dof`.
    ///
    /// ```
    /// use reckon::calibration::Estimate;
    /// let e = Estimate::new(vec!["x"], vec![3.0], nalgebra::DMatrix::from_element(1, 1, 0.25), vec![1.0, 1.0, 2.0]);
    /// assert_eq!((e.dof, e.sigma2), (2, 3.0));
    /// ```
    pub fn new<N: Into<String>>(
        names: impl IntoIterator<Item = N>,
        value: Vec<f64>,
        covariance: DMatrix<f64>,
        residuals: Vec<f64>,
    ) -> Self {
        let names = names.into_iter().map(Into::into).collect();
        let dof = residuals.len().saturating_sub(value.len());
        let rss: f64 = residuals.iter().map(|r| r * r).sum();
        let sigma2 = if dof > 0 { rss / dof as f64 } else { 0.0 };
        Estimate {
            names,
            value,
            covariance,
            residuals,
            dof,
            sigma2,
        }
    }

    /// Standard deviations `σ_i = √(Σ_p̂)_ii`.
    ///
    /// ```
    /// use reckon::calibration::Estimate;
    /// let e = Estimate::new(vec!["x"], vec![3.0], nalgebra::DMatrix::from_element(1, 1, 0.25), vec![]);
    /// assert_eq!(e.std_dev(), vec![0.5]);
    /// ```
    pub fn std_dev(&self) -> Vec<f64> {
        (0..self.value.len())
            .map(|i| self.covariance[(i, i)].max(0.0).sqrt())
            .collect()
    }

    /// `(p̂_i, σ_i)` of the parameter called `name`.
    ///
    /// ```
    /// use reckon::calibration::Estimate;
    /// let e = Estimate::new(vec!["x"], vec![3.0], nalgebra::DMatrix::from_element(1, 1, 0.25), vec![]);
    /// assert_eq!(e.get("x"), Some((3.0, 0.5)));
    /// assert_eq!(e.get("y"), None);
    /// ```
    pub fn get(&self, name: &str) -> Option<(f64, f64)> {
        let i = self.names.iter().position(|n| n == name)?;
        Some((self.value[i], self.covariance[(i, i)].max(0.0).sqrt()))
    }
}

//! IMU preintegration on the manifold (Forster, Carlone, Dellaert and Scaramuzza,
//! "On-Manifold Preintegration for Real-Time Visual-Inertial Odometry", IEEE T-RO 2017,
//! §V–VI; equation numbers below are theirs): the rotation, velocity and position
//! increments `ΔR, Δv, Δp` between two times from raw gyro and accelerometer samples,
//! their 9×9 covariance, the first-order bias Jacobians, the bias-corrected increments and
//! the prediction of a navigation state across the interval.
//!
//! It follows GTSAM's `ManifoldPreintegration` (its `PreintegratedImuMeasurementsManifold`)
//! step for step, and agrees with it to rounding (`tests/it/lie.rs`, reference values from
//! `docs/lie/gtsam_preintegration.py`). Each sample `(ω̃, ã)` is held over its `dt`;
//! with `ω̂ = ω̃ − b̂_g`, `â = ã − b̂_a` (the bias estimate subtracted):
//! `Δp ← Δp + Δv·dt + ½ΔR·â·dt²`, `Δv ← Δv + ΔR·â·dt`, `ΔR ← ΔR·Exp(ω̂·dt)` (eq. 24–26,
//! each with the old `ΔR`, `Δv`).
//!
//! **Covariance.** Noise densities are continuous-time, as GTSAM's
//! `PreintegrationParams` (`gyroscopeCovariance`, `accelerometerCovariance`: σ² per Hz),
//! discretised as `Σ/dt` per sample; `integrationCovariance` adds `Σ_int·dt` to the
//! position block (in GTSAM's frame, see below) each sample. reckon keeps the covariance
//! in Forster's coordinates and order `[δφ, δv, δp]` (eq. 62–63:
//! `ΔR = ΔR̄·Exp(δφ)`, `Δv = Δv̄ + δv`, `Δp = Δp̄ + δp`, additive in the frame at the
//! first time). GTSAM's `preintMeasCov` is ordered `[δθ, δp, δv]` and takes position and
//! velocity errors in the body frame at the second time (`NavState::retract`:
//! `p = p̄ + ΔR̄·δp_b`), so `Σ_gtsam = T·Σ·Tᵀ` with
//! `T = [[I, 0, 0], [0, 0, ΔR̄ᵀ], [0, ΔR̄ᵀ, 0]]` ([`Preintegrated::covariance_gtsam`]).
//!
//! The PyPI `gtsam` (4.3) builds `PreintegratedImuMeasurements` as its tangent-space
//! variant (`GTSAM_TANGENT_PREINTEGRATION`: `θ ← θ + J_r⁻¹(θ)·ω̂·dt`), a different
//! discretisation, 10⁻⁶ to 10⁻³ away from this one on the reference sequences; compare
//! with `PreintegratedImuMeasurementsManifold`.
//!
//! Frames as in [`crate::reckoning::imu`]: the accelerometer measures specific force
//! `f = Rᵀ(a − g)`; [`PreintegrationParams::up`] is GTSAM's `MakeSharedU` (z up,
//! `g = (0, 0, −g)`), [`PreintegrationParams::down`] its `MakeSharedD` (NED).

use crate::error::{Error, Result};
use crate::lie::{So3, hat};
use crate::reckoning::imu::{ImuSample, Nav};
use nalgebra::{Matrix3, SMatrix, Vector3};

/// A 9×9 matrix (the preintegration covariance).
pub type Matrix9 = SMatrix<f64, 9, 9>;

/// Gravity and sensor noise for preintegration, GTSAM's `PreintegrationParams`: the
/// covariances are continuous-time (`σ²` per Hz: (rad/s)²/Hz, (m/s²)²/Hz, m²/s²/Hz, the
/// squares of the noise densities), each `I₃` by default as in GTSAM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PreintegrationParams {
    /// Gravity in the world frame (m/s²).
    pub gravity: Vector3<f64>,
    /// Gyro white-noise covariance density (GTSAM's `gyroscopeCovariance`).
    pub gyro_covariance: Matrix3<f64>,
    /// Accelerometer white-noise covariance density (`accelerometerCovariance`).
    pub accel_covariance: Matrix3<f64>,
    /// Integration (position) uncertainty density (`integrationCovariance`).
    pub integration_covariance: Matrix3<f64>,
}

/// `Ok(m)` if `m` is finite, symmetric and has a non-negative diagonal.
fn covariance(what: &'static str, m: Matrix3<f64>) -> Result<Matrix3<f64>> {
    if !m.iter().all(|x| x.is_finite()) {
        return Err(Error::invalid(what, "non-finite entry"));
    }
    if (m - m.transpose()).amax() > 1e-12 * m.amax() {
        return Err(Error::invalid(what, "not symmetric"));
    }
    if (0..3).any(|i| m[(i, i)] < 0.0) {
        return Err(Error::invalid(what, "negative variance"));
    }
    Ok(m)
}

impl PreintegrationParams {
    /// World z up, `g = (0, 0, −g)` (GTSAM's `MakeSharedU(g)`), covariances `I₃`; or
    /// [`Error::InvalidInput`] for a non-finite `g`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::PreintegrationParams;
    /// let p = PreintegrationParams::up(9.81).unwrap();
    /// assert_eq!(p.gravity.z, -9.81);
    /// ```
    pub fn up(g: f64) -> Result<Self> {
        Self::with_gravity(Vector3::new(0.0, 0.0, -g))
    }

    /// World z down (NED), `g = (0, 0, g)` (GTSAM's `MakeSharedD(g)`), covariances `I₃`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::PreintegrationParams;
    /// assert_eq!(PreintegrationParams::down(9.81).unwrap().gravity.z, 9.81);
    /// ```
    pub fn down(g: f64) -> Result<Self> {
        Self::with_gravity(Vector3::new(0.0, 0.0, g))
    }

    /// Any gravity vector, covariances `I₃`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::PreintegrationParams;
    /// use nalgebra::vector;
    /// assert!(PreintegrationParams::with_gravity(vector![0.0, f64::NAN, 0.0]).is_err());
    /// ```
    pub fn with_gravity(gravity: Vector3<f64>) -> Result<Self> {
        if !gravity.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid("gravity", "non-finite"));
        }
        Ok(PreintegrationParams {
            gravity,
            gyro_covariance: Matrix3::identity(),
            accel_covariance: Matrix3::identity(),
            integration_covariance: Matrix3::identity(),
        })
    }

    /// Gyro covariance density `Σ_g` (symmetric, finite, non-negative diagonal).
    ///
    /// ```
    /// use reckon::reckoning::preintegration::PreintegrationParams;
    /// use nalgebra::Matrix3;
    /// let p = PreintegrationParams::up(9.81).unwrap().gyro(Matrix3::identity() * 1e-6).unwrap();
    /// assert_eq!(p.gyro_covariance[(0, 0)], 1e-6);
    /// assert!(PreintegrationParams::up(9.81).unwrap().gyro(-Matrix3::identity()).is_err());
    /// ```
    pub fn gyro(mut self, cov: Matrix3<f64>) -> Result<Self> {
        self.gyro_covariance = covariance("gyro covariance", cov)?;
        Ok(self)
    }

    /// Accelerometer covariance density `Σ_a`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::PreintegrationParams;
    /// use nalgebra::Matrix3;
    /// let p = PreintegrationParams::up(9.81).unwrap().accel(Matrix3::identity() * 1e-4).unwrap();
    /// assert_eq!(p.accel_covariance[(2, 2)], 1e-4);
    /// ```
    pub fn accel(mut self, cov: Matrix3<f64>) -> Result<Self> {
        self.accel_covariance = covariance("accelerometer covariance", cov)?;
        Ok(self)
    }

    /// Integration covariance density `Σ_int` (added as `Σ_int·dt` per sample).
    ///
    /// ```
    /// use reckon::reckoning::preintegration::PreintegrationParams;
    /// use nalgebra::Matrix3;
    /// let p = PreintegrationParams::up(9.81).unwrap().integration(Matrix3::zeros()).unwrap();
    /// assert_eq!(p.integration_covariance, Matrix3::zeros());
    /// ```
    pub fn integration(mut self, cov: Matrix3<f64>) -> Result<Self> {
        self.integration_covariance = covariance("integration covariance", cov)?;
        Ok(self)
    }
}

/// Constant IMU biases `b = (b_g, b_a)`: a sensor reads `ω̃ = ω + b_g`, `f̃ = f + b_a`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Bias {
    /// Gyro bias (rad/s).
    pub gyro: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub accel: Vector3<f64>,
}

/// The first-order bias Jacobians of the increments at the bias estimate `b̂` (eq. 44):
/// `ΔR(b) ≈ ΔR·Exp(∂ΔR/∂b_g·δb_g)`, `Δv(b) ≈ Δv + ∂Δv/∂b_g·δb_g + ∂Δv/∂b_a·δb_a`, the same
/// for `Δp`, with `δb = b − b̂`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasJacobians {
    /// `∂ΔR/∂b_g` (right-perturbation tangent of `ΔR`).
    pub d_rotation_d_gyro: Matrix3<f64>,
    /// `∂Δv/∂b_g`.
    pub d_velocity_d_gyro: Matrix3<f64>,
    /// `∂Δv/∂b_a`.
    pub d_velocity_d_accel: Matrix3<f64>,
    /// `∂Δp/∂b_g`.
    pub d_position_d_gyro: Matrix3<f64>,
    /// `∂Δp/∂b_a`.
    pub d_position_d_accel: Matrix3<f64>,
}

/// Preintegrated IMU measurements between two times (GTSAM's
/// `PreintegratedImuMeasurementsManifold`): increments, covariance and bias Jacobians,
/// updated sample by sample.
///
/// ```
/// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
/// use reckon::reckoning::imu::Nav;
/// use nalgebra::{vector, Matrix3};
/// // a level IMU at rest for 1 s reads f = (0, 0, g): Δv = (0, 0, g·Δt), Δp = (0, 0, ½g·Δt²)
/// let params = PreintegrationParams::up(9.81).unwrap().accel(Matrix3::identity() * 1e-4).unwrap();
/// let mut pim = Preintegrated::new(params, Bias::default());
/// for _ in 0..100 {
///     pim.integrate(&vector![0.0, 0.0, 0.0], &vector![0.0, 0.0, 9.81], 0.01).unwrap();
/// }
/// assert!((pim.delta_v() - vector![0.0, 0.0, 9.81]).norm() < 1e-13);
/// assert!((pim.delta_p() - vector![0.0, 0.0, 4.905]).norm() < 1e-13);
/// // and the state predicted across it has not moved
/// let nav = pim.predict(&Nav::level(), &Bias::default());
/// assert!(nav.p.norm() < 1e-13 && nav.v.norm() < 1e-13);
/// // velocity variance: a random walk, σ²·Δt
/// assert!((pim.covariance()[(5, 5)] - 1e-4).abs() < 1e-18);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Preintegrated {
    params: PreintegrationParams,
    bias_hat: Bias,
    delta_t: f64,
    delta_r: So3,
    delta_v: Vector3<f64>,
    delta_p: Vector3<f64>,
    cov: Matrix9,
    jac: BiasJacobians,
}

impl Preintegrated {
    /// Nothing integrated yet: `ΔR = I`, `Δv = Δp = 0`, `Σ = 0`, Jacobians 0, at bias
    /// estimate `b̂`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// let pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// assert_eq!(pim.delta_t(), 0.0);
    /// ```
    pub fn new(params: PreintegrationParams, bias_hat: Bias) -> Self {
        Preintegrated {
            params,
            bias_hat,
            delta_t: 0.0,
            delta_r: So3::identity(),
            delta_v: Vector3::zeros(),
            delta_p: Vector3::zeros(),
            cov: Matrix9::zeros(),
            jac: BiasJacobians {
                d_rotation_d_gyro: Matrix3::zeros(),
                d_velocity_d_gyro: Matrix3::zeros(),
                d_velocity_d_accel: Matrix3::zeros(),
                d_position_d_gyro: Matrix3::zeros(),
                d_position_d_accel: Matrix3::zeros(),
            },
        }
    }

    /// Preintegrate samples held until the next one (as
    /// [`strapdown`](crate::reckoning::imu::strapdown)): sample `k` over
    /// `t_{k+1} − t_k`; the last sample's time is the end. [`Error::InvalidInput`] for
    /// fewer than two samples or a time that does not increase.
    ///
    /// ```
    /// use reckon::reckoning::imu::ImuSample;
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{vector, Vector3};
    /// // 1 rad/s about z for 2 s: ΔR is the rotation by 2 rad
    /// let s: Vec<_> = (0..=20).map(|k| ImuSample { t: 0.1 * k as f64, gyro: vector![0.0, 0.0, 1.0], accel: Vector3::zeros() }).collect();
    /// let pim = Preintegrated::from_samples(PreintegrationParams::up(9.81).unwrap(), Bias::default(), &s).unwrap();
    /// assert!((pim.delta_r().log() - vector![0.0, 0.0, 2.0]).norm() < 1e-14);
    /// ```
    pub fn from_samples(params: PreintegrationParams, bias_hat: Bias, samples: &[ImuSample]) -> Result<Self> {
        if samples.len() < 2 {
            return Err(Error::invalid("samples", "at least two IMU samples are needed"));
        }
        let mut pim = Self::new(params, bias_hat);
        for w in samples.windows(2) {
            pim.integrate(&w[0].gyro, &w[0].accel, w[1].t - w[0].t)?;
        }
        Ok(pim)
    }

    /// Add one sample `(ω̃, ã)` held over `dt > 0` (GTSAM's `integrateMeasurement(ã, ω̃,
    /// dt)`; note the order): with `ω̂ = ω̃ − b̂_g`, `â = ã − b̂_a`, `ΔR_k` the rotation so far
    /// and `E = Exp(ω̂·dt)`,
    /// - bias Jacobians (eq. 69, Appendix B): `∂Δp/∂b_a += ∂Δv/∂b_a·dt − ½ΔR_k·dt²`,
    ///   `∂Δp/∂b_g += ∂Δv/∂b_g·dt − ½ΔR_k[â]×∂ΔR/∂b_g·dt²`, `∂Δv/∂b_a −= ΔR_k·dt`,
    ///   `∂Δv/∂b_g −= ΔR_k[â]×∂ΔR/∂b_g·dt`, `∂ΔR/∂b_g ← Eᵀ·∂ΔR/∂b_g − J_r(ω̂·dt)·dt`;
    /// - covariance (eq. 63): `Σ ← AΣAᵀ + B_g(Σ_g/dt)B_gᵀ + B_a(Σ_a/dt)B_aᵀ`, with
    ///   `A = [[Eᵀ, 0, 0], [−ΔR_k[â]×dt, I, 0], [−½ΔR_k[â]×dt², I·dt, I]]`,
    ///   `B_g = [J_r(ω̂·dt)·dt; 0; 0]`, `B_a = [0; ΔR_k·dt; ½ΔR_k·dt²]`; then
    ///   `Σ_pp += ΔR_{k+1}Σ_int ΔR_{k+1}ᵀ·dt` (GTSAM's `integrationCovariance`, which it adds
    ///   in the body frame);
    /// - increments: `Δp += Δv·dt + ½ΔR_k·â·dt²`, `Δv += ΔR_k·â·dt`, `ΔR_{k+1} = ΔR_k·E`.
    ///
    /// [`Error::InvalidInput`] for a non-positive or non-finite `dt` or a non-finite sample.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::vector;
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&vector![0.0, 0.0, 0.0], &vector![1.0, 0.0, 0.0], 0.5).unwrap();
    /// assert_eq!((pim.delta_v().x, pim.delta_p().x), (0.5, 0.125)); // a·dt, ½a·dt²
    /// assert!(pim.integrate(&vector![0.0, 0.0, 0.0], &vector![1.0, 0.0, 0.0], 0.0).is_err());
    /// ```
    pub fn integrate(&mut self, gyro: &Vector3<f64>, accel: &Vector3<f64>, dt: f64) -> Result<()> {
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(Error::invalid("dt", format!("{dt} is not a positive finite time step")));
        }
        if !gyro.iter().chain(accel.iter()).all(|x| x.is_finite()) {
            return Err(Error::invalid("IMU sample", "non-finite gyro or accelerometer value"));
        }
        let w = gyro - self.bias_hat.gyro;
        let a = accel - self.bias_hat.accel;
        let r = self.delta_r.matrix();
        let e = So3::exp(&(w * dt));
        let jr = So3::right_jacobian(&(w * dt));
        let ra = r * hat(&a);
        let dt2 = 0.5 * dt * dt;

        // bias Jacobians, with the old ΔR and ∂ΔR/∂b_g
        let j = &mut self.jac;
        j.d_position_d_accel += j.d_velocity_d_accel * dt - r * dt2;
        j.d_position_d_gyro += j.d_velocity_d_gyro * dt - ra * j.d_rotation_d_gyro * dt2;
        j.d_velocity_d_accel -= r * dt;
        j.d_velocity_d_gyro -= ra * j.d_rotation_d_gyro * dt;
        j.d_rotation_d_gyro = e.matrix().transpose() * j.d_rotation_d_gyro - jr * dt;

        // covariance in [δφ, δv, δp]
        let mut a_mat = Matrix9::identity();
        a_mat.fixed_view_mut::<3, 3>(0, 0).copy_from(&e.matrix().transpose());
        a_mat.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-ra * dt));
        a_mat.fixed_view_mut::<3, 3>(6, 0).copy_from(&(-ra * dt2));
        a_mat
            .fixed_view_mut::<3, 3>(6, 3)
            .copy_from(&(Matrix3::identity() * dt));
        let mut bg = SMatrix::<f64, 9, 3>::zeros();
        bg.fixed_view_mut::<3, 3>(0, 0).copy_from(&(jr * dt));
        let mut ba = SMatrix::<f64, 9, 3>::zeros();
        ba.fixed_view_mut::<3, 3>(3, 0).copy_from(&(r * dt));
        ba.fixed_view_mut::<3, 3>(6, 0).copy_from(&(r * dt2));
        let p = &self.params;
        self.cov = a_mat * self.cov * a_mat.transpose()
            + bg * (p.gyro_covariance / dt) * bg.transpose()
            + ba * (p.accel_covariance / dt) * ba.transpose();

        // increments
        self.delta_p += self.delta_v * dt + r * a * dt2;
        self.delta_v += r * a * dt;
        self.delta_r = self.delta_r.compose(&e);
        self.delta_t += dt;

        let r1 = self.delta_r.matrix();
        let int = r1 * p.integration_covariance * r1.transpose() * dt;
        let mut pp = self.cov.fixed_view_mut::<3, 3>(6, 6);
        pp += int;
        Ok(())
    }

    /// `Δt = Σ dt`, the time preintegrated.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::Vector3;
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&Vector3::zeros(), &Vector3::zeros(), 0.25).unwrap();
    /// assert_eq!(pim.delta_t(), 0.25);
    /// ```
    pub fn delta_t(&self) -> f64 {
        self.delta_t
    }

    /// `ΔR = Π Exp(ω̂_k·dt_k)`, the body's rotation from the first time to the last.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{vector, Vector3};
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&vector![0.5, 0.0, 0.0], &Vector3::zeros(), 2.0).unwrap();
    /// assert!((pim.delta_r().log() - vector![1.0, 0.0, 0.0]).norm() < 1e-15);
    /// ```
    pub fn delta_r(&self) -> So3 {
        self.delta_r
    }

    /// `Δv = Σ ΔR_k·â_k·dt_k`, in the body frame at the first time, gravity not included.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{vector, Vector3};
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&Vector3::zeros(), &vector![0.0, 2.0, 0.0], 0.5).unwrap();
    /// assert_eq!(pim.delta_v(), vector![0.0, 1.0, 0.0]);
    /// ```
    pub fn delta_v(&self) -> Vector3<f64> {
        self.delta_v
    }

    /// `Δp = Σ (Δv_k·dt_k + ½ΔR_k·â_k·dt_k²)`, in the body frame at the first time.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{vector, Vector3};
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&Vector3::zeros(), &vector![0.0, 2.0, 0.0], 0.5).unwrap();
    /// assert_eq!(pim.delta_p(), vector![0.0, 0.25, 0.0]);
    /// ```
    pub fn delta_p(&self) -> Vector3<f64> {
        self.delta_p
    }

    /// The bias estimate `b̂` the samples were corrected with.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// let pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// assert_eq!(pim.bias_hat(), Bias::default());
    /// ```
    pub fn bias_hat(&self) -> Bias {
        self.bias_hat
    }

    /// The 9×9 covariance of `[δφ, δv, δp]` (Forster's order and coordinates; see the
    /// module doc).
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{Matrix3, Vector3};
    /// let p = PreintegrationParams::up(9.81).unwrap().gyro(Matrix3::identity() * 1e-6).unwrap();
    /// let mut pim = Preintegrated::new(p, Bias::default());
    /// for _ in 0..10 { pim.integrate(&Vector3::zeros(), &Vector3::zeros(), 0.1).unwrap(); }
    /// assert!((pim.covariance()[(0, 0)] - 1e-6).abs() < 1e-20); // σ²·Δt, Δt = 1 s
    /// ```
    pub fn covariance(&self) -> Matrix9 {
        self.cov
    }

    /// The covariance as GTSAM's `preintMeasCov`: order `[δθ, δp, δv]`, position and
    /// velocity errors in the body frame at the last time: `T·Σ·Tᵀ`,
    /// `T = [[I, 0, 0], [0, 0, ΔRᵀ], [0, ΔRᵀ, 0]]`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{vector, Matrix3};
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&vector![0.0, 0.0, 1.0], &vector![1.0, 0.0, 0.0], 0.1).unwrap();
    /// let (f, g) = (pim.covariance(), pim.covariance_gtsam());
    /// assert_eq!(g[(0, 0)], f[(0, 0)]);
    /// assert!((g[(3, 3)] + g[(4, 4)] + g[(5, 5)] - (f[(6, 6)] + f[(7, 7)] + f[(8, 8)])).abs() < 1e-15);
    /// ```
    pub fn covariance_gtsam(&self) -> Matrix9 {
        let rt = self.delta_r.matrix().transpose();
        let mut t = Matrix9::zeros();
        t.fixed_view_mut::<3, 3>(0, 0).copy_from(&Matrix3::identity());
        t.fixed_view_mut::<3, 3>(3, 6).copy_from(&rt);
        t.fixed_view_mut::<3, 3>(6, 3).copy_from(&rt);
        t * self.cov * t.transpose()
    }

    /// The bias Jacobians at `b̂`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{Matrix3, Vector3};
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// for _ in 0..10 { pim.integrate(&Vector3::zeros(), &Vector3::zeros(), 0.1).unwrap(); }
    /// let j = pim.bias_jacobians();
    /// // without rotation: ∂Δv/∂b_a = −Δt·I, ∂Δp/∂b_a = −½Δt²·I, ∂ΔR/∂b_g = −Δt·I
    /// assert!((j.d_velocity_d_accel + Matrix3::identity()).amax() < 1e-15);
    /// assert!((j.d_position_d_accel + Matrix3::identity() * 0.5).amax() < 1e-15);
    /// assert!((j.d_rotation_d_gyro + Matrix3::identity()).amax() < 1e-15);
    /// ```
    pub fn bias_jacobians(&self) -> BiasJacobians {
        self.jac
    }

    /// The increments at another bias `b`, to first order without re-integration (eq. 44):
    /// `(ΔR·Exp(∂ΔR/∂b_g·δb_g), Δv + ∂Δv/∂b_g·δb_g + ∂Δv/∂b_a·δb_a, Δp + …)`, `δb = b − b̂`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use nalgebra::{vector, Vector3};
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&Vector3::zeros(), &vector![1.0, 0.0, 0.0], 1.0).unwrap();
    /// // an accelerometer bias of 0.1 along x removes 0.1 m/s from Δv: exact, Δv is linear in b_a
    /// let (_, dv, _) = pim.corrected(&Bias { gyro: Vector3::zeros(), accel: vector![0.1, 0.0, 0.0] });
    /// assert!((dv - vector![0.9, 0.0, 0.0]).norm() < 1e-15);
    /// ```
    pub fn corrected(&self, bias: &Bias) -> (So3, Vector3<f64>, Vector3<f64>) {
        let (dg, da) = (bias.gyro - self.bias_hat.gyro, bias.accel - self.bias_hat.accel);
        let j = &self.jac;
        (
            self.delta_r.compose(&So3::exp(&(j.d_rotation_d_gyro * dg))),
            self.delta_v + j.d_velocity_d_gyro * dg + j.d_velocity_d_accel * da,
            self.delta_p + j.d_position_d_gyro * dg + j.d_position_d_accel * da,
        )
    }

    /// The navigation state at the last time from the state at the first, with the
    /// increments corrected to bias `b` (eq. 45, GTSAM's `predict` without Coriolis):
    /// `R_j = R_i·ΔR(b)`, `v_j = v_i + g·Δt + R_i·Δv(b)`,
    /// `p_j = p_i + v_i·Δt + ½g·Δt² + R_i·Δp(b)`.
    ///
    /// ```
    /// use reckon::reckoning::preintegration::{Bias, Preintegrated, PreintegrationParams};
    /// use reckon::reckoning::imu::Nav;
    /// use nalgebra::{vector, Vector3};
    /// // an IMU reading nothing is in free fall: p = ½g·t²
    /// let mut pim = Preintegrated::new(PreintegrationParams::up(9.81).unwrap(), Bias::default());
    /// pim.integrate(&Vector3::zeros(), &Vector3::zeros(), 2.0).unwrap();
    /// let nav = pim.predict(&Nav::level(), &Bias::default());
    /// assert!((nav.p - vector![0.0, 0.0, -19.62]).norm() < 1e-14);
    /// ```
    pub fn predict(&self, nav: &Nav, bias: &Bias) -> Nav {
        let (dr, dv, dp) = self.corrected(bias);
        let (g, t) = (self.params.gravity, self.delta_t);
        Nav {
            r: nav.r * dr.matrix(),
            v: nav.v + g * t + nav.r * dv,
            p: nav.p + nav.v * t + g * (0.5 * t * t) + nav.r * dp,
        }
    }
}

//! Lie groups of vehicle poses: the rotations SO(3), the planar poses SE(2) and the rigid
//! motions SE(3), each with `exp`, `log`, composition, inverse, action on points, the
//! adjoint `Ad` and the right and left Jacobians with their inverses.
//!
//! Conventions (those of GTSAM's `Rot3`, `Pose2` and `Pose3`, so that numbers can be
//! compared with it directly):
//! - perturbations are on the right, `g·Exp(δ)`, and `exp(ξ + δ) ≈ exp(ξ)·exp(J_r(ξ)·δ)`;
//!   the left Jacobian is `J_l(ξ) = J_r(−ξ)`, with `exp(ξ + δ) ≈ exp(J_l(ξ)·δ)·exp(ξ)`;
//! - SO(3): `φ ∈ ℝ³`, the rotation vector;
//! - SE(3): `ξ = (φ, ρ)`, **rotation first** (GTSAM's `Pose3` orders `(ω, v)`; Barfoot
//!   and Furgale 2014 and Solà et al. 2018 order `(ρ, φ)`, so their 6×6 blocks appear
//!   transposed across the diagonal here);
//! - SE(2): `ξ = (ρ_x, ρ_y, θ)`, **translation first** (GTSAM's `Pose2` orders
//!   `(v_x, v_y, ω)`).
//!
//! Notation follows Solà, Deray and Atchuthan, "A micro Lie theory for state estimation
//! in robotics" (2018), with `Q` from Barfoot and Furgale, "Associating uncertainty with
//! three-dimensional poses for use in estimation problems" (2014, eq. 102). Every
//! coefficient that cancels near 0 (`(1 − cos θ)/θ²`, `(θ − sin θ)/θ³`, …) switches to its
//! Taylor series below `θ = 10⁻²` (`(θ − sin θ)/θ³` and `Q`'s `c₂`, `c₃`: below 0.1), where
//! the truncation error is below 10⁻¹⁶ relative.
//!
//! Uncertainty on these groups (a Gaussian in the right tangent space, its prediction,
//! correction and NEES) is [`crate::kalman::manifold`]. A state vector as an element of
//! a product of these groups with `ℝⁿ`, for the Lie-group integrators
//! ([`crate::methods::LieEuler`], [`crate::methods::Rkmk4`], [`crate::methods::Cf4`]),
//! is [`layout`].

pub mod layout;
pub mod se2;
pub mod se3;
pub mod so3;

pub use layout::{Block, Layout, Side};
pub use se2::Se2;
pub use se3::Se3;
pub use so3::{So3, hat, vee};

/// Below this angle the coefficients are evaluated by their Taylor series.
const SMALL: f64 = 1e-2;

/// The coefficients of Rodrigues' formula and of the SO(3) Jacobians at angle `θ ≥ 0`:
/// `(sin θ/θ, (1 − cos θ)/θ², (θ − sin θ)/θ³)`, without cancellation near 0. The last
/// loses `(6/θ²)·ε` relative in closed form, which SE(3)'s `Q` multiplies by `|φ||ρ|`, so
/// its series runs to `θ = 0.1` (next term `θ⁸/11! < 3·10⁻¹⁶` there).
fn rodrigues(t: f64) -> (f64, f64, f64) {
    let t2 = t * t;
    let c = if t < 0.1 {
        1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0 * (1.0 - t2 / 110.0)))
    } else {
        (t - t.sin()) / (t * t2)
    };
    if t < SMALL {
        (
            1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0)),
            0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0)),
            c,
        )
    } else {
        let h = (0.5 * t).sin() / t;
        (t.sin() / t, 2.0 * h * h, c)
    }
}

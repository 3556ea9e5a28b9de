//! A 3-D vehicle driven by its body twist, with its pose on SE(3): `R' = R·[ω]×`,
//! `p' = R·v` for the held inputs `u = (ω, v)` (body angular and linear velocity), as
//! one model `x' = f(t, x, u)` with `x = (R column-major, p)`, twelve entries; the
//! Lie-group methods take its [`layout`]. Unlike [`super::body3d`] (Euler angles as
//! inputs) the attitude is part of the state and has no singularity.

use crate::lie::{Layout, Se3, So3};
use nalgebra::{Const, Matrix3, SVector, Vector3, Vector6};

/// `x' = f(x, u)`, `x = (R₁₁, R₂₁, …, R₃₃, p)`, `u = (ω, v)`: `R' = R·[ω]×`, `p' = R·v`,
/// i.e. `Ẏ = Y·ξ̂` on SE(3) with the body twist `ξ = (ω, v)` (the order of [`Se3`]).
///
/// ```
/// use reckon::{vehicles::body_se3, lie::{Se3, So3}, System};
/// use nalgebra::{vector, SVector};
/// let g = Se3::new(So3::exp(&vector![0.0, 0.0, std::f64::consts::FRAC_PI_2]), vector![1.0, 2.0, 3.0]);
/// let mut dx = SVector::<f64, 12>::zeros();
/// body_se3::model().rhs(0.0, &body_se3::state(&g), &[0.0, 0.0, 0.0, 2.0, 0.0, 0.0], &mut dx);
/// // moving forward at 2 m/s while facing world +y
/// assert!((dx.fixed_rows::<3>(9) - vector![0.0, 2.0, 0.0]).norm() < 1e-15);
/// ```
pub fn model() -> impl crate::DualSystem<Const<12>> + Clone {
    crate::model!(|_t, x: [S; 12], u: [6]| {
        let (w1, w2, w3, v1, v2, v3) = (u[0], u[1], u[2], u[3], u[4], u[5]);
        nalgebra::vector![
            x[3] * w3 - x[6] * w2,
            x[4] * w3 - x[7] * w2,
            x[5] * w3 - x[8] * w2,
            x[6] * w1 - x[0] * w3,
            x[7] * w1 - x[1] * w3,
            x[8] * w1 - x[2] * w3,
            x[0] * w2 - x[3] * w1,
            x[1] * w2 - x[4] * w1,
            x[2] * w2 - x[5] * w1,
            x[0] * v1 + x[3] * v2 + x[6] * v3,
            x[1] * v1 + x[4] * v2 + x[7] * v3,
            x[2] * v1 + x[5] * v2 + x[8] * v3
        ]
    })
}

/// The structure of [`model`]'s state: one SE(3) block at `0..12`, right-trivialised
/// (body twist).
///
/// ```
/// use reckon::{vehicles::body_se3, lie::{Block, Side}};
/// let l = body_se3::layout();
/// assert_eq!((l.side(), l.blocks()), (Side::Right, &[Block::Se3 { at: 0 }][..]));
/// ```
pub fn layout() -> Layout {
    Layout::right().se3(0)
}

/// The state `x = (R column-major, p)` of a pose `g = (R, p)`.
///
/// ```
/// use reckon::{vehicles::body_se3, lie::Se3};
/// let x = body_se3::state(&Se3::identity());
/// assert_eq!((x[0], x[4], x[8], x[9]), (1.0, 1.0, 1.0, 0.0));
/// ```
pub fn state(g: &Se3) -> SVector<f64, 12> {
    let mut x = SVector::<f64, 12>::zeros();
    x.as_mut_slice()[..9].copy_from_slice(g.rotation.matrix().as_slice());
    x.as_mut_slice()[9..].copy_from_slice(g.translation.as_slice());
    x
}

/// The pose of a state, inverse of [`state`] (`R` unchecked).
///
/// ```
/// use reckon::{vehicles::body_se3, lie::{Se3, So3}};
/// use nalgebra::vector;
/// let g = Se3::new(So3::exp(&vector![0.1, 0.2, 0.3]), vector![1.0, 2.0, 3.0]);
/// assert_eq!(body_se3::pose(&body_se3::state(&g)), g);
/// ```
pub fn pose(x: &SVector<f64, 12>) -> Se3 {
    let r = Matrix3::from_column_slice(&x.as_slice()[..9]);
    Se3::new(So3::from_matrix_unchecked(r), Vector3::new(x[9], x[10], x[11]))
}

/// The exact flow at a constant body twist `ξ = (ω, v)`: `g(t) = g₀·Exp(t·ξ)`.
///
/// ```
/// use reckon::{vehicles::body_se3, lie::Se3};
/// use nalgebra::vector;
/// use std::f64::consts::PI;
/// // half a turn about z at 1 m/s forward: a half circle of radius 1/π
/// let g = body_se3::flow(&Se3::identity(), &vector![0.0, 0.0, PI, 1.0, 0.0, 0.0], 1.0);
/// assert!((g.translation - vector![0.0, 2.0 / PI, 0.0]).norm() < 1e-15);
/// ```
pub fn flow(g0: &Se3, twist: &Vector6<f64>, t: f64) -> Se3 {
    g0.compose(&Se3::exp(&(twist * t)))
}

//! A free rigid body: Euler's equations `I·ω' = (I·ω) × ω` for the body rate `ω` and the
//! attitude `R' = R·[ω]×` on SO(3) (body to world), as one model `x' = f(t, x)` with
//! `x = (R column-major, ω)`, twelve entries, for every method; the Lie-group methods
//! take its [`layout`].

use crate::lie::{Layout, So3};
use nalgebra::{Const, Matrix3, SVector, Vector3};

/// `x' = f(x)` with `x = (R₁₁, R₂₁, R₃₁, R₁₂, …, R₃₃, ω₁, ω₂, ω₃)`: `R' = R·[ω]×` and
/// `ω₁' = (I₂ − I₃)/I₁·ω₂ω₃`, `ω₂' = (I₃ − I₁)/I₂·ω₃ω₁`, `ω₃' = (I₁ − I₂)/I₃·ω₁ω₂`
/// (principal moments `I = (I₁, I₂, I₃)`, no torque).
///
/// ```
/// use reckon::{vehicles::rigid_body, lie::{So3, hat}, System};
/// use nalgebra::{vector, SVector, Matrix3};
/// let (r, w) = (So3::exp(&vector![0.1, 0.2, 0.3]), vector![1.0, 2.0, 3.0]);
/// let mut dx = SVector::<f64, 12>::zeros();
/// rigid_body::model([1.0, 2.0, 3.0]).rhs(0.0, &rigid_body::state(&r, &w), &[], &mut dx);
/// let rd = Matrix3::from_column_slice(&dx.as_slice()[..9]);
/// assert!((rd - r.matrix() * hat(&w)).amax() < 1e-15);
/// assert_eq!((dx[9], dx[10], dx[11]), ((2.0 - 3.0) * 2.0 * 3.0, (3.0 - 1.0) / 2.0 * 3.0, (1.0 - 2.0) / 3.0 * 2.0));
/// ```
pub fn model(inertia: [f64; 3]) -> impl crate::DualSystem<Const<12>> + Clone {
    let [i1, i2, i3] = inertia;
    let (a1, a2, a3) = ((i2 - i3) / i1, (i3 - i1) / i2, (i1 - i2) / i3);
    crate::model!(|_t, x: [S; 12]| {
        let (w1, w2, w3) = (x[9], x[10], x[11]);
        // R' = R·[ω]×, column by column: (ω₃c₂ − ω₂c₃, ω₁c₃ − ω₃c₁, ω₂c₁ − ω₁c₂)
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
            w2 * w3 * a1,
            w3 * w1 * a2,
            w1 * w2 * a3
        ]
    })
}

/// The structure of [`model`]'s state: an SO(3) block at entries `0..9`, right-trivialised
/// (`R' = R·[ω]×`, body rates), and `ω` in `9..12` as vector components.
///
/// ```
/// use reckon::{vehicles::rigid_body, lie::{Block, Side}};
/// let l = rigid_body::layout();
/// assert_eq!((l.side(), l.blocks()), (Side::Right, &[Block::So3 { at: 0 }][..]));
/// ```
pub fn layout() -> Layout {
    Layout::right().so3(0)
}

/// The state `x = (R column-major, ω)`.
///
/// ```
/// use reckon::{vehicles::rigid_body, lie::So3};
/// let x = rigid_body::state(&So3::identity(), &nalgebra::vector![1.0, 2.0, 3.0]);
/// assert_eq!((x[0], x[1], x[4], x[11]), (1.0, 0.0, 1.0, 3.0));
/// ```
pub fn state(r: &So3, w: &Vector3<f64>) -> SVector<f64, 12> {
    let mut x = SVector::<f64, 12>::zeros();
    x.as_mut_slice()[..9].copy_from_slice(r.matrix().as_slice());
    x.as_mut_slice()[9..].copy_from_slice(w.as_slice());
    x
}

/// `(R, ω)` from a state, inverse of [`state`]; `R` unchecked (an integrator that does not
/// keep it on SO(3) returns what it has: measure with `‖RᵀR − I‖`).
///
/// ```
/// use reckon::{vehicles::rigid_body, lie::So3};
/// use nalgebra::vector;
/// let r = So3::exp(&vector![0.1, 0.2, 0.3]);
/// let (r2, w) = rigid_body::split(&rigid_body::state(&r, &vector![1.0, 2.0, 3.0]));
/// assert_eq!((r2, w), (r, vector![1.0, 2.0, 3.0]));
/// ```
pub fn split(x: &SVector<f64, 12>) -> (So3, Vector3<f64>) {
    let r = Matrix3::from_column_slice(&x.as_slice()[..9]);
    (So3::from_matrix_unchecked(r), Vector3::new(x[9], x[10], x[11]))
}

/// The free symmetric top `I = (I₁, I₁, I₃)` in closed form: with `λ = (I₃ − I₁)/I₁·ω₃`
/// and the (constant) world angular momentum `L = R₀·I·ω₀`,
/// `ω(t) = Exp(λt·e₃)·ω₀` (the body rate precesses about the symmetry axis) and
/// `R(t) = Exp(t·L/I₁)·R₀·Exp(−λt·e₃)`. (Since `I·ω = I₁ω + (I₃ − I₁)ω₃e₃`, the body rate
/// is `ω = Rᵀ·L/I₁ − λe₃`, and this `R` has `R' = (L/I₁)^·R − R·λê₃ = R·ω̂`.)
///
/// ```
/// use reckon::{vehicles::rigid_body, lie::So3};
/// use nalgebra::vector;
/// let (r0, w0) = (So3::exp(&vector![0.3, -0.2, 0.5]), vector![0.6, -0.3, 1.0]);
/// let (r, w) = rigid_body::symmetric_top(2.0, 3.0, &r0, &w0, 1.5);
/// assert!((w[2] - 1.0).abs() < 1e-15 && (w.norm() - w0.norm()).abs() < 1e-15);
/// // the world angular momentum is conserved
/// let i = nalgebra::Matrix3::from_diagonal(&vector![2.0, 2.0, 3.0]);
/// assert!((r.matrix() * i * w - r0.matrix() * i * w0).norm() < 1e-14);
/// ```
pub fn symmetric_top(i1: f64, i3: f64, r0: &So3, w0: &Vector3<f64>, t: f64) -> (So3, Vector3<f64>) {
    let lambda = (i3 - i1) / i1 * w0[2];
    let l = r0.matrix() * Vector3::new(i1 * w0[0], i1 * w0[1], i3 * w0[2]);
    let spin = Vector3::new(0.0, 0.0, lambda * t);
    let r = So3::exp(&(l * (t / i1))).compose(r0).compose(&So3::exp(&-spin));
    (r, So3::exp(&spin).act(w0))
}

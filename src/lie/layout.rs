//! A state vector as an element of a product group `G = SO(3)ᵃ × SE(3)ᵇ × ℝⁿ`, for the
//! Lie-group integrators ([`crate::methods::LieEuler`], [`crate::methods::Rkmk4`],
//! [`crate::methods::Cf4`]).
//!
//! The model stays an ordinary `x' = f(t, x)` in ambient coordinates, the same closure
//! every method integrates: a rotation is stored as its nine entries **column-major**,
//! a rigid motion `(R, p)` as the nine entries of `R` (column-major) followed by `p`.
//! A [`Layout`] says where those blocks sit; every other entry is a plain vector
//! component. From `f` the integrators recover the algebra element of each block,
//! `ξ̂ = Y⁻¹·Ẏ` for the right-trivialised form `Ẏ = Y·ξ̂` ([`Side::Right`], body
//! velocities) or `ξ̂ = Ẏ·Y⁻¹` for the left form `Ẏ = ξ̂·Y` ([`Side::Left`], spatial
//! velocities), and move the state by group exponentials, `Y·Exp(u)` or `Exp(u)·Y`;
//! the vector components move by `x + u`.
//!
//! Tangent vectors are stored packed in a vector of the state's own length: a block's
//! tangent (`φ ∈ ℝ³` for SO(3), `(φ, ρ) ∈ ℝ⁶` for SE(3), the ordering of
//! [`So3`](super::So3) and [`Se3`](super::Se3)) in the block's first 3 or 6 entries and
//! zeros in the rest, a vector component's tangent in its own place. Linear
//! combinations of tangents are then combinations of vectors of the state's length.

use super::se3::Se3;
use super::so3::{So3, vee};
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

/// Which trivialisation the model's group blocks follow.
///
/// `Right`: `Ẏ = Y·ξ̂`, so `ξ̂ = Y⁻¹·Ẏ` and a step is `Y₁ = Y₀·Exp(u)` (body-frame
/// velocities: a rigid body's `R' = R·[ω]×`). `Left`: `Ẏ = ξ̂·Y`, so `ξ̂ = Ẏ·Y⁻¹` and
/// `Y₁ = Exp(u)·Y₀` (world-frame velocities).
///
/// ```
/// use reckon::lie::{Layout, Side};
/// assert_eq!(Layout::right().side(), Side::Right);
/// assert_eq!(Layout::left().side(), Side::Left);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// `Ẏ = Y·ξ̂` (body velocities).
    Right,
    /// `Ẏ = ξ̂·Y` (world velocities).
    Left,
}

/// One group block of a state vector, by the index of its first entry.
///
/// `So3 { at }`: `x[at..at + 9]` is `R` column-major (`R_ij = x[at + i + 3j]`), tangent
/// `φ ∈ ℝ³`. `Se3 { at }`: `x[at..at + 9]` is `R` column-major and `x[at + 9..at + 12]`
/// is `p`, the motion `[[R, p], [0, 1]]`, tangent `(φ, ρ) ∈ ℝ⁶`.
///
/// ```
/// use reckon::lie::Block;
/// assert_eq!((Block::So3 { at: 0 }.len(), Block::So3 { at: 0 }.dim()), (9, 3));
/// assert_eq!((Block::Se3 { at: 3 }.len(), Block::Se3 { at: 3 }.dim()), (12, 6));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Block {
    /// A rotation `R ∈ SO(3)`, 9 entries.
    So3 {
        /// Index of `R₁₁`.
        at: usize,
    },
    /// A rigid motion `(R, p) ∈ SE(3)`, 12 entries.
    Se3 {
        /// Index of `R₁₁`.
        at: usize,
    },
}

impl Block {
    /// The index of the block's first entry, `at`.
    ///
    /// ```
    /// use reckon::lie::Block;
    /// assert_eq!(Block::Se3 { at: 4 }.at(), 4);
    /// ```
    pub fn at(&self) -> usize {
        match *self {
            Block::So3 { at } | Block::Se3 { at } => at,
        }
    }
    /// Entries the block takes in the state: 9 (`R`) or 12 (`R`, `p`).
    ///
    /// ```
    /// use reckon::lie::Block;
    /// assert_eq!(Block::So3 { at: 1 }.len(), 9);
    /// ```
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        match self {
            Block::So3 { .. } => 9,
            Block::Se3 { .. } => 12,
        }
    }
    /// Dimension of the group, the length of its tangent: 3 or 6.
    ///
    /// ```
    /// use reckon::lie::Block;
    /// assert_eq!(Block::Se3 { at: 0 }.dim(), 6);
    /// ```
    pub fn dim(&self) -> usize {
        match self {
            Block::So3 { .. } => 3,
            Block::Se3 { .. } => 6,
        }
    }
}

/// The structure of a state vector: its group blocks ([`Block`]) and the
/// trivialisation ([`Side`]); all other entries are vector components. The state is an
/// element of `G = SO(3)ᵃ × SE(3)ᵇ × ℝⁿ` and the model's `x' = f(t, x)` a vector field
/// on it, `Ẏ = Y·ξ(t, Y)` blockwise.
///
/// ```
/// use reckon::lie::{Block, Layout};
/// // a rigid body: R (entries 0..9) and the body rate ω (entries 9..12)
/// let l = Layout::right().so3(0);
/// assert_eq!(l.blocks(), &[Block::So3 { at: 0 }]);
/// let mut x = [0.0; 12];
/// x[0] = 1.0; x[4] = 1.0; x[8] = 1.0; // R = I
/// assert!(l.check(&x).is_ok());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    side: Side,
    blocks: Vec<Block>,
}

/// `R` from the nine entries at `x[a..a + 9]`, column-major.
fn mat(x: &[f64], a: usize) -> Matrix3<f64> {
    Matrix3::from_column_slice(&x[a..a + 9])
}

fn vec3(x: &[f64], a: usize) -> Vector3<f64> {
    Vector3::new(x[a], x[a + 1], x[a + 2])
}

fn put(out: &mut [f64], a: usize, v: &[f64]) {
    out[a..a + v.len()].copy_from_slice(v);
}

impl Layout {
    /// No blocks yet, right-trivialised: `Ẏ = Y·ξ̂`.
    ///
    /// ```
    /// use reckon::lie::{Layout, Side};
    /// let l = Layout::right();
    /// assert!(l.blocks().is_empty() && l.side() == Side::Right);
    /// ```
    pub fn right() -> Self {
        Layout {
            side: Side::Right,
            blocks: Vec::new(),
        }
    }
    /// No blocks yet, left-trivialised: `Ẏ = ξ̂·Y`.
    ///
    /// ```
    /// use reckon::lie::{Layout, Side};
    /// assert_eq!(Layout::left().side(), Side::Left);
    /// ```
    pub fn left() -> Self {
        Layout {
            side: Side::Left,
            blocks: Vec::new(),
        }
    }
    /// Add an SO(3) block at `x[at..at + 9]` (`R` column-major).
    ///
    /// ```
    /// use reckon::lie::{Block, Layout};
    /// assert_eq!(Layout::right().so3(3).blocks(), &[Block::So3 { at: 3 }]);
    /// ```
    pub fn so3(mut self, at: usize) -> Self {
        self.blocks.push(Block::So3 { at });
        self
    }
    /// Add an SE(3) block at `x[at..at + 12]` (`R` column-major, then `p`).
    ///
    /// ```
    /// use reckon::lie::{Block, Layout};
    /// assert_eq!(Layout::left().se3(0).blocks(), &[Block::Se3 { at: 0 }]);
    /// ```
    pub fn se3(mut self, at: usize) -> Self {
        self.blocks.push(Block::Se3 { at });
        self
    }
    /// The trivialisation.
    ///
    /// ```
    /// use reckon::lie::{Layout, Side};
    /// assert_eq!(Layout::left().so3(0).side(), Side::Left);
    /// ```
    pub fn side(&self) -> Side {
        self.side
    }
    /// The group blocks, in the order given.
    ///
    /// ```
    /// use reckon::lie::Layout;
    /// assert_eq!(Layout::right().so3(0).se3(9).blocks().len(), 2);
    /// ```
    pub fn blocks(&self) -> &[Block] {
        &self.blocks
    }

    /// `Ok` when every block lies inside `x` (`at + len ≤ x.len()`), no two overlap, and
    /// every rotation is on SO(3): finite, `‖RᵀR − I‖_max ≤ 10⁻⁹`, `det R > 0`.
    /// Otherwise [`Error::InvalidInput`], naming the block (`what = "layout"` for the
    /// first two, `"x0"` for a state off the group).
    ///
    /// ```
    /// use reckon::{lie::Layout, Error};
    /// let mut x = [0.0; 12];
    /// x[0] = 1.0; x[4] = 1.0; x[8] = 1.0;
    /// assert!(Layout::right().se3(0).check(&x).is_ok());
    /// assert!(matches!(Layout::right().se3(1).check(&x), Err(Error::InvalidInput { what: "layout", .. })));
    /// x[0] = 1.1; // not orthogonal
    /// assert!(matches!(Layout::right().so3(0).check(&x), Err(Error::InvalidInput { what: "x0", .. })));
    /// ```
    pub fn check(&self, x: &[f64]) -> Result<()> {
        let mut spans: Vec<(usize, usize)> = Vec::with_capacity(self.blocks.len());
        for b in &self.blocks {
            let (a, n) = (b.at(), b.len());
            if a.checked_add(n).is_none_or(|e| e > x.len()) {
                return Err(Error::invalid(
                    "layout",
                    format!(
                        "the {} block at {a} takes entries {a}..{} of a state of {}",
                        name(b),
                        a.saturating_add(n),
                        x.len()
                    ),
                ));
            }
            if let Some(&(c, m)) = spans.iter().find(|&&(c, m)| a < c + m && c < a + n) {
                return Err(Error::invalid(
                    "layout",
                    format!("the {} block at {a} overlaps the block at {c}..{}", name(b), c + m),
                ));
            }
            spans.push((a, n));
            let r = mat(x, a);
            let off = |e: Error| Error::invalid("x0", format!("the {} block at {a} is not on the group: {e}", name(b)));
            So3::from_matrix(r).map_err(off)?;
            let bad = (9..b.len()).find(|&i| !x[a + i].is_finite());
            if let Some(i) = bad {
                return Err(Error::invalid(
                    "x0",
                    format!("the SE(3) block at {a}: entry {} is {}", a + i, x[a + i]),
                ));
            }
        }
        Ok(())
    }

    /// The algebra element of `ẋ = dx` at `x`, packed ([module doc](self)): per block
    /// `ξ̂ = Y⁻¹·Ẏ` (right) or `Ẏ·Y⁻¹` (left), so for SO(3) `φ = vee(RᵀṘ)` or
    /// `vee(ṘRᵀ)` and for SE(3) also `ρ = Rᵀṗ` or `ρ = ṗ − φ × p`; `ξ = ẋ` in the vector
    /// components. `vee` takes the antisymmetric part, the projection onto the algebra
    /// of a derivative that is not exactly tangent.
    ///
    /// ```
    /// use reckon::lie::{Layout, So3, hat};
    /// use nalgebra::vector;
    /// // R' = R·[ω]× with ω = (0.1, 0.2, 0.3); the 10th entry is a plain vector component
    /// let (r, w) = (So3::exp(&vector![0.5, -0.4, 1.0]).matrix(), vector![0.1, 0.2, 0.3]);
    /// let (mut x, mut dx, mut xi) = ([0.0; 10], [0.0; 10], [0.0; 10]);
    /// x[..9].copy_from_slice(r.as_slice());
    /// dx[..9].copy_from_slice((r * hat(&w)).as_slice());
    /// dx[9] = 7.0;
    /// Layout::right().so3(0).algebra(&x, &dx, &mut xi);
    /// assert!((vector![xi[0], xi[1], xi[2]] - w).norm() < 1e-15);
    /// assert_eq!((xi[3], xi[8], xi[9]), (0.0, 0.0, 7.0));
    /// ```
    pub fn algebra(&self, x: &[f64], dx: &[f64], xi: &mut [f64]) {
        xi.copy_from_slice(dx);
        for b in &self.blocks {
            let a = b.at();
            let (r, rd) = (mat(x, a), mat(dx, a));
            let phi = match self.side {
                Side::Right => vee(&(r.transpose() * rd)),
                Side::Left => vee(&(rd * r.transpose())),
            };
            xi[a..a + b.len()].fill(0.0);
            put(xi, a, phi.as_slice());
            if let Block::Se3 { .. } = b {
                let (p, pd) = (vec3(x, a + 9), vec3(dx, a + 9));
                let rho = match self.side {
                    Side::Right => r.transpose() * pd,
                    Side::Left => pd - phi.cross(&p),
                };
                put(xi, a + 3, rho.as_slice());
            }
        }
    }

    /// The state moved by the packed tangent `u`: per block `Y·Exp(u)` (right) or
    /// `Exp(u)·Y` (left), `x + u` in the vector components. For SE(3),
    /// `(R, p)·Exp(φ, ρ) = (R·E, R·t + p)` and `Exp(φ, ρ)·(R, p) = (E·R, E·p + t)` with
    /// `(E, t) = Exp(φ, ρ)` ([`Se3::exp`]).
    ///
    /// ```
    /// use reckon::lie::{Layout, So3};
    /// use nalgebra::vector;
    /// let (mut x, mut u, mut y) = ([0.0; 9], [0.0; 9], [0.0; 9]);
    /// x.copy_from_slice(So3::exp(&vector![0.0, 0.0, 0.5]).matrix().as_slice());
    /// u[2] = 0.25; // φ = (0, 0, 0.25)
    /// Layout::right().so3(0).exp_act(&u, &x, &mut y);
    /// let r = So3::from_matrix(nalgebra::Matrix3::from_column_slice(&y)).unwrap();
    /// assert!((r.log() - vector![0.0, 0.0, 0.75]).norm() < 1e-15);
    /// ```
    pub fn exp_act(&self, u: &[f64], x: &[f64], out: &mut [f64]) {
        for i in 0..x.len() {
            out[i] = x[i] + u[i];
        }
        for b in &self.blocks {
            let a = b.at();
            let r = mat(x, a);
            match b {
                Block::So3 { .. } => {
                    let e = So3::exp(&vec3(u, a)).matrix();
                    let m = match self.side {
                        Side::Right => r * e,
                        Side::Left => e * r,
                    };
                    put(out, a, m.as_slice());
                }
                Block::Se3 { .. } => {
                    let g = Se3::exp(&Vector6::from_column_slice(&u[a..a + 6]));
                    let (e, t, p) = (g.rotation.matrix(), g.translation, vec3(x, a + 9));
                    let (m, q) = match self.side {
                        Side::Right => (r * e, r * t + p),
                        Side::Left => (e * r, e * p + t),
                    };
                    put(out, a, m.as_slice());
                    put(out, a + 9, q.as_slice());
                }
            }
        }
    }

    /// `out = dexp⁻¹_u(v)` blockwise, the correction of Runge–Kutta–Munthe-Kaas methods:
    /// with `Y = Y₀·Exp(u)` and `Ẏ = Y·ξ̂`, `u' = J_r⁻¹(u)·ξ`; with `Y = Exp(u)·Y₀` and
    /// `Ẏ = ξ̂·Y`, `u' = J_l⁻¹(u)·ξ` (the inverse right and left Jacobians of
    /// [`So3`] and [`Se3`], exact, singular only at a rotation angle of `2π`); `out = v`
    /// in the vector components.
    ///
    /// ```
    /// use reckon::lie::{Layout, So3};
    /// use nalgebra::vector;
    /// let (mut u, mut v, mut out) = ([0.0; 9], [0.0; 9], [0.0; 9]);
    /// u[..3].copy_from_slice(&[0.3, -0.2, 0.4]);
    /// v[..3].copy_from_slice(&[1.0, 0.5, -0.5]);
    /// Layout::right().so3(0).dexp_inv(&u, &v, &mut out);
    /// let want = So3::right_jacobian_inv(&vector![0.3, -0.2, 0.4]) * vector![1.0, 0.5, -0.5];
    /// assert!((vector![out[0], out[1], out[2]] - want).norm() < 1e-15);
    /// ```
    pub fn dexp_inv(&self, u: &[f64], v: &[f64], out: &mut [f64]) {
        out.copy_from_slice(v);
        for b in &self.blocks {
            let a = b.at();
            match b {
                Block::So3 { .. } => {
                    let phi = vec3(u, a);
                    let j = match self.side {
                        Side::Right => So3::right_jacobian_inv(&phi),
                        Side::Left => So3::left_jacobian_inv(&phi),
                    };
                    put(out, a, (j * vec3(v, a)).as_slice());
                }
                Block::Se3 { .. } => {
                    let xi = Vector6::from_column_slice(&u[a..a + 6]);
                    let j: Matrix6<f64> = match self.side {
                        Side::Right => Se3::right_jacobian_inv(&xi),
                        Side::Left => Se3::left_jacobian_inv(&xi),
                    };
                    put(out, a, (j * Vector6::from_column_slice(&v[a..a + 6])).as_slice());
                }
            }
        }
    }

    /// One Newton step of the polar decomposition on every rotation,
    /// `R ← ½·R·(3I − RᵀR)`, which takes a rotation that is off SO(3) by `δ = ‖RᵀR − I‖`
    /// to one off by `O(δ²)` and moves it by `O(δ)`. The integrators apply it to each
    /// step's result, whose rotations are products of exact exponentials: `δ` is then
    /// rounding (`~10⁻¹⁶`), and the step removes it so that rounding does not accumulate
    /// over millions of steps. Measured on a rigid body (`benches/lie.rs`,
    /// `tests/it/lie_integrators.rs`): 10⁶ products `R·Exp(hω)` without it drift to
    /// `‖RᵀR − I‖_max = 6.8·10⁻¹¹`; 10⁶ RKMK4 steps with it end at `1.1·10⁻¹⁶`.
    ///
    /// ```
    /// use reckon::lie::Layout;
    /// let mut x = [1.0 + 1e-10, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// Layout::right().so3(0).project(&mut x);
    /// assert!((x[0] - 1.0).abs() < 1e-19);
    /// ```
    pub fn project(&self, x: &mut [f64]) {
        for b in &self.blocks {
            let a = b.at();
            let r = mat(x, a);
            let m = r * (Matrix3::identity() * 3.0 - r.transpose() * r) * 0.5;
            put(x, a, m.as_slice());
        }
    }
}

fn name(b: &Block) -> &'static str {
    match b {
        Block::So3 { .. } => "SO(3)",
        Block::Se3 { .. } => "SE(3)",
    }
}

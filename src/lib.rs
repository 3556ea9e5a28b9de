#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

/// The user guide (`docs/guide.md`); its examples run as doctests.
#[doc = include_str!("../docs/guide.md")]
pub mod guide {}

pub mod calibration;
pub mod control;
pub mod controls;
pub mod ensemble;
pub mod error;
pub mod events;
pub mod integrator;
pub mod kalman;
mod lhs;
pub mod linalg;
pub mod lti;
pub mod methods;
pub mod models;
pub mod options;
pub mod params;
pub mod prelude;
pub mod problem;
pub mod problems;
pub mod reckoning;
pub mod sensitivity;
pub mod solution;
pub mod sparse;
pub mod studies;
pub mod symbolic;
pub mod system;

pub use controls::Controls;
pub use error::{Error, Result};
pub use events::{Direction, Event};
pub use integrator::Integrator;
pub use lti::Lti;
pub use nalgebra;
pub use num_dual;

#[doc(hidden)]
pub mod __private {
    pub use crate::lhs::Lhs;
    pub use num_traits::Signed;
    pub use reckon_macros::{lift_literals, mentions};

    /// `vector!`: an array as a column vector.
    pub fn vector_from<T: nalgebra::Scalar, const N: usize>(a: [T; N]) -> nalgebra::SVector<T, N> {
        nalgebra::SVector::from(a)
    }

    /// `matrix!`: rows as a matrix.
    pub fn matrix_from_rows<T: nalgebra::Scalar, const R: usize, const C: usize>(
        rows: [[T; C]; R],
    ) -> nalgebra::SMatrix<T, R, C> {
        nalgebra::SMatrix::from_fn(|i, j| rows[i][j].clone())
    }
}
pub use options::{Options, Save, StepSize};
pub use params::ParamModel;
pub use problem::Problem;
pub use solution::{Solution, Stats, Switch, SwitchReason};
pub use system::{ClosureModel, DualSystem, System};

#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

/// The user guide (`docs/guide.md`); its examples run as doctests.
#[doc = include_str!("../docs/guide.md")]
pub mod guide {}

pub mod calibration;
pub mod ensemble;
pub mod error;
mod integrator;
pub mod jacobian;
pub mod kalman;
pub mod lie;
pub mod linalg;
pub mod methods;
pub mod model;
pub mod prelude;
pub mod problem;
pub mod reckoning;
pub mod sensitivity;
pub mod studies;
pub mod symbolic;
pub mod vehicles;

pub use error::{Error, Result};
pub use integrator::Integrator;
pub use jacobian::LinearSolver;
pub use model::mass::Mass;
pub use model::{ClosureModel, DualFlow, DualSystem, Flow, Lti, ParamModel, Stats, System};
pub use nalgebra;
pub use num_dual;
pub use problem::Problem;
pub use problem::controls::Controls;
pub use problem::events::{Direction, Event};
pub use problem::options::{Options, Save, StepSize};
pub use problem::solution::{Solution, Switch, SwitchReason};

#[doc(hidden)]
pub mod __private {
    pub use crate::model::lhs::Lhs;
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

//! Everything a model and a solve need, in one import, with no direct `nalgebra`
//! dependency: `use reckon::prelude::*;`.
//!
//! The constructors [`vector!`](crate::vector), [`dvector!`](crate::dvector) and
//! [`matrix!`](crate::matrix) are reckon's own (nalgebra's macros expand to paths that
//! need `nalgebra` as a direct dependency); they build the same nalgebra types, so
//! values mix freely with a project's own `nalgebra = "0.35"`.
//!
//! ```
//! use reckon::prelude::*;
//! let f = model!(|_t, x: [S; 2]| vector![x[1], -x[0]]); // harmonic oscillator
//! let sol = Problem::new(&f, vector![1.0, 0.0], (0.0, std::f64::consts::PI))
//!     .solve(Rk45, &Options::default().rtol(1e-10).atol(1e-12))
//!     .unwrap();
//! assert!((sol.last().1[0] + 1.0).abs() < 1e-9);
//! let m: Matrix2<f64> = matrix![1.0, 2.0; 3.0, 4.0];
//! assert_eq!(m[(0, 1)], 2.0);
//! assert_eq!(dvector![1.0, 2.0, 3.0].len(), 3);
//! ```

pub use crate::methods::{Auto, Bdf, Euler, Exact, ExponentialEuler, ImplicitEuler, Rk45, Rodas5P};
pub use crate::nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Matrix4, SMatrix, SVector, Vector2, Vector3, Vector4};
pub use crate::{
    Controls, Direction, Error, Event, Options, Problem, Save, Solution, StepSize, System, dvector, matrix, model,
    vector,
};

/// A fixed-size column vector, `vector![a, b, c]` → `SVector<_, 3>` (as nalgebra's, but
/// usable through `reckon` alone).
///
/// ```
/// let v = reckon::vector![1.0, 2.0, 3.0];
/// assert_eq!(v, reckon::nalgebra::Vector3::new(1.0, 2.0, 3.0));
/// ```
#[macro_export]
macro_rules! vector {
    ($($x:expr),* $(,)?) => {
        $crate::__private::vector_from([$($x),*])
    };
}

/// A dynamically sized column vector, `dvector![a, b]` → `DVector<_>`.
///
/// ```
/// let v = reckon::dvector![1.0, 2.0];
/// assert_eq!(v, reckon::nalgebra::DVector::from_vec(vec![1.0, 2.0]));
/// ```
#[macro_export]
macro_rules! dvector {
    ($($x:expr),* $(,)?) => {
        $crate::nalgebra::DVector::from_vec(::std::vec![$($x),*])
    };
}

/// A fixed-size matrix written by rows, `matrix![a, b; c, d]` → `SMatrix<_, 2, 2>`.
///
/// ```
/// let m = reckon::matrix![1.0, 2.0, 3.0; 4.0, 5.0, 6.0];
/// assert_eq!(m, reckon::nalgebra::Matrix2x3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0));
/// ```
#[macro_export]
macro_rules! matrix {
    ($($($x:expr),+ $(,)?);+ $(;)?) => {
        $crate::__private::matrix_from_rows([$([$($x),+]),+])
    };
}

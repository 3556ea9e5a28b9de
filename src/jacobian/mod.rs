//! Sparse Jacobians: the pattern of `J = ∂f/∂x` in compressed sparse column (CSC) form,
//! and evaluators that fill its non-zeros without ever forming the dense `n × n` matrix.
//!
//! A model offers one through [`System::sparse_jacobian`](crate::System::sparse_jacobian):
//! a traced [`model!`](crate::model) gives the compiled symbolic evaluator
//! ([`crate::symbolic`]); the implicit methods then factor `I − c·J` with a banded LU
//! ([`BandLu`](crate::linalg::BandLu)) when its pattern lies in a narrow band, with faer's
//! sparse LU ([`SparseLu`](crate::linalg::SparseLu)) otherwise, when
//! [`Options::linear_solver`](crate::Options::linear_solver) chooses the sparse path. A model that cannot be traced can still give one by column colouring
//! ([`colour::Coloured`] over its dual-number body).

pub(crate) mod choice;
pub mod colour;

/// [`LinearSolver::Auto`](crate::jacobian::LinearSolver::Auto) takes the sparse path from
/// this many states on (64) when the model offers a sparse Jacobian. One factorisation
/// and solve of `I − c·J` in BRUSS 1-D's pattern (≤ 4 non-zeros per column), faer's
/// dense LU against [`SparseLu`](crate::linalg::SparseLu): 1.5 µs each at 8 states, dense/sparse 1.6× at 32,
/// 4.8× at 64, 40× at 256, 350× at 1 024 (`examples/sparse_scaling.rs crossover`). Below
/// 64 the gain is a few microseconds, and fixed-size models (at most 32 states) keep
/// their stack-allocated dense LU; the model is not even asked for its sparse Jacobian.
pub const AUTO_MIN_STATES: usize = 64;

/// [`LinearSolver::Auto`](crate::jacobian::LinearSolver::Auto) takes the sparse path only
/// when `nnz/n²` of `J` is at most this (0.1). Random patterns (the worst case for
/// fill-in) at density 0.1: the sparse LU is 1.9× slower than the dense one at 64 states
/// (73 against 40 µs) and 1.3× faster at 256; at 0.05 it is faster at both (1.4×, 1.6×);
/// at 0.2 it is 4× slower at 64 states (`examples/sparse_scaling.rs crossover`).
/// Structured patterns (stencils, chains) fill in far less than random ones.
pub const AUTO_MAX_DENSITY: f64 = 0.1;

/// The sparsity pattern of an `n × n` matrix in CSC form: the rows of column `j` are
/// `row_idx[col_ptr[j]..col_ptr[j + 1]]`, sorted ascending, without repeats. Values of a
/// matrix with this pattern are stored in the same order (`values[k]` is at
/// `(row_idx[k], j)`).
///
/// ```
/// use reckon::jacobian::Pattern;
/// // [[a, 0], [b, c]]: column 0 has rows 0, 1; column 1 has row 1
/// let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (1, 1)]).unwrap();
/// assert_eq!(p.col_ptr(), &[0, 2, 3]);
/// assert_eq!(p.row_idx(), &[0, 1, 1]);
/// assert_eq!(p.nnz(), 3);
/// assert_eq!(p.position(1, 0), Some(1));
/// assert_eq!(p.position(0, 1), None);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Pattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

impl Pattern {
    /// The pattern holding the `(row, column)` entries given (any order, repeats
    /// merged) of an `n × n` matrix; [`Error::InvalidInput`](crate::Error::InvalidInput)
    /// for an index `≥ n`.
    ///
    /// ```
    /// use reckon::jacobian::Pattern;
    /// assert_eq!(Pattern::from_entries(2, &[(1, 1), (0, 0), (1, 1)]).unwrap().nnz(), 2);
    /// let e = Pattern::from_entries(2, &[(0, 0), (2, 1)]).unwrap_err();
    /// assert_eq!(e.to_string(), "invalid pattern: entry (2, 1) is outside the 2 × 2 matrix");
    /// ```
    pub fn from_entries(n: usize, entries: &[(usize, usize)]) -> crate::Result<Self> {
        if let Some((r, c)) = entries.iter().find(|&&(r, c)| r >= n || c >= n) {
            return Err(crate::Error::invalid(
                "pattern",
                format!("entry ({r}, {c}) is outside the {n} × {n} matrix"),
            ));
        }
        Ok(Self::from_valid_entries(n, entries))
    }

    /// [`from_entries`](Self::from_entries) of entries known to be in range.
    pub(crate) fn from_valid_entries(n: usize, entries: &[(usize, usize)]) -> Self {
        let mut e: Vec<(usize, usize)> = entries.iter().map(|&(r, c)| (c, r)).collect();
        e.sort_unstable();
        e.dedup();
        let mut col_ptr = vec![0; n + 1];
        for &(c, _) in &e {
            col_ptr[c + 1] += 1;
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let row_idx = e.into_iter().map(|(_, r)| r).collect();
        Pattern { n, col_ptr, row_idx }
    }

    /// Build from CSC arrays; `None` unless they describe a valid `n × n` pattern
    /// (`col_ptr` of length `n + 1` from 0, non-decreasing, rows in range and strictly
    /// ascending within each column).
    pub fn from_csc(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Option<Self> {
        let ok = col_ptr.len() == n + 1
            && col_ptr[0] == 0
            && col_ptr[n] == row_idx.len()
            && col_ptr.windows(2).all(|w| w[0] <= w[1])
            && (0..n).all(|j| {
                let r = &row_idx[col_ptr[j]..col_ptr[j + 1]];
                r.iter().all(|&i| i < n) && r.windows(2).all(|w| w[0] < w[1])
            });
        ok.then_some(Pattern { n, col_ptr, row_idx })
    }

    /// The dense pattern of an `n × n` matrix; [`Error::InvalidInput`](crate::Error::InvalidInput)
    /// when its `n²` row indices cannot be held (`n²` overflows, or the allocation fails).
    ///
    /// ```
    /// use reckon::jacobian::Pattern;
    /// assert_eq!(Pattern::dense(3).unwrap().nnz(), 9);
    /// let e = Pattern::dense(1 << 40).unwrap_err();
    /// assert!(e.to_string().starts_with("invalid pattern: a dense 1099511627776 × 1099511627776"), "{e}");
    /// ```
    pub fn dense(n: usize) -> crate::Result<Self> {
        let too_big = || {
            crate::Error::invalid(
                "pattern",
                format!("a dense {n} × {n} pattern has more entries than memory can hold"),
            )
        };
        let nnz = n
            .checked_mul(n)
            .filter(|&m| m <= isize::MAX as usize / std::mem::size_of::<usize>())
            .ok_or_else(too_big)?;
        let mut row_idx = Vec::new();
        row_idx.try_reserve_exact(nnz).map_err(|_| too_big())?;
        row_idx.extend((0..nnz).map(|k| k % n));
        Ok(Pattern {
            n,
            col_ptr: (0..=n).map(|j| j * n).collect(),
            row_idx,
        })
    }

    /// Matrix size `n`.
    pub fn n(&self) -> usize {
        self.n
    }
    /// Number of structural non-zeros.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
    /// `nnz / n²` (0 for `n = 0`).
    pub fn density(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.nnz() as f64 / (self.n as f64 * self.n as f64)
        }
    }
    /// Column pointers (length `n + 1`).
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }
    /// Row indices, column by column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }
    /// Index into the value array of entry `(row, col)`, if it is in the pattern (`None`
    /// for an index outside the matrix too).
    ///
    /// ```
    /// use reckon::jacobian::Pattern;
    /// let p = Pattern::from_entries(2, &[(0, 0), (1, 1)]).unwrap();
    /// assert_eq!((p.position(1, 1), p.position(0, 2), p.position(5, 0)), (Some(1), None, None));
    /// ```
    pub fn position(&self, row: usize, col: usize) -> Option<usize> {
        if row >= self.n || col >= self.n {
            return None;
        }
        let (a, b) = (self.col_ptr[col], self.col_ptr[col + 1]);
        self.row_idx[a..b].binary_search(&row).ok().map(|k| a + k)
    }
    /// Whether every diagonal entry is in the pattern.
    pub fn has_diagonal(&self) -> bool {
        (0..self.n).all(|j| self.position(j, j).is_some())
    }
    /// The pattern with every diagonal entry added (the pattern of `I − c·J`).
    pub fn with_diagonal(&self) -> Self {
        if self.has_diagonal() {
            return self.clone();
        }
        let mut e: Vec<(usize, usize)> = self.entries().collect();
        e.extend((0..self.n).map(|j| (j, j)));
        Pattern::from_valid_entries(self.n, &e)
    }
    /// Every `(row, col)` entry, column by column.
    pub fn entries(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.n).flat_map(move |j| {
            self.row_idx[self.col_ptr[j]..self.col_ptr[j + 1]]
                .iter()
                .map(move |&i| (i, j))
        })
    }
}

/// An evaluator of `J = ∂f/∂x` into the non-zeros of a fixed [`Pattern`], owning its
/// scratch space so that [`eval`](Self::eval) allocates nothing.
pub trait SparseJacobian {
    /// The pattern the values are written in.
    fn pattern(&self) -> &Pattern;
    /// `values ← J(t, x, u)` in the order of [`pattern`](Self::pattern)`.row_idx()`. `x`
    /// is the state as a slice. [`Error::InvalidInput`](crate::Error::InvalidInput) when
    /// `values` does not hold one value per non-zero (`nnz`); a model that returns the
    /// wrong number of components gives NaN values (the caller reports them).
    fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) -> crate::Result<()>;
}

/// The error of a `values` buffer that is not `nnz` long.
pub(crate) fn check_values(values: &[f64], nnz: usize) -> crate::Result<()> {
    if values.len() == nnz {
        return Ok(());
    }
    Err(crate::Error::invalid(
        "values",
        format!("{} values for a pattern of {nnz} non-zeros", values.len()),
    ))
}

/// The linear algebra of the implicit methods ([`ImplicitEuler`](crate::methods::ImplicitEuler),
/// [`Bdf`](crate::methods::Bdf), [`Rodas5P`](crate::methods::Rodas5P), [`Auto`](crate::methods::Auto)'s
/// BDF): each factors `M = a·I + b·J` (`I − c·J` for Newton, `I/(hγ) − J` for Rodas5P)
/// and solves with it.
///
/// - `Dense`: `J` from [`System::jacobian`](crate::System::jacobian) into an `n × n`
///   matrix, nalgebra's stack LU for fixed sizes, faer's partial-pivoting LU for `DVector`.
/// - `Sparse`: `J`'s non-zeros from the model's
///   [`System::sparse_jacobian`](crate::System::sparse_jacobian) and an LU of `M` in the
///   pattern `J ∪ I`: banded ([`BandLu`](crate::linalg::BandLu), LAPACK's `dgbtrf`) when
///   that pattern lies in a narrow, mostly filled band ([`Band::suits`](crate::linalg::Band::suits):
///   1-D PDE stencils, chains), faer's sparse LU ([`SparseLu`](crate::linalg::SparseLu),
///   analysed once) otherwise; no `n × n` storage. A model without a sparse Jacobian is refused
///   ([`Error::InvalidInput`](crate::Error::InvalidInput) `"linear_solver"`) when an
///   implicit method starts.
/// - `Auto` (default): sparse when the model offers a sparse Jacobian, the state has at
///   least [`AUTO_MIN_STATES`](crate::jacobian::AUTO_MIN_STATES) = 64 components and `J`'s
///   density `nnz/n²` is at most [`AUTO_MAX_DENSITY`](crate::jacobian::AUTO_MAX_DENSITY) = 0.1;
///   dense otherwise (the model is not even asked below 64 states).
///
/// Explicit methods need no `J` and ignore the choice.
///
/// ```
/// use reckon::{model, methods::ImplicitEuler, LinearSolver, Error, Options, Problem};
/// use nalgebra::vector;
/// // a body that branches on the state cannot be traced: no sparse Jacobian
/// let f = model!(|_t, x: [S; 1]| vector![if x[0] > S::from(2.0) { S::from(2.0) } else { -x[0].clone() }]);
/// let p = Problem::new(&f, vector![1.0], (0.0, 1.0));
/// assert_eq!(Options::default().linear_solver, LinearSolver::Auto);
/// let o = Options::default().rtol(1e-3).atol(1e-3);
/// assert!(p.solve(ImplicitEuler::default(), &o).is_ok()); // dense
/// let forced = o.linear_solver(LinearSolver::Sparse);
/// let e = p.solve(ImplicitEuler::default(), &forced).unwrap_err();
/// assert!(matches!(e, Error::InvalidInput { what: "linear_solver", .. }));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LinearSolver {
    /// Sparse for large models with a sparse Jacobian, dense otherwise.
    #[default]
    Auto,
    /// Always the dense `n × n` Jacobian and LU.
    Dense,
    /// Always the model's sparse Jacobian and a sparse (or banded) LU.
    Sparse,
}

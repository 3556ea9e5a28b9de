//! faer's sparse LU of a matrix with a fixed [`Pattern`]: the symbolic analysis (COLAMD
//! column ordering, elimination tree, supernodal or simplicial structure) once, numeric
//! refactorisations with partial pivoting after, reusing every buffer.

use crate::jacobian::Pattern;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu, factorize_symbolic_lu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

/// `A = P⁻¹·L·U·Q` of a sparse `n × n` matrix with a fixed pattern; `b ← A⁻¹·b` in place.
///
/// [`new`](Self::new) analyses the pattern (faer's `factorize_symbolic_lu`: a COLAMD
/// fill-reducing column order `Q`, then a simplicial or supernodal structure chosen by
/// faer's flop ratio); [`factor`](Self::factor) computes `L`, `U` and the row pivoting `P`
/// for new values in that pattern, into the same buffers. faer reports a column with no
/// pivot candidate; a pivot that is numerically zero or a non-finite value shows as a
/// non-finite solution of `A·y = b` for a probe `b`, and either makes `factor` return
/// `false`, as the dense LUs do for a zero or non-finite pivot. Runs on one thread
/// (`Par::Seq`): the same numbers on every run.
///
/// ```
/// use reckon::{jacobian::Pattern, linalg::SparseLu};
/// // [[4, 1], [2, 3]] in CSC order: (0,0), (1,0), (0,1), (1,1)
/// let p = Pattern::from_entries(2, &[(0, 0), (1, 0), (0, 1), (1, 1)]).unwrap();
/// let mut lu = SparseLu::new(&p).unwrap();
/// assert_eq!(lu.factor(&[4.0, 2.0, 1.0, 3.0]), Ok(true));
/// let mut b = [5.0, 5.0]; // A·(1, 1)
/// lu.solve_in_place(&mut b).unwrap();
/// assert!((b[0] - 1.0).abs() < 1e-15 && (b[1] - 1.0).abs() < 1e-15);
/// assert_eq!(lu.factor(&[1.0, 1.0, 1.0, 1.0]), Ok(false)); // singular
/// assert!(lu.solve_in_place(&mut b).is_err()); // no factorisation to solve with
/// ```
pub struct SparseLu {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    factored: bool,
    probe: Vec<f64>,
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu")
            .field("n", &(self.col_ptr.len() - 1))
            .field("nnz", &self.row_idx.len())
            .field("factored", &self.factored)
            .finish()
    }
}

impl SparseLu {
    /// Symbolic analysis of `pattern`; `None` when faer cannot allocate it (or the
    /// pattern has no entries to pivot on in some column).
    pub fn new(pattern: &Pattern) -> Option<Self> {
        let n = pattern.n();
        let col_ptr = pattern.col_ptr().to_vec();
        let row_idx = pattern.row_idx().to_vec();
        let a = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_lu(a, Default::default()).ok()?;
        let factor_mem =
            MemBuffer::try_new(symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default())).ok()?;
        let solve_mem = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq)).ok()?;
        Some(SparseLu {
            col_ptr,
            row_idx,
            symbolic,
            numeric: NumericLu::new(),
            factor_mem,
            solve_mem,
            factored: false,
            probe: vec![0.0; n],
        })
    }

    /// Matrix size `n`.
    pub fn n(&self) -> usize {
        self.col_ptr.len() - 1
    }

    /// Factor the matrix whose non-zeros are `values` (in the pattern's order):
    /// `Ok(false)` when it is singular (no pivot, or a zero or non-finite one),
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when `values` does not have
    /// one value per non-zero of the pattern.
    ///
    /// ```
    /// use reckon::{jacobian::Pattern, linalg::SparseLu};
    /// let p = Pattern::from_entries(2, &[(0, 0), (1, 1)]).unwrap();
    /// let mut lu = SparseLu::new(&p).unwrap();
    /// assert_eq!(lu.factor(&[2.0, 4.0]), Ok(true));
    /// let e = lu.factor(&[2.0, 4.0, 1.0]).unwrap_err();
    /// assert_eq!(e.to_string(), "invalid values: 3 values for a pattern of 2 non-zeros");
    /// assert!(!lu.is_factored());
    /// ```
    pub fn factor(&mut self, values: &[f64]) -> crate::Result<bool> {
        self.factored = false;
        if values.len() != self.row_idx.len() {
            return Err(crate::Error::invalid(
                "values",
                format!(
                    "{} values for a pattern of {} non-zeros",
                    values.len(),
                    self.row_idx.len()
                ),
            ));
        }
        let n = self.n();
        if !values.iter().all(|v| v.is_finite()) {
            return Ok(false);
        }
        let sym = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let a = SparseColMatRef::new(sym, values);
        let stack = MemStack::new(&mut self.factor_mem);
        if self
            .symbolic
            .factorize_numeric_lu(&mut self.numeric, a, Par::Seq, stack, Default::default())
            .is_err()
        {
            return Ok(false);
        }
        self.factored = true;
        // a zero pivot leaves ∞ or NaN in L or U, which every solve meets: probe with a
        // vector without zeros (1, 1.1, 1.2, … cycled) so no product of 0·∞ is skipped
        let mut probe = std::mem::take(&mut self.probe);
        for (i, p) in probe.iter_mut().enumerate() {
            *p = 1.0 + 0.1 * (i % 7) as f64;
        }
        let ok = self.solve_in_place(&mut probe).is_ok() && probe.iter().all(|v| v.is_finite());
        self.probe = probe;
        self.factored = ok;
        Ok(ok)
    }

    /// Forget the factorisation (until the next successful [`factor`](Self::factor)).
    pub fn forget(&mut self) {
        self.factored = false;
    }

    /// Whether the last [`factor`](Self::factor) succeeded.
    pub fn is_factored(&self) -> bool {
        self.factored
    }

    /// `b ← A⁻¹·b` with the last successful factorisation;
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) (and `b` untouched) when there
    /// is none or `b` does not have `n` entries.
    ///
    /// ```
    /// use reckon::{jacobian::Pattern, linalg::SparseLu};
    /// let p = Pattern::from_entries(2, &[(0, 0), (1, 1)]).unwrap();
    /// let mut lu = SparseLu::new(&p).unwrap();
    /// let mut b = [2.0, 8.0];
    /// let e = lu.solve_in_place(&mut b).unwrap_err();
    /// assert_eq!(e.to_string(), "invalid factorisation: solve_in_place before a successful factor");
    /// lu.factor(&[2.0, 4.0]).unwrap();
    /// let e = lu.solve_in_place(&mut [1.0, 2.0, 3.0]).unwrap_err();
    /// assert_eq!(e.to_string(), "invalid rhs: 3 entries for a 2 × 2 matrix");
    /// lu.solve_in_place(&mut b).unwrap();
    /// assert_eq!(b, [1.0, 2.0]);
    /// ```
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> crate::Result<()> {
        if !self.factored {
            return Err(crate::Error::invalid(
                "factorisation",
                "solve_in_place before a successful factor",
            ));
        }
        let n = self.n();
        if b.len() != n {
            return Err(crate::Error::invalid(
                "rhs",
                format!("{} entries for a {n} × {n} matrix", b.len()),
            ));
        }
        let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
        let lu = LuRef::new_unchecked(&self.symbolic, &self.numeric);
        lu.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.solve_mem));
        Ok(())
    }
}

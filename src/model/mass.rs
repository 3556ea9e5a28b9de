//! A constant mass matrix `M` of a differential-algebraic system `M·x' = f(t, x)`:
//! diagonal, dense or sparse, possibly singular (index 1: the components in `M`'s null space
//! are algebraic, fixed by the equations `f` gives in its left null space).

use crate::error::{Error, Result};
use crate::jacobian::Pattern;
use crate::linalg::SparseLu;
use nalgebra::DMatrix;

/// The largest state whose mass matrix is taken densely (an SVD for its null spaces and
/// `M⁺`); above it a singular `M` must be coordinate-structured (zero rows and columns).
pub(crate) const MAX_DENSE_N: usize = 2000;

/// A constant mass matrix `M` for `M·x' = f(t, x)` ([`Problem::mass`](crate::Problem::mass)).
///
/// `Bdf` solves `M·(ψ + d) = c·f(t, y_p + d)` by Newton with `M − c·J`, and
/// `Rodas5P` builds its stages with `W = M/(hγ) − J`; a singular `M` makes an index-1
/// DAE, whose algebraic components are put on the constraint at the start (see
/// [`Solution::x0_corrected`](crate::Solution::x0_corrected)).
///
/// ```
/// use reckon::{model, Mass, Options, Problem, methods::Rodas5P};
/// use nalgebra::vector;
/// // y₁' = −y₁ with y₂ = y₁² as an algebraic equation: y₂ = e^(−2t)
/// let f = model!(|_t, y: [S; 2]| vector![-y[0].clone(), y[0].clone() * y[0].clone() - y[1].clone()]);
/// let sol = Problem::new(&f, vector![1.0, 1.0], (0.0, 1.0))
///     .mass(Mass::diagonal(vec![1.0, 0.0]))
///     .solve(Rodas5P, &Options::default().rtol(1e-10).atol(1e-12))
///     .unwrap();
/// assert!((sol.last().1[1] - (-2.0f64).exp()).abs() < 1e-9);
/// assert!(Mass::diagonal(vec![1.0, 0.0]).is_singular());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Mass {
    repr: Repr,
}

#[derive(Debug, Clone, PartialEq)]
enum Repr {
    Diagonal(Vec<f64>),
    Dense(DMatrix<f64>),
    Sparse(SparseMass),
}

/// A sparse `M`: its non-zeros in compressed columns.
#[derive(Debug, Clone, PartialEq)]
struct SparseMass {
    pattern: Pattern,
    values: Vec<f64>,
    /// The same entries by rows (`Mᵀ`'s columns), for products summed row by row in
    /// column order, as the dense kind sums them.
    by_rows: Pattern,
    row_values: Vec<f64>,
}

/// How a singular `M` splits the state: by coordinates (the algebraic components are
/// zero rows *and* columns of `M`, the rest of `M` regular: `V₂ = U₂ = E_A`), or by
/// general bases from an SVD (`n × k` each), or not at all above [`MAX_DENSE_N`].
pub(crate) enum NullSpaces {
    /// The algebraic components (empty: `M` is regular).
    Coordinates(Vec<usize>),
    /// `(V₂, U₂)`.
    Bases(DMatrix<f64>, DMatrix<f64>),
    /// A singular `M` with no coordinate structure, too large for an SVD.
    TooLarge,
}

impl Mass {
    /// `M = diag(d)`; zeros mark algebraic components.
    ///
    /// ```
    /// use reckon::Mass;
    /// let m = Mass::diagonal(vec![1.0, 0.0]);
    /// assert!(m.is_diagonal() && m.is_singular());
    /// ```
    pub fn diagonal(d: Vec<f64>) -> Self {
        Mass {
            repr: Repr::Diagonal(d),
        }
    }
    /// `M = m`, dense (capacitances coupling two nodes, a constraint mixing components).
    ///
    /// ```
    /// use reckon::Mass;
    /// use nalgebra::dmatrix;
    /// let m = Mass::dense(dmatrix![1.0, -1.0; -1.0, 1.0]); // rank 1
    /// assert!(!m.is_diagonal() && m.is_singular());
    /// ```
    pub fn dense(m: DMatrix<f64>) -> Self {
        Mass { repr: Repr::Dense(m) }
    }

    /// `M = Σ_k v_k·e_{i_k}·e_{j_k}ᵀ`: an `n × n` sparse `M` from `(row, column, value)`
    /// triplets, repeats summed (the assembly of finite elements) and entries summing to
    /// zero dropped. [`Error::InvalidInput`] for an index `≥ n` or a non-finite value.
    ///
    /// The sparse linear algebra forms `a·M + b·J` on the union of `M`'s and `J`'s
    /// patterns (one symbolic analysis per run); products with `M` take `O(nnz)`. A
    /// singular `M` whose null space is a set of zero rows and columns (algebraic
    /// equations) is handled at any size; another singular `M` only up to 2 000 states.
    ///
    /// ```
    /// use reckon::{model, Mass, Options, Problem, methods::Bdf};
    /// use nalgebra::vector;
    /// // M = [[2, 1], [1, 2]] (the two halves summed on the diagonal), M·x' = −x:
    /// // x = e^(−t/3)·(1, 1) along the eigenvector (1, 1) of M (eigenvalue 3)
    /// let m = Mass::sparse(2, &[(0, 0, 1.0), (0, 0, 1.0), (0, 1, 1.0), (1, 0, 1.0), (1, 1, 2.0)]).unwrap();
    /// let f = model!(|_t, x: [S; 2]| vector![-x[0].clone(), -x[1].clone()]);
    /// let sol = Problem::new(&f, vector![1.0, 1.0], (0.0, 3.0))
    ///     .mass(m)
    ///     .solve(Bdf::default(), &Options::default().rtol(1e-10).atol(1e-12))
    ///     .unwrap();
    /// assert!((sol.last().1[0] - (-1.0f64).exp()).abs() < 1e-8);
    /// assert!(Mass::sparse(2, &[(0, 2, 1.0)]).is_err());
    /// ```
    pub fn sparse(n: usize, triplets: &[(usize, usize, f64)]) -> Result<Self> {
        let bad = |why: String| Err(Error::invalid("mass", why));
        if let Some(&(r, c, _)) = triplets.iter().find(|&&(r, c, _)| r >= n || c >= n) {
            return bad(format!("entry ({r}, {c}) is outside the {n} × {n} matrix"));
        }
        if let Some(&(r, c, v)) = triplets.iter().find(|t| !t.2.is_finite()) {
            return bad(format!("entry ({r}, {c}) is {v}"));
        }
        let mut e: Vec<(usize, usize, f64)> = triplets.iter().map(|&(r, c, v)| (c, r, v)).collect();
        e.sort_unstable_by_key(|&(c, r, _)| (c, r));
        let mut merged: Vec<(usize, usize, f64)> = Vec::with_capacity(e.len());
        for (c, r, v) in e {
            match merged.last_mut() {
                Some(last) if (last.0, last.1) == (c, r) => last.2 += v,
                _ => merged.push((c, r, v)),
            }
        }
        merged.retain(|t| t.2 != 0.0);
        if let Some(&(c, r, v)) = merged.iter().find(|t| !t.2.is_finite()) {
            return bad(format!("entry ({r}, {c}) sums to {v}"));
        }
        let col_ptr = compressed_starts(n, merged.iter().map(|t| t.0));
        let row_idx = merged.iter().map(|t| t.1).collect();
        let values = merged.iter().map(|t| t.2).collect();
        let pattern = Pattern::from_csc(n, col_ptr, row_idx).expect("sorted, merged, in range");
        merged.sort_unstable_by_key(|&(c, r, _)| (r, c));
        let row_ptr = compressed_starts(n, merged.iter().map(|t| t.1));
        let col_idx = merged.iter().map(|t| t.0).collect();
        let row_values = merged.iter().map(|t| t.2).collect();
        let by_rows = Pattern::from_csc(n, row_ptr, col_idx).expect("sorted, merged, in range");
        Ok(Mass {
            repr: Repr::Sparse(SparseMass {
                pattern,
                values,
                by_rows,
                row_values,
            }),
        })
    }

    /// `M_{row_idx[k], j} = values[k]` for `k ∈ col_ptr[j]..col_ptr[j + 1]`: `M` from
    /// compressed sparse columns (rows in any order within a column, repeats
    /// summed, as [`sparse`](Self::sparse) does). [`Error::InvalidInput`] for a
    /// non-square shape, arrays that do not describe `nrows × ncols`, an index out of
    /// range or a non-finite value.
    ///
    /// ```
    /// use reckon::Mass;
    /// // [[4, 1], [1, 4]]
    /// let m = Mass::sparse_csc(2, 2, &[0, 2, 4], &[0, 1, 0, 1], &[4.0, 1.0, 1.0, 4.0]).unwrap();
    /// assert_eq!(m, Mass::sparse(2, &[(0, 0, 4.0), (1, 0, 1.0), (0, 1, 1.0), (1, 1, 4.0)]).unwrap());
    /// assert!(!m.is_singular());
    /// let e = Mass::sparse_csc(2, 3, &[0, 0, 0, 0], &[], &[]).unwrap_err();
    /// assert_eq!(e.to_string(), "invalid mass: 2×3 is not square");
    /// ```
    pub fn sparse_csc(
        nrows: usize,
        ncols: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        values: &[f64],
    ) -> Result<Self> {
        let bad = |why: String| Err(Error::invalid("mass", why));
        if nrows != ncols {
            return bad(format!("{nrows}×{ncols} is not square"));
        }
        let n = nrows;
        let nnz = row_idx.len();
        if col_ptr.len() != n + 1
            || col_ptr[0] != 0
            || col_ptr[n] != nnz
            || values.len() != nnz
            || col_ptr.windows(2).any(|w| w[0] > w[1])
        {
            return bad(format!(
                "column pointers ({} of them, last {:?}) and {nnz} rows, {} values do not describe {n} columns",
                col_ptr.len(),
                col_ptr.last(),
                values.len()
            ));
        }
        let mut t = Vec::with_capacity(nnz);
        for j in 0..n {
            for k in col_ptr[j]..col_ptr[j + 1] {
                t.push((row_idx[k], j, values[k]));
            }
        }
        Self::sparse(n, &t)
    }

    /// `M = diag(d)`: whether `M` is stored as its diagonal.
    ///
    /// ```
    /// use reckon::Mass;
    /// assert!(Mass::diagonal(vec![2.0]).is_diagonal());
    /// assert!(!Mass::sparse(1, &[(0, 0, 2.0)]).unwrap().is_diagonal());
    /// ```
    pub fn is_diagonal(&self) -> bool {
        matches!(self.repr, Repr::Diagonal(_))
    }

    /// `σ_min(M) ≤ n·ε·σ_max`: whether `M` is singular (a DAE), that is a zero on the
    /// diagonal, a dense `M` whose smallest singular value is below `n·ε·σ_max`, or a
    /// sparse `M` with a zero row or column, or (above 2 000 states, where no SVD is
    /// taken) whose sparse LU finds no pivot.
    ///
    /// ```
    /// use reckon::Mass;
    /// assert!(Mass::sparse(3, &[(0, 0, 1.0), (1, 1, 1.0)]).unwrap().is_singular());
    /// assert!(!Mass::diagonal(vec![1.0, 2.0]).is_singular());
    /// ```
    pub fn is_singular(&self) -> bool {
        match &self.repr {
            Repr::Diagonal(d) => d.contains(&0.0),
            Repr::Dense(m) => dense_singular(m),
            Repr::Sparse(s) => {
                let n = s.pattern.n();
                let (rows, cols) = s.empty_rows_cols();
                if rows.iter().chain(&cols).any(|&e| e) {
                    return true;
                }
                if n <= MAX_DENSE_N {
                    dense_singular(&s.to_dense())
                } else {
                    s.regular_lu().is_none()
                }
            }
        }
    }

    /// `M` for a state of `n` components: square, of that size, finite.
    pub(crate) fn check(&self, n: usize) -> Result<()> {
        let bad = |why: String| Err(Error::invalid("mass", why));
        match &self.repr {
            Repr::Diagonal(d) if d.len() != n => bad(format!("{} diagonal entries for a state of {n}", d.len())),
            Repr::Dense(m) if m.nrows() != n || m.ncols() != n => {
                bad(format!("{}×{} for a state of {n}", m.nrows(), m.ncols()))
            }
            Repr::Sparse(s) if s.pattern.n() != n => {
                let m = s.pattern.n();
                bad(format!("{m}×{m} for a state of {n}"))
            }
            _ => match self.values().iter().position(|v| !v.is_finite()) {
                Some(k) => bad(format!("entry {k} is {}", self.values()[k])),
                None => Ok(()),
            },
        }
    }

    fn values(&self) -> &[f64] {
        match &self.repr {
            Repr::Diagonal(d) => d,
            Repr::Dense(m) => m.as_slice(),
            Repr::Sparse(s) => &s.values,
        }
    }

    /// `M`'s stored entries `(row, column, value)` when it is diagonal or sparse (`None`
    /// for a dense `M`).
    pub(crate) fn sparse_entries(&self) -> Option<Vec<(usize, usize, f64)>> {
        match &self.repr {
            Repr::Diagonal(d) => Some(d.iter().enumerate().map(|(i, &v)| (i, i, v)).collect()),
            Repr::Sparse(s) => Some(
                s.pattern
                    .entries()
                    .zip(&s.values)
                    .map(|((i, j), &v)| (i, j, v))
                    .collect(),
            ),
            Repr::Dense(_) => None,
        }
    }

    /// `out ← M` (an `n × n` buffer of zeros or not: every entry is written).
    pub(crate) fn write_dense(&self, out: &mut [f64]) {
        match &self.repr {
            Repr::Dense(m) => out.copy_from_slice(m.as_slice()),
            Repr::Diagonal(d) => {
                out.fill(0.0);
                for (i, &v) in d.iter().enumerate() {
                    out[i * d.len() + i] = v;
                }
            }
            Repr::Sparse(s) => out.copy_from_slice(s.to_dense().as_slice()),
        }
    }

    /// `out_i ← a·out_i + b·(M·v)_i`.
    pub(crate) fn mul_into(&self, v: &[f64], a: f64, b: f64, out: &mut [f64]) {
        match &self.repr {
            Repr::Diagonal(d) => {
                for i in 0..out.len() {
                    out[i] = a * out[i] + b * d[i] * v[i];
                }
            }
            Repr::Dense(m) => {
                for (i, o) in out.iter_mut().enumerate() {
                    let mv: f64 = (0..v.len()).map(|j| m[(i, j)] * v[j]).sum();
                    *o = a * *o + b * mv;
                }
            }
            Repr::Sparse(s) => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = a * *o + b * s.row_dot(i, |j| v[j]);
                }
            }
        }
    }

    /// Newton's residual for `M·(ψ + d) = c·f`: `out_i ← c·f_i − (M·(ψ + d))_i`.
    pub(crate) fn residual(&self, c: f64, fx: &[f64], psi: &[f64], d: &[f64], out: &mut [f64]) {
        match &self.repr {
            Repr::Diagonal(m) => {
                for i in 0..out.len() {
                    out[i] = c * fx[i] - m[i] * (psi[i] + d[i]);
                }
            }
            Repr::Dense(m) => {
                for (i, o) in out.iter_mut().enumerate() {
                    let mv: f64 = (0..psi.len()).map(|j| m[(i, j)] * (psi[j] + d[j])).sum();
                    *o = c * fx[i] - mv;
                }
            }
            Repr::Sparse(s) => {
                for (i, o) in out.iter_mut().enumerate() {
                    *o = c * fx[i] - s.row_dot(i, |j| psi[j] + d[j]);
                }
            }
        }
    }

    /// `M`'s right and left null spaces `V₂`, `U₂` (`n × k` each, `k` the nullity: the
    /// algebraic directions of the state and the algebraic equations): coordinate
    /// vectors for a diagonal `M` and a sparse one whose singular part is zero rows and
    /// columns, an SVD's bases for a dense `M` or another sparse one up to
    /// [`MAX_DENSE_N`] states, [`NullSpaces::TooLarge`] above (for a dense `M` there,
    /// unless its LU shows it regular).
    pub(crate) fn null_spaces(&self) -> NullSpaces {
        match &self.repr {
            Repr::Diagonal(d) => NullSpaces::Coordinates((0..d.len()).filter(|&i| d[i] == 0.0).collect()),
            Repr::Dense(m) if m.nrows() <= MAX_DENSE_N => svd_null_spaces(m),
            Repr::Dense(m) => {
                if m.clone().full_piv_lu().is_invertible() {
                    NullSpaces::Coordinates(Vec::new())
                } else {
                    NullSpaces::TooLarge
                }
            }
            Repr::Sparse(s) => {
                let n = s.pattern.n();
                let (rows, cols) = s.empty_rows_cols();
                let alg: Vec<usize> = (0..n).filter(|&i| rows[i] && cols[i]).collect();
                let stray = (0..n).any(|i| rows[i] != cols[i]);
                if !stray && s.regular_lu().is_some() {
                    NullSpaces::Coordinates(alg)
                } else if n <= MAX_DENSE_N {
                    svd_null_spaces(&s.to_dense())
                } else {
                    NullSpaces::TooLarge
                }
            }
        }
    }

    /// `x' = M⁺·f`: the derivative a regular `M` gives, and on the differential part of a
    /// singular one (the least-squares solution, zero along the null space).
    pub(crate) fn derivative(&self, f: &[f64], out: &mut [f64]) {
        match &self.repr {
            Repr::Diagonal(d) => {
                for i in 0..out.len() {
                    out[i] = if d[i] == 0.0 { 0.0 } else { f[i] / d[i] };
                }
            }
            Repr::Dense(m) => {
                let n = m.nrows();
                let svd = m.clone().svd(true, true);
                let tol = rank_tol(n, svd.singular_values.max());
                let b = nalgebra::DVector::from_column_slice(f);
                match svd.solve(&b, tol) {
                    Ok(x) => out.copy_from_slice(x.as_slice()),
                    Err(_) => out.fill(0.0),
                }
            }
            Repr::Sparse(s) => {
                // M = P·blockdiag(M_DD, 0)·Pᵀ: M⁺·f = M_DD⁻¹·f_D on D, 0 on the rest
                let (rows, cols) = s.empty_rows_cols();
                let stray = rows.iter().zip(&cols).any(|(r, c)| r != c);
                if !stray && let Some((lu, keep)) = s.regular_lu() {
                    let mut b: Vec<f64> = keep.iter().map(|&i| f[i]).collect();
                    out.fill(0.0);
                    if let Some(mut lu) = lu
                        && lu.solve_in_place(&mut b).is_ok()
                    {
                        for (&i, v) in keep.iter().zip(b) {
                            out[i] = v;
                        }
                    }
                } else if s.pattern.n() <= MAX_DENSE_N {
                    Mass::dense(s.to_dense()).derivative(f, out);
                } else {
                    // refused before the first step (NullSpaces::TooLarge)
                    out.fill(0.0);
                }
            }
        }
    }
}

impl SparseMass {
    /// `Σ_j M_ij·v(j)` over row `i`'s entries, in column order.
    #[inline]
    fn row_dot(&self, i: usize, v: impl Fn(usize) -> f64) -> f64 {
        let r = self.by_rows.col_ptr()[i]..self.by_rows.col_ptr()[i + 1];
        self.by_rows.row_idx()[r.clone()]
            .iter()
            .zip(&self.row_values[r])
            .map(|(&j, &m)| m * v(j))
            .sum()
    }

    /// `g(i, j, M_ij)` for every stored entry.
    #[inline]
    fn for_each(&self, mut g: impl FnMut(usize, usize, f64)) {
        let (cp, ri) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for j in 0..self.pattern.n() {
            let r = cp[j]..cp[j + 1];
            for (&i, &v) in ri[r.clone()].iter().zip(&self.values[r]) {
                g(i, j, v);
            }
        }
    }

    /// Which rows and which columns have no non-zero.
    fn empty_rows_cols(&self) -> (Vec<bool>, Vec<bool>) {
        let n = self.pattern.n();
        let (mut rows, mut cols) = (vec![true; n], vec![true; n]);
        self.for_each(|i, j, _| {
            rows[i] = false;
            cols[j] = false;
        });
        (rows, cols)
    }

    fn to_dense(&self) -> DMatrix<f64> {
        let n = self.pattern.n();
        let mut m = DMatrix::zeros(n, n);
        self.for_each(|i, j, v| m[(i, j)] += v);
        m
    }

    /// The factored `M_DD` (`M` on the components `D` with a non-empty column, in
    /// order; no LU for an empty `D`) and `D`; `None` when it is singular: no pivot, or
    /// `‖M_DD‖∞·‖y‖∞/‖b‖∞` (a lower bound on its condition number) above `1/(n_D·ε)` for
    /// `y = M_DD⁻¹·b` and a probe `b`.
    fn regular_lu(&self) -> Option<(Option<SparseLu>, Vec<usize>)> {
        let n = self.pattern.n();
        let (_, cols) = self.empty_rows_cols();
        let keep: Vec<usize> = (0..n).filter(|&i| !cols[i]).collect();
        let mut at = vec![usize::MAX; n];
        for (k, &i) in keep.iter().enumerate() {
            at[i] = k;
        }
        let mut e = Vec::with_capacity(self.values.len());
        let mut bad = false;
        self.for_each(|i, j, _| {
            bad |= at[i] == usize::MAX;
            e.push((at[i], at[j]));
        });
        if bad {
            return None;
        }
        // the entries keep their column-major order under the monotone renumbering
        let p = Pattern::from_valid_entries(keep.len(), &e);
        if keep.is_empty() {
            return Some((None, keep));
        }
        let mut lu = SparseLu::new(&p)?;
        if !matches!(lu.factor(&self.values), Ok(true)) {
            return None;
        }
        let mut rows = vec![0.0f64; keep.len()];
        for (&(i, _), &v) in e.iter().zip(&self.values) {
            rows[i] += v.abs();
        }
        let norm = rows.iter().copied().fold(0.0, f64::max);
        let mut y: Vec<f64> = (0..keep.len()).map(|k| 1.0 + 0.1 * (k % 7) as f64).collect();
        let b_norm = y.iter().copied().fold(0.0, f64::max);
        lu.solve_in_place(&mut y).ok()?;
        let kappa = norm * y.iter().map(|v| v.abs()).fold(0.0, f64::max) / b_norm;
        (kappa.is_finite() && kappa * keep.len() as f64 * f64::EPSILON < 1.0).then_some((Some(lu), keep))
    }
}

/// Whether `σ_min(M) ≤ n·ε·σ_max`.
fn dense_singular(m: &DMatrix<f64>) -> bool {
    let sv = m.clone().singular_values();
    let max = sv.max();
    sv.iter().any(|&s| s <= rank_tol(m.nrows(), max))
}

/// `(V₂, U₂)` from an SVD of a dense `M`.
fn svd_null_spaces(m: &DMatrix<f64>) -> NullSpaces {
    let n = m.nrows();
    let svd = m.clone().svd(true, true);
    let (u, vt) = (svd.u.expect("asked for U"), svd.v_t.expect("asked for Vᵀ"));
    let tol = rank_tol(n, svd.singular_values.max());
    let null: Vec<usize> = (0..n).filter(|&k| svd.singular_values[k] <= tol).collect();
    let v2 = DMatrix::from_fn(n, null.len(), |i, k| vt[(null[k], i)]);
    let u2 = DMatrix::from_fn(n, null.len(), |i, k| u[(i, null[k])]);
    NullSpaces::Bases(v2, u2)
}

/// Singular values at or below `n·ε·σ_max` count as zero.
fn rank_tol(n: usize, sigma_max: f64) -> f64 {
    n as f64 * f64::EPSILON * sigma_max
}

/// The start of each of `n` columns (or rows) in a compressed layout, `n + 1` offsets,
/// from the column (row) of every entry, the entries sorted by it.
fn compressed_starts(n: usize, keys: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut ptr = vec![0; n + 1];
    for k in keys {
        ptr[k + 1] += 1;
    }
    for j in 0..n {
        ptr[j + 1] += ptr[j];
    }
    ptr
}

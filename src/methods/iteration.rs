//! The iteration matrix of every implicit method, `M = a·I + b·J` (`I − c·J` for
//! Newton, `I/(hγ) − J` for Rosenbrock), with the Jacobian it is built from: dense
//! (`n × n`, the [`LuDim`] backend) or sparse (`J`'s non-zeros and faer's sparse LU).

use crate::error::Result;
use crate::jacobian::Pattern;
use crate::linalg::{Band, BandLu, SparseLu};
use crate::linalg::{Lu, LuDim};
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, OMatrix, OVector};

/// `J` and the LU of `M = a·I + b·J`, dense or sparse as the run chose
/// ([`Eval::sparse_pattern`]).
pub(crate) enum IterationMatrix<D: LuDim>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    Dense {
        j: OMatrix<f64, D, D>,
        m: OMatrix<f64, D, D>,
        lu: Option<D::Lu>,
        /// The problem's mass matrix, dense (`M = a·mass + b·J`); `None`: `a·I + b·J`.
        mass: Option<OMatrix<f64, D, D>>,
    },
    /// `J` sparse; a diagonal or sparse mass matrix is `mass` (`M = a·mass + b·J`, on the
    /// union of the two patterns and the diagonal).
    Sparse(Box<SparseMatrix>),
    /// `J = [[A, 0], [L, blockdiag(A, …, A)]]` ([`System::jacobian_blocks`]): `M`'s
    /// diagonal blocks are all `a·I + b·A`, factored once (`b_n × b_n`), and
    /// `M·v = r` is solved by forward substitution over the blocks.
    Block {
        j: OMatrix<f64, D, D>,
        nb: usize,
        b: f64,
        lu: Option<BlockLu>,
        tmp: Vec<f64>,
    },
}

/// `J`'s values in its pattern, `M`'s in `J ∪ diag ∪ mass`, the maps between them and
/// the LU (analysed once, on the union): banded when the union lies in a narrow band
/// ([`Band::suits`]), faer's general sparse LU otherwise.
pub(crate) struct SparseMatrix {
    pattern: Pattern,
    j: Vec<f64>,
    m: Vec<f64>,
    /// `m[to_m[k]]` is the entry of `j[k]`.
    to_m: Vec<usize>,
    /// `m[diag[i]]` is `M_ii`.
    diag: Vec<usize>,
    lu: SparseFactor,
    /// `‖J‖∞` of the current `J` (computed with it: O(nnz)) and the row sums it uses.
    norm: f64,
    rows: Vec<f64>,
    /// The mass matrix's values and their positions in `m` (`None`: the identity).
    mass: Option<(Vec<f64>, Vec<usize>)>,
}

impl SparseMatrix {
    /// `mass`: the mass matrix's `(row, column, value)` entries.
    fn new(pattern: Pattern, mass: Option<Vec<(usize, usize, f64)>>) -> Option<Self> {
        let mp = match &mass {
            None => pattern.with_diagonal(),
            Some(e) => {
                let mut all: Vec<(usize, usize)> = pattern.entries().collect();
                all.extend((0..pattern.n()).map(|i| (i, i)));
                all.extend(e.iter().map(|&(i, j, _)| (i, j)));
                Pattern::from_valid_entries(pattern.n(), &all)
            }
        };
        let mass = mass.map(|e| {
            let at = e
                .iter()
                .map(|&(i, j, _)| mp.position(i, j).expect("the mass's pattern is inside M's"))
                .collect();
            (e.into_iter().map(|t| t.2).collect(), at)
        });
        let to_m: Vec<usize> = pattern
            .entries()
            .map(|(i, j)| mp.position(i, j).expect("J's pattern is inside M's"))
            .collect();
        let diag: Vec<usize> = (0..mp.n()).filter_map(|i| mp.position(i, i)).collect();
        let lu = if Band::suits(&mp) {
            SparseFactor::Band(BandLu::new(&mp)?)
        } else {
            SparseFactor::General(Box::new(SparseLu::new(&mp)?))
        };
        Some(SparseMatrix {
            j: vec![0.0; pattern.nnz()],
            m: vec![0.0; mp.nnz()],
            to_m,
            diag,
            lu,
            rows: vec![0.0; pattern.n()],
            pattern,
            norm: f64::NAN,
            mass,
        })
    }
}

/// The factorisation of a sparse `M`.
enum SparseFactor {
    Band(BandLu),
    General(Box<SparseLu>),
}

impl SparseFactor {
    fn factor(&mut self, values: &[f64]) -> bool {
        match self {
            SparseFactor::Band(lu) => lu.factor(values),
            SparseFactor::General(lu) => matches!(lu.factor(values), Ok(true)),
        }
    }
    fn is_factored(&self) -> bool {
        match self {
            SparseFactor::Band(lu) => lu.is_factored(),
            SparseFactor::General(lu) => lu.is_factored(),
        }
    }
    fn forget(&mut self) {
        match self {
            SparseFactor::Band(lu) => lu.forget(),
            SparseFactor::General(lu) => lu.forget(),
        }
    }
    fn solve_in_place(&mut self, b: &mut [f64]) -> bool {
        match self {
            SparseFactor::Band(lu) => lu.solve_in_place(b),
            SparseFactor::General(lu) => lu.solve_in_place(b).is_ok(),
        }
    }
}

impl<D: LuDim> IterationMatrix<D>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    /// Storage for states shaped like `x0`, on the path the run chose.
    pub fn new<S: System<D>>(f: &mut Eval<'_, D, S>, x0: &OVector<f64, D>) -> Result<Self> {
        let mass = f.mass;
        if let Some(p) = f.sparse_pattern(x0.len())? {
            let entries = match mass {
                None => None,
                Some(m) => Some(m.sparse_entries().ok_or_else(|| {
                    crate::Error::invalid(
                        "mass",
                        "a dense mass matrix takes the dense linear solver: give Mass::sparse or Mass::diagonal, or LinearSolver::Dense",
                    )
                })?),
            };
            let s = SparseMatrix::new(p, entries).ok_or_else(|| {
                crate::Error::invalid("linear_solver", "faer's sparse LU could not analyse the pattern")
            })?;
            return Ok(IterationMatrix::Sparse(Box::new(s)));
        }
        let (r, _) = x0.shape_generic();
        if let Some(m) = mass {
            let mut md = OMatrix::<f64, D, D>::zeros_generic(r, r);
            m.write_dense(md.as_mut_slice());
            return Ok(IterationMatrix::Dense {
                j: OMatrix::<f64, D, D>::zeros_generic(r, r),
                m: OMatrix::<f64, D, D>::zeros_generic(r, r),
                lu: None,
                mass: Some(md),
            });
        }
        if let Some(nb) = f.system().jacobian_blocks()
            && nb > 0
            && x0.len().is_multiple_of(nb)
            && x0.len() > nb
            && f.sparse.choice != crate::jacobian::LinearSolver::Sparse
        {
            return Ok(IterationMatrix::Block {
                j: OMatrix::<f64, D, D>::zeros_generic(r, r),
                nb,
                b: 0.0,
                lu: None,
                tmp: vec![0.0; nb],
            });
        }
        Ok(IterationMatrix::Dense {
            j: OMatrix::<f64, D, D>::zeros_generic(r, r),
            m: OMatrix::<f64, D, D>::zeros_generic(r, r),
            lu: None,
            mass: None,
        })
    }

    /// `J ← ∂f/∂x (t, x)`; drops the LU.
    pub fn evaluate<S: System<D>>(&mut self, f: &mut Eval<'_, D, S>, t: f64, x: &OVector<f64, D>) -> Result<()> {
        match self {
            IterationMatrix::Dense { j, lu, .. } => {
                *lu = None;
                f.jacobian(t, x, j)
            }
            IterationMatrix::Block { j, lu, .. } => {
                *lu = None;
                f.jacobian(t, x, j)
            }
            IterationMatrix::Sparse(s) => {
                s.lu_drop();
                f.sparse_jacobian(t, x, &mut s.j)?;
                s.rows.fill(0.0);
                for (&i, v) in s.pattern.row_idx().iter().zip(&s.j) {
                    s.rows[i] += v.abs();
                }
                s.norm = s.rows.iter().copied().fold(0.0, f64::max);
                Ok(())
            }
        }
    }

    /// Factor `M = a·I + b·J`; `false` when it is singular (or has non-finite pivots).
    pub fn factor(&mut self, a: f64, b: f64) -> bool {
        match self {
            IterationMatrix::Dense { j, m, lu, mass } => {
                m.copy_from(j);
                *m *= b;
                match mass {
                    Some(mm) => {
                        for (mi, &v) in m.iter_mut().zip(mm.iter()) {
                            *mi += a * v;
                        }
                    }
                    None => {
                        for i in 0..m.nrows() {
                            m[(i, i)] += a;
                        }
                    }
                }
                *lu = D::Lu::factor(m);
                lu.is_some()
            }
            IterationMatrix::Block { j, nb, b: bs, lu, .. } => {
                let nb = *nb;
                let mut m = nalgebra::DMatrix::from_fn(nb, nb, |r, c| b * j[(r, c)]);
                for i in 0..nb {
                    m[(i, i)] += a;
                }
                *bs = b;
                *lu = block_lu(m);
                lu.is_some()
            }
            IterationMatrix::Sparse(s) => {
                s.m.fill(0.0);
                for (k, &v) in s.j.iter().enumerate() {
                    s.m[s.to_m[k]] = b * v;
                }
                match &s.mass {
                    Some((values, at)) => {
                        for (&k, &mi) in at.iter().zip(values) {
                            s.m[k] += a * mi;
                        }
                    }
                    None => {
                        for &d in &s.diag {
                            s.m[d] += a;
                        }
                    }
                }
                // m has one value per non-zero of the pattern the LU was made for
                s.lu.factor(&s.m)
            }
        }
    }

    /// Whether an LU of the current `J` is at hand.
    pub fn is_factored(&self) -> bool {
        match self {
            IterationMatrix::Dense { lu, .. } => lu.is_some(),
            IterationMatrix::Block { lu, .. } => lu.is_some(),
            IterationMatrix::Sparse(s) => s.lu.is_factored(),
        }
    }

    /// Forget the LU (the next solve must factor again).
    pub fn drop_lu(&mut self) {
        match self {
            IterationMatrix::Dense { lu, .. } => *lu = None,
            IterationMatrix::Block { lu, .. } => *lu = None,
            IterationMatrix::Sparse(s) => s.lu_drop(),
        }
    }

    /// `v ← M⁻¹·v` with the last LU; `false` (v untouched) when there is none.
    pub fn solve(&mut self, v: &mut OVector<f64, D>) -> bool {
        match self {
            IterationMatrix::Dense { lu: Some(lu), .. } => lu.solve_in_place(v).is_ok(),
            IterationMatrix::Dense { lu: None, .. } => false,
            IterationMatrix::Block {
                j,
                nb,
                b,
                lu: Some(lu),
                tmp,
            } => {
                let (nb, b) = (*nb, *b);
                let v = v.as_mut_slice();
                let blocks = v.len() / nb;
                let solve = |s: &mut [f64], lu: &BlockLu| block_solve(lu, s);
                solve(&mut v[..nb], lu);
                tmp.copy_from_slice(&v[..nb]);
                for k in 1..blocks {
                    // r_k − b·L_k·v₀, then the diagonal block
                    for r in 0..nb {
                        let row = k * nb + r;
                        let mut acc = 0.0;
                        for (c, &x) in tmp.iter().enumerate() {
                            acc += j[(row, c)] * x;
                        }
                        v[row] -= b * acc;
                    }
                    solve(&mut v[k * nb..(k + 1) * nb], lu);
                }
                true
            }
            IterationMatrix::Block { lu: None, .. } => false,
            // (a length that is not n is refused, as a missing factorisation is)
            IterationMatrix::Sparse(s) if s.lu.is_factored() => s.lu.solve_in_place(v.as_mut_slice()),
            IterationMatrix::Sparse(_) => false,
        }
    }

    /// `‖J‖∞ = max_i Σ_j |J_ij|` (a bound on every eigenvalue's modulus).
    pub fn norm_inf(&self) -> f64 {
        match self {
            IterationMatrix::Dense { j, .. } | IterationMatrix::Block { j, .. } => j
                .row_iter()
                .map(|r| r.iter().map(|v| v.abs()).sum::<f64>())
                .fold(0.0, f64::max),
            IterationMatrix::Sparse(s) => s.norm,
        }
    }
}

/// The LU of a diagonal block (nalgebra's, partial pivoting).
pub(crate) type BlockLu = nalgebra::linalg::LU<f64, nalgebra::Dyn, nalgebra::Dyn>;

/// Factor a diagonal block; `None` when singular or with non-finite pivots. (Outside the
/// generic impl, whose allocator bounds would otherwise pin nalgebra's `DimMin` output.)
fn block_lu(m: nalgebra::DMatrix<f64>) -> Option<BlockLu> {
    let n = m.nrows();
    let f = nalgebra::linalg::LU::new(m);
    let u = f.u();
    (0..n).all(|i| u[(i, i)] != 0.0 && u[(i, i)].is_finite()).then_some(f)
}

/// `s ← A⁻¹·s` for one block.
fn block_solve(lu: &BlockLu, s: &mut [f64]) {
    let n = s.len();
    let mut w = nalgebra::DVectorViewMut::from_slice(s, n);
    lu.solve_mut(&mut w);
}

impl SparseMatrix {
    fn lu_drop(&mut self) {
        self.lu.forget();
    }
}

#[cfg(test)]
mod tests {
    use super::IterationMatrix;
    use crate::jacobian::LinearSolver;
    use crate::model::Eval;
    use crate::studies::problems::{brusselator, brusselator_y0};

    /// `‖J‖∞` and the solves agree between the dense and the sparse variant.
    #[test]
    fn sparse_variant_matches_dense() {
        let n = 40;
        let sys = brusselator(n);
        let x = brusselator_y0(n).map(|v| v * 0.9 + 0.05);
        let mut fs = Eval::new(&sys, Vec::new());
        fs.sparse.choice = LinearSolver::Sparse;
        let mut fd = Eval::new(&sys, Vec::new());
        fd.sparse.choice = LinearSolver::Dense;
        let mut s = IterationMatrix::new(&mut fs, &x).unwrap();
        let mut d = IterationMatrix::new(&mut fd, &x).unwrap();
        // BRUSS's interleaved (u, v) pattern lies in a band 2 + 2 wide: the banded LU
        assert!(matches!(&s, IterationMatrix::Sparse(m) if matches!(m.lu, super::SparseFactor::Band(_))));
        assert!(matches!(d, IterationMatrix::Dense { .. }));
        s.evaluate(&mut fs, 0.0, &x).unwrap();
        d.evaluate(&mut fd, 0.0, &x).unwrap();
        assert!((s.norm_inf() - d.norm_inf()).abs() <= 1e-14 * d.norm_inf());
        assert!(!s.is_factored() && !s.solve(&mut x.clone()));
        for (a, b) in [(1.0, -1e-3), (1.0 / (0.01 * 0.2), -1.0)] {
            assert!(s.factor(a, b) && d.factor(a, b));
            let (mut vs, mut vd) = (x.clone(), x.clone());
            assert!(s.solve(&mut vs) && d.solve(&mut vd));
            assert!((&vs - &vd).amax() <= 1e-13 * vd.amax());
        }
        s.drop_lu();
        assert!(!s.is_factored());
        assert_eq!(fs.stats.jacobian_evals, 1);
    }

    /// An arrow pattern (full first row and column, the diagonal) is as wide as the
    /// matrix: faer's general sparse LU, which solves as the dense LU does.
    #[test]
    fn wide_patterns_take_the_general_sparse_lu() {
        use super::{SparseFactor, SparseMatrix};
        use nalgebra::{DMatrix, DVector};
        let n = 30;
        let mut e: Vec<(usize, usize)> = (0..n).map(|i| (i, i)).collect();
        e.extend((1..n).flat_map(|i| [(0, i), (i, 0)]));
        let p = crate::jacobian::Pattern::from_entries(n, &e).unwrap();
        let mut s = SparseMatrix::new(p.clone(), None).unwrap();
        assert!(matches!(s.lu, SparseFactor::General(_)));
        let mut j = DMatrix::zeros(n, n);
        for (k, (r, c)) in p.entries().enumerate() {
            let v = if r == c { -2.0 - r as f64 } else { 0.5 + 0.01 * k as f64 };
            s.j[k] = v;
            j[(r, c)] = v;
        }
        let mut m = IterationMatrix::<nalgebra::Dyn>::Sparse(Box::new(s));
        let (a, b) = (1.0, -0.3);
        assert!(m.factor(a, b));
        let rhs = DVector::from_fn(n, |i, _| 1.0 + (i % 5) as f64);
        let mut v = rhs.clone();
        assert!(m.solve(&mut v));
        let dense = (DMatrix::identity(n, n) * a + j * b).lu().solve(&rhs).unwrap();
        assert!((&v - &dense).amax() <= 1e-14 * dense.amax());
    }
}

//! A consistent start for an index-1 DAE `M·x' = f(t, x)`: the algebraic components
//! (`M`'s right null space `V₂`) moved, the differential ones held, until the algebraic
//! equations (`M`'s left null space `U₂`: `U₂ᵀ·f = 0`) hold.

use crate::error::{Error, Result};
use crate::jacobian::Pattern;
use crate::linalg::SparseLu;
use crate::methods::step_size::Weights;
use crate::model::mass::{Mass, NullSpaces};
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DVector, DefaultAllocator, Dim, OMatrix, OVector};

/// Newton iterations allowed.
const MAX_ITERS: usize = 50;
/// A first correction below this many tolerance units leaves `x₀` as given.
const CONSISTENT_ENOUGH: f64 = 1e-3;

/// The Newton matrix of the algebraic equations and its solve.
enum Lin {
    /// `U₂ᵀ·J·V₂` from a dense `J` (bases `V₂`, `U₂`).
    Bases(DMatrix<f64>, DMatrix<f64>),
    /// `J_AA` (rows and columns `A`) from a dense `J`.
    DenseCoords(Vec<usize>),
    /// `J_AA` from the sparse `J` (values of `j` at `from` go to `m[to]`), factored by
    /// the sparse LU of its pattern.
    SparseCoords {
        alg: Vec<usize>,
        j: Vec<f64>,
        from_to: Vec<(usize, usize)>,
        m: Vec<f64>,
        lu: Box<SparseLu>,
    },
}

/// `Some(x₀ + V₂·z)` with `U₂ᵀ·f(t₀, x₀ + V₂·z) = 0` solved by Newton (the matrix
/// `U₂ᵀ·J·V₂`), or `None` when `x₀` already satisfies the algebraic equations to within
/// [`CONSISTENT_ENOUGH`] of the tolerance (measured by the first Newton correction in the
/// error norm `w`). [`Error::Inconsistent`] when Newton fails or `U₂ᵀ·J·V₂` is singular.
/// When `M`'s null spaces are coordinate subspaces (zero rows and columns: `V₂ = U₂ =
/// E_A`) the matrix is `J_AA`, taken from the sparse `J` on the sparse path, so any size
/// works; other singular `M` above [`MAX_DENSE_N`](crate::model::mass::MAX_DENSE_N)
/// states are [`Error::InvalidInput`].
pub(crate) fn consistent_start<D: Dim, S: System<D>>(
    f: &mut Eval<'_, D, S>,
    mass: &Mass,
    t0: f64,
    x0: &OVector<f64, D>,
    w: &Weights<D>,
) -> Result<Option<OVector<f64, D>>>
where
    DefaultAllocator: Allocator<D> + Allocator<D, D>,
{
    let n = x0.len();
    let fail = |reason: String| Error::Inconsistent { t: t0, reason };
    let mut lin = match mass.null_spaces() {
        NullSpaces::Coordinates(a) if a.is_empty() => return Ok(None),
        NullSpaces::Bases(v2, _) if v2.ncols() == 0 => return Ok(None),
        NullSpaces::Bases(v2, u2) => Lin::Bases(v2, u2),
        NullSpaces::TooLarge => {
            return Err(Error::invalid(
                "mass",
                format!(
                    "a singular mass matrix whose null space is not a set of zero rows and columns takes an SVD \
                     for its consistent start: only up to {} states (this one has {n})",
                    crate::model::mass::MAX_DENSE_N
                ),
            ));
        }
        NullSpaces::Coordinates(alg) => match f.sparse_pattern(n)? {
            Some(p) => {
                let mut at = vec![usize::MAX; n];
                for (k, &i) in alg.iter().enumerate() {
                    at[i] = k;
                }
                let mut from_to = Vec::new();
                let mut sub = Vec::new();
                for (k, (i, j)) in p.entries().enumerate() {
                    if at[i] != usize::MAX && at[j] != usize::MAX {
                        sub.push((at[i], at[j]));
                        from_to.push((k, sub.len() - 1));
                    }
                }
                let q = Pattern::from_valid_entries(alg.len(), &sub);
                // the sub-pattern keeps J's column-major order: from_to's targets are
                // q's positions
                for (k, &(r, c)) in sub.iter().enumerate() {
                    from_to[k].1 = q.position(r, c).expect("in q");
                }
                let lu = SparseLu::new(&q).ok_or_else(|| {
                    fail("the algebraic equations' Jacobian J_AA has no sparse LU (a column without entries: not of index 1)".into())
                })?;
                Lin::SparseCoords {
                    alg,
                    j: vec![0.0; p.nnz()],
                    from_to,
                    m: vec![0.0; q.nnz()],
                    lu: Box::new(lu),
                }
            }
            None => Lin::DenseCoords(alg),
        },
    };
    let singular = || fail("the algebraic equations' Jacobian U₂ᵀ·∂f/∂x·V₂ is singular: not of index 1 here".into());
    let (r, _) = x0.shape_generic();
    let mut jac = match lin {
        Lin::SparseCoords { .. } => None,
        _ => Some(OMatrix::<f64, D, D>::zeros_generic(r, r)),
    };
    let mut fx = x0.clone();
    let mut x = x0.clone();
    let mut dx = x0.clone();
    let mut last = f64::INFINITY;
    for it in 0..MAX_ITERS {
        f.rhs(t0, &x, &mut fx)
            .map_err(|e| fail(format!("f at iteration {it}: {e}")))?;
        let jerr = |e: Error| fail(format!("∂f/∂x at iteration {it}: {e}"));
        dx.fill(0.0);
        match (&mut lin, jac.as_mut()) {
            (Lin::Bases(v2, u2), Some(jac)) => {
                f.jacobian(t0, &x, jac).map_err(jerr)?;
                let res = u2.tr_mul(&DVector::from_column_slice(fx.as_slice()));
                let j = DMatrix::from_fn(n, n, |a, b| jac[(a, b)]);
                let a = u2.tr_mul(&(j * &*v2));
                let dz = a
                    .lu()
                    .solve(&(-res))
                    .filter(|dz| dz.iter().all(|v| v.is_finite()))
                    .ok_or_else(singular)?;
                let d = &*v2 * dz;
                dx.as_mut_slice().copy_from_slice(d.as_slice());
            }
            (Lin::DenseCoords(alg), Some(jac)) => {
                f.jacobian(t0, &x, jac).map_err(jerr)?;
                let k = alg.len();
                let a = DMatrix::from_fn(k, k, |p, q| jac[(alg[p], alg[q])]);
                let res = DVector::from_fn(k, |p, _| -fx[alg[p]]);
                let dz = a
                    .lu()
                    .solve(&res)
                    .filter(|dz| dz.iter().all(|v| v.is_finite()))
                    .ok_or_else(singular)?;
                for (p, &i) in alg.iter().enumerate() {
                    dx[i] = dz[p];
                }
            }
            (Lin::SparseCoords { alg, j, from_to, m, lu }, _) => {
                f.sparse_jacobian(t0, &x, j).map_err(jerr)?;
                for &(from, to) in from_to.iter() {
                    m[to] = j[from];
                }
                if !matches!(lu.factor(m), Ok(true)) {
                    return Err(singular());
                }
                let mut dz: Vec<f64> = alg.iter().map(|&i| -fx[i]).collect();
                if lu.solve_in_place(&mut dz).is_err() || !dz.iter().all(|v| v.is_finite()) {
                    return Err(singular());
                }
                for (p, &i) in alg.iter().enumerate() {
                    dx[i] = dz[p];
                }
            }
            _ => unreachable!("a dense Jacobian for the dense variants"),
        }
        let norm = (0..n).map(|i| (dx[i] / w.scale(i, x[i])).powi(2)).sum::<f64>().sqrt() / (n as f64).sqrt();
        if it == 0 && norm < CONSISTENT_ENOUGH {
            return Ok(None);
        }
        let still = (0..n).all(|i| x[i] + dx[i] == x[i]);
        for i in 0..n {
            x[i] += dx[i];
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(fail(format!("Newton drove component {i} to {}", x[i])));
        }
        if still || norm < 1e-10 || (norm < 1e-6 && norm >= 0.5 * last) {
            return Ok(Some(x));
        }
        last = norm;
    }
    Err(fail(format!(
        "Newton on the algebraic equations did not converge in {MAX_ITERS} iterations (last correction {} tolerance units)",
        crate::error::Brief(last)
    )))
}

//! A consistent start for an index-1 DAE `M·x' = f(t, x)`: the algebraic components
//! (`M`'s right null space `V₂`) moved, the differential ones held, until the algebraic
//! equations (`M`'s left null space `U₂`: `U₂ᵀ·f = 0`) hold.

use crate::error::{Error, Result};
use crate::methods::step_size::Weights;
use crate::model::mass::Mass;
use crate::model::{Eval, System};
use nalgebra::allocator::Allocator;
use nalgebra::{DMatrix, DVector, DefaultAllocator, Dim, OMatrix, OVector};

/// The largest state the consistent start handles (it takes a dense Jacobian); a larger
/// DAE starts from the values given, and its first step puts it on the constraint.
pub(crate) const MAX_CONSISTENT_N: usize = 2000;
/// Newton iterations allowed.
const MAX_ITERS: usize = 50;
/// A first correction below this many tolerance units leaves `x₀` as given.
const CONSISTENT_ENOUGH: f64 = 1e-3;

/// `Some(x₀ + V₂·z)` with `U₂ᵀ·f(t₀, x₀ + V₂·z) = 0` solved by Newton (the matrix
/// `U₂ᵀ·J·V₂`), or `None` when `x₀` already satisfies the algebraic equations to within
/// [`CONSISTENT_ENOUGH`] of the tolerance (measured by the first Newton correction in the
/// error norm `w`). [`Error::Inconsistent`] when Newton fails or `U₂ᵀ·J·V₂` is singular.
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
    if n > MAX_CONSISTENT_N {
        return Ok(None);
    }
    let (v2, u2) = mass.null_spaces();
    if v2.ncols() == 0 {
        return Ok(None);
    }
    let fail = |reason: String| Error::Inconsistent { t: t0, reason };
    let (r, _) = x0.shape_generic();
    let mut jac = OMatrix::<f64, D, D>::zeros_generic(r, r);
    let mut fx = x0.clone();
    let mut x = x0.clone();
    let mut last = f64::INFINITY;
    for it in 0..MAX_ITERS {
        f.rhs(t0, &x, &mut fx)
            .map_err(|e| fail(format!("f at iteration {it}: {e}")))?;
        f.jacobian(t0, &x, &mut jac)
            .map_err(|e| fail(format!("∂f/∂x at iteration {it}: {e}")))?;
        let res = u2.tr_mul(&DVector::from_column_slice(fx.as_slice()));
        let j = DMatrix::from_fn(n, n, |a, b| jac[(a, b)]);
        let a = u2.tr_mul(&(j * &v2));
        let dz = a
            .lu()
            .solve(&(-res))
            .filter(|dz| dz.iter().all(|v| v.is_finite()))
            .ok_or_else(|| {
                fail("the algebraic equations' Jacobian U₂ᵀ·∂f/∂x·V₂ is singular: not of index 1 here".into())
            })?;
        let dx = &v2 * dz;
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

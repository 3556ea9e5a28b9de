//! The model's sparse Jacobian as [`Eval`] holds it: the choice of linear algebra made
//! once per run (dense or sparse), the evaluator the model gave, and its counted and
//! checked calls.

use super::{Eval, System};
use crate::error::{Error, Quantity, Result};
use crate::options::LinearSolver;
use crate::sparse::{AUTO_MAX_DENSITY, AUTO_MIN_STATES, Pattern, SparseJacobian};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector};

/// What [`Eval`] keeps of the sparse path: the option, the decision once made (`Some(p)`:
/// sparse with `J`'s pattern `p`) and the model's evaluator.
#[derive(Default)]
pub(crate) struct Slot<'a> {
    pub(crate) choice: LinearSolver,
    decided: Option<Option<Pattern>>,
    evaluator: Option<Box<dyn SparseJacobian + 'a>>,
}

impl<'a, D: Dim, S: System<D>> Eval<'a, D, S>
where
    DefaultAllocator: Allocator<D>,
{
    /// The pattern of `J` if the implicit methods are to use the sparse path for a state
    /// of `n` components, decided on the first call from
    /// [`Options::linear_solver`](crate::Options::linear_solver) and the model's
    /// [`System::sparse_jacobian`] (asked only when the choice may be sparse).
    pub(crate) fn sparse_pattern(&mut self, n: usize) -> Result<Option<Pattern>> {
        if let Some(d) = &self.sparse.decided {
            return Ok(d.clone());
        }
        let ask = match self.sparse.choice {
            LinearSolver::Dense => false,
            LinearSolver::Sparse => true,
            LinearSolver::Auto => n >= AUTO_MIN_STATES,
        };
        let mut decided = None;
        if ask {
            let ev = self.system().sparse_jacobian(n);
            match (&ev, self.sparse.choice) {
                (None, LinearSolver::Sparse) => {
                    return Err(Error::invalid(
                        "linear_solver",
                        "LinearSolver::Sparse needs a model that offers a sparse Jacobian \
                         (System::sparse_jacobian returned None): use Auto or Dense, or give \
                         the model a SparseJacobian (a traced model!, or sparse::colour::Coloured)",
                    ));
                }
                (Some(e), _) if e.pattern().n() != n => {
                    return Err(Error::invalid(
                        "model",
                        format!(
                            "the sparse Jacobian's pattern is {0}x{0} for a state of {n}",
                            e.pattern().n()
                        ),
                    ));
                }
                (Some(e), LinearSolver::Sparse) => decided = Some(e.pattern().clone()),
                (Some(e), _) if e.pattern().density() <= AUTO_MAX_DENSITY => decided = Some(e.pattern().clone()),
                _ => {}
            }
            if decided.is_some() {
                self.sparse.evaluator = ev;
            }
        }
        self.sparse.decided = Some(decided.clone());
        Ok(decided)
    }

    /// `values ← J(t, x)` in the pattern of [`sparse_pattern`](Self::sparse_pattern),
    /// counted as a Jacobian evaluation and checked (a non-finite entry is reported at
    /// its row-major index `row·n + col`, as the dense path reports).
    pub(crate) fn sparse_jacobian(&mut self, t: f64, x: &OVector<f64, D>, values: &mut [f64]) -> Result<()> {
        let Some(ev) = self.sparse.evaluator.as_mut() else {
            return Err(Error::invalid("linear_solver", "no sparse Jacobian was chosen"));
        };
        self.stats.jacobian_evals += 1;
        ev.eval(t, x.as_slice(), &self.u, values)?;
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            let p = ev.pattern();
            let col = p.col_ptr().partition_point(|&c| c <= k) - 1;
            let row = p.row_idx()[k];
            let mut dx = x.clone();
            self.system().rhs(t, x, &self.u, &mut dx);
            if dx.len() != x.len() {
                return Err(Error::invalid(
                    "model",
                    format!("f returned {} components for a state of {}", dx.len(), x.len()),
                ));
            }
            return Err(Error::NonFinite {
                t,
                quantity: Quantity::Jacobian,
                component: row * x.len() + col,
            });
        }
        Ok(())
    }
}

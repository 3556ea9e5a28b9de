//! The choice of linear algebra for a run, made once: dense, or sparse with the pattern
//! and the evaluator the model offered. The model's evaluator ([`Eval`](crate::model::Eval))
//! holds a [`Slot`] and asks it; nothing here knows the model.

use super::{AUTO_MAX_DENSITY, AUTO_MIN_STATES, LinearSolver, Pattern, SparseJacobian};
use crate::error::{Error, Result};

/// The option, the decision once made (`Some(p)`: sparse with `J`'s pattern `p`) and
/// the model's evaluator.
#[derive(Default)]
pub(crate) struct Slot<'a> {
    pub(crate) choice: LinearSolver,
    decided: Option<Option<Pattern>>,
    evaluator: Option<Box<dyn SparseJacobian + 'a>>,
}

impl<'a> Slot<'a> {
    /// The pattern of `J` if the implicit methods are to use the sparse path for a state
    /// of `n` components, decided on the first call from the option and the model's
    /// offer (`offer(n)`, [`System::sparse_jacobian`](crate::System::sparse_jacobian),
    /// asked only when the choice may be sparse).
    pub(crate) fn pattern(
        &mut self,
        n: usize,
        offer: impl FnOnce(usize) -> Option<Box<dyn SparseJacobian + 'a>>,
    ) -> Result<Option<Pattern>> {
        if let Some(d) = &self.decided {
            return Ok(d.clone());
        }
        let ask = match self.choice {
            LinearSolver::Dense => false,
            LinearSolver::Sparse => true,
            LinearSolver::Auto => n >= AUTO_MIN_STATES,
        };
        let mut decided = None;
        if ask {
            let ev = offer(n);
            match (&ev, self.choice) {
                (None, LinearSolver::Sparse) => {
                    return Err(Error::invalid(
                        "linear_solver",
                        "LinearSolver::Sparse needs a model that offers a sparse Jacobian \
                         (System::sparse_jacobian returned None): use Auto or Dense, or give \
                         the model a SparseJacobian (a traced model!, or jacobian::colour::Coloured)",
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
                self.evaluator = ev;
            }
        }
        self.decided = Some(decided.clone());
        Ok(decided)
    }

    /// `values ← J(t, x)` in the chosen pattern; `Ok(Some(row·n + col))` names the first
    /// non-finite entry (row-major, as the dense path reports it).
    pub(crate) fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) -> Result<Option<usize>> {
        let Some(ev) = self.evaluator.as_mut() else {
            return Err(Error::invalid("linear_solver", "no sparse Jacobian was chosen"));
        };
        ev.eval(t, x, u, values)?;
        Ok(values.iter().position(|v| !v.is_finite()).map(|k| {
            let p = ev.pattern();
            let col = p.col_ptr().partition_point(|&c| c <= k) - 1;
            p.row_idx()[k] * x.len() + col
        }))
    }
}

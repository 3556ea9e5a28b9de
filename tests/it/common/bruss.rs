//! BRUSS 1-D (HNW ODE II §IV.1, the body of `reckon::studies::problems::brusselator`) as a
//! hand-written `System<Dyn>` that offers a sparse Jacobian, for the sparse path's tests,
//! benches and examples until `model!` gives one itself: `rhs` at `f64`, the dense
//! `jacobian` exact by hand, and `sparse_jacobian` either the coloured num-dual evaluator
//! (`reckon::jacobian::colour::Coloured` over the same body at `DualDVec64`) or the exact
//! non-zeros by hand (`Jac::Hand`, a stand-in for a compiled evaluator).
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector, Dyn};
use reckon::System;
use reckon::jacobian::colour::Coloured;
use reckon::jacobian::{Pattern, SparseJacobian};
use reckon::num_dual::{DualDVec64, DualNum};
use std::cell::Cell;

/// Which sparse evaluator the model offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Jac {
    /// `Coloured` over the dual-number body.
    Coloured,
    /// The exact non-zeros written by hand.
    Hand,
    /// None: the model has only the dense Jacobian.
    None,
}

/// BRUSS 1-D with `n` grid points (`2n` states `(u₁, v₁, …)`), counting its calls.
pub struct Bruss {
    pub n: usize,
    pub c: f64,
    pub jac: Jac,
    /// `sparse_jacobian` calls (evaluators made).
    pub made: Cell<usize>,
    /// Dense `jacobian` calls.
    pub dense_calls: Cell<usize>,
    /// Sparse evaluations.
    pub sparse_calls: std::rc::Rc<Cell<usize>>,
}

impl Bruss {
    pub fn new(n: usize, jac: Jac) -> Self {
        Bruss {
            n,
            c: (n as f64 + 1.0).powi(2) / 50.0,
            jac,
            made: Cell::new(0),
            dense_calls: Cell::new(0),
            sparse_calls: Default::default(),
        }
    }
}

/// The body of `problems::brusselator`, generic in the scalar.
pub fn body<S: DualNum<Primitive = f64>>(y: &DVector<S>, c: f64) -> DVector<S> {
    let n = y.len() / 2;
    DVector::from_fn(2 * n, |k, _| {
        let i = k / 2;
        let (own, bc) = if k % 2 == 0 { (0, 1.0) } else { (1, 3.0) };
        let at = |j: usize| y[2 * j + own].clone();
        let left = if i == 0 { S::from(bc) } else { at(i - 1) };
        let right = if i + 1 == n { S::from(bc) } else { at(i + 1) };
        let (u, v) = (y[2 * i].clone(), y[2 * i + 1].clone());
        let diff = (left + right - at(i) * 2.0) * c;
        let uuv = u.clone() * u.clone() * v;
        if own == 0 {
            uuv - u * 4.0 + 1.0 + diff
        } else {
            u * 3.0 - uuv + diff
        }
    })
}

/// The entries of `J` for `n` grid points: row `k` reads its own species at `i − 1, i,
/// i + 1` and the other species at `i`.
pub fn entries(n: usize) -> Vec<(usize, usize)> {
    let mut e = Vec::new();
    for k in 0..2 * n {
        let i = k / 2;
        e.push((k, k));
        e.push((k, k ^ 1));
        if i > 0 {
            e.push((k, k - 2));
        }
        if i + 1 < n {
            e.push((k, k + 2));
        }
    }
    e
}

pub fn pattern(n: usize) -> Pattern {
    Pattern::from_entries(2 * n, &entries(n)).unwrap()
}

/// `J(row, col)` by hand.
fn exact(y: &[f64], c: f64, row: usize, col: usize) -> f64 {
    let i = row / 2;
    let (u, v) = (y[2 * i], y[2 * i + 1]);
    if row == col {
        if row.is_multiple_of(2) {
            2.0 * u * v - 4.0 - 2.0 * c
        } else {
            -u * u - 2.0 * c
        }
    } else if col == row ^ 1 {
        if row.is_multiple_of(2) {
            u * u
        } else {
            3.0 - 2.0 * u * v
        }
    } else {
        c
    }
}

/// The hand-written sparse evaluator.
pub struct HandJac {
    pattern: Pattern,
    c: f64,
    calls: std::rc::Rc<Cell<usize>>,
}

impl SparseJacobian for HandJac {
    fn pattern(&self) -> &Pattern {
        &self.pattern
    }
    fn eval(&mut self, _t: f64, x: &[f64], _u: &[f64], values: &mut [f64]) -> reckon::Result<()> {
        self.calls.set(self.calls.get() + 1);
        let (cp, ri) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for j in 0..self.pattern.n() {
            for k in cp[j]..cp[j + 1] {
                values[k] = exact(x, self.c, ri[k], j);
            }
        }
        Ok(())
    }
}

/// `Coloured` with a call counter.
pub struct Counted<J> {
    inner: J,
    calls: std::rc::Rc<Cell<usize>>,
}

impl<J: SparseJacobian> SparseJacobian for Counted<J> {
    fn pattern(&self) -> &Pattern {
        self.inner.pattern()
    }
    fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) -> reckon::Result<()> {
        self.calls.set(self.calls.get() + 1);
        self.inner.eval(t, x, u, values)
    }
}

impl System<Dyn> for Bruss {
    fn rhs(&self, _t: f64, x: &DVector<f64>, _u: &[f64], dx: &mut DVector<f64>) {
        let n = x.len() / 2;
        let c = self.c;
        let dx = dx.as_mut_slice();
        for i in 0..n {
            let (u, v) = (x[2 * i], x[2 * i + 1]);
            let (ul, vl) = if i == 0 {
                (1.0, 3.0)
            } else {
                (x[2 * i - 2], x[2 * i - 1])
            };
            let (ur, vr) = if i + 1 == n {
                (1.0, 3.0)
            } else {
                (x[2 * i + 2], x[2 * i + 3])
            };
            let uuv = u * u * v;
            dx[2 * i] = uuv - u * 4.0 + 1.0 + (ul + ur - u * 2.0) * c;
            dx[2 * i + 1] = u * 3.0 - uuv + (vl + vr - v * 2.0) * c;
        }
    }
    fn jacobian(&self, _t: f64, x: &DVector<f64>, _u: &[f64], jac: &mut DMatrix<f64>) {
        self.dense_calls.set(self.dense_calls.get() + 1);
        jac.fill(0.0);
        for (r, c) in entries(self.n) {
            jac[(r, c)] = exact(x.as_slice(), self.c, r, c);
        }
    }
    fn time_derivative(&self, _t: f64, _x: &DVector<f64>, _u: &[f64], dfdt: &mut DVector<f64>) -> bool {
        dfdt.fill(0.0);
        true
    }
    fn sparse_jacobian(&self, n: usize) -> Option<Box<dyn SparseJacobian + '_>> {
        self.made.set(self.made.get() + 1);
        assert_eq!(n, 2 * self.n);
        let calls = self.sparse_calls.clone();
        let c = self.c;
        match self.jac {
            Jac::None => None,
            Jac::Hand => Some(Box::new(HandJac {
                pattern: pattern(self.n),
                c,
                calls,
            })),
            Jac::Coloured => Some(Box::new(Counted {
                inner: Coloured::new(pattern(self.n), move |_t: f64, x: &DVector<DualDVec64>, _u: &[f64]| {
                    body(x, c)
                }),
                calls,
            })),
        }
    }
}

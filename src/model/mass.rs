//! A constant mass matrix `M` of a differential-algebraic system `M·x' = f(t, x)`:
//! diagonal or dense, possibly singular (index 1: the components in `M`'s null space
//! are algebraic, fixed by the equations `f` gives in its left null space).

use crate::error::{Error, Result};
use nalgebra::DMatrix;

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
}

impl Mass {
    /// `M = diag(d)`; zeros mark algebraic components.
    pub fn diagonal(d: Vec<f64>) -> Self {
        Mass {
            repr: Repr::Diagonal(d),
        }
    }
    /// A dense `M` (capacitances coupling two nodes, a constraint mixing components).
    pub fn dense(m: DMatrix<f64>) -> Self {
        Mass { repr: Repr::Dense(m) }
    }

    /// Whether `M` is diagonal (stored as its diagonal).
    pub fn is_diagonal(&self) -> bool {
        matches!(self.repr, Repr::Diagonal(_))
    }

    /// Whether `M` is singular (a DAE): a zero on the diagonal, or a dense `M` whose
    /// smallest singular value is below `n·ε·σ_max`.
    pub fn is_singular(&self) -> bool {
        match &self.repr {
            Repr::Diagonal(d) => d.contains(&0.0),
            Repr::Dense(m) => {
                let sv = m.clone().singular_values();
                let max = sv.max();
                sv.iter().any(|&s| s <= rank_tol(m.nrows(), max))
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
        }
    }

    /// The diagonal, when `M` is stored as one.
    pub(crate) fn as_diagonal(&self) -> Option<&[f64]> {
        match &self.repr {
            Repr::Diagonal(d) => Some(d),
            Repr::Dense(_) => None,
        }
    }

    /// The dense `M`, when stored as one.
    pub(crate) fn as_dense(&self) -> Option<&DMatrix<f64>> {
        match &self.repr {
            Repr::Dense(m) => Some(m),
            Repr::Diagonal(_) => None,
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
        }
    }

    /// Bases of `M`'s right and left null spaces, `(V₂, U₂)` (`n × k` each, `k` the
    /// nullity): the algebraic directions of the state and the algebraic equations.
    /// Empty for a regular `M`.
    pub(crate) fn null_spaces(&self) -> (DMatrix<f64>, DMatrix<f64>) {
        match &self.repr {
            Repr::Diagonal(d) => {
                let alg: Vec<usize> = (0..d.len()).filter(|&i| d[i] == 0.0).collect();
                let mut e = DMatrix::zeros(d.len(), alg.len());
                for (k, &i) in alg.iter().enumerate() {
                    e[(i, k)] = 1.0;
                }
                (e.clone(), e)
            }
            Repr::Dense(m) => {
                let n = m.nrows();
                let svd = m.clone().svd(true, true);
                let (u, vt) = (svd.u.expect("asked for U"), svd.v_t.expect("asked for Vᵀ"));
                let tol = rank_tol(n, svd.singular_values.max());
                let null: Vec<usize> = (0..n).filter(|&k| svd.singular_values[k] <= tol).collect();
                let v2 = DMatrix::from_fn(n, null.len(), |i, k| vt[(null[k], i)]);
                let u2 = DMatrix::from_fn(n, null.len(), |i, k| u[(i, null[k])]);
                (v2, u2)
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
        }
    }
}

/// Singular values at or below `n·ε·σ_max` count as zero.
fn rank_tol(n: usize, sigma_max: f64) -> f64 {
    n as f64 * f64::EPSILON * sigma_max
}

//! Sparse Jacobians by column colouring (Curtis–Powell–Reid), for models whose body
//! cannot be traced: columns that share no row get one colour, and one evaluation of the
//! model at num-dual's `DualDVec64` with `x_j` seeded by the unit vector of `colour(j)`
//! gives every non-zero, `J_ij = ∂f_i/∂(seed colour(j))`, at the cost of `colours`
//! derivative components instead of `n`.

use super::{Pattern, SparseJacobian};
use nalgebra::DVector;
use num_dual::DualDVec64;

/// A colouring of the columns of a pattern such that no two columns of one colour have
/// an entry in the same row (a distance-2 colouring of the column intersection graph).
///
/// [`greedy`](Self::greedy) visits the columns in order and gives each the smallest
/// colour none of its neighbours (columns sharing a row) has; the count is at least the
/// largest number of entries in a row and at most `1 + Σ` over a column's rows of their
/// other entries.
///
/// ```
/// use reckon::jacobian::{Pattern, colour::Colouring};
/// // tridiagonal 5 × 5: three colours (columns j, j + 3, … share no row)
/// let e: Vec<_> = (0..5usize).flat_map(|i| [(i, i.saturating_sub(1)), (i, i), (i, (i + 1).min(4))]).collect();
/// let c = Colouring::greedy(&Pattern::from_entries(5, &e).unwrap());
/// assert_eq!(c.count(), 3);
/// assert_eq!(c.colours(), &[0, 1, 2, 0, 1]);
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Colouring {
    colours: Vec<usize>,
    count: usize,
}

impl Colouring {
    /// The greedy colouring in natural column order.
    pub fn greedy(p: &Pattern) -> Self {
        let n = p.n();
        // the rows' columns (CSR of the pattern)
        let mut row_ptr = vec![0usize; n + 1];
        for &i in p.row_idx() {
            row_ptr[i + 1] += 1;
        }
        for i in 0..n {
            row_ptr[i + 1] += row_ptr[i];
        }
        let mut fill = row_ptr.clone();
        let mut cols = vec![0usize; p.nnz()];
        for (i, j) in p.entries() {
            cols[fill[i]] = j;
            fill[i] += 1;
        }
        let mut colours = vec![usize::MAX; n];
        // forbidden[c] == j: colour c is taken by a neighbour of column j
        let mut forbidden: Vec<usize> = Vec::new();
        let mut count = 0;
        for j in 0..n {
            for &i in &p.row_idx()[p.col_ptr()[j]..p.col_ptr()[j + 1]] {
                for &k in &cols[row_ptr[i]..row_ptr[i + 1]] {
                    let c = colours[k];
                    if c != usize::MAX {
                        forbidden[c] = j;
                    }
                }
            }
            let c = (0..count).find(|&c| forbidden[c] != j).unwrap_or(count);
            if c == count {
                count += 1;
                forbidden.push(usize::MAX);
            }
            colours[j] = c;
        }
        Colouring { colours, count }
    }

    /// The colour of each column.
    pub fn colours(&self) -> &[usize] {
        &self.colours
    }

    /// Number of colours (derivative components per evaluation).
    pub fn count(&self) -> usize {
        self.count
    }
}

/// `J = ∂f/∂x` into a [`Pattern`] from one evaluation of `g = f` at num-dual's
/// `DualDVec64`, with `x_j = x_j + ε_{colour(j)}` ([`Colouring::greedy`]): then
/// `∂f_i/∂ε_c = Σ_{colour(j) = c} J_ij` has one term in the pattern, so
/// `J_ij = (∂f_i/∂ε)_{colour(j)}`, exact to rounding like the dense autodiff Jacobian.
/// One call costs `colours`, not `n`, derivative components per operation, and no
/// `n × n` storage is ever made. `g` is the body of the model at dual numbers (the
/// closure `model!` builds for a `[S; Dyn]` state). The pattern must hold every entry
/// that can be non-zero ([`detect_pattern`] finds one at given points); an entry `g`
/// depends on but the pattern lacks is silently folded into another of its row's
/// entries of the same colour.
///
/// ```
/// use reckon::jacobian::{Pattern, SparseJacobian, colour::Coloured};
/// use reckon::num_dual::DualDVec64;
/// use nalgebra::DVector;
/// // f_i = x_i² + x_{i+1} (cyclic): J = 2 diag(x) + shift
/// let g = |_t: f64, x: &DVector<DualDVec64>, _u: &[f64]| {
///     let n = x.len();
///     DVector::from_fn(n, |i, _| x[i].clone() * x[i].clone() + x[(i + 1) % n].clone())
/// };
/// let e: Vec<_> = (0..4).flat_map(|i| [(i, i), (i, (i + 1) % 4)]).collect();
/// let mut jac = Coloured::new(Pattern::from_entries(4, &e).unwrap(), g);
/// assert_eq!(jac.colouring().count(), 2);
/// let mut v = vec![0.0; 8];
/// jac.eval(0.0, &[1.0, 2.0, 3.0, 4.0], &[], &mut v).unwrap();
/// // column 0 holds (0,0) = 2·1 and (3,0) = 1; column 1 holds (0,1) = 1 and (1,1) = 2·2
/// assert_eq!(&v[..4], &[2.0, 1.0, 1.0, 4.0]);
/// ```
pub struct Coloured<G> {
    pattern: Pattern,
    colouring: Colouring,
    g: G,
}

impl<G> Coloured<G>
where
    G: Fn(f64, &DVector<DualDVec64>, &[f64]) -> DVector<DualDVec64>,
{
    /// The evaluator of `g`'s Jacobian in `pattern`, coloured greedily.
    pub fn new(pattern: Pattern, g: G) -> Self {
        let colouring = Colouring::greedy(&pattern);
        Coloured { pattern, colouring, g }
    }

    /// The evaluator over the pattern [`detect_pattern`] finds at `x0` (and a perturbed
    /// `x0`), for a model that has no pattern of its own (structural at those points only).
    ///
    /// ```
    /// use reckon::jacobian::{SparseJacobian, colour::Coloured};
    /// use reckon::num_dual::DualDVec64;
    /// use nalgebra::{DVector, dvector};
    /// let g = |_t: f64, x: &DVector<DualDVec64>, _u: &[f64]| dvector![x[0].clone() * x[1].clone(), x[1].clone()];
    /// let mut jac = Coloured::detected(g, 0.0, &dvector![1.0, 0.0], &[]);
    /// let mut v = vec![0.0; jac.pattern().nnz()];
    /// jac.eval(0.0, &[3.0, 2.0], &[], &mut v).unwrap();
    /// assert_eq!(v, [2.0, 3.0, 1.0]); // ∂f₀/∂x₀ = x₁, ∂f₀/∂x₁ = x₀, ∂f₁/∂x₁ = 1
    /// ```
    pub fn detected(g: G, t: f64, x0: &DVector<f64>, u: &[f64]) -> Self {
        let p = detect_pattern(&g, t, x0, u);
        Self::new(p, g)
    }

    /// The colouring in use.
    pub fn colouring(&self) -> &Colouring {
        &self.colouring
    }
}

impl<G> SparseJacobian for Coloured<G>
where
    G: Fn(f64, &DVector<DualDVec64>, &[f64]) -> DVector<DualDVec64>,
{
    fn pattern(&self) -> &Pattern {
        &self.pattern
    }
    fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) -> crate::Result<()> {
        super::check_values(values, self.pattern.nnz())?;
        let n = self.pattern.n();
        let c = self.colouring.count();
        let colours = self.colouring.colours();
        let xd = DVector::from_fn(x.len(), |j, _| {
            let v = DualDVec64::from_re(x[j]);
            if j < n { v.derivative(c, colours[j]) } else { v }
        });
        let r = (self.g)(t, &xd, u);
        if r.len() != n || x.len() != n {
            // the model's length error: NaN, which the caller reports
            values.fill(f64::NAN);
            return Ok(());
        }
        let (cp, ri) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for j in 0..n {
            for k in cp[j]..cp[j + 1] {
                values[k] = r[ri[k]].eps.0.as_ref().map_or(0.0, |e| e[colours[j]]);
            }
        }
        Ok(())
    }
}

/// The structural pattern of `∂g/∂x`, found numerically: every entry that is non-zero
/// (or not finite) in the dense autodiff Jacobian at `x0` or at a perturbed
/// `x0 + δ`, `δ_i = 10⁻³·(1 + |x0_i|)·(1 + (i mod 7))/7`.
///
/// It is structural only at those points: an entry that happens to vanish at both
/// (`∂(x_i x_j)/∂x_i = x_j` where `x_j = 0` at both) is missed, and an entry that a
/// branch on the state reaches elsewhere is missed too. The union over two points
/// catches the accidental zeros of a state like `v = 0` that the perturbation moves.
/// The columns are seeded 64 at a time, so the memory is `O(64·n)`, the time
/// `O(n/64)` evaluations of `g` with 64 derivative components (an `O(n²)` pass in all:
/// fine at thousands of states, too slow at millions, where a traced model gives the
/// pattern at once).
///
/// ```
/// use reckon::jacobian::colour::detect_pattern;
/// use reckon::num_dual::DualDVec64;
/// use nalgebra::{DVector, dvector};
/// // f = (x₀·x₁, x₁): ∂f₀/∂x₀ = x₁ is 0 at x0 but not after the perturbation
/// let g = |_t: f64, x: &DVector<DualDVec64>, _u: &[f64]| dvector![x[0].clone() * x[1].clone(), x[1].clone()];
/// let p = detect_pattern(&g, 0.0, &dvector![1.0, 0.0], &[]);
/// assert_eq!(p.entries().collect::<Vec<_>>(), [(0, 0), (0, 1), (1, 1)]);
/// ```
pub fn detect_pattern<G>(g: &G, t: f64, x0: &DVector<f64>, u: &[f64]) -> Pattern
where
    G: Fn(f64, &DVector<DualDVec64>, &[f64]) -> DVector<DualDVec64>,
{
    const BLOCK: usize = 64;
    let n = x0.len();
    let mut entries: Vec<(usize, usize)> = Vec::new();
    let x1 = DVector::from_fn(n, |i, _| {
        x0[i] + 1e-3 * (1.0 + x0[i].abs()) * (1.0 + (i % 7) as f64) / 7.0
    });
    for x in [x0, &x1] {
        for start in (0..n).step_by(BLOCK) {
            let width = BLOCK.min(n - start);
            let xd = DVector::from_fn(n, |j, _| {
                let v = DualDVec64::from_re(x[j]);
                if (start..start + width).contains(&j) {
                    v.derivative(width, j - start)
                } else {
                    v
                }
            });
            let r = g(t, &xd, u);
            for (i, ri) in r.iter().enumerate().take(n) {
                if let Some(e) = ri.eps.0.as_ref() {
                    for (k, d) in e.iter().enumerate().take(width) {
                        if *d != 0.0 {
                            entries.push((i, start + k));
                        }
                    }
                }
            }
        }
    }
    // rows below n (take(n)), columns below start + width ≤ n
    Pattern::from_valid_entries(n, &entries)
}

/// Largest state for which a model that cannot be traced gets its pattern detected and
/// coloured ([`ColourDim`]): detection is an `O(n²)` pass (about 0.1 s at 10⁴ states on
/// the BRUSS body); beyond this such a model stays on the dense path.
pub const MAX_DETECTED_STATES: usize = 10_000;

/// State dimensions that know how to colour a model's dual-number body: `Dyn` detects the
/// pattern and colours it (up to [`MAX_DETECTED_STATES`]); fixed sizes (at most a few dozen
/// states, on the stack) keep the dense Jacobian.
pub trait ColourDim: nalgebra::Dim
where
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<Self>,
{
    /// The coloured evaluator of `g`'s Jacobian for a state of `n` and `inputs` inputs, with
    /// the pattern detected at a fixed spread of states `xᵢ ∈ [0.5, 1.5)` and inputs `uₖ ∈
    /// [0.5, 1.5)` (and the perturbed state), at `t = 0`; `None` for fixed sizes and above
    /// [`MAX_DETECTED_STATES`].
    fn coloured<'a, G>(g: &'a G, n: usize, inputs: usize) -> Option<Box<dyn SparseJacobian + 'a>>
    where
        G: Fn(
                f64,
                &nalgebra::OVector<num_dual::DualVec64<Self>, Self>,
                &[f64],
            ) -> nalgebra::OVector<num_dual::DualVec64<Self>, Self>
            + 'a;
}

impl<const N: usize> ColourDim for nalgebra::Const<N> {
    fn coloured<'a, G>(_g: &'a G, _n: usize, _inputs: usize) -> Option<Box<dyn SparseJacobian + 'a>>
    where
        G: Fn(
                f64,
                &nalgebra::OVector<num_dual::DualVec64<Self>, Self>,
                &[f64],
            ) -> nalgebra::OVector<num_dual::DualVec64<Self>, Self>
            + 'a,
    {
        None
    }
}

impl ColourDim for nalgebra::Dyn {
    fn coloured<'a, G>(g: &'a G, n: usize, inputs: usize) -> Option<Box<dyn SparseJacobian + 'a>>
    where
        G: Fn(f64, &DVector<DualDVec64>, &[f64]) -> DVector<DualDVec64> + 'a,
    {
        if n == 0 || n > MAX_DETECTED_STATES {
            return None;
        }
        // a deterministic spread (golden-ratio steps), no accidental zeros or repeats
        let spread = |i: usize| 0.5 + (i as f64 * 0.618_033_988_749_894_9).fract();
        let x0 = DVector::from_fn(n, |i, _| spread(i));
        let u: Vec<f64> = (0..inputs).map(|k| spread(n + k)).collect();
        Some(Box::new(Coloured::detected(g, 0.0, &x0, &u)))
    }
}

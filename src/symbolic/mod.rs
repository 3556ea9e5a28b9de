//! Symbolic right-hand sides and Jacobians, traced from the same [`model!`](crate::model)
//! body that computes values and dual numbers.
//!
//! `model!` compiles its body once more with the state's scalar `S` = [`Sym`], a tracing
//! number whose arithmetic records an expression graph instead of computing: every
//! distinct subexpression is one node (hash-consing, so common subexpressions are
//! shared), constants are folded and `0·a`, `1·a`, `a + 0`, `a − a`, `a/1`, `−(−a)` are
//! simplified as the graph is built. [`trace`] runs it on symbolic states `xᵢ`, inputs
//! `uₖ` and time `t`, and differentiates the outputs symbolically (sparse forward
//! accumulation, [`diff`]), which gives
//!
//! - `f`, `∂f/∂x`, `∂f/∂u` and `∂f/∂t` as expressions ([`Traced::rhs`],
//!   [`Traced::jacobian`], [`Traced::input_jacobian`], [`Traced::time_derivative`]);
//! - printing as text, LaTeX, MathML and Rust source ([`Traced::text`], [`Traced::latex`],
//!   [`Traced::mathml`], [`Traced::rust`], [`Traced::json`]);
//! - the sparsity pattern of `∂f/∂x` ([`Traced::pattern`]);
//! - a compiled evaluator of `∂f/∂x` into a dense or a sparse (CSC) matrix
//!   ([`Traced::compile_jacobian`]), which the implicit methods use for large models:
//!   an instruction list, and for up to [`jit::MAX_NATIVE_INSTRUCTIONS`] instructions
//!   also machine code generated with Cranelift (feature `jit`, on by default) that gives
//!   the same bits faster than num-dual.
//!
//! ```
//! use reckon::{vehicles::unicycle, symbolic};
//! let j = symbolic::trace(&unicycle::model(), 3).unwrap().with_names(&["x", "y", "θ"], &["v", "ω"]);
//! assert_eq!(j.jacobian_text(), "∂ẋ/∂θ = −v·sin(θ)\n∂ẏ/∂θ = v·cos(θ)\n");
//! assert_eq!(j.pattern().nnz(), 2);
//! ```
//!
//! A body whose control flow depends on the state (a comparison of traced values, a
//! sign test, reading a traced number) cannot be traced faithfully: [`trace`] returns
//! [`Error::Untraceable`] naming the model, and the model keeps working with its num-dual
//! Jacobian. A time written as a plain `t` (an `f64` in the body) is invisible to the trace,
//! which could record a comparison with it (`t > 0.0 && t < 5.0`, `t.abs() < 5.0`,
//! `t.is_finite()`, `t % 2.0 < 1.0`) for one time only; no set of probe times can rule out
//! a branch at some other time. So a body that *names* its plain `t` anywhere (`model!`
//! looks at the body's tokens: a local variable is reachable only by its name) is refused
//! the same way, and one that does not name it is time-independent. Write `t: S` to trace
//! the time, or `_` for a model that does not read it.
//!
//! ```
//! use reckon::{model, symbolic, Error};
//! use nalgebra::vector;
//! let switched = model!(|t, x: [S; 1]| vector![if t.abs() < 5.0 { x[0].clone() * -100.0 } else { -x[0].clone() }]);
//! assert!(matches!(symbolic::trace(&switched, 1), Err(Error::Untraceable { .. })));
//! let traced = model!(|t: S, x: [S; 1]| vector![x[0] * t.cos()]);
//! assert_eq!(symbolic::trace(&traced, 1).unwrap().jacobian_text(), "∂ẋ₀/∂x₀ = cos(t)\n");
//! ```
//!
//! A model's parameter block (`p: [S; P] = […]`) is traced too, its parameters as the leaves
//! `pₖ` (inputs of the compiled code, not constants). Compiled Jacobians are cached by the
//! recorded graph, so a model rebuilt with the same structure, or with other parameter
//! values, skips the differentiation and the compile: see [`cache`] for the design and
//! for what a traced body may capture.

pub mod cache;
mod compile;
mod diff;
mod graph;
#[cfg(feature = "jit")]
pub mod jit;
#[cfg(not(feature = "jit"))]
#[path = "jit_off.rs"]
pub mod jit;
mod print;
mod sym;

pub use cache::{CacheStats, TraceCounts, cache_stats, clear_cache};
pub use compile::{CompiledJacobian, CompiledVector};
pub use graph::Func;
pub use sym::{Sym, plain_time};

use crate::error::{Error, Result};
use crate::jacobian::Pattern;
use graph::{Graph, Node};
use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, Dim, OVector, U1};
use std::fmt;

/// Names the printed forms use for the states, inputs and time. Defaults: `x₀, x₁, …`,
/// `u₀, u₁, …` and `t`. A name may carry a subscript as `v_l` or `x₁` (LaTeX `v_{l}`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Names {
    /// State names (missing ones print as `xᵢ`).
    pub states: Vec<String>,
    /// Input names (missing ones print as `uₖ`).
    pub inputs: Vec<String>,
    /// The time's name (`t` when empty).
    pub time: String,
    /// Parameter names (missing ones print as `pₖ`).
    pub params: Vec<String>,
}

impl Names {
    /// State `i`'s name: `states[i]`, or `xᵢ` when there is none.
    ///
    /// ```
    /// use reckon::symbolic::Names;
    /// let n = Names { states: vec!["v".into()], ..Default::default() };
    /// assert_eq!((n.state(0), n.state(2)), ("v".to_string(), "x₂".to_string()));
    /// ```
    pub fn state(&self, i: usize) -> String {
        self.states
            .get(i)
            .cloned()
            .unwrap_or_else(|| format!("x{}", print::subscript(i)))
    }
    /// Input `k`'s name: `inputs[k]`, or `uₖ` when there is none.
    ///
    /// ```
    /// use reckon::symbolic::Names;
    /// assert_eq!(Names::default().input(1), "u₁");
    /// ```
    pub fn input(&self, k: usize) -> String {
        self.inputs
            .get(k)
            .cloned()
            .unwrap_or_else(|| format!("u{}", print::subscript(k)))
    }
    pub(crate) fn param(&self, k: usize) -> String {
        self.params
            .get(k)
            .cloned()
            .unwrap_or_else(|| format!("p{}", print::subscript(k)))
    }
    pub(crate) fn time(&self) -> String {
        if self.time.is_empty() {
            "t".into()
        } else {
            self.time.clone()
        }
    }
}

/// How a [`ClosureModel`](crate::ClosureModel) or a [`ParamModel`](crate::ParamModel) runs
/// its body on [`Sym`]: [`NoTrace`] for a model built without one, [`TraceFn`] for the
/// copy `model!` compiles.
pub trait TraceBody<D: Dim>
where
    DefaultAllocator: Allocator<D>,
{
    /// Whether there is a body to run.
    fn traceable(&self) -> bool;
    /// Whether the body reads its time as a plain `f64` (`|t, x: …|` with `t` used in the
    /// body): the trace cannot follow such a time and refuses the body.
    fn plain_time(&self) -> bool {
        false
    }
    /// `f(t, x, u; p)` on traced values (`None` without a body; `p` is empty for a model
    /// without a parameter block).
    fn run(&self, t: Sym, x: &OVector<Sym, D>, u: &[Sym], p: &[Sym]) -> Option<OVector<Sym, D>>;
}

/// No traced copy of the body (a [`ClosureModel::new`](crate::ClosureModel::new) built by hand).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NoTrace;

impl<D: Dim> TraceBody<D> for NoTrace
where
    DefaultAllocator: Allocator<D>,
{
    fn traceable(&self) -> bool {
        false
    }
    fn run(&self, _t: Sym, _x: &OVector<Sym, D>, _u: &[Sym], _p: &[Sym]) -> Option<OVector<Sym, D>> {
        None
    }
}

/// The body instantiated at [`Sym`] (what `model!` generates); `plain_time` when the body
/// reads a time that is a plain `f64` (see [`TraceBody::plain_time`]).
#[derive(Clone)]
pub struct TraceFn<H> {
    /// The traced copy of the body.
    pub body: H,
    /// The body reads its time as a plain `f64`.
    pub plain_time: bool,
}

impl<H> TraceFn<H> {
    /// The traced copy `body`; `plain_time` when it reads a time that is a plain `f64`.
    pub fn new(plain_time: bool, body: H) -> Self {
        TraceFn { body, plain_time }
    }
}

impl<D: Dim, H> TraceBody<D> for TraceFn<H>
where
    H: Fn(Sym, &OVector<Sym, D>, &[Sym]) -> OVector<Sym, D>,
    DefaultAllocator: Allocator<D>,
{
    fn traceable(&self) -> bool {
        true
    }
    fn plain_time(&self) -> bool {
        self.plain_time
    }
    fn run(&self, t: Sym, x: &OVector<Sym, D>, u: &[Sym], _p: &[Sym]) -> Option<OVector<Sym, D>> {
        Some((self.body)(t, x, u))
    }
}

/// The body of a model with a parameter block instantiated at [`Sym`], the parameters
/// traced as the leaves `pₖ` (what `model!` generates for `p: [S; P] = […]`).
#[derive(Clone)]
pub struct TraceParamsFn<H> {
    /// The traced copy of the body.
    pub body: H,
    /// The body reads its time as a plain `f64`.
    pub plain_time: bool,
}

impl<H> TraceParamsFn<H> {
    /// The traced copy `body`; `plain_time` when it reads a time that is a plain `f64`.
    pub fn new(plain_time: bool, body: H) -> Self {
        TraceParamsFn { body, plain_time }
    }
}

impl<D: Dim, H> TraceBody<D> for TraceParamsFn<H>
where
    H: Fn(Sym, &OVector<Sym, D>, &[Sym], &[Sym]) -> OVector<Sym, D>,
    DefaultAllocator: Allocator<D>,
{
    fn traceable(&self) -> bool {
        true
    }
    fn plain_time(&self) -> bool {
        self.plain_time
    }
    fn run(&self, t: Sym, x: &OVector<Sym, D>, u: &[Sym], p: &[Sym]) -> Option<OVector<Sym, D>> {
        Some((self.body)(t, x, u, p))
    }
}

/// The sizes and parameter values of a recording: `n` states, `m` inputs, parameters `p`.
pub(crate) struct Shape<'a> {
    pub n: usize,
    pub m: usize,
    pub p: &'a [f64],
}

/// Record `body` (a model's [`TraceBody`]) for a state of `n`, `m` inputs and the
/// parameters `p` (as leaves): the graph and the outputs' ids, not yet differentiated.
/// `capacity`: the number of nodes expected (a model's previous recording).
fn record_body<D: Dim, B: TraceBody<D>>(
    body: &B,
    model: &str,
    shape: &Shape,
    capacity: usize,
) -> Result<(Graph, Vec<u32>)>
where
    DefaultAllocator: Allocator<D>,
{
    let (m, np) = (shape.m, shape.p.len());
    let n = D::try_to_usize().unwrap_or(shape.n);
    let untraceable = |reason: String| Error::Untraceable {
        model: model.to_string(),
        reason,
    };
    if !body.traceable() {
        return Err(untraceable(
            "it has no traced copy of its body (build it with model!)".into(),
        ));
    }
    if body.plain_time() {
        return Err(untraceable(
            "its body reads its time `t`, a plain f64 the trace cannot follow (a comparison or \
             a computation with it would be recorded for one time only): write `|t: S, x: …|` \
             to trace the time, or `_` for a model that does not read it (its Jacobian still \
             comes from num-dual)"
                .into(),
        ));
    }
    let mut leaves: Vec<Node> = (0..n as u32).map(Node::State).collect();
    leaves.extend((0..m as u32).map(Node::Input));
    leaves.push(Node::Time);
    leaves.extend((0..np as u32).map(Node::Param));
    // a time the body was shown not to read: +∞, so that a hidden use that computes
    // with it records a non-finite constant and is refused
    sym::set_plain_time(f64::INFINITY);
    cache::recorded();
    let recorded = sym::record(&leaves, capacity, |syms| {
        let x = OVector::<Sym, D>::from_iterator_generic(D::from_usize(n), U1, syms[..n].iter().copied());
        body.run(syms[n + m], &x, &syms[n..n + m], &syms[n + m + 1..])
            .map(|f| f.iter().map(|s| s.id()).collect::<Vec<u32>>())
    });
    let (g, f) = match recorded {
        Ok((g, Some(f))) => (g, f),
        Ok((_, None)) => {
            return Err(untraceable(
                "it has no traced copy of its body (build it with model!)".into(),
            ));
        }
        Err(None) => return Err(untraceable("a trace is already running on this thread".into())),
        Err(Some(fault)) => {
            return Err(untraceable(match fault {
                sym::Fault::Compare(op) => format!(
                    "its body applies {op} to a traced value, so its control flow depends on the state \
                     (its Jacobian still comes from num-dual)"
                ),
                sym::Fault::Value => {
                    "its body reads the number of a traced value (re()), so it computes with the state \
                     outside the expression (its Jacobian still comes from num-dual)"
                        .into()
                }
                sym::Fault::PlainValue => "its body computes with a plain f64 the trace cannot see (a time \
                     written `t` instead of `t: S`) or with a non-finite number: write `|t: S, x: …|` \
                     to trace the time (its Jacobian still comes from num-dual)"
                    .into(),
            }));
        }
    };
    if f.len() != n {
        return Err(Error::invalid(
            "model",
            format!("f returned {} components for a state of {n}", f.len()),
        ));
    }
    Ok((g, f))
}

/// Trace `body` (a model's [`TraceBody`]) for a state of `n`, `m` inputs and the
/// parameters `p`.
pub(crate) fn trace_body<D: Dim, B: TraceBody<D>>(body: &B, model: &str, shape: &Shape) -> Result<Traced>
where
    DefaultAllocator: Allocator<D>,
{
    let (g, f) = record_body(body, model, shape, 0)?;
    let n = f.len();
    finite_constants(Traced::build(g, n, shape.m, shape.p, f, model), model)
}

/// `tr` if every constant its right-hand side and derivatives reach is finite. The
/// constants the body wrote are checked as they enter (a `PlainValue` fault); those made
/// by folding (1/L for L = 1e-320 in a derivative) are checked here.
fn finite_constants(tr: Traced, model: &str) -> Result<Traced> {
    let roots: Vec<u32> =
        tr.f.iter()
            .copied()
            .chain(tr.jx.iter().map(|e| e.2))
            .chain(tr.ju.iter().map(|e| e.2))
            .chain(tr.jt.iter().map(|e| e.1))
            .collect();
    let reach = tr.g.reachable(&roots);
    if let Some(v) = (0..tr.g.len() as u32)
        .filter(|id| reach[*id as usize])
        .find_map(|id| tr.g.constant(id).filter(|v| !v.is_finite()))
    {
        return Err(Error::Untraceable {
            model: model.to_string(),
            reason: format!(
                "folding its constants gives {v} (an operation on its numbers overflows or is undefined: \
             a parameter out of range), so its right-hand side or Jacobian is not finite"
            ),
        });
    }
    Ok(tr)
}

/// The compiled `∂f/∂x` of `body` for a state of `n`, `m` inputs and the parameters `p`:
/// the body is recorded, and the compiled Jacobian of an equal recording is taken from
/// the cache ([`cache`]) or the recording is differentiated and compiled. `counters`
/// counts what was done.
pub(crate) fn cached_jacobian<D: Dim, B: TraceBody<D>>(
    body: &B,
    model: &str,
    shape: &Shape,
    counters: &cache::Counters,
) -> Result<CompiledJacobian>
where
    DefaultAllocator: Allocator<D>,
{
    // the model's last recording, or a guess for a new model (a rebuilt one)
    let hint = match cache::Counters::get(&counters.last_nodes) {
        0 => 16 * shape.n + 64,
        last => last,
    };
    let (g, f) = record_body(body, model, shape, hint)?;
    counters.last_nodes.store(g.len(), std::sync::atomic::Ordering::Relaxed);
    let n = f.len();
    let (jac, outcome) = cache::compiled_jacobian(g, f, (n, shape.m, shape.p), |g, f| {
        Traced::build(g, n, shape.m, shape.p, f, model).compile_jacobian()
    });
    counters.count(outcome);
    Ok(jac)
}

/// The trace of a model: its right-hand side and derivatives as expressions of one graph.
///
/// ```
/// use reckon::{model, symbolic};
/// use nalgebra::vector;
/// // Van der Pol, μ = 1
/// let f = model!(|_, x: [S; 2]| vector![x[1].clone(), (1.0 - x[0] * x[0]) * x[1] - x[0]]);
/// let tr = symbolic::trace(&f, 2).unwrap();
/// assert_eq!(tr.rhs(1).to_string(), "x₁·(1 − x₀²) − x₀");
/// assert_eq!(tr.jacobian_entry(1, 0).unwrap().to_string(), "−1 − 2·x₀·x₁");
/// assert_eq!(tr.jacobian_entry(0, 0), None); // a structural zero
/// ```
#[derive(Clone)]
pub struct Traced {
    g: Graph,
    n: usize,
    m: usize,
    /// The parameter values `pₖ` (a parameter block's; empty without one).
    params: Vec<f64>,
    f: Vec<u32>,
    /// `(row, col, node)` of `∂f/∂x`, column by column.
    jx: Vec<(usize, usize, u32)>,
    /// `(row, input, node)` of `∂f/∂u`, row by row.
    ju: Vec<(usize, usize, u32)>,
    /// `(row, node)` of `∂f/∂t`.
    jt: Vec<(usize, u32)>,
    model: String,
    names: Names,
}

impl fmt::Debug for Traced {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Traced")
            .field("model", &self.model)
            .field("n", &self.n)
            .field("inputs", &self.m)
            .field("params", &self.params.len())
            .field("nodes", &self.g.len())
            .field("jacobian_nnz", &self.jx.len())
            .finish()
    }
}

/// One expression of a [`Traced`] model; `Display` prints it as text.
#[derive(Clone, Copy)]
pub struct Expr<'a> {
    tr: &'a Traced,
    id: u32,
}

impl PartialEq for Expr<'_> {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self.tr, other.tr) && self.id == other.id
    }
}

impl fmt::Debug for Expr<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Expr({self})")
    }
}

impl fmt::Display for Expr<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&print::text(&self.tr.g, self.id, &self.tr.names))
    }
}

impl Expr<'_> {
    /// The expression in LaTeX (math mode).
    pub fn latex(&self) -> String {
        print::latex(&self.tr.g, self.id, &self.tr.names)
    }
    /// The expression in presentation MathML (without the `<math>` element).
    pub fn mathml(&self) -> String {
        print::mathml(&self.tr.g, self.id, &self.tr.names)
    }
    /// Its value at `(t, x, u)`, the parameters at the model's values (a slow reference
    /// evaluation; see [`Traced::compile_jacobian`]).
    pub fn eval(&self, t: f64, x: &[f64], u: &[f64]) -> f64 {
        self.tr.g.eval(self.id, t, x, u, &self.tr.params)
    }
    /// The number, if the expression is a constant.
    pub fn constant(&self) -> Option<f64> {
        self.tr.g.constant(self.id)
    }
}

/// The name with a dot over its first letter (`x` → `ẋ`, `x₀` → `ẋ₀`).
fn dotted(name: &str) -> String {
    // the letters Unicode has precomposed with a dot above (ẋ, ẏ, ż…); others combine U+0307
    const PRE: [(char, char); 20] = [
        ('a', 'ȧ'),
        ('b', 'ḃ'),
        ('c', 'ċ'),
        ('d', 'ḋ'),
        ('e', 'ė'),
        ('f', 'ḟ'),
        ('g', 'ġ'),
        ('h', 'ḣ'),
        ('m', 'ṁ'),
        ('n', 'ṅ'),
        ('o', 'ȯ'),
        ('p', 'ṗ'),
        ('r', 'ṙ'),
        ('s', 'ṡ'),
        ('t', 'ṫ'),
        ('w', 'ẇ'),
        ('x', 'ẋ'),
        ('y', 'ẏ'),
        ('z', 'ż'),
        ('X', 'Ẋ'),
    ];
    let mut c = name.chars();
    match c.next() {
        Some(first) => match PRE.iter().find(|p| p.0 == first) {
            Some(&(_, d)) => format!("{d}{}", c.as_str()),
            None => format!("{first}\u{307}{}", c.as_str()),
        },
        None => String::new(),
    }
}

impl Traced {
    fn build(mut g: Graph, n: usize, m: usize, params: &[f64], f: Vec<u32>, model: &str) -> Traced {
        let var_of = |node: Node| match node {
            Node::State(i) => Some(i),
            Node::Input(k) => Some(n as u32 + k),
            Node::Time => Some((n + m) as u32),
            _ => None,
        };
        let grads = diff::gradients(&mut g, &f, var_of);
        let (mut jx, mut ju, mut jt) = (Vec::new(), Vec::new(), Vec::new());
        for (i, grad) in grads.into_iter().enumerate() {
            for (v, d) in grad {
                let v = v as usize;
                if v < n {
                    jx.push((i, v, d));
                } else if v < n + m {
                    ju.push((i, v - n, d));
                } else {
                    jt.push((i, d));
                }
            }
        }
        // column order (rows ascending within a column, as generated): a counting sort
        let mut count = vec![0usize; n + 1];
        for &(_, j, _) in &jx {
            count[j + 1] += 1;
        }
        for j in 0..n {
            count[j + 1] += count[j];
        }
        let mut sorted = vec![(0, 0, 0); jx.len()];
        for e in jx {
            sorted[count[e.1]] = e;
            count[e.1] += 1;
        }
        let jx = sorted;
        Traced {
            g,
            n,
            m,
            params: params.to_vec(),
            f,
            jx,
            ju,
            jt,
            model: model.to_string(),
            names: Names::default(),
        }
    }

    /// The same trace printing with these state and input names.
    pub fn with_names(mut self, states: &[&str], inputs: &[&str]) -> Self {
        self.names.states = states.iter().map(|s| s.to_string()).collect();
        self.names.inputs = inputs.iter().map(|s| s.to_string()).collect();
        self
    }

    /// The names in use.
    pub fn names(&self) -> &Names {
        &self.names
    }

    /// State dimension `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of inputs `m`.
    pub fn inputs(&self) -> usize {
        self.m
    }

    /// The parameter values `pₖ` the trace evaluates and compiles with (a parameter
    /// block's, traced as the leaves `pₖ`; empty for a model without one).
    ///
    /// ```
    /// use reckon::{model, symbolic};
    /// use nalgebra::vector;
    /// let f = model!(|_, x: [S; 1], p: [S; 1] = [2.0]| vector![-(p[0] * x[0])]);
    /// let tr = symbolic::trace(&f, 1).unwrap();
    /// assert_eq!(tr.params(), &[2.0]);
    /// assert_eq!(tr.jacobian_text(), "∂ẋ₀/∂x₀ = −p₀\n");
    /// assert_eq!(tr.jacobian_entry(0, 0).unwrap().eval(0.0, &[1.0], &[]), -2.0);
    /// ```
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// The traced model's name (the function that defined it).
    pub fn model(&self) -> &str {
        &self.model
    }

    /// Nodes in the graph (values and derivatives, shared).
    pub fn nodes(&self) -> usize {
        self.g.len()
    }

    /// `fᵢ`.
    pub fn rhs(&self, i: usize) -> Expr<'_> {
        Expr {
            tr: self,
            id: self.f[i],
        }
    }

    /// `∂fᵢ/∂xⱼ`, `None` where it is structurally zero.
    pub fn jacobian_entry(&self, i: usize, j: usize) -> Option<Expr<'_>> {
        self.jx
            .iter()
            .find(|e| e.0 == i && e.1 == j)
            .map(|e| Expr { tr: self, id: e.2 })
    }

    /// The non-zeros `(i, j, ∂fᵢ/∂xⱼ)` of `∂f/∂x`, column by column.
    pub fn jacobian(&self) -> impl Iterator<Item = (usize, usize, Expr<'_>)> + '_ {
        self.jx.iter().map(move |&(i, j, id)| (i, j, Expr { tr: self, id }))
    }

    /// The non-zeros `(i, k, ∂fᵢ/∂uₖ)` of `∂f/∂u`, row by row.
    pub fn input_jacobian(&self) -> impl Iterator<Item = (usize, usize, Expr<'_>)> + '_ {
        self.ju.iter().map(move |&(i, k, id)| (i, k, Expr { tr: self, id }))
    }

    /// The non-zeros `(i, ∂fᵢ/∂t)` of `∂f/∂t` (empty for a model that does not read `t`).
    pub fn time_derivative(&self) -> impl Iterator<Item = (usize, Expr<'_>)> + '_ {
        self.jt.iter().map(move |&(i, id)| (i, Expr { tr: self, id }))
    }

    /// The sparsity pattern of `∂f/∂x`: the entries that are not structurally zero.
    pub fn pattern(&self) -> Pattern {
        let mut col_ptr = vec![0; self.n + 1];
        for &(_, j, _) in &self.jx {
            col_ptr[j + 1] += 1;
        }
        for j in 0..self.n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let rows = self.jx.iter().map(|e| e.0).collect();
        Pattern::from_csc(self.n, col_ptr, rows).expect("the trace's entries are sorted and unique")
    }

    /// `∂f/∂x` compiled into an instruction list over `f64`, and into machine code when it
    /// is short enough (see [`CompiledJacobian`]).
    pub fn compile_jacobian(&self) -> CompiledJacobian {
        let roots: Vec<u32> = self.jx.iter().map(|e| e.2).collect();
        CompiledJacobian::new(self.pattern(), compile::Program::new(&self.g, &roots, &self.params))
    }

    /// `f` compiled into an instruction list, and into machine code when it is short
    /// enough (see [`CompiledVector`]): the right-hand side of a model given only as its
    /// trace.
    ///
    /// ```
    /// use reckon::{model, symbolic};
    /// use nalgebra::vector;
    /// let f = model!(|_, x: [S; 2]| vector![x[1].clone(), (1.0 - x[0] * x[0]) * x[1] - x[0]]);
    /// let mut rhs = symbolic::trace(&f, 2).unwrap().compile_rhs();
    /// let mut out = [0.0; 2];
    /// rhs.eval(0.0, &[2.0, 3.0], &[], &mut out).unwrap();
    /// assert_eq!(out, [3.0, (1.0 - 4.0) * 3.0 - 2.0]);
    /// ```
    pub fn compile_rhs(&self) -> CompiledVector {
        CompiledVector::new(self.n, &self.g, &self.f, &self.params, (0..self.n).collect())
    }

    /// `∂f/∂t` compiled as [`compile_rhs`](Self::compile_rhs) compiles `f` (all zeros for a
    /// model that does not read the time symbol).
    ///
    /// ```
    /// use reckon::{model, symbolic};
    /// use nalgebra::vector;
    /// let f = model!(|t: S, x: [S; 2]| vector![x[1].clone(), x[0] * t.sin()]);
    /// let mut dt = symbolic::trace(&f, 2).unwrap().compile_time_derivative();
    /// let mut out = [1.0; 2];
    /// dt.eval(0.5, &[2.0, 3.0], &[], &mut out).unwrap();
    /// assert_eq!(out, [0.0, 2.0 * 0.5f64.cos()]);
    /// ```
    pub fn compile_time_derivative(&self) -> CompiledVector {
        let roots: Vec<u32> = self.jt.iter().map(|e| e.1).collect();
        CompiledVector::new(
            self.n,
            &self.g,
            &roots,
            &self.params,
            self.jt.iter().map(|e| e.0).collect(),
        )
    }

    /// Whether `f` reads the time symbol (`∂f/∂t` has a non-zero).
    pub fn reads_time(&self) -> bool {
        !self.jt.is_empty()
    }

    /// The same trace printing with these parameter names (missing ones print as `pₖ`).
    ///
    /// ```
    /// use reckon::symbolic;
    /// let tr = symbolic::trace_fn("decay", 1, &[2.0], |_t, x, p| vec![-(p[0] * x[0])]).unwrap();
    /// assert_eq!(tr.with_param_names(&["k"]).jacobian_text(), "∂ẋ₀/∂x₀ = −k\n");
    /// ```
    pub fn with_param_names(mut self, params: &[&str]) -> Self {
        self.names.params = params.iter().map(|s| s.to_string()).collect();
        self
    }

    fn text_of(&self, id: u32) -> String {
        print::text(&self.g, id, &self.names)
    }

    fn label(&self, i: usize, wrt: String) -> String {
        format!("∂{}/∂{wrt}", dotted(&self.names.state(i)))
    }

    /// `∂f/∂x` as text, one line `∂ẋᵢ/∂xⱼ = …` per non-zero, row by row.
    pub fn jacobian_text(&self) -> String {
        let mut e = self.jx.clone();
        e.sort_unstable_by_key(|&(i, j, _)| (i, j));
        e.iter()
            .map(|&(i, j, id)| format!("{} = {}\n", self.label(i, self.names.state(j)), self.text_of(id)))
            .collect()
    }

    /// Everything as text: `f`, then the non-zeros of `∂f/∂x`, `∂f/∂u` and `∂f/∂t`.
    pub fn text(&self) -> String {
        let mut s = String::new();
        for i in 0..self.n {
            s += &format!("{} = {}\n", dotted(&self.names.state(i)), self.text_of(self.f[i]));
        }
        s += &self.jacobian_text();
        for &(i, k, id) in &self.ju {
            s += &format!("{} = {}\n", self.label(i, self.names.input(k)), self.text_of(id));
        }
        for &(i, id) in &self.jt {
            s += &format!("{} = {}\n", self.label(i, self.names.time()), self.text_of(id));
        }
        s
    }

    /// The four parts [`Traced::text`] prints, as matrices of printed entries (`zero`
    /// where structurally zero): `f` (a column, with the state names for its left-hand
    /// side), `∂f/∂x` (n × n), `∂f/∂u` (n × m, absent without inputs) and `∂f/∂t` (a
    /// column, absent when `f` does not read the time symbol).
    #[allow(clippy::type_complexity)]
    fn parts(
        &self,
        print: fn(&Graph, u32, &Names) -> String,
        zero: &str,
    ) -> (
        Vec<Vec<String>>,
        Vec<Vec<String>>,
        Option<Vec<Vec<String>>>,
        Option<Vec<Vec<String>>>,
    ) {
        let f = self.f.iter().map(|&id| vec![print(&self.g, id, &self.names)]).collect();
        let mut jx = vec![vec![zero.to_string(); self.n]; self.n];
        for &(i, j, id) in &self.jx {
            jx[i][j] = print(&self.g, id, &self.names);
        }
        let ju = (self.m > 0).then(|| {
            let mut ju = vec![vec![zero.to_string(); self.m]; self.n];
            for &(i, k, id) in &self.ju {
                ju[i][k] = print(&self.g, id, &self.names);
            }
            ju
        });
        let jt = (!self.jt.is_empty()).then(|| {
            let mut jt = vec![vec![zero.to_string()]; self.n];
            for &(i, id) in &self.jt {
                jt[i][0] = print(&self.g, id, &self.names);
            }
            jt
        });
        (f, jx, ju, jt)
    }

    /// Fonts with an OpenType MATH table, one per common system (macOS, TeX, Windows,
    /// Linux), then the generic `math`: without one a browser's fences do not stretch.
    pub const MATH_FONTS: &'static str =
        "'STIX Two Math', 'Latin Modern Math', 'Cambria Math', 'DejaVu Math TeX Gyre', 'Noto Sans Math', math";

    /// What [`Traced::text`] prints, in LaTeX (amsmath): an `aligned` block of `f` (as
    /// `d/dt` of the state vector), `∂f/∂x`, `∂f/∂u` (with inputs) and `∂f/∂t` (when `f`
    /// reads the time symbol), each a `pmatrix`.
    ///
    /// ```
    /// use reckon::{vehicles::unicycle, symbolic};
    /// let tr = symbolic::trace(&unicycle::model(), 3).unwrap().with_names(&["x", "y", "θ"], &["v", "ω"]);
    /// let l = tr.latex();
    /// assert!(l.contains("\\frac{\\partial f}{\\partial x} &= \\begin{pmatrix}\n0 & 0 & -v \\, \\sin \\theta"));
    /// assert!(l.contains("\\frac{\\partial f}{\\partial u} &= \\begin{pmatrix}\n\\cos \\theta & 0"));
    /// ```
    pub fn latex(&self) -> String {
        let pm = |rows: &[Vec<String>]| {
            let body: Vec<String> = rows.iter().map(|r| r.join(" & ")).collect();
            format!("\\begin{{pmatrix}}\n{}\n\\end{{pmatrix}}", body.join(" \\\\\n"))
        };
        let (f, jx, ju, jt) = self.parts(print::latex, "0");
        let states: Vec<Vec<String>> = (0..self.n)
            .map(|i| vec![print::latex_name(&self.names.state(i))])
            .collect();
        let mut lines = vec![
            format!("\\frac{{d}}{{dt}} {} &= {}", pm(&states), pm(&f)),
            format!("\\frac{{\\partial f}}{{\\partial x}} &= {}", pm(&jx)),
        ];
        if let Some(ju) = ju {
            lines.push(format!("\\frac{{\\partial f}}{{\\partial u}} &= {}", pm(&ju)));
        }
        if let Some(jt) = jt {
            lines.push(format!("\\frac{{\\partial f}}{{\\partial t}} &= {}", pm(&jt)));
        }
        format!("\\begin{{aligned}}\n{}\n\\end{{aligned}}", lines.join(" \\\\\n"))
    }

    /// What [`Traced::text`] prints, as one MathML `<math>` element: a table of equations
    /// `d/dt (x…) = f`, `∂f/∂x = …`, `∂f/∂u = …` (with inputs) and `∂f/∂t = …` (when `f`
    /// reads the time symbol), each right-hand side a matrix in stretchy parentheses, and
    /// the font stack the fences need to stretch named on the element.
    ///
    /// ```
    /// use reckon::{vehicles::unicycle, symbolic};
    /// let tr = symbolic::trace(&unicycle::model(), 3).unwrap().with_names(&["x", "y", "θ"], &["v", "ω"]);
    /// let m = tr.mathml();
    /// assert!(m.starts_with("<math") && m.ends_with("</math>"));
    /// assert_eq!(m.matches("stretchy=\"true\"").count() % 2, 0);
    /// assert!(m.contains("<mi>u</mi>")); // ∂f/∂u is there, as in the text
    /// ```
    pub fn mathml(&self) -> String {
        let mat = |rows: &[Vec<String>]| {
            let mut s = format!("<mrow>{}<mtable>", print::OPEN);
            for r in rows {
                s += "<mtr>";
                for c in r {
                    s += &format!("<mtd>{c}</mtd>");
                }
                s += "</mtr>";
            }
            s + "</mtable>" + print::CLOSE + "</mrow>"
        };
        let d = |wrt: &str| {
            format!("<mfrac><mrow><mo>∂</mo><mi>f</mi></mrow><mrow><mo>∂</mo><mi>{wrt}</mi></mrow></mfrac>")
        };
        let (f, jx, ju, jt) = self.parts(print::mathml, "<mn>0</mn>");
        let states: Vec<Vec<String>> = (0..self.n)
            .map(|i| vec![print::mathml_name(&self.names.state(i))])
            .collect();
        let mut eqs = vec![
            (
                format!(
                    "<mrow><mfrac><mi>d</mi><mrow><mi>d</mi><mi>t</mi></mrow></mfrac>{}</mrow>",
                    mat(&states)
                ),
                mat(&f),
            ),
            (d("x"), mat(&jx)),
        ];
        if let Some(ju) = ju {
            eqs.push((d("u"), mat(&ju)));
        }
        if let Some(jt) = jt {
            eqs.push((d("t"), mat(&jt)));
        }
        let mut s = format!(
            "<math xmlns=\"http://www.w3.org/1998/Math/MathML\" display=\"block\" \
             style=\"font-family: {}\"><mtable rowspacing=\"1em\">",
            Self::MATH_FONTS
        );
        for (lhs, rhs) in eqs {
            // one cell an equation: browsers centre table cells (MathML Core has no
            // columnalign), so the sign stays next to its left-hand side
            s += &format!("<mtr><mtd><mrow>{lhs}<mo>=</mo>{rhs}</mrow></mtd></mtr>");
        }
        s + "</mtable></math>"
    }

    /// Rust source of two functions, `rhs(t, x, u, dx)` (`dx ← f`) and
    /// `jacobian(t, x, u, jac)` (`jac ← ∂f/∂x`, column-major `n × n`, `jac[i + n·j]`,
    /// structural zeros left as they are), that compile on their own and compute what the
    /// compiled evaluator computes. A model's parameters are the constant `P` the functions
    /// read as `p[k]`.
    pub fn rust(&self) -> String {
        let n = self.n;
        let mut s = format!("// generated by reckon::symbolic from `{}`\n", self.model);
        let p_let = if self.params.is_empty() {
            ""
        } else {
            let values: Vec<String> = self.params.iter().map(|&v| print::rust_number(v)).collect();
            s += &format!(
                "/// The parameters `p` the trace was made with.\npub const P: [f64; {}] = [{}];\n\n",
                values.len(),
                values.join(", ")
            );
            "    let p = &P;\n"
        };
        let f: Vec<(String, u32)> = self
            .f
            .iter()
            .enumerate()
            .map(|(i, &id)| (format!("dx[{i}]"), id))
            .collect();
        s += &format!("/// `dx ← f(t, x, u)` ({n} states, {} inputs).\n", self.m);
        s += "#[allow(unused_variables, clippy::all)]\n";
        s += "pub fn rhs(t: f64, x: &[f64], u: &[f64], dx: &mut [f64]) {\n";
        s += p_let;
        s += &print::rust_body(&self.g, &f, &self.names, "    ");
        s += "}\n\n";
        let jac: Vec<(String, u32)> = self
            .jx
            .iter()
            .map(|&(i, j, id)| (format!("jac[{}]", i + n * j), id))
            .collect();
        s += &format!("/// `jac ← ∂f/∂x (t, x, u)`, column-major {n}×{n} (`jac[i + {n}·j] = ∂fᵢ/∂xⱼ`);\n");
        s += "/// structural zeros are left as they are.\n";
        s += "#[allow(unused_variables, clippy::all)]\n";
        s += "pub fn jacobian(t: f64, x: &[f64], u: &[f64], jac: &mut [f64]) {\n";
        s += p_let;
        s += &print::rust_body(&self.g, &jac, &self.names, "    ");
        s += "}\n";
        s
    }

    /// A JSON object: model, sizes, names, `f` and every non-zero of `∂f/∂x`, `∂f/∂u`,
    /// `∂f/∂t` as text and LaTeX, and the pattern of `∂f/∂x` in CSC form.
    pub fn json(&self) -> serde_json::Value {
        let entry = |i: usize, j: usize, id: u32| {
            serde_json::json!({
                "row": i, "col": j,
                "text": self.text_of(id),
                "latex": print::latex(&self.g, id, &self.names),
            })
        };
        let p = self.pattern();
        serde_json::json!({
            "model": self.model,
            "states": (0..self.n).map(|i| self.names.state(i)).collect::<Vec<_>>(),
            "inputs": (0..self.m).map(|k| self.names.input(k)).collect::<Vec<_>>(),
            "rhs": self.f.iter().map(|&id| self.text_of(id)).collect::<Vec<_>>(),
            "jacobian": self.jx.iter().map(|&(i, j, id)| entry(i, j, id)).collect::<Vec<_>>(),
            "input_jacobian": self.ju.iter().map(|&(i, k, id)| entry(i, k, id)).collect::<Vec<_>>(),
            "time_derivative": self.jt.iter().map(|&(i, id)| entry(i, 0, id)).collect::<Vec<_>>(),
            "pattern": { "n": p.n(), "nnz": p.nnz(), "col_ptr": p.col_ptr(), "row_idx": p.row_idx() },
        })
    }
}

/// Trace a right-hand side given as a function `body(t, x, p)` of traced values: the
/// time `t`, the `n` states `xᵢ` and the parameters `pₖ` (leaves with the values
/// `params`), returning `f` (`n` traced values). It is how a model defined outside Rust
/// (a Python function called once on traced values) becomes a [`Traced`]; a `model!`
/// closure is traced with [`trace`].
///
/// `Err(`[`Error::Untraceable`]`)` when the body compares a traced value or computes with a
/// non-finite number; [`Error::InvalidInput`] when it returns other than `n` values.
///
/// ```
/// use reckon::symbolic;
/// // Van der Pol with μ a parameter
/// let tr = symbolic::trace_fn("vdp", 2, &[1000.0], |_t, x, p| {
///     vec![x[1], p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]]
/// })
/// .unwrap();
/// assert_eq!(tr.jacobian_entry(0, 1).unwrap().constant(), Some(1.0));
/// assert_eq!(tr.jacobian_entry(1, 1).unwrap().eval(0.0, &[2.0, 0.0], &[]), 1000.0 * (1.0 - 4.0));
/// assert!(symbolic::trace_fn("short", 2, &[], |_t, x, _p| vec![x[0]]).is_err());
/// ```
pub fn trace_fn<H>(model: &str, n: usize, params: &[f64], body: H) -> Result<Traced>
where
    H: Fn(Sym, &[Sym], &[Sym]) -> Vec<Sym>,
{
    let body = TraceParamsFn::new(false, |t: Sym, x: &nalgebra::DVector<Sym>, _u: &[Sym], p: &[Sym]| {
        nalgebra::DVector::from_vec(body(t, x.as_slice(), p))
    });
    trace_body::<nalgebra::Dyn, _>(&body, model, &Shape { n, m: 0, p: params })
}

/// Trace `model` (a [`model!`](crate::model) closure) for a state of `n` components
/// (ignored for fixed-size states).
///
/// `Err(`[`Error::Untraceable`]`)` when the body's control flow depends on the state or
/// the model has no traced copy (a hand-written [`System`](crate::System)).
///
/// ```
/// use reckon::{model, symbolic, Error};
/// use nalgebra::vector;
/// let ok = model!(|_, x: [S; 1]| vector![x[0].abs()]);
/// assert_eq!(symbolic::trace(&ok, 1).unwrap().jacobian_text(), "∂ẋ₀/∂x₀ = sgn(x₀)\n");
/// let branchy = model!(|_, x: [S; 1]| vector![if x[0] > S::from(0.0) { x[0].clone() } else { -x[0].clone() }]);
/// assert!(matches!(symbolic::trace(&branchy, 1), Err(Error::Untraceable { .. })));
/// ```
pub fn trace<D: Dim, S: crate::System<D>>(model: &S, n: usize) -> Result<Traced>
where
    DefaultAllocator: Allocator<D>,
{
    model.symbolic(n).unwrap_or_else(|| {
        Err(Error::Untraceable {
            model: std::any::type_name::<S>().to_string(),
            reason: "it is not a model! closure (a hand-written System has no body to trace)".into(),
        })
    })
}

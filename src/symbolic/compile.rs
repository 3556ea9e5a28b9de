//! The compiled evaluator: the part of the graph the requested expressions need,
//! flattened in topological order into a list of three-address instructions over one
//! array of `f64` slots (constants and leaves first, then one slot per instruction).
//! Running it is a single pass with no allocation and no hashing.

use super::graph::{Func, Graph, Node};
use crate::sparse::{Pattern, SparseJacobian};

#[derive(Debug, Clone, Copy)]
enum Op {
    Neg,
    Add,
    Sub,
    Mul,
    Div,
    Rem,
    /// `b` holds the exponent's bits
    Powi,
    /// `b` is the slot of the exponent
    Powf,
    Atan2,
    F(Func),
}

#[derive(Debug, Clone, Copy)]
struct Ins {
    op: Op,
    a: u32,
    b: u32,
}

/// Where a leaf's value comes from when the program runs.
#[derive(Debug, Clone, Copy)]
enum Load {
    State(u32),
    Input(u32),
    Time,
}

/// A flattened evaluator of some nodes of a graph.
#[derive(Debug, Clone)]
pub struct Program {
    /// Slot values with the constants in place (the leaves and results are overwritten).
    template: Vec<f64>,
    loads: Vec<(u32, Load)>,
    base: usize,
    ins: Vec<Ins>,
    outputs: Vec<u32>,
}

impl Program {
    /// The program that evaluates `roots` of `g`.
    pub(crate) fn new(g: &Graph, roots: &[u32]) -> Program {
        let len = g.len();
        let mut reach = vec![false; len];
        let mut stack: Vec<u32> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut reach[id as usize], true) {
                continue;
            }
            let (args, k) = g.node(id).args();
            for &a in &args[..k] {
                if !reach[a as usize] {
                    stack.push(a);
                }
            }
        }
        let mut slot = vec![u32::MAX; len];
        let mut template = Vec::new();
        let mut loads = Vec::new();
        // constants and leaves
        for id in 0..len {
            if !reach[id] {
                continue;
            }
            let s = template.len() as u32;
            match g.node(id as u32) {
                Node::Const(b) => {
                    slot[id] = s;
                    template.push(f64::from_bits(b));
                }
                Node::State(i) => {
                    slot[id] = s;
                    template.push(0.0);
                    loads.push((s, Load::State(i)));
                }
                Node::Input(k) => {
                    slot[id] = s;
                    template.push(0.0);
                    loads.push((s, Load::Input(k)));
                }
                Node::Time => {
                    slot[id] = s;
                    template.push(0.0);
                    loads.push((s, Load::Time));
                }
                _ => {}
            }
        }
        // exponents of powf
        let mut powf_slot = std::collections::HashMap::new();
        for id in 0..len {
            if let (true, Node::Powf(_, p)) = (reach[id], g.node(id as u32)) {
                powf_slot.entry(p).or_insert_with(|| {
                    template.push(f64::from_bits(p));
                    (template.len() - 1) as u32
                });
            }
        }
        let base = template.len();
        let mut ins = Vec::new();
        for id in 0..len {
            if !reach[id] {
                continue;
            }
            let node = g.node(id as u32);
            let (args, k) = node.args();
            if k == 0 {
                continue;
            }
            let a = slot[args[0] as usize];
            let b = if k == 2 { slot[args[1] as usize] } else { 0 };
            let (op, b) = match node {
                Node::Neg(_) => (Op::Neg, 0),
                Node::Add(..) => (Op::Add, b),
                Node::Sub(..) => (Op::Sub, b),
                Node::Mul(..) => (Op::Mul, b),
                Node::Div(..) => (Op::Div, b),
                Node::Rem(..) => (Op::Rem, b),
                Node::Powi(_, n) => (Op::Powi, n as u32),
                Node::Powf(_, p) => (Op::Powf, powf_slot[&p]),
                Node::Atan2(..) => (Op::Atan2, b),
                Node::F(f, _) => (Op::F(f), 0),
                Node::Const(_) | Node::State(_) | Node::Input(_) | Node::Time => unreachable!(),
            };
            slot[id] = (base + ins.len()) as u32;
            ins.push(Ins { op, a, b });
        }
        template.resize(base + ins.len(), 0.0);
        let outputs = roots.iter().map(|&r| slot[r as usize]).collect();
        Program {
            template,
            loads,
            base,
            ins,
            outputs,
        }
    }

    /// Number of instructions.
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        self.ins.len()
    }

    /// A scratch array for [`run`](Self::run), constants in place.
    pub fn scratch(&self) -> Vec<f64> {
        self.template.clone()
    }

    /// Evaluate every slot at `(t, x, u)` into `vals` (from [`scratch`](Self::scratch)).
    /// Missing inputs read as NaN.
    pub fn run(&self, t: f64, x: &[f64], u: &[f64], vals: &mut [f64]) {
        assert_eq!(
            vals.len(),
            self.template.len(),
            "Program::run: scratch of the wrong size"
        );
        for &(s, l) in &self.loads {
            vals[s as usize] = match l {
                Load::State(i) => x.get(i as usize).copied().unwrap_or(f64::NAN),
                Load::Input(k) => u.get(k as usize).copied().unwrap_or(f64::NAN),
                Load::Time => t,
            };
        }
        let (pre, out) = vals.split_at_mut(self.base);
        for (k, ins) in self.ins.iter().enumerate() {
            let get = |s: u32, pre: &[f64], out: &[f64]| {
                let s = s as usize;
                if s < self.base { pre[s] } else { out[s - self.base] }
            };
            let a = get(ins.a, pre, out);
            let v = match ins.op {
                Op::Neg => -a,
                Op::Add => a + get(ins.b, pre, out),
                Op::Sub => a - get(ins.b, pre, out),
                Op::Mul => a * get(ins.b, pre, out),
                Op::Div => a / get(ins.b, pre, out),
                Op::Rem => a % get(ins.b, pre, out),
                Op::Powi => a.powi(ins.b as i32),
                Op::Powf => a.powf(get(ins.b, pre, out)),
                Op::Atan2 => a.atan2(get(ins.b, pre, out)),
                Op::F(f) => f.eval(a),
            };
            out[k] = v;
        }
    }

    /// The value of output `k` after [`run`](Self::run).
    #[inline]
    pub fn output(&self, vals: &[f64], k: usize) -> f64 {
        vals[self.outputs[k] as usize]
    }
}

/// `J = ∂f/∂x` compiled from a traced model: its pattern and a [`Program`] whose outputs
/// are the pattern's non-zeros in order. Evaluates into the sparse values (O(non-zeros)
/// for a local model) or into a dense matrix.
///
/// ```
/// use reckon::{model, symbolic, sparse::SparseJacobian};
/// use nalgebra::vector;
/// let f = model!(|_, x: [S; 2]| vector![x[1].clone(), -x[0].sin()]);
/// let mut jac = symbolic::trace(&f, 2).unwrap().compile_jacobian();
/// let mut v = vec![0.0; jac.pattern().nnz()];
/// jac.eval(0.0, &[0.5, 0.0], &[], &mut v);
/// // CSC order: (1, 0) = −cos x₀, then (0, 1) = 1
/// assert_eq!(v, vec![-0.5f64.cos(), 1.0]);
/// ```
#[derive(Debug, Clone)]
pub struct CompiledJacobian {
    pattern: Pattern,
    program: Program,
    vals: Vec<f64>,
}

impl CompiledJacobian {
    pub(crate) fn new(pattern: Pattern, program: Program) -> Self {
        let vals = program.scratch();
        CompiledJacobian { pattern, program, vals }
    }

    /// The instructions one evaluation runs.
    pub fn instructions(&self) -> usize {
        self.program.len()
    }

    /// `jac ← J(t, x, u)` as a dense column-major `n × n` array (`jac[i + n·j] = ∂fᵢ/∂xⱼ`).
    pub fn eval_dense(&mut self, t: f64, x: &[f64], u: &[f64], jac: &mut [f64]) {
        let n = self.pattern.n();
        assert_eq!(jac.len(), n * n, "eval_dense: jac must hold n² values");
        self.program.run(t, x, u, &mut self.vals);
        jac.fill(0.0);
        let (cp, ri) = (self.pattern.col_ptr(), self.pattern.row_idx());
        for j in 0..n {
            for k in cp[j]..cp[j + 1] {
                jac[ri[k] + n * j] = self.program.output(&self.vals, k);
            }
        }
    }
}

impl SparseJacobian for CompiledJacobian {
    fn pattern(&self) -> &Pattern {
        &self.pattern
    }
    fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) {
        self.program.run(t, x, u, &mut self.vals);
        for (k, v) in values.iter_mut().enumerate() {
            *v = self.program.output(&self.vals, k);
        }
    }
}

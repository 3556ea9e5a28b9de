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
    /// `b` is the slot of the exponent (an integer-valued constant)
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

/// A flattened evaluator of some nodes of a graph.
#[derive(Debug, Clone)]
pub struct Program {
    /// Slot values with the constants in place (the leaves and results are overwritten).
    template: Vec<f64>,
    /// `(slot, state index)` of every state read
    state_loads: Vec<(u32, u32)>,
    /// `(slot, input index)` of every input read
    input_loads: Vec<(u32, u32)>,
    time_slot: Option<u32>,
    /// One more than the largest state and input index read.
    min_x: usize,
    min_u: usize,
    base: usize,
    ins: Vec<Ins>,
    outputs: Vec<u32>,
}

impl Program {
    /// The program that evaluates `roots` of `g`.
    pub(crate) fn new(g: &Graph, roots: &[u32]) -> Program {
        let len = g.len();
        let reach = g.reachable(roots);
        let mut slot = vec![u32::MAX; len];
        let mut template = Vec::new();
        let (mut state_loads, mut input_loads, mut time_slot) = (Vec::new(), Vec::new(), None);
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
                    state_loads.push((s, i));
                }
                Node::Input(k) => {
                    slot[id] = s;
                    template.push(0.0);
                    input_loads.push((s, k));
                }
                Node::Time => {
                    slot[id] = s;
                    template.push(0.0);
                    time_slot = Some(s);
                }
                _ => {}
            }
        }
        // exponents of powi and powf, each in a constant slot
        let mut exp_slot = std::collections::HashMap::new();
        for (id, &r) in reach.iter().enumerate() {
            let bits = match (r, g.node(id as u32)) {
                (true, Node::Powf(_, p)) => p,
                (true, Node::Powi(_, n)) => (n as f64).to_bits(),
                _ => continue,
            };
            exp_slot.entry(bits).or_insert_with(|| {
                template.push(f64::from_bits(bits));
                (template.len() - 1) as u32
            });
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
            // a unary instruction reads its operand twice (every `b` is a slot)
            let b = if k == 2 { slot[args[1] as usize] } else { a };
            let (op, b) = match node {
                Node::Neg(_) => (Op::Neg, b),
                Node::Add(..) => (Op::Add, b),
                Node::Sub(..) => (Op::Sub, b),
                Node::Mul(..) => (Op::Mul, b),
                Node::Div(..) => (Op::Div, b),
                Node::Rem(..) => (Op::Rem, b),
                Node::Powi(_, n) => (Op::Powi, exp_slot[&(n as f64).to_bits()]),
                Node::Powf(_, p) => (Op::Powf, exp_slot[&p]),
                Node::Atan2(..) => (Op::Atan2, b),
                Node::F(f, _) => (Op::F(f), b),
                Node::Const(_) | Node::State(_) | Node::Input(_) | Node::Time => unreachable!(),
            };
            let own = (base + ins.len()) as u32;
            assert!(a < own && b < own, "symbolic: operands must precede their use");
            slot[id] = own;
            ins.push(Ins { op, a, b });
        }
        template.resize(base + ins.len(), 0.0);
        let outputs = roots.iter().map(|&r| slot[r as usize]).collect();
        let min_x = state_loads.iter().map(|&(_, i)| i as usize + 1).max().unwrap_or(0);
        let min_u = input_loads.iter().map(|&(_, k)| k as usize + 1).max().unwrap_or(0);
        Program {
            template,
            state_loads,
            input_loads,
            time_slot,
            min_x,
            min_u,
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
    /// Missing states or inputs read as NaN.
    #[inline]
    pub fn run(&self, t: f64, x: &[f64], u: &[f64], vals: &mut [f64]) {
        assert_eq!(
            vals.len(),
            self.template.len(),
            "Program::run: scratch of the wrong size"
        );
        if x.len() >= self.min_x && u.len() >= self.min_u {
            for &(s, i) in &self.state_loads {
                // SAFETY: every state index is below `min_x ≤ x.len()`, every slot below
                // `base ≤ vals.len()` (checked in `new`)
                unsafe { *vals.get_unchecked_mut(s as usize) = *x.get_unchecked(i as usize) };
            }
            for &(s, k) in &self.input_loads {
                vals[s as usize] = u[k as usize];
            }
        } else {
            for &(s, i) in &self.state_loads {
                vals[s as usize] = x.get(i as usize).copied().unwrap_or(f64::NAN);
            }
            for &(s, k) in &self.input_loads {
                vals[s as usize] = u.get(k as usize).copied().unwrap_or(f64::NAN);
            }
        }
        if let Some(s) = self.time_slot {
            vals[s as usize] = t;
        }
        let p = vals.as_mut_ptr();
        // SAFETY: `new` gives every instruction `k` operands `a`, `b` below its own slot
        // `base + k` (ids are a topological order), and `vals` has `base + ins.len()`
        // slots (asserted above), so every pointer stays in `vals`.
        unsafe {
            let mut q = p.add(self.base);
            for ins in &self.ins {
                let a = *p.add(ins.a as usize);
                let b = *p.add(ins.b as usize);
                *q = match ins.op {
                    Op::Neg => -a,
                    Op::Add => a + b,
                    Op::Sub => a - b,
                    Op::Mul => a * b,
                    Op::Div => a / b,
                    Op::Rem => a % b,
                    Op::Powi => a.powi(b as i32),
                    Op::Powf => a.powf(b),
                    Op::Atan2 => a.atan2(b),
                    Op::F(f) => f.eval(a),
                };
                q = q.add(1);
            }
        }
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
    /// `(slot, i + n·j)` of every non-zero, for the dense matrix.
    dense: Vec<(u32, usize)>,
}

impl CompiledJacobian {
    pub(crate) fn new(pattern: Pattern, program: Program) -> Self {
        let vals = program.scratch();
        let n = pattern.n();
        let dense = pattern
            .entries()
            .enumerate()
            .map(|(k, (i, j))| (program.outputs[k], i + n * j))
            .collect();
        CompiledJacobian {
            pattern,
            program,
            vals,
            dense,
        }
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
        for &(s, d) in &self.dense {
            // SAFETY: `d = i + n·j < n² = jac.len()` (asserted above) and `s` is a slot of
            // the program, below `vals.len()`
            unsafe { *jac.get_unchecked_mut(d) = *self.vals.get_unchecked(s as usize) };
        }
    }
}

impl SparseJacobian for CompiledJacobian {
    fn pattern(&self) -> &Pattern {
        &self.pattern
    }
    fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) {
        self.program.run(t, x, u, &mut self.vals);
        for (v, &s) in values.iter_mut().zip(&self.program.outputs) {
            *v = self.vals[s as usize];
        }
    }
}

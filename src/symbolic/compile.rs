//! The compiled evaluator: the part of the graph the requested expressions need,
//! flattened in topological order into a list of three-address instructions over one
//! array of `f64` slots (constants and parameters first, then one slot per instruction;
//! reading a state, an input or the time is an instruction too). The constant slots are
//! data, not code: the instructions (and the native code made from them) read them from
//! the array, so one instruction list serves every model that differs only in their
//! values (see [`super::cache`]). Running it is a single pass with no
//! allocation and no hashing: one flat opcode per instruction, so the dispatch is one
//! jump table, and `sin a` with `cos a` of the same `a` is one `sin_cos`.

use super::graph::{Func, Graph, Node};
use super::jit::{Layout, Native, NativeFn};
use crate::jacobian::{Pattern, SparseJacobian};
use std::collections::HashMap;
use std::sync::Arc;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Op {
    /// `d ← x[a]`
    LoadX,
    /// `d ← u[a]`
    LoadU,
    /// `d ← t`
    LoadT,
    Neg,
    Add,
    Sub,
    Mul,
    /// `d ← −(a·b)`
    NegMul,
    Div,
    Rem,
    /// `b` is the slot of the exponent (an integer-valued constant)
    Powi,
    /// `b` is the slot of the exponent
    Powf,
    Atan2,
    /// `d ← sin a`, `b ← cos a` (`b` is the slot of the `cos a` node)
    SinCos,
    Sin,
    Cos,
    Tan,
    Exp,
    ExpM1,
    Ln,
    Ln1p,
    Sqrt,
    Cbrt,
    Abs,
    Sign,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Asinh,
    Acosh,
    Atanh,
    Trunc,
}

impl Op {
    fn func(f: Func) -> Op {
        match f {
            Func::Sin => Op::Sin,
            Func::Cos => Op::Cos,
            Func::Tan => Op::Tan,
            Func::Exp => Op::Exp,
            Func::ExpM1 => Op::ExpM1,
            Func::Ln => Op::Ln,
            Func::Ln1p => Op::Ln1p,
            Func::Sqrt => Op::Sqrt,
            Func::Cbrt => Op::Cbrt,
            Func::Abs => Op::Abs,
            Func::Sign => Op::Sign,
            Func::Asin => Op::Asin,
            Func::Acos => Op::Acos,
            Func::Atan => Op::Atan,
            Func::Sinh => Op::Sinh,
            Func::Cosh => Op::Cosh,
            Func::Tanh => Op::Tanh,
            Func::Asinh => Op::Asinh,
            Func::Acosh => Op::Acosh,
            Func::Atanh => Op::Atanh,
            Func::Trunc => Op::Trunc,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Ins {
    pub op: Op,
    /// destination slot
    pub d: u32,
    pub a: u32,
    pub b: u32,
}

/// A flattened evaluator of some nodes of a graph.
#[derive(Debug, Clone)]
pub struct Program {
    /// Slot values with the constants in place (the other slots are overwritten): slots
    /// `0..consts` hold the constants and parameters, the rest the instructions' results.
    template: Vec<f64>,
    /// Number of constant slots (constants, exponents and parameters) at the front.
    consts: usize,
    /// `(k, slot)`: parameter `pₖ` lives in constant slot `slot`.
    params: Vec<(u32, u32)>,
    /// One more than the largest state and input index read.
    min_x: usize,
    min_u: usize,
    ins: Vec<Ins>,
    outputs: Vec<u32>,
}

impl Program {
    /// The program that evaluates `roots` of `g`, the parameters `pₖ` set to `p[k]`
    /// (NaN where `p` has no value).
    pub(crate) fn new(g: &Graph, roots: &[u32], p: &[f64]) -> Program {
        let len = g.len();
        let reach = g.reachable(roots);
        let mut slot = vec![u32::MAX; len];
        let mut template = Vec::new();
        // constants, and the exponents of powi and powf, each in a constant slot
        let mut exp_slot = HashMap::new();
        let (mut sin_of, mut cos_of) = (HashMap::new(), HashMap::new());
        let mut params = Vec::new();
        for id in 0..len {
            if !reach[id] {
                continue;
            }
            let bits = match g.node(id as u32) {
                Node::Const(b) => {
                    slot[id] = template.len() as u32;
                    template.push(f64::from_bits(b));
                    continue;
                }
                Node::Param(k) => {
                    slot[id] = template.len() as u32;
                    params.push((k, slot[id]));
                    template.push(p.get(k as usize).copied().unwrap_or(f64::NAN));
                    continue;
                }
                Node::F(Func::Sin, a) => {
                    sin_of.insert(a, id as u32);
                    continue;
                }
                Node::F(Func::Cos, a) => {
                    cos_of.insert(a, id as u32);
                    continue;
                }
                Node::Powf(_, p) => p,
                Node::Powi(_, n) => (n as f64).to_bits(),
                _ => continue,
            };
            exp_slot.entry(bits).or_insert_with(|| {
                template.push(f64::from_bits(bits));
                (template.len() - 1) as u32
            });
        }
        let consts = template.len();
        // `−(a·b)` is one instruction when the product has no other use
        let mut users = vec![0u32; len];
        let mut negated = vec![false; len];
        for (id, _) in reach.iter().enumerate().filter(|(_, r)| **r) {
            let node = g.node(id as u32);
            let (args, k) = node.args();
            for &a in &args[..k] {
                users[a as usize] += 1;
            }
            if let Node::Neg(m) = node {
                negated[m as usize] = true;
            }
        }
        for &r in roots {
            users[r as usize] += 1;
        }
        let mut ins = Vec::new();
        let mut fused = vec![false; len];
        let (mut min_x, mut min_u) = (0, 0);
        for id in 0..len {
            if !reach[id] || slot[id] != u32::MAX {
                continue;
            }
            let node = g.node(id as u32);
            let own = template.len() as u32;
            template.push(0.0);
            slot[id] = own;
            let (args, k) = node.args();
            let a = if k > 0 { slot[args[0] as usize] } else { 0 };
            // a unary instruction reads its operand twice (every `b` is a slot)
            let b = if k == 2 { slot[args[1] as usize] } else { a };
            let (op, d, a, b) = match node {
                Node::State(i) => {
                    min_x = min_x.max(i as usize + 1);
                    (Op::LoadX, own, i, 0)
                }
                Node::Input(k) => {
                    min_u = min_u.max(k as usize + 1);
                    (Op::LoadU, own, k, 0)
                }
                Node::Time => (Op::LoadT, own, 0, 0),
                Node::Const(_) | Node::Param(_) => unreachable!("constant slots are filled above"),
                Node::Neg(m) => match g.node(m) {
                    Node::Mul(p, q) if users[m as usize] == 1 && fused[m as usize] => {
                        // the product was not emitted: `−(p·q)` in one
                        (Op::NegMul, own, slot[p as usize], slot[q as usize])
                    }
                    _ => (Op::Neg, own, a, b),
                },
                Node::Add(..) => (Op::Add, own, a, b),
                Node::Sub(..) => (Op::Sub, own, a, b),
                Node::Mul(..) => (Op::Mul, own, a, b),
                Node::Div(..) => (Op::Div, own, a, b),
                Node::Rem(..) => (Op::Rem, own, a, b),
                Node::Powi(_, n) => (Op::Powi, own, a, exp_slot[&(n as f64).to_bits()]),
                Node::Powf(_, p) => (Op::Powf, own, a, exp_slot[&p]),
                Node::Atan2(..) => (Op::Atan2, own, a, b),
                Node::F(f @ (Func::Sin | Func::Cos), arg) => {
                    let other = if f == Func::Sin { &cos_of } else { &sin_of };
                    match other.get(&arg) {
                        Some(&o) => {
                            // the other one of `sin a`, `cos a` gets its slot now and
                            // both are computed by one `sin_cos`
                            let os = template.len() as u32;
                            template.push(0.0);
                            slot[o as usize] = os;
                            if f == Func::Sin {
                                (Op::SinCos, own, a, os)
                            } else {
                                (Op::SinCos, os, a, own)
                            }
                        }
                        None => (Op::func(f), own, a, b),
                    }
                }
                Node::F(f, _) => (Op::func(f), own, a, b),
            };
            if let Node::Mul(..) = node {
                // a product whose one user is a negation is left to that negation
                if users[id] == 1 && negated[id] {
                    fused[id] = true;
                    template.pop();
                    slot[id] = u32::MAX - 1;
                    continue;
                }
            }
            ins.push(Ins { op, d, a, b });
        }
        let outputs = roots.iter().map(|&r| slot[r as usize]).collect();
        let p = Program {
            template,
            consts,
            params,
            min_x,
            min_u,
            ins,
            outputs,
        };
        p.check();
        p
    }

    /// Every operand is written before it is read and every slot is in range: what
    /// `run`'s unchecked accesses rely on.
    fn check(&self) {
        let n = self.template.len();
        // constants are in place; every other slot is some instruction's destination
        let mut written = vec![true; n];
        for i in &self.ins {
            for s in [Some(i.d), (i.op == Op::SinCos).then_some(i.b)].into_iter().flatten() {
                assert!(
                    (s as usize) < n && s as usize >= self.consts,
                    "symbolic: slot out of range"
                );
                written[s as usize] = false;
            }
        }
        for i in &self.ins {
            let reads: &[u32] = match i.op {
                Op::LoadX | Op::LoadU | Op::LoadT => &[],
                Op::SinCos => std::slice::from_ref(&i.a),
                _ => &[i.a, i.b],
            };
            for &r in reads {
                assert!(
                    (r as usize) < n && written[r as usize],
                    "symbolic: operand read before it is written"
                );
            }
            assert!((i.d as usize) < n, "symbolic: slot out of range");
            written[i.d as usize] = true;
            if i.op == Op::SinCos {
                assert!((i.b as usize) < n, "symbolic: slot out of range");
                written[i.b as usize] = true;
            }
        }
        for &o in &self.outputs {
            assert!(
                (o as usize) < n && written[o as usize],
                "symbolic: output never written"
            );
        }
    }

    /// The constant template, the instructions and the output slots.
    #[cfg_attr(not(feature = "jit"), allow(dead_code))]
    pub(super) fn parts(&self) -> (&[f64], &[Ins], &[u32]) {
        (&self.template, &self.ins, &self.outputs)
    }

    /// Number of constant slots (at the front of the template).
    #[cfg_attr(not(feature = "jit"), allow(dead_code))]
    pub(super) fn consts(&self) -> usize {
        self.consts
    }

    /// Set the parameters `pₖ ← p[k]` in their constant slots.
    pub(super) fn set_params(&mut self, p: &[f64]) {
        for &(k, s) in &self.params {
            self.template[s as usize] = p.get(k as usize).copied().unwrap_or(f64::NAN);
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
        if x.len() < self.min_x || u.len() < self.min_u {
            // pad what is missing with NaN (a misuse, so the allocation does not matter)
            let pad = |v: &[f64], n: usize| {
                let mut p = v.to_vec();
                p.resize(n.max(v.len()), f64::NAN);
                p
            };
            return self.run(t, &pad(x, self.min_x), &pad(u, self.min_u), vals);
        }
        let p = vals.as_mut_ptr();
        let (xp, up) = (x.as_ptr(), u.as_ptr());
        // SAFETY: `check` (run by `new`) asserted that every slot `d`, `a`, `b` is below
        // `template.len() = vals.len()` (asserted above); every state index is below
        // `min_x ≤ x.len()` and every input index below `min_u ≤ u.len()` (checked above).
        unsafe {
            for ins in &self.ins {
                let d = p.add(ins.d as usize);
                let a = || *p.add(ins.a as usize);
                let b = || *p.add(ins.b as usize);
                *d = match ins.op {
                    Op::LoadX => *xp.add(ins.a as usize),
                    Op::LoadU => *up.add(ins.a as usize),
                    Op::LoadT => t,
                    Op::Neg => -a(),
                    Op::Add => a() + b(),
                    Op::Sub => a() - b(),
                    Op::Mul => a() * b(),
                    Op::NegMul => -(a() * b()),
                    Op::Div => a() / b(),
                    Op::Rem => a() % b(),
                    Op::Powi => a().powi(b() as i32),
                    Op::Powf => a().powf(b()),
                    Op::Atan2 => a().atan2(b()),
                    Op::SinCos => {
                        let (s, c) = a().sin_cos();
                        *p.add(ins.b as usize) = c;
                        s
                    }
                    Op::Sin => a().sin(),
                    Op::Cos => a().cos(),
                    Op::Tan => a().tan(),
                    Op::Exp => a().exp(),
                    Op::ExpM1 => a().exp_m1(),
                    Op::Ln => a().ln(),
                    Op::Ln1p => a().ln_1p(),
                    Op::Sqrt => a().sqrt(),
                    Op::Cbrt => a().cbrt(),
                    Op::Abs => a().abs(),
                    Op::Sign => Func::Sign.eval(a()),
                    Op::Asin => a().asin(),
                    Op::Acos => a().acos(),
                    Op::Atan => a().atan(),
                    Op::Sinh => a().sinh(),
                    Op::Cosh => a().cosh(),
                    Op::Tanh => a().tanh(),
                    Op::Asinh => a().asinh(),
                    Op::Acosh => a().acosh(),
                    Op::Atanh => a().atanh(),
                    Op::Trunc => a().trunc(),
                };
            }
        }
    }
}

/// `J = ∂f/∂x` compiled from a traced model: its pattern and a [`Program`] whose outputs
/// are the pattern's non-zeros in order. Evaluates into the sparse values (O(non-zeros)
/// for a local model) or into a dense matrix.
///
/// Programs of up to [`MAX_NATIVE_INSTRUCTIONS`](super::jit::MAX_NATIVE_INSTRUCTIONS)
/// instructions are also translated into machine code (Cranelift) when the Jacobian is
/// compiled; evaluation then runs that code, which gives the interpreter's values bit for
/// bit. [`interpreted`](Self::interpreted) drops it, [`is_native`](Self::is_native) tells.
///
/// ```
/// use reckon::{model, symbolic, jacobian::SparseJacobian};
/// use nalgebra::vector;
/// let f = model!(|_, x: [S; 2]| vector![x[1].clone(), -x[0].sin()]);
/// let mut jac = symbolic::trace(&f, 2).unwrap().compile_jacobian();
/// let mut v = vec![0.0; jac.pattern().nnz()];
/// jac.eval(0.0, &[0.5, 0.0], &[], &mut v).unwrap();
/// // CSC order: (1, 0) = −cos x₀, then (0, 1) = 1
/// assert_eq!(v, vec![-0.5f64.cos(), 1.0]);
/// // the interpreter gives the same values, bit for bit
/// let mut w = vec![0.0; 2];
/// jac.clone().interpreted().eval(0.0, &[0.5, 0.0], &[], &mut w).unwrap();
/// // a buffer of the wrong length is an error, not a panic
/// assert!(jac.eval(0.0, &[0.5, 0.0], &[], &mut [0.0; 3]).is_err());
/// assert_eq!(v, w);
/// ```
#[derive(Debug, Clone)]
pub struct CompiledJacobian {
    pattern: Pattern,
    program: Program,
    vals: Vec<f64>,
    /// `(slot, i + n·j)` of every non-zero, for the dense matrix.
    dense: Vec<(u32, usize)>,
    /// Native code: function 0 writes the CSC values, function 1 (for `n ≤ NATIVE_DENSE`)
    /// the whole dense matrix.
    native: Option<Arc<Native>>,
    /// Room for the CSC values when a dense matrix is filled from function 0.
    csc: Vec<f64>,
}

/// Up to this many states the native code writes the whole dense matrix, zeros included.
const NATIVE_DENSE: usize = 32;

impl CompiledJacobian {
    pub(crate) fn new(pattern: Pattern, program: Program) -> Self {
        let vals = program.scratch();
        let n = pattern.n();
        let dense: Vec<(u32, usize)> = pattern
            .entries()
            .enumerate()
            .map(|(k, (i, j))| (program.outputs[k], i + n * j))
            .collect();
        let mut layouts = vec![Layout {
            offsets: (0..pattern.nnz()).collect(),
            zeros: Vec::new(),
        }];
        if n <= NATIVE_DENSE {
            let mut nz = vec![false; n * n];
            for &(_, d) in &dense {
                nz[d] = true;
            }
            layouts.push(Layout {
                offsets: dense.iter().map(|&(_, d)| d).collect(),
                zeros: (0..n * n).filter(|&d| !nz[d]).collect(),
            });
        }
        let native = super::cache::native_code(&program, &layouts);
        CompiledJacobian {
            csc: vec![0.0; if native.is_some() { pattern.nnz() } else { 0 }],
            pattern,
            program,
            vals,
            dense,
            native,
        }
    }

    /// The same compiled Jacobian with the parameters `pₖ ← p[k]` (a model's parameter
    /// block: inputs of the compiled code, so no new trace or compile).
    pub(crate) fn set_params(&mut self, p: &[f64]) {
        self.program.set_params(p);
        let k = self.program.consts;
        self.vals[..k].copy_from_slice(&self.program.template[..k]);
    }

    /// The same Jacobian evaluated by the interpreter only (to compare, or to save the
    /// native code's memory).
    pub fn interpreted(mut self) -> Self {
        self.native = None;
        self.csc = Vec::new();
        self
    }

    /// Approximate heap bytes this Jacobian holds (its native code not counted).
    pub(crate) fn bytes(&self) -> usize {
        let p = &self.program;
        8 * (p.template.len() + self.vals.len() + self.csc.len() + self.pattern.nnz() + self.pattern.n())
            + std::mem::size_of::<Ins>() * p.ins.len()
            + 4 * p.outputs.len()
            + 16 * self.dense.len()
    }

    /// Whether evaluation runs native code.
    pub fn is_native(&self) -> bool {
        self.native.is_some()
    }

    /// The instructions one evaluation runs.
    pub fn instructions(&self) -> usize {
        self.program.len()
    }

    /// Run native function `k` into `out`, or return `false` if there is none.
    #[inline]
    fn native(&self, k: usize, t: f64, x: &[f64], u: &[f64], out: &mut [f64]) -> bool {
        let Some(code) = &self.native else {
            return false;
        };
        if x.len() < self.program.min_x || u.len() < self.program.min_u {
            // the interpreter pads missing operands with NaN
            return false;
        }
        // SAFETY: the code reads `x[i]` for `i < min_x ≤ x.len()` and `u[k]` for
        // `k < min_u ≤ u.len()` (checked above), and writes `out[d]` for the layout's
        // offsets: `d < nnz` for function 0 and `d < n²` for function 1, which the callers
        // give as `out.len()` (checked there); it reads the constant slots `s < consts ≤
        // template.len()` of the template it was generated for (the cache hands out code
        // only for programs with the same instructions and slot layout).
        unsafe {
            code.get(k)(
                x.as_ptr(),
                u.as_ptr(),
                t,
                out.as_mut_ptr(),
                self.program.template.as_ptr(),
            )
        };
        true
    }

    /// `jac ← J(t, x, u)` as a dense column-major `n × n` array (`jac[i + n·j] = ∂fᵢ/∂xⱼ`);
    /// [`Error::InvalidInput`](crate::Error::InvalidInput) when `jac` does not hold `n²`
    /// values.
    pub fn eval_dense(&mut self, t: f64, x: &[f64], u: &[f64], jac: &mut [f64]) -> crate::Result<()> {
        let n = self.pattern.n();
        if jac.len() != n * n {
            return Err(crate::Error::invalid(
                "jac",
                format!("{} values for a dense {n} × {n} Jacobian", jac.len()),
            ));
        }
        if n <= NATIVE_DENSE && self.native(1, t, x, u, jac) {
            return Ok(());
        }
        let mut csc = std::mem::take(&mut self.csc);
        let done = self.native(0, t, x, u, &mut csc);
        jac.fill(0.0);
        if done {
            for (k, &(_, d)) in self.dense.iter().enumerate() {
                jac[d] = csc[k];
            }
        } else {
            self.program.run(t, x, u, &mut self.vals);
            for &(s, d) in &self.dense {
                // SAFETY: `d = i + n·j < n² = jac.len()` (checked above) and `s` is a slot
                // of the program, below `vals.len()`
                unsafe { *jac.get_unchecked_mut(d) = *self.vals.get_unchecked(s as usize) };
            }
        }
        self.csc = csc;
        Ok(())
    }
}

impl SparseJacobian for CompiledJacobian {
    fn pattern(&self) -> &Pattern {
        &self.pattern
    }
    fn eval(&mut self, t: f64, x: &[f64], u: &[f64], values: &mut [f64]) -> crate::Result<()> {
        crate::jacobian::check_values(values, self.pattern.nnz())?;
        if self.native(0, t, x, u, values) {
            return Ok(());
        }
        self.program.run(t, x, u, &mut self.vals);
        for (v, &s) in values.iter_mut().zip(&self.program.outputs) {
            *v = self.vals[s as usize];
        }
        Ok(())
    }
}

/// A vector of expressions of a traced model compiled like [`CompiledJacobian`]:
/// `out[offsets[k]] ← eₖ(t, x, u)` and every other entry of `out` set to 0. It is how
/// `f` itself ([`Traced::compile_rhs`](super::Traced::compile_rhs)) and `∂f/∂t`
/// ([`Traced::compile_time_derivative`](super::Traced::compile_time_derivative)) run as
/// compiled code, for a model given only as its trace (one traced from Python).
///
/// A program longer than [`MAX_NATIVE_INSTRUCTIONS`](super::jit::MAX_NATIVE_INSTRUCTIONS)
/// is split into consecutive runs of outputs, each flattened on its own (a subexpression
/// two runs share is computed in both) and translated into machine code when it is short
/// enough; a run that stays too long is interpreted. Every run gives the interpreter's
/// bits.
///
/// ```
/// use reckon::{model, symbolic};
/// use nalgebra::vector;
/// let f = model!(|_, x: [S; 2]| vector![x[1].clone(), -x[0].sin()]);
/// let mut rhs = symbolic::trace(&f, 2).unwrap().compile_rhs();
/// let mut out = [0.0; 2];
/// rhs.eval(0.0, &[0.5, 2.0], &[], &mut out).unwrap();
/// assert_eq!(out, [2.0, -0.5f64.sin()]);
/// let mut w = [0.0; 2];
/// rhs.clone().interpreted().eval(0.0, &[0.5, 2.0], &[], &mut w).unwrap();
/// assert_eq!(out, w);
/// assert!(rhs.eval(0.0, &[0.5, 2.0], &[], &mut [0.0; 3]).is_err());
///
/// // a long f (the Brusselator on 3 000 points: 6 000 states) runs natively in runs of
/// // outputs, with the interpreter's bits and the model's values
/// use reckon::{studies::problems::{brusselator, brusselator_y0}, System};
/// let (f, y) = (brusselator(3000), brusselator_y0(3000));
/// let mut rhs = symbolic::trace(&f, 6000).unwrap().compile_rhs();
/// assert_eq!(rhs.is_native(), symbolic::jit::MAX_NATIVE_INSTRUCTIONS > 0);
/// let (mut a, mut b) = (vec![0.0; 6000], vec![0.0; 6000]);
/// rhs.eval(0.0, y.as_slice(), &[], &mut a).unwrap();
/// rhs.clone().interpreted().eval(0.0, y.as_slice(), &[], &mut b).unwrap();
/// assert_eq!(a, b);
/// let mut dx = y.clone();
/// f.rhs(0.0, &y, &[], &mut dx);
/// assert!(a.iter().zip(dx.iter()).all(|(p, q)| (p - q).abs() <= 1e-9 * q.abs().max(1.0)));
/// ```
#[derive(Debug, Clone)]
pub struct CompiledVector {
    len: usize,
    parts: Vec<Part>,
    zeros: Vec<usize>,
    /// Part 0's native function when it is the only part and writes every output (no
    /// zeros): [`eval`](Self::eval) then makes one checked call (small models evaluate
    /// their `f` a few nanoseconds apart, so the dispatch shows).
    single: Option<NativeFn>,
}

/// One run of outputs of a [`CompiledVector`]: `out[offsets[k]] ← output k of program`.
#[derive(Debug, Clone)]
struct Part {
    program: Program,
    vals: Vec<f64>,
    offsets: Vec<usize>,
    native: Option<Arc<Native>>,
}

impl Part {
    fn new(program: Program, offsets: Vec<usize>) -> Part {
        let native = super::cache::native_code(
            &program,
            &[Layout {
                offsets: offsets.clone(),
                zeros: Vec::new(),
            }],
        );
        Part {
            vals: program.scratch(),
            program,
            offsets,
            native,
        }
    }
}

impl CompiledVector {
    /// `out[offsets[k]] ← roots[k]` of `g` with the parameters `p`, the rest of `out` (of
    /// `len`) zero.
    pub(crate) fn new(len: usize, g: &Graph, roots: &[u32], p: &[f64], offsets: Vec<usize>) -> Self {
        let mut hit = vec![false; len];
        for &o in &offsets {
            hit[o] = true;
        }
        let zeros: Vec<usize> = (0..len).filter(|&i| !hit[i]).collect();
        let whole = Program::new(g, roots, p);
        let limit = super::jit::MAX_NATIVE_INSTRUCTIONS;
        let parts = if whole.len() <= limit || roots.len() < 2 || limit == 0 {
            vec![Part::new(whole, offsets)]
        } else {
            // runs of outputs of about 4/5 of the limit each (a run also recomputes what it
            // shares with its neighbours)
            let runs = whole.len().div_ceil(limit * 4 / 5).min(roots.len());
            let per = roots.len().div_ceil(runs);
            roots
                .chunks(per)
                .zip(offsets.chunks(per))
                .map(|(r, o)| Part::new(Program::new(g, r, p), o.to_vec()))
                .collect()
        };
        let single = match &parts[..] {
            [part] if zeros.is_empty() => part.native.as_ref().map(|code| code.get(0)),
            _ => None,
        };
        CompiledVector {
            len,
            parts,
            zeros,
            single,
        }
    }

    /// The same vector evaluated by the interpreter only.
    pub fn interpreted(mut self) -> Self {
        for part in &mut self.parts {
            part.native = None;
        }
        self.single = None;
        self
    }

    /// Whether evaluation runs native code (for every run of outputs).
    pub fn is_native(&self) -> bool {
        self.parts.iter().all(|p| p.native.is_some())
    }

    /// The instructions one evaluation runs.
    pub fn instructions(&self) -> usize {
        self.parts.iter().map(|p| p.program.len()).sum()
    }

    /// The length of the vector.
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        self.len
    }

    /// `out ← e(t, x, u)`; [`Error::InvalidInput`](crate::Error::InvalidInput) when `out`
    /// does not hold [`len`](Self::len) values.
    #[inline]
    pub fn eval(&mut self, t: f64, x: &[f64], u: &[f64], out: &mut [f64]) -> crate::Result<()> {
        if let (Some(code), [part]) = (self.single, &self.parts[..])
            && out.len() == self.len
            && x.len() >= part.program.min_x
            && u.len() >= part.program.min_u
        {
            // SAFETY: as below: one part writing every output of `out` (`len` values,
            // checked), reading `x` and `u` within their checked lengths and the constant
            // slots of its own template (`single` is part 0's function, kept alive by
            // its `native`)
            unsafe {
                code(
                    x.as_ptr(),
                    u.as_ptr(),
                    t,
                    out.as_mut_ptr(),
                    part.program.template.as_ptr(),
                )
            };
            return Ok(());
        }
        self.eval_parts(t, x, u, out)
    }

    /// [`eval`](Self::eval) run by run (and the interpreter where there is no native code).
    fn eval_parts(&mut self, t: f64, x: &[f64], u: &[f64], out: &mut [f64]) -> crate::Result<()> {
        if out.len() != self.len {
            return Err(crate::Error::invalid(
                "out",
                format!("{} values for a vector of {}", out.len(), self.len),
            ));
        }
        for &z in &self.zeros {
            out[z] = 0.0;
        }
        for part in &mut self.parts {
            if let Some(code) = &part.native
                && x.len() >= part.program.min_x
                && u.len() >= part.program.min_u
            {
                // SAFETY: as in `CompiledJacobian::native`: the code reads `x[i]` for
                // `i < min_x ≤ x.len()`, `u[k]` for `k < min_u ≤ u.len()` (checked above),
                // the constant slots of the template it was generated for, and writes
                // `out[d]` for `d` in `offsets`, all below `len = out.len()` (checked above).
                unsafe {
                    code.get(0)(
                        x.as_ptr(),
                        u.as_ptr(),
                        t,
                        out.as_mut_ptr(),
                        part.program.template.as_ptr(),
                    )
                };
                continue;
            }
            part.program.run(t, x, u, &mut part.vals);
            for (&o, &s) in part.offsets.iter().zip(&part.program.outputs) {
                out[o] = part.vals[s as usize];
            }
        }
        Ok(())
    }
}

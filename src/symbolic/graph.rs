//! The expression graph: hash-consed nodes (one id per distinct expression, so common
//! subexpressions are shared), built through constructors that fold constants and
//! simplify `0·a`, `1·a`, `a + 0`, `a − a`, `a/1`, `−(−a)` as they go.
//!
//! Ids are indices into `nodes` and every node's operands have smaller ids, so the id
//! order is a topological order (operands before their users).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A multiply–rotate hasher (the Firefox/rustc "Fx" hash) for node keys: a few
/// instructions per word where SipHash spends dozens; the keys are our own small
/// integers, so its weaker mixing costs nothing here.
#[derive(Default, Clone, Copy)]
pub(crate) struct FxHasher(u64);

impl Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(w));
        }
    }
    #[inline]
    fn write_u8(&mut self, i: u8) {
        self.write_u64(i as u64);
    }
    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.write_u64(i as u64);
    }
    #[inline]
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.write_u64(i as u64);
    }
    /// The multiply leaves the low bits of the state, which `HashMap` takes for the
    /// bucket index, depending only on the low bits of the words written: a node's first
    /// operand (in the high half of [`Node`]'s first word) reached them through 5 bits
    /// only, so `−a`, `f(a)` and `a·c` for one `c` fell into a few dozen buckets and
    /// hash-consing went quadratic (tracing BRUSS with 1.6·10⁵ points took 30 s, with
    /// 5·10⁵ several minutes). MurmurHash3's finaliser folds the high half down.
    #[inline]
    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        h ^ (h >> 33)
    }
}

type FxMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

/// Elementary functions of one argument a traced body may call.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Func {
    /// `sin a`
    Sin,
    /// `cos a`
    Cos,
    /// `tan a`
    Tan,
    /// `eᵃ`
    Exp,
    /// `eᵃ − 1`
    ExpM1,
    /// `ln a`
    Ln,
    /// `ln(1 + a)`
    Ln1p,
    /// `√a`
    Sqrt,
    /// `∛a`
    Cbrt,
    /// `|a|`
    Abs,
    /// `sign a`: ±1 by the sign bit, as `f64::signum` (+1 at +0, −1 at −0, NaN at NaN).
    /// It is `signum()`'s value and the derivative of `|a|`, which num-dual takes by the
    /// same sign bit (`|a|` is `a` when `a` is sign-positive, `−a` otherwise), so the
    /// two Jacobians agree at ±0 too.
    Sign,
    /// `asin a`
    Asin,
    /// `acos a`
    Acos,
    /// `atan a`
    Atan,
    /// `sinh a`
    Sinh,
    /// `cosh a`
    Cosh,
    /// `tanh a`
    Tanh,
    /// `asinh a`
    Asinh,
    /// `acosh a`
    Acosh,
    /// `atanh a`
    Atanh,
    /// `trunc a` (the integer part, derivative 0 where defined)
    Trunc,
}

impl Func {
    /// The function's value at `a`, as `f64`'s own method computes it.
    #[inline]
    pub fn eval(self, a: f64) -> f64 {
        match self {
            Func::Sin => a.sin(),
            Func::Cos => a.cos(),
            Func::Tan => a.tan(),
            Func::Exp => a.exp(),
            Func::ExpM1 => a.exp_m1(),
            Func::Ln => a.ln(),
            Func::Ln1p => a.ln_1p(),
            Func::Sqrt => a.sqrt(),
            Func::Cbrt => a.cbrt(),
            Func::Abs => a.abs(),
            Func::Sign => a.signum(),
            Func::Asin => a.asin(),
            Func::Acos => a.acos(),
            Func::Atan => a.atan(),
            Func::Sinh => a.sinh(),
            Func::Cosh => a.cosh(),
            Func::Tanh => a.tanh(),
            Func::Asinh => a.asinh(),
            Func::Acosh => a.acosh(),
            Func::Atanh => a.atanh(),
            Func::Trunc => a.trunc(),
        }
    }

    /// The name printed in text and Rust (`sin`, `exp_m1`, …).
    pub fn name(self) -> &'static str {
        match self {
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Exp => "exp",
            Func::ExpM1 => "exp_m1",
            Func::Ln => "ln",
            Func::Ln1p => "ln_1p",
            Func::Sqrt => "sqrt",
            Func::Cbrt => "cbrt",
            Func::Abs => "abs",
            Func::Sign => "signum",
            Func::Asin => "asin",
            Func::Acos => "acos",
            Func::Atan => "atan",
            Func::Sinh => "sinh",
            Func::Cosh => "cosh",
            Func::Tanh => "tanh",
            Func::Asinh => "asinh",
            Func::Acosh => "acosh",
            Func::Atanh => "atanh",
            Func::Trunc => "trunc",
        }
    }
}

/// Whether `v` is ±2ᵏ (multiplying by it is exact, barring overflow and underflow).
fn power_of_two(v: f64) -> bool {
    v != 0.0 && v.is_finite() && (v.abs().to_bits() & ((1u64 << 52) - 1)) == 0
}

/// One node. Constants are stored by their bits so that the node is hashable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Node {
    /// A number (`f64::to_bits`).
    Const(u64),
    /// State component `xᵢ`.
    State(u32),
    /// Held input `uₖ`.
    Input(u32),
    /// Time `t`.
    Time,
    /// Parameter `pₖ` of a model's parameter block: an input of the compiled code, never
    /// folded into a constant (so one compiled program serves every parameter value).
    Param(u32),
    /// `−a`
    Neg(u32),
    /// `a + b`
    Add(u32, u32),
    /// `a − b`
    Sub(u32, u32),
    /// `a · b`
    Mul(u32, u32),
    /// `a / b`
    Div(u32, u32),
    /// `a % b` (Rust's remainder: `a − b·trunc(a/b)`)
    Rem(u32, u32),
    /// `aⁿ`, integer `n`
    Powi(u32, i32),
    /// `aᵖ`, real constant `p` (bits)
    Powf(u32, u64),
    /// `atan2(a, b)` (the angle of `(b, a)`)
    Atan2(u32, u32),
    /// `f(a)`
    F(Func, u32),
}

/// Two words per node (an injective packing, so equal hashes of unequal nodes are only the
/// hasher's collisions): the hash-consing's one cost per operation.
impl std::hash::Hash for Node {
    #[inline]
    fn hash<H: Hasher>(&self, h: &mut H) {
        let w = |tag: u64, a: u32| tag | (a as u64) << 32;
        let (w0, w1) = match *self {
            Node::Const(b) => (0, b),
            Node::State(i) => (1, i as u64),
            Node::Input(k) => (2, k as u64),
            Node::Time => (3, 0),
            Node::Param(k) => (4, k as u64),
            Node::Neg(a) => (w(5, a), 0),
            Node::Add(a, b) => (w(6, a), b as u64),
            Node::Sub(a, b) => (w(7, a), b as u64),
            Node::Mul(a, b) => (w(8, a), b as u64),
            Node::Div(a, b) => (w(9, a), b as u64),
            Node::Rem(a, b) => (w(10, a), b as u64),
            Node::Powi(a, n) => (w(11, a), n as u32 as u64),
            Node::Powf(a, p) => (w(12, a), p),
            Node::Atan2(a, b) => (w(13, a), b as u64),
            Node::F(f, a) => (w(14 | (f as u64) << 8, a), 0),
        };
        h.write_u64(w0);
        h.write_u64(w1);
    }
}

impl Node {
    /// The operands, in order.
    pub fn args(&self) -> ([u32; 2], usize) {
        match *self {
            Node::Const(_) | Node::State(_) | Node::Input(_) | Node::Time | Node::Param(_) => ([0, 0], 0),
            Node::Neg(a) | Node::Powi(a, _) | Node::Powf(a, _) | Node::F(_, a) => ([a, 0], 1),
            Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Mul(a, b)
            | Node::Div(a, b)
            | Node::Rem(a, b)
            | Node::Atan2(a, b) => ([a, b], 2),
        }
    }
}

/// A hash-consed expression graph.
#[derive(Debug, Default, Clone)]
pub struct Graph {
    nodes: Vec<Node>,
    ids: FxMap<Node, u32>,
}

impl Graph {
    /// An empty graph with room for `n` nodes.
    pub fn with_capacity(n: usize) -> Self {
        Graph {
            nodes: Vec::with_capacity(n),
            ids: FxMap::with_capacity_and_hasher(n, Default::default()),
        }
    }

    /// Number of nodes.
    #[allow(clippy::len_without_is_empty)]
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// The nodes, in id order.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Which nodes `roots` depend on (the roots included), indexed by id.
    pub fn reachable(&self, roots: &[u32]) -> Vec<bool> {
        let mut reach = vec![false; self.nodes.len()];
        let mut stack: Vec<u32> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut reach[id as usize], true) {
                continue;
            }
            let (args, k) = self.node(id).args();
            stack.extend(args[..k].iter().filter(|&&a| !reach[a as usize]));
        }
        reach
    }

    /// The node with id `id`.
    pub fn node(&self, id: u32) -> Node {
        self.nodes[id as usize]
    }

    /// The value of `id` if it is a constant.
    pub fn constant(&self, id: u32) -> Option<f64> {
        match self.nodes[id as usize] {
            Node::Const(b) => Some(f64::from_bits(b)),
            _ => None,
        }
    }

    /// The id of `node`, adding it if new (no simplification).
    pub fn intern(&mut self, node: Node) -> u32 {
        let next = self.nodes.len();
        match self.ids.entry(node) {
            std::collections::hash_map::Entry::Occupied(e) => *e.get(),
            std::collections::hash_map::Entry::Vacant(e) => {
                let id = u32::try_from(next).expect("symbolic: more than 2³² nodes");
                e.insert(id);
                self.nodes.push(node);
                id
            }
        }
    }

    /// The id of a commutative `node` (as written) whose operands may come in either
    /// order: found under its sorted form `key`, so `a + b` and `b + a` are one node,
    /// printed in the order first written. (A commutative node enters only here, always
    /// under its key, so a missing key means a new node.)
    fn intern_commutative(&mut self, node: Node, key: Node) -> u32 {
        let next = self.nodes.len();
        match self.ids.entry(key) {
            std::collections::hash_map::Entry::Occupied(e) => *e.get(),
            std::collections::hash_map::Entry::Vacant(e) => {
                let id = u32::try_from(next).expect("symbolic: more than 2³² nodes");
                e.insert(id);
                self.nodes.push(node);
                if node != key {
                    self.ids.insert(node, id);
                }
                id
            }
        }
    }

    /// The constant `v`.
    pub fn num(&mut self, v: f64) -> u32 {
        self.intern(Node::Const(v.to_bits()))
    }

    /// `−a`
    pub fn neg(&mut self, a: u32) -> u32 {
        if let Some(v) = self.constant(a) {
            return self.num(-v);
        }
        match self.node(a) {
            Node::Neg(b) => b,
            Node::Sub(x, y) => self.intern(Node::Sub(y, x)),
            _ => self.intern(Node::Neg(a)),
        }
    }

    /// Display rank of a product's factor: constants, then leaves, then the rest.
    fn rank(&self, id: u32) -> u8 {
        match self.node(id) {
            Node::Const(_) => 0,
            Node::State(_) | Node::Input(_) | Node::Time | Node::Param(_) => 1,
            _ => 2,
        }
    }

    /// `a + b`
    pub fn add(&mut self, a: u32, b: u32) -> u32 {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => return self.num(x + y),
            (Some(0.0), None) => return b,
            (None, Some(0.0)) => return a,
            _ => {}
        }
        if let Node::Neg(c) = self.node(b) {
            return self.sub(a, c);
        }
        if let Node::Neg(c) = self.node(a) {
            return self.sub(b, c);
        }
        // a + a = 2·a exactly
        if a == b {
            let two = self.num(2.0);
            return self.mul(two, a);
        }
        // constants last; `a + b` and `b + a` are one node
        let (p, q) = if self.constant(a).is_some() { (b, a) } else { (a, b) };
        self.intern_commutative(Node::Add(p, q), Node::Add(p.min(q), p.max(q)))
    }

    /// `a − b`
    pub fn sub(&mut self, a: u32, b: u32) -> u32 {
        if a == b {
            return self.num(0.0);
        }
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => return self.num(x - y),
            (None, Some(0.0)) => return a,
            (Some(0.0), None) => return self.neg(b),
            // a − (−c) = a + c exactly
            (None, Some(y)) if y < 0.0 => {
                let c = self.num(-y);
                return self.add(a, c);
            }
            _ => {}
        }
        if let Node::Neg(c) = self.node(b) {
            return self.add(a, c);
        }
        self.intern(Node::Sub(a, b))
    }

    /// `a · b`
    pub fn mul(&mut self, a: u32, b: u32) -> u32 {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => return self.num(x * y),
            (Some(x), None) | (None, Some(x)) if x == 0.0 => return self.num(0.0),
            (Some(1.0), None) => return b,
            (None, Some(1.0)) => return a,
            (Some(-1.0), None) => return self.neg(b),
            (None, Some(-1.0)) => return self.neg(a),
            _ => {}
        }
        // pull negations out: (−a)·b = −(a·b), exactly in IEEE arithmetic
        if let Node::Neg(c) = self.node(a) {
            let m = self.mul(c, b);
            return self.neg(m);
        }
        if let Node::Neg(c) = self.node(b) {
            let m = self.mul(a, c);
            return self.neg(m);
        }
        // c₁·(c₂·x) = (c₁c₂)·x exactly when one of them is a power of two
        if let (Some(c1), Node::Mul(c, x)) = (self.constant(a), self.node(b))
            && let Some(c2) = self.constant(c)
            && (power_of_two(c1) || power_of_two(c2))
        {
            let k = self.num(c1 * c2);
            return self.mul(k, x);
        }
        // printed in the order constants, leaves, the rest (`2·v·sin(θ)`), as written
        // within a rank; `a·b` and `b·a` are one node
        let (p, q) = if self.rank(b) < self.rank(a) { (b, a) } else { (a, b) };
        self.intern_commutative(Node::Mul(p, q), Node::Mul(p.min(q), p.max(q)))
    }

    /// `a / b`
    pub fn div(&mut self, a: u32, b: u32) -> u32 {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => return self.num(x / y),
            (Some(0.0), None) => return self.num(0.0),
            (None, Some(1.0)) => return a,
            (None, Some(-1.0)) => return self.neg(a),
            _ => {}
        }
        if a == b {
            return self.num(1.0);
        }
        if let Node::Neg(c) = self.node(a) {
            let q = self.div(c, b);
            return self.neg(q);
        }
        self.intern(Node::Div(a, b))
    }

    /// `a % b`
    pub fn rem(&mut self, a: u32, b: u32) -> u32 {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.num(x % y),
            _ => self.intern(Node::Rem(a, b)),
        }
    }

    /// `aⁿ`
    pub fn powi(&mut self, a: u32, n: i32) -> u32 {
        if let Some(x) = self.constant(a) {
            return self.num(x.powi(n));
        }
        match n {
            0 => self.num(1.0),
            1 => a,
            _ => self.intern(Node::Powi(a, n)),
        }
    }

    /// `aᵖ`
    pub fn powf(&mut self, a: u32, p: f64) -> u32 {
        if let Some(x) = self.constant(a) {
            return self.num(x.powf(p));
        }
        if p == 1.0 {
            return a;
        }
        if p == 0.0 {
            return self.num(1.0);
        }
        self.intern(Node::Powf(a, p.to_bits()))
    }

    /// `atan2(a, b)`
    pub fn atan2(&mut self, a: u32, b: u32) -> u32 {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.num(x.atan2(y)),
            _ => self.intern(Node::Atan2(a, b)),
        }
    }

    /// `f(a)`
    pub fn func(&mut self, f: Func, a: u32) -> u32 {
        if let Some(x) = self.constant(a) {
            return self.num(f.eval(x));
        }
        match (f, self.node(a)) {
            // |−b| = |b|; sign and trunc of a sign are the sign
            (Func::Abs, Node::Neg(b)) => self.func(Func::Abs, b),
            (Func::Abs, Node::F(Func::Abs, _)) => a,
            (Func::Sign | Func::Trunc, Node::F(Func::Sign, _)) => a,
            _ => self.intern(Node::F(f, a)),
        }
    }

    /// The derivative of node `id` with respect to its operand number `k` (0 or 1), as
    /// a node, where `id`'s own value is at hand for the rules that reuse it.
    pub fn partial(&mut self, id: u32, k: usize) -> u32 {
        match self.node(id) {
            Node::Const(_) | Node::State(_) | Node::Input(_) | Node::Time | Node::Param(_) => self.num(0.0),
            Node::Neg(_) => self.num(-1.0),
            Node::Add(..) => self.num(1.0),
            Node::Sub(..) => self.num(if k == 0 { 1.0 } else { -1.0 }),
            Node::Mul(a, b) => {
                if k == 0 {
                    b
                } else {
                    a
                }
            }
            Node::Div(_, b) => {
                if k == 0 {
                    let one = self.num(1.0);
                    self.div(one, b)
                } else {
                    // ∂(a/b)/∂b = −(a/b)/b
                    let q = self.div(id, b);
                    self.neg(q)
                }
            }
            Node::Rem(a, b) => {
                if k == 0 {
                    self.num(1.0)
                } else {
                    let q = self.div(a, b);
                    let t = self.func(Func::Trunc, q);
                    self.neg(t)
                }
            }
            Node::Powi(a, n) => {
                let p = self.powi(a, n - 1);
                let c = self.num(n as f64);
                self.mul(c, p)
            }
            Node::Powf(a, p) => {
                let p = f64::from_bits(p);
                let q = self.powf(a, p - 1.0);
                let c = self.num(p);
                self.mul(c, q)
            }
            Node::Atan2(a, b) => {
                // ∂/∂a = b/(a² + b²), ∂/∂b = −a/(a² + b²)
                let a2 = self.powi(a, 2);
                let b2 = self.powi(b, 2);
                let r2 = self.add(a2, b2);
                if k == 0 {
                    self.div(b, r2)
                } else {
                    let q = self.div(a, r2);
                    self.neg(q)
                }
            }
            Node::F(f, a) => self.func_partial(f, a, id),
        }
    }

    /// `f'(a)` where `fa` is the node `f(a)`.
    fn func_partial(&mut self, f: Func, a: u32, fa: u32) -> u32 {
        let one = self.num(1.0);
        match f {
            Func::Sin => self.func(Func::Cos, a),
            Func::Cos => {
                let s = self.func(Func::Sin, a);
                self.neg(s)
            }
            // 1 + tan²a, sharing tan a with the value
            Func::Tan => {
                let t2 = self.powi(fa, 2);
                self.add(t2, one)
            }
            Func::Exp => fa,
            Func::ExpM1 => self.func(Func::Exp, a),
            Func::Ln => self.div(one, a),
            Func::Ln1p => {
                let b = self.add(a, one);
                self.div(one, b)
            }
            Func::Sqrt => {
                let two = self.num(2.0);
                let d = self.mul(two, fa);
                self.div(one, d)
            }
            Func::Cbrt => {
                let three = self.num(3.0);
                let c2 = self.powi(fa, 2);
                let d = self.mul(three, c2);
                self.div(one, d)
            }
            Func::Abs => self.func(Func::Sign, a),
            Func::Sign | Func::Trunc => self.num(0.0),
            Func::Asin | Func::Acos => {
                let a2 = self.powi(a, 2);
                let r = self.sub(one, a2);
                let s = self.func(Func::Sqrt, r);
                let d = self.div(one, s);
                if f == Func::Asin { d } else { self.neg(d) }
            }
            Func::Atan => {
                let a2 = self.powi(a, 2);
                let r = self.add(a2, one);
                self.div(one, r)
            }
            Func::Sinh => self.func(Func::Cosh, a),
            Func::Cosh => self.func(Func::Sinh, a),
            // 1/cosh²a: the form 1 − tanh²a loses every digit where tanh a → ±1
            Func::Tanh => {
                let c = self.func(Func::Cosh, a);
                self.powi(c, -2)
            }
            Func::Asinh | Func::Acosh => {
                let a2 = self.powi(a, 2);
                let r = if f == Func::Asinh {
                    self.add(a2, one)
                } else {
                    self.sub(a2, one)
                };
                let s = self.func(Func::Sqrt, r);
                self.div(one, s)
            }
            Func::Atanh => {
                let a2 = self.powi(a, 2);
                let r = self.sub(one, a2);
                self.div(one, r)
            }
        }
    }

    /// The value of node `id` given the leaves (`p` the parameters): a reference
    /// evaluator (allocating; the compiled [`Program`](super::compile::Program) is the fast one).
    pub fn eval(&self, id: u32, t: f64, x: &[f64], u: &[f64], p: &[f64]) -> f64 {
        let mut memo: HashMap<u32, f64> = HashMap::new();
        self.eval_memo(id, (t, x, u, p), &mut memo)
    }

    fn eval_memo(&self, id: u32, at: (f64, &[f64], &[f64], &[f64]), memo: &mut HashMap<u32, f64>) -> f64 {
        if let Some(&v) = memo.get(&id) {
            return v;
        }
        let (t, x, u, p) = at;
        let ev = |k: u32, memo: &mut HashMap<u32, f64>| self.eval_memo(k, at, memo);
        let v = match self.node(id) {
            Node::Const(b) => f64::from_bits(b),
            Node::State(i) => x[i as usize],
            Node::Input(k) => u[k as usize],
            Node::Time => t,
            Node::Param(k) => p[k as usize],
            Node::Neg(a) => -ev(a, memo),
            Node::Add(a, b) => ev(a, memo) + ev(b, memo),
            Node::Sub(a, b) => ev(a, memo) - ev(b, memo),
            Node::Mul(a, b) => ev(a, memo) * ev(b, memo),
            Node::Div(a, b) => ev(a, memo) / ev(b, memo),
            Node::Rem(a, b) => ev(a, memo) % ev(b, memo),
            Node::Powi(a, n) => ev(a, memo).powi(n),
            Node::Powf(a, p) => ev(a, memo).powf(f64::from_bits(p)),
            Node::Atan2(a, b) => ev(a, memo).atan2(ev(b, memo)),
            Node::F(f, a) => f.eval(ev(a, memo)),
        };
        memo.insert(id, v);
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bucket index `HashMap` takes (the low bits of the hash) spreads nodes that
    /// differ in their first operand only: `−a`, `sin a`, `a·c` for one `c`. Before the
    /// finaliser in [`FxHasher::finish`] these 4 096 nodes fell into 32 buckets of 4 096
    /// and hash-consing BRUSS was quadratic in its size.
    #[test]
    fn node_hashes_spread_over_the_low_bits() {
        use std::hash::{BuildHasher, BuildHasherDefault};
        let b = BuildHasherDefault::<FxHasher>::default();
        for make in [
            (|a| Node::Neg(a)) as fn(u32) -> Node,
            |a| Node::F(Func::Sin, a),
            |a| Node::Mul(a, 7),
            |a| Node::Add(a, 7),
        ] {
            let buckets: std::collections::HashSet<u64> = (0..4096u32).map(|a| b.hash_one(make(a)) & 4095).collect();
            assert!(buckets.len() > 2000, "{} of 4096 buckets used", buckets.len());
        }
    }

    #[test]
    fn simplifies_as_it_builds() {
        let mut g = Graph::default();
        let x = g.intern(Node::State(0));
        let y = g.intern(Node::State(1));
        let (zero, one, two) = (g.num(0.0), g.num(1.0), g.num(2.0));
        assert_eq!(g.mul(zero, x), zero);
        assert_eq!(g.mul(one, x), x);
        assert_eq!(g.add(x, zero), x);
        assert_eq!(g.sub(x, x), zero);
        assert_eq!(g.div(x, one), x);
        let nx = g.neg(x);
        assert_eq!(g.neg(nx), x);
        // hash-consing and commutative sharing
        let a = g.add(x, y);
        assert_eq!(g.add(y, x), a);
        let m = g.mul(x, two);
        assert_eq!(g.mul(two, x), m);
        assert_eq!(g.node(m), Node::Mul(two, x));
        let xy = g.mul(y, x);
        assert_eq!(g.mul(x, y), xy);
        assert_eq!(g.node(xy), Node::Mul(y, x)); // as first written
        // constant subtrees fold
        let three = g.add(one, two);
        assert_eq!(g.constant(three), Some(3.0));
        let s = g.func(Func::Sin, zero);
        assert_eq!(g.constant(s), Some(0.0));
    }
}

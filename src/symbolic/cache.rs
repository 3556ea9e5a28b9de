//! The compiled-program cache: a model rebuilt with the same structure reuses the compiled
//! Jacobian of an earlier one instead of differentiating and compiling again.
//!
//! # What is cached, keyed on what
//!
//! A `model!` body is a closure that may read anything it captures — plain values, but also
//! references to `Cell`s, slices or statics — so neither its type nor its size says what it
//! computes: a cache keyed on them would serve a stale program once a captured value changed
//! (a body reading a captured `Cell` would keep the value of its first trace). The one key
//! that names everything a compiled Jacobian depends on is the **recorded expression graph
//! itself**. So every request for a model's compiled Jacobian first *records* the body on
//! the tracing scalar ([`Sym`](super::Sym): one pass over the body, each operation one
//! hash-consed node, no differentiation), then looks up two levels:
//!
//! 1. **Traces** (exact): key = the recorded graph's nodes (every constant's bits
//!    included), the outputs and the numbers of states, inputs and parameters. A hit
//!    hands out a copy of the compiled Jacobian: no differentiation, no flattening, no
//!    code generation. Parameters of a parameter block are leaves of the graph
//!    ([`Node::Param`](super::graph::Node)), never constants, so a model rebuilt with
//!    other parameter values records the very same graph and hits; its parameters are set
//!    in the copy's constant slots.
//! 2. **Code** (structural): key = the flattened program's instructions, output slots and
//!    slot layout, with the *values* of its constant slots left out. Native code reads its
//!    constants and parameters from the program's constant array at run time (they are
//!    inputs of the code, not immediates), so a model whose captured values changed (a new
//!    graph, differentiated again) but whose program has the same shape reuses the machine
//!    code and skips the Cranelift compile, the expensive part. The shape is the same when
//!    the new values fold alike: a value that is 0, ±1 or a power of two, or that equals
//!    another constant of the body, is simplified or shared differently and gives another
//!    shape (compiled once, then cached too).
//!
//! A hit is therefore bit for bit what a fresh trace and compile would give: the graph (or
//! the program) is compared in full, not by a hash alone, and the native code depends on
//! nothing the key leaves out.
//!
//! # What a traced body may capture
//!
//! Anything: values, references, `Cell`s, statics. The compiled Jacobian a solve uses is
//! the one of the body as it records *when the solve starts* (every solve records the body
//! again), so a captured value changed between solves is seen by the next solve. A
//! captured value that changes *during* a solve (a `Cell` the caller or another thread sets
//! while it runs) is not seen by the Jacobian of that solve, only by its right-hand side,
//! as with any Jacobian the implicit methods reuse across steps: change such values
//! between solves. To sweep a value without even differentiating again, make it a
//! parameter (`model!(|_, x: [S; N], p: [S; P] = [...]| …)`): parameters are inputs of the
//! compiled code; captured `f64`s are folded into the graph as constants, and a new value
//! is a new graph (differentiated again, with the machine code reused when its shape
//! allows).
//!
//! The cache holds at most [`MAX_ENTRIES`] graphs and [`MAX_ENTRIES`] native programs,
//! [`MAX_BYTES`] of keys and compiled Jacobians, dropping the oldest first; a single
//! graph larger than that is compiled but not kept.
//!
//! ```
//! use reckon::{model, symbolic, System};
//! use nalgebra::DVector;
//! // a chain x_i' = −k·x_i + x_{i+1} (k a parameter): built twice with other values
//! let build = |k: f64| model!(|_, x: [S; Dyn], p: [S; 1] = [k]| {
//!     let n = x.len();
//!     DVector::from_fn(n, |i, _| -(p[0].clone() * x[i].clone()) + if i + 1 < n { x[i + 1].clone() } else { S::from(0.0) })
//! });
//! let (a, b) = (build(2.0), build(3.0));
//! let mut ja = a.sparse_jacobian(70).unwrap();
//! let mut jb = b.sparse_jacobian(70).unwrap();
//! assert_eq!((b.traces(), b.compiles()), (0, 0)); // the second build reused the first's program
//! let (x, mut va, mut vb) = (vec![1.0; 70], vec![0.0; 139], vec![0.0; 139]);
//! ja.eval(0.0, &x, &[], &mut va).unwrap();
//! jb.eval(0.0, &x, &[], &mut vb).unwrap();
//! assert_eq!((va[0], vb[0]), (-2.0, -3.0)); // ∂ẋ₀/∂x₀ = −k for each model's own k
//! assert!(symbolic::cache_stats().trace_hits >= 1);
//! ```

use super::compile::{CompiledJacobian, Ins, Program};
use super::graph::{FxHasher, Graph, Node};
use super::jit::{self, Layout, Native};
use std::hash::{Hash, Hasher};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// At most this many traced graphs, and as many native programs, are kept.
pub const MAX_ENTRIES: usize = 64;
/// At most this many bytes of traced graphs (the keys) and compiled Jacobians are kept.
pub const MAX_BYTES: usize = 256 << 20;

/// Counters of the compiled-program cache since the process started (all threads):
/// `records` bodies recorded as a key, `traces` of them differentiated and flattened (a
/// miss), `trace_hits` served a cached compiled Jacobian, `compiles` native programs
/// generated, `code_hits` native programs reused.
///
/// ```
/// use reckon::{model, symbolic, System};
/// use nalgebra::DVector;
/// let f = || model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].sin() * 0.25));
/// let before = symbolic::cache_stats();
/// let _ = f().sparse_jacobian(65).unwrap();
/// let _ = f().sparse_jacobian(65).unwrap();
/// let after = symbolic::cache_stats();
/// assert!(after.records >= before.records + 2);
/// assert!(after.trace_hits >= before.trace_hits + 1);
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CacheStats {
    /// Bodies recorded on the tracing scalar to look the cache up.
    pub records: u64,
    /// Recorded graphs differentiated and flattened (not in the cache).
    pub traces: u64,
    /// Recorded graphs found in the cache (no differentiation, no compile).
    pub trace_hits: u64,
    /// Native programs generated with Cranelift.
    pub compiles: u64,
    /// Native programs found in the cache (no Cranelift compile).
    pub code_hits: u64,
}

static RECORDS: AtomicU64 = AtomicU64::new(0);
static TRACES: AtomicU64 = AtomicU64::new(0);
static TRACE_HITS: AtomicU64 = AtomicU64::new(0);
static COMPILES: AtomicU64 = AtomicU64::new(0);
static CODE_HITS: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Native programs generated on this thread (for a model's own counter).
    static LOCAL_COMPILES: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// The cache's counters now ([`CacheStats`]).
pub fn cache_stats() -> CacheStats {
    CacheStats {
        records: RECORDS.load(Ordering::Relaxed),
        traces: TRACES.load(Ordering::Relaxed),
        trace_hits: TRACE_HITS.load(Ordering::Relaxed),
        compiles: COMPILES.load(Ordering::Relaxed),
        code_hits: CODE_HITS.load(Ordering::Relaxed),
    }
}

/// Empty the cache (the counters keep counting): the next request for every model's
/// compiled Jacobian traces and compiles again. For measurements of the cold cost.
///
/// ```
/// use reckon::{model, symbolic, System};
/// use nalgebra::DVector;
/// let f = model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].cos() * 0.5 + 0.125));
/// let _ = f.sparse_jacobian(66).unwrap();
/// symbolic::clear_cache();
/// let _ = f.sparse_jacobian(66).unwrap();
/// assert!(f.traces() >= 1); // traced again after the clear (also when another test cached it)
/// ```
pub fn clear_cache() {
    lock(&GRAPHS).clear();
    lock(&CODE).clear();
}

fn lock<T>(m: &'static Mutex<T>) -> std::sync::MutexGuard<'static, T> {
    // a panic while holding the lock leaves a consistent cache (entries are pushed whole)
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Oldest-first bounded list of `(hash, key, value, bytes)`.
struct Fifo<K, V> {
    items: std::collections::VecDeque<(u64, Arc<K>, V, usize)>,
    bytes: usize,
}

impl<K: PartialEq, V: Clone> Fifo<K, V> {
    const fn new() -> Self {
        Fifo {
            items: std::collections::VecDeque::new(),
            bytes: 0,
        }
    }
    fn get(&self, hash: u64, key: &K) -> Option<V> {
        self.items
            .iter()
            .find(|e| e.0 == hash && *e.1 == *key)
            .map(|e| e.2.clone())
    }
    fn insert(&mut self, hash: u64, key: Arc<K>, value: V, bytes: usize) {
        if bytes > MAX_BYTES || self.get(hash, &key).is_some() {
            return;
        }
        while !self.items.is_empty() && (self.items.len() >= MAX_ENTRIES || self.bytes + bytes > MAX_BYTES) {
            if let Some(e) = self.items.pop_front() {
                self.bytes -= e.3;
            }
        }
        self.bytes += bytes;
        self.items.push_back((hash, key, value, bytes));
    }
    fn clear(&mut self) {
        self.items.clear();
        self.bytes = 0;
    }
}

/// A recorded graph: everything a compiled Jacobian depends on.
#[derive(PartialEq)]
struct GraphKey {
    n: usize,
    m: usize,
    np: usize,
    nodes: Vec<Node>,
    f: Vec<u32>,
}

/// A program's shape: everything its native code depends on (not its constants' values).
#[derive(PartialEq)]
struct CodeKey {
    ins: Vec<Ins>,
    outputs: Vec<u32>,
    consts: usize,
    slots: usize,
    layouts: Vec<(Vec<usize>, Vec<usize>)>,
}

static GRAPHS: Mutex<Fifo<GraphKey, CompiledJacobian>> = Mutex::new(Fifo::new());
static CODE: Mutex<Fifo<CodeKey, Arc<Native>>> = Mutex::new(Fifo::new());

/// What a request for a compiled Jacobian did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// Served from the cache: no differentiation, no compile.
    Hit,
    /// Differentiated and flattened; `compiled` when native code was generated (not
    /// found in the code cache).
    Traced { compiled: bool },
}

/// What a model's [`System::sparse_jacobian`](crate::System::sparse_jacobian) calls did
/// ([`System::trace_counts`](crate::System::trace_counts)): `records` bodies recorded
/// (one per call, the cache's key), `traces` of them differentiated and flattened (not in
/// the cache), `compiles` native programs generated (no program of the same shape cached).
///
/// ```
/// use reckon::{model, symbolic::TraceCounts, System};
/// use nalgebra::DVector;
/// let build = || model!(|_, x: [S; Dyn]| DVector::from_fn(x.len(), |i, _| x[i].sin() * 0.0625));
/// let _ = build().sparse_jacobian(74).unwrap();
/// let again = build();
/// let _ = again.sparse_jacobian(74).unwrap();
/// assert_eq!(again.trace_counts(), TraceCounts { records: 1, traces: 0, compiles: 0 });
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraceCounts {
    /// Bodies recorded on the tracing scalar.
    pub records: usize,
    /// Recordings differentiated and flattened (cache misses).
    pub traces: usize,
    /// Native programs generated.
    pub compiles: usize,
}

/// A model's own counters of its compiled-Jacobian requests.
#[derive(Debug, Default)]
pub(crate) struct Counters {
    pub(crate) records: AtomicUsize,
    pub(crate) traces: AtomicUsize,
    pub(crate) compiles: AtomicUsize,
    /// Nodes of the last recording (room made for the next).
    pub(crate) last_nodes: AtomicUsize,
}

impl Counters {
    pub(crate) fn count(&self, outcome: Outcome) {
        self.records.fetch_add(1, Ordering::Relaxed);
        if let Outcome::Traced { compiled } = outcome {
            self.traces.fetch_add(1, Ordering::Relaxed);
            if compiled {
                self.compiles.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
    pub(crate) fn get(c: &AtomicUsize) -> usize {
        c.load(Ordering::Relaxed)
    }
    pub(crate) fn counts(&self) -> TraceCounts {
        TraceCounts {
            records: Self::get(&self.records),
            traces: Self::get(&self.traces),
            compiles: Self::get(&self.compiles),
        }
    }
}

/// Count one recording (the key of a lookup).
pub(crate) fn recorded() {
    RECORDS.fetch_add(1, Ordering::Relaxed);
}

/// The compiled `∂f/∂x` of the recorded graph `g` with outputs `f`, from the cache or
/// differentiated and compiled now (`build` turns the graph into a compiled Jacobian),
/// with the parameters set to `p`.
pub(crate) fn compiled_jacobian(
    g: Graph,
    f: Vec<u32>,
    (n, m, p): (usize, usize, &[f64]),
    build: impl FnOnce(Graph, Vec<u32>) -> CompiledJacobian,
) -> (CompiledJacobian, Outcome) {
    let key = GraphKey {
        n,
        m,
        np: p.len(),
        nodes: g.nodes().to_vec(),
        f,
    };
    let mut h = FxHasher::default();
    (key.n, key.m, key.np).hash(&mut h);
    key.nodes.hash(&mut h);
    key.f.hash(&mut h);
    let hash = h.finish();
    let found = lock(&GRAPHS).get(hash, &key);
    if let Some(mut jac) = found {
        TRACE_HITS.fetch_add(1, Ordering::Relaxed);
        jac.set_params(p);
        return (jac, Outcome::Hit);
    }
    TRACES.fetch_add(1, Ordering::Relaxed);
    let before = LOCAL_COMPILES.with(|c| c.get());
    let jac = build(g, key.f.clone());
    let compiled = LOCAL_COMPILES.with(|c| c.get()) > before;
    let bytes = key.nodes.len() * std::mem::size_of::<Node>() + key.f.len() * 4 + jac.bytes();
    lock(&GRAPHS).insert(hash, Arc::new(key), jac.clone(), bytes);
    (jac, Outcome::Traced { compiled })
}

/// Native code for `program` with one function per layout: from the cache when a program
/// of the same shape was compiled before (its constants are read at run time), else
/// generated now; `None` when the program is too long or the host unsupported.
pub(crate) fn native_code(program: &Program, layouts: &[Layout]) -> Option<Arc<Native>> {
    if program.len() > jit::MAX_NATIVE_INSTRUCTIONS {
        return None;
    }
    let (template, ins, outputs) = program.parts();
    let key = CodeKey {
        ins: ins.to_vec(),
        outputs: outputs.to_vec(),
        consts: program.consts(),
        slots: template.len(),
        layouts: layouts.iter().map(|l| (l.offsets.clone(), l.zeros.clone())).collect(),
    };
    let mut h = FxHasher::default();
    key.ins.hash(&mut h);
    key.outputs.hash(&mut h);
    (key.consts, key.slots).hash(&mut h);
    key.layouts.hash(&mut h);
    let hash = h.finish();
    if let Some(code) = lock(&CODE).get(hash, &key) {
        CODE_HITS.fetch_add(1, Ordering::Relaxed);
        return Some(code);
    }
    // compiled outside the lock: two threads may compile the same shape once each
    let code = jit::compile(program, layouts)?;
    COMPILES.fetch_add(1, Ordering::Relaxed);
    LOCAL_COMPILES.with(|c| c.set(c.get() + 1));
    lock(&CODE).insert(hash, Arc::new(key), code.clone(), 0);
    Some(code)
}

//! Symbolic differentiation by forward accumulation of sparse gradients.
//!
//! Every node `v` reachable from the roots gets its gradient `∇v` as a sorted list of
//! `(variable, ∂v/∂variable)` pairs, the derivatives themselves nodes of the same graph
//! (so they are simplified and share subexpressions with the values): a leaf variable
//! has `[(k, 1)]`, a constant `[]`, and an operation `v = φ(a, b)` has
//! `∇v = ∂φ/∂a·∇a + ∂φ/∂b·∇b` merged by variable. Only variables a node depends on
//! appear in its list, so the work is proportional to the number of non-zeros of the
//! Jacobian times the depth of the body, not to `n²`; a node's list is dropped once all
//! its users have been processed.

use super::graph::{Graph, Node};

/// `(variable, derivative node)`, sorted by variable.
pub(crate) type Grad = Vec<(u32, u32)>;

/// The gradients of `roots` with respect to the leaves that `var_of` maps to a variable
/// index (other leaves are constants).
pub(crate) fn gradients(g: &mut Graph, roots: &[u32], var_of: impl Fn(Node) -> Option<u32>) -> Vec<Grad> {
    let len = g.len();
    // reachable nodes and their number of users among them
    let mut uses = vec![0u32; len];
    let mut reach = vec![false; len];
    let mut stack: Vec<u32> = roots.to_vec();
    for &r in roots {
        uses[r as usize] += 1; // a root is kept to the end
    }
    while let Some(id) = stack.pop() {
        if reach[id as usize] {
            continue;
        }
        reach[id as usize] = true;
        let (args, k) = g.node(id).args();
        for &a in &args[..k] {
            uses[a as usize] += 1;
            if !reach[a as usize] {
                stack.push(a);
            }
        }
    }
    let mut grads: Vec<Grad> = vec![Vec::new(); len];
    for id in 0..len as u32 {
        if !reach[id as usize] {
            continue;
        }
        let node = g.node(id);
        let (args, k) = node.args();
        let grad = if k == 0 {
            match var_of(node) {
                Some(v) => vec![(v, g.num(1.0))],
                None => Vec::new(),
            }
        } else {
            let mut acc: Grad = Vec::new();
            for (slot, &a) in args[..k].iter().enumerate() {
                if grads[a as usize].is_empty() {
                    continue;
                }
                let p = partial(g, id, slot);
                let part: Grad = grads[a as usize].iter().map(|&(v, d)| (v, g.mul(p, d))).collect();
                acc = merge(g, acc, part);
            }
            // a pair that cancelled (`x − x` inside a larger body) is no entry
            acc.retain(|&(_, d)| g.constant(d) != Some(0.0));
            acc
        };
        for &a in &args[..k] {
            let u = &mut uses[a as usize];
            *u -= 1;
            if *u == 0 {
                grads[a as usize] = Vec::new();
            }
        }
        grads[id as usize] = grad;
    }
    roots.iter().map(|&r| grads[r as usize].clone()).collect()
}

/// `∂node/∂(operand k)`, with the quotient rule as `−a/b²` (the form a reader expects).
fn partial(g: &mut Graph, id: u32, k: usize) -> u32 {
    if let (Node::Div(a, b), 1) = (g.node(id), k) {
        let b2 = g.powi(b, 2);
        let q = g.div(a, b2);
        return g.neg(q);
    }
    g.partial(id, k)
}

/// The sum of two sorted gradients.
fn merge(g: &mut Graph, a: Grad, b: Grad) -> Grad {
    if a.is_empty() {
        return b;
    }
    if b.is_empty() {
        return a;
    }
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].0.cmp(&b[j].0) {
            std::cmp::Ordering::Less => {
                out.push(a[i]);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push(b[j]);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                out.push((a[i].0, g.add(a[i].1, b[j].1)));
                i += 1;
                j += 1;
            }
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

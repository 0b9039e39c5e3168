//! Symbolic derivatives on the graph: forward mode ([`diff`], for Jacobians and canonical
//! equations) and reverse mode ([`gradient`], for ∇V and ∇H, whose cost must stay a small
//! multiple of the function's). Pure graph operations: lowering (Hamilton's equations) and the
//! derive stage (Df, ∇V) both use them.
//!
//! The parameters m of the elliptic functions (sn(u | m), K(m), …) are held fixed: their
//! derivatives are not implemented (they need the integral of the second kind, DLMF 19.4,
//! 22.16), and none is needed, because lowering refuses a parameter m that depends on the
//! state and derivatives are taken with respect to the state only.

use super::{Graph, Id, Input, Node, Rational};
use std::collections::HashMap;

/// ∂(root)/∂(var), memoised in `memo` (one memo per variable).
pub fn diff(g: &mut Graph, root: Id, var: Input, memo: &mut HashMap<Id, Id>) -> Id {
    // Iterative post-order over the reachable nodes, so deep expressions cannot overflow the stack.
    for id in g.reachable(&[root]) {
        if memo.contains_key(&id) {
            continue;
        }
        let d = match g.node(id).clone() {
            Node::Num(_) => g.num(0.0),
            Node::Input(i) => g.num(if i == var { 1.0 } else { 0.0 }),
            Node::Add(c) => {
                let ds: Vec<Id> = c.iter().map(|k| memo[k]).collect();
                g.add(&ds)
            }
            Node::Mul(c) => {
                let mut terms = Vec::new();
                for (i, k) in c.iter().enumerate() {
                    let dk = memo[k];
                    if g.as_num(dk) == Some(0.0) {
                        continue;
                    }
                    terms.push(g.mul(&others_times(&c, i, dk)));
                }
                g.add(&terms)
            }
            Node::Pow(b, e) => {
                let db = memo[&b];
                if g.as_num(db) == Some(0.0) {
                    db
                } else {
                    let local = local_pow(g, b, e);
                    g.mul(&[local, db])
                }
            }
            Node::Func(f, a) => {
                let da = memo[&a];
                match f.derivative(g, id, a) {
                    Some(local) if g.as_num(da) != Some(0.0) => g.mul(&[local, da]),
                    _ => g.num(0.0), // a parameter m is held fixed (module docs)
                }
            }
            Node::Func2(f, [x, m]) => {
                let dx = memo[&x];
                if g.as_num(dx) == Some(0.0) {
                    dx
                } else {
                    let local = f.derivative(g, x, m);
                    g.mul(&[local, dx])
                }
            }
        };
        memo.insert(id, d);
    }
    memo[&root]
}

/// The factors of a product except the i-th, and `extra`: ∂(Π cⱼ)/∂cᵢ · extra.
fn others_times(c: &[Id], i: usize, extra: Id) -> Vec<Id> {
    c.iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(_, &f)| f)
        .chain([extra])
        .collect()
}

/// d(bᵉ)/db = e·bᵉ⁻¹.
fn local_pow(g: &mut Graph, b: Id, e: Rational) -> Id {
    let c = g.num(e.to_f64());
    let p = match e.checked_add(Rational::int(-1)) {
        Some(e1) => g.pow(b, e1),
        None => {
            let (pe, inv) = (g.pow(b, e), g.pow(b, Rational::int(-1)));
            g.mul(&[pe, inv])
        }
    };
    g.mul(&[c, p])
}

/// The gradient of `root` with respect to `vars` in reverse mode: one backward sweep over the
/// DAG accumulates the adjoint of every node, so the gradient costs a small constant times
/// the function, whatever the number of variables.
pub fn gradient(g: &mut Graph, root: Id, vars: &[Input]) -> Vec<Id> {
    let order = g.reachable(&[root]);
    let mut contributions: HashMap<Id, Vec<Id>> = HashMap::new();
    let one = g.num(1.0);
    contributions.insert(root, vec![one]);
    let mut adjoint_of_input: HashMap<Input, Id> = HashMap::new();
    for &id in order.iter().rev() {
        let Some(parts) = contributions.remove(&id) else {
            continue;
        };
        let adj = g.add(&parts);
        if g.as_num(adj) == Some(0.0) {
            continue;
        }
        let push = |child: Id, c: Id, contributions: &mut HashMap<Id, Vec<Id>>| {
            contributions.entry(child).or_default().push(c);
        };
        match g.node(id).clone() {
            Node::Num(_) => {}
            Node::Input(i) => {
                adjoint_of_input.insert(i, adj);
            }
            Node::Add(c) => c.iter().for_each(|&k| push(k, adj, &mut contributions)),
            Node::Mul(c) => {
                for (i, &k) in c.iter().enumerate() {
                    if matches!(g.node(k), Node::Num(_)) {
                        continue;
                    }
                    let t = g.mul(&others_times(&c, i, adj));
                    push(k, t, &mut contributions);
                }
            }
            Node::Pow(b, e) => {
                let local = local_pow(g, b, e);
                let t = g.mul(&[adj, local]);
                push(b, t, &mut contributions);
            }
            Node::Func(f, a) => {
                if let Some(local) = f.derivative(g, id, a) {
                    let t = g.mul(&[adj, local]);
                    push(a, t, &mut contributions);
                }
            }
            Node::Func2(f, [x, m]) => {
                // m is held fixed (module docs): no adjoint flows into it
                let local = f.derivative(g, x, m);
                let t = g.mul(&[adj, local]);
                push(x, t, &mut contributions);
            }
        }
    }
    vars.iter()
        .map(|v| {
            adjoint_of_input
                .get(v)
                .copied()
                .unwrap_or_else(|| g.num(0.0))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::Func;

    /// d/dx of x³·sin(x) at x = 0.7, forward and reverse, against the hand derivative.
    #[test]
    fn forward_and_reverse_agree_with_hand_derivative() {
        let mut g = Graph::new();
        let x = g.input(Input::State(0));
        let x3 = g.pow(x, Rational::int(3));
        let s = g.func(Func::Sin, x);
        let f = g.mul(&[x3, s]);
        let fwd = diff(&mut g, f, Input::State(0), &mut HashMap::new());
        let rev = gradient(&mut g, f, &[Input::State(0)])[0];
        let at = |g: &Graph, id| g.eval_f64(&[id], &mut |_| 0.7)[0];
        let hand = 3.0 * 0.7f64.powi(2) * 0.7f64.sin() + 0.7f64.powi(3) * 0.7f64.cos();
        assert!((at(&g, fwd) - hand).abs() < 1e-15);
        assert!((at(&g, rev) - hand).abs() < 1e-15);
    }

    #[test]
    fn gradient_of_a_quadratic_form() {
        // V = ½(x² + 3y²) ⇒ ∇V = (x, 3y)
        let mut g = Graph::new();
        let x = g.input(Input::State(0));
        let y = g.input(Input::State(1));
        let x2 = g.pow(x, Rational::int(2));
        let y2 = g.pow(y, Rational::int(2));
        let three = g.num(3.0);
        let y23 = g.mul(&[three, y2]);
        let half = g.num(0.5);
        let s = g.add(&[x2, y23]);
        let v = g.mul(&[half, s]);
        let grad = gradient(&mut g, v, &[Input::State(0), Input::State(1)]);
        assert_eq!(grad[0], x);
        assert_eq!(g.display(grad[1]), "3*x1");
    }
}

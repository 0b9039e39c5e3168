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

/// The Jacobian `∂roots[c]/∂vars[i]` (row c, column i) by forward mode, each column computed
/// on the nodes that depend on its variable only: the ancestors of the variable's leaf, found
/// by walking up from it, each sum or product differentiated through the children it was
/// reached from. The cost is the sum over the variables of the nodes depending on each (with
/// their edges), not the whole graph per variable as [`diff`] pays: on the N-body model the
/// graph has O(N²) nodes, each variable's column O(N) of them. The derivatives are the same
/// expressions as [`diff`]'s, built in another order (so with other Ids).
pub fn jacobian(g: &mut Graph, roots: &[Id], vars: &[Input]) -> Vec<Vec<Id>> {
    let order = g.reachable(roots);
    // Dense positions in `order`, and each node's users within it.
    let mut position = vec![u32::MAX; g.len()];
    for (k, &id) in order.iter().enumerate() {
        position[id.index()] = k as u32;
    }
    let mut users: Vec<Vec<u32>> = vec![Vec::new(); order.len()];
    for (k, &id) in order.iter().enumerate() {
        for &c in g.children(id) {
            let list = &mut users[position[c.index()] as usize];
            if list.last() != Some(&(k as u32)) {
                list.push(k as u32);
            }
        }
    }
    let zero = g.num(0.0);
    let one = g.num(1.0);
    let mut columns: Vec<Vec<Id>> = Vec::with_capacity(vars.len());
    // Per column: the stamp of the nodes depending on the variable, their derivatives.
    let mut stamp = vec![usize::MAX; order.len()];
    let mut derivative: Vec<Id> = vec![zero; order.len()];
    for (column, &var) in vars.iter().enumerate() {
        let leaf = g.find(&Node::Input(var)).map(|id| position[id.index()]);
        let Some(leaf) = leaf.filter(|&k| k != u32::MAX) else {
            columns.push(vec![zero; roots.len()]);
            continue;
        };
        let mut ancestors = vec![leaf];
        stamp[leaf as usize] = column;
        let mut k = 0;
        while k < ancestors.len() {
            let at = ancestors[k] as usize;
            k += 1;
            for &u in &users[at] {
                if stamp[u as usize] != column {
                    stamp[u as usize] = column;
                    ancestors.push(u);
                }
            }
        }
        ancestors.sort_unstable();
        let d = |k: Id, stamp: &[usize], derivative: &[Id]| {
            let p = position[k.index()] as usize;
            (stamp[p] == column).then(|| derivative[p])
        };
        for &at in &ancestors {
            let id = order[at as usize];
            let result = match g.node(id).clone() {
                Node::Num(_) => zero,
                Node::Input(_) => one,
                Node::Add(c) => {
                    let ds: Vec<Id> = c
                        .iter()
                        .filter_map(|&k| d(k, &stamp, &derivative))
                        .collect();
                    g.add(&ds)
                }
                Node::Mul(c) => {
                    let mut terms = Vec::new();
                    for (i, &k) in c.iter().enumerate() {
                        match d(k, &stamp, &derivative) {
                            Some(dk) if g.as_num(dk) != Some(0.0) => {
                                terms.push(g.mul(&others_times(&c, i, dk)));
                            }
                            _ => {}
                        }
                    }
                    g.add(&terms)
                }
                Node::Pow(b, e) => match d(b, &stamp, &derivative) {
                    Some(db) if g.as_num(db) != Some(0.0) => {
                        let local = local_pow(g, b, e);
                        g.mul(&[local, db])
                    }
                    _ => zero,
                },
                Node::Func(f, a) => match d(a, &stamp, &derivative) {
                    Some(da) if g.as_num(da) != Some(0.0) => match f.derivative(g, id, a) {
                        Some(local) => g.mul(&[local, da]),
                        None => zero, // a parameter m is held fixed (module docs)
                    },
                    _ => zero,
                },
                Node::Func2(f, [x, m]) => match d(x, &stamp, &derivative) {
                    Some(dx) if g.as_num(dx) != Some(0.0) => {
                        let local = f.derivative(g, x, m);
                        g.mul(&[local, dx])
                    }
                    _ => zero,
                },
            };
            derivative[at as usize] = result;
        }
        columns.push(
            roots
                .iter()
                .map(|&r| d(r, &stamp, &derivative).unwrap_or(zero))
                .collect(),
        );
    }
    (0..roots.len())
        .map(|c| columns.iter().map(|col| col[c]).collect())
        .collect()
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

    /// The sparse Jacobian against [`diff`], entry by entry (same values at a point), on
    /// functions of three variables with sums, products, powers and sin, one of them free of a
    /// variable and one variable absent from the graph.
    #[test]
    fn the_sparse_jacobian_is_the_forward_jacobian() {
        let mut g = Graph::new();
        let [x, y, z] = [0, 1, 2].map(|i| g.input(Input::State(i)));
        let p = g.input(Input::Param(0));
        let s = g.func(Func::Sin, x);
        let xy = g.mul(&[x, y, p]);
        let r2 = {
            let (x2, y2) = (g.pow(x, Rational::int(2)), g.pow(y, Rational::int(2)));
            g.add(&[x2, y2, p])
        };
        let inv_r = g.pow(r2, Rational::new(-1, 2));
        let f0 = g.add(&[s, xy, inv_r]);
        let f1 = g.mul(&[z, inv_r]);
        let f2 = g.mul(&[p, p]);
        let roots = [f0, f1, f2];
        let vars = [
            Input::State(0),
            Input::State(1),
            Input::State(2),
            Input::State(3),
        ];
        let sparse = jacobian(&mut g, &roots, &vars);
        let at = |g: &Graph, id| {
            g.eval_f64(&[id], &mut |i| match i {
                Input::State(k) => [0.7, -1.3, 2.1, 0.4][k as usize],
                _ => 0.35,
            })[0]
        };
        for (c, &f) in roots.iter().enumerate() {
            for (i, &v) in vars.iter().enumerate() {
                let dense = diff(&mut g, f, v, &mut HashMap::new());
                let (a, b) = (at(&g, sparse[c][i]), at(&g, dense));
                assert!(
                    (a - b).abs() <= 1e-15 * b.abs().max(1.0),
                    "∂f{c}/∂x{i}: {a} against {b}"
                );
            }
        }
        assert_eq!(g.as_num(sparse[2][0]), Some(0.0));
        assert_eq!(g.as_num(sparse[0][3]), Some(0.0));
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

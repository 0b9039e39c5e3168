//! Operation counts of expressions, as the emitted code will execute them.

use super::{Graph, Id, Node};

/// Floating-point operations needed to evaluate a set of outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCount {
    /// Counting every use of a shared subexpression again (the expression as a tree).
    pub tree: u64,
    /// Counting each distinct subexpression once (after common-subexpression elimination).
    pub dag: u64,
}

impl Graph {
    /// Operations of one node on its own: k−1 for a k-ary sum or product, the cost of the
    /// power (multiplications, a division, a square root), 1 for a function.
    pub fn node_ops(&self, id: Id) -> u64 {
        match self.node(id) {
            Node::Num(_) | Node::Input(_) => 0,
            Node::Add(c) | Node::Mul(c) => c.len() as u64 - 1,
            Node::Pow(_, e) => {
                let n = e.num.unsigned_abs() as u64;
                let int_part = if e.is_int() { n } else { n / 2 + 1 };
                let mults = if e.is_int() {
                    64 - n.leading_zeros() as u64 - 1 + n.count_ones() as u64 - 1
                } else {
                    int_part.min(3)
                };
                mults + u64::from(e.num < 0) + u64::from(!e.is_int())
            }
            Node::Func(..) | Node::Func2(..) => 1,
        }
    }

    /// Operation counts of evaluating all of `outputs`.
    pub fn op_count(&self, outputs: &[Id]) -> OpCount {
        let order = self.reachable(outputs);
        let dag = order.iter().map(|&id| self.node_ops(id)).sum();
        let mut tree_of = vec![0u64; self.len()];
        for &id in &order {
            tree_of[id.index()] = self.children(id).iter().fold(self.node_ops(id), |acc, c| {
                acc.saturating_add(tree_of[c.index()])
            });
        }
        let tree = outputs
            .iter()
            .fold(0u64, |acc, o| acc.saturating_add(tree_of[o.index()]));
        OpCount { tree, dag }
    }
}

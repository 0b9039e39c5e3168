//! Full expansion of products of sums, used to prove identities such as ∇f · X = 0.
//!
//! Expansion can blow up, so it runs under a term budget and gives up (returns `None`) past it.

use super::{Graph, Id, Node};
use std::collections::HashMap;

/// Total products of terms an expansion may form, in units of its term limit.
const WORK_FACTOR: usize = 64;

/// What an expansion may still do.
struct Budget {
    /// Most terms in one intermediate sum.
    max_terms: usize,
    /// Products of terms left to form.
    work: usize,
}

impl Graph {
    /// The expanded form of `root` (products of sums multiplied out, positive integer powers
    /// of sums expanded), or `None` if some intermediate sum exceeds `max_terms` terms, or the
    /// whole expansion forms more than `WORK_FACTOR · max_terms` products of terms (so that
    /// `(a + b)^999999` gives up at once rather than multiplying for minutes).
    ///
    /// The nodes are expanded in topological order, children first, so a deep expression (a
    /// chain of 50 000 `let`s) cannot overflow the stack.
    pub fn expand(&mut self, root: Id, max_terms: usize) -> Option<Id> {
        let mut memo: HashMap<Id, Id> = HashMap::new();
        let mut budget = Budget {
            max_terms,
            work: max_terms.saturating_mul(WORK_FACTOR),
        };
        for id in self.reachable(&[root]) {
            let e = self.expand_node(id, &mut budget, &memo)?;
            memo.insert(id, e);
        }
        memo.get(&root).copied()
    }

    fn terms(&self, id: Id) -> Vec<Id> {
        match self.node(id) {
            Node::Add(c) => c.to_vec(),
            _ => vec![id],
        }
    }

    fn product_of_sums(&mut self, a: Id, b: Id, budget: &mut Budget) -> Option<Id> {
        let (ta, tb) = (self.terms(a), self.terms(b));
        let products = ta.len() * tb.len();
        if products > budget.max_terms || products > budget.work {
            return None;
        }
        budget.work -= products;
        let mut out = Vec::with_capacity(ta.len() * tb.len());
        for &x in &ta {
            for &y in &tb {
                out.push(self.mul(&[x, y]));
            }
        }
        Some(self.add(&out))
    }

    /// The expansion of one node whose children are expanded in `memo`.
    fn expand_node(&mut self, id: Id, budget: &mut Budget, memo: &HashMap<Id, Id>) -> Option<Id> {
        let result = match self.node(id).clone() {
            Node::Num(_) | Node::Input(_) => id,
            Node::Add(c) => {
                let c: Vec<Id> = c.iter().map(|k| memo[k]).collect();
                self.add(&c)
            }
            Node::Mul(c) => {
                let mut acc = self.num(1.0);
                for k in c.iter() {
                    acc = self.product_of_sums(acc, memo[k], budget)?;
                }
                acc
            }
            Node::Pow(b, e) => {
                let base = memo[&b];
                if e.is_int() && e.num > 0 && matches!(self.node(base), Node::Add(_)) {
                    // An m-term sum to the power e generically has e·(m − 1) + 1 terms or more
                    // (fewer only by cancellation, which then goes unproved).
                    let m = self.terms(base).len();
                    if (e.num as usize).saturating_mul(m - 1) >= budget.max_terms {
                        return None;
                    }
                    let mut acc = base;
                    for _ in 1..e.num {
                        acc = self.product_of_sums(acc, base, budget)?;
                    }
                    acc
                } else {
                    self.pow(base, e)
                }
            }
            Node::Func(f, a) => {
                let a = memo[&a];
                self.func(f, a)
            }
            Node::Func2(f, [x, m]) => self.func2(f, memo[&x], memo[&m]),
        };
        Some(result)
    }
}

#[cfg(test)]
mod tests {
    use crate::ir::{Graph, Input, Rational};

    #[test]
    fn expansion_proves_a_polynomial_identity() {
        // (x + y)² − x² − 2xy − y² ⇒ 0
        let mut g = Graph::new();
        let x = g.input(Input::State(0));
        let y = g.input(Input::State(1));
        let s = g.add(&[x, y]);
        let s2 = g.pow(s, Rational::int(2));
        let x2 = g.pow(x, Rational::int(2));
        let y2 = g.pow(y, Rational::int(2));
        let two = g.num(2.0);
        let xy2 = g.mul(&[two, x, y]);
        let rhs = g.add(&[x2, xy2, y2]);
        let d = g.sub(s2, rhs);
        let e = g.expand(d, 1000).unwrap();
        assert_eq!(g.as_num(e), Some(0.0));
    }
}

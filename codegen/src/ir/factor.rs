//! Rewrites for emission, applied after every check: they change rounding, not values.
//!
//! - Sums are factored greedily: `k·a·x + k·b·x + c → k·x·(a + b) + c` (Horner-like), which
//!   saves the multiplications a hand-written formula would not repeat.
//! - Products share sub-products: when the pair `a·b` occurs in several products, it becomes
//!   one node used by all of them (hash-consed products are flat, so this sharing is not
//!   automatic).

use super::{Graph, Id, Node};
use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet, HashMap};

impl Graph {
    /// The roots rewritten by both passes, for emission.
    pub fn optimize_for_emission(&mut self, roots: &[Id]) -> Vec<Id> {
        let factored = self.factor_sums(roots);
        self.share_products(&factored)
    }

    /// Factors common factors out of every sum reachable from `roots`.
    pub fn factor_sums(&mut self, roots: &[Id]) -> Vec<Id> {
        self.rebuild(roots, |g, node| match node {
            Node::Add(terms) => Some(g.factor_sum(terms.to_vec())),
            _ => None,
        })
    }

    /// The non-numeric factors of a term.
    fn factors_of(&self, t: Id) -> Vec<Id> {
        match self.node(t) {
            Node::Mul(fs) => fs
                .iter()
                .copied()
                .filter(|&f| self.as_num(f).is_none())
                .collect(),
            Node::Num(_) => Vec::new(),
            _ => vec![t],
        }
    }

    /// `t / f` for a factor `f` of the term `t`.
    fn without_factor(&mut self, t: Id, f: Id) -> Id {
        match self.node(t).clone() {
            Node::Mul(fs) => {
                let mut rest: Vec<Id> = fs.to_vec();
                let k = rest
                    .iter()
                    .position(|&x| x == f)
                    .expect("f is a factor of t");
                rest.remove(k);
                self.mul(&rest)
            }
            _ => self.num(1.0),
        }
    }

    /// Groups the terms of a sum by their most frequent factor, repeatedly: each round takes
    /// the factor that occurs in most terms (ties: the first seen, scanning the terms in order
    /// and each term's factors in order), factors it out of the terms that hold it (the
    /// quotients are factored in turn), and appends the grouped term to the remaining ones.
    ///
    /// The counts are kept up to date as terms leave and the grouped term arrives, rather than
    /// recounted each round, so a long sum whose terms share factors pairwise
    /// (`b0·b1 + b1·b2 + …`, one round per term) costs O(n log n), not O(n²).
    fn factor_sum(&mut self, terms: Vec<Id>) -> Id {
        // Terms by sequence number: the order of the list (the grouped term goes last).
        let mut live: BTreeMap<usize, Id> = BTreeMap::new();
        let mut factors: HashMap<usize, Vec<Id>> = HashMap::new();
        // The ranking of the factors by (number of terms, first appearance), the best last.
        // For each factor, the terms holding it and its position in each (for the ties).
        let mut holders: HashMap<Id, BTreeMap<usize, usize>> = HashMap::new();
        type Key = (usize, Reverse<(usize, usize)>, Id);
        let mut ranking: BTreeSet<Key> = BTreeSet::new();
        let mut key_of: HashMap<Id, Key> = HashMap::new();
        let refresh = |f: Id,
                       holders: &HashMap<Id, BTreeMap<usize, usize>>,
                       ranking: &mut BTreeSet<Key>,
                       key_of: &mut HashMap<Id, Key>| {
            if let Some(old) = key_of.remove(&f) {
                ranking.remove(&old);
            }
            let held = &holders[&f];
            if let Some((&first, &position)) = held.first_key_value() {
                let key = (held.len(), Reverse((first, position)), f);
                ranking.insert(key);
                key_of.insert(f, key);
            }
        };
        let mut next = 0;
        let mut insert = |g: &mut Graph,
                          t: Id,
                          live: &mut BTreeMap<usize, Id>,
                          factors: &mut HashMap<usize, Vec<Id>>,
                          holders: &mut HashMap<Id, BTreeMap<usize, usize>>,
                          ranking: &mut BTreeSet<Key>,
                          key_of: &mut HashMap<Id, Key>| {
            let seq = next;
            next += 1;
            live.insert(seq, t);
            let fs = g.factors_of(t);
            for (position, &f) in fs.iter().enumerate() {
                holders.entry(f).or_default().insert(seq, position);
                refresh(f, holders, ranking, key_of);
            }
            factors.insert(seq, fs);
        };
        for t in terms {
            insert(
                self,
                t,
                &mut live,
                &mut factors,
                &mut holders,
                &mut ranking,
                &mut key_of,
            );
        }
        loop {
            let Some(&(_, _, f)) = ranking.last().filter(|(count, ..)| *count >= 2) else {
                let terms: Vec<Id> = live.values().copied().collect();
                return self.add(&terms);
            };
            let seqs: Vec<usize> = holders[&f].keys().copied().collect();
            let with: Vec<Id> = seqs.iter().map(|s| live[s]).collect();
            let mut touched: Vec<Id> = Vec::new();
            for s in &seqs {
                live.remove(s);
                for g in factors.remove(s).expect("a live term") {
                    holders.get_mut(&g).expect("held").remove(s);
                    touched.push(g);
                }
            }
            for g in touched {
                refresh(g, &holders, &mut ranking, &mut key_of);
            }
            let inner_terms: Vec<Id> = with.iter().map(|&t| self.without_factor(t, f)).collect();
            // Nests at most as deep as a term has factors.
            let inner = self.factor_sum(inner_terms);
            let grouped = self.mul(&[f, inner]);
            if live.is_empty() {
                return grouped;
            }
            // `grouped` may share a factor with the remaining terms: factor again (fewer terms).
            insert(
                self,
                grouped,
                &mut live,
                &mut factors,
                &mut holders,
                &mut ranking,
                &mut key_of,
            );
        }
    }

    /// Introduces shared sub-products for factor pairs that occur in several products.
    pub fn share_products(&mut self, roots: &[Id]) -> Vec<Id> {
        let mut roots = roots.to_vec();
        loop {
            let order = self.reachable(&roots);
            let mut pairs: HashMap<(Id, Id), usize> = HashMap::new();
            let mut first_seen: Vec<(Id, Id)> = Vec::new();
            for &id in &order {
                if let Node::Mul(fs) = self.node(id) {
                    let fs: Vec<Id> = fs
                        .iter()
                        .copied()
                        .filter(|&f| self.as_num(f).is_none())
                        .collect();
                    if fs.len() < 3 && self.as_num(self.children(id)[0]).is_none() {
                        continue; // a plain pair is already one node
                    }
                    for i in 0..fs.len() {
                        for j in i + 1..fs.len() {
                            let c = pairs.entry((fs[i], fs[j])).or_insert(0);
                            if *c == 0 {
                                first_seen.push((fs[i], fs[j]));
                            }
                            *c += 1;
                        }
                    }
                }
            }
            let best = first_seen
                .iter()
                .enumerate()
                .max_by_key(|&(i, p)| (pairs[p], std::cmp::Reverse(i)))
                .map(|(_, &p)| p);
            let Some((a, b)) = best.filter(|p| pairs[p] >= 2) else {
                return roots;
            };
            let pair = self.intern(Node::Mul(vec![a, b].into()));
            // Rebuild: every product holding both a and b holds `pair` instead.
            let mut new: HashMap<Id, Id> = HashMap::with_capacity(order.len());
            for id in order {
                let node = self.node(id).clone();
                let rebuilt = match node {
                    Node::Num(_) | Node::Input(_) => id,
                    Node::Mul(c) if id != pair => {
                        let mut c: Vec<Id> = c.iter().map(|k| new[k]).collect();
                        if c.contains(&a) && c.contains(&b) {
                            c.retain(|&x| x != a && x != b);
                            c.push(pair);
                        }
                        self.raw_product(c)
                    }
                    Node::Mul(_) => id,
                    Node::Add(c) => {
                        let c: Vec<Id> = c.iter().map(|k| new[k]).collect();
                        self.intern(Node::Add(c.into()))
                    }
                    Node::Pow(b2, e) => self.intern(Node::Pow(new[&b2], e)),
                    Node::Func(f, x) => self.intern(Node::Func(f, new[&x])),
                    Node::Func2(f, [x, m]) => self.intern(Node::Func2(f, [new[&x], new[&m]])),
                };
                new.insert(id, rebuilt);
            }
            roots = roots.iter().map(|r| new[r]).collect();
        }
    }

    /// A product node without flattening (its factors may be products themselves); the
    /// numeric coefficient stays first.
    fn raw_product(&mut self, mut factors: Vec<Id>) -> Id {
        if factors.len() == 1 {
            return factors[0];
        }
        let coefficient = factors.iter().position(|&f| self.as_num(f).is_some());
        let c = coefficient.map(|k| factors.remove(k));
        factors.sort();
        if let Some(c) = c {
            factors.insert(0, c);
        }
        self.intern(Node::Mul(factors.into()))
    }
}

#[cfg(test)]
mod tests {
    use crate::ir::{Graph, Input};

    #[test]
    fn common_factors_come_out_of_sums() {
        // k·a·x + k·b·x + c ⇒ k·x·(a + b) + c: 4 ops instead of 6
        let mut g = Graph::new();
        let [k, a, b, x, c] = [0, 1, 2, 3, 4].map(|i| g.input(Input::State(i)));
        let t1 = g.mul(&[k, a, x]);
        let t2 = g.mul(&[k, b, x]);
        let s = g.add(&[t1, t2, c]);
        assert_eq!(g.op_count(&[s]).dag, 6);
        let f = g.factor_sums(&[s])[0];
        assert_eq!(g.op_count(&[f]).dag, 4);
        let v = |g: &Graph, id| {
            g.eval_f64(&[id], &mut |i| match i {
                Input::State(k) => [2.0, 3.0, 5.0, 7.0, 11.0][k as usize],
                _ => 0.0,
            })[0]
        };
        assert_eq!(v(&g, s), v(&g, f));
    }

    #[test]
    fn repeated_pairs_in_products_are_shared() {
        // a·b·c + a·b·d ⇒ (a·b)·c + (a·b)·d after sharing (but factoring would do better,
        // so test the pass alone)
        let mut g = Graph::new();
        let [a, b, c, d] = [0, 1, 2, 3].map(|i| g.input(Input::State(i)));
        let p1 = g.mul(&[a, b, c]);
        let p2 = g.mul(&[a, b, d]);
        assert_eq!(g.op_count(&[p1, p2]).dag, 4);
        let shared = g.share_products(&[p1, p2]);
        assert_eq!(g.op_count(&shared).dag, 3);
    }
}

//! Rewrites for emission, applied after every check: they change rounding, not values. The
//! emitted Rust (`lasalle_codegen`'s `emit::body`) and the tapes (`tape`) both write the
//! rewritten graph, so they stay bitwise equal.
//!
//! - Sums are factored greedily: `k·a·x + k·b·x + c → k·x·(a + b) + c` (Horner-like), which
//!   saves the multiplications a hand-written formula would not repeat.
//! - Powers of one base share their square root and their reciprocal ([`Graph::share_roots`]):
//!   when a function needs two or more negative powers of a base b (`1/r`, `1/r³` with
//!   r = √b, or `1/b`, `1/b²`), it computes one reciprocal R (`1/√b` if any of the powers is a
//!   half-integer, else `1/b`) and every negative power as a power of R by multiplications;
//!   all half-integer powers come from one `√b`. A single negative power stays a division.
//! - Parameter-only parts of products and sums are grouped ([`Graph::split_parameter_products`]):
//!   `c·μ·x·y → (c·μ)·x·y`, `x + μ + 1 → x + (μ + 1)`, so that the group is one value computed
//!   once per parameter set.
//! - Products share sub-products: when the pair `a·b` occurs in several products, it becomes
//!   one node used by all of them (hash-consed products are flat, so this sharing is not
//!   automatic).
//! - Sums share sub-sums: a sum that holds all the terms of another sum of the function uses
//!   it (`a + b − c` with `a + b` computed anyway is `(a + b) − c`).

use super::{FxHashMap as HashMap, FxHashSet as HashSet};
use super::{Graph, Id, Node, Rational};
use std::cmp::Reverse;
use std::collections::{BTreeMap, BTreeSet};

/// Graphs with at least this many reachable nodes share products by recursive pairing, in
/// near-linear time (see [`Graph::share_products`]); smaller ones, every model of `models/` among
/// them (the largest has about 630), one pair per round with the graph rebuilt after each.
pub const LARGE_GRAPH: usize = 1_000;

impl Graph {
    /// The roots rewritten by both passes, for emission.
    pub fn optimize_for_emission(&mut self, roots: &[Id]) -> Vec<Id> {
        let factored = self.factor_sums(roots);
        let roots = self.share_roots(&factored);
        let split = self.split_parameter_products(&roots);
        let shared = self.share_products(&split);
        self.share_sums(&shared)
    }

    /// A sum that holds every term of another sum of the function is written with it:
    /// `t = a + b` and `a + b − c` become `t` and `t − c`, so the sum `a + b` is computed once.
    /// Among the candidates the largest is taken; only sums that themselves contain no other
    /// sum are candidates (so the one used is the node the function computes).
    pub fn share_sums(&mut self, roots: &[Id]) -> Vec<Id> {
        let order = self.reachable(roots);
        // Sums with two or more terms, by their smallest term.
        let mut by_first: HashMap<Id, Vec<Id>> = HashMap::default();
        for &id in &order {
            if let Node::Add(ts) = self.node(id) {
                if let Some(&first) = ts.iter().min() {
                    by_first.entry(first).or_default().push(id);
                }
            }
        }
        let terms = |g: &Graph, id: Id| match g.node(id) {
            Node::Add(ts) => ts.to_vec(),
            _ => Vec::new(),
        };
        // The largest sum whose terms are a proper subset of the terms of `sum`.
        let largest_within = |g: &Graph, sum: Id| -> Option<Id> {
            let ts = terms(g, sum);
            let held: HashSet<Id> = ts.iter().copied().collect();
            ts.iter()
                .filter_map(|t| by_first.get(t))
                .flatten()
                .copied()
                .filter(|&a| {
                    let inner = terms(g, a);
                    a != sum && inner.len() < ts.len() && inner.iter().all(|t| held.contains(t))
                })
                .max_by_key(|&a| (terms(g, a).len(), Reverse(a)))
        };
        let minimal: HashSet<Id> = by_first
            .values()
            .flatten()
            .copied()
            .filter(|&a| largest_within(self, a).is_none())
            .collect();
        self.rebuild_raw(roots, &order, |g, old, node| {
            let Node::Add(new_terms) = node else {
                return None;
            };
            let old_terms = terms(g, old);
            let inner = largest_within(g, old).filter(|a| minimal.contains(a))?;
            let inner_terms = terms(g, inner);
            // The rebuilt inner sum, from the rebuilt terms at the same positions.
            let mapped = |t: &Id| new_terms[old_terms.iter().position(|o| o == t).expect("held")];
            let inner = g.raw_sum(inner_terms.iter().map(mapped).collect());
            let mut rest: Vec<Id> = old_terms
                .iter()
                .filter(|t| !inner_terms.contains(t))
                .map(mapped)
                .collect();
            rest.insert(0, inner);
            Some(g.raw_sum(rest))
        })
    }

    /// One square root and one reciprocal per base (see the module docs): for every base b
    /// with two or more negative powers among the nodes reachable from `roots`, R = 1/√b (if
    /// one of b's powers is a half-integer) or R = 1/b, and b^(−k/2) = R^k, b^(−m) = R^(2m)
    /// (or R^m). Half-integer powers of b are powers of one `√b`. Powers with another
    /// denominator (∛b) are left alone.
    ///
    /// Rounding: R^k is k − 1 multiplications after one division, so it may differ from
    /// `1 / b^(k/2)` by a few ulps (at most about k ulps); that is the price of replacing
    /// divisions and square roots by multiplications, and it is why a lone negative power
    /// stays a division.
    pub fn share_roots(&mut self, roots: &[Id]) -> Vec<Id> {
        let order = self.reachable(roots);
        let mut exponents: HashMap<Id, Vec<Rational>> = HashMap::default();
        for &id in &order {
            if let Node::Pow(b, e) = *self.node(id) {
                exponents.entry(b).or_default().push(e);
            }
        }
        // Per base: (one of its powers is a half-integer, two or more are negative).
        let plan: HashMap<Id, (bool, bool)> = exponents
            .into_iter()
            .map(|(b, es)| {
                let half = es.iter().any(|e| e.den == 2);
                let negative = es.iter().filter(|e| e.num < 0 && e.den <= 2).count() >= 2;
                (b, (half, negative))
            })
            .collect();
        self.rebuild_raw(roots, &order, |g, old, node| {
            let (&Node::Pow(b, e), &Node::Pow(old_base, _)) = (node, g.node(old)) else {
                return None;
            };
            let (half, negative) = plan[&old_base];
            if e.den > 2 || (e.den == 1 && !negative) {
                return None;
            }
            // bᵉ = base^k: base = √b, k = 2e if b has a half-integer power; else base = b, k = e.
            let (base, k) = if half {
                (
                    g.intern(Node::Pow(b, Rational::new(1, 2))),
                    e.num * (2 / e.den),
                )
            } else {
                (b, e.num)
            };
            let power = |g: &mut Graph, base: Id, k: i32| match k {
                1 => base,
                k => g.intern(Node::Pow(base, Rational::int(k))),
            };
            Some(if k < 0 && negative {
                let reciprocal = g.intern(Node::Pow(base, Rational::int(-1)));
                power(g, reciprocal, k.checked_neg()?)
            } else {
                power(g, base, k)
            })
        })
    }

    /// Groups the parameter-only factors of every product that also has other factors into one
    /// node (`c·μ·x·y → (c·μ)·x·y`), and likewise the parameter-only terms of sums, when the
    /// group has two or more members (a negation −μ alone is not grouped): the group is one
    /// value computed once per parameter set (see [`Graph::parameter_only`]).
    pub fn split_parameter_products(&mut self, roots: &[Id]) -> Vec<Id> {
        let order = self.reachable(roots);
        // Parameter-only nodes of the rebuilt graph, filled bottom-up.
        let mut parameter_only: HashSet<Id> = HashSet::default();
        self.rebuild_raw(roots, &order, |g, _, node| {
            let id = match node {
                Node::Add(c) | Node::Mul(c) => {
                    let (params, mut rest): (Vec<Id>, Vec<Id>) =
                        c.iter().partition(|id| parameter_only.contains(id));
                    let sum = matches!(node, Node::Add(_));
                    let group = |g: &mut Graph, ids: Vec<Id>| {
                        if sum {
                            g.raw_sum(ids)
                        } else {
                            g.raw_product(ids)
                        }
                    };
                    // −μ alone is no work to save: `x − μ·y` needs no separate −μ.
                    let negation = !sum
                        && params.len() == 2
                        && params.iter().any(|&p| g.as_num(p) == Some(-1.0));
                    if params.len() >= 2 && !rest.is_empty() && !negation {
                        let params = group(g, params);
                        parameter_only.insert(params);
                        rest.push(params);
                        group(g, rest)
                    } else {
                        g.intern_raw(node.clone())
                    }
                }
                other => g.intern_raw(other.clone()),
            };
            let only = match g.node(id) {
                Node::Num(_) | Node::Input(super::Input::Param(_)) => true,
                Node::Input(_) => false,
                _ => g.children(id).iter().all(|c| parameter_only.contains(c)),
            };
            if only {
                parameter_only.insert(id);
            }
            Some(id)
        })
    }

    /// Rebuilds `order` (the nodes reachable from `roots`, ascending) bottom-up without the
    /// canonical constructors: `rewrite` sees each node's old Id and the node with its children
    /// already rebuilt, and returns the new Id, or `None` to intern the node as it is.
    fn rebuild_raw(
        &mut self,
        roots: &[Id],
        order: &[Id],
        mut rewrite: impl FnMut(&mut Graph, Id, &Node) -> Option<Id>,
    ) -> Vec<Id> {
        let mut new: HashMap<Id, Id> =
            HashMap::with_capacity_and_hasher(order.len(), Default::default());
        for &id in order {
            let node = match self.node(id).clone() {
                Node::Add(c) => Node::Add(c.iter().map(|k| new[k]).collect()),
                Node::Mul(c) => Node::Mul(c.iter().map(|k| new[k]).collect()),
                Node::Pow(b, e) => Node::Pow(new[&b], e),
                Node::Func(f, a) => Node::Func(f, new[&a]),
                Node::Func2(f, [a, m]) => Node::Func2(f, [new[&a], new[&m]]),
                leaf @ (Node::Num(_) | Node::Input(_)) => leaf,
            };
            let rebuilt = match rewrite(self, id, &node) {
                Some(r) => r,
                None => self.intern_raw(node),
            };
            new.insert(id, rebuilt);
        }
        roots.iter().map(|r| new[r]).collect()
    }

    /// Interns a node without simplification; products keep their coefficient first and their
    /// other factors sorted ([`Graph::raw_product`]), sums keep their order.
    fn intern_raw(&mut self, node: Node) -> Id {
        match node {
            Node::Mul(c) => self.raw_product(c.into_vec()),
            Node::Add(c) => self.raw_sum(c.into_vec()),
            other => self.intern(other),
        }
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
        let mut factors: HashMap<usize, Vec<Id>> = HashMap::default();
        // The ranking of the factors by (number of terms, first appearance), the best last.
        // For each factor, the terms holding it and its position in each (for the ties).
        let mut holders: HashMap<Id, BTreeMap<usize, usize>> = HashMap::default();
        type Key = (usize, Reverse<(usize, usize)>, Id);
        let mut ranking: BTreeSet<Key> = BTreeSet::new();
        let mut key_of: HashMap<Id, Key> = HashMap::default();
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

    /// Introduces shared sub-products for factor pairs that occur in several products: the
    /// most frequent pair first. Below [`LARGE_GRAPH`] reachable nodes, one pair per round, the
    /// graph rebuilt after each (quadratic in the number of pairs, but these graphs are small);
    /// from `LARGE_GRAPH` on, the same greedy choice by recursive pairing with the counts
    /// updated in place and one rebuild ([`Graph::share_products_linear`]). The two differ
    /// only in how ties between equally frequent pairs are broken: the rounds rank pairs by
    /// their first appearance in the rebuilt graph, recursive pairing by their first
    /// appearance in the pass.
    pub fn share_products(&mut self, roots: &[Id]) -> Vec<Id> {
        if self.reachable(roots).len() >= LARGE_GRAPH {
            return self.share_products_linear(roots);
        }
        let mut roots = roots.to_vec();
        loop {
            let order = self.reachable(&roots);
            let mut pairs: HashMap<(Id, Id), usize> = HashMap::default();
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
            roots = self.rebuild_raw(&roots, &order, |g, old, node| match node {
                Node::Mul(_) if old == pair => Some(pair),
                Node::Mul(c) if c.contains(&a) && c.contains(&b) => {
                    let mut c = c.to_vec();
                    c.retain(|&x| x != a && x != b);
                    c.push(pair);
                    Some(g.raw_product(c))
                }
                _ => None,
            });
        }
    }

    /// [`Graph::share_products`] on a large graph, in time near-linear in its size: the same
    /// greedy choice (the pair held by the most products first; ties: the pair seen first), made
    /// by recursive pairing (Larsson & Moffat's Re-Pair) on the products' factor sets. The pairs'
    /// counts and the products holding each pair are kept in hash maps and updated as each chosen
    /// pair replaces its two factors (a product of k factors costs O(k²) over the whole pass), and
    /// the graph is rebuilt once at the end, not once per pair.
    pub fn share_products_linear(&mut self, roots: &[Id]) -> Vec<Id> {
        let order = self.reachable(roots);
        // A pair chosen so far stands for a product node not yet interned: a virtual Id past
        // the graph's end, its two factors in `pairs`.
        let base = self.len();
        let mut pairs: Vec<(Id, Id)> = Vec::new();
        // The products that take part: (old Id, has a coefficient, non-numeric factors).
        let mut products: Vec<(Id, bool, Vec<Id>)> = Vec::new();
        for &id in &order {
            if let Node::Mul(fs) = self.node(id) {
                let coefficient = self.as_num(fs[0]).is_some();
                let rest: Vec<Id> = fs
                    .iter()
                    .copied()
                    .filter(|&f| self.as_num(f).is_none())
                    .collect();
                if rest.len() >= 3 || (coefficient && rest.len() >= 2) {
                    products.push((id, coefficient, rest));
                }
            }
        }
        let key = |a: Id, b: Id| if a < b { (a, b) } else { (b, a) };
        // Per pair: (count, sequence number of its first appearance), and the products holding it.
        let mut count: HashMap<(Id, Id), (usize, usize)> = HashMap::default();
        let mut holders: HashMap<(Id, Id), Vec<u32>> = HashMap::default();
        let mut ranking: BTreeSet<(usize, Reverse<usize>, (Id, Id))> = BTreeSet::new();
        let mut seen = 0usize;
        let mut bump =
            |p: (Id, Id),
             by: isize,
             count: &mut HashMap<(Id, Id), (usize, usize)>,
             ranking: &mut BTreeSet<(usize, Reverse<usize>, (Id, Id))>| {
                let entry = count.entry(p).or_insert_with(|| {
                    seen += 1;
                    (0, seen)
                });
                ranking.remove(&(entry.0, Reverse(entry.1), p));
                entry.0 = entry
                    .0
                    .checked_add_signed(by)
                    .expect("a pair's count stays ≥ 0");
                if entry.0 >= 2 {
                    ranking.insert((entry.0, Reverse(entry.1), p));
                }
            };
        for (k, (_, _, fs)) in products.iter().enumerate() {
            for i in 0..fs.len() {
                for j in i + 1..fs.len() {
                    let p = key(fs[i], fs[j]);
                    bump(p, 1, &mut count, &mut ranking);
                    holders.entry(p).or_default().push(k as u32);
                }
            }
        }
        while let Some(&(_, _, (a, b))) = ranking.last() {
            let pair = Id(u32::try_from(base + pairs.len()).expect("Ids fit in u32"));
            pairs.push((a, b));
            for k in holders.remove(&(a, b)).unwrap_or_default() {
                let (_, coefficient, fs) = &mut products[k as usize];
                if !(fs.contains(&a) && fs.contains(&b)) {
                    continue;
                }
                // The product's pairs before, out; after, in (a product left with two factors
                // and no coefficient is a plain pair: its pair is no longer counted).
                for i in 0..fs.len() {
                    for j in i + 1..fs.len() {
                        bump(key(fs[i], fs[j]), -1, &mut count, &mut ranking);
                    }
                }
                fs.retain(|&x| x != a && x != b);
                fs.push(pair);
                if fs.len() >= 3 || (*coefficient && fs.len() >= 2) {
                    for i in 0..fs.len() {
                        for j in i + 1..fs.len() {
                            let p = key(fs[i], fs[j]);
                            bump(p, 1, &mut count, &mut ranking);
                            if fs[i] == pair || fs[j] == pair {
                                holders.entry(p).or_default().push(k);
                            }
                        }
                    }
                }
            }
            if let Some(&(c, s)) = count.get(&(a, b)) {
                ranking.remove(&(c, Reverse(s), (a, b)));
            }
        }
        if pairs.is_empty() {
            return roots.to_vec();
        }
        // One rebuild: every product with its final factors, the chosen pairs interned on first use.
        let rewritten: HashMap<Id, (bool, Vec<Id>)> = products
            .into_iter()
            .filter(|(_, _, fs)| fs.iter().any(|f| f.index() >= base))
            .map(|(id, c, fs)| (id, (c, fs)))
            .collect();
        let mut new: HashMap<Id, Id> =
            HashMap::with_capacity_and_hasher(order.len(), Default::default());
        let mut interned: Vec<Option<Id>> = vec![None; pairs.len()];
        fn resolve(
            g: &mut Graph,
            f: Id,
            base: usize,
            pairs: &[(Id, Id)],
            interned: &mut [Option<Id>],
            new: &HashMap<Id, Id>,
        ) -> Id {
            if f.index() < base {
                return new[&f];
            }
            let k = f.index() - base;
            if let Some(id) = interned[k] {
                return id;
            }
            let (a, b) = pairs[k];
            let a = resolve(g, a, base, pairs, interned, new);
            let b = resolve(g, b, base, pairs, interned, new);
            let id = g.raw_product(vec![a, b]);
            interned[k] = Some(id);
            id
        }
        for &id in &order {
            let node = self.node(id).clone();
            let rebuilt = match (&node, rewritten.get(&id)) {
                (Node::Mul(c), Some((coefficient, fs))) => {
                    let mut factors: Vec<Id> = Vec::with_capacity(fs.len() + 1);
                    if *coefficient {
                        factors.push(new[&c[0]]);
                    }
                    for &f in fs {
                        factors.push(resolve(self, f, base, &pairs, &mut interned, &new));
                    }
                    self.raw_product(factors)
                }
                _ => {
                    let node = match node {
                        Node::Add(c) => Node::Add(c.iter().map(|k| new[k]).collect()),
                        Node::Mul(c) => Node::Mul(c.iter().map(|k| new[k]).collect()),
                        Node::Pow(b, e) => Node::Pow(new[&b], e),
                        Node::Func(f, a) => Node::Func(f, new[&a]),
                        Node::Func2(f, [a, m]) => Node::Func2(f, [new[&a], new[&m]]),
                        leaf @ (Node::Num(_) | Node::Input(_)) => leaf,
                    };
                    self.intern_raw(node)
                }
            };
            new.insert(id, rebuilt);
        }
        roots.iter().map(|r| new[r]).collect()
    }

    /// A sum node without flattening or reordering.
    fn raw_sum(&mut self, terms: Vec<Id>) -> Id {
        if terms.len() == 1 {
            return terms[0];
        }
        self.intern(Node::Add(terms.into()))
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
    use crate::ir::{Graph, Input, Node, Rational};

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

    /// The number of nodes of each kind among those reachable: (square roots, reciprocals or
    /// other negative powers).
    fn roots_and_reciprocals(g: &Graph, roots: &[crate::ir::Id]) -> (usize, usize) {
        let order = g.reachable(roots);
        let count = |p: fn(crate::ir::Rational) -> bool| {
            order
                .iter()
                .filter(|&&id| matches!(g.node(id), Node::Pow(_, e) if p(*e)))
                .count()
        };
        (count(|e| e.den == 2), count(|e| e.num < 0))
    }

    #[test]
    fn powers_of_one_radius_share_one_root_and_one_reciprocal() {
        // μ/r + δ/r³ + μ/r⁴·x + 1/r⁵ with r² = x² + y²: before, three half-integer powers and
        // four negative powers of r²; after, one √ and one 1/√, the rest multiplications.
        let mut g = Graph::new();
        let [x, y] = [0, 1].map(|i| g.input(Input::State(i)));
        let [mu, delta] = [0, 1].map(|i| g.input(Input::Param(i)));
        let (x2, y2) = (g.mul(&[x, x]), g.mul(&[y, y]));
        let r2 = g.add(&[x2, y2]);
        let p = |g: &mut Graph, num, den| g.pow(r2, Rational::new(num, den));
        let terms = [
            (mu, p(&mut g, -1, 2)),
            (delta, p(&mut g, -3, 2)),
            (x, p(&mut g, -2, 1)),
            (delta, p(&mut g, -5, 2)),
        ]
        .map(|(a, b)| g.mul(&[a, b]));
        let sum = g.add(&terms);
        assert_eq!(roots_and_reciprocals(&g, &[sum]), (3, 4));
        let shared = g.share_roots(&[sum]);
        assert_eq!(roots_and_reciprocals(&g, &shared), (1, 1));
        let value = |g: &Graph, id| {
            g.eval_f64(&[id], &mut |i| match i {
                Input::State(k) => [0.7, -1.3][k as usize],
                Input::Param(k) => [1.5, 0.25][k as usize],
                _ => 0.0,
            })[0]
        };
        let (before, after) = (value(&g, sum), value(&g, shared[0]));
        assert!((before - after).abs() <= 8.0 * f64::EPSILON * before.abs());
    }

    #[test]
    fn a_single_negative_power_stays_a_division() {
        let mut g = Graph::new();
        let x = g.input(Input::State(0));
        let r3 = g.pow(x, Rational::new(-3, 2));
        let shared = g.share_roots(&[r3]);
        assert_eq!(roots_and_reciprocals(&g, &shared), (1, 1));
        assert!(matches!(g.node(shared[0]), Node::Pow(_, e) if e.num == -3));
    }

    #[test]
    fn parameter_only_factors_are_grouped() {
        // −3·μ·x/m ⇒ (−3·μ/m)·x: one multiplication per call
        let mut g = Graph::new();
        let x = g.input(Input::State(0));
        let [mu, m] = [0, 1].map(|i| g.input(Input::Param(i)));
        let c = g.num(-3.0);
        let q = g.div(x, m);
        let product = g.mul(&[c, mu, q]);
        let split = g.split_parameter_products(&[product])[0];
        let Node::Mul(fs) = g.node(split) else {
            panic!("a product")
        };
        assert_eq!(fs.len(), 2);
        let order = g.reachable(&[split]);
        let only = g.parameter_only(&order);
        assert_eq!(fs.iter().filter(|f| only.contains(f)).count(), 1);
        assert!(fs.contains(&x));
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

    #[test]
    fn recursive_pairing_shares_what_the_rounds_share() {
        // Products c·xᵢ·yⱼ·zₖ·w over a grid of i, j, k, the shape of the N-body terms: both
        // passes keep the values and leave the same number of operations.
        let mut g = Graph::new();
        let x: Vec<_> = (0..4).map(|i| g.input(Input::State(i))).collect();
        let y: Vec<_> = (4..8).map(|i| g.input(Input::State(i))).collect();
        let z: Vec<_> = (8..10).map(|i| g.input(Input::State(i))).collect();
        let w = g.input(Input::Param(0));
        let mut products = Vec::new();
        for (n, &a) in x.iter().enumerate() {
            for &b in &y {
                for &c in &z {
                    let k = g.num(n as f64 + 2.0);
                    products.push(g.mul(&[k, a, b, c, w]));
                }
            }
        }
        let mut rounds = g.clone();
        let by_rounds = rounds.share_products(&products);
        let by_pairing = g.share_products_linear(&products);
        assert!(g.op_count(&by_pairing).dag < g.op_count(&products).dag);
        assert_eq!(g.op_count(&by_pairing).dag, rounds.op_count(&by_rounds).dag);
        let value = |g: &Graph, ids: &[crate::ir::Id]| {
            g.eval_f64(ids, &mut |i| match i {
                Input::State(k) => 1.0 + 0.37 * k as f64,
                Input::Param(_) => 0.81,
                _ => 0.0,
            })
        };
        let (before, after) = (value(&g, &products), value(&g, &by_pairing));
        for (b, a) in before.iter().zip(&after) {
            assert!(
                (a - b).abs() <= 4.0 * f64::EPSILON * b.abs(),
                "{a} against {b}"
            );
        }
    }
}

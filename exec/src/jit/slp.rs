//! Pairing (SLP) of the single-state `eval` function: two isomorphic, independent tape
//! instructions become one two-lane (`F64X2`) instruction.
//!
//! LLVM's SLP vectoriser does this to the emitted Rust (the x, y, z components of a model run
//! through the same operations); without it Cranelift computes every instruction in scalars.
//!
//! **What is paired.** Two live instructions `a`, `b` of the body (after the negation folding
//! of [`fold`]) form a *pack* `(a, b)` — `a` in lane 0, `b` in lane 1 — when they are the same
//! operation (`+ − · /`, negation, `sqrt`, `powi` with the same exponent; or loads of adjacent
//! elements of one input, `x[i]` and `x[i + 1]`, which become one 128-bit load), neither
//! depends on the other, and merging them keeps the dependency graph acyclic (so the packs and
//! the remaining scalar instructions have a topological order, [`Pairing::order`]).
//! The operands of a pack are vectors built per operand position: the pack of the two
//! operands when they form one in the same lane order (free), a splat of a shared operand,
//! a vector constant of two constants (equal or not), one load of a vector slot for two values
//! that are the same for every call ([`invariant_pair`]), or otherwise one instruction putting
//! together the packs and scalars that hold them (`insertlane` into a pack, or a shuffle of
//! two packs; two instructions for two scalars: a splat and an `insertlane`); a scalar user of
//! a packed value extracts its lane (lane 0 is free, lane 1 one shuffle). `x + y` and `x · y`
//! are commutative IEEE operations, so the operands of lane 1 may be swapped to match those of
//! lane 0.
//!
//! **How.** As LLVM: seeds are the adjacent outputs (`out[2m]`, `out[2m + 1]`, each pair
//! stored as one 128-bit store; first all of them as one tree, then each `(out[j], out[j + 1])`
//! alone), then pairs of users of packed values (top down); from a seed, the tree of operand
//! pairs is paired bottom up while isomorphic, and kept only if it saves instructions: one per
//! paired operation (the multiplications of `powi`, two for the slow `/` and `sqrt`), one per
//! adjacent load pair or store pair, against those putting operand vectors together and one
//! per lane 1 a scalar user extracts. The pass is deterministic (tape order throughout) and
//! takes under 0.3 ms on the feedback tapes of `models/` (≤ 280 instructions).
//!
//! **Why the results stay bitwise equal.** Each lane of a two-lane `fadd`, `fsub`, `fmul`,
//! `fdiv`, `fneg`, `sqrt` is the same correctly rounded IEEE operation on the same operands as
//! the scalar instruction (no fusing, no reassociation, no flush to zero), and `powi` is the
//! same multiplication chain lane by lane; operands are only moved between registers, never
//! recomputed differently.

use super::Op;
use lasalle_model::tape::{Reg, Tape};
use std::collections::BTreeSet;

/// Deepest operand tree paired from one seed (deeper operands are put together from scalars).
const MAX_DEPTH: usize = 48;

/// `op` with its negated operands folded: `x + (−y)` is `x − y`, `(−y) + x` is `x − y` (IEEE
/// addition is commutative) and `x − (−y)` is `x + y`, the same IEEE operations; `negated[r]`
/// is `Some(y)` when register r is `Neg(y)`. The negation, if unused otherwise, is then dead.
pub(crate) fn fold(op: Op, negated: &[Option<Reg>]) -> Op {
    match op {
        Op::Add(a, c) => match (negated[a.index()], negated[c.index()]) {
            (_, Some(y)) => Op::Sub(a, y),
            (Some(y), None) => Op::Sub(c, y),
            (None, None) => op,
        },
        Op::Sub(a, c) => match negated[c.index()] {
            Some(y) => Op::Add(a, y),
            None => op,
        },
        _ => op,
    }
}

/// `Some(y)` for the registers that are `Neg(y)`.
pub(crate) fn negations(tape: &Tape) -> Vec<Option<Reg>> {
    tape.body
        .iter()
        .map(|op| match *op {
            Op::Neg(y) => Some(y),
            _ => None,
        })
        .collect()
}

/// One step of the pairing's schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Node {
    /// A scalar instruction.
    Single(usize),
    /// Pack number p of [`Pairing::packs`].
    Pack(usize),
}

/// The pairing of a tape's body.
#[derive(Debug)]
pub(crate) struct Pairing {
    /// The instructions after negation folding; in a pack, the operands of lane 1 are swapped
    /// where that matches them with those of lane 0 (commutative operations only).
    pub ops: Vec<Op>,
    /// The packs: (lane 0, lane 1) instruction indices.
    pub packs: Vec<[usize; 2]>,
    /// The pack and lane of each instruction, if paired.
    pub lane: Vec<Option<(usize, u8)>>,
    /// The live instructions and packs in a topological order that keeps few values live
    /// ([`Slp::schedule`]).
    pub order: Vec<Node>,
}

impl Pairing {
    /// The pack (p, 0) of `(a, b)` if `a` and `b` are its lanes 0 and 1.
    pub fn pack_of(&self, a: Reg, b: Reg) -> Option<usize> {
        match (self.lane[a.index()], self.lane[b.index()]) {
            (Some((p, 0)), Some((q, 1))) if p == q => Some(p),
            _ => None,
        }
    }
}

/// Pairs the body of `tape` (validated).
pub(crate) fn pair(tape: &Tape) -> Pairing {
    let negated = negations(tape);
    let n = tape.body.len();
    let ops: Vec<Op> = tape.body.iter().map(|&op| fold(op, &negated)).collect();
    let mut live = vec![false; n];
    for r in &tape.outputs {
        live[r.index()] = true;
    }
    for i in (0..n).rev() {
        if live[i] {
            for r in ops[i].operands() {
                live[r.index()] = true;
            }
        }
    }
    let mut users = vec![Vec::new(); n];
    for (i, op) in ops.iter().enumerate() {
        if live[i] {
            for r in op.operands() {
                if users[r.index()].last() != Some(&i) {
                    users[r.index()].push(i);
                }
            }
        }
    }
    let mut s = Slp {
        ops,
        live,
        users,
        outputs: tape.outputs.iter().map(|r| r.index()).collect(),
        lane: vec![None; n],
        packs: Vec::new(),
        swapped: Vec::new(),
        seen: vec![0; n],
        seen_up: vec![0; n],
        stamp: 0,
    };
    s.seed();
    let order = s.schedule();
    Pairing {
        ops: s.ops,
        packs: s.packs,
        lane: s.lane,
        order,
    }
}

/// The pass's state.
struct Slp {
    ops: Vec<Op>,
    live: Vec<bool>,
    /// Live users of each instruction (each once).
    users: Vec<Vec<usize>>,
    outputs: Vec<usize>,
    lane: Vec<Option<(usize, u8)>>,
    packs: Vec<[usize; 2]>,
    /// Lane-1 instructions whose operands were swapped (to undo a rejected tree).
    swapped: Vec<usize>,
    /// Visit marks of the reachability search: down the uses, up the operands.
    seen: Vec<u32>,
    seen_up: Vec<u32>,
    stamp: u32,
}

/// The lane-wise operation of a pairable instruction: a kind and an exponent.
fn kind(op: Op) -> Option<(u8, i32)> {
    Some(match op {
        Op::Add(..) => (0, 0),
        Op::Sub(..) => (1, 0),
        Op::Mul(..) => (2, 0),
        Op::Div(..) => (3, 0),
        Op::Neg(_) => (4, 0),
        Op::Sqrt(_) => (5, 0),
        Op::Powi(_, n) => (6, n),
        _ => return None,
    })
}

/// Scalar instructions one two-lane instruction replaces (`/` and `sqrt` count double: they
/// are slow, and a two-lane one costs about what a scalar one does).
fn saving(op: Op) -> i32 {
    match op {
        Op::Div(..) | Op::Sqrt(_) => 2,
        Op::Powi(_, n) => {
            let m = n.unsigned_abs();
            let squares = (u32::BITS - m.leading_zeros()).saturating_sub(1);
            let products = m.count_ones().saturating_sub(1);
            (squares + products) as i32 + i32::from(n < 0)
        }
        _ => 1,
    }
}

/// Adjacent elements `x[i]`, `x[i + 1]` of one input.
fn adjacent(a: Op, b: Op) -> bool {
    match (a, b) {
        (Op::State(i), Op::State(j))
        | (Op::Target(i), Op::Target(j))
        | (Op::Gain(i), Op::Gain(j))
        | (Op::Hoisted(i), Op::Hoisted(j)) => i.checked_add(1) == Some(j),
        _ => false,
    }
}

/// Two values that are the same for every call, at least one of them hoisted: the kernel
/// stores them side by side after the hoisted values (a *vector slot*, see `Slots` in the
/// parent module), so that the operand vector `(a, b)` is one 128-bit load whatever the lanes
/// and wherever `a` and `b` are in the tape. (Two constants are one vector constant.)
pub(crate) fn invariant_pair(a: Op, b: Op) -> bool {
    matches!(
        (a, b),
        (Op::Hoisted(_), Op::Hoisted(_) | Op::Const(_)) | (Op::Const(_), Op::Hoisted(_))
    )
}

/// The two operands (the second `None` for unary operations).
fn operands(op: Op) -> (Reg, Option<Reg>) {
    let mut it = op.operands();
    let a = it.next().expect("an operation with operands");
    (a, it.next())
}

impl Slp {
    /// The instructions merged with `i` (itself, and its lane partner).
    fn members(&self, i: usize) -> [usize; 2] {
        match self.lane[i] {
            Some((p, _)) => self.packs[p],
            None => [i, i],
        }
    }

    /// Whether `to` is reachable from `from` along uses (packs merged).
    ///
    /// Two searches in lockstep, one instruction each in turn: down the uses from `from`, and
    /// up the operands from `to`. The answer is yes as soon as either finds the other's start
    /// or an instruction the other has visited (a path from `from` through it to `to`), and no
    /// as soon as either has visited everything it can reach. So a search costs at most twice
    /// the smaller of the two cones, not the cone of every transitive user of `from` (on a
    /// large tape, most of the tape for an instruction near its inputs), with the same answer.
    fn reaches(&mut self, from: usize, to: usize) -> bool {
        self.stamp += 1;
        let (source, target) = (self.members(from), self.members(to));
        let mut down = vec![from];
        let mut up = vec![to];
        loop {
            let Some(i) = down.pop() else {
                return false;
            };
            for m in self.members(i) {
                if self.seen[m] == self.stamp {
                    continue;
                }
                self.seen[m] = self.stamp;
                if target.contains(&m) || self.seen_up[m] == self.stamp {
                    return true;
                }
                down.extend(self.users[m].iter().copied());
            }
            let Some(i) = up.pop() else {
                return false;
            };
            for m in self.members(i) {
                if self.seen_up[m] == self.stamp {
                    continue;
                }
                self.seen_up[m] = self.stamp;
                if source.contains(&m) || self.seen[m] == self.stamp {
                    return true;
                }
                up.extend(self.ops[m].operands().map(|r| r.index()));
            }
        }
    }

    /// Records the pack `(a, b)`.
    fn add_pack(&mut self, a: usize, b: usize) {
        let p = self.packs.len();
        self.packs.push([a, b]);
        self.lane[a] = Some((p, 0));
        self.lane[b] = Some((p, 1));
    }

    /// A quick match score of an operand pair (to choose the operand order of lane 1).
    fn score(&self, x: Reg, y: Reg) -> i32 {
        let (a, b) = (x.index(), y.index());
        let (oa, ob) = (self.ops[a], self.ops[b]);
        match (self.lane[a], self.lane[b]) {
            (Some((p, 0)), Some((q, 1))) if p == q => return 3,
            _ => {}
        }
        if a == b || adjacent(oa, ob) || invariant_pair(oa, ob) {
            3
        } else if matches!((oa, ob), (Op::Const(_), Op::Const(_))) {
            2
        } else if kind(oa).is_some() && kind(oa) == kind(ob) {
            1
        } else {
            0
        }
    }

    /// Pairs the operand trees of `(a, b)` (tentatively: see [`Slp::rollback`]) and returns the
    /// cost of the vector `(a, b)` in instructions (negative: a saving).
    fn bundle(&mut self, a: usize, b: usize, depth: usize) -> i32 {
        if let (Some((p, 0)), Some((q, 1))) = (self.lane[a], self.lane[b]) {
            if p == q {
                return 0;
            }
        }
        let (oa, ob) = (self.ops[a], self.ops[b]);
        if invariant_pair(oa, ob) || matches!((oa, ob), (Op::Const(_), Op::Const(_))) {
            return 0; // one load: of a vector slot of the hoisted values, or a vector constant
        }
        if a == b {
            return 1; // a splat
        }
        // put together: one instruction from a pack, two from two scalars
        let gather = if self.lane[a].is_some() || self.lane[b].is_some() {
            1
        } else {
            2
        };
        if self.lane[a].is_some() || self.lane[b].is_some() || depth >= MAX_DEPTH {
            return gather;
        }
        if adjacent(oa, ob) {
            self.add_pack(a, b);
            return -1;
        }
        if kind(oa).is_none() || kind(oa) != kind(ob) || self.reaches(a, b) || self.reaches(b, a) {
            return gather;
        }
        self.add_pack(a, b);
        let (xa, ya) = operands(oa);
        let (mut xb, mut yb) = operands(ob);
        if let (Some(y), Some(v)) = (ya, yb) {
            let commutes = matches!(ob, Op::Add(..) | Op::Mul(..));
            if commutes
                && self.score(xa, v) + self.score(y, xb) > self.score(xa, xb) + self.score(y, v)
            {
                self.ops[b] = match ob {
                    Op::Add(..) => Op::Add(v, xb),
                    _ => Op::Mul(v, xb),
                };
                (xb, yb) = (v, Some(xb));
                self.swapped.push(b);
            }
        }
        let mut cost = -saving(oa) + self.bundle(xa.index(), xb.index(), depth + 1);
        if let (Some(y), Some(v)) = (ya, yb) {
            cost += self.bundle(y.index(), v.index(), depth + 1);
        }
        cost
    }

    /// Undoes the packs from number `mark` on and the operand swaps from `swaps` on.
    fn rollback(&mut self, mark: usize, swaps: usize) {
        for [a, b] in self.packs.drain(mark..) {
            self.lane[a] = None;
            self.lane[b] = None;
        }
        for b in self.swapped.drain(swaps..) {
            self.ops[b] = match self.ops[b] {
                Op::Add(x, y) => Op::Add(y, x),
                Op::Mul(x, y) => Op::Mul(y, x),
                op => op,
            };
        }
    }

    /// The lane extractions the packs from number `mark` on need: lane 1 of a value with a
    /// scalar use (an unpaired user, an output not stored with its lane partner) costs one
    /// shuffle (lane 0 is free; packed users put their operand vectors together, counted by
    /// [`Slp::bundle`]).
    fn extractions(&self, mark: usize) -> i32 {
        let mut cost = 0;
        for &[a, b] in &self.packs[mark..] {
            let scalar_use = self.users[b].iter().any(|&u| self.lane[u].is_none());
            let out_use = self
                .outputs
                .iter()
                .enumerate()
                .any(|(j, &o)| o == b && (j == 0 || self.outputs[j - 1] != a));
            cost += i32::from(scalar_use || out_use);
        }
        cost
    }

    /// Tries the trees of the `roots` together, each with `extra` added to its cost (a saved
    /// store); keeps them if they save instructions.
    fn attempt(&mut self, roots: &[(usize, usize)], extra: i32) {
        let (mark, swaps) = (self.packs.len(), self.swapped.len());
        let mut cost = 0;
        for &(a, b) in roots {
            if a != b && self.lane[a].is_none() && self.lane[b].is_none() {
                cost += extra + self.bundle(a, b, 0);
            }
        }
        if self.packs.len() == mark || cost + self.extractions(mark) >= 0 {
            self.rollback(mark, swaps);
        }
    }

    /// Seeds from the adjacent outputs (all pairs `(out[2m], out[2m + 1])` together, then
    /// every `(out[j], out[j + 1])` alone), then from the users of packed values, until
    /// nothing more pairs.
    fn seed(&mut self) {
        let stores: Vec<(usize, usize)> =
            self.outputs.chunks_exact(2).map(|c| (c[0], c[1])).collect();
        self.attempt(&stores, -1);
        for j in 1..self.outputs.len() {
            self.attempt(&[(self.outputs[j - 1], self.outputs[j])], -1);
        }
        let mut done = 0;
        while done < self.packs.len() {
            let [a, b] = self.packs[done];
            done += 1;
            for ua in self.users[a].clone() {
                for ub in self.users[b].clone() {
                    if kind(self.ops[ua]).is_some() && kind(self.ops[ua]) == kind(self.ops[ub]) {
                        self.attempt(&[(ua, ub)], 0);
                    }
                }
            }
        }
    }

    /// The live scalar instructions and the packs in a topological order that keeps few
    /// values live: a list schedule taking, among the ready nodes, one that adds the fewest
    /// live values — one for its result if used, less one per operand it is the last user of —
    /// and among those the earliest in the tape (by its last instruction). `eval` is compiled
    /// in this order (at `opt_level = none`), so the register allocator has fewer values to
    /// keep: against Cranelift's own order (its e-graph elaborates the body depth first from
    /// the stores) Kepler is 9% faster, the CR3BPs 3% and 7%, the SO(3) extremals 4–15%, the
    /// other models of `models/` within ±2%.
    fn schedule(&self) -> Vec<Node> {
        let n = self.ops.len();
        let node = |i: usize| match self.lane[i] {
            Some((p, _)) => n + p,
            None => i,
        };
        let key = |v: usize| {
            if v < n {
                v
            } else {
                self.packs[v - n][0].max(self.packs[v - n][1])
            }
        };
        let total = n + self.packs.len();
        let mut pending = vec![0usize; total];
        // one entry per use (a node using a value twice is listed twice)
        let mut users: Vec<Vec<usize>> = vec![Vec::new(); total];
        let mut operands: Vec<Vec<usize>> = vec![Vec::new(); total];
        let mut nodes = Vec::new();
        for i in (0..n).filter(|&i| self.live[i]) {
            let v = node(i);
            if v == i || self.packs[v - n][0] == i {
                nodes.push(v);
            }
            for r in self.ops[i].operands() {
                let u = node(r.index());
                if u != v {
                    pending[v] += 1;
                    users[u].push(v);
                    operands[v].push(u);
                }
            }
        }
        // uses of each value not yet scheduled
        let mut remaining: Vec<usize> = users.iter().map(Vec::len).collect();
        let growth = |v: usize, remaining: &[usize]| {
            let ops = &operands[v];
            let last_uses = ops
                .iter()
                .enumerate()
                .filter(|&(k, &u)| {
                    !ops[..k].contains(&u)
                        && remaining[u] == ops.iter().filter(|&&w| w == u).count()
                })
                .count();
            i64::from(!users[v].is_empty()) - last_uses as i64
        };
        // the ready nodes by (growth, key), and the growth each was filed under
        let mut ready = BTreeSet::new();
        let mut filed: Vec<Option<i64>> = vec![None; total];
        for &v in nodes.iter().filter(|&&v| pending[v] == 0) {
            let g = growth(v, &remaining);
            ready.insert((g, key(v), v));
            filed[v] = Some(g);
        }
        let mut order = Vec::with_capacity(nodes.len());
        while let Some((_, _, v)) = ready.pop_first() {
            filed[v] = None;
            order.push(if v < n {
                Node::Single(v)
            } else {
                Node::Pack(v - n)
            });
            for &u in &operands[v] {
                remaining[u] -= 1;
            }
            // ready users of the same operands may now be their last users: only when an
            // operand has at most four uses left (a node, two lanes of two operands, holds an
            // operand at most four times), so a value with many users is not revisited at
            // each of them
            for &u in &operands[v] {
                if remaining[u] > 4 {
                    continue;
                }
                for &w in &users[u] {
                    if let Some(old) = filed[w] {
                        let g = growth(w, &remaining);
                        if g != old {
                            ready.remove(&(old, key(w), w));
                            ready.insert((g, key(w), w));
                            filed[w] = Some(g);
                        }
                    }
                }
            }
            for &w in &users[v] {
                pending[w] -= 1;
                if pending[w] == 0 {
                    let g = growth(w, &remaining);
                    ready.insert((g, key(w), w));
                    filed[w] = Some(g);
                }
            }
        }
        debug_assert_eq!(order.len(), nodes.len(), "the packs keep the graph acyclic");
        order
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lasalle_model::tape::ModelTapes;

    fn feedback(file: &str, text: &str) -> Tape {
        let model = lasalle_model::lower_source(file, text).unwrap();
        ModelTapes::new(&lasalle_model::derive(model))
            .unwrap()
            .feedback
    }

    /// The most values live at once when the nodes run in `order`.
    fn peak(p: &Pairing, order: &[Node], outputs: &[Reg]) -> usize {
        let n = p.ops.len();
        let node = |i: usize| p.lane[i].map_or(i, |(q, _)| n + q);
        let members = |v: Node| match v {
            Node::Single(i) => vec![i],
            Node::Pack(q) => p.packs[q].to_vec(),
        };
        let mut uses = vec![0usize; n + p.packs.len()];
        for &v in order {
            for i in members(v) {
                for r in p.ops[i].operands() {
                    uses[node(r.index())] += 1;
                }
            }
        }
        for r in outputs {
            uses[node(r.index())] += 1; // live to the end
        }
        let (mut live, mut most) = (0usize, 0usize);
        for &v in order {
            let id = node(members(v)[0]);
            live += 1;
            most = most.max(live);
            for i in members(v) {
                for r in p.ops[i].operands() {
                    let u = node(r.index());
                    uses[u] -= 1;
                    if uses[u] == 0 {
                        live -= 1;
                    }
                }
            }
            if uses[id] == 0 {
                live -= 1; // a value nothing uses
            }
        }
        most
    }

    /// On the feedback fields of the paper's models and of the SO(3) extremals, the schedule
    /// is a topological order with every live instruction once, and at its peak it keeps no
    /// more values live than the tape's own order does (fewer on the larger ones).
    #[test]
    fn the_schedule_is_a_topological_order_that_keeps_few_values_live() {
        let models = [
            ("kepler", include_str!("../../../models/kepler.lsl")),
            ("rigid_body", include_str!("../../../models/rigid_body.lsl")),
            ("so3_type_i", include_str!("../../../models/so3_type_i.lsl")),
        ];
        for (name, text) in models {
            let tape = feedback(name, text);
            let p = pair(&tape);
            let n = p.ops.len();
            let mut done = vec![false; n];
            for &v in &p.order {
                let members = match v {
                    Node::Single(i) => vec![i],
                    Node::Pack(q) => p.packs[q].to_vec(),
                };
                for &i in &members {
                    assert!(!done[i], "{name}: r{i} twice");
                    for r in p.ops[i].operands() {
                        let r = r.index();
                        assert!(done[r] || members.contains(&r), "{name}: r{i} before r{r}");
                    }
                }
                for i in members {
                    done[i] = true;
                }
            }
            assert!(tape.outputs.iter().all(|r| done[r.index()]), "{name}");
            // the tape's order: the ready node with the smallest last instruction first
            let last = |v: Node| match v {
                Node::Single(i) => i,
                Node::Pack(q) => p.packs[q][0].max(p.packs[q][1]),
            };
            let mut left = p.order.clone();
            let mut placed = vec![false; n];
            let mut tape_order = Vec::new();
            while !left.is_empty() {
                let ready = |v: Node| {
                    let members = match v {
                        Node::Single(i) => vec![i],
                        Node::Pack(q) => p.packs[q].to_vec(),
                    };
                    members.iter().all(|&i| {
                        p.ops[i]
                            .operands()
                            .all(|r| placed[r.index()] || members.contains(&r.index()))
                    })
                };
                let k = (0..left.len())
                    .filter(|&k| ready(left[k]))
                    .min_by_key(|&k| last(left[k]))
                    .expect("a ready node");
                let v = left.remove(k);
                match v {
                    Node::Single(i) => placed[i] = true,
                    Node::Pack(q) => p.packs[q].iter().for_each(|&i| placed[i] = true),
                }
                tape_order.push(v);
            }
            let (ours, theirs) = (
                peak(&p, &p.order, &tape.outputs),
                peak(&p, &tape_order, &tape.outputs),
            );
            assert!(
                ours <= theirs,
                "{name}: {ours} live values against {theirs}"
            );
            if name == "so3_type_i" {
                assert!(ours < theirs, "{name}: {ours} live values against {theirs}");
            }
        }
    }
}

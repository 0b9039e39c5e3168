//! Families kept as loops (see [`crate::loops`]): a `sum` over index ranges whose body reads
//! the members of indexed state and parameters is lowered once, with one *slot* per member
//! component read (an auxiliary input standing for "component c of member `idx(i, j, …)`"),
//! instead of once per index tuple. The index tuples are enumerated (integer work only) and
//! each slot records, per tuple, the flat state or parameter index it reads.
//!
//! The body may use the indices only inside subscripts (`q[i]`, `q[i + 1]`, `m[j]`); a body
//! that uses an index as a number, holds another family, or subscripts something that is not
//! indexed state or parameters is unrolled as before (the attempt leaves unused nodes in the
//! graph, nothing else).

use super::family::mentions;
use super::lower::{Ctx, Lowerer, L};
use super::{Shape, Value};
use crate::ir::{FxHashMap, Input, Node};
use crate::loops::index::{tuples, Compare, Ix, LoopClause, SlotIndex};
use crate::loops::{Family, Slot, Source};
use crate::parse::ast::*;

/// The state of lowering one family body with slots.
pub(super) struct SlotMode {
    /// The family's index names, outermost first.
    vars: Vec<String>,
    /// Where they sit in `Lowerer::indices`.
    base: usize,
    /// The bound values of every index tuple, in the order the unrolled sum adds them.
    tuples: Vec<Vec<i64>>,
    /// Evaluating a subscript (indices may be used as numbers there).
    pub(super) in_subscript: bool,
    /// Why the body cannot be a loop, once that is known.
    pub(super) failed: Option<&'static str>,
    slots: Vec<Slot>,
    slot_of: FxHashMap<(Source, Vec<u32>), usize>,
}

impl Lowerer {
    /// In a family body being lowered with slots: is `name` one of its indices?
    pub(super) fn slot_index(&self, name: &str) -> bool {
        self.slot
            .as_ref()
            .is_some_and(|s| s.vars.iter().any(|v| v == name))
    }

    /// Marks the family body being lowered with slots as not loopable.
    pub(super) fn slot_fail(&mut self, why: &'static str) {
        if let Some(s) = &mut self.slot {
            s.failed.get_or_insert(why);
        }
    }

    /// `sum(head: body)` as one loop family, if loops are on, the family is large enough and
    /// its body qualifies; `Ok(None)` to unroll it.
    pub(super) fn loop_family(
        &mut self,
        op: FamilyOp,
        head: &FamilyHead,
        body: &Expr,
        ctx: Ctx,
    ) -> L<Option<Value>> {
        let Some(min) = self.loops.as_ref().map(|c| c.min_tuples) else {
            return Ok(None);
        };
        if op != FamilyOp::Sum || ctx != Ctx::Model || self.slot.is_some() {
            self.slot_fail("a family inside a loop family");
            return Ok(None);
        }
        let vars: Vec<String> = head
            .clauses
            .iter()
            .filter_map(|c| match c {
                Clause::Range { var, .. } => Some(var.name.clone()),
                Clause::Cond { .. } => None,
            })
            .collect();
        if !mentions(body, &vars) {
            return Ok(None);
        }
        // The index tuples (the unrolled sum's order); errors in the head as when unrolling.
        let base = self.indices.len();
        let mut tuples: Vec<Vec<i64>> = Vec::new();
        let mut count = 0;
        self.for_each(head, 0, &mut count, &mut |lw| {
            tuples.push(lw.indices[base..].iter().map(|&(_, v)| v).collect());
            Ok(())
        })?;
        if (tuples.len() as u64) < min.max(1) {
            return Ok(None);
        }
        for (v, &x) in vars.iter().zip(&tuples[0]) {
            self.indices.push((v.clone(), x));
        }
        self.slot = Some(SlotMode {
            vars,
            base,
            tuples,
            in_subscript: false,
            failed: None,
            slots: Vec::new(),
            slot_of: FxHashMap::default(),
        });
        let value = self.expr(body, ctx);
        let mode = self.slot.take().expect("set above");
        self.indices.truncate(base);
        let value = value?;
        if mode.failed.is_some() {
            return Ok(None);
        }
        let clauses = self.loop_clauses(head, &mode.vars, &mode.tuples);
        let collector = self.loops.as_mut().expect("checked above");
        let placeholders: Vec<u32> = value.ids.iter().map(|_| collector.symbol()).collect();
        let ids = placeholders
            .iter()
            .map(|&s| self.g.input(Input::Symbol(s)))
            .collect();
        let collector = self.loops.as_mut().expect("checked above");
        collector.families.push(Family {
            count: mode.tuples.len(),
            slots: mode.slots,
            body: value.ids,
            placeholders,
            span: body.span.clone(),
            clauses,
        });
        Ok(Some(Value {
            shape: value.shape,
            ids,
        }))
    }

    /// `x[idx]` inside a family body lowered with slots, when a subscript mentions one of its
    /// indices: one slot per component of the member read. `Ok(None)` if `x[idx]` does not
    /// qualify (the body is then unrolled).
    pub(super) fn slot_member(&mut self, base: &Expr, v: &Value, idx: &[Expr]) -> L<Option<Value>> {
        let Some(mode) = &self.slot else {
            return Ok(None);
        };
        if !mentions_any(idx, &mode.vars) {
            return Ok(None);
        }
        let family = match &base.kind {
            ExprKind::Name(n) => self.families.get(&n.name).copied(),
            _ => None,
        };
        let (k, n, member) = match (v.shape, family, idx.len()) {
            (Shape::Matrix(k, n), Some(m), 1) => (k, n, m),
            (Shape::Vector(n), _, 1) => (1, n, Shape::Scalar),
            _ => {
                self.slot_fail("a subscript that is not a member of a family");
                return Ok(None);
            }
        };
        // The member index of every tuple.
        let (start, count) = {
            let mode = self.slot.as_ref().expect("checked above");
            (mode.base, mode.tuples.len())
        };
        let mut members = Vec::with_capacity(count);
        let mut result = Ok(());
        for t in 0..count {
            let mode = self.slot.as_mut().expect("checked above");
            mode.in_subscript = true;
            for (c, &x) in mode.tuples[t].iter().enumerate() {
                self.indices[start + c].1 = x;
            }
            match self.index(&idx[0], n) {
                Ok(i) => members.push(i),
                Err(d) => {
                    result = Err(d);
                    break;
                }
            }
        }
        let mode = self.slot.as_mut().expect("checked above");
        mode.in_subscript = false;
        let first = mode.tuples[0].clone();
        if result.is_err() {
            // The failing tuple is still bound: the message says where.
            return result.map(|_| None).map_err(|d| self.locate_in_family(d));
        }
        for (c, &x) in first.iter().enumerate() {
            self.indices[start + c].1 = x;
        }
        // The subscript as an expression of the indices, if it reproduces every member read.
        let (vars, tuples) = {
            let mode = self.slot.as_ref().expect("checked above");
            (mode.vars.clone(), mode.tuples.clone())
        };
        let member_ix = self.ix(&idx[0], &vars).filter(|ix| {
            tuples
                .iter()
                .zip(&members)
                .all(|(t, &m)| ix.eval(t) == Some(m as i64))
        });
        let mut ids = Vec::with_capacity(k);
        for c in 0..k {
            let mut column = Vec::with_capacity(count);
            let mut source = None;
            for &i in &members {
                let (s, at) = match *self.g.node(v.ids[i * k + c]) {
                    Node::Input(Input::State(s)) => (Source::State, s),
                    Node::Input(Input::Param(p)) => (Source::Param, p),
                    _ => {
                        self.slot_fail("a member that is not a state or parameter component");
                        return Ok(None);
                    }
                };
                if *source.get_or_insert(s) != s {
                    self.slot_fail(
                        "a member that is state for some indices, parameters for others",
                    );
                    return Ok(None);
                }
                column.push(at);
            }
            let source = source.unwrap_or(Source::State);
            let stride = k as i64;
            let base = i64::from(column[0]) - stride * members[0] as i64;
            let index = member_ix
                .as_ref()
                .filter(|_| {
                    column
                        .iter()
                        .zip(&members)
                        .all(|(&at, &m)| i64::from(at) == base + stride * m as i64)
                })
                .map(|member| SlotIndex {
                    base,
                    stride,
                    member: member.clone(),
                });
            let mode = self.slot.as_mut().expect("checked above");
            let key = (source, column);
            let slot = match mode.slot_of.get(&key) {
                Some(&s) => s,
                None => {
                    let symbol = self.loops.as_mut().expect("on").symbol();
                    let mode = self.slot.as_mut().expect("checked above");
                    mode.slots.push(Slot {
                        symbol,
                        source,
                        column: key.1.clone(),
                        index,
                    });
                    mode.slot_of.insert(key, mode.slots.len() - 1);
                    mode.slots.len() - 1
                }
            };
            let symbol = self.slot.as_ref().expect("checked above").slots[slot].symbol;
            ids.push(self.g.input(Input::Symbol(symbol)));
        }
        Ok(Some(Value { shape: member, ids }))
    }
}

impl Lowerer {
    /// The head's clauses as index expressions, if they enumerate exactly `expected`.
    fn loop_clauses(
        &mut self,
        head: &FamilyHead,
        vars: &[String],
        expected: &[Vec<i64>],
    ) -> Option<Vec<LoopClause>> {
        let mut clauses = Vec::with_capacity(head.clauses.len());
        for c in &head.clauses {
            clauses.push(match c {
                Clause::Range { var, start, end } => LoopClause::Range {
                    var: var.name.clone(),
                    start: self.ix(start, vars)?,
                    end: self.ix(end, vars)?,
                },
                Clause::Cond { lhs, op, rhs } => LoopClause::Cond {
                    lhs: self.ix(lhs, vars)?,
                    op: match op {
                        IndexComparison::Eq => Compare::Eq,
                        IndexComparison::Ne => Compare::Ne,
                        IndexComparison::Less => Compare::Lt,
                        IndexComparison::LessEq => Compare::Le,
                        IndexComparison::Greater => Compare::Gt,
                        IndexComparison::GreaterEq => Compare::Ge,
                    },
                    rhs: self.ix(rhs, vars)?,
                },
            });
        }
        (tuples(&clauses, expected.len() + 1)?.as_slice() == expected).then_some(clauses)
    }

    /// `e` as an integer expression of the indices `vars`: whole literals, the indices,
    /// constants (by value) and `+ - * %`; `None` for anything else.
    fn ix(&mut self, e: &Expr, vars: &[String]) -> Option<Ix> {
        if !mentions(e, vars) {
            let saved = self.slot.as_ref().map(|m| m.failed);
            let k = self.integer(e, "an index").ok();
            if let (Some(mode), Some(failed)) = (self.slot.as_mut(), saved) {
                mode.failed = failed;
            }
            return k.map(Ix::Int);
        }
        match &e.kind {
            ExprKind::Name(n) => vars.iter().position(|v| *v == n.name).map(Ix::Var),
            ExprKind::Neg(a) => Some(Ix::Sub(Box::new(Ix::Int(0)), Box::new(self.ix(a, vars)?))),
            ExprKind::Chain(first, rest) => {
                let mut acc = self.ix(first, vars)?;
                for (op, x) in rest {
                    let (a, b) = (Box::new(acc), Box::new(self.ix(x, vars)?));
                    acc = match op {
                        BinOp::Add => Ix::Add(a, b),
                        BinOp::Sub => Ix::Sub(a, b),
                        BinOp::Mul => Ix::Mul(a, b),
                        BinOp::Rem => Ix::Rem(a, b),
                        BinOp::Div | BinOp::Pow => return None,
                    };
                }
                Some(acc)
            }
            _ => None,
        }
    }
}

fn mentions_any(idx: &[Expr], vars: &[String]) -> bool {
    idx.iter().any(|e| mentions(e, vars))
}

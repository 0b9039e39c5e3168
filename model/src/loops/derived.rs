//! The derived functions of a [`LoopModel`] as loop tapes: the Jacobian Df of the invariants,
//! V, ∇V and X − ∇V, and the half-fields of a partitioned field.
//!
//! - **Df.** An invariant is a plain part plus family terms `c·body` reduced into its output
//!   `o`. Row `o` of Df is the plain part's gradient plus, per family term, the body's partial
//!   with respect to each state component it reads — a slot `k` of tuple `t` reads
//!   `gather[t, k]`, so the partial is scattered to `o·N + gather[t, k]`.
//! - **V, ∇V, X − ∇V** in three stages. V reads the state x, the targets, the gains and the
//!   family sums `S_k` its invariants hold. Stage 1 computes the sums, a loop tape of the
//!   state: for V alone [`LoopFeedback::sums`]; for ∇V and X − ∇V [`LoopFeedback::pass`], which
//!   in the same loop over each family's tuples carries C: per sum, its gradient `∇S_k` (the
//!   body's partials, scattered to the components the slots read) on each state member it
//!   reaches, then the field's family outputs on each member they reach. A Hamiltonian term
//!   `c·body` whose body is a sum V reads (the energy's) is not run again: its equations are
//!   `c·J∇S_k`, read from that sum's gradient. Stage 2 ([`LoopFeedback::weights`]) computes V
//!   and the weights `w_k = ∂V/∂S_k` from `[x, S]`, a plain tape. Stage 3 is the chain rule
//!   `∇V = ∂V/∂x|_S + Σ_k w_k ∇S_k`, a loop tape of `[x, S, C, w]` whose plain part is
//!   `∂V/∂x|_S` and whose regions are, per state member, a loop over its components adding
//!   `Σ_k w_k ∇S_k` there (their structure as families of one index,
//!   [`LoopFeedback::families`]). X − ∇V is the same with the field's plain part, its carried
//!   family outputs and the shared Hamiltonian terms added. So each family's body runs once
//!   per tuple, and the code stays independent of the number of tuples.
//! - **Half-fields.** The field's loop tape restricted to the outputs of each half of the
//!   partition; the partition is the 2-colouring of [`Model::partition`](crate::Model::partition)
//!   with the edges read from the plain part and the regions' gather and scatter tables.
//!
//! Every stage is an ordinary [`LoopTape`] or [`Tape`], so the back ends that agree bit for bit
//! on those agree on the stages, run in this order.

use super::{Builder, Family, LoopModel, LoopTape, Outputs, Region, Source};
use crate::error::Error;
use crate::ir::{gradient, Id, Input, Node};
use crate::tape::{Dims, Tape, TapeError};

/// V, ∇V and X − ∇V of a [`LoopModel`] in stages (see the [module docs](super)); K is the
/// number of family sums V reads, D the number of values the pass carries to the last stage
/// ([`LoopFeedback::carried`]), N the state's and M the invariants' components.
#[derive(Clone, Debug)]
pub struct LoopFeedback {
    /// V's stage 1: the sums S from the state (N inputs, K outputs).
    pub sums: LoopTape,
    /// Stage 2: V and w = ∂V/∂S (1 + K outputs) from `[x, S]` (N + K state inputs), the M
    /// targets and the gains.
    pub weights: Tape,
    /// Stage 1 of ∇V and X − ∇V: the sums S and the carried values (K + D outputs) from the
    /// state, in one pass over each family's tuples. Where nothing is carried, `sums`.
    pub pass: LoopTape,
    /// Stage 3: ∇V (N outputs) from `[x, S, carried, w]` (N + 2K + D state inputs), the
    /// targets and gains.
    pub gradient: LoopTape,
    /// Stage 3: X − ∇V (N outputs), with the inputs of `gradient`.
    pub feedback: LoopTape,
    /// The loops of stage 3 over the state's members, as families: region `r` of `gradient`
    /// or `feedback` with `r.family` ≥ F (the model's [`LoopModel::families`]) runs
    /// `families[r.family − F]`.
    pub families: Vec<Family>,
}

/// The half-fields of a partitioned loop field (q̇ = a(p), ṗ = b(q)).
#[derive(Clone, Debug)]
pub struct LoopPartition {
    /// `true` at the q components of the state.
    pub is_q: Vec<bool>,
    /// The field components where `is_q`, in order.
    pub field_q: LoopTape,
    /// The field components where `!is_q`, in order.
    pub field_p: LoopTape,
}

/// Where a state variable of a family reads, per tuple.
#[derive(Clone, Copy)]
pub(super) enum Column {
    /// Slot k of the family.
    Slot(usize),
    /// The same component every tuple (state the body reads directly).
    Fixed(u32),
}

impl LoopModel {
    /// Df, row-major: M × N outputs, `∂f_c/∂x_i` at `c·N + i` (the layout of
    /// [`ModelTapes::jacobian`](crate::tape::ModelTapes)).
    pub fn jacobian(&self) -> Result<LoopTape, Error> {
        let mut b = Builder::new(self);
        let m = &self.model;
        let n = m.dim();
        let vars: Vec<Input> = (0..n as u32).map(Input::State).collect();
        let mut roots = Vec::with_capacity(m.invariant_dim() * n);
        let mut outs = Outputs::default();
        for f in &m.invariants {
            for (c, &id) in f.value.ids.iter().enumerate() {
                let o = (f.offset + c) as u32;
                let mut terms = Outputs::default();
                let e0 = b.split(id, o, &f.span, &mut terms)?;
                roots.extend(gradient(&mut b.g, e0, &vars));
                for (fam, list) in terms {
                    for (term, col) in list {
                        b.partials(fam, term, |t, at| col[t] * n as u32 + at, &mut outs);
                    }
                }
            }
        }
        b.tape(&roots, b.dims(0, false), outs)
    }

    /// V, ∇V and X − ∇V in three stages. Refused (with a located message) where the field is:
    /// see [`LoopModel::tapes`].
    pub fn feedback(&self) -> Result<LoopFeedback, Error> {
        let mut b = Builder::new(self);
        let m = &self.model;
        let n = m.dim() as u32;
        // The sums V reads, in (family, component) order.
        let mut used: Vec<(usize, usize, u32)> =
            b.g.reachable(&[m.lyapunov])
                .into_iter()
                .filter_map(|id| match b.g.node(id) {
                    Node::Input(Input::Symbol(s)) => b.placeholder.get(s).map(|&(f, c)| (f, c, *s)),
                    _ => None,
                })
                .collect();
        used.sort_unstable();
        let k = used.len() as u32;
        // Stage 1.
        let mut outs = Outputs::default();
        for (i, &(f, c, _)) in used.iter().enumerate() {
            let fam = &self.families[f];
            outs.entry(f)
                .or_default()
                .push((fam.body[c], vec![i as u32; fam.count]));
        }
        let zero = b.g.num(0.0);
        let sums = b.tape(&vec![zero; used.len()], b.dims(0, false), outs)?;
        // Stage 2: V and its partials by the state (with S fixed) and by the sums.
        let mut vars: Vec<Input> = (0..n).map(Input::State).collect();
        vars.extend(used.iter().map(|&(_, _, s)| Input::Symbol(s)));
        let grad = gradient(&mut b.g, m.lyapunov, &vars);
        let at: crate::ir::FxHashMap<u32, u32> = used
            .iter()
            .enumerate()
            .map(|(i, &(_, _, s))| (s, n + i as u32))
            .collect();
        let mut v_w = vec![m.lyapunov];
        v_w.extend_from_slice(&grad[n as usize..]);
        let v_w = b.g.rename_inputs(&v_w, |i| match i {
            Input::Symbol(s) => at.get(&s).map_or(i, |&x| Input::State(x)),
            _ => i,
        });
        let explicit = b.g.rename_inputs(&grad[..n as usize], |i| match i {
            Input::Symbol(s) => at.get(&s).map_or(i, |&x| Input::State(x)),
            _ => i,
        });
        let internal = |e: TapeError| Error::Internal(format!("loop tape of V: {e}"));
        let weights = Tape::from_graph(&b.g, &v_w, b.dims(k as usize, true)).map_err(internal)?;
        // The pass: per family, its sums, their partials (the entries of ∇S_k) and its
        // outputs of the field, scattered to `[S, D]`.
        let mut pass_outs = Outputs::default();
        for (i, &(f, c, _)) in used.iter().enumerate() {
            let fam = &self.families[f];
            pass_outs
                .entry(f)
                .or_default()
                .push((fam.body[c], vec![i as u32; fam.count]));
        }
        // ∇S_i's entries at the components they reach (`reach[i]`, increasing).
        let mut grads: Vec<Outputs> = Vec::with_capacity(used.len());
        let mut reach: Vec<Vec<u32>> = Vec::with_capacity(used.len());
        for &(f, c, _) in &used {
            let mut outs = Outputs::default();
            let body = self.families[f].body[c];
            b.partials(f, body, |_, at| at, &mut outs);
            reach.push(reached(&outs));
            grads.push(outs);
        }
        // The state's members: the combination runs as one loop per member.
        let members: Vec<(u32, u32)> = m
            .state
            .iter()
            .map(|v| (v.offset as u32, v.shape.len() as u32))
            .collect();
        let mut member_of = vec![0usize; n as usize];
        for (j, &(o, len)) in members.iter().enumerate() {
            member_of[o as usize..(o + len) as usize].fill(j);
        }
        let touched = |r: &[u32]| -> Vec<usize> {
            let mut t: Vec<usize> = r.iter().map(|&s| member_of[s as usize]).collect();
            t.dedup();
            t
        };
        let grad_members: Vec<Vec<usize>> = reach.iter().map(|r| touched(r)).collect();
        // The field: its plain part, its explicit family outputs, and the Hamiltonian's terms;
        // a term whose body is a sum V reads (the energy's) is not run again, its equations
        // are read from that sum's gradient: c·J∇S_i, member by member.
        let (field_roots, mut field_outs, hamiltonian) = b.field_parts()?;
        // (sum i, factor c·sign, member read, member written)
        let mut shared: Vec<(usize, f64, usize, usize)> = Vec::new();
        if let Some(h) = hamiltonian {
            // validates the terms as the field does (canonical pairs, consistent members)
            let mut check = Outputs::default();
            b.hamilton(&h.terms, &h.q, &h.p, &mut check)?;
            let mut partner: Vec<Option<(u32, f64)>> = vec![None; n as usize];
            for (&qa, &pa) in h.q.iter().zip(&h.p) {
                partner[qa] = Some((pa as u32, -1.0));
                partner[pa] = Some((qa as u32, 1.0));
            }
            // member j's partner member and sign, where the pairing maps it whole and in order
            let paired: Vec<Option<(usize, f64)>> = members
                .iter()
                .map(|&(o, len)| {
                    let (to, sign) = partner[o as usize]?;
                    let to_member = member_of[to as usize];
                    let (to_o, to_len) = members[to_member];
                    let whole = to_len == len
                        && (0..len).all(|s| partner[(o + s) as usize] == Some((to_o + s, sign)));
                    whole.then_some((to_member, sign))
                })
                .collect();
            let mut rest = Outputs::default();
            for &(f, c, coeff) in &h.coefficients {
                let body = self.families[f].body[c];
                let direct = b
                    .state_vars(f, &[body])
                    .iter()
                    .all(|(_, v)| matches!(v, Column::Slot(_)));
                let i = used.iter().position(|&(uf, uc, _)| (uf, uc) == (f, c));
                let pairs = i.and_then(|i| {
                    grad_members[i]
                        .iter()
                        .map(|&j| paired[j].map(|(to, sign)| (i, coeff * sign, j, to)))
                        .collect::<Option<Vec<_>>>()
                });
                match pairs {
                    Some(pairs) if direct => shared.extend(pairs),
                    _ => {
                        let k = b.g.num(coeff);
                        let term = b.g.mul(&[k, body]);
                        let count = self.families[f].count;
                        rest.entry(f).or_default().push((term, vec![0; count]));
                    }
                }
            }
            b.hamilton(&rest, &h.q, &h.p, &mut field_outs)?;
        }
        // The carried values: per sum, its gradient on each member it reaches, then the
        // field's family outputs on each member they reach, each block the member's length.
        let mut d = 0u32;
        let mut block = |j: usize| {
            let at = d;
            d += members[j].1;
            at
        };
        let grad_at: Vec<Vec<u32>> = grad_members
            .iter()
            .map(|js| js.iter().map(|&j| block(j)).collect())
            .collect();
        let field_reach = reached(&field_outs);
        let field_members = touched(&field_reach);
        let field_at: Vec<u32> = field_members.iter().map(|&j| block(j)).collect();
        // carried index of component s in sum i's gradient, in the field's part
        let in_block = |js: &[usize], at: &[u32], s: u32| -> u32 {
            let j = member_of[s as usize];
            let pos = js.iter().position(|&x| x == j).expect("a reached member");
            at[pos] + s - members[j].0
        };
        for (i, outs) in grads.into_iter().enumerate() {
            for (f, list) in outs {
                for (e, col) in list {
                    let col = col
                        .iter()
                        .map(|&s| k + in_block(&grad_members[i], &grad_at[i], s))
                        .collect();
                    pass_outs.entry(f).or_default().push((e, col));
                }
            }
        }
        for (f, list) in field_outs {
            for (e, col) in list {
                let col = col
                    .iter()
                    .map(|&o| k + in_block(&field_members, &field_at, o))
                    .collect();
                pass_outs.entry(f).or_default().push((e, col));
            }
        }
        let pass = b.tape(&vec![zero; (k + d) as usize], b.dims(0, false), pass_outs)?;
        // The last stage, of `[x, S, C, w]`: ∇V = ∂V/∂x|_S + Σ_i w_i ∇S_i and X − ∇V = X's
        // plain part + its family outputs + c·J∇S_i of the shared terms − ∇V: the plain parts,
        // then per member a loop over its components.
        let dims = b.dims((2 * k + d) as usize, true);
        let mut gradient_tape = b.tape(&explicit, dims, Outputs::default())?;
        let roots: Vec<Id> = field_roots
            .iter()
            .zip(&explicit)
            .map(|(&x, &e)| b.g.sub(x, e))
            .collect();
        let mut feedback = b.tape(&roots, dims, Outputs::default())?;
        let carried = n + k;
        let weight = |i: usize| n + k + d + i as u32;
        let mut families = Vec::new();
        let first = self.families.len();
        for (to, &(o, len)) in members.iter().enumerate() {
            // ∇V: Σ w_i ∇S_i on this member
            let mut grad_terms = Vec::new(); // (carried block, weight)
            for (i, js) in grad_members.iter().enumerate() {
                if let Some(pos) = js.iter().position(|&j| j == to) {
                    grad_terms.push((carried + grad_at[i][pos], weight(i)));
                }
            }
            let mut plus = Vec::new(); // (carried block, factor)
            if let Some(pos) = field_members.iter().position(|&j| j == to) {
                plus.push((carried + field_at[pos], 1.0));
            }
            for &(i, factor, from, _) in shared.iter().filter(|sh| sh.3 == to) {
                let pos = grad_members[i].iter().position(|&j| j == from);
                plus.push((carried + grad_at[i][pos.expect("a reached member")], factor));
            }
            let span = &m.state[to].span;
            if !grad_terms.is_empty() {
                let r = self.combination(&[], &grad_terms, 1.0, (o, len), span, dims)?;
                gradient_tape
                    .regions
                    .push(r.0.with_family(first + families.len()));
                families.push(r.1);
            }
            if !grad_terms.is_empty() || !plus.is_empty() {
                let r = self.combination(&plus, &grad_terms, -1.0, (o, len), span, dims)?;
                feedback
                    .regions
                    .push(r.0.with_family(first + families.len()));
                families.push(r.1);
            }
        }
        Ok(LoopFeedback {
            sums,
            weights,
            pass,
            gradient: gradient_tape,
            feedback,
            families,
        })
    }

    /// One loop of the last stage over the components `o..o + len` of a member, adding to
    /// component `o + c` `Σ factor·C[block + c]` over `plus` plus `sign·Σ w·C[block + c]` over
    /// `weighted` (`(block, weight's input)`); its loop's structure as a family.
    fn combination(
        &self,
        plus: &[(u32, f64)],
        weighted: &[(u32, u32)],
        sign: f64,
        (o, len): (u32, u32),
        span: &crate::error::Span,
        dims: Dims,
    ) -> Result<(Region, Family), Error> {
        use super::index::{Ix, LoopClause, SlotIndex};
        use super::Slot;
        let indexed: Vec<u32> = plus
            .iter()
            .map(|p| p.0)
            .chain(weighted.iter().map(|w| w.0))
            .collect();
        let slots = indexed.len() + weighted.len();
        let mut g = crate::ir::Graph::new();
        let mut terms = Vec::new();
        for (j, &(_, factor)) in plus.iter().enumerate() {
            let v = g.input(Input::State(j as u32));
            terms.push(if factor == 1.0 {
                v
            } else {
                let c = g.num(factor);
                g.mul(&[c, v])
            });
        }
        let mut products = Vec::new();
        for j in 0..weighted.len() {
            let v = g.input(Input::State((plus.len() + j) as u32));
            let w = g.input(Input::State((indexed.len() + j) as u32));
            products.push(g.mul(&[w, v]));
        }
        if !products.is_empty() {
            let sum = g.add(&products);
            terms.push(if sign == 1.0 { sum } else { g.neg(sum) });
        }
        let root = g.add(&terms);
        let rdims = Dims {
            state: slots,
            params: dims.params,
            targets: 0,
            gains: 0,
        };
        let tape = Tape::from_graph(&g, &[root], rdims)
            .map_err(|e| Error::Internal(format!("loop tape of X − ∇V: {e}")))?;
        let count = len as usize;
        let mut gather = Vec::with_capacity(count * slots);
        for c in 0..len {
            gather.extend(indexed.iter().map(|&at| at + c));
            gather.extend(weighted.iter().map(|w| w.1));
        }
        let slot = |at: u32| Slot {
            symbol: 0,
            source: Source::State,
            column: (0..len).map(|c| at + c).collect(),
            index: Some(SlotIndex {
                base: i64::from(at),
                stride: 1,
                member: Ix::Var(0),
            }),
        };
        let family = Family {
            count,
            slots: indexed.iter().map(|&at| slot(at)).collect(),
            body: Vec::new(),
            placeholders: Vec::new(),
            span: span.clone(),
            clauses: Some(vec![LoopClause::Range {
                var: "c".into(),
                start: Ix::Int(0),
                end: Ix::Int(i64::from(len)),
            }]),
        };
        let region = Region {
            tape,
            sources: vec![Source::State; slots],
            gather,
            scatter: (o..o + len).collect(),
            count,
            family: 0,
        };
        Ok((region, family))
    }

    /// The half-fields, if the field is partitioned (as [`Model::partition`](crate::Model::partition)
    /// decides on the unrolled field). Refused where a family adds to both halves.
    pub fn partition(&self) -> Result<Option<LoopPartition>, Error> {
        let mut b = Builder::new(self);
        let (roots, field) = b.field()?;
        let m = &self.model;
        let nb = m.state.len();
        let mut block_of = vec![0usize; m.dim()];
        for (i, s) in m.state.iter().enumerate() {
            block_of[s.offset..s.offset + s.shape.len()].fill(i);
        }
        let mut edge = vec![false; nb * nb];
        let mut add = |a: usize, c: usize| {
            if a == c {
                return false; // a rate that depends on its own group
            }
            edge[a * nb + c] = true;
            edge[c * nb + a] = true;
            true
        };
        for (o, &r) in roots.iter().enumerate() {
            for id in b.g.reachable(&[r]) {
                if let Node::Input(Input::State(s)) = b.g.node(id) {
                    if !add(block_of[o], block_of[*s as usize]) {
                        return Ok(None);
                    }
                }
            }
        }
        for (&f, list) in &field {
            let fam = &self.families[f];
            for (e, col) in list {
                for (_, v) in b.state_vars(f, &[*e]) {
                    for (t, &o) in col.iter().enumerate() {
                        let s = match v {
                            Column::Slot(k) => fam.slots[k].column[t],
                            Column::Fixed(s) => s,
                        };
                        if !add(block_of[o as usize], block_of[s as usize]) {
                            return Ok(None);
                        }
                    }
                }
            }
        }
        let edges: Vec<Vec<usize>> = (0..nb)
            .map(|a| (0..nb).filter(|&c| edge[a * nb + c]).collect())
            .collect();
        let Some(is_q) = m.colour_blocks(&edges) else {
            return Ok(None);
        };
        let mut half = |q: bool| -> Result<LoopTape, Error> {
            let mut pos = vec![u32::MAX; is_q.len()];
            let mut next = 0;
            for (o, &x) in is_q.iter().enumerate() {
                if x == q {
                    pos[o] = next;
                    next += 1;
                }
            }
            let part: Vec<Id> = (roots.iter().zip(&is_q))
                .filter(|(_, &x)| x == q)
                .map(|(&id, _)| id)
                .collect();
            let mut outs = Outputs::default();
            for (&f, list) in &field {
                for (e, col) in list {
                    let inside = col.iter().filter(|&&o| is_q[o as usize] == q).count();
                    if inside == 0 {
                        continue;
                    }
                    if inside != col.len() {
                        return Err(b.refuse(
                            &self.families[f].span,
                            "this family adds to both halves of the partitioned field",
                            "load the model with its families unrolled",
                        ));
                    }
                    let col = col.iter().map(|&o| pos[o as usize]).collect();
                    outs.entry(f).or_default().push((*e, col));
                }
            }
            b.tape(&part, b.dims(0, false), outs)
        };
        let field_q = half(true)?;
        let field_p = half(false)?;
        Ok(Some(LoopPartition {
            is_q,
            field_q,
            field_p,
        }))
    }
}

impl Builder<'_> {
    /// The model's dims with `extra` more state inputs, with or without its targets and gains.
    fn dims(&self, extra: usize, feedback: bool) -> Dims {
        let m = &self.lm.model;
        Dims {
            state: m.dim() + extra,
            params: m.param_slots(),
            targets: if feedback { m.invariant_dim() } else { 0 },
            gains: if feedback { m.gains.len() } else { 0 },
        }
    }

    /// The state family `f`'s expressions `exprs` read, as variables with where they read:
    /// its state slots, then the model's state they read directly (components beyond the
    /// model's state — the weights of ∇V — are not variables).
    pub(super) fn state_vars(&self, f: usize, exprs: &[Id]) -> Vec<(Input, Column)> {
        let fam = &self.lm.families[f];
        let n = self.lm.model.dim() as u32;
        let reach = self.g.reachable(exprs);
        let mut symbols = crate::ir::FxHashMap::default();
        let mut fixed = Vec::new();
        for id in reach {
            match self.g.node(id) {
                Node::Input(Input::Symbol(s)) => {
                    symbols.insert(*s, ());
                }
                Node::Input(Input::State(s)) if *s < n => fixed.push(*s),
                _ => {}
            }
        }
        fixed.sort_unstable();
        let mut vars: Vec<(Input, Column)> = fam
            .slots
            .iter()
            .enumerate()
            .filter(|(_, s)| s.source == Source::State && symbols.contains_key(&s.symbol))
            .map(|(k, s)| (Input::Symbol(s.symbol), Column::Slot(k)))
            .collect();
        vars.extend(
            fixed
                .into_iter()
                .map(|s| (Input::State(s), Column::Fixed(s))),
        );
        vars
    }

    /// Adds to `outs` the partials of family `f`'s expression `term` by its state variables,
    /// each scattered per tuple `t` to `place(t, component the variable reads)`.
    fn partials(
        &mut self,
        f: usize,
        term: Id,
        place: impl Fn(usize, u32) -> u32,
        outs: &mut Outputs,
    ) {
        let vars = self.state_vars(f, &[term]);
        let inputs: Vec<Input> = vars.iter().map(|v| v.0).collect();
        let grad = gradient(&mut self.g, term, &inputs);
        let fam = &self.lm.families[f];
        for ((_, v), d) in vars.into_iter().zip(grad) {
            if self.g.as_num(d) == Some(0.0) {
                continue;
            }
            let column = (0..fam.count)
                .map(|t| {
                    let at = match v {
                        Column::Slot(k) => fam.slots[k].column[t],
                        Column::Fixed(s) => s,
                    };
                    place(t, at)
                })
                .collect();
            outs.entry(f).or_default().push((d, column));
        }
    }
}

impl LoopFeedback {
    /// The number D of values the pass carries to the last stage after the sums.
    pub fn carried(&self) -> usize {
        self.pass.n_outputs() - self.sums.n_outputs()
    }

    /// V at a state, in f64 from the tapes (stages 1 and 2).
    fn value(
        &self,
        params: &[f64],
        x: &[f64],
        targets: &[f64],
        gains: &[f64],
    ) -> Result<f64, TapeError> {
        let mut xs = x.to_vec();
        xs.extend(self.sums.eval(params, x)?);
        Ok(self.weights.eval(params, &xs, targets, gains)?[0])
    }

    /// `[x, S, carried, w]` at a state, in f64 from the tapes (the pass, then stage 2).
    fn stages(
        &self,
        params: &[f64],
        x: &[f64],
        targets: &[f64],
        gains: &[f64],
    ) -> Result<Vec<f64>, TapeError> {
        let k = self.sums.n_outputs();
        let mut xs = x.to_vec();
        xs.extend(self.pass.eval(params, x)?);
        let vw = self
            .weights
            .eval(params, &xs[..x.len() + k], targets, gains)?;
        xs.extend_from_slice(&vw[1..]);
        Ok(xs)
    }

    /// V evaluated from the tapes (the reference the back ends agree with bit for bit).
    pub fn eval_lyapunov(
        &self,
        params: &[f64],
        x: &[f64],
        targets: &[f64],
        gains: &[f64],
    ) -> Result<f64, TapeError> {
        self.value(params, x, targets, gains)
    }

    /// ∇V evaluated from the tapes.
    pub fn eval_gradient(
        &self,
        params: &[f64],
        x: &[f64],
        targets: &[f64],
        gains: &[f64],
    ) -> Result<Vec<f64>, TapeError> {
        let xsw = self.stages(params, x, targets, gains)?;
        self.gradient.eval_with(params, &xsw, targets, gains)
    }

    /// X − ∇V evaluated from the tapes.
    pub fn eval_feedback(
        &self,
        params: &[f64],
        x: &[f64],
        targets: &[f64],
        gains: &[f64],
    ) -> Result<Vec<f64>, TapeError> {
        let xsw = self.stages(params, x, targets, gains)?;
        self.feedback.eval_with(params, &xsw, targets, gains)
    }
}

/// The components the outputs' scatter columns reach, increasing.
fn reached(outs: &Outputs) -> Vec<u32> {
    let mut r: Vec<u32> = outs
        .values()
        .flatten()
        .flat_map(|(_, col)| col.iter().copied())
        .collect();
    r.sort_unstable();
    r.dedup();
    r
}

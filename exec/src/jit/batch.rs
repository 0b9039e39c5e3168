//! A batch of steps compiled whole: the loop of [`CompiledStep`]'s batches
//! (`lasalle_runtime::CompiledStep`) as native code around a step tape's `eval`.
//!
//! `batch(hoisted, a, target, gains, b, k) -> taken` runs up to k steps on the state in `a`,
//! each reading one buffer and writing the other (a, b, a, …), and stops before the first
//! step whose new state is not finite or whose guards' margins fail (`m > 0` for a strict
//! guard, `m ≥ 0` otherwise; NaN fails both), as the Rust loop does. It returns the steps
//! taken: the state after them is in `a` if that number is even, in `b` if odd. Each step is
//! `eval`'s instructions, in its order, so the states are bitwise those of k calls of
//! `eval`; what the batch saves is the call per step and the check in Rust, and the loop
//! keeps the pointers and the counter in registers.
//!
//! A state of at most [`CARRIED`] components (rigid body, Kepler, the SO(3) models, …), the
//! batch also
//! - carries in registers, as the previous step computed it (only the first step loads it
//!   from `a`): read back from the buffer just stored, each step would wait for the stores
//!   on the loop's critical path, and a 128-bit load of two components that two stores
//!   wrote (`x[3]`, `x[4]` after the stores of `x[2..4]` and `x[4..6]`) cannot be forwarded
//!   from them at all;
//! - computes what is the same for every step (the instructions, packs and operand vectors
//!   of targets, gains, hoisted values and constants alone) once, before the loop, into a
//!   stack area the loop reads at each use, so none of it holds a register;
//! - puts each operand vector gathered from scalars and lanes together once per step;
//!
//! and is compiled at `opt_level = none`, like `eval` (see `mod.rs`), in the pairing's
//! order: at `speed`, Cranelift's e-graph re-orders the body (depth first from the stores)
//! and keeps the invariants in registers spilled around it, which made the rigid body's
//! steps slower by a seventh. A longer state is read from the buffers and the batch compiled
//! at `speed`: there (a chain of 16 particles, 32 components) the pairing's order spills
//! more than the e-graph's.
//!
//! [`CompiledStep`]: lasalle_runtime::CompiledStep

use std::collections::HashMap;

use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{
    types, BlockArg, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Value,
};

use super::{input, offset, scalar_flags, slp, vector_flags, Args, Emit, JitKernel, Mode};
use super::{Stored, F64X2};
use crate::{ExecError, Op, Reg, Tape};

/// The most state components a batch carries in registers from step to step: 8 two-lane
/// vectors, half the vector registers of x86-64.
pub(super) const CARRIED: usize = 16;

/// Whether a batch of steps on `n` state components carries them in registers (and is
/// compiled at `opt_level = none`, see the module's documentation).
pub(super) fn carries(n: usize) -> bool {
    n <= CARRIED
}

impl JitKernel {
    /// Compiles a step tape whose first `n` outputs are the new state and the others the
    /// guards' margins (`strict` per margin): `eval` and `lanes` as [`JitKernel::new`], and
    /// the batch of steps ([`Kernel::raw_batch`](crate::Kernel::raw_batch)).
    pub fn with_batch(tape: &Tape, n: usize, strict: &[bool]) -> Result<JitKernel, ExecError> {
        if n + strict.len() != tape.outputs.len() {
            return Err(ExecError::Jit(format!(
                "a batch of steps of {n} components and {} guards, on a tape of {} outputs",
                strict.len(),
                tape.outputs.len()
            )));
        }
        let mut kernel = JitKernel::new(tape)?;
        let (code, f, compiled) = Self::compile(tape, Mode::Batch { n, strict })?;
        // the batch reads the vector slots `hoist` appends for `eval`: the same pairing, so
        // the same slots, in the same order
        if compiled.slots != kernel.slots {
            return Err(ExecError::Jit(
                "the batch of steps pairs its instructions unlike eval".into(),
            ));
        }
        // SAFETY: the function was just defined with exactly this signature (five pointers and
        // an i64, returning an i64, in the host's C convention); `code` owns it and lives in
        // the kernel.
        let f = unsafe { std::mem::transmute::<*const u8, lasalle_runtime::RawBatch>(f) };
        kernel.batch = Some((code, f));
        Ok(kernel)
    }
}

impl Emit<'_> {
    /// The batch's loop around `eval`'s body; `args.state` is buffer a, `args.out` buffer b.
    /// Returns the number of instructions computed in pairs.
    pub(super) fn batch(
        &mut self,
        tape: &Tape,
        args: &Args,
        k: Value,
        n: usize,
        strict: &[bool],
    ) -> Result<usize, ExecError> {
        let [pre, head, advance, exit] = [(); 4].map(|()| self.b.create_block());
        let i = self.b.append_block_param(head, types::I64);
        let from = self.b.append_block_param(head, self.ptr);
        let to = self.b.append_block_param(head, self.ptr);
        let taken = self.b.append_block_param(exit, types::I64);
        let zero = self.b.ins().iconst(types::I64, 0);
        self.b
            .ins()
            .brif(k, pre, &[], exit, &[BlockArg::Value(zero)]);

        // before the loop, for a carried state: the invariants, and the first step's state
        self.b.switch_to_block(pre);
        let pairing = self.pairing(tape, args)?;
        self.number_slots(&pairing, args);
        let carry = carries(n);
        let pieces = if carry {
            self.gathered = Some(HashMap::new());
            self.hoist_invariants(&pairing, args)?;
            state_pieces(tape, &pairing, n)
        } else {
            Vec::new()
        };
        let mut start: Vec<BlockArg> = [zero, args.state, args.out].map(BlockArg::Value).into();
        let mut carried = Vec::with_capacity(n);
        for &(j, pair) in &pieces {
            let (ty, flags) = if pair {
                (F64X2, vector_flags())
            } else {
                (types::F64, scalar_flags())
            };
            let v = self.b.ins().load(ty, flags, args.state, offset(j)?);
            start.push(BlockArg::Value(v));
            let v = self.b.append_block_param(head, ty);
            if pair {
                carried.extend([(v, Some(0)), (v, Some(1))]);
            } else {
                carried.push((v, None));
            }
        }
        self.b.ins().jump(head, &start);

        self.b.switch_to_block(head);
        if carry {
            self.carried = Some(carried);
        } else {
            self.state_written = true;
        }
        let step = Args {
            state: from,
            out: to,
            ..*args
        };
        let (paired, stored) = self.body(tape, &pairing, &step)?;
        let holds = self.step_holds(&stored, n, strict);
        self.b
            .ins()
            .brif(holds, advance, &[], exit, &[BlockArg::Value(i)]);

        // the next step reads the pieces of the state this one stored
        self.b.switch_to_block(advance);
        let next = self.b.ins().iadd_imm_s(i, 1);
        let more = self.b.ins().icmp(IntCC::UnsignedLessThan, next, k);
        let mut again: Vec<BlockArg> = [next, to, from].map(BlockArg::Value).into();
        let mut pieces = pieces.iter().peekable();
        let mut j = 0;
        for &s in &stored {
            let (v, width) = match s {
                Stored::Pair(v) => (v, 2),
                Stored::Single(v) => (v, 1),
            };
            while let Some(&&(first, pair)) = pieces.peek().filter(|p| p.0 < j + width) {
                // a pair whose second output is a margin is a piece of one component
                let v = match (pair, s) {
                    (false, Stored::Pair(_)) => self.b.ins().extractlane(v, (first - j) as u8),
                    _ => v,
                };
                again.push(BlockArg::Value(v));
                pieces.next();
            }
            j += width;
        }
        self.b
            .ins()
            .brif(more, head, &again, exit, &[BlockArg::Value(next)]);

        self.b.switch_to_block(exit);
        self.b.ins().return_(&[taken]);
        Ok(paired)
    }

    /// Numbers the vector slots in the order `eval` does ([`Emit::slot`]), before the loop
    /// reads any: the batch reads `eval`'s slots, and emits the instructions of invariants
    /// first.
    fn number_slots(&mut self, pairing: &slp::Pairing, args: &Args) {
        for &node in &pairing.order {
            let slp::Node::Pack(p) = node else { continue };
            let [a, b] = pairing.packs[p];
            if input(args, self.ops[a]).is_some() {
                continue;
            }
            let (xs, ys) = (self.ops[a].operands(), self.ops[b].operands());
            for (x, y) in xs.zip(ys) {
                let (ox, oy) = (self.ops[x.index()], self.ops[y.index()]);
                if pairing.pack_of(x, y).is_none() && slp::invariant_pair(ox, oy) {
                    self.slot(x, y);
                }
            }
        }
    }

    /// Computes, in the current block (before the loop), the instructions and packs that are
    /// the same for every step, and the operand vectors of two such values that the loop's
    /// packs read, and stores them in a stack area ([`Invariants`]).
    fn hoist_invariants(&mut self, pairing: &slp::Pairing, args: &Args) -> Result<(), ExecError> {
        let leaf = |op| {
            matches!(
                op,
                Op::Const(_) | Op::Target(_) | Op::Gain(_) | Op::Hoisted(_)
            )
        };
        let mut same = vec![false; self.ops.len()];
        for (i, &op) in self.ops.iter().enumerate() {
            same[i] = leaf(op)
                || matches!(
                    op,
                    Op::Add(..)
                        | Op::Sub(..)
                        | Op::Mul(..)
                        | Op::Div(..)
                        | Op::Neg(_)
                        | Op::Sqrt(_)
                        | Op::Powi(..)
                ) && op.operands().all(|r| same[r.index()]);
        }
        self.eval = Some(*args);
        let (mut scalars, mut vectors) = (Vec::new(), Vec::new());
        for &node in &pairing.order {
            match node {
                slp::Node::Single(i) if same[i] && !leaf(self.ops[i]) => {
                    for r in self.ops[i].operands() {
                        self.scalar_value(pairing, r);
                    }
                    let v = self.op(i, args, &mut |_, _| {
                        Err(ExecError::Jit("state read by an invariant".into()))
                    })?;
                    self.values[i] = Some(v);
                    scalars.push(Reg(i as u32));
                }
                slp::Node::Single(_) => {}
                slp::Node::Pack(p) => {
                    let [a, b] = pairing.packs[p];
                    if same[a] && same[b] {
                        let v = self.pack(pairing, p, args)?;
                        self.vectors[a] = Some(v);
                        vectors.push([a, b].map(|i| Reg(i as u32)));
                        scalars.extend(
                            [a, b]
                                .into_iter()
                                .filter(|&i| !leaf(self.ops[i]))
                                .map(|i| Reg(i as u32)),
                        );
                    } else if input(args, self.ops[a]).is_none() {
                        let (xs, ys) = (self.ops[a].operands(), self.ops[b].operands());
                        for (x, y) in xs.zip(ys) {
                            let (ox, oy) = (self.ops[x.index()], self.ops[y.index()]);
                            if same[x.index()]
                                && same[y.index()]
                                && pairing.pack_of(x, y).is_none()
                                && !slp::invariant_pair(ox, oy)
                                && !vectors.contains(&[x, y])
                            {
                                vectors.push([x, y]);
                            }
                        }
                    }
                }
            }
        }
        let size = 16 * vectors.len() + 8 * scalars.len();
        let size = u32::try_from(size)
            .map_err(|_| ExecError::Jit(format!("{size} bytes of loop invariants")))?;
        let area = StackSlotData::new(StackSlotKind::ExplicitSlot, size, 4);
        let area = self.b.create_sized_stack_slot(area);
        let base = self.b.ins().stack_addr(self.ptr, area, 0);
        let mut at = HashMap::new();
        let mut off = 0;
        for &[x, y] in &vectors {
            let v = match pairing.pack_of(x, y) {
                Some(p) => self.pack_vector(pairing, p),
                None => self.gather(pairing, x, y),
            };
            self.b.ins().store(area_flags(), v, base, off);
            at.insert(Hoisted::Vector(x, y), off);
            off += 16;
        }
        for &r in &scalars {
            let v = self.scalar_value(pairing, r);
            self.b.ins().store(area_flags(), v, base, off);
            at.insert(Hoisted::Scalar(r), off);
            off += 8;
        }
        // the loop computes nothing of this again, and holds none of it in a register
        self.values.fill(None);
        self.vectors.fill(None);
        if let Some(g) = &mut self.gathered {
            g.clear();
        }
        self.squares.clear();
        self.invariants = Some(Invariants { same, base, at });
        Ok(())
    }

    /// Whether `node` is computed before the loop.
    pub(super) fn hoisted_node(&self, pairing: &slp::Pairing, node: slp::Node) -> bool {
        let Some(inv) = &self.invariants else {
            return false;
        };
        match node {
            slp::Node::Single(i) => inv.at.contains_key(&Hoisted::Scalar(Reg(i as u32))),
            slp::Node::Pack(p) => pairing.packs[p].iter().all(|&i| inv.same[i]),
        }
    }

    /// Whether register `r` is the same for every step of the batch being emitted.
    pub(super) fn is_invariant(&self, r: Reg) -> bool {
        self.invariants
            .as_ref()
            .is_some_and(|inv| inv.same[r.index()])
    }

    /// An invariant computed before the loop (`Hoisted::Scalar`) or vector, loaded from
    /// the stack area, if it is one.
    pub(super) fn hoisted(&mut self, h: Hoisted) -> Option<Value> {
        let inv = self.invariants.as_ref()?;
        let (off, base) = (*inv.at.get(&h)?, inv.base);
        let ty = match h {
            Hoisted::Scalar(_) => types::F64,
            Hoisted::Vector(..) => F64X2,
        };
        Some(self.b.ins().load(ty, area_flags(), base, off))
    }

    /// State component `i` as the previous step computed it, in a batch.
    pub(super) fn carried_scalar(&mut self, i: usize) -> Option<Value> {
        let (v, lane) = self.carried.as_ref()?[i];
        Some(match lane {
            None => v,
            Some(l) => self.b.ins().extractlane(v, l),
        })
    }

    /// State components `(i, i + 1)` as the previous step computed them, in a batch: one
    /// piece, or put together from two (with one instruction, two for two scalars).
    pub(super) fn carried_pair(&mut self, i: usize) -> Option<Value> {
        let c = self.carried.as_ref()?;
        Some(match (c[i], c[i + 1]) {
            ((v, Some(0)), (w, Some(1))) if v == w => v,
            ((v, Some(l)), (w, Some(m))) => self.shuffle(v, l, w, m),
            ((v, Some(0)), (s, None)) => self.b.ins().insertlane(v, s, 1),
            ((s, None), (w, Some(1))) => self.b.ins().insertlane(w, s, 0),
            _ => {
                let (s, t) = (self.carried_scalar(i)?, self.carried_scalar(i + 1)?);
                let v = self.b.ins().splat(F64X2, s);
                self.b.ins().insertlane(v, t, 1)
            }
        })
    }

    /// Whether the step's outputs, as stored, are a finite state and margins that hold: a
    /// value v is finite iff v − v = 0, so the state is finite iff the sum of those
    /// differences is 0 (a NaN or an infinity makes it NaN).
    fn step_holds(&mut self, stored: &[Stored], n: usize, strict: &[bool]) -> Value {
        let mut scalars = Vec::with_capacity(stored.len() * 2);
        let mut pairs = None;
        let mut j = 0;
        for &s in stored {
            match s {
                Stored::Pair(v) if j + 1 < n => {
                    let d = self.b.ins().fsub(v, v);
                    pairs = Some(match pairs {
                        Some(acc) => self.b.ins().fadd(acc, d),
                        None => d,
                    });
                    j += 2;
                }
                Stored::Pair(v) => {
                    for lane in 0..2 {
                        scalars.push((j, self.b.ins().extractlane(v, lane)));
                        j += 1;
                    }
                }
                Stored::Single(v) => {
                    scalars.push((j, v));
                    j += 1;
                }
            }
        }
        let mut sum = pairs.map(|acc| {
            let lo = self.b.ins().extractlane(acc, 0);
            let hi = self.b.ins().extractlane(acc, 1);
            self.b.ins().fadd(lo, hi)
        });
        let mut holds = None;
        for (j, v) in scalars {
            let test = if j < n {
                let d = self.b.ins().fsub(v, v);
                sum = Some(match sum {
                    Some(s) => self.b.ins().fadd(s, d),
                    None => d,
                });
                continue;
            } else {
                let cc = if strict[j - n] {
                    FloatCC::GreaterThan
                } else {
                    FloatCC::GreaterThanOrEqual
                };
                let zero = self.b.ins().f64const(0.0);
                self.b.ins().fcmp(cc, v, zero)
            };
            holds = Some(match holds {
                Some(h) => self.b.ins().band(h, test),
                None => test,
            });
        }
        let finite = sum.map(|s| {
            let zero = self.b.ins().f64const(0.0);
            self.b.ins().fcmp(FloatCC::Equal, s, zero)
        });
        match (finite, holds) {
            (Some(f), Some(h)) => self.b.ins().band(f, h),
            (Some(c), None) | (None, Some(c)) => c,
            (None, None) => self.b.ins().iconst(types::I8, 1),
        }
    }
}

/// The pieces a step stores the state in, as `eval` stores its outputs: the first component
/// of each and whether it is a pair (one 128-bit store).
fn state_pieces(tape: &Tape, pairing: &slp::Pairing, n: usize) -> Vec<(usize, bool)> {
    let mut pieces = Vec::new();
    let mut j = 0;
    while j < n {
        let pair = j + 1 < n
            && pairing
                .pack_of(tape.outputs[j], tape.outputs[j + 1])
                .is_some();
        pieces.push((j, pair));
        j += 1 + usize::from(pair);
    }
    pieces
}

/// What a batch of steps computes before its loop: which registers are the same for every
/// step, and where the stack area at `base` holds those the loop reads.
pub(super) struct Invariants {
    same: Vec<bool>,
    base: Value,
    at: HashMap<Hoisted, i32>,
}

/// A value the loop reads from the stack area: an invariant instruction computed in
/// scalars or a lane of an invariant pack, or the operand vector of two invariant registers.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Hoisted {
    Scalar(Reg),
    Vector(Reg, Reg),
}

/// The stack area: aligned (16 bytes for the vectors, 8 for the scalars after them), in
/// bounds.
fn area_flags() -> MemFlagsData {
    MemFlagsData::trusted()
}

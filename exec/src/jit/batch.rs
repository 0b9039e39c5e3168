//! A batch of steps compiled whole: the loop of [`CompiledStep`]'s batches
//! (`lasalle_runtime::CompiledStep`) as native code around a step tape's `eval`.
//!
//! `batch(hoisted, a, target, gains, b, k) -> taken` runs up to k steps on the state in `a`,
//! each reading one buffer and writing the other (a, b, a, …), and stops before the first
//! step whose new state is not finite or whose guards' margins fail (`m > 0` for a strict
//! guard, `m ≥ 0` otherwise; NaN fails both), as the Rust loop does. It returns the steps
//! taken: the state after them is in `a` if that number is even, in `b` if odd. Each step is
//! `eval`'s code, in its order, so the states are bitwise those of k calls of `eval`; what
//! the batch saves is the call per step and the check in Rust, and the loop keeps the pointers
//! and the counter in registers.
//!
//! [`CompiledStep`]: lasalle_runtime::CompiledStep

use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{types, BlockArg, InstBuilder, Value};

use super::{Args, Emit, JitKernel, Mode, Stored};
use crate::{ExecError, Tape};

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
        self.state_written = true;
        let (head, advance, exit) = (
            self.b.create_block(),
            self.b.create_block(),
            self.b.create_block(),
        );
        let i = self.b.append_block_param(head, types::I64);
        let from = self.b.append_block_param(head, self.ptr);
        let to = self.b.append_block_param(head, self.ptr);
        let taken = self.b.append_block_param(exit, types::I64);
        let zero = self.b.ins().iconst(types::I64, 0);
        let start = [zero, args.state, args.out].map(BlockArg::Value);
        self.b
            .ins()
            .brif(k, head, &start, exit, &[BlockArg::Value(zero)]);

        self.b.switch_to_block(head);
        let step = Args {
            state: from,
            out: to,
            ..*args
        };
        let (paired, stored) = self.scalar_body(tape, &step)?;
        let holds = self.step_holds(&stored, n, strict);
        self.b
            .ins()
            .brif(holds, advance, &[], exit, &[BlockArg::Value(i)]);

        self.b.switch_to_block(advance);
        let next = self.b.ins().iadd_imm_s(i, 1);
        let more = self.b.ins().icmp(IntCC::UnsignedLessThan, next, k);
        let again = [next, to, from].map(BlockArg::Value);
        self.b
            .ins()
            .brif(more, head, &again, exit, &[BlockArg::Value(next)]);

        self.b.switch_to_block(exit);
        self.b.ins().return_(&[taken]);
        Ok(paired)
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

//! The Taylor program of X − ∇V in loop form ([`FeedbackTaylorProgram`]) compiled by
//! Cranelift for one order p: [`JitLoopFeedbackTaylor`]. One function: the orders unrolled as
//! in [`JitTaylor`] (the same emitter), and at each order the three stages
//! on the shared table — the pass's plain recurrences and one loop block over the tuples per
//! region (as [`JitLoopTaylor`](super::JitLoopTaylor)'s, adding to order k of the S and C rows), the
//! weights' recurrences, then the last stage's plain recurrences and its regions' loops (adding
//! to order k + 1 of the x rows). The code is independent of the number of tuples; the
//! operations and their order are those of the interpreter ([`LoopFeedbackTaylor`]), so the
//! two agree bitwise. The tuples' tables are compact, as the field's. It also compiles the
//! chaos indicators' staged field (the same three stages).
//!
//! A stage's plain program above [`MAX_INSTRUCTIONS`] estimated instructions
//! ([`JitTaylor::instructions`]) is not compiled: the code
//! calls the interpreter's loop over its recurrences at each order (`plain_order`, the same
//! operations), so the code stays independent of its size. This is the indicators' stage 2,
//! whose λ = u·Au/(u·u) and rates are a few Cauchy products per state component: unrolled,
//! they made the code grow as N·p² (at 256 bodies, minutes of compiling and a gigabyte).

use super::loops::{layout, Layout, LoopEmit};
use super::{
    call_signatures, jit_err, jit_module, offset, Code, Emit, JitTaylor, Leaves, EARLY_GROUP,
    MAX_INSTRUCTIONS, OPT_LEVEL,
};
use crate::taylor::feedback::plain_order;
use crate::taylor::{LoopFeedbackTaylor, TaylorError};
use crate::ExecError;
use cranelift_codegen::ir::immediates::Ieee64;
use cranelift_codegen::ir::{types, AbiParam, InstBuilder, MemFlagsData, Value};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::Module;
use lasalle_model::loops::{FeedbackTaylorProgram, LoopFeedback, LoopTape, LoopTaylorProgram};
use lasalle_model::tape::taylor::TaylorProgram;
use lasalle_runtime::taylor::TaylorKernel;
use lasalle_runtime::StepError;
use std::collections::HashMap;

/// `(state, pointers)`: `pointers` is [params, table, target, gains, the hoisted values of the
/// sums' plain tape, of the weights' and of the last stage's plain tape, the three stages'
/// [`PlainCall`]s, then per region of the sums and then of the last stage its hoisted values,
/// gather table, scatter table and block table].
type FeedbackTaylorFn = unsafe extern "C" fn(*const f64, *const *const u8);

/// The loop form of the Taylor program of X − ∇V compiled for the order p; see the
/// [module docs](self).
pub struct JitLoopFeedbackTaylor {
    /// The tables and inputs, as the interpreter's.
    data: LoopFeedbackTaylor,
    _code: Code,
    func: FeedbackTaylorFn,
    /// The pointers handed to the function, rebuilt at every compute.
    pointers: Vec<*const u8>,
}

// SAFETY: the module is only touched again in `drop`; the compiled function keeps no state
// (it reads and writes only what its arguments point to); the pointers are rebuilt from
// `data` before every call.
unsafe impl Send for JitLoopFeedbackTaylor {}

impl std::fmt::Debug for JitLoopFeedbackTaylor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitLoopFeedbackTaylor")
            .field("order", &self.data.max_order)
            .finish_non_exhaustive()
    }
}

/// A stage's plain program run by the interpreter from the compiled code ([`call_plain`]);
/// built at every compute from the kernel's current inputs.
struct PlainCall<'a> {
    program: &'a TaylorProgram,
    /// Its hoisted values, the targets and the gains.
    inputs: [&'a [f64]; 3],
    /// The shared table's length and stride.
    len: usize,
    stride: usize,
}

/// Order `k` of the plain program of `call` on the shared table `table`.
///
/// # Safety
/// `call` points to a live [`PlainCall`] and `table` to its `len` f64, which nothing else
/// accesses during the call.
unsafe extern "C" fn call_plain(call: *const PlainCall<'_>, table: *mut f64, k: usize) {
    // SAFETY: see above
    let (c, t) = unsafe { (&*call, std::slice::from_raw_parts_mut(table, (*call).len)) };
    plain_order(t, c.stride, c.program, c.inputs, k);
}

/// Whether a stage's plain program is interpreted from the code (see the [module docs](self)).
fn interpreted(program: &TaylorProgram, p: usize) -> bool {
    JitTaylor::instructions(program, p) > MAX_INSTRUCTIONS
}

/// The compact layouts of a loop stage's regions, and its blocks resized to them.
fn compact(
    program: &LoopTaylorProgram,
    tape: &LoopTape,
    blocks: &mut [Vec<f64>],
    stride: usize,
) -> Vec<Layout> {
    let layouts: Vec<Layout> = program.regions.iter().map(|r| layout(r, stride)).collect();
    for ((block, l), region) in blocks.iter_mut().zip(&layouts).zip(&tape.regions) {
        *block = vec![0.0; l.size * region.count];
    }
    layouts
}

impl JitLoopFeedbackTaylor {
    /// Compiles the loop form of the Taylor program of X − ∇V given by the stages `tapes` for
    /// the order `order`, with parameter values `params` (targets and gains 0 until
    /// [`TaylorKernel::set_inputs`]).
    pub fn new(
        tapes: &LoopFeedback,
        params: &[f64],
        order: u32,
    ) -> Result<JitLoopFeedbackTaylor, TaylorError> {
        let mut data = LoopFeedbackTaylor::new(tapes, params, order)?;
        let p = order as usize;
        let layouts = [
            compact(
                &data.program.sums,
                &tapes.pass,
                &mut data.sums_blocks,
                p + 1,
            ),
            compact(
                &data.program.feedback,
                &tapes.feedback,
                &mut data.feedback_blocks,
                p + 1,
            ),
        ];
        let (code, func) = jit_module(OPT_LEVEL, false)
            .and_then(|module| {
                Code::compile(module, |m| define(m, tapes, &data.program, &layouts, p))
            })
            .map_err(TaylorError::kernels)?;
        // SAFETY: defined just now with this signature (two pointers, the host's C calling
        // convention); the module owning the code lives in the result.
        let func = unsafe { std::mem::transmute::<*const u8, FeedbackTaylorFn>(func) };
        let regions = tapes.pass.regions.len() + tapes.feedback.regions.len();
        Ok(JitLoopFeedbackTaylor {
            pointers: Vec::with_capacity(10 + 4 * regions),
            data,
            _code: code,
            func,
        })
    }
}

impl TaylorKernel<crate::LoadedModel> for JitLoopFeedbackTaylor {
    fn dim(&self) -> usize {
        self.data.program.dim
    }

    fn max_order(&self) -> usize {
        self.data.max_order
    }

    fn sync(&mut self, model: &crate::LoadedModel) -> Result<(), StepError> {
        self.data.sync_params(model.params())
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        self.data.set_targets(target, gains)
    }

    /// Always computes the compiled order p and hands out `order + 1` coefficients.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    fn compute(&mut self, x: &[f64], order: usize) {
        let d = &mut self.data;
        assert_eq!(x.len(), d.program.dim, "state dimension");
        d.order = order.min(d.max_order);
        let ptrs = &mut self.pointers;
        ptrs.clear();
        ptrs.push(d.params.as_ptr().cast());
        ptrs.push(d.table.as_mut_ptr().cast_const().cast());
        ptrs.push(d.target.as_ptr().cast());
        ptrs.push(d.gains.as_ptr().cast());
        ptrs.push(d.hoisted.sums[0].as_ptr().cast());
        ptrs.push(d.hoisted.weights.as_ptr().cast());
        ptrs.push(d.hoisted.feedback[0].as_ptr().cast());
        let (len, stride) = (d.table.len(), d.stride);
        let (target, gains) = (&d.target[..], &d.gains[..]);
        let calls = [
            (&d.program.sums.base, &d.hoisted.sums[0][..]),
            (&d.program.weights, &d.hoisted.weights[..]),
            (&d.program.feedback.base, &d.hoisted.feedback[0][..]),
        ]
        .map(|(program, hoisted)| PlainCall {
            program,
            inputs: [hoisted, target, gains],
            len,
            stride,
        });
        for call in &calls {
            ptrs.push(std::ptr::from_ref(call).cast());
        }
        let stages = [
            (&d.tapes.pass, &d.hoisted.sums, &mut d.sums_blocks),
            (
                &d.tapes.feedback,
                &d.hoisted.feedback,
                &mut d.feedback_blocks,
            ),
        ];
        for (tape, hoisted, blocks) in stages {
            for (r, region) in tape.regions.iter().enumerate() {
                ptrs.push(hoisted[r + 1].as_ptr().cast());
                ptrs.push(region.gather.as_ptr().cast());
                ptrs.push(region.scatter.as_ptr().cast());
                ptrs.push(blocks[r].as_mut_ptr().cast_const().cast());
            }
        }
        // SAFETY: the code reads x[..N], the parameters, targets, gains, hoisted values and the
        // gather and scatter tables at the sizes the program was compiled for (the tapes were
        // validated, so every gathered and scattered index is in range, and `set_inputs` keeps
        // the targets and gains at their sizes), and writes the table and the blocks,
        // allocated for the compiled order; nothing else accesses them meanwhile. The
        // `PlainCall`s it hands to `call_plain` live until the end of this function.
        unsafe { (self.func)(x.as_ptr(), self.pointers.as_ptr()) }
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        self.data.state_coefficients(i)
    }
}

/// Defines and finalises the function; returns its id.
fn define(
    module: &mut JITModule,
    tapes: &LoopFeedback,
    program: &FeedbackTaylorProgram,
    layouts: &[Vec<Layout>; 2],
    p: usize,
) -> Result<cranelift_module::FuncId, ExecError> {
    let stride = p + 1;
    offset(program.rows * stride)?;
    for l in layouts.iter().flatten() {
        offset(l.size)?;
    }
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 2]);
    let id = module.declare_anonymous_function(&sig).map_err(jit_err)?;
    let mut ctx = module.make_context();
    ctx.func.signature = sig;
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let [state, pointers]: [Value; 2] =
            b.block_params(entry).try_into().expect("two parameters");
        let [unary, binary, ellipj] = call_signatures(module);
        let zero = b.ins().f64const(Ieee64::with_bits(0f64.to_bits()));
        let flags = MemFlagsData::trusted().with_readonly().with_can_move();
        let at = |b: &mut FunctionBuilder, i: usize| {
            b.ins()
                .load(ptr, flags, pointers, (i * ptr.bytes() as usize) as i32)
        };
        let [params, table, target, gains, h_sums, h_weights, h_feedback] =
            std::array::from_fn(|i| at(&mut b, i));
        let plains = [&program.sums.base, &program.weights, &program.feedback.base];
        let calls = std::array::from_fn(|s| interpreted(plains[s], p).then(|| at(&mut b, 7 + s)));
        let first = tapes.pass.regions.len();
        let sums_regions: Vec<[Value; 4]> = (0..first)
            .map(|r| std::array::from_fn(|j| at(&mut b, 10 + 4 * r + j)))
            .collect();
        let feedback_regions: Vec<[Value; 4]> = (0..tapes.feedback.regions.len())
            .map(|r| std::array::from_fn(|j| at(&mut b, 10 + 4 * (first + r) + j)))
            .collect();
        let mut call_sig = module.make_signature();
        call_sig
            .params
            .extend([ptr, ptr, types::I64].map(AbiParam::new));
        let mut e = Emit {
            b,
            ptr,
            unary,
            binary,
            ellipj,
            table,
            stride,
            lanes: 1,
            layout: None,
            rows: vec![0; program.rows],
            recent: Default::default(),
            early: HashMap::new(),
            zero,
            ellipj_out: None,
        };
        let n = program.dim;
        let mut stages = Stages {
            program,
            tapes,
            sums: loop_emit(
                (&tapes.pass, &program.sums, &layouts[0]),
                [params, table, h_sums],
                sums_regions,
                n,
            ),
            feedback: loop_emit(
                (&tapes.feedback, &program.feedback, &layouts[1]),
                [params, table, h_feedback],
                feedback_regions,
                0,
            ),
            leaves: [h_sums, h_weights, h_feedback].map(|hoisted| Leaves {
                state,
                hoisted,
                target,
                gains,
            }),
            calls,
            call_sig,
        };
        stages.body(&mut e, state, p)?;
        e.b.ins().return_(&[]);
        e.b.seal_all_blocks();
        e.b.finalize(module.target_config());
    }
    module.define_function(id, &mut ctx).map_err(jit_err)?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(jit_err)?;
    Ok(id)
}

/// The emitter of a loop stage's regions, adding to order k + 1 of the rows from `first` on
/// if `first` is 0 (the x rows), else to order k (the S rows).
fn loop_emit<'a>(
    (tape, program, layouts): (&'a LoopTape, &'a LoopTaylorProgram, &'a [Layout]),
    [params, table, hoisted]: [Value; 3],
    regions: Vec<[Value; 4]>,
    first: usize,
) -> LoopEmit<'a> {
    LoopEmit {
        tape,
        program,
        layouts,
        params,
        table,
        hoisted,
        regions,
        region_rows: program.regions.iter().map(|r| vec![0; r.rows]).collect(),
        first,
        shift: usize::from(first == 0),
    }
}

/// The three stages being emitted.
struct Stages<'a> {
    program: &'a FeedbackTaylorProgram,
    tapes: &'a LoopFeedback,
    /// The regions of the sums (adding to order k of the S rows) and of the last stage
    /// (adding to order k + 1 of the x rows).
    sums: LoopEmit<'a>,
    feedback: LoopEmit<'a>,
    /// The leaves of the sums', the weights' and the last stage's plain programs.
    leaves: [Leaves; 3],
    /// Per plain program, its [`PlainCall`] if it is interpreted (see the [module docs](self)),
    /// and the signature of [`call_plain`].
    calls: [Option<Value>; 3],
    call_sig: cranelift_codegen::ir::Signature,
}

impl Stages<'_> {
    /// Orders 0..p, as [`LoopFeedbackTaylor::compute`].
    fn body(&mut self, e: &mut Emit<'_>, state: Value, p: usize) -> Result<(), ExecError> {
        let prog = self.program;
        let (n, nk) = (prog.dim, prog.pass_outputs());
        for i in 0..n {
            let x = e.load(state, i)?;
            e.push(i, 0, x);
        }
        let plains = [&prog.sums.base, &prog.weights, &prog.feedback.base];
        let early = plains.map(|p| p.early_sums(EARLY_GROUP));
        let region_early = |l: &LoopTaylorProgram| -> Vec<_> {
            l.regions
                .iter()
                .map(|r| r.early_sums(EARLY_GROUP))
                .collect()
        };
        let sums_early = region_early(&prog.sums);
        let feedback_early = region_early(&prog.feedback);
        let stride = e.stride;
        let store = |e: &mut Emit<'_>, v: Value, i: usize, k: usize| -> Result<(), ExecError> {
            let off = offset(i * stride + k)?;
            e.b.ins().store(MemFlagsData::trusted(), v, e.table, off);
            Ok(())
        };
        // the rows of each plain program's own recurrences (its inputs are the rows below its
        // dimension, placed where they are)
        let own: [Vec<usize>; 3] = plains.map(|p| {
            let rows = std::cell::RefCell::new(std::collections::BTreeSet::new());
            for &(r, _) in &p.recs {
                r.map_rows(|row| {
                    if row >= p.dim {
                        rows.borrow_mut().insert(row);
                    }
                    row
                });
            }
            rows.into_inner().into_iter().collect()
        });
        let (calls, call_sig) = (self.calls, &self.call_sig);
        let plain = |e: &mut Emit<'_>, s: usize, leaves: &Leaves, k: usize| {
            if let Some(call) = calls[s] {
                // the interpreter's recurrences at order k; the constant rows' higher orders
                // are the table's 0, as the emitted code's
                let kv = e.b.ins().iconst(types::I64, k as i64);
                e.call(
                    call_plain as *const () as usize,
                    call_sig,
                    &[call, e.table, kv],
                );
                for &r in &own[s] {
                    e.rows[r] = k + 1;
                }
                return Ok(());
            }
            if k >= 1 {
                e.early_sums(&early[s], k);
            }
            for &(r, constant) in &plains[s].recs {
                if k == 0 {
                    e.zeroth(r, leaves)?;
                } else if !constant {
                    e.coefficient(r, k);
                }
            }
            debug_assert!(e.early.is_empty(), "every early sum is read at its order");
            Ok::<_, ExecError>(())
        };
        for k in 0..p {
            // 1. S and the carried values: order k of their rows
            plain(e, 0, &self.leaves[0], k)?;
            let mut first: Vec<Value> = vec![e.zero; nk];
            for (&o, &row) in self.tapes.pass.base_at.iter().zip(&prog.sums.base.outputs) {
                first[o as usize] = e.c(row, k);
            }
            for (i, &v) in first.iter().enumerate() {
                store(e, v, prog.sum_row(i), k)?;
            }
            for (r, early) in sums_early.iter().enumerate() {
                self.sums.region(e, r, early, k)?;
            }
            for i in 0..nk {
                // the S rows' order k is in the table now
                debug_assert_eq!(e.rows[prog.sum_row(i)], k, "orders in sequence");
                e.rows[prog.sum_row(i)] += 1;
            }
            // 2. w: order k of the w rows
            plain(e, 1, &self.leaves[1], k)?;
            for (i, &row) in prog.weights.outputs[1..].iter().enumerate() {
                let v = e.c(row, k);
                e.push(prog.weight_row(i), k, v);
            }
            // 3. X − ∇V: order k + 1 of the x rows
            plain(e, 2, &self.leaves[2], k)?;
            let mut first: Vec<Value> = vec![e.zero; n];
            for (&o, &row) in self
                .tapes
                .feedback
                .base_at
                .iter()
                .zip(&prog.feedback.base.outputs)
            {
                first[o as usize] = e.c(row, k);
            }
            for (i, &v) in first.iter().enumerate() {
                store(e, v, i, k + 1)?;
            }
            for (r, early) in feedback_early.iter().enumerate() {
                self.feedback.region(e, r, early, k)?;
            }
            let inv = e.constant(1.0 / (k as f64 + 1.0));
            let flags = MemFlagsData::trusted();
            for i in 0..n {
                let off = offset(i * stride + k + 1)?;
                let x = e.b.ins().load(types::F64, flags, e.table, off);
                let v = e.fmul(x, inv);
                e.push(i, k + 1, v);
            }
        }
        Ok(())
    }
}

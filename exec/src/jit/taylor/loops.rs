//! The loop form of the Taylor program ([`LoopTaylorProgram`]) compiled by Cranelift for one
//! order p: [`JitLoopTaylor`]. One function: the orders unrolled as in [`JitTaylor`](super::JitTaylor)
//! (the same emitter), and at each order, per region, one loop block over the
//! tuples whose body gathers the slots' order-k coefficients from the state rows, runs the
//! body's recurrences at order k over the tuple's own table (the emitter's table pointer is
//! the tuple's block) and adds the outputs' order k to the state rows' order k + 1 through
//! the scatter table. The code is independent of the number of tuples; the operations and
//! their order are those of the interpreter ([`LoopTaylorTape`]), so the two agree bitwise.
//!
//! The tuples' tables are compact: a row holds all p + 1 orders only if some recurrence reads
//! its lower orders again (an operand of a Cauchy sum, the result of a recurrence that reads
//! its own past); every other row holds one value, its current order. For the N-body pair
//! term that is 6 rows of 29, so the tables of 1 128 pairs take 1.3 MB at p = 19 and stay in
//! the cache (the interpreter keeps full tables, the same values).

use super::{
    call_signatures, jit_err, jit_module, offset, Code, Emit, Leaves, EARLY_GROUP, OPT_LEVEL,
};
use crate::taylor::{LoopTaylorTape, TaylorError};
use crate::ExecError;
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::immediates::Ieee64;
use cranelift_codegen::ir::{types, AbiParam, BlockArg, InstBuilder, MemFlagsData, Value};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::Module;
use lasalle_model::loops::{LoopTape, LoopTaylorProgram, Source};
use lasalle_model::tape::taylor::{EarlySum, Rec, Span, TaylorProgram};
use lasalle_runtime::taylor::TaylorKernel;
use lasalle_runtime::StepError;
use std::collections::HashMap;

/// `(state, pointers)`: `pointers` is [params, table, plain hoisted, then per region its
/// hoisted values, gather table, scatter table and block table].
type LoopTaylorFn = unsafe extern "C" fn(*const f64, *const *const u8);

/// The loop form of a field's Taylor program compiled for the order p; see the
/// [module docs](self).
pub struct JitLoopTaylor {
    /// The tables and inputs, as the interpreter's.
    data: LoopTaylorTape,
    _code: Code,
    func: LoopTaylorFn,
    /// The pointers handed to the function, rebuilt at every compute.
    pointers: Vec<*const u8>,
}

// SAFETY: the module is only touched again in `drop`; the compiled function keeps no state
// (it reads and writes only what its arguments point to); the pointers are rebuilt from
// `data` before every call.
unsafe impl Send for JitLoopTaylor {}

impl std::fmt::Debug for JitLoopTaylor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitLoopTaylor")
            .field("order", &self.data.max_order)
            .finish_non_exhaustive()
    }
}

impl JitLoopTaylor {
    /// Compiles the loop form of the Taylor program of `tape` (a field) for the order
    /// `order`, with parameter values `params`.
    pub fn new(tape: &LoopTape, params: &[f64], order: u32) -> Result<JitLoopTaylor, TaylorError> {
        let mut data = LoopTaylorTape::new(tape, params, order)?;
        let p = order as usize;
        let layouts: Vec<Layout> = data
            .program
            .regions
            .iter()
            .map(|r| layout(r, p + 1))
            .collect();
        // the compiled code's blocks are compact (the interpreter's layout is never used here)
        for ((block, l), region) in data.blocks.iter_mut().zip(&layouts).zip(&tape.regions) {
            *block = vec![0.0; l.size * region.count];
        }
        let (code, func) = jit_module(OPT_LEVEL, false)
            .and_then(|module| {
                Code::compile(module, |m| define(m, tape, &data.program, &layouts, p))
            })
            .map_err(TaylorError::kernels)?;
        // SAFETY: defined just now with this signature (two pointers, the host's C calling
        // convention); the module owning the code lives in the result.
        let func = unsafe { std::mem::transmute::<*const u8, LoopTaylorFn>(func) };
        Ok(JitLoopTaylor {
            pointers: Vec::with_capacity(3 + 4 * tape.regions.len()),
            data,
            _code: code,
            func,
        })
    }
}

impl TaylorKernel<crate::LoadedModel> for JitLoopTaylor {
    fn dim(&self) -> usize {
        self.data.program.base.dim
    }

    fn max_order(&self) -> usize {
        self.data.max_order
    }

    fn sync(&mut self, model: &crate::LoadedModel) -> Result<(), StepError> {
        self.data.sync_params(model.params())
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        TaylorKernel::<crate::LoadedModel>::set_inputs(&mut self.data, target, gains)
    }

    /// Always computes the compiled order p and hands out `order + 1` coefficients.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    fn compute(&mut self, x: &[f64], order: usize) {
        let d = &mut self.data;
        assert_eq!(x.len(), d.program.base.dim, "state dimension");
        d.order = order.min(d.max_order);
        let ptrs = &mut self.pointers;
        ptrs.clear();
        ptrs.push(d.params.as_ptr().cast());
        ptrs.push(d.table.as_mut_ptr().cast_const().cast());
        ptrs.push(d.hoisted[0].as_ptr().cast());
        for (r, region) in d.tape.regions.iter().enumerate() {
            ptrs.push(d.hoisted[r + 1].as_ptr().cast());
            ptrs.push(region.gather.as_ptr().cast());
            ptrs.push(region.scatter.as_ptr().cast());
            ptrs.push(d.blocks[r].as_mut_ptr().cast_const().cast());
        }
        // SAFETY: the code reads x[..N], the parameters, the hoisted values and the gather and
        // scatter tables at the sizes the program was compiled for (the tape was validated, so
        // every gathered and scattered index is in range), and writes the table and the
        // blocks, allocated for the compiled order; nothing else accesses them meanwhile.
        unsafe { (self.func)(x.as_ptr(), self.pointers.as_ptr()) }
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        self.data.state_coefficients(i)
    }
}

/// Where the rows of a region's tuple block are (see [`Emit::layout`]) and the block's size.
pub(super) struct Layout {
    pub(super) rows: Vec<(usize, bool)>,
    pub(super) size: usize,
}

/// The compact layout of a region's block: the rows whose lower orders some recurrence reads
/// after their order (operands of Cauchy sums, the results of the recurrences that read their
/// own lower orders) hold all p + 1 orders; every other row holds one value, its current
/// order (rows constant along the solution: their order 0). A tuple's block is then a few
/// rows long instead of all of them, which keeps the blocks of all tuples in the cache.
pub(super) fn layout(program: &TaylorProgram, stride: usize) -> Layout {
    let mut history = vec![false; program.rows];
    for &(r, constant) in &program.recs {
        if constant {
            continue;
        }
        let all: &[usize] = match r {
            Rec::Mul { a, b, .. } => &[a, b],
            Rec::Square { a, .. } => &[a],
            Rec::Div { b, d, .. } => &[b, d],
            Rec::Pow { a, d, .. } | Rec::Exp { a, d, .. } | Rec::Ln { a, d, .. } => &[a, d],
            Rec::Sqrt { d, .. } => &[d],
            Rec::SinCos { s, c, a } => &[s, c, a],
            Rec::Jacobi { rows, a, .. } => {
                for r in rows.into_iter().chain([a]) {
                    history[r] = true;
                }
                &[]
            }
            Rec::EllipF { a, w, .. } => &[a, w],
            Rec::Leaf { .. }
            | Rec::Add { .. }
            | Rec::Sub { .. }
            | Rec::Neg { .. }
            | Rec::Scale { .. }
            | Rec::DivConst { .. }
            | Rec::EllipK { .. } => &[],
        };
        for &r in all {
            history[r] = true;
        }
    }
    let mut size = 0;
    let rows = history
        .into_iter()
        .map(|h| {
            let start = size;
            size += if h { stride } else { 1 };
            (start, h)
        })
        .collect();
    Layout { rows, size }
}

/// Defines and finalises the function; returns its id.
fn define(
    module: &mut JITModule,
    tape: &LoopTape,
    program: &LoopTaylorProgram,
    layouts: &[Layout],
    p: usize,
) -> Result<cranelift_module::FuncId, ExecError> {
    let stride = p + 1;
    offset(program.base.rows * stride)?;
    for l in layouts {
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
        let params = at(&mut b, 0);
        let table = at(&mut b, 1);
        let hoisted = at(&mut b, 2);
        let regions: Vec<[Value; 4]> = (0..tape.regions.len())
            .map(|r| std::array::from_fn(|j| at(&mut b, 3 + 4 * r + j)))
            .collect();
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
            rows: vec![0; program.base.rows],
            recent: Default::default(),
            early: HashMap::new(),
            zero,
            ellipj_out: None,
        };
        let mut l = LoopEmit {
            tape,
            program,
            layouts,
            params,
            table,
            hoisted,
            regions,
            region_rows: program.regions.iter().map(|r| vec![0; r.rows]).collect(),
            first: 0,
            shift: 1,
        };
        l.body(&mut e, state, p)?;
        e.b.ins().return_(&[]);
        e.b.seal_all_blocks();
        e.b.finalize(module.target_config());
    }
    module.define_function(id, &mut ctx).map_err(jit_err)?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(jit_err)?;
    Ok(id)
}

/// What the loop form adds to the emitter.
pub(super) struct LoopEmit<'a> {
    pub(super) tape: &'a LoopTape,
    pub(super) program: &'a LoopTaylorProgram,
    pub(super) layouts: &'a [Layout],
    pub(super) params: Value,
    /// The plain table (the state rows first).
    pub(super) table: Value,
    /// The plain tape's hoisted values.
    pub(super) hoisted: Value,
    /// Per region: hoisted values, gather table, scatter table, block table.
    pub(super) regions: Vec<[Value; 4]>,
    /// Per region, how many orders of each row its blocks hold.
    pub(super) region_rows: Vec<Vec<usize>>,
    /// Where the regions add their outputs' order k: to order k + `shift` of row
    /// `first` + the output (the field's: 0 and 1).
    pub(super) first: usize,
    pub(super) shift: usize,
}

impl LoopEmit<'_> {
    /// Orders 0..p, as [`LoopTaylorTape::compute`].
    fn body(&mut self, e: &mut Emit<'_>, state: Value, p: usize) -> Result<(), ExecError> {
        let base = &self.program.base;
        let n = base.dim;
        for i in 0..n {
            let x = e.load(state, i)?;
            e.push(i, 0, x);
        }
        let early = base.early_sums(EARLY_GROUP);
        let region_early: Vec<_> = self
            .program
            .regions
            .iter()
            .map(|r| r.early_sums(EARLY_GROUP))
            .collect();
        // Leaves of the plain tape: no targets or gains in a field (the pointers are unused)
        let leaves = Leaves {
            state,
            hoisted: self.hoisted,
            target: self.params,
            gains: self.params,
        };
        let stride = e.stride;
        let store = |e: &mut Emit<'_>, v: Value, i: usize, k: usize| -> Result<(), ExecError> {
            let off = offset(i * stride + k)?;
            e.b.ins().store(MemFlagsData::trusted(), v, e.table, off);
            Ok(())
        };
        for k in 0..p {
            if k >= 1 {
                e.early_sums(&early, k);
            }
            for &(r, constant) in &base.recs {
                if k == 0 {
                    e.zeroth(r, &leaves)?;
                } else if !constant {
                    e.coefficient(r, k);
                }
            }
            debug_assert!(e.early.is_empty(), "every early sum is read at its order");
            let mut first: Vec<Value> = vec![e.zero; n];
            for (&o, &row) in self.tape.base_at.iter().zip(&base.outputs) {
                first[o as usize] = e.c(row, k);
            }
            for (i, &v) in first.iter().enumerate() {
                store(e, v, i, k + 1)?;
            }
            for (r, early) in region_early.iter().enumerate() {
                self.region(e, r, early, k)?;
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

    /// Order k of region `r`: a loop over its tuples.
    pub(super) fn region(
        &mut self,
        e: &mut Emit<'_>,
        r: usize,
        early: &[(Span, Vec<EarlySum>)],
        k: usize,
    ) -> Result<(), ExecError> {
        let region = &self.tape.regions[r];
        let prog = &self.program.regions[r];
        if region.count == 0 {
            return Ok(());
        }
        let [hoisted, gather, scatter, blocks] = self.regions[r];
        let ptr = e.ptr;
        let stride = e.stride;
        let block_bytes = (self.layouts[r].size * 8) as i64;
        let slots = region.sources.len();
        let outs = prog.outputs.len();
        let span = e.b.ins().iconst(ptr, block_bytes * region.count as i64);
        let end = e.b.ins().iadd(blocks, span);
        let body = e.b.create_block();
        let bp = e.b.append_block_param(body, ptr);
        let gp = e.b.append_block_param(body, ptr);
        let sp = e.b.append_block_param(body, ptr);
        let exit = e.b.create_block();
        e.b.ins().jump(
            body,
            &[
                BlockArg::Value(blocks),
                BlockArg::Value(gather),
                BlockArg::Value(scatter),
            ],
        );
        e.b.switch_to_block(body);
        // the emitter now works on the tuple's block
        std::mem::swap(&mut e.rows, &mut self.region_rows[r]);
        e.table = bp;
        e.layout = Some(self.layouts[r].rows.clone());
        e.recent.clear();
        let ro = MemFlagsData::trusted().with_readonly();
        let flags = MemFlagsData::trusted();
        let row_bytes = e.b.ins().iconst(types::I64, (stride * 8) as i64);
        for (j, src) in region.sources.iter().enumerate() {
            let base = match src {
                Source::State => self.table,
                Source::Param if k == 0 => self.params,
                Source::Param => continue,
            };
            let idx = e.b.ins().uload32(ro, gp, (4 * j) as i32);
            let scaled = match src {
                Source::State => e.b.ins().imul(idx, row_bytes),
                Source::Param => {
                    let eight = e.b.ins().iconst(types::I64, 8);
                    e.b.ins().imul(idx, eight)
                }
            };
            let addr = e.b.ins().iadd(base, scaled);
            let off = match src {
                Source::State => offset(k)?,
                Source::Param => 0,
            };
            let v = e.b.ins().load(types::F64, flags, addr, off);
            e.push(j, k, v);
        }
        if k >= 1 {
            e.early_sums(early, k);
        }
        let leaves = Leaves {
            state: self.params,
            hoisted,
            target: self.params,
            gains: self.params,
        };
        for &(rec, constant) in &prog.recs {
            if k == 0 {
                e.zeroth(rec, &leaves)?;
            } else if !constant {
                e.coefficient(rec, k);
            }
        }
        debug_assert!(e.early.is_empty(), "every early sum is read at its order");
        for (j, &row) in prog.outputs.iter().enumerate() {
            let v = e.c(row, k);
            let idx = e.b.ins().uload32(ro, sp, (4 * j) as i32);
            let scaled = e.b.ins().imul(idx, row_bytes);
            let addr = e.b.ins().iadd(self.table, scaled);
            let off = offset(self.first * stride + k + self.shift)?;
            let old = e.b.ins().load(types::F64, flags, addr, off);
            let sum = e.fadd(old, v);
            e.b.ins().store(flags, sum, addr, off);
        }
        let step = |e: &mut Emit<'_>, v: Value, by: i64| {
            let by = e.b.ins().iconst(ptr, by);
            e.b.ins().iadd(v, by)
        };
        let bn = step(e, bp, block_bytes);
        let gn = step(e, gp, (4 * slots) as i64);
        let sn = step(e, sp, (4 * outs) as i64);
        let more = e.b.ins().icmp(IntCC::NotEqual, bn, end);
        e.b.ins().brif(
            more,
            body,
            &[
                BlockArg::Value(bn),
                BlockArg::Value(gn),
                BlockArg::Value(sn),
            ],
            exit,
            &[],
        );
        e.b.switch_to_block(exit);
        std::mem::swap(&mut e.rows, &mut self.region_rows[r]);
        e.table = self.table;
        e.layout = None;
        e.recent.clear();
        Ok(())
    }
}

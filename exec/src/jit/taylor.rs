//! The Taylor-coefficient recurrences of a field tape ([`TaylorProgram`]) compiled by
//! Cranelift for one order p: [`JitTaylor`], the default [`TaylorKernel`] of loaded models
//! with the JIT back end (the interpreted [`TaylorTape`](crate::TaylorTape) stays the kernel
//! of the interpreter back end); programs too large to compile at once are interpreted first
//! and compiled after [`DEFER_COMPUTES`] computes ([`DeferredJit`]).
//!
//! # Code shape: orders unrolled, long sums as loops
//!
//! The loop over the orders k = 0..p is unrolled, and so are the sums of fewer than
//! `LOOP_TERMS` terms: no index arithmetic and no dispatch. Every coefficient is stored into
//! one table (rows × (p + 1), row-major, the state rows first, which
//! [`TaylorKernel::coefficients`] reads) at a constant offset, and read back by a load at its
//! uses, emitted right before the product that consumes it so that x86 folds it into the
//! multiplication: keeping all coefficients as SSA values instead made the register allocator
//! spill them anyway, and compiled several times slower. The last few stored values are
//! reused without a load. Rows constant along the solution have their higher coefficients as
//! the constant 0, as in the interpreter's table.
//!
//! A Cauchy sum Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\] of `LOOP_TERMS` or more terms is a loop:
//! its first 1 + (hi − lo) mod `LOOP_UNROLL` terms unrolled, then passes of
//! `LOOP_UNROLL` terms along two pointers, one up the table and one down (the same
//! operations in the same order, so still bitwise the interpreter's). Unrolled throughout,
//! the code grows as p²: Kepler's field is 39 KB at p = 19, the rigid body's 99 KB, beyond
//! the instruction cache, each instruction run once per step.
//!
//! # Early sums
//!
//! At each order the program's early sums ([`TaylorProgram::early_sums`]: a product's all but
//! two newest terms, the folded sums of squares and square roots, which read only lower
//! orders) are computed first, each group of up to [`EARLY_GROUP`] in one loop as above
//! (those sharing a row together: the rigid body's R·Ω̂ has six products per component of Ω),
//! each sum still accumulated alone in its own order. The loop loads a shared row once per
//! term instead of once per sum, and its independent chains of additions overlap instead of
//! waiting on one another.
//!
//! Measured by `lasalle run <model> --method taylor --rtol 1e-15 --atol 1e-15` (AMD EPYC,
//! quiet, 2026-11-25, fastest of 5; rigid body to t = 1000, Kepler 1000 periods): fully
//! unrolled 0.0102 s and 0.043 s; loops of one term per pass in programs above 65 KB only
//! 0.0127 s and 0.043 s; loops of four terms per pass in every program
//! 0.0093 s and 0.038 s (two terms per pass 0.0102 s and 0.038 s, eight 0.0095 s and
//! 0.042 s; `LOOP_TERMS` 4, 6 or 8 within the noise); and with early sums, up to 1, 2, 4, 6
//! or 8 per loop: 0.0103, 0.0089, 0.0080, 0.0078 and 0.0080 s for the rigid body, Kepler
//! 0.038–0.039 s throughout. Against loops above 65 KB only, every model's run takes
//! 0.61–1.02× the time; the current times per model are in `docs/performance.md`.
//!
//! [`JitTaylor::new`] refuses above [`MAX_INSTRUCTIONS`] estimated instructions, which bounds
//! the compile time when a model's Taylor kernels are built to ≈ 20 ms; the caller then takes
//! a [`DeferredJit`], which compiles the program (with loops: 1.4–1.7× faster than the
//! interpreter on every model's X − ∇V at p = 19, 20) only once a run has spent about the
//! compile time interpreting it.
//!
//! # Bitwise agreement with the interpreter
//!
//! The operations are those of [`lasalle_runtime::taylor::rec`] in the same order: every sum
//! is accumulated from its first term upwards (Rust's `f64` `Sum` folds from −0.0, and
//! −0.0 + t = t exactly), products (j·a)·b with the integer weight j first (skipped for j = 1,
//! 1·a = a exactly), the division by k + 1 as a product with the rounded 1/(k + 1), and the
//! order-0 values through the same `std` and `lasalle_runtime::elliptic` functions (the
//! `extern "C"` wrappers of the parent module and below). Cranelift neither fuses nor
//! reassociates floating-point operations, so [`JitTaylor`] and [`TaylorTape`](crate::TaylorTape)
//! agree bitwise (`exec/tests/taylor.rs`: every model in `models/`, field and X − ∇V, every
//! operation's recurrence, the elliptic functions).

use super::{call_cbrt, call_cos, call_exp, call_ln, call_sin, jit_err, jit_module, Code};
use crate::taylor::{Inputs, TaylorError};
use crate::ExecError;
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::immediates::Ieee64;
use cranelift_codegen::ir::{
    types, AbiParam, BlockArg, InstBuilder, MemFlagsData, Signature, StackSlotData, StackSlotKind,
    Value,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::Module;
use lasalle_model::tape::taylor::{EarlySum, Leaf, PowZero, Rec, Span, TaylorProgram, EARLY_GROUP};
use lasalle_model::tape::Tape;
use lasalle_runtime::taylor::TaylorKernel;
use lasalle_runtime::StepError;
use std::collections::HashMap;

pub mod feedback;
pub mod loops;
pub use feedback::JitLoopFeedbackTaylor;
pub use loops::JitLoopTaylor;

/// `(state, hoisted, target, gains, table)`: fills the state rows of `table` (N × (p + 1),
/// row-major) with x^\[0..=p\] of the solution through `state`.
type TaylorFn = unsafe extern "C" fn(*const f64, *const f64, *const f64, *const f64, *mut f64);

/// The largest estimated instruction count (see [`JitTaylor::instructions`]) compiled; above
/// it [`JitTaylor::new`] returns `None` (the caller then takes a [`DeferredJit`]). Cranelift
/// compiles about 10⁶ of these per second here, so this bounds a kernel's compile time to
/// about 20 ms. At p = 19 it admits the field X of every model in `models/` (the rigid body's
/// is 15 276) and X − ∇V of the small ones (CR3BP 13 224, the closed-form pendulum 18 145), but
/// not X − ∇V of Kepler (41 420) or the rigid body (68 153).
pub const MAX_INSTRUCTIONS: usize = 20_000;

/// How many of the last stored coefficients are reused as values instead of reloaded (the
/// next recurrences usually read them: a store and a load back cost the store-forwarding
/// latency on the critical path).
const RECENT: usize = 4;

/// The shortest Cauchy sum made a loop (see the [module docs](self)).
const LOOP_TERMS: usize = 6;

/// Terms per pass of a Cauchy loop (fewer than [`LOOP_TERMS`], so that every loop makes at
/// least one pass).
const LOOP_UNROLL: usize = 4;
const _: () = assert!(LOOP_UNROLL < LOOP_TERMS);

/// Cranelift's optimisation level. Its e-graph passes find little to improve in straight-line
/// IEEE arithmetic (no reassociation, no fusion), and what they do (sharing constants, moving
/// loads) lengthens live ranges: "speed" made the Kepler kernel 1.2× and the rigid body's 1.5×
/// slower than "none" (`--bench taylor`), and compiles slower.
const OPT_LEVEL: &str = "none";

extern "C" fn call_powf(x: f64, p: f64) -> f64 {
    x.powf(p)
}
extern "C" fn call_ellipk(m: f64) -> f64 {
    lasalle_runtime::elliptic::ellipk(m)
}
extern "C" fn call_ellipf(phi: f64, m: f64) -> f64 {
    lasalle_runtime::elliptic::ellipf(phi, m)
}
/// sn, cn, dn of (u | m) into `out[0..3]`.
///
/// # Safety
/// `out` points to 3 writable f64 that nothing else accesses during the call.
unsafe extern "C" fn call_ellipj(u: f64, m: f64, out: *mut [f64; 3]) {
    let j = lasalle_runtime::elliptic::ellipj(u, m);
    // SAFETY: the caller's stack slot, see above
    unsafe { *out = [j.sn, j.cn, j.dn] };
}

/// A field tape's Taylor recurrences compiled for the order p: a [`TaylorKernel`] of
/// [`LoadedModel`](crate::LoadedModel); see the [module docs](self).
pub struct JitTaylor {
    inputs: Inputs,
    /// Owns the code; freed on drop.
    /// Owns the code `code` points into.
    _code: Code,
    func: TaylorFn,
    dim: usize,
    /// The compiled order p (= the stride − 1 of the table).
    order: usize,
    /// The coefficients of every row, rows × (p + 1), row-major (the state rows first).
    table: Vec<f64>,
    /// The order asked for by the last [`TaylorKernel::compute`].
    last: usize,
}

// SAFETY: the module is only touched again in `drop` (which has `&mut self`); the compiled
// function keeps no state (it reads its arguments and writes the table passed to it).
unsafe impl Send for JitTaylor {}

impl std::fmt::Debug for JitTaylor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitTaylor")
            .field("dim", &self.dim)
            .field("order", &self.order)
            .finish_non_exhaustive()
    }
}

impl JitTaylor {
    /// Compiles the recurrences of `tape` (a field) for the order `order` with parameter
    /// values `params`; `Ok(None)` if the unrolled code would exceed [`MAX_INSTRUCTIONS`].
    pub fn new(tape: &Tape, params: &[f64], order: u32) -> Result<Option<JitTaylor>, TaylorError> {
        let program = TaylorProgram::new(tape).map_err(TaylorError::kernels)?;
        if Self::instructions(&program, order as usize) > MAX_INSTRUCTIONS {
            return Ok(None);
        }
        Self::with_program(program, tape, params, order).map(Some)
    }

    /// [`JitTaylor::new`] with the recurrences `program` of `tape` (e.g.
    /// [`TaylorProgram::unfused`], to compare with), whatever their size.
    pub fn with_program(
        program: TaylorProgram,
        tape: &Tape,
        params: &[f64],
        order: u32,
    ) -> Result<JitTaylor, TaylorError> {
        if order == 0 {
            return Err(TaylorError::Option("the order must be at least 1".into()));
        }
        let p = order as usize;
        let inputs = Inputs::new(tape, params)?;
        let (code, func) = compile(&program, p, 1)?;
        Ok(JitTaylor {
            inputs,
            _code: code,
            func,
            dim: program.dim,
            order: p,
            table: vec![0.0; program.rows * (p + 1)],
            last: 0,
        })
    }

    /// An estimate of the IR instructions of the unrolled code at order p: the sums of the
    /// non-constant recurrences, counted in half sums (a folded square or square-root sum is
    /// one, a Cauchy product, quotient, power or weighted sum two, sin and cos four, sn, cn,
    /// dn with their three products twelve); a full sum has about k terms at order k, so
    /// p(p − 1)/2 over the orders, of four instructions each (two loads, a product, a sum);
    /// plus one instruction per recurrence and order for the rest.
    pub fn instructions(program: &TaylorProgram, p: usize) -> usize {
        let sums = |r: &Rec| match r {
            Rec::Leaf { .. }
            | Rec::Add { .. }
            | Rec::Sub { .. }
            | Rec::Neg { .. }
            | Rec::Scale { .. }
            | Rec::DivConst { .. }
            | Rec::EllipK { .. } => 0,
            Rec::Square { .. } | Rec::Sqrt { .. } => 1,
            Rec::SinCos { .. } => 4,
            Rec::Jacobi { .. } => 12,
            _ => 2,
        };
        let per_order: usize = program
            .recs
            .iter()
            .filter(|(_, constant)| !constant)
            .map(|(r, _)| sums(r))
            .sum();
        let all = program.recs.len() + program.dim;
        // half sums × p(p − 1)/4 terms × 4 instructions
        per_order * p * p.saturating_sub(1) + all * p
    }
}

impl TaylorKernel<crate::LoadedModel> for JitTaylor {
    fn dim(&self) -> usize {
        self.dim
    }

    fn max_order(&self) -> usize {
        self.order
    }

    fn sync(&mut self, model: &crate::LoadedModel) -> Result<(), StepError> {
        self.inputs.sync(model)
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        self.inputs.set_inputs(target, gains)
    }

    /// Always computes the compiled order p (the coefficients up to a lower `order` are the
    /// same values) and hands out `order + 1` of them.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    fn compute(&mut self, x: &[f64], order: usize) {
        assert_eq!(x.len(), self.dim, "state dimension");
        self.last = order.min(self.order);
        let i = &self.inputs;
        // SAFETY: the code reads x[..N], hoisted[..H], target[..M], gains[..G] and writes
        // table[..N(p + 1)]; `x` was checked above, `Inputs` keeps the hoisted values, targets
        // and gains at the tape's sizes, and the table was allocated with N(p + 1) entries.
        // The code lives as long as `self`.
        unsafe {
            (self.func)(
                x.as_ptr(),
                i.hoisted.as_ptr(),
                i.target.as_ptr(),
                i.gains.as_ptr(),
                self.table.as_mut_ptr(),
            )
        }
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        let s = self.order + 1;
        &self.table[i * s..i * s + self.last + 1]
    }
}

/// Orbits per call of a [`JitTaylorBatch`]: the two f64 of an SSE2 `F64X2` vector, the widest
/// that Cranelift emits for x86-64.
pub const LANES: usize = 2;

/// A field tape's Taylor recurrences compiled for the order p on [`LANES`] states at once: the
/// code of [`JitTaylor`] with every value a vector of one f64 per orbit (the calls of `std`'s
/// functions made orbit by orbit), so each orbit's coefficients are bitwise its
/// [`JitTaylor`]'s. A [`TaylorBatch`](lasalle_runtime::TaylorBatch) for
/// [`TaylorLanes`](lasalle_runtime::TaylorLanes).
pub struct JitTaylorBatch {
    inputs: Inputs,
    /// Owns the code `func` points into.
    _code: Code,
    func: TaylorFn,
    dim: usize,
    order: usize,
    /// rows × (p + 1) × [`LANES`]: order k of row r of orbit l at (r(p + 1) + k)·LANES + l.
    table: Vec<f64>,
}

// SAFETY: as `JitTaylor`'s
unsafe impl Send for JitTaylorBatch {}

impl std::fmt::Debug for JitTaylorBatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitTaylorBatch")
            .field("dim", &self.dim)
            .field("order", &self.order)
            .finish_non_exhaustive()
    }
}

impl JitTaylorBatch {
    /// Compiles the recurrences of `tape` (a field) for the order `order` with parameter
    /// values `params`; `Ok(None)` above [`MAX_INSTRUCTIONS`] (estimated for one orbit), where
    /// compiling costs more than lanes save in an ensemble's runs.
    pub fn new(
        tape: &Tape,
        params: &[f64],
        order: u32,
    ) -> Result<Option<JitTaylorBatch>, TaylorError> {
        let program = TaylorProgram::new(tape).map_err(TaylorError::kernels)?;
        let p = order as usize;
        if order == 0 || JitTaylor::instructions(&program, p) > MAX_INSTRUCTIONS {
            return Ok(None);
        }
        let inputs = Inputs::new(tape, params)?;
        let (code, func) = compile(&program, p, LANES)?;
        Ok(Some(JitTaylorBatch {
            inputs,
            _code: code,
            func,
            dim: program.dim,
            order: p,
            table: vec![0.0; program.rows * (p + 1) * LANES],
        }))
    }
}

impl lasalle_runtime::TaylorBatch<crate::LoadedModel> for JitTaylorBatch {
    fn dim(&self) -> usize {
        self.dim
    }

    fn lanes(&self) -> usize {
        LANES
    }

    fn order(&self) -> usize {
        self.order
    }

    fn sync(&mut self, model: &crate::LoadedModel) -> Result<(), StepError> {
        self.inputs.sync(model)
    }

    fn compute(&mut self, x: &[f64]) {
        assert_eq!(x.len(), self.dim * LANES, "state dimension × lanes");
        let i = &self.inputs;
        // SAFETY: as in `JitTaylor::compute`, with the state and the table LANES times as long
        unsafe {
            (self.func)(
                x.as_ptr(),
                i.hoisted.as_ptr(),
                i.target.as_ptr(),
                i.gains.as_ptr(),
                self.table.as_mut_ptr(),
            )
        }
    }

    fn table(&self) -> &[f64] {
        &self.table[..self.dim * (self.order + 1) * LANES]
    }
}

/// Interpreted computes after which a [`DeferredJit`] compiles its program. Measured on X − ∇V
/// at p = 19 and 20 (Kepler, the perturbed Kepler problem, the rigid body, SO(3) type III;
/// loaded machine): an interpreted compute takes 10–20 µs, the compiled one 0.6–0.7× that, and
/// compiling 90–375 ms, i.e. the time of 8 000–19 000 interpreted computes (with the
/// four-term loops and early sums, quiet machine of 2026-11-25, p = 19: 63 ms for the
/// perturbed Kepler problem, 110 ms Kepler, 156 ms the rigid body, 199 ms SO(3) type III, the
/// time of 8 500–10 800 interpreted computes, so the rule stands). Compiling after
/// about as many computes as the compile costs bounds a run's kernel time by twice the better
/// of interpreting throughout and compiling at once (the ski-rental rule), without knowing the
/// run's length: a short run (the rigid body's 4 741 steps to t = 1000) never compiles, a long
/// one (Kepler's 57 931 over 1000 periods) runs most of its steps compiled.
pub const DEFER_COMPUTES: usize = 10_000;

/// The kernel of a program above [`MAX_INSTRUCTIONS`] (X − ∇V of the larger models): the
/// interpreted [`TaylorTape`](crate::TaylorTape) for its first [`DEFER_COMPUTES`] computes,
/// then the program compiled by [`JitTaylor::with_program`] (with loops, see the [module
/// docs](self)). Both compute the same coefficients bitwise, so the switch does not show in
/// the results; the compile allocates, once, inside the step that makes it. If it fails the
/// kernel stays interpreted.
pub struct DeferredJit {
    tape: Tape,
    interpreted: crate::TaylorTape,
    /// Interpreted computes so far (counted up to [`DEFER_COMPUTES`]).
    computes: usize,
    compiled: Option<JitTaylor>,
}

impl std::fmt::Debug for DeferredJit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeferredJit")
            .field("computes", &self.computes)
            .field("compiled", &self.compiled)
            .finish_non_exhaustive()
    }
}

impl DeferredJit {
    /// The interpreted kernel of `tape` (a field) for orders up to `order`, with parameter
    /// values `params`, to be compiled for the order `order` after [`DEFER_COMPUTES`] computes.
    pub fn new(tape: &Tape, params: &[f64], order: u32) -> Result<DeferredJit, TaylorError> {
        Ok(DeferredJit {
            interpreted: crate::TaylorTape::new(tape, params, order)?,
            tape: tape.clone(),
            computes: 0,
            compiled: None,
        })
    }

    /// Whether the program has been compiled (after [`DEFER_COMPUTES`] computes).
    pub fn is_compiled(&self) -> bool {
        self.compiled.is_some()
    }

    /// Compiles the program with the interpreter's current parameters, targets and gains.
    fn compile(&mut self) {
        let order = self.interpreted.max_order() as u32;
        let inputs = self.interpreted.inputs();
        let jit = TaylorProgram::new(&self.tape)
            .map_err(TaylorError::kernels)
            .and_then(|program| {
                JitTaylor::with_program(program, &self.tape, &inputs.params, order)
            });
        if let Ok(mut jit) = jit {
            jit.inputs = inputs.clone();
            self.compiled = Some(jit);
        }
    }
}

impl TaylorKernel<crate::LoadedModel> for DeferredJit {
    fn dim(&self) -> usize {
        self.interpreted.dim()
    }

    fn max_order(&self) -> usize {
        TaylorKernel::<crate::LoadedModel>::max_order(&self.interpreted)
    }

    fn sync(&mut self, model: &crate::LoadedModel) -> Result<(), StepError> {
        match &mut self.compiled {
            Some(jit) => jit.sync(model),
            None => self.interpreted.sync(model),
        }
    }

    fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), StepError> {
        match &mut self.compiled {
            Some(jit) => jit.set_inputs(target, gains),
            None => {
                TaylorKernel::<crate::LoadedModel>::set_inputs(&mut self.interpreted, target, gains)
            }
        }
    }

    fn compute(&mut self, x: &[f64], order: usize) {
        if self.compiled.is_none() && self.computes == DEFER_COMPUTES {
            self.compile();
        }
        match &mut self.compiled {
            Some(jit) => jit.compute(x, order),
            None => {
                self.computes = (self.computes + 1).min(DEFER_COMPUTES + 1);
                self.interpreted.compute(x, order)
            }
        }
    }

    fn coefficients(&self, i: usize) -> &[f64] {
        match &self.compiled {
            Some(jit) => jit.coefficients(i),
            None => self.interpreted.state_coefficients(i),
        }
    }
}

/// The recurrences of `program` compiled for the order p on `lanes` orbits per call, and the
/// code that owns the function.
fn compile(
    program: &TaylorProgram,
    p: usize,
    lanes: usize,
) -> Result<(Code, TaylorFn), TaylorError> {
    let (code, func) = jit_module(OPT_LEVEL, false)
        .and_then(|module| Code::compile(module, |m| define(m, program, p, lanes)))
        .map_err(TaylorError::kernels)?;
    // SAFETY: the function was just defined with this signature (five pointers, the host's C
    // calling convention), and `code` owns the module it lives in.
    let func = unsafe { std::mem::transmute::<*const u8, TaylorFn>(func) };
    Ok((code, func))
}

/// Defines and finalises the function; returns its id.
fn define(
    module: &mut JITModule,
    program: &TaylorProgram,
    p: usize,
    lanes: usize,
) -> Result<cranelift_module::FuncId, ExecError> {
    // every offset into the table fits an immediate
    offset(program.rows * (p + 1) * lanes)?;
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 5]);
    let id = module.declare_anonymous_function(&sig).map_err(jit_err)?;
    let mut ctx = module.make_context();
    ctx.func.signature = sig;
    let mut fctx = FunctionBuilderContext::new();
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let args: [Value; 5] = b.block_params(entry).try_into().expect("five parameters");
        let [unary, binary, ellipj] = call_signatures(module);
        let zero = b.ins().f64const(Ieee64::with_bits(0f64.to_bits()));
        let zero = match lanes {
            1 => zero,
            _ => b.ins().splat(types::F64X2, zero),
        };
        let [state, hoisted, target, gains, table] = args;
        let mut e = Emit {
            b,
            ptr,
            unary,
            binary,
            ellipj,
            table,
            stride: p + 1,
            lanes,
            layout: None,
            rows: vec![0; program.rows],
            recent: Default::default(),
            early: HashMap::new(),
            zero,
            ellipj_out: None,
        };
        let leaves = Leaves {
            state,
            hoisted,
            target,
            gains,
        };
        e.body(program, p, &leaves)?;
        e.b.ins().return_(&[]);
        e.b.seal_all_blocks();
        e.b.finalize(module.target_config());
    }
    module.define_function(id, &mut ctx).map_err(jit_err)?;
    module.clear_context(&mut ctx);
    module.finalize_definitions().map_err(jit_err)?;
    Ok(id)
}

/// A byte offset for element `i` of an input or of the table.
fn offset(i: usize) -> Result<i32, ExecError> {
    i.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| ExecError::Jit(format!("index {i} too large for an immediate offset")))
}

/// The function being built.
struct Emit<'a> {
    b: FunctionBuilder<'a>,
    ptr: types::Type,
    unary: Signature,
    binary: Signature,
    ellipj: Signature,
    /// The table's address and its stride p + 1.
    table: Value,
    stride: usize,
    /// Orbits per call: 1 (values `F64`) or [`LANES`] (values `F64X2`, the table's entries
    /// `LANES` f64 apart, one per orbit).
    lanes: usize,
    /// Where each row starts in the table and whether it holds every order (else only the
    /// current one, in one place), if not every row holds p + 1 orders at r (p + 1): the
    /// compact tables of the loop form (`loops::layout`).
    layout: Option<Vec<(usize, bool)>>,
    /// How many orders of each row are in the table.
    rows: Vec<usize>,
    /// The last values stored, (row, order, value), read back without a load.
    recent: std::collections::VecDeque<(usize, usize, Value)>,
    /// Order k's early sums computed by [`Emit::early_sums`], by (a, b, lo, hi).
    early: HashMap<(usize, usize, usize, usize), Value>,
    /// The constant 0 (the higher coefficients of rows constant along the solution).
    zero: Value,
    /// The address of a 3-f64 stack slot for `call_ellipj`, once needed.
    ellipj_out: Option<Value>,
}

impl Emit<'_> {
    /// The table index of order k of row r.
    fn at(&self, r: usize, k: usize) -> usize {
        match &self.layout {
            None => r * self.stride + k,
            Some(l) => match l[r] {
                (start, true) => start + k,
                (start, false) => start,
            },
        }
    }

    /// Order k of row r: a load from the table (0 past the order-0 value of a constant row).
    fn c(&mut self, r: usize, k: usize) -> Value {
        if k >= self.rows[r] {
            return self.zero;
        }
        if let Some(&(_, _, v)) = self.recent.iter().find(|&&(rr, kk, _)| rr == r && kk == k) {
            return v;
        }
        let off = self.at(r, k) * 8 * self.lanes;
        let off = i32::try_from(off).expect("table size checked in `define`");
        let (ty, flags) = (self.ty(), self.flags());
        self.b.ins().load(ty, flags, self.table, off)
    }

    /// The type of a value: one f64 per orbit.
    fn ty(&self) -> types::Type {
        if self.lanes == 1 {
            types::F64
        } else {
            types::F64X2
        }
    }

    /// The flags of the table's loads and stores: in bounds and aligned for one f64 (a
    /// vector's 16 bytes are not known to be aligned).
    fn flags(&self) -> MemFlagsData {
        if self.lanes == 1 {
            MemFlagsData::trusted()
        } else {
            MemFlagsData::new().with_notrap()
        }
    }

    /// Stores order k of row `d`.
    fn push(&mut self, d: usize, k: usize, v: Value) {
        debug_assert_eq!(self.rows[d], k, "orders in sequence");
        let off = self.at(d, k) * 8 * self.lanes;
        let off = i32::try_from(off).expect("table size checked in `define`");
        let flags = self.flags();
        self.b.ins().store(flags, v, self.table, off);
        self.rows[d] += 1;
        if self.recent.len() == RECENT {
            self.recent.pop_front();
        }
        self.recent.push_back((d, k, v));
    }

    fn fadd(&mut self, x: Value, y: Value) -> Value {
        self.b.ins().fadd(x, y)
    }

    fn fsub(&mut self, x: Value, y: Value) -> Value {
        self.b.ins().fsub(x, y)
    }

    fn fmul(&mut self, x: Value, y: Value) -> Value {
        self.b.ins().fmul(x, y)
    }

    fn fdiv(&mut self, x: Value, y: Value) -> Value {
        self.b.ins().fdiv(x, y)
    }

    fn fneg(&mut self, x: Value) -> Value {
        self.b.ins().fneg(x)
    }

    fn constant(&mut self, x: f64) -> Value {
        let x = self.b.ins().f64const(Ieee64::with_bits(x.to_bits()));
        self.splat(x)
    }

    /// A value of every orbit equal to the scalar `x`.
    fn splat(&mut self, x: Value) -> Value {
        match self.lanes {
            1 => x,
            _ => self.b.ins().splat(types::F64X2, x),
        }
    }

    /// Input `i` shared by the orbits (a hoisted value, a target, a gain).
    fn load(&mut self, base: Value, i: usize) -> Result<Value, ExecError> {
        let flags = MemFlagsData::trusted().with_readonly().with_can_move();
        let x = self.b.ins().load(types::F64, flags, base, offset(i)?);
        Ok(self.splat(x))
    }

    /// Component `i` of the state, one per orbit (the orbits' states interleaved).
    fn load_state(&mut self, base: Value, i: usize) -> Result<Value, ExecError> {
        let flags = self.flags().with_readonly().with_can_move();
        let ty = self.ty();
        Ok(self.b.ins().load(ty, flags, base, offset(i * self.lanes)?))
    }

    /// `f` of each orbit's values `args`, one scalar call per orbit.
    fn per_lane(&mut self, f: usize, sig: &Signature, args: &[Value]) -> Value {
        if self.lanes == 1 {
            return self.call(f, sig, args).expect("one result");
        }
        let mut out = None;
        for lane in 0..LANES as u8 {
            let scalars: Vec<Value> = args
                .iter()
                .map(|&a| self.b.ins().extractlane(a, lane))
                .collect();
            let r = self.call(f, sig, &scalars).expect("one result");
            out = Some(match out {
                None => self.b.ins().splat(types::F64X2, r),
                Some(v) => self.b.ins().insertlane(v, r, lane),
            });
        }
        out.expect("at least one lane")
    }

    fn call(&mut self, f: usize, sig: &Signature, args: &[Value]) -> Option<Value> {
        let sig = self.b.import_signature(sig.clone());
        let callee = self.b.ins().iconst(self.ptr, f as i64);
        let call = self.b.ins().call_indirect(sig, callee, args);
        self.b.inst_results(call).first().copied()
    }

    fn unary(&mut self, f: extern "C" fn(f64) -> f64, x: Value) -> Value {
        let sig = self.unary.clone();
        self.per_lane(f as *const () as usize, &sig, &[x])
    }

    fn binary(&mut self, f: extern "C" fn(f64, f64) -> f64, x: Value, y: Value) -> Value {
        let sig = self.binary.clone();
        self.per_lane(f as *const () as usize, &sig, &[x, y])
    }

    /// Σ_{j ∈ js} x_j·y_j from the first term upwards, `None` if empty; `term(j)` emits the
    /// factors' loads right before their product, so that the loads fold into the products
    /// and nothing is kept in registers across the sum.
    fn sum(
        &mut self,
        js: impl IntoIterator<Item = usize>,
        mut term: impl FnMut(&mut Self, usize) -> (Value, Value),
    ) -> Option<Value> {
        let mut acc: Option<Value> = None;
        for j in js {
            let (x, y) = term(self, j);
            let t = self.fmul(x, y);
            acc = Some(match acc {
                None => t,
                Some(s) => self.fadd(s, t),
            });
        }
        acc
    }

    /// Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\] (`rec::cauchy`; 0 if lo > hi): computed at the start of
    /// the order by [`Emit::early_sums`], or unrolled below [`LOOP_TERMS`] terms, else a loop
    /// ([`Emit::looped`]).
    fn cauchy(&mut self, a: usize, b: usize, k: usize, lo: usize, hi: usize) -> Value {
        if let Some(v) = self.early.remove(&(a, b, lo, hi)) {
            return v;
        }
        if !self.loops_over(a, b, k, lo, hi) {
            return self
                .sum(lo..=hi, |e, j| (e.c(a, j), e.c(b, k - j)))
                .unwrap_or(self.zero);
        }
        self.looped(&[(a, b)], k, lo, hi)[0]
    }

    /// Whether Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\] is a loop: [`LOOP_TERMS`] terms or more, all
    /// of them in the table.
    fn loops_over(&self, a: usize, b: usize, k: usize, lo: usize, hi: usize) -> bool {
        hi + 1 >= lo + LOOP_TERMS && self.rows[a] > hi && self.rows[b] > k - lo
    }

    /// Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\] for every (a, b) of `pairs` (at least
    /// [`LOOP_TERMS`] terms, all in the table), in one loop: the first
    /// 1 + (hi − lo) mod [`LOOP_UNROLL`] terms of each unrolled, then passes of
    /// [`LOOP_UNROLL`] terms of every sum along two pointers, one up the table (table + 8j,
    /// with each a's row as the load's offset) and one down (table + 8(k − j)). Each sum is
    /// accumulated in its own order, from its first term upwards; a row read at the same
    /// place by several sums is loaded once.
    fn looped(&mut self, pairs: &[(usize, usize)], k: usize, lo: usize, hi: usize) -> Vec<Value> {
        let head = lo + 1 + (hi - lo) % LOOP_UNROLL;
        let firsts: Vec<Value> = pairs
            .iter()
            .map(|&(a, b)| {
                let s = self.sum(lo..head, |e, j| (e.c(a, j), e.c(b, k - j)));
                s.expect("at least one term")
            })
            .collect();
        let (ptr, ty, w) = (self.ptr, self.ty(), 8 * self.lanes);
        let at = |e: &mut Self, j: usize| {
            let off = e.b.ins().iconst(ptr, (j * w) as i64);
            e.b.ins().iadd(e.table, off)
        };
        let (up, down, end) = (at(self, head), at(self, k - head), at(self, hi + 1));
        let body = self.b.create_block();
        let mut accs: Vec<Value> = firsts
            .iter()
            .map(|_| self.b.append_block_param(body, ty))
            .collect();
        let up_v = self.b.append_block_param(body, ptr);
        let down_v = self.b.append_block_param(body, ptr);
        let exit = self.b.create_block();
        for _ in pairs {
            self.b.append_block_param(exit, ty);
        }
        let args: Vec<BlockArg> = firsts
            .iter()
            .chain([&up, &down])
            .map(|&v| BlockArg::Value(v))
            .collect();
        self.b.ins().jump(body, &args);
        self.b.switch_to_block(body);
        let flags = self.flags();
        let starts: Vec<(usize, i32)> = pairs
            .iter()
            .flat_map(|&(a, b)| [a, b])
            .map(|r| (r, (self.at(r, 0) * w) as i32))
            .collect();
        let row = |r: usize| starts.iter().find(|s| s.0 == r).expect("a summed row").1;
        for u in 0..LOOP_UNROLL as i32 {
            let mut loaded: Vec<((bool, usize), Value)> = Vec::new();
            for (m, &(a, b)) in pairs.iter().enumerate() {
                let mut load = |e: &mut Self, key: (bool, usize), base: Value, off: i32| {
                    if let Some(&(_, v)) = loaded.iter().find(|(kk, _)| *kk == key) {
                        return v;
                    }
                    let v = e.b.ins().load(ty, flags, base, off);
                    loaded.push((key, v));
                    v
                };
                let x = load(self, (true, a), up_v, row(a) + w as i32 * u);
                let y = load(self, (false, b), down_v, row(b) - w as i32 * u);
                let t = self.fmul(x, y);
                accs[m] = self.fadd(accs[m], t);
            }
        }
        let step = self.b.ins().iconst(ptr, (w * LOOP_UNROLL) as i64);
        let up_n = self.b.ins().iadd(up_v, step);
        let down_n = self.b.ins().isub(down_v, step);
        let more = self.b.ins().icmp(IntCC::NotEqual, up_n, end);
        let again: Vec<BlockArg> = accs
            .iter()
            .chain([&up_n, &down_n])
            .map(|&v| BlockArg::Value(v))
            .collect();
        let done: Vec<BlockArg> = accs.iter().map(|&v| BlockArg::Value(v)).collect();
        self.b.ins().brif(more, body, &again, exit, &done);
        self.b.switch_to_block(exit);
        self.b.block_params(exit).to_vec()
    }

    /// Order k's early sums ([`TaylorProgram::early_sums`], groups of up to [`EARLY_GROUP`]) that
    /// loop, each group in one loop, before the order's recurrences; [`Emit::cauchy`] then
    /// takes them from `early`.
    fn early_sums(&mut self, groups: &[(Span, Vec<EarlySum>)], k: usize) {
        for (span, group) in groups {
            let (lo, hi) = span.range(k);
            let pairs: Vec<(usize, usize)> = group
                .iter()
                .map(|e| (e.a, e.b))
                .filter(|&(a, b)| self.loops_over(a, b, k, lo, hi))
                .collect();
            if pairs.is_empty() {
                continue;
            }
            let sums = self.looped(&pairs, k, lo, hi);
            for (&(a, b), v) in pairs.iter().zip(sums) {
                self.early.insert((a, b, lo, hi), v);
            }
        }
    }

    /// j·x for the weight j: exact and skipped for j = 1.
    fn weight(&mut self, j: usize, x: Value) -> Value {
        if j == 1 {
            x
        } else {
            let w = self.constant(j as f64);
            self.fmul(w, x)
        }
    }

    /// Σ_{j=1}^{k} (j a^\[j\]) b^\[k−j\] (`rec::weighted`).
    fn weighted(&mut self, a: usize, b: usize, k: usize) -> Value {
        self.sum(1..=k, |e, j| {
            let x = e.c(a, j);
            (e.weight(j, x), e.c(b, k - j))
        })
        .expect("k ≥ 1 terms")
    }

    /// (Σ_{j=1}^{k−1} a^\[j\] b^\[k−j\] + a^\[0\] b^\[k\]) + a^\[k\] b^\[0\] (`rec::mul`).
    fn mul(&mut self, a: usize, b: usize, k: usize) -> Value {
        let s = self.cauchy(a, b, k, 1, k - 1);
        let (x, y) = (self.c(a, 0), self.c(b, k));
        let t = self.fmul(x, y);
        let s = self.fadd(s, t);
        let (x, y) = (self.c(a, k), self.c(b, 0));
        let t = self.fmul(x, y);
        self.fadd(s, t)
    }

    /// 2 (Σ_{j=lo}^{(k−1)/2} a^\[j\] a^\[k−j\] (+ a^\[0\] a^\[k\] if `newest`)) + a^\[k/2\]² for even
    /// k: `rec::square` (lo = 1 with the newest term) and `rec::sqrt`'s sum (lo = 1 without).
    fn folded(&mut self, a: usize, k: usize, newest: bool) -> Value {
        let half = (k - 1) / 2;
        let mut s = self.cauchy(a, a, k, 1, half);
        if newest {
            let (x, y) = (self.c(a, 0), self.c(a, k));
            let t = self.fmul(x, y);
            s = self.fadd(s, t);
        }
        let two = self.constant(2.0);
        let mut s = self.fmul(two, s);
        if k.is_multiple_of(2) {
            let m = self.c(a, k / 2);
            let sq = self.fmul(m, m);
            s = self.fadd(s, sq);
        }
        s
    }

    /// w / k.
    fn over_k(&mut self, w: Value, k: usize) -> Value {
        let kv = self.constant(k as f64);
        self.fdiv(w, kv)
    }

    /// The whole function: orders 0..p of every recurrence into the table.
    fn body(
        &mut self,
        program: &TaylorProgram,
        p: usize,
        leaves: &Leaves,
    ) -> Result<(), ExecError> {
        for i in 0..program.dim {
            let x = self.load_state(leaves.state, i)?;
            self.push(i, 0, x);
        }
        let early = program.early_sums(EARLY_GROUP);
        for k in 0..p {
            if k >= 1 {
                self.early_sums(&early, k);
            }
            for &(r, constant) in &program.recs {
                if k == 0 {
                    self.zeroth(r, leaves)?;
                } else if !constant {
                    self.coefficient(r, k);
                }
            }
            debug_assert!(
                self.early.is_empty(),
                "every early sum is read at its order"
            );
            let inv = self.constant(1.0 / (k as f64 + 1.0));
            for (i, &o) in program.outputs.iter().enumerate() {
                let x = self.c(o, k);
                let v = self.fmul(x, inv);
                self.push(i, k + 1, v);
            }
        }
        Ok(())
    }

    /// Order 0 (as `zeroth` of the interpreter).
    fn zeroth(&mut self, r: Rec, leaves: &Leaves) -> Result<(), ExecError> {
        let (d, v) = match r {
            Rec::Leaf { d, leaf } => (
                d,
                match leaf {
                    Leaf::Const(x) => self.constant(x),
                    Leaf::Hoisted(k) => self.load(leaves.hoisted, k)?,
                    Leaf::Target(k) => self.load(leaves.target, k)?,
                    Leaf::Gain(k) => self.load(leaves.gains, k)?,
                },
            ),
            Rec::Add { d, a, b } => {
                let (x, y) = (self.c(a, 0), self.c(b, 0));
                (d, self.fadd(x, y))
            }
            Rec::Sub { d, a, b } => {
                let (x, y) = (self.c(a, 0), self.c(b, 0));
                (d, self.fsub(x, y))
            }
            Rec::Neg { d, a } => {
                let x = self.c(a, 0);
                (d, self.fneg(x))
            }
            Rec::Mul { d, a, b } | Rec::Scale { d, a, c: b } => {
                let (x, y) = (self.c(a, 0), self.c(b, 0));
                (d, self.fmul(x, y))
            }
            Rec::Square { d, a } => {
                let x = self.c(a, 0);
                (d, self.fmul(x, x))
            }
            Rec::Div { d, a, b } | Rec::DivConst { d, a, c: b } => {
                let (x, y) = (self.c(a, 0), self.c(b, 0));
                (d, self.fdiv(x, y))
            }
            Rec::Pow { d, a, zero, .. } => {
                let v = match zero {
                    PowZero::Cbrt => {
                        let x = self.c(a, 0);
                        self.unary(call_cbrt, x)
                    }
                    PowZero::Powf(q) => {
                        let (x, q) = (self.c(a, 0), self.constant(q));
                        self.binary(call_powf, x, q)
                    }
                    // order 0 is the fused chain's
                    PowZero::Fused => return Ok(()),
                };
                (d, v)
            }
            Rec::Sqrt { d, a } => {
                let x = self.c(a, 0);
                (d, self.b.ins().sqrt(x))
            }
            Rec::Exp { d, a } => {
                let x = self.c(a, 0);
                (d, self.unary(call_exp, x))
            }
            Rec::Ln { d, a } => {
                let x = self.c(a, 0);
                (d, self.unary(call_ln, x))
            }
            Rec::SinCos { s, c, a } => {
                let x = self.c(a, 0);
                let sv = self.unary(call_sin, x);
                let cv = self.unary(call_cos, x);
                self.push(s, 0, sv);
                self.push(c, 0, cv);
                return Ok(());
            }
            Rec::Jacobi { rows, a, m } => {
                let out = match self.ellipj_out {
                    Some(out) => out,
                    None => {
                        let slot = self.b.create_sized_stack_slot(StackSlotData::new(
                            StackSlotKind::ExplicitSlot,
                            24,
                            3,
                        ));
                        let out = self.b.ins().stack_addr(self.ptr, slot, 0);
                        self.ellipj_out = Some(out);
                        out
                    }
                };
                let (u, m) = (self.c(a, 0), self.c(m, 0));
                let sig = self.ellipj.clone();
                // one call per orbit, its sn, cn, dn gathered into the orbits' values
                let mut lanes: Vec<[Value; 3]> = Vec::with_capacity(self.lanes);
                for lane in 0..self.lanes {
                    let (u, m) = match self.lanes {
                        1 => (u, m),
                        _ => (
                            self.b.ins().extractlane(u, lane as u8),
                            self.b.ins().extractlane(m, lane as u8),
                        ),
                    };
                    self.call(call_ellipj as *const () as usize, &sig, &[u, m, out]);
                    let flags = MemFlagsData::trusted();
                    lanes
                        .push([0, 8, 16].map(|off| self.b.ins().load(types::F64, flags, out, off)));
                }
                let [sn, cn, dn] = [0, 1, 2].map(|j| {
                    let v = self.splat(lanes[0][j]);
                    lanes[1..]
                        .iter()
                        .enumerate()
                        .fold(v, |v, (l, x)| self.b.ins().insertlane(v, x[j], l as u8 + 1))
                });
                let cd = self.fmul(cn, dn);
                let sd = self.fmul(sn, dn);
                let sc = self.fmul(sn, cn);
                for (r, v) in rows.into_iter().zip([sn, cn, dn, cd, sd, sc]) {
                    self.push(r, 0, v);
                }
                return Ok(());
            }
            Rec::EllipK { d, a } => {
                let x = self.c(a, 0);
                (d, self.unary(call_ellipk, x))
            }
            Rec::EllipF { d, a, m, .. } => {
                let (x, m) = (self.c(a, 0), self.c(m, 0));
                (d, self.binary(call_ellipf, x, m))
            }
        };
        self.push(d, 0, v);
        Ok(())
    }

    /// Order k ≥ 1 of a non-constant recurrence (as `rec`).
    fn coefficient(&mut self, r: Rec, k: usize) {
        let (d, v) = match r {
            Rec::Leaf { .. } | Rec::EllipK { .. } => return,
            Rec::Add { d, a, b } => {
                let (x, y) = (self.c(a, k), self.c(b, k));
                (d, self.fadd(x, y))
            }
            Rec::Sub { d, a, b } => {
                let (x, y) = (self.c(a, k), self.c(b, k));
                (d, self.fsub(x, y))
            }
            Rec::Neg { d, a } => {
                let x = self.c(a, k);
                (d, self.fneg(x))
            }
            Rec::Mul { d, a, b } => (d, self.mul(a, b, k)),
            Rec::Scale { d, a, c } => {
                let (x, y) = (self.c(a, k), self.c(c, 0));
                (d, self.fmul(x, y))
            }
            Rec::Square { d, a } => (d, self.folded(a, k, true)),
            Rec::Div { d, a, b } => {
                let s = self.cauchy(b, d, k, 1, k);
                let x = self.c(a, k);
                let num = self.fsub(x, s);
                let b0 = self.c(b, 0);
                (d, self.fdiv(num, b0))
            }
            Rec::DivConst { d, a, c } => {
                let (x, y) = (self.c(a, k), self.c(c, 0));
                (d, self.fdiv(x, y))
            }
            Rec::Pow { d, a, alpha, .. } => {
                // Σ_{j=1}^{k−1} (α(k−j) − j) a^[k−j] u^[j], then the term j = 0, the weights
                // rounded as `rec::pow`'s
                let kf = k as f64;
                let s = self.sum(1..k, |e, j| {
                    let w = e.constant(alpha * (kf - j as f64) - j as f64);
                    let x = e.c(a, k - j);
                    (e.fmul(w, x), e.c(d, j))
                });
                let w = self.constant(alpha * kf);
                let x = self.c(a, k);
                let x = self.fmul(w, x);
                let u0 = self.c(d, 0);
                let t = self.fmul(x, u0);
                let s = match s {
                    Some(s) => self.fadd(s, t),
                    None => t,
                };
                let kv = self.constant(kf);
                let a0 = self.c(a, 0);
                let den = self.fmul(kv, a0);
                (d, self.fdiv(s, den))
            }
            Rec::Sqrt { d, a } => {
                let s = if k >= 2 {
                    self.folded(d, k, false)
                } else {
                    self.zero
                };
                let x = self.c(a, k);
                let num = self.fsub(x, s);
                let two = self.constant(2.0);
                let u0 = self.c(d, 0);
                let den = self.fmul(two, u0);
                (d, self.fdiv(num, den))
            }
            Rec::Exp { d, a } => {
                let s = self.weighted(a, d, k);
                (d, self.over_k(s, k))
            }
            Rec::Ln { d, a } => {
                // Σ_{j=1}^{k−1} (j u^[j]) a^[k−j]
                let s = self
                    .sum(1..k, |e, j| {
                        let u = e.c(d, j);
                        (e.weight(j, u), e.c(a, k - j))
                    })
                    .unwrap_or(self.zero);
                let q = self.over_k(s, k);
                let x = self.c(a, k);
                let num = self.fsub(x, q);
                let a0 = self.c(a, 0);
                (d, self.fdiv(num, a0))
            }
            Rec::SinCos { s, c, a } => {
                let ws = self.weighted(a, c, k);
                let wc = self.weighted(a, s, k);
                let sk = self.over_k(ws, k);
                let nwc = self.fneg(wc);
                let ck = self.over_k(nwc, k);
                self.push(s, k, sk);
                self.push(c, k, ck);
                return;
            }
            Rec::Jacobi { rows, a, m } => {
                let [sn, cn, dn, cd, sd, sc] = rows;
                let w = self.weighted(a, cd, k);
                let sk = self.over_k(w, k);
                let w = self.weighted(a, sd, k);
                let nw = self.fneg(w);
                let ck = self.over_k(nw, k);
                let w = self.weighted(a, sc, k);
                let m0 = self.c(m, 0);
                let nm = self.fneg(m0);
                let mw = self.fmul(nm, w);
                let dk = self.over_k(mw, k);
                self.push(sn, k, sk);
                self.push(cn, k, ck);
                self.push(dn, k, dk);
                let v = self.mul(cn, dn, k);
                self.push(cd, k, v);
                let v = self.mul(sn, dn, k);
                self.push(sd, k, v);
                let v = self.mul(sn, cn, k);
                self.push(sc, k, v);
                return;
            }
            Rec::EllipF { d, a, w, .. } => {
                let s = self.weighted(a, w, k);
                (d, self.over_k(s, k))
            }
        };
        self.push(d, k, v);
    }
}

/// The input pointers.
struct Leaves {
    state: Value,
    hoisted: Value,
    target: Value,
    gains: Value,
}

/// The signatures of the math wrappers the recurrences call: x ↦ f(x), (x, y) ↦ f(x, y) and
/// `ellipj`'s (u, m, out).
fn call_signatures(module: &JITModule) -> [Signature; 3] {
    let mut unary = module.make_signature();
    unary.params.push(AbiParam::new(types::F64));
    unary.returns.push(AbiParam::new(types::F64));
    let mut binary = unary.clone();
    binary.params.push(AbiParam::new(types::F64));
    let mut ellipj = binary.clone();
    ellipj.returns.clear();
    ellipj
        .params
        .push(AbiParam::new(module.target_config().pointer_type()));
    [unary, binary, ellipj]
}

//! The Cranelift back end: one native function per entry point of a tape.
//!
//! Every register is one SSA value. `+ − · /`, negation and `sqrt` are native instructions
//! (IEEE, correctly rounded, never fused or reassociated by Cranelift); `Powi` is expanded
//! inline by the binary exponentiation of
//! [`lasalle_model::tape::powi`]; `cbrt`, `exp`, `ln`, `sin`, `cos` and
//! `powf` call `extern "C"` wrappers of the `std` functions, and the elliptic functions
//! (K, sn, cn, dn, F) wrappers of `lasalle_runtime::elliptic`'s, so results are bitwise those
//! of the interpreter and of the emitted Rust. sn, cn and dn go through a per-call cache of the
//! last `ellipj` arguments and values (a stack slot), so those of one (u | m) cost one call.
//!
//! Two functions are compiled per tape, three per step tape:
//! - `eval(hoisted, state, target, gains, out)` for one state, with pairs of isomorphic,
//!   independent instructions (the x, y, z components of a model running through the same
//!   operations) computed as one two-lane `F64X2` instruction, as LLVM's SLP vectoriser does
//!   to the emitted Rust: adjacent input elements loaded and adjacent outputs stored 128 bits
//!   at a time, `+ − · /`, negation, `sqrt` and `powi` lane-wise — the same IEEE operation
//!   in each lane, so the results are bitwise those of scalar code (the pairing pass, what it
//!   pairs and its cost model: `exec/src/jit/slp.rs`;
//!   [`JitKernel::paired_instructions`] counts the paired instructions). An operand vector of
//!   two values that are the same for every call (two hoisted values, or one and a constant,
//!   in any lanes) is one 128-bit load of a *vector slot*: `hoist` appends the pair to the
//!   tape's hoisted values, so `hoisted` is longer for this back end than for the others.
//!   The packs and scalar instructions are emitted in an order that keeps few values live
//!   (`Slp::schedule` in `slp.rs`), each input element and constant at its first use, and
//!   `eval` is compiled in a module of its own at `opt_level = none`, which keeps that order:
//!   Cranelift's e-graph (at `speed`) would elaborate the body depth first from the stores,
//!   and has nothing to add to a tape that is already simplified and shared (the effect:
//!   `docs/performance.md`, back ends);
//! - for a step tape ([`JitKernel::with_batch`]), also `batch`, the loop of a batch of
//!   steps around `eval`'s code (`batch.rs`, also compiled at `none` for short states);
//! - `lanes(k, hoisted, state, target, gains, out)`, a loop over the k lanes of
//!   structure-of-arrays inputs, four lanes at a time as two 128-bit vectors (the same IEEE
//!   operations lane by lane; calls are made per lane), then two, then the odd last lane in
//!   scalars. The two vectors of the four-lane loop are independent dependency chains, emitted
//!   instruction by instruction in turn, so one's square roots and divisions overlap the
//!   other's work (Kepler: −7% per state against two lanes per iteration; Cranelift's x86-64
//!   back end has no 256-bit vectors). Instructions that read no state (targets, gains,
//!   hoisted values, constants and what depends on them alone) are computed once before the
//!   loop.
//!
//! For speed: in `lanes`, the loads of the inputs are marked pure (see `load_flags`), so
//! Cranelift places them at their uses instead of loading everything up front and spilling
//! (in `eval` the schedule places them); `x + (−y)` is
//! emitted as `x − y` and `x − (−y)` as `x + y` (the same IEEE operations); and
//! [`Kernel::raw_eval`] hands out the `eval` function itself, which
//! [`LoadedModel`](crate::LoadedModel) calls directly after comparing the lengths.

use crate::{Common, Dims, ExecError, Kernel, Op, Tape};
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::immediates::Ieee64;
use cranelift_codegen::ir::{
    types, AbiParam, BlockArg, Endianness, InstBuilder, InstructionData, MemFlagsData, Signature,
    StackSlotData, StackSlotKind, Value,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::Module;
use lasalle_model::ir::{Func, Func2, Rational};
use lasalle_runtime::elliptic::ellipj;

mod batch;
pub(crate) mod region;
mod slp;
pub mod taylor;

type EvalFn = crate::RawEval;
type LanesFn =
    unsafe extern "C" fn(usize, *const f64, *const f64, *const f64, *const f64, *mut f64);

pub(crate) extern "C" fn call_cbrt(x: f64) -> f64 {
    x.cbrt()
}
pub(crate) extern "C" fn call_exp(x: f64) -> f64 {
    x.exp()
}
pub(crate) extern "C" fn call_ln(x: f64) -> f64 {
    x.ln()
}
pub(crate) extern "C" fn call_sin(x: f64) -> f64 {
    x.sin()
}
pub(crate) extern "C" fn call_cos(x: f64) -> f64 {
    x.cos()
}
extern "C" fn call_ellipk(m: f64) -> f64 {
    Func::EllipK.apply(m)
}
/// sn, cn or dn (`which` = 0, 1, 2) of (u | m), through the compiled function's cache
/// `[u, m, sn, cn, dn]` of its last `ellipj` call: sn, cn, dn of one (u | m) cost one call
/// (keyed by the bits of u and m, so the values are those of separate calls).
///
/// # Safety
/// `cache` points to 5 writable, initialised f64 that nothing else accesses during the call.
unsafe extern "C" fn call_jacobi(u: f64, m: f64, which: i32, cache: *mut [f64; 5]) -> f64 {
    // SAFETY: the caller's stack slot, see above
    let c = unsafe { &mut *cache };
    if c[0].to_bits() != u.to_bits() || c[1].to_bits() != m.to_bits() {
        let j = ellipj(u, m);
        *c = [u, m, j.sn, j.cn, j.dn];
    }
    c[2 + (which as usize).min(2)]
}
extern "C" fn call_ellipf(phi: f64, m: f64) -> f64 {
    Func2::EllipF.apply(phi, m)
}
extern "C" fn call_powf(x: f64, num: i32, den: i32) -> f64 {
    crate::interp::powf(x, Rational { num, den })
}

pub(crate) fn jit_err(e: impl std::fmt::Display) -> ExecError {
    ExecError::Jit(e.to_string())
}

/// Tapes with a body at least this long are compiled for compile time: Cranelift's
/// backtracking register allocator grows faster than linearly on one long straight-line
/// function (at 66 gravitational pairs, 12 bodies, it was two thirds of the model's load), so
/// these use its single-pass allocator, and their `lanes` are compiled without optimisation.
/// Register allocation and the optimisation level change which registers and spills the code
/// uses, never an arithmetic operation, so the results are the same bit for bit.
pub const LARGE_TAPE: usize = 2_000;

/// A JIT module for the host, optimising for speed (the IR verifier in debug builds only: the
/// IR is built by this crate from validated tapes); `fast_regalloc` chooses Cranelift's
/// single-pass register allocator (see [`LARGE_TAPE`]).
pub(crate) fn jit_module(opt_level: &str, fast_regalloc: bool) -> Result<JITModule, ExecError> {
    let mut flags = settings::builder();
    let set = |f: &mut settings::Builder, k, v| f.set(k, v).map_err(jit_err);
    set(&mut flags, "use_colocated_libcalls", "false")?;
    set(&mut flags, "is_pic", "false")?;
    set(&mut flags, "opt_level", opt_level)?;
    if fast_regalloc {
        set(&mut flags, "regalloc_algorithm", "single_pass")?;
    }
    let verify = if cfg!(debug_assertions) {
        "true"
    } else {
        "false"
    };
    set(&mut flags, "enable_verifier", verify)?;
    let isa = cranelift_native::builder()
        .map_err(jit_err)?
        .finish(settings::Flags::new(flags))
        .map_err(jit_err)?;
    let module = JITModule::new(JITBuilder::with_isa(
        isa,
        cranelift_module::default_libcall_names(),
    ));
    Ok(module)
}

/// The machine code of a finalised module, freed when this value is dropped: the owner of
/// function pointers into it (a kernel) holds it next to them, so the code outlives them.
pub(crate) struct Code(Option<JITModule>);

impl Code {
    /// Takes ownership of a finalised module.
    pub(crate) fn new(module: JITModule) -> Code {
        Code(Some(module))
    }

    /// The code of one function compiled in `module`, a module of its own: `define` declares,
    /// defines and finalises it and returns its id. Returns the code and the function's
    /// address (to be transmuted to the signature `define` gave it); on an error the
    /// module's memory is freed.
    pub(crate) fn compile(
        mut module: JITModule,
        define: impl FnOnce(&mut JITModule) -> Result<cranelift_module::FuncId, ExecError>,
    ) -> Result<(Code, *const u8), ExecError> {
        match define(&mut module) {
            Ok(id) => {
                let f = module.get_finalized_function(id);
                Ok((Code::new(module), f))
            }
            Err(e) => {
                // SAFETY: nothing compiled in this module has been handed out.
                unsafe { module.free_memory() };
                Err(e)
            }
        }
    }
}

impl Drop for Code {
    fn drop(&mut self) {
        if let Some(module) = self.0.take() {
            // SAFETY: the function pointers into this module live in its owner only, which
            // is being dropped and never calls them again.
            unsafe { module.free_memory() };
        }
    }
}

/// A tape compiled to native code.
pub struct JitKernel {
    common: Common,
    /// Owns the code `eval` and `lanes` point into (a module each); freed on drop.
    _code: [Code; 2],
    eval: EvalFn,
    lanes: LanesFn,
    /// The batch of steps, for a step tape compiled with [`JitKernel::with_batch`].
    batch: Option<(Code, lasalle_runtime::RawBatch)>,
    /// Instructions of the body `eval` computes two at a time (see [`slp`]).
    paired: usize,
    /// The values [`Kernel::hoist`] appends to the tape's hoisted ones: the vector slots of
    /// `eval`.
    slots: Vec<Invariant>,
}

/// What compiling `eval` found out (nothing for `lanes`).
#[derive(Default)]
struct EvalInfo {
    /// Instructions computed two at a time.
    paired: usize,
    /// The vector slots, two values each.
    slots: Vec<Invariant>,
}

// SAFETY: the module is only touched again in `drop` (which has `&mut self`); the compiled
// functions are pure: they read their arguments, write `out` and keep no state, so calling
// them from several threads at once is sound.
unsafe impl Send for JitKernel {}
// SAFETY: as above; `&self` methods only call the pure compiled functions.
unsafe impl Sync for JitKernel {}

impl std::fmt::Debug for JitKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitKernel")
            .field("dims", &self.common.dims())
            .finish_non_exhaustive()
    }
}

/// Where the pointer arguments are in the entry block's parameters.
#[derive(Clone, Copy)]
struct Args {
    hoisted: Value,
    state: Value,
    target: Value,
    gains: Value,
    out: Value,
}

impl JitKernel {
    /// Compiles a tape (checked with [`Tape::validate`]).
    pub fn new(tape: &Tape) -> Result<JitKernel, ExecError> {
        tape.validate()?;
        let (eval_code, eval, compiled) = Self::compile(tape, Mode::Eval)?;
        let (lanes_code, lanes, _) = Self::compile(tape, Mode::Lanes)?;
        // SAFETY: the two functions were just defined with exactly these signatures (pointer
        // arguments and a usize, in the ISA's default calling convention, which is the C
        // convention of the host), and the modules that own their code live in `self`.
        let (eval, lanes) = unsafe {
            (
                std::mem::transmute::<*const u8, EvalFn>(eval),
                std::mem::transmute::<*const u8, LanesFn>(lanes),
            )
        };
        Ok(JitKernel {
            common: Common::new(tape).with_extra_hoisted(compiled.slots.len()),
            _code: [eval_code, lanes_code],
            eval,
            lanes,
            batch: None,
            paired: compiled.paired,
            slots: compiled.slots,
        })
    }

    /// How many instructions of the tape's body the single-state function computes in pairs,
    /// as two-lane vector instructions (twice the number of packs of the pairing pass).
    pub fn paired_instructions(&self) -> usize {
        self.paired
    }

    /// Compiles `eval`, `lanes` or a batch of steps in a module of its own: `eval` at
    /// `opt_level = none`, so Cranelift keeps the order of the pairing's schedule (its e-graph
    /// would elaborate the body depth first from the stores, and the body is already
    /// simplified and shared by the tape), and so is a batch that carries its state in
    /// registers (`batch.rs`, which moves the invariants out of the loop itself); `lanes` and
    /// the other batches at `speed`, where the e-graph also moves what does not change from
    /// one iteration to the next out of the loop.
    fn compile(tape: &Tape, mode: Mode) -> Result<(Code, *const u8, EvalInfo), ExecError> {
        let large = tape.body.len() >= LARGE_TAPE;
        let speed = match mode {
            Mode::Eval => false,
            Mode::Lanes => true,
            Mode::Batch { n, .. } => !batch::carries(n),
        } && !large;
        let module = jit_module(if speed { "speed" } else { "none" }, large)?;
        let mut info = EvalInfo::default();
        let (code, f) = Code::compile(module, |m| {
            let (id, compiled) = Self::define(m, tape, mode)?;
            info = compiled;
            Ok(id)
        })?;
        Ok((code, f, info))
    }

    fn define(
        module: &mut JITModule,
        tape: &Tape,
        mode: Mode,
    ) -> Result<(cranelift_module::FuncId, EvalInfo), ExecError> {
        let ptr = module.target_config().pointer_type();
        let mut ctx = module.make_context();
        let mut fctx = FunctionBuilderContext::new();
        let mut sig = module.make_signature();
        if matches!(mode, Mode::Lanes) {
            sig.params.push(AbiParam::new(ptr));
        }
        sig.params.extend([AbiParam::new(ptr); 5]);
        if let Mode::Batch { .. } = mode {
            sig.params.push(AbiParam::new(types::I64));
            sig.returns.push(AbiParam::new(types::I64));
        }
        let id = module.declare_anonymous_function(&sig).map_err(jit_err)?;
        ctx.func.signature = sig;
        let mut compiled = EvalInfo::default();
        {
            let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
            let entry = b.create_block();
            b.append_block_params_for_function_params(entry);
            b.switch_to_block(entry);
            let p = b.block_params(entry).to_vec();
            let (k, p) = match mode {
                Mode::Lanes => (Some(p[0]), &p[1..]),
                Mode::Eval => (None, &p[..]),
                Mode::Batch { .. } => (Some(p[5]), &p[..5]),
            };
            let args = Args {
                hoisted: p[0],
                state: p[1],
                target: p[2],
                gains: p[3],
                out: p[4],
            };
            let mut e = Emit {
                b,
                ptr,
                values: vec![None; tape.body.len()],
                vectors: vec![None; tape.body.len()],
                other: Vec::new(),
                vector: false,
                ops: Vec::new(),
                math: Math::new(module),
                jacobi_cache: None,
                slots: Slots {
                    base: tape.hoisted.len(),
                    ..Slots::default()
                },
                eval: None,
                state_written: false,
                gathered: None,
                squares: std::collections::HashMap::new(),
                invariants: None,
                carried: None,
            };
            let jacobi = |op: &Op| matches!(op, Op::Func2(Func2::Sn | Func2::Cn | Func2::Dn, ..));
            if tape.body.iter().any(jacobi) {
                let slot = e.b.create_sized_stack_slot(StackSlotData::new(
                    StackSlotKind::ExplicitSlot,
                    40,
                    3,
                ));
                let nan = e.b.ins().f64const(Ieee64::with_bits(f64::NAN.to_bits()));
                for i in 0..5 {
                    e.b.ins().stack_store(ptr, nan, slot, 8 * i);
                }
                e.jacobi_cache = Some(e.b.ins().stack_addr(ptr, slot, 0));
            }
            match (mode, k) {
                (Mode::Lanes, Some(k)) => e.lanes(tape, &args, k)?,
                (Mode::Batch { n, strict }, Some(k)) => {
                    compiled.paired = e.batch(tape, &args, k, n, strict)?;
                    compiled.slots = std::mem::take(&mut e.slots.values);
                }
                _ => {
                    compiled.paired = e.scalar(tape, &args)?;
                    compiled.slots = std::mem::take(&mut e.slots.values);
                }
            }
            e.b.seal_all_blocks();
            e.b.finalize(module.target_config());
        }
        module.define_function(id, &mut ctx).map_err(jit_err)?;
        module.finalize_definitions().map_err(jit_err)?;
        Ok((id, compiled))
    }
}

/// Which function of a tape is compiled.
#[derive(Clone, Copy)]
enum Mode<'a> {
    /// `eval`, one state.
    Eval,
    /// `lanes`, k states in structure of arrays.
    Lanes,
    /// A batch of steps of a step tape whose first `n` outputs are the new state and the
    /// others the guards' margins, `strict` per margin ([`batch`]).
    Batch { n: usize, strict: &'a [bool] },
}

/// An output value `eval` stored: one output, or two adjacent ones with one 128-bit store.
#[derive(Clone, Copy)]
enum Stored {
    Single(Value),
    Pair(Value),
}

/// Signatures of the math wrappers.
struct Math {
    unary: Signature,
    binary: Signature,
    powf: Signature,
    jacobi: Signature,
}

impl Math {
    fn new(module: &JITModule) -> Math {
        let mut unary = module.make_signature();
        unary.params.push(AbiParam::new(types::F64));
        unary.returns.push(AbiParam::new(types::F64));
        let mut binary = unary.clone();
        binary.params.push(AbiParam::new(types::F64));
        let mut powf = module.make_signature();
        powf.params.extend([
            AbiParam::new(types::F64),
            AbiParam::new(types::I32),
            AbiParam::new(types::I32),
        ]);
        powf.returns.push(AbiParam::new(types::F64));
        let mut jacobi = binary.clone();
        let ptr = module.target_config().pointer_type();
        jacobi
            .params
            .extend([AbiParam::new(types::I32), AbiParam::new(ptr)]);
        Math {
            unary,
            binary,
            powf,
            jacobi,
        }
    }
}

/// The function being built.
struct Emit<'a> {
    b: FunctionBuilder<'a>,
    ptr: types::Type,
    /// Scalar value of each register (shared or of the current lane).
    values: Vec<Option<Value>>,
    /// Two-lane vector value of each register, in the vector loops (of the first pair of lanes
    /// in the four-lane loop); in `eval`, that of each pack, at its lane-0 register.
    vectors: Vec<Option<Value>>,
    /// The vector values of the second pair of lanes, in the four-lane loop (swapped with
    /// `vectors` while its instructions are emitted).
    other: Vec<Option<Value>>,
    /// Emitting a vector loop.
    vector: bool,
    /// The instructions with their negated operands folded ([`slp::fold`]): `x + (−y)` is
    /// emitted as `x − y` and `x − (−y)` as `x + y`, the same IEEE operations (the negation,
    /// if unused otherwise, is then dead and not emitted).
    ops: Vec<Op>,
    math: Math,
    /// The address of the `[u, m, sn, cn, dn]` cache of `call_jacobi` (a stack slot filled
    /// with NaN on entry), if the tape has sn, cn or dn.
    jacobi_cache: Option<Value>,
    /// The vector slots `eval` loads, after the tape's hoisted values.
    slots: Slots,
    /// In `eval` (compiled at `opt_level = none`), its arguments: each unpaired input element
    /// is loaded (and each unpaired constant materialised) at its first use, not where the
    /// schedule has it, and a negation is an `xor` with −0 from the constant pool.
    eval: Option<Args>,
    /// In a batch of steps that reads its state from the buffers, the state is a buffer the
    /// function itself writes: its loads are not marked pure.
    state_written: bool,
    /// In a batch of steps, the operand vectors [`Emit::gather`] put together in the current
    /// step, by their registers: at `opt_level = none` nothing shares them otherwise.
    gathered: Option<std::collections::HashMap<(crate::Reg, crate::Reg), Value>>,
    /// In `eval` and a batch of steps, the squares x^(2^k), k ≥ 1, of the values powers
    /// were taken of, by value ([`Emit::square`]).
    squares: std::collections::HashMap<Value, Vec<Value>>,
    /// In a batch of steps, what is the same for every step, computed before the loop.
    invariants: Option<batch::Invariants>,
    /// In a batch of steps, each state component as the previous step computed it: a
    /// vector and the lane holding it, or a scalar (see `batch.rs`).
    carried: Option<Vec<(Value, Option<u8>)>>,
}

/// A value that is the same for every call: a hoisted value or a constant.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Invariant {
    Hoisted(usize),
    Const(f64),
}

/// The operand vectors of `eval` whose two values are the same for every call
/// ([`slp::invariant_pair`]): [`Kernel::hoist`] appends them to the tape's hoisted values,
/// two by two, so that each is one 128-bit load instead of two loads and a shuffle.
#[derive(Debug, Default)]
struct Slots {
    /// The number of the tape's hoisted values: the index of the first slot's lane 0.
    base: usize,
    /// The values of the slots, two per slot.
    values: Vec<Invariant>,
    /// The index in the hoisted values of each slot's lane 0, by its two registers.
    index: std::collections::HashMap<(crate::Reg, crate::Reg), usize>,
}

/// Two lanes per vector: SSE2 on x86-64, NEON on aarch64.
const F64X2: types::Type = types::F64X2;

/// A byte offset for a load or store of element `i`.
fn offset(i: usize) -> Result<i32, ExecError> {
    i.checked_mul(8)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| ExecError::Jit(format!("index {i} too large for an immediate offset")))
}

/// The argument and the index an input element is loaded from.
fn input(args: &Args, op: Op) -> Option<(Value, u32)> {
    match op {
        Op::State(i) => Some((args.state, i)),
        Op::Target(i) => Some((args.target, i)),
        Op::Gain(i) => Some((args.gains, i)),
        Op::Hoisted(i) => Some((args.hoisted, i)),
        _ => None,
    }
}

/// Stores of f64 (8-byte aligned, in bounds).
fn scalar_flags() -> MemFlagsData {
    MemFlagsData::trusted()
}

/// Stores of two lanes: in bounds but only 8-byte aligned.
fn vector_flags() -> MemFlagsData {
    MemFlagsData::new().with_notrap()
}

/// Loads of the inputs. They are in bounds (`notrap`), and the inputs are shared slices that
/// nothing writes during a call (`out` is a `&mut` slice, so it cannot overlap them):
/// `readonly` + `can_move` make the loads pure for Cranelift's e-graph, which then places each
/// load next to its first use (or folds it into the instruction as a memory operand) instead
/// of issuing every load up front and spilling the values.
fn load_flags(f: MemFlagsData) -> MemFlagsData {
    f.with_readonly().with_can_move()
}

impl Emit<'_> {
    /// The value of register `r` in the current mode.
    fn value(&self, r: crate::Reg) -> Value {
        let v = if self.vector {
            self.vectors[r.index()]
        } else {
            self.values[r.index()]
        };
        v.expect("validated: operands are defined before use")
    }

    fn load(&mut self, base: Value, i: usize) -> Result<Value, ExecError> {
        let off = offset(i)?;
        Ok(self.load_at(base, off))
    }

    /// The input element at byte offset `off` of `base`.
    fn load_at(&mut self, base: Value, off: i32) -> Value {
        let flags = self.input_flags(base, scalar_flags());
        self.b.ins().load(types::F64, flags, base, off)
    }

    /// The flags of a load of an input from `base`: pure ([`load_flags`]) unless it is the
    /// state of a batch of steps, which the function writes.
    fn input_flags(&self, base: Value, f: MemFlagsData) -> MemFlagsData {
        if self.state_written && self.eval.is_some_and(|a| a.state == base) {
            f
        } else {
            load_flags(f)
        }
    }

    /// A constant in the current mode.
    fn constant(&mut self, c: f64) -> Value {
        let x = self.b.ins().f64const(Ieee64::with_bits(c.to_bits()));
        if self.vector {
            self.b.ins().splat(F64X2, x)
        } else {
            x
        }
    }

    /// Whether `v` is a scalar constant other than NaN.
    fn is_constant(&self, v: Value) -> bool {
        let dfg = &self.b.func.dfg;
        dfg.value_def(v).inst().is_some_and(|i| {
            matches!(dfg.insts[i], InstructionData::UnaryIeee64 { imm, .. }
                if !f64::from_bits(imm.bits()).is_nan())
        })
    }

    /// The vector `(c[0], c[1])`, from the constant pool.
    fn vector_constant(&mut self, c: [f64; 2]) -> Value {
        let bytes: Vec<u8> = c.iter().flat_map(|v| v.to_le_bytes()).collect();
        let data = self.b.func.dfg.constants.insert(bytes.into());
        self.b.ins().vconst(F64X2, data)
    }

    fn call(&mut self, f: usize, sig: Signature, args: &[Value]) -> Value {
        let sig = self.b.import_signature(sig);
        let callee = self.b.ins().iconst(self.ptr, f as i64);
        let call = self.b.ins().call_indirect(sig, callee, args);
        self.b.inst_results(call)[0]
    }

    /// Calls a scalar wrapper on `x`, lane by lane in the vector loop; `extra` are further
    /// (scalar) arguments.
    fn call_lanes(&mut self, f: usize, sig: &Signature, x: Value, extra: &[Value]) -> Value {
        if !self.vector {
            let args: Vec<Value> = [x].into_iter().chain(extra.iter().copied()).collect();
            return self.call(f, sig.clone(), &args);
        }
        let mut lanes = [x; 2];
        for (lane, r) in lanes.iter_mut().enumerate() {
            let xl = self.b.ins().extractlane(x, lane as u8);
            let args: Vec<Value> = [xl].into_iter().chain(extra.iter().copied()).collect();
            *r = self.call(f, sig.clone(), &args);
        }
        let v = self.b.ins().splat(F64X2, lanes[0]);
        self.b.ins().insertlane(v, lanes[1], 1)
    }

    fn unary(&mut self, f: extern "C" fn(f64) -> f64, x: Value) -> Value {
        let sig = self.math.unary.clone();
        self.call_lanes(f as *const () as usize, &sig, x, &[])
    }

    /// Calls a scalar wrapper of two arguments, lane by lane in the vector loop.
    fn binary(&mut self, f: extern "C" fn(f64, f64) -> f64, x: Value, y: Value) -> Value {
        let (f, sig) = (f as *const () as usize, self.math.binary.clone());
        if !self.vector {
            return self.call(f, sig, &[x, y]);
        }
        let mut lanes = [x; 2];
        for (lane, r) in lanes.iter_mut().enumerate() {
            let xl = self.b.ins().extractlane(x, lane as u8);
            let yl = self.b.ins().extractlane(y, lane as u8);
            *r = self.call(f, sig.clone(), &[xl, yl]);
        }
        let v = self.b.ins().splat(F64X2, lanes[0]);
        self.b.ins().insertlane(v, lanes[1], 1)
    }

    /// xⁿ by binary exponentiation (`lasalle_model::tape::powi`).
    fn powi(&mut self, x: Value, n: i32) -> Value {
        let mut bits = n.unsigned_abs();
        let mut square = x;
        let mut k = 0;
        let mut result: Option<Value> = None;
        while bits != 0 {
            if bits & 1 == 1 {
                result = Some(match result {
                    None => square,
                    Some(r) => self.b.ins().fmul(r, square),
                });
            }
            bits >>= 1;
            if bits != 0 {
                square = self.square(x, k, square);
                k += 1;
            }
        }
        let r = match result {
            Some(r) => r,
            None => self.constant(1.0),
        };
        if n < 0 {
            let one = self.constant(1.0);
            self.b.ins().fdiv(one, r)
        } else {
            r
        }
    }

    /// x^(2^(k+1)) from `square` = x^(2^k): in `eval` and a batch (one block each, compiled
    /// at `opt_level = none`) computed once for all powers of x (`x²` and `x³` share the
    /// multiplication x · x), the same multiplication whichever power asks first.
    fn square(&mut self, x: Value, k: usize, square: Value) -> Value {
        if self.eval.is_none() {
            return self.b.ins().fmul(square, square);
        }
        if let Some(&v) = self.squares.get(&x).and_then(|s| s.get(k)) {
            return v;
        }
        let v = self.b.ins().fmul(square, square);
        self.squares.entry(x).or_default().push(v);
        v
    }

    /// `+ − · /`, negation, `sqrt` or `powi` (`op`, folded) of the values `x` and `y` (`None`
    /// for the unary ones), in the current mode.
    fn arith(&mut self, op: Op, x: Value, y: Option<Value>) -> Value {
        let y = || y.expect("a binary operation has two operands");
        match op {
            // c + y and c · y as y + c and y · c, the same IEEE operations (c is not NaN, so
            // no NaN payload depends on the order): x86-64 reads a second operand that is a
            // constant from the constant pool, a first one it builds in a register with two
            // instructions (Cranelift does not swap them itself)
            Op::Add(..) if self.eval.is_some() && !self.vector && self.is_constant(x) => {
                self.b.ins().fadd(y(), x)
            }
            Op::Mul(..) if self.eval.is_some() && !self.vector && self.is_constant(x) => {
                self.b.ins().fmul(y(), x)
            }
            Op::Add(..) => self.b.ins().fadd(x, y()),
            Op::Sub(..) => self.b.ins().fsub(x, y()),
            Op::Mul(..) => self.b.ins().fmul(x, y()),
            Op::Div(..) => self.b.ins().fdiv(x, y()),
            Op::Neg(_) if self.eval.is_some() => {
                // the sign bit flipped, as `fneg`, by an `xor` with −0 loaded from the
                // constant pool (Cranelift's `fneg` of `F64X2` builds the mask in a register
                // with two instructions, of `F64` with two through a general register; in the
                // lane loop, at `speed`, the e-graph would share one mask register instead)
                let sign = if self.vector {
                    self.vector_constant([-0.0; 2])
                } else {
                    self.b
                        .ins()
                        .f64const(Ieee64::with_bits((-0.0f64).to_bits()))
                };
                self.b.ins().bxor(x, sign)
            }
            Op::Neg(_) => self.b.ins().fneg(x),
            Op::Sqrt(_) => self.b.ins().sqrt(x),
            Op::Powi(_, n) => self.powi(x, n),
            _ => unreachable!("not an arithmetic operation: {op:?}"),
        }
    }

    /// The value of instruction `i` in the current mode; `state(i)` loads state component i.
    fn op(
        &mut self,
        i: usize,
        args: &Args,
        state: &mut dyn FnMut(&mut Self, usize) -> Result<Value, ExecError>,
    ) -> Result<Value, ExecError> {
        let v = |e: &Self, r| e.value(r);
        let op = self.ops[i];
        Ok(match op {
            Op::State(i) => state(self, i as usize)?,
            Op::Target(i) => self.load(args.target, i as usize)?,
            Op::Gain(i) => self.load(args.gains, i as usize)?,
            Op::Hoisted(i) => self.load(args.hoisted, i as usize)?,
            Op::Param(_) => {
                return Err(ExecError::Jit("a parameter in the body".into()));
            }
            Op::Const(c) => self.constant(c),
            Op::Add(a, c) | Op::Sub(a, c) | Op::Mul(a, c) | Op::Div(a, c) => {
                let (x, y) = (v(self, a), v(self, c));
                self.arith(op, x, Some(y))
            }
            Op::Neg(a) | Op::Sqrt(a) | Op::Powi(a, _) => {
                let x = v(self, a);
                self.arith(op, x, None)
            }
            Op::Cbrt(a) => self.unary(call_cbrt, v(self, a)),
            Op::Exp(a) => self.unary(call_exp, v(self, a)),
            Op::Ln(a) => self.unary(call_ln, v(self, a)),
            Op::Sin(a) => self.unary(call_sin, v(self, a)),
            Op::Cos(a) => self.unary(call_cos, v(self, a)),
            Op::EllipK(a) => self.unary(call_ellipk, v(self, a)),
            Op::Func2(Func2::EllipF, a, m) => {
                let (x, m) = (v(self, a), v(self, m));
                self.binary(call_ellipf, x, m)
            }
            Op::Func2(f, a, m) => {
                let (x, m) = (v(self, a), v(self, m));
                let which = self.b.ins().iconst(types::I32, f as i64);
                let cache = self.jacobi_cache.ok_or_else(|| {
                    ExecError::Jit("sn, cn or dn without the ellipj cache".into())
                })?;
                let (f, sig) = (call_jacobi as *const () as usize, self.math.jacobi.clone());
                if !self.vector {
                    self.call(f, sig, &[x, m, which, cache])
                } else {
                    let mut lanes = [x; 2];
                    for (lane, r) in lanes.iter_mut().enumerate() {
                        let xl = self.b.ins().extractlane(x, lane as u8);
                        let ml = self.b.ins().extractlane(m, lane as u8);
                        *r = self.call(f, sig.clone(), &[xl, ml, which, cache]);
                    }
                    let v = self.b.ins().splat(F64X2, lanes[0]);
                    self.b.ins().insertlane(v, lanes[1], 1)
                }
            }
            Op::Powf(a, p) => {
                let x = v(self, a);
                let num = self.b.ins().iconst(types::I32, i64::from(p.num));
                let den = self.b.ins().iconst(types::I32, i64::from(p.den));
                let sig = self.math.powf.clone();
                self.call_lanes(call_powf as *const () as usize, &sig, x, &[num, den])
            }
        })
    }

    /// Stores the outputs of the lane(s) at `out` to `out + j·kb` (`kb = 8k`).
    fn store_outputs(&mut self, tape: &Tape, out: Value, kb: Value) {
        let flags = if self.vector {
            vector_flags()
        } else {
            scalar_flags()
        };
        for (j, &r) in tape.outputs.iter().enumerate() {
            let x = self.value(r);
            let at = self.b.ins().imul_imm_s(kb, j as i64);
            let addr = self.b.ins().iadd(out, at);
            self.b.ins().store(flags, x, addr, 0);
        }
    }

    /// The scalar value of register `r` in `eval`: lane of its pack, if paired; an unpaired
    /// input element or constant is emitted here, at its first use.
    fn scalar_value(&mut self, pairing: &slp::Pairing, r: crate::Reg) -> Value {
        if let Some(v) = self.values[r.index()] {
            return v;
        }
        if let Some(v) = self.hoisted(batch::Hoisted::Scalar(r)) {
            return v;
        }
        // a batch's loop has no packs of invariants: their leaves are loaded singly
        let lane = pairing.lane[r.index()].filter(|_| !self.is_invariant(r));
        if let (Some(args), None) = (self.eval, lane) {
            let v = match self.ops[r.index()] {
                Op::Const(c) => Some(self.constant(c)),
                Op::State(i) if self.carried.is_some() => self.carried_scalar(i as usize),
                // `scalar` checked the offsets of all input elements
                op => input(&args, op).map(|(base, i)| self.load_at(base, 8 * i as i32)),
            };
            if let Some(v) = v {
                // in a batch's loop, an invariant is loaded at each use: it holds no register
                if !self.is_invariant(r) {
                    self.values[r.index()] = Some(v);
                }
                return v;
            }
        }
        let (p, lane) = pairing.lane[r.index()].expect("scheduled: operands come first");
        let packed = self.vectors[pairing.packs[p][0]].expect("scheduled: packs come first");
        let v = self.b.ins().extractlane(packed, lane);
        self.values[r.index()] = Some(v);
        v
    }

    /// The vector of pack `p` in `eval` (in a batch's loop, of an invariant pack: loaded).
    fn pack_vector(&mut self, pairing: &slp::Pairing, p: usize) -> Value {
        let [a, b] = pairing.packs[p].map(|i| crate::Reg(i as u32));
        if let Some(v) = self.hoisted(batch::Hoisted::Vector(a, b)) {
            return v;
        }
        self.vectors[pairing.packs[p][0]].expect("scheduled: packs come first")
    }

    /// The vector `(x, y)` in `eval`: a pack, a vector slot of two values the same for every
    /// call, or else [`Emit::gather`]ed.
    fn operand_vector(
        &mut self,
        pairing: &slp::Pairing,
        args: &Args,
        x: crate::Reg,
        y: crate::Reg,
    ) -> Result<Value, ExecError> {
        if let Some(p) = pairing.pack_of(x, y) {
            return Ok(self.pack_vector(pairing, p));
        }
        let (ox, oy) = (self.ops[x.index()], self.ops[y.index()]);
        if let Some(v) = self.hoisted(batch::Hoisted::Vector(x, y)) {
            return Ok(v);
        }
        if slp::invariant_pair(ox, oy) {
            let i = self.slot(x, y);
            let flags = load_flags(vector_flags());
            return Ok(self.b.ins().load(F64X2, flags, args.hoisted, offset(i)?));
        }
        Ok(self.gather(pairing, x, y))
    }

    /// The index in the hoisted values of the vector slot `(x, y)` of two invariant
    /// registers, added if new.
    fn slot(&mut self, x: crate::Reg, y: crate::Reg) -> usize {
        let invariant = |op| match op {
            Op::Hoisted(i) => Invariant::Hoisted(i as usize),
            Op::Const(c) => Invariant::Const(c),
            _ => unreachable!("slots hold hoisted values and constants"),
        };
        let (ix, iy) = (
            invariant(self.ops[x.index()]),
            invariant(self.ops[y.index()]),
        );
        let s = &mut self.slots;
        *s.index.entry((x, y)).or_insert_with(|| {
            s.values.extend([ix, iy]);
            s.base + s.values.len() - 2
        })
    }

    /// The vector `(x, y)` of values that form no pack: a splat, two constants, or put
    /// together from the packs and scalars holding x and y with one instruction (two for two
    /// scalars).
    fn gather(&mut self, pairing: &slp::Pairing, x: crate::Reg, y: crate::Reg) -> Value {
        if let Some(&v) = self.gathered.as_ref().and_then(|g| g.get(&(x, y))) {
            return v;
        }
        let v = self.put_together(pairing, x, y);
        if let Some(g) = &mut self.gathered {
            g.insert((x, y), v);
        }
        v
    }

    /// [`Emit::gather`]'s instructions.
    fn put_together(&mut self, pairing: &slp::Pairing, x: crate::Reg, y: crate::Reg) -> Value {
        if let (Op::Const(c), Op::Const(d)) = (self.ops[x.index()], self.ops[y.index()]) {
            return self.vector_constant([c, d]);
        }
        if x == y {
            let s = self.scalar_value(pairing, x);
            return self.b.ins().splat(F64X2, s);
        }
        let place = |e: &mut Self, r: crate::Reg| {
            pairing.lane[r.index()].map(|(p, lane)| (e.pack_vector(pairing, p), lane))
        };
        match (place(self, x), place(self, y)) {
            (Some((vx, 0)), None) => {
                let sy = self.scalar_value(pairing, y);
                self.b.ins().insertlane(vx, sy, 1)
            }
            (None, Some((vy, 1))) => {
                let sx = self.scalar_value(pairing, x);
                self.b.ins().insertlane(vy, sx, 0)
            }
            (None, None) => {
                let (sx, sy) = (self.scalar_value(pairing, x), self.scalar_value(pairing, y));
                let v = self.b.ins().splat(F64X2, sx);
                self.b.ins().insertlane(v, sy, 1)
            }
            (px, py) => {
                let splat = |e: &mut Self, r| {
                    let s = e.scalar_value(pairing, r);
                    (e.b.ins().splat(F64X2, s), 0)
                };
                let (vx, i) = px.unwrap_or_else(|| splat(self, x));
                let (vy, j) = py.unwrap_or_else(|| splat(self, y));
                self.shuffle(vx, i, vy, j)
            }
        }
    }

    /// `(vx[i], vy[j])` (one shuffle).
    fn shuffle(&mut self, vx: Value, i: u8, vy: Value, j: u8) -> Value {
        let mask: Vec<u8> = (0..8)
            .map(|k| 8 * i + k)
            .chain((0..8).map(|k| 16 + 8 * j + k))
            .collect();
        let mask = self.b.func.dfg.immediates.push(mask.into());
        let flags = MemFlagsData::new().with_endianness(Endianness::Little);
        let bx = self.b.ins().bitcast(types::I8X16, flags, vx);
        let by = self.b.ins().bitcast(types::I8X16, flags, vy);
        let s = self.b.ins().shuffle(bx, by, mask);
        self.b.ins().bitcast(F64X2, flags, s)
    }

    /// The two-lane instruction of pack `p` in `eval`: one 128-bit load of two adjacent
    /// input elements, or one lane-wise operation.
    fn pack(&mut self, pairing: &slp::Pairing, p: usize, args: &Args) -> Result<Value, ExecError> {
        let [a, b] = pairing.packs[p];
        let (oa, ob) = (self.ops[a], self.ops[b]);
        if let Op::State(i) = oa {
            if let Some(v) = self.carried_pair(i as usize) {
                return Ok(v);
            }
        }
        if let Some((base, i)) = input(args, oa) {
            let flags = self.input_flags(base, vector_flags());
            return Ok(self.b.ins().load(F64X2, flags, base, offset(i as usize)?));
        }
        let (mut xs, mut ys) = (oa.operands(), ob.operands());
        let (xa, xb) = (xs.next(), ys.next());
        let x = match (xa, xb) {
            (Some(xa), Some(xb)) => self.operand_vector(pairing, args, xa, xb)?,
            _ => unreachable!("a pack of operations with operands"),
        };
        let y = match (xs.next(), ys.next()) {
            (Some(ya), Some(yb)) => Some(self.operand_vector(pairing, args, ya, yb)?),
            _ => None,
        };
        self.vector = true;
        let v = self.arith(oa, x, y);
        self.vector = false;
        Ok(v)
    }

    /// `eval`: the packs and the remaining scalar instructions of the pairing ([`slp`]) in
    /// its order, then the stores, two adjacent outputs of one pack with one 128-bit store.
    /// Returns the number of instructions computed in pairs.
    fn scalar(&mut self, tape: &Tape, args: &Args) -> Result<usize, ExecError> {
        let (paired, _) = self.scalar_body(tape, args)?;
        self.b.ins().return_(&[]);
        Ok(paired)
    }

    /// `eval`'s instructions and stores, without the return: the number of instructions
    /// computed in pairs and the values stored, in order.
    fn scalar_body(&mut self, tape: &Tape, args: &Args) -> Result<(usize, Vec<Stored>), ExecError> {
        let pairing = self.pairing(tape, args)?;
        self.body(tape, &pairing, args)
    }

    /// The pairing of `tape`'s body, its instructions taken as those emitted, after checking
    /// the offsets of all input elements.
    fn pairing(&mut self, tape: &Tape, args: &Args) -> Result<slp::Pairing, ExecError> {
        let pairing = slp::pair(tape);
        self.ops.clone_from(&pairing.ops);
        for &op in &self.ops {
            if let Some((_, i)) = input(args, op) {
                offset(i as usize)?;
            }
        }
        Ok(pairing)
    }

    /// [`Emit::scalar_body`] for a pairing: the instructions (in a batch's loop, those not
    /// computed before it) and the stores.
    fn body(
        &mut self,
        tape: &Tape,
        pairing: &slp::Pairing,
        args: &Args,
    ) -> Result<(usize, Vec<Stored>), ExecError> {
        self.eval = Some(*args);
        let leaf = |op| matches!(op, Op::Const(_)) || input(args, op).is_some();
        let base = args.state;
        for &node in &pairing.order {
            if self.hoisted_node(pairing, node) {
                continue;
            }
            match node {
                // emitted at their first use, see `scalar_value`
                slp::Node::Single(i) if leaf(self.ops[i]) => {}
                slp::Node::Single(i) => {
                    // the operands an invariant batch loads at this use, for `op` only
                    let mut fresh = Vec::new();
                    for r in pairing.ops[i].operands() {
                        let v = self.scalar_value(pairing, r);
                        if self.values[r.index()].is_none() {
                            self.values[r.index()] = Some(v);
                            fresh.push(r);
                        }
                    }
                    let v = self.op(i, args, &mut |e, k| e.load(base, k))?;
                    for r in fresh {
                        self.values[r.index()] = None;
                    }
                    self.values[i] = Some(v);
                }
                slp::Node::Pack(p) => {
                    let v = self.pack(pairing, p, args)?;
                    self.vectors[pairing.packs[p][0]] = Some(v);
                }
            }
        }
        let mut stored = Vec::with_capacity(tape.outputs.len());
        let mut j = 0;
        while j < tape.outputs.len() {
            let r = tape.outputs[j];
            let off = offset(j)?;
            match tape.outputs.get(j + 1).and_then(|&s| pairing.pack_of(r, s)) {
                Some(p) => {
                    let v = self.pack_vector(pairing, p);
                    self.b.ins().store(vector_flags(), v, args.out, off);
                    stored.push(Stored::Pair(v));
                    j += 2;
                }
                None => {
                    let v = self.scalar_value(pairing, r);
                    self.b.ins().store(scalar_flags(), v, args.out, off);
                    stored.push(Stored::Single(v));
                    j += 1;
                }
            }
        }
        Ok((2 * pairing.packs.len(), stored))
    }

    /// The per-lane instructions for the lane(s) at the byte offsets `offs` (one, or in the
    /// vector loop two: each instruction is emitted for both pairs of lanes in turn, so the
    /// two independent dependency chains overlap), and their stores.
    fn lane_body(
        &mut self,
        tape: &Tape,
        args: &Args,
        per_lane: &[bool],
        offs: &[Value],
        kb: Value,
    ) -> Result<(), ExecError> {
        let (ty, flags) = if self.vector {
            (F64X2, vector_flags())
        } else {
            (types::F64, scalar_flags())
        };
        let states: Vec<Value> = offs
            .iter()
            .map(|&off| self.b.ins().iadd(args.state, off))
            .collect();
        for i in (0..tape.body.len()).filter(|&i| per_lane[i]) {
            for (part, &state) in states.iter().enumerate() {
                self.swap_part(part);
                let v = self.op(i, args, &mut |e, c| {
                    let at = e.b.ins().imul_imm_s(kb, c as i64);
                    let addr = e.b.ins().iadd(state, at);
                    Ok(e.b.ins().load(ty, load_flags(flags), addr, 0))
                });
                let slot = if self.vector {
                    &mut self.vectors[i]
                } else {
                    &mut self.values[i]
                };
                *slot = Some(v?);
                self.swap_part(part);
            }
        }
        for (part, &off) in offs.iter().enumerate() {
            self.swap_part(part);
            let out = self.b.ins().iadd(args.out, off);
            self.store_outputs(tape, out, kb);
            self.swap_part(part);
        }
        Ok(())
    }

    /// Makes the values of the second pair of lanes current (`part` 1), or back (`part` 1
    /// again); `part` 0 is the first pair, always current otherwise.
    fn swap_part(&mut self, part: usize) {
        if part == 1 {
            std::mem::swap(&mut self.vectors, &mut self.other);
        }
    }

    /// Lanes four at a time (two vectors), then two (one vector), then the odd last lane
    /// (scalars).
    fn lanes(&mut self, tape: &Tape, args: &Args, k: Value) -> Result<(), ExecError> {
        // Which registers depend on the state (those are computed per lane).
        let mut per_lane = vec![false; tape.body.len()];
        for (i, op) in tape.body.iter().enumerate() {
            per_lane[i] = matches!(op, Op::State(_)) || op.operands().any(|r| per_lane[r.index()]);
        }
        let negated = slp::negations(tape);
        self.ops = tape
            .body
            .iter()
            .map(|&op| slp::fold(op, &negated))
            .collect();
        // Entry: everything shared by the lanes, also as two-lane vectors.
        for i in (0..tape.body.len()).filter(|&i| !per_lane[i]) {
            let v = self.op(i, args, &mut |_, _| {
                Err(ExecError::Jit("state read outside the lane loop".into()))
            })?;
            self.values[i] = Some(v);
            self.vectors[i] = Some(self.b.ins().splat(F64X2, v));
        }
        self.other = self.vectors.clone();
        let kb = self.b.ins().ishl_imm_u(k, 3);
        let zero = self.b.ins().iconst(self.ptr, 0);
        let [qhead, qbody, vhead, vbody, shead, sbody, exit] =
            [(); 7].map(|()| self.b.create_block());
        self.b.ins().jump(qhead, &[BlockArg::Value(zero)]);
        // qhead(off): four more lanes?
        self.b.switch_to_block(qhead);
        let off = self.b.append_block_param(qhead, self.ptr);
        let next = self.b.ins().iadd_imm_u(off, 32);
        let fits = self.b.ins().icmp(IntCC::UnsignedLessThanOrEqual, next, kb);
        self.b
            .ins()
            .brif(fits, qbody, &[], vhead, &[BlockArg::Value(off)]);
        self.b.switch_to_block(qbody);
        self.vector = true;
        let second = self.b.ins().iadd_imm_u(off, 16);
        self.lane_body(tape, args, &per_lane, &[off, second], kb)?;
        self.b.ins().jump(qhead, &[BlockArg::Value(next)]);
        // vhead(off): two more lanes? (at most once: fewer than four are left)
        self.b.switch_to_block(vhead);
        let off = self.b.append_block_param(vhead, self.ptr);
        let next = self.b.ins().iadd_imm_u(off, 16);
        let fits = self.b.ins().icmp(IntCC::UnsignedLessThanOrEqual, next, kb);
        self.b
            .ins()
            .brif(fits, vbody, &[], shead, &[BlockArg::Value(off)]);
        self.b.switch_to_block(vbody);
        self.lane_body(tape, args, &per_lane, &[off], kb)?;
        self.vector = false;
        self.b.ins().jump(shead, &[BlockArg::Value(next)]);
        // shead(off): one more lane?
        self.b.switch_to_block(shead);
        let off = self.b.append_block_param(shead, self.ptr);
        let more = self.b.ins().icmp(IntCC::UnsignedLessThan, off, kb);
        self.b.ins().brif(more, sbody, &[], exit, &[]);
        self.b.switch_to_block(sbody);
        self.lane_body(tape, args, &per_lane, &[off], kb)?;
        let next = self.b.ins().iadd_imm_u(off, 8);
        self.b.ins().jump(shead, &[BlockArg::Value(next)]);
        self.b.switch_to_block(exit);
        self.b.ins().return_(&[]);
        Ok(())
    }
}

impl Kernel for JitKernel {
    fn dims(&self) -> Dims {
        self.common.dims()
    }

    fn n_outputs(&self) -> usize {
        self.common.n_outputs()
    }

    fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError> {
        let mut hoisted = self.common.hoist(params)?;
        hoisted.reserve(self.slots.len());
        for &v in &self.slots {
            hoisted.push(match v {
                Invariant::Hoisted(i) => hoisted[i],
                Invariant::Const(c) => c,
            });
        }
        Ok(hoisted)
    }

    fn eval(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        self.common.check(1, hoisted, state, target, gains, out)?;
        // SAFETY: `check` proved every slice has the length the code indexes (it reads
        // `hoisted[..H]`, `state[..N]`, `target[..M]`, `gains[..G]` and writes `out[..O]`
        // only); the code is alive while `self` is.
        unsafe {
            (self.eval)(
                hoisted.as_ptr(),
                state.as_ptr(),
                target.as_ptr(),
                gains.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        Ok(())
    }

    unsafe fn eval_unchecked(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) {
        // SAFETY: the caller guarantees the lengths `eval` checks.
        unsafe {
            (self.eval)(
                hoisted.as_ptr(),
                state.as_ptr(),
                target.as_ptr(),
                gains.as_ptr(),
                out.as_mut_ptr(),
            )
        }
    }

    fn raw_eval(&self) -> Option<crate::RawEval> {
        Some(self.eval)
    }

    fn raw_batch(&self) -> Option<lasalle_runtime::RawBatch> {
        self.batch.as_ref().map(|&(_, f)| f)
    }

    fn eval_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) -> Result<(), ExecError> {
        self.common.check(k, hoisted, state, target, gains, out)?;
        // SAFETY: as in `eval`, with `state.len() = N·k` and `out.len() = O·k` checked, so
        // every address `base + 8(i·k + lane)` the loop forms is inside its slice (and
        // 8·N·k fits in a pointer-sized integer because the slices exist).
        unsafe {
            (self.lanes)(
                k,
                hoisted.as_ptr(),
                state.as_ptr(),
                target.as_ptr(),
                gains.as_ptr(),
                out.as_mut_ptr(),
            )
        };
        Ok(())
    }
}

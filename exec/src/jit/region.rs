//! A loop region ([`lasalle_model::loops::Region`]) compiled to one function: its body run
//! once per tuple — gather the slots through the tuple's row of the gather table, run the
//! body, add each output to the function output its row of the scatter table names — two
//! tuples at a time, t and t + 1 in the two lanes of `F64X2` vectors, then the odd last tuple
//! in scalars. The code is the body twice (two lanes, one lane), whatever the number of tuples.
//!
//! In the two-lane loop:
//! - `+ − · /`, negation, `sqrt` and `powi`'s multiplications are the same IEEE instructions
//!   lane by lane, and the `extern "C"` wrappers are called once per lane;
//! - a slot is two loads put together, or one 128-bit load where the gather table has the two
//!   tuples of every pair read adjacent elements (FPUT's neighbours: tuple t reads q[t] and
//!   q[t + 1]), which the compiler decides from the table;
//! - the outputs are added to `out` lane 0's first, in order, then lane 1's: tuple t's
//!   read-add-stores, then tuple t + 1's, the order of one tuple at a time, which matters
//!   where the two add to the same element (neighbours again, and a body's partials to its
//!   member in consecutive pairs).
//!
//! In both loops, slots and outputs whose indices differ by the same amount in every tuple
//! (the x, y and z of one body) share one index load and address ([`leads`]); a slot that
//! gathers the same index for every tuple is loaded once, before the loop (as the constants
//! and the hoisted values are), and splatted for the two-lane loop.
//!
//! What pays (`docs/performance.md`, the loop form): a pass is bound by its loads and stores
//! (the indices, the gathers, the read-add-stores) more than by its arithmetic, so the shared
//! index loads do most for N-body, whose term is long, and the two lanes for FPUT, whose term
//! is short and whose slots are one 128-bit load each; neither makes any family slower.
//!
//! Every instruction is the IEEE operation (or the call of the `extern "C"` wrapper of the
//! same `std` function) that [`crate::loops`]'s interpreter performs, in the same order for
//! each tuple, and the additions to `out` are made in the interpreter's order, so the two
//! agree bit for bit.

use super::{call_cbrt, call_cos, call_ellipf, call_ellipk, call_exp, call_ln, call_powf};
use super::{call_sin, jit_err, jit_module, Code, Math};
use crate::{ExecError, Op, Reg};
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::immediates::Ieee64;
use cranelift_codegen::ir::{
    types, AbiParam, BlockArg, InstBuilder, MemFlagsData, Signature, Type, Value,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::JITModule;
use cranelift_module::Module;
use lasalle_model::ir::Func2;
use lasalle_model::loops::{Region, Source};

/// `(hoisted, state, params, gather, scatter, out)`.
pub(crate) type RegionFn =
    unsafe extern "C" fn(*const f64, *const f64, *const f64, *const u32, *const u32, *mut f64);

/// Compiles a region (validated by the caller with its loop tape).
pub(crate) fn compile(r: &Region) -> Result<(Code, RegionFn), ExecError> {
    let (code, f) = Code::compile(jit_module("speed", false)?, |m| define(m, r))?;
    // SAFETY: defined just now with exactly this signature (six pointers, the host's C
    // convention); the module that owns the code is returned with it.
    let f = unsafe { std::mem::transmute::<*const u8, RegionFn>(f) };
    Ok((code, f))
}

/// How many tuples one pass of the body computes: one, in scalars, or two (t and t + 1), in
/// the lanes of `F64X2` vectors.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Lanes {
    One,
    Two,
}

impl Lanes {
    fn count(self) -> usize {
        match self {
            Lanes::One => 1,
            Lanes::Two => 2,
        }
    }
}

fn define(module: &mut JITModule, r: &Region) -> Result<cranelift_module::FuncId, ExecError> {
    let ptr = module.target_config().pointer_type();
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 6]);
    let id = module.declare_anonymous_function(&sig).map_err(jit_err)?;
    ctx.func.signature = sig;
    let math = Math::new(module);
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let p = b.block_params(entry).to_vec();
        let hoisted = p[0];
        let flags = MemFlagsData::trusted();
        let ops = &r.tape.body;
        let width = r.sources.len();
        // Values the same for every tuple, computed before the loop: the constants, the
        // hoisted values, and the slots that gather the same index for every tuple (loaded
        // once; the region writes only `out`, which is not its input).
        let mut fixed: Vec<Option<Value>> = vec![None; ops.len()];
        for (i, op) in ops.iter().enumerate() {
            match *op {
                Op::State(s) if r.count > 0 => {
                    let s = s as usize;
                    let at = r.gather[s];
                    let same = (1..r.count).all(|t| r.gather[t * width + s] == at);
                    let off = i32::try_from(8 * at as usize).ok();
                    if let (true, Some(off)) = (same, off) {
                        let base = match r.sources[s] {
                            Source::State => p[1],
                            Source::Param => p[2],
                        };
                        fixed[i] = Some(b.ins().load(types::F64, flags, base, off));
                    }
                }
                Op::Const(c) => {
                    fixed[i] = Some(b.ins().f64const(Ieee64::with_bits(c.to_bits())));
                }
                Op::Hoisted(k) => {
                    let off = i32::try_from(8 * k as usize).map_err(|_| jit_err("offset"))?;
                    fixed[i] = Some(b.ins().load(types::F64, flags, hoisted, off));
                }
                _ => {}
            }
        }
        let splats = fixed
            .iter()
            .map(|x| x.map(|x| b.ins().splat(types::F64X2, x)))
            .collect();
        // The slots whose two tuples read adjacent elements in every pair the loop runs.
        let adjacent = (0..width)
            .map(|s| {
                (0..r.count / 2).all(|pair| {
                    let t = 2 * pair;
                    r.gather[t * width + s].checked_add(1) == Some(r.gather[(t + 1) * width + s])
                })
            })
            .collect();
        let same_source = |s: usize, l: usize| r.sources[s] == r.sources[l];
        let sign = b.ins().f64const(Ieee64::with_bits((-0.0f64).to_bits()));
        let sign = [sign, b.ins().splat(types::F64X2, sign)];
        let body = Body {
            r,
            ptr,
            math: &math,
            state: p[1],
            params: p[2],
            gather: p[3],
            scatter: p[4],
            out: p[5],
            fixed,
            splats,
            adjacent,
            gather_leads: leads(&r.gather, width, r.count, same_source),
            scatter_leads: leads(&r.scatter, r.tape.outputs.len(), r.count, |_, _| true),
            sign,
        };
        let (pass, tail) = (b.create_block(), b.create_block());
        let zero = b.ins().iconst(ptr, 0);
        if r.count < 2 {
            b.ins().jump(tail, &[]);
        } else {
            b.ins().jump(pass, &[BlockArg::Value(zero)]);
        }
        b.switch_to_block(pass);
        let t = b.append_block_param(pass, ptr);
        body.pass(&mut b, Lanes::Two, t)?;
        let next = b.ins().iadd_imm_u(t, 2);
        let end = b.ins().iconst(ptr, (r.count - r.count % 2) as i64);
        let more = b.ins().icmp(IntCC::UnsignedLessThan, next, end);
        b.ins()
            .brif(more, pass, &[BlockArg::Value(next)], tail, &[]);
        b.switch_to_block(tail);
        if r.count % 2 == 1 {
            let t = b.ins().iconst(ptr, (r.count - 1) as i64);
            body.pass(&mut b, Lanes::One, t)?;
        }
        b.ins().return_(&[]);
        b.seal_all_blocks();
        b.finalize(module.target_config());
    }
    module.define_function(id, &mut ctx).map_err(jit_err)?;
    module.finalize_definitions().map_err(jit_err)?;
    Ok(id)
}

/// What a pass of the body reads: the region, the function's arguments, the values computed
/// before the loop.
struct Body<'a> {
    r: &'a Region,
    ptr: Type,
    math: &'a Math,
    state: Value,
    params: Value,
    gather: Value,
    scatter: Value,
    out: Value,
    /// The value of each register that is the same for every tuple (a constant, a hoisted
    /// value, a slot that gathers one index), computed before the loop.
    fixed: Vec<Option<Value>>,
    /// Those values in both lanes.
    splats: Vec<Option<Value>>,
    /// Per slot: its two tuples read adjacent elements in every pair (one 128-bit load).
    adjacent: Vec<bool>,
    /// Per slot, the slot whose index it shares, and the byte offset from that slot's element.
    gather_leads: Vec<(usize, i32)>,
    /// Per output, the output whose index it shares, and the byte offset.
    scatter_leads: Vec<(usize, i32)>,
    /// −0 in one lane and in two: negation is `x xor −0`, the sign bit flipped (as `fneg`),
    /// with the mask made once, before the loop, instead of at each negation (Cranelift's
    /// x86-64 `fneg` builds it in a register each time).
    sign: [Value; 2],
}

/// Per column of a tuple-major table of `width` columns, its *lead* and the distance to it in
/// bytes of f64 elements: the first column (for which `pair` holds) whose entry is, for every
/// tuple, at the same distance from its own. The columns of one `vec3` (x, y, z of a body)
/// share the first's index load and address, with the distance as an immediate offset; loads
/// of indices are a large part of a pass (N-body: 8 slots and 6 outputs, 6 index loads per
/// tuple instead of 14). A column no earlier one fits leads itself, at distance 0.
fn leads(
    table: &[u32],
    width: usize,
    count: usize,
    pair: impl Fn(usize, usize) -> bool,
) -> Vec<(usize, i32)> {
    let mut leads: Vec<(usize, i32)> = Vec::with_capacity(width);
    for c in 0..width {
        let entry = |t: usize, c: usize| i64::from(table[t * width + c]);
        let distance = |l: usize| {
            let d = entry(0, c) - entry(0, l);
            let same = (1..count).all(|t| entry(t, c) - entry(t, l) == d);
            i32::try_from(8 * d).ok().filter(|_| same)
        };
        let lead = (0..c)
            .filter(|&l| count > 0 && leads[l].0 == l && pair(c, l))
            .find_map(|l| distance(l).map(|bytes| (l, bytes)));
        leads.push(lead.unwrap_or((c, 0)));
    }
    leads
}

/// Loads of the state and the parameters, gather and scatter tables and `out`: in bounds and
/// aligned.
fn flags() -> MemFlagsData {
    MemFlagsData::trusted()
}

/// Loads of the inputs (state, parameters, tables), which nothing writes during a call (the
/// region writes only `out`, a `&mut` slice that cannot overlap them): pure for Cranelift's
/// e-graph, which places each at its first use (or folds it into the instruction) instead of
/// issuing all up front and spilling.
fn input() -> MemFlagsData {
    flags().with_readonly().with_can_move()
}

/// The byte offset `4·i` of an entry of a table.
fn entry(i: usize) -> Result<i32, ExecError> {
    i.checked_mul(4)
        .and_then(|o| i32::try_from(o).ok())
        .ok_or_else(|| jit_err(format!("table entry {i} too far for an immediate offset")))
}

impl Body<'_> {
    /// Emits one pass at tuple `t` (a pointer-sized index): the body on the `lanes` tuples
    /// from t, and their outputs added to `out`, tuple by tuple.
    fn pass(&self, b: &mut FunctionBuilder<'_>, lanes: Lanes, t: Value) -> Result<(), ExecError> {
        let r = self.r;
        let (k, o) = (r.sources.len(), r.tape.outputs.len());
        let grow = self.row(b, self.gather, k, t);
        let srow = self.row(b, self.scatter, o, t);
        let mut local = match lanes {
            Lanes::One => self.fixed.clone(),
            Lanes::Two => self.splats.clone(),
        };
        // the addresses of the leads' elements, per lane, at their first use
        let mut gathered: Vec<[Option<Value>; 2]> = vec![[None; 2]; k];
        for (i, op) in r.tape.body.iter().enumerate() {
            if local[i].is_some() {
                continue;
            }
            let v = |r: Reg| local[r.index()].expect("validated: defined before use");
            let x = match *op {
                Op::State(s) => self.slot(b, lanes, grow, &mut gathered, s as usize)?,
                Op::Add(a, c) => b.ins().fadd(v(a), v(c)),
                Op::Sub(a, c) => b.ins().fsub(v(a), v(c)),
                Op::Mul(a, c) => b.ins().fmul(v(a), v(c)),
                Op::Div(a, c) => b.ins().fdiv(v(a), v(c)),
                Op::Neg(a) => {
                    let sign = self.sign[lanes.count() - 1];
                    b.ins().bxor(v(a), sign)
                }
                Op::Sqrt(a) => b.ins().sqrt(v(a)),
                Op::Powi(a, n) => self.powi(b, lanes, v(a), n),
                Op::Cbrt(a) => self.unary(b, lanes, call_cbrt, v(a)),
                Op::Exp(a) => self.unary(b, lanes, call_exp, v(a)),
                Op::Ln(a) => self.unary(b, lanes, call_ln, v(a)),
                Op::Sin(a) => self.unary(b, lanes, call_sin, v(a)),
                Op::Cos(a) => self.unary(b, lanes, call_cos, v(a)),
                Op::EllipK(a) => self.unary(b, lanes, call_ellipk, v(a)),
                Op::Powf(a, q) => {
                    let num = b.ins().iconst(types::I32, i64::from(q.num));
                    let den = b.ins().iconst(types::I32, i64::from(q.den));
                    let powf = &self.math.powf;
                    self.call(
                        b,
                        lanes,
                        call_powf as *const () as usize,
                        powf,
                        &[v(a)],
                        &[num, den],
                    )
                }
                Op::Func2(f, a, c) => {
                    let w = match f {
                        Func2::EllipF => call_ellipf as *const () as usize,
                        Func2::Sn => region_sn as *const () as usize,
                        Func2::Cn => region_cn as *const () as usize,
                        Func2::Dn => region_dn as *const () as usize,
                    };
                    let binary = &self.math.binary;
                    self.call(b, lanes, w, binary, &[v(a), v(c)], &[])
                }
                Op::Param(_) | Op::Target(_) | Op::Gain(_) | Op::Hoisted(_) | Op::Const(_) => {
                    return Err(jit_err(format!("a loop region's body has {op:?}")))
                }
            };
            local[i] = Some(x);
        }
        // tuple t's outputs in order, then tuple t + 1's (the interpreter's order)
        for lane in 0..lanes.count() {
            // the addresses of the leads' elements, at their first use
            let mut addresses: Vec<Option<Value>> = vec![None; o];
            for (j, reg) in r.tape.outputs.iter().enumerate() {
                let (lead, off) = self.scatter_leads[j];
                let addr = match addresses[lead] {
                    Some(a) => a,
                    None => {
                        let idx = b.ins().uload32(input(), srow, entry(lane * o + lead)?);
                        self.element(b, self.out, idx)
                    }
                };
                addresses[lead] = Some(addr);
                let old = b.ins().load(types::F64, flags(), addr, off);
                let x = local[reg.index()].expect("validated: outputs are defined");
                let x = lane_of(b, lanes, x, lane);
                let new = b.ins().fadd(old, x);
                b.ins().store(flags(), new, addr, off);
            }
        }
        Ok(())
    }

    /// The address of row `t` of a table of `width` entries per tuple.
    fn row(&self, b: &mut FunctionBuilder<'_>, table: Value, width: usize, t: Value) -> Value {
        let off = b.ins().imul_imm_s(t, 4 * width as i64);
        b.ins().iadd(table, off)
    }

    /// The address of element `idx` (a u32 loaded from a table) of `base`.
    fn element(&self, b: &mut FunctionBuilder<'_>, base: Value, idx: Value) -> Value {
        let idx = if self.ptr == types::I64 {
            idx
        } else {
            b.ins().ireduce(self.ptr, idx)
        };
        let off = b.ins().imul_imm_s(idx, 8);
        b.ins().iadd(base, off)
    }

    /// Slot `s` of the `lanes` tuples whose gather row starts at `grow`; `gathered` holds the
    /// addresses of the elements of the leads ([`leads`]) loaded so far.
    fn slot(
        &self,
        b: &mut FunctionBuilder<'_>,
        lanes: Lanes,
        grow: Value,
        gathered: &mut [[Option<Value>; 2]],
        s: usize,
    ) -> Result<Value, ExecError> {
        let base = match self.r.sources[s] {
            Source::State => self.state,
            Source::Param => self.params,
        };
        let k = self.r.sources.len();
        let (lead, off) = self.gather_leads[s];
        let mut address = |b: &mut FunctionBuilder<'_>, lane: usize| {
            if let Some(a) = gathered[lead][lane] {
                return Ok(a);
            }
            let idx = b.ins().uload32(input(), grow, entry(lane * k + lead)?);
            let a = self.element(b, base, idx);
            gathered[lead][lane] = Some(a);
            Ok::<_, ExecError>(a)
        };
        let first = address(b, 0)?;
        Ok(match lanes {
            Lanes::One => b.ins().load(types::F64, input(), first, off),
            // 8-byte aligned only
            Lanes::Two if self.adjacent[s] => {
                let f = MemFlagsData::new()
                    .with_notrap()
                    .with_readonly()
                    .with_can_move();
                b.ins().load(types::F64X2, f, first, off)
            }
            Lanes::Two => {
                let second = address(b, 1)?;
                let x = b.ins().load(types::F64, input(), first, off);
                let y = b.ins().load(types::F64, input(), second, off);
                join(b, x, y)
            }
        })
    }

    /// xⁿ by binary exponentiation, operation for operation [`lasalle_model::tape::powi`].
    fn powi(&self, b: &mut FunctionBuilder<'_>, lanes: Lanes, x: Value, n: i32) -> Value {
        let mut bits = n.unsigned_abs();
        let mut square = x;
        let mut result: Option<Value> = None;
        while bits != 0 {
            if bits & 1 == 1 {
                result = Some(match result {
                    None => square,
                    Some(r) => b.ins().fmul(r, square),
                });
            }
            bits >>= 1;
            if bits != 0 {
                square = b.ins().fmul(square, square);
            }
        }
        let mut one = b.ins().f64const(1.0);
        if lanes == Lanes::Two {
            one = b.ins().splat(types::F64X2, one);
        }
        let r = result.unwrap_or(one);
        if n < 0 {
            b.ins().fdiv(one, r)
        } else {
            r
        }
    }

    /// Calls a wrapper of one argument, once per lane.
    fn unary(
        &self,
        b: &mut FunctionBuilder<'_>,
        lanes: Lanes,
        f: extern "C" fn(f64) -> f64,
        x: Value,
    ) -> Value {
        let unary = &self.math.unary;
        self.call(b, lanes, f as *const () as usize, unary, &[x], &[])
    }

    /// Calls the `extern "C"` wrapper at `f` (of signature `sig`) on the values `x` and the
    /// scalar arguments `extra`, once per lane.
    fn call(
        &self,
        b: &mut FunctionBuilder<'_>,
        lanes: Lanes,
        f: usize,
        sig: &Signature,
        x: &[Value],
        extra: &[Value],
    ) -> Value {
        let sig = b.import_signature(sig.clone());
        let mut results = [None; 2];
        for (lane, result) in results.iter_mut().enumerate().take(lanes.count()) {
            let mut args: Vec<Value> = x.iter().map(|&v| lane_of(b, lanes, v, lane)).collect();
            args.extend_from_slice(extra);
            let callee = b.ins().iconst(self.ptr, f as i64);
            let c = b.ins().call_indirect(sig, callee, &args);
            *result = Some(b.inst_results(c)[0]);
        }
        match results {
            [Some(x), Some(y)] => join(b, x, y),
            [x, _] => x.expect("one lane at least"),
        }
    }
}

/// The value of tuple `lane` in `x`.
fn lane_of(b: &mut FunctionBuilder<'_>, lanes: Lanes, x: Value, lane: usize) -> Value {
    match lanes {
        Lanes::One => x,
        Lanes::Two => b.ins().extractlane(x, lane as u8),
    }
}

/// The vector `(x, y)`.
fn join(b: &mut FunctionBuilder<'_>, x: Value, y: Value) -> Value {
    let v = b.ins().splat(types::F64X2, x);
    b.ins().insertlane(v, y, 1)
}

/// sn, cn, dn of (u | m), one `ellipj` call each (as the interpreter of loop regions).
pub(crate) extern "C" fn region_sn(u: f64, m: f64) -> f64 {
    Func2::Sn.apply(u, m)
}
pub(crate) extern "C" fn region_cn(u: f64, m: f64) -> f64 {
    Func2::Cn.apply(u, m)
}
pub(crate) extern "C" fn region_dn(u: f64, m: f64) -> f64 {
    Func2::Dn.apply(u, m)
}

//! A loop region ([`lasalle_model::loops::Region`]) compiled to one function with a loop block:
//! per tuple, gather the slots through the tuple's row of the gather table, run the region's
//! body, and add each output to the function output its row of the scatter table names (a slot
//! that gathers the same index for every tuple is loaded once, before the loop). The code is
//! the body once, whatever the number of tuples.
//!
//! Every instruction is the IEEE operation (or the call of the `extern "C"` wrapper of the
//! same `std` function) that [`crate::loops`]'s interpreter performs, in the same order, so
//! the two agree bit for bit.

use super::{call_cbrt, call_cos, call_ellipf, call_ellipk, call_exp, call_ln, call_powf};
use super::{call_sin, jit_err, jit_module, Code, Math};
use crate::{ExecError, Op};
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::immediates::Ieee64;
use cranelift_codegen::ir::{types, AbiParam, BlockArg, InstBuilder, MemFlagsData, Value};
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

fn define(module: &mut JITModule, r: &Region) -> Result<cranelift_module::FuncId, ExecError> {
    let ptr = module.target_config().pointer_type();
    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 6]);
    let id = module.declare_anonymous_function(&sig).map_err(jit_err)?;
    ctx.func.signature = sig;
    let Math {
        unary,
        binary,
        powf,
        ..
    } = Math::new(module);
    {
        let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let p = b.block_params(entry).to_vec();
        let (hoisted, state, params, gather, scatter, out) = (p[0], p[1], p[2], p[3], p[4], p[5]);
        let flags = MemFlagsData::trusted();
        let ops = &r.tape.body;
        // Values the same for every tuple, computed before the loop: the constants, the
        // hoisted values, and the slots that gather the same index for every tuple (loaded
        // once; the region writes only `out`, which is not its input).
        let mut values: Vec<Option<Value>> = vec![None; ops.len()];
        let width = r.sources.len();
        for (i, op) in ops.iter().enumerate() {
            match *op {
                Op::State(s) if r.count > 0 => {
                    let s = s as usize;
                    let at = r.gather[s];
                    let fixed = (1..r.count).all(|t| r.gather[t * width + s] == at);
                    let off = i32::try_from(8 * at as usize).ok();
                    if let (true, Some(off)) = (fixed, off) {
                        let base = match r.sources[s] {
                            Source::State => state,
                            Source::Param => params,
                        };
                        values[i] = Some(b.ins().load(types::F64, flags, base, off));
                    }
                }
                Op::Const(c) => {
                    values[i] = Some(b.ins().f64const(Ieee64::with_bits(c.to_bits())));
                }
                Op::Hoisted(k) => {
                    let off = i32::try_from(8 * k as usize).map_err(|_| jit_err("offset"))?;
                    values[i] = Some(b.ins().load(types::F64, flags, hoisted, off));
                }
                _ => {}
            }
        }
        let (body, exit) = (b.create_block(), b.create_block());
        let zero = b.ins().iconst(ptr, 0);
        if r.count == 0 {
            b.ins().jump(exit, &[]);
        } else {
            b.ins().jump(body, &[BlockArg::Value(zero)]);
        }
        b.switch_to_block(body);
        let t = b.append_block_param(body, ptr);
        let (k, o) = (r.sources.len() as i64, r.tape.outputs.len() as i64);
        let row = |b: &mut FunctionBuilder<'_>, table: Value, width: i64| {
            let w = b.ins().iconst(ptr, 4 * width);
            let off = b.ins().imul(t, w);
            b.ins().iadd(table, off)
        };
        let grow = row(&mut b, gather, k);
        let srow = row(&mut b, scatter, o);
        let element = |b: &mut FunctionBuilder<'_>, base: Value, idx: Value| {
            let idx = if ptr == types::I64 {
                idx
            } else {
                b.ins().ireduce(ptr, idx)
            };
            let eight = b.ins().iconst(ptr, 8);
            let off = b.ins().imul(idx, eight);
            b.ins().iadd(base, off)
        };
        let call = |b: &mut FunctionBuilder<'_>,
                    f: usize,
                    sig: &cranelift_codegen::ir::Signature,
                    args: &[Value]| {
            let sig = b.import_signature(sig.clone());
            let callee = b.ins().iconst(ptr, f as i64);
            let c = b.ins().call_indirect(sig, callee, args);
            b.inst_results(c)[0]
        };
        let mut local = values.clone();
        for (i, op) in ops.iter().enumerate() {
            if local[i].is_some() {
                continue;
            }
            let v = |r: crate::Reg| local[r.index()].expect("validated: defined before use");
            let x = match *op {
                Op::State(s) => {
                    let off = i32::try_from(4 * s as usize).map_err(|_| jit_err("offset"))?;
                    let idx = b.ins().uload32(flags, grow, off);
                    let base = match r.sources[s as usize] {
                        Source::State => state,
                        Source::Param => params,
                    };
                    let addr = element(&mut b, base, idx);
                    b.ins().load(types::F64, flags, addr, 0)
                }
                Op::Add(a, c) => b.ins().fadd(v(a), v(c)),
                Op::Sub(a, c) => b.ins().fsub(v(a), v(c)),
                Op::Mul(a, c) => b.ins().fmul(v(a), v(c)),
                Op::Div(a, c) => b.ins().fdiv(v(a), v(c)),
                Op::Neg(a) => b.ins().fneg(v(a)),
                Op::Sqrt(a) => b.ins().sqrt(v(a)),
                Op::Powi(a, n) => {
                    // lasalle_model::tape::powi, operation for operation
                    let mut bits = n.unsigned_abs();
                    let mut square = v(a);
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
                    let one = b.ins().f64const(1.0);
                    let r = result.unwrap_or(one);
                    if n < 0 {
                        b.ins().fdiv(one, r)
                    } else {
                        r
                    }
                }
                Op::Cbrt(a) => call(&mut b, call_cbrt as *const () as usize, &unary, &[v(a)]),
                Op::Exp(a) => call(&mut b, call_exp as *const () as usize, &unary, &[v(a)]),
                Op::Ln(a) => call(&mut b, call_ln as *const () as usize, &unary, &[v(a)]),
                Op::Sin(a) => call(&mut b, call_sin as *const () as usize, &unary, &[v(a)]),
                Op::Cos(a) => call(&mut b, call_cos as *const () as usize, &unary, &[v(a)]),
                Op::EllipK(a) => call(&mut b, call_ellipk as *const () as usize, &unary, &[v(a)]),
                Op::Powf(a, q) => {
                    let num = b.ins().iconst(types::I32, i64::from(q.num));
                    let den = b.ins().iconst(types::I32, i64::from(q.den));
                    call(
                        &mut b,
                        call_powf as *const () as usize,
                        &powf,
                        &[v(a), num, den],
                    )
                }
                Op::Func2(Func2::EllipF, a, c) => call(
                    &mut b,
                    call_ellipf as *const () as usize,
                    &binary,
                    &[v(a), v(c)],
                ),
                Op::Func2(f, a, c) => {
                    let w = match f {
                        Func2::Sn => region_sn as *const () as usize,
                        Func2::Cn => region_cn as *const () as usize,
                        _ => region_dn as *const () as usize,
                    };
                    call(&mut b, w, &binary, &[v(a), v(c)])
                }
                Op::Param(_) | Op::Target(_) | Op::Gain(_) | Op::Hoisted(_) | Op::Const(_) => {
                    return Err(jit_err(format!("a loop region's body has {op:?}")))
                }
            };
            local[i] = Some(x);
        }
        for (j, reg) in r.tape.outputs.iter().enumerate() {
            let idx = b.ins().uload32(flags, srow, 4 * j as i32);
            let addr = element(&mut b, out, idx);
            let old = b.ins().load(types::F64, flags, addr, 0);
            let val = local[reg.index()].expect("validated: outputs are defined");
            let new = b.ins().fadd(old, val);
            b.ins().store(flags, new, addr, 0);
        }
        let next = b.ins().iadd_imm_u(t, 1);
        let count = b.ins().iconst(ptr, r.count as i64);
        let more = b.ins().icmp(IntCC::UnsignedLessThan, next, count);
        b.ins()
            .brif(more, body, &[BlockArg::Value(next)], exit, &[]);
        b.switch_to_block(exit);
        b.ins().return_(&[]);
        b.seal_all_blocks();
        b.finalize(module.target_config());
    }
    module.define_function(id, &mut ctx).map_err(jit_err)?;
    module.finalize_definitions().map_err(jit_err)?;
    Ok(id)
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

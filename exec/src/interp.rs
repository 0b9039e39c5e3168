//! The interpreter: one pass over a pre-decoded copy of the body per call.
//!
//! # Layout
//!
//! [`Interpreter::new`] decodes the body once into a register file of *slots*:
//!
//! ```text
//! [ state N | targets M | gains G | hoisted H | constants C | computed … ]
//! ```
//!
//! A call copies its inputs and the (pooled) constants into the first slots, which replaces
//! every leaf instruction of the tape, and then runs the computed instructions (instruction i
//! writes slot `first + i`). Decoding also
//! - expands `Powi` into the multiplications of its binary exponentiation
//!   ([`lasalle_model::tape::powi`]: the same IEEE operations in the same order), with `x⁰`
//!   the constant 1 and `x¹` the slot of x itself;
//! - folds a product used once, by a sum or a difference, into it (`a·b + c`, `a·b − c`,
//!   `c − a·b`: the product and the sum rounded separately as in the tape, never a fused
//!   multiply-add);
//! - folds a negation used once, by a sum or as the subtrahend of a difference, into it
//!   (`x + (−y)` and `−y + x` are the IEEE `x − y`; `x − (−y)` is `x + y`);
//! - orders the instructions into *runs* of one kind (`Kind`: `·`, `+`, `−`, the three folded
//!   products, and the others), a topological order found greedily (`schedule`: the
//!   instructions whose operands are computed, all of one kind at a time with those that
//!   become ready meanwhile; division, square root and the functions first, else the kind
//!   with the most ready instructions). The models of `models/` take 3 to 24 runs for 5 to
//!   174 instructions.
//!
//! The one-state loop takes one branch per run and none per instruction (an interpreter's
//! usual cost is the mispredicted jump per instruction): a run is a loop over its
//! instructions in one form, each a single word of packed operand slots (one load). Every
//! value is the IEEE operation or `std` call of the tape on the same operands (in another
//! order, which changes nothing: each instruction still reads the values it read in the
//! tape): the results are bitwise those of the tape, except that a NaN may come out with
//! another sign or payload (a folded negation is a subtraction, `−x` runs as `−0 − x`, and
//! `c + a·b` as `a·b + c`; the tests count every NaN as equal). sn, cn and dn of one (u | m)
//! share one `ellipj` call when no other (u | m) is evaluated between them (the one-state loop
//! remembers the last arguments; the values are those of separate calls).
//!
//! # Cost
//!
//! A run costs about one cycle per instruction on the large models (the loads of the operands
//! are the limit) and each call a copy of its inputs; on the small ones the time is the
//! longest chain of dependent instructions, each waiting for the store of its operand to be
//! forwarded to its load (~7 cycles) and for its own operation — so folding, which takes a
//! store and a load off the chain, helps them most (docs/performance.md).
//!
//! # Safety of the unchecked loop
//!
//! Decoding proves, once, that every operand slot of instruction i is below its own slot
//! `first + i` in the order of the runs (so it was written earlier in the same call, by the
//! input copies or by an earlier instruction), that the inputs fill exactly the slots below
//! `first`, and that every output slot is below the number of slots. The runs' lengths add up
//! to the number of instructions, those of the straight kinds to the packed operand words and
//! those of the other kind to the special instructions (by construction). A call then only
//! needs the input lengths (checked by [`Kernel::eval`], guaranteed by the caller of
//! [`Kernel::eval_unchecked`]) and a buffer of `n_slots` values; the loop indexes it without
//! bounds checks. The slots are fewer than 2²¹ (three fit in a word; a larger tape is
//! [`TapeError::TooLarge`]).
//!
//! # Scratch
//!
//! The slots live on the stack when they fit in `STACK_SLOTS` = 480 (no allocation, no
//! thread-local access, never initialised: every slot is written before it is read, as above);
//! larger tapes use a thread-local buffer that is taken out of its cell for the call and put
//! back afterwards (so a re-entrant call finds the cell empty and uses a buffer of its own).
//!
//! With k lanes (`eval_lanes`) slot s of lane l is at `s*k + l`, and every instruction is a
//! loop over the lanes, which the compiler vectorises.

use crate::{Common, Dims, ExecError, Kernel, Op, Reg, Tape, TapeError};
use lasalle_model::ir::{Func, Func2, Rational, Scalar};
use lasalle_runtime::elliptic::{ellipj, Jacobi};
use std::cell::Cell;
use std::mem::MaybeUninit;

thread_local! {
    static SCRATCH: Cell<Vec<f64>> = const { Cell::new(Vec::new()) };
}

/// Tapes with at most this many slots run on a stack buffer (under a page, so the frame needs
/// no stack probe loop).
const STACK_SLOTS: usize = 480;

/// Runs `f` on a thread-local scratch slice of `len` values (contents unspecified).
pub(crate) fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    SCRATCH.with(|cell| {
        let mut v = cell.take();
        if v.len() < len {
            v.resize(len, 0.0);
        }
        let r = f(&mut v[..len]);
        cell.set(v);
        r
    })
}

/// What a decoded instruction computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum Code {
    Add,
    Sub,
    Mul,
    Div,
    Neg,
    Sqrt,
    Cbrt,
    Exp,
    Ln,
    Sin,
    Cos,
    /// K(a)
    EllipK,
    /// sn(a | b), cn(a | b), dn(a | b), F(a | b)
    Sn,
    Cn,
    Dn,
    EllipF,
    /// `b` indexes [`Interpreter::rationals`], not a slot.
    Powf,
    /// `a·b + c`: a product whose one use is this sum (`Add(Mul(a, b), c)` or
    /// `Add(c, Mul(a, b))`, the same IEEE sum), two roundings as in the tape, never fused.
    MulAdd,
    /// `a·b − c`: a product whose one use is this difference, rounded as in the tape.
    MulSub,
    /// `c − a·b`: a product whose one use is this difference, rounded as in the tape.
    SubMul,
}

impl Code {
    fn of(f: Func2) -> Code {
        match f {
            Func2::Sn => Code::Sn,
            Func2::Cn => Code::Cn,
            Func2::Dn => Code::Dn,
            Func2::EllipF => Code::EllipF,
        }
    }
}

/// A decoded instruction: `slot[first + i] = code(slot[a], slot[b])` (`b` unused by unary
/// codes, the exponent's index for `Powf`).
#[derive(Clone, Copy, Debug)]
struct Ins {
    a: u32,
    b: u32,
    /// The third operand of `MulAdd`, `MulSub` and `SubMul`.
    c: u32,
    code: Code,
}

/// The kind of a run of the one-state loop: instruction after instruction of one form, so the
/// loop over a run takes no data-dependent branch (an interpreter's usual cost is the
/// mispredicted jump per instruction). Decoding orders the instructions into few runs
/// ([`schedule`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// `x·y`, operands packed by [`pack2`].
    Mul,
    /// `x + y`, operands packed by [`pack2`].
    Add,
    /// `x − y`, operands packed by [`pack2`]; also `−x` as `−0 − x` (the same value for every
    /// x but a NaN: −0 − (+0) = −0, −0 − (−0) = +0).
    Sub,
    /// `x·y + z`, operands packed by [`pack3`]: two roundings as in the tape, never fused.
    MulAdd,
    /// `x·y − z`, operands packed by [`pack3`].
    MulSub,
    /// `z − x·y`, operands packed by [`pack3`].
    SubMul,
    /// Any other instruction ([`Special`]).
    Special,
}

impl Kind {
    fn of(code: Code) -> Kind {
        match code {
            Code::Mul => Kind::Mul,
            Code::Add => Kind::Add,
            Code::Sub | Code::Neg => Kind::Sub,
            Code::MulAdd => Kind::MulAdd,
            Code::MulSub => Kind::MulSub,
            Code::SubMul => Kind::SubMul,
            _ => Kind::Special,
        }
    }
}

/// `len` consecutive instructions of one kind.
#[derive(Clone, Copy, Debug)]
struct Run {
    kind: Kind,
    len: u32,
}

/// Bits of one operand in [`pack3`]: the slots are fewer than 2²¹.
const FIELD: u32 = 21;
/// One operand of [`pack3`].
const MASK: u64 = (1 << FIELD) - 1;

/// Two operand slots in one word (one load in the loop).
fn pack2(a: u32, b: u32) -> u64 {
    a as u64 | (b as u64) << 32
}

/// The slots of [`pack2`].
#[inline(always)]
fn unpack2(x: u64) -> (usize, usize) {
    (x as u32 as usize, (x >> 32) as usize)
}

/// Three operand slots (each below 2²¹) in one word.
fn pack3(a: u32, b: u32, c: u32) -> u64 {
    a as u64 | (b as u64) << FIELD | (c as u64) << (2 * FIELD)
}

/// The slots of [`pack3`].
#[inline(always)]
fn unpack3(x: u64) -> (usize, usize, usize) {
    (
        (x & MASK) as usize,
        ((x >> FIELD) & MASK) as usize,
        (x >> (2 * FIELD)) as usize,
    )
}

/// An instruction of a [`Kind::Special`] run: `code(slot[a], slot[b])` (`b` is the exponent's
/// index for `Powf`).
#[derive(Clone, Copy, Debug)]
struct Special {
    code: Code,
    a: u32,
    b: u32,
}

/// A tape ready to be interpreted.
#[derive(Clone, Debug)]
pub struct Interpreter {
    common: Common,
    /// The pooled constants, copied to the slots `N + M + G + H..first` on each call.
    consts: Vec<f64>,
    /// Slot written by the first instruction.
    first: usize,
    /// The instructions in the order of `runs` (instruction i writes slot `first + i`).
    code: Vec<Ins>,
    /// `code` for the one-state loop: the runs…
    runs: Vec<Run>,
    /// … the packed operands of the instructions of the straight kinds, in order…
    packed: Vec<u64>,
    /// … and the others, in order.
    specials: Vec<Special>,
    /// Exponents of the `Powf` instructions.
    rationals: Vec<Rational>,
    /// Slot of each output.
    outputs: Vec<u32>,
    /// first + code.len().
    n_slots: usize,
}

/// `Op::Powf` in f64: as the generic evaluation of the tape ([`Scalar::powf`] for f64).
pub fn powf(x: f64, p: Rational) -> f64 {
    Scalar::powf(&x, p)
}

/// Decodes a body; see the [module docs](self).
struct Decoder {
    consts: Vec<f64>,
    /// Constants as (bits, index), for pooling.
    pool: std::collections::HashMap<u64, u32>,
    /// Instructions on unplaced slots (`Powf`: the exponent's index as `Slot::Fixed`; the
    /// third operand is that of `MulAdd`, `MulSub` and `SubMul`, else a copy of the first).
    code: Vec<(Code, Slot, Slot, Slot)>,
    /// The factors of the products deferred to their sum ([`Slot::Product`]).
    products: Vec<(Slot, Slot)>,
    /// The operands of the negations deferred to their use ([`Slot::Negated`]).
    negated: Vec<Slot>,
    rationals: Vec<Rational>,
}

impl Decoder {
    fn constant(&mut self, c: f64) -> u32 {
        let n = self.consts.len() as u32;
        *self.pool.entry(c.to_bits()).or_insert_with(|| {
            self.consts.push(c);
            n
        })
    }

    /// Appends an instruction; its slot.
    fn push(&mut self, code: Code, a: Slot, b: Slot) -> Slot {
        self.push3(code, a, b, a)
    }

    /// A deferred value computed after all (a sum of two products, say), or `s` itself.
    fn materialize(&mut self, s: Slot) -> Slot {
        match s {
            Slot::Product(p) => {
                let (x, y) = self.products[p];
                self.push(Code::Mul, x, y)
            }
            Slot::Negated(k) => {
                let x = self.negated[k];
                self.push(Code::Neg, x, x)
            }
            s => s,
        }
    }

    /// `x + y`, or `x − y` if `subtract`, with a deferred product or negation among the
    /// operands folded into the instruction: the IEEE operations of the tape, since
    /// `x + (−v)` and `−v + x` are `x − v`, `x − (−v)` is `x + v`, and a product is rounded on
    /// its own before it is added or subtracted.
    fn sum(&mut self, x: Slot, y: Slot, subtract: bool) -> Slot {
        let negated = |s: Slot| matches!(s, Slot::Negated(_));
        // −u − v: −u computed on its own
        let x = if negated(x) && negated(y) != subtract {
            self.materialize(x)
        } else {
            x
        };
        let plain = |dec: &Self, s: Slot| match s {
            Slot::Negated(k) => dec.negated[k],
            s => s,
        };
        // now p + q or p − q, with p and q products or computed values
        let (p, q, minus) = match (negated(x), negated(y) != subtract) {
            (false, minus) => (x, plain(self, y), minus),
            (true, _) => (plain(self, y), plain(self, x), true),
        };
        match (p, q, minus) {
            (Slot::Product(k), c, false) | (c, Slot::Product(k), false) => {
                // a sum of two products computes the other one on its own
                let c = self.materialize(c);
                let (a, b) = self.products[k];
                self.push3(Code::MulAdd, a, b, c)
            }
            (Slot::Product(k), c, true) => {
                let c = self.materialize(c);
                let (a, b) = self.products[k];
                self.push3(Code::MulSub, a, b, c)
            }
            (c, Slot::Product(k), true) => {
                let (a, b) = self.products[k];
                self.push3(Code::SubMul, a, b, c)
            }
            (p, q, false) => self.push(Code::Add, p, q),
            (p, q, true) => self.push(Code::Sub, p, q),
        }
    }

    /// Appends an instruction with three operands; its slot.
    fn push3(&mut self, code: Code, a: Slot, b: Slot, c: Slot) -> Slot {
        self.code.push((code, a, b, c));
        Slot::Computed(self.code.len() - 1)
    }
}

/// A slot before the constants are placed: an input, a constant or a computed value.
#[derive(Clone, Copy)]
enum Slot {
    /// An input (or, as the second operand of `Powf`, the exponent's index).
    Fixed(usize),
    /// The constant `consts[i]`.
    Const(u32),
    /// The value of the instruction `code[i]`.
    Computed(usize),
    /// Not computed: the product `products[i]`, folded into its one use, a sum.
    Product(usize),
    /// Not computed: minus `negated[i]`, folded into its one use, a sum or a difference.
    Negated(usize),
}

impl Interpreter {
    /// Prepares a tape (checked with [`Tape::validate`]).
    pub fn new(tape: &Tape) -> Result<Interpreter, ExecError> {
        tape.validate()?;
        let d = tape.dims;
        let n_hoisted = tape.hoisted.len();
        let too_large = || ExecError::Tape(TapeError::TooLarge);
        let consts_at = [d.state, d.targets, d.gains, n_hoisted]
            .into_iter()
            .try_fold(0usize, |a, n| a.checked_add(n))
            .ok_or_else(too_large)?;
        // Pass 1: computed instructions are numbered from 0, constants pooled; the slots of
        // both are fixed in pass 2 once the number of constants is known.
        let mut dec = Decoder {
            consts: Vec::new(),
            pool: Default::default(),
            code: Vec::new(),
            rationals: Vec::new(),
            products: Vec::new(),
            negated: Vec::new(),
        };
        // The products used once, by a sum or a difference: computed in its `MulAdd`,
        // `MulSub` or `SubMul`…
        let mut uses = vec![0u32; tape.body.len()];
        for r in tape
            .body
            .iter()
            .flat_map(Op::operands)
            .chain(tape.outputs.iter().copied())
        {
            uses[r.index()] += 1;
        }
        // …and the negations used once, by a sum or as what a difference subtracts:
        // `x + (−y)` and `−y + x` are the IEEE `x − y`, `x − (−y)` is `x + y`.
        let mut fold = vec![false; tape.body.len()];
        for op in &tape.body {
            let once = |r: Reg| uses[r.index()] == 1;
            match *op {
                Op::Add(a, b) => {
                    for r in [a, b] {
                        if once(r) && matches!(tape.body[r.index()], Op::Mul(..) | Op::Neg(_)) {
                            fold[r.index()] = true;
                        }
                    }
                }
                Op::Sub(a, b) => {
                    for (r, neg) in [(a, false), (b, true)] {
                        if once(r)
                            && matches!(
                                (&tape.body[r.index()], neg),
                                (Op::Mul(..), _) | (Op::Neg(_), true)
                            )
                        {
                            fold[r.index()] = true;
                        }
                    }
                }
                _ => {}
            }
        }
        let mut slots: Vec<Slot> = Vec::with_capacity(tape.body.len());
        let inputs = |base: usize, k: u32| Slot::Fixed(base + k as usize);
        for (i, &op) in tape.body.iter().enumerate() {
            // operands are earlier registers (validated)
            let s = |r: Reg| slots[r.index()];
            let slot = match op {
                Op::Mul(a, b) if fold[i] => {
                    dec.products.push((s(a), s(b)));
                    Slot::Product(dec.products.len() - 1)
                }
                Op::Neg(a) if fold[i] => {
                    dec.negated.push(s(a));
                    Slot::Negated(dec.negated.len() - 1)
                }
                Op::Add(a, b) => dec.sum(s(a), s(b), false),
                Op::Sub(a, b) => dec.sum(s(a), s(b), true),
                Op::State(k) => inputs(0, k),
                Op::Target(k) => inputs(d.state, k),
                Op::Gain(k) => inputs(d.state + d.targets, k),
                Op::Hoisted(k) => inputs(d.state + d.targets + d.gains, k),
                Op::Param(_) => return Err(ExecError::Jit("a parameter in the body".into())),
                Op::Const(c) => Slot::Const(dec.constant(c)),
                Op::Powi(a, n) => powi_slots(&mut dec, s(a), n),
                op => {
                    let (code, a, b) = match op {
                        Op::Mul(a, b) => (Code::Mul, s(a), s(b)),
                        Op::Div(a, b) => (Code::Div, s(a), s(b)),
                        Op::Neg(a) => (Code::Neg, s(a), s(a)),
                        Op::Sqrt(a) => (Code::Sqrt, s(a), s(a)),
                        Op::Cbrt(a) => (Code::Cbrt, s(a), s(a)),
                        Op::Exp(a) => (Code::Exp, s(a), s(a)),
                        Op::Ln(a) => (Code::Ln, s(a), s(a)),
                        Op::Sin(a) => (Code::Sin, s(a), s(a)),
                        Op::Cos(a) => (Code::Cos, s(a), s(a)),
                        Op::EllipK(a) => (Code::EllipK, s(a), s(a)),
                        Op::Func2(f, a, b) => (Code::of(f), s(a), s(b)),
                        Op::Powf(a, p) => {
                            dec.rationals.push(p);
                            (Code::Powf, s(a), Slot::Fixed(dec.rationals.len() - 1))
                        }
                        _ => unreachable!("leaves, sums, differences and powi are handled above"),
                    };
                    dec.push(code, a, b)
                }
            };
            slots.push(slot);
        }
        // `−x` runs as `−0 − x`
        let minus_zero = dec
            .code
            .iter()
            .any(|&(code, ..)| code == Code::Neg)
            .then(|| dec.constant(-0.0));
        // Pass 2: the instructions in runs, constants at consts_at.., computed values at
        // first...
        let (order, runs) = schedule(&dec.code);
        let mut position = vec![0; order.len()];
        for (new, &old) in order.iter().enumerate() {
            position[old] = new;
        }
        let first = consts_at
            .checked_add(dec.consts.len())
            .ok_or_else(too_large)?;
        let n_slots = first.checked_add(dec.code.len()).ok_or_else(too_large)?;
        // every slot index fits in a `pack3` field
        if n_slots > 1 << FIELD {
            return Err(too_large());
        }
        let place = |s: Slot| -> u32 {
            (match s {
                Slot::Fixed(i) => i,
                Slot::Const(c) => consts_at + c as usize,
                Slot::Computed(i) => first + position[i],
                Slot::Product(_) | Slot::Negated(_) => {
                    unreachable!("a deferred value is only read by its one use")
                }
            }) as u32
        };
        let code: Vec<Ins> = order
            .iter()
            .map(|&i| {
                let (code, a, b, c) = dec.code[i];
                Ins {
                    a: place(a),
                    b: match (code, b) {
                        (Code::Powf, Slot::Fixed(i)) => i as u32,
                        _ => place(b),
                    },
                    c: place(c),
                    code,
                }
            })
            .collect();
        // The safety argument of the unchecked loop (module docs), checked here once.
        for (i, ins) in code.iter().enumerate() {
            let own = (first + i) as u32;
            let binary = ins.code != Code::Powf;
            if ins.a >= own || (binary && ins.b >= own) || ins.c >= own {
                return Err(ExecError::Tape(TapeError::Malformed(format!(
                    "decoded instruction {i} reads a later slot"
                ))));
            }
            if ins.code == Code::Powf && (ins.b as usize >= dec.rationals.len() || ins.b >= 1 << 24)
            {
                return Err(ExecError::Tape(TapeError::Malformed("bad exponent".into())));
            }
        }
        let mut packed = Vec::new();
        let mut specials = Vec::new();
        for ins in &code {
            match ins.code {
                Code::Mul | Code::Add | Code::Sub => packed.push(pack2(ins.a, ins.b)),
                Code::Neg => {
                    let minus_zero = place(Slot::Const(minus_zero.expect("pooled")));
                    packed.push(pack2(minus_zero, ins.a))
                }
                Code::MulAdd | Code::MulSub | Code::SubMul => {
                    packed.push(pack3(ins.a, ins.b, ins.c))
                }
                code => specials.push(Special {
                    code,
                    a: ins.a,
                    b: ins.b,
                }),
            }
        }
        let outputs: Vec<u32> = tape
            .outputs
            .iter()
            .map(|r| place(slots[r.index()]))
            .collect();
        if outputs.iter().any(|&s| s as usize >= n_slots) {
            return Err(ExecError::Tape(TapeError::Malformed(
                "an output past the slots".into(),
            )));
        }
        Ok(Interpreter {
            common: Common::new(tape),
            consts: dec.consts,
            first,
            code,
            runs,
            packed,
            specials,
            rationals: dec.rationals,
            outputs,
            n_slots,
        })
    }

    /// Copies the inputs and constants into `w[..first]`, runs the instructions and copies
    /// the outputs.
    ///
    /// # Safety
    ///
    /// `w` points to `n_slots` writable values (initialised or not); the inputs have the
    /// lengths of `self.common.dims()` and the hoisted count, `out` the number of outputs.
    #[inline(always)]
    unsafe fn run(
        &self,
        w: *mut f64,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) {
        // SAFETY (whole body): see the module docs; the inputs (of the lengths of the tape's
        // dimensions) and the constants fill exactly the slots below `first`, instruction i
        // writes `first + i < n_slots` and reads slots below it.
        unsafe {
            let mut at = w;
            for input in [state, target, gains, hoisted, &self.consts] {
                copy_short(input, at);
                at = at.add(input.len());
            }
            debug_assert_eq!(at, w.add(self.first));
            let r = |s: usize| *w.add(s);
            let mut dst = w.add(self.first);
            // the runs' lengths add up to the instructions; those of the straight kinds to
            // `packed`, those of `Kind::Special` to `specials` (as decoded)
            let mut ops = self.packed.as_ptr();
            let mut special = self.specials.as_ptr();
            let mut jacobi = None;
            for run in &self.runs {
                let n = run.len as usize;
                match run.kind {
                    Kind::Mul => straight(ops, n, dst, |x| {
                        let (a, b) = unpack2(x);
                        r(a) * r(b)
                    }),
                    Kind::Add => straight(ops, n, dst, |x| {
                        let (a, b) = unpack2(x);
                        r(a) + r(b)
                    }),
                    Kind::Sub => straight(ops, n, dst, |x| {
                        let (a, b) = unpack2(x);
                        r(a) - r(b)
                    }),
                    Kind::MulAdd => straight(ops, n, dst, |x| {
                        let (a, b, c) = unpack3(x);
                        r(a) * r(b) + r(c)
                    }),
                    Kind::MulSub => straight(ops, n, dst, |x| {
                        let (a, b, c) = unpack3(x);
                        r(a) * r(b) - r(c)
                    }),
                    Kind::SubMul => straight(ops, n, dst, |x| {
                        let (a, b, c) = unpack3(x);
                        r(c) - r(a) * r(b)
                    }),
                    Kind::Special => {
                        for k in 0..n {
                            let s = &*special.add(k);
                            let (a, b) = (s.a as usize, s.b as usize);
                            // division and square root (the frequent ones) inline, the rest
                            // in a call; `b` is a slot unless the exponent's index (Powf)
                            *dst.add(k) = match s.code {
                                Code::Div => r(a) / r(b),
                                Code::Sqrt => r(a).sqrt(),
                                Code::Powf => self.special(s, r(a), 0.0, &mut jacobi),
                                _ => self.special(s, r(a), r(b), &mut jacobi),
                            };
                        }
                        special = special.add(n);
                    }
                }
                if run.kind != Kind::Special {
                    ops = ops.add(n);
                }
                dst = dst.add(n);
            }
            let r = |s: u32| r(s as usize);
            for (o, &s) in out.iter_mut().zip(&self.outputs) {
                *o = r(s);
            }
        }
    }

    /// An instruction off the straight path other than a division or a square root (those are
    /// inlined in `run`). `jacobi` holds the arguments and values of the last `ellipj` call of
    /// this evaluation, so sn, cn, dn of one (u | m) share it.
    #[inline(never)]
    fn special(&self, s: &Special, x: f64, y: f64, jacobi: &mut Option<(u64, u64, Jacobi)>) -> f64 {
        match s.code {
            Code::Cbrt => x.cbrt(),
            Code::Exp => x.exp(),
            Code::Ln => x.ln(),
            Code::Sin => x.sin(),
            Code::Cos => x.cos(),
            Code::EllipK => Func::EllipK.apply(x),
            Code::Sn | Code::Cn | Code::Dn => {
                let key = (x.to_bits(), y.to_bits());
                let j = match *jacobi {
                    Some((u, m, j)) if (u, m) == key => j,
                    _ => {
                        let j = ellipj(x, y);
                        *jacobi = Some((key.0, key.1, j));
                        j
                    }
                };
                match s.code {
                    Code::Sn => j.sn,
                    Code::Cn => j.cn,
                    _ => j.dn,
                }
            }
            Code::EllipF => Func2::EllipF.apply(x, y),
            Code::Powf => powf(x, self.rationals[s.b as usize]),
            Code::Add
            | Code::Sub
            | Code::Mul
            | Code::Neg
            | Code::MulAdd
            | Code::MulSub
            | Code::SubMul => {
                unreachable!("decoded: these take the straight path")
            }
            Code::Div | Code::Sqrt => unreachable!("inlined in `run`"),
        }
    }

    /// The body for k lanes into `w` (`n_slots·k` values), outputs into `out`.
    #[allow(clippy::too_many_arguments)]
    fn run_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        w: &mut [f64],
        out: &mut [f64],
    ) {
        // inputs: the state is already structure of arrays; the rest is shared by the lanes
        let (head, rest) = w.split_at_mut(state.len());
        head.copy_from_slice(state);
        let shared = target
            .iter()
            .chain(gains)
            .chain(hoisted)
            .chain(&self.consts);
        for (lanes, &v) in rest.chunks_exact_mut(k).zip(shared) {
            lanes.fill(v);
        }
        for (i, ins) in self.code.iter().enumerate() {
            let (src, dst) = w.split_at_mut((self.first + i) * k);
            let dst = &mut dst[..k];
            let lane = |s: u32| &src[s as usize * k..][..k];
            let a = lane(ins.a);
            match ins.code {
                Code::Add => map2(dst, a, lane(ins.b), |x, y| x + y),
                Code::Sub => map2(dst, a, lane(ins.b), |x, y| x - y),
                Code::Mul => map2(dst, a, lane(ins.b), |x, y| x * y),
                Code::Div => map2(dst, a, lane(ins.b), |x, y| x / y),
                Code::Neg => map1(dst, a, |x| -x),
                Code::MulAdd => map3(dst, a, lane(ins.b), lane(ins.c), |x, y, z| x * y + z),
                Code::MulSub => map3(dst, a, lane(ins.b), lane(ins.c), |x, y, z| x * y - z),
                Code::SubMul => map3(dst, a, lane(ins.b), lane(ins.c), |x, y, z| z - x * y),
                Code::Sqrt => map1(dst, a, f64::sqrt),
                Code::Cbrt => map1(dst, a, f64::cbrt),
                Code::Exp => map1(dst, a, f64::exp),
                Code::Ln => map1(dst, a, f64::ln),
                Code::Sin => map1(dst, a, f64::sin),
                Code::Cos => map1(dst, a, f64::cos),
                Code::EllipK => map1(dst, a, |x| Func::EllipK.apply(x)),
                Code::Sn => map2(dst, a, lane(ins.b), |x, m| Func2::Sn.apply(x, m)),
                Code::Cn => map2(dst, a, lane(ins.b), |x, m| Func2::Cn.apply(x, m)),
                Code::Dn => map2(dst, a, lane(ins.b), |x, m| Func2::Dn.apply(x, m)),
                Code::EllipF => map2(dst, a, lane(ins.b), |x, m| Func2::EllipF.apply(x, m)),
                Code::Powf => {
                    let p = self.rationals[ins.b as usize];
                    map1(dst, a, |x| powf(x, p))
                }
            }
        }
        for (j, &s) in self.outputs.iter().enumerate() {
            out[j * k..][..k].copy_from_slice(&w[s as usize * k..][..k]);
        }
    }
}

/// Copies `src` (a tape's input: a few values) to `dst` in at most two unaligned moves of
/// two, four or eight values, the second overlapping the first (a `memcpy` call, which is
/// what the compiler makes of a loop, costs more than the copy).
///
/// # Safety
///
/// `dst` points to `src.len()` writable values.
#[inline(always)]
unsafe fn copy_short(src: &[f64], dst: *mut f64) {
    /// `K` values from `s + i` to `d + i`.
    unsafe fn mov<const K: usize>(s: *const f64, d: *mut f64, i: usize) {
        // SAFETY: as the caller guarantees
        unsafe {
            let v = s.add(i).cast::<[f64; K]>().read_unaligned();
            d.add(i).cast::<[f64; K]>().write_unaligned(v);
        }
    }
    // SAFETY: every move is inside `src` and inside the `src.len()` values at `dst`
    unsafe {
        let (n, s) = (src.len(), src.as_ptr());
        match n {
            0 => {}
            1 => *dst = *s,
            2..4 => {
                mov::<2>(s, dst, 0);
                mov::<2>(s, dst, n - 2);
            }
            4..8 => {
                mov::<4>(s, dst, 0);
                mov::<4>(s, dst, n - 4);
            }
            8..16 => {
                mov::<8>(s, dst, 0);
                mov::<8>(s, dst, n - 8);
            }
            _ => std::ptr::copy_nonoverlapping(s, dst, n),
        }
    }
}

/// `dst[i] = f(ops[i])` for i < `len`, two at a time (half the loop overhead).
///
/// # Safety
///
/// `ops` and `dst` point to `len` values; `f` reads only slots written before (raw pointers:
/// the second of a pair may read the first's slot, which the order of the writes keeps).
#[inline(always)]
unsafe fn straight(ops: *const u64, len: usize, dst: *mut f64, f: impl Fn(u64) -> f64) {
    // SAFETY: as the caller guarantees
    unsafe {
        let mut i = 0;
        while i + 2 <= len {
            *dst.add(i) = f(*ops.add(i));
            *dst.add(i + 1) = f(*ops.add(i + 1));
            i += 2;
        }
        if i < len {
            *dst.add(i) = f(*ops.add(i));
        }
    }
}

/// The order in which to run `code`, and its runs: a topological order (every instruction
/// after those whose values it reads) that takes, from the instructions whose operands are
/// computed, all those of one kind at a time, with those that become ready meanwhile; the
/// specials first (they are the slow ones: the sooner they start, the more the processor
/// overlaps them), else the kind with the most ready instructions.
fn schedule(code: &[(Code, Slot, Slot, Slot)]) -> (Vec<usize>, Vec<Run>) {
    const KINDS: [Kind; 7] = [
        Kind::Special,
        Kind::Mul,
        Kind::Add,
        Kind::Sub,
        Kind::MulAdd,
        Kind::MulSub,
        Kind::SubMul,
    ];
    let kind = |i: usize| {
        let k = Kind::of(code[i].0);
        KINDS.iter().position(|&x| x == k).expect("a kind")
    };
    let mut users: Vec<Vec<usize>> = vec![Vec::new(); code.len()];
    let mut waiting = vec![0u32; code.len()];
    for (i, &(op, a, b, c)) in code.iter().enumerate() {
        let mut reads: Vec<usize> = [a, b, c]
            .into_iter()
            .enumerate()
            .filter_map(|(k, s)| match s {
                // `b` of Powf is the exponent's index
                Slot::Computed(j) if !(k == 1 && op == Code::Powf) => Some(j),
                _ => None,
            })
            .collect();
        reads.sort_unstable();
        reads.dedup();
        for j in reads {
            users[j].push(i);
            waiting[i] += 1;
        }
    }
    let mut ready: [std::collections::VecDeque<usize>; KINDS.len()] = Default::default();
    for (i, &w) in waiting.iter().enumerate() {
        if w == 0 {
            ready[kind(i)].push_back(i);
        }
    }
    let mut order = Vec::with_capacity(code.len());
    let mut runs = Vec::new();
    while order.len() < code.len() {
        let k = if ready[0].is_empty() {
            (1..KINDS.len())
                .rev()
                .max_by_key(|&k| ready[k].len())
                .expect("kinds")
        } else {
            0
        };
        let start = order.len();
        while let Some(i) = ready[k].pop_front() {
            order.push(i);
            for &u in &users[i] {
                waiting[u] -= 1;
                if waiting[u] == 0 {
                    ready[kind(u)].push_back(u);
                }
            }
        }
        // decoded operands come before their uses, so some instruction is always ready
        assert!(
            order.len() > start,
            "a decoded instruction reads a later one"
        );
        runs.push(Run {
            kind: KINDS[k],
            len: (order.len() - start) as u32,
        });
    }
    (order, runs)
}

/// `xⁿ` as [`lasalle_model::tape::powi`] computes it: the multiplications of the binary exponentiation (the first
/// square is taken as is), and `1 / r` for n < 0.
fn powi_slots(dec: &mut Decoder, x: Slot, n: i32) -> Slot {
    let mut bits = n.unsigned_abs();
    let mut square = x;
    let mut result: Option<Slot> = None;
    while bits != 0 {
        if bits & 1 == 1 {
            result = Some(match result {
                None => square,
                Some(r) => dec.push(Code::Mul, r, square),
            });
        }
        bits >>= 1;
        if bits != 0 {
            square = dec.push(Code::Mul, square, square);
        }
    }
    let r = match result {
        Some(r) => r,
        None => Slot::Const(dec.constant(1.0)),
    };
    if n < 0 {
        let one = Slot::Const(dec.constant(1.0));
        dec.push(Code::Div, one, r)
    } else {
        r
    }
}

#[inline(always)]
fn map1(dst: &mut [f64], a: &[f64], f: impl Fn(f64) -> f64) {
    for (d, &x) in dst.iter_mut().zip(a) {
        *d = f(x);
    }
}

#[inline(always)]
fn map3(dst: &mut [f64], a: &[f64], b: &[f64], c: &[f64], f: impl Fn(f64, f64, f64) -> f64) {
    for (((d, &x), &y), &z) in dst.iter_mut().zip(a).zip(b).zip(c) {
        *d = f(x, y, z);
    }
}

#[inline(always)]
fn map2(dst: &mut [f64], a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> f64) {
    for ((d, &x), &y) in dst.iter_mut().zip(a).zip(b) {
        *d = f(x, y);
    }
}

impl Interpreter {
    /// Runs on a stack buffer when the slots fit, else on the thread-local one.
    ///
    /// # Safety
    ///
    /// As [`Interpreter::run`], without the buffer.
    #[inline]
    unsafe fn eval_with_scratch(
        &self,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        out: &mut [f64],
    ) {
        if self.n_slots <= STACK_SLOTS {
            let mut buf = [MaybeUninit::<f64>::uninit(); STACK_SLOTS];
            // SAFETY: n_slots values fit; `run` writes each slot before reading it.
            unsafe { self.run(buf.as_mut_ptr().cast(), hoisted, state, target, gains, out) }
        } else {
            with_scratch(self.n_slots, |w| {
                // SAFETY: `w` has n_slots values.
                unsafe { self.run(w.as_mut_ptr(), hoisted, state, target, gains, out) }
            })
        }
    }
}

impl Kernel for Interpreter {
    fn dims(&self) -> Dims {
        self.common.dims()
    }

    fn n_outputs(&self) -> usize {
        self.common.n_outputs()
    }

    fn hoist(&self, params: &[f64]) -> Result<Vec<f64>, ExecError> {
        self.common.hoist(params)
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
        // SAFETY: `check` proved the lengths.
        unsafe { self.eval_with_scratch(hoisted, state, target, gains, out) };
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
        unsafe { self.eval_with_scratch(hoisted, state, target, gains, out) }
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
        if k == 0 {
            return Ok(());
        }
        // `check` proved state.len() = N·k, so N·k fits; the slots need their own check.
        let len = self.n_slots.checked_mul(k).ok_or(TapeError::TooLarge)?;
        with_scratch(len, |w| {
            self.run_lanes(k, hoisted, state, target, gains, w, out)
        });
        Ok(())
    }
}

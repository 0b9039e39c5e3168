//! The module `kernels` of an emitted model: f64 kernels generated from the model's tapes
//! ([`ModelTapes`]) rather than from the symbolic graph. The preludes of the tapes
//! (`kernels::Prelude`, computed by `<Model>::prepare` and kept in the prepared model), the
//! Taylor-coefficient kernels of the field and of X − ∇V (`kernels::TaylorField`,
//! `kernels::TaylorFeedback`, see [`lasalle_runtime::taylor`]) and the batched evaluation of
//! every function for K states per call (`kernels::Lanes`, see [`super::lanes`]).
//!
//! Both start from the tapes so that they compute what the tape interpreter and the JIT
//! compute, bitwise: the tape is lowered exactly as the emitter writes the scalar functions
//! (see [`crate::tape`]), so each lane of a batch equals the scalar emitted function, and
//! the Taylor kernels run the lowering of [`TaylorProgram`] with the recurrence functions
//! of `lasalle_runtime::taylor::rec`, exactly as `lasalle_exec::TaylorTape` interprets it.
//!
//! The module is written as formatted text and appended to the formatted items, with one
//! header and one `allow` (unused registers, clippy) for all of it: its items are
//! straight-line code over numbered registers and table rows (`t[12][k]`), in which readable
//! names would not help, and formatting them with `prettyplease` would take most of the
//! generation time of a large model (5× the rest for 20 000 `let`s).
//!
//! # The emitted Taylor kernel
//!
//! Per field, a `Recurrences` impl (`kernels::FieldRecurrences`: sizes, the prepared model's
//! prelude and the coefficient loop); the runtime's generic `taylor::Emitted<R>` is the
//! kernel and owns the inputs and the table `[[f64; P + 1]; ROWS]` with
//! P = [`lasalle_runtime::taylor::EMITTED_MAX_ORDER`], allocated once. `compute` is one loop
//! over the order k. Order 0 is the straight-line f64 code of every recurrence. Order k ≥ 1
//! first computes the early sums ([`TaylorProgram::early_sums`]: `rec::cauchy_many`, one
//! loop per group of up to [`EARLY_GROUP`] sums), then calls the recurrence function of each
//! non-constant instruction on constant row indices (`rec::mul_after`, `square_after` or
//! `sqrt_after` for those given their early sum). The early sums took the compiled kernels'
//! Taylor runs (`cargo bench --bench taylor`, quiet, 2026-11-25) from 0.0408 to 0.036 s on
//! Kepler (1000 periods) and from 0.0079 to 0.0067 s on the rigid body (t = 1000), at the
//! same coefficients bitwise (`tests/tape_kernels.rs`). Passing the rows as slices instead
//! of the table and row indices made the rigid body's 0.0091–0.0156 s: the twelve slices did
//! not stay in registers.
//!
//! [`lasalle_runtime::taylor`]: https://docs.rs/lasalle-runtime
//! [`lasalle_runtime::taylor::EMITTED_MAX_ORDER`]: https://docs.rs/lasalle-runtime

use super::Emitter;
use crate::ir::{Func2, Input};
use crate::tape::taylor::{Leaf, PowZero, Rec, TaylorProgram, EARLY_GROUP};
use crate::tape::{ModelTapes, Op, Tape};
use proc_macro2::TokenStream;
use std::fmt::Write;

/// An f64 literal that reads back to the same bits (`2.5_f64`, `(-1e-7_f64)`).
pub(super) fn f64_lit(x: f64) -> String {
    if x.is_nan() {
        "f64::NAN".into()
    } else if x.is_infinite() {
        if x > 0.0 {
            "f64::INFINITY"
        } else {
            "f64::NEG_INFINITY"
        }
        .into()
    } else if x.is_sign_negative() {
        format!("-{:?}_f64", -x)
    } else {
        format!("{x:?}_f64")
    }
}

/// The f64 expression of a non-leaf tape instruction over the operand expressions `r(reg)`.
pub(super) fn op_expr(op: &Op, r: impl Fn(crate::tape::Reg) -> String) -> String {
    match *op {
        Op::Add(a, b) => format!("{} + {}", r(a), r(b)),
        Op::Sub(a, b) => format!("{} - {}", r(a), r(b)),
        Op::Mul(a, b) => format!("{} * {}", r(a), r(b)),
        Op::Div(a, b) => format!("{} / {}", r(a), r(b)),
        Op::Neg(a) => format!("-{}", r(a)),
        Op::Powi(a, n) => format!("{}.powi({n})", r(a)),
        Op::Sqrt(a) => format!("{}.sqrt()", r(a)),
        Op::Cbrt(a) => format!("{}.cbrt()", r(a)),
        Op::Powf(a, p) => format!("{}.powf({})", r(a), f64_lit(p.to_f64())),
        Op::Exp(a) => format!("{}.exp()", r(a)),
        Op::Ln(a) => format!("{}.ln()", r(a)),
        Op::Sin(a) => format!("{}.sin()", r(a)),
        Op::Cos(a) => format!("{}.cos()", r(a)),
        Op::EllipK(m) => format!("lasalle_runtime::elliptic::ellipk({})", r(m)),
        Op::Func2(Func2::EllipF, a, m) => {
            format!("lasalle_runtime::elliptic::ellipf({}, {})", r(a), r(m))
        }
        Op::Func2(f, a, m) => format!(
            "lasalle_runtime::elliptic::ellipj({}, {}).{}",
            r(a),
            r(m),
            f.name()
        ),
        Op::State(_)
        | Op::Param(_)
        | Op::Target(_)
        | Op::Gain(_)
        | Op::Hoisted(_)
        | Op::Const(_) => unreachable!("leaves are rendered by the caller"),
    }
}

/// One tape's prelude (parameter slots `p` → its hoisted values), f64 op for f64 op as
/// `Tape::hoist`: a block of `let`s ending in the array of hoisted values.
pub(super) fn prelude_block(tape: &Tape) -> String {
    let mut s = String::from("{\n");
    for (i, op) in tape.prelude.iter().enumerate() {
        let e = match *op {
            Op::Param(k) => format!("p[{k}]"),
            Op::Const(c) => f64_lit(c),
            _ => op_expr(op, |r| format!("p{}", r.0)),
        };
        let _ = writeln!(s, "    let p{i}: f64 = {e};");
    }
    let hs: Vec<String> = tape.hoisted.iter().map(|r| format!("p{}", r.0)).collect();
    let _ = write!(s, "    [{}]\n}}", hs.join(", "));
    s
}

/// Indents every non-empty line of `text` by `by` spaces.
fn indent(text: &str, by: usize) -> String {
    text.lines()
        .map(|l| {
            if l.is_empty() {
                "\n".to_string()
            } else {
                format!("{:by$}{l}\n", "")
            }
        })
        .collect()
}

impl Emitter<'_> {
    /// The module `kernels`, formatted: the parameter slots as f64, the preludes of the tapes
    /// (`Prelude`, a field of the prepared model), the Taylor kernels and the lanes.
    pub fn tape_items(&mut self, tapes: &ModelTapes) -> crate::Result<String> {
        let ty = self.ty.to_string();
        let prep = self.prepared_ty.to_string();
        let np = self.model.param_slots();
        let slots: Vec<String> = (0..np)
            .map(|k| {
                let e = self.leaves.input(Input::Param(k as u32)).1.to_string();
                format!("{}.to_f64().unwrap_or(f64::NAN)", e.replace(' ', ""))
            })
            .collect();
        let all = tapes.all();
        let prelude_fields: String = all
            .iter()
            .map(|(name, tape)| format!("    {name}: [f64; {}],\n", tape.hoisted.len()))
            .collect();
        let prelude_inits: String = all
            .iter()
            .map(|(name, tape)| {
                let block = indent(&prelude_block(tape), 12);
                format!("            {name}: {},\n", block.trim())
            })
            .collect();
        let mut s = format!(
            "impl<T: Float> super::{ty}<T> {{
    /// The parameter slots as f64, in the order of `PARAMS` (matrices column-major).
    pub fn slot_values(&self) -> [f64; {np}] {{
        [{slots}]
    }}
}}

/// The parameter-only values of every tape (its prelude) in f64, computed once by
/// `{ty}::prepare` (a field of the prepared model), read by the Taylor kernels and the lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prelude {{
{prelude_fields}}}

impl Prelude {{
    /// The preludes of every tape from the parameter slots, f64 op for f64 op as the tapes'.
    pub fn new(p: &[f64; {np}]) -> Self {{
        Prelude {{
{prelude_inits}        }}
    }}
}}

impl<T: Float> super::{prep}<T> {{
    /// The adaptive Taylor integrator (Jorba & Zou; `lasalle_runtime::taylor`) of the field
    /// and of X − ∇V over this model's emitted kernels.
    pub fn taylor(
        &self,
        opts: lasalle_runtime::TaylorOptions,
    ) -> Result<lasalle_runtime::Taylor<Self>, lasalle_runtime::TaylorError> {{
        lasalle_runtime::Taylor::new(taylor_kernels(self), opts)
    }}

    /// The model's functions for K states per call, with this model's parameters.
    pub fn lanes(&self) -> Lanes {{
        Lanes {{ prelude: self.kernels }}
    }}
}}

/// The emitted Taylor kernels of the field and of X − ∇V.
pub fn taylor_kernels<T: Float>(
    m: &super::{prep}<T>,
) -> lasalle_runtime::TaylorKernels<super::{prep}<T>> {{
    lasalle_runtime::TaylorKernels {{
        field: Box::new(TaylorField::new(m)),
        feedback: Box::new(TaylorFeedback::new(m)),
    }}
}}
",
            slots = slots.join(", ")
        );
        let field = TaylorProgram::new(&tapes.field).map_err(internal)?;
        let feedback = TaylorProgram::new(&tapes.feedback).map_err(internal)?;
        s.push_str(&self.taylor_kernel(
            ("TaylorField", "FieldRecurrences"),
            "field",
            "X",
            &tapes.field,
            &field,
        ));
        s.push_str(&self.taylor_kernel(
            ("TaylorFeedback", "FeedbackRecurrences"),
            "feedback",
            "X − ∇V",
            &tapes.feedback,
            &feedback,
        ));
        s.push_str(&super::lanes::lanes_items(&prep, tapes));
        let doc = format!(
            "\n/// The machine kernels of `{ty}`, generated from its tapes rather than written from its
/// formulas: the parameter-only values of every function in f64 ([`Prelude`](kernels::Prelude),
/// a field of [`{prep}`]), the Taylor-coefficient kernels of X and X − ∇V
/// ([`TaylorField`](kernels::TaylorField), [`TaylorFeedback`](kernels::TaylorFeedback)) and
/// every function for K states per call ([`Lanes`](kernels::Lanes)). Straight-line code over numbered registers and table rows, each operation the
/// IEEE operation of the functions above, so that they agree bitwise with them, with the JIT
/// and with the tape interpreter; not meant to be read.
pub mod kernels {{
    #![allow(unused_variables, clippy::all)]
    use lasalle_runtime::num_traits::Float;

"
        );
        Ok(format!("{doc}{}}}\n", indent(&s, 4)))
    }

    /// The `TaylorKernel` hook of the `Declared` impl.
    pub fn taylor_hook(&self) -> TokenStream {
        quote::quote! {
            fn taylor_kernels(&self, _max_order: u32) -> Result<lasalle_runtime::TaylorKernels<Self>, lasalle_runtime::TaylorError> {
                Ok(kernels::taylor_kernels(self))
            }
        }
    }

    /// The recurrences of one field (`Recurrences` of the runtime, whose `Emitted` makes the
    /// kernel) and the kernel's name.
    fn taylor_kernel(
        &self,
        (kernel, recurrences): (&str, &str),
        prelude: &str,
        what: &str,
        tape: &Tape,
        program: &TaylorProgram,
    ) -> String {
        let (ty, prep) = (self.ty.to_string(), self.prepared_ty.to_string());
        let d = tape.dims;
        let (n, nh, nt, ng, rows) = (
            d.state,
            tape.hoisted.len(),
            d.targets,
            d.gains,
            program.rows,
        );
        let indent = |line: String| {
            line.lines()
                .map(|l| format!("                {l}\n"))
                .collect::<String>()
        };
        let mut zeroth = String::new();
        let mut higher = String::new();
        let groups = program.early_sums(EARLY_GROUP);
        let mut early = vec![false; program.recs.len()];
        for (span, group) in &groups {
            let names: Vec<String> = group.iter().map(|e| format!("e{}", e.d)).collect();
            let rows: Vec<String> = group
                .iter()
                .map(|e| format!("({}, {})", e.a, e.b))
                .collect();
            higher.push_str(&indent(format!(
                "let [{}] =\n    rec::cauchy_many(t, [{}], k, 1, {});\n",
                names.join(", "),
                rows.join(", "),
                span.hi_source()
            )));
            for e in group {
                early[e.rec] = true;
            }
        }
        for (i, &(rec, constant)) in program.recs.iter().enumerate() {
            zeroth.push_str(&indent(zeroth_line(rec)));
            if !constant {
                higher.push_str(&indent(coefficient_line(rec, early[i])));
            }
        }
        let outputs: String = program
            .outputs
            .iter()
            .enumerate()
            .map(|(i, o)| format!("            t[{i}][k + 1] = t[{o}][k] * inv;\n"))
            .collect();
        // a field without products, quotients or functions (linear) needs no helper of `rec`
        let imports = if zeroth.contains("rec::") || higher.contains("rec::") {
            "{rec, EMITTED_MAX_ORDER}"
        } else {
            "EMITTED_MAX_ORDER"
        };
        format!(
            r#"/// The Taylor-coefficient kernel of {what} (`lasalle_runtime::TaylorKernel`).
pub type {kernel} = lasalle_runtime::taylor::Emitted<{recurrences}>;
/// The recurrences of {what}'s tape (`lasalle_runtime::taylor::Recurrences`), {rows} rows of
/// orders 0..=`EMITTED_MAX_ORDER`.
pub struct {recurrences};
impl<T: Float> lasalle_runtime::taylor::Recurrences<super::{prep}<T>> for {recurrences} {{
    const NAME: &'static str = "{ty}: {kernel}";
    const DIM: usize = {n};
    const ROWS: usize = {rows};
    const HOISTED: usize = {nh};
    const TARGETS: usize = {nt};
    const GAINS: usize = {ng};
    fn hoisted(m: &super::{prep}<T>) -> &[f64] {{
        &m.kernels.{prelude}
    }}
    fn compute(
        t: &mut [[f64; lasalle_runtime::taylor::EMITTED_MAX_ORDER + 1]],
        hoisted: &[f64],
        target: &[f64],
        gains: &[f64],
        x: &[f64],
        order: usize,
    ) {{
        use lasalle_runtime::taylor::{imports};
        let t: &mut [[f64; EMITTED_MAX_ORDER + 1]; {rows}] = t.try_into().expect("rows: {rows}");
        let hoisted: &[f64; {nh}] = hoisted.try_into().expect("hoisted values: {nh}");
        let target: &[f64; {nt}] = target.try_into().expect("targets: {nt}");
        let gains: &[f64; {ng}] = gains.try_into().expect("gains: {ng}");
        for (row, xi) in t.iter_mut().zip(&x[..{n}]) {{
            row[0] = *xi;
        }}
        for k in 0..order {{
            if k == 0 {{
{zeroth}            }} else {{
{higher}            }}
            let inv = 1.0 / (k as f64 + 1.0);
{outputs}        }}
    }}
}}
"#
        )
    }
}

fn internal(e: crate::tape::TapeError) -> crate::Error {
    crate::Error::Internal(format!("the tape of the field: {e}"))
}

/// Order 0 of a recurrence: the f64 operation of the tape.
fn zeroth_line(r: Rec) -> String {
    let z = |row: usize| format!("t[{row}][0]");
    let (d, e) = match r {
        Rec::Leaf { d, leaf } => (
            d,
            match leaf {
                Leaf::Const(c) => f64_lit(c),
                Leaf::Hoisted(k) => format!("hoisted[{k}]"),
                Leaf::Target(k) => format!("target[{k}]"),
                Leaf::Gain(k) => format!("gains[{k}]"),
            },
        ),
        Rec::Add { d, a, b } => (d, format!("{} + {}", z(a), z(b))),
        Rec::Sub { d, a, b } => (d, format!("{} - {}", z(a), z(b))),
        Rec::Neg { d, a } => (d, format!("-{}", z(a))),
        Rec::Mul { d, a, b } => (d, format!("{} * {}", z(a), z(b))),
        Rec::Scale { d, a, c } => (d, format!("{} * {}", z(a), z(c))),
        Rec::Square { d, a } => (d, format!("{} * {}", z(a), z(a))),
        Rec::Div { d, a, b } | Rec::DivConst { d, a, c: b } => (d, format!("{} / {}", z(a), z(b))),
        Rec::Pow { d, a, zero, .. } => (
            d,
            match zero {
                PowZero::Cbrt => format!("{}.cbrt()", z(a)),
                PowZero::Powf(p) => format!("{}.powf({})", z(a), f64_lit(p)),
                // order 0 is the fused chain's
                PowZero::Fused => return String::new(),
            },
        ),
        Rec::Sqrt { d, a } => (d, format!("{}.sqrt()", z(a))),
        Rec::Exp { d, a } => (d, format!("{}.exp()", z(a))),
        Rec::Ln { d, a } => (d, format!("{}.ln()", z(a))),
        Rec::SinCos { s, c, a } => {
            return format!(
                "let (s, c) = {}.sin_cos();\nt[{s}][0] = s;\nt[{c}][0] = c;\n",
                z(a)
            )
        }
        Rec::Jacobi {
            rows: [sn, cn, dn, cd, sd, sc],
            a,
            m,
        } => {
            return format!(
                "let j = lasalle_runtime::elliptic::ellipj({}, {});\n\
                 t[{sn}][0] = j.sn;\nt[{cn}][0] = j.cn;\nt[{dn}][0] = j.dn;\n\
                 t[{cd}][0] = j.cn * j.dn;\nt[{sd}][0] = j.sn * j.dn;\nt[{sc}][0] = j.sn * j.cn;\n",
                z(a),
                z(m)
            )
        }
        Rec::EllipK { d, a } => (d, format!("lasalle_runtime::elliptic::ellipk({})", z(a))),
        Rec::EllipF { d, a, m, .. } => (
            d,
            format!("lasalle_runtime::elliptic::ellipf({}, {})", z(a), z(m)),
        ),
    };
    format!("t[{d}][0] = {e};\n")
}

/// Order k ≥ 1 of a non-constant recurrence, by `lasalle_runtime::taylor::rec`; `early`: from
/// its early sum `e{d}` ([`TaylorProgram::early_sums`]).
fn coefficient_line(r: Rec, early: bool) -> String {
    const REC: &str = "rec";
    let (d, e) = match r {
        Rec::Mul { d, a, b } if early => (d, format!("{REC}::mul_after(e{d}, &t[{a}], &t[{b}], k)")),
        Rec::Square { d, a } if early => (d, format!("{REC}::square_after(e{d}, &t[{a}], k)")),
        Rec::Sqrt { d, a } if early => (d, format!("{REC}::sqrt_after(e{d}, &t[{a}], &t[{d}], k)")),
        Rec::Leaf { .. } => return String::new(),
        Rec::Add { d, a, b } => (d, format!("t[{a}][k] + t[{b}][k]")),
        Rec::Sub { d, a, b } => (d, format!("t[{a}][k] - t[{b}][k]")),
        Rec::Neg { d, a } => (d, format!("-t[{a}][k]")),
        Rec::Mul { d, a, b } => (d, format!("{REC}::mul(&t[{a}], &t[{b}], k)")),
        Rec::Scale { d, a, c } => (d, format!("t[{a}][k] * t[{c}][0]")),
        Rec::Square { d, a } => (d, format!("{REC}::square(&t[{a}], k)")),
        Rec::Div { d, a, b } => (d, format!("{REC}::div(&t[{a}], &t[{b}], &t[{d}], k)")),
        Rec::DivConst { d, a, c } => (d, format!("t[{a}][k] / t[{c}][0]")),
        Rec::Pow { d, a, alpha, .. } => (
            d,
            format!("{REC}::pow(&t[{a}], &t[{d}], {}, k)", f64_lit(alpha)),
        ),
        Rec::Sqrt { d, a } => (d, format!("{REC}::sqrt(&t[{a}], &t[{d}], k)")),
        Rec::Exp { d, a } => (d, format!("{REC}::exp(&t[{a}], &t[{d}], k)")),
        Rec::Ln { d, a } => (d, format!("{REC}::ln(&t[{a}], &t[{d}], k)")),
        Rec::SinCos { s, c, a } => {
            return format!(
                "let (s, c) = {REC}::sin_cos(&t[{a}], &t[{s}], &t[{c}], k);\nt[{s}][k] = s;\nt[{c}][k] = c;\n"
            )
        }
        Rec::Jacobi {
            rows: [sn, cn, dn, cd, sd, sc],
            a,
            m,
        } => {
            return format!(
                "let (s, c, d) = {REC}::jacobi(&t[{a}], &t[{cd}], &t[{sd}], &t[{sc}], t[{m}][0], k);\n\
                 t[{sn}][k] = s;\nt[{cn}][k] = c;\nt[{dn}][k] = d;\n\
                 t[{cd}][k] = {REC}::mul(&t[{cn}], &t[{dn}], k);\n\
                 t[{sd}][k] = {REC}::mul(&t[{sn}], &t[{dn}], k);\n\
                 t[{sc}][k] = {REC}::mul(&t[{sn}], &t[{cn}], k);\n"
            )
        }
        Rec::EllipK { .. } => return String::new(),
        Rec::EllipF { d, a, w, .. } => (d, format!("{REC}::chain(&t[{a}], &t[{w}], k)")),
    };
    format!("t[{d}][k] = {e};\n")
}

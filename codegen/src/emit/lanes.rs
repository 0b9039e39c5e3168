//! Batched evaluation: every function of a compiled model for K states per call, structure of
//! arrays, emitted from the model's tapes.
//!
//! `<Model>Prepared::lanes(&self)` returns a `kernels::Lanes` over the prepared model's
//! preludes (the parameter-only values of every tape, computed once by `prepare`), whose methods (`field`, `invariants`, `jacobian`,
//! `lyapunov`, `lyapunov_gradient`, `feedback`, and `hamiltonian`, `field_q`, `field_p` when
//! the model has them) take `x: &[[f64; K]; N]` (component i of lane l at `x[i][l]`, the
//! layout of `lasalle_exec::Kernel::eval_lanes` with k = K) and write `out: &mut [[f64; K];
//! OUT]`; targets and gains are shared by the lanes, as in the JIT.
//!
//! # Why arrays of lanes, not a SIMD scalar type
//!
//! Every tape register becomes a `[f64; K]` computed by one loop over the lanes
//! (`core::array::from_fn(|l| r3[l] * r4[l])`), with K a const generic: LLVM unrolls the
//! loop and turns it into packed SSE2/AVX instructions (`mulpd`, `divpd`, `sqrtpd`), while
//! transcendental functions stay per-lane calls. A lane type implementing `num_traits::Float`
//! for the generic emitted functions would need comparisons, `max`, and the rest of `Float`
//! on vectors, whose meaning is per lane only in part (`PartialOrd`), and would route the
//! emitted code through dozens of trait methods; the tape already is the straight-line
//! program of every function, and each of its instructions is the scalar emitted code's
//! IEEE operation, so every lane equals the scalar function bitwise.

use super::taylor::{f64_lit, op_expr};
use crate::tape::{ModelTapes, Op, Tape};
use std::fmt::Write;

/// The `Lanes` struct and its methods, formatted (`<Model>Prepared::lanes` makes one).
pub(super) fn lanes_items(prep: &str, tapes: &ModelTapes) -> String {
    let mut s = format!(
        "/// The model's functions for K states per call (structure of arrays), reading the
/// parameter-only values of [`{prep}`](super::{prep}): see `{prep}::lanes`.
#[derive(Clone, Debug)]
pub struct Lanes {{
    prelude: Prelude,
}}

impl Lanes {{
"
    );
    for (name, tape) in &tapes.all() {
        s.push_str(&lanes_fn(name, tape));
    }
    s.push_str("}\n");
    s
}

/// One batched function: a `[f64; K]` per tape register.
fn lanes_fn(name: &str, tape: &Tape) -> String {
    let d = tape.dims;
    let (n, nout) = (d.state, tape.outputs.len());
    let inputs = if d.targets + d.gains > 0 {
        format!(
            "\n        target: &[f64; {}],\n        gains: &[f64; {}],",
            d.targets, d.gains
        )
    } else {
        String::new()
    };
    let mut s = format!(
        "    /// `{name}` for K states: `x[i][l]` is component i of lane l, `out[j][l]` output j
    /// of lane l; each lane equals the scalar function bitwise.
    pub fn {name}<const K: usize>(
        &self,
        x: &[[f64; K]; {n}],{inputs}
        out: &mut [[f64; K]; {nout}],
    ) {{
        let h = &self.prelude.{name};
"
    );
    for (i, op) in tape.body.iter().enumerate() {
        let e = match *op {
            Op::State(k) => format!("x[{k}]"),
            Op::Const(c) => format!("[{}; K]", f64_lit(c)),
            Op::Hoisted(k) => format!("[h[{k}]; K]"),
            Op::Target(k) => format!("[target[{k}]; K]"),
            Op::Gain(k) => format!("[gains[{k}]; K]"),
            Op::Param(_) => unreachable!("a validated tape reads parameters in its prelude only"),
            _ => format!(
                "core::array::from_fn(|l| {})",
                op_expr(op, |r| format!("r{}[l]", r.0))
            ),
        };
        let _ = writeln!(s, "        let r{i}: [f64; K] = {e};");
    }
    for (j, r) in tape.outputs.iter().enumerate() {
        let _ = writeln!(s, "        out[{j}] = r{};", r.0);
    }
    s.push_str("    }\n");
    s
}

//! A field tape lowered to Taylor-coefficient recurrences, the [`TaylorProgram`]: one [`Rec`]
//! per instruction over rows of a coefficient table, the one program of every Taylor back end
//! — the interpreted kernel (`lasalle_exec::TaylorTape`), the JIT's
//! (`lasalle_exec::jit::taylor`) and the emitted kernels of compiled models
//! (`lasalle_codegen`'s `emit::taylor`) — which therefore run the same recurrences
//! (`lasalle_runtime::taylor::rec`) in the same order and agree bitwise. The driver, the
//! kernel interface and the error of the Taylor method are `lasalle_runtime::taylor`'s.
//!
//! Rows: the state components first (row i is x_i), then one row per body register that is
//! not a state leaf, and internal rows (the cosine partner of a lone sine, the squares of a
//! `powi`, the constant 1). Sine and cosine of the same operand share one [`Rec::SinCos`].
//! `powi` is expanded into the squares and products `f64::powi` performs ([`super::powi`];
//! the squares of one base are shared: the perturbed Kepler problem's `powi(u, 2)` and
//! `powi(u, 4)` = (u²)², u = 1/r, compute u² once),
//! then 1/· by the division recurrence for a negative exponent, so the order-0 values are the
//! tape's bitwise and a base with a^\[0\] = 0 is fine for a positive exponent. sn, cn, dn of
//! one (u | m) share one [`Rec::Jacobi`] (with the products cn·dn, sn·dn, sn·cn their
//! recurrences read); F(φ | m) gets rows for sin φ, cos φ, sin²φ, m sin²φ, 1 − m sin²φ and
//! w = (1 − m sin²φ)^(−1/2), F′ = w φ′. The parameter m must be constant along the solution,
//! as the model language guarantees.
//!
//! An instruction whose operands are all constant along the solution (leaves other than the
//! state, and instructions of those) is marked `constant`: only its order 0 is computed.
//!
//! # Fused powers
//!
//! A gravitational field's μ/r³ is, on the tape, r = √s, `powi(r, 3)` = r²·r and μ/r³: a
//! square-root, a square, a product and a quotient recurrence (≈ 6 half sums of k terms at
//! order k). The same value is C·s^β with C = μ, β = −3/2, which the power recurrence
//! u^\[k\] = 1/(k s^\[0\]) Σ_{j=0}^{k−1} (β(k−j) − j) s^\[k−j\] u^\[j\] computes alone (≈ 3 half
//! sums: k terms of two products): it follows from s u′ = β s′ u, which is linear in u, so it
//! holds for any constant factor C, and it needs only s and u^\[0\]. So [`TaylorProgram::new`]
//! finds the *power chains*: a square root √s (s not constant) continued by `powi(·, n)`
//! (n ≠ 0, 1) and c/· (c constant), each register of which is C·s^β. Above order 0 each
//! register of a chain is computed by its own recurrence (which needs its operand's higher
//! coefficients), by the power recurrence on s ([`Rec::Pow`] with [`PowZero::Fused`]), or not
//! at all if nothing outside the chain reads it; the cheapest choice over each chain's tree
//! is taken (costs per order in half sums: a folded square or square root 1, a product or
//! quotient 2, the power recurrence 3; ties keep the own recurrence).
//!
//! **Order 0 stays the tape's, bitwise**: every instruction of a chain still computes its
//! order 0 by its own f64 operation (its recurrences are then marked order-0-only, as
//! constants are), and the fused power recurrence runs for k ≥ 1 only, from that u^\[0\]. So
//! the field (x^\[1\]) and everything at order 0 are unchanged (`order_one_is_the_field_bitwise`
//! in `exec/tests/taylor.rs`), and the higher coefficients differ from the unfused program's
//! ([`TaylorProgram::unfused`]) by rounding only, the fused ones being the more accurate:
//! against 50-digit coefficients (mpmath) at orders 1–20, t^(3/2) is within 1–3 ulps fused
//! and 12–27 unfused, (1 + t²)^(−3/2) within 33–111 and 73–655, at t = 0.3, 0.7, 1.1.
//! Kepler's field becomes three squares, one power and three products; the CR3BP's two
//! 1/r³ are fused alike; the perturbed Kepler problem's 1/r (read by r⁻² and r⁻⁴, and
//! elsewhere) keeps its recurrences (no cheaper assignment).

//!
//! # Early sums
//!
//! Most of a product's order k, Σ_{j=1}^{k−1} a^\[j\] b^\[k−j\] (all but its two newest
//! terms, which the recurrence adds last), reads only orders below k, and so do the folded
//! sums of squares and square roots. [`TaylorProgram::early_sums`] groups them, sums sharing
//! a row together, so that a kernel can compute each group at the start of the order in one
//! loop: a shared row is loaded once per term instead of once per sum, and the group's
//! independent chains of additions overlap instead of waiting on one another. Each sum is
//! still accumulated alone, from its first term upwards, so the coefficients are bitwise
//! those of the recurrences computed one by one (`rec::cauchy_many` in the emitted kernels,
//! `Emit::early_sums` of `lasalle_exec::jit::taylor`).

use super::{Op, Reg, Tape, TapeError};
use crate::ir::Func2;
use std::collections::HashMap;

/// One recurrence; the fields are row indices (`d` the result).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rec {
    /// A leaf constant along the solution.
    Leaf {
        /// Result row.
        d: usize,
        /// Its order-0 value.
        leaf: Leaf,
    },
    /// a + b
    Add {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// Operand.
        b: usize,
    },
    /// a − b
    Sub {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// Operand.
        b: usize,
    },
    /// −a
    Neg {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
    },
    /// a · b, the Cauchy product.
    Mul {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// Operand.
        b: usize,
    },
    /// a · c with c constant along the solution.
    Scale {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// The constant's row.
        c: usize,
    },
    /// a · a (the symmetric Cauchy product).
    Square {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
    },
    /// a / b
    Div {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// Operand.
        b: usize,
    },
    /// a / c with c constant along the solution.
    DivConst {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// The constant's row.
        c: usize,
    },
    /// a^α by the power recurrence.
    Pow {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// The exponent.
        alpha: f64,
        /// How the order-0 value is computed.
        zero: PowZero,
    },
    /// √a
    Sqrt {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
    },
    /// eᵃ
    Exp {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
    },
    /// ln a
    Ln {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
    },
    /// sin a and cos a together.
    SinCos {
        /// Row of sin a.
        s: usize,
        /// Row of cos a.
        c: usize,
        /// Operand.
        a: usize,
    },
    /// sn, cn, dn of (a | m) together, m constant along the solution, with the products
    /// cn·dn, sn·dn, sn·cn their recurrences read (s' = c d a', c' = −s d a', d' = −m s c a').
    Jacobi {
        /// Rows of sn, cn, dn, cn·dn, sn·dn, sn·cn, in this order.
        rows: [usize; 6],
        /// Operand.
        a: usize,
        /// The parameter's row (constant).
        m: usize,
    },
    /// K(a), a constant along the solution (order 0 only).
    EllipK {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
    },
    /// F(a | m), m constant: u' = w a' with w = (1 − m sin²a)^(−1/2) computed by earlier rows.
    EllipF {
        /// Result row.
        d: usize,
        /// Operand.
        a: usize,
        /// The parameter's row (constant).
        m: usize,
        /// The row of w.
        w: usize,
    },
}

impl Rec {
    /// The same recurrence with every row `r` it names replaced by `f(r)` (to place a program's
    /// rows in a table shared with other programs).
    pub fn map_rows(self, f: impl Fn(usize) -> usize) -> Rec {
        match self {
            Rec::Leaf { d, leaf } => Rec::Leaf { d: f(d), leaf },
            Rec::Add { d, a, b } => Rec::Add {
                d: f(d),
                a: f(a),
                b: f(b),
            },
            Rec::Sub { d, a, b } => Rec::Sub {
                d: f(d),
                a: f(a),
                b: f(b),
            },
            Rec::Neg { d, a } => Rec::Neg { d: f(d), a: f(a) },
            Rec::Mul { d, a, b } => Rec::Mul {
                d: f(d),
                a: f(a),
                b: f(b),
            },
            Rec::Scale { d, a, c } => Rec::Scale {
                d: f(d),
                a: f(a),
                c: f(c),
            },
            Rec::Square { d, a } => Rec::Square { d: f(d), a: f(a) },
            Rec::Div { d, a, b } => Rec::Div {
                d: f(d),
                a: f(a),
                b: f(b),
            },
            Rec::DivConst { d, a, c } => Rec::DivConst {
                d: f(d),
                a: f(a),
                c: f(c),
            },
            Rec::Pow { d, a, alpha, zero } => Rec::Pow {
                d: f(d),
                a: f(a),
                alpha,
                zero,
            },
            Rec::Sqrt { d, a } => Rec::Sqrt { d: f(d), a: f(a) },
            Rec::Exp { d, a } => Rec::Exp { d: f(d), a: f(a) },
            Rec::Ln { d, a } => Rec::Ln { d: f(d), a: f(a) },
            Rec::SinCos { s, c, a } => Rec::SinCos {
                s: f(s),
                c: f(c),
                a: f(a),
            },
            Rec::Jacobi { rows, a, m } => Rec::Jacobi {
                rows: rows.map(&f),
                a: f(a),
                m: f(m),
            },
            Rec::EllipK { d, a } => Rec::EllipK { d: f(d), a: f(a) },
            Rec::EllipF { d, a, m, w } => Rec::EllipF {
                d: f(d),
                a: f(a),
                m: f(m),
                w: f(w),
            },
        }
    }
}

/// Sources of the order-0 value of a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Leaf {
    /// A number.
    Const(f64),
    /// A hoisted (prelude) value.
    Hoisted(usize),
    /// A target component f(x₀)_k.
    Target(usize),
    /// A gain.
    Gain(usize),
}

/// The order-0 value of a power, as the tape computes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PowZero {
    /// `f64::cbrt`.
    Cbrt,
    /// `f64::powf` with this exponent.
    Powf(f64),
    /// A fused power C·a^α (see the [module docs](self)): the order-0 value is the tape's, written
    /// by the order-0-only recurrences of the chain this one replaces above order 0, so the
    /// power recurrence computes only the orders k ≥ 1.
    Fused,
}

/// The recurrences of a field tape; see the [module docs](self).
#[derive(Clone, Debug, PartialEq)]
pub struct TaylorProgram {
    /// The recurrences in order, each with whether only its order 0 is computed: a row
    /// constant along the solution, or a step of a chain that a fused power replaces above
    /// order 0 (its higher coefficients are then never read).
    pub recs: Vec<(Rec, bool)>,
    /// The rows holding the outputs X_i.
    pub outputs: Vec<usize>,
    /// The number of rows.
    pub rows: usize,
    /// The state dimension N (rows 0..N are the state).
    pub dim: usize,
}

impl TaylorProgram {
    /// The recurrences of `tape`, a field: as many outputs as state components. Chains of
    /// square roots, integer powers and constant quotients are fused into power recurrences
    /// where that is cheaper (see the [module docs](self)).
    pub fn new(tape: &Tape) -> Result<TaylorProgram, TapeError> {
        Self::field_check(tape)?;
        Self::lower(tape, true, &[])
    }

    /// The recurrences of any function of the state (as many outputs as it has), for a
    /// caller that supplies the state rows' coefficients itself (the regions of a loop
    /// form, [`crate::loops::LoopTaylorProgram`]): rows 0..N are the state, component k
    /// constant along the solution where `constant_state[k]` (its higher coefficients are
    /// never read as anything but 0, and the instructions on it are constants and scalings);
    /// [`TaylorProgram::outputs`] are the rows of the tape's outputs.
    pub fn function(tape: &Tape, constant_state: &[bool]) -> Result<TaylorProgram, TapeError> {
        if constant_state.len() > tape.dims.state {
            return Err(TapeError::Malformed(
                "more constant flags than state components".into(),
            ));
        }
        Self::lower(tape, true, constant_state)
    }

    fn field_check(tape: &Tape) -> Result<(), TapeError> {
        let n = tape.dims.state;
        if tape.outputs.len() != n {
            return Err(TapeError::Malformed(format!(
                "a Taylor integrator needs a field: the tape has {} outputs for a state of dimension {n}",
                tape.outputs.len()
            )));
        }
        Ok(())
    }

    /// The recurrences of `tape` without fused powers: every instruction by its own
    /// recurrence (the reference the fused program is tested against).
    pub fn unfused(tape: &Tape) -> Result<TaylorProgram, TapeError> {
        Self::field_check(tape)?;
        Self::lower(tape, false, &[])
    }

    /// `constant_state[k]`: state component k is constant along the solution (missing: not).
    fn lower(tape: &Tape, fuse: bool, constant_state: &[bool]) -> Result<TaylorProgram, TapeError> {
        tape.validate()?;
        let n = tape.dims.state;
        let const_state = |k: u32| constant_state.get(k as usize).copied().unwrap_or(false);
        let mut b = Builder {
            rows: n,
            recs: Vec::with_capacity(tape.body.len()),
            one: None,
            squares: HashMap::new(),
        };
        let powers = if fuse {
            fused_powers(tape, &const_state)
        } else {
            vec![None; tape.body.len()]
        };
        let mut row_of: Vec<usize> = vec![usize::MAX; tape.body.len()];
        let mut constant: Vec<bool> = vec![false; tape.body.len()];
        // the registers computing sin and cos of each operand, to pair them
        let mut sin_of = HashMap::new();
        let mut cos_of = HashMap::new();
        // …and sn, cn, dn of each (u, m), to compute them as one triple
        let mut jacobi_of = HashMap::<(Reg, Reg), [Option<usize>; 3]>::new();
        for (i, op) in tape.body.iter().enumerate() {
            match *op {
                Op::Sin(a) => {
                    sin_of.entry(a).or_insert(i);
                }
                Op::Cos(a) => {
                    cos_of.entry(a).or_insert(i);
                }
                Op::Func2(f @ (Func2::Sn | Func2::Cn | Func2::Dn), u, m) => {
                    jacobi_of.entry((u, m)).or_default()[f as usize].get_or_insert(i);
                }
                _ => {}
            }
        }
        for (i, op) in tape.body.iter().enumerate() {
            let all_const = op.operands().all(|r| constant[r.index()]);
            // only order 0 for a step of a fused chain (its operands are not constant)
            let power = powers[i];
            let order0 = all_const || power.is_some_and(|p| p.above != Above::Own);
            let row = |r: Reg| row_of[r.index()];
            let is_const = |r: Reg| constant[r.index()];
            let leaf = match *op {
                Op::State(k) => {
                    row_of[i] = k as usize;
                    constant[i] = const_state(k);
                    continue;
                }
                Op::Const(c) => Some(Leaf::Const(c)),
                Op::Hoisted(k) => Some(Leaf::Hoisted(k as usize)),
                Op::Target(k) => Some(Leaf::Target(k as usize)),
                Op::Gain(k) => Some(Leaf::Gain(k as usize)),
                Op::Param(_) => return Err(TapeError::Malformed("a parameter in the body".into())),
                _ => None,
            };
            if let Some(leaf) = leaf {
                let d = b.rec(true, |d| Rec::Leaf { d, leaf });
                row_of[i] = d;
                constant[i] = true;
                continue;
            }
            // the second of a Sin/Cos pair already has its row
            if row_of[i] != usize::MAX {
                constant[i] = all_const;
                continue;
            }
            let d = match *op {
                Op::Add(x, y) => b.rec(all_const, |d| Rec::Add {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Sub(x, y) => b.rec(all_const, |d| Rec::Sub {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Neg(x) => b.rec(all_const, |d| Rec::Neg { d, a: row(x) }),
                Op::Mul(x, y) if x == y => b.rec(all_const, |d| Rec::Square { d, a: row(x) }),
                Op::Mul(x, y) if is_const(y) && !is_const(x) => b.rec(false, |d| Rec::Scale {
                    d,
                    a: row(x),
                    c: row(y),
                }),
                Op::Mul(x, y) if is_const(x) && !is_const(y) => b.rec(false, |d| Rec::Scale {
                    d,
                    a: row(y),
                    c: row(x),
                }),
                Op::Mul(x, y) => b.rec(all_const, |d| Rec::Mul {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Div(x, y) if is_const(y) && !is_const(x) => b.rec(false, |d| Rec::DivConst {
                    d,
                    a: row(x),
                    c: row(y),
                }),
                Op::Div(x, y) => b.rec(order0, |d| Rec::Div {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Powi(x, e) => b.powi(row(x), e, order0),
                Op::Sqrt(x) => b.rec(order0, |d| Rec::Sqrt { d, a: row(x) }),
                Op::Cbrt(x) => b.rec(all_const, |d| Rec::Pow {
                    d,
                    a: row(x),
                    alpha: 1.0 / 3.0,
                    zero: PowZero::Cbrt,
                }),
                Op::Powf(x, p) => b.rec(all_const, |d| Rec::Pow {
                    d,
                    a: row(x),
                    alpha: p.to_f64(),
                    zero: PowZero::Powf(p.to_f64()),
                }),
                Op::Exp(x) => b.rec(all_const, |d| Rec::Exp { d, a: row(x) }),
                Op::Ln(x) => b.rec(all_const, |d| Rec::Ln { d, a: row(x) }),
                Op::Sin(x) | Op::Cos(x) => {
                    let s = b.row();
                    let c = b.row();
                    b.recs.push((Rec::SinCos { s, c, a: row(x) }, all_const));
                    if let Some(&j) = sin_of.get(&x) {
                        row_of[j] = s;
                    }
                    if let Some(&j) = cos_of.get(&x) {
                        row_of[j] = c;
                    }
                    constant[i] = all_const;
                    continue;
                }
                Op::Func2(_, _, m) | Op::EllipK(m) if !is_const(m) => {
                    return Err(TapeError::Malformed(
                        "an elliptic function whose parameter m varies along the solution (the \
                         model language never writes one)"
                            .into(),
                    ))
                }
                Op::Func2(Func2::Sn | Func2::Cn | Func2::Dn, x, m) => {
                    let rows = std::array::from_fn(|_| b.row());
                    b.recs.push((
                        Rec::Jacobi {
                            rows,
                            a: row(x),
                            m: row(m),
                        },
                        all_const,
                    ));
                    for (k, j) in jacobi_of[&(x, m)].iter().enumerate() {
                        if let Some(&j) = j.as_ref() {
                            row_of[j] = rows[k];
                        }
                    }
                    constant[i] = all_const;
                    continue;
                }
                Op::EllipK(x) => b.rec(true, |d| Rec::EllipK { d, a: row(x) }),
                Op::Func2(Func2::EllipF, x, m) => {
                    // w = (1 − m sin²φ)^(−1/2) by the sine, square, scaling and power rows
                    let (a, m) = (row(x), row(m));
                    let (s, c) = (b.row(), b.row());
                    b.recs.push((Rec::SinCos { s, c, a }, all_const));
                    let q = b.rec(all_const, |d| Rec::Square { d, a: s });
                    let mq = b.rec(all_const, |d| Rec::Scale { d, a: q, c: m });
                    let one = b.one();
                    let r = b.rec(all_const, |d| Rec::Sub { d, a: one, b: mq });
                    let w = b.rec(all_const, |d| Rec::Pow {
                        d,
                        a: r,
                        alpha: -0.5,
                        zero: PowZero::Powf(-0.5),
                    });
                    b.rec(all_const, |d| Rec::EllipF { d, a, m, w })
                }
                Op::State(_)
                | Op::Param(_)
                | Op::Const(_)
                | Op::Hoisted(_)
                | Op::Target(_)
                | Op::Gain(_) => unreachable!("leaves are handled above"),
            };
            if let Some(Power {
                s,
                beta,
                above: Above::Pow,
            }) = power
            {
                // orders ≥ 1 of C·s^β; order 0 was the chain's
                b.recs.push((
                    Rec::Pow {
                        d,
                        a: row(s),
                        alpha: beta,
                        zero: PowZero::Fused,
                    },
                    false,
                ));
            }
            row_of[i] = d;
            constant[i] = all_const;
        }
        Ok(TaylorProgram {
            outputs: tape.outputs.iter().map(|r| row_of[r.index()]).collect(),
            recs: b.recs,
            rows: b.rows,
            dim: n,
        })
    }

    /// The sums of order k that read only orders below k, in groups to be computed together
    /// at the start of each order, before its recurrences (see [Early sums](self#early-sums)):
    /// at most `max` sums of one [`Span`] per group, those sharing a row (as a or as b)
    /// together, in program order otherwise. A sum whose (a, b, span) repeats an earlier one's
    /// is left to its recurrence.
    pub fn early_sums(&self, max: usize) -> Vec<(Span, Vec<EarlySum>)> {
        let mut by_span: Vec<(Span, Vec<EarlySum>)> = Vec::new();
        for (rec, &(r, constant)) in self.recs.iter().enumerate() {
            let (span, d, a, b) = match r {
                _ if constant => continue,
                Rec::Mul { d, a, b } => (Span::Product, d, a, b),
                Rec::Square { d, a } => (Span::Half, d, a, a),
                Rec::Sqrt { d, .. } => (Span::Half, d, d, d),
                _ => continue,
            };
            let sum = EarlySum { rec, d, a, b };
            match by_span.iter_mut().find(|(sp, _)| *sp == span) {
                Some((_, sums)) if sums.iter().any(|e| (e.a, e.b) == (a, b)) => {}
                Some((_, sums)) => sums.push(sum),
                None => by_span.push((span, vec![sum])),
            }
        }
        let mut groups = Vec::new();
        for (span, mut left) in by_span {
            while !left.is_empty() {
                let mut group = vec![left.remove(0)];
                while group.len() < max && !left.is_empty() {
                    let shares = |e: &EarlySum| group.iter().any(|g| g.a == e.a || g.b == e.b);
                    let i = left.iter().position(shares).unwrap_or(0);
                    group.push(left.remove(i));
                }
                groups.push((span, group));
            }
        }
        groups
    }
}

/// The most early sums in one group of [`TaylorProgram::early_sums`] that the kernels take
/// (measured with the JIT: up to 1, 2, 4, 6, 8 sums per loop ran the rigid body's Taylor run
/// in 0.0103, 0.0089, 0.0080, 0.0078 and 0.0080 s).
pub const EARLY_GROUP: usize = 6;

/// Which terms of a Cauchy sum Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\] at order k ≥ 1 an
/// [`EarlySum`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Span {
    /// A product's all but two newest terms: j = 1..=k−1 (`rec::mul`).
    Product,
    /// The folded half of a square or square root: j = 1..=(k−1)/2 (`rec::square`,
    /// `rec::sqrt`; the square root's only for k ≥ 2).
    Half,
}

impl Span {
    /// The range (lo, hi) of j at order k ≥ 1 (empty if lo > hi).
    pub fn range(self, k: usize) -> (usize, usize) {
        match self {
            Span::Product => (1, k - 1),
            Span::Half => (1, (k - 1) / 2),
        }
    }

    /// hi of [`Span::range`] as Rust source in `k` (lo is 1), for the emitted kernels.
    pub fn hi_source(self) -> &'static str {
        match self {
            Span::Product => "k - 1",
            Span::Half => "(k - 1) / 2",
        }
    }
}

/// A Cauchy sum of [`TaylorProgram::early_sums`]: the one of recurrence `recs[rec]` (a
/// product, square or square root), over rows `a` and `b`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EarlySum {
    /// Index into [`TaylorProgram::recs`].
    pub rec: usize,
    /// The recurrence's result row.
    pub d: usize,
    /// Row of the a^\[j\] factors.
    pub a: usize,
    /// Row of the b^\[k−j\] factors.
    pub b: usize,
}

/// The recurrences and rows of a [`TaylorProgram`] under construction.
struct Builder {
    rows: usize,
    recs: Vec<(Rec, bool)>,
    /// The row of the constant 1, once needed.
    one: Option<usize>,
    /// The rows of the squares `powi` made, by operand row and order-0-only flag: x² of
    /// `powi(x, 2)` and `powi(x, 4)` is computed once.
    squares: HashMap<(usize, bool), usize>,
}

impl Builder {
    /// A new row.
    fn row(&mut self) -> usize {
        self.rows += 1;
        self.rows - 1
    }

    /// Pushes `make(new row)`; returns the row.
    fn rec(&mut self, constant: bool, make: impl FnOnce(usize) -> Rec) -> usize {
        let d = self.row();
        self.recs.push((make(d), constant));
        d
    }

    fn one(&mut self) -> usize {
        match self.one {
            Some(r) => r,
            None => {
                let d = self.rec(true, |d| Rec::Leaf {
                    d,
                    leaf: Leaf::Const(1.0),
                });
                self.one = Some(d);
                d
            }
        }
    }

    /// aᵉ as `f64::powi` computes it ([`super::powi`]): the squares a, a², a⁴, … (each row
    /// made once per base, shared between `powi`s) multiplied into the result in increasing
    /// order, the first without a product, then 1/· for e < 0, each step with its Cauchy
    /// recurrence. Returns the row.
    fn powi(&mut self, base: usize, e: i32, constant: bool) -> usize {
        if e == 0 {
            // powi(x, 0) = 1, even for x = NaN
            return self.one();
        }
        let mut bits = e.unsigned_abs();
        let mut square = base;
        let mut result: Option<usize> = None;
        while bits != 0 {
            if bits & 1 == 1 {
                result = Some(match result {
                    None => square,
                    Some(r) => self.rec(constant, |d| Rec::Mul { d, a: r, b: square }),
                });
            }
            bits >>= 1;
            if bits != 0 {
                let a = square;
                square = match self.squares.get(&(a, constant)) {
                    Some(&row) => row,
                    None => {
                        let row = self.rec(constant, |d| Rec::Square { d, a });
                        self.squares.insert((a, constant), row);
                        row
                    }
                };
            }
        }
        let r = result.expect("e ≠ 0 has a bit set");
        if e < 0 {
            let one = self.one();
            self.rec(constant, |d| Rec::Div { d, a: one, b: r })
        } else {
            // e = 1 is the base itself (the tape never has it, but a hand-built tape may)
            r
        }
    }
}

/// How a register of a power chain is computed above order 0.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Above {
    /// By its own recurrence, as without fusion.
    Own,
    /// Not at all: nothing reads its higher coefficients.
    Zero,
    /// By the power recurrence of C·s^β on the chain's radicand s.
    Pow,
}

/// A register of a power chain: C·s^β for a constant C and the radicand s of the chain's
/// square root, with how it is computed above order 0.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Power {
    s: Reg,
    beta: f64,
    above: Above,
}

/// A register of a power chain, C·s^β.
#[derive(Clone, Copy, Debug)]
struct Link {
    s: Reg,
    beta: f64,
    /// The cost per order of its own recurrence, in half sums.
    own: u32,
    /// Its operand, if in the chain (not for the square root).
    operand: Option<usize>,
}

/// The cost of the power recurrence per order, in half sums (as [`powi_cost`]): k terms of
/// two products (the weight α(k − j) − j, then the coefficient) and a sum.
const POW_COST: u32 = 3;

/// The cost per order of `f64::powi(·, n)`'s recurrences ([`Builder::powi`]) in half sums:
/// a folded square 1, a Cauchy product or quotient 2 (about k/2 and k terms at order k).
fn powi_cost(n: i32) -> u32 {
    let m = n.unsigned_abs();
    let squares = 31 - m.leading_zeros();
    let products = m.count_ones() - 1;
    squares + 2 * products + if n < 0 { 2 } else { 0 }
}

/// The power chains of `tape` and how each of their registers is computed above order 0 (see
/// the [module docs](self)); `None` for the other registers.
///
/// A chain starts at √s (s not constant) and continues through `powi(·, n)` (n ≠ 0, 1) and
/// c/· (c constant): each register is C·s^β. One that is read outside its chain (or is an
/// output) must have its higher coefficients, by its own recurrence (which needs its
/// operand's) or by the power recurrence on s (which needs only s); one that is not may have
/// none. The cheapest assignment is found over each chain's tree of registers, ties going to
/// the own recurrence, then to none.
fn fused_powers(tape: &Tape, const_state: &dyn Fn(u32) -> bool) -> Vec<Option<Power>> {
    let n = tape.body.len();
    let mut constant = vec![false; n];
    let mut node: Vec<Option<Link>> = vec![None; n];
    for (i, op) in tape.body.iter().enumerate() {
        constant[i] = match *op {
            Op::State(k) => const_state(k),
            _ => op.operands().all(|r| constant[r.index()]),
        };
        let next = |x: Reg, beta: &dyn Fn(f64) -> f64, own| {
            node[x.index()].map(|l| Link {
                s: l.s,
                beta: beta(l.beta),
                own,
                operand: Some(x.index()),
            })
        };
        node[i] = match *op {
            Op::Sqrt(s) if !constant[s.index()] => Some(Link {
                s,
                beta: 0.5,
                own: 1,
                operand: None,
            }),
            Op::Powi(x, e) if e != 0 && e != 1 => next(x, &|b| b * f64::from(e), powi_cost(e)),
            Op::Div(c, x) if constant[c.index()] => next(x, &|b| -b, 2),
            _ => None,
        };
    }
    // the registers of each chain that read it, and which are read elsewhere
    let mut children = vec![Vec::new(); n];
    let mut external = vec![false; n];
    for (i, op) in tape.body.iter().enumerate() {
        for r in op.operands() {
            let r = r.index();
            match node[i] {
                Some(Link {
                    operand: Some(p), ..
                }) if p == r => children[r].push(i),
                _ => external[r] = true,
            }
        }
    }
    for r in &tape.outputs {
        external[r.index()] = true;
    }
    // the cheapest (cost, choice) of each register's subtree, given whether its operand has
    // higher coefficients; children come after their operand
    let mut best = vec![[(0, Above::Own); 2]; n];
    for i in (0..n).rev() {
        let Some(Link { own, .. }) = node[i] else {
            continue;
        };
        // the children's cost when this register has no higher coefficients, and when it has
        let [without, with] = [false, true].map(|avail| -> u32 {
            children[i]
                .iter()
                .map(|&c| best[c][usize::from(avail)].0)
                .sum()
        });
        for avail in [false, true] {
            let mut options = Vec::with_capacity(3);
            if avail {
                options.push((own + with, Above::Own));
            }
            if !external[i] {
                options.push((without, Above::Zero));
            }
            options.push((POW_COST + with, Above::Pow));
            // the first of the cheapest
            best[i][usize::from(avail)] = options
                .into_iter()
                .reduce(|a, b| if b.0 < a.0 { b } else { a })
                .expect("the power recurrence is always an option");
        }
    }
    let mut powers: Vec<Option<Power>> = vec![None; n];
    for i in 0..n {
        if let Some(Link {
            s, beta, operand, ..
        }) = node[i]
        {
            let avail = operand.is_none_or(|p| powers[p].is_some_and(|p| p.above != Above::Zero));
            let above = best[i][usize::from(avail)].1;
            powers[i] = Some(Power { s, beta, above });
        }
    }
    powers
}

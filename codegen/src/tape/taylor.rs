//! A field tape lowered to Taylor-coefficient recurrences: one [`Rec`] per instruction over
//! rows of a coefficient table, shared by the interpreted kernel (`lasalle_exec::TaylorTape`)
//! and the emitted kernels of compiled models (`emit::taylor`), which therefore run the same
//! recurrences (`lasalle_runtime::taylor::rec`) in the same order and agree bitwise.
//!
//! Rows: the state components first (row i is x_i), then one row per body register that is
//! not a state leaf, and internal rows (the cosine partner of a lone sine, the squares of a
//! `powi`, the constant 1). Sine and cosine of the same operand share one [`Rec::SinCos`].
//! `powi` is expanded into the squares and products `f64::powi` performs ([`super::powi`]),
//! then 1/· by the division recurrence for a negative exponent, so the order-0 values are the
//! tape's bitwise and a base with a^\[0\] = 0 is fine for a positive exponent. sn, cn, dn of
//! one (u | m) share one [`Rec::Jacobi`] (with the products cn·dn, sn·dn, sn·cn their
//! recurrences read); F(φ | m) gets rows for sin φ, cos φ, sin²φ, m sin²φ, 1 − m sin²φ and
//! w = (1 − m sin²φ)^(−1/2), F′ = w φ′. The parameter m must be constant along the solution,
//! as the model language guarantees.
//!
//! An instruction whose operands are all constant along the solution (leaves other than the
//! state, and instructions of those) is marked `constant`: only its order 0 is computed.

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
}

/// The recurrences of a field tape; see the [module docs](self).
#[derive(Clone, Debug, PartialEq)]
pub struct TaylorProgram {
    /// The recurrences in order, each with whether its row is constant along the solution.
    pub recs: Vec<(Rec, bool)>,
    /// The rows holding the outputs X_i.
    pub outputs: Vec<usize>,
    /// The number of rows.
    pub rows: usize,
    /// The state dimension N (rows 0..N are the state).
    pub dim: usize,
}

impl TaylorProgram {
    /// The recurrences of `tape`, a field: as many outputs as state components.
    pub fn new(tape: &Tape) -> Result<TaylorProgram, TapeError> {
        tape.validate()?;
        let n = tape.dims.state;
        if tape.outputs.len() != n {
            return Err(TapeError::Malformed(format!(
                "a Taylor integrator needs a field: the tape has {} outputs for a state of dimension {n}",
                tape.outputs.len()
            )));
        }
        let mut b = Builder {
            rows: n,
            recs: Vec::with_capacity(tape.body.len()),
            one: None,
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
            let row = |r: Reg| row_of[r.index()];
            let is_const = |r: Reg| constant[r.index()];
            let leaf = match *op {
                Op::State(k) => {
                    row_of[i] = k as usize;
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
                Op::Div(x, y) => b.rec(all_const, |d| Rec::Div {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Powi(x, e) => b.powi(row(x), e, all_const),
                Op::Sqrt(x) => b.rec(all_const, |d| Rec::Sqrt { d, a: row(x) }),
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
}

/// The recurrences and rows of a [`TaylorProgram`] under construction.
struct Builder {
    rows: usize,
    recs: Vec<(Rec, bool)>,
    /// The row of the constant 1, once needed.
    one: Option<usize>,
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

    /// aᵉ as `f64::powi` computes it ([`super::powi`]): the squares a, a², a⁴, … multiplied
    /// into the result in increasing order, the first without a product, then 1/· for e < 0,
    /// each step with its Cauchy recurrence. Returns the row.
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
                square = self.rec(constant, |d| Rec::Square { d, a: square });
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

//! A Taylor-series integrator generated from a field tape, as in heyoka (Biscani & Izzo,
//! *Revisiting high-order Taylor methods for astrodynamics and celestial mechanics*, MNRAS 504
//! (2021) 2614–2628).
//!
//! # Taylor coefficients by automatic differentiation
//!
//! For ẋ = X(x), the normalised Taylor coefficients x^\[k\] = x⁽ᵏ⁾(t₀)/k! of the solution through
//! x(t₀) = x₀ follow from x^\[0\] = x₀ and
//!
//! ```text
//! x^[k+1] = X(x)^[k] / (k + 1),
//! ```
//!
//! where X(x)^\[k\] is the k-th coefficient of the composite function t ↦ X(x(t)), computed
//! instruction by instruction along the field's tape from the coefficients 0..=k of the
//! instruction's operands (Moore 1966; Griewank & Walther, *Evaluating Derivatives*, 2nd ed.,
//! ch. 13; Jorba & Zou 2005). With a, b the operands and u the result of an
//! instruction (all normalised coefficients, k ≥ 1; the order-0 value is the instruction's own
//! f64 operation, so order 0 is the tape's value):
//!
//! | op | recurrence |
//! | --- | --- |
//! | u = a ± b | u^\[k\] = a^\[k\] ± b^\[k\] |
//! | u = a·b | u^\[k\] = Σ_{j=0}^{k} a^\[j\] b^\[k−j\] (Cauchy product; a·c for a constant c is a scaling) |
//! | u = a/b | u^\[k\] = (a^\[k\] − Σ_{j=1}^{k} b^\[j\] u^\[k−j\]) / b^\[0\] |
//! | u = aⁿ, n ∈ ℕ | binary exponentiation by Cauchy products (squares and products, as `f64::powi`), so a^\[0\] = 0 is fine |
//! | u = a⁻ⁿ | the chain for aⁿ, then 1/aⁿ by the division recurrence |
//! | u = a^α (Powf, ∛) | u^\[k\] = 1/(k a^\[0\]) Σ_{j=0}^{k−1} (α(k−j) − j) a^\[k−j\] u^\[j\] (from a u' = α a' u) |
//! | u = √a | u^\[k\] = (a^\[k\] − Σ_{j=1}^{k−1} u^\[j\] u^\[k−j\]) / (2 u^\[0\]) (from u² = a) |
//! | u = eᵃ | u^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] u^\[k−j\] (from u' = a' u) |
//! | u = ln a | u^\[k\] = (a^\[k\] − (1/k) Σ_{j=1}^{k−1} j u^\[j\] a^\[k−j\]) / a^\[0\] (from a u' = a') |
//! | s = sin a, c = cos a | s^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] c^\[k−j\], c^\[k\] = −(1/k) Σ_{j=1}^{k} j a^\[j\] s^\[k−j\] |
//! | s, c, d = sn, cn, dn (a \| m), m constant | s^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] (cd)^\[k−j\], c^\[k\] = −(1/k) Σ j a^\[j\] (sd)^\[k−j\], d^\[k\] = −(m/k) Σ j a^\[j\] (sc)^\[k−j\], the products cd, sd, sc by Cauchy products (from s' = c d a', c' = −s d a', d' = −m s c a') |
//! | u = F(a \| m), m constant | u^\[k\] = (1/k) Σ_{j=1}^{k} j a^\[j\] w^\[k−j\], w = (1 − m sin²a)^(−1/2) by the rows above |
//!
//! Leaves other than the state (constants, hoisted parameter values, targets, gains) and every
//! instruction whose operands are all such leaves are constant along the solution: only their
//! order-0 value is computed, their higher coefficients stay 0. Sine and cosine are always
//! computed together (a tape with only `Sin(a)` gets an internal cosine row); a tape with both
//! `Sin(a)` and `Cos(a)` computes the pair once. Likewise sn, cn, dn of one (a | m) are one
//! triple, with one `ellipj` call at order 0; F(φ | m) has u' = w φ' with internal rows for
//! sin φ, cos φ, sin²φ, 1 − m sin²φ and w = (1 − m sin²φ)^(−1/2). The parameter m of every
//! elliptic function must be constant along the solution, as the model language guarantees
//! ([`TaylorError::Unsupported`] otherwise).
//!
//! The coefficients live in one table of `rows × (p_max + 1)` f64 (one row per state component,
//! per tape register that is not a state leaf, and per internal row: the cosine partner, the
//! squares of `powi`), allocated once; a step writes into it and allocates nothing.
//! A step to order p costs Σ_{k<p} O(k) per nonlinear instruction, i.e. about p²/2 times a
//! field evaluation.
//!
//! # Order and step size (Jorba & Zou 2005)
//!
//! Following Jorba & Zou, *A software package for the numerical integration of ODEs by means of
//! high-order Taylor methods*, Experimental Mathematics 14(1) (2005) 99–117 (their step size
//! and order control), with equal
//! absolute and relative tolerances ε (as heyoka's `taylor_adaptive` does):
//! - the order is p = ⌈−½ ln ε + 1⌉ (fixed for a given ε; 19 for ε = 10⁻¹⁵, 20 for the double
//!   precision ε ≈ 2.2·10⁻¹⁶), see [`order_for_tolerance`];
//! - with m = ‖x₀‖∞, the tolerance is absolute when m ≤ 1 and relative otherwise
//!   (ε_r m > ε_a ⇔ m > 1): the radius estimates are
//!   ρ_j = (c / ‖x^\[j\]‖∞)^{1/j}, c = 1 (absolute) or m (relative), for j = p − 1 and j = p,
//!   ρ = min(ρ_{p−1}, ρ_p);
//! - the step is h = ρ / e² · exp(−0.7/(p − 1)) (the `exp(−0.7/(p−1))` safety factor of
//!   Jorba & Zou, also used by heyoka).
//!
//! The last two terms of the series are then about ε c in size (for ρ the radius of
//! convergence of an analytic solution, ‖x^\[j\]‖ h^j ≈ (h/ρ)^j ≤ e^{−2j}). Steps are never
//! rejected. The new state is the Taylor polynomial evaluated at h by Horner's scheme, and the
//! same polynomial is the dense output on [t, t + h] ([`DenseOutput`]).
//!
//! # Use
//!
//! ```
//! use lasalle_exec::{Backend, LoadedModel};
//! use lasalle_exec::taylor::{Taylor, TaylorOptions};
//! use lasalle_runtime::{integrate, Parameters};
//!
//! let text = "model Osc { state q: scalar, p: scalar; param w = 2;
//!             d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2;
//!             point start { q = 1; p = 0; } }";
//! let m = LoadedModel::from_source("osc.lsl", text, Backend::Interpreter).unwrap();
//! let mut taylor = Taylor::for_model(&m, TaylorOptions::with_tol(1e-15)).unwrap();
//! let x0 = m.point("start").unwrap();
//! // h = 0: the stepper chooses the first step; then every step is Jorba–Zou's
//! let end = integrate(&mut taylor, &m, &x0, 0.0, 10.0, 0.0, &mut ()).unwrap();
//! assert!((end.x[0] - 20f64.cos()).abs() < 1e-13);
//! ```
//!
//! The feedback field X − ∇V runs through [`Taylor`] as a
//! `Stepper<f64, Vec<f64>, FeedbackField<LoadedModel, Vec<f64>, Vec<f64>>>`, or with the target
//! and gains held by the stepper ([`TaylorField::Feedback`]).

use lasalle_codegen::derive;
use lasalle_codegen::ir::{Func, Func2};
use lasalle_codegen::tape::{ModelTapes, Op, Reg, Tape, TapeError};
use lasalle_runtime::{DenseOutput, FeedbackField, StepError, StepOutcome, Stepper};

use crate::LoadedModel;

/// What can go wrong setting up a Taylor integrator.
#[derive(Debug, thiserror::Error)]
pub enum TaylorError {
    /// The tape is malformed, or an input has the wrong length.
    #[error(transparent)]
    Tape(#[from] TapeError),
    /// The model's functions could not be rebuilt from its text.
    #[error(transparent)]
    Model(#[from] lasalle_codegen::Error),
    /// The field tape does not map the state to a vector of the same size.
    #[error("the field tape has {outputs} outputs for a state of dimension {state}")]
    NotAField {
        /// Outputs of the tape.
        outputs: usize,
        /// State dimension of the tape.
        state: usize,
    },
    /// A function the Taylor recurrences do not cover (an elliptic function whose parameter m
    /// varies along the solution; the model language never writes one).
    #[error("the Taylor integrator does not support {0}")]
    Unsupported(String),
    /// An invalid option (tolerance, order or largest step).
    #[error("invalid Taylor option: {0}")]
    Option(String),
}

/// Jorba & Zou's order for a tolerance ε: p = ⌈−½ ln ε + 1⌉ (at least 2).
///
/// 19 for ε = 10⁻¹⁵, 20 for `f64::EPSILON`, 11 for 10⁻⁸.
pub fn order_for_tolerance(tol: f64) -> u32 {
    let p = (-0.5 * tol.ln() + 1.0).ceil();
    if p.is_finite() {
        p.clamp(2.0, 1000.0) as u32
    } else {
        2
    }
}

/// Jorba & Zou's step size (see the [module docs](self)) from the state norm m = ‖x^\[0\]‖∞ and
/// the norms of the last two coefficients, ‖x^\[p−1\]‖∞ and ‖x^\[p\]‖∞. `+∞` if both norms are 0
/// (a polynomial solution of degree < p − 1: any step is exact).
pub fn jorba_zou_step(order: u32, state_norm: f64, norm_pm1: f64, norm_p: f64) -> f64 {
    let p = f64::from(order.max(2));
    let c = if state_norm > 1.0 { state_norm } else { 1.0 };
    let rho_pm1 = (c / norm_pm1).powf(1.0 / (p - 1.0));
    let rho_p = (c / norm_p).powf(1.0 / p);
    let rho = rho_pm1.min(rho_p);
    rho * (-0.7 / (p - 1.0)).exp() / (std::f64::consts::E * std::f64::consts::E)
}

/// One recurrence on rows of the coefficient table (row indices are offsets of the row's
/// first coefficient in the table).
#[derive(Clone, Copy, Debug)]
enum Inst {
    /// A leaf constant along the solution: its order-0 value comes from [`Leaf`].
    Leaf {
        d: usize,
        leaf: Leaf,
    },
    Add {
        d: usize,
        a: usize,
        b: usize,
    },
    Sub {
        d: usize,
        a: usize,
        b: usize,
    },
    Neg {
        d: usize,
        a: usize,
    },
    /// Cauchy product.
    Mul {
        d: usize,
        a: usize,
        b: usize,
    },
    /// a · c with c constant along the solution.
    Scale {
        d: usize,
        a: usize,
        c: usize,
    },
    /// Cauchy square a·a (symmetric: half the products).
    Square {
        d: usize,
        a: usize,
    },
    Div {
        d: usize,
        a: usize,
        b: usize,
    },
    /// a / c with c constant along the solution.
    DivConst {
        d: usize,
        a: usize,
        c: usize,
    },
    /// a^α by the power recurrence; `zero` says how the order-0 value is computed.
    Pow {
        d: usize,
        a: usize,
        alpha: f64,
        zero: PowZero,
    },
    Sqrt {
        d: usize,
        a: usize,
    },
    Exp {
        d: usize,
        a: usize,
    },
    Ln {
        d: usize,
        a: usize,
    },
    SinCos {
        s: usize,
        c: usize,
        a: usize,
    },
    /// sn, cn, dn of (a | m) with m constant along the solution, and the products cn·dn,
    /// sn·dn, sn·cn their recurrences read: the six rows `s + i·stride`, i = 0..6, in this
    /// order.
    Jacobi {
        s: usize,
        stride: usize,
        a: usize,
        m: usize,
    },
    /// K(a), a constant along the solution (order 0 only).
    EllipK {
        d: usize,
        a: usize,
    },
    /// F(a | m), m constant, from the row w = 1/√(1 − m sin²a) of F′: u' = w a'.
    EllipF {
        d: usize,
        a: usize,
        m: usize,
        w: usize,
    },
}

/// Sources of the order-0 value of a leaf.
#[derive(Clone, Copy, Debug)]
enum Leaf {
    Const(f64),
    Hoisted(usize),
    Target(usize),
    Gain(usize),
}

/// The order-0 value of a power: as the tape computes it.
#[derive(Clone, Copy, Debug)]
enum PowZero {
    Cbrt,
    Powf(f64),
}

/// The Taylor-coefficient recurrences of one field tape, with their coefficient table.
///
/// Built once per tape ([`TaylorTape::new`]); [`TaylorTape::compute`] fills the coefficients
/// x^\[0..=p\] of the solution of ẋ = tape(x) through a state, without allocating.
#[derive(Clone, Debug)]
pub struct TaylorTape {
    /// Per instruction: the recurrence and whether the row is constant along the solution.
    program: Vec<(Inst, bool)>,
    /// Table offsets of the rows holding the outputs X_i.
    outputs: Vec<usize>,
    n: usize,
    max_order: usize,
    stride: usize,
    /// rows × (max_order + 1), row-major.
    table: Vec<f64>,
    hoisted: Vec<f64>,
    target: Vec<f64>,
    gains: Vec<f64>,
    /// Number of hoisted values, targets and gains the tape reads.
    dims: (usize, usize, usize),
    /// The order of the last [`TaylorTape::compute`] (0 before any).
    order: usize,
}

impl TaylorTape {
    /// The recurrences of `tape` (state → ẋ, as many outputs as state components), with
    /// `hoisted = tape.hoist(params)`, for orders up to `max_order`. Targets and gains (for
    /// X − ∇V) start at 0; set them with [`TaylorTape::set_inputs`].
    pub fn new(tape: &Tape, hoisted: &[f64], max_order: u32) -> Result<TaylorTape, TaylorError> {
        tape.validate()?;
        let d = tape.dims;
        if tape.outputs.len() != d.state {
            return Err(TaylorError::NotAField {
                outputs: tape.outputs.len(),
                state: d.state,
            });
        }
        lasalle_codegen::tape::expect_len("hoisted", tape.hoisted.len(), hoisted.len())?;
        if max_order == 0 {
            return Err(TaylorError::Option("the order must be at least 1".into()));
        }
        let n = d.state;
        let stride = max_order as usize + 1;
        // rows: the state first, then one per non-state register, and internal rows
        let mut b = Builder {
            rows: n,
            stride,
            program: Vec::with_capacity(tape.body.len()),
            one: None,
        };
        let mut row_of: Vec<usize> = vec![usize::MAX; tape.body.len()];
        let mut constant: Vec<bool> = vec![false; tape.body.len()];
        // the registers computing sin and cos of each operand, to pair them
        let mut sin_of = std::collections::HashMap::new();
        let mut cos_of = std::collections::HashMap::new();
        // …and sn, cn, dn of each (u, m)
        let mut jacobi_of = std::collections::HashMap::<(Reg, Reg), [Option<usize>; 3]>::new();
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
                    row_of[i] = k as usize * stride;
                    continue;
                }
                Op::Const(c) => Some(Leaf::Const(c)),
                Op::Hoisted(k) => Some(Leaf::Hoisted(k as usize)),
                Op::Target(k) => Some(Leaf::Target(k as usize)),
                Op::Gain(k) => Some(Leaf::Gain(k as usize)),
                Op::Param(_) => {
                    return Err(TaylorError::Tape(TapeError::Malformed(
                        "a parameter in the body".into(),
                    )))
                }
                _ => None,
            };
            if let Some(leaf) = leaf {
                let d = b.row();
                b.push(Inst::Leaf { d, leaf }, true);
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
                Op::Add(x, y) => b.inst(all_const, |d| Inst::Add {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Sub(x, y) => b.inst(all_const, |d| Inst::Sub {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Neg(x) => b.inst(all_const, |d| Inst::Neg { d, a: row(x) }),
                Op::Mul(x, y) if x == y => b.inst(all_const, |d| Inst::Square { d, a: row(x) }),
                Op::Mul(x, y) if is_const(y) && !is_const(x) => b.inst(false, |d| Inst::Scale {
                    d,
                    a: row(x),
                    c: row(y),
                }),
                Op::Mul(x, y) if is_const(x) && !is_const(y) => b.inst(false, |d| Inst::Scale {
                    d,
                    a: row(y),
                    c: row(x),
                }),
                Op::Mul(x, y) => b.inst(all_const, |d| Inst::Mul {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Div(x, y) if is_const(y) && !is_const(x) => b.inst(false, |d| Inst::DivConst {
                    d,
                    a: row(x),
                    c: row(y),
                }),
                Op::Div(x, y) => b.inst(all_const, |d| Inst::Div {
                    d,
                    a: row(x),
                    b: row(y),
                }),
                Op::Powi(x, e) => b.powi(row(x), e, all_const),
                Op::Sqrt(x) => b.inst(all_const, |d| Inst::Sqrt { d, a: row(x) }),
                Op::Cbrt(x) => b.inst(all_const, |d| Inst::Pow {
                    d,
                    a: row(x),
                    alpha: 1.0 / 3.0,
                    zero: PowZero::Cbrt,
                }),
                Op::Powf(x, p) => b.inst(all_const, |d| Inst::Pow {
                    d,
                    a: row(x),
                    alpha: p.to_f64(),
                    zero: PowZero::Powf(p.to_f64()),
                }),
                Op::Exp(x) => b.inst(all_const, |d| Inst::Exp { d, a: row(x) }),
                Op::Ln(x) => b.inst(all_const, |d| Inst::Ln { d, a: row(x) }),
                Op::Sin(x) | Op::Cos(x) => {
                    let s = b.row();
                    let c = b.row();
                    b.push(Inst::SinCos { s, c, a: row(x) }, all_const);
                    if let Some(&j) = sin_of.get(&x) {
                        row_of[j] = s;
                    }
                    if let Some(&j) = cos_of.get(&x) {
                        row_of[j] = c;
                    }
                    constant[i] = all_const;
                    continue;
                }
                Op::Func2(Func2::Sn | Func2::Cn | Func2::Dn, x, m) => {
                    if !is_const(m) {
                        return Err(TaylorError::Unsupported(
                            "sn, cn, dn with a parameter m that varies along the solution".into(),
                        ));
                    }
                    let s = b.row();
                    for _ in 1..6 {
                        b.row();
                    }
                    let inst = Inst::Jacobi {
                        s,
                        stride,
                        a: row(x),
                        m: row(m),
                    };
                    b.push(inst, all_const);
                    for (k, j) in jacobi_of[&(x, m)].iter().enumerate() {
                        if let Some(&j) = j.as_ref() {
                            row_of[j] = s + k * stride;
                        }
                    }
                    constant[i] = all_const;
                    continue;
                }
                Op::EllipK(x) if all_const => b.inst(true, |d| Inst::EllipK { d, a: row(x) }),
                Op::EllipK(_) => {
                    return Err(TaylorError::Unsupported(
                        "K(m) of a parameter m that varies along the solution".into(),
                    ))
                }
                Op::Func2(Func2::EllipF, _, m) if !is_const(m) => {
                    return Err(TaylorError::Unsupported(
                        "F(φ | m) with a parameter m that varies along the solution".into(),
                    ))
                }
                Op::Func2(Func2::EllipF, x, m) => {
                    // w = (1 − m sin²φ)^(−1/2) by the sine, square, scaling and power rows
                    let (a, m) = (row(x), row(m));
                    let (s, c) = (b.row(), b.row());
                    b.push(Inst::SinCos { s, c, a }, all_const);
                    let q = b.inst(all_const, |d| Inst::Square { d, a: s });
                    let mq = b.inst(all_const, |d| Inst::Scale { d, a: q, c: m });
                    let one = b.one();
                    let r = b.inst(all_const, |d| Inst::Sub { d, a: one, b: mq });
                    let w = b.inst(all_const, |d| Inst::Pow {
                        d,
                        a: r,
                        alpha: -0.5,
                        zero: PowZero::Powf(-0.5),
                    });
                    b.inst(all_const, |d| Inst::EllipF { d, a, m, w })
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
        let rows = b.rows;
        let program = b.program;
        let outputs = tape.outputs.iter().map(|r| row_of[r.index()]).collect();
        Ok(TaylorTape {
            program,
            outputs,
            n,
            max_order: max_order as usize,
            stride,
            table: vec![0.0; rows * stride],
            hoisted: hoisted.to_vec(),
            target: vec![0.0; d.targets],
            gains: vec![0.0; d.gains],
            dims: (tape.hoisted.len(), d.targets, d.gains),
            order: 0,
        })
    }

    /// Replaces the hoisted values (after a parameter change: `tape.hoist(params)`).
    pub fn set_hoisted(&mut self, hoisted: &[f64]) -> Result<(), TaylorError> {
        lasalle_codegen::tape::expect_len("hoisted", self.dims.0, hoisted.len())?;
        self.hoisted.copy_from_slice(hoisted);
        Ok(())
    }

    /// Sets the targets f(x₀) and the gains read by the tape (X − ∇V); no allocation.
    pub fn set_inputs(&mut self, target: &[f64], gains: &[f64]) -> Result<(), TaylorError> {
        lasalle_codegen::tape::expect_len("target", self.dims.1, target.len())?;
        lasalle_codegen::tape::expect_len("gains", self.dims.2, gains.len())?;
        self.target.copy_from_slice(target);
        self.gains.copy_from_slice(gains);
        Ok(())
    }

    /// The state dimension N.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// The largest order [`TaylorTape::compute`] accepts.
    pub fn max_order(&self) -> usize {
        self.max_order
    }

    /// The order of the last [`TaylorTape::compute`].
    pub fn order(&self) -> usize {
        self.order
    }

    /// Rows of the coefficient table (state components, registers and internal rows).
    pub fn rows(&self) -> usize {
        self.table.len() / self.stride
    }

    /// Computes the normalised Taylor coefficients x^\[0..=order\] of the solution through `x`
    /// (`order ≤ max_order`; the excess is clamped). Allocates nothing.
    ///
    /// # Panics
    /// If `x.len()` is not the state dimension.
    pub fn compute(&mut self, x: &[f64], order: usize) {
        assert_eq!(x.len(), self.n, "state dimension");
        let order = order.min(self.max_order);
        let stride = self.stride;
        self.order = order;
        let t = &mut self.table[..];
        for (i, &xi) in x.iter().enumerate().take(self.n) {
            t[i * stride] = xi;
        }
        for k in 0..order {
            for &(inst, constant) in &self.program {
                if k == 0 {
                    zeroth(t, inst, &self.hoisted, &self.target, &self.gains);
                } else if !constant {
                    coefficient(t, inst, k);
                }
            }
            let inv = 1.0 / (k as f64 + 1.0);
            for (i, &o) in self.outputs.iter().enumerate() {
                t[i * stride + k + 1] = t[o + k] * inv;
            }
        }
    }

    /// The coefficients x_i^\[0..=order\] of state component `i` from the last
    /// [`TaylorTape::compute`].
    pub fn state_coefficients(&self, i: usize) -> &[f64] {
        &self.table[i * self.stride..i * self.stride + self.order + 1]
    }

    /// ‖x^\[k\]‖∞ over the state components.
    pub fn norm(&self, k: usize) -> f64 {
        (0..self.n)
            .map(|i| self.table[i * self.stride + k].abs())
            .fold(0.0, f64::max)
    }

    /// Evaluates the Taylor polynomial of the state at `s` (time since the expansion point)
    /// by Horner's scheme into `out`.
    ///
    /// # Panics
    /// If `out.len()` is not the state dimension.
    pub fn evaluate(&self, s: f64, out: &mut [f64]) {
        assert_eq!(out.len(), self.n, "state dimension");
        for (i, o) in out.iter_mut().enumerate().take(self.n) {
            let c = &self.table[i * self.stride..i * self.stride + self.order + 1];
            *o = c.iter().rev().fold(0.0, |acc, &ck| acc * s + ck);
        }
    }
}

/// The program and rows of a [`TaylorTape`] under construction.
struct Builder {
    rows: usize,
    stride: usize,
    program: Vec<(Inst, bool)>,
    /// The row of the constant 1, once needed.
    one: Option<usize>,
}

impl Builder {
    /// A new row: its offset in the table.
    fn row(&mut self) -> usize {
        let r = self.rows * self.stride;
        self.rows += 1;
        r
    }

    fn push(&mut self, inst: Inst, constant: bool) {
        self.program.push((inst, constant));
    }

    /// Pushes `make(new row)`; returns the row.
    fn inst(&mut self, constant: bool, make: impl FnOnce(usize) -> Inst) -> usize {
        let d = self.row();
        self.push(make(d), constant);
        d
    }

    fn one(&mut self) -> usize {
        match self.one {
            Some(r) => r,
            None => {
                let d = self.inst(true, |d| Inst::Leaf {
                    d,
                    leaf: Leaf::Const(1.0),
                });
                self.one = Some(d);
                d
            }
        }
    }

    /// aᵉ as `f64::powi` computes it ([`lasalle_codegen::tape::powi`]): the squares a, a², a⁴, … multiplied into the
    /// result in increasing order, the first without a product, then 1/· for e < 0, each
    /// step with its Cauchy recurrence (so a^\[0\] = 0 is fine for e > 0). Returns the row.
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
                    Some(r) => self.inst(constant, |d| Inst::Mul { d, a: r, b: square }),
                });
            }
            bits >>= 1;
            if bits != 0 {
                square = self.inst(constant, |d| Inst::Square { d, a: square });
            }
        }
        let r = result.expect("e ≠ 0 has a bit set");
        if e < 0 {
            let one = self.one();
            self.inst(constant, |d| Inst::Div { d, a: one, b: r })
        } else {
            // e = 1 is the base itself (the tape never has it, but a hand-built tape may)
            r
        }
    }
}

/// Order 0: the instruction's own f64 operation (the tape's value).
#[inline]
fn zeroth(t: &mut [f64], inst: Inst, hoisted: &[f64], target: &[f64], gains: &[f64]) {
    match inst {
        Inst::Leaf { d, leaf } => {
            t[d] = match leaf {
                Leaf::Const(c) => c,
                Leaf::Hoisted(k) => hoisted[k],
                Leaf::Target(k) => target[k],
                Leaf::Gain(k) => gains[k],
            }
        }
        Inst::Add { d, a, b } => t[d] = t[a] + t[b],
        Inst::Sub { d, a, b } => t[d] = t[a] - t[b],
        Inst::Neg { d, a } => t[d] = -t[a],
        Inst::Mul { d, a, b } => t[d] = t[a] * t[b],
        Inst::Scale { d, a, c } => t[d] = t[a] * t[c],
        Inst::Square { d, a } => t[d] = t[a] * t[a],
        Inst::Div { d, a, b } => t[d] = t[a] / t[b],
        Inst::DivConst { d, a, c } => t[d] = t[a] / t[c],
        Inst::Pow { d, a, zero, .. } => {
            t[d] = match zero {
                PowZero::Cbrt => t[a].cbrt(),
                PowZero::Powf(p) => t[a].powf(p),
            }
        }
        Inst::Sqrt { d, a } => t[d] = t[a].sqrt(),
        Inst::Exp { d, a } => t[d] = t[a].exp(),
        Inst::Ln { d, a } => t[d] = t[a].ln(),
        Inst::SinCos { s, c, a } => {
            let (sa, ca) = t[a].sin_cos();
            t[s] = sa;
            t[c] = ca;
        }
        Inst::Jacobi { s, stride, a, m } => {
            let [sn, cn, dn] = [Func2::Sn, Func2::Cn, Func2::Dn].map(|f| f.apply(t[a], t[m]));
            for (i, v) in [sn, cn, dn, cn * dn, sn * dn, sn * cn]
                .into_iter()
                .enumerate()
            {
                t[s + i * stride] = v;
            }
        }
        Inst::EllipK { d, a } => t[d] = Func::EllipK.apply(t[a]),
        Inst::EllipF { d, a, m, .. } => t[d] = Func2::EllipF.apply(t[a], t[m]),
    }
}

/// Σ_{j=lo}^{hi} a^\[j\] b^\[k−j\] for rows at offsets a, b.
#[inline(always)]
fn cauchy(t: &[f64], a: usize, b: usize, k: usize, lo: usize, hi: usize) -> f64 {
    if lo > hi {
        return 0.0;
    }
    let ra = &t[a + lo..=a + hi];
    let rb = &t[b + k - hi..=b + k - lo];
    ra.iter().zip(rb.iter().rev()).map(|(x, y)| x * y).sum()
}

/// Σ_{j=1}^{k} j a^\[j\] b^\[k−j\] (the weighted product of the exp and sin/cos recurrences).
#[inline(always)]
fn weighted(t: &[f64], a: usize, b: usize, k: usize) -> f64 {
    let ra = &t[a + 1..=a + k];
    let rb = &t[b..b + k];
    ra.iter()
        .zip(rb.iter().rev())
        .enumerate()
        .map(|(j, (x, y))| (j + 1) as f64 * x * y)
        .sum()
}

/// Order k ≥ 1 of a non-constant instruction (see the table in the module docs).
#[inline]
fn coefficient(t: &mut [f64], inst: Inst, k: usize) {
    match inst {
        Inst::Leaf { .. } => {}
        Inst::Add { d, a, b } => t[d + k] = t[a + k] + t[b + k],
        Inst::Sub { d, a, b } => t[d + k] = t[a + k] - t[b + k],
        Inst::Neg { d, a } => t[d + k] = -t[a + k],
        Inst::Mul { d, a, b } => t[d + k] = cauchy(t, a, b, k, 0, k),
        Inst::Scale { d, a, c } => t[d + k] = t[a + k] * t[c],
        Inst::Square { d, a } => {
            // Σ_{j=0}^{k} a^[j] a^[k−j] = 2 Σ_{j<k/2} a^[j] a^[k−j] (+ a^[k/2]² for even k)
            let half = (k - 1) / 2; // the largest j < k/2
            let mut s = 2.0 * cauchy(t, a, a, k, 0, half);
            if k.is_multiple_of(2) {
                s += t[a + k / 2] * t[a + k / 2];
            }
            t[d + k] = s;
        }
        Inst::Div { d, a, b } => {
            t[d + k] = (t[a + k] - cauchy(t, b, d, k, 1, k)) / t[b];
        }
        Inst::DivConst { d, a, c } => t[d + k] = t[a + k] / t[c],
        Inst::Pow { d, a, alpha, .. } => {
            // u^[k] = 1/(k a0) Σ_{j=0}^{k−1} (α(k−j) − j) a^[k−j] u^[j]
            let kf = k as f64;
            let ra = &t[a + 1..=a + k];
            let ru = &t[d..d + k];
            let s: f64 = ru
                .iter()
                .zip(ra.iter().rev())
                .enumerate()
                .map(|(j, (u, x))| (alpha * (kf - j as f64) - j as f64) * x * u)
                .sum();
            t[d + k] = s / (kf * t[a]);
        }
        Inst::Sqrt { d, a } => {
            // u^[k] = (a^[k] − Σ_{j=1}^{k−1} u^[j] u^[k−j]) / (2 u0), the sum folded in half
            let mut s = 0.0;
            if k >= 2 {
                let half = (k - 1) / 2; // the largest j < k/2
                s = 2.0 * cauchy(t, d, d, k, 1, half);
                if k.is_multiple_of(2) {
                    s += t[d + k / 2] * t[d + k / 2];
                }
            }
            t[d + k] = (t[a + k] - s) / (2.0 * t[d]);
        }
        Inst::Exp { d, a } => t[d + k] = weighted(t, a, d, k) / k as f64,
        Inst::Ln { d, a } => {
            // (a^[k] − (1/k) Σ_{j=1}^{k−1} j u^[j] a^[k−j]) / a0
            let s = if k >= 2 {
                let ru = &t[d + 1..d + k];
                let ra = &t[a + 1..a + k];
                ru.iter()
                    .zip(ra.iter().rev())
                    .enumerate()
                    .map(|(j, (u, x))| (j + 1) as f64 * u * x)
                    .sum()
            } else {
                0.0
            };
            t[d + k] = (t[a + k] - s / k as f64) / t[a];
        }
        Inst::SinCos { s, c, a } => {
            let kf = k as f64;
            let sk = weighted(t, a, c, k) / kf;
            let ck = -weighted(t, a, s, k) / kf;
            t[s + k] = sk;
            t[c + k] = ck;
        }
        Inst::Jacobi { s, stride, a, m } => {
            // s' = c d a', c' = −s d a', d' = −m s c a' (m constant), then the products
            let [c, d, cd, sd, sc] = [1, 2, 3, 4, 5].map(|i| s + i * stride);
            let kf = k as f64;
            let sk = weighted(t, a, cd, k) / kf;
            let ck = -weighted(t, a, sd, k) / kf;
            let dk = -t[m] * weighted(t, a, sc, k) / kf;
            t[s + k] = sk;
            t[c + k] = ck;
            t[d + k] = dk;
            t[cd + k] = cauchy(t, c, d, k, 0, k);
            t[sd + k] = cauchy(t, s, d, k, 0, k);
            t[sc + k] = cauchy(t, s, c, k, 0, k);
        }
        Inst::EllipK { .. } => {} // constant along the solution
        Inst::EllipF { d, a, w, .. } => t[d + k] = weighted(t, a, w, k) / k as f64,
    }
}

/// Options of [`Taylor`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaylorOptions {
    /// The tolerance ε, absolute for ‖x‖∞ ≤ 1 and relative above (default `1e-15`).
    pub tol: f64,
    /// The order p; `None` (default) for Jorba & Zou's ⌈−½ ln ε + 1⌉.
    pub order: Option<u32>,
    /// The largest step (default `+∞`).
    pub h_max: f64,
}

impl Default for TaylorOptions {
    fn default() -> Self {
        TaylorOptions {
            tol: 1e-15,
            order: None,
            h_max: f64::INFINITY,
        }
    }
}

impl TaylorOptions {
    /// The defaults with tolerance `tol`.
    pub fn with_tol(tol: f64) -> Self {
        TaylorOptions {
            tol,
            ..Default::default()
        }
    }
}

/// Which field [`Taylor`] integrates as a `Stepper<f64, Vec<f64>, LoadedModel>`.
#[derive(Clone, Debug, PartialEq)]
pub enum TaylorField {
    /// The model's field X.
    Plain,
    /// The feedback field X − ∇V with the target f(x₀) (M values) and the gains.
    Feedback {
        /// f(x₀).
        target: Vec<f64>,
        /// The gains, one per declared gain.
        gains: Vec<f64>,
    },
}

/// Which coefficient table holds the last step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Which {
    Field,
    Feedback,
}

/// Adaptive Taylor integrator (Jorba & Zou 2005; heyoka) for a [`LoadedModel`]'s field X and
/// feedback field X − ∇V; see the [module docs](self).
///
/// - `Stepper<f64, Vec<f64>, LoadedModel>`: integrates X, or X − ∇V with the stepper's own
///   target and gains ([`Taylor::set_field`]); never allocates in a step.
/// - `Stepper<f64, Vec<f64>, FeedbackField<LoadedModel, Vec<f64>, Vec<f64>>>`: integrates
///   X − ∇V with the feedback field's target and current gains (read every step;
///   [`FeedbackField::gains`] hands out a copy, the one allocation of such a step).
///
/// The model passed to `step` must be the one given to [`Taylor::for_model`] (same functions);
/// a change of its parameters is picked up at the next step (the tapes' preludes are rerun).
#[derive(Clone, Debug)]
pub struct Taylor {
    opts: TaylorOptions,
    order: u32,
    field_tape: Tape,
    feedback_tape: Tape,
    field: TaylorTape,
    feedback: TaylorTape,
    mode: TaylorField,
    /// The parameters the hoisted values were computed for.
    params: Vec<f64>,
    /// The last accepted step (t, h) and the table holding its expansion.
    last: Option<(f64, f64, Which)>,
}

impl Taylor {
    /// The Taylor integrator of `model`'s field (mode [`TaylorField::Plain`]): rebuilds the
    /// model's tapes (field and X − ∇V) from [`LoadedModel::model`] and sizes the coefficient
    /// tables for the order of `opts`.
    pub fn for_model(model: &LoadedModel, opts: TaylorOptions) -> Result<Taylor, TaylorError> {
        let mut m = model.model().clone();
        let d = derive::derive(&mut m);
        let tapes = ModelTapes::new(&m, &d)?;
        Taylor::from_tapes(tapes.field, tapes.feedback, model.params(), opts)
    }

    /// The integrator of a field tape and its feedback tape (state → ẋ; the feedback tape also
    /// reads the targets and gains), with parameter values `params`.
    pub fn from_tapes(
        field_tape: Tape,
        feedback_tape: Tape,
        params: &[f64],
        opts: TaylorOptions,
    ) -> Result<Taylor, TaylorError> {
        if !(opts.tol > 0.0 && opts.tol < 1.0) {
            return Err(TaylorError::Option(format!(
                "the tolerance must lie in (0, 1), got {}",
                opts.tol
            )));
        }
        if opts.h_max.is_nan() || opts.h_max <= 0.0 {
            return Err(TaylorError::Option(format!(
                "h_max must be positive, got {}",
                opts.h_max
            )));
        }
        let order = opts.order.unwrap_or_else(|| order_for_tolerance(opts.tol));
        if !(2..=1000).contains(&order) {
            return Err(TaylorError::Option(format!(
                "the order must lie in 2..=1000, got {order}"
            )));
        }
        if feedback_tape.dims.state != field_tape.dims.state {
            return Err(TaylorError::Option(
                "the field and feedback tapes have different state dimensions".into(),
            ));
        }
        let field = TaylorTape::new(&field_tape, &field_tape.hoist(params)?, order)?;
        let feedback = TaylorTape::new(&feedback_tape, &feedback_tape.hoist(params)?, order)?;
        Ok(Taylor {
            opts,
            order,
            field_tape,
            feedback_tape,
            field,
            feedback,
            mode: TaylorField::Plain,
            params: params.to_vec(),
            last: None,
        })
    }

    /// Chooses the field of the `Stepper<f64, Vec<f64>, LoadedModel>` implementation.
    pub fn set_field(&mut self, mode: TaylorField) -> Result<(), TaylorError> {
        if let TaylorField::Feedback { target, gains } = &mode {
            self.feedback.set_inputs(target, gains)?;
        }
        self.mode = mode;
        self.last = None;
        Ok(())
    }

    /// [`Taylor::set_field`] returning `self`.
    pub fn with_field(mut self, mode: TaylorField) -> Result<Taylor, TaylorError> {
        self.set_field(mode)?;
        Ok(self)
    }

    /// The field integrated as a `Stepper<…, LoadedModel>`.
    pub fn field(&self) -> &TaylorField {
        &self.mode
    }

    /// The options.
    pub fn options(&self) -> TaylorOptions {
        self.opts
    }

    /// The coefficient recurrences of the field X.
    pub fn field_coefficients(&self) -> &TaylorTape {
        &self.field
    }

    /// The coefficient recurrences of the feedback field X − ∇V.
    pub fn feedback_coefficients(&self) -> &TaylorTape {
        &self.feedback
    }

    /// The coefficients x^\[0..=p\] of component `i` of the last accepted step's expansion
    /// (about its initial point), if there was one.
    pub fn last_coefficients(&self, i: usize) -> Option<&[f64]> {
        let (_, _, which) = self.last?;
        Some(self.table(which).state_coefficients(i))
    }

    fn table(&self, which: Which) -> &TaylorTape {
        match which {
            Which::Field => &self.field,
            Which::Feedback => &self.feedback,
        }
    }

    /// Reruns the preludes if the model's parameters changed since the last step.
    fn sync_params(&mut self, params: &[f64]) -> Result<(), StepError> {
        if params == self.params.as_slice() {
            return Ok(());
        }
        let bad = |e: &dyn std::fmt::Display| StepError::InvalidInput(format!("{e}"));
        let hf = self.field_tape.hoist(params).map_err(|e| bad(&e))?;
        let hb = self.feedback_tape.hoist(params).map_err(|e| bad(&e))?;
        self.field.set_hoisted(&hf).map_err(|e| bad(&e))?;
        self.feedback.set_hoisted(&hb).map_err(|e| bad(&e))?;
        self.params.clear();
        self.params.extend_from_slice(params);
        Ok(())
    }

    /// Coefficients at `x` in table `which`, and Jorba–Zou's step.
    fn expand(&mut self, which: Which, x: &[f64]) -> f64 {
        let p = self.order as usize;
        let tt = match which {
            Which::Field => &mut self.field,
            Which::Feedback => &mut self.feedback,
        };
        tt.compute(x, p);
        jorba_zou_step(self.order, tt.norm(0), tt.norm(p - 1), tt.norm(p))
    }

    /// One step of at most `h` in table `which`.
    fn advance(
        &mut self,
        which: Which,
        t: f64,
        x: &mut [f64],
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        let n = self.field.dim();
        if x.len() != n {
            return Err(StepError::InvalidInput(format!(
                "the state has {} components, the model {n}",
                x.len()
            )));
        }
        if h.is_nan() || h <= 0.0 {
            return Err(StepError::InvalidInput(format!(
                "step size must be positive, got {h}"
            )));
        }
        let h_jz = self.expand(which, x);
        if h_jz.is_nan() {
            return Err(StepError::NonFinite {
                what: "field",
                t,
                h,
                state: x.to_vec(),
            });
        }
        let h_own = h_jz.min(self.opts.h_max);
        let h_taken = h.min(h_own);
        let tt = self.table(which);
        // Horner into x; the coefficients stay in the table for the dense output
        tt.evaluate(h_taken, x);
        self.last = Some((t, h_taken, which));
        let h_next = if h_own.is_finite() { h_own } else { h };
        Ok(StepOutcome {
            h_taken,
            h_next,
            rejections: 0,
            evaluations: self.order,
        })
    }

    fn initial(&mut self, which: Which, t0: f64, x0: &[f64], t_end: f64) -> Option<f64> {
        if x0.len() != self.field.dim() {
            return None;
        }
        let h = self.expand(which, x0).min(self.opts.h_max);
        let span = t_end - t0;
        let h = if span > 0.0 { h.min(span) } else { h };
        (h > 0.0 && h.is_finite()).then_some(h)
    }
}

impl Stepper<f64, Vec<f64>, LoadedModel> for Taylor {
    /// A Taylor step of the field chosen by [`Taylor::set_field`]: the Jorba–Zou step, or `h`
    /// if smaller. Never rejects; `evaluations` reports the order p (each order is one sweep
    /// of the tape's recurrences).
    fn step(
        &mut self,
        model: &LoadedModel,
        t: f64,
        x: &mut Vec<f64>,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        self.sync_params(model.params())?;
        let which = match self.mode {
            TaylorField::Plain => Which::Field,
            TaylorField::Feedback { .. } => Which::Feedback,
        };
        self.advance(which, t, x, h)
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        format!("taylor({})", self.order)
    }

    fn is_adaptive(&self) -> bool {
        true
    }

    fn initial_step(
        &mut self,
        model: &LoadedModel,
        t0: f64,
        x0: &Vec<f64>,
        t_end: f64,
    ) -> Option<f64> {
        self.sync_params(model.params()).ok()?;
        let which = match self.mode {
            TaylorField::Plain => Which::Field,
            TaylorField::Feedback { .. } => Which::Feedback,
        };
        self.initial(which, t0, x0, t_end)
    }

    fn reset(&mut self) {
        self.last = None;
    }
}

impl Stepper<f64, Vec<f64>, FeedbackField<'_, LoadedModel, Vec<f64>, Vec<f64>>> for Taylor {
    /// A Taylor step of X − ∇V with the feedback field's target and current gains.
    fn step(
        &mut self,
        fb: &FeedbackField<'_, LoadedModel, Vec<f64>, Vec<f64>>,
        t: f64,
        x: &mut Vec<f64>,
        h: f64,
    ) -> Result<StepOutcome<f64>, StepError> {
        self.sync_params(fb.model().params())?;
        self.feedback
            .set_inputs(fb.target(), &fb.gains())
            .map_err(|e| StepError::InvalidInput(e.to_string()))?;
        self.advance(Which::Feedback, t, x, h)
    }

    fn order(&self) -> u32 {
        self.order
    }

    fn name(&self) -> String {
        format!("taylor({})", self.order)
    }

    fn is_adaptive(&self) -> bool {
        true
    }

    fn initial_step(
        &mut self,
        fb: &FeedbackField<'_, LoadedModel, Vec<f64>, Vec<f64>>,
        t0: f64,
        x0: &Vec<f64>,
        t_end: f64,
    ) -> Option<f64> {
        self.sync_params(fb.model().params()).ok()?;
        self.feedback.set_inputs(fb.target(), &fb.gains()).ok()?;
        self.initial(Which::Feedback, t0, x0, t_end)
    }

    fn reset(&mut self) {
        self.last = None;
    }
}

impl DenseOutput<f64, Vec<f64>> for Taylor {
    fn dense_interval(&self) -> Option<(f64, f64)> {
        self.last.map(|(t, h, _)| (t, t + h))
    }

    /// The Taylor polynomial of the last step at t − t_old, by Horner's scheme.
    fn interpolate(&self, t: f64, out: &mut Vec<f64>) -> bool {
        let Some((t0, h, which)) = self.last else {
            return false;
        };
        let s = t - t0;
        let slack = 1e-9 * h.abs().max(f64::MIN_POSITIVE);
        if !(s >= -slack && s <= h + slack) || out.len() != self.field.dim() {
            return false;
        }
        self.table(which).evaluate(s, out);
        true
    }
}

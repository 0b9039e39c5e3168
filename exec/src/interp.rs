//! The interpreter: one pass over the body per call.
//!
//! Registers live in a thread-local scratch buffer that is taken out of its cell for the
//! duration of a call and put back afterwards, so calls allocate nothing once a thread has
//! seen its largest tape, need no lock, and stay correct if a call is re-entered (the inner
//! call then finds the cell empty and uses a buffer of its own). With k lanes the buffer holds
//! register r of lane l at `r*k + l`, and every instruction is a loop over the lanes, which
//! the compiler vectorises.

use crate::{Common, Dims, ExecError, Kernel, Op, Reg, Tape};
use lasalle_codegen::ir::{Rational, Scalar};
use lasalle_codegen::tape::powi;
use std::cell::Cell;

thread_local! {
    static SCRATCH: Cell<Vec<f64>> = const { Cell::new(Vec::new()) };
}

/// Runs `f` on a scratch slice of `len` registers (contents unspecified).
fn with_scratch<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
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

/// A tape ready to be interpreted.
#[derive(Clone, Debug)]
pub struct Interpreter {
    common: Common,
    body: Vec<Op>,
    outputs: Vec<Reg>,
}

/// `Op::Powf` in f64: as the generic evaluation of the tape ([`Scalar::powf`] for f64).
pub fn powf(x: f64, p: Rational) -> f64 {
    Scalar::powf(&x, p)
}

impl Interpreter {
    /// Prepares a tape (checked with [`Tape::validate`]).
    pub fn new(tape: &Tape) -> Result<Interpreter, ExecError> {
        tape.validate()?;
        Ok(Interpreter {
            common: Common::new(tape),
            body: tape.body.clone(),
            outputs: tape.outputs.clone(),
        })
    }

    fn run(&self, hoisted: &[f64], state: &[f64], target: &[f64], gains: &[f64], w: &mut [f64]) {
        for (i, &op) in self.body.iter().enumerate() {
            let r = |k: Reg| w[k.index()];
            w[i] = match op {
                Op::State(k) => state[k as usize],
                Op::Target(k) => target[k as usize],
                Op::Gain(k) => gains[k as usize],
                Op::Hoisted(k) => hoisted[k as usize],
                // `validate` rejects parameters in the body.
                Op::Param(_) => f64::NAN,
                Op::Const(c) => c,
                Op::Add(a, b) => r(a) + r(b),
                Op::Sub(a, b) => r(a) - r(b),
                Op::Mul(a, b) => r(a) * r(b),
                Op::Div(a, b) => r(a) / r(b),
                Op::Neg(a) => -r(a),
                Op::Powi(a, n) => powi(r(a), n),
                Op::Sqrt(a) => r(a).sqrt(),
                Op::Cbrt(a) => r(a).cbrt(),
                Op::Powf(a, p) => powf(r(a), p),
                Op::Exp(a) => r(a).exp(),
                Op::Ln(a) => r(a).ln(),
                Op::Sin(a) => r(a).sin(),
                Op::Cos(a) => r(a).cos(),
            };
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn run_lanes(
        &self,
        k: usize,
        hoisted: &[f64],
        state: &[f64],
        target: &[f64],
        gains: &[f64],
        w: &mut [f64],
    ) {
        for (i, &op) in self.body.iter().enumerate() {
            let (src, dst) = w.split_at_mut(i * k);
            let dst = &mut dst[..k];
            let lane = |r: Reg| &src[r.index() * k..][..k];
            match op {
                Op::State(s) => dst.copy_from_slice(&state[s as usize * k..][..k]),
                Op::Target(t) => dst.fill(target[t as usize]),
                Op::Gain(g) => dst.fill(gains[g as usize]),
                Op::Hoisted(h) => dst.fill(hoisted[h as usize]),
                Op::Param(_) => dst.fill(f64::NAN),
                Op::Const(c) => dst.fill(c),
                Op::Add(a, b) => map2(dst, lane(a), lane(b), |x, y| x + y),
                Op::Sub(a, b) => map2(dst, lane(a), lane(b), |x, y| x - y),
                Op::Mul(a, b) => map2(dst, lane(a), lane(b), |x, y| x * y),
                Op::Div(a, b) => map2(dst, lane(a), lane(b), |x, y| x / y),
                Op::Neg(a) => map1(dst, lane(a), |x| -x),
                Op::Powi(a, n) => map1(dst, lane(a), |x| powi(x, n)),
                Op::Sqrt(a) => map1(dst, lane(a), f64::sqrt),
                Op::Cbrt(a) => map1(dst, lane(a), f64::cbrt),
                Op::Powf(a, p) => map1(dst, lane(a), |x| powf(x, p)),
                Op::Exp(a) => map1(dst, lane(a), f64::exp),
                Op::Ln(a) => map1(dst, lane(a), f64::ln),
                Op::Sin(a) => map1(dst, lane(a), f64::sin),
                Op::Cos(a) => map1(dst, lane(a), f64::cos),
            }
        }
    }
}

#[inline(always)]
fn map1(dst: &mut [f64], a: &[f64], f: impl Fn(f64) -> f64) {
    for (d, &x) in dst.iter_mut().zip(a) {
        *d = f(x);
    }
}

#[inline(always)]
fn map2(dst: &mut [f64], a: &[f64], b: &[f64], f: impl Fn(f64, f64) -> f64) {
    for ((d, &x), &y) in dst.iter_mut().zip(a).zip(b) {
        *d = f(x, y);
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
        with_scratch(self.body.len(), |w| {
            self.run(hoisted, state, target, gains, w);
            for (o, r) in out.iter_mut().zip(&self.outputs) {
                *o = w[r.index()];
            }
        });
        Ok(())
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
        // `check` proved state.len() = N·k, so N·k fits; registers ≥ N need their own check.
        let len = self
            .body
            .len()
            .checked_mul(k)
            .ok_or(crate::TapeError::TooLarge)?;
        with_scratch(len, |w| {
            self.run_lanes(k, hoisted, state, target, gains, w);
            for (j, r) in self.outputs.iter().enumerate() {
                out[j * k..][..k].copy_from_slice(&w[r.index() * k..][..k]);
            }
        });
        Ok(())
    }
}

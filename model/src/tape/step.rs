//! A whole step of a fixed-step explicit Runge–Kutta method as one tape: the stages, the
//! update and the guards' margins of the new state, so that a back end compiles a step as one
//! function instead of calling the field once per stage from a generic stepper.
//!
//! The step does the IEEE operations of `lasalle_runtime::ExplicitRk::step`, in its order, so
//! that a run with the compiled step is bitwise the run with the generic stepper:
//! `y = x`, then `y = y + (h·a_ij)·k_j` for j < i with a_ij ≠ 0, `k_i = X(y)`; and
//! `x' = x`, then `x' = x' + (h·b_i)·k_i` for b_i ≠ 0.

use std::collections::HashMap;

use super::{Dims, Op, Reg, Tape, TapeError};

/// The step tape of the explicit Runge–Kutta method with coefficients `a` (row i holds
/// a_i0 … a_i(i−1); rows may be longer, the rest is ignored) and weights `b` on `field`, and
/// the margins of `guards` (a tape whose gain 0 is the step size the guards read) on the new
/// state.
///
/// Inputs: the state and the field's targets; the gains are the field's, then h (the step
/// taken), then the step size the guards read. Outputs: x_{n+1} (N values), then the guards'
/// margins.
pub fn rk_step(
    field: &Tape,
    a: &[&[f64]],
    b: &[f64],
    guards: Option<&Tape>,
) -> Result<Tape, TapeError> {
    let n = field.dims.state;
    if field.outputs.len() != n
        || a.len() != b.len()
        || a.iter().enumerate().any(|(i, row)| row.len() < i)
    {
        return Err(TapeError::Malformed(format!(
            "a Runge–Kutta step needs a field of {n} outputs (it has {}) and a tableau of \
             matching rows and weights ({} rows, {} weights)",
            field.outputs.len(),
            a.len(),
            b.len()
        )));
    }
    if let Some(g) = guards {
        if g.dims.state != n || g.dims.gains != 1 || g.dims.targets != 0 {
            return Err(TapeError::Malformed(
                "the guards' tape must read the state and one gain (the step size)".to_string(),
            ));
        }
    }
    let mut step = Composer::new(field, guards);
    let gains = field.dims.gains as u32;
    let x: Vec<Reg> = (0..n as u32).map(|i| step.leaf(Op::State(i))).collect();
    let h = step.leaf(Op::Gain(gains));
    let mut k: Vec<Vec<Reg>> = Vec::with_capacity(b.len());
    for row in a {
        let mut y = x.clone();
        for (j, &c) in row.iter().take(k.len()).enumerate() {
            step.accumulate(&mut y, h, c, &k[j]);
        }
        let ki = step.inline(field, &y, &|g| Op::Gain(g), 0);
        k.push(ki);
    }
    let mut next = x;
    for (ki, &c) in k.iter().zip(b) {
        step.accumulate(&mut next, h, c, ki);
    }
    let mut outputs = next.clone();
    if let Some(g) = guards {
        let dt = Op::Gain(gains + 1);
        let offset = field.hoisted.len() as u32;
        outputs.extend(step.inline(g, &next, &|_| dt, offset));
    }
    let dims = Dims {
        gains: field.dims.gains + 2,
        ..field.dims
    };
    let tape = Tape {
        prelude: step.prelude,
        hoisted: step.hoisted,
        body: step.body,
        outputs,
        dims,
    };
    tape.validate()?;
    Ok(tape)
}

/// The step's tape under construction.
struct Composer {
    prelude: Vec<Op>,
    hoisted: Vec<Reg>,
    body: Vec<Op>,
    /// Leaves (inputs, hoisted values, constants) already in the body, each written once.
    leaves: HashMap<(u8, u64, u64), Reg>,
}

impl Composer {
    /// The field's prelude, then the guards' (their registers shifted after the field's).
    fn new(field: &Tape, guards: Option<&Tape>) -> Composer {
        let mut prelude = field.prelude.clone();
        let mut hoisted = field.hoisted.clone();
        if let Some(g) = guards {
            let shift = field.prelude.len() as u32;
            prelude.extend(g.prelude.iter().map(|op| remap(*op, |r| Reg(r.0 + shift))));
            hoisted.extend(g.hoisted.iter().map(|r| Reg(r.0 + shift)));
        }
        Composer {
            prelude,
            hoisted,
            body: Vec::new(),
            leaves: HashMap::new(),
        }
    }

    fn push(&mut self, op: Op) -> Reg {
        self.body.push(op);
        Reg(self.body.len() as u32 - 1)
    }

    fn leaf(&mut self, op: Op) -> Reg {
        if let Some(&r) = self.leaves.get(&op.key()) {
            return r;
        }
        let r = self.push(op);
        self.leaves.insert(op.key(), r);
        r
    }

    /// `y = y + (h·c)·k`, componentwise, unless c = 0 (as the generic stepper does).
    fn accumulate(&mut self, y: &mut [Reg], h: Reg, c: f64, k: &[Reg]) {
        if c == 0.0 {
            return;
        }
        let c = self.leaf(Op::Const(c));
        let hc = self.push(Op::Mul(h, c));
        for (yn, &kn) in y.iter_mut().zip(k) {
            let term = self.push(Op::Mul(hc, kn));
            *yn = self.push(Op::Add(*yn, term));
        }
    }

    /// The body of `tape` on the state `x`, its gains mapped by `gain`, its hoisted values
    /// shifted by `hoisted`; the registers of its outputs.
    fn inline(
        &mut self,
        tape: &Tape,
        x: &[Reg],
        gain: &dyn Fn(u32) -> Op,
        hoisted: u32,
    ) -> Vec<Reg> {
        let mut regs = Vec::with_capacity(tape.body.len());
        for op in &tape.body {
            let r = match *op {
                Op::State(i) => x[i as usize],
                Op::Gain(g) => self.leaf(gain(g)),
                Op::Hoisted(i) => self.leaf(Op::Hoisted(i + hoisted)),
                Op::Target(_) | Op::Const(_) => self.leaf(*op),
                _ => {
                    let op = remap(*op, |r| regs[r.index()]);
                    self.push(op)
                }
            };
            regs.push(r);
        }
        tape.outputs.iter().map(|r| regs[r.index()]).collect()
    }
}

/// `op` with its operands renamed by `f`.
fn remap(op: Op, f: impl Fn(Reg) -> Reg) -> Op {
    match op {
        Op::Add(a, b) => Op::Add(f(a), f(b)),
        Op::Sub(a, b) => Op::Sub(f(a), f(b)),
        Op::Mul(a, b) => Op::Mul(f(a), f(b)),
        Op::Div(a, b) => Op::Div(f(a), f(b)),
        Op::Func2(g, a, b) => Op::Func2(g, f(a), f(b)),
        Op::Neg(a) => Op::Neg(f(a)),
        Op::Powi(a, n) => Op::Powi(f(a), n),
        Op::Sqrt(a) => Op::Sqrt(f(a)),
        Op::Cbrt(a) => Op::Cbrt(f(a)),
        Op::Powf(a, p) => Op::Powf(f(a), p),
        Op::Exp(a) => Op::Exp(f(a)),
        Op::Ln(a) => Op::Ln(f(a)),
        Op::Sin(a) => Op::Sin(f(a)),
        Op::Cos(a) => Op::Cos(f(a)),
        Op::EllipK(a) => Op::EllipK(f(a)),
        Op::State(_)
        | Op::Param(_)
        | Op::Target(_)
        | Op::Gain(_)
        | Op::Hoisted(_)
        | Op::Const(_) => op,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{Func, Graph, Input, Rational};

    /// The pendulum q̇ = p, ṗ = −(g/l)·sin q with parameters g, l, and the guard
    /// `dt·|p| <= 1` (margin 1 − dt·√(p²)).
    fn pendulum() -> (Tape, Tape) {
        let mut g = Graph::new();
        let [q, p] = [0, 1].map(|i| g.input(Input::State(i)));
        let [gr, l] = [0, 1].map(|i| g.input(Input::Param(i)));
        let sin = g.func(Func::Sin, q);
        let inv_l = g.pow(l, Rational::int(-1));
        let acc = g.mul(&[gr, inv_l, sin]);
        let pdot = g.neg(acc);
        let dims = Dims {
            state: 2,
            params: 2,
            ..Dims::default()
        };
        let field = Tape::from_graph(&g, &[p, pdot], dims).unwrap();
        let mut g = Graph::new();
        let p = g.input(Input::State(1));
        let dt = g.input(Input::Gain(0));
        let p2 = g.mul(&[p, p]);
        let speed = g.sqrt(p2);
        let one = g.num(1.0);
        let reach = g.mul(&[dt, speed]);
        let margin = g.sub(one, reach);
        let guards = Tape::from_graph(&g, &[margin], Dims { gains: 1, ..dims }).unwrap();
        (field, guards)
    }

    /// The generic stepper's arithmetic, on the field's tape.
    fn reference_step(
        field: &Tape,
        params: &[f64],
        a: &[&[f64]],
        b: &[f64],
        x: &[f64],
        h: f64,
    ) -> Vec<f64> {
        let f = |y: &[f64]| field.eval(params, y, &[], &[]).unwrap();
        let mut k: Vec<Vec<f64>> = Vec::new();
        for row in a {
            let mut y = x.to_vec();
            for (j, &c) in row.iter().take(k.len()).enumerate() {
                if c != 0.0 {
                    let hc = h * c;
                    for (yn, kn) in y.iter_mut().zip(&k[j]) {
                        *yn += hc * *kn;
                    }
                }
            }
            k.push(f(&y));
        }
        let mut next = x.to_vec();
        for (ki, &c) in k.iter().zip(b) {
            if c != 0.0 {
                let hc = h * c;
                for (xn, kn) in next.iter_mut().zip(ki) {
                    *xn += hc * *kn;
                }
            }
        }
        next
    }

    #[test]
    fn a_step_tape_is_bitwise_the_generic_step_with_the_guards_margins() {
        let (field, guards) = pendulum();
        let params = [9.81, 1.3];
        let rk4: [&[f64]; 4] = [&[], &[0.5], &[0.0, 0.5], &[0.0, 0.0, 1.0]];
        let b4 = [1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0];
        let euler: [&[f64]; 1] = [&[]];
        for (a, b) in [(&rk4[..], &b4[..]), (&euler[..], &[1.0][..])] {
            let step = rk_step(&field, a, b, Some(&guards)).unwrap();
            assert_eq!(step.outputs.len(), 3);
            let (h, dt) = (0.0173, 0.02);
            let mut x = vec![1.1, -0.4];
            for _ in 0..50 {
                let out = step.eval(&params, &x, &[], &[h, dt]).unwrap();
                let expect = reference_step(&field, &params, a, b, &x, h);
                assert_eq!(out[0].to_bits(), expect[0].to_bits());
                assert_eq!(out[1].to_bits(), expect[1].to_bits());
                let margin = guards.eval(&params, &expect, &[], &[dt]).unwrap()[0];
                assert_eq!(out[2].to_bits(), margin.to_bits());
                x = expect;
            }
        }
        // without guards: the new state only; a tableau that does not fit is refused
        assert_eq!(
            rk_step(&field, &euler, &[1.0], None).unwrap().outputs.len(),
            2
        );
        assert!(rk_step(&field, &rk4, &[1.0], None).is_err());
    }
}

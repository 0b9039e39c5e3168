//! The continuous extension of one step: the stepper's own dense output where it has one
//! (DOPRI5's interpolant, the Taylor polynomial), else the cubic Hermite interpolant of the
//! step's end states and fields.

use crate::state::State;
use crate::steppers::DenseOutput;

/// The cubic Hermite interpolant on [t₀, t₁] of x₀, x₁ with derivatives f₀ = X(x₀),
/// f₁ = X(x₁) (HNW I §II.6, eq. (6.7)): third order, exact at both ends.
pub struct Hermite<'a, X> {
    /// Start of the step.
    pub t0: f64,
    /// End of the step.
    pub t1: f64,
    /// State at t₀.
    pub x0: &'a X,
    /// State at t₁.
    pub x1: &'a X,
    /// Field at x₀.
    pub f0: &'a X,
    /// Field at x₁.
    pub f1: &'a X,
}

impl<X: State<f64>> Hermite<'_, X> {
    /// The weights of x₀, x₁, f₀, f₁ at t.
    fn weights(&self, t: f64) -> [f64; 4] {
        let h = self.t1 - self.t0;
        let s = ((t - self.t0) / h).clamp(0.0, 1.0);
        let s2 = s * s;
        let s3 = s2 * s;
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h01 = 1.0 - h00;
        let h10 = (s3 - 2.0 * s2 + s) * h;
        let h11 = (s3 - s2) * h;
        [h00, h01, h10, h11]
    }

    /// x(t) for t in [t₀, t₁], into `out`.
    pub fn eval(&self, t: f64, out: &mut X) {
        let [h00, h01, h10, h11] = self.weights(t);
        let ends = self.x0.as_ref().iter().zip(self.x1.as_ref());
        let slopes = self.f0.as_ref().iter().zip(self.f1.as_ref());
        for (o, ((x0, x1), (f0, f1))) in out.as_mut().iter_mut().zip(ends.zip(slopes)) {
            *o = h00 * x0 + h01 * x1 + h10 * f0 + h11 * f1;
        }
    }

    /// x(t) at each of the times `ts` into `outs` (as many): bitwise what [`Hermite::eval`]
    /// writes at each, the weights of all the times computed first (their divisions
    /// overlap).
    pub fn eval_many(&self, ts: &[f64], outs: &mut [X]) {
        const TIMES: usize = 4;
        for (ts, outs) in ts.chunks(TIMES).zip(outs.chunks_mut(TIMES)) {
            let mut w = [[0.0; 4]; TIMES];
            for (wk, &t) in w.iter_mut().zip(ts) {
                *wk = self.weights(t);
            }
            for (out, [h00, h01, h10, h11]) in outs.iter_mut().zip(&w) {
                let ends = self.x0.as_ref().iter().zip(self.x1.as_ref());
                let slopes = self.f0.as_ref().iter().zip(self.f1.as_ref());
                for (o, ((x0, x1), (f0, f1))) in out.as_mut().iter_mut().zip(ends.zip(slopes)) {
                    *o = h00 * x0 + h01 * x1 + h10 * f0 + h11 * f1;
                }
            }
        }
    }
}

/// The continuous extension of the step just taken.
pub enum Extension<'a, X> {
    /// The stepper's dense output over [t₀, t₁] (times are clamped into it).
    Dense(&'a dyn DenseOutput<f64, X>, f64, f64),
    /// The Hermite cubic of the end states and fields.
    Hermite(Hermite<'a, X>),
}

impl<X: State<f64>> Extension<'_, X> {
    /// x(t) into `out`; at the step's ends exactly the states the stepper produced.
    pub fn eval(&self, t: f64, out: &mut X) {
        match self {
            Extension::Dense(d, t0, t1) => {
                if !d.interpolate(t.clamp(*t0, *t1), out) {
                    // outside the stepper's interval by more than its slack: never at the
                    // times a step's watch asks for, which lie in [t₀, t₁]
                    out.as_mut().iter_mut().for_each(|v| *v = f64::NAN);
                }
            }
            Extension::Hermite(h) => h.eval(t, out),
        }
    }

    /// x(t) at each of the times `ts` into `outs` (as many), bitwise what
    /// [`Extension::eval`] writes at each; the times together cost less than one by one.
    pub fn eval_many(&self, ts: &[f64], outs: &mut [X]) {
        match self {
            Extension::Dense(d, t0, t1) => {
                let mut clamped = [0.0; 8];
                for (ts, outs) in ts.chunks(clamped.len()).zip(outs.chunks_mut(clamped.len())) {
                    for (c, &t) in clamped.iter_mut().zip(ts) {
                        *c = t.clamp(*t0, *t1);
                    }
                    if !d.interpolate_many(&clamped[..ts.len()], outs) {
                        // outside the stepper's interval: as `eval`, never at the watch's times
                        for (out, &t) in outs.iter_mut().zip(ts) {
                            self.eval(t, out);
                        }
                    }
                }
            }
            Extension::Hermite(h) => h.eval_many(ts, outs),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Several times at once are bitwise the times one by one.
    #[test]
    fn hermite_many_is_hermite_one_by_one() {
        let (x0, x1, f0, f1) = ([1.0, -0.3], [0.7, 0.2], [-0.4, 1.1], [0.3, 0.9]);
        let h = Hermite {
            t0: 0.1,
            t1: 0.37,
            x0: &x0,
            x1: &x1,
            f0: &f0,
            f1: &f1,
        };
        let ts = [0.1, 0.1675, 0.235, 0.3025, 0.37 - 2.7e-7, 0.37];
        let mut many = [[0.0; 2]; 6];
        h.eval_many(&ts, &mut many);
        for (t, m) in ts.iter().zip(&many) {
            let mut one = [0.0; 2];
            h.eval(*t, &mut one);
            assert_eq!(one.map(f64::to_bits), m.map(f64::to_bits), "{t}");
        }
    }

    /// The Hermite cubic reproduces a cubic exactly.
    #[test]
    fn hermite_is_exact_on_cubics() {
        let p = |t: f64| 1.0 - 2.0 * t + 0.5 * t * t + 0.25 * t.powi(3);
        let dp = |t: f64| -2.0 + t + 0.75 * t * t;
        let (t0, t1) = (0.3, 1.1);
        let (x0, x1, f0, f1) = ([p(t0)], [p(t1)], [dp(t0)], [dp(t1)]);
        let h = Hermite {
            t0,
            t1,
            x0: &x0,
            x1: &x1,
            f0: &f0,
            f1: &f1,
        };
        let mut out = [0.0];
        for k in 0..=10 {
            let t = t0 + (t1 - t0) * k as f64 / 10.0;
            h.eval(t, &mut out);
            assert!((out[0] - p(t)).abs() < 1e-15, "{t}");
        }
    }
}

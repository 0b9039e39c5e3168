//! The Taylor integrator (`lasalle_exec::taylor`):
//! - coefficients against closed forms (exponential growth, harmonic oscillator, circular
//!   Kepler orbit), against repeated differentiation (x^[k+1] = (1/(k+1)) D x^[k] · X, by
//!   finite differences of the coefficients themselves) and order 1 against the field tape,
//!   bitwise;
//! - every op's recurrence against the Taylor expansion of random-ish expressions of one
//!   variable, computed independently by the Cauchy integral formula (trapezoidal rule on a
//!   circle, evaluating the tape in complex arithmetic);
//! - adaptive runs at tol 1e-15: harmonic oscillator and Kepler e = 0.8 (invariants within
//!   1e-13), the feedback field, dense output against steps;
//! - no allocation per step (a counting allocator);
//! - `#[ignore]`d timing runs (Kepler 1000 periods, rigid body t = 1000): `cargo test --release
//!   -p lasalle-exec --test taylor -- --ignored --nocapture`.

use lasalle_exec::taylor::{jorba_zou_step, order_for_tolerance};
use lasalle_exec::{Backend, LoadedModel, TaylorField, TaylorOptions, TaylorTape};
use lasalle_model::ir::{Rational, Scalar};
use lasalle_model::tape::{ModelTapes, Tape};
use lasalle_runtime::{
    integrate, DenseOutput, Driver, FeedbackField, Field, Invariants, Parameters, Stepper,
    TaylorKernel,
};
use lasalle_testkit::{allocations, assert_same, same, CountingAllocator};

// ---------------------------------------------------------------------------------------
// Allocation counting (per thread: the test harness runs tests in parallel)

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

// ---------------------------------------------------------------------------------------
// Helpers

fn model_text(name: &str) -> String {
    std::fs::read_to_string(format!(
        "{}/../models/{name}.lsl",
        env!("CARGO_MANIFEST_DIR")
    ))
    .expect("model file")
}

/// The tapes of a model text (not checked: test models need not declare invariants).
fn tapes(text: &str) -> (ModelTapes, Vec<f64>) {
    let derived =
        lasalle_model::derive(lasalle_model::lower_source("test.lsl", text).expect("model"));
    let tapes = ModelTapes::new(&derived).expect("tapes");
    (tapes, derived.model.default_params())
}

/// x^[0..=order] per component of the field tape at `x`.
fn coefficients(tape: &Tape, params: &[f64], x: &[f64], order: usize) -> Vec<Vec<f64>> {
    let mut tt = TaylorTape::new(tape, params, order as u32).unwrap();
    tt.compute(x, order);
    (0..x.len())
        .map(|i| tt.state_coefficients(i).to_vec())
        .collect()
}

fn factorial(k: usize) -> f64 {
    (1..=k).map(|i| i as f64).product()
}

fn kepler_energy(x: &[f64]) -> f64 {
    let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
    0.5 * (x[3] * x[3] + x[4] * x[4] + x[5] * x[5]) - 1.0 / r
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

const OSC: &str = "model Osc { state q: scalar, p: scalar; param w = 2;
    d/dt q = p; d/dt p = -w^2 * q; integral E = p^2/2 + w^2 * q^2/2;
    point start { q = 0.3; p = -0.8; } }";

// ---------------------------------------------------------------------------------------
// Coefficients: closed forms

#[test]
fn exponential_growth() {
    let (t, params) = tapes("model G { state x: scalar; param a = 0.7; d/dt x = a * x; }");
    let c = coefficients(&t.field, &params, &[1.3], 25);
    for (k, &ck) in c[0].iter().enumerate() {
        let exact = 1.3 * 0.7f64.powi(k as i32) / factorial(k);
        assert!(
            (ck - exact).abs() <= 1e-15 * exact,
            "k = {k}: {ck} vs {exact}"
        );
    }
}

#[test]
fn harmonic_oscillator() {
    let (t, params) = tapes(OSC);
    let (q0, p0, w) = (0.3, -0.8, 2.0f64);
    let c = coefficients(&t.field, &params, &[q0, p0], 24);
    // q = q0 cos wt + p0/w sin wt, p = q'
    let cos_d = [1.0, 0.0, -1.0, 0.0];
    let sin_d = [0.0, 1.0, 0.0, -1.0];
    for k in 0..=24 {
        let wk = w.powi(k as i32) / factorial(k);
        let q = (q0 * cos_d[k % 4] + p0 / w * sin_d[k % 4]) * wk;
        let wk1 = w.powi(k as i32 + 1) / factorial(k);
        let p = (q0 * cos_d[(k + 1) % 4] + p0 / w * sin_d[(k + 1) % 4]) * wk1;
        assert!(
            (c[0][k] - q).abs() <= 1e-15 * wk.max(1e-300) * 4.0,
            "q k={k}"
        );
        assert!(
            (c[1][k] - p).abs() <= 1e-15 * wk1.max(1e-300) * 4.0,
            "p k={k}"
        );
    }
}

#[test]
fn kepler_circular_orbit() {
    let (t, params) = tapes(&model_text("kepler"));
    // x = (cos t, sin t, 0), v = (−sin t, cos t, 0) for μ = 1, r = 1
    // r = 1 along the orbit: the coefficients of x·x = cos² + sin² (of size 2^k/k!) cancel to
    // round-off, which r^-3 = 1/(√(x·x))³ amplifies further: the error of order k is a few
    // ε 3^k / k! (absolute 6e-26 at k = 22, where the coefficient is 9e-22)
    let c = coefficients(&t.field, &params, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 22);
    let cos_d = [1.0, 0.0, -1.0, 0.0];
    let sin_d = [0.0, 1.0, 0.0, -1.0];
    for k in 0..=22 {
        let f = factorial(k);
        let want = [
            cos_d[k % 4] / f,
            sin_d[k % 4] / f,
            0.0,
            cos_d[(k + 1) % 4] / f,
            sin_d[(k + 1) % 4] / f,
            0.0,
        ];
        for i in 0..6 {
            assert!(
                (c[i][k] - want[i]).abs() <= 1e-14 * 3f64.powi(k as i32) / f,
                "component {i}, k = {k}: {} vs {}",
                c[i][k],
                want[i]
            );
        }
    }
}

/// Order 1 is the field itself, bitwise (order 0 of every recurrence is the tape's own f64
/// operation, powi included).
#[test]
fn order_one_is_the_field_bitwise() {
    for (name, x) in [
        ("kepler", vec![1.0, 0.1, -0.2, 0.05, 1.3, 0.2]),
        (
            "rigid_body",
            vec![
                0.9, 0.1, 0.2, -0.1, 0.8, 0.3, 0.05, -0.2, 1.1, 1.0, 0.7, -0.4,
            ],
        ),
        ("cr3bp", vec![0.5, 0.2, -0.1, 0.3]),
        ("perturbed_kepler", vec![1.0, 0.1, -0.2, 0.05, 1.3, 0.2]),
        ("pendulum_closed_form", vec![0.7, 0.1, 1.2, -0.3, 0.2, 0.4]),
    ] {
        let (t, params) = tapes(&model_text(name));
        let c = coefficients(&t.field, &params, &x, 3);
        let f = t.field.eval(&params, &x, &[], &[]).unwrap();
        for i in 0..x.len() {
            assert_eq!(c[i][0].to_bits(), x[i].to_bits());
            assert_eq!(c[i][1].to_bits(), f[i].to_bits(), "{name}: component {i}");
        }
    }
}

/// x^[k+1](x) = (1/(k+1)) · D x^[k](x) · X(x): the coefficients as functions of the state are
/// the Lie derivatives of each other. The directional derivative is a 4th-order central
/// difference of the coefficient functions along X.
#[test]
fn repeated_differentiation() {
    let cases = [
        ("kepler", vec![1.0, 0.1, -0.2, 0.05, 1.3, 0.2]),
        (
            "rigid_body",
            vec![
                0.9, 0.1, 0.2, -0.1, 0.8, 0.3, 0.05, -0.2, 1.1, 1.0, 0.7, -0.4,
            ],
        ),
        ("cr3bp", vec![0.5, 0.2, -0.1, 0.3]),
    ];
    let trig = "model Mixed { state a: scalar, b: scalar, c: scalar;
        d/dt a = sin(b) * exp(-c^2) + (1 + a^2)^(1/3);
        d/dt b = cos(a) - log(2 + b^2) / (1 + c^2);
        d/dt c = (a*b + 3)^(-3/2) - (1 + c^4)^(1/2); }";
    let mut all: Vec<(ModelTapes, Vec<f64>, Vec<f64>)> = cases
        .iter()
        .map(|(n, x)| {
            let (t, p) = tapes(&model_text(n));
            (t, p, x.clone())
        })
        .collect();
    let (t, p) = tapes(trig);
    all.push((t, p, vec![0.3, -0.4, 0.5]));
    for (t, params, x) in &all {
        let order = 7;
        let base = coefficients(&t.field, params, x, order);
        let fx = t.field.eval(params, x, &[], &[]).unwrap();
        let scale = fx.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let eps = 1e-3 / scale;
        let at = |s: f64| {
            let y: Vec<f64> = x.iter().zip(&fx).map(|(xi, fi)| xi + s * fi).collect();
            coefficients(&t.field, params, &y, order)
        };
        let (p1, m1, p2, m2) = (at(eps), at(-eps), at(2.0 * eps), at(-2.0 * eps));
        for k in 1..order {
            for i in 0..x.len() {
                let d = (-p2[i][k] + 8.0 * p1[i][k] - 8.0 * m1[i][k] + m2[i][k]) / (12.0 * eps);
                let want = d / (k as f64 + 1.0);
                let mag = (0..x.len())
                    .map(|j| base[j][k + 1].abs())
                    .fold(1e-3, f64::max);
                assert!(
                    (base[i][k + 1] - want).abs() <= 1e-7 * mag,
                    "component {i}, k = {}: {} vs {want}",
                    k + 1,
                    base[i][k + 1]
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Every op against the Cauchy integral formula

/// A complex number, to evaluate tapes off the real axis.
#[derive(Clone, Copy, Debug)]
struct C {
    re: f64,
    im: f64,
}

impl C {
    fn new(re: f64, im: f64) -> C {
        C { re, im }
    }
    fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }
    fn arg(self) -> f64 {
        self.im.atan2(self.re)
    }
}

impl Scalar for C {
    fn from_f64(c: f64) -> Self {
        C::new(c, 0.0)
    }
    fn add(&self, o: &Self) -> Self {
        C::new(self.re + o.re, self.im + o.im)
    }
    fn mul(&self, o: &Self) -> Self {
        C::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn recip(&self) -> Self {
        let d = self.re * self.re + self.im * self.im;
        C::new(self.re / d, -self.im / d)
    }
    fn powi(&self, n: i32) -> Self {
        let mut r = C::from_f64(1.0);
        for _ in 0..n.unsigned_abs() {
            r = r.mul(self);
        }
        if n < 0 {
            r.recip()
        } else {
            r
        }
    }
    fn powf(&self, p: Rational) -> Self {
        self.ln().mul(&C::from_f64(p.to_f64())).exp()
    }
    fn exp(&self) -> Self {
        let m = self.re.exp();
        C::new(m * self.im.cos(), m * self.im.sin())
    }
    fn ln(&self) -> Self {
        C::new(self.abs().ln(), self.arg())
    }
    fn sin(&self) -> Self {
        C::new(
            self.re.sin() * self.im.cosh(),
            self.re.cos() * self.im.sinh(),
        )
    }
    fn cos(&self) -> Self {
        C::new(
            self.re.cos() * self.im.cosh(),
            -self.re.sin() * self.im.sinh(),
        )
    }
}

/// Normalised Taylor coefficients g^[0..=kmax] of g at t0 by the Cauchy integral formula,
/// g^[k] = (1/2πi) ∮ g(z) / (z − t0)^{k+1} dz on |z − t0| = r, by the trapezoidal rule with
/// `n` nodes (exact up to the aliased coefficients g^[k + n] rⁿ, below round-off here).
fn cauchy_coefficients(g: impl Fn(C) -> C, t0: f64, r: f64, n: usize, kmax: usize) -> Vec<f64> {
    let values: Vec<(f64, C)> = (0..n)
        .map(|j| {
            let th = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
            (th, g(C::new(t0 + r * th.cos(), r * th.sin())))
        })
        .collect();
    (0..=kmax)
        .map(|k| {
            let s: f64 = values
                .iter()
                .map(|&(th, v)| {
                    // Re(v e^{−ikθ})
                    let (c, s) = ((k as f64 * th).cos(), (k as f64 * th).sin());
                    v.re * c + v.im * s
                })
                .sum();
            s / n as f64 / r.powi(k as i32)
        })
        .collect()
}

/// One-variable expressions covering every operation's recurrence (y' = g(t), t' = 1).
const EXPRS: [&str; 12] = [
    "sin(t) * cos(2*t) + t^2",             // Sin, Cos, Mul, Powi (square), Add
    "exp(t/3) - log(t + 1)",               // Exp, Ln, Div by a constant, Sub
    "(1 + t^2)^(1/2) + t^(3/2)",           // Sqrt, Powi(Sqrt)
    "t^(1/3) + (2 + t)^(2/3) - t^(-3/4)",  // Cbrt, Powf
    "t^(-3) + 1/(1 + t) + t^5 - t^7",      // 1/Powi, Div, Powi chains
    "-(t * exp(c * t)) + c / t",           // Neg, hoisted constants, const / x
    "sin(t)^2 + cos(t)^3 + sin(sin(t))",   // paired Sin/Cos, nested
    "cos(t) * t - exp(log(t) * 2)",        // Cos alone
    "(t^2 + c)^(-1/2) * sin(c * t) + c*c", // Powi(Sqrt) negative, constant products
    "log(1 + t^4) / (2 + sin(t)) - t^(4/3)", // Div of two series, Powf
    "c * t / (1 + t^2)^(3/2) + (t + 2)^(-5/2)", // fused powers: c/√s³, 1/√s⁵
    "(1 + t^2)^(1/2) * t + (1 + t^2)^(7/2)", // √s read elsewhere, √s⁷ fused
];

/// A model of the elliptic functions' recurrences.
const ELLIPTIC: &str = "model F { state t: scalar, u: scalar, v: scalar; param m = 0.7;
    d/dt t = 1; d/dt u = ellipf(2 * t, m) + ellipk(m) * t;
    d/dt v = sn(t * t, m) * cd(u, 0.3) + dn(t, m); }";

/// (name, model text) of every model file and of a one-equation model per expression of
/// [`EXPRS`].
fn model_and_expression_texts() -> Vec<(String, String)> {
    let mut texts: Vec<(String, String)> = lasalle_testkit::model_files()
        .iter()
        .map(|p| (p.display().to_string(), std::fs::read_to_string(p).unwrap()))
        .collect();
    for expr in EXPRS {
        let text = format!(
            "model E {{ state t: scalar, y: scalar; param c = 0.37;
               d/dt t = 1; d/dt y = {expr}; }}"
        );
        texts.push((expr.to_string(), text));
    }
    texts
}

#[test]
fn every_op_against_the_cauchy_integral() {
    // y' = g(t), t' = 1: y^[k+1] = g^[k] / (k + 1), g^[k] the coefficients of s ↦ g(t0 + s)
    let (t0, r, nodes, kmax) = (0.8, 0.3, 128, 14);
    for expr in EXPRS {
        let text = format!(
            "model E {{ state t: scalar, y: scalar; param c = 0.37;
               d/dt t = 1; d/dt y = {expr}; }}"
        );
        let (tp, params) = tapes(&text);
        let got = coefficients(&tp.field, &params, &[t0, 0.25], kmax + 1);
        let cp: Vec<C> = params.iter().map(|&p| C::from_f64(p)).collect();
        let g = |z: C| {
            tp.field
                .eval(&cp, &[z, C::from_f64(0.25)], &[], &[])
                .unwrap()[1]
        };
        let want = cauchy_coefficients(g, t0, r, nodes, kmax);
        let size = (0..nodes)
            .map(|j| {
                let th = 2.0 * std::f64::consts::PI * j as f64 / nodes as f64;
                g(C::new(t0 + r * th.cos(), r * th.sin())).abs()
            })
            .fold(0.0, f64::max);
        // t is the time: t^[1] = 1, t^[k] = 0 beyond
        assert_eq!(got[0][1], 1.0);
        assert!(got[0][2..].iter().all(|&v| v == 0.0));
        for k in 0..=kmax {
            let mine = got[1][k + 1] * (k as f64 + 1.0);
            assert!(
                (mine - want[k]).abs() * r.powi(k as i32) <= 1e-13 * size,
                "{expr}: k = {k}: {mine} vs {}",
                want[k]
            );
        }
    }
}

/// A coefficient that vanishes at order 0 (powi of a zero series) has the right expansion:
/// x^5 along x = s gives s^5.
#[test]
fn powi_of_a_vanishing_series() {
    let (tp, params) =
        tapes("model Z { state x: scalar, y: scalar; d/dt x = 1; d/dt y = x^5 + x^2; }");
    let c = coefficients(&tp.field, &params, &[0.0, 0.0], 8);
    // y = s^6/6 + s^3/3
    let want = [0.0, 0.0, 0.0, 1.0 / 3.0, 0.0, 0.0, 1.0 / 6.0, 0.0, 0.0];
    assert_eq!(c[1], want);
}

// ---------------------------------------------------------------------------------------
// Order and step size

#[test]
fn jorba_zou_order_and_step() {
    assert_eq!(order_for_tolerance(1e-15), 19);
    assert_eq!(order_for_tolerance(f64::EPSILON), 20);
    assert_eq!(order_for_tolerance(1e-8), 11);
    // absolute mode (m ≤ 1): ρ = min((1/n_{p−1})^{1/(p−1)}, (1/n_p)^{1/p})
    let h = jorba_zou_step(11, 0.5, 1e-10, 1e-12);
    let rho = (1e10f64).powf(1.0 / 10.0).min((1e12f64).powf(1.0 / 11.0));
    let fac = (-0.7f64 / 10.0).exp() / std::f64::consts::E.powi(2);
    assert!((h - rho * fac).abs() <= 1e-15 * h);
    // relative mode (m > 1)
    let h = jorba_zou_step(11, 8.0, 1e-10, 1e-12);
    let rho = (8e10f64).powf(1.0 / 10.0).min((8e12f64).powf(1.0 / 11.0));
    assert!((h - rho * fac).abs() <= 1e-15 * h);
    assert_eq!(jorba_zou_step(11, 1.0, 0.0, 0.0), f64::INFINITY);
}

// ---------------------------------------------------------------------------------------
// Adaptive runs

#[test]
fn harmonic_oscillator_100_periods() {
    let m = LoadedModel::from_source("osc.lsl", OSC, Backend::Interpreter).unwrap();
    let x0 = m.point("start").unwrap();
    let mut taylor = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    let t_end = 100.0 * std::f64::consts::PI; // 100 periods of w = 2
    let end = integrate(&mut taylor, &m, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    let mut f0 = vec![0.0];
    let mut f1 = vec![0.0];
    m.invariants(&x0, &mut f0);
    m.invariants(&end.x, &mut f1);
    assert!(
        (f1[0] - f0[0]).abs() <= 1e-13,
        "energy error {}",
        f1[0] - f0[0]
    );
    let (q0, p0, w) = (0.3, -0.8, 2.0f64);
    let q = q0 * (w * t_end).cos() + p0 / w * (w * t_end).sin();
    assert!((end.x[0] - q).abs() <= 1e-12, "q error {}", end.x[0] - q);
    assert_eq!(end.rejections, 0);
    assert!(end.steps > 100 && end.steps < 10_000, "{} steps", end.steps);
}

/// Kepler e = 0.8 (the paper's point): L, A (the model's invariants) and the energy within
/// 1e-13 after 10 periods at tol 1e-15 (the drift is linear in time: about 1e-14 per 10
/// periods at this tolerance) and after 100 periods at tol = ε (heyoka's default); the orbit
/// closes.
#[test]
fn kepler_eccentric_orbit() {
    let m = LoadedModel::from_source("kepler.lsl", &model_text("kepler"), Backend::Interpreter)
        .unwrap();
    let x0 = m.point("paper").unwrap();
    let period = 2.0 * std::f64::consts::PI * 5f64.powf(1.5);
    for (tol, periods, close) in [(1e-15, 10.0, 1e-10), (f64::EPSILON, 100.0, 1e-9)] {
        let mut taylor = m.taylor(TaylorOptions::with_tol(tol)).unwrap();
        let end = integrate(&mut taylor, &m, &x0, 0.0, periods * period, 0.0, &mut ()).unwrap();
        let mut f0 = vec![0.0; 6];
        let mut f1 = vec![0.0; 6];
        m.invariants(&x0, &mut f0);
        m.invariants(&end.x, &mut f1);
        let inv = max_diff(&f0, &f1);
        let de = (kepler_energy(&end.x) - kepler_energy(&x0)).abs();
        assert!(inv <= 1e-13, "tol {tol:e}: L, A error {inv:e}");
        assert!(de <= 1e-13, "tol {tol:e}: energy error {de:e}");
        assert!(max_diff(&end.x, &x0) <= close, "{:?}", end.x);
        assert!(end.steps as f64 > 40.0 * periods, "{} steps", end.steps);
    }
}

/// X − ∇V through `FeedbackField` and through `TaylorField::Feedback`: the same steps,
/// bitwise, and the invariants kept.
#[test]
fn feedback_field() {
    let m = LoadedModel::from_source("kepler.lsl", &model_text("kepler"), Backend::Interpreter)
        .unwrap();
    let x0 = m.point("paper").unwrap();
    let fb = FeedbackField::from_initial(&m, &x0, vec![4.0, 2.0]);
    let t_end = 10.0 * 70.2481;
    let mut a = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    let end_a = integrate(&mut a, &fb, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    let mut b = m
        .taylor(TaylorOptions::with_tol(1e-15))
        .unwrap()
        .with_field(TaylorField::Feedback {
            target: fb.target().clone(),
            gains: vec![4.0, 2.0],
        })
        .unwrap();
    let end_b = integrate(&mut b, &m, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    assert_same(&end_a.x, &end_b.x, "feedback field vs feedback kernel");
    assert_eq!(end_a.steps, end_b.steps);
    let mut f1 = vec![0.0; 6];
    m.invariants(&end_a.x, &mut f1);
    assert!(max_diff(fb.target(), &f1) <= 1e-13);
    // the feedback field really is used: at a perturbed state, X − ∇V ≠ X
    let mut x = x0.clone();
    x[0] += 1e-3;
    let (mut f, mut g) = (vec![0.0; 6], vec![0.0; 6]);
    m.field(&x, &mut f);
    fb.field(&x, &mut g);
    assert!(max_diff(&f, &g) > 1e-4);
    let mut s = x.clone();
    Stepper::<f64, Vec<f64>, _>::step(&mut a, &fb, 0.0, &mut s, 1e-3).unwrap();
    let c = a.last_coefficients(0).unwrap();
    assert_eq!(c[1], g[0]);
}

/// Dense output: the polynomial at the step's end is the new state (bitwise); inside the step
/// it is the Taylor step of that length (bitwise) and the exact solution (oscillator).
#[test]
fn dense_output_against_steps() {
    let m = LoadedModel::from_source("osc.lsl", OSC, Backend::Interpreter).unwrap();
    let x0 = m.point("start").unwrap();
    let mut taylor = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    assert_eq!(DenseOutput::<f64, Vec<f64>>::dense_interval(&taylor), None);
    let mut x = x0.clone();
    let out = taylor.step(&m, 0.0, &mut x, 10.0).unwrap();
    let h = out.h_taken;
    assert!(h < 10.0 && h > 0.1, "h = {h}");
    assert_eq!(
        DenseOutput::<f64, Vec<f64>>::dense_interval(&taylor),
        Some((0.0, h))
    );
    let mut y = vec![0.0; 2];
    assert!(taylor.interpolate(h, &mut y));
    assert_same(&y, &x, "the polynomial at the step's end");
    assert!(!taylor.interpolate(1.01 * h, &mut y));
    // several times at once (five: a pass of four and one) are the times one by one, bitwise
    let ts: Vec<f64> = [0.0, 0.25, 0.5, 0.75, 1.0].iter().map(|f| f * h).collect();
    let mut many = vec![vec![0.0; 2]; ts.len()];
    assert!(taylor.interpolate_many(&ts, &mut many));
    for (&t, m) in ts.iter().zip(&many) {
        assert!(taylor.interpolate(t, &mut y));
        assert_same(&y, m, format!("t = {t}"));
    }
    assert!(!taylor.interpolate_many(&[0.5 * h, 1.01 * h], &mut many[..2]));
    let (q0, p0, w) = (0.3, -0.8, 2.0f64);
    for theta in [0.1, 0.37, 0.5, 0.9] {
        let s = theta * h;
        assert!(taylor.interpolate(s, &mut y));
        let q = q0 * (w * s).cos() + p0 / w * (w * s).sin();
        assert!((y[0] - q).abs() <= 1e-15, "θ = {theta}: {}", y[0] - q);
        let mut fresh = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
        let mut z = x0.clone();
        let o = fresh.step(&m, 0.0, &mut z, s).unwrap();
        assert_eq!(o.h_taken, s);
        assert_same(&z, &y, format!("θ = {theta}"));
    }
    // through the driver: output times between steps
    let times: Vec<f64> = (0..=40).map(|i| i as f64 * 0.25).collect();
    let mut got = Vec::new();
    let mut fresh = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    Driver::new(0.0, 10.0, 0.0)
        .run_dense(
            &mut fresh,
            &m,
            &x0,
            &times,
            &mut |_i: u64, t: f64, x: &Vec<f64>| {
                got.push((t, x[0]));
                lasalle_runtime::Control::Continue
            },
        )
        .unwrap();
    assert_eq!(got.len(), times.len());
    for (t, q) in got {
        let exact = q0 * (w * t).cos() + p0 / w * (w * t).sin();
        assert!((q - exact).abs() <= 1e-14, "t = {t}: {}", q - exact);
    }
}

/// The stepper picks up a parameter change at the next step.
#[test]
fn parameter_change() {
    let mut m = LoadedModel::from_source("osc.lsl", OSC, Backend::Interpreter).unwrap();
    let x0 = m.point("start").unwrap();
    let mut taylor = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    m.set_param("w", &[3.0]).unwrap();
    let end = integrate(&mut taylor, &m, &x0, 0.0, 1.0, 0.0, &mut ()).unwrap();
    let q = 0.3 * 3f64.cos() - 0.8 / 3.0 * 3f64.sin();
    assert!((end.x[0] - q).abs() <= 1e-14);
}

/// No allocation in a step (plain field and X − ∇V with the stepper's own target and gains),
/// after the first, with either back end's kernels.
#[test]
fn no_allocation_per_step() {
    for &backend in Backend::available() {
        no_allocation_per_step_with(backend);
    }
}

fn no_allocation_per_step_with(backend: Backend) {
    let m = LoadedModel::from_source("kepler.lsl", &model_text("kepler"), backend).unwrap();
    let x0 = m.point("paper").unwrap();
    let mut target = vec![0.0; 6];
    m.invariants(&x0, &mut target);
    for mode in [
        TaylorField::Plain,
        TaylorField::Feedback {
            target,
            gains: vec![4.0, 2.0],
        },
    ] {
        let mut taylor = m
            .taylor(TaylorOptions::with_tol(1e-15))
            .unwrap()
            .with_field(mode)
            .unwrap();
        let mut x = x0.clone();
        let mut t = 0.0;
        let mut h = 0.01;
        let mut y = x0.clone();
        let before = allocations();
        for _ in 0..2000 {
            let out = taylor.step(&m, t, &mut x, h).unwrap();
            t += out.h_taken;
            h = out.h_next;
            assert!(taylor.interpolate(t - 0.5 * out.h_taken, &mut y));
        }
        assert_eq!(allocations() - before, 0);
        assert!(t > 50.0);
    }
}

#[test]
fn rejects_bad_options() {
    let m = LoadedModel::from_source("osc.lsl", OSC, Backend::Interpreter).unwrap();
    for opts in [
        TaylorOptions::with_tol(0.0),
        TaylorOptions::with_tol(2.0),
        TaylorOptions {
            order: Some(1),
            ..Default::default()
        },
        TaylorOptions {
            h_max: 0.0,
            ..Default::default()
        },
    ] {
        assert!(m.taylor(opts).is_err(), "{opts:?}");
    }
    let mut taylor = m.taylor(TaylorOptions::default()).unwrap();
    let mut x = vec![1.0, 2.0, 3.0];
    assert!(taylor.step(&m, 0.0, &mut x, 0.1).is_err());
    assert!(taylor
        .set_field(TaylorField::Feedback {
            target: vec![],
            gains: vec![]
        })
        .is_err());
}

// ---------------------------------------------------------------------------------------
// Timing (release build; prints, asserts only accuracy)

fn timed_run(
    name: &str,
    point: &str,
    t_end: f64,
    tol: f64,
) -> (f64, u64, Vec<f64>, Vec<f64>, Vec<f64>) {
    let m = LoadedModel::from_source(name, &model_text(name), Backend::Jit).unwrap();
    let x0 = m.point(point).unwrap();
    let mut taylor = m.taylor(TaylorOptions::with_tol(tol)).unwrap();
    let start = std::time::Instant::now();
    let end = integrate(&mut taylor, &m, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    let secs = start.elapsed().as_secs_f64();
    let mi = m.invariant_dim();
    let (mut f0, mut f1) = (vec![0.0; mi], vec![0.0; mi]);
    m.invariants(&x0, &mut f0);
    m.invariants(&end.x, &mut f1);
    (secs, end.steps, f0, f1, end.x)
}

#[test]
#[ignore = "timing: run with --release --ignored --nocapture"]
fn timing_kepler_and_rigid_body() {
    let period = 2.0 * std::f64::consts::PI * 5f64.powf(1.5);
    for tol in [1e-15, f64::EPSILON, 1e-10] {
        let (secs, steps, f0, f1, x) = timed_run("kepler", "paper", 1000.0 * period, tol);
        let m0 = LoadedModel::from_source("k", &model_text("kepler"), Backend::Jit).unwrap();
        let e0 = kepler_energy(&m0.point("paper").unwrap());
        println!(
            "kepler e=0.8, 1000 periods, tol {tol:e}: {secs:.3} s, {steps} steps ({:.2} µs/step), \
             |ΔL, ΔA|∞ = {:.2e}, |ΔE| = {:.2e}",
            secs / steps as f64 * 1e6,
            max_diff(&f0, &f1),
            (kepler_energy(&x) - e0).abs()
        );
        let (secs, steps, f0, f1, _) = timed_run("rigid_body", "paper", 1000.0, tol);
        let blocks = [("C", 0..9), ("E", 9..10), ("pi", 10..13)];
        let errs: Vec<String> = blocks
            .iter()
            .map(|(n, r)| format!("|Δ{n}|∞ = {:.2e}", max_diff(&f0[r.clone()], &f1[r.clone()])))
            .collect();
        println!(
            "rigid body, t = 1000, tol {tol:e}: {secs:.3} s, {steps} steps ({:.2} µs/step), {}",
            secs / steps as f64 * 1e6,
            errs.join(", ")
        );
    }
}

/// Jacobi elliptic functions through the Taylor recurrences (sn, cn, dn as one triple):
/// `models/pendulum_closed_form.lsl` from the bottom follows θ = 2 asin(k sn(t | k²)),
/// ω = 2k cn(t | k²), and its y = F(t | k²), z = sd(t | k²), s = t/K(k²), to rounding; DOPRI5
/// at tight tolerance agrees.
#[test]
fn elliptic_functions_closed_form() {
    use lasalle_runtime::elliptic::{ellipf, ellipj, ellipk};
    let m = LoadedModel::from_source(
        "pendulum_closed_form.lsl",
        &model_text("pendulum_closed_form"),
        Backend::Interpreter,
    )
    .unwrap();
    let x0 = m.point("bottom").unwrap();
    let (k, t_end) = (0.9f64, 20.0);
    let mm = k * k;
    let exact = |t: f64| {
        let j = ellipj(t, mm);
        [
            t,
            2.0 * (k * j.sn).asin(),
            2.0 * k * j.cn,
            ellipf(t, mm),
            j.sn / j.dn,
            t / ellipk(mm),
        ]
    };
    let mut taylor = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    let end = integrate(&mut taylor, &m, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    let err_taylor = max_diff(&end.x, &exact(t_end));
    assert!(err_taylor < 1e-12, "Taylor vs closed form: {err_taylor:e}");
    let mut dp = lasalle_runtime::DormandPrince::new(lasalle_runtime::DormandPrinceOptions {
        rtol: 1e-13,
        atol: 1e-13,
        ..Default::default()
    });
    let end_dp = integrate(&mut dp, &m, &x0, 0.0, t_end, 0.0, &mut ()).unwrap();
    let err_dp = max_diff(&end_dp.x, &exact(t_end));
    assert!(err_dp < 1e-10, "DOPRI5 vs closed form: {err_dp:e}");
    // F(φ | m) of a varying φ through its own recurrence (w = (1 − m sin²φ)^(−1/2)), and the
    // Jacobi triple of a varying argument, against DOPRI5
    let text = "model F { state t: scalar, u: scalar, v: scalar; param m = 0.7;
        d/dt t = 1; d/dt u = ellipf(2 * t, m); d/dt v = sn(t * t, m) * cd(u, 0.3); }";
    let f = LoadedModel::from_source("f.lsl", text, Backend::Interpreter).unwrap();
    let x0 = vec![0.0, 0.0, 0.0];
    let mut taylor = f.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
    let a = integrate(&mut taylor, &f, &x0, 0.0, 3.0, 0.0, &mut ()).unwrap();
    let mut dp = lasalle_runtime::DormandPrince::new(lasalle_runtime::DormandPrinceOptions {
        rtol: 1e-13,
        atol: 1e-13,
        ..Default::default()
    });
    let b = integrate(&mut dp, &f, &x0, 0.0, 3.0, 0.0, &mut ()).unwrap();
    let err = max_diff(&a.x, &b.x);
    println!("Taylor vs closed form {err_taylor:.1e}, DOPRI5 vs closed form {err_dp:.1e}, F and sn of varying arguments: Taylor vs DOPRI5 {err:.1e}");
    assert!(
        err < 1e-11,
        "Taylor vs DOPRI5 with F and sn of varying arguments: {err:e}"
    );
    // a parameter m that varies along the solution has no recurrence here: refused by the
    // language before it reaches the Taylor builder
    assert!(LoadedModel::from_source(
        "v.lsl",
        "model V { state t: scalar, u: scalar; d/dt t = 1; d/dt u = sn(t, u^2/2); }",
        Backend::Interpreter,
    )
    .is_err());
}

/// The fused powers (`TaylorProgram::new`) compute the coefficients of the unfused program
/// (every instruction by its own recurrence) up to rounding, at every order up to 20: every
/// built-in model (field and X − ∇V) and every expression of `EXPRS`, at random states;
/// orders 0 and 1 (the field) bitwise. Relative to the largest coefficient of the same order
/// the differences stay below 4096 units in the last place: ≤ 120 on the models (Kepler and
/// the CR3BP at orders 13–20), up to ≈ 2400 on the expressions of (1 + t²)^(n/2), where the
/// unfused chain is the less accurate one (against 50-digit coefficients: (1 + t²)^(−3/2) at
/// t = 1.1 within 111 ulps fused, 655 unfused; see `tape::taylor`'s docs).
#[test]
fn fused_powers_match_the_unfused_recurrences() {
    use lasalle_model::tape::taylor::{PowZero, Rec, TaylorProgram};
    let texts = model_and_expression_texts();
    let order = 20;
    let (mut fused, mut worst) = (0, 0.0f64);
    for (name, text) in &texts {
        // each text its own stream: a model added to `models/` leaves the others' states alone
        let seed = name.bytes().fold(0x2545_f491_4f6c_dd1d_u64, |h, b| {
            h.wrapping_mul(0x100_0000_01b3) ^ u64::from(b)
        });
        let mut rng = lasalle_testkit::Rng::new(seed);
        let mut rand = move || rng.uniform(0.25, 1.25);
        let (tp, params) = tapes(text);
        for tape in [&tp.field, &tp.feedback] {
            let program = TaylorProgram::new(tape).unwrap();
            fused += program
                .recs
                .iter()
                .filter(|(r, _)| {
                    matches!(
                        r,
                        Rec::Pow {
                            zero: PowZero::Fused,
                            ..
                        }
                    )
                })
                .count();
            let n = tape.dims.state;
            let target: Vec<f64> = (0..tape.dims.targets).map(|_| rand()).collect();
            let gains: Vec<f64> = (0..tape.dims.gains).map(|_| rand()).collect();
            let unfused = TaylorProgram::unfused(tape).unwrap();
            let mut a = TaylorTape::with_program(program, tape, &params, order).unwrap();
            let mut b = TaylorTape::with_program(unfused, tape, &params, order).unwrap();
            for t in [&mut a, &mut b] {
                TaylorKernel::<LoadedModel>::set_inputs(t, &target, &gains).unwrap();
            }
            for _ in 0..3 {
                let x: Vec<f64> = (0..n).map(|_| rand()).collect();
                a.compute(&x, order as usize);
                b.compute(&x, order as usize);
                for k in 0..=order as usize {
                    let scale = (0..n)
                        .map(|i| b.state_coefficients(i)[k].abs())
                        .fold(0.0, f64::max);
                    for i in 0..n {
                        let (u, v) = (a.state_coefficients(i)[k], b.state_coefficients(i)[k]);
                        if k <= 1 {
                            assert_eq!(u.to_bits(), v.to_bits(), "{name}: x_{i}^[{k}]");
                        }
                        let err = if u == v {
                            0.0
                        } else {
                            (u - v).abs() / (scale * f64::EPSILON)
                        };
                        worst = worst.max(err);
                        assert!(err <= 4096.0, "{name}: x_{i}^[{k}]: {u:e} vs {v:e}");
                    }
                }
            }
        }
    }
    println!("{fused} fused powers; largest difference {worst:.1} ulps of the order's scale");
    assert!(
        fused >= 4,
        "Kepler's, the CR3BP's and those of EXPRS are fused"
    );
}

// ---------------------------------------------------------------------------------------
// The compiled kernel (JIT back end)

/// `JitTaylor` computes the interpreter's coefficients bitwise: every built-in model (field
/// and X − ∇V, random targets and gains), every operation's recurrence (`EXPRS`) and the
/// elliptic functions, at random states, for several orders; and a JIT-loaded model's
/// integrator ends where the interpreted one does, bitwise. Every field compiles at p = 20
/// (X − ∇V of the larger models exceeds `MAX_INSTRUCTIONS` at p ≥ 19 and is interpreted);
/// prints the compile times.
#[cfg(feature = "jit")]
#[test]
fn jit_kernel_agrees_with_the_tape_bitwise() {
    use lasalle_exec::jit::taylor::JitTaylor;
    let mut rng = lasalle_testkit::Rng::new(0x9e37_79b9_7f4a_7c15);
    let mut rand = move || rng.uniform(0.25, 1.25);
    let mut texts = model_and_expression_texts();
    texts.push(("elliptic".into(), ELLIPTIC.into()));
    for (name, text) in &texts {
        let (tp, params) = tapes(text);
        for (what, tape) in [("field", &tp.field), ("feedback", &tp.feedback)] {
            let n = tape.dims.state;
            let target: Vec<f64> = (0..tape.dims.targets).map(|_| rand()).collect();
            let gains: Vec<f64> = (0..tape.dims.gains).map(|_| rand()).collect();
            for order in [1u32, 7, 19, 20] {
                let mut tt = TaylorTape::new(tape, &params, order).unwrap();
                let start = std::time::Instant::now();
                let Some(mut jt) = JitTaylor::new(tape, &params, order).unwrap() else {
                    // too large to unroll: X − ∇V of the larger models at high orders, and the
                    // families and the Pleiades (5 and 7 bodies, 16 particles)
                    // and the fields that switch (`sign`), which the JIT does not expand
                    assert!(
                        tape.dims.state >= 28
                            || (order >= 19 && what == "feedback")
                            || text.contains("sign("),
                        "{name}: {what} at p = {order}"
                    );
                    continue;
                };
                if order == 20 {
                    println!(
                        "{name}: {what}: JIT kernel at p = 20 in {:?}",
                        start.elapsed()
                    );
                }
                TaylorKernel::<LoadedModel>::set_inputs(&mut tt, &target, &gains).unwrap();
                jt.set_inputs(&target, &gains).unwrap();
                for _ in 0..3 {
                    let x: Vec<f64> = (0..n).map(|_| rand()).collect();
                    tt.compute(&x, order as usize);
                    jt.compute(&x, order as usize);
                    for i in 0..n {
                        let (a, b) = (tt.state_coefficients(i), jt.coefficients(i));
                        assert_eq!(a.len(), b.len());
                        for (k, (&a, &b)) in a.iter().zip(b).enumerate() {
                            assert!(
                                same(a, b),
                                "{name}, p = {order}, x_{i}^[{k}]: {a:e} vs {b:e}"
                            );
                        }
                    }
                }
            }
        }
    }
    // the integrators of the two back ends end at the same point
    let text = model_text("kepler");
    let ends: Vec<Vec<f64>> = [Backend::Jit, Backend::Interpreter]
        .into_iter()
        .map(|b| {
            let m = LoadedModel::from_source("kepler.lsl", &text, b).unwrap();
            let x0 = m.point("paper").unwrap();
            let mut taylor = m.taylor(TaylorOptions::with_tol(1e-15)).unwrap();
            integrate(&mut taylor, &m, &x0, 0.0, 50.0, 0.0, &mut ())
                .unwrap()
                .x
        })
        .collect();
    assert_eq!(ends[0], ends[1]);
}

/// `JitTaylorBatch` computes each orbit's coefficients bitwise as the interpreter does for it
/// alone: every built-in model's field, every operation's recurrence (`EXPRS`) and the
/// elliptic functions (calls made lane by lane), two different random states per call.
#[cfg(feature = "jit")]
#[test]
fn batch_kernel_lanes_are_the_lone_coefficients_bitwise() {
    use lasalle_exec::jit::taylor::{JitTaylorBatch, LANES};
    use lasalle_runtime::TaylorBatch;
    let mut rng = lasalle_testkit::Rng::new(0x5851_f42d_4c95_7f2d);
    let mut rand = move || rng.uniform(0.25, 1.25);
    let mut texts = model_and_expression_texts();
    texts.push(("elliptic".into(), ELLIPTIC.into()));
    let mut compiled = 0;
    for (name, text) in &texts {
        let (tp, params) = tapes(text);
        let n = tp.field.dims.state;
        for order in [1u32, 7, 19] {
            let Some(mut batch) = JitTaylorBatch::new(&tp.field, &params, order).unwrap() else {
                continue;
            };
            compiled += 1;
            let p = order as usize;
            let mut tt = TaylorTape::new(&tp.field, &params, order).unwrap();
            let states: Vec<Vec<f64>> = (0..LANES)
                .map(|_| (0..n).map(|_| rand()).collect())
                .collect();
            let packed: Vec<f64> = (0..n * LANES)
                .map(|j| states[j % LANES][j / LANES])
                .collect();
            batch.compute(&packed);
            for (l, x) in states.iter().enumerate() {
                tt.compute(x, p);
                for i in 0..n {
                    for (k, &want) in tt.state_coefficients(i).iter().enumerate() {
                        let got = batch.table()[(i * (p + 1) + k) * LANES + l];
                        assert!(
                            same(got, want),
                            "{name}, p = {order}, lane {l}, x_{i}^[{k}]: {got:e} vs {want:e}"
                        );
                    }
                }
            }
        }
    }
    assert!(compiled >= 3 * 20, "{compiled} batch kernels compiled");
}

/// Orbits in lanes (`TaylorLanes`) end bitwise where each ends alone under the driver, with
/// their own step counts, a lane refilled as its orbit ends: Kepler orbits of eccentricities
/// 0 … 0.9 (from 20 to several hundred steps), one from a non-finite state (failed, not
/// started), to t = 30 from Jorba & Zou's first step and from a given one.
#[cfg(feature = "jit")]
#[test]
fn orbits_in_lanes_end_where_they_end_alone() {
    use lasalle_runtime::{LaneRuns, TaylorLanes};
    let m = LoadedModel::from_source("kepler.lsl", &model_text("kepler"), Backend::Jit).unwrap();
    let opts = TaylorOptions::with_tol(1e-15);
    let order = opts.checked_order().unwrap();
    let mut starts: Vec<Vec<f64>> = [0.0, 0.3, 0.9, 0.5, 0.1, 0.7]
        .iter()
        .map(|e: &f64| vec![1.0 - e, 0.0, 0.0, 0.0, ((1.0 + e) / (1.0 - e)).sqrt(), 0.05])
        .collect();
    starts.insert(2, vec![f64::NAN; 6]);
    for h0 in [0.0, 1e-3] {
        let kernel = m
            .taylor_batch(order)
            .unwrap()
            .expect("Kepler's field compiles in lanes");
        let mut lanes = TaylorLanes::new(kernel, opts).unwrap();
        let runs = LaneRuns {
            t_end: 30.0,
            h0,
            max_steps: 100_000,
            guards: None,
            stop: None,
        };
        let ends = lanes.run(&m, &starts, &runs);
        for (x0, end) in starts.iter().zip(&ends) {
            let mut taylor = m.taylor(opts).unwrap();
            let alone = Driver::new(0.0, 30.0, h0).run(&mut taylor, &m, x0, &mut ());
            match (alone, end) {
                (Ok(alone), Some(end)) => {
                    assert_eq!(end.steps, alone.steps, "{x0:?}");
                    assert_eq!(end.evaluations, alone.evaluations, "{x0:?}");
                    assert!(same(end.t, alone.t) && end.t == 30.0);
                    assert_same(&end.x, &alone.x, format!("{x0:?}"));
                }
                (Err(_), None) => assert!(x0[0].is_nan()),
                (alone, end) => panic!("{x0:?}: alone {alone:?}, in lanes {end:?}"),
            }
        }
    }
}

/// A program above `MAX_INSTRUCTIONS` (Kepler's X − ∇V at p = 19) is interpreted for
/// `DEFER_COMPUTES` computes, then compiled: the coefficients equal the interpreter's bitwise
/// before and after the switch (random states, targets and gains, and a parameter change
/// before the switch that the compiled kernel keeps); the JIT back end's kernels take this
/// form.
#[cfg(feature = "jit")]
#[test]
fn deferred_jit_compiles_later_and_agrees_bitwise() {
    use lasalle_exec::jit::taylor::{DeferredJit, JitTaylor, DEFER_COMPUTES};
    let mut rng = lasalle_testkit::Rng::new(0x5851_f42d_4c95_7f2d);
    let mut rand = move || rng.uniform(0.25, 1.25);
    let (tp, params) = tapes(&model_text("kepler"));
    let (tape, order) = (&tp.feedback, 19);
    assert!(JitTaylor::new(tape, &params, order).unwrap().is_none());
    let mut deferred = DeferredJit::new(tape, &params, order).unwrap();
    let mut tt = TaylorTape::new(tape, &params, order).unwrap();
    let target: Vec<f64> = (0..tape.dims.targets).map(|_| rand()).collect();
    let gains: Vec<f64> = (0..tape.dims.gains).map(|_| rand()).collect();
    deferred.set_inputs(&target, &gains).unwrap();
    TaylorKernel::<LoadedModel>::set_inputs(&mut tt, &target, &gains).unwrap();
    // a parameter change reaches the deferred kernel through `sync`
    let mut m =
        LoadedModel::from_source("kepler.lsl", &model_text("kepler"), Backend::Jit).unwrap();
    m.set_param("mu", &[1.1]).unwrap();
    deferred.sync(&m).unwrap();
    tt.set_params(m.params()).unwrap();
    let x0: Vec<f64> = (0..tape.dims.state).map(|_| rand()).collect();
    for c in 0..DEFER_COMPUTES + 3 {
        assert_eq!(deferred.is_compiled(), c > DEFER_COMPUTES, "compute {c}");
        let check = c % 1000 == 0 || c >= DEFER_COMPUTES;
        let x: Vec<f64> = if check {
            x0.iter().map(|v| v + 0.1 * rand()).collect()
        } else {
            x0.clone()
        };
        deferred.compute(&x, order as usize);
        if check {
            tt.compute(&x, order as usize);
            for i in 0..x.len() {
                let (a, b) = (tt.state_coefficients(i), deferred.coefficients(i));
                assert!(
                    a.iter().zip(b).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "compute {c}, x_{i}"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// The split step: X by Taylor, then a gradient step on V (an alternative to X − ∇V)

/// Integrates `m` from `x0` to `t_end` by Taylor steps of the plain field X, or (θ > 0) by
/// the driver's split step (`Taylor::set_split`: each Taylor step of X followed by one explicit
/// Euler step x ← x − h ∇V_k(x) of the gradient flow of V_k = ½ Σ k_i |f_i(x) − target_i|²),
/// with the gains k = θ/(h L(x)) · (1, …, 1), L(x) = ‖Df(x)ᵀDf(x)‖₂ (refreshed every 10
/// steps) and h the step proposed, so that h k L ≈ θ. Returns the end state, the steps and
/// the CPU seconds.
fn split_run(
    m: &LoadedModel,
    x0: &[f64],
    target: &[f64],
    t_end: f64,
    tol: f64,
    theta: f64,
) -> (Vec<f64>, u64, f64) {
    use lasalle_runtime::{gauss_newton_norm, ModelInfo};
    let split = theta > 0.0;
    let mut taylor = m
        .taylor(TaylorOptions::with_tol(tol))
        .unwrap()
        .with_split(split);
    let unit = vec![1.0; m.gain_names().len()];
    let fb = FeedbackField::new(m, target.to_vec(), unit.clone());
    let mut x = x0.to_vec();
    let (mut t, mut steps, mut l) = (0.0, 0u64, 0.0);
    let mut h = Stepper::<f64, Vec<f64>, LoadedModel>::initial_step(&mut taylor, m, 0.0, &x, t_end)
        .unwrap();
    let start = std::time::Instant::now();
    while t < t_end {
        let h_try = h.min(t_end - t);
        let out = if split {
            if steps % 10 == 0 {
                l = gauss_newton_norm::<_, f64, Vec<f64>, Vec<f64>>(m, &x, &unit);
            }
            fb.set_gains(vec![theta / (h_try * l); unit.len()]);
            taylor.step(&fb, t, &mut x, h_try).unwrap()
        } else {
            taylor.step(m, t, &mut x, h_try).unwrap()
        };
        t += out.h_taken;
        h = out.h_next;
        steps += 1;
    }
    (x, steps, start.elapsed().as_secs_f64())
}

/// The split step pulls drift back: Kepler started 1e-6 off its invariant set (v scaled by
/// 1 + 1e-6) with the target of the unperturbed orbit. Plain Taylor keeps the offset; with
/// the gradient step (θ = 0.5) the invariants return to the target within 10 periods.
#[test]
fn split_step_pulls_drift_back() {
    let m =
        LoadedModel::from_source("kepler.lsl", &model_text("kepler"), Backend::default()).unwrap();
    let x0 = m.point("paper").unwrap();
    let mut target = vec![0.0; m.invariant_dim()];
    m.invariants(&x0, &mut target);
    let mut xp = x0.clone();
    xp[3..].iter_mut().for_each(|v| *v *= 1.0 + 1e-6);
    let period = 2.0 * std::f64::consts::PI * 5f64.powf(1.5);
    let err = |x: &Vec<f64>| {
        let mut f = vec![0.0; target.len()];
        m.invariants(x, &mut f);
        max_diff(&f, &target)
    };
    let (plain, _, _) = split_run(&m, &xp, &target, 10.0 * period, 1e-15, 0.0);
    let (split, _, _) = split_run(&m, &xp, &target, 10.0 * period, 1e-15, 0.5);
    println!(
        "10 periods from 1e-6 off: plain {:.1e}, split {:.1e}",
        err(&plain),
        err(&split)
    );
    assert!(err(&plain) > 1e-7, "plain: {:e}", err(&plain));
    assert!(err(&split) < 1e-9, "split: {:e}", err(&split));
}

/// Kepler, 1000 periods at tol 1e-15 and 1e-16: plain Taylor against the split step for
/// θ = 0.05, 0.5, 1 (invariant error and CPU time).
#[test]
#[ignore = "timing: run with --release --ignored --nocapture"]
fn timing_split_step() {
    let m =
        LoadedModel::from_source("kepler.lsl", &model_text("kepler"), Backend::default()).unwrap();
    let x0 = m.point("paper").unwrap();
    let mut target = vec![0.0; m.invariant_dim()];
    m.invariants(&x0, &mut target);
    let period = 2.0 * std::f64::consts::PI * 5f64.powf(1.5);
    for tol in [1e-15, 1e-16] {
        for theta in [0.0, 0.05, 0.5, 1.0] {
            let (x, steps, secs) = split_run(&m, &x0, &target, 1000.0 * period, tol, theta);
            let mut f = vec![0.0; target.len()];
            m.invariants(&x, &mut f);
            println!(
                "tol {tol:e}, θ = {theta}: {secs:.4} s, {steps} steps, |Δ(L, A)|∞ = {:.2e}",
                max_diff(&f, &target)
            );
        }
    }
}

//! The feedback-integrator paper's runs (Chang, Jiménez & Perlmutter 2016, §4.1 and §4.2) as a
//! careful person writes them by hand: the fields on fixed-size arrays, Euler and RK4 as plain
//! loops, the invariants' errors sampled as often as `lasalle run` records them. Built with
//! fat LTO and one codegen unit (this crate's profile), it is the baseline the runs from the
//! model files are measured against (`scripts/performance.sh paper-runs`).
//!
//! ```text
//! handwritten-runs MODEL METHOD STEPS SAMPLES
//!   MODEL    kepler | rigid-body (the paper's parameters, gains, initial state and step)
//!   METHOD   euler | rk4 | feedback-euler | feedback-rk4
//!   STEPS    the number of steps
//!   SAMPLES  how many times the invariants' errors are sampled (as `lasalle run` records)
//! ```
//!
//! Prints one JSON line: the loop's CPU seconds, the final state and the largest error of
//! each invariant over the samples.

#[path = "mod.rs"]
mod fields;

use std::process::ExitCode;

/// The process's CPU time in seconds (the clock `lasalle run` reports as `cpu_seconds`).
fn cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_PROCESS_CPUTIME_ID) failed");
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

/// One model of the paper: its field, its feedback field and its invariants' errors.
trait Paper<const N: usize> {
    const H: f64;
    fn initial() -> [f64; N];
    fn field(&self, x: &[f64; N], dx: &mut [f64; N]);
    fn feedback(&self, x: &[f64; N], dx: &mut [f64; N]);
    /// The errors of the invariants against their initial values.
    fn errors(&self, x: &[f64; N]) -> Vec<f64>;
}

#[derive(Clone, Copy, PartialEq)]
enum Method {
    Euler,
    Rk4,
}

/// Kepler, μ = 1, e = 0.8 (§4.2): L and A, gains k₁ = 4, k₂ = 2, h = 0.005.
struct Kepler {
    l0: [f64; 3],
    a0: [f64; 3],
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q) * (p - q))
        .sum::<f64>()
        .sqrt()
}

impl Kepler {
    fn invariants(s: &[f64; 6]) -> ([f64; 3], [f64; 3]) {
        let x = [s[0], s[1], s[2]];
        let v = [s[3], s[4], s[5]];
        let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
        let l = cross(x, v);
        let vl = cross(v, l);
        (l, std::array::from_fn(|c| vl[c] - x[c] / r))
    }

    fn new() -> Kepler {
        let (l0, a0) = Kepler::invariants(&Self::initial());
        Kepler { l0, a0 }
    }
}

impl Paper<6> for Kepler {
    const H: f64 = 0.005;

    fn initial() -> [f64; 6] {
        [1.0, 0.0, 0.0, 0.0, 1.8f64.sqrt(), 0.0]
    }

    fn field(&self, s: &[f64; 6], ds: &mut [f64; 6]) {
        let r2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        let mu_r3 = 1.0 / (r2 * r2.sqrt());
        for c in 0..3 {
            ds[c] = s[3 + c];
            ds[3 + c] = -mu_r3 * s[c];
        }
    }

    fn feedback(&self, s: &[f64; 6], ds: &mut [f64; 6]) {
        fields::kepler(1.0, s, &self.l0, &self.a0, &[4.0, 2.0], ds);
    }

    fn errors(&self, s: &[f64; 6]) -> Vec<f64> {
        let (l, a) = Kepler::invariants(s);
        vec![dist(&l, &self.l0), dist(&a, &self.a0)]
    }
}

/// The free rigid body, 𝕀 = diag(3, 2, 1) (§4.1): RᵀR = I, E and π, gains 50, 100, 50,
/// h = 10⁻⁴.
struct RigidBody {
    e0: f64,
    pi0: [f64; 3],
}

const INERTIA: [f64; 3] = [3.0, 2.0, 1.0];

impl RigidBody {
    fn invariants(x: &[f64; 12]) -> ([f64; 9], f64, [f64; 3]) {
        let r = |a: usize, b: usize| x[a + 3 * b];
        let m: [f64; 3] = std::array::from_fn(|b| INERTIA[b] * x[9 + b]);
        let c = std::array::from_fn(|k| {
            let (a, b) = (k % 3, k / 3);
            let s = r(0, a) * r(0, b) + r(1, a) * r(1, b) + r(2, a) * r(2, b);
            if a == b {
                s - 1.0
            } else {
                s
            }
        });
        let e = 0.5 * (m[0] * x[9] + m[1] * x[10] + m[2] * x[11]);
        let pi = std::array::from_fn(|a| r(a, 0) * m[0] + r(a, 1) * m[1] + r(a, 2) * m[2]);
        (c, e, pi)
    }

    fn new() -> RigidBody {
        let (_, e0, pi0) = RigidBody::invariants(&Self::initial());
        RigidBody { e0, pi0 }
    }
}

impl Paper<12> for RigidBody {
    const H: f64 = 1e-4;

    fn initial() -> [f64; 12] {
        [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
    }

    fn field(&self, x: &[f64; 12], dx: &mut [f64; 12]) {
        let w = [x[9], x[10], x[11]];
        // Ṙ = RΩ̂, column by column: Ω̂e₀ = (0, ω₂, −ω₁), Ω̂e₁ = (−ω₂, 0, ω₀), Ω̂e₂ = (ω₁, −ω₀, 0)
        for a in 0..3 {
            let (r0, r1, r2) = (x[a], x[a + 3], x[a + 6]);
            dx[a] = w[2] * r1 - w[1] * r2;
            dx[a + 3] = w[0] * r2 - w[2] * r0;
            dx[a + 6] = w[1] * r0 - w[0] * r1;
        }
        let m = [INERTIA[0] * w[0], INERTIA[1] * w[1], INERTIA[2] * w[2]];
        let mw = cross(m, w);
        for b in 0..3 {
            dx[9 + b] = mw[b] / INERTIA[b];
        }
    }

    fn feedback(&self, x: &[f64; 12], dx: &mut [f64; 12]) {
        fields::rigid_body(&INERTIA, x, self.e0, &self.pi0, &[50.0, 100.0, 50.0], dx);
    }

    fn errors(&self, x: &[f64; 12]) -> Vec<f64> {
        let (c, e, pi) = RigidBody::invariants(x);
        vec![
            c.iter().map(|v| v * v).sum::<f64>().sqrt(),
            (e - self.e0).abs(),
            dist(&pi, &self.pi0),
        ]
    }
}

/// One step of Euler or RK4 on `f`.
#[inline(always)]
fn step<const N: usize>(
    method: Method,
    f: &impl Fn(&[f64; N], &mut [f64; N]),
    x: &mut [f64; N],
    h: f64,
) {
    let mut k1 = [0.0; N];
    f(x, &mut k1);
    if method == Method::Euler {
        for i in 0..N {
            x[i] += h * k1[i];
        }
        return;
    }
    let (mut k2, mut k3, mut k4, mut y) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    for i in 0..N {
        y[i] = x[i] + 0.5 * h * k1[i];
    }
    f(&y, &mut k2);
    for i in 0..N {
        y[i] = x[i] + 0.5 * h * k2[i];
    }
    f(&y, &mut k3);
    for i in 0..N {
        y[i] = x[i] + h * k3[i];
    }
    f(&y, &mut k4);
    for i in 0..N {
        x[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    }
}

/// The run: `steps` steps, the errors sampled `samples` times; the JSON line.
fn run<const N: usize, P: Paper<N>>(
    model: &P,
    method: Method,
    feedback: bool,
    steps: u64,
    samples: u64,
) -> String {
    let start = cpu_seconds();
    let mut x = P::initial();
    let every = (steps / samples.max(1)).max(1);
    let mut worst = model.errors(&x);
    let sample = |x: &[f64; N], worst: &mut Vec<f64>| {
        for (w, e) in worst.iter_mut().zip(model.errors(x)) {
            *w = w.max(e);
        }
    };
    let (field, fb) = (
        |x: &[f64; N], dx: &mut [f64; N]| model.field(x, dx),
        |x: &[f64; N], dx: &mut [f64; N]| model.feedback(x, dx),
    );
    for n in 1..=steps {
        if feedback {
            step(method, &fb, &mut x, P::H);
        } else {
            step(method, &field, &mut x, P::H);
        }
        if n % every == 0 || n == steps {
            sample(&x, &mut worst);
        }
    }
    let cpu = cpu_seconds() - start;
    let list = |v: &[f64]| {
        v.iter()
            .map(|e| format!("{e:e}"))
            .collect::<Vec<_>>()
            .join(",")
    };
    format!(
        "{{\"cpu_seconds\":{cpu},\"steps\":{steps},\"final_state\":[{}],\"max_errors\":[{}]}}",
        list(&x),
        list(&worst)
    )
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: handwritten-runs kepler|rigid-body euler|rk4|feedback-euler|feedback-rk4 STEPS SAMPLES";
    let [model, method, steps, samples] = args.as_slice() else {
        eprintln!("{usage}");
        return ExitCode::from(2);
    };
    let (method, feedback) = match method.as_str() {
        "euler" => (Method::Euler, false),
        "rk4" => (Method::Rk4, false),
        "feedback-euler" => (Method::Euler, true),
        "feedback-rk4" => (Method::Rk4, true),
        other => {
            eprintln!("unknown method `{other}`; {usage}");
            return ExitCode::from(2);
        }
    };
    let (Ok(steps), Ok(samples)) = (steps.parse::<u64>(), samples.parse::<u64>()) else {
        eprintln!("STEPS and SAMPLES are whole numbers; {usage}");
        return ExitCode::from(2);
    };
    let line = match model.as_str() {
        "kepler" => run(&Kepler::new(), method, feedback, steps, samples),
        "rigid-body" => run(&RigidBody::new(), method, feedback, steps, samples),
        other => {
            eprintln!("unknown model `{other}`; {usage}");
            return ExitCode::from(2);
        }
    };
    println!("{line}");
    ExitCode::SUCCESS
}

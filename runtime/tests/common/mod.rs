//! Test models with known answers (diffsol's `test_models` habit).
//!
//! The pendulum and the free rigid body are the code generator's golden fixtures
//! (`codegen/tests/golden/*.rs`, pinned by that crate's tests), included as they are emitted: the
//! runtime is tested on the code users run. The harmonic oscillator (with its exact solution) and
//! the Kepler problem (with L, A and the paper's feedback written out by hand) stay hand-written,
//! so that the runtime is also checked against formulas the generator did not produce.
#![allow(dead_code)]

use lasalle_runtime::*;

pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

pub fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// Least-squares slope of log(err) against log(h).
pub fn fit_slope(hs: &[f64], errs: &[f64]) -> f64 {
    let n = hs.len() as f64;
    let lx: Vec<f64> = hs.iter().map(|h| h.ln()).collect();
    let ly: Vec<f64> = errs.iter().map(|e| e.ln()).collect();
    let mx = lx.iter().sum::<f64>() / n;
    let my = ly.iter().sum::<f64>() / n;
    let sxy: f64 = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = lx.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

// ---------------------------------------------------------------- harmonic oscillator

/// q̇ = p, ṗ = −q; exact solution q = q₀ cos t + p₀ sin t. Invariant: E = ½(q² + p²).
pub struct Oscillator;

impl Field<f64, [f64; 2]> for Oscillator {
    fn field(&self, x: &[f64; 2], dx: &mut [f64; 2]) {
        dx[0] = x[1];
        dx[1] = -x[0];
    }
}

impl Partitioned<f64, [f64; 2]> for Oscillator {
    fn is_q(&self) -> &[bool] {
        &[true, false]
    }
    fn field_q(&self, x: &[f64; 2], dx: &mut [f64; 2]) {
        dx[0] = x[1];
    }
    fn field_p(&self, x: &[f64; 2], dx: &mut [f64; 2]) {
        dx[1] = -x[0];
    }
}

impl Invariants<f64, [f64; 2], [f64; 1]> for Oscillator {
    fn invariants(&self, x: &[f64; 2], f: &mut [f64; 1]) {
        f[0] = 0.5 * (x[0] * x[0] + x[1] * x[1]);
    }
    fn invariants_jacobian(&self, x: &[f64; 2], jac: &mut [[f64; 2]; 1]) {
        jac[0] = [x[0], x[1]];
    }
}

impl ModelInfo for Oscillator {
    fn model_name(&self) -> &'static str {
        "oscillator"
    }
    fn state_slots(&self) -> &'static [Slot] {
        &[
            Slot {
                name: "q",
                shape: Shape::Scalar,
                offset: 0,
            },
            Slot {
                name: "p",
                shape: Shape::Scalar,
                offset: 1,
            },
        ]
    }
    fn invariant_infos(&self) -> &'static [InvariantInfo] {
        &[InvariantInfo {
            slot: Slot {
                name: "E",
                shape: Shape::Scalar,
                offset: 0,
            },
            kind: InvariantKind::Integral,
            gain: 0,
        }]
    }
    fn gain_names(&self) -> &'static [&'static str] {
        &["k"]
    }
    fn default_gain_values(&self) -> &'static [f64] {
        &[1.0]
    }
    fn param_slots(&self) -> &'static [Slot] {
        &[]
    }
}

// ---------------------------------------------------------------- Kepler

/// ẋ = v, v̇ = −μx/|x|³ (Chang, Jiménez & Perlmutter 2016, (31)); invariants L = x × v (f[0..3]) and
/// A = v × L − μx/|x| (f[3..6]); gains k₁ (L), k₂ (A).
pub struct Kepler {
    pub mu: f64,
}

impl Kepler {
    pub fn energy(&self, x: &[f64; 6]) -> f64 {
        0.5 * norm(&x[3..6]).powi(2) - self.mu / norm(&x[0..3])
    }

    /// The feedback field of Lemma 3.5 / (41), written out by hand (Chang, Jiménez & Perlmutter 2016, §3.2).
    pub fn hand_feedback(&self, x: &[f64; 6], target: &[f64; 6], k: &[f64; 2], dx: &mut [f64; 6]) {
        let mu = self.mu;
        let p = [x[0], x[1], x[2]];
        let v = [x[3], x[4], x[5]];
        let mut f = [0.0; 6];
        self.invariants(x, &mut f);
        let dl = [f[0] - target[0], f[1] - target[1], f[2] - target[2]];
        let da = [f[3] - target[3], f[4] - target[4], f[5] - target[5]];
        let r = norm(&p);
        let (k1, k2) = (k[0], k[1]);
        // ∇ₓV = k₁ v × ΔL + k₂ (v × (ΔA × v) − (μ/r) ΔA + (μ/r³) x xᵀ ΔA)
        let vxdl = cross(&v, &dl);
        let vxdaxv = cross(&v, &cross(&da, &v));
        let xda: f64 = (0..3).map(|i| p[i] * da[i]).sum();
        // ∇ᵥV = k₁ ΔL × x + k₂ ((x × v) × ΔA + x × (v × ΔA))
        let dlxx = cross(&dl, &p);
        let lxda = cross(&cross(&p, &v), &da);
        let xxvxda = cross(&p, &cross(&v, &da));
        for i in 0..3 {
            let gx = k1 * vxdl[i] + k2 * (vxdaxv[i] - mu / r * da[i] + mu / r.powi(3) * p[i] * xda);
            let gv = k1 * dlxx[i] + k2 * (lxda[i] + xxvxda[i]);
            dx[i] = v[i] - gx;
            dx[3 + i] = -mu * p[i] / r.powi(3) - gv;
        }
    }
}

impl Field<f64, [f64; 6]> for Kepler {
    fn field(&self, x: &[f64; 6], dx: &mut [f64; 6]) {
        let r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        let c = -self.mu / (r2 * r2.sqrt());
        dx[0] = x[3];
        dx[1] = x[4];
        dx[2] = x[5];
        dx[3] = c * x[0];
        dx[4] = c * x[1];
        dx[5] = c * x[2];
    }
}

impl Partitioned<f64, [f64; 6]> for Kepler {
    fn is_q(&self) -> &[bool] {
        &[true, true, true, false, false, false]
    }
    fn field_q(&self, x: &[f64; 6], dx: &mut [f64; 6]) {
        dx[0] = x[3];
        dx[1] = x[4];
        dx[2] = x[5];
    }
    fn field_p(&self, x: &[f64; 6], dx: &mut [f64; 6]) {
        let r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2];
        let c = -self.mu / (r2 * r2.sqrt());
        dx[3] = c * x[0];
        dx[4] = c * x[1];
        dx[5] = c * x[2];
    }
}

fn hat(a: &[f64; 3]) -> [[f64; 3]; 3] {
    [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]]
}

fn matmul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

impl Invariants<f64, [f64; 6], [f64; 6]> for Kepler {
    fn invariants(&self, x: &[f64; 6], f: &mut [f64; 6]) {
        let p = [x[0], x[1], x[2]];
        let v = [x[3], x[4], x[5]];
        let l = cross(&p, &v);
        let a = cross(&v, &l);
        let r = norm(&p);
        for i in 0..3 {
            f[i] = l[i];
            f[3 + i] = a[i] - self.mu * p[i] / r;
        }
    }

    /// ∂L/∂x = −v̂, ∂L/∂v = x̂; ∂A/∂x = −v̂v̂ − μ(I/r − x xᵀ/r³), ∂A/∂v = −L̂ + v̂x̂.
    fn invariants_jacobian(&self, x: &[f64; 6], jac: &mut [[f64; 6]; 6]) {
        let p = [x[0], x[1], x[2]];
        let v = [x[3], x[4], x[5]];
        let l = cross(&p, &v);
        let r = norm(&p);
        let (vh, xh, lh) = (hat(&v), hat(&p), hat(&l));
        let vv = matmul3(&vh, &vh);
        let vx = matmul3(&vh, &xh);
        for i in 0..3 {
            for j in 0..3 {
                let delta = if i == j { 1.0 } else { 0.0 };
                jac[i][j] = -vh[i][j];
                jac[i][3 + j] = xh[i][j];
                jac[3 + i][j] = -vv[i][j] - self.mu * (delta / r - p[i] * p[j] / r.powi(3));
                jac[3 + i][3 + j] = -lh[i][j] + vx[i][j];
            }
        }
    }
}

impl Lyapunov<f64, [f64; 6], [f64; 6], [f64; 2]> for Kepler {
    fn lyapunov(&self, x: &[f64; 6], target: &[f64; 6], gains: &[f64; 2]) -> f64 {
        let mut g = [0.0; 6];
        default_lyapunov_gradient(self, x, target, gains, &mut g)
    }
    fn lyapunov_gradient(
        &self,
        x: &[f64; 6],
        target: &[f64; 6],
        gains: &[f64; 2],
        grad: &mut [f64; 6],
    ) {
        default_lyapunov_gradient(self, x, target, gains, grad);
    }
    fn feedback_field(&self, x: &[f64; 6], target: &[f64; 6], gains: &[f64; 2], dx: &mut [f64; 6]) {
        let mut g = [0.0; 6];
        default_lyapunov_gradient(self, x, target, gains, &mut g);
        self.field(x, dx);
        for i in 0..6 {
            dx[i] -= g[i];
        }
    }
}

impl ModelInfo for Kepler {
    fn model_name(&self) -> &'static str {
        "kepler"
    }
    fn state_slots(&self) -> &'static [Slot] {
        &[
            Slot {
                name: "x",
                shape: Shape::Vector(3),
                offset: 0,
            },
            Slot {
                name: "v",
                shape: Shape::Vector(3),
                offset: 3,
            },
        ]
    }
    fn invariant_infos(&self) -> &'static [InvariantInfo] {
        &[
            InvariantInfo {
                slot: Slot {
                    name: "L",
                    shape: Shape::Vector(3),
                    offset: 0,
                },
                kind: InvariantKind::Integral,
                gain: 0,
            },
            InvariantInfo {
                slot: Slot {
                    name: "A",
                    shape: Shape::Vector(3),
                    offset: 3,
                },
                kind: InvariantKind::Integral,
                gain: 1,
            },
        ]
    }
    fn gain_names(&self) -> &'static [&'static str] {
        &["k1", "k2"]
    }
    fn default_gain_values(&self) -> &'static [f64] {
        &[4.0, 2.0]
    }
    fn param_slots(&self) -> &'static [Slot] {
        &[Slot {
            name: "mu",
            shape: Shape::Scalar,
            offset: 0,
        }]
    }
}

/// The planar Kepler orbit (μ = 1) that starts at periapsis (rp, 0, 0) with velocity
/// (0, √((1+e)/rp), 0): initial state and exact state at time t via Kepler's equation.
pub struct KeplerOrbit {
    pub e: f64,
    pub rp: f64,
}

impl KeplerOrbit {
    pub fn a(&self) -> f64 {
        self.rp / (1.0 - self.e)
    }
    pub fn period(&self) -> f64 {
        2.0 * std::f64::consts::PI * self.a().powf(1.5)
    }
    pub fn initial(&self) -> [f64; 6] {
        [
            self.rp,
            0.0,
            0.0,
            0.0,
            ((1.0 + self.e) / self.rp).sqrt(),
            0.0,
        ]
    }
    pub fn exact(&self, t: f64) -> [f64; 6] {
        let (a, e) = (self.a(), self.e);
        let n = a.powf(-1.5);
        let m = n * t;
        let mut ecc = if e > 0.8 { std::f64::consts::PI } else { m };
        for _ in 0..100 {
            let d = (ecc - e * ecc.sin() - m) / (1.0 - e * ecc.cos());
            ecc -= d;
            if d.abs() < 1e-16 {
                break;
            }
        }
        let b = a * (1.0 - e * e).sqrt();
        let edot = n / (1.0 - e * ecc.cos());
        [
            a * (ecc.cos() - e),
            b * ecc.sin(),
            0.0,
            -a * ecc.sin() * edot,
            b * ecc.cos() * edot,
            0.0,
        ]
    }
}

// ---------------------------------------------------------------- golden fixtures

mod golden {
    include!("../../../codegen/tests/golden/pendulum.rs");
    include!("../../../codegen/tests/golden/rigid_body.rs");
}

/// The pendulum q̇ = p, ṗ = −(g/l) sin q with E = ½p² − (g/l) cos q, as generated.
pub type Pendulum = golden::pendulum::PendulumPrepared;

/// The pendulum with g/l = 1.
pub fn pendulum() -> Pendulum {
    golden::pendulum::Pendulum { g: 1.0, l: 1.0 }.prepare()
}

/// The free rigid body Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω), as generated: R column-major in x[0..9], Ω in
/// x[9..12]; invariants RᵀR − I (f[0..9]), E = ½Ωᵀ𝕀Ω (f[9]), π = R𝕀Ω (f[10..13]).
pub type RigidBody = golden::rigid_body::RigidBodyPrepared;

/// The free rigid body with principal moments `inertia`.
pub fn rigid_body(inertia: [f64; 3]) -> RigidBody {
    golden::rigid_body::RigidBody { i: inertia }.prepare()
}

/// Checks written independently of the generated invariants.
impl RigidBody {
    pub fn r(x: &[f64; 12], a: usize, b: usize) -> f64 {
        x[a + 3 * b]
    }
    pub fn initial() -> [f64; 12] {
        [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]
    }
    pub fn energy(&self, x: &[f64; 12]) -> f64 {
        0.5 * (0..3).map(|k| self.i[k] * x[9 + k] * x[9 + k]).sum::<f64>()
    }
    pub fn spatial_momentum(&self, x: &[f64; 12]) -> [f64; 3] {
        std::array::from_fn(|a| {
            (0..3)
                .map(|b| Self::r(x, a, b) * self.i[b] * x[9 + b])
                .sum()
        })
    }
    pub fn orthogonality_error(x: &[f64; 12]) -> f64 {
        let mut s = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let c: f64 = (0..3)
                    .map(|k| Self::r(x, k, i) * Self::r(x, k, j))
                    .sum::<f64>()
                    - if i == j { 1.0 } else { 0.0 };
                s += c * c;
            }
        }
        s.sqrt()
    }
}

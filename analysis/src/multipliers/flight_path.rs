//! The paper's frames: the spherical flight-path frame (r, φ, θ, v, γ, δ) and the plumb-line
//! frame (x, y, z, l, m, n) = (x, y, z, ẋ, ẏ, ż) of a vehicle thrusting in vacuum about a
//! non-rotating spherical body, thrust acceleration a = T/M (constant thrust and weight flow:
//! a = a₀/(1 − k t)).
//!
//! With U = (cos φ cos θ, cos φ sin θ, sin φ) (up), N = (−sin φ cos θ, −sin φ sin θ, cos φ)
//! (north) and W = (sin θ, −cos θ, 0) — the paper's θ grows westward,
//! θ̇ = −v cos γ sin δ/(r cos φ) — the change is R = r U, V = v (sin γ U + cos γ cos δ N + cos γ sin δ W), the paper's
//! transformation equations. In the plumb-line frame the control angles eliminate to thrust
//! along σ_V = (σ_l, σ_m, σ_n); in the spherical frame the paper obtains, by transforming,
//!
//! ```text
//! v̇ = a λ_v/S − g sin γ
//! γ̇ = a λ_γ/(v² S) + (v/r − g/v) cos γ
//! δ̇ = a λ_δ/(v² cos²γ S) + v cos γ sin δ tan φ / r
//! S = (λ_v² + λ_γ²/v² + λ_δ²/(v² cos²γ))^½ = |σ_V|,  g = μ/r²,
//! tan α = λ_γ/(v λ_v),  tan β = λ_δ/(v λ_v cos γ).
//! ```

use lasalle_model::ir::{Func, Graph, Id, Input, Rational};
use lasalle_runtime::{Control, DormandPrince, DormandPrinceOptions, Driver, Field};

use super::{CoordinateChange, EulerLagrange, MultiplierError};

/// The spherical flight-path frame's coordinates.
pub const SPHERICAL: [&str; 6] = ["r", "φ", "θ", "v", "γ", "δ"];
/// The plumb-line frame's coordinates (l, m, n = ẋ, ẏ, ż).
pub const PLUMB_LINE: [&str; 6] = ["x", "y", "z", "l", "m", "n"];

/// Parameter slots of the equations: μ and the thrust acceleration a = T/M.
const MU: u32 = 0;
const ACC: u32 = 1;

fn state(g: &mut Graph, n: usize) -> Vec<Id> {
    (0..n as u32).map(|i| g.input(Input::State(i))).collect()
}

fn trig(g: &mut Graph, a: Id) -> (Id, Id) {
    (g.func(Func::Sin, a), g.func(Func::Cos, a))
}

/// The paper's transformation equations, spherical → plumb line.
pub fn change() -> CoordinateChange {
    let mut g = Graph::new();
    let s = state(&mut g, 6);
    let (r, v) = (s[0], s[3]);
    let (sf, cf) = trig(&mut g, s[1]);
    let (st, ct) = trig(&mut g, s[2]);
    let (sg, cg) = trig(&mut g, s[4]);
    let (sd, cd) = trig(&mut g, s[5]);
    let mut h = vec![g.mul(&[r, cf, ct]), g.mul(&[r, cf, st]), g.mul(&[r, sf])];
    // l = v[sin γ cos φ cos θ − sin φ cos θ cos γ cos δ + sin θ cos γ sin δ], m, n likewise
    let l = {
        let a = g.mul(&[sg, cf, ct]);
        let b = g.mul(&[sf, ct, cg, cd]);
        let b = g.neg(b);
        let c = g.mul(&[st, cg, sd]);
        g.add(&[a, b, c])
    };
    let m = {
        let a = g.mul(&[sg, cf, st]);
        let b = g.mul(&[ct, cg, sd]);
        let b = g.neg(b);
        let c = g.mul(&[sf, st, cg, cd]);
        let c = g.neg(c);
        g.add(&[a, b, c])
    };
    let n = {
        let a = g.mul(&[sg, sf]);
        let b = g.mul(&[cf, cg, cd]);
        g.add(&[a, b])
    };
    for w in [l, m, n] {
        h.push(g.mul(&[v, w]));
    }
    CoordinateChange::new(g, &SPHERICAL, &PLUMB_LINE, h)
        .expect("the paper's change has six expressions in the six coordinates")
}

/// The inverse change, plumb line → spherical: r = |R|, θ = atan2(y, x),
/// φ = atan2(z, (x² + y²)^½), v = |V|, γ = atan2(V·U, ((V·N)² + (V·W)²)^½),
/// δ = atan2(V·W, V·N).
pub fn spherical(y: &[f64]) -> [f64; 6] {
    let (x, yy, z) = (y[0], y[1], y[2]);
    let vel = [y[3], y[4], y[5]];
    let r = (x * x + yy * yy + z * z).sqrt();
    let th = yy.atan2(x);
    let ph = z.atan2(x.hypot(yy));
    let (sf, cf, st, ct) = (ph.sin(), ph.cos(), th.sin(), th.cos());
    let dot = |a: [f64; 3]| a[0] * vel[0] + a[1] * vel[1] + a[2] * vel[2];
    let vu = dot([cf * ct, cf * st, sf]);
    let vn = dot([-sf * ct, -sf * st, cf]);
    let vw = dot([st, -ct, 0.0]);
    let v = (vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2]).sqrt();
    [r, ph, th, v, vu.atan2(vn.hypot(vw)), vw.atan2(vn)]
}

/// The plumb-line equations with the control angles eliminated (thrust along σ_V):
/// Ṙ = V, V̇ = a σ_V/|σ_V| − μR/r³; their adjoint is derived by the IR.
pub fn plumb_line_equations() -> EulerLagrange {
    let mut g = Graph::new();
    let s = state(&mut g, 6);
    let sig: Vec<Id> = (3..6).map(|i| g.input(Input::Symbol(i))).collect();
    let mu = g.input(Input::Param(MU));
    let a = g.input(Input::Param(ACC));
    let sq = |g: &mut Graph, v: &[Id]| {
        let t: Vec<Id> = v.iter().map(|&e| g.pow(e, Rational::int(2))).collect();
        g.add(&t)
    };
    let r2 = sq(&mut g, &s[..3]);
    let s2 = sq(&mut g, &sig);
    let inv_r3 = g.pow(r2, Rational::new(-3, 2));
    let inv_s = g.pow(s2, Rational::new(-1, 2));
    let mut f = vec![s[3], s[4], s[5]];
    for i in 0..3 {
        let thrust = g.mul(&[a, sig[i], inv_s]);
        let grav = g.mul(&[mu, s[i], inv_r3]);
        f.push(g.sub(thrust, grav));
    }
    EulerLagrange::new(g, f)
}

/// The spherical equations the paper prints after transforming (the module's formulas), with
/// the adjoint λ̇ = −∂(λ·f)/∂x derived by the IR.
pub fn spherical_equations() -> EulerLagrange {
    let mut g = Graph::new();
    let s = state(&mut g, 6);
    let lam: Vec<Id> = (3..6).map(|i| g.input(Input::Symbol(i))).collect();
    let mu = g.input(Input::Param(MU));
    let a = g.input(Input::Param(ACC));
    let (r, v) = (s[0], s[3]);
    let (sf, cf) = trig(&mut g, s[1]);
    let (sg, cg) = trig(&mut g, s[4]);
    let (sd, cd) = trig(&mut g, s[5]);
    let inv_r = g.pow(r, Rational::int(-1));
    let inv_v = g.pow(v, Rational::int(-1));
    let inv_v2 = g.pow(v, Rational::int(-2));
    let inv_cg2 = g.pow(cg, Rational::int(-2));
    let inv_cf = g.pow(cf, Rational::int(-1));
    let grav = g.mul(&[mu, inv_r, inv_r]);
    let s2 = {
        let a2 = g.pow(lam[0], Rational::int(2));
        let b2 = g.pow(lam[1], Rational::int(2));
        let b2 = g.mul(&[b2, inv_v2]);
        let c2 = g.pow(lam[2], Rational::int(2));
        let c2 = g.mul(&[c2, inv_v2, inv_cg2]);
        g.add(&[a2, b2, c2])
    };
    let inv_s = g.pow(s2, Rational::new(-1, 2));
    let rdot = g.mul(&[v, sg]);
    let phdot = g.mul(&[v, cg, cd, inv_r]);
    let thdot = {
        let t = g.mul(&[v, cg, sd, inv_r, inv_cf]);
        g.neg(t)
    };
    let vdot = {
        let t = g.mul(&[a, lam[0], inv_s]);
        let w = g.mul(&[grav, sg]);
        g.sub(t, w)
    };
    let gdot = {
        let t = g.mul(&[a, lam[1], inv_v2, inv_s]);
        let vr = g.mul(&[v, inv_r]);
        let gv = g.mul(&[grav, inv_v]);
        let k = g.sub(vr, gv);
        let k = g.mul(&[k, cg]);
        g.add(&[t, k])
    };
    let ddot = {
        let t = g.mul(&[a, lam[2], inv_v2, inv_cg2, inv_s]);
        let k = g.mul(&[v, cg, sd, sf, inv_cf, inv_r]);
        g.add(&[t, k])
    };
    EulerLagrange::new(g, vec![rdot, phdot, thdot, vdot, gdot, ddot])
}

/// tan α and tan β from the spherical rates by the paper's equations of motion with the
/// angles (before elimination), and the thrust acceleration they imply,
/// a = ±(v̇ + g sin γ)(1 + tan²α + tan²β)^½ (the sign of λ_v: the paper's ± before the root).
pub fn angles(mu: f64, x: &[f64], xdot: &[f64]) -> (f64, f64, f64) {
    let (r, ph, v, ga, de) = (x[0], x[1], x[3], x[4], x[5]);
    let g = mu / (r * r);
    let p = xdot[3] + g * ga.sin();
    let ta = v * (xdot[4] - (v / r - g / v) * ga.cos()) / p;
    let drift = v * ga.cos() * de.sin() * ph.tan() / r;
    let tb = v * ga.cos() * (xdot[5] - drift) / p;
    (ta, tb, p * (1.0 + ta * ta + tb * tb).sqrt())
}

/// The paper's printed partials ∂(v, γ, δ)/∂(l, m, n) (rows v, γ, δ; columns l, m, n) as
/// printed — δ_l with the printed sign.
pub fn printed_partials(x: &[f64]) -> [[f64; 3]; 3] {
    let (v, f, t, g, d) = (x[3], x[1], x[2], x[4], x[5]);
    let (sf, cf, st, ct) = (f.sin(), f.cos(), t.sin(), t.cos());
    let (sg, cg, sd, cd) = (g.sin(), g.cos(), d.sin(), d.cos());
    [
        [
            st * cg * sd + cf * ct * sg - sf * ct * cg * cd,
            cf * st * sg - ct * cg * sd - sf * st * cg * cd,
            sf * sg + cf * cg * cd,
        ],
        [
            (cf * ct * cg + sf * ct * sg * cd - st * sg * sd) / v,
            (ct * sg * sd + cf * st * cg + sf * st * sg * cd) / v,
            (sf * cg - cf * sg * cd) / v,
        ],
        [
            -(st * cd + sf * ct * sd) / (v * cg),
            (sf * st * sd - ct * cd) / (v * cg),
            -(cf * sd) / (v * cg),
        ],
    ]
}

/// A thrusting extremal in the plumb-line frame: μ, the initial thrust acceleration a₀ and the
/// mass-flow rate k (a = a₀/(1 − k t)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extremal {
    /// μ.
    pub mu: f64,
    /// a₀ = T/M₀.
    pub a0: f64,
    /// k = ṁ/M₀.
    pub k: f64,
}

impl Extremal {
    /// a = T/M at time t.
    pub fn acceleration(&self, t: f64) -> f64 {
        self.a0 / (1.0 - self.k * t)
    }

    /// The paper's plumb-line equations and Euler–Lagrange equations as printed:
    /// state (R, V, σ_R, σ_V, t), σ̇_R = μσ_V/r³ − 3μR(R·σ_V)/r⁵, σ̇_V = −σ_R.
    fn rates(&self, s: &[f64], d: &mut [f64]) {
        let r2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
        let k = self.mu / (r2 * r2.sqrt());
        let dot = s[0] * s[9] + s[1] * s[10] + s[2] * s[11];
        let norm = (s[9] * s[9] + s[10] * s[10] + s[11] * s[11]).sqrt();
        let a = self.acceleration(s[12]);
        for i in 0..3 {
            d[i] = s[3 + i];
            d[3 + i] = a * s[9 + i] / norm - k * s[i];
            d[6 + i] = k * s[9 + i] - 3.0 * k * s[i] * dot / r2;
            d[9 + i] = -s[6 + i];
        }
        d[12] = 1.0;
    }

    /// Integrates the extremal from `y0` (R, V) and `sigma0` over [0, t_end] with DOPRI5
    /// (rtol 1e-13) and returns (t, y, σ) at every accepted step.
    #[allow(clippy::type_complexity)]
    pub fn integrate(
        &self,
        y0: &[f64; 6],
        sigma0: &[f64; 6],
        t_end: f64,
    ) -> Result<Vec<(f64, [f64; 6], [f64; 6])>, MultiplierError> {
        if !(self.k * t_end < 1.0 && self.mu > 0.0 && self.a0 >= 0.0) {
            return Err(MultiplierError::Shape(format!(
                "the extremal needs μ > 0, a₀ ≥ 0 and mass left at t_end (k·t_end = {} < 1)",
                self.k * t_end
            )));
        }
        let mut x: Vec<f64> = y0.iter().chain(sigma0).copied().collect();
        x.push(0.0);
        let opts = DormandPrinceOptions {
            rtol: 1e-13,
            atol: 1e-15,
            ..Default::default()
        };
        let mut dp5 = DormandPrince::<f64, Vec<f64>>::new(opts);
        let mut out = Vec::new();
        let mut observe = |_: u64, t: f64, s: &Vec<f64>| {
            let mut y = [0.0; 6];
            let mut sg = [0.0; 6];
            y.copy_from_slice(&s[..6]);
            sg.copy_from_slice(&s[6..12]);
            out.push((t, y, sg));
            Control::Continue
        };
        Driver::new(0.0, t_end, 0.0)
            .max_steps(1_000_000)
            .run(&mut dp5, self, &x, &mut observe)
            .map_err(|e| {
                MultiplierError::Shape(format!("the extremal's integration failed: {e}"))
            })?;
        Ok(out)
    }

    /// The plumb-line rates (ẏ, σ̇) at time t, as the integrator sees them.
    pub fn plumb_line_rates(&self, t: f64, y: &[f64; 6], sigma: &[f64; 6]) -> ([f64; 6], [f64; 6]) {
        let mut s: Vec<f64> = y.iter().chain(sigma).copied().collect();
        s.push(t);
        let mut d = vec![0.0; 13];
        self.rates(&s, &mut d);
        let mut yd = [0.0; 6];
        let mut sd = [0.0; 6];
        yd.copy_from_slice(&d[..6]);
        sd.copy_from_slice(&d[6..12]);
        (yd, sd)
    }
}

impl Field<f64, Vec<f64>> for Extremal {
    fn field(&self, s: &Vec<f64>, d: &mut Vec<f64>) {
        self.rates(s, d);
    }
}

/// The residuals of the paper's identities at one point of an extremal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residuals {
    /// The time.
    pub t: f64,
    /// |σ_l² + σ_m² + σ_n² − (λ_v² + λ_γ²/v² + λ_δ²/(v² cos²γ))| / (σ_l² + σ_m² + σ_n²).
    pub norm: f64,
    /// |tan α − λ_γ/(v λ_v)| / |tan α|, tan α from the rates by the equations of motion.
    pub tan_alpha: f64,
    /// |tan β − λ_δ/(v λ_v cos γ)| / |tan β|.
    pub tan_beta: f64,
    /// ||a| implied by the rates − T/M| / (T/M).
    pub thrust: f64,
    /// The largest |ẋ transformed − ẋ printed| over the rounding scale of each component.
    pub state: f64,
    /// The largest |λ̇ transformed − λ̇ derived from the printed equations| over the rounding
    /// scale of each component.
    pub adjoint: f64,
    /// tan α and tan β (λ_γ/(v λ_v), λ_δ/(v λ_v cos γ)).
    pub tans: (f64, f64),
}

/// The frames and equations the check uses, built once.
pub struct Check {
    change: CoordinateChange,
    plumb: EulerLagrange,
    sphere: EulerLagrange,
}

impl Default for Check {
    fn default() -> Self {
        Check::new()
    }
}

impl Check {
    /// Builds the change and both frames' equations.
    pub fn new() -> Check {
        Check {
            change: change(),
            plumb: plumb_line_equations(),
            sphere: spherical_equations(),
        }
    }

    /// The coordinate change.
    pub fn change(&self) -> &CoordinateChange {
        &self.change
    }

    /// The residuals at (t, y, σ) of the extremal `e`.
    pub fn at(
        &self,
        e: &Extremal,
        t: f64,
        y: &[f64; 6],
        sigma: &[f64; 6],
    ) -> Result<Residuals, MultiplierError> {
        let x = spherical(y);
        let lam = self.change.multipliers(&x, sigma)?;
        let (v, cg) = (x[3], x[4].cos());
        let s2 = sigma[3] * sigma[3] + sigma[4] * sigma[4] + sigma[5] * sigma[5];
        let l2 = lam[3] * lam[3] + (lam[4] / v).powi(2) + (lam[5] / (v * cg)).powi(2);
        let (yd, sd) = e.plumb_line_rates(t, y, sigma);
        let xd = self.change.state_rates(&x, &yd)?;
        let (ta, tb, acc) = angles(e.mu, &x, &xd);
        let tans = (lam[4] / (v * lam[3]), lam[5] / (v * lam[3] * cg));
        let params = [e.mu, e.acceleration(t)];
        // the transformed equations against the spherical ones (rounding scales of both)
        let (fx, fl) = self.sphere.eval_scaled(&x, &lam, &params);
        let ld = self.change.multiplier_rates_scaled(&x, &xd, sigma, &sd)?;
        let rel = |a: f64, b: f64, s: f64| (a - b).abs() / s.max(a.abs()).max(b.abs());
        let state = (0..6)
            .map(|i| rel(xd[i], fx[i].0, fx[i].1))
            .fold(0.0, f64::max);
        let adjoint = (0..6)
            .map(|i| rel(ld[i].0, fl[i].0, fl[i].1.max(ld[i].1)))
            .fold(0.0, f64::max);
        Ok(Residuals {
            t,
            norm: (s2 - l2).abs() / s2,
            tan_alpha: (ta - tans.0).abs() / ta.abs(),
            tan_beta: (tb - tans.1).abs() / tb.abs(),
            thrust: (acc.abs() - params[1]).abs() / params[1],
            state,
            adjoint,
            tans,
        })
    }

    /// The plumb-line frame's IR-derived adjoint against the paper's printed σ̇ at (t, y, σ):
    /// the largest difference over the rounding scale.
    pub fn plumb_line_adjoint(&self, e: &Extremal, t: f64, y: &[f64; 6], sigma: &[f64; 6]) -> f64 {
        let (yd, sd) = e.plumb_line_rates(t, y, sigma);
        let (f, a) = self.plumb.eval_scaled(y, sigma, &[e.mu, e.acceleration(t)]);
        (0..6)
            .map(|i| {
                let ds = (f[i].0 - yd[i]).abs() / f[i].1.max(yd[i].abs());
                let da = (a[i].0 - sd[i]).abs() / a[i].1.max(sd[i].abs());
                ds.max(da)
            })
            .fold(0.0, f64::max)
    }

    /// The plumb-line equations transformed to the spherical frame at (x, λ) (the general
    /// [`CoordinateChange::transform_equations`]) against the spherical ones: the largest
    /// difference over the rounding scale.
    pub fn transformed_at(
        &self,
        mu: f64,
        a: f64,
        x: &[f64],
        lam: &[f64],
    ) -> Result<f64, MultiplierError> {
        let params = [mu, a];
        let (xd, ld) = self
            .change
            .transform_equations(&self.plumb, &params, x, lam)?;
        // the rounding scales of λ̇ = Jᵀσ̇ + J̇ᵀσ at the same σ, ẋ, σ̇
        let sigma = self.change.multipliers_inverse(x, lam)?;
        let (_, sd) = self.plumb.eval(&self.change.apply(x)?, &sigma, &params);
        let scales = self.change.multiplier_rates_scaled(x, &xd, &sigma, &sd)?;
        let (fx, fl) = self.sphere.eval_scaled(x, lam, &params);
        let rel = |a: f64, b: f64, s: f64| (a - b).abs() / s.max(a.abs()).max(b.abs());
        Ok((0..6)
            .map(|i| {
                rel(xd[i], fx[i].0, fx[i].1).max(rel(ld[i], fl[i].0, fl[i].1.max(scales[i].1)))
            })
            .fold(0.0, f64::max))
    }
}

/// The thrusting extremal of the documentation and the experiment: μ of the Earth
/// [km³/s²], a₀ = 20 m/s², a thousandth of the initial mass burnt per second, started at
/// (r, φ, θ, v, γ, δ) = (6678.137 km, 0.3, 0.5, 7.9 km/s, 0.05, 0.8) with
/// σ = (1e-3, −2e-3, 1.5e-3, 0.4, −0.7, 0.6); returns it with y₀ = h(x₀), σ₀ and x₀.
pub fn example() -> (Extremal, [f64; 6], [f64; 6], [f64; 6]) {
    let e = Extremal {
        mu: 398_600.441_8,
        a0: 0.02,
        k: 1e-3,
    };
    let x0 = [6678.137, 0.3, 0.5, 7.9, 0.05, 0.8];
    let y = change().apply(&x0).expect("six finite values");
    let y0 = [y[0], y[1], y[2], y[3], y[4], y[5]];
    (e, y0, [1.0e-3, -2.0e-3, 1.5e-3, 0.4, -0.7, 0.6], x0)
}

/// `count` spherical points off the singular set (r ∈ [6500, 9000] km, |φ|, |γ| ≤ 1.2,
/// v ∈ [3, 11] km/s) with multipliers (λ_v ∈ [0.2, 1], the others of both signs), from a
/// xorshift64* generator seeded by `seed`.
pub fn sample_points(count: usize, seed: u64) -> Vec<([f64; 6], [f64; 6])> {
    let mut state = seed.max(1);
    let mut next = |lo: f64, hi: f64| {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        let u = (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    };
    (0..count)
        .map(|_| {
            let x = [
                next(6500.0, 9000.0),
                next(-1.2, 1.2),
                next(-3.0, 3.0),
                next(3.0, 11.0),
                next(-1.2, 1.2),
                next(-3.0, 3.0),
            ];
            let l = [
                next(-1e-3, 1e-3),
                next(-5.0, 5.0),
                next(-5.0, 5.0),
                next(0.2, 1.0),
                next(-5.0, 5.0),
                next(-5.0, 5.0),
            ];
            (x, l)
        })
        .collect()
}

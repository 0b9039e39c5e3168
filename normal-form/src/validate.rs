//! Checks against the outside world: Deprit's closed form for D₄, a Dormand–Prince 5(4)
//! integrator of the full Hamiltonian field, and frequencies measured along true orbits.

use crate::hamiltonian::{taylor, HamiltonianFn};
use crate::monomial::MonomialTable;
use crate::normal_form::NormalForm;
use std::sync::Arc;

/// Deprit & Deprit-Bartholomé's (1967) D₄ at L4 in its textbook form
/// `D₄(μ) = −(36 − 541w + 644w²) / (8(1 − 4w)(4 − 25w))`, `w = ω₁²ω₂² = 27μ(1−μ)/4`.
pub fn deprit_d4(mu: f64) -> f64 {
    let w = 27.0 * mu * (1.0 - mu) / 4.0;
    -(36.0 - 541.0 * w + 644.0 * w * w) / (8.0 * (1.0 - 4.0 * w) * (4.0 - 25.0 * w))
}

/// The L4 frequencies ω₁ > ω₂ > 0 in closed form (ω₁² + ω₂² = 1, ω₁²ω₂² = 27μ(1−μ)/4).
pub fn l4_frequencies(mu: f64) -> (f64, f64) {
    let w = 27.0 * mu * (1.0 - mu) / 4.0;
    let d = (1.0 - 4.0 * w).sqrt();
    (((1.0 + d) / 2.0).sqrt(), ((1.0 - d) / 2.0).sqrt())
}

/// The Hamiltonian field ż = J∇H(z) (gradient by a degree-1 jet).
pub struct Field<'a, H: ?Sized> {
    h: &'a H,
    table: Arc<MonomialTable>,
}

impl<'a, H: HamiltonianFn + ?Sized> Field<'a, H> {
    /// The field of `h`.
    pub fn new(h: &'a H) -> Self {
        Field {
            h,
            table: Arc::new(MonomialTable::new(2 * h.n_dof(), 1)),
        }
    }
    /// ż at z.
    pub fn eval(&self, z: &[f64]) -> Vec<f64> {
        let n = self.h.n_dof();
        let p = taylor(self.h, z, &self.table);
        let mut g = vec![0.0; 2 * n];
        let mut e = vec![0u8; 2 * n];
        for (i, gi) in g.iter_mut().enumerate() {
            e[i] = 1;
            *gi = p.coeff(&e);
            e[i] = 0;
        }
        let mut f = vec![0.0; 2 * n];
        for k in 0..n {
            f[k] = g[n + k];
            f[n + k] = -g[k];
        }
        f
    }
}

/// Integrates y' = f(y) from `y0` over `[0, t]` with the Dormand–Prince 5(4) pair
/// (Hairer, Nørsett & Wanner, Solving ODEs I, §II.5), local error control
/// `|err_i| ≤ atol + rtol·|y_i|`. Returns y(t) and the number of accepted steps.
pub fn dopri5(
    f: &dyn Fn(&[f64]) -> Vec<f64>,
    y0: &[f64],
    t: f64,
    rtol: f64,
    atol: f64,
) -> (Vec<f64>, usize) {
    const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
    const A: [[f64; 6]; 7] = [
        [0.0; 6],
        [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
        [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
        [
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
            0.0,
            0.0,
        ],
        [
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
            0.0,
        ],
        [
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ];
    const B: [f64; 7] = [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
        0.0,
    ];
    const E: [f64; 7] = [
        71.0 / 57600.0,
        0.0,
        -71.0 / 16695.0,
        71.0 / 1920.0,
        -17253.0 / 339200.0,
        22.0 / 525.0,
        -1.0 / 40.0,
    ];
    let _ = C;
    let n = y0.len();
    let mut y = y0.to_vec();
    let mut s = 0.0;
    let mut h = (t.abs() / 100.0).clamp(1e-6, 0.01) * t.signum();
    let mut k: Vec<Vec<f64>> = vec![f(&y); 7];
    let mut steps = 0;
    while (t - s) * t.signum() > 0.0 {
        if (s + h - t) * t.signum() > 0.0 {
            h = t - s;
        }
        let mut yi = vec![0.0; n];
        for i in 1..7 {
            for (j, yj) in yi.iter_mut().enumerate() {
                *yj = y[j] + h * (0..i).map(|l| A[i][l] * k[l][j]).sum::<f64>();
            }
            k[i] = f(&yi);
        }
        let ynew: Vec<f64> = (0..n)
            .map(|j| y[j] + h * (0..7).map(|l| B[l] * k[l][j]).sum::<f64>())
            .collect();
        let err = (0..n)
            .map(|j| {
                let e = h * (0..7).map(|l| E[l] * k[l][j]).sum::<f64>();
                let sc = atol + rtol * y[j].abs().max(ynew[j].abs());
                (e / sc).powi(2)
            })
            .sum::<f64>()
            / n as f64;
        let err = err.sqrt();
        if err <= 1.0 {
            s += h;
            y = ynew;
            k[0] = k[6].clone(); // FSAL
            steps += 1;
        }
        let fac = (0.9 * err.max(1e-10).powf(-0.2)).clamp(0.2, 5.0);
        h *= fac;
    }
    (y, steps)
}

/// Frequencies ν_k measured along the true orbit from `z0`: the orbit is integrated with
/// DOPRI5 (rtol = atol = `tol`) and sampled every `dt` up to `t_end`; each sample is mapped
/// to the normal coordinates of `reference` (only as a chart: any chart whose angles stay
/// within a bounded distance of the true angles gives the same long-time slope), the angles
/// `θ_k = atan2(P'_k, Q'_k)` are unwrapped and fitted by least squares, and ν_k = −slope
/// (the planes rotate clockwise for ν > 0).
pub fn measure_frequencies<H: HamiltonianFn + ?Sized>(
    h: &H,
    reference: &NormalForm,
    z0: &[f64],
    t_end: f64,
    dt: f64,
    tol: f64,
) -> Vec<f64> {
    let n = h.n_dof();
    let field = Field::new(h);
    let f = |z: &[f64]| field.eval(z);
    let steps = (t_end / dt).round() as usize;
    let mut z = z0.to_vec();
    let mut ts = Vec::with_capacity(steps + 1);
    let mut thetas: Vec<Vec<f64>> = vec![Vec::with_capacity(steps + 1); n];
    let mut last = vec![0.0f64; n];
    for s in 0..=steps {
        if s > 0 {
            z = dopri5(&f, &z, dt, tol, tol).0;
        }
        let w = reference
            .to_normal(&z)
            .expect("reference with transformation");
        ts.push(s as f64 * dt);
        for k in 0..n {
            let th = w[n + k].atan2(w[k]);
            let th = if s == 0 {
                th
            } else {
                let mut d = th - last[k].rem_euclid(2.0 * std::f64::consts::PI);
                while d > std::f64::consts::PI {
                    d -= 2.0 * std::f64::consts::PI;
                }
                while d < -std::f64::consts::PI {
                    d += 2.0 * std::f64::consts::PI;
                }
                last[k] + d
            };
            last[k] = th;
            thetas[k].push(th);
        }
    }
    let m = ts.len() as f64;
    let tm = ts.iter().sum::<f64>() / m;
    thetas
        .iter()
        .map(|th| {
            let thm = th.iter().sum::<f64>() / m;
            let num: f64 = ts.iter().zip(th).map(|(t, y)| (t - tm) * (y - thm)).sum();
            let den: f64 = ts.iter().map(|t| (t - tm) * (t - tm)).sum();
            -num / den
        })
        .collect()
}

//! Checks against the outside world: Deprit's closed form for D₄, true orbits of the full
//! Hamiltonian field (integrated by `lasalle_runtime`'s Dormand–Prince 5(4)), and
//! frequencies measured along them.

use crate::bound::{distance, point_at, Bound, Metric};
use crate::error::NormalFormError;
use crate::hamiltonian::{taylor, HamiltonianFn};
use crate::monomial::MonomialTable;
use crate::normal_form::NormalForm;
use lasalle_runtime::{Control, DormandPrince, Driver, Field};
use serde::Serialize;
use std::sync::Arc;

/// The Earth–Moon mass ratio μ = m₂/(m₁ + m₂) (the default of `models/cr3bp.lsl`).
pub const EARTH_MOON_MU: f64 = 0.012_150_585_609_624_04;

/// Routh's critical mass ratio μ_R = (1 − √(23/27))/2: L4 is linearly stable below it.
pub fn mu_routh() -> f64 {
    (1.0 - (23.0f64 / 27.0).sqrt()) / 2.0
}

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

/// The Hamiltonian field ż = J∇H(z) (gradient by a degree-1 jet) as a
/// `lasalle_runtime::Field` on ℝᴺ, N = 2n, so that the runtime's steppers integrate it.
pub struct HamiltonianField<'a, H: ?Sized, const N: usize> {
    h: &'a H,
    table: Arc<MonomialTable>,
}

impl<'a, H: HamiltonianFn + ?Sized, const N: usize> HamiltonianField<'a, H, N> {
    /// The field of `h`; `N` must be twice its degrees of freedom.
    pub fn new(h: &'a H) -> Result<Self, NormalFormError> {
        if 2 * h.n_dof() != N {
            return Err(NormalFormError::Invalid(format!(
                "field of dimension {N} for {} degrees of freedom",
                h.n_dof()
            )));
        }
        Ok(HamiltonianField {
            h,
            table: Arc::new(MonomialTable::new(N, 1)),
        })
    }
}

impl<H: HamiltonianFn + ?Sized, const N: usize> Field<f64, [f64; N]>
    for HamiltonianField<'_, H, N>
{
    fn field(&self, z: &[f64; N], dz: &mut [f64; N]) {
        let n = N / 2;
        let p = taylor(self.h, z, &self.table);
        let g = p.part(1).expect("degree-1 table");
        // the degree-1 monomials are x_v in variable order (descending lexicographic)
        for k in 0..n {
            dz[k] = g[n + k];
            dz[n + k] = -g[k];
        }
    }
}

fn orbit_n<H: HamiltonianFn + ?Sized, const N: usize>(
    h: &H,
    z0: &[f64],
    times: &[f64],
    tol: f64,
    on_sample: &mut dyn FnMut(f64, &[f64]) -> bool,
) -> Result<(), NormalFormError> {
    let field = HamiltonianField::<H, N>::new(h)?;
    let x0: [f64; N] = z0
        .try_into()
        .map_err(|_| NormalFormError::Invalid(format!("initial state of length {}", z0.len())))?;
    let mut stepper = DormandPrince::<f64, [f64; N]>::with_tolerances(tol, tol);
    let t_end = times.last().copied().unwrap_or(0.0);
    Driver::new(0.0, t_end, 0.0)
        .run_dense(
            &mut stepper,
            &field,
            &x0,
            times,
            &mut |_: u64, t: f64, x: &[f64; N]| {
                if on_sample(t, x) {
                    Control::Continue
                } else {
                    Control::Stop
                }
            },
        )
        .map_err(|e| NormalFormError::Invalid(format!("integration failed: {e}")))?;
    Ok(())
}

/// The true orbit of H from `z0` sampled at `times` (sorted, ≥ 0), each sample passed to
/// `on_sample(t, z)`, which returns `false` to stop: `lasalle_runtime`'s adaptive
/// Dormand–Prince 5(4) with rtol = atol = `tol` and its dense output (HNW I §II.5–6). Up to 6
/// degrees of freedom.
pub fn orbit_with<H: HamiltonianFn + ?Sized>(
    h: &H,
    z0: &[f64],
    times: &[f64],
    tol: f64,
    on_sample: &mut dyn FnMut(f64, &[f64]) -> bool,
) -> Result<(), NormalFormError> {
    macro_rules! dispatch {
        ($($n:literal),*) => {
            match 2 * h.n_dof() {
                $($n => orbit_n::<H, $n>(h, z0, times, tol, on_sample),)*
                d => Err(NormalFormError::Invalid(format!("orbits of dimension {d} (at most 12)"))),
            }
        };
    }
    dispatch!(2, 4, 6, 8, 10, 12)
}

/// The true orbit of H from `z0` sampled at `times` ([`orbit_with`]).
pub fn orbit<H: HamiltonianFn + ?Sized>(
    h: &H,
    z0: &[f64],
    times: &[f64],
    tol: f64,
) -> Result<Vec<Vec<f64>>, NormalFormError> {
    let mut out = Vec::with_capacity(times.len());
    orbit_with(h, z0, times, tol, &mut |_, z| {
        out.push(z.to_vec());
        true
    })?;
    Ok(out)
}

/// One orbit of [`tube_orbits`]; the per-chart fields have one entry per normal form given.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TubeOrbit {
    /// The initial point (model coordinates).
    pub start: Vec<f64>,
    /// The initial actions' share of each mode (sums to 1).
    pub split: Vec<f64>,
    /// First sample time with distance > d₁, if any.
    pub exit_time: Option<f64>,
    /// The time integrated to (the end, or the exit).
    pub t_end: f64,
    /// ρ = |z'| at t = 0, per chart.
    pub rho_start: Vec<f64>,
    /// max over the samples of ρ, per chart.
    pub rho_max: Vec<f64>,
    /// max over the samples of |Σ I_k(t) − Σ I_k(0)| = |ρ(t)² − ρ(0)²|/2, per chart.
    pub action_drift: Vec<f64>,
    /// max over the samples of T⁺(ρ(0), ρ_e(t)) / t, T⁺ the upper quadrature sum (64
    /// intervals) of the chart's bound and ρ_e(t) the largest ρ so far with the integration
    /// noise taken off (`ρ_e² = ρ(0)² + 2 max(0, (ρ_max² − ρ(0)²)/2 − noise(t))`): the bound
    /// holds along the orbit, as far as the integration resolves, iff this is ≤ 1.
    pub worst_ratio: Vec<f64>,
    /// The integration noise on Σ I_k up to the end: max_{s≤t} of |W_f(s) − W_c(s)| with
    /// `W = |A⁻¹(z − z_eq)|²/2` (Σ I_k in the linear normal coordinates) along this orbit
    /// (rtol = atol = `tol`) and along a second one at [`COARSE_FACTOR`]·`tol`: DOPRI5's error
    /// grows with the tolerance, so this overestimates the error of the first orbit.
    pub noise: f64,
}

/// The tolerance of the comparison orbit of [`TubeOrbit::noise`], relative to `tol`.
pub const COARSE_FACTOR: f64 = 10.0;

/// Unit directions of initial points in the linear normal coordinates (Q, P): every action
/// split `s` on the simplex grid of step `1/splits` (s_k ≥ 0, Σ s_k = 1) and every phase
/// combination on a grid of `phases` angles per mode: `Q_k = √s_k cos φ_k`,
/// `P_k = √s_k sin φ_k`. Modes with s_k = 0 get one phase only.
pub fn split_phase_directions(n: usize, splits: usize, phases: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    fn simplex(n: usize, left: usize, cur: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if cur.len() + 1 == n {
            cur.push(left);
            out.push(cur.clone());
            cur.pop();
            return;
        }
        for k in 0..=left {
            cur.push(k);
            simplex(n, left - k, cur, out);
            cur.pop();
        }
    }
    let splits = splits.max(1);
    let mut grid = Vec::new();
    simplex(n, splits, &mut Vec::new(), &mut grid);
    let mut out = Vec::new();
    for g in grid {
        let s: Vec<f64> = g.iter().map(|&k| k as f64 / splits as f64).collect();
        let counts: Vec<usize> = s
            .iter()
            .map(|&x| if x > 0.0 { phases.max(1) } else { 1 })
            .collect();
        let total: usize = counts.iter().product();
        for mut idx in 0..total {
            let mut w = vec![0.0; 2 * n];
            for k in 0..n {
                let j = idx % counts[k];
                idx /= counts[k];
                let phi = 2.0 * std::f64::consts::PI * j as f64 / counts[k] as f64;
                w[k] = s[k].sqrt() * phi.cos();
                w[n + k] = s[k].sqrt() * phi.sin();
            }
            out.push((w, s.clone()));
        }
    }
    out
}

/// How [`tube_orbits`] integrates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TubeRun {
    /// Initial distance d₀ and the outer tube d₁ (in `metric`).
    pub d0: f64,
    /// The outer tube.
    pub d1: f64,
    /// How distances are measured.
    pub metric: Metric,
    /// Integrate to this time (or the exit).
    pub t_end: f64,
    /// Sample every dt (exits are detected at the samples).
    pub dt: f64,
    /// DOPRI5 rtol = atol.
    pub tol: f64,
    /// Action splits: the simplex grid step is 1/splits.
    pub splits: usize,
    /// Phases per mode.
    pub phases: usize,
}

/// Integrates H from points at distance `d0` (in `metric`) from the equilibrium, in the
/// directions of [`split_phase_directions`] (mapped by A and normalised for
/// [`Metric::Euclidean`]), sampled every `dt` up to `t_end` with DOPRI5; an orbit stops at its
/// first sample beyond distance `d1`. Along each orbit ρ(t) = |z'(t)| is measured in the
/// normal coordinates of every chart (normal forms of the same equilibrium, with their
/// transformations, e.g. of several orders) and compared with the chart's bound.
pub fn tube_orbits<H: HamiltonianFn + ?Sized>(
    h: &H,
    charts: &[(&NormalForm, &Bound)],
    run: &TubeRun,
) -> Result<Vec<TubeOrbit>, NormalFormError> {
    let Some(&(first, _)) = charts.first() else {
        return Ok(Vec::new());
    };
    let rho_of = |nf: &NormalForm, z: &[f64]| -> Result<f64, NormalFormError> {
        let w = nf.to_normal(z).ok_or_else(|| {
            NormalFormError::Invalid("the normal form has no transformation".into())
        })?;
        Ok(w.iter().map(|x| x * x).sum::<f64>().sqrt())
    };
    let steps = (run.t_end / run.dt).ceil() as usize;
    let times: Vec<f64> = (0..=steps)
        .map(|s| (s as f64 * run.dt).min(run.t_end))
        .collect();
    let mut out = Vec::new();
    for (w, split) in split_phase_directions(first.n_dof, run.splits, run.phases) {
        let u: Vec<f64> = match run.metric {
            Metric::LinearNormal => w,
            Metric::Euclidean => {
                let v: Vec<f64> = first
                    .linear_map
                    .iter()
                    .map(|row| row.iter().zip(&w).map(|(a, b)| a * b).sum())
                    .collect();
                let r = v.iter().map(|x| x * x).sum::<f64>().sqrt();
                v.iter().map(|x| x / r).collect()
            }
        };
        let z0 = point_at(first, &u, run.d0, run.metric);
        let rho_start = charts
            .iter()
            .map(|(nf, _)| rho_of(nf, &z0))
            .collect::<Result<Vec<_>, _>>()?;
        let mut orbit = TubeOrbit {
            start: z0.clone(),
            split,
            exit_time: None,
            t_end: 0.0,
            rho_max: rho_start.clone(),
            rho_start,
            action_drift: vec![0.0; charts.len()],
            worst_ratio: vec![0.0; charts.len()],
            noise: 0.0,
        };
        let linear_actions =
            |z: &[f64]| 0.5 * first.to_linear_normal(z).iter().map(|x| x * x).sum::<f64>();
        let mut coarse = Vec::with_capacity(times.len());
        orbit_with(h, &z0, &times, COARSE_FACTOR * run.tol, &mut |_, z| {
            coarse.push(linear_actions(z));
            true
        })?;
        let mut sample = 0;
        let mut failure = None;
        orbit_with(h, &z0, &times, run.tol, &mut |t, z| {
            orbit.t_end = t;
            // the coarse orbit may have stopped earlier (integration failure): then the noise
            // stays at its last value
            if let Some(&c) = coarse.get(sample) {
                orbit.noise = orbit.noise.max((linear_actions(z) - c).abs());
            }
            sample += 1;
            for (c, (nf, bound)) in charts.iter().enumerate() {
                let rho = match rho_of(nf, z) {
                    Ok(r) => r,
                    Err(e) => {
                        failure = Some(e);
                        return false;
                    }
                };
                let r0 = orbit.rho_start[c];
                orbit.action_drift[c] =
                    orbit.action_drift[c].max(0.5 * (rho * rho - r0 * r0).abs());
                orbit.rho_max[c] = orbit.rho_max[c].max(rho);
                let excess = 0.5 * (orbit.rho_max[c].powi(2) - r0 * r0) - orbit.noise;
                if t > 0.0 && excess > 0.0 {
                    let rho_e = (r0 * r0 + 2.0 * excess).sqrt();
                    let needed = bound.time_with(r0, rho_e, 64).upper;
                    orbit.worst_ratio[c] = orbit.worst_ratio[c].max(needed / t);
                }
            }
            if distance(first, z, run.metric) > run.d1 {
                orbit.exit_time = Some(t);
                return false;
            }
            true
        })?;
        if let Some(e) = failure {
            return Err(e);
        }
        out.push(orbit);
    }
    Ok(out)
}

/// Frequencies ν_k measured along the true orbit from `z0`: the orbit is integrated with
/// DOPRI5 ([`orbit`], rtol = atol = `tol`) and sampled every `dt` up to `t_end`; each sample is mapped
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
) -> Result<Vec<f64>, NormalFormError> {
    let n = h.n_dof();
    let steps = (t_end / dt).round() as usize;
    let ts: Vec<f64> = (0..=steps).map(|s| s as f64 * dt).collect();
    let zs = orbit(h, z0, &ts, tol)?;
    let mut thetas: Vec<Vec<f64>> = vec![Vec::with_capacity(steps + 1); n];
    let mut last = vec![0.0f64; n];
    for (s, z) in zs.iter().enumerate() {
        let w = reference.to_normal(z).ok_or_else(|| {
            NormalFormError::Invalid("the reference normal form has no transformation".into())
        })?;
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
    Ok(thetas
        .iter()
        .map(|th| {
            let thm = th.iter().sum::<f64>() / m;
            let num: f64 = ts.iter().zip(th).map(|(t, y)| (t - tm) * (y - thm)).sum();
            let den: f64 = ts.iter().map(|t| (t - tm) * (t - tm)).sum();
            -num / den
        })
        .collect())
}

//! Checks against the outside world: Deprit's closed form for D₄, true orbits of the full
//! Hamiltonian field (integrated by `lasalle_runtime`'s Dormand–Prince 5(4)), and
//! frequencies measured along them.

use crate::error::NormalFormError;
use crate::hamiltonian::{taylor, HamiltonianFn};
use crate::monomial::MonomialTable;
use crate::normal_form::NormalForm;
use lasalle_runtime::{Control, DormandPrince, Driver, Field};
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
) -> Result<Vec<Vec<f64>>, NormalFormError> {
    let field = HamiltonianField::<H, N>::new(h)?;
    let x0: [f64; N] = z0
        .try_into()
        .map_err(|_| NormalFormError::Invalid(format!("initial state of length {}", z0.len())))?;
    let mut stepper = DormandPrince::<f64, [f64; N]>::with_tolerances(tol, tol);
    let mut out = Vec::with_capacity(times.len());
    let t_end = times.last().copied().unwrap_or(0.0);
    Driver::new(0.0, t_end, 0.0)
        .run_dense(
            &mut stepper,
            &field,
            &x0,
            times,
            &mut |_: u64, _: f64, x: &[f64; N]| {
                out.push(x.to_vec());
                Control::Continue
            },
        )
        .map_err(|e| NormalFormError::Invalid(format!("integration failed: {e}")))?;
    Ok(out)
}

/// The true orbit of H from `z0` sampled at `times` (sorted, ≥ 0): `lasalle_runtime`'s
/// adaptive Dormand–Prince 5(4) with rtol = atol = `tol` and its dense output (HNW I §II.5–6).
/// Up to 6 degrees of freedom.
pub fn orbit<H: HamiltonianFn + ?Sized>(
    h: &H,
    z0: &[f64],
    times: &[f64],
    tol: f64,
) -> Result<Vec<Vec<f64>>, NormalFormError> {
    macro_rules! dispatch {
        ($($n:literal),*) => {
            match 2 * h.n_dof() {
                $($n => orbit_n::<H, $n>(h, z0, times, tol),)*
                d => Err(NormalFormError::Invalid(format!("orbits of dimension {d} (at most 12)"))),
            }
        };
    }
    dispatch!(2, 4, 6, 8, 10, 12)
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

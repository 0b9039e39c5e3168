//! Planar Lyapunov orbits of the full spatial three-body model by differential correction,
//! and their vertical stability: the halo bifurcation of the full problem, computed without
//! the normal form, to check the reduced flow's ([`poincare::halo_bifurcation`]).
//!
//! The planar Lyapunov orbits about L1/L2 are symmetric about the x axis: they start at
//! `(x₀, 0, 0)` with velocity `(0, v_y, 0)` and cross `y = 0` again after half a period with
//! `v_x = 0`. For a given `x₀`, `v_y` is corrected by the secant method on `v_x` at that
//! crossing; the crossing is located on one integration (`lasalle_runtime`'s Dormand–Prince
//! 5(4) with dense output, sampled every 10⁻³) by cubic Hermite interpolation between the two
//! samples around it. The vertical pair (z, p_z) decouples to first order from a planar orbit;
//! its 2 × 2 monodromy block is taken by central differences of the full flow over one
//! period. The halo family branches off where its trace reaches 2 (a multiplier pair at +1).
//!
//! [`poincare::halo_bifurcation`]: super::poincare::halo_bifurcation

use crate::error::NormalFormError;
use crate::hamiltonian::HamiltonianFn;
use crate::validate::{orbit, orbit_with, HamiltonianField};
use lasalle_runtime::Field;
use serde::Serialize;

/// A planar Lyapunov orbit of the full model.
#[derive(Clone, Debug, Serialize)]
pub struct FullLyapunov {
    /// x₀ − x_L: the displacement of the start on the axis.
    pub dx: f64,
    /// v_y at the start.
    pub vy: f64,
    /// The period.
    pub period: f64,
    /// H − E₀ (E₀ = H at the equilibrium).
    pub energy: f64,
    /// v_x at the half-period crossing after the correction (the residual).
    pub residual: f64,
    /// The trace of the vertical monodromy block (2 at the halo bifurcation).
    pub vertical_trace: f64,
}

/// The model state z = (x, y, z, p_x, p_y, p_z) of position (x, 0, 0) and velocity
/// (0, v_y, 0) in the rotating frame (p = v + ẑ × q).
fn start(x: f64, vy: f64) -> [f64; 6] {
    [x, 0.0, 0.0, 0.0, vy + x, 0.0]
}

/// The first crossing of y = 0 after t = 0.05: (time, state), by Hermite interpolation.
fn half_crossing<H: HamiltonianFn + ?Sized>(
    h: &H,
    z0: &[f64; 6],
    tol: f64,
) -> Result<(f64, [f64; 6]), NormalFormError> {
    let field = HamiltonianField::<H, 6>::new(h)?;
    let step = 1e-3;
    let times: Vec<f64> = (0..=10_000).map(|k| k as f64 * step).collect();
    let mut prev: Option<(f64, [f64; 6])> = None;
    let mut found = None;
    orbit_with(h, z0, &times, tol, &mut |t, z| {
        let z: [f64; 6] = z.try_into().expect("6 components");
        if t > 0.05 {
            if let Some((t0, z_prev)) = prev {
                if z_prev[1].signum() != z[1].signum() || z[1] == 0.0 {
                    found = Some((t0, z_prev, t, z));
                    return false;
                }
            }
        }
        prev = Some((t, z));
        true
    })?;
    let (t0, a, t1, b) = found.ok_or_else(|| {
        NormalFormError::Invalid("the orbit does not return to y = 0 within t = 10".into())
    })?;
    let (mut da, mut db) = ([0.0; 6], [0.0; 6]);
    field.field(&a, &mut da);
    field.field(&b, &mut db);
    let dt = t1 - t0;
    // cubic Hermite on [t0, t1] in s ∈ [0, 1]
    let hermite = |k: usize, s: f64| {
        let (h00, h10, h01, h11) = (
            2.0 * s * s * s - 3.0 * s * s + 1.0,
            s * s * s - 2.0 * s * s + s,
            -2.0 * s * s * s + 3.0 * s * s,
            s * s * s - s * s,
        );
        h00 * a[k] + h10 * dt * da[k] + h01 * b[k] + h11 * dt * db[k]
    };
    let dhermite = |k: usize, s: f64| {
        let (d00, d10, d01, d11) = (
            6.0 * s * s - 6.0 * s,
            3.0 * s * s - 4.0 * s + 1.0,
            -6.0 * s * s + 6.0 * s,
            3.0 * s * s - 2.0 * s,
        );
        (d00 * a[k] + d01 * b[k]) / dt + d10 * da[k] + d11 * db[k]
    };
    let mut s = a[1] / (a[1] - b[1]);
    for _ in 0..20 {
        let d = dhermite(1, s) * dt;
        if d == 0.0 {
            break;
        }
        let ds = hermite(1, s) / d;
        s -= ds;
        if ds.abs() < 1e-16 {
            break;
        }
    }
    let z: [f64; 6] = std::array::from_fn(|k| hermite(k, s));
    Ok((t0 + s * dt, z))
}

/// The planar Lyapunov orbit through (x_L + dx, 0, 0) of the spatial model `h` about the
/// collinear point `eq` (its state, 6 components), from the guess `vy` of v_y (the secant
/// method on v_x at the half-period crossing, to |v_x| < 10⁻¹³), with its vertical monodromy
/// trace; integration tolerance `tol`.
pub fn planar_lyapunov<H: HamiltonianFn + ?Sized>(
    h: &H,
    eq: &[f64],
    dx: f64,
    vy: f64,
    tol: f64,
) -> Result<FullLyapunov, NormalFormError> {
    if h.n_dof() != 3 || eq.len() != 6 {
        return Err(NormalFormError::Invalid(
            "planar Lyapunov orbits are computed for the spatial three-body model (3 degrees of freedom)".into(),
        ));
    }
    let x = eq[0] + dx;
    let vx_at = |vy: f64| -> Result<(f64, f64), NormalFormError> {
        let (t, z) = half_crossing(h, &start(x, vy), tol)?;
        Ok((z[3] + z[1], t))
    };
    let (mut v0, mut v1) = (vy, vy * (1.0 + 1e-6));
    let (mut f0, _) = vx_at(v0)?;
    let mut half = 0.0;
    let mut residual = f64::INFINITY;
    for _ in 0..40 {
        let (f1, t) = vx_at(v1)?;
        half = t;
        residual = f1;
        if f1.abs() < 1e-13 || f1 == f0 {
            break;
        }
        let v2 = v1 - f1 * (v1 - v0) / (f1 - f0);
        (v0, f0, v1) = (v1, f1, v2);
    }
    if residual.abs() > 1e-10 {
        return Err(NormalFormError::Invalid(format!(
            "the differential correction did not converge at dx = {dx} (|v_x| = {residual:e})"
        )));
    }
    let vy = v1;
    let z0 = start(x, vy);
    let period = 2.0 * half;
    let eps = 1e-6;
    let column = |k: usize| -> Result<[f64; 2], NormalFormError> {
        let (mut a, mut b) = (z0, z0);
        a[k] += eps;
        b[k] -= eps;
        let fa = orbit(h, &a, &[0.0, period], tol)?;
        let fb = orbit(h, &b, &[0.0, period], tol)?;
        Ok([
            (fa[1][2] - fb[1][2]) / (2.0 * eps),
            (fa[1][5] - fb[1][5]) / (2.0 * eps),
        ])
    };
    let cz = column(2)?;
    let cp = column(5)?;
    Ok(FullLyapunov {
        dx,
        vy,
        period,
        energy: h.eval(&z0) - h.eval(eq),
        residual,
        vertical_trace: cz[0] + cp[1],
    })
}

/// The halo bifurcation of the full model: continues the planar Lyapunov family from
/// |dx| = `step` in steps of `step` (dx of the sign of `toward`, ±1) until the vertical trace passes 2, then the secant method on the trace to
/// |trace − 2| < 10⁻⁹. The guess of v_y at the first member is the linear one,
/// `v_y = −dx (ω_p² + 1 + 2c₂)/2` with c₂ = ω_v². Returns the orbit at the bifurcation.
pub fn full_halo_bifurcation<H: HamiltonianFn + ?Sized>(
    h: &H,
    eq: &[f64],
    omega_p: f64,
    omega_v: f64,
    step: f64,
    toward: f64,
    tol: f64,
) -> Result<FullLyapunov, NormalFormError> {
    let c2 = omega_v * omega_v;
    let mut dx = toward * step;
    let mut orbit = planar_lyapunov(
        h,
        eq,
        dx,
        -dx * (omega_p * omega_p + 1.0 + 2.0 * c2) / 2.0,
        tol,
    )?;
    let mut prev: Option<FullLyapunov> = None;
    for _ in 0..200 {
        if orbit.vertical_trace >= 2.0 {
            break;
        }
        let next_dx = dx + toward * step;
        let guess = orbit.vy * next_dx / dx;
        prev = Some(orbit);
        dx = next_dx;
        orbit = planar_lyapunov(h, eq, dx, guess, tol)?;
    }
    let mut a = prev.ok_or_else(|| {
        NormalFormError::Invalid("the vertical trace is above 2 at the first member".into())
    })?;
    let mut b = orbit;
    if b.vertical_trace < 2.0 {
        return Err(NormalFormError::Invalid(
            "no halo bifurcation along the continued planar family".into(),
        ));
    }
    for _ in 0..30 {
        if (b.vertical_trace - 2.0).abs() < 1e-9 {
            break;
        }
        let (fa, fb) = (a.vertical_trace - 2.0, b.vertical_trace - 2.0);
        let dx = b.dx - fb * (b.dx - a.dx) / (fb - fa);
        let guess = b.vy + (a.vy - b.vy) * (dx - b.dx) / (a.dx - b.dx);
        let c = planar_lyapunov(h, eq, dx, guess, tol)?;
        (a, b) = (b, c);
    }
    Ok(b)
}

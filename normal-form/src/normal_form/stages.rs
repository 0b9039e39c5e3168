//! The stages of one run in a fixed precision: equilibrium → Taylor expansion → linear
//! normalisation → resonance check → Lie normalisation → real forms and remainder.

use super::assemble::Raw;
use super::expansion::{
    integer_vectors, minus_i_pow, pair_blocks, real_part, to_complex_coordinates, widen,
};
use super::options::{Options, Point, Precision, Progress, Stage};
use super::result::{DegreeError, Remainder, RemainderPart, ResonantTerm, SmallDivisor, Timings};
use crate::complex::Complex;
use crate::error::NormalFormError;
use crate::hamiltonian::{find_equilibrium, gradient_hessian, taylor, HamiltonianFn};
use crate::lie;
use crate::linalg::Mat;
use crate::linear::{complexification, linear_normalization, symplectic_inverse};
use crate::monomial::MonomialTable;
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use crate::Dd;
use std::sync::Arc;
use std::time::Instant;

pub(super) fn run<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
) -> Result<Raw<R>, NormalFormError> {
    let t_start = Instant::now();
    let precision = if R::NAME == "f64" {
        Precision::F64
    } else {
        Precision::DoubleDouble
    };
    Progress::report(&o.progress, Stage::Start(precision));
    let n = h.n_dof();
    let d = 2 * n;
    let nmax = o.order;
    let top = o.remainder_degree.unwrap_or(nmax).max(nmax);
    let (start, given) = match point {
        Point::Given(v) => (v, true),
        Point::Newton(v) => (v, false),
    };
    if start.len() != d {
        return Err(NormalFormError::Invalid(format!(
            "point has {} components, expected {d}",
            start.len()
        )));
    }
    let start: Vec<R> = start.iter().map(|&x| R::from_f64(x)).collect();
    let eq = find_equilibrium(h, &start, o.max_newton)?;
    if given && eq.initial_gradient > o.equilibrium_tol {
        return Err(NormalFormError::NotAnEquilibrium {
            gradient_norm: eq.initial_gradient,
        });
    }
    let table = Arc::new(MonomialTable::new(d, top));
    let hz = taylor(h, &eq.z, &table);
    if !hz.is_finite() {
        return Err(NormalFormError::NonFinite("the Taylor expansion"));
    }
    let energy = hz.constant_term();
    let mut timings = Timings {
        taylor: t_start.elapsed().as_secs_f64(),
        ..Timings::default()
    };

    // linear normalisation
    let t = Instant::now();
    // in double-double whatever the working precision: a 2n×2n problem, and f64 frequencies
    // and A come out correctly rounded (the small divisors amplify every error in ω)
    let (_, s) = gradient_hessian(&hz);
    let s_dd: Mat<Dd> = s
        .iter()
        .map(|row| row.iter().map(|&x| widen(x)).collect())
        .collect();
    let lin_dd = linear_normalization(&s_dd, &o.basis_rotation)?;
    let lin = lin_dd.rounded(&s);
    let ainv = symplectic_inverse(&lin.a);
    let (_, ci) = complexification::<R>(n);
    let compensate_to = if R::NAME == "f64" {
        o.compensated_degree.min(nmax)
    } else {
        0
    };
    let mut hc = to_complex_coordinates(&hz, &lin.a, compensate_to);
    let lambda: Vec<Complex<R>> = lin
        .omega
        .iter()
        .zip(&lin.sigma)
        .map(|(&w, &sg)| Complex::new(R::zero(), w.scale(sg as f64)))
        .collect();
    let mut quadratic_residual: f64 = 0.0;
    let mut h2 = vec![Complex::zero(); table.count(2)];
    for k in 0..n {
        let mut e = vec![0u8; d];
        e[k] = 1;
        e[n + k] = 1;
        let (_, i) = table.index(&e).expect("x_k y_k");
        h2[i] = lambda[k];
    }
    if let Some(p) = hc.part(2) {
        for (x, y) in p.iter().zip(&h2) {
            quadratic_residual = quadratic_residual.max((*x - *y).magnitude());
        }
    }
    hc.set_part(2, h2);
    hc.set_part(1, Vec::new());
    timings.linear = t.elapsed().as_secs_f64();

    // Assumption 1′
    check_nonresonant(n, nmax, &lin.omega, o)?;
    let mdot = |m: &[i32]| m_dot_omega(m, &lin.omega);
    let tol = o.resonance_tol;
    let resonant_mode = o.resonant;
    let is_res = |m: &[i32]| resonant_mode && mdot(m).abs().to_f64() < tol;

    // Lie normalisation
    let t = Instant::now();
    let out = lie::normalize(
        hc,
        nmax,
        &lin_dd.omega,
        &lin.sigma,
        &is_res,
        compensate_to,
        &|degree| {
            Progress::report(
                &o.progress,
                Stage::Degree {
                    degree,
                    order: nmax,
                    precision,
                },
            )
        },
    );
    Progress::report(&o.progress, Stage::Transform);
    timings.lie = t.elapsed().as_secs_f64();

    // H̄ in actions: x_k y_k = −i I_k
    let mut hbar: Vec<(Vec<u32>, R)> = Vec::new();
    let mut hbar_imag: f64 = 0.0;
    let mut resonant_terms = Vec::new();
    let mut degrees = Vec::new();
    for k in (2..=nmax).step_by(2) {
        let mut dn = DegreeError {
            degree: k,
            max_coeff: 0.0,
            max_imag: 0.0,
            max_error: None,
            max_relative_error: None,
        };
        for i in 0..table.count(k) {
            let e = table.exponents(k, i);
            if e[..n] == e[n..] {
                let z = out.z.part(k).map_or(Complex::zero(), |p| p[i]);
                let v = z * minus_i_pow::<R>(k / 2);
                dn.max_imag = dn.max_imag.max(v.im.abs().to_f64());
                dn.max_coeff = dn.max_coeff.max(v.re.abs().to_f64());
                hbar.push((e[..n].iter().map(|&x| x as u32).collect(), v.re));
            }
        }
        hbar_imag = hbar_imag.max(dn.max_imag);
        degrees.push(dn);
    }
    let mut remainder = o.remainder_degree.map(|_| Remainder {
        degree: top,
        parts: Vec::new(),
    });
    for (k, i, zc) in out.z.terms() {
        let e = table.exponents(k, i);
        if k < 3 || e[..n] == e[n..] {
            continue;
        }
        if let Some(rem) = remainder.as_mut() {
            let c = zc.magnitude();
            if c != 0.0 {
                let split = |s: &[u8]| s.iter().map(|&x| x as i64).sum::<i64>();
                let radial = (split(&e[..n]) - split(&e[n..])).unsigned_abs() as f64 * c;
                match rem.parts.last_mut() {
                    Some(p) if p.degree == k => {
                        p.terms += 1;
                        p.sum_abs += c;
                        p.radial += radial;
                    }
                    _ => rem.parts.push(RemainderPart {
                        degree: k,
                        terms: 1,
                        sum_abs: c,
                        radial,
                    }),
                }
            }
        }
        if k <= nmax {
            let (re, im) = zc.to_f64();
            resonant_terms.push(ResonantTerm {
                x: e[..n].iter().map(|&x| x as u32).collect(),
                y: e[n..].iter().map(|&x| x as u32).collect(),
                re,
                im,
            });
        }
    }
    let divisors = out
        .divisors
        .iter()
        .map(|dv| SmallDivisor {
            m: dv.m.clone(),
            m_dot_omega: dv.value.to_f64(),
            order: dv.order,
            resonant: resonant_mode && dv.value.abs().to_f64() < tol,
        })
        .collect();

    // D4 (meaningless when resonant terms were kept: H̄ is then not a function of I alone)
    let d4 = twist_coefficients(
        n,
        nmax,
        resonant_terms.is_empty(),
        &hbar,
        &lin.omega,
        &lin.sigma,
    );

    // generating function in real form: G(u) with u = C⁻¹ w
    let t = Instant::now();
    let mut gsum = Poly::zero(table.clone());
    for (r, g) in out.generators.iter().enumerate() {
        if !g.is_empty() {
            gsum.set_part(r, g.clone());
        }
    }
    let (greal, generating_imag) = real_part(&gsum.substitute_pairs(&pair_blocks(&ci)));
    let greal_parts: Vec<Vec<R>> = (0..=nmax)
        .map(|r| greal.part(r).map_or(Vec::new(), |p| p.to_vec()))
        .collect();
    let mut generating = Vec::new();
    for r in 3..=nmax {
        for i in 0..table.count(r) {
            let v = greal.part(r).map_or(R::zero(), |p| p[i]);
            generating.push((
                table.exponents(r, i).iter().map(|&x| x as u32).collect(),
                r,
                v,
            ));
        }
    }

    // transformations
    let (mut to_normal, mut from_normal, transform_imag) = (None, None, 0.0f64);
    if o.transform && nmax >= 2 {
        let cap = top - 1;
        let fwd = lie::coordinate_maps(&table, &greal_parts, cap, true);
        let inv = lie::coordinate_maps(&table, &greal_parts, cap, false);
        // the generators in real form generate the same maps in (Q, P), since the
        // complexification is symplectic: the coordinate maps are real Lie series
        let from = fwd;
        let to = inv;
        to_normal = Some(to);
        from_normal = Some(from);
    }
    timings.transform = t.elapsed().as_secs_f64();
    timings.total = t_start.elapsed().as_secs_f64();
    Ok(Raw {
        eq,
        energy,
        omega: lin.omega.clone(),
        sigma: lin.sigma.clone(),
        a: lin.a.clone(),
        ainv,
        symplectic_residual: lin.symplectic_residual,
        diagonal_residual: lin.diagonal_residual,
        quadratic_residual,
        hbar,
        hbar_imag,
        degrees,
        resonant_terms,
        generating,
        generating_imag,
        divisors,
        d4,
        remainder,
        to_normal,
        from_normal,
        transform_imag,
        timings,
        table_bytes: table.memory_bytes(),
    })
}

/// The Arnold–Moser twist coefficients `[A, B, C, D₄]` from H̄₄ (two degrees of freedom,
/// order ≥ 4, no resonant terms kept), see [`super::ArnoldMoser`].
fn twist_coefficients<R: Real>(
    n: usize,
    nmax: usize,
    no_resonant_terms: bool,
    hbar: &[(Vec<u32>, R)],
    omega: &[R],
    sigma: &[i8],
) -> Option<[R; 4]> {
    if n == 2 && nmax >= 4 && no_resonant_terms {
        let get = |a: [u32; 2]| {
            hbar.iter()
                .find(|(e, _)| e[..] == a)
                .map_or(R::zero(), |(_, v)| *v)
        };
        let (a, b, cc) = (get([2, 0]).scale(2.0), get([1, 1]), get([0, 2]).scale(2.0));
        let nu1 = omega[0].scale(sigma[0] as f64);
        let nu2 = omega[1].scale(sigma[1] as f64);
        let d4 = a * nu2 * nu2 - (b * nu1 * nu2).scale(2.0) + cc * nu1 * nu1;
        Some([a, b, cc, d4])
    } else {
        None
    }
}

/// m·ω in the working precision.
fn m_dot_omega<R: Real>(m: &[i32], omega: &[R]) -> R {
    m.iter()
        .zip(omega)
        .fold(R::zero(), |s, (&a, &w)| s + w.scale(a as f64))
}

/// Assumption 1′: fails with [`NormalFormError::Resonance`] on the first m with
/// |m·ω| < `resonance_tol` that matters up to order N (unless `resonant`).
fn check_nonresonant<R: Real>(
    n: usize,
    nmax: usize,
    omega: &[R],
    o: &Options,
) -> Result<(), NormalFormError> {
    let omega_f: Vec<f64> = omega.iter().map(|w| w.to_f64()).collect();
    let mdot = |m: &[i32]| m_dot_omega(m, omega);
    if !o.resonant {
        for m in integer_vectors(n, nmax) {
            let v = mdot(&m);
            // a monomial x^a y^b with a − b = m has degree ≥ |m|₁ of the same parity, and the
            // Lie normalisation starts at degree 3: m first matters at this degree
            let norm1: usize = m.iter().map(|x| x.unsigned_abs() as usize).sum();
            let order = if norm1 < 3 { norm1 + 2 } else { norm1 };
            if order <= nmax && v.abs().to_f64() < o.resonance_tol {
                return Err(NormalFormError::Resonance {
                    m,
                    m_dot_omega: v.to_f64(),
                    order,
                    omega: omega_f,
                });
            }
        }
    }
    Ok(())
}

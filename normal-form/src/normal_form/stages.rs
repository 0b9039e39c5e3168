//! The stages of one run in a fixed precision, each a function of the previous one's output:
//! equilibrium and Taylor expansion ([`expand`]) → linear normalisation ([`normalize_linear`])
//! → resonance check ([`check_nonresonant`]) → Lie normalisation (`lie::normalize`) → H̄ in the
//! actions ([`in_actions`]), the resonant terms and the remainder ([`off_action_terms`]), the
//! twist coefficients ([`twist_coefficients`]) → the generating function in real form
//! ([`generating_function`]) and the coordinate maps (`lie::coordinate_maps`).

use super::assemble::Raw;
use super::expansion::{
    integer_vectors, minus_i_pow, pair_blocks, real_part, to_complex_coordinates,
};
use super::options::{Options, Point, Precision, Progress, Stage};
use super::result::{DegreeError, Remainder, RemainderPart, ResonantTerm, SmallDivisor, Timings};
use crate::complex::Complex;
use crate::error::NormalFormError;
use crate::hamiltonian::{
    find_equilibrium, gradient_hessian, null_directions, taylor, Equilibrium, HamiltonianFn,
};
use crate::lie;
use crate::linalg::Mat;
use crate::linear::{
    complexification, linear_normalization, symplectic_inverse, LinearNormalization,
};
use crate::monomial::MonomialTable;
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use std::sync::Arc;
use std::time::Instant;

pub(super) fn run<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
) -> Result<Raw<R>, NormalFormError> {
    let nmax = o.order;
    let top = o.remainder_degree.unwrap_or(nmax).max(nmax);
    let mut p = prepare::<R, H>(h, point, o, nmax, top)?;
    check_nonresonant(h.n_dof(), nmax, &p.linear.lin.omega, o)?;
    let t = Instant::now();
    let precision = p.precision;
    let tol = o.resonance_tol;
    let omega = p.linear.lin.omega.clone();
    let is_res = |m: &[i32]| o.resonant && m_dot_omega(m, &omega).abs().to_f64() < tol;
    let out = lie::normalize(
        p.linear.hc.clone(),
        nmax,
        &p.linear.omega_w,
        &p.linear.lin.sigma,
        &is_res,
        p.compensate_to,
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
    p.timings.lie = t.elapsed().as_secs_f64();
    let (_, greal_parts, _) = real_generators(&out.generators, &p, nmax);
    let maps = coordinate_maps_of(&p.table, &greal_parts, o, nmax, top);
    Ok(finish(&p, &out, o, nmax, top, maps))
}

/// What every order of one run shares: the expansion, the linear normalisation and the
/// timings of both.
struct Prepared<R: Real> {
    eq: Equilibrium<R>,
    energy: R,
    table: Arc<MonomialTable>,
    linear: Linear<R>,
    compensate_to: usize,
    precision: Precision,
    timings: Timings,
    started: Instant,
}

/// Stages 1–2 with the table to degree `top` (brackets compensated to degree
/// min(`compensated_degree`, `nmax`) in f64).
fn prepare<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
    nmax: usize,
    top: usize,
) -> Result<Prepared<R>, NormalFormError> {
    let started = Instant::now();
    let precision = Precision::of::<R>();
    Progress::report(&o.progress, Stage::Start(precision));
    let Expansion { eq, hz, table } = expand::<R, H>(h, point, o, top)?;
    let energy = hz.constant_term();
    let mut timings = Timings {
        taylor: started.elapsed().as_secs_f64(),
        ..Timings::default()
    };
    let t = Instant::now();
    let compensate_to = if R::NAME == "f64" {
        o.compensated_degree.min(nmax)
    } else {
        0
    };
    let linear = normalize_linear(&hz, &table, o, compensate_to)?;
    timings.linear = t.elapsed().as_secs_f64();
    Ok(Prepared {
        eq,
        energy,
        table,
        linear,
        compensate_to,
        precision,
        timings,
        started,
    })
}

/// The generators in real form ([`generating_function`]) through degree `nmax`.
#[allow(clippy::type_complexity)]
fn real_generators<R: Real>(
    generators: &[Vec<Complex<R>>],
    p: &Prepared<R>,
    nmax: usize,
) -> (Vec<(Vec<u32>, usize, R)>, Vec<Vec<R>>, f64) {
    let gens: Vec<Vec<Complex<R>>> = generators.iter().take(nmax + 1).cloned().collect();
    let (greal_parts, generating, imag) = generating_function(&gens, &p.table, &p.linear.ci, nmax);
    (generating, greal_parts, imag)
}

/// The coordinate maps (to, from the normal coordinates) to degree `top − 1`, as asked.
fn coordinate_maps_of<R: Real>(
    table: &Arc<MonomialTable>,
    greal_parts: &[Vec<R>],
    o: &Options,
    nmax: usize,
    top: usize,
) -> Maps<R> {
    if o.transform && nmax >= 2 {
        // the generators in real form generate the same maps in (Q, P), since the
        // complexification is symplectic: the coordinate maps are real Lie series
        let cap = top - 1;
        (
            Some(lie::coordinate_maps(table, greal_parts, cap, false)),
            o.inverse_transform
                .then(|| lie::coordinate_maps(table, greal_parts, cap, true)),
        )
    } else {
        (None, None)
    }
}

/// The coordinate maps to and from the normal coordinates, each where asked for.
type Maps<R> = (Option<Vec<Poly<R>>>, Option<Vec<Poly<R>>>);

/// Stages 4–6 of order `nmax` with the remainder to degree `top`, from the normalisation
/// `out` (its degrees above `top` are ignored) and the coordinate maps.
fn finish<R: Real>(
    p: &Prepared<R>,
    out: &lie::LieOutput<R>,
    o: &Options,
    nmax: usize,
    top: usize,
    maps: Maps<R>,
) -> Raw<R> {
    let t = Instant::now();
    let table = &p.table;
    let n = table.nvars() / 2;
    let tol = o.resonance_tol;
    let (hbar, hbar_imag, degrees) = in_actions(&out.z, table, n, nmax);
    let mut remainder = o.remainder_degree.map(|_| Remainder {
        degree: top,
        parts: Vec::new(),
    });
    let resonant_terms = off_action_terms(&out.z, table, n, nmax, top, remainder.as_mut());
    let divisors = out
        .divisors
        .iter()
        .map(|dv| SmallDivisor {
            m: dv.m.clone(),
            m_dot_omega: dv.value.to_f64(),
            order: dv.order,
            resonant: o.resonant && dv.value.abs().to_f64() < tol,
        })
        .collect();
    let lin = &p.linear.lin;
    // D4 (meaningless when resonant terms were kept: H̄ is then not a function of I alone)
    let d4 = twist_coefficients(
        n,
        nmax,
        resonant_terms.is_empty(),
        &hbar,
        &lin.omega,
        &lin.sigma,
    );
    let (generating, _, generating_imag) = real_generators(&out.generators, p, nmax);
    let (to_normal, from_normal) = maps;
    let mut timings = p.timings.clone();
    timings.transform += t.elapsed().as_secs_f64();
    timings.total = p.started.elapsed().as_secs_f64();
    Raw {
        eq: p.eq.clone(),
        energy: p.energy,
        ainv: symplectic_inverse(&lin.a),
        omega: lin.omega.clone(),
        sigma: lin.sigma.clone(),
        a: lin.a.clone(),
        symplectic_residual: lin.symplectic_residual,
        diagonal_residual: lin.diagonal_residual,
        quadratic_residual: p.linear.quadratic_residual,
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
        transform_imag: 0.0,
        timings,
        table_bytes: table.memory_bytes(),
    }
}

/// The polynomials truncated at degree `top`.
fn truncated<R: Real>(maps: &[Poly<R>], top: usize) -> Vec<Poly<R>> {
    maps.iter()
        .map(|m| {
            let mut m = m.clone();
            for k in top + 1..=m.max_degree() {
                m.set_part(k, Vec::new());
            }
            m
        })
        .collect()
}

/// The normal forms of the orders `orders` = [(N, M), …] (increasing N, remainder degree M)
/// in one normalisation: the table to the largest M, the degrees normalised one after the
/// other, each order's result taken when its degree is reached ([`lie::Normalizer`]) and its
/// coordinate maps extended from the previous order's ([`lie::extend_coordinate_maps`]).
/// Each result is the one [`run`] gives for (N, M) (bitwise in double-double and
/// quad-double, and in f64 from N ≥ `compensated_degree`; to rounding otherwise) and goes
/// to `emit`, which says whether to go on. Assumption 1′ is checked before each order.
pub(super) fn run_orders<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
    orders: &[(usize, usize)],
    emit: &mut dyn FnMut(Raw<R>, usize) -> bool,
) -> Result<(), NormalFormError> {
    let (Some(&(last, _)), Some(cap)) = (orders.last(), orders.iter().map(|x| x.1).max()) else {
        return Ok(());
    };
    let mut p = prepare::<R, H>(h, point, o, last, cap)?;
    let precision = p.precision;
    let tol = o.resonance_tol;
    let omega = p.linear.lin.omega.clone();
    let omega_w = p.linear.omega_w.clone();
    let sigma = p.linear.lin.sigma.clone();
    let is_res = |m: &[i32]| o.resonant && m_dot_omega(m, &omega).abs().to_f64() < tol;
    let mut nz = lie::Normalizer::new(
        p.linear.hc.clone(),
        &omega_w,
        &sigma,
        &is_res,
        p.compensate_to,
    );
    let mut done = 2usize;
    let mut to_maps: Option<Vec<Poly<R>>> = None;
    let mut from_maps: Option<Vec<Poly<R>>> = None;
    for &(nmax, top) in orders {
        check_nonresonant(h.n_dof(), nmax, &omega, o)?;
        let t = Instant::now();
        for r in done + 1..=nmax {
            Progress::report(
                &o.progress,
                Stage::Degree {
                    degree: r,
                    order: nmax,
                    precision,
                },
            );
            nz.step(r);
        }
        p.timings.lie = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let (_, greal_parts, _) = real_generators(&nz.generators, &p, nmax);
        if o.transform && nmax >= 2 {
            let table = &p.table;
            let grow = |maps: &mut Option<Vec<Poly<R>>>, forward: bool| match maps {
                None => *maps = Some(lie::coordinate_maps(table, &greal_parts, cap - 1, forward)),
                Some(m) => {
                    lie::extend_coordinate_maps(table, &greal_parts, done, m, cap - 1, forward)
                }
            };
            grow(&mut to_maps, false);
            if o.inverse_transform {
                grow(&mut from_maps, true);
            }
        }
        p.timings.transform = t.elapsed().as_secs_f64();
        done = nmax;
        let out = lie::LieOutput {
            z: nz.h.clone(),
            generators: nz.generators[..=nmax].to_vec(),
            divisors: nz.divisors(),
        };
        let maps = (
            to_maps.as_ref().map(|m| truncated(m, top - 1)),
            from_maps.as_ref().map(|m| truncated(m, top - 1)),
        );
        let o_n = Options {
            order: nmax,
            remainder_degree: Some(top),
            ..o.clone()
        };
        let raw = finish(&p, &out, &o_n, nmax, top, maps);
        if !emit(raw, nmax) {
            break;
        }
    }
    Ok(())
}

/// What the expansion hands on.
struct Expansion<R> {
    /// The equilibrium.
    eq: Equilibrium<R>,
    /// H about it, to degree `top`.
    hz: Poly<R>,
    /// The monomials of degree ≤ `top` in 2n variables.
    table: Arc<MonomialTable>,
}

/// Stage 1: the equilibrium (Newton from the given point, or checked there) and the Taylor
/// expansion of H about it to degree `top`.
fn expand<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &Point,
    o: &Options,
    top: usize,
) -> Result<Expansion<R>, NormalFormError> {
    let d = 2 * h.n_dof();
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
    let directions = null_directions(h, &eq.z, &gradient_hessian(&hz).1);
    if !directions.is_empty() {
        return Err(NormalFormError::Degenerate {
            point: eq.z.iter().map(|x| x.to_f64()).collect(),
            directions,
            coordinates: h.coordinate_names(),
        });
    }
    Ok(Expansion { eq, hz, table })
}

/// What the linear normalisation hands on.
struct Linear<R: Real> {
    /// ω, σ, A rounded to the working precision.
    lin: LinearNormalization<R>,
    /// ω in the wide precision (double-double or wider), for the small divisors.
    omega_w: Vec<R::Wide>,
    /// The complexification's inverse C⁻¹.
    ci: Mat<Complex<R>>,
    /// H in the complex normal coordinates, its quadratic part exactly Σ λ_k x_k y_k.
    hc: Poly<Complex<R>>,
    /// max |H₂ − Σ λ_k x_k y_k| before it was set exactly.
    quadratic_residual: f64,
}

/// Stage 2: the linear normalisation (in double-double, or the working precision if wider: a
/// 2n×2n problem, and f64 frequencies and A come out correctly rounded — the small divisors
/// amplify every error in ω) and H in complex normal coordinates.
fn normalize_linear<R: Real>(
    hz: &Poly<R>,
    table: &MonomialTable,
    o: &Options,
    compensate_to: usize,
) -> Result<Linear<R>, NormalFormError> {
    let n = table.nvars() / 2;
    let (_, s) = gradient_hessian(hz);
    let s_w: Mat<R::Wide> = s
        .iter()
        .map(|row| row.iter().map(|&x| R::Wide::convert(x)).collect())
        .collect();
    let lin_w = linear_normalization(&s_w, &o.basis_rotation)?;
    let lin = lin_w.rounded(&s);
    let (_, ci) = complexification::<R>(n);
    let mut hc = to_complex_coordinates(hz, &lin.a, compensate_to);
    let mut quadratic_residual: f64 = 0.0;
    let mut h2 = vec![Complex::zero(); table.count(2)];
    for k in 0..n {
        let mut e = vec![0u8; 2 * n];
        e[k] = 1;
        e[n + k] = 1;
        let (_, i) = table.index(&e).expect("x_k y_k");
        h2[i] = Complex::new(R::zero(), lin.omega[k].scale(lin.sigma[k] as f64));
    }
    if let Some(p) = hc.part(2) {
        for (x, y) in p.iter().zip(&h2) {
            quadratic_residual = quadratic_residual.max((*x - *y).magnitude());
        }
    }
    hc.set_part(2, h2);
    hc.set_part(1, Vec::new());
    Ok(Linear {
        lin,
        omega_w: lin_w.omega,
        ci,
        hc,
        quadratic_residual,
    })
}

/// Stage 4a: H̄ in the actions (x_k y_k = −i I_k): its coefficients, the largest imaginary
/// part (zero up to rounding for a real H), and the sizes per degree.
#[allow(clippy::type_complexity)]
fn in_actions<R: Real>(
    z: &Poly<Complex<R>>,
    table: &MonomialTable,
    n: usize,
    nmax: usize,
) -> (Vec<(Vec<u32>, R)>, f64, Vec<DegreeError>) {
    let mut hbar: Vec<(Vec<u32>, R)> = Vec::new();
    let mut hbar_imag: f64 = 0.0;
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
                let zc = z.part(k).map_or(Complex::zero(), |p| p[i]);
                let v = zc * minus_i_pow::<R>(k / 2);
                dn.max_imag = dn.max_imag.max(v.im.abs().to_f64());
                dn.max_coeff = dn.max_coeff.max(v.re.abs().to_f64());
                hbar.push((e[..n].iter().map(|&x| x as u32).collect(), v.re));
            }
        }
        hbar_imag = hbar_imag.max(dn.max_imag);
        degrees.push(dn);
    }
    (hbar, hbar_imag, degrees)
}

/// Stage 4b: the terms of Z that are not functions of the actions: up to order N the
/// resonant terms kept (`--resonant`), beyond it the remainder's sizes per degree.
fn off_action_terms<R: Real>(
    z: &Poly<Complex<R>>,
    table: &MonomialTable,
    n: usize,
    nmax: usize,
    top: usize,
    mut remainder: Option<&mut Remainder>,
) -> Vec<ResonantTerm> {
    let mut resonant_terms = Vec::new();
    for (k, i, zc) in z.terms() {
        let e = table.exponents(k, i);
        if k < 3 || k > top || e[..n] == e[n..] {
            continue;
        }
        if let Some(rem) = remainder.as_deref_mut() {
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
    resonant_terms
}

/// Stage 5: the generating function in real form, G(u) with u = C⁻¹ w: its parts by degree,
/// its terms (exponents, degree, coefficient) and the largest imaginary part dropped.
#[allow(clippy::type_complexity)]
fn generating_function<R: Real>(
    generators: &[Vec<Complex<R>>],
    table: &Arc<MonomialTable>,
    ci: &Mat<Complex<R>>,
    nmax: usize,
) -> (Vec<Vec<R>>, Vec<(Vec<u32>, usize, R)>, f64) {
    let mut gsum = Poly::zero(table.clone());
    for (r, g) in generators.iter().enumerate() {
        if !g.is_empty() {
            gsum.set_part(r, g.clone());
        }
    }
    let (greal, generating_imag) = real_part(&gsum.substitute_pairs(&pair_blocks(ci)));
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
    (greal_parts, generating, generating_imag)
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

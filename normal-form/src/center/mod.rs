//! Centre manifolds at saddle × centre × … equilibria — the collinear points L1, L2, L3 of the
//! restricted three-body problem — by the partial normal form of Jorba & Masdemont (1999),
//! and the Birkhoff normal form there.
//!
//! ```
//! use lasalle_normal_form::center::{center_manifold_model, CenterOptions};
//! use lasalle_normal_form::validate::EARTH_MOON_MU;
//!
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl");
//! let model = lasalle_model::load_model(std::path::Path::new(path)).unwrap();
//! let params = [("mu".to_string(), EARTH_MOON_MU)];
//! let cm = center_manifold_model(&model, &params, "L1", &CenterOptions::with_order(8)).unwrap();
//! assert!((cm.lambda.value - 2.932055).abs() < 1e-6); // Jorba & Masdemont's λ at Earth–Moon L1
//! println!("{}", cm.to_table());
//! ```
//!
//! ## Pipeline
//!
//! 1. **Equilibrium**: Newton on the model's ∇H in the working precision. For `L1`, `L2`,
//!    `L3` of a model that does not declare them but has a parameter `mu` and the layout of
//!    `models/cr3bp.lsl` / `models/cr3bp_spatial.lsl`, the start is the root of the
//!    quintic ([`collinear`](self::gamma)), and γ (the distance to the nearest primary) is
//!    reported.
//! 2. **Taylor expansion** of H about it by jets (the same code as the elliptic normal form);
//!    along the axis its coefficients are the Legendre coefficients `−c_n(μ) sⁿ γ^{2−n}`
//!    ([`c_n`], checked in the tests).
//! 3. **Linear normalisation** (in double-double): `H₂ = λ Q₁P₁ + Σ σ_k ω_k (Q_k² + P_k²)/2`
//!    with a real symplectic A; anything but one real pair ±λ and n − 1 distinct imaginary
//!    pairs is [`NormalFormError::NotSaddleCentre`]. Then the centres are complexified,
//!    `x_k = (Q_k − iP_k)/√2`, `y_k = (P_k − iQ_k)/√2`, the hyperbolic pair kept real
//!    (`x₁ = Q₁`, `y₁ = P₁`).
//! 4. **Reduction to the centre manifold** (Jorba & Masdemont 1999, §3): for r = 3…N, the
//!    generator G_r removes every monomial `xᵃyᵇ` of degree r with `a₁ ≠ b₁`, solving
//!    `{H₂, G_r} + H_r = Z_r` term by term (`g = h/⟨ν, a − b⟩`, `ν = (λ, iσ₂ω₂, …)`, never
//!    small since Re = λ(a₁ − b₁) ≠ 0); H ← H ∘ φ_{G_r}. What is left has a₁ = b₁ in every
//!    term, so `Q₁ = P₁ = 0` is invariant up to degree N: the reduced Hamiltonian is the part
//!    without the hyperbolic pair, a real polynomial of degree N in
//!    `(Q₂…Q_n, P₂…P_n)` ([`CenterManifold::reduced`]). This removes less than a normal form
//!    does (the centre terms are left alone), so its coefficients of degree ≥ 3 depend on the
//!    scheme and on the gauge of A: only the linear frequencies and the Birkhoff coefficients
//!    are invariants.
//! 5. **Birkhoff normal form** (optional, [`CenterOptions::birkhoff`]): the reduction continued
//!    by removing every `a ≠ b`, giving `H̄ = E₀ + λI₁ + Σ σ_k ω_k I_k + Σ h_a Iᵃ` with the
//!    hyperbolic "action" `I₁ = Q₁'P₁'` and `I_k = (Q_k'² + P_k'²)/2` — coefficients that do
//!    not depend on any choice (no small divisors at the collinear points below very high
//!    orders: |m·ω| ≥ 0.06 at Earth–Moon L1/L2 through degree 16).
//! 6. **Coordinate changes**: the generators of step 4 in real form, and the maps
//!    `(Q,P) ↔ (Q',P')` as Lie series to degree N − 1 ([`CenterManifold::from_normal_map`]);
//!    [`CenterManifold::to_model`] maps a point of the reduced phase space into the model's
//!    coordinates.
//!
//! ## Units
//!
//! Everything is in the model's units. Jorba & Masdemont (and hiten) scale lengths by γ
//! (H by 1/γ², time unchanged): a coefficient of degree d there is this one times γ^{d−2}
//! ([`CenterManifold::scaled_by_gamma`]).
#![allow(clippy::too_many_arguments)]

mod collinear;
mod linear;
pub mod lyapunov;
mod output;
pub mod poincare;
mod reduce;

pub use collinear::{c_n, gamma, linear_frequencies, position, Collinear};

use crate::complex::Complex;
use crate::error::NormalFormError;
use crate::hamiltonian::{find_equilibrium, gradient_hessian, taylor, HamiltonianFn};
use crate::linalg::{matvec, Mat};
use crate::linear::{complexification, symplectic_inverse};
use crate::model::ModelHamiltonian;
use crate::monomial::MonomialTable;
use crate::normal_form::{ActionTerm, PolyMap, Precision, Term, Value, MAX_ORDER};
use crate::poly::Poly;
use crate::scalar::{Coeff, Real};
use crate::Dd;
use lasalle_model::Model;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// Options of [`center_manifold`].
#[derive(Clone, Debug)]
pub struct CenterOptions {
    /// Truncation degree N ≥ 2 of the reduced Hamiltonian. Default: 16.
    pub order: usize,
    /// Working precision. Default: double-double.
    pub precision: Precision,
    /// Also compute the Birkhoff normal form (every non-action term removed). Default: true.
    pub birkhoff: bool,
    /// Compute the coordinate changes. Default: true.
    pub transform: bool,
    /// Newton iterations allowed for the equilibrium. Default: 50.
    pub max_newton: usize,
    /// Drop, during the Lie series, every term whose degree plus hyperbolic degree
    /// (a₁ + b₁) exceeds N: they cannot reach the reduced Hamiltonian (see the module docs).
    /// The Birkhoff coefficients are then given for 2|a| + 2a₁ ≤ N, and the coordinate
    /// changes are exact on the centre manifold but truncated off it. Default: true.
    pub prune: bool,
}

impl Default for CenterOptions {
    fn default() -> Self {
        CenterOptions {
            order: 16,
            precision: Precision::DoubleDouble,
            birkhoff: true,
            transform: true,
            max_newton: 50,
            prune: true,
        }
    }
}

impl CenterOptions {
    /// Defaults with this order.
    pub fn with_order(order: usize) -> Self {
        CenterOptions {
            order,
            ..CenterOptions::default()
        }
    }
}

/// Wall-clock seconds per stage.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CenterTimings {
    /// Newton + Taylor expansion.
    pub taylor: f64,
    /// Linear normalisation and complex coordinates.
    pub linear: f64,
    /// The centre-manifold reduction (Lie series, steps 3…N) and the reduced Hamiltonian in
    /// real form.
    pub reduction: f64,
    /// The Birkhoff normal form (0 if not asked).
    pub birkhoff: f64,
    /// The coordinate changes (0 if not asked).
    pub transform: f64,
    /// Everything.
    pub total: f64,
}

/// Checks of the computation.
#[derive(Clone, Debug, Serialize)]
pub struct CenterDiagnostics {
    /// Newton iterations for the equilibrium.
    pub newton_iterations: usize,
    /// |∇H| at the equilibrium.
    pub gradient_norm: f64,
    /// max |AᵀJA − J|.
    pub symplectic_residual: f64,
    /// max |AᵀSA − diag form|.
    pub diagonal_residual: f64,
    /// Largest imaginary part dropped from the reduced Hamiltonian in real form (zero up to
    /// rounding).
    pub reduced_imag_residual: f64,
    /// Largest |coefficient| of a term with a₁ ≠ b₁ left after the reduction (zero by
    /// construction: the invariance of the centre manifold to degree N).
    pub hyperbolic_residual: f64,
    /// Smallest |⟨ν, a − b⟩| used as a divisor by the Birkhoff normal form (None if not run).
    pub smallest_divisor: Option<f64>,
    /// Timings.
    pub timings: CenterTimings,
}

/// The centre manifold of a saddle × centre equilibrium to degree N (see the module docs).
#[derive(Clone, Debug, Serialize)]
pub struct CenterManifold {
    /// Model name with parameters.
    pub model: String,
    /// The point as asked (`L1`, …, or `given`).
    pub point: String,
    /// Degrees of freedom n of the full problem.
    pub n_dof: usize,
    /// Truncation degree N.
    pub order: usize,
    /// Working precision.
    pub precision: Precision,
    /// Names of the model's canonical coordinates z.
    pub coordinates: Vec<String>,
    /// The equilibrium z_eq.
    pub equilibrium: Vec<Value>,
    /// H(z_eq).
    pub energy: Value,
    /// γ, the distance to the nearest primary (collinear points of the three-body models).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gamma: Option<Value>,
    /// λ > 0: the eigenvalues ±λ of the hyperbolic pair.
    pub lambda: Value,
    /// ω_k > 0 of the centres, in the order of (Q₂, P₂), …: (ω_p, ω_v) in the spatial
    /// three-body problem.
    pub omega: Vec<Value>,
    /// σ_k of the centres (H₂ = λQ₁P₁ + Σ σ_k ω_k (Q_k² + P_k²)/2).
    pub signs: Vec<i8>,
    /// A: z − z_eq = A (Q, P).
    pub linear_map: Vec<Vec<f64>>,
    /// A⁻¹.
    pub linear_inverse: Vec<Vec<f64>>,
    /// The reduced Hamiltonian H_cm − E₀ on the centre manifold, degrees 2…N: exponents of
    /// (Q₂…Q_n, P₂…P_n), all monomials (zeros included) in the monomial table's order.
    pub reduced: Vec<Term>,
    /// The Birkhoff normal form H̄ − E₀ in (I₁ = Q₁'P₁', I₂, …), degrees 2…N (empty if not
    /// asked).
    pub birkhoff: Vec<ActionTerm>,
    /// Checks and timings.
    pub diagnostics: CenterDiagnostics,
    /// The reduced Hamiltonian H_cm − E₀ as a polynomial in (Q₂…Q_n, P₂…P_n).
    #[serde(skip)]
    pub reduced_poly: Poly<f64>,
    /// (Q', P') as polynomials in the linear normal coordinates (Q, P) (degree ≤ N − 1).
    #[serde(skip)]
    pub to_normal_map: Option<PolyMap>,
    /// (Q, P) as polynomials in (Q', P') (degree ≤ N − 1).
    #[serde(skip)]
    pub from_normal_map: Option<PolyMap>,
}

/// The coordinate maps (to normal, from normal), one polynomial per coordinate.
type Maps<R> = (Vec<Poly<R>>, Vec<Poly<R>>);

/// Internal result in the working precision.
struct Raw<R> {
    eq: crate::hamiltonian::Equilibrium<R>,
    energy: R,
    lambda: R,
    omega: Vec<R>,
    sigma: Vec<i8>,
    a: Mat<R>,
    symplectic_residual: f64,
    diagonal_residual: f64,
    reduced: Poly<R>,
    reduced_imag: f64,
    hyperbolic_residual: f64,
    birkhoff: Vec<(Vec<u32>, R)>,
    smallest_divisor: Option<f64>,
    /// (to normal, from normal)
    maps: Option<Maps<R>>,
    timings: CenterTimings,
}

/// The blocks of the partial complexification: the identity on the hyperbolic pair, the
/// elliptic normal form's `C` (or `C⁻¹`) on the centres.
fn blocks<R: Real>(n: usize, inverse: bool) -> Vec<[[Complex<R>; 2]; 2]> {
    let (c, ci) = complexification::<R>(n);
    let m = if inverse { ci } else { c };
    (0..n)
        .map(|k| {
            if k == 0 {
                [
                    [Complex::one(), Complex::zero()],
                    [Complex::zero(), Complex::one()],
                ]
            } else {
                [[m[k][k], m[k][n + k]], [m[n + k][k], m[n + k][n + k]]]
            }
        })
        .collect()
}

/// The real part of a complex polynomial and the largest imaginary part.
fn real_part<R: Real>(p: &Poly<Complex<R>>) -> (Poly<R>, f64) {
    let imag = p
        .terms()
        .map(|(_, _, c)| c.im.abs().to_f64())
        .fold(0.0, f64::max);
    (p.map(|c| c.re), imag)
}

fn run<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    start: &[f64],
    o: &CenterOptions,
) -> Result<Raw<R>, NormalFormError> {
    let t0 = Instant::now();
    let n = h.n_dof();
    let d = 2 * n;
    let nmax = o.order;
    let start: Vec<R> = start.iter().map(|&x| R::from_f64(x)).collect();
    let eq = find_equilibrium(h, &start, o.max_newton)?;
    let table = Arc::new(MonomialTable::new(d, nmax));
    let hz = taylor(h, &eq.z, &table);
    if !hz.is_finite() {
        return Err(NormalFormError::NonFinite("the Taylor expansion"));
    }
    let mut timings = CenterTimings {
        taylor: t0.elapsed().as_secs_f64(),
        ..CenterTimings::default()
    };

    let t = Instant::now();
    let (_, s) = gradient_hessian(&hz);
    let s_dd: Mat<Dd> = s
        .iter()
        .map(|row| {
            row.iter()
                .map(|&x| {
                    let (hi, lo) = x.hi_lo();
                    Dd::from_parts(hi, lo)
                })
                .collect()
        })
        .collect();
    let lin_dd = linear::saddle_centre(&s_dd)?;
    let lin = lin_dd.rounded(&s);
    let energy = hz.constant_term();
    let mut hc = hz
        .substitute_linear(&lin.a)
        .map(Complex::real)
        .substitute_pairs(&blocks::<R>(n, false));
    let mut h2 = vec![Complex::zero(); table.count(2)];
    for k in 0..n {
        let mut e = vec![0u8; d];
        e[k] = 1;
        e[n + k] = 1;
        let (_, i) = table.index(&e).expect("x_k y_k");
        h2[i] = if k == 0 {
            Complex::real(lin.lambda)
        } else {
            Complex::new(R::zero(), lin.omega[k - 1].scale(lin.sigma[k - 1] as f64))
        };
    }
    hc.set_part(2, h2);
    hc.set_part(1, Vec::new());
    hc.set_part(0, Vec::new());
    timings.linear = t.elapsed().as_secs_f64();

    // step 4: the reduction
    let t = Instant::now();
    let kill_cm = |e: &[u8]| e[0] != e[n];
    let gens = reduce::normalize(
        &mut hc,
        3,
        nmax,
        lin_dd.lambda,
        &lin_dd.omega,
        &lin.sigma,
        &kill_cm,
        o.prune,
        &|_| {},
    );
    let mut hyperbolic_residual: f64 = 0.0;
    for (k, i, c) in hc.terms() {
        if k >= 3 && kill_cm(table.exponents(k, i)) {
            hyperbolic_residual = hyperbolic_residual.max(c.magnitude());
        }
    }
    // the reduced Hamiltonian: the terms free of the hyperbolic pair, in real (Q, P)
    let mut free = Poly::zero(table.clone());
    for k in 2..=nmax {
        let Some(p) = hc.part(k) else { continue };
        let v: Vec<Complex<R>> = p
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                let e = table.exponents(k, i);
                if e[0] == 0 && e[n] == 0 {
                    c
                } else {
                    Complex::zero()
                }
            })
            .collect();
        free.set_part(k, v);
    }
    let (free_real, reduced_imag) = real_part(&free.substitute_pairs(&blocks::<R>(n, true)));
    let rtable = Arc::new(MonomialTable::new(d - 2, nmax));
    let mut reduced = Poly::zero(rtable.clone());
    for (k, i, c) in free_real.terms() {
        let e = table.exponents(k, i);
        let re: Vec<u8> = (1..n).chain(n + 1..d).map(|v| e[v]).collect();
        reduced.set_coeff(&re, c);
    }
    timings.reduction = t.elapsed().as_secs_f64();

    // step 5: the Birkhoff normal form
    let t = Instant::now();
    let (birkhoff, smallest_divisor) = if o.birkhoff {
        let mut hb = hc.clone();
        let kill_all = |e: &[u8]| e[..n] != e[n..];
        reduce::normalize(
            &mut hb,
            3,
            nmax,
            lin_dd.lambda,
            &lin_dd.omega,
            &lin.sigma,
            &kill_all,
            o.prune,
            &|_| {},
        );
        let mut terms = Vec::new();
        for k in (2..=nmax).step_by(2) {
            for i in 0..table.count(k) {
                let e = table.exponents(k, i);
                if e[..n] != e[n..] || (o.prune && k + 2 * e[0] as usize > nmax) {
                    continue;
                }
                let c = hb.part(k).map_or(Complex::zero(), |p| p[i]);
                // x_k y_k = −i I_k for the centres, x₁y₁ = I₁
                let centre: usize = e[1..n].iter().map(|&x| x as usize).sum();
                let v = c * crate::normal_form::minus_i_pow::<R>(centre);
                terms.push((e[..n].iter().map(|&x| x as u32).collect(), v.re));
            }
        }
        (terms, Some(smallest_centre_divisor(&lin.omega, nmax)))
    } else {
        (Vec::new(), None)
    };
    timings.birkhoff = t.elapsed().as_secs_f64();

    // step 6: the coordinate changes
    let t = Instant::now();
    let maps = if o.transform {
        let mut gsum = Poly::zero(table.clone());
        for (r, g) in gens.iter().enumerate() {
            if !g.is_empty() {
                gsum.set_part(r, g.clone());
            }
        }
        let (greal, _) = real_part(&gsum.substitute_pairs(&blocks::<R>(n, true)));
        let parts: Vec<Vec<R>> = (0..=nmax)
            .map(|r| greal.part(r).map_or(Vec::new(), |p| p.to_vec()))
            .collect();
        let cap = nmax.saturating_sub(1).max(1);
        Some((
            crate::lie::coordinate_maps(&table, &parts, cap, false),
            crate::lie::coordinate_maps(&table, &parts, cap, true),
        ))
    } else {
        None
    };
    timings.transform = t.elapsed().as_secs_f64();
    timings.total = t0.elapsed().as_secs_f64();
    Ok(Raw {
        eq,
        energy,
        lambda: lin.lambda,
        omega: lin.omega,
        sigma: lin.sigma,
        a: lin.a,
        symplectic_residual: lin.symplectic_residual,
        diagonal_residual: lin.diagonal_residual,
        reduced,
        reduced_imag,
        hyperbolic_residual,
        birkhoff,
        smallest_divisor,
        maps,
        timings,
    })
}

/// min |m·ω| over the centre frequencies for 0 < |m|₁ ≤ N (the hyperbolic part of a divisor
/// is λ(a₁ − b₁), which only adds to its modulus).
fn smallest_centre_divisor<R: Real>(omega: &[R], nmax: usize) -> f64 {
    let w: Vec<f64> = omega.iter().map(|x| x.to_f64()).collect();
    let mut best = f64::INFINITY;
    for m in crate::normal_form::integer_vectors(w.len(), nmax) {
        let v: f64 = m.iter().zip(&w).map(|(&a, &b)| a as f64 * b).sum();
        best = best.min(v.abs());
    }
    best
}

fn assemble<R: Real, H: HamiltonianFn + ?Sized>(
    h: &H,
    point: &str,
    gamma: Option<Dd>,
    raw: Raw<R>,
    o: &CenterOptions,
) -> CenterManifold {
    let mat = |m: &Mat<R>| -> Vec<Vec<f64>> {
        m.iter()
            .map(|r| r.iter().map(|x| x.to_f64()).collect())
            .collect()
    };
    // rounding noise on coefficients that vanish by symmetry: below 64 unit roundoffs of the
    // largest coefficient of their degree, they are set to zero
    let mut raw = raw;
    let eps = 64.0 * R::EPSILON;
    let rt = raw.reduced.table().clone();
    for k in 2..=rt.max_degree() {
        let big = raw.reduced.max_abs(k);
        if big > 0.0 && raw.reduced.part(k).is_some() {
            for c in raw.reduced.part_mut(k).iter_mut() {
                if c.to_f64().abs() < eps * big {
                    *c = R::zero();
                }
            }
        }
    }
    let mut big_b = std::collections::BTreeMap::new();
    for (e, v) in &raw.birkhoff {
        let deg: u32 = e.iter().sum();
        let b = big_b.entry(deg).or_insert(0.0f64);
        *b = b.max(v.to_f64().abs());
    }
    for (e, v) in raw.birkhoff.iter_mut() {
        let deg: u32 = e.iter().sum();
        if v.to_f64().abs() < eps * big_b[&deg] {
            *v = R::zero();
        }
    }
    let mut reduced = Vec::new();
    for k in 2..=rt.max_degree() {
        for i in 0..rt.count(k) {
            let c = raw.reduced.part(k).map_or(R::zero(), |p| p[i]);
            reduced.push(Term {
                exponents: rt.exponents(k, i).iter().map(|&x| x as u32).collect(),
                degree: k,
                coeff: Value::of(c),
            });
        }
    }
    let birkhoff = raw
        .birkhoff
        .iter()
        .map(|(e, v)| ActionTerm {
            exponents: e.clone(),
            degree: 2 * e.iter().sum::<u32>() as usize,
            coeff: Value::of(*v),
        })
        .collect();
    let to_map = |ps: Vec<Poly<R>>| PolyMap {
        components: ps.iter().map(|p| p.map(|c| c.to_f64())).collect(),
    };
    let (to_normal_map, from_normal_map) = match raw.maps {
        Some((to, from)) => (Some(to_map(to)), Some(to_map(from))),
        None => (None, None),
    };
    CenterManifold {
        model: h.name(),
        point: point.to_string(),
        n_dof: h.n_dof(),
        order: o.order,
        precision: o.precision,
        coordinates: h.coordinate_names(),
        equilibrium: raw.eq.z.iter().map(|&x| Value::of(x)).collect(),
        energy: Value::of(raw.energy),
        gamma: gamma.map(Value::of),
        lambda: Value::of(raw.lambda),
        omega: raw.omega.iter().map(|&x| Value::of(x)).collect(),
        signs: raw.sigma.clone(),
        linear_inverse: mat(&symplectic_inverse(&raw.a)),
        linear_map: mat(&raw.a),
        reduced,
        birkhoff,
        diagnostics: CenterDiagnostics {
            newton_iterations: raw.eq.iterations,
            gradient_norm: raw.eq.gradient,
            symplectic_residual: raw.symplectic_residual,
            diagonal_residual: raw.diagonal_residual,
            reduced_imag_residual: raw.reduced_imag,
            hyperbolic_residual: raw.hyperbolic_residual,
            smallest_divisor: raw.smallest_divisor,
            timings: raw.timings,
        },
        reduced_poly: raw.reduced.map(|c| c.to_f64()),
        to_normal_map,
        from_normal_map,
    }
}

fn validate(h_dof: usize, o: &CenterOptions) -> Result<(), NormalFormError> {
    if o.order < 2 || o.order > MAX_ORDER {
        return Err(NormalFormError::Invalid(format!(
            "order {} outside 2…{MAX_ORDER}",
            o.order
        )));
    }
    if h_dof < 2 {
        return Err(NormalFormError::Invalid(format!(
            "a centre manifold needs a hyperbolic pair and at least one centre: {h_dof} degree(s) of freedom"
        )));
    }
    if o.max_newton == 0 {
        return Err(NormalFormError::Invalid(
            "max_newton = 0: at least one Newton iteration is needed".into(),
        ));
    }
    Ok(())
}

/// The centre manifold of `h` at the saddle × centre equilibrium found by Newton from `start`
/// (z order), named `point` in reports; `gamma` is reported if given.
pub fn center_manifold<H: HamiltonianFn + ?Sized>(
    h: &H,
    start: &[f64],
    point: &str,
    gamma: Option<Dd>,
    o: &CenterOptions,
) -> Result<CenterManifold, NormalFormError> {
    validate(h.n_dof(), o)?;
    if start.len() != 2 * h.n_dof() {
        return Err(NormalFormError::Invalid(format!(
            "point has {} components, expected {}",
            start.len(),
            2 * h.n_dof()
        )));
    }
    Ok(match o.precision {
        Precision::F64 => assemble(h, point, gamma, run::<f64, H>(h, start, o)?, o),
        Precision::DoubleDouble => assemble(h, point, gamma, run::<Dd, H>(h, start, o)?, o),
        Precision::QuadDouble => {
            return Err(NormalFormError::Invalid(
                "the centre manifold is computed in f64 or double-double: use `--precision dd`"
                    .to_string(),
            ))
        }
    })
}

/// The starting point for `at` in a model: a declared point of that name, or for `L1`…`L3`
/// (not declared) the quintic's root in the layout of the three-body models (needs a
/// parameter `mu`, state `q`, `p` of 2 or 3 components); then γ is returned too.
pub fn start_point(
    h: &ModelHamiltonian<'_>,
    model: &Model,
    at: &str,
) -> Result<(Vec<f64>, Option<Dd>), NormalFormError> {
    if let Some(z) = h.point(at) {
        return Ok((z, None));
    }
    let Some(which) = Collinear::parse(at) else {
        return Err(NormalFormError::Model(format!(
            "no point `{at}` (the model has: {}; L1, L2, L3 are located for the three-body models)",
            h.point_names().join(", ")
        )));
    };
    let mu = model
        .param("mu")
        .filter(|p| p.slots() == 1)
        .map(|p| h.params()[p.offset])
        .ok_or_else(|| {
            NormalFormError::Model(format!(
                "`{at}` is located as a collinear point of the restricted three-body problem, which needs a scalar parameter `mu`; model `{}` has none (declare the point, or give a Newton start x1,x2,…)",
                model.name
            ))
        })?;
    let n = h.n_dof();
    let names = h.coordinate_names();
    let expected: Vec<String> = (0..n)
        .map(|k| format!("q[{k}]"))
        .chain((0..n).map(|k| format!("p[{k}]")))
        .collect();
    if !(n == 2 || n == 3) || names != expected {
        return Err(NormalFormError::Model(format!(
            "`{at}` is located for the layout of models/cr3bp.lsl (state q, p of 2 or 3 components); this model's coordinates are {}: declare the point, or give a Newton start",
            names.join(", ")
        )));
    }
    let g = gamma(mu, which).ok_or_else(|| {
        NormalFormError::Model(format!(
            "`mu = {mu}`: the collinear points are located for 0 < mu ≤ 1/2"
        ))
    })?;
    let x = position(mu, which, g).to_f64();
    let mut z = vec![0.0; 2 * n];
    z[0] = x;
    z[n + 1] = x; // p_y = x at rest in the rotating frame
    Ok((z, Some(g)))
}

/// [`center_manifold`] of a lowered model at `at` (a declared point, or `L1`/`L2`/`L3`, see
/// [`start_point`]).
pub fn center_manifold_model(
    model: &Model,
    params: &[(String, f64)],
    at: &str,
    o: &CenterOptions,
) -> Result<CenterManifold, NormalFormError> {
    let h = ModelHamiltonian::new(model, params)?;
    validate(h.n_dof(), o)?;
    let (z, g) = start_point(&h, model, at)?;
    center_manifold(&h, &z, at, g, o)
}

/// [`center_manifold_model`] from a model at a Newton start given in the flat state order.
pub fn center_manifold_model_at(
    model: &Model,
    params: &[(String, f64)],
    start: &[f64],
    o: &CenterOptions,
) -> Result<CenterManifold, NormalFormError> {
    let h = ModelHamiltonian::new(model, params)?;
    validate(h.n_dof(), o)?;
    if start.len() != model.dim() {
        return Err(NormalFormError::Invalid(format!(
            "point has {} components, the state has {}",
            start.len(),
            model.dim()
        )));
    }
    let z = h.to_z(start);
    center_manifold(&h, &z, "given", None, o)
}

impl CenterManifold {
    /// Number of centre degrees of freedom (n − 1).
    pub fn n_centre(&self) -> usize {
        self.n_dof - 1
    }

    /// The coefficients in Jorba & Masdemont's units (lengths scaled by γ, H by 1/γ²): a
    /// coefficient of degree d times γ^{d−2}. None unless γ is known.
    pub fn scaled_by_gamma(&self) -> Option<(Vec<Term>, Vec<ActionTerm>)> {
        let g = self.gamma?.value;
        let red = self
            .reduced
            .iter()
            .map(|t| {
                let mut t = t.clone();
                let f = g.powi(t.degree as i32 - 2);
                t.coeff = Value::of(t.coeff.value * f);
                t
            })
            .collect();
        let bnf = self
            .birkhoff
            .iter()
            .map(|t| {
                let mut t = t.clone();
                let f = g.powi(t.degree as i32 - 2);
                t.coeff = Value::of(t.coeff.value * f);
                t
            })
            .collect();
        Some((red, bnf))
    }

    /// H_cm(w) − E₀ at a point w = (Q₂…Q_n, P₂…P_n) of the reduced phase space.
    pub fn reduced_energy(&self, w: &[f64]) -> f64 {
        self.reduced_poly.eval(w)
    }

    /// The full normal coordinates (Q', P') of a reduced point: Q₁' = P₁' = 0.
    pub fn embed(&self, w: &[f64]) -> Vec<f64> {
        let n = self.n_dof;
        let mut full = vec![0.0; 2 * n];
        for k in 1..n {
            full[k] = w[k - 1];
            full[n + k] = w[n - 1 + k - 1];
        }
        full
    }

    /// The model state z of normal coordinates (Q', P') (needs the transformation).
    pub fn from_normal(&self, w: &[f64]) -> Option<Vec<f64>> {
        let l = self.from_normal_map.as_ref()?.eval(w);
        let dz = matvec(&self.linear_map, &l);
        Some(
            self.equilibrium
                .iter()
                .zip(dz)
                .map(|(e, x)| e.value + e.lo + x)
                .collect(),
        )
    }

    /// Normal coordinates (Q', P') of a model state z (needs the transformation).
    pub fn to_normal(&self, z: &[f64]) -> Option<Vec<f64>> {
        let dz: Vec<f64> = z
            .iter()
            .zip(&self.equilibrium)
            .map(|(x, e)| (x - e.value) - e.lo)
            .collect();
        let l = matvec(&self.linear_inverse, &dz);
        Some(self.to_normal_map.as_ref()?.eval(&l))
    }

    /// The model state of a point w = (Q₂…Q_n, P₂…P_n) of the centre manifold.
    pub fn to_model(&self, w: &[f64]) -> Option<Vec<f64>> {
        self.from_normal(&self.embed(w))
    }
}

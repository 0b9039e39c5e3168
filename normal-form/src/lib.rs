//! # lasalle-normal-form
//!
//! Birkhoff normal forms of Hamiltonian systems at elliptic equilibria, to any order, in
//! f64 or double-double precision — the restricted three-body problem at L4 being the
//! reference case (seed `004`, first paper pp. 8–22; `docs/equations.md` §3).
//!
//! ```
//! use lasalle_normal_form::validate::{deprit_d4, EARTH_MOON_MU};
//! use lasalle_normal_form::{normalize_model_file, ModelPoint, Options};
//!
//! let model = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/cr3bp.lsl");
//! let params = [("mu".to_string(), EARTH_MOON_MU)];
//! let at = ModelPoint::Named("L4".into());
//! let nf = normalize_model_file(model, &params, &at, &Options::with_order(6)).unwrap();
//! let d4 = nf.d4.as_ref().unwrap().d4.value;
//! assert!((d4 + deprit_d4(EARTH_MOON_MU)).abs() < 1e-10);
//! println!("{}", nf.to_table());
//! ```
//!
//! This is what `lasalle normal-form models/cr3bp.lsl --order 6` calls. Any
//! [`HamiltonianFn`] goes through [`normalize`] the same way; the crate's own Rust
//! Hamiltonians ([`models`]) are only independent checks.
//!
//! ## Pipeline
//!
//! 1. **Equilibrium.** Newton on ∇H = 0 from the given point, in the working precision
//!    ([`Point::Given`] additionally requires |∇H| ≤ `equilibrium_tol` at the start).
//! 2. **Taylor expansion** of H about the equilibrium to degree N by evaluating the
//!    expression once over truncated multivariate series ([`jet`]): `1/r`, `x^p`, `exp`, …
//!    are series recurrences, never symbolic derivatives. The same code evaluates a model's
//!    DAG (`lasalle_codegen::ir::Graph::eval`) and, with one variable, series in time.
//! 3. **Linear normalisation.** Eigenvalues of `J S` (S = Hessian) from the even
//!    characteristic polynomial; unless they are distinct and purely imaginary the run stops
//!    with [`NormalFormError::NotElliptic`] listing them. A real symplectic `A`
//!    (`AᵀJA = J` checked) gives `H₂ = Σ σ_k ω_k (Q_k² + P_k²)/2`, ω₁ > ω₂ > … > 0.
//! 4. **Assumption 1′**: |m·ω| ≥ `resonance_tol` (default 1e-6) for 0 < |m|₁ ≤ N, else
//!    [`NormalFormError::Resonance`] names m, m·ω and the order |m|₁ (at L4: μ ≈ 0.0242939
//!    is 1:2, order 3; μ ≈ 0.0135160 is 1:3, order 4). `resonant = true` keeps those terms.
//! 5. **Lie-series normalisation** degree 3…N in the complex coordinates
//!    `x_k = (Q_k − iP_k)/√2`, `y_k = (P_k − iQ_k)/√2` (`H₂ = Σ iσ_kω_k x_k y_k`), solving the
//!    homological equation monomial by monomial, `g = h/⟨λ, a − b⟩` (seed eq. 21); see the
//!    `lie` module docs.
//! 6. **Real forms**: H̄ in actions, the generators G₃…G_N as real polynomials in (Q, P), and
//!    the coordinate maps (Q,P) ↔ (Q',P') as real Lie series.
//!
//! ## Conventions (exactly)
//!
//! * Coordinates `z = (q₁…q_n, p₁…p_n)`, `ż = J∇H`, `J = [[0, I], [−I, 0]]`,
//!   `{F, G} = Σ ∂F/∂q_k ∂G/∂p_k − ∂F/∂p_k ∂G/∂q_k`.
//! * Linear normal coordinates `(Q, P) = A⁻¹(z − z_eq)`; nonlinear normal coordinates
//!   `(Q', P')`; the maps between them are [`NormalForm::to_normal_map`] /
//!   [`NormalForm::from_normal_map`] (degree ≤ N−1).
//! * Actions `I_k = (Q'_k² + P'_k²)/2 ≥ 0`, signs as they come:
//!   `H̄ = H(z_eq) + Σ σ_k ω_k I_k + Σ_{|a|≥2} h_a I^a`. At L4, σ = (+1, −1):
//!   `H̄ = ω₁I₁ − ω₂I₂ + ½(A I₁² + 2B I₁I₂ + C I₂²) + …` with ω₁ the short-period frequency.
//! * The transformation is `z = φ_{G₃} ∘ φ_{G₄} ∘ … ∘ φ_{G_N}(z')` (time-one flows), so
//!   `H̄ = H ∘ φ_{G₃} ∘ … ∘ φ_{G_N}` truncated; each plane of the truncated flow rotates
//!   clockwise, `Q' + iP' ↦ (Q' + iP') e^{−iν_k t}`, `ν = ∂H̄/∂I` (seed eq. 5; [`NormalForm::flow`]).
//! * Small divisors are reported as m·ω with the positive ω and the first nonzero m_k > 0.
//! * **Arnold–Moser:** `D₄ = A ν₂² − 2B ν₁ν₂ + C ν₁²` with ν = (σ₁ω₁, σ₂ω₂), i.e.
//!   `D₄ = −det[[A, B, ν₁], [B, C, ν₂], [ν₁, ν₂, 0]]`; at L4 it is Deprit's
//!   `A ω₂² + 2B ω₁ω₂ + C ω₁²`.
//!
//! ### Sign of D₄
//!
//! Our D₄ equals `+(36 − 541w + 644w²)/(8(1 − 4w)(4 − 25w))`, `w = ω₁²ω₂²`, to 1e-12
//! relative over the whole stable range (tests/deprit.rs): the magnitude and the zero
//! μ_c = 0.010913667677201 agree with Deprit & Deprit-Bartholomé, the sign is opposite to the
//! textbook form. The sign is not a matter of how the planes are oriented: the Birkhoff
//! coefficients h_a are invariants of the function H once the actions are nonnegative, and
//! ours are checked against the true flow (tests/frequencies.rs: ∂H̄/∂I matches frequencies
//! measured along DOPRI5 orbits, which fixes the signs of A, B, C). D₄ is odd under
//! H → −H (A, B, C change sign, ω do not), so the textbook form corresponds to normalising
//! −H, i.e. to the convention in which Hamilton's equations read ż = −J∇H (or, equivalently,
//! in which the L4 quadratic part is taken as −ω₁I₁ + ω₂I₂ and relabelled). At Earth–Moon
//! ours is D₄ = −0.33759; the textbook value is +0.33759.
//!
//! ## Precision and error estimates
//!
//! All algebra is generic over the coefficient ([`Real`]: `f64` or [`Dd`], a double-double
//! with ≈ 32 digits, and [`Complex`] of either). Small divisors amplify rounding; with
//! `error_estimate` (default) the other precision is run too and each coefficient carries
//! `error = |c_f64 − c_dd|` (f64 run) or `|c_f64 − c_dd|·2⁻⁵¹` (dd run: the same amplification
//! acting on a 2⁵¹ times smaller unit roundoff). An estimate independent of precision:
//! rerun with `basis_rotation` (H̄ does not depend on it, the rounding does).
//! At μ = 0.001 f64 loses the degree-8 coefficients to ~1e-5 and the degree-12 ones to
//! 10–40 %, double-double keeps every coefficient through degree 12 to ~1e-17
//! (tests/precision.rs).
//!
//! ## Performance
//!
//! Dense per-degree monomial arrays with additive keys ([`MonomialTable`]): products and
//! brackets are index-table lookups, no hashing. Double-double uses fused accumulation
//! kernels with FMA when the CPU has it (runtime detection). Timings per order:
//! `cargo run -p lasalle-normal-form --release --example bench_orders`.
#![warn(missing_docs)]

mod complex;
mod dd;
mod emit;
mod error;
mod hamiltonian;
pub mod jet;
mod lie;
pub mod linalg;
mod linear;
pub mod model;
pub mod models;
mod monomial;
mod normal_form;
mod output;
pub mod poly;
mod scalar;
pub mod validate;

pub use complex::Complex;
pub use dd::Dd;
pub use error::{Eigenvalue, NormalFormError};
pub use hamiltonian::{find_equilibrium, taylor, Equilibrium, HamiltonianFn};
pub use jet::Jet;
pub use lasalle_codegen::ir::{Rational, Scalar};
pub use model::{normalize_model, normalize_model_file, ModelHamiltonian, ModelPoint};
pub use monomial::{binomial, MonomialTable};
pub use normal_form::{
    normalize, ActionTerm, ArnoldMoser, Diagnostics, NormalForm, Options, Point, PolyMap,
    Precision, ResonantTerm, SmallDivisor, Term, Timings, Value,
};
pub use poly::Poly;
pub use scalar::{Coeff, Real};

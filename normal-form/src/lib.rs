//! # lasalle-normal-form
//!
//! Birkhoff normal forms of Hamiltonian systems at elliptic equilibria, to any order, in
//! f64, double-double or quad-double ([`Qd`]) precision — the restricted three-body problem at
//! L4 being the reference case (the first paper of NASA TM X-53478, *Progress Report No. 8*,
//! Marshall Space Flight Center, 1966; `docs/normal-form.md`).
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
//!    DAG (`lasalle_model::ir::Graph::eval`) and, with one variable, series in time.
//! 3. **Linear normalisation.** Eigenvalues of `J S` (S = Hessian) from the even
//!    characteristic polynomial; unless they are purely imaginary the run stops with
//!    [`NormalFormError::NotElliptic`] listing them. A real symplectic `A`
//!    (`AᵀJA = J` checked) gives `H₂ = Σ σ_k ω_k (Q_k² + P_k²)/2`, ω₁ ≥ ω₂ ≥ … > 0. A
//!    repeated frequency (within 1e-9·ω₁) is accepted when `J S` is diagonalisable on it: its
//!    eigenspace gets a basis orthonormal for the Hermitian form `−(i/2) fᴴ J g` (the signs
//!    are the σ_k, so 1:1 and 1:−1 both work); with a nilpotent part (fewer eigenvectors than
//!    the multiplicity) the run stops with [`NormalFormError::Defective`].
//! 4. **Assumption 1′**: |m·ω| ≥ `resonance_tol` (default 1e-6) for every m met up to degree
//!    N, else [`NormalFormError::Resonance`] names m, m·ω and the first degree where m
//!    occurs (|m|₁, or 4 for |m|₁ = 2: H₂ is already diagonal), and suggests `resonant` or a
//!    lower order (at L4: μ ≈ 0.0242939 is 1:2, order 3; μ ≈ 0.0135160 is 1:3, order 4; a
//!    repeated frequency, e.g. Hénon–Heiles, is m = (1, −1), order 4). `resonant = true`
//!    keeps those terms: H̄ is then the action part plus [`NormalForm::resonant_terms`], and
//!    D₄ is not computed.
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
//! textbook form `−(36 − 541w + 644w²)/(…)`. The textbook sign is the one in error:
//!
//! - our A, B, C agree one by one, to 1e-10, with the closed forms of the same paper (as given
//!   by Meyer, Hall & Offin): `A = ω₂²(81 − 696ω₁² + 124ω₁⁴)/(72(1 − 2ω₁²)²(1 − 5ω₁²))`,
//!   `B = −ω₁ω₂(43 + 64w)/(6(1 − 4w)(4 − 25w))`, `C` = A with ω₁ ↔ ω₂;
//! - inserted in the definition D₄ = Aω₂² + 2Bω₁ω₂ + Cω₁², these closed forms give the plus
//!   sign (tests/deprit.rs checks this algebra numerically);
//! - the signs of A, B, C are also fixed by the flow: ∂H̄/∂I matches frequencies measured along
//!   DOPRI5 orbits (tests/frequencies.rs). The Birkhoff coefficients are invariants of H once
//!   the actions are nonnegative, so no orientation convention can flip them; only H → −H
//!   (equations ż = −J∇H) flips D₄.
//!
//! So the published closed form for D₄ carries a sign inconsistent with its own A, B, C;
//! its magnitude and zero (what Arnold–Moser stability needs: D₄ ≠ 0) are right. At
//! Earth–Moon D₄ = −0.33759 (textbook formula: +0.33759).
//!
//! ## Precision and error estimates
//!
//! All algebra is generic over the coefficient ([`Real`]: `f64`, [`Dd`], a double-double
//! with ≈ 32 digits, or [`Qd`], a quad-double with ≈ 64 digits, and [`Complex`] of any).
//! With `auto_precision` a run that fails the precision check is redone in the next wider
//! precision, f64 → double-double → quad-double (Sun–Jupiter L4 needs quad-double from
//! degree 24 on); the frequencies, the small divisors and the linear normalisation are
//! formed in [`Real::Wide`] (double-double, or quad-double in a quad-double run). Small divisors amplify rounding; each
//! coefficient of H̄ carries an error estimate ([`ErrorEstimate`]):
//! [`ErrorEstimate::OtherPrecision`] (the library default) runs the other precision too,
//! `error = |c_f64 − c_dd|` (f64 run) or `|c_f64 − c_dd|·2⁻⁵¹` (dd run: the same amplification
//! acting on a 2⁵¹ times smaller unit roundoff); [`ErrorEstimate::Rotation`] (the command
//! line's default for f64) reruns the same precision with every normal plane rotated (H̄ does
//! not depend on it, the rounding does): one run instead of 1.2–3.3, and within a factor ~3
//! of the real f64 error (`examples/noise.rs`).
//!
//! **Precision check.** The estimates are checked against `max_relative_error` (default
//! 1e-3: three digits in every coefficient, coefficients below 1000 unit roundoffs of the
//! largest of their degree measured against that): above it the run fails with
//! [`NormalFormError::PrecisionLost`] naming the first bad degree, or, with `auto_precision`
//! (the command line's default), an f64 run is redone in double-double and
//! [`Diagnostics::precision_note`] says so. At Earth–Moon f64 holds through degree 16 and
//! breaks at 18: the I₁ᵏ coefficients (the short-period family) are 10⁻¹³…10⁻¹⁵ of the
//! largest of their degree and lose to rounding 1.3e-3 (I₁⁹), 6e-3 (I₁⁸I₂), 0.19 (I₁⁹I₂ at
//! degree 20), while the degree as a whole is still good to 4e-8. The imaginary parts left
//! on H̄ ([`Diagnostics::hbar_imag_residual`], 0.7 at order 20) are no measure of this: the
//! brackets are exactly real by construction, and 0.7 is 1e-20 of a degree-20 coefficient.
//! At μ = 0.001 (ω₂ = 0.082) f64 loses the degree-8 coefficients to ~1e-5 and the degree-12
//! ones to a few %, double-double keeps every coefficient through degree 12 to ~1e-17
//! (tests/precision.rs).
//!
//! Whatever the precision, the 2n×2n linear normalisation runs in double-double (A and ω
//! rounded once), the homological quotients `h/(i m·ω)` are correctly rounded with divisors
//! formed in double-double, and in f64 runs the Poisson brackets and the substitution into
//! the complex coordinates are *compensated* up to degree [`Options::compensated_degree`]
//! (12): products and sums of the f64 values by error-free transformations, one rounding per
//! result.
//!
//! ### f64 at Earth–Moon through degree 8
//!
//! `cargo run -p lasalle-normal-form --release --example accuracy -- 0.01215058560962404 8`
//! (and `-- --scan 8`), against double-double:
//!
//! | f64 variant | worst relative error, degrees ≤ 8, at μ_EM | 12 mass ratios μ_EM·(1 + 7·10⁻⁴k) |
//! |---|---|---|
//! | plain arithmetic (`compensated_degree = 0`) | 1.7e-9 (I₁⁴ = 1.2776) | median 2.0e-9, max 3.2e-9 |
//! | compensated (default) | 8.4e-11 (I₁³I₂; I₁⁴ 2.3e-12) | median 2.0e-10, max 4.1e-10 |
//!
//! *Where the rounding comes from.* Not the inputs: rounding the Taylor coefficients of a
//! double-double run to f64 moves I₁⁴ by 1e-12 only. It is made inside the Lie series, in
//! two ways. (i) **Cancellation in the brackets**: `{T, G} = P + conj P` with
//! `P = Σ_k T_{x_k} G_{y_k}` (see the `lie` module), and P is up to 80 times larger than the
//! bracket; the intermediate degree-8 terms reach 2e9 for final coefficients ≤ 5.5e4.
//! Rounding only P to f64 in an otherwise double-double run reproduces the f64 error
//! (1.3e-9 at I₁⁴), almost all of it from the brackets landing in degrees 4 and 5
//! (3.5e-10 and 9.1e-10; degrees ≥ 6: ≤ 4e-11). (ii) **Amplification afterwards**: an error
//! of 1e-13 in the degree-4 part of H after G₃ (5 ulp of its largest coefficient, 1.8e2)
//! moves I₁⁴ by 4.5e-10, through the later small divisors (ω₁ − 3ω₂ = 0.060 next to the 1:3
//! resonance, ω₂ = 0.298). The f64 linear algebra (ω₂ to ~80 ulp from the characteristic
//! polynomial) added another few 1e-10. Compensation removes (i) where it matters, cheaply:
//! the low degrees are small arrays.
//!
//! *Why 1e-10 is not reliably reachable in f64.* What remains is storing the low-degree
//! intermediates in 53 bits at all. In a double-double run, rounding to f64 only H in the
//! complex coordinates moves I₁⁴ by 4.2e-11, only the generators G_r by 2.1e-11, only the
//! links of the Lie chains by 2.5e-11, only H after each generator by 4.9e-12. An f64 run
//! rounds at all of these stages, so its error is a random walk of 1e-11…4e-11 steps: median
//! 2e-10 over the neighbouring mass ratios, and Earth–Moon itself happens to fall at 8.4e-11.
//! Doing better needs the degree ≤ 6 coefficients kept in more than 53 bits, which is
//! [`Precision::DoubleDouble`] (1e-25 here, at 1.3–3.3 times the f64 time).
//!
//! ## Performance
//!
//! Dense per-degree monomial arrays with additive keys ([`MonomialTable`]): products and
//! brackets are index-table lookups, no hashing. Brackets of real functions in the complex
//! coordinates take half the products (`{T, G} = P + conj P`), derivatives enter the
//! products in sparse form, and the complexification is substituted pair by pair.
//! Double-double products run in AVX2 kernels (two complex or four real products per
//! iteration, FMA cross terms; runtime detection, with a scalar FMA fallback that gives the
//! same bits and a plain one without FMA). Earth–Moon L4, best of several runs
//! (`cargo run -p lasalle-normal-form --release --example bench_orders`):
//!
//! | order | f64, H̄ only | dd, H̄ only | ratio | f64, with maps | dd, with maps | ratio |
//! |---:|---:|---:|---:|---:|---:|---:|
//! | 8 | 0.7 ms | 0.8 ms | 1.2 | 1.0 ms | 1.4 ms | 1.3 |
//! | 12 | 3.6 ms | 4.3 ms | 1.2 | 7.7 ms | 10.6 ms | 1.4 |
//! | 16 | 8.1 ms | 17.7 ms | 2.2 | 34 ms | 57 ms | 1.7 |
//! | 20 | 21 ms | 61 ms | 2.9 | 0.14 s | 0.24 s | 1.7 |
//! | 24 | 58 ms | 0.18 s | 3.1 | 0.50 s | 0.81 s | 1.6 |
//! | 28 | 0.14 s | 0.46 s | 3.2 | 1.47 s | 2.28 s | 1.6 |
//! | 32 | 0.33 s | 1.11 s | 3.3 | 3.88 s | 6.02 s | 1.6 |
//!
//! ("H̄ only": `transform(false)`, which still gives the generators in real form; "with
//! maps": also both coordinate transformations. f64 up to order 12 includes the compensated
//! degrees, hence the ratios near 1 there.)
//!
//! Three degrees of freedom, the spatial problem (`models/cr3bp_spatial.lsl`) at Earth–Moon
//! L4, order 16, H̄ only: 0.6 s in double-double (tests/spatial.rs; 164 coefficients, those
//! without the vertical action equal to the planar model's).
#![warn(missing_docs)]

pub mod bound;
pub mod center;
mod complex;
mod dd;
mod emit;
mod error;
mod hamiltonian;
pub mod interval;
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
mod qd;
mod scalar;
pub mod validate;

pub use complex::Complex;
pub use dd::Dd;
pub use error::{Eigenvalue, LoadError, NormalFormError};
pub use hamiltonian::{
    find_equilibrium, null_directions, taylor, Equilibrium, HamiltonianFn, NullDirection,
    DEGENERATE_HESSIAN,
};
pub use interval::Iv;
pub use jet::Jet;
/// Re-exported because they appear in this crate's API: [`HamiltonianFn::eval`] is generic
/// over [`Scalar`], whose `powf` takes a [`Rational`].
pub use lasalle_model::ir::{Rational, Scalar};
pub use model::{
    normalize_model, normalize_model_file, normalize_model_orders, ModelHamiltonian, ModelPoint,
};
pub use monomial::{binomial, MonomialTable};
pub use normal_form::{
    normalize, normalize_orders, ActionTerm, ArnoldMoser, DegreeError, Diagnostics, ErrorEstimate,
    NormalForm, Options, Point, PolyMap, Precision, Progress, Remainder, RemainderPart,
    ResonantTerm, SmallDivisor, Stage, Term, Timings, Value, DEFAULT_MAX_RELATIVE_ERROR, MAX_ORDER,
};
pub use poly::Poly;
pub use qd::Qd;
pub use scalar::{Coeff, Real};

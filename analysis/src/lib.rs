//! # lasalle-analysis
//!
//! The analyses lasalle runs on a model, beyond integrating it. Each works on the front end's
//! [`Model`](lasalle_model::Model) (its expression DAG, for symbolic derivatives) and, where it
//! integrates, on a loaded model of [`lasalle_exec`]:
//!
//! - [`lie_poisson`]: equilibria of Lie–Poisson models on so(3)* and their stability by the
//!   energy–Casimir method, on one Casimir level or swept over a range (`lasalle stability` on
//!   an so(3) model);
//! - [`canonical`]: stability of an equilibrium of a canonical Hamiltonian model from its
//!   Birkhoff normal form, with finite-time tube bounds (`lasalle stability --time-bound`);
//! - [`attraction`]: domains of attraction of a planar equilibrium, estimated by sublevel sets
//!   of Lyapunov functions and compared with the stable manifolds of the saddles around it
//!   (`lasalle stability` on a dissipative planar model);
//! - [`stability`]: the analysis a model's structure chooses (one of the three above), as
//!   `lasalle stability` runs it, with typed results and their JSON
//!   ([`stability::StabilityReport::to_json`]);
//! - [`closed_forms`]: the closed-form extremals of the SO(3) optimal-control problems, as
//!   corrected and as printed in the thesis they come from;
//! - [`feedback_hypotheses`]: the hypotheses of the feedback-integrator paper's lemmas and
//!   theorems (Df's rank on V⁻¹(0), the bounds on c, Theorem 3.9's common root, the rigid
//!   body's period) computed for its §4 systems (`lasalle experiment`);
//! - [`infante`]: Infante's quadratic Liapunov functions of the n-th order linear equation,
//!   AᵀB + BA = −C solved for the companion matrix symbolically in its coefficients;
//! - [`multipliers`]: Lagrange multipliers and Euler–Lagrange equations carried across a
//!   coordinate change given in the IR (λ = Jᵀσ), with the plumb-line and flight-path frames of
//!   a thrusting vehicle;
//! - [`primer`]: the primer vector (the Lagrange multipliers of the minimum-fuel problem) on a
//!   Kepler coast arc in closed form, for every eccentricity.
//!
//! The derivations, the checks and the measured numbers are in `docs/stability.md` and
//! `docs/so3.md`.
#![warn(missing_docs)]

pub mod attraction;
pub mod canonical;
pub mod closed_forms;
pub mod feedback_hypotheses;
pub mod infante;
pub mod lie_poisson;
pub mod multipliers;
pub mod primer;
pub mod stability;

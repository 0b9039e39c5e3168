// models/so3_type_iib.lsl — Type IIb optimal control on SO(3): ġ = g(E3 + u1 E1 + u2 E2),
// cost ½∫ (c1 u1² + c2 u2²), c1, c2 > 0 (path planning on SO(3), §3.2).
// Rodgerson (2009), ch. 6, Theorem 6.2.1: u1 = P1/c1, u2 = P2/c2 (6.3) and
// H = ½ (P1²/c1 + P2²/c2) + P3 (6.4); the extremal equations (6.5)–(6.7) are
//     Ṗ1 = P2 − P2 P3/c2,   Ṗ2 = −P1 + P1 P3/c1,   Ṗ3 = (c1 − c2)/(c1 c2) P1 P2.
// Convention: Lie–Poisson with {P1, P2} = −P3, {P2, P3} = −P1, {P3, P1} = −P2 (3.11), i.e. the
// minus bracket {F, G}(P) = −P · (∇F × ∇G), so Ṗ = {P, H} = P × ∇H — what
// `lie_poisson_so3(P)` generates. Derived from (6.4) this way, (6.5)–(6.7) hold as printed (and
// as in the thesis' TypeIIb.m), with no sign or factor discrepancy.
// Reconstruction ġ = g Ξ, Ξ = hat(∇H) = hat(u1, u2, 1). Then d/dt (g P) = g (∇H × P + P × ∇H) = 0
// identically (without using gᵀg = I): g P is the spatial momentum, the vector of the thesis'
// (3.12) g P g⁻¹ = Λ (hat(g P) = g hat(P) g⁻¹ for g ∈ SO(3)).
// Erratum (not in the field): for c1 = c2 = c, Prop. 6.3.1's closed form
// P2 = √k1 sin((1 − k2/c) t + k3), k3 = −atan(P2(0)/P1(0)), has the wrong sign (it gives
// P2(0) → −P2(0)); the rotation matrix in its proof is right: (P1, P2) turns by −(1 − P3/c) t.
model So3TypeIib {
    state P: vec3, g: mat3;
    param c1 = 1.0;                                 // Appendix B, case C.6
    param c2 = 0.5;

    hamiltonian H = P[0]^2 / (2 * c1) + P[1]^2 / (2 * c2) + P[2];    // (6.4)
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H (6.5)–(6.7); Casimir |P|²

    let u1 = P[0] / c1;                             // the optimal controls (6.3)
    let u2 = P[1] / c2;
    d/dt g = g * hat([u1, u2, 1]);                  // reconstruction (6.2): ġ = g (E3 + u1 E1 + u2 E2)
    constraint orthogonality = transpose(g) * g - eye(3);
    integral Lambda = g * P;                        // (3.12): hat(g P) = g P g⁻¹ = Λ

    // Appendix B / C, Type IIb. A point carries only the state: the cases' c1, c2 are in the
    // comments (and in the `run` presets below); the defaults are C.6's. P(0) is the one the
    // thesis integrates (its ode45 calls, 4 decimals) and that its elliptic solutions (Section 2)
    // fit; the captions of Figures C.6 and C.8 print P1(0), P2(0) too large by a factor √2 (C.6:
    // P2(0) = 11√3/16 ≈ 1.1908, ode45 0.8420 = 11√6/32; C.8: (√17/2, √5/4, ½), ode45 (1.4577,
    // 0.3953, 0.5) = (√34/4, √10/8, ½)).
    point case_c6 { P = [1 / (2 * sqrt(2)), 11 * sqrt(6) / 32, 5 / 32]; g = eye(3); } // CASE (I) first part:   c1 = 1, c2 = 1/2, t ∈ [0, 10] (3-D plot [0, 30])
    point case_c7 { P = [sqrt(3 / 2), 2 * sqrt(2), -1]; g = eye(3); }                  // CASE (I) second part:  c1 = 1, c2 = 1/2, t ∈ [0, 10]
    point case_c8 { P = [sqrt(34) / 4, sqrt(10) / 8, 1 / 2]; g = eye(3); }            // CASE (II) first part:  c1 = 1, c2 = 2,   t ∈ [0, 10] (3-D plot [0, 30])
    point case_c9 { P = [2 * sqrt(5), 1, -2]; g = eye(3); }                            // CASE (II) second part: c1 = 1, c2 = 2,   t ∈ [0, 10]

    // The Appendix B cases with their parameters: `lasalle run <model> --preset case_cN`
    run case_c6 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c6; c1 = 1; c2 = 1/2; }
    run case_c7 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c7; c1 = 1; c2 = 1/2; }
    run case_c8 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c8; c1 = 1; c2 = 2; }
    run case_c9 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c9; c1 = 1; c2 = 2; }
}

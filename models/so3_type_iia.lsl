// models/so3_type_iia.lsl — Type IIa optimal control on SO(3): ġ = g(u1 E1 + u2 E2),
// cost ½∫ (c1 u1² + c2 u2²), c1, c2 > 0.
// Rodgerson (2009), ch. 5, Theorem 5.2.1: u1 = P1/c1, u2 = P2/c2 (5.3) and
// H = ½ (P1²/c1 + P2²/c2) (5.4); the extremal equations (5.5)–(5.7) are
//     Ṗ1 = −P2 P3/c2,   Ṗ2 = P1 P3/c1,   Ṗ3 = (c1 − c2)/(c1 c2) P1 P2.
// Convention: Lie–Poisson with {P1, P2} = −P3, {P2, P3} = −P1, {P3, P1} = −P2 (3.11), i.e. the
// minus bracket {F, G}(P) = −P · (∇F × ∇G), so Ṗ = {P, H} = P × ∇H — what
// `lie_poisson_so3(P)` generates. Derived from (5.4) this way, (5.5)–(5.7) hold as printed (and
// as in the thesis' TypeIIa.m), with no sign or factor discrepancy.
// Reconstruction ġ = g Ξ, Ξ = hat(∇H) = hat(u1, u2, 0). Then d/dt (g P) = g (∇H × P + P × ∇H) = 0
// identically (without using gᵀg = I): g P is the spatial momentum, the vector of the thesis'
// (3.12) g P g⁻¹ = Λ (hat(g P) = g hat(P) g⁻¹ for g ∈ SO(3)).
model So3TypeIia {
    state P: vec3, g: mat3;
    param c1 = 4.0;                                 // Appendix B, case C.2
    param c2 = 1.0;

    hamiltonian H = P[0]^2 / (2 * c1) + P[1]^2 / (2 * c2);    // (5.4)
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H (5.5)–(5.7); Casimir |P|²

    let u1 = P[0] / c1;                             // the optimal controls (5.3)
    let u2 = P[1] / c2;
    d/dt g = g * hat([u1, u2, 0]);                  // reconstruction (5.2): ġ = g (u1 E1 + u2 E2)
    constraint orthogonality = transpose(g) * g - eye(3);
    integral Lambda = g * P;                        // (3.12): hat(g P) = g P g⁻¹ = Λ

    // Appendix B / C, Type IIa, all ode45 on [0, 10]. A point carries only the state: the
    // cases' c1, c2 are in the comments (and in the `run` presets below); the defaults are C.2's.
    point case_c2 { P = [2, 2, 4]; g = eye(3); }    // CASE (I) first part:   c1 = 4, c2 = 1, t ∈ [0, 10]
    point case_c3 { P = [4, 2, 2]; g = eye(3); }    // CASE (I) second part:  c1 = 4, c2 = 1, t ∈ [0, 10]
    point case_c4 { P = [1, 2, 3]; g = eye(3); }    // CASE (II) first part:  c1 = 1, c2 = 4, t ∈ [0, 10]
    point case_c5 { P = [3, 2, 1]; g = eye(3); }    // CASE (II) second part: c1 = 1, c2 = 4, t ∈ [0, 10]

    // The Appendix B cases with their parameters: `lasalle run <model> --preset case_cN`
    run case_c2 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c2; c1 = 4; c2 = 1; }
    run case_c3 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c3; c1 = 4; c2 = 1; }
    run case_c4 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c4; c1 = 1; c2 = 4; }
    run case_c5 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c5; c1 = 1; c2 = 4; }
}

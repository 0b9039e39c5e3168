// models/so3_type_iii.lsl — Type III optimal control on SO(3): ġ = g(u1 E1 + u2 E2 + u3 E3),
// cost ½∫ (c1 u1² + c2 u2² + c3 u3²), c1, c2, c3 > 0 (the free rigid body's extremals).
// Rodgerson (2009), ch. 7, Theorem 7.2.1: ui = Pi/ci (7.3) and H = ½ Σ Pi²/ci (7.4); the
// extremal equations (7.5)–(7.7) are
//     Ṗ1 = (c2 − c3)/(c2 c3) P2 P3,   Ṗ2 = (c3 − c1)/(c1 c3) P1 P3,   Ṗ3 = (c1 − c2)/(c1 c2) P1 P2.
// Convention: Lie–Poisson with {P1, P2} = −P3, {P2, P3} = −P1, {P3, P1} = −P2 (3.11), i.e. the
// minus bracket {F, G}(P) = −P · (∇F × ∇G), so Ṗ = {P, H} = P × ∇H — what
// `lie_poisson_so3(P)` generates. Derived from (7.4) this way, (7.5)–(7.7) hold as printed (and
// as in the thesis' TypeIII.m), with no sign or factor discrepancy.
// Reconstruction ġ = g Ξ, Ξ = hat(∇H) = hat(u1, u2, u3). Then d/dt (g P) = g (∇H × P + P × ∇H) = 0
// identically (without using gᵀg = I): g P is the spatial momentum, the vector of the thesis'
// (3.12) g P g⁻¹ = Λ (hat(g P) = g hat(P) g⁻¹ for g ∈ SO(3)).
// Erratum (not in the field): for c1 = c2 = c ≠ c3, (7.5)–(7.7) make P3 constant and (P1, P2)
// turn by the angle −(c − c3)/(c c3) P3(0) t; Prop. 7.3.2 prints cosh/sinh instead, with
// different arguments in the diagonal and off-diagonal entries (the diagonal one is real, so its
// cosh grows).
model So3TypeIii {
    state P: vec3, g: mat3;
    param c1 = 3.0;                                 // Appendix B, case C.10
    param c2 = 2.0;
    param c3 = 4.0;

    hamiltonian H = P[0]^2 / (2 * c1) + P[1]^2 / (2 * c2) + P[2]^2 / (2 * c3);    // (7.4)
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H (7.5)–(7.7); Casimir |P|²

    let u1 = P[0] / c1;                             // the optimal controls (7.3)
    let u2 = P[1] / c2;
    let u3 = P[2] / c3;
    d/dt g = g * hat([u1, u2, u3]);                 // reconstruction (7.2): ġ = g (u1 E1 + u2 E2 + u3 E3)
    constraint orthogonality = transpose(g) * g - eye(3);
    integral Lambda = g * P;                        // (3.12): hat(g P) = g P g⁻¹ = Λ

    // Appendix B / C, Type III, all ode45 on [0, 30]. A point carries only the state: the cases'
    // c1, c2, c3 are in the comments and in the `run` presets below; the defaults are C.10's.
    point case_c10 { P = [0, 1, 2]; g = eye(3); }           // CASE 1A(I) first part:   c1 = 3, c2 = 2,   c3 = 4, t ∈ [0, 30]
    point case_c11 { P = [0, 2, 1]; g = eye(3); }           // CASE 1A(I) second part:  c1 = 3, c2 = 2,   c3 = 4, t ∈ [0, 30]
    point case_c12 { P = [1, 1, 2]; g = eye(3); }           // CASE 1A(II) first part:  c1 = 1, c2 = 2,   c3 = 3, t ∈ [0, 30]
    point case_c13 { P = [1, 1, 1]; g = eye(3); }           // CASE 1A(II) second part: c1 = 1, c2 = 2,   c3 = 3, t ∈ [0, 30]
    point case_c14 { P = [1, 1, 1]; g = eye(3); }           // CASE 1B(I) first part:   c1 = 2, c2 = 3,   c3 = 1, t ∈ [0, 30]
    point case_c15 { P = [1, 2, 1]; g = eye(3); }           // CASE 1B(I) second part:  c1 = 2, c2 = 3,   c3 = 1, t ∈ [0, 30]
    point case_c16 { P = [1, 1, 1]; g = eye(3); }           // CASE 1B(II) first part:  c1 = 3, c2 = 2,   c3 = 1, t ∈ [0, 30]
    point case_c17 { P = [2, 1, 1]; g = eye(3); }           // CASE 1B(II) second part: c1 = 3, c2 = 2,   c3 = 1, t ∈ [0, 30]
    point case_c18 { P = [sqrt(3), 1, 1]; g = eye(3); }     // CASE 2 (c2 < c3 < c1):   c1 = 2, c2 = 1/2, c3 = 1, t ∈ [0, 30]
    point case_c19 { P = [2, 2, 2]; g = eye(3); }           // CASE 2 (c1 < c3 < c2):   c1 = 1, c2 = 3,   c3 = 2, t ∈ [0, 30]

    // The Appendix B cases with their parameters: `lasalle run <model> --preset case_cN`
    run case_c10 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c10; c1 = 3; c2 = 2; c3 = 4; }
    run case_c11 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c11; c1 = 3; c2 = 2; c3 = 4; }
    run case_c12 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c12; c1 = 1; c2 = 2; c3 = 3; }
    run case_c13 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c13; c1 = 1; c2 = 2; c3 = 3; }
    run case_c14 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c14; c1 = 2; c2 = 3; c3 = 1; }
    run case_c15 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c15; c1 = 2; c2 = 3; c3 = 1; }
    run case_c16 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c16; c1 = 3; c2 = 2; c3 = 1; }
    run case_c17 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c17; c1 = 3; c2 = 2; c3 = 1; }
    run case_c18 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c18; c1 = 2; c2 = 1/2; c3 = 1; }
    run case_c19 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c19; c1 = 1; c2 = 3; c3 = 2; }
}

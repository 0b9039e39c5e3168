// models/so3_type_i.lsl — Type I optimal control on SO(3): ġ = g(E3 + u E1), cost ½∫ c1 u²
// Rodgerson (2009), ch. 4: the extremals are Lie–Poisson on so(3)* with
// H = P1²/(2 c1) + P3 and Casimir |P|², u = P1/c1; g is reconstructed on SO(3).
// Convention: {P1, P2} = −P3, {P2, P3} = −P1, {P3, P1} = −P2 (3.11), i.e. Ṗ = {P, H} = P × ∇H,
// which gives (4.5)–(4.7) as printed: Ṗ1 = P2, Ṗ2 = −P1 + P1 P3/c1, Ṗ3 = −P1 P2/c1.
// With Ξ = hat(∇H) = hat(u, 0, 1), d/dt (g P) = g (∇H × P + P × ∇H) = 0 identically: g P is the
// spatial momentum, the vector of the thesis' (3.12) g P g⁻¹ = Λ (hat(g P) = g hat(P) g⁻¹).
model So3TypeI {
    state P: vec3, g: mat3;
    param c1 = 2.0;

    hamiltonian H = P[0]^2 / (2 * c1) + P[2];
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H, the Casimir |P|² is automatic

    let u = P[0] / c1;                              // the optimal control
    d/dt g = g * hat([u, 0, 1]);                    // reconstruction: ġ = g (u E1 + E3)
    constraint orthogonality = transpose(g) * g - eye(3);
    integral Lambda = g * P;                        // (3.12): hat(g P) = g P g⁻¹ = Λ

    // Appendix B: c1 = 2, P(0) = (4, 0, 1)
    point thesis { P = [4, 0, 1]; g = eye(3); }
    // the same, named as the other types' cases (Figure C.1): c1 = 2, ode45 on t ∈ [0, 10]
    point case_c1 { P = [4, 0, 1]; g = eye(3); }

    // Appendix B, C.1: c1 = 2 on [0, 10]
    run case_c1 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c1; c1 = 2; }
}

// models/so3_type_i.lsl — Type I optimal control on SO(3): ġ = g(E3 + u E1), cost ½∫ c1 u²
// Rodgerson (2009), ch. 4: the extremals are Lie–Poisson on so(3)* with
// H = P1²/(2 c1) + P3 and Casimir |P|², u = P1/c1; g is reconstructed on SO(3).
model So3TypeI {
    state P: vec3, g: mat3;
    param c1 = 2.0;

    hamiltonian H = P[0]^2 / (2 * c1) + P[2];
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H, the Casimir |P|² is automatic

    let u = P[0] / c1;                              // the optimal control
    d/dt g = g * hat([u, 0, 1]);                    // reconstruction: ġ = g (u E1 + E3)
    constraint orthogonality = transpose(g) * g - eye(3);

    // Appendix B: c1 = 2, P(0) = (4, 0, 1)
    point thesis { P = [4, 0, 1]; g = eye(3); }
}

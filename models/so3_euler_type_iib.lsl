// models/so3_euler_type_iib.lsl — Type IIb on SO(3) in Euler angles: Prop. 6.5.1 of Rodgerson
// (2009), as printed (it is right). The extremal P(t) is that of models/so3_type_iib.lsl
// (Ṗ = P × ∇H, H = ½ (P1²/c1 + P2²/c2) + P3, ui = Pi/ci, ġ = g(E3 + u1 E1 + u2 E2)); instead
// of the 3×3 matrix g, the state carries the three angles of the thesis' coordinates (3.4), (6.23):
//     g = exp(φ1 Λ/√K) exp(φ2 E2) exp(φ3 E3),   Λ = g P g⁻¹ (constant, (3.12)), K = |P|²,
// i.e. g = R_n(φ1) R_y(φ2) R_z(φ3): a turn by φ1 about the constant unit vector n = g P/|P|
// (the axis of Λ, a parameter here: for g(0) = I it is P(0)/|P(0)|), then φ2 about e2, then φ3
// about e3 (Ei = hat(ei); exp(φ E2) = [[cos φ, 0, sin φ], [0, 1, 0], [−sin φ, 0, cos φ]]).
// (This is not the "x-y-z convention" that §2 describes in words.)
// ġ = g Ξ with Ξ = hat(∇H) and g⁻¹ n = P/√K give the linear system of the proposition's proof,
//     (P/√K) φ̇1 + (sin φ3, cos φ3, 0) φ̇2 + e3 φ̇3 = ∇H = (P1/c1, P2/c2, 1),
// with determinant P1 cos φ3 − P2 sin φ3 = −D. Its solution, with X = (c2 − c1)/c1 · P1 cos φ3/D:
//     φ̇1 = √K/c2 (1 − X),   φ̇2 = (c2 − c1)/(c1 c2) · P1 P2/D,   φ̇3 = 1 − P3/c2 (1 − X).
// The chart is singular where D = 0; unless n ⊥ e2 the angles reach that set in finite time on
// many orbits (the map φ ↦ g then has a fold there; C.6, C.7, C.8 with g(0) = I at t ≈ 0.6,
// 0.5, 5.5), hence the guard.
// The constraint (g(φ) P/√K = n: the spatial momentum (3.12) fixed) is what the angles encode;
// the generator checks that this field keeps it.
model So3EulerTypeIib {
    state phi: vec3, P: vec3;
    param c1 = 1.0;                                 // Appendix B, case C.9
    param c2 = 2.0;
    param n = [2 * sqrt(5), 1, -2] / 5;             // the unit axis of Λ: P(0)/|P(0)| for g(0) = I

    hamiltonian H = P[0]^2 / (2 * c1) + P[1]^2 / (2 * c2) + P[2];    // (6.4)
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H (6.5)–(6.7); Casimir |P|²

    let sqrtK = norm(P);
    let s3 = sin(phi[2]);
    let co3 = cos(phi[2]);
    let D = P[1] * s3 - P[0] * co3;
    let X = (c2 - c1) / c1 * P[0] * co3 / D;
    d/dt phi = [
        sqrtK / c2 * (1 - X),
        (c2 - c1) / (c1 * c2) * P[0] * P[1] / D,
        1 - P[2] / c2 * (1 - X)
    ];

    // g(φ) = R_n(φ1) R_y(φ2) R_z(φ3) (Rodrigues: R_a(θ) = I + sin θ hat(a) + (1 − cos θ) hat(a)²)
    let Rn = eye(3) + sin(phi[0]) * hat(n) + (1 - cos(phi[0])) * hat(n) * hat(n);
    let Ry = eye(3) + sin(phi[1]) * hat([0, 1, 0]) + (1 - cos(phi[1])) * hat([0, 1, 0]) * hat([0, 1, 0]);
    let Rz = eye(3) + sin(phi[2]) * hat([0, 0, 1]) + (1 - cos(phi[2])) * hat([0, 0, 1]) * hat([0, 0, 1]);
    constraint spatial_momentum = Rn * Ry * Rz * P / sqrtK - n;     // (3.12): g P g⁻¹ = Λ = √K hat(n)
    guard chart: D^2 >= 1e-6 * dot(P, P);          // the coordinates (6.23) break down at D = 0

    // Appendix B, C.9 (c = (1, 2), P(0) = (2√5, 1, −2)) with g(0) = I: φ(0) = 0, n = P(0)/|P(0)|
    point case_c9 { phi = [0, 0, 0]; P = [2 * sqrt(5), 1, -2]; }
    run case_c9 { method = dopri5; dt = 1e-3; t_end = 10; init = case_c9; c1 = 1; c2 = 2; }
}

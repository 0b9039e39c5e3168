// models/so3_euler_type_iii.lsl — Type III on SO(3) in Euler angles: Prop. 7.5.1 of Rodgerson
// (2009), with its φ̇3 corrected. The extremal P(t) is that of models/so3_type_iii.lsl
// (Ṗ = P × ∇H, H = ½ Σ Pi²/ci, ui = Pi/ci); instead of the 3×3 matrix g, the state carries the
// three angles of the thesis' coordinates (3.4), (7.29):
//     g = exp(φ1 Λ/√K) exp(φ2 E2) exp(φ3 E3),   Λ = g P g⁻¹ (constant, (3.12)), K = |P|²,
// i.e. g = R_n(φ1) R_y(φ2) R_z(φ3): a turn by φ1 about the constant unit vector n = g P/|P|
// (the axis of Λ, a parameter here: for g(0) = I it is P(0)/|P(0)|), then φ2 about e2, then φ3
// about e3 (Ei = hat(ei); exp(φ E2) = [[cos φ, 0, sin φ], [0, 1, 0], [−sin φ, 0, cos φ]]).
// (This is not the "x-y-z convention" that §2 describes in words.)
// ġ = g Ξ with Ξ = hat(∇H) and g⁻¹ n = P/√K give the linear system of the proposition's proof,
//     (P/√K) φ̇1 + (sin φ3, cos φ3, 0) φ̇2 + e3 φ̇3 = ∇H = (P1/c1, P2/c2, P3/c3),
// with determinant P1 cos φ3 − P2 sin φ3 = −D. Its solution, with X = (c2 − c1)/c1 · P1 cos φ3/D:
//     φ̇1 = √K/c2 (1 − X),   φ̇2 = (c2 − c1)/(c1 c2) · P1 P2/D        (as printed)
//     φ̇3 = P3/c3 − P3 φ̇1/√K = (c2 − c3)/(c2 c3) P3 + P3 X/c2        (corrected)
// Erratum: the thesis prints φ̇3 = (c2 − c3)/(c2 c3) P3 (1 − X), which is the above minus
// P3 X/c3 (the factor (1 − X) multiplies P3/c3 too, which the third equation does not have);
// right only for c1 = c2. Against ġ = gΞ it is off by O(1) within a few time units (docs/so3.md).
// The chart is singular where D = 0; unless n ⊥ e2 (n = ±e1 or ±e3, …) the angles reach that
// set in finite time on many orbits (the map φ ↦ g then has a fold there), hence the guard.
// The constraint (g(φ) P/√K = n: the spatial momentum (3.12) fixed) is what the angles encode;
// the generator checks that this field keeps it.
model So3EulerTypeIii {
    state phi: vec3, P: vec3;
    param c1 = 1.0;                                 // Appendix B, case C.12
    param c2 = 2.0;
    param c3 = 3.0;
    param n = [1, 1, 2] / sqrt(6);                  // the unit axis of Λ: P(0)/|P(0)| for g(0) = I

    hamiltonian H = P[0]^2 / (2 * c1) + P[1]^2 / (2 * c2) + P[2]^2 / (2 * c3);    // (7.4)
    structure lie_poisson_so3(P);                   // Ṗ = P × ∇H (7.5)–(7.7); Casimir |P|²

    let sqrtK = norm(P);
    let s3 = sin(phi[2]);
    let co3 = cos(phi[2]);
    let D = P[1] * s3 - P[0] * co3;
    let X = (c2 - c1) / c1 * P[0] * co3 / D;
    let phi1_dot = sqrtK / c2 * (1 - X);
    d/dt phi = [
        phi1_dot,
        (c2 - c1) / (c1 * c2) * P[0] * P[1] / D,
        P[2] / c3 - P[2] * phi1_dot / sqrtK         // Prop. 7.5.1 prints (c2 − c3)/(c2 c3) P3 (1 − X)
    ];

    // g(φ) = R_n(φ1) R_y(φ2) R_z(φ3) (Rodrigues: R_a(θ) = I + sin θ hat(a) + (1 − cos θ) hat(a)²)
    let Rn = eye(3) + sin(phi[0]) * hat(n) + (1 - cos(phi[0])) * hat(n) * hat(n);
    let Ry = eye(3) + sin(phi[1]) * hat([0, 1, 0]) + (1 - cos(phi[1])) * hat([0, 1, 0]) * hat([0, 1, 0]);
    let Rz = eye(3) + sin(phi[2]) * hat([0, 0, 1]) + (1 - cos(phi[2])) * hat([0, 0, 1]) * hat([0, 0, 1]);
    constraint spatial_momentum = Rn * Ry * Rz * P / sqrtK - n;     // (3.12): g P g⁻¹ = Λ = √K hat(n)
    guard chart: D^2 >= 1e-6 * dot(P, P);          // the coordinates (7.29) break down at D = 0

    // Appendix B, C.12 (c = (1, 2, 3), P(0) = (1, 1, 2)) with g(0) = I: φ(0) = 0, n = P(0)/|P(0)|
    point case_c12 { phi = [0, 0, 0]; P = [1, 1, 2]; }
    run case_c12 { method = dopri5; dt = 1e-3; t_end = 30; init = case_c12; c1 = 1; c2 = 2; c3 = 3; }
}

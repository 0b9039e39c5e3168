// models/min_time.lsl — minimum-time transfer to the origin with discontinuous feedback:
// Example 1 of H. Hermes, "Discontinuous vector fields and feedback control" (the second
// paper of NASA TM X-53478, Progress Report No. 8, Marshall Space Flight Center, 1966):
//     ẋ₁ = u₁,  ẋ₂ = u₂,  |u₁| + |u₂| ≤ 1,  target the origin,
// reached at best in time |x₁⁰| + |x₂⁰|. Two feedback laws synthesized from open-loop
// strategies, selected by the parameter `strategy`:
//   Strategy 1: u = (−1, 0) for x₁ > 0, x₂ ≥ 0;  (0, −1) for x₁ ≤ 0, x₂ > 0;
//               (1, 0) for x₁ < 0, x₂ ≤ 0;   (0, 1) for x₁ ≥ 0, x₂ < 0;   0 at the origin.
//   Strategy 2: u = (0, −1) for x₂ > 0;  (−1, 0) for x₂ = 0, x₁ > 0;  (1, 0) for x₂ = 0, x₁ < 0;
//               (0, 1) for x₂ < 0;  0 at the origin.
// From (1, 1) both reach the origin at t = 2 as classical solutions; in the sense of Filippov
// Strategy 1 still does, while Strategy 2 comes to rest at (1, 0) at t = 1: its first
// component is nonzero only on the x₁-axis, a set of measure zero (docs/switching.md).
model MinTime {
    state x1: scalar, x2: scalar;
    param strategy = 1;                       // 1 or 2

    let s1 = sign(x1);
    let s2 = sign(x2);
    // indicators of g > 0, g < 0, g ≥ 0, g ≤ 0 from s = sign(g) ∈ {−1, 0, 1}
    let pos1 = (s1 + s1^2) / 2;
    let neg1 = (s1^2 - s1) / 2;
    let pos2 = (s2 + s2^2) / 2;
    let neg2 = (s2^2 - s2) / 2;

    let u1_strategy1 = -pos1 * (1 - neg2) + neg1 * (1 - pos2);
    let u2_strategy1 = -(1 - pos1) * pos2 + (1 - neg1) * neg2;

    // Strategy 2: u = (−(1 − s2²) s1, −s2)
    d/dt x1 = (2 - strategy) * u1_strategy1 - (strategy - 1) * (1 - s2^2) * s1;
    d/dt x2 = (2 - strategy) * u2_strategy1 - (strategy - 1) * s2;

    point start { x1 = 1; x2 = 1; }

    run strategy1 { method = dopri5; t_end = 3; init = start; strategy = 1; }
    run strategy2 { method = dopri5; t_end = 3; init = start; strategy = 2; }
}

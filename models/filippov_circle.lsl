// models/filippov_circle.lsl — Example 2 of H. Hermes, "Discontinuous vector fields and
// feedback control" (NASA TM X-53478, 1966, second paper):
//     ẋ₁ = x₂,  ẋ₂ = −x₁ + u,  0 ≤ u ≤ 1,
// with the control synthesized from the open-loop strategy "u = 0 until the circle
// (x₁ − 1)² + x₂² = 1 is reached, then u = 1": u(x) = 1 on that circle and 0 elsewhere. With
// u = 0 the motion turns about the origin; on the circle u = 1 turns it about (1, 0), along the
// circle, through the origin. Classical solutions reach the origin that way, at zero cost;
// in the sense of Filippov u = 1 on a set of measure zero does not count, K[X] = (x₂, −x₁),
// and |x(t)| = |x(0)| for ever (docs/switching.md).
model FilippovCircle {
    state x1: scalar, x2: scalar;

    let on_circle = 1 - sign((x1 - 1)^2 + x2^2 - 1)^2;     // 1 on the circle, 0 off it

    d/dt x1 = x2;
    d/dt x2 = -x1 + on_circle;

    point start { x1 = 0; x2 = 1.5; }

    run start { method = dopri5; t_end = 8; init = start; }
}

// models/duffing.lsl — the Duffing equation with damping, (24) of the domain-of-attraction
// survey in NASA TM X-53478 (Progress Report No. 8, Marshall Space Flight Center, 1966, third
// paper: "estimating the domain of attraction … optimal quadratic form Liapunov functions"):
//     ẋ₁ = x₂,  ẋ₂ = −ε₁x₂ − x₁ + ε₂x₁³,
// with the paper's ε₁ = 1, ε₂ = 0.04 (its Figs. 3 and 5–12). The origin is asymptotically
// stable; (±1/√ε₂, 0) = (±5, 0) are saddles whose stable manifolds bound its domain of
// attraction. `lasalle stability models/duffing.lsl` estimates that domain (docs/stability.md).
model Duffing {
    state x1: scalar, x2: scalar;
    param eps1 = 1;                                     // damping ε₁
    param eps2 = 0.04;                                  // softening cubic spring ε₂

    d/dt x1 = x2;
    d/dt x2 = -eps1 * x2 - x1 + eps2 * x1^3;

    // The energy of the undamped system, the paper's comparison Liapunov function (38):
    // along the damped motion its rate is −ε₁x₂² ≤ 0.
    let energy = x2^2 / 2 + x1^2 / 2 - eps2 * x1^4 / 4;

    point origin { x1 = 0; x2 = 0; }
    point saddle { x1 = 1 / sqrt(eps2); x2 = 0; }
    // inside the optimal estimate (37), ½x₁² + ½x₁x₂ + ¼x₂² = 12.25 < 12.5, and outside the
    // energy estimate (38): E = 24.5 > 6.25
    point inside { x1 = 0; x2 = 7; }

    run inside { method = dopri5; dt = 0.01; t_end = 30; init = inside; }
}

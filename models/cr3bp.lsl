// models/cr3bp.lsl — the planar circular restricted three-body problem in the rotating frame
// NASA TM X-53478 (1965), first paper, eq. (6): normalised units (G = 1, m1 + m2 = 1,
// distance 1, angular velocity 1), mu = m2. Primaries at (−mu, 0) and (1 − mu, 0).
model CR3BP {
    state q: vec2, p: vec2;
    param mu = 0.01215058560962404;                 // Earth–Moon

    let r1 = norm(q - [-mu, 0]);                    // distance to the primary m1 = 1 − mu
    let r2 = norm(q - [1 - mu, 0]);                 // distance to the secondary m2 = mu

    hamiltonian H = dot(p, p) / 2 + q[1] * p[0] - q[0] * p[1] - (1 - mu) / r1 - mu / r2;
    structure canonical(q, p);                      // q̇ = ∂H/∂p, ṗ = −∂H/∂q; H is the Jacobi integral

    // The section y = 0 crossed upwards (ẏ = p₁ − q₀ > 0), plotted in (x, ẋ = p₀ + q₁)
    event section: q[1] = 0 rising;

    // The Lagrange point L4, leading the secondary by 60°.
    point L4 { q = [0.5 - mu, sqrt(3) / 2]; p = [-sqrt(3) / 2, 0.5 - mu]; }
    // A small libration about L4 (displaced by 0.01 along x): `lasalle run cr3bp --init near_L4`.
    point near_L4 { q = [0.51 - mu, sqrt(3) / 2]; p = [-sqrt(3) / 2, 0.5 - mu]; }

    run near_L4 { method = feedback_rk4; dt = 1e-3; t_end = 100; init = near_L4; }
}

// models/cr3bp_spatial.lsl — the spatial circular restricted three-body problem in the rotating frame
// Same conventions as models/cr3bp.lsl (NASA TM X-53478 (1965), first paper, eq. (6), extended
// by the out-of-plane coordinate): normalised units (G = 1, m1 + m2 = 1, distance 1, angular
// velocity 1 about the q[2] axis), mu = m2, primaries at (−mu, 0, 0) and (1 − mu, 0, 0).
// The plane q[2] = p[2] = 0 is invariant and carries models/cr3bp.lsl.
model CR3BPSpatial {
    state q: vec3, p: vec3;
    param mu = 0.01215058560962404;                 // Earth–Moon

    let r1 = norm(q - [-mu, 0, 0]);                 // distance to the primary m1 = 1 − mu
    let r2 = norm(q - [1 - mu, 0, 0]);              // distance to the secondary m2 = mu

    hamiltonian H = dot(p, p) / 2 + q[1] * p[0] - q[0] * p[1] - (1 - mu) / r1 - mu / r2;
    structure canonical(q, p);                      // q̇ = ∂H/∂p, ṗ = −∂H/∂q; H is the Jacobi integral

    // The Lagrange point L4, leading the secondary by 60° in the plane of the primaries; its
    // vertical oscillation has frequency exactly 1 (r1 = r2 = 1 there).
    point L4 { q = [0.5 - mu, sqrt(3) / 2, 0]; p = [-sqrt(3) / 2, 0.5 - mu, 0]; }
    // A small libration about L4, displaced by 0.01 along x and by 0.01 out of the plane:
    // `lasalle run cr3bp_spatial --init near_L4`.
    point near_L4 { q = [0.51 - mu, sqrt(3) / 2, 0.01]; p = [-sqrt(3) / 2, 0.5 - mu, 0]; }

    run near_L4 { method = dopri5; dt = 1e-3; t_end = 100; init = near_L4; }
}

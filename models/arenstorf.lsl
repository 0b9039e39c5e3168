// models/arenstorf.lsl — Arenstorf's periodic orbit of the restricted three-body problem
// Hairer, Nørsett & Wanner, "Solving Ordinary Differential Equations I", §II.0, eq. (0.1):
// the planar circular restricted problem in the rotating frame (Earth of mass 1 − mu at
// (−mu, 0), Moon of mass mu at (1 − mu, 0)), with the initial values (0.2) of a closed orbit
// of period T = 17.0652165601579625588917206249.
model Arenstorf {
    state x: vec2, v: vec2;
    param mu = 0.012277471;

    let r1 = norm(x - [-mu, 0]);                    // distance to the Earth
    let r2 = norm(x - [1 - mu, 0]);                 // distance to the Moon

    d/dt x = v;
    d/dt v = x + 2 * [v[1], -v[0]] - (1 - mu) * (x - [-mu, 0]) / r1^3 - mu * (x - [1 - mu, 0]) / r2^3;

    // the Jacobi integral: the energy in the rotating frame (the Jacobi constant is −2C)
    integral C = dot(v, v) / 2 - dot(x, x) / 2 - (1 - mu) / r1 - mu / r2 gain k = 1;

    // (0.2): the orbit closes after one period T (the first of its loops around the Moon)
    point orbit { x = [0.994, 0]; v = [0, -2.00158510637908252240537862224]; }

    run orbit { method = dopri5; t_end = 17.0652165601579625588917206249; init = orbit; }
}

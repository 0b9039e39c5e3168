// models/kepler.lsl — the Kepler problem
// Chang, Jiménez, Perlmutter, "Feedback Integrators" (J. Nonlinear Sci. 2016), §3.2 and §4.2.
model Kepler {
    state x: vec3, v: vec3;
    param mu = 1.0;

    let r = norm(x);

    d/dt x = v;                                         // (31)
    d/dt v = -mu * x / r^3;

    integral L = cross(x, v)                        gain k1 = 4;   // angular momentum (32)
    integral A = cross(v, cross(x, v)) - mu * x / r gain k2 = 2;   // Laplace–Runge–Lenz (33)

    // §4.2: e = 0.8, L(0) = (0, 0, √1.8), A(0) = (0.8, 0, 0), period T = 70.2481
    point paper { x = [1, 0, 0]; v = [0, sqrt(1.8), 0]; }

    // §4.2: the paper's run, with the paper's gains (one period here; `--t-end 70248.1` for its
    // 1000 periods)
    run paper { method = feedback_euler; dt = 0.005; t_end = 70.2481; init = paper; gains = [4, 2]; }

    // The field is singular at x = 0; a fixed step that moves farther than the distance to the
    // centre jumps over the close approach instead of resolving it.
    guard collision: norm(x) > 1e-6;
    guard resolved: dt * norm(v) <= norm(x);
}

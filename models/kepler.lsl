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
}

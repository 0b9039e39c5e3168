// models/perturbed_kepler.lsl — a perturbed Kepler problem with rotational symmetry
// Chang, Jiménez, Perlmutter, "Feedback Integrators" (J. Nonlinear Sci. 2016), §3.3 and §4.3;
// Hairer, Lubich, Wanner, "Geometric Numerical Integration", Example IV.4.3.
model PerturbedKepler {
    state x: vec3, v: vec3;
    param mu = 1.0;
    param delta = 0.0025;
    param e = 0.6;                                  // eccentricity of the initial orbit

    let r = norm(x);
    let U = -mu / r - delta / r^3;                  // potential U(|x|) (56)
    let dU = mu / r^2 + 3 * delta / r^4;            // U′(|x|)

    d/dt x = v;                                     // (42)
    d/dt v = -dU * x / r;

    integral E = dot(v, v) / 2 + U gain k1 = 2;     // energy (43)
    integral L = cross(x, v)       gain k2 = 3;     // angular momentum (44)

    // §4.3: E(0) = −0.5390625, L(0) = (0, 0, 0.8)
    point paper { x = [1 - e, 0, 0]; v = [0, sqrt((1 + e) / (1 - e)), 0]; }

    // §4.3: the paper's run, with the paper's gains (the model's)
    run paper { method = feedback_euler; dt = 0.03; t_end = 200; init = paper; gains = [2, 3]; }

    // The field is singular at x = 0 (see kepler.lsl).
    guard collision: norm(x) > 1e-6;
    guard resolved: dt * norm(v) <= norm(x);
}

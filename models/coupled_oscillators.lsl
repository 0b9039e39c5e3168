// models/coupled_oscillators.lsl — two oscillators with frequencies 1 and √2, coupled by
// cubic and quartic terms: a generic elliptic equilibrium at the origin (normal-form tests).
model CoupledOscillators {
    state q: vec2, p: vec2;
    param w1 = 1.0;
    param w2 = sqrt(2);
    param a = 0.1;                                   // q1² q2
    param b = 0.05;                                  // q1 q2²
    param c = 0.02;                                  // (q1² + q2²)²

    hamiltonian H = w1 / 2 * (q[0]^2 + p[0]^2) + w2 / 2 * (q[1]^2 + p[1]^2)
                  + a * q[0]^2 * q[1] + b * q[0] * q[1]^2 + c * (q[0]^2 + q[1]^2)^2;
    structure canonical(q, p);

    point origin { q = [0, 0]; p = [0, 0]; }
    point excited { q = [0.1, 0.05]; p = [0, 0.1]; }

    run excited { method = stormer_verlet_a; dt = 1e-2; t_end = 100; init = excited; }
}

// The gravitational N-body problem in space, as a family: n bodies with masses m_i, G = 1.
// Change n on its line (and the masses' default, which has one value per body) to change N.
model NBody {
    param n = 5;
    state q: vec3[n], p: vec3[n];
    param G = 1;
    param m: scalar[n] = [i in 0..n: 1 / (i + 1)];

    hamiltonian H = sum(i in 0..n: dot(p[i], p[i]) / (2 * m[i]))
                  - sum(i in 0..n, j in i+1..n: G * m[i] * m[j] / norm(q[i] - q[j]));
    structure canonical(q, p);

    integral P = sum(i in 0..n: p[i]);                  // momentum
    integral L = sum(i in 0..n: cross(q[i], p[i]));     // angular momentum

    // the bodies on a tilted ring, each moving tangentially
    point ring {
        q = [i in 0..n: [2 * cos(6.283185307179586 * i / n), 2 * sin(6.283185307179586 * i / n), 0.1 * (i - 2)]];
        p = [i in 0..n: m[i] * 0.5 * [-sin(6.283185307179586 * i / n), cos(6.283185307179586 * i / n), 0]];
    }
    run ring { method = dopri5; t_end = 10; init = ring; }
}

// models/pleiades.lsl — the Pleiades: seven stars in the plane, masses m_i = i, G = 1
// Hairer, Nørsett & Wanner, "Solving Ordinary Differential Equations I", §II.10; the IVP test
// set of Mazzia & Magherini (problem PLEI), t ∈ [0, 3]. q = (x₁…x₇, y₁…y₇), p = m v. Its close
// encounters make the field stiff for a few steps at a time.
model Pleiades {
    param n = 7;
    state q: scalar[2 * n], p: scalar[2 * n];

    hamiltonian H = sum(i in 0..n: (p[i]^2 + p[n + i]^2) / (2 * (i + 1)))
        - sum(i in 0..n, j in i+1..n: (i + 1) * (j + 1) / sqrt((q[i] - q[j])^2 + (q[n + i] - q[n + j])^2));
    structure canonical(q, p);

    integral P = [sum(i in 0..n: p[i]), sum(i in 0..n: p[n + i])];    // momentum
    integral L = sum(i in 0..n: q[i] * p[n + i] - q[n + i] * p[i]);    // angular momentum

    // the test set's initial values: x, y, and p = m (ẋ, ẏ) with ẋ₆ = 1.75, ẋ₇ = −1.5,
    // ẏ₄ = −1.25, ẏ₅ = 1
    point testset { q = [3, 3, -1, -3, 2, -2, 2, 3, -3, 2, 0, 0, -4, 4]; p = [0, 0, 0, 0, 0, 10.5, -10.5, 0, 0, 0, -5, 5, 0, 0]; }

    run testset { method = dopri5; t_end = 3; init = testset; }
}

// The golden fixture of the loop form: models/fput.lsl at n = 6, generated with its families as loops.
// The Fermi–Pasta–Ulam–Tsingou chain (1955): n particles of unit mass between two fixed walls,
// neighbours joined by springs of potential V(r) = r²/2 + α r³/3 + β r⁴/4.
// Change n on its line to change the chain's length.
model Fput {
    param n = 6;
    state q: scalar[n], p: scalar[n];
    param alpha = 0.25;
    param beta = 0;

    hamiltonian H = sum(i in 0..n: p[i]^2 / 2)
        + sum(i in 0..n-1: (q[i+1] - q[i])^2 / 2 + alpha * (q[i+1] - q[i])^3 / 3 + beta * (q[i+1] - q[i])^4 / 4)
        + q[0]^2 / 2 + alpha * q[0]^3 / 3 + beta * q[0]^4 / 4            // the left wall
        + q[n-1]^2 / 2 - alpha * q[n-1]^3 / 3 + beta * q[n-1]^4 / 4;     // the right wall
    structure canonical(q, p);

    // all the energy in the lowest normal mode, as in the original experiment
    point mode1 { q = [i in 0..n: sin(3.141592653589793 * (i + 1) / (n + 1))]; p = [i in 0..n: 0]; }
    run mode1 { method = stormer_verlet_b; dt = 0.05; t_end = 1000; init = mode1; every = 20; }
}

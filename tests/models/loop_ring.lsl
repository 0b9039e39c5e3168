// A periodic chain whose sums exercise the loop form's index structures: a remainder
// (`(i + 1) % n`), a remainder of a difference that is negative at i = 0 (`(i - 1) % n`), a
// condition (`i != j`), and a subscript with a division, which has no loop form and is listed;
// guards (one reading the step size) and events (one reading the time) outside the families.
model LoopRing {
    param n = 7;
    state q: scalar[n], p: scalar[n];
    param k: scalar[n] = [i in 0..n: 1 + i / 10];

    hamiltonian H = sum(i in 0..n: p[i]^2 / 2)
        + sum(i in 0..n: k[i] * (q[(i + 1) % n] - q[i])^4 / 4)
        + sum(i in 0..n: (q[i] - q[(i - 1) % n])^2 / 2)
        + sum(i in 0..n, j in 0..n, i != j: q[i] * q[j] / 20)
        + sum(i in 0..n: q[(2 * i) / 2]^6 / 6);
    structure canonical(q, p);

    guard bounded: norm(q) < 8;
    guard resolved: dt * norm(p) <= 1;
    event turn: p[0] = 0 rising;
    event late: t - q[1] - 2 = 0 stop;
}

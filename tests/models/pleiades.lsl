// The Pleiades: seven stars in the plane with masses m_i = i and G = 1, t in [0, 3]
// (Hairer, Norsett & Wanner, Solving ODEs I, II.10; the IVP test set of Mazzia & Magherini).
// q = (x1..x7, y1..y7), p = m v. Written out pair by pair (21 pairs), as a user writes it.
model Pleiades {
    state q: vec14, p: vec14;
    hamiltonian H = (p[0]^2 + p[7]^2) / 2 + (p[1]^2 + p[8]^2) / 4 + (p[2]^2 + p[9]^2) / 6 + (p[3]^2 + p[10]^2) / 8 + (p[4]^2 + p[11]^2) / 10 + (p[5]^2 + p[12]^2) / 12 + (p[6]^2 + p[13]^2) / 14
        - (2 / sqrt((q[0] - q[1])^2 + (q[7] - q[8])^2) + 3 / sqrt((q[0] - q[2])^2 + (q[7] - q[9])^2) + 4 / sqrt((q[0] - q[3])^2 + (q[7] - q[10])^2) + 5 / sqrt((q[0] - q[4])^2 + (q[7] - q[11])^2) + 6 / sqrt((q[0] - q[5])^2 + (q[7] - q[12])^2) + 7 / sqrt((q[0] - q[6])^2 + (q[7] - q[13])^2) + 6 / sqrt((q[1] - q[2])^2 + (q[8] - q[9])^2) + 8 / sqrt((q[1] - q[3])^2 + (q[8] - q[10])^2) + 10 / sqrt((q[1] - q[4])^2 + (q[8] - q[11])^2) + 12 / sqrt((q[1] - q[5])^2 + (q[8] - q[12])^2) + 14 / sqrt((q[1] - q[6])^2 + (q[8] - q[13])^2) + 12 / sqrt((q[2] - q[3])^2 + (q[9] - q[10])^2) + 15 / sqrt((q[2] - q[4])^2 + (q[9] - q[11])^2) + 18 / sqrt((q[2] - q[5])^2 + (q[9] - q[12])^2) + 21 / sqrt((q[2] - q[6])^2 + (q[9] - q[13])^2) + 20 / sqrt((q[3] - q[4])^2 + (q[10] - q[11])^2) + 24 / sqrt((q[3] - q[5])^2 + (q[10] - q[12])^2) + 28 / sqrt((q[3] - q[6])^2 + (q[10] - q[13])^2) + 30 / sqrt((q[4] - q[5])^2 + (q[11] - q[12])^2) + 35 / sqrt((q[4] - q[6])^2 + (q[11] - q[13])^2) + 42 / sqrt((q[5] - q[6])^2 + (q[12] - q[13])^2));
    structure canonical(q, p);
    integral P = [p[0] + p[1] + p[2] + p[3] + p[4] + p[5] + p[6], p[7] + p[8] + p[9] + p[10] + p[11] + p[12] + p[13]];
    integral L = q[0] * p[7] - q[7] * p[0] + q[1] * p[8] - q[8] * p[1] + q[2] * p[9] - q[9] * p[2] + q[3] * p[10] - q[10] * p[3] + q[4] * p[11] - q[11] * p[4] + q[5] * p[12] - q[12] * p[5] + q[6] * p[13] - q[13] * p[6];
    point start { q = [3, 3, -1, -3, 2, -2, 2, 3, -3, 2, 0, 0, -4, 4]; p = [0, 0, 0, 0, 0, 10.5, -10.5, 0, 0, 0, -5, 5, 0, 0]; }
}

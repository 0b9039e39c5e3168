// models/infante_example1.lsl — Example 1 of E. F. Infante, "Stability criteria for n-th order,
// homogeneous linear differential equations" (the fifth paper of NASA TM X-53478):
//     ẍ + p ẋ + q(t) x = 0,   q(t) = q0 + dq sin(omega t),
// in companion form, the state `clock` standing for t. With p = 1 the paper's (4.9) admits
// q(t) ∈ [z₁, z₁ + 2√(¼ + z₁ + √z₁)]; q ∈ [0.3, 2.2] lies inside the interval (0.25, 2.25) of
// α = (½, 1), C = diag(1, 0):
//     lasalle infante models/infante_example1.lsl --alpha 0.5,1 --c 1,0 --t-end 6.283185307179586
// (docs/infante.md).
model InfanteExample1 {
    state x: scalar;
    state v: scalar;
    state clock: scalar;
    param p = 1;
    param q0 = 1.25;
    param dq = 0.95;
    param omega = 1;

    d/dt x = v;
    d/dt v = -p * v - (q0 + dq * sin(omega * clock)) * x;
    d/dt clock = 1;

    point start { x = 1; v = 0; clock = 0; }

    run decay { method = dopri5; t_end = 40; init = start; }
}

// models/infante_example2.lsl — Example 2 of E. F. Infante, "Stability criteria for n-th order,
// homogeneous linear differential equations" (the fifth paper of NASA TM X-53478):
//     x⃛ + p ẍ + ẋ + r(t) x = 0,   r(t) = r0 + dr cos(omega t),
// in companion form, the state `clock` standing for t. With p = 1 the paper's (4.20) admits
// 0 < r(t) < 3/(4(λ + 1)); with λ = 0.1 (C = C₁ + λC₂ of Table I) and the α's of (4.15)–(4.19),
// α = (½, ¾, 15/88), r ∈ [0.05, 0.65] is inside:
//     lasalle infante models/infante_example2.lsl --alpha 0.5,0.75,0.17045454545454544 \
//         --c 0.06973140495867769,0.040909090909090916,0 --t-end 6.283185307179586
// (docs/infante.md).
model InfanteExample2 {
    state x: scalar;
    state v: scalar;
    state a: scalar;
    state clock: scalar;
    param p = 1;
    param r0 = 0.35;
    param dr = 0.3;
    param omega = 1;

    d/dt x = v;
    d/dt v = a;
    d/dt a = -p * a - v - (r0 + dr * cos(omega * clock)) * x;
    d/dt clock = 1;

    point start { x = 1; v = 0; a = 0; clock = 0; }

    run decay { method = dopri5; t_end = 80; init = start; }
}

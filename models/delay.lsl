// models/delay.lsl — a scalar delay equation, the example of §3 of J. P. LaSalle,
// "An invariance principle in the theory of stability" (the sixth paper of NASA TM X-53478,
// Progress Report No. 8, Marshall Space Flight Center, 1966), after Hale:
//     ẋ(t) = a x(t) + b x(t − r),   x = 1 on [−r, 0].
// With |b| < |a| the functional V(φ) = −φ(0)²/(2a) + ½∫₋ᵣ⁰ φ(θ)² dθ has
// V̇(φ) = −½[φ(0)² + (2b/a) φ(0) φ(−r) + φ(−r)²] ≤ 0: for a > 0 the zero solution is unstable
// (the solution from this history grows without bound), for a < 0 asymptotically stable in
// the large (it decays to 0). The rate is the rightmost root of λ = a + b e^{−λr}
// (docs/delay.md).
model Delay {
    state x: scalar;
    param a = 0.5;
    param b = 0.3;
    param r = 1;

    d/dt x = a * x + b * delay(x, r);

    point history { x = 1; }

    run steps { method = dopri5; t_end = 10; init = history; }
}

// models/pendulum_closed_form.lsl — the pendulum θ'' = −sin θ through its closed form in
// Jacobi elliptic functions (A&S 16.1, 16.16; Lawden, Elliptic Functions and Applications
// (1989) §5.1). Started at the bottom with speed 2k (0 < k < 1: libration, amplitude 2 asin k),
//     θ(t) = 2 asin(k sn(t | m)),   θ'(t) = 2k cn(t | m),   m = k²
// (m is the parameter, not the modulus k). The state carries the clock t; θ and ω = θ' are
// driven by the closed form's derivatives, so along the run from `bottom` ω' = −2k sn dn is
// −sin θ (tests/elliptic_model.rs checks this and the integrated pendulum). y, z and s
// exercise the rest of the elliptic vocabulary: F′, a Glaisher quotient, K.
model PendulumClosedForm {
    state t: scalar, theta: scalar, omega: scalar, y: scalar, z: scalar, s: scalar;
    param k = 0.9;

    let m = k^2;

    d/dt t = 1;
    d/dt theta = 2 * k * cn(t, m);
    d/dt omega = -2 * k * sn(t, m) * dn(t, m);
    d/dt y = 1 / sqrt(1 - m * sin(t)^2);           // F′(t | m) = 1/Δ(t)
    d/dt z = cd(t, m) * nd(t, m);                  // sd′ = cd nd (DLMF 22.13.1)
    d/dt s = 1 / ellipk(m);                        // the phase t/K, a quarter period per unit

    integral W = omega - 2 * k * cn(t, m);
    integral Y = y - ellipf(t, m);
    integral Z = z - sd(t, m);
    integral S = s - t / ellipk(m);

    point bottom { t = 0; theta = 0; omega = 2 * k; y = 0; z = 0; s = 0; }
}

// models/henon_heiles.lsl — the Hénon–Heiles system (Hénon & Heiles 1964): a star in an
// axisymmetric galactic potential, reduced to the meridian plane,
//     H = (p₀² + p₁²)/2 + (q₀² + q₁²)/2 + q₀² q₁ − q₁³/3.
// Motion is bounded for energies below the saddles' 1/6. At E = 1/12 most orbits are regular
// (invariant curves on the section q₀ = 0); at E = 1/8 a chaotic sea surrounds the islands.
model HenonHeiles {
    state q: vec2, p: vec2;
    hamiltonian H = (p[0]^2 + p[1]^2 + q[0]^2 + q[1]^2) / 2 + q[0]^2 * q[1] - q[1]^3 / 3;
    structure canonical(q, p);

    // Hénon & Heiles' surface of section: q₀ = 0 crossed upwards (p₀ = q̇₀ > 0), plotted in
    // (q₁, p₁): `lasalle section henon_heiles --event section --energy 0.125 --solve p[0] …`
    event section: q[0] = 0 rising;

    // E = 1/8 on the section q₀ = 0 at q₁ = −0.1, p₁ = 0 (p₀ > 0 from the energy): in the
    // chaotic sea (MEGNO ⟨Y⟩ grows like λt/2, λ ≈ 0.05; `run/tests/chaos.rs`)
    point chaotic { q = [0, -0.1]; p = [sqrt(0.25 - 0.01 - 0.002 / 3), 0]; }
    // E = 1/12 on the section q₀ = 0, q₁ = 0, p₁ = 0: a regular (quasi-periodic) orbit
    point regular { q = [0, 0]; p = [sqrt(1/6), 0]; }

    run chaotic { method = feedback_rk4; dt = 0.01; t_end = 100; init = chaotic; }
}

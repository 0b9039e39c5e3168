// models/rigid_body.lsl — the free rigid body on R^{3×3} × R^3
// Chang, Jiménez, Perlmutter, "Feedback Integrators" (J. Nonlinear Sci. 2016), §3.1 and §4.1.
model RigidBody {
    state R: mat3, Omega: vec3;
    param I = diag(3, 2, 1);                        // inertia tensor 𝕀

    d/dt R = R * hat(Omega);                        // (13)
    d/dt Omega = inv(I) * cross(I * Omega, Omega);

    constraint C = transpose(R) * R - eye(3) gain k0 = 50;   // SO(3) = {RᵀR = I}
    integral E = dot(Omega, I * Omega) / 2   gain k1 = 100;  // energy
    integral pi = R * I * Omega              gain k2 = 50;   // spatial angular momentum

    // (18): V = k0/4 ‖RᵀR − I‖² + k1/2 |E − E0|² + k2/2 |π − π0|²
    lyapunov V = k0 / 4 * norm(C)^2
               + k1 / 2 * (E - target(E))^2
               + k2 / 2 * norm(pi - target(pi))^2;

    // §4.1: E(0) = 3, π(0) = (3, 2, 1), period of Ω(t) T_Ω ≈ 6.4227
    point paper { R = eye(3); Omega = [1, 1, 1]; }

    // §4.1: the paper's run, with the paper's gains (the model's)
    run paper { method = feedback_euler; dt = 1e-4; t_end = 1000; init = paper; gains = [50, 100, 50]; }

    // GNI §VII.5: the three-rotation splitting (`--method splitting`); the generator checks
    // that the field above is the free rigid body's.
    splitting rigid_body(R, Omega, I);
}

// Lotka–Volterra predator–prey: x prey, y predators. Along the motion
// V = δ x − γ ln x + β y − α ln y stays constant (its level set is the closed orbit).
model LotkaVolterra {
    state x: scalar, y: scalar;
    param alpha = 1.0;
    param beta = 0.5;
    param gamma = 0.75;
    param delta = 0.25;

    d/dt x = x * (alpha - beta * y);
    d/dt y = y * (delta * x - gamma);

    integral V = delta * x - gamma * log(x) + beta * y - alpha * log(y) gain 2;

    point start { x = 5; y = 1; }
    // the equilibrium (γ/δ, α/β)
    point centre { x = gamma / delta; y = alpha / beta; }

    guard prey: x > 0;
    guard predators: y > 0;
}

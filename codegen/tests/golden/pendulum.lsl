// The golden fixture: a pendulum with its energy.
model Pendulum {
    state theta: scalar, omega: scalar;
    param g = 9.81;
    param l = 1.0;

    let k = g / l;
    d/dt theta = omega;
    d/dt omega = -k * sin(theta);

    integral E = omega^2 / 2 - k * cos(theta) gain 2;

    point rest { theta = 0; omega = 0; }
}

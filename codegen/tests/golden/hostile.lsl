// A model without parameters whose names are Rust keywords, or names the generated code uses
// itself: it must generate code that compiles (tests/golden.rs includes it).
model Hostile {
    state fn: scalar, self: scalar, type: vec2, x: scalar, x_mut: scalar;
    let lit = type[0] * x;
    let T = 1 + lit^2;
    let _ = self * T;
    d/dt fn = _;
    d/dt self = -fn * T;
    d/dt type = [type[1], -type[0]];
    d/dt x = x_mut;
    d/dt x_mut = -x;
    integral E = fn^2 + self^2;
    integral F = dot(type, type);
    point start { fn = 1; self = 0; type = [1, 0]; x = 0; x_mut = 1; }
}

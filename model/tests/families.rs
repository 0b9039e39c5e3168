//! Families: a model written with index ranges, sums over them and indexed equations is the
//! model written out term by term (the same DAG, so the same values bit for bit), its integrals
//! are proved, the discretised operators have their closed-form spectra, and every mistake
//! inside a family is a located error that says at which indices it happened.

use lasalle_model::ir::Input;
use lasalle_model::{check, derive, lower_source, Model};

const PLEIADES: &str = include_str!("../../tests/models/pleiades.lsl");

/// The Pleiades as a family, with the written model's layout q = (x₁…x₇, y₁…y₇) and the
/// masses m_i = i written as numbers (so every coefficient folds as in the written model).
const PLEIADES_FAMILY: &str = "model PleiadesFamily {
    param n = 7;
    state q: scalar[2 * n], p: scalar[2 * n];
    hamiltonian H = sum(i in 0..n: (p[i]^2 + p[n + i]^2) / (2 * (i + 1)))
        - sum(i in 0..n, j in i+1..n: (i + 1) * (j + 1) / sqrt((q[i] - q[j])^2 + (q[n + i] - q[n + j])^2));
    structure canonical(q, p);
    integral P = [sum(i in 0..n: p[i]), sum(i in 0..n: p[n + i])];
    integral L = sum(i in 0..n: q[i] * p[n + i] - q[n + i] * p[i]);
}";

fn model(text: &str) -> Model {
    lower_source("m.lsl", text).unwrap_or_else(|e| panic!("{e}"))
}

/// `outputs` of `m` at state `x` with the default parameters.
fn eval(m: &Model, outputs: &[lasalle_model::ir::Id], x: &[f64]) -> Vec<f64> {
    let params = m.default_params();
    m.graph.eval_f64(outputs, &mut |i| match i {
        Input::State(k) => x[k as usize],
        Input::Param(k) => params[k as usize],
        _ => f64::NAN,
    })
}

/// Deterministic states with components in [-2, 2).
fn states(dim: usize, count: usize) -> Vec<Vec<f64>> {
    let mut rng = lasalle_testkit::Rng::new(0x2545_f491_4f6c_dd1d);
    (0..count)
        .map(|_| (0..dim).map(|_| rng.uniform(-2.0, 2.0)).collect())
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn pleiades_family_is_the_written_model_bit_for_bit() {
    let (written, family) = (model(PLEIADES), model(PLEIADES_FAMILY));
    assert_eq!(written.dim(), family.dim());
    assert_eq!(written.invariant_dim(), family.invariant_dim());
    // `n` is a size: a constant of the model, not a run-time parameter
    assert!(family.params.is_empty());
    for x in states(28, 50) {
        assert_eq!(
            bits(&eval(&written, &written.field, &x)),
            bits(&eval(&family, &family.field, &x))
        );
        assert_eq!(
            bits(&eval(&written, &written.invariant_ids(), &x)),
            bits(&eval(&family, &family.invariant_ids(), &x))
        );
    }
    check(&derive(family)).expect("H, P and L are conserved");
}

const NBODY: &str = "model NBody {
    param n = 5;
    state q: vec3[n], p: vec3[n];
    param G = 1;
    param m: scalar[n] = [i in 0..n: 1 / (i + 1)];
    hamiltonian H = sum(i in 0..n: dot(p[i], p[i]) / (2 * m[i]))
                  - sum(i in 0..n, j in i+1..n: G * m[i] * m[j] / norm(q[i] - q[j]));
    structure canonical(q, p);
    integral P = sum(i in 0..n: p[i]);
    integral L = sum(i in 0..n: cross(q[i], p[i]));
}";

/// The written-out N-body model, member i of q being the columns of a mat3xN written as
/// `[q[0, i], q[1, i], q[2, i]]`.
fn nbody_columns(n: usize) -> String {
    let col = |v: &str, i: usize| format!("[{v}[0, {i}], {v}[1, {i}], {v}[2, {i}]]");
    let mut kinetic = Vec::new();
    let mut potential = Vec::new();
    for i in 0..n {
        kinetic.push(format!(
            "dot({}, {}) / (2 * m[{i}])",
            col("p", i),
            col("p", i)
        ));
        for j in i + 1..n {
            potential.push(format!(
                "G * m[{i}] * m[{j}] / norm({} - {})",
                col("q", i),
                col("q", j)
            ));
        }
    }
    let masses: Vec<String> = (0..n).map(|i| format!("1 / {}", i + 1)).collect();
    let p: Vec<String> = (0..n).map(|i| col("p", i)).collect();
    let l: Vec<String> = (0..n)
        .map(|i| format!("cross({}, {})", col("q", i), col("p", i)))
        .collect();
    format!(
        "model Written {{
            state q: mat3x{n}, p: mat3x{n};
            param G = 1;
            param m = [{}];
            hamiltonian H = {} - ({});
            structure canonical(q, p);
            integral P = {};
            integral L = {};
        }}",
        masses.join(", "),
        kinetic.join(" + "),
        potential.join(" + "),
        p.join(" + "),
        l.join(" + ")
    )
}

#[test]
fn nbody_family_is_the_written_model_bit_for_bit() {
    let (written, family) = (model(&nbody_columns(5)), model(NBODY));
    assert_eq!(family.dim(), 30);
    assert_eq!(
        family.param_slots(),
        6,
        "G and the five masses; n has no slot"
    );
    assert_eq!(family.default_params(), written.default_params());
    for x in states(30, 50) {
        assert_eq!(
            bits(&eval(&written, &written.field, &x)),
            bits(&eval(&family, &family.field, &x))
        );
        assert_eq!(
            bits(&eval(&written, &written.invariant_ids(), &x)),
            bits(&eval(&family, &family.invariant_ids(), &x))
        );
    }
    let derived = derive(family);
    let checked = check(&derived).expect("energy, momentum and angular momentum are conserved");
    assert_eq!(checked.conservation().len(), 3);
}

/// FPUT with fixed ends: for α = β = 0 the chain is linear and its normal mode k,
/// q_i = sin(kπ(i+1)/(n+1)), has q̈ = −ω_k² q with ω_k = 2 sin(kπ / (2(n+1))).
#[test]
fn fput_linear_modes_have_their_closed_form_frequencies() {
    let text =
        include_str!("../../models/fput.lsl").replace("param alpha = 0.25;", "param alpha = 0;");
    let m = model(&text);
    let n = m.dim() / 2;
    assert_eq!(n, 16);
    for k in 1..=n {
        let mode: Vec<f64> = (0..n)
            .map(|i| (k as f64 * std::f64::consts::PI * (i + 1) as f64 / (n + 1) as f64).sin())
            .collect();
        let mut x = mode.clone();
        x.extend(vec![0.0; n]);
        let f = eval(&m, &m.field, &x);
        let w = 2.0 * (k as f64 * std::f64::consts::PI / (2.0 * (n + 1) as f64)).sin();
        for i in 0..n {
            assert!(
                (f[n + i] + w * w * mode[i]).abs() < 1e-13,
                "mode {k}, particle {i}: {} vs {}",
                f[n + i],
                -w * w * mode[i]
            );
        }
    }
    check(&derive(m)).expect("the energy is conserved");
}

/// The 1-D heat equation u_t = κ u_xx on (0, 1) with u = 0 at both ends, on n interior
/// points: the discrete Laplacian's first eigenvector sin(π x_i) has the eigenvalue
/// −λ = −(4κ/h²) sin²(πh/2), h = 1/(n+1).
pub const HEAT: &str = "model Heat {
    param n = 32;
    state u: scalar[n];
    param kappa = 1;
    let h = 1 / (n + 1);
    for i in 1..n-1: d/dt u[i] = kappa * (u[i-1] - 2 * u[i] + u[i+1]) / h^2;
    d/dt u[0] = kappa * (u[1] - 2 * u[0]) / h^2;
    d/dt u[n-1] = kappa * (u[n-2] - 2 * u[n-1]) / h^2;
    point mode1 { u = [i in 0..n: sin(3.141592653589793 * (i + 1) / (n + 1))]; }
}";

#[test]
fn heat_laplacian_has_its_closed_form_eigenvalue() {
    let m = model(HEAT);
    let n = 32;
    let u = m.point_values("mode1", &m.default_params()).unwrap();
    let f = eval(&m, &m.field, &u);
    let h = 1.0 / (n + 1) as f64;
    let lambda = 4.0 / (h * h) * (std::f64::consts::PI * h / 2.0).sin().powi(2);
    for i in 0..n {
        assert!((f[i] + lambda * u[i]).abs() < 1e-11 * lambda, "{i}");
    }
}

/// Periodic ends with `%`: the chain's total momentum is conserved, and the field of a
/// shifted state is the shifted field.
#[test]
fn periodic_chain_with_remainder() {
    let text = "model Ring {
        param n = 8;
        state q: scalar[n], p: scalar[n];
        hamiltonian H = sum(i in 0..n: p[i]^2 / 2 + (q[(i + 1) % n] - q[i])^4 / 4);
        structure canonical(q, p);
        integral P = sum(i in 0..n: p[i]);
    }";
    let m = model(text);
    for x in states(16, 10) {
        let f = eval(&m, &m.field, &x);
        let mut shifted = x.clone();
        shifted[..8].rotate_right(1);
        shifted[8..].rotate_right(1);
        let mut g = eval(&m, &m.field, &shifted);
        g[..8].rotate_left(1);
        g[8..].rotate_left(1);
        for (a, b) in f.iter().zip(&g) {
            assert!((a - b).abs() <= 1e-14 * (1.0 + a.abs()), "{a} {b}");
        }
    }
    check(&derive(m)).expect("H and P are conserved");
}

/// Conditions, products and a comprehension of a family of parameters.
#[test]
fn conditions_products_and_comprehensions() {
    let text = "model C {
        param n = 4;
        state x: scalar[n];
        param w: scalar[n] = [i in 0..n: i + 1];
        param a: vec2[n] = [1, 2];
        for i in 0..n: d/dt x[i] = sum(j in 0..n, j != i: w[j]) * prod(k in 0..n, k < i: x[k]) + a[i][1];
    }";
    let m = model(text);
    assert_eq!(
        m.default_params(),
        [1.0, 2.0, 3.0, 4.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0]
    );
    let x = [2.0, 3.0, 5.0, 7.0];
    let f = eval(&m, &m.field, &x);
    // Σ_{j≠i} w_j = 10 − (i + 1); Π_{k<i} x_k (empty product 1); + a_i[1] = 2
    assert_eq!(
        f,
        [
            9.0 + 2.0,
            8.0 * 2.0 + 2.0,
            7.0 * 6.0 + 2.0,
            6.0 * 30.0 + 2.0
        ]
    );
}

/// The message and `file:line:col` of the first error of `text`.
fn error(text: &str) -> String {
    match lower_source("f.lsl", text).and_then(|m| check(&derive(m)).map(|_| ())) {
        Ok(()) => panic!("expected an error:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn nbody_with(hamiltonian: &str) -> String {
    format!(
        "model E {{\n    param n = 5;\n    state q: vec3[n], p: vec3[n];\n    param m: scalar[n] = 1;\n    hamiltonian H = {hamiltonian};\n    structure canonical(q, p);\n}}"
    )
}

#[test]
fn errors_inside_families_are_located() {
    let e = error(&nbody_with("sum(i in 0..n: dot(p[i + 1], p[i]))"));
    assert!(
        e.contains("index 5 is out of range 0..5 (where i = 4)") && e.contains("f.lsl:5:"),
        "{e}"
    );
    let e = error(&nbody_with("sum(i in 0..n: dot(p[i], p[i]) + p[i])"));
    assert!(
        e.contains("cannot add a scalar and a vec3 (where i = 0)"),
        "{e}"
    );
    let e = error(&nbody_with("sum(i in 0..n: dot(p[k], p[i]))"));
    assert!(
        e.contains("unknown symbol `k` (where i = 0)") && e.contains("f.lsl:5:42"),
        "{e}"
    );
    let e = error(&nbody_with("sum(p in 0..n: m[p])"));
    assert!(
        e.contains("index `p` would hide the state variable `p`"),
        "{e}"
    );
    let e = error(&nbody_with("sum(i in 0..n: p[i, 0])"));
    assert!(
        e.contains("`p` is a family of 5 vec3s: it takes one index"),
        "{e}"
    );
    let e = error(&nbody_with("sum(i in 0..n: p[i][3])"));
    assert!(
        e.contains("index 3 is out of range 0..3 (where i = 0)"),
        "{e}"
    );
    let e = error(&nbody_with("sum(i in 0..n i != 0: m[i])"));
    assert!(e.contains("expected"), "{e}");
    let e = error("model E { param n = 2.5; state q: scalar[n]; d/dt q = q; }");
    assert!(
        e.contains("a size must be a whole number, this is 2.5"),
        "{e}"
    );
    let e = error(
        "model E { param n = 3; state q: scalar[n]; param m: scalar[n] = [1, 2]; d/dt q = m; }",
    );
    assert!(
        e.contains("parameter `m` is declared a scalar[n] but its default is a vec2"),
        "{e}"
    );
    let e = error(
        "model E { param n = 3; state q: scalar[n]; for i in 0..n: d/dt q[i] = 0; d/dt q[2] = 1; }",
    );
    assert!(e.contains("`q[2]` already has an equation"), "{e}");
    let e = error("model E { param n = 3; state q: scalar[n]; for i in 1..n: d/dt q[i] = 0; }");
    assert!(e.contains("state `q` has no equation"), "{e}");
    let e = error("model E { param n = 3; state q: vec2[n]; for i in 0..n: d/dt q[i] = 0; }");
    assert!(
        e.contains("d/dt q[i] is a vec2 but this is a scalar (where i = 0)"),
        "{e}"
    );
    let e =
        error("model E { param n = 3; state q: scalar[n]; d/dt q = [i in 0..n: q[(i + 1) % 0]]; }");
    assert!(e.contains("`%` takes two constant whole numbers"), "{e}");
    let e = error("model E { param n = 3; state q: mat2[n]; d/dt q = q; }");
    assert!(
        e.contains("a family's members are scalars or vectors, not a mat2"),
        "{e}"
    );
}

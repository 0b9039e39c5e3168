//! Constraints are checked together on their common manifold, and integrals may hold on it
//! only (the spherical pendulum: |x|² − 1 and x·v, and its energy).

use lasalle_codegen::generate_source;
use lasalle_codegen::Verdict;

const PENDULUM: &str = "model SphericalPendulum {
    state x: vec3, v: vec3;
    param g = 9.81;
    d/dt x = v;
    d/dt v = -g * [0, 0, 1] + (g * x[2] - dot(v, v)) * x;
    constraint sphere = dot(x, x) - 1 gain 10;
    constraint tangent = dot(x, v) gain 10;
    integral E = dot(v, v) / 2 + g * x[2];
    integral Lz = x[0] * v[1] - x[1] * v[0];
}";

fn verdict<'a>(m: &'a lasalle_codegen::GeneratedModel, name: &str) -> &'a Verdict {
    &m.report
        .conservation
        .iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no verdict for {name}"))
        .verdict
}

#[test]
fn the_spherical_pendulum_is_accepted_with_its_energy_on_the_manifold() {
    let m = generate_source("pendulum.lsl", PENDULUM).expect("generates");
    // each constraint holds on the other's manifold: checked jointly
    assert!(matches!(verdict(&m, "sphere"), Verdict::Sampled { .. }));
    assert!(matches!(verdict(&m, "tangent"), Verdict::Sampled { .. }));
    // the energy is conserved only where the constraints hold
    assert!(matches!(
        verdict(&m, "E"),
        Verdict::OnConstraints { samples: 128, .. }
    ));
    assert!(matches!(verdict(&m, "Lz"), Verdict::Proved));
    assert!(m
        .summary
        .contains("conserved on the constraints' manifold only"));
}

#[test]
fn an_integral_not_conserved_on_the_manifold_either_is_refused() {
    let text = PENDULUM.replace(
        "integral E = dot(v, v) / 2 + g * x[2];",
        "integral E = dot(v, v) / 2 + 2 * g * x[2];",
    );
    let e = generate_source("pendulum.lsl", &text)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("integral `E` is not conserved by the field")
            && e.contains("it is not conserved on the constraints' manifold either"),
        "{e}"
    );
}

#[test]
fn a_constraint_the_field_leaves_is_still_refused() {
    // without the centripetal term the motion leaves the sphere
    let text = PENDULUM.replace("+ (g * x[2] - dot(v, v)) * x", "");
    let e = generate_source("pendulum.lsl", &text)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("constraint `tangent` is not conserved by the field"),
        "{e}"
    );
}

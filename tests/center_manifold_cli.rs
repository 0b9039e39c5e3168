//! `lasalle normal-form --center-manifold --poincare` from the command line: the section's
//! landmarks at Earth–Moon L1 and the errors of the option.

mod common;
use common::lasalle_text;

/// Above the halo bifurcation (h = 0.307 in γ units, `tests/center.rs` in the normal-form
/// crate) the section shows the vertical Lyapunov orbit and two halo fixed points at
/// Q₂ = ±0.5568γ; the figure is written.
#[test]
fn poincare_section_above_the_bifurcation_has_two_halo_points() {
    let dir = std::env::temp_dir().join(format!("lasalle-cm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (ok, _, err) = lasalle_text(&[
        "normal-form",
        "models/cr3bp_spatial.lsl",
        "--at",
        "L1",
        "--center-manifold",
        "--order",
        "12",
        "--poincare",
        dir.to_str().unwrap(),
        "--energies",
        "0.4",
    ]);
    assert!(ok, "{err}");
    let line = err
        .lines()
        .find(|l| l.starts_with("h = 0.4:"))
        .unwrap_or_else(|| panic!("landmarks on stderr: {err}"));
    assert!(line.contains("2 halo fixed point(s)"), "{line}");
    assert!(line.contains("(0.5567"), "{line}");
    assert!(line.contains("(-0.5567"), "{line}");
    for ext in ["svg", "png"] {
        let p = dir.join(format!("center_manifold_L1.{ext}"));
        assert!(
            std::fs::metadata(&p)
                .map(|m| m.len() > 1000)
                .unwrap_or(false),
            "{p:?}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn poincare_errors_name_the_option() {
    // the planar model's centre manifold has one degree of freedom: no section
    let dir = std::env::temp_dir();
    let (ok, _, err) = lasalle_text(&[
        "normal-form",
        "models/cr3bp.lsl",
        "--at",
        "L1",
        "--center-manifold",
        "--order",
        "6",
        "--poincare",
        dir.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(
        err.contains("--poincare") && err.contains("two-degree-of-freedom"),
        "{err}"
    );
    let (ok, _, err) = lasalle_text(&[
        "normal-form",
        "models/cr3bp_spatial.lsl",
        "--at",
        "L1",
        "--center-manifold",
        "--order",
        "6",
        "--poincare",
        dir.to_str().unwrap(),
        "--energies",
        "0.2,-1",
    ]);
    assert!(!ok);
    assert!(
        err.contains("--energies 0.2,-1") && err.contains("`-1`"),
        "{err}"
    );
}

//! The Rust examples of the README, compiled and run: one Kepler period of feedback-Euler, and
//! the run example checked against the crate doctest that runs it.

use lasalle::models::kepler::Kepler;
use lasalle::{integrate, sample_capacity, ExplicitRk, FeedbackField, Recorder};

#[test]
fn readme_example() -> Result<(), Box<dyn std::error::Error>> {
    let m = Kepler::<f64>::default().prepare();
    let x0 = m.point_paper(); // x = (1, 0, 0), v = (0, √1.8, 0)
    let fb = FeedbackField::from_initial(&m, &x0, [4.0, 2.0]); // ẋ = X(x) − ∇V(x)
    let mut rec = Recorder::new(&m, &x0, 100, sample_capacity(14_050, 100));
    integrate(
        &mut ExplicitRk::euler(),
        &fb,
        &x0,
        0.0,
        70.2481,
        0.005,
        &mut rec,
    )?;
    // After one period the orbit is kept: |ΔL| and |ΔA| stay small.
    for block in 0..2 {
        assert!(
            rec.max_error(block) < 1e-3,
            "invariant {block}: {}",
            rec.max_error(block)
        );
    }
    Ok(())
}

/// The README's run-time example: the same model loaded from its file.
#[test]
fn readme_loaded_example() -> Result<(), Box<dyn std::error::Error>> {
    use lasalle::{Backend, LoadedModel, Parameters};
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/kepler.lsl");
    let m = LoadedModel::load(path, Backend::Jit)?; // parse, derive, check, compile
    let x0 = m.point("paper").unwrap(); // Vec<f64>
    let fb = FeedbackField::from_initial(&m, &x0, vec![4.0, 2.0]);
    let end = integrate(
        &mut ExplicitRk::euler(),
        &fb,
        &x0,
        0.0,
        70.2481,
        0.005,
        &mut (),
    )?;
    assert_eq!(end.steps, 14_050);
    Ok(())
}

/// The README's run example is the `lasalle` crate's doctest (which compiles and runs it),
/// line for line.
#[test]
fn readme_run_example_is_the_crate_doctest() {
    let root = env!("CARGO_MANIFEST_DIR");
    let readme = std::fs::read_to_string(format!("{root}/README.md")).unwrap();
    let lib = std::fs::read_to_string(format!("{root}/src/lib.rs")).unwrap();
    // the README's ```rust block that builds a RunSpec
    let shown: Vec<&str> = readme
        .split("```rust\n")
        .skip(1)
        .map(|b| b.split("```").next().unwrap_or(""))
        .find(|b| b.contains("RunSpec::from_preset"))
        .expect("the README shows a RunSpec example")
        .lines()
        .collect();
    // the doctest in the crate docs, without its hidden lines
    let docs: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("//!"))
        .map(|l| l.strip_prefix(' ').unwrap_or(l))
        .collect();
    let start = docs.iter().position(|l| *l == "```").expect("a doctest") + 1;
    let len = docs[start..].iter().position(|l| *l == "```").unwrap();
    let tested: Vec<&str> = docs[start..start + len]
        .iter()
        .copied()
        .filter(|l| !l.starts_with("# "))
        .collect();
    assert_eq!(shown, tested);
}

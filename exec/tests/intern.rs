//! A model's description (its names and tables, handed out as `'static` like a compiled
//! model's) is stored once per distinct content: loading the same model many times, as a
//! notebook or a sweep does, does not grow what the process holds. One test in its own binary,
//! so no other load runs beside it.

use lasalle_exec::{interned, Backend, LoadedModel};
use lasalle_runtime::ModelInfo;

#[test]
fn loading_a_model_again_interns_nothing_new() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/rigid_body.lsl");
    let first = LoadedModel::load(path, Backend::Interpreter).unwrap();
    let after_first = interned();
    assert!(
        after_first.names > 10 && after_first.tables > 5,
        "{after_first:?}"
    );
    for _ in 0..50 {
        let again = LoadedModel::load(path, Backend::Interpreter).unwrap();
        assert!(std::ptr::eq(again.model_name(), first.model_name()));
        assert!(std::ptr::eq(again.state_slots(), first.state_slots()));
        assert!(std::ptr::eq(
            again.invariant_infos(),
            first.invariant_infos()
        ));
        assert!(std::ptr::eq(again.gain_names(), first.gain_names()));
    }
    assert_eq!(interned(), after_first);
    // another model adds its own names and tables, and only once
    let other = concat!(env!("CARGO_MANIFEST_DIR"), "/../models/kepler.lsl");
    LoadedModel::load(other, Backend::Interpreter).unwrap();
    let with_other = interned();
    assert!(with_other.names > after_first.names, "{with_other:?}");
    for _ in 0..10 {
        LoadedModel::load(other, Backend::Interpreter).unwrap();
    }
    assert_eq!(interned(), with_other);
}

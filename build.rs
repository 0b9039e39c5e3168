//! Generates a module for every model in `models/` (and the variational equations of a few)
//! into `$OUT_DIR/models.rs`, and embeds the
//! model files themselves (`$OUT_DIR/model_files.rs`) so the command line finds them by name
//! from any directory.

use std::fmt::Write;
use std::path::PathBuf;

fn main() {
    // The variational equations of three models, as emitted Rust, for the tests that hold
    // them against the JIT's: the state-transition matrix, and 2 tangent vectors.
    use lasalle_codegen::variational::Extension::Variational;
    let built = lasalle_codegen::Builder::new()
        .models_in("models")
        .model_extended("models/kepler.lsl", Variational { tangents: 6 })
        .model_extended("models/henon_heiles.lsl", Variational { tangents: 4 })
        .model_extended("models/henon_heiles.lsl", Variational { tangents: 2 })
        .model_extended("models/rigid_body.lsl", Variational { tangents: 3 })
        .build();
    if let Err(e) = built {
        // Cargo shows a failing build script's stderr: file:line:col and the snippet.
        eprintln!("{e}");
        std::process::exit(1);
    }
    let dir =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo")).join("models");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("models/ exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
        .collect();
    files.sort();
    let mut out = String::from(
        "/// The repository's model files, embedded: (file stem, text), sorted by name.\n\
         pub const MODEL_FILES: &[(&str, &str)] = &[\n",
    );
    for f in &files {
        let stem = f.file_stem().expect("a file").to_string_lossy();
        writeln!(
            out,
            "    ({stem:?}, include_str!({:?})),",
            f.display().to_string()
        )
        .unwrap();
    }
    out.push_str("];\n");
    let target =
        PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo")).join("model_files.rs");
    std::fs::write(target, out).expect("OUT_DIR is writable");
    println!("cargo:rerun-if-changed=models");
}

//! Generates a module for every model in `models/` (and the variational equations of a few)
//! into `$OUT_DIR/models.rs` (the model files themselves are embedded by `lasalle-run`, for
//! every front end).

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
    let built = match built {
        Ok(built) => built,
        Err(e) => {
            // Cargo shows a failing build script's stderr: file:line:col and the snippet.
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    loop_forms();
    let dir =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo")).join("models");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("models/ exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
        .collect();
    files.sort();
    model_list(&built, &files);
    println!("cargo:rerun-if-changed=models");
    println!("cargo:rerun-if-changed=tests/models/loop_ring.lsl");
}

/// `$OUT_DIR/model_list.rs`: the macro `for_each_model!(callback)`, which calls
/// `callback!(module, Type, TypePrepared, "file.lsl", loops: _, invariants: _, partitioned: _,
/// hamiltonian: _);` for every model file of `models/` (`files`, sorted), so that a test covers
/// every model file, present and future, by `include!`-ing it. The flags are read off the
/// generated model: `loops` for a model emitted in its loop form (which has no Taylor kernels or
/// lanes), `invariants` where the model declares integrals or constraints (so that V reads
/// targets and gains), `partitioned` where the prepared model implements `Partitioned` (and the
/// lanes the half-fields), `hamiltonian` where the lanes evaluate the Hamiltonian; a wrong flag
/// fails to compile, and the tests that use them check them against the model's tapes.
fn model_list(built: &lasalle_codegen::Generated, files: &[PathBuf]) {
    let mut calls = String::new();
    for f in files {
        // the plain models come first, the extended ones (same file) after them
        let m = built
            .models
            .iter()
            .find(|m| m.path.file_name() == f.file_name())
            .expect("every model file is generated");
        let loops = !m.code.contains("pub type TaylorField");
        let invariants = !m.report.conservation.is_empty();
        let partitioned = m.code.contains("fn field_q(");
        let hamiltonian = m.code.contains("pub fn hamiltonian<const K");
        let file = f.file_name().expect("a file").to_string_lossy();
        writeln!(
            calls,
            "        $m!({module}, {name}, {name}Prepared, {file:?}, loops: {loops}, \
             invariants: {invariants}, partitioned: {partitioned}, hamiltonian: {hamiltonian});",
            module = m.module,
            name = m.name
        )
        .unwrap();
    }
    let text = format!(
        "/// Calls `$m!(module, Type, TypePrepared, \"file.lsl\", loops: bool, invariants: bool,\n\
         /// partitioned: bool, hamiltonian: bool);` for every model file of `models/`, sorted by file name.\n\
         #[allow(unused_macros)]\n\
         macro_rules! for_each_model {{\n    ($m:ident) => {{\n{calls}    }};\n}}\n"
    );
    let target =
        PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo")).join("model_list.rs");
    lasalle_codegen::write_if_changed(&target, &text).expect("OUT_DIR is writable");
}

/// The loop forms of the N-body and FPUT families at three sizes each (`param n` set on its
/// line) and of the periodic chain of `tests/models/loop_ring.lsl`, into
/// `$OUT_DIR/loop_forms.rs`, for the test that holds them against the JIT's loop kernels
/// (`tests/loops_emitted.rs`, which sets the sizes the same way).
fn loop_forms() {
    let mut models = Vec::new();
    let forms: [(&str, &[usize]); 3] = [
        ("models/nbody", &[3, 9, 20]),
        ("models/fput", &[5, 12, 40]),
        ("tests/models/loop_ring", &[7]),
    ];
    for (file, sizes) in forms {
        let text = std::fs::read_to_string(format!("{file}.lsl")).expect("a model file");
        let file = file.rsplit('/').next().expect("a file name");
        for &n in sizes {
            let line = text
                .lines()
                .find(|l| l.trim_start().starts_with("param n = "))
                .expect("a `param n = …;` line");
            let sized = text.replace(line, &format!("    param n = {n};"));
            let path = format!("{file}_{n}.lsl");
            let families = lasalle_codegen::Families::Loops;
            match lasalle_codegen::generate_source_with(&path, &sized, families) {
                Ok(m) => models.push(m),
                Err(e) => {
                    eprintln!("{e}");
                    std::process::exit(1);
                }
            }
        }
    }
    let code = lasalle_codegen::Generated { models }.module_file();
    let target =
        PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo")).join("loop_forms.rs");
    lasalle_codegen::write_if_changed(&target, &code).expect("OUT_DIR is writable");
}

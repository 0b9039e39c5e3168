//! Generates a module for every model in `models/` into `$OUT_DIR/models.rs`, and embeds the
//! model files themselves (`$OUT_DIR/model_files.rs`) so the command line finds them by name
//! from any directory.

use std::fmt::Write;
use std::path::PathBuf;

fn main() {
    if let Err(e) = lasalle_codegen::Builder::new().models_in("models").build() {
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

//! Embeds the repository's model files (`../models/*.lsl`) as `$OUT_DIR/model_files.rs`, so
//! every front end finds them by name from any directory ([`crate::builtin`]). Built outside
//! the repository (no `../models`), the table is empty and names are refused with the usual
//! message.

use std::fmt::Write;
use std::path::PathBuf;

fn main() {
    let dir = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"))
        .join("..")
        .join("models");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    let mut out = String::from(
        "/// The repository's model files, embedded: (file stem, text), sorted by name.\n\
         pub const MODEL_FILES: &[(&str, &str)] = &[\n",
    );
    for f in &files {
        let stem = f.file_stem().expect("a file").to_string_lossy();
        let path = f.canonicalize().unwrap_or_else(|_| f.clone());
        writeln!(
            out,
            "    ({stem:?}, include_str!({:?})),",
            path.display().to_string()
        )
        .expect("writing to a String");
    }
    out.push_str("];\n");
    let target =
        PathBuf::from(std::env::var("OUT_DIR").expect("set by cargo")).join("model_files.rs");
    std::fs::write(target, out).expect("OUT_DIR is writable");
    println!("cargo:rerun-if-changed=../models");
}

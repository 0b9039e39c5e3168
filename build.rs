//! Generates a module for every model in `models/` into `$OUT_DIR/models.rs`.

fn main() {
    if let Err(e) = lasalle_codegen::Builder::new().models_in("models").build() {
        // Cargo shows a failing build script's stderr: file:line:col and the snippet.
        eprintln!("{e}");
        std::process::exit(1);
    }
}

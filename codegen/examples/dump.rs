//! Writes the generated code of every model file given to stdout (to compare generator versions).
fn main() {
    for path in std::env::args().skip(1) {
        match lasalle_codegen::generate_file(&path) {
            Ok(m) => println!("// {path}\n{}", m.code),
            Err(e) => println!("// {path}\n{e}"),
        }
    }
}

//! The `lasalle` command line: generate code from models, run them, reproduce the paper's
//! experiments and compute Birkhoff normal forms.

mod cli;

fn main() {
    if let Err(e) = cli::main() {
        let text = e.to_string();
        // Model diagnostics already start with `error:` and carry file:line:col.
        if text.starts_with("error") {
            eprintln!("{text}");
        } else {
            eprintln!("error: {text}");
        }
        std::process::exit(1);
    }
}

//! The `lasalle` command line: generate code from models, run them, reproduce the paper's
//! experiments and compute Birkhoff normal forms.

mod cli;

/// Exit codes: 0 success, 1 a model error or a run that failed (diverged, left its domain),
/// 2 a mistake in the command line.
fn main() {
    if let Err(e) = cli::main() {
        let text = e.to_string();
        // Model diagnostics already start with `error:` and carry file:line:col.
        if text.starts_with("error") {
            eprintln!("{text}");
        } else {
            eprintln!("error: {text}");
        }
        std::process::exit(if e.is::<cli::Usage>() { 2 } else { 1 });
    }
}

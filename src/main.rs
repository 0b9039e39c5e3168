//! The `lasalle` command line: generate code from models, run them, reproduce the paper's
//! experiments and compute Birkhoff normal forms.

mod cli;

/// Exit codes: 0 success, then [`cli::exit_code`]'s table (1 a failed run, 2 a mistake in
/// the command line, 3 a model that does not load).
fn main() {
    // A reader that closes the pipe early (`lasalle run … | head -1`) ends the process quietly,
    // as it ends `cat`; Rust ignores SIGPIPE by default, and the next print would panic.
    #[cfg(unix)]
    // SAFETY: sets the default disposition of one signal, before any other thread exists.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    if let Err(e) = cli::main() {
        let text = e.to_string();
        // Model diagnostics already start with `error:` and carry file:line:col.
        if text.starts_with("error") {
            eprintln!("{text}");
        } else {
            eprintln!("error: {text}");
        }
        std::process::exit(cli::exit_code(e.as_ref()));
    }
}

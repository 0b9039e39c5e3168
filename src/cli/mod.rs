//! Subcommands. Each lives in its own module; this file only parses arguments and dispatches.

mod gen;

use clap::{Parser, Subcommand};

/// The error type of the command line: any error, shown with its message.
pub type CliResult<T = ()> = Result<T, Box<dyn std::error::Error>>;

/// lasalle: symbolic-to-numeric code generation for structure-preserving simulation.
#[derive(Parser)]
#[command(name = "lasalle", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate Rust from a model file: print it, or write a standalone crate.
    Gen(gen::GenArgs),
}

/// Parses the command line and runs the subcommand.
pub fn main() -> CliResult {
    match Cli::parse().command {
        Command::Gen(args) => gen::run(&args),
    }
}

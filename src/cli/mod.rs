//! Subcommands. Each lives in its own module; this file only parses arguments and dispatches.

mod attraction;
mod bench;
mod experiment;
mod gen;
mod load;
mod normal_form;
mod plot;
mod run;
mod sim;
mod stability;
mod stability_figure;
mod sweep;

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
    /// Integrate a model with one method; write trace.csv and summary.json.
    Run(run::RunArgs),
    /// Reproduce the paper's §4 experiments (rigid-body, kepler, perturbed-kepler) or the
    /// gain study (gains): data, tables and figures.
    Experiment(experiment::ExperimentArgs),
    /// Birkhoff normal form of a Hamiltonian model at an elliptic equilibrium.
    NormalForm(normal_form::NormalFormArgs),
    /// One run per point of a parameter grid or per row of a list, in parallel; `--shard i/n`
    /// for a cluster's array jobs; one table.
    Sweep(sweep::SweepArgs),
    /// Join the tables of a sharded sweep, checking that every row is there once.
    SweepMerge(sweep::MergeArgs),
    /// Stability of equilibria, the analysis chosen by the model's structure: Lie–Poisson
    /// (energy–Casimir over Casimir levels), canonical (Arnold–Moser, time bounds for tubes
    /// from the normal form), none (domains of attraction of a dissipative planar field).
    Stability(stability::StabilityArgs),
    /// CPU time of the JIT-compiled feedback field per state, one and k states per call, as
    /// one JSON line (for benchmarks against other integrators).
    BenchEval(bench::BenchEvalArgs),
}

/// Parses the command line and runs the subcommand.
pub fn main() -> CliResult {
    match Cli::parse().command {
        Command::Gen(args) => gen::run(&args),
        Command::Run(args) => run::run(&args),
        Command::Experiment(args) => experiment::run(&args),
        Command::NormalForm(args) => normal_form::run(&args),
        Command::Sweep(args) => sweep::run(&args),
        Command::SweepMerge(args) => sweep::merge(&args),
        Command::Stability(args) => stability::run(&args),
        Command::BenchEval(args) => bench::run(&args),
    }
}

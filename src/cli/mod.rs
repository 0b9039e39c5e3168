//! Subcommands. Each lives in its own module; this file only parses arguments and dispatches.

mod args;
mod attraction;
mod bench;
mod center_manifold;
mod chaos;
mod experiment;
mod gen;
mod infante;
mod load;
mod normal_form;
mod plot;
mod progress;
mod run;
mod section;
mod stability;
mod stability_figure;
mod sweep;

use std::collections::BTreeSet;
use std::fmt;

use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory, FromArgMatches, Parser, Subcommand};

/// The error type of the command line: any error, shown with its message.
pub type CliResult<T = ()> = Result<T, Box<dyn std::error::Error>>;

/// A mistake in the command line — a flag's value, a flag that does not apply, an unknown
/// name — as opposed to a run that failed: exit code 2, as for the parser's own errors.
#[derive(Debug)]
pub struct Usage(pub String);

impl fmt::Display for Usage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// `message` as a [`Usage`] error.
pub fn usage(message: impl fmt::Display) -> Box<dyn std::error::Error> {
    Box::new(Usage(message.to_string()))
}

/// A model file that does not read, check or compile — a syntax error, an unknown symbol, a
/// shape mismatch, a declared integral that is not conserved: exit code 3, so that a script
/// can tell a broken model from a run that failed and from a mistyped flag.
#[derive(Debug)]
pub struct ModelFailure(pub String);

impl fmt::Display for ModelFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ModelFailure {}

/// A model's diagnostic as a [`ModelFailure`].
pub fn model_failure(diagnostic: impl fmt::Display) -> Box<dyn std::error::Error> {
    Box::new(ModelFailure(diagnostic.to_string()))
}

/// The exit code of a command that ended with `error`, the same for every subcommand:
/// 1 a run or computation that failed (diverged, left its domain, found no bound), 2 a
/// mistake in the command line ([`Usage`]), 3 a model that does not load ([`ModelFailure`]).
pub fn exit_code(error: &(dyn std::error::Error + 'static)) -> i32 {
    if error.is::<Usage>() {
        2
    } else if error.is::<ModelFailure>() {
        3
    } else {
        1
    }
}

/// The flags given on the command line (not defaults), by argument id (`time_bound`), so that
/// a flag that does not apply to the chosen method or model is refused instead of ignored.
#[derive(Debug, Default)]
pub struct Given(BTreeSet<String>);

impl Given {
    fn from_matches(m: &ArgMatches) -> Given {
        Given(
            m.ids()
                .filter(|id| m.value_source(id.as_str()) == Some(ValueSource::CommandLine))
                .map(|id| id.to_string())
                .collect(),
        )
    }

    /// Was `--<id>` given?
    pub fn has(&self, id: &str) -> bool {
        self.0.contains(id)
    }

    /// Refuses the first of `ids` that was given: "--<flag> <why>".
    pub fn refuse(&self, ids: &[&str], why: &str) -> CliResult {
        match ids.iter().find(|id| self.has(id)) {
            Some(id) => Err(usage(format!("--{} {why}", id.replace('_', "-")))),
            None => Ok(()),
        }
    }
}

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
    /// A Poincaré section: the crossings of a model's event by many orbits, as CSV and a figure.
    Section(section::SectionArgs),
    /// Infante's stability criterion for x⁽ⁿ⁾ + p₁(t)x⁽ⁿ⁻¹⁾ + … + pₙ(t)x = 0 on a model in
    /// companion form: w(t) of the paraboloid (2.20) along t, and its smallest value.
    Infante(infante::InfanteArgs),
}

/// Parses the command line and runs the subcommand. A malformed command line is a
/// [`Usage`] error in one line (the parser's message and its tip, without the usage text).
pub fn main() -> CliResult {
    let matches = match Cli::command().try_get_matches() {
        Ok(m) => m,
        Err(e) if !e.use_stderr() => e.exit(), // --help, --version
        Err(e) => return Err(usage(one_line(&e.render().to_string()))),
    };
    let cli = Cli::from_arg_matches(&matches).map_err(|e| usage(one_line(&e.to_string())))?;
    let given = matches
        .subcommand()
        .map(|(_, m)| Given::from_matches(m))
        .unwrap_or_default();
    match cli.command {
        Command::Gen(args) => gen::run(&args),
        Command::Run(args) => run::run(&args, &given),
        Command::Experiment(args) => experiment::run(&args),
        Command::NormalForm(args) => normal_form::run(&args),
        Command::Sweep(args) => sweep::run(&args, &given),
        Command::SweepMerge(args) => sweep::merge(&args),
        Command::Stability(args) => stability::run(&args, &given),
        Command::BenchEval(args) => bench::run(&args),
        Command::Section(args) => section::run(&args, &given),
        Command::Infante(args) => infante::run(&args),
    }
}

/// The parser's message on one line: its first paragraph (the message and what it lists,
/// without `error: `), the possible values and its tip.
fn one_line(text: &str) -> String {
    let text = text.trim().strip_prefix("error: ").unwrap_or(text.trim());
    let mut paragraphs = text.split("\n\n");
    let first: Vec<&str> = paragraphs
        .next()
        .unwrap_or("invalid command line")
        .lines()
        .map(str::trim)
        .collect();
    let notes: Vec<&str> = paragraphs
        .flat_map(str::lines)
        .map(str::trim)
        .filter(|l| l.starts_with("tip:"))
        .collect();
    let mut line = first.join(" ");
    if !notes.is_empty() {
        line = format!("{line} ({})", notes.join("; "));
    }
    line
}

/// Parsers of flag values: what clap checks is refused before anything runs, with exit code 2.
pub mod value {
    /// A finite number > 0.
    pub fn positive(s: &str) -> Result<f64, String> {
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
            _ => Err(format!("`{s}` is not a positive finite number")),
        }
    }

    /// An end time: a finite number other than 0; a negative one integrates backwards.
    pub fn end_time(s: &str) -> Result<f64, String> {
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v != 0.0 => Ok(v),
            _ => Err(format!(
                "`{s}` is not a finite number other than 0 (a negative end time integrates \
                 backwards)"
            )),
        }
    }

    /// A finite number ≥ 0.
    pub fn non_negative(s: &str) -> Result<f64, String> {
        match s.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
            _ => Err(format!("`{s}` is not a finite number ≥ 0")),
        }
    }

    /// A whole number ≥ 1.
    pub fn count(s: &str) -> Result<u64, String> {
        match s.trim().parse::<u64>() {
            Ok(v) if v >= 1 => Ok(v),
            _ => Err(format!("`{s}` is not a whole number ≥ 1")),
        }
    }

    /// A whole number ≥ 1, as a size.
    pub fn size(s: &str) -> Result<usize, String> {
        count(s).and_then(|v| usize::try_from(v).map_err(|_| format!("`{s}` is too large")))
    }
}

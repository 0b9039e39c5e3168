//! Finding and loading a model: a path to any `.lsl` file, or the name of one of the
//! repository's models (embedded in the binary, so the names work from any directory).

use lasalle::exec::Families;
use lasalle::{Backend, LoadedModel};

use super::{model_failure, usage, CliResult};

/// Which back end runs a loaded model (`--backend`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum BackendArg {
    /// Native code compiled by Cranelift when the model is loaded (the default).
    #[default]
    Jit,
    /// An interpreter of the model's tapes (no code generation; slower).
    Interpreter,
}

impl From<BackendArg> for Backend {
    fn from(b: BackendArg) -> Backend {
        match b {
            BackendArg::Jit => Backend::Jit,
            BackendArg::Interpreter => Backend::Interpreter,
        }
    }
}

/// How a model's families are compiled (`--families`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum FamiliesArg {
    /// Loops for the sums of at least 64 index tuples, the others written out.
    #[default]
    Auto,
    /// Every sum whose term reads members of indexed state and parameters is a loop.
    Loops,
    /// Every family written out term by term.
    Unrolled,
}

/// `--families`, declared once for every subcommand that loads a model file.
#[derive(Clone, Copy, Debug, Default, clap::Args)]
pub struct FamiliesOpt {
    /// How the model's families (`sum(i in 0..n: …)`) are compiled: as loops, one per sum,
    /// for the sums of at least 64 index tuples (auto), for every sum that can be (loops), or
    /// written out term by term (unrolled). Loops load large models in a fraction of the time;
    /// the functions that have no loop form (the variational equations, anything a loop
    /// refuses) are built from the unrolled model when a method first needs them.
    #[arg(long, value_enum, default_value_t)]
    pub families: FamiliesArg,
}

impl From<FamiliesOpt> for Families {
    fn from(f: FamiliesOpt) -> Families {
        f.families.into()
    }
}

impl From<FamiliesArg> for Families {
    fn from(f: FamiliesArg) -> Families {
        match f {
            FamiliesArg::Auto => Families::Auto,
            FamiliesArg::Loops => Families::Loops,
            FamiliesArg::Unrolled => Families::Unrolled,
        }
    }
}

/// The text of a model given as a path or a name ([`lasalle::run::model_text`]), with the path
/// to show in messages and the name to use for output directories (the file stem). A model
/// that is not there is a [`super::Usage`] error.
pub fn model_text(arg: &str) -> CliResult<(String, String, String)> {
    let found = lasalle::run::model_text(arg).map_err(|e| usage(e.to_string()))?;
    Ok((found.path, found.stem, found.text))
}

/// Loads a model given as a path or a name and compiles it with `backend`.
pub fn load(arg: &str, backend: Backend) -> CliResult<(LoadedModel, String)> {
    load_with(arg, backend, Families::Unrolled)
}

/// [`load`], with its families compiled as `families` says.
pub fn load_with(
    arg: &str,
    backend: Backend,
    families: Families,
) -> CliResult<(LoadedModel, String)> {
    let (path, stem, text) = model_text(arg)?;
    let model =
        LoadedModel::from_source_with(&path, &text, backend, families).map_err(model_failure)?;
    Ok((model, stem))
}

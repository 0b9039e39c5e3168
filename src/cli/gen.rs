//! `lasalle gen <model> [--out <file>] [--stats] [--variational [--tangents K] | --indicators]`;
//! with `--crate <dir> [--runtime-path <path> | --runtime-registry]` a standalone crate.

use super::CliResult;
use clap::Args;
use lasalle_codegen::variational::Extension;
use std::path::{Path, PathBuf};

/// Arguments of `lasalle gen`.
#[derive(Args)]
pub struct GenArgs {
    /// The model: a path to a model file (`.lsl`) or the name of a built-in model.
    model: String,
    /// Write a standalone crate (Cargo.toml + src/lib.rs depending on lasalle-runtime, and the
    /// checkout's Cargo.lock with the runtime sources) here, named after the model
    /// (`model RigidBody` → `rigid-body-model`).
    #[arg(long = "crate", value_name = "DIR")]
    crate_dir: Option<PathBuf>,
    /// Write the generated module to this file instead of standard output.
    #[arg(long, value_name = "FILE", conflicts_with = "crate_dir")]
    out: Option<PathBuf>,
    /// The generated crate depends on lasalle-runtime at this path, written into its
    /// Cargo.toml as given (a relative path is relative to the crate's directory). Default: the
    /// runtime sources this lasalle was built from, by a path relative to the crate, when they
    /// are still there; else the version of lasalle-runtime this lasalle was built with.
    #[arg(long, value_name = "PATH", requires = "crate_dir")]
    runtime_path: Option<PathBuf>,
    /// The generated crate depends on lasalle-runtime by version, from crates.io, even when the
    /// runtime sources this lasalle was built from are here (a crate to publish or to move).
    #[arg(long, requires = "crate_dir", conflicts_with = "runtime_path")]
    runtime_registry: bool,
    /// Emit the model's variational equations: the state (x, Φ) and the field (X, DX·Φ), DX
    /// derived symbolically, as the model `<Model>Variational` in the module
    /// `<file>_variational`. Φ is the state-transition matrix (N×N, Φ(0) = I), or K tangent
    /// vectors with --tangents K.
    #[arg(long)]
    variational: bool,
    /// With --variational: the number K of tangent vectors (1 ≤ K ≤ N), the columns of the
    /// N×K matrix Φ, which start as the first K columns of the identity.
    #[arg(long, value_name = "K", requires = "variational")]
    tangents: Option<usize>,
    /// Emit the model extended for the chaos indicators (a unit tangent vector and the
    /// integrals of its growth rate: the maximal Lyapunov exponent, MEGNO), as the model
    /// `<Model>Indicators` in the module `<file>_indicators`.
    #[arg(long, conflicts_with = "variational")]
    indicators: bool,
    /// How the model's families (`sum(i in 0..n: …)`) are compiled: as loops, one per sum,
    /// for the sums of at least 64 index tuples (auto), for every sum that can be (loops), or
    /// written out term by term (unrolled). With loops the module has the field, the
    /// invariants, their Jacobian, V, ∇V, X − ∇V and the half-fields as loops over the
    /// families' ranges, its size independent of theirs, and leaves out what has no loop form
    /// (the Taylor kernels, the lanes of the derived functions); unrolled emits them all.
    #[arg(long, value_enum, default_value_t)]
    families: super::load::FamiliesArg,
    /// Print operation counts, conservation verdicts, time and size to standard error.
    #[arg(long)]
    stats: bool,
}

/// Runs `lasalle gen`.
pub fn run(args: &GenArgs) -> CliResult {
    let (path, _, text) = super::load::model_text(&args.model)?;
    let model = match extension(args, &path, &text)? {
        Some(e) => {
            lasalle_codegen::generate_extended(&path, &text, e).map_err(super::model_failure)?
        }
        None => lasalle_codegen::generate_source_with(&path, &text, args.families.into())
            .map_err(super::model_failure)?,
    };
    if args.stats {
        print_stats(&model);
    }
    let generated = lasalle_codegen::Generated {
        models: vec![model],
    };
    match (&args.crate_dir, &args.out) {
        (Some(dir), _) => {
            let sources = runtime_sources();
            let runtime = match (&args.runtime_path, &sources) {
                (Some(p), _) => Runtime::Path(p.clone()),
                (None, Some(s)) if !args.runtime_registry => Runtime::Sources(s.clone()),
                (None, _) => Runtime::Version(VERSION),
            };
            let dependency = write_crate(dir, &generated, &runtime)?;
            eprintln!(
                "wrote crate `{}` to {}",
                crate_name(&generated),
                dir.display()
            );
            eprintln!("  lasalle-runtime = {dependency}");
            match &runtime {
                Runtime::Path(_) => eprintln!("  (--runtime-path, as given)"),
                Runtime::Sources(s) => {
                    eprintln!(
                        "  (the runtime sources this lasalle was built from, {}; \
                         --runtime-registry for the version on crates.io instead)",
                        s.display()
                    );
                    if let Some(lock) = seed_lock(dir, s)? {
                        eprintln!(
                            "  Cargo.lock: the versions of {}, so the first build needs no \
                             registry update",
                            lock.display()
                        );
                    }
                }
                Runtime::Version(_) => eprintln!("{}", version_note(dir, sources.as_deref())),
            }
        }
        (None, Some(file)) => {
            std::fs::write(file, generated.module_file()).map_err(|e| cannot_write(file, e))?
        }
        (None, None) => print!("{}", generated.module_file()),
    }
    Ok(())
}

/// The extension `--variational [--tangents K]` or `--indicators` asks for.
fn extension(args: &GenArgs, path: &str, text: &str) -> CliResult<Option<Extension>> {
    if !(args.indicators || args.variational) {
        return Ok(None);
    }
    if args.families == super::load::FamiliesArg::Loops {
        return Err(super::usage(
            "--families loops: the variational equations and the chaos indicators have no loop \
             form in the emitted Rust; use --families auto or unrolled (they are emitted unrolled)"
                .to_string(),
        ));
    }
    if args.indicators {
        return Ok(Some(Extension::Indicators));
    }
    let n = lasalle_codegen::lower_source(path, text)
        .map_err(super::model_failure)?
        .dim();
    let tangents = args.tangents.unwrap_or(n);
    if !(1..=n).contains(&tangents) {
        return Err(super::usage(format!(
            "--tangents {tangents}: the number of tangent vectors is between 1 and the state's \
             dimension, {n}, for {path}"
        )));
    }
    Ok(Some(Extension::Variational { tangents }))
}

fn cannot_write(path: &Path, e: std::io::Error) -> String {
    format!("cannot write {}: {e}", path.display())
}

/// The crate's name, after the model (not the file): `model RigidBody` → `rigid-body-model`.
fn crate_name(generated: &lasalle_codegen::Generated) -> String {
    let model = &generated.models[0];
    format!(
        "{}-model",
        lasalle_codegen::snake(&model.name).replace('_', "-")
    )
}

/// The version of lasalle-runtime this lasalle was built with (the workspace's one version).
const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The runtime sources this lasalle was built from, if they are still there: the directory
/// `runtime` of the checkout, holding the manifest of `lasalle-runtime`.
fn runtime_sources() -> Option<PathBuf> {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/runtime"));
    let manifest = std::fs::read_to_string(dir.join("Cargo.toml")).ok()?;
    manifest
        .lines()
        .any(|l| l.trim() == "name = \"lasalle-runtime\"")
        .then(|| dir.canonicalize().ok())
        .flatten()
}

/// What to do when the registry has no lasalle-runtime of this version: the flag, or the line
/// of the crate's manifest to change. `sources`: the runtime sources this lasalle was built
/// from, if they are there (then the crate depends on the version because it was asked to).
fn version_note(dir: &Path, sources: Option<&Path>) -> String {
    let (why, path) = match sources {
        Some(s) => {
            let from_crate = dir.canonicalize().ok().and_then(|d| relative(&d, s));
            let path = from_crate.as_deref().unwrap_or(s).display().to_string();
            ("--runtime-registry".to_string(), path)
        }
        None => (
            format!(
                "the runtime sources this lasalle was built from, {}/runtime, are not there",
                env!("CARGO_MANIFEST_DIR")
            ),
            "PATH".to_string(),
        ),
    };
    let what = if sources.is_some() {
        ""
    } else {
        " (PATH: the `runtime` directory of a lasalle checkout, absolute or relative to the \
         crate's directory)"
    };
    format!(
        "note: the crate depends on lasalle-runtime {VERSION} from crates.io ({why}). Where \
         crates.io has no lasalle-runtime {VERSION}, build it against a lasalle checkout: run \
         `lasalle gen` again with `--runtime-path {path}`{what}, or change the line in {} to\n    \
         lasalle-runtime = {{ path = {path:?} }}",
        dir.join("Cargo.toml").display()
    )
}

/// Seeds the crate's `Cargo.lock` with the checkout's next to the runtime sources, unless it
/// has one: the crate then resolves to the versions the runtime was built and tested with
/// without asking the registry, so it builds offline from the registry cache the checkout's
/// build filled (Cargo drops the entries the crate does not use). Returns the lock copied.
fn seed_lock(dir: &Path, sources: &Path) -> CliResult<Option<PathBuf>> {
    let lock = dir.join("Cargo.lock");
    let checkout = match sources.parent() {
        Some(root) if !lock.exists() => root.join("Cargo.lock"),
        _ => return Ok(None),
    };
    if !checkout.is_file() {
        return Ok(None);
    }
    std::fs::copy(&checkout, &lock).map_err(|e| cannot_write(&lock, e))?;
    Ok(Some(checkout))
}

/// Where a generated crate finds lasalle-runtime.
pub enum Runtime {
    /// `lasalle-runtime = "<version>"`, from the registry.
    Version(&'static str),
    /// `lasalle-runtime = { path = "<path>" }`, the path as given (relative to the crate).
    Path(PathBuf),
    /// `lasalle-runtime = { path = "<path>" }` to the runtime sources at this canonical path:
    /// relative to the crate's (canonical) directory, or absolute where there is no relative
    /// path (another drive).
    Sources(PathBuf),
}

/// Writes `Cargo.toml` and `src/lib.rs` of a crate holding the generated model; returns the
/// dependency on lasalle-runtime as written (`"0.1.0"`, `{ path = "../runtime" }`).
pub fn write_crate(
    dir: &Path,
    generated: &lasalle_codegen::Generated,
    runtime: &Runtime,
) -> CliResult<String> {
    if let Runtime::Path(p) = runtime {
        // Resolved as Cargo will: a relative path from the crate's directory, `..` taken
        // lexically (the crate's directory may not exist yet).
        let manifest = lexical(&dir.join(p)).join("Cargo.toml");
        if !manifest.is_file() {
            return Err(format!(
                "--runtime-path {}: no lasalle-runtime there ({} does not exist; a relative \
                 path is relative to the crate directory {})",
                p.display(),
                manifest.display(),
                dir.display()
            )
            .into());
        }
    }
    std::fs::create_dir_all(dir.join("src")).map_err(|e| cannot_write(dir, e))?;
    let dependency = match runtime {
        Runtime::Version(v) => format!("{v:?}"),
        Runtime::Path(p) => {
            let path = p
                .to_str()
                .ok_or_else(|| format!("--runtime-path {}: not valid UTF-8", p.display()))?;
            format!("{{ path = {path:?} }}")
        }
        Runtime::Sources(sources) => {
            let crate_dir = dir.canonicalize().map_err(|e| cannot_write(dir, e))?;
            let path = relative(&crate_dir, sources).unwrap_or_else(|| sources.clone());
            let path = path.to_str().ok_or_else(|| {
                format!(
                    "the path from {} to the runtime sources {} is not valid UTF-8: pass \
                     --runtime-path",
                    crate_dir.display(),
                    sources.display()
                )
            })?;
            format!("{{ path = {path:?} }}")
        }
    };
    // `[workspace]`: the crate is a workspace of its own, so it builds inside another one
    // (under this checkout's `target/`, say) without being listed as a member there.
    let manifest = format!(
        "[package]\nname = \"{}\"\nversion = \"0.1.0\"\nedition = \"2021\"\ndescription = \"Model generated by lasalle-codegen\"\n\n\
         [dependencies]\nlasalle-runtime = {dependency}\n\n[workspace]\n",
        crate_name(generated),
    );
    let (cargo_toml, lib) = (dir.join("Cargo.toml"), dir.join("src/lib.rs"));
    lasalle_codegen::write_if_changed(&cargo_toml, &manifest)
        .map_err(|e| cannot_write(&cargo_toml, e))?;
    lasalle_codegen::write_if_changed(&lib, &generated.crate_lib())
        .map_err(|e| cannot_write(&lib, e))?;
    Ok(dependency)
}

/// The path from the directory `from` to `to`, both absolute and canonical, with `/` between
/// its components (`../../lasalle/runtime`); `None` when they share no root (two drives).
fn relative(from: &Path, to: &Path) -> Option<PathBuf> {
    let (from, to): (Vec<_>, Vec<_>) = (from.components().collect(), to.components().collect());
    if from.first() != to.first() {
        return None;
    }
    let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
    let mut parts: Vec<&str> = vec![".."; from.len() - common];
    for c in &to[common..] {
        parts.push(c.as_os_str().to_str()?);
    }
    Some(PathBuf::from(if parts.is_empty() {
        ".".to_string()
    } else {
        parts.join("/")
    }))
}

/// `path` with `.` dropped and `a/..` removed, without asking the file system.
fn lexical(path: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir
                if matches!(out.components().next_back(), Some(Component::Normal(_))) =>
            {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

fn print_stats(m: &lasalle_codegen::GeneratedModel) {
    let s = &m.report.stats;
    eprintln!(
        "{} ({}): generated in {:.1} ms, {} lines, {} bytes",
        m.module,
        m.path.display(),
        m.report.time.as_secs_f64() * 1e3,
        m.report.lines,
        m.report.bytes
    );
    for (name, c) in [
        ("field X", s.field),
        ("invariants f", s.invariants),
        ("Jacobian Df", s.jacobian),
        ("V", s.lyapunov),
        ("∇V", s.lyapunov_gradient),
        ("X − ∇V", s.feedback_field),
    ] {
        eprintln!(
            "  {name:<14} ops: {:>6} as a tree, {:>5} after CSE, {:>5} as emitted",
            c.tree, c.cse, c.emitted
        );
    }
    for c in &m.report.conservation {
        eprintln!("  {}: {:?}", c.name, c.verdict);
    }
}

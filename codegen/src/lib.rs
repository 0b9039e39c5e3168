//! # lasalle-codegen
//!
//! The lasalle generator: a model file (`.lsl`) is parsed, lowered into one hash-consed
//! expression DAG, differentiated and simplified symbolically, checked (shapes, names,
//! conservation of every declared integral) and emitted as plain, formatted Rust that
//! implements the traits of `lasalle-runtime`.
//!
//! The front end — parse, lower, derive, check, the tapes and their Taylor program — is the
//! crate [`lasalle_model`]; this crate is emission (`syn`, `quote`, `prettyplease`), the
//! whole pipeline ([`generate_source`]) and the [`Builder`] of build scripts. It re-exports
//! the front end's pipeline, so `lasalle_codegen::lower_source`,
//! `lasalle_codegen::tape::ModelTapes` or `lasalle_codegen::Structure` name the same items as
//! in `lasalle_model`. Code that runs a model without emitting it (an interpreter, a JIT, an
//! analysis) depends on `lasalle-model` alone.
//!
//! Pipeline: parse → lower (onto [`ir`]) → derive → check → emit, each stage a function of the
//! previous stage's output type:
//!
//! ```text
//! lasalle-model    lower_source(path, text) -> Model        parse and lower onto one hash-consed graph
//!                  derive(Model)            -> Derived      Df, ∇f·X, ∇V, X − ∇V, the partition
//!                  check(&Derived)          -> Checked<'_>  every invariant conserved, every constant finite
//! lasalle-codegen  emit(&Checked)           -> Emitted      Rust items, statistics, the tape kernels
//! ```
//! ([`lower_source`], [`derive()`], [`check()`], [`emit()`]; [`generate_source`] runs them all.)
//!
//! A model's module reads as written from the formulas first (the parameter struct
//! `<Model>`, its `prepare()`, the prepared model `<Model>Prepared` that implements the
//! runtime's traits once, each output under its model line), then fences the machine kernels
//! generated from the tapes into one submodule, `kernels`, with one header and one lint
//! `allow` (see the module docs of `emit`, and `docs/dsl.md`, "What is generated").
//!
//! # What is public
//!
//! Emission's output types ([`Emitted`], [`Stats`], [`Ops`]), the generated code
//! ([`GeneratedModel`], [`Generated`], [`Report`]) and the [`Builder`] are this crate's; the
//! rest of the list — the stage functions and their output types, the lowered [`Model`] with
//! the types of its fields, the conservation verdicts, the errors, and the modules [`ir`],
//! [`tape`] and [`vocabulary`] — is re-exported from [`lasalle_model`], where it is
//! documented.
//!
//! In a build script, with the generator as a build dependency and the runtime the generated
//! code implements as a dependency (from crates.io, or by path to a lasalle checkout):
//!
//! ```toml
//! [dependencies]
//! lasalle-runtime = { path = "../lasalle/runtime" }  # or "0.1.0"
//!
//! [build-dependencies]
//! lasalle-codegen = { path = "../lasalle/codegen" }  # or "0.1.0"
//! ```
//!
//! ```no_run
//! // build.rs, inside `fn main()`:
//! if let Err(e) = lasalle_codegen::Builder::new().models_in("models").build() {
//!     eprintln!("{e}"); // file:line:col, the line, a caret and a help
//!     std::process::exit(1);
//! }
//! // src/lib.rs:  pub mod models { include!(concat!(env!("OUT_DIR"), "/models.rs")); }
//! ```
#![warn(missing_docs)]

mod emit;

pub use emit::{emit, snake, Emitted, Ops, Stats};
pub use lasalle_model::loops::Families;
pub use lasalle_model::variational;
pub use lasalle_model::{
    check, derive, ir, load_model, lower_source, tape, vocabulary, Binding, CanonicalHamiltonian,
    Checked, Conservation, Derivatives, Derived, Diagnostic, DiagnosticKind, Error, Gain, Guard,
    Hamiltonian, Invariant, InvariantKind, Model, NotCanonical, Param, Point, Preset, Result,
    Shape, Source, Span, Splitting, StateVar, Structure, Value, Verdict, GUARD_STEP,
};

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What generating one model produced and cost.
#[derive(Clone, Debug)]
pub struct Report {
    /// Operation counts of the emitted functions.
    pub stats: emit::Stats,
    /// How each invariant was shown to be conserved.
    pub conservation: Vec<Conservation>,
    /// Wall time of parse → emit → format.
    pub time: Duration,
    /// Size of the formatted code in bytes.
    pub bytes: usize,
    /// Lines of formatted code.
    pub lines: usize,
}

/// One generated model.
#[derive(Clone, Debug)]
pub struct GeneratedModel {
    /// The model's name as declared (`model RigidBody { … }`).
    pub name: String,
    /// Module name (the file stem, snake_case).
    pub module: String,
    /// Module docs.
    pub summary: String,
    /// The formatted items (struct and impls).
    pub code: String,
    /// The same items as token text (with the note markers), to build modules from.
    items: String,
    /// The module `kernels` emitted from the tapes (preludes, Taylor kernels, lanes),
    /// formatted when generated:
    /// straight-line code too large to go through the formatter again in every module file.
    tape_code: String,
    /// Statistics.
    pub report: Report,
    /// The model file.
    pub path: PathBuf,
}

/// Generates the code of one model text: the whole pipeline.
pub fn generate_source(path: &str, text: &str) -> Result<GeneratedModel> {
    let start = Instant::now();
    generate_model(path, lower_source(path, text)?, start, None)
}

/// Generates the code of one model text with its families (`sum(i in 0..n, …: …)`) kept as
/// loops as `families` says ([`Families::Auto`]: the sums of at least
/// [`AUTO_MIN_TUPLES`](lasalle_model::loops::AUTO_MIN_TUPLES) index tuples).
///
/// A model with a family kept as a loop is emitted in its loop form (see the module docs of
/// `emit::loops`): the field and the invariants as loops over the families' index ranges,
/// whose size does not depend on the number of tuples, bitwise equal to the JIT's loop
/// kernels; so are the derived functions: the prepared model implements `Field`,
/// `Invariants` (with Df), `Lyapunov` (V, ∇V, X − ∇V, in the staged kernels' three stages),
/// `Partitioned` (the half-fields, where the field is partitioned), `Declared`, `Parameters`
/// and `ModelInfo`. What has no loop form (the Taylor kernels, the derived functions' lanes,
/// the points at other than the default parameters) is left out; a guard or an event that
/// reads a family's sum is refused. A
/// model without such a family is
/// generated as [`generate_source`] does, and so is one whose families the loop form refuses
/// under [`Families::Auto`] (under [`Families::Loops`] the refusal is the error).
pub fn generate_source_with(path: &str, text: &str, families: Families) -> Result<GeneratedModel> {
    let start = Instant::now();
    if families == Families::Unrolled {
        return generate_source(path, text);
    }
    let lm = lasalle_model::loops::LoopModel::from_source(path, text, families)?;
    if lm.families().is_empty() {
        return generate_model(path, lm.unrolled()?, start, None);
    }
    let built = lm.check().and_then(|c| {
        let tapes = lm.tapes()?;
        Ok((c, tapes, emit::LoopDerived::new(&lm)?))
    });
    let (conservation, tapes, derived) = match built {
        Ok(ctd) => ctd,
        Err(_) if families == Families::Auto => {
            return generate_model(path, lm.unrolled()?, start, None)
        }
        Err(e) => return Err(e),
    };
    let (code, summary) = emit::emit_loops(&lm, &tapes, &derived, &conservation);
    let model = lm.lowered();
    let instructions = |t: &lasalle_model::loops::LoopTape| Ops {
        emitted: t.instructions() as u64,
        ..Ops::default()
    };
    let [jacobian, lyapunov, lyapunov_gradient, feedback_field] =
        derived.instructions().map(|k| Ops {
            emitted: k as u64,
            ..Ops::default()
        });
    Ok(GeneratedModel {
        name: model.name.clone(),
        module: module_name(path, &model.name, None),
        summary,
        report: Report {
            stats: Stats {
                field: instructions(&tapes.field),
                invariants: instructions(&tapes.invariants),
                jacobian,
                lyapunov,
                lyapunov_gradient,
                feedback_field,
            },
            conservation,
            time: start.elapsed(),
            bytes: code.len(),
            lines: code.lines().count(),
        },
        items: String::new(),
        tape_code: code.clone(),
        code,
        path: PathBuf::from(path),
    })
}

/// The module of a model generated from `path` (its file stem, snake_case; the model's name if
/// the path has none), with the extension's suffix.
fn module_name(
    path: &str,
    name: &str,
    extension: Option<(variational::Extension, usize)>,
) -> String {
    let stem = Path::new(path)
        .file_stem()
        .map_or_else(|| name.to_string(), |s| s.to_string_lossy().into_owned());
    let module = emit::snake(&stem).replace(|c: char| !c.is_ascii_alphanumeric() && c != '_', "_");
    let module = match extension {
        Some((e, n)) => format!("{module}{}", extension_suffix(e, n).1),
        None => module,
    };
    // `fn.lsl`, `self.lsl`, `1d.lsl`, `_.lsl` still name a valid module: `fn_`, `self_`, `v1d`, `v_`.
    lasalle_model::names::identifier(&module)
}

/// Generates the code of one model text extended by `extension`
/// ([`lasalle_model::variational`]): the variational field (X, DX·Φ) of k tangent vectors
/// (k = N: the state-transition matrix), or the unit tangent vector and the integrals of its
/// growth rate behind the chaos indicators. DX is derived symbolically and the extended model
/// is emitted like any other, so its field is the one the JIT and the interpreter compile for
/// the same extension.
///
/// The model is renamed after the extension and so is its module, so a crate can hold a model
/// and its extensions side by side: `model Kepler` in `kepler.lsl` becomes `KeplerVariational`
/// in `kepler_variational` (the state-transition matrix), `KeplerVariational2` in
/// `kepler_variational_2` (2 tangent vectors) or `KeplerIndicators` in `kepler_indicators`. Its
/// state is the extended state: x, then Φ (an N×k state variable `Phi`, column by column);
/// its points start Φ at the first k columns of the identity
/// ([`Extension::extend_state`](variational::Extension::extend_state)). It declares no
/// partition or splitting: only the methods that integrate the field as it is (Euler, Heun,
/// RK4, DOPRI5, Taylor) keep Φ in step with x.
pub fn generate_extended(
    path: &str,
    text: &str,
    extension: variational::Extension,
) -> Result<GeneratedModel> {
    let start = Instant::now();
    let model = lower_source(path, text)?;
    let mut extended = extension.apply(&model)?;
    extended.name = format!(
        "{}{}",
        model.name,
        extension_suffix(extension, model.dim()).0
    );
    describe_extension(&mut extended, extension, model.state.len());
    let base = (extension, model.name.clone(), model.dim());
    generate_model(path, extended, start, Some(base))
}

/// The suffixes of an extended model's name and module, for a model of dimension `n`:
/// `Variational`/`_variational` for the state-transition matrix, `Variational2`/
/// `_variational_2` for 2 tangent vectors, `Indicators`/`_indicators`.
fn extension_suffix(extension: variational::Extension, n: usize) -> (String, String) {
    match extension {
        variational::Extension::Variational { tangents } if tangents == n => {
            ("Variational".into(), "_variational".into())
        }
        variational::Extension::Variational { tangents } => (
            format!("Variational{tangents}"),
            format!("_variational_{tangents}"),
        ),
        variational::Extension::Indicators => ("Indicators".into(), "_indicators".into()),
    }
}

/// Points the field's added components at text of their own, quoted above them in the
/// emitted code (`// d/dt Phi = DX * Phi …`) where a model line is quoted for the others.
/// `first`: the index of the first state variable the extension added.
fn describe_extension(model: &mut Model, extension: variational::Extension, first: usize) {
    let added = &model.state[first..];
    let name = |k: usize| added[k].name.as_str();
    let lines: Vec<String> = match extension {
        variational::Extension::Variational { .. } => vec![format!(
            "d/dt {} = DX * {}   (the variational equations, DX = ∂X/∂x derived symbolically)",
            name(0),
            name(0)
        )],
        variational::Extension::Indicators => vec![
            format!(
                "d/dt {u} = DX * {u} - λ {u},   λ = {u}·DX·{u} / ({u}·{u})   (a unit tangent vector)",
                u = name(0)
            ),
            format!("d/dt {} = λ", name(1)),
            format!("d/dt {} = 1", name(2)),
            format!("d/dt {} = {} λ", name(3), name(2)),
            format!(
                "d/dt {} = 2 {} {} / ({}² + {:e})",
                name(4),
                name(3),
                name(2),
                name(2),
                variational::CLOCK_FLOOR
            ),
        ],
    };
    let source = std::sync::Arc::new(Source {
        path: model.source.path.clone(),
        text: lines.join("\n"),
    });
    let mut start = 0;
    let spans: Vec<Span> = lines
        .iter()
        .map(|l| {
            let span = Span {
                source: source.clone(),
                start,
                end: start + l.len(),
            };
            start += l.len() + 1;
            span
        })
        .collect();
    for (k, s) in added.iter().enumerate() {
        let span = &spans[k.min(spans.len() - 1)];
        let range = s.offset..s.offset + s.shape.len();
        model.field_spans[range].fill(span.clone());
    }
}

/// The summary's lines on what the state carries beyond x.
fn extension_note(extension: variational::Extension, base: &str, n: usize) -> String {
    match extension {
        variational::Extension::Variational { tangents } => {
            let what = if tangents == n {
                "the state-transition matrix Φ(t) = ∂x(t)/∂x(0)".to_string()
            } else {
                format!(
                    "{tangents} tangent vector{}",
                    if tangents == 1 { "" } else { "s" }
                )
            };
            format!(
                "\n\nThe variational equations of `{base}`: the state is (x, Φ), Φ the {n}×{tangents} \
                 state variable `Phi` ({what}, column by column after the {n} components of x), \
                 and the field is (X, DX·Φ), DX derived symbolically. The points start Φ at the \
                 first {tangents} columns of the identity."
            )
        }
        variational::Extension::Indicators => format!(
            "\n\nThe chaos indicators of `{base}`: the state is (x, u, ℓ, τ, a, b), u a unit \
             tangent vector, λ = u·DX·u/(u·u), u̇ = DX·u − λu, ℓ̇ = λ, τ̇ = 1, ȧ = τλ, \
             ḃ = 2aτ/(τ² + ε): ℓ/τ is the finite-time maximal Lyapunov exponent, 2a/τ MEGNO and \
             b/τ its mean (see `lasalle_model::variational`)."
        ),
    }
}

fn generate_model(
    path: &str,
    model: Model,
    start: Instant,
    extension: Option<(variational::Extension, String, usize)>,
) -> Result<GeneratedModel> {
    let derived = derive(model);
    let checked = check(&derived)?;
    let emitted = emit(&checked)?;
    let model = &derived.model;
    let mut code = emit::format(&emitted.items)?;
    code.push_str(&emitted.tape_code);
    let fallback = extension.as_ref().map_or(&model.name, |e| &e.1);
    let module = module_name(path, fallback, extension.as_ref().map(|e| (e.0, e.2)));
    let mut summary = emitted.summary;
    if let Some((e, base, n)) = extension {
        summary.truncate(summary.trim_end().len());
        summary.push_str(&extension_note(e, &base, n));
    }
    Ok(GeneratedModel {
        name: model.name.clone(),
        module,
        summary,
        report: Report {
            stats: emitted.stats,
            conservation: checked.into_conservation(),
            time: start.elapsed(),
            bytes: code.len(),
            lines: code.lines().count(),
        },
        code,
        items: emitted.items.to_string(),
        tape_code: emitted.tape_code,
        path: PathBuf::from(path),
    })
}

impl GeneratedModel {
    /// `pub mod <module> { … }` with the summary as its docs, formatted, the module `kernels`
    /// at the end.
    fn module_text(&self) -> String {
        let mut text = emit::format(&self.module_tokens())
            .expect("the items of every model parsed when they were generated");
        let end = text.trim_end().len() - 1; // the module's closing brace
        let kernels: String = self
            .tape_code
            .lines()
            .map(|l| {
                if l.is_empty() {
                    "\n".to_string()
                } else {
                    format!("    {l}\n")
                }
            })
            .collect();
        text.insert_str(end, &kernels);
        text
    }

    /// `pub mod <module> { … }` with the summary as its docs.
    fn module_tokens(&self) -> proc_macro2::TokenStream {
        let docs = self.summary.lines().map(|line| {
            if line.is_empty() {
                String::new()
            } else {
                format!(" {line}")
            }
        });
        let name = quote::format_ident!("{}", self.module);
        let items: proc_macro2::TokenStream = self
            .items
            .parse()
            .expect("the items parsed when they were generated");
        quote::quote! {
            #(#[doc = #docs])*
            pub mod #name {
                // Literals come from the model file, which may write 3.14 for a reason.
                #![allow(clippy::approx_constant)]
                #items
            }
        }
    }
}

/// Generates the code of a model file.
pub fn generate_file(path: impl AsRef<Path>) -> Result<GeneratedModel> {
    let path = path.as_ref();
    generate_source(&path.display().to_string(), &read(path)?)
}

/// Generates the code of a model file with its families kept as loops as `families` says (see
/// [`generate_source_with`]).
pub fn generate_file_with(path: impl AsRef<Path>, families: Families) -> Result<GeneratedModel> {
    let path = path.as_ref();
    generate_source_with(&path.display().to_string(), &read(path)?, families)
}

/// Generates the code of a model file extended by `extension` (see [`generate_extended`]).
pub fn generate_file_extended(
    path: impl AsRef<Path>,
    extension: variational::Extension,
) -> Result<GeneratedModel> {
    let path = path.as_ref();
    generate_extended(&path.display().to_string(), &read(path)?, extension)
}

fn read(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        source: e,
    })
}

/// The generated code of a set of models, not yet written anywhere.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The models, in the order given (directories sorted by file name).
    pub models: Vec<GeneratedModel>,
}

const HEADER: &str =
    "// @generated by lasalle-codegen. Do not edit: edit the model files instead.\n";

impl Generated {
    /// One Rust file holding a `pub mod <model>` per model, to `include!` in a crate.
    pub fn module_file(&self) -> String {
        let modules: Vec<String> = self
            .models
            .iter()
            .map(GeneratedModel::module_text)
            .collect();
        format!("{HEADER}\n{}", modules.join("\n"))
    }

    /// A standalone `lib.rs`: crate docs and the models as modules.
    pub fn crate_lib(&self) -> String {
        let mut out = String::from(HEADER);
        out.push_str("//! Models generated by lasalle-codegen from:\n");
        for m in &self.models {
            out.push_str(&format!(
                "//! - `{}` → [`{}`]\n",
                m.path.display(),
                m.module
            ));
        }
        out.push('\n');
        out.push_str(&self.module_file()[HEADER.len()..]);
        out
    }
}

/// Writes `contents` to `path` only if it differs, so unchanged output triggers no rebuild.
pub fn write_if_changed(path: &Path, contents: &str) -> std::io::Result<()> {
    if std::fs::read_to_string(path).ok().as_deref() == Some(contents) {
        return Ok(());
    }
    std::fs::write(path, contents)
}

/// Configures code generation for a build script.
#[derive(Clone, Debug, Default)]
pub struct Builder {
    models: Vec<PathBuf>,
    extended: Vec<(PathBuf, variational::Extension)>,
    dirs: Vec<PathBuf>,
    out_dir: Option<PathBuf>,
    out_file: Option<String>,
    families: Families,
}

impl Builder {
    /// A builder with no models; the output goes to `$OUT_DIR/models.rs`.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one model file.
    pub fn model(&mut self, path: impl Into<PathBuf>) -> &mut Self {
        self.models.push(path.into());
        self
    }

    /// Adds one model file extended by `extension`: its variational equations, as
    /// `Extension::Variational { tangents }` (tangents = the state's dimension: the
    /// state-transition matrix), or its chaos indicators. The module is named after the file
    /// and the extension (`kepler_variational`, `kepler_variational_2`, `kepler_indicators`; see
    /// [`generate_extended`]); it comes after the plain models, in the order added.
    pub fn model_extended(
        &mut self,
        path: impl Into<PathBuf>,
        extension: variational::Extension,
    ) -> &mut Self {
        self.extended.push((path.into(), extension));
        self
    }

    /// How the models' families are emitted (default [`Families::Auto`]; see
    /// [`generate_source_with`]). Extended models are always unrolled.
    pub fn families(&mut self, families: Families) -> &mut Self {
        self.families = families;
        self
    }

    /// Adds every `*.lsl` file of a directory (sorted by name, so output is deterministic).
    pub fn models_in(&mut self, dir: impl Into<PathBuf>) -> &mut Self {
        self.dirs.push(dir.into());
        self
    }

    /// The output directory. Default: `$OUT_DIR`.
    pub fn out_dir(&mut self, dir: impl Into<PathBuf>) -> &mut Self {
        self.out_dir = Some(dir.into());
        self
    }

    /// The output file name. Default: `models.rs`.
    pub fn out_file(&mut self, name: impl Into<String>) -> &mut Self {
        self.out_file = Some(name.into());
        self
    }

    fn paths(&self) -> Result<Vec<PathBuf>> {
        let mut paths = self.models.clone();
        for dir in &self.dirs {
            let read = std::fs::read_dir(dir).map_err(|e| Error::Io {
                path: dir.display().to_string(),
                source: e,
            })?;
            let mut found: Vec<PathBuf> = read
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "lsl"))
                .collect();
            found.sort();
            paths.extend(found);
        }
        Ok(paths)
    }

    /// Generates every model in memory; collects the errors of all models.
    pub fn generate(&self) -> Result<Generated> {
        let mut models = Vec::new();
        let mut diagnostics = Vec::new();
        let plain = self.paths()?.into_iter().map(|p| (p, None));
        let extended = self.extended.iter().map(|(p, e)| (p.clone(), Some(*e)));
        for (path, extension) in plain.chain(extended) {
            let generated = match extension {
                None => generate_file_with(&path, self.families),
                Some(e) => generate_file_extended(&path, e),
            };
            match generated {
                Ok(m) => models.push(m),
                Err(Error::Model(d)) => diagnostics.extend(d),
                Err(e) => return Err(e),
            }
        }
        if !diagnostics.is_empty() {
            return Err(Error::Model(diagnostics));
        }
        let mut seen = std::collections::HashSet::new();
        for m in &models {
            if !seen.insert(m.module.clone()) {
                return Err(Error::Internal(format!(
                    "two model files map to the module `{}`; rename one",
                    m.module
                )));
            }
        }
        Ok(Generated { models })
    }

    /// For build scripts: generates, writes the module file if it changed, and prints
    /// `cargo:rerun-if-changed` for every input.
    pub fn build(&self) -> Result<Generated> {
        for dir in &self.dirs {
            println!("cargo:rerun-if-changed={}", dir.display());
        }
        for path in self
            .paths()?
            .iter()
            .chain(self.extended.iter().map(|(p, _)| p))
        {
            println!("cargo:rerun-if-changed={}", path.display());
        }
        let generated = self.generate()?;
        let out_dir = match &self.out_dir {
            Some(d) => d.clone(),
            None => PathBuf::from(std::env::var_os("OUT_DIR").ok_or_else(|| {
                Error::Internal(
                    "OUT_DIR is not set: call build() from a build script or set out_dir".into(),
                )
            })?),
        };
        let file = out_dir.join(self.out_file.as_deref().unwrap_or("models.rs"));
        write_if_changed(&file, &generated.module_file()).map_err(|e| Error::Io {
            path: file.display().to_string(),
            source: e,
        })?;
        Ok(generated)
    }
}

/// Shortcut for a build script with one model: `lasalle_codegen::compile("models/kepler.lsl")`.
pub fn compile(path: impl Into<PathBuf>) -> Result<Generated> {
    Builder::new().model(path).build()
}

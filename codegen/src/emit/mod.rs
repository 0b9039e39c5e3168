//! Stage 5: emission. Builds the Rust items of a model with `quote`, formats them with
//! `prettyplease`, and turns the note markers into comments that point at the model file.
//!
//! # Work done once
//!
//! The emitted functions do per call only what depends on the state, the targets or the gains:
//!
//! - Before a function is written its outputs are rewritten by
//!   [`Graph::optimize_for_emission`](crate::ir::Graph::optimize_for_emission): common factors
//!   out of sums, one square root and one reciprocal per base with two or more negative powers
//!   (`r = s.sqrt()`, `1/r`, then `1/r³ = (1/r)³`), parameter-only factors of a product grouped
//!   (`−3μ·x/m → (−3μ/m)·x`), repeated sub-products shared. A reciprocal replaces divisions only
//!   where it is a value of its own (used twice or more, or parameter-only); a lone `a / b` stays
//!   a division.
//! - The maximal parameter-only subexpressions of each function are fields of the prepared
//!   model `<Model>Prepared` (module `prepared`), computed once by `<Model>::prepare()`; inside
//!   them negative powers are always divisions, so a field rounds the same for every function.
//!   The same call runs the preludes of the machine kernels' tapes (`kernels::Prelude`, below):
//!   parameters are prepared in one place, once per parameter set.
//!
//! # One model type for the runtime: the prepared one
//!
//! The runtime's traits (`Field`, `Invariants`, `Lyapunov`, `Partitioned`, `Declared`,
//! `ModelInfo`, `Parameters`) are implemented once, on `<Model>Prepared`; the model struct
//! `<Model>` holds the parameters (public fields, `Default`, the points, the state views) and
//! offers `prepare()`. A run prepares once and every call reads the prepared values.
//!
//! Why a companion and not a cache in the model: the parameters stay public fields
//! (`model.c1 = …`), and a cache next to them would go stale on such an assignment. Why not
//! impls on both, the model's preparing on every call: each trait would be written twice, and
//! a call on the model would silently pay for the preparation. The prepared model is immutable
//! (private fields, `Deref` to the model for reading), so it is always consistent with the
//! parameters it was made from; `Parameters::set_param` on it prepares again.
//!
//! # Layout of the emitted module
//!
//! The readable part first, written from the formulas: the parameter struct, the prepared
//! model, the state views, then the trait impls, each output under the model line it comes
//! from. Leaves and values carry the names a person would give them: state and parameter
//! components (`x_0`, `r_1_2`, `i_0`), the components of an invariant (`l_2`, `c_0_1`), its
//! target f(x₀) (`l0_2`, `e0`), the deviation from it (`dl_2`, `de`), `let` names, and
//! parameter-only values named after what they hold (`i_1_minus_i_2_over_i_0`).
//!
//! Then one module, `kernels`, with one header and one `allow` for all of it: the machine
//! kernels generated from the tapes rather than the formulas (`taylor` and `lanes`): the
//! preludes (`Prelude`, in the prepared model), the Taylor-coefficient kernels of X and X − ∇V
//! and the batched functions for K states per call. They are straight-line code over numbered
//! registers and table rows, appended as formatted text.
//!
//! The tapes (`crate::tape`) are lowered from the same rewritten graph with the same rules
//! (their prelude is the prepared fields' computation), so the emitted Rust, the JIT and the
//! interpreter stay bitwise equal (`tests/tape_vs_emitted.rs`).

mod body;
mod items;
mod lanes;
mod leaves;
mod loop_traits;
mod loops;
mod prepared;
mod taylor;
mod traits;

pub(crate) use loop_traits::LoopDerived;
pub(crate) use loops::emit_loops;
pub use names::snake;

use crate::ir::{Graph, OpCount};
use body::{Body, Hoisting, Output};
use lasalle_model::names;
use lasalle_model::{Checked, Conservation, Derivatives, InvariantKind, Model, Verdict};
use leaves::Leaves;
use prepared::Prepared;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// Operation counts of one emitted function.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ops {
    /// As an expression tree (every use of a shared subexpression counted again).
    pub tree: u64,
    /// After common-subexpression elimination (the hash-consed DAG).
    pub cse: u64,
    /// As emitted: after CSE, factoring of sums and sharing of sub-products.
    pub emitted: u64,
}

impl Ops {
    fn new(counts: OpCount, emitted: u64) -> Ops {
        Ops {
            tree: counts.tree,
            cse: counts.dag,
            emitted,
        }
    }
}

/// Operation counts of the emitted functions.
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// X(x).
    pub field: Ops,
    /// f(x).
    pub invariants: Ops,
    /// Df(x).
    pub jacobian: Ops,
    /// V(x).
    pub lyapunov: Ops,
    /// ∇V(x).
    pub lyapunov_gradient: Ops,
    /// X − ∇V, computed together.
    pub feedback_field: Ops,
}

/// The emitted items of one model.
pub struct Emitted {
    /// The items (struct and impls), unformatted.
    pub items: TokenStream,
    /// One-paragraph summary for module docs.
    pub summary: String,
    /// Operation counts.
    pub stats: Stats,
    /// The module `kernels` emitted from the tapes (preludes, Taylor kernels and lanes),
    /// already formatted: to append to the formatted items (they are large, straight-line
    /// code that would dominate the time of formatting).
    pub tape_code: String,
}

/// An index or size as an unsuffixed literal (`3`, not `3usize`).
pub(crate) fn u(k: usize) -> Literal {
    Literal::usize_unsuffixed(k)
}

pub(crate) fn file_name(model: &Model) -> String {
    std::path::Path::new(&model.source.path)
        .file_name()
        .map_or_else(
            || model.source.path.clone(),
            |f| f.to_string_lossy().into_owned(),
        )
}

/// A note (comment) quoting the model item at `span`: `kepler.lsl:9: d/dt v = -mu * x / r^3;` for the item at `span`.
pub(crate) fn note_for(model: &Model, span: &crate::Span) -> String {
    let (line, _) = span.line_col();
    note_at(model, span, line)
}

/// [`note_for`] with the line number already known (see [`LineIndex`]).
pub(crate) fn note_at(model: &Model, span: &crate::Span, line: usize) -> String {
    let text = span.text().split_whitespace().collect::<Vec<_>>().join(" ");
    if !std::sync::Arc::ptr_eq(&span.source, &model.source) {
        // not from the model file: the text a transformation wrote for what it added
        return text;
    }
    let text = if text.chars().count() > 90 {
        format!("{}…", text.chars().take(89).collect::<String>())
    } else {
        text
    };
    format!("{}:{line}: {text}", file_name(model))
}

/// The 1-based line of any byte offset of a text, by binary search over its line starts:
/// [`crate::Span::line_col`] scans the text before the span, which is quadratic over the
/// thousands of `let`s of a large model.
pub(crate) struct LineIndex(Vec<usize>);

impl LineIndex {
    pub(crate) fn new(text: &str) -> Self {
        let starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        LineIndex(starts)
    }

    pub(crate) fn line(&self, offset: usize) -> usize {
        self.0.partition_point(|&s| s <= offset)
    }
}

/// The emission of one model: the model, its derivatives, a copy of the graph that the
/// emission rewrites may extend, and the names of its leaves.
pub(crate) struct Emitter<'a> {
    model: &'a Model,
    d: &'a Derivatives,
    graph: Graph,
    leaves: Leaves<'a>,
    /// The parameter-only values the functions read, fields of the prepared model.
    prepared: Prepared,
    ty: proc_macro2::Ident,
    prepared_ty: proc_macro2::Ident,
    n: usize,
    m: usize,
}

impl<'a> Emitter<'a> {
    fn new(model: &'a Model, d: &'a Derivatives) -> crate::Result<Self> {
        let leaves = Leaves::new(model)?;
        let params: Vec<&str> = leaves.fields.iter().map(String::as_str).collect();
        Ok(Emitter {
            model,
            d,
            graph: model.graph.clone(),
            prepared: Prepared::new(&params),
            leaves,
            ty: format_ident!("{}", model.name),
            prepared_ty: format_ident!("{}Prepared", model.name),
            n: model.dim(),
            m: model.invariant_dim(),
        })
    }

    /// Number of gains.
    fn gains(&self) -> usize {
        self.model.gains.len()
    }

    /// The body of a per-call function of the prepared model computing `outputs` (see
    /// [`body::body`]).
    fn body(&mut self, outputs: &[Output], reserved: &[&str]) -> Body {
        let hoisting = Hoisting::Read(&mut self.prepared);
        body::body(&mut self.graph, &self.leaves, outputs, reserved, hoisting)
    }

    /// The body of a function of the parameters alone, computing `outputs` in place.
    fn inline_body(&mut self, outputs: &[Output], reserved: &[&str]) -> Body {
        body::body(
            &mut self.graph,
            &self.leaves,
            outputs,
            reserved,
            Hoisting::Inline,
        )
    }
}

/// Emits the struct and trait impls of a model, given its derivatives and the conservation
/// verdicts (quoted in the docs).
pub fn emit(checked: &Checked) -> crate::Result<Emitted> {
    let (model, d) = (checked.model(), checked.derivatives());
    let conservation = checked.conservation();
    let mut e = Emitter::new(model, d)?;
    // The order of the bodies fixes the Ids of the nodes the rewrites add, hence the output:
    // keep it stable.
    let (field, field_ops) = e.field_impl();
    let (invariants, inv_ops, jac_ops, jac_ids) = e.invariants_impl();
    let (lyapunov, [v_ops, grad_ops, fb_ops]) = e.lyapunov_impl();
    let partitioned = e.partitioned_impl();
    let declared = e.declared_impl();
    let prepared = e.prepared_items();
    let struct_items = e.struct_items();
    let (accessors, info, parameters) = (e.accessors(), e.model_info_impl(), e.parameters_impl());
    let tapes = crate::tape::ModelTapes::new(checked.derived())
        .map_err(|err| crate::Error::Internal(format!("the tapes of `{}`: {err}", model.name)))?;
    let tape_code = e.tape_items(&tapes)?;

    let g = &model.graph;
    let stats = Stats {
        field: Ops::new(g.op_count(&model.field), field_ops),
        invariants: Ops::new(g.op_count(&model.invariant_ids()), inv_ops),
        jacobian: Ops::new(g.op_count(&jac_ids), jac_ops),
        lyapunov: Ops::new(g.op_count(&[model.lyapunov]), v_ops),
        lyapunov_gradient: Ops::new(g.op_count(&d.lyapunov_gradient), grad_ops),
        feedback_field: Ops::new(g.op_count(&d.feedback), fb_ops),
    };
    let body = quote! {
        #struct_items
        #prepared
        #accessors
        #field
        #invariants
        #lyapunov
        #partitioned
        #declared
        #info
        #parameters
    };
    let imports = imports(&body);
    let items = quote! {
        #imports
        #body
    };
    Ok(Emitted {
        items,
        summary: summary(model, d, conservation, &stats),
        stats,
        tape_code,
    })
}

/// The names the emitted items may use, with the path each is imported from.
const IMPORTABLE: &[(&str, &str)] = &[
    ("Deref", "core::ops"),
    ("Float", "lasalle_runtime::num_traits"),
    ("MatrixView", "lasalle_runtime::nalgebra"),
    ("MatrixViewMut", "lasalle_runtime::nalgebra"),
    ("Scalar", "lasalle_runtime::nalgebra"),
    ("lit", "lasalle_runtime"),
    ("Declared", "lasalle_runtime"),
    ("DelaySpec", "lasalle_runtime"),
    ("EventDirection", "lasalle_runtime"),
    ("EventSpec", "lasalle_runtime"),
    ("Field", "lasalle_runtime"),
    ("GuardFailure", "lasalle_runtime"),
    ("InvariantInfo", "lasalle_runtime"),
    ("InvariantKind", "lasalle_runtime"),
    ("Invariants", "lasalle_runtime"),
    ("Lyapunov", "lasalle_runtime"),
    ("ModelInfo", "lasalle_runtime"),
    ("ParamError", "lasalle_runtime"),
    ("Parameters", "lasalle_runtime"),
    ("Partitioned", "lasalle_runtime"),
    ("Preset", "lasalle_runtime"),
    ("Shape", "lasalle_runtime"),
    ("Slot", "lasalle_runtime"),
    ("Splitting", "lasalle_runtime"),
    ("SwitchSpec", "lasalle_runtime"),
];

/// The `use` items for the names `items` uses: [`IMPORTABLE`] names, and nalgebra's
/// dimension types `U1`, `U2`, … of the state views. One `use` per path, names sorted.
fn imports(items: &TokenStream) -> TokenStream {
    fn idents(ts: &TokenStream, out: &mut std::collections::BTreeSet<String>) {
        for tt in ts.clone() {
            match tt {
                proc_macro2::TokenTree::Ident(i) => {
                    out.insert(i.to_string());
                }
                proc_macro2::TokenTree::Group(g) => idents(&g.stream(), out),
                _ => {}
            }
        }
    }
    let mut used = std::collections::BTreeSet::new();
    idents(items, &mut used);
    let dims = used
        .iter()
        .filter(|n| names::is_dimension(n))
        .map(|n| (n.as_str(), "lasalle_runtime::nalgebra"));
    let mut by_path: std::collections::BTreeMap<&str, Vec<&str>> = Default::default();
    for (name, path) in IMPORTABLE
        .iter()
        .copied()
        .filter(|(n, _)| used.contains(*n))
        .chain(dims)
    {
        by_path.entry(path).or_default().push(name);
    }
    let uses = by_path.into_iter().map(|(path, mut names)| {
        names.sort_unstable();
        let path: TokenStream = path.parse().expect("a path");
        let names = names.iter().map(|n| format_ident!("{}", n));
        quote!(use #path::{#(#names),*};)
    });
    quote!(#(#uses)*)
}

fn summary(model: &Model, d: &Derivatives, conservation: &[Conservation], s: &Stats) -> String {
    let mut out = format!(
        "The model `{}` from `{}`, generated by lasalle-codegen.\n\n",
        model.name,
        file_name(model)
    );
    out.push_str("State (flat, matrices column-major):\n");
    for v in &model.state {
        out.push_str(&format!(
            "- `{}`: {} at x[{}..{}]\n",
            v.name,
            v.shape,
            v.offset,
            v.offset + v.shape.len()
        ));
    }
    out.push_str("\nInvariants (stacked f):\n");
    for f in &model.invariants {
        let how = conservation.iter().find(|c| c.name == f.name).map(|c| match &c.verdict {
            Verdict::Proved => "conservation proved symbolically".to_string(),
            Verdict::Sampled { samples, worst_relative } => {
                format!("conserved at {samples} random states (worst relative residual {worst_relative:.1e})")
            }
            Verdict::OnConstraints { samples, worst_relative } => {
                format!("conserved on the constraints' manifold only, at {samples} random states on it (worst relative residual {worst_relative:.1e})")
            }
        });
        let kind = if f.kind == InvariantKind::Constraint {
            "constraint"
        } else {
            "integral"
        };
        out.push_str(&format!(
            "- `{}`: {kind}, {} at f[{}..{}], gain `{}` = {}{}\n",
            f.name,
            f.value.shape,
            f.offset,
            f.offset + f.value.shape.len(),
            model.gains[f.gain].name,
            model.gains[f.gain].default,
            how.map(|h| format!("; {h}")).unwrap_or_default()
        ));
    }
    if d.partition.is_some() {
        out.push_str("\nThe field is partitioned (q̇ = a(p), ṗ = b(q)): Störmer–Verlet applies.\n");
    }
    out.push_str(&format!(
        "\nOperations (as a tree → after CSE → as emitted): {}.\n",
        [
            ("X", s.field),
            ("f", s.invariants),
            ("Df", s.jacobian),
            ("V", s.lyapunov),
            ("∇V", s.lyapunov_gradient),
            ("X − ∇V", s.feedback_field)
        ]
        .map(|(name, o)| format!("{name} {} → {} → {}", o.tree, o.cse, o.emitted))
        .join(", ")
    ));
    out
}

/// Formats items with prettyplease and turns note markers into `//` comments.
pub fn format(items: &TokenStream) -> crate::Result<String> {
    let file: syn::File = syn::parse2(items.clone())
        .map_err(|e| crate::Error::Internal(format!("emitted code does not parse: {e}")))?;
    let text = prettyplease::unparse(&file);
    Ok(separate_items(&indent_wrapped_patterns(&replace_notes(
        &text,
    ))))
}

/// Indents the continuation lines of a destructuring `let [a, b, …] = *x;` that prettyplease
/// wrapped at the line width: it continues the pattern at the indentation of the `let`, which
/// reads as a new statement.
fn indent_wrapped_patterns(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + text.len() / 64);
    let mut open = false;
    for line in text.lines() {
        if open {
            out.push_str("    ");
            open = !line.contains("] = ");
        } else {
            let t = line.trim_start();
            open = t.starts_with("let [") && !t.contains("] = ");
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// A blank line between consecutive items (prettyplease writes none): before a line that
/// starts an item, its docs or attributes, right after an item that ended at the same
/// indentation (`}` or `;`).
fn separate_items(text: &str) -> String {
    const STARTS: &[&str] = &[
        "pub ", "impl", "fn ", "#[", "///", "const ", "type ", "mod ", "struct ", "trait ",
    ];
    let indent = |l: &str| l.len() - l.trim_start().len();
    let mut out = String::with_capacity(text.len() + text.len() / 16);
    let mut prev: Option<&str> = None;
    for line in text.lines() {
        if let Some(p) = prev {
            let (pt, lt) = (p.trim(), line.trim_start());
            let ended = pt == "}" || pt.ends_with(';');
            if ended && indent(p) == indent(line) && STARTS.iter().any(|s| lt.starts_with(s)) {
                out.push('\n');
            }
        }
        out.push_str(line);
        out.push('\n');
        prev = Some(line);
    }
    out
}

fn replace_notes(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        if !trimmed.starts_with("lasalle_note!(") {
            out.push_str(line);
            out.push('\n');
            continue;
        }
        // prettyplease may break a long marker over several lines.
        let mut call = trimmed.to_string();
        while !call.ends_with(");") {
            match lines.next() {
                Some(more) => call.push_str(more.trim()),
                None => break,
            }
        }
        let inner = call
            .trim_start_matches("lasalle_note!(")
            .trim_end_matches(");")
            .trim()
            .trim_end_matches(',');
        let lit: syn::LitStr = syn::parse_str(inner).expect("a string literal we emitted");
        out.push_str(&line[..line.len() - trimmed.len()]);
        out.push_str("// ");
        out.push_str(&lit.value());
        out.push('\n');
    }
    out
}

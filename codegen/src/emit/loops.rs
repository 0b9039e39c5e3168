//! The loop form of a model whose families are kept as loops ([`lasalle_model::loops`]): the
//! field X and the invariants f as Rust loops over the families' index ranges, their size
//! independent of the number of index tuples.
//!
//! Each function is written from its [`LoopTape`], the program the JIT's and the
//! interpreter's loop kernels run: first the part outside the families (straight-line code),
//! then per family its ranges and conditions as nested `for` and `if`
//! (`for i in 0..12 { for j in (i + 1)..12 { … } }`), the members its body reads gathered by
//! index arithmetic (`x[3 * i + 36]`), the body's instructions as `let`s, and each output
//! added to the component it belongs to (`out[3 * j] += r7;`). Tuples come in the order the
//! loop kernels run them, outputs in tape order, after the plain part, with the same IEEE
//! operations: the emitted functions equal the loop kernels bit for bit.
//!
//! Where the lowering kept no index structure for a family (a subscript or a bound that is no
//! sum, difference, product or remainder of its indices and constants) or an output's
//! component is no such expression, the family's tuples are written as `const` tables of the
//! indices read and written, and a comment says so.
//!
//! The derived functions (Df, V, ∇V, X − ∇V, the half-fields) and the traits they fill are
//! written the same way from their loop tapes ([`super::loop_traits`]). What has no loop form
//! is left out rather than written out term by term: the Taylor kernels, the batched forms of
//! the derived functions, and the points at other than the default parameters; the module's
//! docs say so, and
//! `--families unrolled` emits the model whole.

use super::loop_traits::LoopDerived;
use super::taylor::{f64_lit, op_expr, prelude_block};
use lasalle_model::loops::index::{Ix, LoopClause, SlotIndex};
use lasalle_model::loops::{Family, LoopModel, LoopTape, LoopTapes, Region, Source};
use lasalle_model::tape::{Op, Reg, Tape};
use lasalle_model::{Conservation, Model, Shape, Verdict};
use std::fmt::Write;

/// The loop form of a model: its module's items as formatted text, and the module docs.
pub(crate) fn emit_loops(
    lm: &LoopModel,
    tapes: &LoopTapes,
    derived: &LoopDerived,
    conservation: &[Conservation],
) -> (String, String) {
    let model = lm.lowered();
    let ty = &model.name;
    let prep = format!("{ty}Prepared");
    let (n, m, np) = (model.dim(), model.invariant_dim(), model.param_slots());
    let mut functions = vec![("field", &tapes.field), ("invariants", &tapes.invariants)];
    functions.extend(derived.functions());
    let mut imports = vec![
        "Field",
        "InvariantInfo",
        "InvariantKind",
        "ModelInfo",
        "Shape",
        "Slot",
    ];
    imports.extend(derived.imports(model));
    imports.sort_unstable();
    let mut s = String::new();
    let _ = write!(
        s,
        "// Loops index several arrays with the same index.
#![allow(clippy::needless_range_loop)]

use lasalle_runtime::{{{imports}}};

/// State components.
pub const DIM: usize = {n};

/// Stacked invariant components.
pub const INVARIANT_DIM: usize = {m};

/// Parameter slots.
pub const PARAM_SLOTS: usize = {np};

{constants}
/// The parameters of the model `{ty}` as flat slots (where each parameter sits:
/// [`{ty}::PARAMS`]), read by index in the families' loops.
#[derive(Clone, Debug, PartialEq)]
pub struct {ty} {{
    /// The parameter slots (matrices column-major).
    pub params: [f64; PARAM_SLOTS],
}}

impl Default for {ty} {{
    fn default() -> Self {{
        {ty} {{
            params: {ty}::DEFAULT_PARAMS,
        }}
    }}
}}

impl {ty} {{
    /// The model's name.
    pub const NAME: &'static str = {name:?};

{decls}
    /// The parameter-only values of the functions, computed once.
    pub fn prepare(&self) -> {prep} {{
{let_p}        {prep} {{
{prepare}            params: self.params,
        }}
    }}
}}

/// The model `{ty}` with its parameter-only values computed once ([`{ty}::prepare`]).
#[derive(Clone, Debug, PartialEq)]
pub struct {prep} {{
{fields}    params: [f64; PARAM_SLOTS],
}}

impl {prep} {{
    /// The parameter slots it was prepared from.
    pub fn params(&self) -> &[f64; PARAM_SLOTS] {{
        &self.params
    }}

{inherent}}}

impl Field<f64, [f64; DIM]> for {prep} {{
{field}}}

{traits}
impl ModelInfo for {prep} {{
    fn model_name(&self) -> &'static str {{
        {ty}::NAME
    }}

    fn state_slots(&self) -> &'static [Slot] {{
        {ty}::STATE
    }}

    fn invariant_infos(&self) -> &'static [InvariantInfo] {{
        {ty}::INVARIANTS
    }}

    fn gain_names(&self) -> &'static [&'static str] {{
        {ty}::GAIN_NAMES
    }}

    fn default_gain_values(&self) -> &'static [f64] {{
        {ty}::DEFAULT_GAINS
    }}

    fn param_slots(&self) -> &'static [Slot] {{
        {ty}::PARAMS
    }}
}}
",
        name = model.name,
        imports = imports.join(", "),
        constants = derived.constants(model),
        traits = derived.trait_impls(lm, &tapes.invariants, &prep),
        let_p = if named(&functions).iter().any(|(_, t)| t.prelude.iter().any(|op| matches!(op, Op::Param(_)))) {
            "        let p = &self.params;\n"
        } else {
            ""
        },
        decls = indent(&declarations(model), 4),
        prepare = indent(&prepare_fields(&functions), 12),
        fields = indent(&struct_fields(&functions), 4),
        inherent = indent(
            &(function(
                lm,
                &tapes.field,
                "field",
                "/// X for K states per call (structure of arrays): `x[i][l]` is component i of lane l,\n/// `out[i][l]` its rate; each lane equals `field` bit for bit.\npub fn field_lanes<const K: usize>(&self, x: &[[f64; K]; DIM], out: &mut [[f64; K]; DIM]) {",
                true,
                None,
                &[],
            ) + "\n" + &function(
                lm,
                &tapes.invariants,
                "invariants",
                "/// f for K states per call, as [`Self::field_lanes`]; each lane equals `invariants`.\npub fn invariants_lanes<const K: usize>(&self, x: &[[f64; K]; DIM], out: &mut [[f64; K]; INVARIANT_DIM]) {",
                true,
                None,
                &[],
            ) + "\n" + &derived.stage_methods(lm)),
            4
        ),
        field = indent(
            &function(
                lm,
                &tapes.field,
                "field",
                "/// X(x).\nfn field(&self, x: &[f64; DIM], out: &mut [f64; DIM]) {",
                false,
                None,
                &[],
            ),
            4
        ),
    );
    (s, summary(lm, derived, conservation))
}

/// The module docs.
fn summary(lm: &LoopModel, derived: &LoopDerived, conservation: &[Conservation]) -> String {
    let model = lm.lowered();
    let mut out = format!(
        "The model `{}` from `{}`, generated by lasalle-codegen with its families as loops.\n\n",
        model.name,
        super::file_name(model)
    );
    out.push_str("State (flat, matrices column-major):\n");
    for v in &model.state {
        let _ = writeln!(
            out,
            "- `{}`: {} at x[{}..{}]",
            v.name,
            v.shape,
            v.offset,
            v.offset + v.shape.len()
        );
    }
    out.push_str("\nInvariants (stacked f):\n");
    for f in &model.invariants {
        let how = conservation
            .iter()
            .find(|c| c.name == f.name)
            .map(|c| match &c.verdict {
                Verdict::Proved => "conservation proved symbolically".to_string(),
                Verdict::Sampled { samples, .. } | Verdict::OnConstraints { samples, .. } => {
                    format!("conserved at {samples} random states")
                }
            });
        let _ = writeln!(
            out,
            "- `{}`: {} at f[{}..{}]{}",
            f.name,
            f.value.shape,
            f.offset,
            f.offset + f.value.shape.len(),
            how.map(|h| format!("; {h}")).unwrap_or_default()
        );
    }
    let _ = write!(
        out,
        "\n{} families are loops, written once whatever their number of index tuples. \
         `{}Prepared` implements `Field`, `ModelInfo`, `Parameters`, {}, and has `field_lanes` \
         and `invariants_lanes` (K states per call); the Taylor kernels, the lanes of the \
         derived functions and the points at other than the default parameters have no loop \
         form here: generate with \
         `--families unrolled` for them.\n",
        lm.families().len(),
        model.name,
        derived.summary()
    );
    out
}

/// The declarations: slots of the state, the invariants and the parameters, the gains, the
/// default parameters and the points (at the default parameters).
fn declarations(model: &Model) -> String {
    let shape = |s: Shape| match s {
        Shape::Scalar => "Shape::Scalar".to_string(),
        Shape::Vector(k) => format!("Shape::Vector({k})"),
        Shape::Matrix(r, c) => format!("Shape::Matrix({r}, {c})"),
    };
    let slot = |name: &str, s: Shape, offset: usize| {
        format!(
            "Slot {{ name: {name:?}, shape: {}, offset: {offset} }}",
            shape(s)
        )
    };
    let mut s = String::from("/// The state variables with their offsets in the flat state.\npub const STATE: &'static [Slot] = &[\n");
    for v in &model.state {
        let _ = writeln!(s, "    {},", slot(&v.name, v.shape, v.offset));
    }
    s.push_str("];\n\n/// The invariants with their offsets in the stacked f.\npub const INVARIANTS: &'static [InvariantInfo] = &[\n");
    for f in &model.invariants {
        let kind = match f.kind {
            lasalle_model::InvariantKind::Constraint => "Constraint",
            lasalle_model::InvariantKind::Integral => "Integral",
        };
        let _ = writeln!(
            s,
            "    InvariantInfo {{ slot: {}, kind: InvariantKind::{kind}, gain: {} }},",
            slot(&f.name, f.value.shape, f.offset),
            f.gain
        );
    }
    let gains: Vec<String> = model
        .gains
        .iter()
        .map(|g| format!("{:?}", g.name))
        .collect();
    let defaults: Vec<String> = model.gains.iter().map(|g| f64_text(g.default)).collect();
    let _ = write!(
        s,
        "];\n\n/// The names of the gains.\npub const GAIN_NAMES: &'static [&'static str] = &[{}];\n\n\
         /// The gains as written in the model file.\npub const DEFAULT_GAINS: &'static [f64] = &[{}];\n\n\
         /// The parameters with their offsets in the parameter slots.\npub const PARAMS: &'static [Slot] = &[\n",
        gains.join(", "),
        defaults.join(", ")
    );
    for p in &model.params {
        let _ = writeln!(s, "    {},", slot(&p.name, p.shape, p.offset));
    }
    let params = model.default_params();
    let _ = write!(
        s,
        "];\n\n/// The parameter slots as written in the model file.\npub const DEFAULT_PARAMS: [f64; PARAM_SLOTS] = [{}];\n",
        list(&params)
    );
    if !model.points.is_empty() {
        s.push_str(
            "\n/// The named points (flat states) at the default parameters ([`Self::DEFAULT_PARAMS`]).\n\
             pub const POINTS: &'static [(&'static str, [f64; DIM])] = &[\n",
        );
        for pt in &model.points {
            let values = model.graph.eval_f64(&pt.values, &mut |i| match i {
                lasalle_model::ir::Input::Param(k) => params[k as usize],
                _ => f64::NAN,
            });
            let _ = writeln!(s, "    ({:?}, [{}]),", pt.name, list(&values));
        }
        s.push_str("];\n");
    }
    s
}

/// `1.0`, `-0.5`: a float literal whose type the context gives.
pub(super) fn f64_text(x: f64) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else {
        f64_lit(x)
    }
}

fn list(xs: &[f64]) -> String {
    xs.iter()
        .map(|&x| f64_text(x))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The tapes of the functions: per function the plain one first, then the regions, with their
/// names as fields of the prepared model.
fn named<'t>(functions: &[(&str, &'t LoopTape)]) -> Vec<(String, &'t Tape)> {
    let mut out = Vec::new();
    for (f, lt) in functions {
        out.push((format!("{f}_plain"), &lt.base));
        for (k, r) in lt.regions.iter().enumerate() {
            out.push((format!("{f}_loop_{k}"), &r.tape));
        }
    }
    out.retain(|(_, t)| !t.hoisted.is_empty());
    out
}

fn struct_fields(functions: &[(&str, &LoopTape)]) -> String {
    named(functions)
        .iter()
        .map(|(name, t)| format!("{name}: [f64; {}],\n", t.hoisted.len()))
        .collect()
}

fn prepare_fields(functions: &[(&str, &LoopTape)]) -> String {
    named(functions)
        .iter()
        .map(|(name, t)| format!("{name}: {},\n", prelude_block(t)))
        .collect()
}

/// One function: `header`, the plain part, then a loop per region.
/// With `lanes`, K states per call: every value a `[f64; K]` (parameters and hoisted values
/// shared), each operation a loop over the lanes, so each lane repeats the scalar function's
/// operations in its order. `init` replaces the line that zeroes `out`; `extra` names the
/// state inputs beyond the model's state (the sums and weights of V's stages) in comments.
pub(super) fn function(
    lm: &LoopModel,
    lt: &LoopTape,
    name: &str,
    header: &str,
    lanes: bool,
    init: Option<&str>,
    extra: &[String],
) -> String {
    function_with(lm, &[], lt, name, header, lanes, init, extra)
}

/// [`function`] of a tape whose regions may run families beyond the model's: region `r` with
/// `r.family` ≥ F (the model's families) runs `more[r.family − F]` (the loops of V's last stage
/// over the state's members, [`lasalle_model::loops::LoopFeedback::families`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn function_with(
    lm: &LoopModel,
    more: &[Family],
    lt: &LoopTape,
    name: &str,
    header: &str,
    lanes: bool,
    init: Option<&str>,
    extra: &[String],
) -> String {
    let mut s = format!("{header}\n");
    let len = lt.n_outputs();
    let reads_params = lt.regions.iter().any(|r| {
        r.sources
            .iter()
            .enumerate()
            .any(|(c, s)| *s == Source::Param && r.tape.body.contains(&Op::State(c as u32)))
    });
    if reads_params {
        s.push_str("    let params = &self.params;\n");
    }
    if let Some(init) = init {
        s.push_str(&indent(init, 4));
    } else if lanes {
        let _ = writeln!(s, "    *out = [[0.0; K]; {len}];");
    } else {
        let _ = writeln!(s, "    *out = [0.0; {len}];");
    }
    if !lt.base.outputs.is_empty() {
        s.push_str("    // the terms outside the families\n    {\n");
        let mut body = String::new();
        let plain = (!lt.base.hoisted.is_empty()).then(|| format!("{name}_plain"));
        let state = |k| match lanes {
            true => format!("x[{k}][l]"),
            false => format!("x[{k}]"),
        };
        let r = straight(&lt.base, plain.as_deref(), &state, lanes, &mut body);
        for (&o, reg) in lt.base_at.iter().zip(&lt.base.outputs) {
            let value = r(*reg);
            if lanes && value.ends_with("[l]") {
                let _ = writeln!(body, "out[{o}] = core::array::from_fn(|l| {value});");
            } else if lanes {
                let _ = writeln!(body, "out[{o}] = [{value}; K];");
            } else {
                let _ = writeln!(body, "out[{o}] = {};", r(*reg));
            }
        }
        s.push_str(&indent(&body, 8));
        s.push_str("    }\n");
    }
    for (k, region) in lt.regions.iter().enumerate() {
        let own = lm.families();
        let fam = own
            .get(region.family)
            .unwrap_or_else(|| &more[region.family - own.len()]);
        let hoisted = (!region.tape.hoisted.is_empty()).then(|| format!("{name}_loop_{k}"));
        s.push_str(&indent(
            &region_code(
                lm.lowered(),
                fam,
                region,
                hoisted.as_deref(),
                k,
                lanes,
                extra,
            ),
            4,
        ));
    }
    s.push_str("}\n");
    s
}

/// The body of `tape` as `let`s into `s`; returns how to name a register (leaves inline).
/// `state(k)` renders state input k; `hoisted` names the prepared field of the hoisted values.
/// With `lanes`, registers are `[f64; K]` and the names are those of lane `l`.
fn straight<'t>(
    tape: &'t Tape,
    hoisted: Option<&str>,
    state: &dyn Fn(u32) -> String,
    lanes: bool,
    s: &mut String,
) -> impl Fn(Reg) -> String + 't {
    if let Some(h) = hoisted {
        let _ = writeln!(s, "let h = &self.{h};");
    }
    let leaf = |op: &Op| -> Option<String> {
        Some(match *op {
            Op::State(k) => state(k),
            Op::Const(c) => f64_lit(c),
            Op::Hoisted(k) => format!("h[{k}]"),
            Op::Target(k) => format!("target[{k}]"),
            Op::Gain(k) => format!("gains[{k}]"),
            Op::Param(k) => format!("self.params[{k}]"),
            _ => return None,
        })
    };
    // with lanes: does the value differ between lanes (does it read the state)?
    let mut varying = vec![false; tape.body.len()];
    let mut names: Vec<String> = Vec::with_capacity(tape.body.len());
    for (i, op) in tape.body.iter().enumerate() {
        if let Some(text) = leaf(op) {
            varying[i] = lanes && text.ends_with("[l]");
            names.push(text);
            continue;
        }
        varying[i] = lanes && op.operands().any(|r| varying[r.index()]);
        let e = op_expr(op, |r| names[r.index()].clone());
        if varying[i] {
            let _ = writeln!(s, "let r{i}: [f64; K] = core::array::from_fn(|l| {e});");
            names.push(format!("r{i}[l]"));
        } else {
            let _ = writeln!(s, "let r{i} = {e};");
            names.push(format!("r{i}"));
        }
    }
    move |r: Reg| names[r.index()].clone()
}

/// How one index of a region's tuple is written.
enum Place {
    /// The same index for every tuple.
    Fixed(u32),
    /// An expression of the family's indices.
    Indexed(SlotIndex),
}

/// The places of a region's gathers and scatters as expressions of its indices, if they all
/// have one.
fn places(fam: &Family, region: &Region) -> Option<(Vec<Place>, Vec<Place>)> {
    fam.clauses.as_ref()?;
    let (k, o) = (region.sources.len(), region.tape.outputs.len());
    let column = |table: &[u32], width: usize, c: usize| -> Vec<u32> {
        (0..region.count).map(|t| table[t * width + c]).collect()
    };
    let mut gather = Vec::with_capacity(k);
    for c in 0..k {
        gather.push(match fam.slots.get(c) {
            Some(slot) => Place::Indexed(slot.index.clone()?),
            None => Place::Fixed(region.gather[c]),
        });
    }
    let mut scatter = Vec::with_capacity(o);
    for c in 0..o {
        let col = column(&region.scatter, o, c);
        if col.iter().all(|&v| v == col[0]) {
            scatter.push(Place::Fixed(col[0]));
            continue;
        }
        // the component a state slot reads, shifted (∂H/∂q[i] into ṗ[i])
        let shifted = fam.slots.iter().enumerate().find_map(|(j, slot)| {
            let index = slot
                .index
                .as_ref()
                .filter(|_| slot.source == Source::State)?;
            let g = column(&region.gather, k, j);
            let d = i64::from(col[0]) - i64::from(g[0]);
            let same = g
                .iter()
                .zip(&col)
                .all(|(&a, &b)| i64::from(a) + d == i64::from(b));
            (same && index.base + d >= 0).then(|| SlotIndex {
                base: index.base + d,
                ..index.clone()
            })
        });
        scatter.push(Place::Indexed(shifted?));
    }
    Some((gather, scatter))
}

/// One family's loop.
fn region_code(
    model: &Model,
    fam: &Family,
    region: &Region,
    hoisted: Option<&str>,
    number: usize,
    lanes: bool,
    extra: &[String],
) -> String {
    let mut s = format!(
        "// {}\n",
        super::note_for(model, &fam.span).replace('\n', " ")
    );
    let (k, o) = (region.sources.len(), region.tape.outputs.len());
    let read = |c: usize, at: &str| match region.sources[c] {
        Source::State => format!("x[{at}]"),
        Source::Param => format!("params[{at}]"),
    };
    let slot = |c: u32| match (lanes, region.sources[c as usize]) {
        (true, Source::State) => format!("s{c}[l]"),
        _ => format!("s{c}"),
    };
    let add = |at: &str, value: &str| match lanes {
        true => format!("for l in 0..K {{\n    out[{at}][l] += {value};\n}}"),
        false => format!("out[{at}] += {value};"),
    };
    let used: Vec<bool> = (0..k)
        .map(|c| region.tape.body.contains(&Op::State(c as u32)))
        .collect();
    if let Some(h) = hoisted {
        let _ = writeln!(s, "let h = &self.{h};");
    }
    let mut body = String::new();
    let Some((gather, scatter)) = places(fam, region) else {
        // the tables
        let _ = writeln!(
            s,
            "// Its index tuples are listed: its subscripts or ranges have no loop form here.\n\
             {{\n    const GATHER_{number}: [[u32; {k}]; {n}] = [{}];\n    const SCATTER_{number}: [[u32; {o}]; {n}] = [{}];",
            rows(&region.gather, k),
            rows(&region.scatter, o),
            n = region.count
        );
        let _ = writeln!(
            s,
            "    for (g, w) in GATHER_{number}.iter().zip(&SCATTER_{number}) {{"
        );
        for c in (0..k).filter(|&c| used[c]) {
            let _ = writeln!(body, "let s{c} = {};", read(c, &format!("g[{c}] as usize")));
        }
        let r = straight(&region.tape, None, &slot, lanes, &mut body);
        for (j, reg) in region.tape.outputs.iter().enumerate() {
            let _ = writeln!(body, "{}", add(&format!("w[{j}] as usize"), &r(*reg)));
        }
        s.push_str(&indent(&body, 8));
        s.push_str("    }\n}\n");
        return s;
    };
    let clauses = fam.clauses.as_ref().expect("places checked");
    let ranges: Vec<&str> = clauses
        .iter()
        .filter_map(|c| match c {
            LoopClause::Range { var, .. } => Some(var.as_str()),
            LoopClause::Cond { .. } => None,
        })
        .collect();
    let mut reads: Vec<&Ix> = Vec::new();
    for c in clauses {
        match c {
            LoopClause::Range { start, end, .. } => reads.extend([start, end]),
            LoopClause::Cond { lhs, rhs, .. } => reads.extend([lhs, rhs]),
        }
    }
    fn indexed(p: &Place) -> Option<&Ix> {
        match p {
            Place::Indexed(i) => Some(&i.member),
            Place::Fixed(_) => None,
        }
    }
    let members: Vec<&Ix> = gather
        .iter()
        .enumerate()
        .filter(|(c, _)| used[*c])
        .filter_map(|(_, p)| indexed(p))
        .chain(scatter.iter().filter_map(indexed))
        .collect();
    reads.extend(members.iter().copied());
    let unsigned = unsigned_ok(clauses, &members);
    let names: Vec<String> = ranges
        .iter()
        .enumerate()
        .map(|(v, name)| {
            let base = if is_plain_name(name) {
                name.to_string()
            } else {
                format!("i{v}")
            };
            if reads.iter().any(|ix| ix.reads(v)) {
                base
            } else {
                format!("_{base}")
            }
        })
        .collect();
    let w = Writer {
        names: &names,
        unsigned,
    };
    let mut depth = 0;
    let mut v = 0;
    let mut open = String::new();
    for c in clauses {
        let pad = "    ".repeat(depth);
        match c {
            LoopClause::Range { start, end, .. } => {
                let _ = writeln!(
                    open,
                    "{pad}for {} in {}..{} {{",
                    names[v],
                    w.bound(start),
                    w.bound(end)
                );
                v += 1;
            }
            LoopClause::Cond { lhs, op, rhs } => {
                let _ = writeln!(
                    open,
                    "{pad}if {} {} {} {{",
                    w.expr(lhs, 1),
                    op.symbol(),
                    w.expr(rhs, 1)
                );
            }
        }
        depth += 1;
    }
    s.push_str(&open);
    for (c, place) in gather.iter().enumerate().filter(|(c, _)| used[*c]) {
        let (at, what) = match place {
            Place::Fixed(at) => (
                at.to_string(),
                describe(model, region.sources[c], i64::from(*at), None, &w, extra),
            ),
            Place::Indexed(i) => (
                w.place(i),
                describe(model, region.sources[c], i.base, Some(i), &w, extra),
            ),
        };
        let what = if what.is_empty() {
            what
        } else {
            format!(" // {what}")
        };
        let _ = writeln!(body, "let s{c} = {};{what}", read(c, &at));
    }
    let r = straight(&region.tape, None, &slot, lanes, &mut body);
    for (reg, place) in region.tape.outputs.iter().zip(&scatter) {
        let at = match place {
            Place::Fixed(at) => at.to_string(),
            Place::Indexed(i) => w.place(i),
        };
        let _ = writeln!(body, "{}", add(&at, &r(*reg)));
    }
    s.push_str(&indent(&body, 4 * depth));
    for d in (0..depth).rev() {
        let _ = writeln!(s, "{}}}", "    ".repeat(d));
    }
    s
}

/// A table as rows of `width`, on one line.
fn rows(table: &[u32], width: usize) -> String {
    table
        .chunks(width)
        .map(|r| {
            format!(
                "[{}]",
                r.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// `q[i + 1], component 2` for a comment.
fn describe(
    model: &Model,
    source: Source,
    base: i64,
    index: Option<&SlotIndex>,
    w: &Writer,
    extra: &[String],
) -> String {
    if source == Source::State && index.is_none() && base >= model.dim() as i64 {
        return extra
            .get((base - model.dim() as i64) as usize)
            .cloned()
            .unwrap_or_default();
    }
    let found = match source {
        Source::State => model
            .state
            .iter()
            .map(|v| (v.name.as_str(), v.offset, v.shape))
            .find(|(_, o, s)| (*o as i64..(*o + s.len()) as i64).contains(&base)),
        Source::Param => model
            .params
            .iter()
            .map(|p| (p.name.as_str(), p.offset, p.shape))
            .find(|(_, o, s)| (*o as i64..(*o + s.len()) as i64).contains(&base)),
    };
    let Some((name, offset, shape)) = found else {
        return String::new();
    };
    let c = base - offset as i64;
    match index {
        Some(i) => {
            let member = Writer {
                names: w.names,
                unsigned: true,
            }
            .dsl(&i.member, 0);
            match shape {
                Shape::Matrix(..) => format!("{name}[{member}], component {}", c % i.stride),
                _ => format!("{name}[{member}]"),
            }
        }
        None if shape == Shape::Scalar => name.to_string(),
        None => format!("{name}, component {c}"),
    }
}

/// Can every index expression be computed in `usize` (all intermediate values ≥ 0, at every
/// bound prefix the loops reach)?
fn unsigned_ok(clauses: &[LoopClause], members: &[&Ix]) -> bool {
    fn go(clauses: &[LoopClause], bound: &mut Vec<i64>, members: &[&Ix], budget: &mut u64) -> bool {
        if *budget == 0 {
            return false;
        }
        *budget -= 1;
        let Some((first, rest)) = clauses.split_first() else {
            return members.iter().all(|m| m.non_negative(bound));
        };
        match first {
            LoopClause::Range { start, end, .. } => {
                if !(start.non_negative(bound) && end.non_negative(bound)) {
                    return false;
                }
                let (a, b) = (start.eval(bound).unwrap_or(0), end.eval(bound).unwrap_or(0));
                for v in a..b {
                    bound.push(v);
                    let ok = go(rest, bound, members, budget);
                    bound.pop();
                    if !ok {
                        return false;
                    }
                }
                true
            }
            LoopClause::Cond { lhs, op, rhs } => {
                if !(lhs.non_negative(bound) && rhs.non_negative(bound)) {
                    return false;
                }
                let holds = op.holds(lhs.eval(bound).unwrap_or(0), rhs.eval(bound).unwrap_or(0));
                !holds || go(rest, bound, members, budget)
            }
        }
    }
    go(clauses, &mut Vec::new(), members, &mut 50_000_000)
}

fn is_plain_name(name: &str) -> bool {
    const TAKEN: &[&str] = &[
        "x", "out", "h", "p", "g", "w", "self", "as", "fn", "for", "if", "in", "let", "mut", "ref",
        "type", "use", "loop", "match", "move", "impl", "mod", "pub", "where", "while", "true",
        "false", "break", "const", "crate", "else", "enum", "extern", "return", "static", "struct",
        "super", "trait", "unsafe", "dyn", "do", "box", "try", "async", "await", "yield",
    ];
    let mut chars = name.chars();
    let ok_start = chars.next().is_some_and(|c| c.is_ascii_lowercase());
    let numbered = |p: char| {
        name.strip_prefix(p)
            .is_some_and(|rest| !rest.is_empty() && rest.chars().all(|c| c.is_ascii_digit()))
    };
    ok_start
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
        && !TAKEN.contains(&name)
        && !numbered('r')
        && !numbered('s')
        && !numbered('i')
}

/// Writes index expressions in `usize` (every value non-negative) or `i64`.
struct Writer<'a> {
    names: &'a [String],
    unsigned: bool,
}

impl Writer<'_> {
    /// `e` with the precedence level of its context (0: none, 1: a sum, 2: a product).
    fn expr(&self, e: &Ix, level: u8) -> String {
        let (text, own) = match e {
            Ix::Int(k) if self.unsigned || *k >= 0 => (k.to_string(), 3),
            Ix::Int(k) => (format!("({k})"), 3),
            Ix::Var(v) => (self.names[*v].trim_start_matches('_').to_string(), 3),
            Ix::Add(a, b) => (format!("{} + {}", self.expr(a, 1), self.expr(b, 2)), 1),
            Ix::Sub(a, b) => (format!("{} - {}", self.expr(a, 1), self.expr(b, 2)), 1),
            Ix::Mul(a, b) => (format!("{} * {}", self.expr(a, 2), self.expr(b, 3)), 2),
            Ix::Rem(a, b) if self.unsigned => {
                (format!("{} % {}", self.expr(a, 2), self.expr(b, 3)), 2)
            }
            Ix::Rem(a, b) => (
                format!("({}).rem_euclid({})", self.expr(a, 0), self.expr(b, 0)),
                3,
            ),
        };
        if own < level {
            format!("({text})")
        } else {
            text
        }
    }

    /// A range's bound.
    fn bound(&self, e: &Ix) -> String {
        let t = self.expr(e, 3);
        if self.unsigned || !matches!(e, Ix::Int(_)) {
            t
        } else {
            format!("{}_i64", t.trim_start_matches('(').trim_end_matches(')'))
        }
    }

    /// The DSL's text of a member expression (for comments).
    fn dsl(&self, e: &Ix, level: u8) -> String {
        self.expr(e, level)
    }

    /// `base + stride · member` as an index: `3 * i + 18` where the member is a sum of
    /// multiples of the indices and a constant, all non-negative.
    fn place(&self, i: &SlotIndex) -> String {
        if let Some((coeffs, c)) = affine(&i.member) {
            let c = c * i.stride + i.base;
            if c >= 0 && coeffs.iter().all(|&k| k >= 0) {
                let mut terms: Vec<String> = coeffs
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| k != 0)
                    .map(|(v, &k)| {
                        let name = self.names[v].trim_start_matches('_');
                        match k * i.stride {
                            1 => name.to_string(),
                            k => format!("{k} * {name}"),
                        }
                    })
                    .collect();
                if c != 0 || terms.is_empty() {
                    terms.push(c.to_string());
                }
                let text = terms.join(" + ");
                return if self.unsigned {
                    text
                } else if terms.len() == 1 && !text.contains(' ') {
                    format!("{text} as usize")
                } else {
                    format!("({text}) as usize")
                };
            }
        }
        let member = match i.stride {
            1 => self.expr(&i.member, 1),
            k => format!("{k} * {}", self.expr(&i.member, 3)),
        };
        let text = match i.base {
            0 => member,
            b => format!("{member} + {b}"),
        };
        if self.unsigned {
            text
        } else if text.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            format!("{text} as usize")
        } else {
            format!("({text}) as usize")
        }
    }
}

/// `e` as Σ kᵥ·indexᵥ + c, if it is one (no remainder, no product of two indices).
fn affine(e: &Ix) -> Option<(Vec<i64>, i64)> {
    fn add(a: (Vec<i64>, i64), b: (Vec<i64>, i64), sign: i64) -> (Vec<i64>, i64) {
        let n = a.0.len().max(b.0.len());
        let k = (0..n)
            .map(|v| a.0.get(v).copied().unwrap_or(0) + sign * b.0.get(v).copied().unwrap_or(0))
            .collect();
        (k, a.1 + sign * b.1)
    }
    Some(match e {
        Ix::Int(k) => (Vec::new(), *k),
        Ix::Var(v) => {
            let mut k = vec![0; v + 1];
            k[*v] = 1;
            (k, 0)
        }
        Ix::Add(a, b) => add(affine(a)?, affine(b)?, 1),
        Ix::Sub(a, b) => add(affine(a)?, affine(b)?, -1),
        Ix::Mul(a, b) => {
            let (a, b) = (affine(a)?, affine(b)?);
            let (k, (f, c)) = match (a.0.iter().all(|&k| k == 0), b.0.iter().all(|&k| k == 0)) {
                (true, _) => (a.1, b),
                (_, true) => (b.1, a),
                _ => return None,
            };
            (f.iter().map(|x| x * k).collect(), c * k)
        }
        Ix::Rem(..) => return None,
    })
}

/// Indents every non-empty line of `text` by `by` spaces.
pub(super) fn indent(text: &str, by: usize) -> String {
    text.lines()
        .map(|l| {
            if l.is_empty() {
                "\n".to_string()
            } else {
                format!("{:by$}{l}\n", "")
            }
        })
        .collect()
}

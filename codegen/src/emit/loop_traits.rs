//! The derived functions of the loop form ([`super::loops`]): Df, V, ∇V, X − ∇V and the
//! half-fields, written as loops from the loop tapes the JIT's and the interpreter's loop
//! kernels run ([`LoopModel::jacobian`], [`LoopModel::feedback`], [`LoopModel::partition`]),
//! and the runtime traits they fill: `Invariants`, `Lyapunov`, `Partitioned`, `Declared`.
//!
//! - **Df** is one loop tape with M·N outputs, row-major: each family term's partials are
//!   added at `row · DIM + the component they read`, into the flat view of `jac`.
//! - **V, ∇V, X − ∇V** run in stages, as the staged kernels do: the family sums S that V reads
//!   (a loop tape of x; for ∇V and X − ∇V the pass, which also carries the family parts C of
//!   ∇S and of the field, in the same loop over each family's tuples), then V and the weights
//!   w = ∂V/∂S (straight-line code of x and S), then ∇V or X − ∇V (a loop tape of
//!   `[x, S, C, w]`: ∂V/∂x at fixed S, then per state member a loop over its components
//!   combining C with w).
//! - **The half-fields** are the field's loop tape restricted to the q or the p components,
//!   written into those components of `dx`.
//! - **Guards and events** are straight-line code (a guard or an event that reads a family's
//!   sum is refused: `--families unrolled` emits it).
//!
//! Each function repeats its tape's operations in the tape's order, so it equals the loop
//! kernels bit for bit, and its size does not depend on the number of index tuples.

use super::loops::{f64_text as float, function, function_with, indent};
use lasalle_model::ir::{Id, Input};
use lasalle_model::loops::{LoopFeedback, LoopModel, LoopTape, Source};
use lasalle_model::tape::{Dims, Op, TapeBuilder};
use lasalle_model::{Diagnostic, Model, Span, EVENT_TIME, GUARD_STEP};
use std::fmt::Write;

/// The loop tapes of the derived functions of a loop model.
pub(crate) struct LoopDerived {
    /// Df, M·N outputs row-major.
    jacobian: LoopTape,
    /// V's stages.
    feedback: LoopFeedback,
    /// Stage 2 (V and w from `[x, S]`) as a loop tape without regions.
    weights: LoopTape,
    /// The half-fields with their outputs at the state's components, if the field is
    /// partitioned and no family adds to both halves.
    halves: Option<Halves>,
    /// The field is partitioned but a family adds to both halves: no loop form.
    halves_refused: bool,
    /// The guards' margins, the step size as gain 0, if the model has guards.
    guards: Option<LoopTape>,
    /// The events' functions g, the time as gain 0, if the model has events.
    events: Option<LoopTape>,
}

struct Halves {
    is_q: Vec<bool>,
    q: LoopTape,
    p: LoopTape,
}

impl LoopDerived {
    /// The loop tapes of Df, V's stages and the half-fields (errors where the loop form refuses
    /// the field or the invariants, as [`LoopModel::tapes`] does).
    pub(crate) fn new(lm: &LoopModel) -> lasalle_model::Result<Self> {
        let jacobian = lm.jacobian()?;
        let feedback = lm.feedback()?;
        let k = feedback.weights.outputs.len();
        let weights = LoopTape {
            base: feedback.weights.clone(),
            base_at: (0..k as u32).collect(),
            outputs: k,
            regions: Vec::new(),
        };
        let n = lm.lowered().dim();
        let (halves, halves_refused) = match lm.partition() {
            Ok(Some(p)) => {
                // the compact outputs of each half at the state's components
                let at = |q: bool| -> Vec<u32> {
                    (0..n as u32).filter(|&i| p.is_q[i as usize] == q).collect()
                };
                let halves = Halves {
                    q: widen(&p.field_q, &at(true), n),
                    p: widen(&p.field_p, &at(false), n),
                    is_q: p.is_q,
                };
                (Some(halves), false)
            }
            Ok(None) => (None, false),
            Err(_) => (None, true),
        };
        let model = lm.declarations();
        let guards: Vec<(Id, &Span)> = model.guards.iter().map(|g| (g.margin, &g.span)).collect();
        let events: Vec<(Id, &Span)> = model.events.iter().map(|e| (e.value, &e.span)).collect();
        Ok(LoopDerived {
            jacobian,
            feedback,
            weights,
            halves,
            halves_refused,
            guards: one_gain(model, &guards, GUARD_STEP)?,
            events: one_gain(model, &events, EVENT_TIME)?,
        })
    }

    /// The number K of family sums V reads.
    fn sums(&self) -> usize {
        self.feedback.sums.outputs
    }

    /// The number D of values the pass carries to the last stage.
    fn carried(&self) -> usize {
        self.feedback.carried()
    }

    /// The derived functions' loop tapes with the names of their prepared fields.
    pub(crate) fn functions(&self) -> Vec<(&'static str, &LoopTape)> {
        let mut out = vec![
            ("jacobian", &self.jacobian),
            ("sums", &self.feedback.sums),
            ("pass", &self.feedback.pass),
            ("weights", &self.weights),
            ("gradient", &self.feedback.gradient),
            ("feedback", &self.feedback.feedback),
        ];
        if let Some(h) = &self.halves {
            out.extend([("field_q", &h.q), ("field_p", &h.p)]);
        }
        if let Some(g) = &self.guards {
            out.push(("guards", g));
        }
        if let Some(e) = &self.events {
            out.push(("events", e));
        }
        out
    }

    /// The instruction counts of Df, V (stages 1 and 2), ∇V and X − ∇V (all three stages).
    pub(crate) fn instructions(&self) -> [usize; 4] {
        let w = self.weights.instructions();
        let v = self.feedback.sums.instructions() + w;
        let pass = self.feedback.pass.instructions() + w;
        [
            self.jacobian.instructions(),
            v,
            pass + self.feedback.gradient.instructions(),
            pass + self.feedback.feedback.instructions(),
        ]
    }

    /// The names of the runtime traits beyond `Field` and `ModelInfo` the items implement, for
    /// the `use` line.
    pub(crate) fn imports(&self, model: &Model) -> Vec<&'static str> {
        let mut out = vec![
            "Declared",
            "Invariants",
            "Lyapunov",
            "ParamError",
            "Parameters",
        ];
        if self.halves.is_some() {
            out.push("Partitioned");
        }
        if !model.presets.is_empty() {
            out.push("Preset");
        }
        if model.splitting.is_some() {
            out.push("Splitting");
        }
        if self.guards.is_some() {
            out.push("GuardFailure");
        }
        if self.events.is_some() {
            out.extend(["EventDirection", "EventSpec"]);
        }
        if !model.delays.is_empty() {
            out.push("DelaySpec");
        }
        out
    }

    /// What the module docs say of the derived functions.
    pub(crate) fn summary(&self) -> &'static str {
        if self.halves_refused {
            "`Invariants` (with Df), `Lyapunov` (V, ∇V, X − ∇V) and `Declared` (the presets, \
             guards, events and splitting); the field is \
             partitioned but a family adds to both halves, so the half-fields (`Partitioned`, \
             Störmer–Verlet) have no loop form here"
        } else if self.halves.is_some() {
            "`Invariants` (with Df), `Lyapunov` (V, ∇V, X − ∇V), `Partitioned` (the half-fields \
             of Störmer–Verlet) and `Declared` (the presets, guards, events, half-fields and \
             splitting)"
        } else {
            "`Invariants` (with Df), `Lyapunov` (V, ∇V, X − ∇V) and `Declared` (the presets, \
             guards, events and splitting)"
        }
    }
}

/// The plain tape of the guards' margins or the events' functions, with `input` (the step
/// size, the time) as its one gain; `None` without any. Refused, located, where one reads a
/// family's sum.
fn one_gain(
    model: &Model,
    outputs: &[(Id, &Span)],
    input: Input,
) -> lasalle_model::Result<Option<LoopTape>> {
    if outputs.is_empty() {
        return Ok(None);
    }
    let mut graph = model.graph.clone();
    let ids: Vec<Id> = outputs.iter().map(|o| o.0).collect();
    let ids = graph.rename_inputs(&ids, |i| if i == input { Input::Gain(0) } else { i });
    if let Some(k) = ids
        .iter()
        .position(|&id| graph.depends_on(id, |i| matches!(i, Input::Symbol(_))))
    {
        return Err(lasalle_model::Error::Model(vec![Diagnostic::new(
            outputs[k].1,
            "this reads a family's sum: the emitted loop form has no code for it",
        )
        .help("generate the model with `--families unrolled`")]));
    }
    let dims = Dims {
        state: model.dim(),
        params: model.param_slots(),
        targets: 0,
        gains: 1,
    };
    let base = TapeBuilder::new(graph, dims).build(&ids).map_err(|e| {
        lasalle_model::Error::Internal(format!("tape of the guards or events: {e}"))
    })?;
    Ok(Some(LoopTape {
        base,
        base_at: (0..ids.len() as u32).collect(),
        outputs: ids.len(),
        regions: Vec::new(),
    }))
}

/// `t` with its outputs moved to the components `at` of an N-vector.
fn widen(t: &LoopTape, at: &[u32], n: usize) -> LoopTape {
    let mut t = t.clone();
    for o in &mut t.base_at {
        *o = at[*o as usize];
    }
    for r in &mut t.regions {
        for o in &mut r.scatter {
            *o = at[*o as usize];
        }
    }
    t.outputs = n;
    t
}

/// Does the function read the state (`x`)?
fn reads_state(lt: &LoopTape) -> bool {
    lt.base.body.iter().any(|op| matches!(op, Op::State(_)))
        || lt.regions.iter().any(|r| {
            r.tape.body.iter().any(|op| match op {
                Op::State(c) => r.sources[*c as usize] == Source::State,
                _ => false,
            })
        })
}

/// Does the plain part read a target or a gain (the regions read neither)?
fn reads(lt: &LoopTape, leaf: fn(&Op) -> bool) -> bool {
    lt.base.body.iter().any(leaf)
}

/// `name` or `_name` as the function reads it or not.
fn arg(used: bool, name: &str) -> String {
    if used {
        name.to_string()
    } else {
        format!("_{name}")
    }
}

/// `x`, `target`, `gains` of a stage of V as it reads them.
fn args(lt: &LoopTape) -> (String, String, String) {
    (
        arg(reads_state(lt), "x"),
        arg(reads(lt, |op| matches!(op, Op::Target(_))), "target"),
        arg(reads(lt, |op| matches!(op, Op::Gain(_))), "gains"),
    )
}

/// Where the outputs of one half sit: `out[a..b].fill(0.0);` per run of its components.
fn zero_runs(is_q: &[bool], q: bool) -> String {
    let mut s = String::new();
    for (a, b) in runs(is_q, q) {
        if b == a + 1 {
            let _ = writeln!(s, "out[{a}] = 0.0;");
        } else {
            let _ = writeln!(s, "out[{a}..{b}].fill(0.0);");
        }
    }
    s
}

/// The maximal runs `a..b` of components where `is_q` is `q`.
fn runs(is_q: &[bool], q: bool) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < is_q.len() {
        if is_q[i] != q {
            i += 1;
            continue;
        }
        let a = i;
        while i < is_q.len() && is_q[i] == q {
            i += 1;
        }
        out.push((a, i));
    }
    out
}

/// The names of the state inputs of V's third stage beyond the model's state, for comments:
/// the sums S, the carried values C and the weights w.
fn stage_names(k: usize, carried: usize) -> Vec<String> {
    (0..k)
        .map(|i| format!("S[{i}], a family sum V reads"))
        .chain((0..carried).map(|i| format!("C[{i}], carried by the pass")))
        .chain((0..k).map(|i| format!("w[{i}] = ∂V/∂S[{i}]")))
        .collect()
}

impl LoopDerived {
    /// The inherent methods of the prepared model that V's stages need (private), as text.
    pub(crate) fn stage_methods(&self, lm: &LoopModel) -> String {
        let k = self.sums();
        let extra = stage_names(k, self.carried());
        let fb = &self.feedback;
        let (wx, wt, wg) = args(&self.weights);
        let (gx, gt, gg) = args(&fb.gradient);
        let (fx, ft, fg) = args(&fb.feedback);
        let sx = arg(reads_state(&fb.sums), "x");
        let px = arg(reads_state(&fb.pass), "x");
        let mut s = function(
            lm,
            &fb.sums,
            "sums",
            &format!(
                "/// Stage 1 of V: the family sums S that V reads.\n\
                 fn lyapunov_sums(&self, {sx}: &[f64; DIM], out: &mut [f64; SUMS]) {{"
            ),
            false,
            None,
            &[],
        );
        s.push('\n');
        s.push_str(&function(
            lm,
            &fb.pass,
            "pass",
            &format!(
                "/// Stage 1 of ∇V and X − ∇V: the sums S, then the values C carried to stage 3 (the\n\
                 /// family parts of ∇S and of the field), in one loop over each family's tuples.\n\
                 fn lyapunov_pass(&self, {px}: &[f64; DIM], out: &mut [f64; SUMS + CARRIED]) {{"
            ),
            false,
            None,
            &[],
        ));
        s.push('\n');
        s.push_str(&function(
            lm,
            &self.weights,
            "weights",
            &format!(
                "/// Stage 2: V and the weights w = ∂V/∂S from x and S.\n\
                 fn lyapunov_weights(&self, {wx}: &[f64; DIM + SUMS], {wt}: &[f64; INVARIANT_DIM], {wg}: &[f64; GAINS], out: &mut [f64; 1 + SUMS]) {{"
            ),
            false,
            None,
            &extra,
        ));
        s.push_str(
            "\n/// Stages 1 and 2 of V.\n\
             fn lyapunov_value(&self, x: &[f64; DIM], target: &[f64; INVARIANT_DIM], gains: &[f64; GAINS]) -> f64 {\n\
             \x20   let mut xs = [0.0; DIM + SUMS];\n\
             \x20   xs[..DIM].copy_from_slice(x);\n\
             \x20   let mut sums = [0.0; SUMS];\n\
             \x20   self.lyapunov_sums(x, &mut sums);\n\
             \x20   xs[DIM..].copy_from_slice(&sums);\n\
             \x20   let mut vw = [0.0; 1 + SUMS];\n\
             \x20   self.lyapunov_weights(&xs, target, gains, &mut vw);\n\
             \x20   vw[0]\n\
             }\n\n\
             /// The pass and stage 2: `[x, S, C, w]`, the input of stage 3.\n\
             fn lyapunov_stages(&self, x: &[f64; DIM], target: &[f64; INVARIANT_DIM], gains: &[f64; GAINS]) -> [f64; DIM + 2 * SUMS + CARRIED] {\n\
             \x20   let mut xsw = [0.0; DIM + 2 * SUMS + CARRIED];\n\
             \x20   xsw[..DIM].copy_from_slice(x);\n\
             \x20   let mut pass = [0.0; SUMS + CARRIED];\n\
             \x20   self.lyapunov_pass(x, &mut pass);\n\
             \x20   xsw[DIM..DIM + SUMS + CARRIED].copy_from_slice(&pass);\n\
             \x20   let mut xs = [0.0; DIM + SUMS];\n\
             \x20   xs.copy_from_slice(&xsw[..DIM + SUMS]);\n\
             \x20   let mut vw = [0.0; 1 + SUMS];\n\
             \x20   self.lyapunov_weights(&xs, target, gains, &mut vw);\n\
             \x20   xsw[DIM + SUMS + CARRIED..].copy_from_slice(&vw[1..]);\n\
             \x20   xsw\n\
             }\n\n",
        );
        s.push_str(&function_with(
            lm,
            &fb.families,
            &fb.gradient,
            "gradient",
            &format!(
                "/// Stage 3 of ∇V: ∂V/∂x at fixed S, plus Σ w·∇S from the carried values.\n\
                 fn lyapunov_gradient_stage(&self, {gx}: &[f64; DIM + 2 * SUMS + CARRIED], {gt}: &[f64; INVARIANT_DIM], {gg}: &[f64; GAINS], out: &mut [f64; DIM]) {{"
            ),
            false,
            None,
            &extra,
        ));
        s.push('\n');
        s.push_str(&function_with(
            lm,
            &fb.families,
            &fb.feedback,
            "feedback",
            &format!(
                "/// Stage 3 of X − ∇V: X − ∂V/∂x at fixed S, plus from the carried values the\n\
                 /// family parts of X minus Σ w·∇S.\n\
                 fn feedback_stage(&self, {fx}: &[f64; DIM + 2 * SUMS + CARRIED], {ft}: &[f64; INVARIANT_DIM], {fg}: &[f64; GAINS], out: &mut [f64; DIM]) {{"
            ),
            false,
            None,
            &extra,
        ));
        s.push_str(&self.guards_and_events(lm));
        s
    }

    /// The guards' margins and the events' functions as private methods (the step size and
    /// the time are the tapes' one gain), each preceded by a blank line.
    fn guards_and_events(&self, lm: &LoopModel) -> String {
        let mut s = String::new();
        let items = [
            (&self.guards, "guards", "guard_margins", "dt", "The guards' margins (the guard holds where its margin is positive, or\n/// non-negative for `>=` and `<=`) at step size `dt`."),
            (&self.events, "events", "event_functions", "t", "The events' functions g(x, t), whose zeros are the events."),
        ];
        for (tape, field, name, gain, doc) in items {
            let Some(tape) = tape else { continue };
            let x = arg(reads_state(tape), "x");
            let g = arg(reads(tape, |op| matches!(op, Op::Gain(_))), gain);
            let code = function(
                lm,
                tape,
                field,
                &format!(
                    "/// {doc}\nfn {name}(&self, {x}: &[f64; DIM], {g}: f64, out: &mut [f64; {}]) {{",
                    tape.outputs
                ),
                false,
                None,
                &[],
            );
            // the tape's one gain is the step size or the time
            s.push('\n');
            s.push_str(&code.replace("gains[0]", gain));
        }
        s
    }

    /// `impl Invariants` with `invariants` written from `invariants`, `impl Lyapunov`,
    /// `impl Partitioned` and `impl Declared` on the prepared model, as text.
    pub(crate) fn trait_impls(&self, lm: &LoopModel, invariants: &LoopTape, prep: &str) -> String {
        let model = lm.lowered();
        let jx = arg(reads_state(&self.jacobian), "x");
        let mut s =
            format!("impl Invariants<f64, [f64; DIM], [f64; INVARIANT_DIM]> for {prep} {{\n");
        s.push_str(&indent(
            &function(
                lm,
                invariants,
                "invariants",
                "/// f(x), the stacked invariants.\n\
                 fn invariants(&self, x: &[f64; DIM], out: &mut [f64; INVARIANT_DIM]) {",
                false,
                None,
                &[],
            ),
            4,
        ));
        s.push('\n');
        s.push_str(&indent(
            &function(
                lm,
                &self.jacobian,
                "jacobian",
                &format!(
                    "/// Df(x), row c = ∇f_c(x), through its flat view `out` (row-major): the plain\n\
                     /// part's gradient, then each family term's partials added at\n\
                     /// `row · DIM +` the component they read.\n\
                     fn invariants_jacobian(&self, {jx}: &[f64; DIM], jac: &mut [[f64; DIM]; INVARIANT_DIM]) {{"
                ),
                false,
                Some("let out = jac.as_flattened_mut();\nout.fill(0.0);\n"),
                &[],
            ),
            4,
        ));
        s.push_str("}\n\n");
        let _ = write!(
            s,
            "impl Lyapunov<f64, [f64; DIM], [f64; INVARIANT_DIM], [f64; GAINS]> for {prep} {{
    /// V(x): the sums it reads (stage 1), then V (stage 2).
    fn lyapunov(&self, x: &[f64; DIM], target: &[f64; INVARIANT_DIM], gains: &[f64; GAINS]) -> f64 {{
        self.lyapunov_value(x, target, gains)
    }}

    /// ∇V(x), in three stages.
    fn lyapunov_gradient(&self, x: &[f64; DIM], target: &[f64; INVARIANT_DIM], gains: &[f64; GAINS], grad: &mut [f64; DIM]) {{
        let xsw = self.lyapunov_stages(x, target, gains);
        self.lyapunov_gradient_stage(&xsw, target, gains, grad);
    }}

    /// X(x) − ∇V(x), in three stages.
    fn feedback_field(&self, x: &[f64; DIM], target: &[f64; INVARIANT_DIM], gains: &[f64; GAINS], dx: &mut [f64; DIM]) {{
        let xsw = self.lyapunov_stages(x, target, gains);
        self.feedback_stage(&xsw, target, gains, dx);
    }}
}}

"
        );
        if let Some(h) = &self.halves {
            let _ = writeln!(
                s,
                "impl Partitioned<f64, [f64; DIM]> for {prep} {{\n    fn is_q(&self) -> &[bool] {{\n        &IS_Q\n    }}\n"
            );
            for (q, name, tape, group) in [
                (true, "field_q", &h.q, "q̇ = a(p)"),
                (false, "field_p", &h.p, "ṗ = b(q)"),
            ] {
                let x = arg(reads_state(tape), "x");
                s.push_str(&indent(
                    &function(
                        lm,
                        tape,
                        name,
                        &format!(
                            "/// {group} into its components of `out` (the others are left alone).\n\
                             fn {name}(&self, {x}: &[f64; DIM], out: &mut [f64; DIM]) {{"
                        ),
                        false,
                        Some(&zero_runs(&h.is_q, q)),
                        &[],
                    ),
                    4,
                ));
                if q {
                    s.push('\n');
                }
            }
            s.push_str("}\n\n");
        }
        s.push_str(&self.declared(model, prep));
        s.push('\n');
        s.push_str(&Self::parameters(model, prep));
        s
    }

    /// The constants the trait impls read (`GAINS`, `SUMS`, `IS_Q`), as text.
    pub(crate) fn constants(&self, model: &Model) -> String {
        let mut s = format!(
            "/// Gains.\npub const GAINS: usize = {};\n\n\
             /// The family sums S that V reads, computed first by V, ∇V and X − ∇V.\n\
             const SUMS: usize = {};\n\n\
             /// The values the pass of ∇V and X − ∇V carries to their last stage after S.\n\
             const CARRIED: usize = {};\n",
            model.gains.len(),
            self.sums(),
            self.carried()
        );
        if let Some(h) = &self.halves {
            s.push_str(
                "\n/// `true` at the components of q, the group whose rate reads only p \
                 (Störmer–Verlet's half-fields).\nconst IS_Q: [bool; DIM] = {\n    let mut is_q = [false; DIM];\n",
            );
            for (a, b) in runs(&h.is_q, true) {
                let names: Vec<&str> = model
                    .state
                    .iter()
                    .filter(|v| v.offset >= a && v.offset + v.shape.len() <= b)
                    .map(|v| v.name.as_str())
                    .collect();
                let _ = writeln!(
                    s,
                    "    let mut i = {a};\n    while i < {b} {{\n        // {}\n        is_q[i] = true;\n        i += 1;\n    }}",
                    names.join(", ")
                );
            }
            s.push_str("    is_q\n};\n");
        }
        s
    }

    /// `impl Parameters`: the parameters by name, as slots (the diagonal of a `diag(…)`
    /// parameter); setting one prepares the model again. The points are known at the default
    /// parameters only (`POINTS`: their comprehensions have no loop form).
    pub(crate) fn parameters(model: &Model, prep: &str) -> String {
        let ty = &model.name;
        let known: Vec<String> = model
            .params
            .iter()
            .map(|p| format!("`{}`", p.name))
            .collect();
        let known = if known.is_empty() {
            "(none)".to_string()
        } else {
            known.join(", ")
        };
        let unknown = format!(
            "Err(ParamError::Unknown {{\n    name: name.to_string(),\n    known: {known:?}.to_string(),\n}})"
        );
        let mut s = format!(
            "/// Parameters by name (their slots; the diagonal of a `diag(…)` parameter); setting one\n\
             /// prepares the model again. The points are known at the default parameters only\n\
             /// ([`{ty}::POINTS`]; their comprehensions have no loop form): `point` is `None` after\n\
             /// a parameter changed.\nimpl Parameters for {prep} {{\n"
        );
        let slots: Vec<String> = model
            .params
            .iter()
            .map(|p| format!("{:?} => {}..{},", p.name, p.offset, p.offset + p.slots()))
            .collect();
        let mut items = Vec::new();
        if model.params.is_empty() {
            items.push(format!(
                "fn set_param(&mut self, name: &str, _values: &[f64]) -> Result<(), ParamError> {{\n{}}}\n",
                indent(&unknown, 4)
            ));
            items.push("fn param(&self, _name: &str) -> Option<Vec<f64>> {\n    None\n}\n".into());
        } else {
            let slots = indent(&slots.join("\n"), 8);
            let unknown = indent(&unknown, 12);
            items.push(format!(
                "fn set_param(&mut self, name: &str, values: &[f64]) -> Result<(), ParamError> {{
    let at = match name {{
{slots}        _ => {{
            return {unknown_first}
        }}
    }};
    if values.len() != at.len() {{
        return Err(ParamError::WrongLength {{
            name: name.to_string(),
            expected: at.len(),
            given: values.len(),
        }});
    }}
    let mut params = self.params;
    params[at].copy_from_slice(values);
    *self = {ty} {{ params }}.prepare();
    Ok(())
}}
",
                unknown_first = unknown.trim()
            ));
            items.push(format!(
                "fn param(&self, name: &str) -> Option<Vec<f64>> {{
    let at = match name {{
{slots}        _ => return None,
    }};
    Some(self.params[at].to_vec())
}}
"
            ));
        }
        let names: Vec<String> = model
            .points
            .iter()
            .map(|p| format!("{:?}", p.name))
            .collect();
        items.push(format!(
            "fn point_names(&self) -> &'static [&'static str] {{\n    &[{}]\n}}\n",
            names.join(", ")
        ));
        if model.points.is_empty() {
            items.push("fn point(&self, _name: &str) -> Option<Vec<f64>> {\n    None\n}\n".into());
        } else {
            items.push(format!(
                "fn point(&self, name: &str) -> Option<Vec<f64>> {{
    if self.params != {ty}::DEFAULT_PARAMS {{
        return None;
    }}
    {ty}::POINTS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, x)| x.to_vec())
}}
"
            ));
        }
        s.push_str(&indent(&items.join("\n"), 4));
        s.push_str("}\n");
        s
    }

    /// `impl Declared`: the run presets, the half-fields, the splitting.
    fn declared(&self, model: &Model, prep: &str) -> String {
        let mut items: Vec<String> = Vec::new();
        let opt_str = |v: &Option<String>| match v {
            Some(x) => format!("Some({x:?})"),
            None => "None".into(),
        };
        let opt_f64 = |v: Option<f64>| match v {
            Some(x) => format!("Some({})", float(x)),
            None => "None".into(),
        };
        if !model.presets.is_empty() {
            let mut s = String::from("fn presets(&self) -> &'static [Preset] {\n    &[\n");
            for p in &model.presets {
                let gains = match &p.gains {
                    Some(g) => format!(
                        "Some(&[{}])",
                        g.iter().map(|&x| float(x)).collect::<Vec<_>>().join(", ")
                    ),
                    None => "None".into(),
                };
                let params: Vec<String> = p
                    .params
                    .iter()
                    .map(|(name, v)| {
                        let v: Vec<String> = v.iter().map(|&x| float(x)).collect();
                        format!("({name:?}, &[{}])", v.join(", "))
                    })
                    .collect();
                let _ = writeln!(
                    s,
                    "        Preset {{\n            name: {:?},\n            method: {},\n            dt: {},\n            t_end: {},\n            every: {},\n            init: {},\n            gains: {gains},\n            params: &[{}],\n        }},",
                    p.name,
                    opt_str(&p.method),
                    opt_f64(p.dt),
                    opt_f64(p.t_end),
                    p.every.map_or("None".into(), |k| format!("Some({k})")),
                    opt_str(&p.init),
                    params.join(", ")
                );
            }
            s.push_str("    ]\n}\n");
            items.push(s);
        }
        if self.halves.is_some() {
            items.push(
                "fn partitioned(&self) -> Option<&dyn Partitioned<f64, [f64; DIM]>> {\n    Some(self)\n}\n"
                    .into(),
            );
        }
        if let Some(g) = &self.guards {
            let checks: Vec<String> = model
                .guards
                .iter()
                .enumerate()
                .map(|(i, g)| {
                    format!(
                        "GuardFailure::check({:?}, {:?}, margin[{i}], {})",
                        g.name, g.condition, g.strict
                    )
                })
                .collect();
            items.push(format!(
                "fn check_guards(&self, x: &[f64; DIM], dt: f64) -> Option<GuardFailure> {{\n    \
                 let mut margin = [0.0; {}];\n    self.guard_margins(x, dt, &mut margin);\n    {}\n}}\n",
                g.outputs,
                checks.join("\n        .or_else(|| ")
                    + &")".repeat(checks.len() - 1)
            ));
        }
        if let Some(e) = &self.events {
            let specs: Vec<String> = model
                .events
                .iter()
                .map(|e| {
                    let direction = match e.direction {
                        lasalle_model::Direction::Both => "Both",
                        lasalle_model::Direction::Rising => "Rising",
                        lasalle_model::Direction::Falling => "Falling",
                    };
                    format!(
                        "EventSpec {{ name: {:?}, direction: EventDirection::{direction}, terminal: {} }},",
                        e.name, e.terminal
                    )
                })
                .collect();
            items.push(format!(
                "fn events(&self) -> &'static [EventSpec] {{\n    &[\n{}    ]\n}}\n",
                indent(&specs.join("\n"), 8)
            ));
            items.push(format!(
                "fn event_values(&self, x: &[f64; DIM], t: f64, g: &mut [f64]) {{\n    \
                 let mut values = [0.0; {k}];\n    self.event_functions(x, t, &mut values);\n    \
                 g[..{k}].copy_from_slice(&values);\n}}\n",
                k = e.outputs
            ));
        }
        if !model.delays.is_empty() {
            let specs: Vec<String> = model
                .delays
                .iter()
                .map(|d| {
                    format!(
                        "DelaySpec {{ text: {:?}, location: {:?}, component: {}, slot: {}, clock: {} }},",
                        d.text,
                        d.span.location(),
                        d.component,
                        d.slot,
                        d.clock
                    )
                })
                .collect();
            items.push(format!(
                "fn delays(&self) -> &'static [DelaySpec] {{\n    &[\n{}    ]\n}}\n",
                indent(&specs.join("\n"), 8)
            ));
        }
        if let Some(sp) = &model.splitting {
            let values: Vec<String> = sp
                .params
                .iter()
                .map(|k| format!("self.params[{k}]"))
                .collect();
            items.push(format!(
                "fn splitting(&self) -> Option<Splitting<f64>> {{\n    Splitting::declared({:?}, &[{}])\n}}\n",
                sp.kind,
                values.join(", ")
            ));
        }
        format!(
            "impl Declared<f64, [f64; DIM]> for {prep} {{\n{}}}\n",
            indent(&items.join("\n"), 4)
        )
    }
}

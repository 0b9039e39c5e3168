//! The n-th order equation x⁽ⁿ⁾ + p₁(t)x⁽ⁿ⁻¹⁾ + … + pₙ(t)x = 0 read off a model in the
//! companion form (2.1): states x₁ … xₙ with
//!
//! ```text
//! d/dt x₁ = x₂, …, d/dt xₙ₋₁ = xₙ,   d/dt xₙ = −pₙ(t)x₁ − … − p₁(t)xₙ,
//! ```
//!
//! and, when the coefficients vary, one clock state c with d/dt c = 1 standing for t (the
//! model language has no explicit time in a field). The coefficients are read symbolically:
//! p_{n+1−j} = −∂(d/dt xₙ)/∂x_j, each required to depend on the clock and the parameters
//! only, and the equation is required to be homogeneous (d/dt xₙ = 0 at x = 0). Any departure
//! is a [`EquationError`] at the file, line and column of the offending equation.

use std::collections::HashMap;
use std::fmt;

use lasalle_model::ir::{diff, Graph, Id, Input, Node};
use lasalle_model::{Model, Span};

/// Where and why a model is not an n-th order linear equation in companion form.
#[derive(Clone, Debug, PartialEq)]
pub struct EquationError {
    /// `path:line:col` of the offending item (or of the model).
    pub location: String,
    /// The source line.
    pub line: String,
    /// What is wrong and what the form needs.
    pub message: String,
}

impl fmt::Display for EquationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: not an n-th order linear equation in companion form: {}\n  | {}",
            self.location,
            self.message,
            self.line.trim()
        )
    }
}

impl std::error::Error for EquationError {}

fn at(span: &Span, message: String) -> EquationError {
    EquationError {
        location: span.location(),
        line: span.line_text().to_string(),
        message,
    }
}

/// The equation read off a model.
#[derive(Clone)]
pub struct CompanionEquation {
    /// The model's name.
    pub name: String,
    graph: Graph,
    /// The flat index of the clock state, if there is one.
    pub clock: Option<usize>,
    /// The names of x₁ … xₙ and of the clock.
    pub names: Vec<String>,
    /// The clock's name.
    pub clock_name: Option<String>,
    /// p₁ … pₙ as expressions of the clock and the parameters.
    pub coefficients: Vec<Id>,
    /// The printer's names of the slots ([`slot_legend`]).
    pub legend: String,
}

/// The name of flat component k (`x`, or `x[2]` for a member of a vector state).
fn component_name(model: &Model, k: usize) -> String {
    let s = model
        .state
        .iter()
        .rev()
        .find(|s| s.offset <= k)
        .expect("every component belongs to a state");
    if s.shape.len() == 1 {
        s.name.clone()
    } else {
        format!("{}[{}]", s.name, k - s.offset)
    }
}

/// The printer's names of the model's slots, `x0 = x, x1 = v, …; p0 = p, …`, for reading
/// expressions shown by [`Graph::display`].
pub fn slot_legend(model: &Model) -> String {
    let states: Vec<String> = (0..model.dim())
        .map(|k| format!("x{k} = {}", component_name(model, k)))
        .collect();
    let params: Vec<String> = model
        .params
        .iter()
        .flat_map(|p| {
            (0..p.slots()).map(move |k| {
                if p.slots() == 1 {
                    format!("p{} = {}", p.offset, p.name)
                } else {
                    format!("p{} = {}[{k}]", p.offset + k, p.name)
                }
            })
        })
        .collect();
    if params.is_empty() {
        states.join(", ")
    } else {
        format!("{}; {}", states.join(", "), params.join(", "))
    }
}

impl CompanionEquation {
    /// Reads the equation off `model` with the parameter slots `params` (see the
    /// [module docs](self)).
    pub fn from_model(model: &Model, params: &[f64]) -> Result<CompanionEquation, EquationError> {
        let dim = model.dim();
        let whole = Span {
            source: model.source.clone(),
            start: 0,
            end: 0,
        };
        let clocks: Vec<usize> = (0..dim)
            .filter(|&k| model.graph.as_num(model.field[k]) == Some(1.0))
            .collect();
        if clocks.len() > 1 {
            return Err(at(
                &model.field_spans[clocks[1]],
                format!(
                    "a second clock (d/dt {} = 1, after d/dt {} = 1); the form has one state standing for t",
                    component_name(model, clocks[1]),
                    component_name(model, clocks[0])
                ),
            ));
        }
        let clock = clocks.first().copied();
        let xs: Vec<usize> = (0..dim).filter(|&k| Some(k) != clock).collect();
        if xs.is_empty() {
            return Err(at(
                &whole,
                format!("`{}` has no state besides the clock", model.name),
            ));
        }
        let names: Vec<String> = xs.iter().map(|&k| component_name(model, k)).collect();
        let n = xs.len();
        for k in 0..n - 1 {
            let f = model.field[xs[k]];
            if model.graph.node(f) != &Node::Input(Input::State(xs[k + 1] as u32)) {
                return Err(at(
                    &model.field_spans[xs[k]],
                    format!(
                        "d/dt {} is {}; the form (2.1) has {} there (d/dt x₁ = x₂, …, d/dt xₙ₋₁ = xₙ, \
                         d/dt xₙ = −pₙ(t)x₁ − … − p₁(t)xₙ, the states in that order) [{}]",
                        names[k],
                        model.graph.display(f),
                        names[k + 1],
                        slot_legend(model)
                    ),
                ));
            }
        }
        let mut graph = model.graph.clone();
        let last = model.field[xs[n - 1]];
        let span = &model.field_spans[xs[n - 1]];
        let mut coefficients = vec![last; n];
        for (j, &x) in xs.iter().enumerate() {
            let d = diff(
                &mut graph,
                last,
                Input::State(x as u32),
                &mut HashMap::new(),
            );
            let minus = graph.neg(d);
            if let Some(other) = xs
                .iter()
                .find(|&&y| graph.depends_on(minus, |i| i == Input::State(y as u32)))
            {
                return Err(at(
                    span,
                    format!(
                        "the coefficient of {} in d/dt {} is {}, which depends on the state {}; \
                         the coefficients may depend on the clock and the parameters only (a linear equation) [{}]",
                        names[j],
                        names[n - 1],
                        graph.display(d),
                        component_name(model, *other),
                        slot_legend(model)
                    ),
                ));
            }
            coefficients[n - 1 - j] = minus;
        }
        let eq = CompanionEquation {
            name: model.name.clone(),
            graph,
            clock,
            names,
            clock_name: clock.map(|k| component_name(model, k)),
            coefficients,
            legend: slot_legend(model),
        };
        eq.check_homogeneous(params, last, &xs, span)?;
        Ok(eq)
    }

    /// d/dt xₙ at x = 0 must vanish (its coefficients being state-free, it is then linear).
    fn check_homogeneous(
        &self,
        params: &[f64],
        last: Id,
        xs: &[usize],
        span: &Span,
    ) -> Result<(), EquationError> {
        for t in [0.0, 0.377, 1.25, 2.5, 9.75] {
            let v = self.graph.eval_f64(&[last], &mut |i| match i {
                Input::Param(k) => params[k as usize],
                Input::State(k) if Some(k as usize) == self.clock => t,
                _ => 0.0,
            })[0];
            if v != 0.0 {
                return Err(at(
                    span,
                    format!(
                        "d/dt {} is {} at {} = 0{}: a term without the state, so the equation is not homogeneous",
                        self.names[xs.len() - 1],
                        v,
                        self.names.join(" = "),
                        self.clock_name
                            .as_ref()
                            .map_or(String::new(), |c| format!(", {c} = {t}"))
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The order n.
    pub fn order(&self) -> usize {
        self.coefficients.len()
    }

    /// p₁(t) … pₙ(t) with the parameter slots `params` (the model's layout).
    pub fn coefficients_at(&self, t: f64, params: &[f64]) -> Vec<f64> {
        self.graph.eval_f64(&self.coefficients, &mut |i| match i {
            Input::Param(k) => params[k as usize],
            Input::State(k) if Some(k as usize) == self.clock => t,
            _ => f64::NAN,
        })
    }

    /// p_k as written by the generator's printer (1-based k).
    pub fn coefficient_text(&self, k: usize) -> String {
        self.graph.display(self.coefficients[k - 1])
    }

    /// Does any coefficient vary with the clock?
    pub fn time_varying(&self) -> bool {
        self.clock.is_some_and(|c| {
            self.coefficients
                .iter()
                .any(|&p| self.graph.depends_on(p, |i| i == Input::State(c as u32)))
        })
    }
}

/// The criterion along t: w(t) and its parts on a grid of [t₀, t₁], and the smallest w.
#[derive(Clone, Debug)]
pub struct Assessment {
    /// The grid's times.
    pub t: Vec<f64>,
    /// p₁(t) … pₙ(t) on the grid.
    pub p: Vec<Vec<f64>>,
    /// w(t) and its parts on the grid.
    pub terms: Vec<super::criterion::Terms>,
    /// min w over [t₀, t₁] (the grid's smallest refined by golden sections between its
    /// neighbours) and where.
    pub min_w: f64,
    /// Where the minimum is.
    pub t_min: f64,
}

impl Assessment {
    /// Does the criterion hold on the interval (min w > 0)?
    pub fn holds(&self) -> bool {
        self.min_w > 0.0
    }
}

/// Evaluates `criterion` along `eq` on `samples` + 1 equally spaced times of [t₀, t₁].
pub fn assess(
    eq: &CompanionEquation,
    criterion: &super::criterion::Criterion,
    params: &[f64],
    (t0, t1): (f64, f64),
    samples: usize,
) -> Assessment {
    let samples = samples.max(1);
    let w_at = |t: f64| criterion.w(&eq.coefficients_at(t, params));
    let t: Vec<f64> = (0..=samples)
        .map(|k| t0 + (t1 - t0) * k as f64 / samples as f64)
        .collect();
    let p: Vec<Vec<f64>> = t.iter().map(|&s| eq.coefficients_at(s, params)).collect();
    let terms: Vec<_> = p.iter().map(|q| criterion.terms(q)).collect();
    let k = (0..terms.len())
        .min_by(|&a, &b| terms[a].w.total_cmp(&terms[b].w))
        .unwrap_or(0);
    let (mut a, mut b) = (t[k.saturating_sub(1)], t[(k + 1).min(samples)]);
    // golden sections for the minimum between the neighbours of the grid's smallest
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..80 {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if w_at(c) < w_at(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let tm = 0.5 * (a + b);
    let (min_w, t_min) = if w_at(tm) < terms[k].w {
        (w_at(tm), tm)
    } else {
        (terms[k].w, t[k])
    };
    Assessment {
        t,
        p,
        terms,
        min_w,
        t_min,
    }
}

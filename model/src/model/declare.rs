//! Lowering of what a model declares for running it: run presets, domain guards and
//! structure-specific splittings.

use super::lower::{Ctx, Kind, Lowerer, Symbol, L};
use super::*;
use crate::error::Diagnostic;
use crate::ir::Input;
use crate::parse::ast::*;

/// The settings a `run` preset may have.
const PRESET_KEYS: &[&str] = &["method", "dt", "t_end", "every", "init", "gains"];

impl Lowerer {
    /// `run NAME { key = value; … }`. Values are constants; `method` and `init` are names.
    pub(super) fn preset(
        &mut self,
        name: &Ident,
        values: &[(Ident, Expr)],
        span: &Span,
    ) -> L<Preset> {
        let mut p = Preset {
            name: name.name.clone(),
            method: None,
            dt: None,
            t_end: None,
            every: None,
            init: None,
            gains: None,
            params: Vec::new(),
            span: span.clone(),
        };
        let mut seen: Vec<&str> = Vec::new();
        for (key, e) in values {
            if seen.contains(&key.name.as_str()) {
                return Err(Diagnostic::new(
                    &key.span,
                    format!("`{}` is set twice in preset `{}`", key.name, name.name),
                ));
            }
            seen.push(&key.name);
            let word = |e: &Expr, what: &str| match &e.kind {
                ExprKind::Name(n) => Ok(n.name.clone()),
                _ => Err(Diagnostic::new(&e.span, format!("{what} must be a name"))),
            };
            match key.name.as_str() {
                "method" => {
                    // `feedback_euler` or `feedback-euler` (parsed as a difference of names)
                    let text = &e.span.source.text[e.span.start..e.span.end];
                    if !text
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
                    {
                        return Err(Diagnostic::new(&e.span, "the method must be a name")
                            .help("e.g. `method = feedback_euler;`"));
                    }
                    p.method = Some(text.replace('_', "-"));
                }
                "init" => p.init = Some(word(e, "`init`")?),
                "dt" | "t_end" => {
                    let v = self.constant(e, &format!("`{}`", key.name))?;
                    if !(v.is_finite() && v > 0.0) {
                        return Err(Diagnostic::new(
                            &e.span,
                            format!("`{}` must be positive and finite, got {v}", key.name),
                        ));
                    }
                    if key.name == "dt" {
                        p.dt = Some(v);
                    } else {
                        p.t_end = Some(v);
                    }
                }
                "every" => {
                    let v = self.constant(e, "`every`")?;
                    if !(v >= 1.0 && v.fract() == 0.0 && v < 1e15) {
                        return Err(Diagnostic::new(
                            &e.span,
                            format!("`every` must be a whole number ≥ 1, got {v}"),
                        ));
                    }
                    p.every = Some(v as u64);
                }
                "gains" => {
                    let items: Vec<&Expr> = match &e.kind {
                        ExprKind::List(items) => items.iter().collect(),
                        _ => vec![e],
                    };
                    let mut gains = Vec::new();
                    for g in items {
                        let v = self.constant(g, "a gain")?;
                        if !(v.is_finite() && v >= 0.0) {
                            return Err(Diagnostic::new(
                                &g.span,
                                format!("a gain must be finite and ≥ 0, got {v}"),
                            ));
                        }
                        gains.push(v);
                    }
                    p.gains = Some(gains);
                }
                other
                    if self
                        .symbols
                        .get(other)
                        .is_some_and(|s| s.kind == Kind::Param) =>
                {
                    // a parameter: its slots, as `--param` takes them (the diagonal of `diag`)
                    let items: Vec<&Expr> = match &e.kind {
                        ExprKind::List(items) => items.iter().collect(),
                        _ => vec![e],
                    };
                    let mut values = Vec::new();
                    for v in items {
                        values.push(self.constant(v, &format!("parameter `{other}`"))?);
                    }
                    p.params.push((other.to_string(), values));
                }
                other => {
                    let known: Vec<String> = PRESET_KEYS.iter().map(|k| format!("`{k}`")).collect();
                    return Err(Diagnostic::new(
                        &key.span,
                        format!("unknown setting `{other}` in preset `{}`", name.name),
                    )
                    .help(format!(
                        "a `run` preset may set {} and the model's parameters",
                        known.join(", ")
                    )));
                }
            }
        }
        Ok(p)
    }

    /// Checks what presets refer to once every item is known: points and the gain count.
    pub(super) fn check_presets(
        &self,
        presets: &[Preset],
        points: &[Point],
        params: &[Param],
        gains: usize,
    ) -> L<()> {
        for (i, p) in presets.iter().enumerate() {
            if presets[..i].iter().any(|q| q.name == p.name) {
                return Err(Diagnostic::new(
                    &p.span,
                    format!("a second preset called `{}`", p.name),
                ));
            }
            if let Some(init) = &p.init {
                if !points.iter().any(|q| &q.name == init) {
                    let known: Vec<&str> = points.iter().map(|q| q.name.as_str()).collect();
                    return Err(Diagnostic::new(
                        &p.span,
                        format!(
                            "preset `{}` starts from `{init}`, which is not a point",
                            p.name
                        ),
                    )
                    .help(if known.is_empty() {
                        "declare it with `point NAME { … }`".to_string()
                    } else {
                        format!("the model's points: {}", known.join(", "))
                    }));
                }
            }
            for (name, values) in &p.params {
                let slots = params
                    .iter()
                    .find(|q| &q.name == name)
                    .map_or(0, Param::slots);
                if values.len() != slots {
                    return Err(Diagnostic::new(
                        &p.span,
                        format!(
                            "preset `{}` gives parameter `{name}` {} value(s), it has {slots}",
                            p.name,
                            values.len()
                        ),
                    ));
                }
            }
            if let Some(g) = &p.gains {
                if g.len() != gains {
                    return Err(Diagnostic::new(
                        &p.span,
                        format!(
                            "preset `{}` gives {} gains, the model has {gains}",
                            p.name,
                            g.len()
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// `guard NAME: lhs op rhs;` — scalar sides over the state, the parameters, `let`s and the
    /// step size `dt`.
    pub(super) fn guard(
        &mut self,
        name: &Ident,
        lhs: &Expr,
        op: Comparison,
        rhs: &Expr,
        span: &Span,
    ) -> L<Guard> {
        // `dt` means the step size inside a guard, and only there.
        let shadowed = self.symbols.insert(
            "dt".to_string(),
            Symbol {
                kind: Kind::Let,
                value: Value::scalar(self.g.input(GUARD_STEP)),
                span: name.span.clone(),
            },
        );
        let sides = (|| {
            let l = self.expr(lhs, Ctx::Model)?;
            let l = self.expect_scalar(&l, lhs, "a guard's side")?;
            let r = self.expr(rhs, Ctx::Model)?;
            let r = self.expect_scalar(&r, rhs, "a guard's side")?;
            Ok((l, r))
        })();
        match shadowed {
            Some(s) => self.symbols.insert("dt".to_string(), s),
            None => self.symbols.remove("dt"),
        };
        let (l, r) = sides?;
        let (margin, strict) = match op {
            Comparison::Greater => (self.g.sub(l, r), true),
            Comparison::GreaterEq => (self.g.sub(l, r), false),
            Comparison::Less => (self.g.sub(r, l), true),
            Comparison::LessEq => (self.g.sub(r, l), false),
        };
        let text = &span.source.text[lhs.span.start..rhs.span.end];
        Ok(Guard {
            name: name.name.clone(),
            margin,
            strict,
            condition: text.split_whitespace().collect::<Vec<_>>().join(" "),
            span: span.clone(),
        })
    }

    /// `event NAME: expr = 0 [rising | falling] [stop];` — a scalar over the state, the
    /// parameters, `let`s and the time `t` (unless the model names something `t` itself).
    pub(super) fn event(
        &mut self,
        name: &Ident,
        expr: &Expr,
        zero: &Expr,
        direction: Option<&Ident>,
        terminal: bool,
        span: &Span,
    ) -> L<Event> {
        if !matches!(zero.kind, ExprKind::Num(z) if z == 0.0) {
            return Err(
                Diagnostic::new(&zero.span, "an event's right side must be 0")
                    .help("move it to the left: `event escape: norm(x) - 10 = 0;`"),
            );
        }
        // `t` means the time inside an event, where the model does not name something `t`.
        let time = !self.symbols.contains_key("t");
        if time {
            self.symbols.insert(
                "t".to_string(),
                Symbol {
                    kind: Kind::Let,
                    value: Value::scalar(self.g.input(EVENT_TIME)),
                    span: name.span.clone(),
                },
            );
        }
        let value = (|| {
            let v = self.expr(expr, Ctx::Model)?;
            self.expect_scalar(&v, expr, "an event's expression")
        })();
        if time {
            self.symbols.remove("t");
        }
        let direction = match direction.map(|d| d.name.as_str()) {
            Some("rising") => Direction::Rising,
            Some("falling") => Direction::Falling,
            _ => Direction::Both,
        };
        Ok(Event {
            name: name.name.clone(),
            value: value?,
            direction,
            terminal,
            expr: expr
                .span
                .text()
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" "),
            span: span.clone(),
        })
    }

    /// `splitting rigid_body(R, Omega, I);`: checks the layout the splitting needs and that the
    /// field is the free rigid body's, at random states.
    pub(super) fn splitting(
        &mut self,
        kind: &Ident,
        args: &[Ident],
        span: &Span,
        state: &[StateVar],
        params: &[Param],
        field: &[Id],
    ) -> L<Splitting> {
        if kind.name != "rigid_body" {
            return Err(
                Diagnostic::new(&kind.span, format!("unknown splitting `{}`", kind.name))
                    .help("known splittings: `rigid_body(R, Omega, I)` (the free rigid body)"),
            );
        }
        let [r, omega, inertia] = args else {
            return Err(Diagnostic::new(
                span,
                format!(
                    "`rigid_body` takes 3 arguments (R, Omega, I), {} given",
                    args.len()
                ),
            ));
        };
        let var = |a: &Ident, shape: Shape, offset: usize| -> L<()> {
            match state.iter().find(|s| s.name == a.name) {
                Some(s) if s.shape == shape && s.offset == offset => Ok(()),
                Some(s) => Err(Diagnostic::new(
                    &a.span,
                    format!(
                        "the rigid-body splitting needs `{}` as a {shape} at x[{offset}..{}], it is a {} at x[{}..{}]",
                        a.name,
                        offset + shape.len(),
                        s.shape,
                        s.offset,
                        s.offset + s.shape.len()
                    ),
                )
                .help("declare `state R: mat3, Omega: vec3;` in this order")),
                None => Err(Diagnostic::new(
                    &a.span,
                    format!("`{}` is not a state variable", a.name),
                )),
            }
        };
        var(r, Shape::Matrix(3, 3), 0)?;
        var(omega, Shape::Vector(3), 9)?;
        if state.iter().map(|s| s.shape.len()).sum::<usize>() != 12 {
            return Err(Diagnostic::new(
                span,
                "the rigid-body splitting needs the state (R, Omega) and nothing else",
            ));
        }
        let p = params
            .iter()
            .find(|p| p.name == inertia.name)
            .ok_or_else(|| {
                Diagnostic::new(
                    &inertia.span,
                    format!("`{}` is not a parameter", inertia.name),
                )
                .help("declare the inertia tensor as `param I = diag(3, 2, 1);`")
            })?;
        if !(p.slots() == 3 && (p.diagonal || p.shape == Shape::Vector(3))) {
            return Err(Diagnostic::new(
                &inertia.span,
                format!(
                    "the rigid-body splitting needs the principal moments of inertia: `{}` must be `diag(I1, I2, I3)` or a vec3",
                    inertia.name
                ),
            ));
        }
        let slots = [p.offset as u32, p.offset as u32 + 1, p.offset as u32 + 2];
        // The field must be Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω): compare at random states.
        let defaults: Vec<f64> = params.iter().flat_map(|q| q.defaults.clone()).collect();
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for _ in 0..16 {
            let x: Vec<f64> = (0..12).map(|_| next()).collect();
            let got = self.g.eval_f64(field, &mut |i| match i {
                Input::State(k) => x[k as usize],
                Input::Param(k) => defaults[k as usize],
                _ => f64::NAN,
            });
            let i: Vec<f64> = slots.iter().map(|&k| defaults[k as usize]).collect();
            let w = &x[9..12];
            let rr = |a: usize, b: usize| x[a + 3 * b];
            let mut want = [0.0; 12];
            // (R Ω̂)_{ab} = Σ_c R_{ac} Ω̂_{cb}, Ω̂ = [[0, −w3, w2], [w3, 0, −w1], [−w2, w1, 0]]
            let hat = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]];
            for a in 0..3 {
                for b in 0..3 {
                    want[a + 3 * b] = (0..3).map(|c| rr(a, c) * hat[c][b]).sum();
                }
            }
            let m = [i[0] * w[0], i[1] * w[1], i[2] * w[2]];
            let cross = [
                m[1] * w[2] - m[2] * w[1],
                m[2] * w[0] - m[0] * w[2],
                m[0] * w[1] - m[1] * w[0],
            ];
            for k in 0..3 {
                want[9 + k] = cross[k] / i[k];
            }
            let bad = (0..12).find(|&k| (got[k] - want[k]).abs() > 1e-12 * (1.0 + want[k].abs()));
            if let Some(k) = bad {
                return Err(Diagnostic::new(
                    span,
                    format!(
                        "the field is not the free rigid body's, so the rigid-body splitting does not apply: component {k} is {} where Ṙ = RΩ̂, Ω̇ = 𝕀⁻¹((𝕀Ω) × Ω) gives {}",
                        got[k], want[k]
                    ),
                )
                .help("write `d/dt R = R * hat(Omega); d/dt Omega = inv(I) * cross(I * Omega, Omega);`"));
            }
        }
        Ok(Splitting::RigidBody { inertia: slots })
    }
}

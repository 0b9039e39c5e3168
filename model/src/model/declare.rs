//! Lowering of what a model declares for running it: run presets, domain guards and events.

use super::lower::{Ctx, Kind, Lowerer, Symbol, L};
use super::*;
use crate::error::Diagnostic;
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
}

//! Recursive-descent parser: tokens → [`ModelAst`].
//!
//! Grammar (precedence from loosest to tightest: `+ -`, `* /`, unary `-`, `^` (right
//! associative), postfix indexing). Chains of `+ -` and of `* /` are parsed in a loop into one
//! flat node, so their length is unbounded; nesting (parentheses, calls, lists, unary
//! operators, powers, indexing) is bounded by [`MAX_DEPTH`], so no input exhausts the stack:
//! ```text
//! file      = "model" NAME "{" item* "}"
//! item      = "state" NAME ":" TYPE ("," NAME ":" TYPE)* ";"
//!           | "param" NAME [":" TYPE] "=" expr ";" | "let" NAME "=" expr ";"
//!           | "d" "/" "dt" NAME ["[" expr ("," expr)* "]"] "=" expr ";"
//!           | "for" head ":" item
//!           | ("integral" | "constraint") NAME "=" expr ["gain" [NAME "="] expr] ";"
//!           | "lyapunov" NAME "=" expr ";"       | "hamiltonian" NAME "=" expr ";"
//!           | "structure" ("canonical" "(" NAME "," NAME ")" | "lie_poisson_so3" "(" NAME ")") ";"
//!           | "point" NAME "{" (NAME "=" expr ";")* "}"
//!           | "run" NAME "{" (NAME "=" expr ";")* "}"
//!           | "guard" NAME ":" expr ("<" | "<=" | ">" | ">=") expr ";"
//!           | "event" NAME ":" expr "=" expr ["rising" | "falling"] ["stop"] ";"
//!           | "splitting" NAME "(" NAME ("," NAME)* ")" ";"
//! TYPE      = NAME ["[" expr "]"]                  (a family: `vec3[n]`)
//! head      = clause ("," clause)*;  clause = NAME "in" expr ".." expr | expr CMP expr
//! primary   = NUM | NAME | NAME "(" args ")" | "(" expr ")" | "[" expr ("," expr)* "]"
//!           | ("sum" | "prod") "(" head ":" expr ")" | "[" head ":" expr "]"
//! ```
//! `%` is parsed with `*` and `/`; the family forms are in `family`.

use super::ast::*;
use super::lexer::{Tok, Token};
use crate::error::{Diagnostic, Span};

mod family;

/// The parser state: a token list and a cursor.
pub struct Parser {
    tokens: Vec<Token>,
    pos: usize,
    /// Current nesting of expressions, bounded so no input can exhaust the stack.
    depth: usize,
}

/// Deepest nesting of parentheses, calls, lists and unary operators accepted.
const MAX_DEPTH: usize = 200;

type PResult<T> = Result<T, Diagnostic>;

impl Parser {
    /// A parser over `tokens` (which end with `Tok::Eof`).
    pub fn new(tokens: Vec<Token>) -> Self {
        Parser {
            tokens,
            pos: 0,
            depth: 0,
        }
    }

    fn peek(&self) -> &Token {
        &self.tokens[self.pos.min(self.tokens.len() - 1)]
    }

    fn peek_at(&self, k: usize) -> &Tok {
        &self.tokens[(self.pos + k).min(self.tokens.len() - 1)].tok
    }

    fn bump(&mut self) -> Token {
        let t = self.peek().clone();
        if self.pos < self.tokens.len() - 1 {
            self.pos += 1;
        }
        t
    }

    fn prev_span(&self) -> Span {
        self.tokens[self.pos.saturating_sub(1)].span.clone()
    }

    fn is_punct(&self, c: char) -> bool {
        self.peek().tok == Tok::Punct(c)
    }

    fn is_keyword(&self, k: &str) -> bool {
        matches!(&self.peek().tok, Tok::Ident(s) if s == k)
    }

    fn unexpected(&self, expected: &str) -> Diagnostic {
        let t = self.peek();
        Diagnostic::new(
            &t.span,
            format!("expected {expected}, found {}", t.tok.describe()),
        )
    }

    fn expect_punct(&mut self, c: char) -> PResult<Span> {
        if self.is_punct(c) {
            Ok(self.bump().span)
        } else {
            let mut d = self.unexpected(&format!("`{c}`"));
            if c == ';' {
                // Point at the end of the previous token: that is where the `;` is missing.
                let prev = self.prev_span();
                d = Diagnostic::new(
                    &Span {
                        start: prev.end,
                        end: prev.end + 1,
                        ..prev
                    },
                    d.message,
                )
                .help("every item ends with `;`");
            }
            Err(d)
        }
    }

    fn expect_keyword(&mut self, k: &str) -> PResult<Span> {
        if self.is_keyword(k) {
            Ok(self.bump().span)
        } else {
            Err(self.unexpected(&format!("`{k}`")))
        }
    }

    fn ident(&mut self, what: &str) -> PResult<Ident> {
        match &self.peek().tok {
            Tok::Ident(name) => {
                let name = name.clone();
                let span = self.bump().span;
                Ok(Ident { name, span })
            }
            _ => Err(self.unexpected(what)),
        }
    }

    /// Parses a whole model file.
    pub fn model(&mut self) -> PResult<ModelAst> {
        self.expect_keyword("model")
            .map_err(|d| d.help("a model file starts with `model Name { … }`"))?;
        let name = self.ident("the model's name")?;
        self.expect_punct('{')?;
        let mut items = Vec::new();
        while !self.is_punct('}') {
            if self.peek().tok == Tok::Eof {
                return Err(self
                    .unexpected("`}` closing the model")
                    .help("the model body is not closed"));
            }
            items.push(self.item()?);
        }
        self.bump();
        if self.peek().tok != Tok::Eof {
            return Err(self
                .unexpected("end of file")
                .help("a file holds exactly one model"));
        }
        Ok(ModelAst { name, items })
    }

    fn item(&mut self) -> PResult<Spanned> {
        let start = self.peek().span.clone();
        let keyword = match &self.peek().tok {
            Tok::Ident(k) => k.clone(),
            _ => return Err(self.expected_item()),
        };
        let item = match keyword.as_str() {
            "state" => {
                self.bump();
                let mut decls = Vec::new();
                loop {
                    let name = self.ident("a state variable's name")?;
                    self.expect_punct(':')
                        .map_err(|d| d.help("declare a shape: `state x: vec3;`"))?;
                    let ty = self.type_name()?;
                    decls.push((name, ty));
                    if self.is_punct(',') {
                        self.bump();
                    } else {
                        break;
                    }
                }
                self.expect_punct(';')?;
                Item::State(decls)
            }
            "param" => {
                self.bump();
                let name = self.ident("a name")?;
                let ty = if self.is_punct(':') {
                    self.bump();
                    Some(self.type_name()?)
                } else {
                    None
                };
                self.expect_punct('=')?;
                let value = self.expr()?;
                self.expect_punct(';')?;
                Item::Param(name, ty, value)
            }
            "for" => return self.for_item(),
            "let" | "lyapunov" | "hamiltonian" => {
                self.bump();
                let name = self.ident("a name")?;
                self.expect_punct('=')?;
                let value = self.expr()?;
                self.expect_punct(';')?;
                match keyword.as_str() {
                    "let" => Item::Let(name, value),
                    "lyapunov" => Item::Lyapunov(name, value),
                    _ => Item::Hamiltonian(name, value),
                }
            }
            "d" if self.peek_at(1) == &Tok::Punct('/') => {
                self.bump();
                self.bump();
                self.expect_keyword("dt")
                    .map_err(|d| d.help("write a derivative as `d/dt x = …;`"))?;
                let name = self.ident("a state variable")?;
                let indices = if self.is_punct('[') {
                    Some(self.subscripts()?)
                } else {
                    None
                };
                self.expect_punct('=')?;
                let value = self.expr()?;
                self.expect_punct(';')?;
                match indices {
                    Some(indices) => Item::ElementDerivative(name, indices, value),
                    None => Item::Derivative(name, value),
                }
            }
            "integral" | "constraint" => {
                self.bump();
                let kind = if keyword == "integral" {
                    InvariantDeclKind::Integral
                } else {
                    InvariantDeclKind::Constraint
                };
                let name = self.ident("a name")?;
                self.expect_punct('=')?;
                let value = self.expr()?;
                let gain = if self.is_keyword("gain") {
                    self.bump();
                    let named = matches!(self.peek().tok, Tok::Ident(_))
                        && self.peek_at(1) == &Tok::Punct('=');
                    let name = if named {
                        let n = self.ident("a gain name")?;
                        self.bump();
                        Some(n)
                    } else {
                        None
                    };
                    Some(GainDecl {
                        name,
                        value: self.expr()?,
                    })
                } else {
                    None
                };
                self.expect_punct(';')?;
                Item::Invariant {
                    kind,
                    name,
                    value,
                    gain,
                }
            }
            "structure" => {
                self.bump();
                let kind = self.ident("`canonical` or `lie_poisson_so3`")?;
                self.expect_punct('(')?;
                let s = match kind.name.as_str() {
                    "canonical" => {
                        let q = self.ident("the position variable")?;
                        self.expect_punct(',')?;
                        let p = self.ident("the momentum variable")?;
                        StructureDecl::Canonical(q, p)
                    }
                    "lie_poisson_so3" => {
                        StructureDecl::LiePoissonSo3(self.ident("the momentum variable")?)
                    }
                    other => {
                        return Err(Diagnostic::new(
                            &kind.span,
                            format!("unknown structure `{other}`"),
                        )
                        .help("known structures: `canonical(q, p)`, `lie_poisson_so3(P)`"))
                    }
                };
                self.expect_punct(')')?;
                self.expect_punct(';')?;
                Item::Structure(s, kind.span)
            }
            "point" | "run" => {
                self.bump();
                let name = self.ident(if keyword == "point" {
                    "the point's name"
                } else {
                    "the preset's name"
                })?;
                self.expect_punct('{')?;
                let mut values = Vec::new();
                while !self.is_punct('}') {
                    let var = self.ident(if keyword == "point" {
                        "a state variable or `}`"
                    } else {
                        "a setting (`method`, `dt`, `t_end`, `gains`, `every`, `init`) or `}`"
                    })?;
                    self.expect_punct('=')?;
                    let value = self.expr()?;
                    self.expect_punct(';')?;
                    values.push((var, value));
                }
                self.bump();
                if keyword == "point" {
                    Item::Point(name, values)
                } else {
                    Item::Run(name, values)
                }
            }
            "guard" => {
                self.bump();
                let name = self.ident("the guard's name")?;
                self.expect_punct(':')
                    .map_err(|d| d.help("write a guard as `guard collision: norm(x) > 1e-6;`"))?;
                let lhs = self.expr()?;
                let op = if self.is_punct('<') {
                    Comparison::Less
                } else if self.is_punct('>') {
                    Comparison::Greater
                } else {
                    return Err(self
                        .unexpected("a comparison `<`, `<=`, `>` or `>=`")
                        .help("a guard states a condition every state must satisfy: `guard collision: norm(x) > 1e-6;`"));
                };
                self.bump();
                let op = if self.is_punct('=') {
                    self.bump();
                    match op {
                        Comparison::Less => Comparison::LessEq,
                        _ => Comparison::GreaterEq,
                    }
                } else {
                    op
                };
                let rhs = self.expr()?;
                self.expect_punct(';')?;
                Item::Guard { name, lhs, op, rhs }
            }
            "event" => {
                self.bump();
                const HELP: &str =
                    "write an event as `event pericentre: dot(x, v) = 0 rising;` (then optionally `rising` or `falling`, and `stop`)";
                let name = self.ident("the event's name")?;
                self.expect_punct(':').map_err(|d| d.help(HELP))?;
                let expr = self.expr()?;
                self.expect_punct('=').map_err(|d| d.help(HELP))?;
                let zero = self.expr()?;
                let mut direction = None;
                let mut stop = None;
                while let Tok::Ident(word) = &self.peek().tok {
                    match word.as_str() {
                        "rising" | "falling" if direction.is_none() && stop.is_none() => {
                            direction = Some(self.ident("`rising` or `falling`")?);
                        }
                        "stop" if stop.is_none() => stop = Some(self.ident("`stop`")?),
                        _ => {
                            return Err(self
                                .unexpected("`rising`, `falling`, `stop` or `;`")
                                .help(HELP))
                        }
                    }
                }
                self.expect_punct(';').map_err(|d| d.help(HELP))?;
                Item::Event {
                    name,
                    expr,
                    zero,
                    direction,
                    stop,
                }
            }
            "splitting" => {
                self.bump();
                let kind = self.ident("a splitting kind (e.g. `rigid_body`)")?;
                self.expect_punct('(')?;
                let mut args = vec![self.ident("an argument")?];
                while self.is_punct(',') {
                    self.bump();
                    args.push(self.ident("an argument")?);
                }
                self.expect_punct(')')?;
                self.expect_punct(';')?;
                Item::Splitting(kind, args)
            }
            _ => return Err(self.expected_item()),
        };
        Ok(Spanned {
            item,
            span: start.to(&self.prev_span()),
        })
    }

    fn expected_item(&self) -> Diagnostic {
        let list: Vec<String> = crate::vocabulary::KEYWORDS
            .iter()
            .filter(|k| k.starts_item)
            .map(|k| format!("`{}`", k.name))
            .collect();
        self.unexpected(&format!("one of {}", list.join(", ")))
    }

    /// Runs `parse` one nesting level deeper, or fails if the input nests too deeply.
    fn nested<T>(&mut self, parse: impl FnOnce(&mut Self) -> PResult<T>) -> PResult<T> {
        if self.depth >= MAX_DEPTH {
            return Err(Diagnostic::new(
                &self.peek().span,
                format!("expression nested more than {MAX_DEPTH} levels deep"),
            )
            .help("split it with `let` bindings"));
        }
        self.depth += 1;
        let result = parse(self);
        self.depth -= 1;
        result
    }

    /// expr = term (("+" | "-") term)*
    pub fn expr(&mut self) -> PResult<Expr> {
        self.nested(Self::sum)
    }

    fn sum(&mut self) -> PResult<Expr> {
        self.chain(Self::term, |c| match c {
            '+' => Some(BinOp::Add),
            '-' => Some(BinOp::Sub),
            _ => None,
        })
    }

    /// term = unary (("*" | "/" | "%") unary)*
    fn term(&mut self) -> PResult<Expr> {
        self.chain(Self::unary, |c| match c {
            '*' => Some(BinOp::Mul),
            '/' => Some(BinOp::Div),
            '%' => Some(BinOp::Rem),
            _ => None,
        })
    }

    /// `operand (op operand)*`, parsed in a loop into one flat [`ExprKind::Chain`].
    fn chain(
        &mut self,
        operand: fn(&mut Self) -> PResult<Expr>,
        op_of: fn(char) -> Option<BinOp>,
    ) -> PResult<Expr> {
        let first = operand(self)?;
        let mut rest = Vec::new();
        while let Tok::Punct(c) = self.peek().tok {
            let Some(op) = op_of(c) else { break };
            self.bump();
            rest.push((op, operand(self)?));
        }
        if rest.is_empty() {
            return Ok(first);
        }
        let span = first.span.to(&rest[rest.len() - 1].1.span);
        Ok(Expr {
            kind: ExprKind::Chain(Box::new(first), rest),
            span,
        })
    }

    fn unary(&mut self) -> PResult<Expr> {
        self.nested(Self::unary_inner)
    }

    fn unary_inner(&mut self) -> PResult<Expr> {
        if self.is_punct('-') {
            let start = self.bump().span;
            let inner = self.unary()?;
            let span = start.to(&inner.span);
            return Ok(Expr {
                kind: ExprKind::Neg(Box::new(inner)),
                span,
            });
        }
        if self.is_punct('+') {
            self.bump();
            return self.unary();
        }
        self.power()
    }

    fn power(&mut self) -> PResult<Expr> {
        let base = self.postfix()?;
        if self.is_punct('^') {
            self.bump();
            let exponent = self.unary()?; // right associative: a^b^c = a^(b^c); a^-1 allowed
            return Ok(binary(BinOp::Pow, base, exponent));
        }
        Ok(base)
    }

    fn postfix(&mut self) -> PResult<Expr> {
        let mut e = self.primary()?;
        let mut levels = 0;
        while self.is_punct('[') {
            // `x[0][0]…` nests like parentheses: bounded the same way.
            levels += 1;
            if self.depth + levels > MAX_DEPTH {
                return Err(Diagnostic::new(
                    &self.peek().span,
                    format!("expression nested more than {MAX_DEPTH} levels deep"),
                )
                .help("split it with `let` bindings"));
            }
            let indices = self.subscripts()?;
            let span = e.span.to(&self.prev_span());
            e = Expr {
                kind: ExprKind::Index(Box::new(e), indices),
                span,
            };
        }
        Ok(e)
    }

    fn primary(&mut self) -> PResult<Expr> {
        let t = self.peek().clone();
        match t.tok {
            Tok::Num(x) => {
                self.bump();
                Ok(Expr {
                    kind: ExprKind::Num(x),
                    span: t.span,
                })
            }
            Tok::Ident(name) if self.starts_family() => {
                let op = if name == "sum" {
                    FamilyOp::Sum
                } else {
                    FamilyOp::Prod
                };
                self.family(op)
            }
            Tok::Punct('[') if self.starts_comprehension() => self.comprehension(),
            Tok::Ident(name) => {
                self.bump();
                let id = Ident {
                    name,
                    span: t.span.clone(),
                };
                if self.is_punct('(') {
                    self.bump();
                    let mut args = Vec::new();
                    if !self.is_punct(')') {
                        args.push(self.expr()?);
                        while self.is_punct(',') {
                            self.bump();
                            args.push(self.expr()?);
                        }
                    }
                    let end = self.expect_punct(')')?;
                    Ok(Expr {
                        kind: ExprKind::Call(id, args),
                        span: t.span.to(&end),
                    })
                } else {
                    Ok(Expr {
                        kind: ExprKind::Name(id),
                        span: t.span,
                    })
                }
            }
            Tok::Punct('(') => {
                self.bump();
                let inner = self.expr()?;
                let end = self.expect_punct(')')?;
                Ok(Expr {
                    kind: inner.kind,
                    span: t.span.to(&end),
                })
            }
            Tok::Punct('[') => {
                self.bump();
                let mut elems = vec![self.expr()?];
                while self.is_punct(',') {
                    self.bump();
                    elems.push(self.expr()?);
                }
                let end = self.expect_punct(']')?;
                Ok(Expr {
                    kind: ExprKind::List(elems),
                    span: t.span.to(&end),
                })
            }
            _ => Err(self.unexpected("an expression")),
        }
    }
}

fn binary(op: BinOp, lhs: Expr, rhs: Expr) -> Expr {
    let span = lhs.span.to(&rhs.span);
    Expr {
        kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
        span,
    }
}

//! The family forms: `sum(…: …)`, `prod(…: …)`, `[i in 0..n: …]`, `for …: item`, shapes with a
//! count (`vec3[n]`) and subscripts.

use super::{PResult, Parser};
use crate::error::Diagnostic;
use crate::parse::ast::*;
use crate::parse::lexer::Tok;

impl Parser {
    /// `NAME ["[" expr "]"]`: a shape, or a family of `count` members of that shape.
    pub(super) fn type_name(&mut self) -> PResult<TypeName> {
        let ty = self.ident("a shape (`scalar`, `vec2`, `vec3`, `mat2`, `mat3`, …)")?;
        let count = if self.is_punct('[') {
            self.bump();
            let count = self.expr()?;
            self.expect_punct(']')
                .map_err(|d| d.help("a family's size is one number: `vec3[n]`"))?;
            Some(count)
        } else {
            None
        };
        Ok(TypeName {
            name: ty.name,
            span: ty.span.to(&self.prev_span()),
            count,
        })
    }

    /// `"[" expr ("," expr)* "]"`.
    pub(super) fn subscripts(&mut self) -> PResult<Vec<Expr>> {
        self.expect_punct('[')?;
        let mut indices = vec![self.expr()?];
        while self.is_punct(',') {
            self.bump();
            indices.push(self.expr()?);
        }
        self.expect_punct(']')?;
        Ok(indices)
    }

    /// `sum(` or `prod(`.
    pub(super) fn starts_family(&self) -> bool {
        matches!(&self.peek().tok, Tok::Ident(s) if s == "sum" || s == "prod")
            && self.peek_at(1) == &Tok::Punct('(')
    }

    /// `[ NAME in`.
    pub(super) fn starts_comprehension(&self) -> bool {
        self.is_punct('[')
            && matches!(self.peek_at(1), Tok::Ident(_))
            && matches!(self.peek_at(2), Tok::Ident(s) if s == "in")
    }

    /// `sum(head: body)` or `prod(head: body)`.
    pub(super) fn family(&mut self, op: FamilyOp) -> PResult<Expr> {
        let start = self.bump().span;
        self.expect_punct('(')?;
        let head = self.head()?;
        let body = self.expr()?;
        let end = self.expect_punct(')')?;
        Ok(Expr {
            kind: ExprKind::Family(op, head, Box::new(body)),
            span: start.to(&end),
        })
    }

    /// `[head: body]`.
    pub(super) fn comprehension(&mut self) -> PResult<Expr> {
        let start = self.bump().span;
        let head = self.head()?;
        let body = self.expr()?;
        let end = self.expect_punct(']')?;
        Ok(Expr {
            kind: ExprKind::Comprehension(head, Box::new(body)),
            span: start.to(&end),
        })
    }

    /// `for head: item`: the item once per index tuple.
    pub(super) fn for_item(&mut self) -> PResult<Spanned> {
        let start = self.bump().span;
        let head = self.head()?;
        let inner = self.item()?;
        let span = start.to(&inner.span);
        Ok(Spanned {
            item: Item::For(head, Box::new(inner)),
            span,
        })
    }

    /// `clause ("," clause)* ":"`; a clause is a range `NAME in a..b` or a condition.
    fn head(&mut self) -> PResult<FamilyHead> {
        let first = self.peek().span.clone();
        let mut clauses = Vec::new();
        loop {
            let is_range = matches!(self.peek().tok, Tok::Ident(_))
                && matches!(self.peek_at(1), Tok::Ident(s) if s == "in");
            if is_range {
                let var = self.ident("an index")?;
                self.bump(); // `in`
                let start = self.expr()?;
                if self.peek().tok != Tok::DotDot {
                    return Err(self.unexpected("`..`").help(
                        "an index runs over a range `start..end` (end excluded): `i in 0..n`",
                    ));
                }
                self.bump();
                let end = self.expr()?;
                clauses.push(Clause::Range { var, start, end });
            } else if clauses.is_empty() {
                return Err(self
                    .unexpected("an index range `i in 0..n`")
                    .help("a family starts with its indices: `sum(i in 0..n: x[i])`"));
            } else {
                let lhs = self.expr()?;
                let op = self.index_comparison()?;
                let rhs = self.expr()?;
                clauses.push(Clause::Cond { lhs, op, rhs });
            }
            if self.is_punct(',') {
                self.bump();
            } else {
                break;
            }
        }
        let span = first.to(&self.prev_span());
        self.expect_punct(':').map_err(|d| {
            d.help("the indices end with `:` before the term: `sum(i in 0..n, j in i+1..n: …)`")
        })?;
        Ok(FamilyHead { clauses, span })
    }

    /// `==`, `!=`, `<`, `<=`, `>` or `>=`.
    fn index_comparison(&mut self) -> PResult<IndexComparison> {
        let op = match (self.peek().tok.clone(), self.peek_at(1).clone()) {
            (Tok::Punct('='), Tok::Punct('=')) => Some((IndexComparison::Eq, 2)),
            (Tok::Punct('!'), Tok::Punct('=')) => Some((IndexComparison::Ne, 2)),
            (Tok::Punct('<'), Tok::Punct('=')) => Some((IndexComparison::LessEq, 2)),
            (Tok::Punct('>'), Tok::Punct('=')) => Some((IndexComparison::GreaterEq, 2)),
            (Tok::Punct('<'), _) => Some((IndexComparison::Less, 1)),
            (Tok::Punct('>'), _) => Some((IndexComparison::Greater, 1)),
            _ => None,
        };
        let Some((op, tokens)) = op else {
            return Err(Diagnostic::new(
                &self.peek().span,
                format!(
                    "expected a comparison (`==`, `!=`, `<`, `<=`, `>`, `>=`), found {}",
                    self.peek().tok.describe()
                ),
            )
            .help("after the ranges, a family takes conditions on its indices: `i != j`"));
        };
        for _ in 0..tokens {
            self.bump();
        }
        Ok(op)
    }
}

//! Splits a model file into tokens; `//` and `/* */` comments are skipped.

use crate::error::{Diagnostic, Source, Span};
use std::sync::Arc;

/// A token's kind.
#[derive(Clone, Debug, PartialEq)]
pub enum Tok {
    /// A name or keyword.
    Ident(String),
    /// A numeric literal.
    Num(f64),
    /// Punctuation: one of `{ } ( ) [ ] , ; : = + - * / ^ < > % !`.
    Punct(char),
    /// `..`, the range operator of a family (`i in 0..n`).
    DotDot,
    /// End of file.
    Eof,
}

impl Tok {
    /// How the token is shown in "expected …, found …" messages.
    pub fn describe(&self) -> String {
        match self {
            Tok::Ident(s) => format!("`{s}`"),
            Tok::Num(x) => format!("number `{x}`"),
            Tok::Punct(c) => format!("`{c}`"),
            Tok::DotDot => "`..`".to_string(),
            Tok::Eof => "end of file".to_string(),
        }
    }
}

/// A token and where it is.
#[derive(Clone, Debug)]
pub struct Token {
    /// The token.
    pub tok: Tok,
    /// Its extent.
    pub span: Span,
}

/// Tokenises `source`, or reports the first character that starts no token.
pub fn lex(source: &Arc<Source>) -> Result<Vec<Token>, Diagnostic> {
    let text = source.text.as_bytes();
    let span = |start: usize, end: usize| Span {
        source: source.clone(),
        start,
        end,
    };
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        if c.is_ascii_whitespace() {
            i += 1;
        } else if text[i..].starts_with(b"//") {
            while i < text.len() && text[i] != b'\n' {
                i += 1;
            }
        } else if text[i..].starts_with(b"/*") {
            let start = i;
            match source.text[i + 2..].find("*/") {
                Some(k) => i += k + 4,
                None => {
                    return Err(Diagnostic::new(
                        &span(start, start + 2),
                        "unterminated block comment",
                    )
                    .help("close it with `*/`"))
                }
            }
        } else if c.is_ascii_alphabetic() || c == b'_' {
            let start = i;
            while i < text.len() && (text[i].is_ascii_alphanumeric() || text[i] == b'_') {
                i += 1;
            }
            tokens.push(Token {
                tok: Tok::Ident(source.text[start..i].to_string()),
                span: span(start, i),
            });
        } else if c.is_ascii_digit()
            || (c == b'.' && text.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            let start = i;
            // `0..n` is a number and a range: a `.` followed by `.` ends the number.
            while i < text.len()
                && (text[i].is_ascii_digit() || (text[i] == b'.' && text.get(i + 1) != Some(&b'.')))
            {
                i += 1;
            }
            if i < text.len() && (text[i] == b'e' || text[i] == b'E') {
                let mut j = i + 1;
                if j < text.len() && (text[j] == b'+' || text[j] == b'-') {
                    j += 1;
                }
                if j < text.len() && text[j].is_ascii_digit() {
                    i = j;
                    while i < text.len() && text[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let literal = &source.text[start..i];
            let value: f64 = literal.parse().map_err(|_| {
                Diagnostic::new(&span(start, i), format!("malformed number `{literal}`"))
            })?;
            tokens.push(Token {
                tok: Tok::Num(value),
                span: span(start, i),
            });
        } else if text[i..].starts_with(b"..") {
            tokens.push(Token {
                tok: Tok::DotDot,
                span: span(i, i + 2),
            });
            i += 2;
        } else if b"{}()[],;:=+-*/^<>%!".contains(&c) {
            tokens.push(Token {
                tok: Tok::Punct(c as char),
                span: span(i, i + 1),
            });
            i += 1;
        } else {
            let ch = source.text[i..].chars().next().unwrap_or('?');
            return Err(Diagnostic::new(
                &span(i, i + ch.len_utf8()),
                format!("unexpected character `{ch}`"),
            )
            .help("model files use ASCII names, numbers and the operators + - * / ^ %"));
        }
    }
    tokens.push(Token {
        tok: Tok::Eof,
        span: span(text.len(), text.len()),
    });
    Ok(tokens)
}

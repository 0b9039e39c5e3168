//! Errors with spans: every message that comes from a user's model names file:line:col and
//! shows the offending line with a caret, in rustc's style.

use std::fmt;
use std::sync::Arc;

/// A model source file, shared by every span that points into it.
#[derive(Debug)]
pub struct Source {
    /// The path as given by the user (used in messages).
    pub path: String,
    /// The whole text.
    pub text: String,
}

/// A byte range in a [`Source`].
#[derive(Clone, Debug)]
pub struct Span {
    /// The file the range lies in.
    pub source: Arc<Source>,
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// 1-based line and column (in characters) of the start.
    pub fn line_col(&self) -> (usize, usize) {
        let before = &self.source.text[..self.start.min(self.source.text.len())];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let col = before[line_start..].chars().count() + 1;
        (line, col)
    }

    /// The text of the line the span starts on.
    pub fn line_text(&self) -> &str {
        let text = &self.source.text;
        let start = self.start.min(text.len());
        let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        &text[line_start..line_end]
    }

    /// `path:line:col`.
    pub fn location(&self) -> String {
        let (line, col) = self.line_col();
        format!("{}:{line}:{col}", self.source.path)
    }

    /// The smallest span covering both.
    pub fn to(&self, other: &Span) -> Span {
        Span {
            source: self.source.clone(),
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }

    /// The covered source text.
    pub fn text(&self) -> &str {
        &self.source.text
            [self.start.min(self.source.text.len())..self.end.min(self.source.text.len())]
    }
}

/// What kind of problem a [`Diagnostic`] reports, for code that reacts to it (a message's text
/// is for people and may change).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum DiagnosticKind {
    /// The text does not parse (lexer or parser).
    Syntax,
    /// A name that is not declared, or a function that does not exist.
    UnknownName,
    /// A declared name used where it may not be (a gain outside `lyapunov`, a state variable
    /// in a parameter's default).
    NotAllowedHere,
    /// A keyword or built-in function used as a name.
    Reserved,
    /// A constant that is not finite (`1/0`, `log(0)`, `1e400`).
    NotFinite,
    /// A parameter m of an elliptic function that depends on the state (derivatives in m are
    /// not implemented).
    StateDependentParameter,
    /// A check of the model's claims failed: an invariant the field does not conserve, an
    /// explicit Lyapunov function that is not one.
    FailedCheck,
    /// A use of a definition that failed: already reported at the definition, never shown.
    AlreadyReported,
    /// Any other problem in the model (shapes, arity, duplicates, structure, …).
    Invalid,
}

/// One problem found in a model, with where it is and what to do about it.
#[derive(Clone, Debug)]
pub struct Diagnostic {
    /// What kind of problem it is.
    pub kind: DiagnosticKind,
    /// What is wrong, lowercase, no trailing period.
    pub message: String,
    /// Where; `None` for problems that concern no particular line.
    pub span: Option<Span>,
    /// What to do about it.
    pub help: Option<String>,
}

impl Diagnostic {
    /// An error at `span`, of kind [`DiagnosticKind::Invalid`] (see [`Diagnostic::kind`]).
    pub fn new(span: &Span, message: impl Into<String>) -> Self {
        Diagnostic {
            kind: DiagnosticKind::Invalid,
            message: message.into(),
            span: Some(span.clone()),
            help: None,
        }
    }

    /// The use at `span` of a definition whose error was reported already.
    pub fn already_reported(span: &Span) -> Self {
        Diagnostic::new(span, "(already reported)").kind(DiagnosticKind::AlreadyReported)
    }

    /// Sets the kind.
    pub fn kind(mut self, kind: DiagnosticKind) -> Self {
        self.kind = kind;
        self
    }

    /// Adds a help line.
    pub fn help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "error: {}", self.message)?;
        if let Some(span) = &self.span {
            let (line, col) = span.line_col();
            let gutter = line.to_string().len();
            let width = span
                .text()
                .chars()
                .take_while(|&c| c != '\n')
                .count()
                .max(1);
            // Long lines are shown as a window around the caret.
            let chars: Vec<char> = span.line_text().chars().collect();
            let start = (col - 1).saturating_sub(40);
            let end = (col - 1 + width.min(40) + 40).min(chars.len());
            let (prefix, suffix) = (
                if start > 0 { "…" } else { "" },
                if end < chars.len() { "…" } else { "" },
            );
            let text: String = chars[start..end].iter().collect();
            let pad = col - 1 - start + prefix.chars().count();
            writeln!(f, "{:gutter$}--> {}", "", span.location())?;
            writeln!(f, "{:gutter$} |", "")?;
            writeln!(f, "{line} | {prefix}{text}{suffix}")?;
            writeln!(
                f,
                "{:gutter$} | {:pad$}{}",
                "",
                "",
                "^".repeat(width.min(end - (col - 1)).max(1))
            )?;
        }
        if let Some(help) = &self.help {
            writeln!(f, "  = help: {help}")?;
        }
        Ok(())
    }
}

/// Everything that can go wrong while generating code for a model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The model file could not be read.
    #[error("cannot read `{path}`: {source}")]
    Io {
        /// The path.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// One or more problems in the model (syntax, names, shapes, conservation).
    #[error("{}", render(.0))]
    Model(Vec<Diagnostic>),
    /// Something the generator cannot express (a bug if it ever shows).
    #[error("internal error: {0}")]
    Internal(String),
}

fn render(diagnostics: &[Diagnostic]) -> String {
    let mut out = String::new();
    for d in diagnostics {
        out.push_str(&d.to_string());
    }
    let n = diagnostics.len();
    if n > 1 {
        out.push_str(&format!("error: aborting due to {n} errors\n"));
    }
    out.trim_end().to_string()
}

impl From<Diagnostic> for Error {
    fn from(d: Diagnostic) -> Self {
        Error::Model(vec![d])
    }
}

impl Error {
    /// The diagnostics, if this error comes from the model's text.
    pub fn diagnostics(&self) -> &[Diagnostic] {
        match self {
            Error::Model(d) => d,
            _ => &[],
        }
    }
}

/// Result alias for the generator.
pub type Result<T, E = Error> = std::result::Result<T, E>;

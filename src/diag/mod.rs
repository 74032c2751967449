//! The bottom of the pipeline: source spans, the one neutral diagnostic type (produced by the
//! parser, the checker and the lattice lints; rendered by the CLI as human, plain or JSON and
//! converted by editors), the stable codes, the one "did you mean" rule, and the one way text
//! from outside is made safe to print ([`terminal_safe`]).

pub mod codes;
mod escape;
pub mod suggest;

pub use escape::{TerminalSafe, terminal_safe};

use serde::{Deserialize, Serialize};

/// A byte range in one source file. `file` indexes the compiled domain's files
/// (`ir::Domain::files`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub struct Span {
    pub file: u32,
    pub start: u32,
    pub end: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    Error,
    Warning,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Label {
    pub span: Span,
    pub message: String,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnostic {
    /// Stable code: `R0001`–`R0099` front end (syntax, names, types), `R0100`–`R0199` lattice
    /// lints.
    pub code: &'static str,
    pub severity: Severity,
    /// One line, lowercase, no final period, user input in backticks.
    pub message: String,
    /// The primary span (what is underlined), when the problem has a place in source.
    pub span: Option<Span>,
    /// The primary label text (may be empty).
    pub label: String,
    /// Secondary spans (e.g. the other declaration of a duplicate).
    pub related: Vec<Label>,
    pub help: Option<String>,
}

impl Diagnostic {
    /// An error at `span`; add a label, help and related spans with the builder methods.
    pub fn error(code: &'static str, span: Span, message: impl Into<String>) -> Self {
        Self::new(code, Severity::Error, Some(span), message)
    }

    /// A warning at `span`.
    pub fn warning(code: &'static str, span: Span, message: impl Into<String>) -> Self {
        Self::new(code, Severity::Warning, Some(span), message)
    }

    pub fn new(code: &'static str, severity: Severity, span: Option<Span>, message: impl Into<String>) -> Self {
        Diagnostic {
            code,
            severity,
            message: message.into(),
            span,
            label: String::new(),
            related: Vec::new(),
            help: None,
        }
    }

    #[must_use]
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    #[must_use]
    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    #[must_use]
    pub fn with_related(mut self, span: Span, message: impl Into<String>) -> Self {
        self.related.push(Label { span, message: message.into() });
        self
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// The deterministic report order: file, then position, then code.
    pub fn sort_key(&self) -> (u32, u32, u32, &'static str) {
        match self.span {
            Some(s) => (s.file, s.start, s.end, self.code),
            None => (u32::MAX, 0, 0, self.code),
        }
    }
}

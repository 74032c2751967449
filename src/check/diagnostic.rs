//! The one neutral diagnostic type: produced by the checker and the lattice lints, rendered by
//! the CLI (human via miette, plain, JSON) and converted by editors.

use serde::Serialize;

use crate::ir::Span;

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

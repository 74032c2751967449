//! `revelio fmt`: one canonical layout for `.rev` files, every comment kept where it was.
//!
//! The formatter reads the file twice over: pest's tree says where items, blocks and statements
//! are ([`layout`] turns it into a line-break plan), and the lossless tokens of
//! [`crate::syntax::lexer`] carry everything the tree drops — comments and blank lines — which
//! [`printer`] writes back around the planned breaks. The significant tokens come out in the
//! same order with the same text (only trailing commas of one-line lists are dropped and those
//! of broken lists added), so the file means what it meant before.
//!
//! The style (docs/formatting.md): two-space indentation; one statement per line in item
//! bodies; settings blocks (`region`, `preset`, `camera`) on one line when they fit in
//! [`MAX_WIDTH`] columns, else filled line by line with two spaces between settings; `enum`
//! variants on one line when they fit, else one per line; one space around operators and after
//! commas and colons, none inside parentheses or around `.`, `..` and `::`; at most one blank
//! line kept where the author left blank lines between items or statements, none after `{` or
//! before `}`. Lines are not broken inside a statement: a long `when` or `elements` line stays
//! long. A file with syntax errors is not formatted (its structure is not known).

pub mod diff;
mod layout;
mod printer;

use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::syntax;

/// Settings blocks and `enum` lists are kept on one line up to this many columns.
pub const MAX_WIDTH: usize = 100;

/// Format `text`, or return the syntax errors that keep it from being formatted.
pub fn format(text: &str) -> Result<String, Vec<Diagnostic>> {
    let parsed = syntax::parse(0, text);
    let errors: Vec<Diagnostic> = parsed
        .diagnostics
        .into_iter()
        .filter(|d| d.is_error() && (d.code == codes::SYNTAX || d.code == codes::TOO_DEEP))
        .collect();
    if !errors.is_empty() {
        return Err(errors);
    }
    let tokens = syntax::lexer::lex(text);
    match layout::plan(text, &tokens) {
        Some(plan) => Ok(printer::print(text, &tokens, &plan)),
        // The parser accepted the file, so this is a bug in the formatter, not the input.
        None => Err(vec![Diagnostic::new(
            codes::SYNTAX,
            crate::diag::Severity::Error,
            None,
            "cannot format this file: its layout could not be planned (a bug in `revelio fmt`)",
        )]),
    }
}

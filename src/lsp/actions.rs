//! Quick fixes: the checker's "did you mean `X`?" as an edit, and `allow CODE` for a lattice
//! lint, written above the domain's `rules` block with a `///` line for the reason (an `allow`
//! without one is itself a warning, R0065).

use std::collections::HashMap;

use lsp_types::{
    CodeAction, CodeActionKind, CodeActionOrCommand, Diagnostic as LspDiagnostic, TextEdit, Url, WorkspaceEdit,
};

use super::analysis::Analysis;
use super::text::{Encoding, LineIndex};
use crate::diag::{Diagnostic, Severity};
use crate::syntax::ast::ItemKind;

/// The fixes for `diags` (each paired with its LSP form) that touch the byte range `from..to`.
pub fn actions(
    a: &Analysis,
    uri: &Url,
    lines: &LineIndex,
    enc: Encoding,
    diags: &[(&Diagnostic, LspDiagnostic)],
    from: u32,
    to: u32,
) -> Vec<CodeActionOrCommand> {
    let text = a.text(0);
    let mut out = Vec::new();
    for (d, lsp) in diags {
        let Some(span) = d.span.filter(|s| s.file == 0 && s.start <= to && from <= s.end) else { continue };
        let edit = |range, new_text: String| {
            let changes = HashMap::from([(uri.clone(), vec![TextEdit { range, new_text }])]);
            Some(WorkspaceEdit { changes: Some(changes), ..WorkspaceEdit::default() })
        };
        if let Some(suggestion) = d.help.as_deref().and_then(did_you_mean) {
            let old = text.get(span.start as usize..span.end as usize).unwrap_or("");
            // `did you mean `std::driving`?` is about the module name after `std::`.
            let new = match suggestion.rsplit_once("::") {
                Some((_, last)) if !old.contains("::") => last,
                _ => suggestion,
            };
            out.push(CodeActionOrCommand::CodeAction(CodeAction {
                title: format!("Replace `{old}` with `{new}`"),
                kind: Some(CodeActionKind::QUICKFIX),
                diagnostics: Some(vec![lsp.clone()]),
                edit: edit(lines.range(text, span.start, span.end, enc), new.to_string()),
                is_preferred: Some(true),
                ..CodeAction::default()
            }));
        }
        if d.severity == Severity::Warning && is_lattice_lint(d.code) {
            let at = allow_position(a);
            let pos = lines.position(text, at, enc);
            let insert = format!("/// TODO: say why {} is expected in this domain\nallow {}\n\n", d.code, d.code);
            out.push(CodeActionOrCommand::CodeAction(CodeAction {
                title: format!("Allow {} in this domain (with a `///` reason to fill in)", d.code),
                kind: Some(CodeActionKind::QUICKFIX),
                diagnostics: Some(vec![lsp.clone()]),
                edit: edit(lsp_types::Range { start: pos, end: pos }, insert),
                ..CodeAction::default()
            }));
        }
    }
    out
}

/// The name in a help text "did you mean `NAME`?".
fn did_you_mean(help: &str) -> Option<&str> {
    help.strip_prefix("did you mean `")?.strip_suffix("`?")
}

fn is_lattice_lint(code: &str) -> bool {
    code.strip_prefix("R01").is_some_and(|n| n.len() == 2 && n.bytes().all(|b| b.is_ascii_digit()))
}

/// Where a new `allow` goes: above the `rules` block and its doc comment, or at the end.
fn allow_position(a: &Analysis) -> u32 {
    let text = a.text(0);
    let Some(rules) = a.trees.first().and_then(|t| t.items.iter().find(|i| matches!(i.kind, ItemKind::Rules { .. })))
    else {
        return text.len() as u32;
    };
    let mut start = text[..rules.span.start as usize].rfind('\n').map_or(0, |i| i + 1);
    let doc_lines = if rules.doc.is_empty() { 0 } else { rules.doc.split('\n').count() };
    for _ in 0..doc_lines {
        start = text[..start.saturating_sub(1)].rfind('\n').map_or(0, |i| i + 1);
    }
    start as u32
}

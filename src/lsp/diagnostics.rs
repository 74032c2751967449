//! Our diagnostics as LSP diagnostics: positions in the negotiated encoding, the code, help
//! appended to the message, related spans as related information. Lattice lints the domain
//! silences with `allow CODE` are left out, as `revelio check` leaves them out of its output.

use lsp_types::{
    Diagnostic as LspDiagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString,
};

use super::analysis::{Analysis, Files};
use super::text::{Encoding, LineIndex};
use crate::diag::{Diagnostic, Severity};

/// Whether the domain silences this diagnostic with an `allow` item.
pub fn allowed(a: &Analysis, d: &Diagnostic) -> bool {
    d.severity == Severity::Warning
        && a.compiled.domain.as_ref().is_some_and(|dom| dom.allow.iter().any(|x| x.code == d.code))
}

/// Convert `d` of analysis `a`; `lines[i]` indexes the text of file `i`.
pub fn convert(a: &Analysis, d: &Diagnostic, lines: &[LineIndex], files: &Files, enc: Encoding) -> LspDiagnostic {
    let range = |s: crate::ir::Span| {
        let text = a.text(s.file);
        lines.get(s.file as usize).map(|l| l.range(text, s.start, s.end, enc)).unwrap_or_default()
    };
    let mut message = d.message.clone();
    if !d.label.is_empty() && d.label != d.message {
        message = format!("{message}\n{}", d.label);
    }
    if let Some(h) = &d.help {
        message = format!("{message}\nhelp: {h}");
    }
    let related: Vec<DiagnosticRelatedInformation> = d
        .related
        .iter()
        .filter_map(|r| {
            let name = &a.compiled.files.get(r.span.file as usize)?.name;
            Some(DiagnosticRelatedInformation {
                location: Location { uri: files.uri(name)?, range: range(r.span) },
                message: r.message.clone(),
            })
        })
        .collect();
    LspDiagnostic {
        range: d.span.map(range).unwrap_or_default(),
        severity: Some(match d.severity {
            Severity::Error => DiagnosticSeverity::ERROR,
            Severity::Warning => DiagnosticSeverity::WARNING,
        }),
        code: Some(NumberOrString::String(d.code.to_string())),
        source: Some("revelio".to_string()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        ..LspDiagnostic::default()
    }
}

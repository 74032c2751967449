//! Lattice lints for `revelio check` (being built).
use crate::check::diagnostic::Diagnostic;
use crate::ir::Domain;

/// Warnings computed over the enumerated lattice of a compiled domain.
pub fn lint_domain(_domain: &Domain) -> Vec<Diagnostic> {
    Vec::new()
}

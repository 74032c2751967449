//! Namespaces of declared names, duplicate detection, unknown-name diagnostics with "did you
//! mean", and the record of every name resolved (what the language server navigates by).

use std::collections::HashMap;

use crate::diag::suggest::suggest;
use crate::diag::{Diagnostic, codes};
use crate::ir::Span;
use crate::syntax::ast::Ident;

/// One namespace (concepts, regions, …): names in declaration order with a value each.
#[derive(Debug)]
pub(crate) struct Namespace<T> {
    map: HashMap<String, usize>,
    entries: Vec<(String, Span, T)>,
}

impl<T> Default for Namespace<T> {
    fn default() -> Self {
        Namespace { map: HashMap::new(), entries: Vec::new() }
    }
}

impl<T: Clone> Namespace<T> {
    /// Declare `name`; a second declaration is reported (pointing at both) and ignored.
    /// `sort` names what the first declaration was, for the message.
    pub fn declare(
        &mut self,
        name: &Ident,
        value: T,
        sort: impl Fn(&T) -> &'static str,
        diags: &mut Vec<Diagnostic>,
    ) -> bool {
        if let Some(&i) = self.map.get(&name.name) {
            let (_, first, ref prev) = self.entries[i];
            diags.push(
                Diagnostic::error(
                    codes::DUPLICATE_NAME,
                    name.span,
                    format!("`{}` is already declared as {}", name.name, sort(prev)),
                )
                .with_label("declared again here")
                .with_related(first, "first declared here")
                .with_help("rename one of them; names are global across all loaded modules"),
            );
            return false;
        }
        self.map.insert(name.name.clone(), self.entries.len());
        self.entries.push((name.name.clone(), name.span, value));
        true
    }

    pub fn get(&self, name: &str) -> Option<&T> {
        self.map.get(name).map(|&i| &self.entries[i].2)
    }

    pub fn span(&self, name: &str) -> Option<Span> {
        self.map.get(name).map(|&i| self.entries[i].1)
    }

    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.iter().map(|(n, _, _)| n.as_str())
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }
}

/// One use of a name and the declaration it resolved to: what the language server's go to
/// definition, find references, hover and highlighting read, so that names are resolved once,
/// here. `decl` is the declared name's span; for an attribute, its whole declaration
/// (`NAME: TYPE = DEFAULT`); for a module, the start of its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reference {
    pub at: Span,
    pub decl: Span,
}

/// "unknown SORT `name`" with a "did you mean" help when a candidate is close.
pub fn unknown<'a>(sort: &str, name: &Ident, candidates: impl IntoIterator<Item = &'a str>) -> Diagnostic {
    let d = Diagnostic::error(codes::UNKNOWN_NAME, name.span, format!("unknown {sort} `{}`", name.name))
        .with_label(format!("no {sort} has this name"));
    match suggest(&name.name, candidates) {
        Some(s) => d.with_help(format!("did you mean `{s}`?")),
        None => d,
    }
}

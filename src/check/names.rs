//! Namespaces of declared names, duplicate detection, and "did you mean" suggestions.

use std::collections::HashMap;

use super::codes;
use super::diagnostic::Diagnostic;
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

/// Levenshtein distance (on chars), case-insensitive so that `weather` finds `Weather`.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.to_lowercase().chars().collect();
    let b: Vec<char> = b.to_lowercase().chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.iter().enumerate() {
        cur[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The closest candidate within a third of the name's length (at least 1 edit, at most 3);
/// ties go to the candidate seen first, so the result is deterministic.
pub fn suggest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).clamp(1, 3);
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        if c == name {
            continue;
        }
        let d = edit_distance(name, c);
        if d <= limit && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_and_suggestions() {
        assert_eq!(edit_distance("kitten", "sitting"), 3);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(suggest("pedestrain", ["Pedestrian", "Cyclist"]), Some("Pedestrian"));
        assert_eq!(suggest("xyz", ["Pedestrian", "Cyclist"]), None);
        assert_eq!(suggest("far", ["far", "near"]), None);
    }
}

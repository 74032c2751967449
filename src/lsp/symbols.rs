//! Document symbols: the outline of a file — its items, with attributes, variants, options,
//! rules and added entities under them.

use lsp_types::{DocumentSymbol, SymbolKind};

use super::analysis::Analysis;
use super::index::Sort;
use super::text::{Encoding, LineIndex};

pub fn outline(a: &Analysis, lines: &LineIndex, enc: Encoding) -> Vec<DocumentSymbol> {
    let ix = &a.index;
    let text = a.text(0);
    let make = |id: usize, children: Vec<DocumentSymbol>| {
        let s = &ix.symbols[id];
        let full = if s.full.start <= s.decl.start && s.decl.end <= s.full.end { s.full } else { s.decl };
        #[allow(deprecated)]
        DocumentSymbol {
            name: s.name.clone(),
            detail: Some(s.sort.word().to_string()),
            kind: kind_of(s.sort),
            tags: None,
            deprecated: None,
            range: lines.range(text, full.start, full.end, enc),
            selection_range: lines.range(text, s.decl.start, s.decl.end, enc),
            children: (!children.is_empty()).then_some(children),
        }
    };
    let mut out = Vec::new();
    for (id, s) in ix.symbols.iter().enumerate() {
        if s.decl.file != 0 || s.parent.is_some() || matches!(s.sort, Sort::Module | Sort::Var) {
            continue;
        }
        // World attributes have no parent symbol; they are listed at the top level.
        let children: Vec<DocumentSymbol> = ix
            .symbols
            .iter()
            .enumerate()
            .filter(|(_, c)| c.parent == Some(id) && c.decl.file == 0)
            .map(|(c, _)| make(c, Vec::new()))
            .collect();
        out.push(make(id, children));
    }
    out
}

fn kind_of(sort: Sort) -> SymbolKind {
    match sort {
        Sort::Module => SymbolKind::MODULE,
        Sort::Unit => SymbolKind::CONSTANT,
        Sort::Enum => SymbolKind::ENUM,
        Sort::Variant | Sort::Option => SymbolKind::ENUM_MEMBER,
        Sort::Tag => SymbolKind::INTERFACE,
        Sort::Relation | Sort::Rule => SymbolKind::FUNCTION,
        Sort::Kind | Sort::Preset | Sort::Stage => SymbolKind::STRUCT,
        Sort::Attr | Sort::WorldAttr => SymbolKind::FIELD,
        Sort::Region => SymbolKind::NAMESPACE,
        Sort::Concept | Sort::Modifier => SymbolKind::CLASS,
        Sort::Constraint => SymbolKind::OPERATOR,
        Sort::Question => SymbolKind::OBJECT,
        Sort::Entity | Sort::Var => SymbolKind::VARIABLE,
    }
}

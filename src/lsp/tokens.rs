//! Semantic tokens through the lossless lexer: comments, strings, numbers and operators by
//! token class; words by what the index says they name (a kind, an attribute, a variant …),
//! and as keywords only where they name nothing — so `color` is a keyword in a shape part and
//! an attribute in `color: Signal = red`.

use lsp_types::{SemanticToken, SemanticTokenModifier, SemanticTokenType, SemanticTokensLegend};

use super::analysis::Analysis;
use super::index::Sort;
use super::text::{Encoding, LineIndex};
use crate::syntax::ast::ItemKind;
use crate::syntax::lexer::{self, TokenKind};

const TYPES: &[SemanticTokenType] = &[
    SemanticTokenType::COMMENT,
    SemanticTokenType::STRING,
    SemanticTokenType::NUMBER,
    SemanticTokenType::OPERATOR,
    SemanticTokenType::KEYWORD,
    SemanticTokenType::STRUCT,
    SemanticTokenType::INTERFACE,
    SemanticTokenType::ENUM,
    SemanticTokenType::ENUM_MEMBER,
    SemanticTokenType::PROPERTY,
    SemanticTokenType::CLASS,
    SemanticTokenType::FUNCTION,
    SemanticTokenType::VARIABLE,
    SemanticTokenType::NAMESPACE,
    SemanticTokenType::TYPE,
    SemanticTokenType::PARAMETER,
];

const MODIFIERS: &[SemanticTokenModifier] =
    &[SemanticTokenModifier::DECLARATION, SemanticTokenModifier::DOCUMENTATION, SemanticTokenModifier::DEFAULT_LIBRARY];

pub fn legend() -> SemanticTokensLegend {
    SemanticTokensLegend { token_types: TYPES.to_vec(), token_modifiers: MODIFIERS.to_vec() }
}

fn type_index(t: &SemanticTokenType) -> u32 {
    TYPES.iter().position(|x| x == t).unwrap_or(0) as u32
}

fn type_of(sort: Sort) -> SemanticTokenType {
    match sort {
        Sort::Kind | Sort::Preset | Sort::Stage => SemanticTokenType::STRUCT,
        Sort::Tag => SemanticTokenType::INTERFACE,
        Sort::Enum => SemanticTokenType::ENUM,
        Sort::Variant | Sort::Option => SemanticTokenType::ENUM_MEMBER,
        Sort::Attr | Sort::WorldAttr => SemanticTokenType::PROPERTY,
        Sort::Concept | Sort::Modifier | Sort::Constraint => SemanticTokenType::CLASS,
        Sort::Rule | Sort::Relation => SemanticTokenType::FUNCTION,
        Sort::Entity | Sort::Var => SemanticTokenType::VARIABLE,
        Sort::Module | Sort::Question | Sort::Region => SemanticTokenType::NAMESPACE,
        Sort::Unit => SemanticTokenType::TYPE,
    }
}

/// The semantic tokens of file 0 of `a`, encoded relative to each other as LSP wants.
pub fn tokens(a: &Analysis, lines: &LineIndex, enc: Encoding) -> Vec<SemanticToken> {
    let text = a.text(0);
    let mut raw: Vec<(u32, u32, u32, u32)> = Vec::new(); // start byte, end byte, type, modifiers
    // A relation's placement words (`distance`, `on_top`) are keywords only in its `{ … }`.
    let placement_words: Vec<u32> = a
        .trees
        .first()
        .into_iter()
        .flat_map(|f| &f.items)
        .filter_map(|i| match &i.kind {
            ItemKind::Relation { placements: Some(ps), .. } => Some(ps),
            _ => None,
        })
        .flatten()
        .map(|p| p.word.span.start)
        .collect();
    for t in lexer::lex(text) {
        let (ty, mods) = match t.kind {
            TokenKind::Comment => (SemanticTokenType::COMMENT, 0),
            TokenKind::DocComment => (SemanticTokenType::COMMENT, 2),
            TokenKind::String | TokenKind::RawString | TokenKind::UnterminatedString => (SemanticTokenType::STRING, 0),
            TokenKind::Number | TokenKind::Color => (SemanticTokenType::NUMBER, 0),
            TokenKind::CmpOp | TokenKind::Pipe | TokenKind::Eq | TokenKind::DotDot => (SemanticTokenType::OPERATOR, 0),
            TokenKind::Wildcard => (SemanticTokenType::CLASS, 0),
            TokenKind::Ident => match a.index.at(0, t.start).filter(|(s, _)| s.start == t.start && s.end == t.end) {
                Some((span, id)) => {
                    let s = &a.index.symbols[id];
                    let mut mods = 0;
                    if s.decl == span {
                        mods |= 1;
                    }
                    if a.compiled.files.get(s.decl.file as usize).is_some_and(|f| f.name.starts_with("std/")) {
                        mods |= 4;
                    }
                    (type_of(s.sort), mods)
                }
                None if lexer::is_keyword(t.text(text))
                    || matches!(t.text(text), "ego" | "self")
                    || placement_words.contains(&t.start) =>
                {
                    (SemanticTokenType::KEYWORD, 0)
                }
                None => continue,
            },
            _ => continue,
        };
        // A token that spans lines (a raw string) is sent line by line.
        let mut start = t.start;
        for piece in t.text(text).split_inclusive('\n') {
            let end = start + piece.trim_end_matches(['\n', '\r']).len() as u32;
            if end > start {
                raw.push((start, end, type_index(&ty), mods));
            }
            start += piece.len() as u32;
        }
    }
    let mut out = Vec::with_capacity(raw.len());
    let (mut line, mut col) = (0, 0);
    for (s, e, ty, mods) in raw {
        let p = lines.position(text, s, enc);
        let length = lines.position(text, e, enc).character - p.character;
        let delta_line = p.line - line;
        let delta_start = if delta_line == 0 { p.character - col } else { p.character };
        out.push(SemanticToken { delta_line, delta_start, length, token_type: ty, token_modifiers_bitset: mods });
        (line, col) = (p.line, p.character);
    }
    out
}

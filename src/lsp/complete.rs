//! Completion by context, read from the tokens before the cursor: kinds and tags after `add x:`,
//! `target`, `exists v:` and `|`; attributes after `.` (of the world, of an `exists`
//! variable's kinds, of `self`); options after `expect q.`; enum variants after `=` and
//! comparisons; units right after a number; concept names in `has`, `elements` and constraint
//! lists; regions, relations, lint codes, stdlib modules, and the statement keywords of the
//! block the cursor is in.

use lsp_types::{CompletionItem, CompletionItemKind};

use super::analysis::Analysis;
use super::index::{Index, Sort};
use crate::check::STDLIB;
use crate::syntax::grammar::{Block, block_keywords};
use crate::syntax::lexer::{self, Token, TokenKind};

/// Completions at byte `offset` of the document `text` (file 0 of `a`).
pub fn complete(a: &Analysis, text: &str, offset: u32) -> Vec<CompletionItem> {
    let tokens = lexer::lex(text);
    let ix = &a.index;
    // The word being typed, if the cursor is at the end of (or inside) one.
    let word = tokens.iter().position(|t| t.start < offset && offset <= t.end);
    let partial =
        word.filter(|&i| matches!(tokens[i].kind, TokenKind::Ident | TokenKind::Number | TokenKind::Wildcard));
    if let Some(i) = partial
        && tokens[i].kind == TokenKind::Number
    {
        return units(ix, &tokens[i].text(text)[..(offset - tokens[i].start) as usize]);
    }
    let before_end = partial.map_or(offset, |i| tokens[i].start);
    let sig: Vec<Token> = tokens.iter().filter(|t| t.end <= before_end && !t.kind.is_trivia()).copied().collect();
    let word_of = |t: &Token| t.text(text);
    let prev = sig.last().copied();
    let prev_word = prev.map(|t| word_of(&t)).unwrap_or("");
    let statement = statement_tokens(&sig, text);
    let first = statement.first().map(&word_of).unwrap_or("");

    // After `.`: attributes, options or variants of what precedes the dot.
    if prev.is_some_and(|t| t.kind == TokenKind::Dot) && sig.len() >= 2 {
        let owner = word_of(&sig[sig.len() - 2]);
        return after_dot(ix, &sig, text, owner, block_owner(&sig, text));
    }
    // Inside `add … { ATTR = VALUE, … }`: the added kind's attributes.
    if block(&sig, text).as_deref() == Some("add")
        && matches!(prev.map(|t| t.kind), Some(TokenKind::LBrace | TokenKind::Comma))
    {
        let add = sig.iter().rposition(|t| word_of(t) == "add");
        let kind = add.and_then(|i| sig.get(i + 3)).map(&word_of).unwrap_or("");
        let kinds: Vec<usize> =
            ix.global(&[Sort::Kind, Sort::Tag], kind).map(|k| ix.kinds_matching(&[k])).unwrap_or_default();
        return symbols(ix, &kinds.iter().flat_map(|&k| ix.attrs_of_kind(k)).collect::<Vec<_>>());
    }
    let at_statement_start = text[..before_end as usize]
        .rsplit('\n')
        .next()
        .is_some_and(|line| line.trim().is_empty() || line.trim_end().ends_with('{'));
    if at_statement_start && !matches!(prev.map(|t| t.kind), Some(TokenKind::Colon | TokenKind::Eq | TokenKind::Pipe)) {
        return keywords(block(&sig, text).as_deref());
    }
    match prev.map(|t| t.kind) {
        Some(TokenKind::Colon) => {
            return match first {
                "add" | "when" | "where" | "rule" => names(ix, &[Sort::Kind, Sort::Tag]),
                "kind" => names(ix, &[Sort::Kind, Sort::Tag]),
                "tag" => names(ix, &[Sort::Tag]),
                _ if statement.iter().any(|t| word_of(t) == "exists") => names(ix, &[Sort::Kind, Sort::Tag]),
                _ => types(ix),
            };
        }
        Some(TokenKind::Pipe) => return names(ix, &[Sort::Kind, Sort::Tag]),
        Some(TokenKind::Eq | TokenKind::CmpOp) if first == "constraint" && prev_word == "=" => {
            return ["exclusive", "at_most", "requires", "forbids"]
                .iter()
                .map(|f| item(f, CompletionItemKind::FUNCTION, "constraint"))
                .collect();
        }
        Some(TokenKind::Eq | TokenKind::CmpOp) => return values(ix, &sig, text),
        Some(TokenKind::LParen | TokenKind::Comma) if first == "constraint" => {
            let mut out = names(ix, &[Sort::Concept, Sort::Modifier]);
            out.push(item("category", CompletionItemKind::KEYWORD, "every concept of a category"));
            return out;
        }
        Some(TokenKind::Comma) if first == "elements" => return names(ix, &[Sort::Concept, Sort::Modifier]),
        _ => {}
    }
    match prev_word {
        "target" => {
            let mut out = names(ix, &[Sort::Kind, Sort::Tag]);
            out.push(item("world", CompletionItemKind::KEYWORD, "the world"));
            out
        }
        "move" => names(ix, &[Sort::Region]),
        "drawn_by" => names(ix, &[Sort::Stage]),
        "in" if first == "add"
            || first == "when"
            || first == "where"
            || statement.iter().any(|t| word_of(t) == "exists") =>
        {
            names(ix, &[Sort::Region])
        }
        "has" | "elements" => names(ix, &[Sort::Concept, Sort::Modifier]),
        "look" => names(ix, &[Sort::Kind]),
        "visible" => names(ix, &[Sort::Kind, Sort::Tag, Sort::Concept, Sort::Modifier]),
        "expect" => ix
            .all(&[Sort::Option])
            .filter_map(|(_, o)| {
                let q = &ix.symbols[o.parent?];
                Some(item(&format!("{}.{}", q.name, o.name), CompletionItemKind::ENUM_MEMBER, o.notes.first()?))
            })
            .collect(),
        "for" if first == "preset" => ix
            .all(&[Sort::Variant])
            .filter_map(|(_, v)| {
                Some(item(
                    &format!("{}.{}", ix.symbols[v.parent?].name, v.name),
                    CompletionItemKind::ENUM_MEMBER,
                    "variant",
                ))
            })
            .collect(),
        "allow" => LINTS.iter().map(|(code, what)| item(code, CompletionItemKind::CONSTANT, what)).collect(),
        "use" => STDLIB
            .iter()
            .map(|(m, _)| item(&format!("std::{m}"), CompletionItemKind::MODULE, "standard library"))
            .collect(),
        "when" | "where" | "and" | "or" | "not" => expression_starts(ix),
        _ if first == "add" => add_position(ix, &statement, text),
        _ => {
            let mut out = keywords(block(&sig, text).as_deref());
            out.extend(names(ix, &[Sort::Concept, Sort::Modifier, Sort::Kind, Sort::Tag, Sort::Region]));
            out
        }
    }
}

/// The lattice-lint codes an `allow` may name.
const LINTS: &[(&str, &str)] = &[
    ("R0100", "a concept appears in no valid set"),
    ("R0101", "a rule is never selected"),
    ("R0102", "a rule leaves the expected answer undetermined"),
    ("R0103", "best fit: two rules with different answers tie"),
    ("R0104", "an answer option is never expected"),
    ("R0105", "a modifier has no possible target"),
    ("R0106", "no rule matches some valid set"),
    ("R0107", "a concept or pair is hidden in rendered scenes (check --render)"),
    ("R0108", "an entity a concept places draws nothing: its visibility cannot be measured (check --render)"),
];

fn item(label: &str, kind: CompletionItemKind, detail: &str) -> CompletionItem {
    CompletionItem {
        label: label.to_string(),
        kind: Some(kind),
        detail: (!detail.is_empty()).then(|| detail.to_string()),
        ..CompletionItem::default()
    }
}

fn kind_of(sort: Sort) -> CompletionItemKind {
    match sort {
        Sort::Kind => CompletionItemKind::STRUCT,
        Sort::Tag => CompletionItemKind::INTERFACE,
        Sort::Enum => CompletionItemKind::ENUM,
        Sort::Variant | Sort::Option => CompletionItemKind::ENUM_MEMBER,
        Sort::Attr | Sort::WorldAttr => CompletionItemKind::FIELD,
        Sort::Unit => CompletionItemKind::UNIT,
        Sort::Concept | Sort::Modifier => CompletionItemKind::CLASS,
        Sort::Rule | Sort::Relation => CompletionItemKind::FUNCTION,
        Sort::Module => CompletionItemKind::MODULE,
        Sort::Entity | Sort::Var => CompletionItemKind::VARIABLE,
        _ => CompletionItemKind::VALUE,
    }
}

/// Every symbol of these sorts, once per name.
fn names(ix: &Index, sorts: &[Sort]) -> Vec<CompletionItem> {
    let mut out: Vec<CompletionItem> = Vec::new();
    for (_, s) in ix.all(sorts) {
        if !out.iter().any(|o| o.label == s.name) {
            let mut it = item(&s.name, kind_of(s.sort), s.sort.word());
            if !s.doc.is_empty() || !s.notes.is_empty() {
                let doc = if s.doc.is_empty() { s.notes[0].clone() } else { s.doc.clone() };
                it.documentation = Some(lsp_types::Documentation::String(doc));
            }
            out.push(it);
        }
    }
    out
}

fn symbols(ix: &Index, ids: &[usize]) -> Vec<CompletionItem> {
    let mut out: Vec<CompletionItem> = Vec::new();
    for &id in ids {
        let s = &ix.symbols[id];
        if !out.iter().any(|o| o.label == s.name) {
            out.push(item(&s.name, kind_of(s.sort), s.snippet.lines().next().unwrap_or("")));
        }
    }
    out
}

fn units(ix: &Index, typed: &str) -> Vec<CompletionItem> {
    let digits: String = typed.chars().take_while(|c| c.is_ascii_digit() || matches!(c, '.' | '-')).collect();
    ix.all(&[Sort::Unit])
        .map(|(_, u)| {
            let mut it =
                item(&format!("{digits}{}", u.name), CompletionItemKind::UNIT, u.notes.first().map_or("", |n| n));
            it.filter_text = Some(it.label.clone());
            it
        })
        .collect()
}

fn types(ix: &Index) -> Vec<CompletionItem> {
    let mut out = vec![
        item("bool", CompletionItemKind::KEYWORD, "true or false"),
        item("number", CompletionItemKind::KEYWORD, "a plain number"),
    ];
    let mut dims: Vec<&str> =
        ix.all(&[Sort::Unit]).filter_map(|(_, u)| u.notes.first()?.strip_prefix("measures ")).collect();
    dims.dedup();
    for d in dims {
        if !out.iter().any(|o| o.label == d) {
            out.push(item(d, CompletionItemKind::UNIT, "a number with a unit of this dimension"));
        }
    }
    out.extend(names(ix, &[Sort::Enum]));
    out
}

fn expression_starts(ix: &Index) -> Vec<CompletionItem> {
    let mut out: Vec<CompletionItem> = ["has", "exists", "count", "not", "world", "true", "false"]
        .iter()
        .map(|k| item(k, CompletionItemKind::KEYWORD, ""))
        .collect();
    out.extend(names(ix, &[Sort::Concept, Sort::Modifier]).into_iter().map(|mut c| {
        c.insert_text = Some(format!("has {}", c.label));
        c.label = format!("has {}", c.label);
        c
    }));
    out
}

/// The tokens of the statement the cursor is in: back to the nearest statement keyword of the
/// enclosing block, `{` or `}`.
fn statement_tokens(sig: &[Token], text: &str) -> Vec<Token> {
    let mut start = sig.len();
    while start > 0 {
        let t = sig[start - 1];
        if matches!(t.kind, TokenKind::LBrace | TokenKind::RBrace) {
            break;
        }
        start -= 1;
        if t.kind == TokenKind::Ident && lexer::starts_statement(t.text(text)) {
            break;
        }
    }
    sig[start..].to_vec()
}

/// The keyword that opened the innermost `{` around the cursor (`concept`, `rule`, `shape`, …).
fn block(sig: &[Token], text: &str) -> Option<String> {
    const OPENERS: &[&str] = &[
        "concept", "modifier", "kind", "world", "region", "preset", "camera", "stage", "question", "rules", "rule",
        "look", "shape", "enum", "add",
    ];
    let mut stack: Vec<Option<String>> = Vec::new();
    for (i, t) in sig.iter().enumerate() {
        match t.kind {
            TokenKind::LBrace => {
                let opener = sig[..i]
                    .iter()
                    .rev()
                    .take_while(|t| !matches!(t.kind, TokenKind::LBrace | TokenKind::RBrace))
                    .find(|t| t.kind == TokenKind::Ident && OPENERS.contains(&t.text(text)))
                    .map(|t| t.text(text).to_string());
                stack.push(opener);
            }
            TokenKind::RBrace => {
                stack.pop();
            }
            _ => {}
        }
    }
    stack.pop().flatten()
}

/// The kind a `look NAME { … }` or `kind NAME { shape { … } }` draws, for `self.`.
fn block_owner<'t>(sig: &[Token], text: &'t str) -> Option<&'t str> {
    let mut depth = 0i32;
    for (i, t) in sig.iter().enumerate().rev() {
        match t.kind {
            TokenKind::RBrace => depth += 1,
            TokenKind::LBrace => depth -= 1,
            TokenKind::Ident if depth < 0 && matches!(t.text(text), "look" | "kind") => {
                return sig.get(i + 1).map(|n| n.text(text));
            }
            _ => {}
        }
    }
    None
}

/// The keywords that start a statement in the block opened by `opener` (the file's items
/// outside any block); none in a block of names and values (`enum`, `add … {`).
fn keywords(opener: Option<&str>) -> Vec<CompletionItem> {
    let words = match opener {
        None => block_keywords(Block::File),
        Some(w) => Block::opened_by(w).map_or(&[][..], block_keywords),
    };
    words.iter().map(|w| item(w, CompletionItemKind::KEYWORD, "")).collect()
}

/// After `OWNER.`: world attributes, `self`'s attributes, an `exists` variable's attributes, a
/// question's options or an enum's variants.
fn after_dot(ix: &Index, sig: &[Token], text: &str, owner: &str, self_kind: Option<&str>) -> Vec<CompletionItem> {
    if owner == "world" {
        return symbols(ix, &ix.world_attrs());
    }
    if owner == "self" {
        let kinds: Vec<usize> = self_kind.and_then(|k| ix.global(&[Sort::Kind], k)).into_iter().collect();
        return symbols(ix, &kinds.iter().flat_map(|&k| ix.attrs_of_kind(k)).collect::<Vec<_>>());
    }
    if let Some(q) = ix.global(&[Sort::Question], owner) {
        return symbols(ix, &ix.options_of(q));
    }
    if let Some(e) = ix.global(&[Sort::Enum], owner) {
        return symbols(ix, &ix.variants_of(e));
    }
    // `exists OWNER: A | B` earlier in the statement: the attributes of those kinds.
    let filter = exists_filter(sig, text, owner);
    let kinds =
        ix.kinds_matching(&filter.iter().filter_map(|f| ix.global(&[Sort::Kind, Sort::Tag], f)).collect::<Vec<_>>());
    if !kinds.is_empty() {
        return symbols(ix, &kinds.iter().flat_map(|&k| ix.attrs_of_kind(k)).collect::<Vec<_>>());
    }
    symbols(ix, &ix.all(&[Sort::Attr]).map(|(i, _)| i).collect::<Vec<_>>())
}

/// The filter of the last `exists VAR: A | B` before the cursor.
fn exists_filter<'t>(sig: &[Token], text: &'t str, var: &str) -> Vec<&'t str> {
    for i in (0..sig.len().saturating_sub(2)).rev() {
        if sig[i].text(text) == "exists" && sig[i + 1].text(text) == var && sig[i + 2].kind == TokenKind::Colon {
            return sig[i + 3..]
                .iter()
                .take_while(|t| matches!(t.kind, TokenKind::Ident | TokenKind::Pipe) && t.text(text) != "where")
                .filter(|t| t.kind == TokenKind::Ident)
                .map(|t| t.text(text))
                .collect();
        }
    }
    Vec::new()
}

/// After `ATTR =` or `PATH <op>`: the values of that attribute.
fn values(ix: &Index, sig: &[Token], text: &str) -> Vec<CompletionItem> {
    let n = sig.len();
    let attr_name = if n >= 2 { sig[n - 2].text(text) } else { "" };
    let world = n >= 4 && sig[n - 3].kind == TokenKind::Dot && sig[n - 4].text(text) == "world";
    let candidates: Vec<usize> =
        if world { ix.world_attrs() } else { ix.all(&[Sort::Attr, Sort::WorldAttr]).map(|(i, _)| i).collect() };
    let attr = candidates.into_iter().find(|&a| ix.symbols[a].name == attr_name);
    // `NAME: Enum =` in a declaration: the type is the token before `=` (or before `in`).
    let declared =
        (n >= 4 && sig[n - 3].kind == TokenKind::Colon).then(|| ix.global(&[Sort::Enum], attr_name)).flatten();
    match attr.and_then(|a| ix.enum_of_attr(a)).or(declared) {
        Some(e) => symbols(ix, &ix.variants_of(e)),
        None if attr.is_some_and(|a| ix.symbols[a].snippet.contains(": bool")) || attr_name == "bool" => {
            vec![item("true", CompletionItemKind::KEYWORD, ""), item("false", CompletionItemKind::KEYWORD, "")]
        }
        None => Vec::new(),
    }
}

/// `add NAME: KIND in REGION …`: relations after the region, entities (and `ego`) after the
/// relation.
fn add_position(ix: &Index, statement: &[Token], text: &str) -> Vec<CompletionItem> {
    let words: Vec<&str> = statement.iter().map(|t| t.text(text)).collect();
    // add NAME : KIND in REGION RELATION TARGET
    match words.len() {
        6 => names(ix, &[Sort::Relation]),
        7 => {
            let mut out = vec![item("ego", CompletionItemKind::VARIABLE, "the camera's owner")];
            out.extend(names(ix, &[Sort::Entity]));
            out
        }
        _ => Vec::new(),
    }
}

//! Text → syntax tree, with error recovery (grammar: `grammar/revelio.pest`).
//!
//! Naming rule: a function named after a grammar rule (`concept_stmt`, `value`, `vec3`, …)
//! takes one pest pair *of that rule* and returns its syntax-tree node; it never fails, because
//! the grammar already guaranteed the shape (malformed literals are reported and replaced by a
//! neutral value). `junk_*` functions turn a recovery node into a diagnostic. `next_*` helpers
//! pull the next child of a given sort from a [`Children`] cursor, skipping keyword tokens.
//!
//! Parsing never fails: pest only errs at the file level when the call limit stops
//! pathological nesting, and that becomes a diagnostic too.
//!
//! The builder is split by what it builds: items (`items.rs`), statements and shapes
//! (`statements.rs`), expressions (`expr.rs`), literals (`literals.rs`), and the diagnostics of
//! recovery nodes (`recovery.rs`). `///` doc comments come from the lossless token layer
//! ([`super::lexer`]), which keeps the comments the grammar skips.

use std::num::NonZeroUsize;

use pest::Parser;
use pest::iterators::Pair;

use super::ast::*;
use super::grammar::{RevParser, Rule, is_keyword};
use super::lexer::{self, Token};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::Span;

mod expr;
mod items;
mod literals;
mod recovery;
mod statements;
#[cfg(test)]
mod tests;

use recovery::token_end;

/// Rule calls allowed per parse: plenty for real files (a domain takes well under a million),
/// small enough to stop `((((…` bombs quickly.
const CALL_LIMIT: usize = 20_000_000;

/// The result of parsing one file: the tree (with error nodes) and the syntax diagnostics.
#[derive(Debug, Clone)]
pub struct Parsed {
    pub file: File,
    pub diagnostics: Vec<Diagnostic>,
}

/// Parse the text of file number `file` (its index in the compilation's file list).
pub fn parse(file: u32, text: &str) -> Parsed {
    pest::set_call_limit(NonZeroUsize::new(CALL_LIMIT));
    pest::set_error_detail(true);
    let mut b = Builder { file, text, tokens: lexer::lex(text), diagnostics: Vec::new() };
    if let Some(pos) = too_deep_at(text) {
        // The tree builder and the checker recurse over nesting; refuse before either runs.
        let span = b.span_at(pos, pos + 1);
        b.diagnostics.push(too_deep(span));
        return Parsed { file: File { items: Vec::new() }, diagnostics: b.diagnostics };
    }
    let items = match RevParser::parse(Rule::file, text) {
        Ok(mut pairs) => {
            let file_pair = pairs.next().expect("the file rule yields one pair");
            file_pair.into_inner().filter(|p| p.as_rule() != Rule::EOI).map(|p| b.item(p)).collect()
        }
        Err(e) => {
            let pos = match e.location {
                pest::error::InputLocation::Pos(p) => p,
                pest::error::InputLocation::Span((s, _)) => s,
            };
            let span = b.span_at(pos, token_end(text, pos));
            b.diagnostics.push(too_deep(span));
            Vec::new()
        }
    };
    Parsed { file: File { items }, diagnostics: b.diagnostics }
}

/// Deepest `(`/`{` nesting accepted; real files stay below 10.
pub const MAX_NESTING: usize = 200;

fn too_deep(span: Span) -> Diagnostic {
    Diagnostic::error(codes::TOO_DEEP, span, "the input nests too deeply to parse")
        .with_label(format!("more than {MAX_NESTING} levels of `(` and `{{`"))
        .with_help("split deeply nested expressions into several rules or `and` terms")
}

/// How many `not`s are chained at this node.
fn not_chain(mut p: Pair<Rule>) -> usize {
    let mut depth = 0;
    while p.as_rule() == Rule::not_expr {
        depth += 1;
        match Children::of(p).rest().next() {
            Some(inner) => p = inner,
            None => break,
        }
    }
    depth
}

/// Where `(`/`{` nesting first exceeds [`MAX_NESTING`], outside strings and comments.
fn too_deep_at(text: &str) -> Option<usize> {
    let bytes = text.as_bytes();
    let (mut depth, mut i) = (0usize, 0usize);
    while i < bytes.len() {
        match bytes[i] {
            b'(' | b'{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Some(i);
                }
            }
            b')' | b'}' => depth = depth.saturating_sub(1),
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                i += text[i..].find('\n').unwrap_or(text.len() - i);
            }
            b'"' if text[i..].starts_with("\"\"\"") => {
                i += 3 + text[i + 3..].find("\"\"\"").map_or(text.len() - i - 3, |e| e + 2);
            }
            b'"' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' && bytes[i] != b'\n' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
            }
            _ => {}
        }
        i += 1;
    }
    None
}

struct Builder<'t> {
    file: u32,
    text: &'t str,
    /// The lossless tokens of `text`, for the doc comments the grammar skips.
    tokens: Vec<Token>,
    diagnostics: Vec<Diagnostic>,
}

/// Children of a pair, with keyword tokens (`kw_*`) skipped unless asked for.
struct Children<'i> {
    pairs: std::iter::Peekable<pest::iterators::Pairs<'i, Rule>>,
}

impl<'i> Children<'i> {
    fn of(p: Pair<'i, Rule>) -> Self {
        Children { pairs: p.into_inner().peekable() }
    }
    /// The next child that is not a keyword.
    fn next(&mut self) -> Pair<'i, Rule> {
        self.skip_keywords();
        self.pairs.next().expect("grammar guarantees the child")
    }
    fn peek_rule(&mut self) -> Option<Rule> {
        self.skip_keywords();
        self.pairs.peek().map(|p| p.as_rule())
    }
    /// The next child if it has rule `r`.
    fn next_if(&mut self, r: Rule) -> Option<Pair<'i, Rule>> {
        if self.peek_rule() == Some(r) { self.pairs.next() } else { None }
    }
    /// The first token of the node (keywords included): what a statement starts with.
    fn first_token(&mut self) -> Option<Rule> {
        self.pairs.peek().map(|p| p.as_rule())
    }
    fn rest(self) -> impl Iterator<Item = Pair<'i, Rule>> {
        self.pairs.filter(|p| !is_keyword(p.as_rule()))
    }
    fn skip_keywords(&mut self) {
        while self.pairs.peek().is_some_and(|p| is_keyword(p.as_rule())) {
            self.pairs.next();
        }
    }
}

impl<'t> Builder<'t> {
    fn span_at(&self, start: usize, end: usize) -> Span {
        Span { file: self.file, start: start as u32, end: end as u32 }
    }
    fn span(&self, p: &Pair<Rule>) -> Span {
        let s = p.as_span();
        self.span_at(s.start(), s.end())
    }
    fn ident(&self, p: Pair<Rule>) -> Ident {
        Ident { name: p.as_str().to_string(), span: self.span(&p) }
    }
    fn idents(&self, c: Children) -> Vec<Ident> {
        c.rest().filter(|p| p.as_rule() == Rule::ident).map(|p| self.ident(p)).collect()
    }

    /// The `///` lines right above the node starting at `start`.
    fn doc_at(&self, start: u32) -> String {
        lexer::doc_before(self.text, &self.tokens, start)
    }
}

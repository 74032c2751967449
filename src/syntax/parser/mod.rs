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
use super::lexer::{self, Token, TokenKind};
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
    if let Some(pos) = too_deep_at(text, &b.tokens) {
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

/// The one nesting budget of the front end: the most levels of `(`, `{`, `not` and
/// `exists … where` that one point of a file may stand inside. Every later stage (the tree
/// builder, the checker, the oracle, the formatter, the language server) recurses over this
/// nesting, so a file past it is refused here, before any of them runs; real files stay below 10.
pub const MAX_NESTING: usize = 100;

fn too_deep(span: Span) -> Diagnostic {
    Diagnostic::error(codes::TOO_DEEP, span, "the input nests too deeply to parse")
        .with_label(format!("more than {MAX_NESTING} levels of `(`, `{{`, `not` and `where`"))
        .with_help("split deeply nested expressions into several rules or `and` terms")
}

/// Where the nesting first exceeds [`MAX_NESTING`], read from the tokens so that it runs before
/// pest (whose descent recurses too) and cannot itself overflow.
///
/// The count never falls short of the nesting any parse of the text reaches; it may overcount:
/// - `(` and `{` open a level until their closer; a bracket inside an unclosed `"` string counts
///   too, as recovery reads that text outside any string.
/// - `where` opens a level that lasts to the end of the enclosing bracket: its condition runs to
///   the end of the expression, and an expression ends no later than its bracket.
/// - A `not` before `not` or `exists` lasts as long; a `not` before `(` is one more level for
///   that bracket; a `not` before anything else is one level for the one term it negates.
/// - A `}` ends the item or statement around it (no expression holds a `{`), so the `not` and
///   `where` levels open in the enclosing bracket close with it.
fn too_deep_at(text: &str, tokens: &[Token]) -> Option<usize> {
    let mut nesting = Nesting { frames: vec![Frame { open: 0, negated: false }], depth: 0 };
    let significant: Vec<&Token> = tokens.iter().filter(|t| !t.kind.is_trivia()).collect();
    let mut not_before_paren = false;
    for (i, t) in significant.iter().enumerate() {
        let mut at = t.start as usize;
        let over = match t.kind {
            TokenKind::LParen | TokenKind::LBrace | TokenKind::RParen | TokenKind::RBrace => {
                nesting.bracket(text.as_bytes()[at], std::mem::take(&mut not_before_paren))
            }
            TokenKind::UnterminatedString => match t.text(text).bytes().position(|b| nesting.bracket(b, false)) {
                Some(j) => {
                    at += j;
                    true
                }
                None => false,
            },
            TokenKind::Ident if t.text(text) == "where" => nesting.open(),
            TokenKind::Ident if t.text(text) == "not" => {
                match significant.get(i + 1).map(|n| (n.kind, n.text(text))) {
                    Some((TokenKind::LParen, _)) => {
                        not_before_paren = true;
                        false
                    }
                    Some((TokenKind::Ident, "not" | "exists")) => nesting.open(),
                    // One term, whose own nesting is counted as it comes.
                    _ => nesting.depth + 1 > MAX_NESTING,
                }
            }
            _ => false,
        };
        if over {
            return Some(at);
        }
    }
    None
}

/// The running count of [`too_deep_at`]: one frame per open bracket, plus the file's.
struct Nesting {
    frames: Vec<Frame>,
    depth: usize,
}

struct Frame {
    /// `not` and `where` levels opened inside this bracket and still open.
    open: usize,
    /// Whether a `not` stands right before the bracket (one more level while it is open).
    negated: bool,
}

impl Nesting {
    /// Open a `not`/`where` level in the innermost bracket; whether the budget is passed.
    fn open(&mut self) -> bool {
        self.frames.last_mut().expect("the file frame stays").open += 1;
        self.depth += 1;
        self.depth > MAX_NESTING
    }

    /// Count byte `b` if it is a bracket; whether the budget is passed.
    fn bracket(&mut self, b: u8, negated: bool) -> bool {
        match b {
            b'(' | b'{' => {
                self.depth += 1 + usize::from(negated);
                self.frames.push(Frame { open: 0, negated });
                self.depth > MAX_NESTING
            }
            b')' | b'}' if self.frames.len() > 1 => {
                let f = self.frames.pop().expect("more than the file frame");
                self.depth -= 1 + usize::from(f.negated) + f.open;
                if b == b'}' {
                    let parent = self.frames.last_mut().expect("the file frame stays");
                    self.depth -= parent.open;
                    parent.open = 0;
                }
                false
            }
            _ => false,
        }
    }
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

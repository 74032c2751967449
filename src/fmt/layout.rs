//! From pest's tree to a line-break plan: for each significant token, what goes before it (a
//! line break at some indentation, a fill point, or the spacing the token pair calls for).
//! Comments are not planned here; the printer places them around the plan.

use pest::Parser;
use pest::iterators::Pair;

use super::MAX_WIDTH;
use crate::syntax::grammar::{RevParser, Rule};
use crate::syntax::lexer::{Token, TokenKind};

/// What goes before a significant token.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Sep {
    /// The spacing the token pair calls for ([`gap`]).
    Auto,
    /// A line break, the token indented `level` steps; a blank line is kept when the source had
    /// one and `blank` allows it. Comments in the gap go on their own lines at `comments` steps.
    Line { level: usize, blank: bool, comments: usize },
    /// Two spaces if the next setting (`width` columns wide; `None` when it cannot be flat) fits
    /// on the line, else a line break at `level`.
    Fill { level: usize, width: Option<usize> },
    /// Two spaces: between the settings of a one-line block.
    TwoSpaces,
}

pub(super) struct Plan {
    pub sep: Vec<Sep>,
    /// Tokens left out (trailing commas of one-line lists).
    pub skip: Vec<bool>,
    /// Text written right after a token (the trailing comma of a broken list).
    pub suffix: Vec<Option<&'static str>>,
}

/// The spacing between two significant tokens on one line.
pub(super) fn gap(text: &str, prev: Token, next: Token) -> &'static str {
    use TokenKind::*;
    match (prev.kind, next.kind) {
        (_, Comma | Colon | RParen) | (LParen, _) => "",
        (ColonColon | Dot | DotDot, _) | (_, ColonColon | Dot | DotDot) => "",
        (LBrace, RBrace) => "",
        // `exclusive(a, b)` and `count(Agent)` call; `size (…)`, `at (…)` and `when (…)` do not.
        (Ident, LParen) => {
            let word = prev.text(text);
            if matches!(word, "size" | "at" | "look_at" | "step" | "when" | "and" | "or" | "not" | "where") {
                " "
            } else {
                ""
            }
        }
        _ => " ",
    }
}

/// The line-break plan for `text`, which parsed without syntax errors; `None` if pest disagrees.
pub(super) fn plan(text: &str, tokens: &[Token]) -> Option<Plan> {
    let n = tokens.len();
    let mut l =
        Layout { text, tokens, plan: Plan { sep: vec![Sep::Auto; n], skip: vec![false; n], suffix: vec![None; n] } };
    let file = RevParser::parse(Rule::file, text).ok()?.next()?;
    for item in file.into_inner().filter(|p| p.as_rule() != Rule::EOI) {
        let first = l.first(&item)?;
        l.line(first, 0, true);
        l.item(&item, 0)?;
    }
    Some(l.plan)
}

struct Layout<'a> {
    text: &'a str,
    tokens: &'a [Token],
    plan: Plan,
}

/// How the statements of a `{ … }` block are laid out.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Style {
    /// One statement per line.
    Lines,
    /// Settings: one line if the whole item fits, else filled.
    Fill,
}

impl Layout<'_> {
    /// The token starting at byte `pos`.
    fn at(&self, pos: usize) -> Option<usize> {
        let i = self.tokens.partition_point(|t| (t.start as usize) < pos);
        (i < self.tokens.len() && self.tokens[i].start as usize == pos).then_some(i)
    }

    fn first(&self, p: &Pair<Rule>) -> Option<usize> {
        self.at(p.as_span().start())
    }

    /// The token ending at the end of `p`.
    fn last(&self, p: &Pair<Rule>) -> Option<usize> {
        let end = p.as_span().end() as u32;
        let i = self.tokens.partition_point(|t| t.end < end);
        (i < self.tokens.len() && self.tokens[i].end == end).then_some(i)
    }

    fn line(&mut self, i: usize, level: usize, blank: bool) {
        self.plan.sep[i] = Sep::Line { level, blank, comments: level };
    }

    fn has_comments(&self, a: usize, b: usize) -> bool {
        self.tokens[a..=b].iter().any(|t| t.kind.is_comment())
    }

    /// Columns that tokens `a..=b` take on one line, or `None` if they cannot share one line.
    fn flat_width(&self, a: usize, b: usize) -> Option<usize> {
        let mut width = 0;
        let mut prev: Option<Token> = None;
        for (i, t) in self.tokens.iter().enumerate().take(b + 1).skip(a) {
            if t.kind.is_comment() {
                return None;
            }
            if t.kind.is_trivia() || self.plan.skip[i] {
                continue;
            }
            let s = t.text(self.text);
            if s.contains('\n') {
                return None;
            }
            if let Some(p) = prev {
                width += gap(self.text, p, *t).len();
            }
            width += s.chars().count() + self.plan.suffix[i].map_or(0, str::len);
            prev = Some(*t);
        }
        Some(width)
    }

    /// The `{` of an item's body (the first one outside its children) and the closing `}`.
    fn braces(&self, p: &Pair<Rule>) -> Option<(usize, usize)> {
        let (a, b) = (self.first(p)?, self.last(p)?);
        let children: Vec<(u32, u32)> =
            p.clone().into_inner().map(|c| (c.as_span().start() as u32, c.as_span().end() as u32)).collect();
        let open = (a..=b).find(|&i| {
            let t = self.tokens[i];
            t.kind == TokenKind::LBrace && !children.iter().any(|&(s, e)| t.start >= s && t.end <= e)
        })?;
        Some((open, b))
    }

    fn item(&mut self, p: &Pair<Rule>, level: usize) -> Option<()> {
        let children: Vec<Pair<Rule>> = p.clone().into_inner().collect();
        let of = |rules: &[Rule]| children.iter().filter(|c| rules.contains(&c.as_rule())).cloned().collect::<Vec<_>>();
        match p.as_rule() {
            Rule::enum_item => self.enum_list(p, level)?,
            Rule::kind_item | Rule::world_item => {
                let (open, close) = self.braces(p)?;
                let stmts = of(&[Rule::attr_decl, Rule::shape_block, Rule::stands_in]);
                // `kind Tree: Extra { in verge }` stays on one line when it fits.
                let style =
                    if stmts.iter().all(|s| s.as_rule() == Rule::stands_in) { Style::Fill } else { Style::Lines };
                self.block(open, close, &stmts, level, style, p)?;
                for s in stmts.iter().filter(|s| s.as_rule() == Rule::shape_block) {
                    let parts = s.clone().into_inner().find(|c| c.as_rule() == Rule::parts)?;
                    self.parts(&parts, level + 1)?;
                }
            }
            Rule::look_item | Rule::stage_item => self.parts(children.last()?, level)?,
            // `relation near "is near" { distance 0m..1.5m }`: settings, filled.
            Rule::relation_item => {
                if let Some(body) = children.iter().find(|c| c.as_rule() == Rule::placements) {
                    let stmts: Vec<Pair<Rule>> = body.clone().into_inner().collect();
                    self.block(self.first(body)?, self.last(body)?, &stmts, level, Style::Fill, p)?;
                }
            }
            Rule::region_item | Rule::preset_item | Rule::camera_item | Rule::visible_item => {
                let (open, close) = self.braces(p)?;
                let stmts = of(&[Rule::region_stmt, Rule::preset_param, Rule::camera_stmt]);
                self.block(open, close, &stmts, level, Style::Fill, p)?;
            }
            Rule::concept_item | Rule::modifier_item => {
                let body = children.iter().find(|c| c.as_rule() == Rule::concept_body)?;
                let stmts: Vec<Pair<Rule>> = body.clone().into_inner().collect();
                self.block(self.first(body)?, self.last(body)?, &stmts, level, Style::Lines, p)?;
                for s in &stmts {
                    for c in s.clone().into_inner() {
                        match c.as_rule() {
                            Rule::shape_block => {
                                let parts = c.into_inner().find(|c| c.as_rule() == Rule::parts)?;
                                self.parts(&parts, level + 1)?;
                            }
                            Rule::attr_values => self.inline_list(&c)?,
                            _ => {}
                        }
                    }
                }
            }
            Rule::question_item => {
                let (open, close) = self.braces(p)?;
                self.block(open, close, &of(&[Rule::question_stmt]), level, Style::Lines, p)?;
            }
            Rule::rules_item => {
                let (open, close) = self.braces(p)?;
                let rules = of(&[Rule::rule_item]);
                self.block(open, close, &rules, level, Style::Lines, p)?;
                for r in &rules {
                    let (open, close) = self.braces(r)?;
                    let stmts: Vec<Pair<Rule>> =
                        r.clone().into_inner().filter(|c| c.as_rule() == Rule::rule_stmt).collect();
                    self.block(open, close, &stmts, level + 1, Style::Lines, r)?;
                }
            }
            _ => {}
        }
        Some(())
    }

    /// A `{ … }` of shape parts, one per line.
    fn parts(&mut self, parts: &Pair<Rule>, level: usize) -> Option<()> {
        let stmts: Vec<Pair<Rule>> = parts.clone().into_inner().collect();
        self.block(self.first(parts)?, self.last(parts)?, &stmts, level, Style::Lines, parts)
    }

    /// Lay out the statements `stmts` of the block `open..=close` of `owner`, whose first line is
    /// indented `level` steps.
    fn block(
        &mut self,
        open: usize,
        close: usize,
        stmts: &[Pair<Rule>],
        level: usize,
        style: Style,
        owner: &Pair<Rule>,
    ) -> Option<()> {
        let comments = self.has_comments(open, close);
        if stmts.is_empty() {
            if comments {
                self.plan.sep[close] = Sep::Line { level, blank: false, comments: level + 1 };
            }
            return Some(());
        }
        if style == Style::Fill && !comments {
            let whole = self.flat_width(self.first(owner)?, close);
            // Settings are two spaces apart on one line, one more than `gap` counts.
            if whole.is_some_and(|w| 2 * level + w + stmts.len() - 1 <= MAX_WIDTH) {
                for s in &stmts[1..] {
                    let i = self.first(s)?;
                    self.plan.sep[i] = Sep::TwoSpaces;
                }
                return Some(());
            }
        }
        for (k, s) in stmts.iter().enumerate() {
            let i = self.first(s)?;
            if style == Style::Fill && k > 0 {
                let width = self.flat_width(i, self.last(s)?);
                self.plan.sep[i] = Sep::Fill { level: level + 1, width };
            } else {
                self.line(i, level + 1, k > 0);
            }
        }
        self.plan.sep[close] = Sep::Line { level, blank: false, comments: level + 1 };
        Some(())
    }

    /// `enum NAME { a, b }` on one line when it fits, else one variant per line.
    fn enum_list(&mut self, p: &Pair<Rule>, level: usize) -> Option<()> {
        let (open, close) = self.braces(p)?;
        let variants: Vec<Pair<Rule>> = p.clone().into_inner().filter(|c| c.as_rule() == Rule::ident).skip(1).collect();
        let Some(last_variant) = variants.last() else {
            return self.block(open, close, &[], level, Style::Lines, p);
        };
        let last = self.last(last_variant)?;
        let trailing = self.next_significant(last).filter(|&i| self.tokens[i].kind == TokenKind::Comma);
        let comments = self.has_comments(open, close);
        if let Some(t) = trailing.filter(|_| !comments) {
            self.plan.skip[t] = true;
        }
        let fits = !comments && self.flat_width(self.first(p)?, close).is_some_and(|w| 2 * level + w <= MAX_WIDTH);
        if fits {
            return Some(());
        }
        if let Some(t) = trailing {
            self.plan.skip[t] = false;
        } else {
            self.plan.suffix[last] = Some(",");
        }
        for (k, v) in variants.iter().enumerate() {
            self.line(self.first(v)?, level + 1, k > 0);
        }
        self.plan.sep[close] = Sep::Line { level, blank: false, comments: level + 1 };
        Some(())
    }

    /// `{ a = 1, b = 2 }`: always one line; a trailing comma is dropped unless comments sit in
    /// the list (then the list is left as written).
    fn inline_list(&mut self, p: &Pair<Rule>) -> Option<()> {
        let (open, close) = (self.first(p)?, self.last(p)?);
        if self.has_comments(open, close) {
            return Some(());
        }
        if let Some(before_close) = self.prev_significant(close).filter(|&i| i > open)
            && self.tokens[before_close].kind == TokenKind::Comma
        {
            self.plan.skip[before_close] = true;
        }
        Some(())
    }

    fn next_significant(&self, i: usize) -> Option<usize> {
        (i + 1..self.tokens.len()).find(|&j| !self.tokens[j].kind.is_trivia())
    }

    fn prev_significant(&self, i: usize) -> Option<usize> {
        (0..i).rev().find(|&j| !self.tokens[j].kind.is_trivia())
    }
}

//! Writes the tokens back out along the plan, putting each comment where it was: a comment that
//! followed a token on its line stays at the end of that line; a comment on a line of its own
//! stays on a line of its own, before the same token, indented like the code around it. Either
//! way the next token starts a new line, so a comment never swallows code.

use super::MAX_WIDTH;
use super::layout::{Plan, Sep, gap};
use crate::syntax::lexer::{Token, TokenKind};

const INDENT: &str = "  ";

pub(super) fn print(text: &str, tokens: &[Token], plan: &Plan) -> String {
    let mut p = Printer { text, out: String::with_capacity(text.len() + text.len() / 8), level: 0 };
    // Trivia seen since the last significant token: newlines and comments, in order.
    let mut newlines = 0usize;
    let mut comments: Vec<(usize, &str)> = Vec::new();
    let mut prev: Option<Token> = None;
    for (i, &t) in tokens.iter().enumerate() {
        match t.kind {
            TokenKind::Whitespace => newlines += t.text(text).matches('\n').count(),
            TokenKind::Bom => {}
            TokenKind::Comment | TokenKind::DocComment => {
                comments.push((newlines, t.text(text).trim_end()));
                newlines = 0;
            }
            _ if plan.skip[i] => {}
            _ => {
                p.gap(plan.sep[i], prev, t, &comments, newlines);
                p.out.push_str(t.text(text));
                if let Some(s) = plan.suffix[i] {
                    p.out.push_str(s);
                }
                prev = Some(t);
                comments.clear();
                newlines = 0;
            }
        }
    }
    // Comments after the last token: on their own lines at the left margin, or trailing.
    let end = Sep::Line { level: 0, blank: true, comments: 0 };
    p.comments(end, &comments);
    if !p.out.is_empty() {
        p.out.push('\n');
    }
    p.out
}

struct Printer<'a> {
    text: &'a str,
    out: String,
    /// Indentation of the current line's statement; continuation lines go one step deeper.
    level: usize,
}

impl Printer<'_> {
    fn newline(&mut self, blank: bool, level: usize) {
        if !self.out.is_empty() {
            self.out.push('\n');
            if blank {
                self.out.push('\n');
            }
        }
        for _ in 0..level {
            self.out.push_str(INDENT);
        }
    }

    fn column(&self) -> usize {
        self.out[self.out.rfind('\n').map_or(0, |i| i + 1)..].chars().count()
    }

    /// Write the comments that precede a token with separator `sep`; true if one was written
    /// (the token must then start a new line).
    fn comments(&mut self, sep: Sep, comments: &[(usize, &str)]) -> bool {
        let (level, blank_ok) = match sep {
            Sep::Line { comments, blank, .. } => (comments, blank),
            Sep::Fill { level, .. } => (level, false),
            Sep::Auto | Sep::TwoSpaces => (self.level + 1, false),
        };
        for &(newlines_before, c) in comments {
            if newlines_before == 0 && !self.out.is_empty() {
                self.out.push(' ');
            } else {
                self.newline(blank_ok && newlines_before > 1, level);
            }
            self.out.push_str(c);
        }
        !comments.is_empty()
    }

    /// Write what goes between the previous token and `t`.
    fn gap(&mut self, sep: Sep, prev: Option<Token>, t: Token, comments: &[(usize, &str)], newlines: usize) {
        let forced = self.comments(sep, comments);
        match sep {
            Sep::Line { level, blank, .. } => {
                self.newline(blank && newlines > 1, level);
                self.level = level;
            }
            Sep::Fill { level, width } => {
                let fits = width.is_some_and(|w| self.column() + 2 + w <= MAX_WIDTH);
                if forced || !fits {
                    self.newline(false, level);
                    self.level = level;
                } else {
                    self.out.push_str("  ");
                }
            }
            Sep::Auto | Sep::TwoSpaces if forced => self.newline(false, self.level + 1),
            Sep::TwoSpaces => self.out.push_str("  "),
            Sep::Auto => {
                if let Some(p) = prev {
                    self.out.push_str(gap(self.text, p, t));
                }
            }
        }
    }
}

//! Literals: names, numbers, values, strings (escapes decoded and checked).

use pest::iterators::Pair;

use super::{Builder, Children};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::{CmpOp, Span};
use crate::syntax::ast::*;
use crate::syntax::grammar::Rule;

impl Builder<'_> {
    pub(super) fn path(&self, p: Pair<Rule>) -> Path {
        let span = self.span(&p);
        Path { parts: Children::of(p).rest().map(|i| self.ident(i)).collect(), span }
    }

    pub(super) fn value(&mut self, p: Pair<Rule>) -> ValueLit {
        let mut c = Children::of(p);
        let first = c.next();
        match first.as_rule() {
            Rule::number => {
                let lo = self.number(first);
                match c.peek_rule() {
                    Some(_) => ValueLit::Range(lo, self.number(c.next())),
                    None => ValueLit::Num(lo),
                }
            }
            Rule::boolean => ValueLit::Bool(first.as_str() == "true", self.span(&first)),
            _ => ValueLit::Name(self.ident(first)),
        }
    }

    pub(super) fn number(&mut self, p: Pair<Rule>) -> Num {
        let span = self.span(&p);
        let mut c = Children::of(p);
        let digits = c.next();
        let value = digits.as_str().parse::<f64>().unwrap_or(f64::NAN);
        if !value.is_finite() {
            self.diagnostics.push(Diagnostic::error(
                codes::INVALID_LITERAL,
                span,
                format!("number `{}` is too large", digits.as_str()),
            ));
        }
        let unit = c.peek_rule().map(|_| self.ident(c.next()));
        Num { value: if value.is_finite() { value } else { 0.0 }, unit, span }
    }

    pub(super) fn vec3(&mut self, p: Pair<Rule>) -> [Num; 3] {
        let mut c = Children::of(p);
        let x = self.number(c.next());
        let y = self.number(c.next());
        [x, y, self.number(c.next())]
    }

    pub(super) fn int(&mut self, p: Pair<Rule>) -> u32 {
        p.as_str().parse::<u32>().unwrap_or_else(|_| {
            let span = self.span(&p);
            self.diagnostics.push(Diagnostic::error(
                codes::INVALID_LITERAL,
                span,
                format!("integer `{}` is too large", p.as_str()),
            ));
            0
        })
    }

    pub(super) fn string(&mut self, p: Pair<Rule>) -> Str {
        let span = self.span(&p);
        let raw = p.as_str();
        let value = if let Some(inner) = raw.strip_prefix("\"\"\"").and_then(|s| s.strip_suffix("\"\"\"")) {
            // A raw string that starts on the next line keeps only its content lines.
            inner.strip_prefix('\n').or_else(|| inner.strip_prefix("\r\n")).unwrap_or(inner).to_string()
        } else {
            self.unescape(&raw[1..raw.len() - 1], span.start as usize + 1)
        };
        Str { value, span }
    }

    pub(super) fn unescape(&mut self, s: &str, offset: usize) -> String {
        let mut out = String::with_capacity(s.len());
        let mut chars = s.char_indices();
        while let Some((i, ch)) = chars.next() {
            if ch != '\\' {
                out.push(ch);
                continue;
            }
            match chars.next() {
                Some((_, '"')) => out.push('"'),
                Some((_, '\\')) => out.push('\\'),
                Some((_, 'n')) => out.push('\n'),
                Some((_, 't')) => out.push('\t'),
                Some((j, other)) => {
                    let span = self.span_at(offset + i, offset + j + other.len_utf8());
                    self.diagnostics.push(
                        Diagnostic::error(
                            codes::INVALID_LITERAL,
                            span,
                            format!("unknown escape `\\{other}` in string"),
                        )
                        .with_help("the escapes are `\\\"`, `\\\\`, `\\n` and `\\t`"),
                    );
                }
                None => {}
            }
        }
        out
    }
}

pub(super) fn cmp_op(s: &str) -> CmpOp {
    match s {
        "==" => CmpOp::Eq,
        "!=" => CmpOp::Ne,
        "<" => CmpOp::Lt,
        "<=" => CmpOp::Le,
        ">" => CmpOp::Gt,
        _ => CmpOp::Ge,
    }
}

pub(super) fn span_text(text: &str, s: Span) -> &str {
    &text[s.start as usize..s.end as usize]
}

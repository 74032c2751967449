//! Rule conditions and `when` expressions.

use pest::iterators::Pair;

use super::literals::{cmp_op, span_text};
use super::{Builder, Children, MAX_NESTING, not_chain, too_deep};
use crate::syntax::ast::*;
use crate::syntax::grammar::Rule;

impl Builder<'_> {
    pub(super) fn expr(&mut self, p: Pair<Rule>) -> Expr {
        let span = self.span(&p);
        let rule = p.as_rule();
        if rule == Rule::not_expr && not_chain(p.clone()) > MAX_NESTING {
            // `not not not …` nests without parentheses; the same limit applies.
            self.diagnostics.push(too_deep(span));
            return Expr { kind: ExprKind::Bool(false), span };
        }
        let mut c = Children::of(p);
        let kind = match rule {
            Rule::expr | Rule::and_expr => {
                let mut terms: Vec<Expr> = c.rest().map(|t| self.expr(t)).collect();
                if terms.len() == 1 {
                    return terms.pop().expect("one term");
                }
                if rule == Rule::expr { ExprKind::Or(terms) } else { ExprKind::And(terms) }
            }
            Rule::not_expr => ExprKind::Not(Box::new(self.expr(c.next()))),
            Rule::boolean => ExprKind::Bool(span_text(self.text, span) == "true"),
            Rule::has_expr => ExprKind::Has(self.ident(c.next())),
            Rule::exists_expr => {
                let var = self.ident(c.next());
                let filter = self.idents(Children::of(c.next()));
                let cond = c.peek_rule().map(|_| Box::new(self.expr(c.next())));
                ExprKind::Exists { var, filter, cond }
            }
            Rule::count_expr => {
                let filter = self.idents(Children::of(c.next()));
                let op = cmp_op(c.next().as_str());
                ExprKind::Count { filter, op, n: self.int(c.next()) }
            }
            Rule::in_expr => {
                let var = self.ident(c.next());
                ExprKind::In { var, region: self.ident(c.next()) }
            }
            Rule::related_expr => {
                let var = self.ident(c.next());
                let relation = self.ident(c.next());
                ExprKind::Related { var, relation, to: self.ident(c.next()) }
            }
            _ => {
                let path = self.path(c.next());
                let op = cmp_op(c.next().as_str());
                let rhs = c.next();
                if rhs.as_rule() == Rule::attr_ref {
                    ExprKind::CmpAttrs { left: path, op, right: self.path(rhs) }
                } else {
                    ExprKind::Cmp { path, op, value: self.value(rhs) }
                }
            }
        };
        Expr { kind, span }
    }
}

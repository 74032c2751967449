//! Rule conditions and `when` expressions.

use pest::iterators::Pair;

use super::literals::{cmp_op, span_text};
use super::{Builder, Children};
use crate::syntax::ast::*;
use crate::syntax::grammar::{Rule, is_keyword};

impl Builder<'_> {
    pub(super) fn expr(&mut self, mut p: Pair<Rule>) -> Expr {
        // An `or` or `and` of one term (every level of brackets has two) is that term: step
        // down to it here rather than recurse, so the tree builder uses as little stack per
        // level of nesting as the budget ([`super::MAX_NESTING`]) assumes.
        while matches!(p.as_rule(), Rule::expr | Rule::and_expr) {
            let mut terms = p.clone().into_inner().filter(|t| !is_keyword(t.as_rule()));
            match (terms.next(), terms.next()) {
                (Some(only), None) => p = only,
                _ => break,
            }
        }
        let span = self.span(&p);
        let rule = p.as_rule();
        let mut c = Children::of(p);
        let kind = match rule {
            Rule::expr | Rule::and_expr => {
                let mut terms = Vec::new();
                for t in c.rest() {
                    terms.push(self.expr(t));
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

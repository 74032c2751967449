//! Questions and ground-truth rules.

use super::expr::Scope;
use super::lower::{Checker, duplicate_statement};
use super::names::{Namespace, unknown};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::diag::suggest::suggest;
use crate::ir::*;
use crate::syntax::ast::{self, Item, ItemKind, QuestionStmt, RuleStmt};

const SELECTIONS: &[&str] = &["priority", "best_fit"];

impl Checker<'_> {
    pub(crate) fn lower_questions(&mut self, items: &[(u32, &Item)]) {
        for (_, item) in items {
            let ItemKind::Question { name, stmts } = &item.kind else { continue };
            if self.questions.span(&name.name) != Some(name.span) {
                continue;
            }
            let mut text: Option<(String, Span)> = None;
            let mut options = Namespace::<String>::default();
            for s in stmts {
                match s {
                    QuestionStmt::Text(t) => match &text {
                        Some((_, prev)) => {
                            let prev = *prev;
                            self.error(duplicate_statement("text", t.span, prev));
                        }
                        None => text = Some((t.value.clone(), t.span)),
                    },
                    QuestionStmt::Option { name, text } => {
                        options.declare(name, text.value.clone(), |_| "an option of this question", &mut self.diags);
                    }
                }
            }
            if item.broken {
                // A statement that failed to parse may be the missing one.
            } else if text.is_none() {
                self.error(
                    Diagnostic::error(
                        codes::MISSING_STATEMENT,
                        name.span,
                        format!("question `{}` has no `text`", name.name),
                    )
                    .with_label("what is asked?")
                    .with_help("add `text \"…\"` with the question put to the model"),
                );
            }
            if !item.broken && options.len() < 2 {
                self.error(
                    Diagnostic::error(
                        codes::MISSING_STATEMENT,
                        name.span,
                        format!("question `{}` needs at least two options", name.name),
                    )
                    .with_label(format!("{} option(s)", options.len()))
                    .with_help("add `option NAME \"…\"` lines; their letters are A, B, C … in order"),
                );
            }
            self.option_spans.push(options.names().filter_map(|n| options.span(n)).collect());
            let options = options
                .names()
                .map(|n| AnswerOption { name: n.to_string(), text: options.get(n).cloned().unwrap_or_default() })
                .collect();
            self.d.questions.push(Question {
                name: name.name.clone(),
                text: text.map(|t| t.0).unwrap_or_default(),
                options,
                span: item.span,
            });
        }
    }

    pub(crate) fn lower_rules(&mut self, entry: u32, items: &[(u32, &Item)]) {
        let blocks: Vec<&Item> =
            items.iter().filter(|(_, i)| matches!(i.kind, ItemKind::Rules { .. })).map(|(_, i)| *i).collect();
        let domain_line = items.iter().find(|(f, i)| *f == entry && matches!(i.kind, ItemKind::Domain(_)));
        match (blocks.first(), domain_line) {
            (None, Some((_, d))) => self.error(
                Diagnostic::error(codes::RULES_BLOCK, d.span, format!("domain `{}` has no `rules` block", self.d.name))
                    .with_label("no ground-truth rules")
                    .with_help("add `rules priority { … }` or `rules best_fit { … }`"),
            ),
            (Some(first), _) => {
                for extra in &blocks[1..] {
                    self.error(
                        Diagnostic::error(codes::RULES_BLOCK, extra.span, "a domain has exactly one `rules` block")
                            .with_label("second `rules` block")
                            .with_related(first.span, "first `rules` block")
                            .with_help("merge the rules into one block; their order is their priority"),
                    );
                }
                if let ItemKind::Rules { selection, rules } = &first.kind {
                    self.lower_rule_block(selection, rules, first.broken);
                }
            }
            (None, None) => {}
        }
    }

    fn lower_rule_block(&mut self, selection: &ast::Ident, rules: &[ast::RuleDecl], broken: bool) {
        self.d.selection = match selection.name.as_str() {
            "priority" => Selection::Priority,
            "best_fit" => Selection::BestFit,
            _ => {
                let d = Diagnostic::error(
                    codes::UNKNOWN_SELECTION,
                    selection.span,
                    format!("unknown selection `{}`", selection.name),
                )
                .with_label("not `priority` or `best_fit`");
                let d = match suggest(&selection.name, SELECTIONS.iter().copied()) {
                    Some(s) => d.with_help(format!("did you mean `{s}`?")),
                    None => d.with_help(
                        "`priority`: first matching rule decides; `best_fit`: the best-covering matching rule",
                    ),
                };
                self.error(d);
                return;
            }
        };
        let mut names = Namespace::<()>::default();
        let mut first_expect: Option<(QuestionId, Span)> = None;
        for r in rules {
            if !names.declare(&r.name, (), |_| "a rule", &mut self.diags) {
                continue;
            }
            let (rule, expect) = self.lower_rule(r, broken);
            if let (Selection::Priority, Some((question, expect_span))) = (self.d.selection, expect) {
                match first_expect {
                    None => first_expect = Some((question, expect_span)),
                    Some((q, span)) if q != question => {
                        let (a, b) = (&self.d.questions[q.index()].name, &self.d.questions[question.index()].name);
                        let d = Diagnostic::error(
                            codes::MIXED_QUESTIONS,
                            expect_span,
                            format!(
                                "`priority` rules must all expect options of one question, but this one uses `{b}`"
                            ),
                        )
                        .with_label(format!("question `{b}`"))
                        .with_related(span, format!("the first rule uses `{a}`"))
                        .with_help("use `rules best_fit` for rules that ask different questions");
                        self.error(d);
                        continue;
                    }
                    Some(_) => {}
                }
            }
            if let Some(rule) = rule {
                self.d.rules.push(rule);
            }
        }
    }

    /// The rule (`None` on errors) and, when its `expect` resolved, the question it uses.
    fn lower_rule(&mut self, r: &ast::RuleDecl, broken: bool) -> (Option<Rule>, Option<(QuestionId, Span)>) {
        let mut when: Option<Span> = None;
        let mut expect: Option<(QuestionId, u32, Span)> = None;
        let mut expect_seen: Option<Span> = None;
        let mut elements: Option<Span> = None;
        let mut safe: Option<Span> = None;
        let mut rule = Rule {
            name: r.name.name.clone(),
            id: RuleId(self.d.rules.len() as u32),
            rationale: r.doc.clone(),
            question: QuestionId(0),
            expect: 0,
            when: None,
            elements: ConceptSet::EMPTY,
            safe: false,
            span: r.span,
        };
        let mut ok = true;
        for s in &r.stmts {
            let (key, span, slot) = match s {
                RuleStmt::When(_, sp) => ("when", *sp, &mut when),
                RuleStmt::Expect(p) => ("expect", p.span, &mut expect_seen),
                RuleStmt::Elements(_, sp) => ("elements", *sp, &mut elements),
                RuleStmt::Safe(sp) => ("safe", *sp, &mut safe),
            };
            if let Some(prev) = *slot {
                self.error(duplicate_statement(key, span, prev));
                ok = false;
                continue;
            }
            *slot = Some(span);
            match s {
                RuleStmt::When(e, _) => match self.lower_expr(e, &mut Scope::default()) {
                    Some(e) => rule.when = Some(e),
                    None => ok = false,
                },
                RuleStmt::Expect(p) => match self.lower_expect(p) {
                    Some((q, o)) => expect = Some((q, o, p.span)),
                    None => ok = false,
                },
                RuleStmt::Elements(names, _) => {
                    for n in names {
                        self.refer(n, self.concepts.span(&n.name));
                        match self.concepts.get(&n.name) {
                            Some(id) if id.index() < MAX_CONCEPTS => rule.elements = rule.elements.with(*id),
                            Some(_) => ok = false, // past the set width: reported as R0044
                            None => {
                                let d = unknown("concept", n, self.concepts.names());
                                self.error(d);
                                ok = false;
                            }
                        }
                    }
                }
                RuleStmt::Safe(_) => rule.safe = true,
            }
        }
        if expect_seen.is_none() {
            if broken {
                return (None, None); // the `expect` may be the statement that failed to parse
            }
            self.error(
                Diagnostic::error(
                    codes::MISSING_STATEMENT,
                    r.name.span,
                    format!("rule `{}` has no `expect`", r.name.name),
                )
                .with_label("what is the right answer?")
                .with_help("add `expect QUESTION.OPTION`"),
            );
            return (None, None);
        }
        let Some((q, o, span)) = expect else { return (None, None) };
        rule.question = q;
        rule.expect = o;
        (ok.then_some(rule), Some((q, span)))
    }

    /// Resolve `QUESTION.OPTION` to the question and the option's index.
    fn lower_expect(&mut self, p: &ast::Path) -> Option<(QuestionId, u32)> {
        let [q, o] = p.parts.as_slice() else {
            self.error(
                Diagnostic::error(codes::BAD_REFERENCE, p.span, "expected `QUESTION.OPTION`")
                    .with_label("not an answer option")
                    .with_help("name the question and its expected option, e.g. `expect drive.stop`"),
            );
            return None;
        };
        let Some(&qid) = self.questions.get(&q.name) else {
            let d = unknown("question", q, self.questions.names());
            self.error(d);
            return None;
        };
        self.refer(q, self.questions.span(&q.name));
        let question = &self.d.questions[qid.index()];
        match question.options.iter().position(|x| x.name == o.name) {
            Some(i) => {
                let decl = self.option_spans.get(qid.index()).and_then(|o| o.get(i)).copied();
                self.refer(o, decl);
                Some((qid, i as u32))
            }
            None => {
                let qname = question.name.clone();
                let d = unknown("option", o, question.options.iter().map(|x| x.name.as_str()))
                    .with_label(format!("question `{qname}` has no such option"));
                self.error(d);
                None
            }
        }
    }
}

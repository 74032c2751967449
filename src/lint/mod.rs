//! Lattice lints for `revelio check`: warnings (`R0100`–`R0199`) that only an enumerated lattice
//! can give. Every valid set of up to [`DEFAULT_MAX_SIZE`] concepts is judged by the oracle once;
//! the findings summarise that pass, each with one example set so the author can reproduce it with
//! `revelio oracle`.
//!
//! | code  | finding |
//! |-------|---------|
//! | R0100 | a concept appears in no valid set |
//! | R0101 | a rule is never selected (shadowed, or its condition never holds) |
//! | R0102 | a rule leaves the expected answer undetermined for some valid set |
//! | R0103 | best fit: two rules with different answers tie (same score and specificity) for some valid set |
//! | R0104 | an answer option is never expected |
//! | R0105 | a modifier has no possible target |
//! | R0106 | no rule matches some valid set |
//!
//! Memory grows with the lattice and linearly with the rules: per rule, the rules that shadow
//! it or tie with it are tallied for at most [`TRACKED`] partners (a rule with more says "at
//! least"), never in a rule × rule table.
//!
//! A lattice past the limit (`--max-sets`) is not enumerated: R0100 and R0105 stay exact (from
//! the lattice's [`Diagram`] and the target masks), and the rule lints judge a stated sample
//! ([`Sample`]): every set of the sizes that fit, then the same number of sets drawn uniformly
//! from each larger size. A finding with an example set (R0102, R0103, R0106) is then still a
//! fact; one that says "never" (R0101, R0104) is a bound, and every such diagnostic names the
//! method in its help.

use crate::anchor::Tri;
use crate::diag::{Diagnostic, Label, Severity};
use crate::ir::{ConceptSet, Domain, Selection, Span};
use crate::lattice::{DEFAULT_MAX_SETS, DEFAULT_MAX_SIZE, Diagram, Lattice, PROGRESS_EVERY, Progress, Validity, quiet};
use crate::oracle::{self, Decision, Oracle, explain, set_text};

/// Partners (shadowing or tying rules) tallied per rule.
pub const TRACKED: usize = 8;

/// The lattice the lints judge: sets of up to `max_size` concepts, at most `max_sets` of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    pub max_size: usize,
    pub max_sets: u64,
}

impl Default for Limits {
    fn default() -> Limits {
        Limits { max_size: DEFAULT_MAX_SIZE, max_sets: DEFAULT_MAX_SETS }
    }
}

/// Warnings computed over the lattice of a compiled domain (sets of up to
/// [`DEFAULT_MAX_SIZE`] concepts), or R0070 when that lattice is past [`DEFAULT_MAX_SETS`].
pub fn lint_domain(domain: &Domain) -> Vec<Diagnostic> {
    lint_domain_with(domain, Limits::default(), &mut quiet)
}

/// [`lint_domain`] with chosen limits, reporting progress (counting, enumerating, judging).
pub fn lint_domain_with(domain: &Domain, limits: Limits, progress: Progress) -> Vec<Diagnostic> {
    let validity = Validity::new(domain);
    let diagram = Diagram::build(&validity, limits.max_size);
    if diagram.total() <= u128::from(limits.max_sets) {
        return match Lattice::build(domain, limits.max_size, limits.max_sets, progress) {
            Ok(lattice) => lint_lattice_with(domain, &lattice, progress),
            Err(too_large) => vec![too_large.diagnostic()],
        };
    }
    lint_sampled(domain, &validity, &diagram, Sample::plan(&diagram, SAMPLED_SETS), progress)
}

/// Sets the rule lints judge when the lattice is past the limit.
pub const SAMPLED_SETS: u64 = 100_000;

/// Which sets the rule lints judge past the limit: every set of sizes `1..=exhaustive`, then
/// `per_size` sets drawn uniformly (a fixed seed, so the output is deterministic) from each
/// larger size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sample {
    pub exhaustive: usize,
    pub per_size: u64,
    pub max_size: usize,
}

impl Sample {
    /// The plan for a budget of `budget` sets: whole sizes while they fit half of it, the rest
    /// shared among the larger sizes.
    pub fn plan(diagram: &Diagram, budget: u64) -> Sample {
        let counts = diagram.counts();
        let mut used = 0u128;
        let mut exhaustive = 0;
        for (k, &c) in counts.iter().enumerate().skip(1) {
            if used + c > u128::from(budget / 2) {
                break;
            }
            used += c;
            exhaustive = k;
        }
        let larger = (diagram.max_size() - exhaustive).max(1) as u64;
        let per_size = (budget - used as u64) / larger;
        Sample { exhaustive, per_size, max_size: diagram.max_size() }
    }

    /// What the method guarantees, for the help of a diagnostic with `code`: a finding that
    /// says "never" (R0101, R0104) is always reported when true and may be false for a rare
    /// rule or option; any other names a judged set that shows it and may miss one.
    pub fn method(&self, code: &str) -> String {
        let whole = match self.exhaustive {
            0 => String::new(),
            1 => "every valid set of 1 concept and ".into(),
            k => format!("every valid set of up to {k} concepts and "),
        };
        let judged = format!(
            "not exhaustive — the lattice is past `--max-sets`, so the rules were judged on {whole}{} sets drawn \
             uniformly from each larger size up to {}",
            self.per_size, self.max_size
        );
        let bound = match code {
            "R0101" | "R0104" => format!(
                "nothing that is never selected is missed, but a rule or option that decides at least 1 in {} \
                 sets of some drawn size is reported falsely with probability under 5% (per rule)",
                (self.per_size / 3).max(1)
            ),
            _ => "the example set shows the finding; sets no judged set showed may be missed".to_string(),
        };
        format!("{judged}: {bound} (raise `--max-sets` for an exhaustive check)")
    }
}

/// The lints of a lattice past the limit (see the module docs).
fn lint_sampled(
    domain: &Domain,
    validity: &Validity,
    diagram: &Diagram,
    plan: Sample,
    progress: Progress,
) -> Vec<Diagnostic> {
    use rand::SeedableRng;
    let mut sets: Vec<ConceptSet> = Vec::new();
    for k in 1..=plan.exhaustive {
        let _ = diagram.try_for_each_of_size(k, |s| {
            sets.push(s);
            std::ops::ControlFlow::<()>::Continue(())
        });
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    for k in plan.exhaustive + 1..=plan.max_size {
        let mut drawn = std::collections::HashSet::new();
        for _ in 0..plan.per_size {
            if let Some(s) = diagram.sample(k, &mut rng)
                && drawn.insert(s)
            {
                sets.push(s);
            }
        }
    }
    let survey = Survey::run(domain, &sets, progress);
    let mut out = Vec::new();
    concept_lints_of(domain, diagram.support(), validity.modifier_targets(), plan.max_size, &mut out);
    let mut rules = Vec::new();
    survey.rule_lints(domain, plan.max_size, &mut rules);
    survey.option_lints(domain, &mut rules);
    survey.no_rule_lint(domain, &mut rules);
    for d in &mut rules {
        let method = plan.method(d.code);
        d.help = Some(match d.help.take() {
            Some(h) => format!("{h}; {method}"),
            None => method,
        });
    }
    out.extend(rules);
    out
}

/// Warnings computed over an already enumerated lattice.
pub fn lint_lattice(domain: &Domain, lattice: &Lattice) -> Vec<Diagnostic> {
    lint_lattice_with(domain, lattice, &mut quiet)
}

fn lint_lattice_with(domain: &Domain, lattice: &Lattice, progress: Progress) -> Vec<Diagnostic> {
    let survey = Survey::run(domain, &lattice.sets, progress);
    let mut out = Vec::new();
    concept_lints_of(domain, lattice.support(), lattice.validity().modifier_targets(), lattice.max_size(), &mut out);
    survey.rule_lints(domain, lattice.max_size(), &mut out);
    survey.option_lints(domain, &mut out);
    survey.no_rule_lint(domain, &mut out);
    out
}

/// A finding with an example set and how many sets show it.
#[derive(Debug, Clone, Copy)]
struct Example {
    set: ConceptSet,
    count: usize,
}

impl Example {
    fn note(slot: &mut Option<Example>, set: ConceptSet) {
        match slot {
            Some(e) => e.count += 1,
            None => *slot = Some(Example { set, count: 1 }),
        }
    }
}

/// Per rule, the other rules met in some role (shadowing it, tying with it), each with an
/// example: the first [`TRACKED`] partners exactly, then only how many sets had another.
#[derive(Debug, Clone, Default)]
struct Partners {
    /// `(partner rule, example)`, in order of first meeting.
    kept: Vec<(usize, Example)>,
    /// Sets whose partner was not kept.
    more: usize,
}

impl Partners {
    fn note(&mut self, partner: usize, set: ConceptSet) {
        if let Some((_, e)) = self.kept.iter_mut().find(|(p, _)| *p == partner) {
            e.count += 1;
        } else if self.kept.len() < TRACKED {
            self.kept.push((partner, Example { set, count: 1 }));
        } else {
            self.more += 1;
        }
    }

    /// The kept partners in rule order.
    fn by_rule(&self) -> Vec<(usize, Example)> {
        let mut v = self.kept.clone();
        v.sort_by_key(|(p, _)| *p);
        v
    }
}

/// What judging every set of the lattice found, per rule and option.
struct Survey {
    selected: Vec<bool>,
    applies: Vec<bool>,
    /// Per rule: the rules that took a set where this rule applied.
    shadowed_by: Vec<Partners>,
    undetermined: Vec<Option<Example>>,
    /// Per rule: the rules that beat it in a best-fit tie with a different answer.
    ties: Vec<Partners>,
    /// Per question, per option: whether some set expects it.
    expected: Vec<Vec<bool>>,
    no_rule: Option<Example>,
}

impl Survey {
    fn run(domain: &Domain, sets: &[ConceptSet], progress: Progress) -> Survey {
        let n = domain.rules.len();
        let mut s = Survey {
            selected: vec![false; n],
            applies: vec![false; n],
            shadowed_by: vec![Partners::default(); n],
            undetermined: vec![None; n],
            ties: vec![Partners::default(); n],
            expected: domain.questions.iter().map(|q| vec![false; q.options.len()]).collect(),
            no_rule: None,
        };
        let oracle = Oracle::new(domain);
        let total = sets.len() as u64;
        for (i, &set) in sets.iter().enumerate() {
            if (i as u64).is_multiple_of(PROGRESS_EVERY) {
                progress("judging valid sets", i as u64, total);
            }
            // Lattice sets are valid by construction, so `judge` only fails if the validity masks
            // and the anchor graph disagree; such a set has nothing to lint.
            if let Ok(j) = oracle.judge(set) {
                s.record(domain, set, &j.conditions, j.decision);
            }
        }
        s
    }

    fn record(&mut self, domain: &Domain, set: ConceptSet, conditions: &[Tri], decision: Decision) {
        for (i, t) in conditions.iter().enumerate() {
            self.applies[i] |= *t == Tri::True;
        }
        match decision {
            Decision::Selected { rule, .. } => {
                self.selected[rule] = true;
                let r = &domain.rules[rule];
                if let Some(slot) = self.expected.get_mut(r.question.index()).and_then(|q| q.get_mut(r.expect as usize))
                {
                    *slot = true;
                }
                for (i, t) in conditions.iter().enumerate() {
                    if *t == Tri::True && i != rule {
                        self.shadowed_by[i].note(rule, set);
                    }
                }
                if domain.selection == Selection::BestFit {
                    for other in oracle::tied_later(domain, set, conditions, rule) {
                        let o = &domain.rules[other];
                        if (o.question, o.expect) != (r.question, r.expect) {
                            self.ties[other].note(rule, set);
                        }
                    }
                }
            }
            Decision::Undetermined { rule } => Example::note(&mut self.undetermined[rule], set),
            Decision::NoRule => Example::note(&mut self.no_rule, set),
        }
    }

    fn rule_lints(&self, domain: &Domain, max_size: usize, out: &mut Vec<Diagnostic>) {
        for (i, rule) in domain.rules.iter().enumerate() {
            // An undetermined rule is reported by R0102 alone: until its condition is decided,
            // whether it is shadowed (and what reordering would help) is not known either.
            if !self.selected[i] && self.undetermined[i].is_none() {
                out.push(self.never_selected(domain, i, max_size));
            }
            if let Some(ex) = self.undetermined[i] {
                out.push(undetermined(domain, i, ex, self.never_selected_note(domain, i)));
            }
            let ties = self.ties[i].by_rule();
            for (k, &(winner, ex)) in ties.iter().enumerate() {
                let w = &domain.rules[winner];
                let also = match self.ties[i].more {
                    more if more > 0 && k + 1 == ties.len() => {
                        format!("; `{}` also ties with other rules for {more} more valid sets", rule.name)
                    }
                    _ => String::new(),
                };
                out.push(Diagnostic {
                        code: "R0103",
                        severity: Severity::Warning,
                        message: format!(
                            "rules `{}` and `{}` tie with different answers for {}{}",
                            w.name,
                            rule.name,
                            set_text(domain, ex.set),
                            others(ex.count)
                        ),
                        span: Some(rule.span),
                        label: "loses the tie only because it is declared later".into(),
                        related: vec![Label { span: w.span, message: "wins the tie by declaration order".into() }],
                        help: Some(format!(
                            "make one rule fit these sets better (add an element to `{}` or `{}`), or make their conditions exclusive{also}",
                            w.name, rule.name
                        )),
                });
            }
        }
    }

    /// For an undetermined rule that is also never selected: the rule selected instead where
    /// its condition holds, as a note for R0102.
    fn never_selected_note(&self, domain: &Domain, i: usize) -> Option<Label> {
        if self.selected[i] {
            return None;
        }
        let (winner, ex) = self.shadowed_by[i].by_rule().into_iter().max_by_key(|(_, e)| e.count)?;
        Some(Label {
            span: domain.rules[winner].span,
            message: format!(
                "where `{}` holds it is never selected: this rule is, e.g. for {}",
                domain.rules[i].name,
                set_text(domain, ex.set)
            ),
        })
    }

    fn never_selected(&self, domain: &Domain, i: usize, max_size: usize) -> Diagnostic {
        let rule = &domain.rules[i];
        let mut d = Diagnostic {
            code: "R0101",
            severity: Severity::Warning,
            message: String::new(),
            span: Some(rule.span),
            label: "never selected".into(),
            related: vec![],
            help: None,
        };
        if !self.applies[i] {
            d.message = format!(
                "rule `{}` is never selected: its condition holds for no valid set of up to {max_size} concepts",
                rule.name
            );
            d.help = Some("check the condition against the concepts' attributes, or remove the rule".into());
            return d;
        }
        // Name the rule that takes most of the sets this one applies to (the first on a tie).
        let shadows = self.shadowed_by[i].by_rule();
        let Some(&(winner, ex)) = shadows.iter().rev().max_by_key(|(_, e)| e.count) else {
            d.message = format!(
                "rule `{}` is never selected: wherever its condition holds, the answer is undetermined",
                rule.name
            );
            d.help = Some("resolve the undetermined rules reported for these sets (R0102)".into());
            return d;
        };
        let w = &domain.rules[winner];
        let more = match (shadows.len(), self.shadowed_by[i].more) {
            (n, m) if m > 0 => format!(" and at least {n} other rules"),
            (1, _) => String::new(),
            (2, _) => " and 1 other rule".into(),
            (n, _) => format!(" and {} other rules", n - 1),
        };
        d.message = format!("rule `{}` is shadowed by `{}`{more}", rule.name, w.name);
        d.related
            .push(Label { span: w.span, message: format!("selected instead, e.g. for {}", set_text(domain, ex.set)) });
        d.help = Some(match domain.selection {
            Selection::Priority => {
                format!("move `{}` before `{}`, or narrow the condition of `{}`", rule.name, w.name, w.name)
            }
            Selection::BestFit => format!("give `{}` elements that fit its sets better than `{}`", rule.name, w.name),
        });
        d
    }

    fn option_lints(&self, domain: &Domain, out: &mut Vec<Diagnostic>) {
        for (qi, q) in domain.questions.iter().enumerate() {
            if !domain.rules.iter().any(|r| r.question.index() == qi) {
                continue;
            }
            for (oi, opt) in q.options.iter().enumerate() {
                if self.expected[qi][oi] {
                    continue;
                }
                let expecting: Vec<String> = domain
                    .rules
                    .iter()
                    .filter(|r| r.question.index() == qi && r.expect as usize == oi)
                    .map(|r| format!("`{}`", r.name))
                    .collect();
                let help = if expecting.is_empty() {
                    "no rule expects it; add a rule that does, or remove the option".to_string()
                } else {
                    format!("the rules that expect it ({}) are never selected", expecting.join(", "))
                };
                out.push(Diagnostic {
                    code: "R0104",
                    severity: Severity::Warning,
                    message: format!("option `{}.{}` is never the expected answer", q.name, opt.name),
                    span: Some(q.span),
                    label: format!("option `{}` is never expected", opt.name),
                    related: vec![],
                    help: Some(help),
                });
            }
        }
    }

    fn no_rule_lint(&self, domain: &Domain, out: &mut Vec<Diagnostic>) {
        let Some(ex) = self.no_rule else { return };
        let help = match domain.selection {
            Selection::Priority => "add a last rule without `when` as the default answer",
            Selection::BestFit => "add a rule whose condition holds for these sets",
        };
        out.push(Diagnostic {
            code: "R0106",
            severity: Severity::Warning,
            message: format!("no rule matches {}{}", set_text(domain, ex.set), others(ex.count)),
            span: domain.rules.last().map(|r| r.span),
            label: "no rule up to here matches".into(),
            related: vec![],
            help: Some(help.into()),
        });
    }
}

fn others(count: usize) -> String {
    match count {
        0 | 1 => String::new(),
        2 => " and 1 other valid set".into(),
        n => format!(" and {} other valid sets", n - 1),
    }
}

fn undetermined(domain: &Domain, i: usize, ex: Example, shadowed: Option<Label>) -> Diagnostic {
    let rule = &domain.rules[i];
    let oracle = Oracle::new(domain);
    // Re-judge the example to name the straddling attribute.
    let cause = oracle
        .judge(ex.set)
        .ok()
        .and_then(|j| rule.when.as_ref().and_then(|w| explain::unknown_cause(domain, &j.graph, w, &mut Vec::new())))
        .unwrap_or_else(|| "its condition is unknown".into());
    Diagnostic {
        code: "R0102",
        severity: Severity::Warning,
        message: format!(
            "rule `{}` leaves the expected answer undetermined for {}{}",
            rule.name,
            set_text(domain, ex.set),
            others(ex.count)
        ),
        span: Some(rule.span),
        label: cause,
        related: shadowed.into_iter().collect(),
        help: Some(
            "split the concept's range at the rule's threshold, or move the threshold outside the range, so that \
             every image of the set gets the same answer"
                .into(),
        ),
    }
}

/// R0105 and R0100, in concept order.
fn concept_lints_of(
    domain: &Domain,
    support: ConceptSet,
    targets: &[crate::lattice::ModifierTarget],
    max_size: usize,
    out: &mut Vec<Diagnostic>,
) {
    for c in domain.concepts.iter().take(crate::ir::MAX_CONCEPTS) {
        let target = targets.iter().find(|t| t.modifier == c.id);
        if let Some(t) = target.filter(|t| t.providers.difference(t.lacking).is_empty()) {
            out.push(no_target(domain, c.id, t.providers, c.span));
        } else if !support.contains(c.id) {
            out.push(Diagnostic {
                code: "R0100",
                severity: Severity::Warning,
                message: format!("concept `{}` appears in no valid set of up to {} concepts", c.name, max_size),
                span: Some(c.span),
                label: "in no valid set".into(),
                related: vec![],
                help: Some(excluded_help(domain, ConceptSet::single(c.id))),
            });
        }
    }
}

fn no_target(domain: &Domain, modifier: crate::ir::ConceptId, providers: ConceptSet, span: Span) -> Diagnostic {
    let m = &domain.concepts[modifier.index()];
    let filter = m.target.clone().unwrap_or_default();
    let (message, help) = if providers.is_empty() {
        (
            format!(
                "modifier `{}` has no possible target: no concept adds an entity matching `{}`",
                m.name,
                explain::filter_text(domain, &filter)
            ),
            "add a concept that adds such an entity, or widen the modifier's `target`".to_string(),
        )
    } else {
        (
            format!(
                "modifier `{}` has no possible target: every entity it can apply to lacks an attribute it sets",
                m.name
            ),
            format!(
                "give the kinds matching `{}` the attributes the modifier sets",
                explain::filter_text(domain, &filter)
            ),
        )
    };
    Diagnostic {
        code: "R0105",
        severity: Severity::Warning,
        message,
        span: Some(span),
        label: "no possible target".into(),
        related: vec![],
        help: Some(help),
    }
}

/// A hint for R0100: the constraint that rejects the concept even alone, when there is one.
fn excluded_help(domain: &Domain, single: ConceptSet) -> String {
    match crate::lattice::validate(domain, single) {
        Err(crate::lattice::Violation::Constraint { name, says, .. }) => {
            format!("constraint `{name}` ({says}) excludes it even alone")
        }
        _ => "every set holding it that is small enough violates a constraint; check the constraints that mention it"
            .into(),
    }
}

#[cfg(test)]
mod tests;

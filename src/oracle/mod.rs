//! Ground truth for a concept set: which question to ask, and which option is right.
//!
//! Rules are evaluated on the set's anchor scene graph ([`anchor::build`] + [`anchor::eval`]),
//! where a number may still be a range, so every image of a set shares one expected answer. A
//! rule's condition is three-valued; the decision is *undetermined* when a condition that could
//! change the outcome is unknown (a range straddles its threshold), and the oracle then refuses
//! to answer rather than guess.
//!
//! Selection ([`Selection`]):
//! - **priority**: the first rule, in order, whose condition is true decides; an unknown
//!   condition before it makes the decision undetermined.
//! - **best fit**: among the rules whose condition is true, the one with the highest element-fit
//!   score |set ∩ elements| decides; ties go to the more specific rule (the higher fraction
//!   |set ∩ elements| / |elements| of its elements covered), then to the rule declared first. An
//!   unknown condition of a rule that would win if true makes the decision undetermined.
//!
//! A `safe` rule (a safe-scene rule) only matches sets made entirely of its elements: its
//! condition is false for any set holding another concept, under either selection.

pub mod explain;

use crate::anchor::{self, AnchorGraph, Tri};
use crate::ir::{ConceptSet, Domain, QuestionId, RuleId, Selection};
use crate::lattice::{Validity, Violation};

pub use explain::{option_letter, set_text};

/// The ground truth of one valid set.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Verdict {
    /// The question to ask (the deciding rule's).
    pub question: QuestionId,
    /// Index of the expected option in the question's options.
    pub expected: u32,
    /// The rule that decided.
    pub rule: RuleId,
    /// One line saying why this rule decided.
    pub explanation: String,
    /// Best fit: the deciding rule's element-fit score; `None` under priority selection.
    pub score: Option<u32>,
}

impl Verdict {
    /// The expected option's letter (A, B, …).
    pub fn letter(&self) -> String {
        option_letter(self.expected)
    }
}

/// Why a set has no ground truth.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OracleError {
    #[error("invalid concept set {set}: {violation}")]
    Invalid { set: String, violation: Violation },
    #[error("the expected answer for {set} is undetermined: rule `{rule}` may or may not apply, because {cause}")]
    Undetermined { set: String, rule: String, cause: String },
    #[error("no rule matches {set}")]
    NoRule { set: String },
}

/// The ground truth of `set` (validated first).
pub fn evaluate(domain: &Domain, set: ConceptSet) -> Result<Verdict, OracleError> {
    Oracle::new(domain).evaluate(set)
}

/// How the rules decide one set, by index (no text): what the lints consume.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Rule `rule` decides, with its element-fit score (0 under priority).
    Selected {
        rule: usize,
        score: u32,
    },
    /// Rule `rule`'s unknown condition could change the outcome.
    Undetermined {
        rule: usize,
    },
    NoRule,
}

/// Every rule's condition on one set's anchor graph, and the resulting decision.
#[derive(Debug, Clone)]
pub struct Judgement {
    pub graph: AnchorGraph,
    /// One value per rule, in rule order (a rule without a condition is true).
    pub conditions: Vec<Tri>,
    pub decision: Decision,
}

/// An oracle for one domain: validity compiled once, then any number of sets.
pub struct Oracle<'d> {
    domain: &'d Domain,
    validity: Validity,
}

impl<'d> Oracle<'d> {
    pub fn new(domain: &'d Domain) -> Oracle<'d> {
        Oracle { domain, validity: Validity::new(domain) }
    }

    pub fn evaluate(&self, set: ConceptSet) -> Result<Verdict, OracleError> {
        let d = self.domain;
        let j = self.judge(set)?;
        match j.decision {
            Decision::Selected { rule, score } => {
                let r = &d.rules[rule];
                Ok(Verdict {
                    question: r.question,
                    expected: r.expect,
                    rule: r.id,
                    explanation: self.explanation(&j, rule, score),
                    score: (d.selection == Selection::BestFit).then_some(score),
                })
            }
            Decision::Undetermined { rule } => {
                let cond = d.rules[rule].when.as_ref();
                let cause = cond
                    .and_then(|c| explain::unknown_cause(d, &j.graph, c, &mut Vec::new()))
                    .unwrap_or_else(|| "its condition is unknown".into());
                Err(OracleError::Undetermined { set: set_text(d, set), rule: d.rules[rule].name.clone(), cause })
            }
            Decision::NoRule => Err(OracleError::NoRule { set: set_text(d, set) }),
        }
    }

    /// Validate `set`, build its anchor graph and decide, without composing text.
    pub fn judge(&self, set: ConceptSet) -> Result<Judgement, OracleError> {
        let d = self.domain;
        let invalid = |violation| OracleError::Invalid { set: set_text(d, set), violation };
        self.validity.check(set).map_err(|v| invalid(v.resolve(d)))?;
        // The masks mirror `anchor::build`; should they ever disagree, its error still names
        // the modifier.
        let graph = anchor::build(d, set).map_err(|e| match e {
            anchor::AnchorError::NoTarget { modifier } => invalid(Violation::NoTarget { modifier }),
            anchor::AnchorError::MissingAttr { modifier, attr, target } => {
                invalid(Violation::TargetLacksAttr { modifier, attr, target })
            }
            anchor::AnchorError::NoRelationTarget { concept, entity, relation, target } => {
                invalid(Violation::NoRelationTarget { concept, entity, relation, target })
            }
        })?;
        let conditions: Vec<Tri> = (0..d.rules.len()).map(|i| condition(d, &graph, i)).collect();
        let decision = decide(d, set, &conditions);
        Ok(Judgement { graph, conditions, decision })
    }

    fn explanation(&self, j: &Judgement, rule: usize, score: u32) -> String {
        let d = self.domain;
        let r = &d.rules[rule];
        let why = match &r.when {
            None => "it has no condition".to_string(),
            Some(w) => {
                let mut s = format!("`{}` holds", explain::expr_text(d, w));
                if let Some(who) = explain::witness(d, &j.graph, w) {
                    s.push_str(&format!(" for {who}"));
                }
                s
            }
        };
        match d.selection {
            Selection::Priority => {
                format!("`{}` is the first rule (#{} of {}) that applies: {why}", r.name, rule + 1, d.rules.len())
            }
            Selection::BestFit => {
                let matching = j.conditions.iter().filter(|t| **t == Tri::True).count();
                let elements = d.set_names(j.graph.set.intersection(r.elements));
                let listed = elements.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ");
                let fit = if elements.is_empty() { String::new() } else { format!(" ({listed})") };
                let mut tie = String::new();
                let specific = less_specific(d, j.graph.set, &j.conditions, rule);
                if !specific.is_empty() {
                    tie.push_str(&format!(
                        "; it is more specific than {} (a higher fraction of its elements)",
                        quote_rules(d, &specific)
                    ));
                }
                let ties = tied_later(d, j.graph.set, &j.conditions, rule);
                if !ties.is_empty() {
                    tie.push_str(&format!("; it ties with {} and is declared first", quote_rules(d, &ties)));
                }
                format!(
                    "`{}` fits best among {matching} matching rule{}: {score} of the set's concepts {} among its \
                     elements{fit}{tie}; {why}",
                    r.name,
                    if matching == 1 { "" } else { "s" },
                    if score == 1 { "is" } else { "are" }
                )
            }
        }
    }
}

/// Rule `rule`'s condition on a set's anchor graph: its `when` (true when absent), and for a
/// safe rule also that every concept of the set is one of its elements.
pub fn condition(domain: &Domain, graph: &AnchorGraph, rule: usize) -> Tri {
    let r = &domain.rules[rule];
    if r.safe && !graph.set.is_subset_of(r.elements) {
        return Tri::False;
    }
    r.when.as_ref().map_or(Tri::True, |w| anchor::eval(domain, graph, w, &mut Vec::new()))
}

/// The element-fit score of rule `rule` for `set`.
pub fn score(domain: &Domain, set: ConceptSet, rule: usize) -> u32 {
    set.intersection(domain.rules[rule].elements).len() as u32
}

/// Best fit: how rules `a` and `b` rank for `set` before declaration order breaks the tie —
/// by score, then by the fraction of their elements covered (compared exactly, as
/// `score_a / |elements_a|` vs `score_b / |elements_b|`; a rule without elements covers 0).
pub fn fit_cmp(domain: &Domain, set: ConceptSet, a: usize, b: usize) -> std::cmp::Ordering {
    let (sa, sb) = (u64::from(score(domain, set, a)), u64::from(score(domain, set, b)));
    let (ea, eb) = (domain.rules[a].elements.len() as u64, domain.rules[b].elements.len() as u64);
    sa.cmp(&sb).then_with(|| (sa * eb).cmp(&(sb * ea)))
}

/// Best fit: whether rule `a` beats rule `b` for `set` (declaration order last).
fn beats(domain: &Domain, set: ConceptSet, a: usize, b: usize) -> bool {
    fit_cmp(domain, set, a, b).then(b.cmp(&a)).is_gt()
}

/// The decision of the domain's selection given every rule's condition value.
pub fn decide(domain: &Domain, set: ConceptSet, conditions: &[Tri]) -> Decision {
    match domain.selection {
        Selection::Priority => {
            for (i, t) in conditions.iter().enumerate() {
                match t {
                    Tri::True => return Decision::Selected { rule: i, score: score(domain, set, i) },
                    Tri::Unknown => return Decision::Undetermined { rule: i },
                    Tri::False => {}
                }
            }
            Decision::NoRule
        }
        Selection::BestFit => {
            let mut best: Option<usize> = None;
            for (i, t) in conditions.iter().enumerate() {
                if *t == Tri::True && best.is_none_or(|b| beats(domain, set, i, b)) {
                    best = Some(i);
                }
            }
            // An unknown rule matters when, were it true, it would beat the winner.
            let upset = (0..conditions.len())
                .find(|&i| conditions[i] == Tri::Unknown && best.is_none_or(|b| beats(domain, set, i, b)));
            match (upset, best) {
                (Some(i), _) => Decision::Undetermined { rule: i },
                (None, Some(rule)) => Decision::Selected { rule, score: score(domain, set, rule) },
                (None, None) => Decision::NoRule,
            }
        }
    }
}

/// Best fit: the true rules declared after `winner` that rank equal to it (it beat them only by
/// declaration order).
pub fn tied_later(domain: &Domain, set: ConceptSet, conditions: &[Tri], winner: usize) -> Vec<usize> {
    (winner + 1..conditions.len())
        .filter(|&i| conditions[i] == Tri::True && fit_cmp(domain, set, i, winner).is_eq())
        .collect()
}

/// Best fit: the true rules with the winner's score that it beat by covering a higher fraction
/// of its elements.
pub fn less_specific(domain: &Domain, set: ConceptSet, conditions: &[Tri], winner: usize) -> Vec<usize> {
    (0..conditions.len())
        .filter(|&i| {
            conditions[i] == Tri::True
                && score(domain, set, i) == score(domain, set, winner)
                && fit_cmp(domain, set, i, winner).is_lt()
        })
        .collect()
}

fn quote_rules(domain: &Domain, rules: &[usize]) -> String {
    rules.iter().map(|&i| format!("`{}`", domain.rules[i].name)).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests;

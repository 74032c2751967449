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
//!   score |set ∩ elements| decides, ties going to the rule declared first; an unknown condition
//!   of a rule that would win if true makes the decision undetermined.

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
        })?;
        let conditions: Vec<Tri> = d
            .rules
            .iter()
            .map(|r| r.when.as_ref().map_or(Tri::True, |w| anchor::eval(d, &graph, w, &mut Vec::new())))
            .collect();
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
                let ties = tied_later(d, j.graph.set, &j.conditions, rule, score);
                let tie = if ties.is_empty() {
                    String::new()
                } else {
                    format!("; it ties with {} and is declared first", quote_rules(d, &ties))
                };
                format!(
                    "`{}` fits best among {matching} matching rule{}: {score} of the set's concepts are its elements{fit}{tie}; {why}",
                    r.name,
                    if matching == 1 { "" } else { "s" }
                )
            }
        }
    }
}

/// The element-fit score of rule `rule` for `set`.
pub fn score(domain: &Domain, set: ConceptSet, rule: usize) -> u32 {
    set.intersection(domain.rules[rule].elements).len() as u32
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
            let mut best: Option<(usize, u32)> = None;
            for (i, t) in conditions.iter().enumerate() {
                let s = score(domain, set, i);
                if *t == Tri::True && best.is_none_or(|(_, b)| s > b) {
                    best = Some((i, s));
                }
            }
            // An unknown rule matters when, were it true, it would beat or pre-empt the winner.
            let upset = conditions.iter().enumerate().find(|&(i, t)| {
                *t == Tri::Unknown
                    && best.is_none_or(|(w, b)| score(domain, set, i) > b || (score(domain, set, i) == b && i < w))
            });
            match (upset, best) {
                (Some((i, _)), _) => Decision::Undetermined { rule: i },
                (None, Some((rule, score))) => Decision::Selected { rule, score },
                (None, None) => Decision::NoRule,
            }
        }
    }
}

/// Best fit: the true rules declared after `winner` with the same score (the ones it beat only
/// by declaration order).
pub fn tied_later(domain: &Domain, set: ConceptSet, conditions: &[Tri], winner: usize, best: u32) -> Vec<usize> {
    (winner + 1..conditions.len()).filter(|&i| conditions[i] == Tri::True && score(domain, set, i) == best).collect()
}

fn quote_rules(domain: &Domain, rules: &[usize]) -> String {
    rules.iter().map(|&i| format!("`{}`", domain.rules[i].name)).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests;

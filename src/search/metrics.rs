//! Run metrics (paper section 4): PFM, MFR and Div, over the evaluated sets of a run.
//!
//! How non-answers enter: a set's failure rate is `wrong / answered` where *answered* counts the
//! observations whose reply named exactly one option (`correct` + `wrong`). `unparsed`,
//! `ambiguous`, `refusal`, `blocked`, `truncated` and `api_error` observations are neither
//! failures nor successes: they say nothing about the scene, only about the model's formatting or
//! the provider, and counting them as failures would plant fake failure modes wherever a provider
//! had an outage. They still spend budget, and are counted and reported per outcome. A set with
//! no answered observation has no failure rate (`None`) and never counts as a failure mode.
//! MFR is `wrong / all inferences` as in the paper, so unanswered observations lower it.
use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::ir::ConceptSet;
use crate::outcome::Outcome;

/// The observations of one concept set.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SetStats {
    pub set: ConceptSet,
    pub correct: u32,
    pub wrong: u32,
    /// Observations without a single parsed option, by outcome.
    pub unanswered: BTreeMap<Outcome, u32>,
}

impl SetStats {
    pub fn new(set: ConceptSet) -> SetStats {
        SetStats { set, ..SetStats::default() }
    }

    pub fn add(&mut self, outcome: Outcome) {
        match outcome {
            Outcome::Correct => self.correct += 1,
            Outcome::Wrong => self.wrong += 1,
            other => *self.unanswered.entry(other).or_default() += 1,
        }
    }

    pub fn answered(&self) -> u32 {
        self.correct + self.wrong
    }

    pub fn observations(&self) -> u32 {
        self.answered() + self.unanswered.values().sum::<u32>()
    }

    /// Failure rate over answered observations; `None` when none was answered.
    pub fn fr(&self) -> Option<f64> {
        let n = self.answered();
        (n > 0).then(|| f64::from(self.wrong) / f64::from(n))
    }

    /// The failure rate the search algorithms steer by: a set with no answer counts as 0.
    pub fn value(&self) -> f64 {
        self.fr().unwrap_or(0.0)
    }

    pub fn is_failure_mode(&self, threshold: f64) -> bool {
        self.fr().is_some_and(|fr| fr >= threshold)
    }

    /// 95 % anytime-valid interval of the failure rate ([`super::cs`]: it holds however the
    /// search chose to stop asking about the set; `[0, 1]` when nothing was answered).
    pub fn ci95(&self) -> [f64; 2] {
        super::cs::interval(self.wrong, self.answered())
    }

    /// The fixed-n Wilson interval: what the searches steer by (not what they report).
    pub fn wilson95(&self) -> [f64; 2] {
        super::interval::wilson(self.wrong, self.answered())
    }

    /// Add the observations of `more` (of the same set).
    pub fn merge(&mut self, more: &SetStats) {
        debug_assert_eq!(self.set, more.set);
        self.correct += more.correct;
        self.wrong += more.wrong;
        for (o, n) in &more.unanswered {
            *self.unanswered.entry(*o).or_default() += n;
        }
    }
}

/// The metrics of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Evaluated sets.
    pub sets: usize,
    /// All inferences (observations).
    pub inferences: u64,
    pub failures: u64,
    /// Number of failure modes (sets with FR ≥ τ).
    pub failure_modes: usize,
    /// Percent of evaluated sets that are failure modes.
    pub pfm: f64,
    /// Percent of all inferences that were wrong answers.
    pub mfr: f64,
    /// Mean pairwise Jaccard distance among failure modes; `None` with fewer than two.
    pub div: Option<f64>,
    /// Unanswered observations by outcome.
    pub unanswered: BTreeMap<Outcome, u64>,
}

pub fn metrics(stats: &[SetStats], threshold: f64) -> Metrics {
    let modes: Vec<ConceptSet> = stats.iter().filter(|s| s.is_failure_mode(threshold)).map(|s| s.set).collect();
    let inferences: u64 = stats.iter().map(|s| u64::from(s.observations())).sum();
    let failures: u64 = stats.iter().map(|s| u64::from(s.wrong)).sum();
    let mut unanswered = BTreeMap::new();
    for s in stats {
        for (o, n) in &s.unanswered {
            *unanswered.entry(*o).or_default() += u64::from(*n);
        }
    }
    Metrics {
        sets: stats.len(),
        inferences,
        failures,
        failure_modes: modes.len(),
        pfm: percent(modes.len() as f64, stats.len() as f64),
        mfr: percent(failures as f64, inferences as f64),
        div: diversity(&modes),
        unanswered,
    }
}

fn percent(a: f64, b: f64) -> f64 {
    if b == 0.0 { 0.0 } else { 100.0 * a / b }
}

/// Mean pairwise Jaccard distance; `None` for fewer than two sets.
pub fn diversity(sets: &[ConceptSet]) -> Option<f64> {
    if sets.len() < 2 {
        return None;
    }
    let mut sum = 0.0;
    for (i, a) in sets.iter().enumerate() {
        for b in &sets[i + 1..] {
            sum += 1.0 - a.jaccard(*b);
        }
    }
    let pairs = (sets.len() * (sets.len() - 1) / 2) as f64;
    Some(sum / pairs)
}

/// Sets ranked for reports and validation: highest failure rate first, then most answered
/// observations, then the canonical set order (deterministic).
pub fn ranked(stats: &[SetStats]) -> Vec<&SetStats> {
    let mut v: Vec<&SetStats> = stats.iter().filter(|s| s.fr().is_some()).collect();
    v.sort_by(|a, b| b.value().total_cmp(&a.value()).then(b.answered().cmp(&a.answered())).then(a.set.cmp(&b.set)));
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::interval::mean_sd;

    fn stats(bits: u128, outcomes: &[Outcome]) -> SetStats {
        let mut s = SetStats::new(ConceptSet::from_bits(bits));
        outcomes.iter().for_each(|o| s.add(*o));
        s
    }

    #[test]
    fn hand_computed_metrics() {
        use Outcome::*;
        let runs = [
            stats(0b011, &[Wrong, Wrong, Wrong, Correct, Correct]), // FR 0.6: a failure mode
            stats(0b110, &[Wrong, Wrong, Wrong, Wrong, Unparsed]),  // FR 4/4
            stats(0b100, &[Correct, Correct, Correct, Correct, Wrong]),
            stats(0b1000, &[ApiError, ApiError, ApiError, ApiError, ApiError]), // no FR
        ];
        let m = metrics(&runs, 0.6);
        assert_eq!((m.sets, m.inferences, m.failures, m.failure_modes), (4, 20, 8, 2));
        assert_eq!(m.pfm, 50.0);
        assert_eq!(m.mfr, 40.0);
        // {0,1} vs {1,2}: Jaccard 1/3, distance 2/3.
        assert!((m.div.unwrap() - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.unanswered, BTreeMap::from([(Unparsed, 1), (ApiError, 5)]));
        assert_eq!(runs[3].fr(), None);
        assert_eq!(runs[1].fr(), Some(1.0));
        let order: Vec<u128> = ranked(&runs).iter().map(|s| s.set.low_bits()).collect();
        assert_eq!(order, vec![0b110, 0b011, 0b100]);
    }

    #[test]
    fn diversity_needs_two_modes() {
        assert_eq!(diversity(&[ConceptSet::from_bits(1)]), None);
        assert_eq!(
            diversity(&[ConceptSet::from_bits(1), ConceptSet::from_bits(2), ConceptSet::from_bits(1)]),
            Some(2.0 / 3.0)
        );
        assert_eq!(mean_sd(&[1.0, 3.0]), (2.0, 2f64.sqrt()));
    }
}

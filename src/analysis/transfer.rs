//! Transfer of one model's failure modes to other models (paper RQ3, Table 3), as a pure
//! function of the observations: per set, its failure rate on the source and on each target;
//! per target, the mean failure rate (MFR: wrong answers over answered observations, pooled) on
//! the transferred sets and on as many random valid sets, their ratio, and how many transferred
//! sets reach FR ≥ τ on the target. [`TransferReport`] is `transfer.json`.

use serde::{Deserialize, Serialize};

use crate::run::summary::Spend;
use crate::search::SetStats;

/// `transfer.json`: the transfer table and each model's spend.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransferReport {
    #[serde(flatten)]
    pub transfer: Transfer,
    /// Per model (in `models` order): tokens and money of its transfer observations.
    pub spend: Vec<Spend>,
}

/// One set's failure rates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetLine {
    pub concepts: Vec<String>,
    /// The set's FR in the source run (`None` for random sets, which the search may not have
    /// seen).
    pub source_fr: Option<f64>,
    /// Per target, in `Transfer::models` order: FR and answered observations.
    pub target_fr: Vec<Option<f64>>,
    pub answered: Vec<u32>,
}

impl SetLine {
    /// Wrong answers of model `m` (from its FR and answered count).
    pub fn wrong(&self, m: usize) -> u32 {
        match (self.target_fr.get(m).copied().flatten(), self.answered.get(m)) {
            (Some(fr), Some(&n)) => (fr * f64::from(n)).round() as u32,
            _ => 0,
        }
    }
}

/// Model `m`'s wrong and answered observations pooled over `lines` (its MFR's counts).
pub fn pooled_counts(lines: &[SetLine], m: usize) -> (u64, u64) {
    lines
        .iter()
        .fold((0, 0), |(w, a), l| (w + u64::from(l.wrong(m)), a + u64::from(l.answered.get(m).copied().unwrap_or(0))))
}

/// One target's summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TargetRow {
    pub model: String,
    /// MFR on the transferred sets.
    pub transferred_mfr: Option<f64>,
    /// MFR on the random sets.
    pub random_mfr: Option<f64>,
    /// `transferred_mfr / random_mfr` (`None` when the random MFR is 0 or unknown).
    pub ratio: Option<f64>,
    /// Transferred sets with FR ≥ τ on this target.
    pub transfers: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Transfer {
    pub source: String,
    pub threshold: f64,
    pub samples: u32,
    /// The models asked, the source first.
    pub models: Vec<String>,
    pub sets: Vec<SetLine>,
    pub random: Vec<SetLine>,
    pub targets: Vec<TargetRow>,
}

fn pooled(stats: &[&SetStats]) -> Option<f64> {
    let (wrong, answered) = stats.iter().fold((0u32, 0u32), |(w, a), s| (w + s.wrong, a + s.answered()));
    (answered > 0).then(|| f64::from(wrong) / f64::from(answered))
}

fn lines(names: &[Vec<String>], source: &[Option<f64>], per_model: &[Vec<SetStats>]) -> Vec<SetLine> {
    names
        .iter()
        .enumerate()
        .map(|(i, n)| SetLine {
            concepts: n.clone(),
            source_fr: source.get(i).copied().flatten(),
            target_fr: per_model.iter().map(|m| m[i].fr()).collect(),
            answered: per_model.iter().map(|m| m[i].answered()).collect(),
        })
        .collect()
}

/// The transfer table. `transferred[m][i]` are model m's observations of transferred set i,
/// `random[m][j]` of random set j; `source_fr[i]` is set i's FR in the source run.
#[allow(clippy::too_many_arguments)]
pub fn table(
    source: &str,
    models: &[String],
    threshold: f64,
    samples: u32,
    set_names: &[Vec<String>],
    source_fr: &[Option<f64>],
    transferred: &[Vec<SetStats>],
    random_names: &[Vec<String>],
    random: &[Vec<SetStats>],
) -> Transfer {
    let targets = models
        .iter()
        .enumerate()
        .map(|(m, model)| {
            let t = pooled(&transferred[m].iter().collect::<Vec<_>>());
            let r = pooled(&random[m].iter().collect::<Vec<_>>());
            TargetRow {
                model: model.clone(),
                transferred_mfr: t,
                random_mfr: r,
                ratio: match (t, r) {
                    (Some(t), Some(r)) if r > 0.0 => Some(t / r),
                    _ => None,
                },
                transfers: transferred[m].iter().filter(|s| s.fr().is_some_and(|f| f >= threshold)).count(),
            }
        })
        .collect();
    Transfer {
        source: source.to_string(),
        threshold,
        samples,
        models: models.to_vec(),
        sets: lines(set_names, source_fr, transferred),
        random: lines(random_names, &[], random),
        targets,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::ConceptSet;
    use crate::outcome::Outcome;

    fn stats(wrong: u32, right: u32) -> SetStats {
        let mut s = SetStats::new(ConceptSet::EMPTY);
        (0..wrong).for_each(|_| s.add(Outcome::Wrong));
        (0..right).for_each(|_| s.add(Outcome::Correct));
        s.add(Outcome::Unparsed);
        s
    }

    #[test]
    fn mfr_is_pooled_and_transfers_count_sets_at_threshold() {
        let names = vec![vec!["a".to_string()], vec!["b".to_string()]];
        let t = table(
            "src",
            &["src".into(), "m2".into()],
            0.6,
            4,
            &names,
            &[Some(1.0), Some(0.8)],
            &[vec![stats(4, 0), stats(3, 1)], vec![stats(3, 1), stats(0, 4)]],
            &names,
            &[vec![stats(1, 3), stats(0, 4)], vec![stats(0, 4), stats(0, 4)]],
        );
        assert_eq!(t.targets[0].transferred_mfr, Some(7.0 / 8.0));
        assert_eq!(t.targets[0].random_mfr, Some(1.0 / 8.0));
        assert_eq!(t.targets[0].ratio, Some(7.0));
        assert_eq!(t.targets[0].transfers, 2);
        assert_eq!(t.targets[1].transfers, 1);
        assert_eq!(t.targets[1].ratio, None, "a random MFR of 0 has no ratio");
        assert_eq!(t.sets[1].target_fr, vec![Some(0.75), Some(0.0)]);
        assert_eq!(t.sets[0].answered, vec![4, 4], "unparsed replies are not answers");
        assert_eq!((t.sets[1].wrong(0), t.sets[1].wrong(1), t.sets[1].wrong(2)), (3, 0, 0));
        assert_eq!(pooled_counts(&t.sets, 0), (7, 8), "the counts behind the MFR 7/8");
    }
}

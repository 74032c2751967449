//! The paper's Table 2 across runs: per run its domain, model and algorithm, PFM, MFR and Div
//! with 95 % intervals, its failure modes, its distinct cores (the shrink phase's, from
//! `summary.json`; for a run that did not shrink, its failure modes with no smaller failure mode
//! inside them) and its spend.
//!
//! Intervals: Wilson score intervals for PFM (failure modes among evaluated sets) and MFR (wrong
//! answers among inferences); for Div, the mean pairwise Jaccard distance, ± 1.96 jackknife
//! standard errors over the failure modes (clamped to [0, 1]).

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

/// What comparing needs from one run.
#[derive(Debug, Clone, PartialEq)]
pub struct RunFacts {
    pub run: String,
    pub domain: String,
    pub model: String,
    pub algo: String,
    pub seed: u64,
    /// `--budget`: the run's model calls, every phase included; `shrink` is the share set aside
    /// for shrinking.
    pub budget: u64,
    pub shrink: u64,
    pub sets: usize,
    pub inferences: u64,
    pub failures: u64,
    /// The failure modes' concept names.
    pub failure_modes: Vec<Vec<String>>,
    /// The shrink phase's distinct cores (`summary.json`'s `cores`); `None` for a run that did
    /// not shrink, whose cores are counted as its failure modes with no smaller one inside.
    pub shrunk_cores: Option<usize>,
    pub calls: u64,
    pub cost_usd: f64,
}

/// A rate with its 95 % interval, all in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rate {
    pub value: f64,
    pub low: f64,
    pub high: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    pub run: String,
    pub domain: String,
    pub model: String,
    pub algo: String,
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub budget: u64,
    #[serde(default)]
    pub shrink: u64,
    pub pfm: Rate,
    pub mfr: Rate,
    /// `None` with fewer than two failure modes.
    pub div: Option<Rate>,
    pub failure_modes: usize,
    /// Distinct cores: the shrink phase's minimal failure modes for a run that shrank, else
    /// failure modes with no smaller failure mode inside them.
    pub cores: usize,
    pub sets: usize,
    pub inferences: u64,
    pub calls: u64,
    pub cost_usd: f64,
}

/// `k` of `n` with its Wilson score 95 % interval ([`crate::search::interval::wilson`]); no
/// trial at all says nothing: 0 in [0, 1].
pub fn wilson(k: u64, n: u64) -> Rate {
    match super::wilson95(k, n) {
        Some((low, high)) => Rate { value: k.min(n) as f64 / n as f64, low, high },
        None => Rate { value: 0.0, low: 0.0, high: 1.0 },
    }
}

fn jaccard_distance(a: &BTreeSet<&str>, b: &BTreeSet<&str>) -> f64 {
    let union = a.union(b).count();
    if union == 0 { 0.0 } else { 1.0 - a.intersection(b).count() as f64 / union as f64 }
}

/// The mean pairwise distance with mode `skip` left out, pair by pair: the definition, which
/// [`diversity`] computes from row sums instead (the test checks that the two agree).
#[cfg(test)]
fn mean_distance(sets: &[BTreeSet<&str>], skip: Option<usize>) -> f64 {
    let (mut sum, mut pairs) = (0.0, 0u64);
    for i in 0..sets.len() {
        for j in i + 1..sets.len() {
            if Some(i) == skip || Some(j) == skip {
                continue;
            }
            sum += jaccard_distance(&sets[i], &sets[j]);
            pairs += 1;
        }
    }
    if pairs == 0 { 0.0 } else { sum / pairs as f64 }
}

/// Div with a jackknife interval; `None` for fewer than two modes.
pub fn diversity(modes: &[Vec<String>]) -> Option<Rate> {
    let sets: Vec<BTreeSet<&str>> = modes.iter().map(|m| m.iter().map(String::as_str).collect()).collect();
    let n = sets.len();
    if n < 2 {
        return None;
    }
    // Each distance once, with each mode's row sum: leaving mode `i` out removes exactly its row,
    // so every leave-one-out mean comes from the total in O(1), and the whole is O(n²) distances
    // (it was O(n³) recomputing the pairs for each left-out mode).
    let (mut total, mut rows) = (0.0, vec![0.0; n]);
    for i in 0..n {
        for j in i + 1..n {
            let d = jaccard_distance(&sets[i], &sets[j]);
            total += d;
            rows[i] += d;
            rows[j] += d;
        }
    }
    let pairs = |m: usize| (m * (m - 1) / 2) as f64;
    let value = total / pairs(n);
    if n < 3 {
        return Some(Rate { value, low: 0.0, high: 1.0 });
    }
    // Rounding can leave a hair below zero where every remaining distance is 0.
    let loo: Vec<f64> = rows.iter().map(|r| ((total - r) / pairs(n - 1)).max(0.0)).collect();
    let mean = loo.iter().sum::<f64>() / n as f64;
    let var = (n as f64 - 1.0) / n as f64 * loo.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
    let half = crate::search::interval::Z95 * var.sqrt();
    Some(Rate { value, low: (value - half).max(0.0), high: (value + half).min(1.0) })
}

/// How many failure modes hold no other failure mode as a proper subset.
pub fn cores(modes: &[Vec<String>]) -> usize {
    let sets: Vec<BTreeSet<&str>> = modes.iter().map(|m| m.iter().map(String::as_str).collect()).collect();
    sets.iter().filter(|a| !sets.iter().any(|b| b.len() < a.len() && b.is_subset(a))).count()
}

pub fn row(f: &RunFacts) -> Row {
    Row {
        run: f.run.clone(),
        domain: f.domain.clone(),
        model: f.model.clone(),
        algo: f.algo.clone(),
        seed: f.seed,
        budget: f.budget,
        shrink: f.shrink,
        pfm: wilson(f.failure_modes.len() as u64, f.sets as u64),
        mfr: wilson(f.failures, f.inferences),
        div: diversity(&f.failure_modes),
        failure_modes: f.failure_modes.len(),
        cores: f.shrunk_cores.unwrap_or_else(|| cores(&f.failure_modes)),
        sets: f.sets,
        inferences: f.inferences,
        calls: f.calls,
        cost_usd: f.cost_usd,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&[&str]]) -> Vec<Vec<String>> {
        v.iter().map(|s| s.iter().map(|c| c.to_string()).collect()).collect()
    }

    #[test]
    fn wilson_matches_known_values() {
        let r = wilson(5, 10);
        assert!((r.low - 0.2366).abs() < 1e-3 && (r.high - 0.7634).abs() < 1e-3, "{r:?}");
        let z = wilson(0, 20);
        assert_eq!((z.value, z.low), (0.0, 0.0));
        assert!(z.high > 0.1 && z.high < 0.2);
        assert_eq!(wilson(0, 0).high, 1.0);
    }

    #[test]
    fn cores_are_modes_without_a_smaller_mode_inside() {
        let m = names(&[&["a"], &["a", "b"], &["c", "d"], &["c", "d", "e"], &["f", "g"]]);
        assert_eq!(cores(&m), 3);
    }

    #[test]
    fn a_shrunk_run_counts_its_own_cores() {
        let facts = |shrunk_cores| RunFacts {
            run: "r".into(),
            domain: "d".into(),
            model: "m".into(),
            algo: "beam".into(),
            seed: 0,
            budget: 50,
            shrink: 0,
            sets: 10,
            inferences: 50,
            failures: 20,
            failure_modes: names(&[&["a", "b"], &["a", "c"], &["d", "e"]]),
            shrunk_cores,
            calls: 50,
            cost_usd: 0.0,
        };
        assert_eq!(row(&facts(None)).cores, 3, "no smaller failure mode inside any of them");
        assert_eq!(row(&facts(Some(2))).cores, 2, "the shrink found `a` and `d`");
        assert_eq!(row(&facts(Some(0))).cores, 0, "a shrink that confirmed nothing");
    }

    #[test]
    fn diversity_and_its_interval() {
        assert_eq!(diversity(&names(&[&["a"]])), None);
        let same = diversity(&names(&[&["a"], &["a"], &["a"]])).unwrap();
        assert_eq!((same.value, same.low, same.high), (0.0, 0.0, 0.0));
        let d = diversity(&names(&[&["a"], &["b"], &["a", "b"], &["c"]])).unwrap();
        assert!(d.low <= d.value && d.value <= d.high && d.value > 0.5, "{d:?}");
    }

    /// The jackknife as first written: every leave-one-out mean recomputed pair by pair (O(n³)).
    fn diversity_by_definition(modes: &[Vec<String>]) -> Option<Rate> {
        let sets: Vec<BTreeSet<&str>> = modes.iter().map(|m| m.iter().map(String::as_str).collect()).collect();
        let n = sets.len();
        if n < 2 {
            return None;
        }
        let value = mean_distance(&sets, None);
        if n < 3 {
            return Some(Rate { value, low: 0.0, high: 1.0 });
        }
        let loo: Vec<f64> = (0..n).map(|i| mean_distance(&sets, Some(i))).collect();
        let mean = loo.iter().sum::<f64>() / n as f64;
        let var = (n as f64 - 1.0) / n as f64 * loo.iter().map(|x| (x - mean).powi(2)).sum::<f64>();
        let half = crate::search::interval::Z95 * var.sqrt();
        Some(Rate { value, low: (value - half).max(0.0), high: (value + half).min(1.0) })
    }

    #[test]
    fn the_row_sum_jackknife_equals_the_definition_on_random_modes() {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = |below: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % below
        };
        let concepts = ["a", "b", "c", "d", "e", "f", "g", "h"];
        for trial in 0..200 {
            let n = next(40) as usize;
            let modes: Vec<Vec<String>> = (0..n)
                .map(|_| {
                    let k = next(5) as usize;
                    (0..k).map(|_| concepts[next(if trial % 3 == 0 { 3 } else { 8 }) as usize].to_string()).collect()
                })
                .collect();
            let (fast, slow) = (diversity(&modes), diversity_by_definition(&modes));
            match (fast, slow) {
                (None, None) => {}
                (Some(f), Some(s)) => {
                    for (a, b) in [(f.value, s.value), (f.low, s.low), (f.high, s.high)] {
                        assert!((a - b).abs() < 1e-9, "trial {trial}: {f:?} vs {s:?}");
                    }
                }
                other => panic!("trial {trial}: {other:?}"),
            }
        }
    }
}

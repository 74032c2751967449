//! What a finished run says beyond its list of failure modes, as pure functions of its summary
//! rows and journal records: per-concept failure F(c), pairwise failure rates, the discovery
//! curve (failure modes and distinct cores found against inferences spent), the outcome
//! breakdown, and — for runs that predate shrinking — cores approximated by the minimal failure
//! modes. The report ([`crate::report`]) draws these; nothing here reads a file.
//!
//! Sets are handled by concept name (index order, as the journal and the summary write them), so
//! a run can be analysed without recompiling its domain.

use std::collections::{BTreeMap, HashMap};

use crate::journal::{Phase, Record};
use crate::outcome::Outcome;
use crate::run::runner::SetRow;

/// Whether every concept of `small` is in `big`.
pub fn is_subset(small: &[String], big: &[String]) -> bool {
    small.iter().all(|c| big.contains(c))
}

/// Whether the two lists name the same concepts (in any order).
pub fn same_set(a: &[String], b: &[String]) -> bool {
    a.len() == b.len() && is_subset(a, b)
}

/// z for a two-sided 95 % interval.
const Z95: f64 = 1.959_963_984_540_054;

/// Wilson score 95 % interval of `k` failures in `n` answered observations; `None` for n = 0.
///
/// Only for runs whose `summary.json` carries no `ci95` (written before intervals were added):
/// the report reads the summary's own intervals when they are there.
pub fn wilson95(k: u64, n: u64) -> Option<(f64, f64)> {
    if n == 0 {
        return None;
    }
    let (k, n) = (k.min(n) as f64, n as f64);
    let p = k / n;
    let z2 = Z95 * Z95;
    let denom = 1.0 + z2 / n;
    let centre = (p + z2 / (2.0 * n)) / denom;
    let half = Z95 * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / denom;
    Some(((centre - half).max(0.0), (centre + half).min(1.0)))
}

/// F(c) for one concept: the mean failure rate of the evaluated sets that contain it.
#[derive(Debug, Clone, PartialEq)]
pub struct ConceptRate {
    pub concept: String,
    /// Mean FR over the sets containing the concept that have a failure rate.
    pub f: f64,
    /// Evaluated sets (with a failure rate) containing the concept.
    pub n: u32,
    /// Of those, failure modes (FR ≥ τ).
    pub failure_modes: u32,
}

/// F(c) for every concept that occurs in an evaluated set with a failure rate; highest F first,
/// then most sets, then by name.
pub fn concept_rates(sets: &[SetRow], threshold: f64) -> Vec<ConceptRate> {
    let mut acc: BTreeMap<&str, (f64, u32, u32)> = BTreeMap::new();
    for s in sets {
        let Some(fr) = s.fr else { continue };
        for c in &s.concepts {
            let e = acc.entry(c).or_default();
            e.0 += fr;
            e.1 += 1;
            e.2 += u32::from(fr >= threshold);
        }
    }
    let mut v: Vec<ConceptRate> = acc
        .into_iter()
        .map(|(c, (sum, n, modes))| ConceptRate {
            concept: c.to_string(),
            f: sum / f64::from(n),
            n,
            failure_modes: modes,
        })
        .collect();
    v.sort_by(|a, b| b.f.total_cmp(&a.f).then(b.n.cmp(&a.n)).then(a.concept.cmp(&b.concept)));
    v
}

/// One cell of the pair matrix: the mean FR of the evaluated sets holding both concepts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairRate {
    pub fr: f64,
    pub n: u32,
}

/// Pairwise failure rates over `concepts` (rows and columns in that order). The diagonal is
/// F(c); a cell is `None` when no evaluated set holds both concepts.
#[derive(Debug, Clone, PartialEq)]
pub struct PairRates {
    pub concepts: Vec<String>,
    pub cells: Vec<Vec<Option<PairRate>>>,
}

pub fn pair_rates(sets: &[SetRow], concepts: &[String]) -> PairRates {
    let index: HashMap<&str, usize> = concepts.iter().enumerate().map(|(i, c)| (c.as_str(), i)).collect();
    let k = concepts.len();
    let mut sum = vec![vec![(0.0, 0u32); k]; k];
    for s in sets {
        let Some(fr) = s.fr else { continue };
        let idx: Vec<usize> = s.concepts.iter().filter_map(|c| index.get(c.as_str()).copied()).collect();
        for &i in &idx {
            for &j in &idx {
                sum[i][j].0 += fr;
                sum[i][j].1 += 1;
            }
        }
    }
    let cells = sum
        .into_iter()
        .map(|row| row.into_iter().map(|(s, n)| (n > 0).then(|| PairRate { fr: s / f64::from(n), n })).collect())
        .collect();
    PairRates { concepts: concepts.to_vec(), cells }
}

/// The observations that count: a resumed run asks again after a failed call, so the journal
/// may hold several lines for one (phase, set, observation); the newest wins, as it does for
/// the run itself. Returned in journal order of the winning lines.
pub fn latest_observations(records: &[Record]) -> Vec<&Record> {
    let mut last: HashMap<(Phase, &[String], u32), usize> = HashMap::new();
    for (i, r) in records.iter().enumerate() {
        last.insert((r.phase, r.set.as_slice(), r.obs), i);
    }
    let mut keep: Vec<usize> = last.into_values().collect();
    keep.sort_unstable();
    keep.into_iter().map(|i| &records[i]).collect()
}

/// Observations by phase and outcome.
pub fn outcome_counts(observations: &[&Record]) -> BTreeMap<Phase, BTreeMap<Outcome, u64>> {
    let mut out: BTreeMap<Phase, BTreeMap<Outcome, u64>> = BTreeMap::new();
    for r in observations {
        *out.entry(r.phase).or_default().entry(r.outcome).or_default() += 1;
    }
    out
}

/// One step of the discovery curve: after `inferences` observations, how many failure modes and
/// distinct cores had been found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DiscoveryPoint {
    pub inferences: u64,
    pub failure_modes: usize,
    pub cores: usize,
}

/// The discovery curve of a run, and where each phase after the first began.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Discovery {
    /// Steps, starting at (0, 0, 0) and ending at the last inference; a point is added wherever a
    /// count changes.
    pub points: Vec<DiscoveryPoint>,
    /// Inferences spent before each later phase started (e.g. shrinking after the search).
    pub phase_starts: Vec<(u64, Phase)>,
    pub inferences: u64,
}

/// The discovery curve over the observations of every phase but validation (which re-checks
/// what was found and finds nothing new). A failure mode counts as found at its last
/// observation in the phase that first evaluated it (shrinking re-tests failure modes later,
/// which finds nothing new); a core counts as found when the first failure mode containing it
/// is found.
pub fn discovery(observations: &[&Record], failure_modes: &[Vec<String>], cores: &[Vec<String>]) -> Discovery {
    let searched: Vec<&Record> = observations.iter().copied().filter(|r| r.phase != Phase::Validate).collect();
    let mut first_phase: HashMap<&[String], Phase> = HashMap::new();
    let mut last: HashMap<&[String], usize> = HashMap::new();
    for (i, r) in searched.iter().enumerate() {
        let phase = *first_phase.entry(r.set.as_slice()).or_insert(r.phase);
        if r.phase == phase {
            last.insert(r.set.as_slice(), i);
        }
    }
    let mut found_at: Vec<(usize, &Vec<String>)> =
        failure_modes.iter().filter_map(|m| last.iter().find(|(s, _)| same_set(s, m)).map(|(_, &i)| (i, m))).collect();
    found_at.sort_by_key(|(i, _)| *i);
    let mut points = vec![DiscoveryPoint { inferences: 0, failure_modes: 0, cores: 0 }];
    let mut core_found = vec![false; cores.len()];
    let (mut modes, mut ncores) = (0, 0);
    for (i, mode) in found_at {
        modes += 1;
        for (c, done) in cores.iter().zip(core_found.iter_mut()) {
            if !*done && is_subset(c, mode) {
                *done = true;
                ncores += 1;
            }
        }
        let at = i as u64 + 1;
        match points.last_mut() {
            Some(p) if p.inferences == at => {
                *p = DiscoveryPoint { inferences: at, failure_modes: modes, cores: ncores }
            }
            _ => points.push(DiscoveryPoint { inferences: at, failure_modes: modes, cores: ncores }),
        }
    }
    let total = searched.len() as u64;
    if points.last().is_some_and(|p| p.inferences < total) {
        points.push(DiscoveryPoint { inferences: total, failure_modes: modes, cores: ncores });
    }
    let mut phase_starts = Vec::new();
    for (i, w) in searched.windows(2).enumerate() {
        if w[0].phase != w[1].phase {
            phase_starts.push((i as u64 + 1, w[1].phase));
        }
    }
    Discovery { points, phase_starts, inferences: total }
}

/// Indices of the failure modes no other failure mode is a proper subset of: the smallest
/// failing set of each family the search evaluated. They stand in for cores in runs made before
/// shrinking existed; a shrunk run's `cores` say more (a core there may never have been reached
/// by the search itself). Ordered by how many failure modes contain them (the family each one
/// explains), then by FR (highest first), then by size.
pub fn minimal_failure_modes(modes: &[SetRow]) -> Vec<usize> {
    let mut minimal: Vec<usize> = (0..modes.len())
        .filter(|&i| {
            !modes.iter().enumerate().any(|(j, m)| {
                j != i && m.concepts.len() < modes[i].concepts.len() && is_subset(&m.concepts, &modes[i].concepts)
            })
        })
        .collect();
    let supersets = |i: usize| supersets(&modes[i].concepts, modes);
    minimal.sort_by(|&a, &b| {
        let fr = |i: usize| modes[i].fr.unwrap_or(0.0);
        supersets(b)
            .cmp(&supersets(a))
            .then(fr(b).total_cmp(&fr(a)))
            .then(modes[a].concepts.len().cmp(&modes[b].concepts.len()))
            .then(a.cmp(&b))
    });
    minimal
}

/// How many of `modes` contain `core`, itself included (as `summary.json`'s `cores` count them).
pub fn supersets(core: &[String], modes: &[SetRow]) -> usize {
    modes.iter().filter(|m| is_subset(core, &m.concepts)).count()
}

#[cfg(test)]
mod tests;

//! What a finished run says beyond its list of failure modes, as pure functions of its summary
//! rows and journal records: per-concept failure F(c), pairwise failure rates, the discovery
//! curve (failure modes and distinct cores found against inferences spent), the outcome
//! breakdown, and — for runs that predate shrinking — cores approximated by the minimal failure
//! modes. The report ([`crate::report`]) draws these; they read no file.
//!
//! Sets are handled by concept name (index order, as the journal and the summary write them), so
//! a run can be analysed without recompiling its domain.
//!
//! The submodules go further: recognition vs. reasoning and lift ([`probe`]), transfer to other
//! models ([`transfer`]), runs compared ([`compare`]), ablation sweeps and their plot
//! ([`sweep`]), and the drivers that ask a run's sets again through the one observe pipeline
//! ([`reask`]). Their computations are pure functions of observations; only `reask` does I/O
//! (through `run`).

pub mod compare;
#[cfg(test)]
mod pipeline_tests;
pub mod probe;
pub mod reask;
pub mod sweep;
pub mod transfer;

use std::collections::{BTreeMap, HashMap};

use crate::journal::{Phase, Record};
use crate::outcome::Outcome;
use crate::run::summary::SetRow;

/// Whether every concept of `small` is in `big`.
pub fn is_subset(small: &[String], big: &[String]) -> bool {
    small.iter().all(|c| big.contains(c))
}

/// Whether the two lists name the same concepts (in any order).
pub fn same_set(a: &[String], b: &[String]) -> bool {
    a.len() == b.len() && is_subset(a, b)
}

/// The 95 % anytime-valid interval ([`crate::search::cs`]) of `k` failures in `n` answered
/// observations; `None` for n = 0. What every per-set rate (and probe's R(c)) is shown with:
/// it holds however the command decided how many observations to make.
pub fn anytime95(k: u64, n: u64) -> Option<(f64, f64)> {
    if n == 0 {
        return None;
    }
    match (u32::try_from(k.min(n)), u32::try_from(n)) {
        (Ok(k), Ok(n)) => {
            let [lo, hi] = crate::search::cs::interval(k, n);
            Some((lo, hi))
        }
        _ => {
            let p = k.min(n) as f64 / n as f64;
            Some((p, p))
        }
    }
}

/// Wilson score 95 % interval ([`crate::search::interval::wilson`], the one the search's
/// sequential test uses) of `k` failures in `n` answered observations; `None` for n = 0.
///
/// For counts a run's `summary.json` carries no interval for (runs written before intervals
/// were added, PFM and MFR); the report reads the summary's own intervals when they are there.
pub fn wilson95(k: u64, n: u64) -> Option<(f64, f64)> {
    if n == 0 {
        return None;
    }
    match (u32::try_from(k.min(n)), u32::try_from(n)) {
        (Ok(k), Ok(n)) => {
            let [lo, hi] = crate::search::interval::wilson(k, n);
            Some((lo, hi))
        }
        // Beyond 4·10⁹ trials the interval is narrower than any rate is printed.
        _ => {
            let p = k.min(n) as f64 / n as f64;
            Some((p, p))
        }
    }
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
/// may hold several lines for one (phase, set, observation, model); the newest wins, as it does
/// for the run itself. Returned in journal order of the winning lines.
pub fn latest_observations(records: &[Record]) -> Vec<&Record> {
    // (phase, set, observation, the model when it is not the run's own)
    type Line<'a> = (Phase, &'a [String], u32, Option<&'a str>);
    let mut last: HashMap<Line, usize> = HashMap::new();
    for (i, r) in records.iter().enumerate() {
        last.insert((r.phase, r.set.as_slice(), r.obs, r.model.as_deref()), i);
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

/// How a set of scenes fared with the visibility guard (`run::observe`): each scene shown to a
/// model — or not, when an entity a concept placed stayed hidden — counted once however many
/// models saw it (a transfer shows one scene to every model).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneVisibility {
    pub scenes: u64,
    /// Scenes whose renderer measured visibility (the builtin renderer does).
    pub measured: u64,
    /// Scenes drawn again at least once because an entity was not visible.
    pub resampled: u64,
    /// Draws thrown away, summed over the scenes.
    pub redraws: u64,
    /// Scenes recorded `invisible`: still hiding an entity after every redraw.
    pub invisible: u64,
}

impl SceneVisibility {
    fn add(&mut self, r: &Record) {
        self.scenes += 1;
        self.measured += u64::from(!r.visibility.is_empty());
        self.resampled += u64::from(r.resamples > 0);
        self.redraws += u64::from(r.resamples);
        self.invisible += u64::from(r.outcome == Outcome::Invisible);
    }
}

/// The visibility guard's counts per phase over `observations` (each (phase, set, index) once).
pub fn visibility_by_phase(observations: &[&Record]) -> BTreeMap<Phase, SceneVisibility> {
    let mut seen: std::collections::HashSet<(Phase, &[String], u32)> = std::collections::HashSet::new();
    let mut out: BTreeMap<Phase, SceneVisibility> = BTreeMap::new();
    for r in observations {
        if seen.insert((r.phase, r.set.as_slice(), r.obs)) {
            out.entry(r.phase).or_default().add(r);
        }
    }
    out
}

/// The visibility guard's counts over `observations`, all phases together.
pub fn visibility(observations: &[&Record]) -> SceneVisibility {
    let mut total = SceneVisibility::default();
    for v in visibility_by_phase(observations).values() {
        total.scenes += v.scenes;
        total.measured += v.measured;
        total.resampled += v.resampled;
        total.redraws += v.redraws;
        total.invisible += v.invisible;
    }
    total
}

/// The figures measured for one concept's entities across scenes.
#[derive(Debug, Clone, PartialEq)]
pub struct ConceptVisibility {
    pub concept: String,
    /// Entities measured (one per scene and entity the concept placed).
    pub n: usize,
    pub min_pixels: u32,
    pub median_pixels: u32,
    pub median_contrast: f64,
}

/// Per concept, the visible pixels and contrast of the entities it placed in the scenes of
/// `observations` (each scene once), fewest pixels first.
pub fn concept_visibility(observations: &[&Record]) -> Vec<ConceptVisibility> {
    let mut seen: std::collections::HashSet<(Phase, &[String], u32)> = std::collections::HashSet::new();
    let mut by: BTreeMap<&str, (Vec<u32>, Vec<f64>)> = BTreeMap::new();
    for r in observations {
        if !seen.insert((r.phase, r.set.as_slice(), r.obs)) {
            continue;
        }
        for v in &r.visibility {
            if let Some(c) = &v.concept {
                let e = by.entry(c).or_default();
                e.0.push(v.pixels);
                e.1.push(v.contrast);
            }
        }
    }
    let mut out: Vec<ConceptVisibility> = by
        .into_iter()
        .map(|(c, (mut px, mut contrast))| {
            px.sort_unstable();
            contrast.sort_by(f64::total_cmp);
            ConceptVisibility {
                concept: c.to_string(),
                n: px.len(),
                min_pixels: px[0],
                median_pixels: px[px.len() / 2],
                median_contrast: contrast[contrast.len() / 2],
            }
        })
        .collect();
    out.sort_by(|a, b| a.min_pixels.cmp(&b.min_pixels).then_with(|| a.concept.cmp(&b.concept)));
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

/// The discovery curve over the observations of the search and shrink phases (validation
/// re-checks what was found, and probe and transfer re-ask it: they find nothing new). A failure mode counts as found at its last
/// observation in the phase that first evaluated it (shrinking re-tests failure modes later,
/// which finds nothing new); a core counts as found when the first failure mode containing it
/// is found.
pub fn discovery(observations: &[&Record], failure_modes: &[Vec<String>], cores: &[Vec<String>]) -> Discovery {
    let searched: Vec<&Record> =
        observations.iter().copied().filter(|r| matches!(r.phase, Phase::Search | Phase::Shrink)).collect();
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

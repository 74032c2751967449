//! The group-testing surrogate of `--algo interact` (`--surrogate patterns`, the default).
//!
//! A failure mode is a small set of concepts that makes the model fail in every scene that holds
//! it: a *core*. Testing a set S tests every sub-pattern of S at once — the search is group
//! testing. The surrogate keeps, for every valid set of at most [`MAX_PATTERN`] concepts (a
//! *pattern*; 3 582 on the driving domain), the evidence that it is a core:
//!
//! ```text
//! P(wrong | S) = r(k) = b + (e − b)·(1 − d)^k    when S holds a core p, k = |S| − |p|
//!              = bg(S)                           otherwise
//! ```
//!
//! `b` is the model's base error (estimated from the sets that do not fail), `e` the error of a
//! core alone ([`CORE_RATE`]), `d` the *dilution*: how much of a core's effect each further
//! concept takes away (the paper's strong models fail in small scenes and seldom in crowded ones).
//! `bg(S)` is what S's already-tested subsets explain: the largest smoothed failure rate among
//! them (at least `b`). Each answered observation of a tested set adds, to each of its
//! sub-patterns, the log-likelihood ratio of "this pattern is a core" against "S fails only as
//! much as its tested subsets do" — so a set that fails because of a known pair gives no evidence
//! to the pair's supersets, and a set that passes clears its sub-patterns. `d` is unknown: the
//! evidence is kept for each of [`DILUTIONS`], and the posterior over `d` is how well each value
//! predicts every tested set's answers (a mixture over the set's background and its sub-patterns,
//! each a core with its posterior probability).
//!
//! A pattern's prior is an Occam prior — [`EXPECTED_CORES`] cores expected among the patterns of
//! each size, so a pair starts more likely than a triple (there are ten times fewer pairs); a
//! concept that cannot stand alone keeps its share in the sets that make it valid (`towel_near +
//! stove_on` is as likely as one concept: the towel is valid only by a lit hob) — plus
//! a weak heredity term ([`HEREDITY`]): a pattern whose part already fails more often than the
//! base rate is likelier a core, as the paper's failure modes mostly are.
//!
//! The acquisition ([`Fit::scorer`], [`Scorer::score`]) is Thompson sampling over `d` (one draw from its posterior per
//! pick) and, under the drawn `d`, the probability that testing S reveals a new core —
//! 1 − Π(1 − q_p·det(k)) over S's open sub-patterns, where `det(k)` is the chance that a screen of
//! S shows a core `k` concepts smaller — divided by the expected cost of testing S: the screen,
//! plus the escalation and the sequential tests that S's background rate `bg` would trigger
//! without any new core. Everything is a pure function of the observations and the draw.
//!
//! Costs: patterns and each set's sub-patterns are indexed once (CSR); a fit is linear in the
//! evaluated sets; a score is linear in the sub-patterns of a set.

use std::collections::HashMap;

use crate::ir::{ConceptId, ConceptSet};

use super::{SetStats, Space};

/// The largest pattern: cores of up to three concepts are modelled (larger ones are still found
/// by shrinking a failing set, only not predicted).
pub const MAX_PATTERN: usize = 3;

/// The dilution hypotheses `d`.
pub const DILUTIONS: [f64; 4] = [0.0, 0.15, 0.3, 0.45];
const D: usize = DILUTIONS.len();

/// The prior over [`DILUTIONS`]: no dilution 0.7, each other 0.1. The posterior is fitted with
/// every pattern's core probability plugged in, and those already hold the same answers, so with
/// little evidence it swings between d = 0 and 0.45 (on driving_gemini, seed 1, with a uniform
/// prior, d = 0.45 held 0.85–1.0 of it from about 400 to 570 observations of a profile without
/// dilution, and the search screened a hot pair's completions one concept at a time). Measured
/// (release, the fifteen shipped profiles, 40 seeds, width 16, paired against the uniform prior):
/// +2.2 [+0.6, +3.8] points recovered, +2.1 over seeds 0–19 and +2.4 over 20–39; the three
/// graded profiles −0.3 [−4.8, +4.3] (their must-find modes: delivery_graded +11, driving_graded
/// −4, indoor_graded −8), the others +2.9 [+1.2, +4.5] (docs/search.md, "A sixth round").
pub const DILUTION_PRIOR: [f64; D] = [0.7, 0.1, 0.1, 0.1];

/// The failure rate of a core on its own.
pub const CORE_RATE: f64 = 0.85;

/// Cores expected among the patterns of each size (the Occam prior).
pub const EXPECTED_CORES: f64 = 1.5;

/// Prior log-odds added to a pattern whose strongest part fails at τ; scaled down to 0 at the base
/// rate on a log scale (a part at twice the base rate already counts).
pub const HEREDITY: f64 = 4.0;

/// Pseudo-observations of the base rate in a tested set's smoothed rate.
const PRIOR_WEIGHT: f64 = 10.0;

/// The base error is estimated on sets whose failure rate is below this (the others hold a core).
const BASE_FROM_BELOW: f64 = 0.5;

/// Width of the logistic step that turns "a screen shows it" into "it will be confirmed".
const CONFIRM_STEP: f64 = 0.05;

/// The index of sub-patterns holds at most this many entries; larger lattices model smaller
/// patterns (pairs, then single concepts) so the index stays within ~128 MB.
const MAX_ENTRIES: usize = 32 << 20;

/// Patterns and, for every set of the pool (the search space's sets, or for a sampled space the
/// sets drawn so far), its sub-patterns.
pub struct Patterns {
    /// Valid sets of at most `max` concepts: in the space's order, or as the pool met them.
    pats: Vec<ConceptSet>,
    index: HashMap<ConceptSet, u32>,
    /// The pool's position of each of its sets.
    pool: HashMap<ConceptSet, u32>,
    /// For pool set i: `subs[offsets[i]..offsets[i + 1]]`.
    offsets: Vec<u32>,
    subs: Vec<u32>,
    /// Per entry of `subs`: how many concepts the set has beyond the pattern.
    extra: Vec<u8>,
    /// Concepts per pool set.
    set_len: Vec<u8>,
    /// Concepts per pattern.
    pat_len: Vec<u8>,
    /// logit of each pattern's prior.
    logit_prior: Vec<f64>,
    /// For pattern j: its proper sub-patterns, `parents[parent_at[j]..parent_at[j + 1]]`.
    parents: Vec<u32>,
    parent_at: Vec<u32>,
    /// Valid patterns per size in the whole lattice (the Occam prior's denominators).
    per_size: Vec<f64>,
    /// The largest pattern size indexed.
    pub max: usize,
}

/// The Occam prior's probability for a pattern among `of` of its size.
fn occam(of: f64) -> f64 {
    (EXPECTED_CORES / of.max(1.0)).min(0.2)
}

/// The prior logit of pattern `p` whose concepts `own` are those it does not hold only to be valid
/// (`p` itself when it holds none), `holding` the number of valid sets of `p`'s size that hold
/// `own`. A concept that cannot stand alone (a towel by the hob needs the hob on) is as likely a
/// core as one that can, its share spread over the sets that make it valid: `towel_near +
/// stove_on` is as likely as one concept, each of a puddle's two weathers half as likely — never
/// less likely than any pattern of its size.
fn prior(per_size: &[f64], p: ConceptSet, own: ConceptSet, holding: impl Fn() -> f64) -> f64 {
    let mut q = occam(per_size[p.len()]);
    if own != p {
        q = q.max(occam(per_size[own.len()]) / holding().max(1.0));
    }
    (q / (1.0 - q)).ln()
}

/// The concepts of `p` that it does not hold only to be valid: without each of the others, `p`
/// is not valid (a towel by the hob needs the hob on, so `towel_near + stove_on` is held for
/// `towel_near`). `p` itself when it holds no such concept, or only such concepts.
fn unforced(p: ConceptSet, valid: impl Fn(ConceptSet) -> bool) -> ConceptSet {
    if p.len() < 2 {
        return p;
    }
    let own = p.iter().filter(|&c| valid(p.without(c))).fold(ConceptSet::EMPTY, |a, c| a.with(c));
    if own.is_empty() { p } else { own }
}

impl Patterns {
    pub fn new(space: &Space) -> Patterns {
        let mut max = MAX_PATTERN;
        loop {
            let entries: usize = space.sets.iter().map(|s| sub_count(s.len(), max)).sum();
            if entries <= MAX_ENTRIES || max == 1 {
                break;
            }
            max -= 1;
        }
        let pats: Vec<ConceptSet> = space.sets.iter().copied().filter(|s| s.len() <= max).collect();
        let index: HashMap<ConceptSet, u32> = pats.iter().enumerate().map(|(i, s)| (*s, i as u32)).collect();
        let mut offsets = Vec::with_capacity(space.sets.len() + 1);
        let mut subs = Vec::new();
        let mut extra = Vec::new();
        offsets.push(0);
        for &set in &space.sets {
            for_each_subset(set, max, |p| {
                if let Some(&j) = index.get(&p) {
                    subs.push(j);
                    extra.push((set.len() - p.len()) as u8);
                }
            });
            offsets.push(subs.len() as u32);
        }
        let pat_len: Vec<u8> = pats.iter().map(|p| p.len() as u8).collect();
        let mut per_size = vec![0.0; max + 1];
        pat_len.iter().for_each(|&k| per_size[usize::from(k)] += 1.0);
        // The patterns that hold concepts only to be valid, and how many patterns of their size
        // hold the rest (every valid set of at most `max` concepts is a pattern here).
        let own: Vec<ConceptSet> = pats.iter().map(|&p| unforced(p, |q| index.contains_key(&q))).collect();
        let mut holding: HashMap<(ConceptSet, usize), f64> =
            pats.iter().zip(&own).filter(|(p, u)| p != u).map(|(p, u)| ((*u, p.len()), 0.0)).collect();
        if !holding.is_empty() {
            for p in &pats {
                for_each_subset(*p, p.len(), |u| {
                    if let Some(n) = holding.get_mut(&(u, p.len())) {
                        *n += 1.0;
                    }
                });
            }
        }
        let logit_prior = pats
            .iter()
            .zip(&own)
            .map(|(p, u)| prior(&per_size, *p, *u, || holding.get(&(*u, p.len())).copied().unwrap_or(1.0)))
            .collect();
        let mut parent_at = vec![0u32];
        let mut parents = Vec::new();
        for p in &pats {
            for_each_subset(*p, p.len() - 1, |t| parents.extend(index.get(&t)));
            parent_at.push(parents.len() as u32);
        }
        Patterns {
            parent_at,
            parents,
            set_len: space.sets.iter().map(|s| s.len() as u8).collect(),
            pool: space.sets.iter().enumerate().map(|(i, s)| (*s, i as u32)).collect(),
            pats,
            index,
            offsets,
            subs,
            extra,
            pat_len,
            logit_prior,
            per_size,
            max,
        }
    }

    /// No pool yet, for a sampled space: sets join with [`Patterns::add`]; the prior counts the
    /// whole lattice's patterns (the diagram's exact counts per size).
    pub fn pooled(space: &Space) -> Patterns {
        let counts = space.counts();
        let per_size = (0..=MAX_PATTERN).map(|k| counts.get(k).map_or(0.0, |&c| c as f64)).collect();
        Patterns {
            pats: Vec::new(),
            index: HashMap::new(),
            pool: HashMap::new(),
            offsets: vec![0],
            subs: Vec::new(),
            extra: Vec::new(),
            set_len: Vec::new(),
            pat_len: Vec::new(),
            logit_prior: Vec::new(),
            parents: Vec::new(),
            parent_at: vec![0],
            per_size,
            max: MAX_PATTERN,
        }
    }

    /// Add `set` to the pool (at the next position) with its sub-patterns, the ones valid in
    /// `space` and not indexed yet becoming patterns; false when it is already in the pool.
    pub fn add(&mut self, set: ConceptSet, space: &Space) -> bool {
        let valid = |p: ConceptSet| space.contains(p);
        if self.pool.contains_key(&set) {
            return false;
        }
        self.pool.insert(set, self.set_len.len() as u32);
        let max = self.max;
        for_each_subset(set, max, |p| {
            let j = match self.index.get(&p) {
                Some(&j) => Some(j),
                None if valid(p) => {
                    let j = self.pats.len() as u32;
                    // Smaller subsets come first, so the pattern's parts are indexed already.
                    for_each_subset(p, p.len() - 1, |t| self.parents.extend(self.index.get(&t)));
                    self.parent_at.push(self.parents.len() as u32);
                    self.pats.push(p);
                    self.index.insert(p, j);
                    self.pat_len.push(p.len() as u8);
                    let u = unforced(p, valid);
                    let holding = || space.count_containing(u, p.len()) as f64;
                    self.logit_prior.push(prior(&self.per_size, p, u, holding));
                    Some(j)
                }
                None => None,
            };
            if let Some(j) = j {
                self.subs.push(j);
                self.extra.push((set.len() - p.len()) as u8);
            }
        });
        self.offsets.push(self.subs.len() as u32);
        self.set_len.push(set.len() as u8);
        true
    }

    pub fn len(&self) -> usize {
        self.pats.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pats.is_empty()
    }

    pub fn pattern(&self, j: u32) -> ConceptSet {
        self.pats[j as usize]
    }

    pub fn position(&self, p: ConceptSet) -> Option<u32> {
        self.index.get(&p).copied()
    }

    /// The pool's position of `set`.
    pub fn pool_position(&self, set: ConceptSet) -> Option<usize> {
        self.pool.get(&set).map(|&i| i as usize)
    }

    /// The sub-patterns of the pool's set `i`.
    pub fn subs(&self, i: usize) -> &[u32] {
        &self.subs[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// The sub-patterns of any set (the pool's sets read the index; others are enumerated).
    fn subs_of(&self, set: ConceptSet) -> Vec<u32> {
        match self.pool_position(set) {
            Some(i) => self.subs(i).to_vec(),
            None => {
                let mut out = Vec::new();
                for_each_subset(set, self.max, |p| out.extend(self.index.get(&p)));
                out
            }
        }
    }

    /// The evidence of every pattern from the evaluated sets (`history`), given the confirmed
    /// cores.
    pub fn fit(&self, _space: &Space, history: &[SetStats], cores: &[ConceptSet], threshold: f64) -> Fit {
        let base = base_rate(history, cores);
        let smoothed =
            |s: &SetStats| (f64::from(s.wrong) + base * PRIOR_WEIGHT) / (f64::from(s.answered()) + PRIOR_WEIGHT);
        let tested: HashMap<ConceptSet, f64> =
            history.iter().filter(|s| s.answered() > 0).map(|s| (s.set, smoothed(s))).collect();
        let mut llr = vec![[0.0; D]; self.pats.len()];
        // Per tested set: its answers, its size, its sub-patterns.
        let mut seen: Vec<(f64, f64, usize, Vec<u32>)> = Vec::new();
        for s in history.iter().filter(|s| s.answered() > 0) {
            // What the set's tested subsets already explain.
            let bg = s.set.proper_subsets().filter_map(|sub| tested.get(&sub)).fold(base, |a, &v| a.max(v));
            let bg = bg.min(1.0 - 1e-9);
            let (w, n) = (f64::from(s.wrong), f64::from(s.answered()));
            let subs = self.subs_of(s.set);
            for &j in &subs {
                let k = s.set.len() - usize::from(self.pat_len[j as usize]);
                for (di, d) in DILUTIONS.iter().enumerate() {
                    let alt = core_rate(base, *d, k).max(bg + 1e-6).min(1.0 - 1e-9);
                    llr[j as usize][di] += w * (alt / bg).ln() + (n - w) * ((1.0 - alt) / (1.0 - bg)).ln();
                }
            }
            seen.push((w, n, s.set.len(), subs));
        }
        let mut est = vec![base; self.pats.len()];
        for (set, v) in &tested {
            if let Some(&j) = self.index.get(set) {
                est[j as usize] = *v;
            }
        }
        // A core fails by definition: a pattern whose own answers pass (the 95 % interval of its
        // failure rate below τ) is none, whatever its supersets did.
        let mut cleared = vec![false; self.pats.len()];
        for s in history.iter().filter(|s| s.answered() > 0 && s.wilson95()[1] < threshold) {
            if let Some(&j) = self.index.get(&s.set) {
                cleared[j as usize] = true;
            }
        }
        // Weak heredity: a pattern one of whose parts fails more often than the base is likelier a
        // core (the paper's failure modes mostly have parts that carry some of the signal).
        let mut lift = vec![0.0; self.pats.len()];
        for (j, l) in lift.iter_mut().enumerate() {
            let parts = &self.parents[self.parent_at[j] as usize..self.parent_at[j + 1] as usize];
            let strongest = parts.iter().map(|&t| est[t as usize]).fold(base, f64::max);
            *l = HEREDITY * ((strongest / base).ln() / (threshold / base).ln().max(1e-6)).clamp(0.0, 1.0);
        }
        // The posterior over d: how well each hypothesis predicts every tested set's answers, each
        // set failing at the base rate or, when some of its sub-patterns are cores (each with that
        // hypothesis' posterior), at the diluted rate of the strongest of them — the expected
        // maximum over independent indicators, strongest first. (Not at its background rate: a
        // set that fails less than its subsets is what dilution means.)
        let mut log_pd = [0.0; D];
        let mut gains: Vec<(f64, f64)> = Vec::new();
        for (di, l) in log_pd.iter_mut().enumerate() {
            for (w, n, len, subs) in &seen {
                gains.clear();
                for &j in subs {
                    let j = j as usize;
                    if cleared[j] {
                        continue;
                    }
                    let k = len - usize::from(self.pat_len[j]);
                    let gain = core_rate(base, DILUTIONS[di], k) - base;
                    let q = 1.0 / (1.0 + (-(self.logit_prior[j] + lift[j] + llr[j][di])).exp());
                    gains.push((gain, q));
                }
                gains.sort_by(|a, b| b.0.total_cmp(&a.0));
                let (mut none, mut expected) = (1.0, 0.0);
                for &(gain, q) in &gains {
                    expected += gain * q * none;
                    none *= 1.0 - q;
                }
                let p = (base + expected).clamp(1e-9, 1.0 - 1e-9);
                *l += w * p.ln() + (n - w) * (1.0 - p).ln();
            }
        }
        for (l, prior) in log_pd.iter_mut().zip(DILUTION_PRIOR) {
            *l += prior.ln();
        }
        let top = log_pd.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut pd = log_pd.map(|l| (l - top).exp());
        let z: f64 = pd.iter().sum();
        pd.iter_mut().for_each(|p| *p /= z);
        Fit { base, llr, est, pd, lift, cleared }
    }
}

/// The evidence of one fit.
pub struct Fit {
    /// The estimated base error.
    pub base: f64,
    /// Per pattern, per dilution hypothesis: log-likelihood ratio "core" vs "explained".
    llr: Vec<[f64; D]>,
    /// Per pattern: its smoothed observed rate where tested, else the base error.
    est: Vec<f64>,
    /// Posterior over the dilution hypotheses.
    pub pd: [f64; D],
    /// Per pattern: the heredity term added to its prior log-odds.
    lift: Vec<f64>,
    /// Per pattern: its own answers pass, so it is no core.
    cleared: Vec<bool>,
}

impl Fit {
    /// Index into [`DILUTIONS`] drawn from the posterior with `u` uniform in [0, 1).
    pub fn draw_dilution(&self, u: f64) -> usize {
        let mut acc = 0.0;
        for (i, p) in self.pd.iter().enumerate() {
            acc += p;
            if u < acc {
                return i;
            }
        }
        D - 1
    }

    /// The probability that pattern `j` is a core under dilution `di` (`open`: false for
    /// patterns that are or hold a confirmed core).
    pub fn q(&self, pats: &Patterns, j: u32, di: usize) -> f64 {
        if self.cleared[j as usize] {
            return 0.0;
        }
        let x = pats.logit_prior[j as usize] + self.lift[j as usize] + self.llr[j as usize][di];
        1.0 / (1.0 + (-x).exp())
    }

    /// The failure rate of a set holding a confirmed core `k` concepts smaller, under dilution
    /// hypothesis `di`.
    pub fn core_rate(&self, di: usize, k: usize) -> f64 {
        core_rate(self.base, DILUTIONS[di], k)
    }

    /// The probability that pattern `j` is a core, averaged over the dilution posterior.
    pub fn q_mean(&self, pats: &Patterns, j: u32) -> f64 {
        (0..D).map(|di| self.pd[di] * self.q(pats, j, di)).sum()
    }

    /// [`Scorer::score`] of the space's set `i` under dilution `di` without the scorer's tables
    /// (the same value, from the set's own sub-patterns): a pick's score under a fit refitted
    /// since its scorer was built.
    #[allow(clippy::too_many_arguments)]
    pub fn score_one(
        &self,
        pats: &Patterns,
        open: &[bool],
        di: usize,
        screen: u32,
        samples: u32,
        tau: f64,
        i: usize,
    ) -> f64 {
        let (miss, bg) = miss_and_background(pats, &self.est, i, |j, k| {
            let q = if open[j] { self.q(pats, j as u32, di) } else { 0.0 };
            1.0 - q * detect(core_rate(self.base, DILUTIONS[di], k), screen, tau)
        });
        per_observation(1.0 - miss, bg, screen, samples, tau)
    }

    /// The scorer of one pick: per pattern q under dilution `di`, and the tables the score reads.
    pub fn scorer(&self, pats: &Patterns, open: &[bool], di: usize, screen: u32, samples: u32, tau: f64) -> Scorer {
        let n = pats.len();
        let q: Vec<f64> = (0..n as u32).map(|j| if open[j as usize] { self.q(pats, j, di) } else { 0.0 }).collect();
        let kmax = pats.set_len.iter().copied().max().unwrap_or(0) as usize;
        let mut miss = vec![1.0; (kmax + 1) * n];
        for k in 0..=kmax {
            let det = detect(core_rate(self.base, DILUTIONS[di], k), screen, tau);
            for j in 0..n {
                miss[k * n + j] = 1.0 - q[j] * det;
            }
        }
        Scorer { miss, n, est: self.est.clone(), screen, samples, tau }
    }
}

/// Scores sets for one pick.
pub struct Scorer {
    /// Per `k · patterns + j`: the chance that a screen of a set `k` concepts larger than pattern
    /// `j` does not reveal it as a new core (1 − q_j · det(k)).
    miss: Vec<f64>,
    n: usize,
    est: Vec<f64>,
    screen: u32,
    samples: u32,
    tau: f64,
}

/// Escalated sets that fail their first m observations are sent to the sequential test and
/// shrinking: about this many observations (measured on the shipped profiles).
const FOLLOW_UP_COST: f64 = 15.0;

impl Scorer {
    /// The chance that testing the space's set `i` reveals a new core.
    pub fn value(&self, pats: &Patterns, i: usize) -> f64 {
        1.0 - self.miss_and_background(pats, i).0
    }

    fn miss_and_background(&self, pats: &Patterns, i: usize) -> (f64, f64) {
        miss_and_background(pats, &self.est, i, |j, k| self.miss[k * self.n + j])
    }

    /// The chance that testing the space's set `i` reveals a new core, per expected observation.
    pub fn score(&self, pats: &Patterns, i: usize) -> f64 {
        let (miss, bg) = self.miss_and_background(pats, i);
        per_observation(1.0 - miss, bg, self.screen, self.samples, self.tau)
    }
}

/// Of the space's set `i`: the chance that a screen reveals none of its sub-patterns as a core
/// (the product of `miss(j, k)` over its patterns j, each k concepts smaller than the set), and
/// the highest estimated rate `est` among them (what it fails at without a new core).
fn miss_and_background(pats: &Patterns, est: &[f64], i: usize, miss: impl Fn(usize, usize) -> f64) -> (f64, f64) {
    let (from, to) = (pats.offsets[i] as usize, pats.offsets[i + 1] as usize);
    let mut product = 1.0;
    let mut bg: f64 = 0.0;
    for (&j, &k) in pats.subs[from..to].iter().zip(&pats.extra[from..to]) {
        product *= miss(j as usize, usize::from(k));
        bg = bg.max(est[j as usize]);
    }
    (product, bg)
}

/// The chance that a screen of `screen` observations of a set failing at `r` shows it failing,
/// times the chance that its sequential test then takes it past τ.
fn detect(r: f64, screen: u32, tau: f64) -> f64 {
    (1.0 - (1.0 - r).powi(screen as i32)) / (1.0 + (-(r - tau) / CONFIRM_STEP).exp())
}

/// A set's chance `value` of revealing a new core per observation it is expected to take: its
/// screen, the escalation to m when the screen answers wrong at its background rate `bg`, and
/// the follow-up when its m observations fail.
fn per_observation(value: f64, bg: f64, screen: u32, samples: u32, tau: f64) -> f64 {
    let s = f64::from(screen);
    let m = f64::from(samples);
    let escalate = 1.0 - (1.0 - bg).powf(s);
    let follow = at_least(samples, (tau * m).ceil() as u32, bg);
    value / (s + escalate * (m - s).max(0.0) + follow * FOLLOW_UP_COST)
}

/// P(Binomial(n, p) ≥ k).
fn at_least(n: u32, k: u32, p: f64) -> f64 {
    let mut c = 1.0;
    let mut total = 0.0;
    for i in 0..=n {
        if i > 0 {
            c = c * f64::from(n - i + 1) / f64::from(i);
        }
        if i >= k {
            total += c * p.powi(i as i32) * (1.0 - p).powi((n - i) as i32);
        }
    }
    total
}

/// The failure rate of a set holding a core `k` concepts smaller, under dilution `d`.
fn core_rate(base: f64, d: f64, k: usize) -> f64 {
    base + (CORE_RATE - base).max(0.0) * (1.0 - d).powi(k as i32)
}

/// The base error: pooled over sets that hold no confirmed core and fail less than half the time,
/// with one wrong answer in twenty as a prior; kept in [0.005, 0.3].
fn base_rate(history: &[SetStats], cores: &[ConceptSet]) -> f64 {
    let (mut w, mut a) = (0u64, 0u64);
    for s in history {
        if s.answered() == 0 || s.value() >= BASE_FROM_BELOW || cores.iter().any(|c| c.is_subset_of(s.set)) {
            continue;
        }
        w += u64::from(s.wrong);
        a += u64::from(s.answered());
    }
    ((w as f64 + 1.0) / (a as f64 + 20.0)).clamp(0.005, 0.3)
}

/// Σ_{k ≤ max} C(n, k).
fn sub_count(n: usize, max: usize) -> usize {
    let mut c = 1usize;
    let mut total = 0;
    for k in 1..=max.min(n) {
        c = c * (n - k + 1) / k;
        total += c;
    }
    total
}

/// Calls `f` with every non-empty subset of `set` of at most `max` concepts, smaller first.
fn for_each_subset(set: ConceptSet, max: usize, mut f: impl FnMut(ConceptSet)) {
    let bits: Vec<ConceptId> = set.iter().collect();
    for k in 1..=max.min(bits.len()) {
        subsets_of_size(&bits, 0, k, ConceptSet::EMPTY, &mut f);
    }
}

/// Calls `f` with every subset of `set` of exactly `k` concepts, in concept order.
pub(super) fn for_each_subset_of_size(set: ConceptSet, k: usize, mut f: impl FnMut(ConceptSet)) {
    let bits: Vec<ConceptId> = set.iter().collect();
    if k > 0 && k <= bits.len() {
        subsets_of_size(&bits, 0, k, ConceptSet::EMPTY, &mut f);
    }
}

/// `acc` with `left` more of `bits[from..]`, each way, to `f`.
fn subsets_of_size(bits: &[ConceptId], from: usize, left: usize, acc: ConceptSet, f: &mut impl FnMut(ConceptSet)) {
    if left == 0 {
        f(acc);
        return;
    }
    for i in from..bits.len() {
        subsets_of_size(bits, i + 1, left - 1, acc.with(bits[i]), f);
    }
}

#[cfg(test)]
mod tests;

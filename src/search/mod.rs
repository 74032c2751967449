//! The search runtime: Random, diversity-aware Beam search (paper Algorithm 1) and GP Thompson
//! sampling (Algorithm 2) over the valid concept lattice, the sequential test that decides how
//! many observations a set gets ([`sequential`]), and shrinking failure modes to minimal cores
//! ([`shrink`]).
//!
//! Every decision an algorithm makes is a pure function of the run seed and the failure rates it
//! has observed: candidate orders are fixed, ties break on the canonical set order, and random
//! draws come from a ChaCha stream seeded by the run seed. Resuming a run therefore replays the
//! algorithm from the start against the journal ([`crate::journal`]): finished observations are
//! served from it, and the run continues exactly where the killed one stopped.
//!
//! Budgets count inferences (every observation, answered or not; one model call each), and
//! `--budget` caps every phase of a search together ([`Params::max_calls`]); how it is split among
//! the phases is [`budget::Plan`] ([`Params::plan`]). With the paper's fixed count an algorithm
//! evaluates at most `plan().search / samples` sets, each with `samples` observations; with
//! sequential sampling ([`Rule`]) a set may get up to `max_samples`, and fewer sets fit. No set is
//! evaluated twice: more observations of a set continue its observation indices.
//!
//! Building blocks for other algorithms: a [`Driver`] holds the budget and the history;
//! through the [`Drive`] trait, [`Drive::evaluate`] evaluates new sets under the rule,
//! [`Drive::top_up`] gives settled or unsettled sets the observations the rule asks for,
//! [`Drive::test`] does either for one set, and [`shrink::shrink`] reduces one failing set to a
//! minimal failing subset through a driver, or through a [`lanes::Lane`] of one, beside others.

pub mod beam;
pub mod budget;
pub mod confirm;
pub mod cs;
pub mod ebh;
pub mod gp;
pub mod gp_rbf;
pub mod gpts;
pub mod interact;
pub mod interval;
pub mod lanes;
pub mod metrics;
pub mod patterns;
pub mod random;
pub mod sequential;
pub mod shrink;
pub mod space;
pub mod surrogate;

use std::collections::{HashMap, HashSet};
use std::future::Future;
use std::ops::Range;

use serde::{Deserialize, Serialize};

use crate::ir::ConceptSet;
pub use metrics::SetStats;
pub use sequential::Rule;
pub use space::Space;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Algo {
    Random,
    Beam,
    Gpts,
    Interact,
}

impl Algo {
    /// Every algorithm, in the order help texts and benchmarks list them.
    pub const ALL: [Algo; 4] = [Algo::Random, Algo::Beam, Algo::Gpts, Algo::Interact];

    pub fn name(self) -> &'static str {
        match self {
            Algo::Random => "random",
            Algo::Beam => "beam",
            Algo::Gpts => "gpts",
            Algo::Interact => "interact",
        }
    }
}

impl std::str::FromStr for Algo {
    type Err = String;
    fn from_str(s: &str) -> Result<Algo, String> {
        Algo::ALL.into_iter().find(|a| a.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Algo::ALL.iter().map(|a| a.name()).collect();
            format!("unknown algorithm `{s}`: expected one of {}", names.join(", "))
        })
    }
}

/// Default diversity weight λ of the beam value FR − λ·max Jaccard. With m = 5 a failure-rate
/// step is 0.2; two sets of size t that share t−1 concepts have Jaccard (t−1)/(t+1), so at
/// λ = 0.5 a near-duplicate sibling costs 0.17 at level 2 and 0.25 at level 3: diversity breaks
/// ties and outweighs one observation from level 3 on, but never a clearly stronger set (two
/// observations, 0.4). Benchmarks in `docs/search.md` show PFM is flat in λ at the paper's
/// budget.
pub const DEFAULT_LAMBDA: f64 = 0.5;

/// Search parameters (the paper's defaults in [`Params::default`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Params {
    pub algo: Algo,
    /// The most model calls the command makes, every phase included ([`Params::max_calls`]).
    pub budget: u64,
    /// Observations per set (m).
    pub samples: u32,
    /// Failure threshold τ.
    pub threshold: f64,
    pub beam_width: usize,
    pub max_depth: usize,
    pub lambda: f64,
    /// GPTS: inferences spent in the beam phase.
    pub beam_budget: u64,
    /// GPTS: Thompson draws (and sets evaluated in parallel) per round.
    pub batch: usize,
    /// GPTS: the GP kernel (the paper's DotProduct + White unless its kernel ablation asks for
    /// RBF + White).
    #[serde(default, skip_serializing_if = "gp::Kernel::is_default")]
    pub kernel: gp::Kernel,
    pub seed: u64,
    /// Largest set size in the lattice.
    pub max_size: usize,
    /// Interact: the surrogate.
    #[serde(default)]
    pub surrogate: interact::Surrogate,
    /// Interact: what happens to the supersets of a confirmed core.
    #[serde(default)]
    pub supersets: interact::Supersets,
    /// Sequential sampling: the most observations a set can get (`None`: exactly `samples`, the
    /// paper's fixed count).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_samples: Option<u32>,
    /// The part of `budget` set aside for shrinking failure modes to cores after the search and
    /// confirming them on fresh scenes (0: neither). The paper's algorithms search with
    /// `budget − shrink`; `interact`, which shrinks as it searches, keeps `shrink` for
    /// confirming the minimal failure modes no core of its explains, and confirmation's share
    /// per core besides ([`budget::Plan`]).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shrink: u64,
    /// The indifference zone δ around τ of the anytime-valid test ([`cs`]): a reported core is
    /// established above τ − δ, a set passes once established below τ + δ (`--delta`).
    #[serde(default = "default_delta", skip_serializing_if = "is_default_delta")]
    pub delta: f64,
    /// The false discovery rate q the confirmed cores are held to by e-BH ([`ebh`], `--fdr`).
    #[serde(default = "default_fdr", skip_serializing_if = "is_default_fdr")]
    pub fdr: f64,
}

/// The default indifference zone δ: a 0.85 mode is established above τ − δ = 0.5 in about 10
/// observations, a 0.7 one in about 40; testing against τ itself would take hundreds.
pub const DEFAULT_DELTA: f64 = 0.1;

/// The default false discovery rate of the confirmed cores.
pub const DEFAULT_FDR: f64 = 0.05;

fn default_delta() -> f64 {
    DEFAULT_DELTA
}

fn is_default_delta(x: &f64) -> bool {
    *x == DEFAULT_DELTA
}

fn default_fdr() -> f64 {
    DEFAULT_FDR
}

fn is_default_fdr(x: &f64) -> bool {
    *x == DEFAULT_FDR
}

fn is_zero(x: &u64) -> bool {
    *x == 0
}

/// The default shrink budget is this share of the budget (`--shrink`): 1/4. Shrinking one failure
/// family of size 4–5 to a pair costs about 60–120 inferences with the sequential test (each
/// subset 5–20 observations), so a quarter of 1000 confirms the strongest 3–5 families — a
/// handful of distinct findings. The paper's setting is `--shrink 0` (a 1000-call search).
pub const SHRINK_SHARE: u64 = 4;

/// The shrink phase always tests sequentially: up to `--max-samples`, or this many times m when
/// the search itself ran with the fixed count. A core kept on 3 of 5 wrong answers would be
/// wrong one time in four at an error of 0.35 (a single concept's partial effect); at up to 20
/// observations it is wrong about once in a hundred.
pub const SHRINK_MAX_FACTOR: u32 = 4;

/// `--algo interact` confirms cores with up to this many times m observations.
pub const CONFIRM_MAX_FACTOR: u32 = 8;

impl Default for Params {
    fn default() -> Params {
        Params {
            algo: Algo::Gpts,
            budget: 1000,
            samples: 5,
            threshold: 0.6,
            beam_width: 5,
            max_depth: 5,
            lambda: DEFAULT_LAMBDA,
            beam_budget: 500,
            batch: 1,
            kernel: gp::Kernel::Dot,
            seed: 0,
            max_size: 5,
            surrogate: interact::Surrogate::default(),
            supersets: interact::Supersets::default(),
            max_samples: None,
            shrink: 0,
            delta: DEFAULT_DELTA,
            fdr: DEFAULT_FDR,
        }
    }
}

impl Params {
    /// Whether the parameter named `key` (as `config.json` names it) steers `algo`: the beam's
    /// width, depth and λ only beam and GPTS (its warm-up), the beam budget and kernel only GPTS,
    /// the batch GPTS and interact, the surrogate and supersets policy only interact; the rest
    /// every algorithm.
    pub fn applies(key: &str, algo: Algo) -> bool {
        match key {
            "beam_width" | "max_depth" | "lambda" => matches!(algo, Algo::Beam | Algo::Gpts),
            "beam_budget" | "kernel" => algo == Algo::Gpts,
            "batch" => matches!(algo, Algo::Gpts | Algo::Interact),
            "surrogate" | "supersets" => algo == Algo::Interact,
            _ => true,
        }
    }

    /// Check values a user can get wrong; the message names the flag.
    pub fn validate(&self) -> Result<(), String> {
        let bad = |flag: &str, why: &str| Err(format!("invalid `--{flag}`: {why}"));
        if self.samples == 0 {
            return bad("samples", "must be at least 1");
        }
        if self.budget < u64::from(self.samples) {
            return bad(
                "budget",
                &format!("{} inferences cannot evaluate one set of {} samples", self.budget, self.samples),
            );
        }
        if !(0.0..=1.0).contains(&self.threshold) {
            return bad("threshold", &format!("must be between 0 and 1, got {}", self.threshold));
        }
        if self.beam_width == 0 {
            return bad("beam-width", "must be at least 1");
        }
        if self.max_depth == 0 {
            return bad("max-depth", "must be at least 1");
        }
        if !self.lambda.is_finite() || self.lambda < 0.0 {
            return bad("lambda", &format!("must be a non-negative number, got {}", self.lambda));
        }
        if self.algo != Algo::Interact && self.shrink > 0 && self.plan().search < u64::from(self.samples) {
            return bad(
                "shrink",
                &format!(
                    "{} of a budget of {} model calls leaves the search too few for one set of {} samples",
                    self.shrink, self.budget, self.samples
                ),
            );
        }
        if self.beam_budget > self.plan().search {
            return bad(
                "beam-budget",
                &format!("{} exceeds the search's budget {}", self.beam_budget, self.plan().search),
            );
        }
        if self.batch == 0 {
            return bad("batch", "must be at least 1");
        }
        if self.max_size == 0 || self.max_size > crate::ir::MAX_CONCEPTS {
            return bad("max-size", "must be between 1 and 512");
        }
        if let Some(max) = self.max_samples.filter(|&m| m < self.samples) {
            return bad("max-samples", &format!("must be at least `--samples` ({}), got {max}", self.samples));
        }
        if self.shrink > 0 && self.shrink < u64::from(self.samples) {
            return bad(
                "shrink",
                &format!(
                    "{} inferences cannot test one subset of {} samples (0 turns shrinking off)",
                    self.shrink, self.samples
                ),
            );
        }
        if !(self.delta >= 0.0 && self.delta < 0.5) {
            return bad("delta", &format!("must be at least 0 and below 0.5, got {}", self.delta));
        }
        if !(self.fdr > 0.0 && self.fdr < 1.0) {
            return bad("fdr", &format!("must be above 0 and below 1, got {}", self.fdr));
        }
        if self.algo == Algo::Gpts && self.kernel == gp::Kernel::Rbf && self.max_size > gp_rbf::MAX_DRAW_SET {
            return bad(
                "kernel",
                &format!(
                    "rbf's exact Thompson draw sums over every subset of a set, so it needs `--max-size` ≤ {}, got {}",
                    gp_rbf::MAX_DRAW_SET,
                    self.max_size
                ),
            );
        }
        Ok(())
    }

    /// The search's sequential rule (fixed m unless `max_samples` is set).
    pub fn rule(&self) -> Rule {
        Rule::sequential(self.samples, self.max_samples.unwrap_or(self.samples), self.threshold)
    }

    /// The shrink phase's rule: always sequential ([`SHRINK_MAX_FACTOR`]).
    pub fn shrink_rule(&self) -> Rule {
        let max = self.max_samples.filter(|&m| m > self.samples).unwrap_or(SHRINK_MAX_FACTOR * self.samples);
        Rule::sequential(self.samples, max, self.threshold)
    }

    /// The rule `--algo interact` confirms a core with: m observations, then the sequential test
    /// up to `--max-samples` or 8·m (40 at m = 5: a 0.5 concept passes for a 0.6 one one time in
    /// seven, against one in four at 20).
    pub fn confirm_rule(&self) -> Rule {
        let max = self.max_samples.filter(|&m| m > self.samples).unwrap_or(CONFIRM_MAX_FACTOR * self.samples);
        Rule::sequential(self.samples, max, self.threshold)
    }

    /// The most model calls the search command makes, every phase included (search, sequential
    /// top-ups, confirmation, shrink): `--budget`.
    pub fn max_calls(&self) -> u64 {
        self.budget
    }

    /// How `--budget` is split among the search, the shrink phase and fresh confirmation: the
    /// one place that decides it ([`budget::Plan`]).
    pub fn plan(&self) -> budget::Plan {
        let cap = self.confirm_rule().max_samples;
        budget::Plan::new(
            self.budget,
            self.shrink,
            self.algo == Algo::Interact,
            self.threshold,
            self.delta,
            self.samples,
            cap,
        )
    }

    /// How fresh confirmation runs with these parameters and `budget` inferences.
    pub fn confirm_plan(&self, budget: u64) -> confirm::Plan {
        confirm::Plan {
            tau: self.threshold,
            delta: self.delta,
            q: self.fdr,
            batch: self.samples,
            cap: self.confirm_rule().max_samples,
            extended: match self.max_samples {
                Some(_) => self.confirm_rule().max_samples,
                None => confirm::EXTEND_FACTOR * self.confirm_rule().max_samples,
            },
            budget,
        }
    }

    /// Sets the search phase's budget pays for with the fixed count.
    pub fn max_sets(&self) -> usize {
        (self.plan().search / u64::from(self.samples)) as usize
    }

    /// The default `--shrink` for a budget.
    pub fn default_shrink(budget: u64) -> u64 {
        budget / SHRINK_SHARE
    }
}

/// Observations `obs` (indices) of `set`. Indices continue a set's earlier observations, so an
/// evaluator can derive each scene from (set, index) and serve any it already holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ask {
    pub set: ConceptSet,
    pub obs: Range<u32>,
}

impl Ask {
    pub fn len(&self) -> u32 {
        self.obs.end.saturating_sub(self.obs.start)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Makes observations of concept sets, concurrently.
pub trait Evaluate {
    /// Why observations could not be made (a run's evaluator: a stopped run, a failing model);
    /// the search hands it back to its caller as it is, in [`SearchError::Eval`].
    type Error;

    /// Make the asked observations; returns, per ask and in order, the stats of those
    /// observations alone (the caller adds them to what it had).
    fn evaluate(&mut self, asks: &[Ask]) -> impl Future<Output = Result<Vec<SetStats>, Self::Error>>;
}

/// Why a search ended before its budget did: its evaluator failed (the evaluator's own error,
/// typed, so the caller reports the real cause), or the search itself could not go on.
#[derive(Debug, Clone, PartialEq)]
pub enum SearchError<E> {
    Eval(E),
    /// A surrogate that could not be fitted, with the reason.
    Search(String),
}

impl<E: std::fmt::Display> std::fmt::Display for SearchError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SearchError::Eval(e) => e.fmt(f),
            SearchError::Search(m) => f.write_str(m),
        }
    }
}

/// The result of a search step driven by evaluator `E`.
pub type Searched<T, E> = Result<T, SearchError<<E as Evaluate>::Error>>;

/// What a search's model calls were for (`--algo interact`): screening new sets, escalating the
/// ones that answered wrong, explaining a failing set (jumps to likely cores and the triage's
/// shrinking), and confirming a core under the full rule.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Purpose {
    Screening,
    Escalation,
    Explaining,
    Confirmation,
}

/// Model calls by [`Purpose`].
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CallsBy {
    pub screening: u64,
    pub escalation: u64,
    pub explaining: u64,
    pub confirmation: u64,
}

impl CallsBy {
    fn add(&mut self, purpose: Purpose, n: u64) {
        *match purpose {
            Purpose::Screening => &mut self.screening,
            Purpose::Escalation => &mut self.escalation,
            Purpose::Explaining => &mut self.explaining,
            Purpose::Confirmation => &mut self.confirmation,
        } += n;
    }

    pub fn total(&self) -> u64 {
        self.screening + self.escalation + self.explaining + self.confirmation
    }
}

/// Fills a call narrower than the width: given the history, the call's asks and how many
/// observations fit, the asks to add: new sets' screens, or more observations of evaluated sets
/// continuing their indices ([`Driver::fill_to`]).
pub type Fill<'e> = Box<dyn FnMut(&[SetStats], &[Ask], usize) -> Vec<Ask> + 'e>;

/// What a search step tests through: the [`Driver`] itself, or a lane of it that explains one
/// failing set beside others ([`lanes`]). Steps written against it (a shrink, interact's
/// explaining) run either way; the driver's evaluate, top-up and test are defined here once.
#[allow(async_fn_in_trait, reason = "the search futures run on one thread; no Send bound is needed")]
pub trait Drive {
    type Eval: Evaluate;

    /// The sequential rule the next observations are asked under.
    fn rule(&self) -> Rule;

    fn set_rule(&mut self, rule: Rule);

    /// What the calls made now are for, when the algorithm says (interact).
    fn set_purpose(&mut self, purpose: Option<Purpose>);

    /// Inferences this driver may still spend.
    fn remaining(&self) -> u64;

    /// Change the budget (GPTS caps it for its beam phase, then restores it; interact keeps fresh
    /// confirmation's share for each core it finds).
    fn set_budget(&mut self, budget: u64);

    /// Everything observed of `set` so far.
    fn get(&self, set: ConceptSet) -> Option<SetStats>;

    /// `f` of every evaluated set, in the order each was first evaluated.
    fn with_history<R>(&self, f: impl FnOnce(&[SetStats]) -> R) -> R;

    /// How many sets a step that tests sets one after another (a shrink's one-smaller subsets)
    /// tests together.
    fn lookahead(&self) -> usize;

    /// Make the asked observations and record them.
    async fn call(&mut self, asks: Vec<Ask>) -> Searched<(), Self::Eval>;

    /// Whether the budget still pays the first m observations of a new set.
    fn can_start(&self) -> bool {
        self.remaining() >= u64::from(self.rule().samples)
    }

    /// Evaluate the sets not evaluated yet, in order, as far as the budget goes, and top up the
    /// requested sets evaluated before; returns the stats of every requested set that has been
    /// evaluated (now or before), in request order.
    ///
    /// New sets go in chunks that the budget pays even if every set takes M observations
    /// (`remaining / M`, at least one): each chunk gets its m observations concurrently, then
    /// top-up rounds until all its sets are settled, then the next chunk. So top-ups are never
    /// starved by sets evaluated later, and with M = m the whole request is one chunk cut at
    /// `remaining / m` sets — the paper's estimator, unchanged.
    async fn evaluate(&mut self, sets: &[ConceptSet]) -> Searched<Vec<SetStats>, Self::Eval> {
        let mut fresh = Vec::new();
        let mut batch = HashSet::new();
        let mut earlier = Vec::new();
        for &s in sets {
            if !batch.insert(s) {
                continue;
            }
            if self.get(s).is_some() { earlier.push(s) } else { fresh.push(s) }
        }
        let rule = self.rule();
        let (m, max) = (u64::from(rule.samples), u64::from(rule.max_samples.max(rule.samples)));
        let mut next = 0;
        while next < fresh.len() {
            let affordable = (self.remaining() / m) as usize;
            if affordable == 0 {
                break;
            }
            let chunk = ((self.remaining() / max) as usize).max(1).min(affordable).min(fresh.len() - next);
            let sets = &fresh[next..next + chunk];
            let asks: Vec<Ask> = sets.iter().map(|&set| Ask { set, obs: 0..rule.samples }).collect();
            self.call(asks).await?;
            self.top_up(sets).await?;
            next += chunk;
        }
        self.top_up(&earlier).await?;
        Ok(sets.iter().filter_map(|s| self.get(*s)).collect())
    }

    /// Give evaluated sets the observations the rule asks for ([`Rule::next`]), round after
    /// round, until every one is settled or the budget is spent (the last batch may be cut
    /// short). Sets not evaluated yet are ignored.
    async fn top_up(&mut self, sets: &[ConceptSet]) -> Searched<(), Self::Eval> {
        let rule = self.rule();
        loop {
            let mut left = self.remaining();
            let mut asks: Vec<Ask> = Vec::new();
            for &set in sets {
                let Some(s) = self.get(set) else { continue };
                if left == 0 || asks.iter().any(|a| a.set == set) {
                    continue;
                }
                let k = u64::from(rule.next(&s)).min(left);
                if k > 0 {
                    let n = s.observations();
                    asks.push(Ask { set, obs: n..n + k as u32 });
                    left -= k;
                }
            }
            if asks.is_empty() {
                return Ok(());
            }
            self.call(asks).await?;
        }
    }

    /// `k` more observations of the evaluated `set` whatever the rule says (at most what the
    /// budget has left); false when it was not evaluated or nothing could be paid.
    async fn observe_more(&mut self, set: ConceptSet, k: u32) -> Searched<bool, Self::Eval> {
        let Some(s) = self.get(set) else { return Ok(false) };
        let k = u64::from(k).min(self.remaining()) as u32;
        if k == 0 {
            return Ok(false);
        }
        let n = s.observations();
        self.call(vec![Ask { set, obs: n..n + k }]).await?;
        Ok(true)
    }

    /// Evaluate `set` or top it up under the rule; `None` when it is new and the budget cannot
    /// pay its first m observations.
    async fn test(&mut self, set: ConceptSet) -> Searched<Option<SetStats>, Self::Eval> {
        Ok(self.evaluate(&[set]).await?.into_iter().next())
    }
}

impl<E: Evaluate> Drive for Driver<'_, E> {
    type Eval = E;

    fn rule(&self) -> Rule {
        self.rule
    }

    fn set_rule(&mut self, rule: Rule) {
        self.rule = rule;
    }

    fn set_purpose(&mut self, purpose: Option<Purpose>) {
        self.purpose = purpose;
    }

    fn remaining(&self) -> u64 {
        self.budget.saturating_sub(self.spent)
    }

    fn set_budget(&mut self, budget: u64) {
        self.budget = budget;
    }

    fn get(&self, set: ConceptSet) -> Option<SetStats> {
        self.stats(set).cloned()
    }

    fn with_history<R>(&self, f: impl FnOnce(&[SetStats]) -> R) -> R {
        f(&self.history)
    }

    /// The width over m when calls are filled ([`Driver::fill_to`]), else one.
    fn lookahead(&self) -> usize {
        match &self.fill {
            Some((width, ..)) => (*width / self.rule.samples.max(1) as usize).max(1),
            None => 1,
        }
    }

    async fn call(&mut self, asks: Vec<Ask>) -> Searched<(), E> {
        self.call_parts(vec![(self.purpose, asks)]).await
    }
}

/// Budget, history and the sequential rule, shared by the algorithms and the shrink phase.
pub struct Driver<'e, E> {
    eval: &'e mut E,
    /// Every evaluated set, in the order it was first evaluated, with all its observations.
    pub history: Vec<SetStats>,
    /// Index into `history` of every evaluated set.
    seen: HashMap<ConceptSet, usize>,
    rule: Rule,
    /// Inferences this driver may spend.
    budget: u64,
    spent: u64,
    /// Calls in flight a call is filled to, observations per filling set, and the filler. Not
    /// dropped with the driver (a driver owns nothing that needs dropping, so the evaluator it
    /// borrows is free again as soon as it is last used): [`Driver::clear_fill`] drops it.
    fill: Option<(usize, u32, std::mem::ManuallyDrop<Fill<'e>>)>,
    /// Sets the filler added, not yet taken by the search ([`Driver::take_filled`]).
    filled: Vec<ConceptSet>,
    /// What the calls made now are for, when the algorithm says (interact).
    pub purpose: Option<Purpose>,
    /// Calls by purpose (those made with a purpose set).
    pub calls_by: CallsBy,
}

impl<'e, E: Evaluate> Driver<'e, E> {
    pub fn new(eval: &'e mut E, rule: Rule, budget: u64) -> Self {
        Driver::with_history(eval, rule, budget, Vec::new())
    }

    /// A driver that knows `history` (sets evaluated earlier, e.g. by the search before a shrink
    /// phase): asking for them again tops them up instead of starting over. `budget` counts
    /// from now.
    pub fn with_history(eval: &'e mut E, rule: Rule, budget: u64, history: Vec<SetStats>) -> Self {
        let seen = history.iter().enumerate().map(|(i, s)| (s.set, i)).collect();
        Driver {
            eval,
            history,
            seen,
            rule,
            budget,
            spent: 0,
            fill: None,
            filled: Vec::new(),
            purpose: None,
            calls_by: CallsBy::default(),
        }
    }

    /// Fill every call to a multiple of `width` observations (the calls in flight) with the asks
    /// `fill` makes (a new set gets `obs` observations), as far as the budget goes: so a search
    /// whose steps ask about a few sets at a time (a shrink, a confirmation) still keeps the
    /// model busy. The new sets added are the search's to decide on: [`Driver::take_filled`].
    pub fn fill_to(&mut self, width: usize, obs: u32, fill: Fill<'e>) {
        self.clear_fill();
        self.fill = Some((width.max(1), obs.max(1), std::mem::ManuallyDrop::new(fill)));
    }

    /// Stop filling calls, and drop the filler.
    pub fn clear_fill(&mut self) {
        if let Some((.., fill)) = self.fill.take() {
            drop(std::mem::ManuallyDrop::into_inner(fill));
        }
    }

    /// The sets the filler added since the last call, in the order they were asked.
    pub fn take_filled(&mut self) -> Vec<ConceptSet> {
        std::mem::take(&mut self.filled)
    }

    /// Make the asked observations of one call, each part's asks counted to its purpose (filled,
    /// see [`Driver::fill_to`]), and record them. An ask for a set that an earlier part of the
    /// call also asks about extends that ask (the parts counted their ranges from the same
    /// observations), so one call never shows a scene twice.
    pub(crate) async fn call_parts(&mut self, parts: Vec<(Option<Purpose>, Vec<Ask>)>) -> Searched<(), E> {
        let mut all: Vec<Ask> = Vec::new();
        let mut purposes: Vec<Option<Purpose>> = Vec::new();
        for (purpose, asks) in parts {
            for ask in asks {
                match all.iter_mut().find(|a| a.set == ask.set) {
                    Some(a) => a.obs.end += ask.len(),
                    None => {
                        all.push(ask);
                        purposes.push(purpose);
                    }
                }
            }
        }
        let own = all.len();
        if let Some((width, obs, fill)) = &mut self.fill {
            let asked: u64 = all.iter().map(|a| u64::from(a.len())).sum();
            let width = *width as u64;
            let affordable = self.budget.saturating_sub(self.spent + asked);
            let mut room = ((width - asked % width) % width).min(affordable);
            if room > 0 {
                for ask in fill(&self.history, &all, room as usize) {
                    let n = self.seen.get(&ask.set).map_or(0, |&i| self.history[i].observations());
                    // A new set gets its screen; an evaluated one continues its observations.
                    let fits = if n == 0 { ask.obs == (0..*obs) } else { ask.obs.start == n && !ask.is_empty() };
                    if fits && u64::from(ask.len()) <= room && !all.iter().any(|a| a.set == ask.set) {
                        room -= u64::from(ask.len());
                        purposes.push(Some(if n == 0 { Purpose::Screening } else { Purpose::Escalation }));
                        all.push(ask);
                    }
                }
            }
        }
        let stats = self.eval.evaluate(&all).await.map_err(SearchError::Eval)?;
        self.filled.extend(all[own..].iter().filter(|a| a.obs.start == 0).map(|a| a.set));
        self.record(&all, &purposes, stats);
        Ok(())
    }

    /// The calls in flight every call is filled to ([`Driver::fill_to`]), if it is.
    pub fn width(&self) -> Option<usize> {
        self.fill.as_ref().map(|(width, ..)| *width)
    }

    pub fn budget(&self) -> u64 {
        self.budget
    }

    /// Inferences spent through this driver.
    pub fn spent(&self) -> u64 {
        self.spent
    }

    pub fn seen(&self, set: ConceptSet) -> bool {
        self.seen.contains_key(&set)
    }

    /// Everything observed of `set` so far.
    pub fn stats(&self, set: ConceptSet) -> Option<&SetStats> {
        self.seen.get(&set).map(|&i| &self.history[i])
    }

    fn record(&mut self, asks: &[Ask], purposes: &[Option<Purpose>], stats: Vec<SetStats>) {
        debug_assert_eq!(asks.len(), stats.len());
        for ((ask, purpose), s) in asks.iter().zip(purposes).zip(stats) {
            debug_assert_eq!(s.observations(), ask.len(), "the evaluator answers what was asked");
            self.spent += u64::from(ask.len());
            if let Some(p) = *purpose {
                self.calls_by.add(p, u64::from(ask.len()));
            }
            match self.seen.get(&ask.set) {
                Some(&i) => self.history[i].merge(&s),
                None => {
                    self.seen.insert(ask.set, self.history.len());
                    self.history.push(s);
                }
            }
        }
    }
}

/// Run the chosen algorithm; returns every evaluated set in evaluation order.
pub async fn run<E: Evaluate>(params: &Params, space: &Space, eval: &mut E) -> Searched<Vec<SetStats>, E> {
    Ok(run_counted(params, space, eval).await?.0)
}

/// [`run`], with where the calls went (interact; `None` for the paper's algorithms).
pub async fn run_counted<E: Evaluate>(
    params: &Params,
    space: &Space,
    eval: &mut E,
) -> Searched<(Vec<SetStats>, Option<CallsBy>), E> {
    let mut driver = Driver::new(eval, params.rule(), params.plan().search);
    match params.algo {
        Algo::Random => random::run(params, space, &mut driver).await?,
        Algo::Beam => beam::run(params, space, &mut driver).await?,
        Algo::Gpts => gpts::run(params, space, &mut driver).await?,
        Algo::Interact => interact::run(params, space, &mut driver).await?,
    }
    let calls = (params.algo == Algo::Interact).then(|| driver.calls_by.clone());
    Ok((driver.history, calls))
}

#[cfg(test)]
mod tests;

//! `--algo interact`: a search for every distinct failure mode, each reported once as its core.
//!
//! Two surrogates ([`Surrogate`]):
//!
//! - **`patterns`** (the default): group testing ([`super::patterns`]). A round picks `batch`
//!   unexplored open sets (holding no confirmed core), each the set with the best chance per
//!   expected observation of revealing a new core under a dilution drawn from its posterior. A
//!   pick is *screened* with [`SCREEN`] observation; a wrong answer escalates it to [`ESCALATE`]
//!   observations and more while they leave it undecided. A set that fails is explained at once:
//!   its likeliest sub-patterns (at most [`JUMPS`]) are tested and shrunk, and if none holds up
//!   the set itself is shrunk one concept at a time ([`super::shrink::shrink`]). The escalation
//!   and this explaining use the confirmation rule's sequential test at 80 % ([`TRIAGE_Z`]),
//!   which decides the many sets with a part of a failure mode's signal in half the
//!   observations. A core this triage finds is shrunk again under the confirmation rule
//!   itself ([`Params::confirm_rule`] with the indifference zone `--delta`: the anytime-valid
//!   test of [`super::cs`], a core established above τ − δ): the core and its one-smaller
//!   subsets are topped up
//!   until they settle, and it is confirmed only if it still holds. A confirmed core's supersets
//!   leave the open sets (exclusion) and it closes every pattern that holds it (conditioning), so
//!   the next picks go looking for the next family. A failing set that does not lift over a
//!   passing subset near τ ([`Shrunk::NotDistinct`]) is no core, and that subset's family is set
//!   aside the same way ([`PatternSearcher::explain`]) without being reported; so is a core's
//!   when its test, which may go to [`CORE_TEST_STRETCH`] times the rule's M, ends undecided.
//! - **`horseshoe`**, **`ridge`**, **`linear`**: Thompson sampling with a Bayesian regression on
//!   concept indicators and their pairwise products ([`super::surrogate`]), as in BOCS. A round:
//!   a few Gibbs sweeps on every evaluated set (warm-started), `batch` draws, and for each the
//!   unexplored open set with the highest drawn failure rate. A picked set that fails is shrunk
//!   under the shrink phase's rule; its core leaves the open sets and becomes an indicator feature
//!   of the surrogate. When a draw finds no open set with a drawn failure rate of at least τ,
//!   every other such draw measures the known families' extent (the best unexplored superset of a
//!   confirmed core) while the others keep exploring.
//!
//! Confirmation and shrinking spend the search's budget: the run as a whole stays within
//! [`super::budget::Plan::search_cap`], which keeps fresh confirmation's share for every core
//! found and one more, and for the minimal failure modes no core explains. Every decision is a
//! pure function of the seed and the observed answers, so a resumed run replays exactly.
use std::cell::RefCell;
use std::collections::{BinaryHeap, VecDeque};
use std::rc::Rc;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::ir::ConceptSet;

use super::lanes;
use super::patterns::{Fit, Patterns, for_each_subset_of_size};
use super::shrink::{self, Shrunk};
use super::surrogate::{Basis, Data, Draw, Gibbs, Order, Prior};
use super::{Drive, Driver, Evaluate, Params, Purpose, Rule, Searched, SetStats, Space};

/// Salt for the interact random stream.
const STREAM: u64 = 0x696e_7465_7261_6374;

/// Gibbs sweeps per round (the chain is warm-started from the previous round).
const SWEEPS: usize = 4;

/// The surrogate variants compared in `docs/search.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Surrogate {
    /// Group testing: evidence per pattern of at most three concepts ([`super::patterns`]).
    #[default]
    Patterns,
    /// Pairwise regression, horseshoe prior (BOCS).
    Horseshoe,
    /// Pairwise regression, one learned Gaussian variance per group.
    Ridge,
    /// Concept indicators only, horseshoe prior.
    Linear,
}

impl Surrogate {
    pub const ALL: [Surrogate; 4] = [Surrogate::Patterns, Surrogate::Horseshoe, Surrogate::Ridge, Surrogate::Linear];

    pub fn name(self) -> &'static str {
        match self {
            Surrogate::Patterns => "patterns",
            Surrogate::Horseshoe => "horseshoe",
            Surrogate::Ridge => "ridge",
            Surrogate::Linear => "linear",
        }
    }

    /// The regression surrogate's features and prior; `None` for the pattern surrogate.
    pub fn parts(self) -> Option<(Order, Prior)> {
        Some(match self {
            Surrogate::Patterns => return None,
            Surrogate::Horseshoe => (Order::Pairwise, Prior::Horseshoe),
            Surrogate::Ridge => (Order::Pairwise, Prior::Ridge),
            Surrogate::Linear => (Order::Linear, Prior::Horseshoe),
        })
    }
}

impl std::str::FromStr for Surrogate {
    type Err = String;
    fn from_str(s: &str) -> Result<Surrogate, String> {
        Surrogate::ALL.into_iter().find(|a| a.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Surrogate::ALL.iter().map(|a| a.name()).collect();
            format!("unknown surrogate `{s}`: expected one of {}", names.join(", "))
        })
    }
}

/// What the search does with the supersets of a confirmed core.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Supersets {
    /// Never picked while an open set is left.
    Exclude,
    /// Picked only when a draw sees no open set failing (the regression surrogate) or no open set
    /// is left (the pattern surrogate); the default.
    #[default]
    Fallback,
    /// Treated like any other set (the core is only a feature of the surrogate).
    Keep,
}

impl Supersets {
    pub const ALL: [Supersets; 3] = [Supersets::Exclude, Supersets::Fallback, Supersets::Keep];

    pub fn name(self) -> &'static str {
        match self {
            Supersets::Exclude => "exclude",
            Supersets::Fallback => "fallback",
            Supersets::Keep => "keep",
        }
    }
}

impl std::str::FromStr for Supersets {
    type Err = String;
    fn from_str(s: &str) -> Result<Supersets, String> {
        Supersets::ALL.into_iter().find(|a| a.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Supersets::ALL.iter().map(|a| a.name()).collect();
            format!("unknown superset policy `{s}`: expected one of {}", names.join(", "))
        })
    }
}

/// The lattice as the search sees it: which sets were evaluated, which hold a confirmed core. Its
/// sets are the space's, or for a sampled space the pool drawn so far ([`Board::push`]).
struct Board {
    sets: Vec<ConceptSet>,
    index: std::collections::HashMap<ConceptSet, u32>,
    explored: Vec<bool>,
    covered: Vec<bool>,
    /// Every set evaluated (a pool set may join after it was).
    seen: std::collections::HashSet<ConceptSet>,
    /// Sets whose supersets are covered.
    asides: Vec<ConceptSet>,
}

impl Board {
    fn new(space: &Space) -> Board {
        Board {
            sets: space.sets.clone(),
            index: space.sets.iter().enumerate().map(|(i, s)| (*s, i as u32)).collect(),
            explored: vec![false; space.sets.len()],
            covered: vec![false; space.sets.len()],
            seen: Default::default(),
            asides: Vec::new(),
        }
    }

    fn position(&self, set: ConceptSet) -> Option<usize> {
        self.index.get(&set).map(|&i| i as usize)
    }

    /// Add a set to the pool (a sampled space); false when it is in it already.
    fn push(&mut self, set: ConceptSet) -> bool {
        if self.index.contains_key(&set) {
            return false;
        }
        self.index.insert(set, self.sets.len() as u32);
        self.sets.push(set);
        self.explored.push(self.seen.contains(&set));
        self.covered.push(self.asides.iter().any(|a| a.is_subset_of(set)));
        true
    }

    fn explore(&mut self, set: ConceptSet) {
        self.seen.insert(set);
        if let Some(i) = self.position(set) {
            self.explored[i] = true;
        }
    }

    /// Mark the sets evaluated since the first `*marked` of `history` as explored.
    fn explore_since(&mut self, history: &[SetStats], marked: &mut usize) {
        for s in &history[*marked..] {
            self.explore(s.set);
        }
        *marked = history.len();
    }

    fn cover(&mut self, core: ConceptSet) {
        self.asides.push(core);
        for (i, s) in self.sets.iter().enumerate() {
            if core.is_subset_of(*s) {
                self.covered[i] = true;
            }
        }
    }

    fn is_covered(&self, set: ConceptSet) -> bool {
        self.position(set).is_some_and(|i| self.covered[i])
    }

    /// The unexplored set with the highest score among the open (`covered == false`) or the
    /// covered sets; ties go to the earliest in lattice order.
    fn argmax(&self, covered: bool, score: impl Fn(ConceptSet) -> f64) -> Option<(ConceptSet, f64)> {
        self.argmax_at(covered, |_, s| score(s))
    }

    /// The unexplored open sets (no core covers them), each with its score under the fit of
    /// `version` (none scored −∞), as a queue best first; ties go to the earliest in lattice
    /// order, as in [`Board::argmax`].
    fn queue_at(&self, version: u32, score: impl Fn(usize, ConceptSet) -> f64) -> BinaryHeap<Queued> {
        let mut queued = Vec::new();
        for (i, set) in self.sets.iter().enumerate() {
            if self.explored[i] || self.covered[i] {
                continue;
            }
            let v = score(i, *set);
            if v > f64::NEG_INFINITY {
                queued.push(Queued { score: v, at: i, version });
            }
        }
        BinaryHeap::from(queued)
    }

    /// [`Board::argmax`] with the set's position in the space handed to the score too.
    fn argmax_at(&self, covered: bool, score: impl Fn(usize, ConceptSet) -> f64) -> Option<(ConceptSet, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for (i, set) in self.sets.iter().enumerate() {
            if self.explored[i] || self.covered[i] != covered {
                continue;
            }
            let v = score(i, *set);
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((i, v));
            }
        }
        best.map(|(i, v)| (self.sets[i], v))
    }
}

/// The search state between rounds: surrogate, Gibbs chain, lattice bookkeeping, random stream.
pub struct Searcher {
    params: Params,
    basis: Basis,
    gibbs: Gibbs,
    board: Board,
    rng: ChaCha8Rng,
    /// Draws so far that saw no open set failing: every other one explores the open sets anyway.
    idle: u64,
}

impl Searcher {
    pub fn new(params: &Params, space: &Space, (order, prior): (Order, Prior)) -> Searcher {
        Searcher {
            params: params.clone(),
            basis: Basis::new(&space.sets, space.dim, order),
            gibbs: Gibbs::new(prior),
            board: Board::new(space),
            rng: ChaCha8Rng::seed_from_u64(params.seed ^ STREAM),
            idle: 0,
        }
    }

    /// Mark a set as evaluated.
    pub fn explored(&mut self, set: ConceptSet) {
        self.board.explore(set);
    }

    /// A confirmed core: its supersets leave the open sets, and it becomes a feature.
    pub fn confirm(&mut self, core: ConceptSet) {
        self.basis.add_core(core);
        self.board.cover(core);
    }

    pub fn is_covered(&self, set: ConceptSet) -> bool {
        self.board.is_covered(set)
    }

    /// One round: Gibbs sweeps on every evaluated set, `batch` Thompson draws, and each draw's
    /// pick among all unexplored valid sets.
    pub fn propose(&mut self, history: &[SetStats]) -> Vec<ConceptSet> {
        let data = data(history);
        let conditional = self.gibbs.sweep(&self.basis, &data, SWEEPS, &mut self.rng);
        let tau = self.params.threshold;
        let mut picks: Vec<ConceptSet> = Vec::with_capacity(self.params.batch);
        for _ in 0..self.params.batch {
            let draw = Draw::new(&self.basis, &conditional.draw(&mut self.rng));
            let pick = match self.params.supersets {
                Supersets::Keep => self
                    .board
                    .argmax(false, |s| draw.score_open(s))
                    .into_iter()
                    .chain(self.board.argmax(true, |s| draw.score(s)))
                    .max_by(|a, b| a.1.total_cmp(&b.1)),
                policy => match self.board.argmax(false, |s| draw.score_open(s)) {
                    Some((set, v)) if policy == Supersets::Fallback && v < tau => {
                        self.idle += 1;
                        if self.idle % 2 == 1 {
                            self.board.argmax(true, |s| draw.score(s)).filter(|(_, w)| *w > v).or(Some((set, v)))
                        } else {
                            Some((set, v))
                        }
                    }
                    Some(open) => Some(open),
                    None => self.board.argmax(true, |s| draw.score(s)),
                },
            };
            if let Some((set, _)) = pick.filter(|(s, _)| !picks.contains(s)) {
                picks.push(set);
            }
        }
        picks
    }
}

fn data(history: &[SetStats]) -> Data {
    let mut data = Data::default();
    for s in history {
        if let Some(fr) = s.fr() {
            data.push(s.set, fr, f64::from(s.answered()));
        }
    }
    data
}

pub async fn run<'d, E: Evaluate>(params: &Params, space: &'d Space, driver: &mut Driver<'d, E>) -> Searched<(), E> {
    match params.surrogate.parts() {
        Some(parts) => run_regression(params, space, driver, parts).await,
        None => run_patterns(params, space, driver).await,
    }
}

async fn run_regression<E: Evaluate>(
    params: &Params,
    space: &Space,
    driver: &mut Driver<'_, E>,
    parts: (Order, Prior),
) -> Searched<(), E> {
    let mut searcher = Searcher::new(params, space, parts);
    let mut marked = 0;
    let (plan, mut cores) = (params.plan(), Vec::new());
    while driver.can_start() {
        let picks = searcher.propose(&driver.history);
        if picks.is_empty() {
            break;
        }
        let stats = driver.evaluate(&picks).await?;
        searcher.board.explore_since(&driver.history, &mut marked);
        for s in stats {
            if !s.is_failure_mode(params.threshold) || searcher.is_covered(s.set) || !driver.can_start() {
                continue;
            }
            // Confirm and shrink under the shrink phase's sequential rule: a core is only as good
            // as the evidence that its parts pass, and m observations mistake a 0.35 set for a
            // failure one time in four.
            let search_rule = driver.rule();
            driver.set_rule(params.shrink_rule());
            let shrunk = shrink::shrink(driver, space, s.set).await;
            driver.set_rule(search_rule);
            searcher.board.explore_since(&driver.history, &mut marked);
            if let Shrunk::Core(core) = shrunk? {
                searcher.confirm(core.stats.set);
                cores.push(core.stats.set);
            }
            driver.set_budget(search_cap(&plan, &driver.history, space, params.threshold, &cores));
        }
    }
    Ok(())
}

/// Observations of a screen: a set whose first answer is right is set aside.
pub const SCREEN: u32 = 1;

/// The interval of the triage: the jumps to likely cores and the shrinking that follow a failing
/// set are decided at 80 % (Φ⁻¹(0.9)); a core they find is then confirmed, with its one-smaller
/// subsets, at the confirmation rule's 95 %. A set at 0.35 — a failure mode's part, which carries
/// some of its signal — that fails at its rate clears τ = 0.6 after 15 observations at 95 %, after
/// 7 at 80 %. Before the triage, a quarter of a run's inferences on `driving_gemini.toml` went to
/// sets between 0.2 and 0.6 that got more than m observations each.
pub const TRIAGE_Z: f64 = 1.281_551_565_544_601;

/// Observations a screened set that answered wrong gets first; then more, by the triage's
/// sequential test, while its interval straddles τ (3/3 fails at 80 %; 1/3 needs more). A fixed
/// m (5) spent four more observations on every wrong screen, whatever the set held.
pub const ESCALATE: u32 = 3;

/// Sub-patterns of a failing set tested directly (most probable core first) before the set itself
/// is shrunk one concept at a time.
pub const JUMPS: usize = 3;

/// The core a triage found is confirmed in the search with up to this many times the
/// confirmation rule's M observations (its lift test with twice as many again): a core at 0.75,
/// just above τ + δ, is established above τ − δ by the anytime-valid test in about 36 on
/// average, so at M = 40 one now and then ended undecided (1 of 20 seeds in
/// `search::tests::interact_establishes_a_core_just_above_the_zone_past_the_rules_cap`), was
/// taken for no core, and its family stayed open — the search found it again through every
/// superset it screened (on `driving_many.toml`, seed 0, `child_pedestrian` at 0.75 read 30 of 44
/// and 369 of 770 search calls went to sets holding it). A core still undecided at this cap is
/// near τ: its family is set aside as a not-distinct set's is. Measured (release, the fifteen
/// shipped profiles, width 16): +1.6 [+0.0, +3.1] points recovered over seeds 0–19, +2.0 [+1.0,
/// +3.1] over 0–39 (docs/search.md, "Near-τ cores in the search").
pub const CORE_TEST_STRETCH: u32 = 2;

/// Fills escalate hot sets ahead of the workers up to their number plus one in this many of the
/// sets waiting: a long queue (every set of four answering wrong on its screen) is worked through
/// instead of screened past, a short one is not escalated before a core may cover it.
pub const AHEAD_SHARE: usize = 4;

/// A listed space: calls are filled with screens to this share of their width, no further (at
/// width 16, 13 calls): the last screens of a fill, the least promising, are left to a later
/// round that has seen more answers. Measured (release, 40 seeds on each of the seven shipped
/// profiles, width 16): 3.1 [0.4, 5.7] points more recovered than filling to the width; picking
/// rounds of 13 instead of 16 as well took 0.8 of it back (docs/search.md, "Parallel interact").
pub const FILL_SHARE: (usize, usize) = (4, 5);

/// The room of a call at `width` that fills leave empty: what [`FILL_SHARE`] does not ask for.
fn fill_spare(width: usize) -> usize {
    let (num, den) = FILL_SHARE;
    width - (width * num).div_ceil(den)
}

/// A listed space: a fill ranks this many times its room of sets off the families being decided
/// on, and screens first those apart from one another ([`spread`]). The best sets of one posterior
/// share its best pattern: screened side by side they tell what one of them would, where one pick
/// at a time would have moved on. Measured (release, 40 seeds on each of the seven shipped
/// profiles, width 16): +1.7 [-0.8, +4.1] points recovered (graded +4.4 [+0.1, +8.8]); against
/// one pick at a time -0.0 [-2.8, +2.7] (docs/search.md, "Parallel interact").
pub const SPREAD: usize = 3;

/// Up to `n` of the `ranked` sets (best first): first, in rank order, each that shares at most one
/// concept with every one taken before it ([`apart`]), then the best of the rest.
fn spread(ranked: &[ConceptSet], n: usize) -> Vec<ConceptSet> {
    let mut taken: Vec<ConceptSet> = Vec::with_capacity(n);
    for &set in ranked {
        if taken.len() < n && apart(&taken, set, ConceptSet::EMPTY) {
            taken.push(set);
        }
    }
    for &set in ranked {
        if taken.len() < n && !taken.contains(&set) {
            taken.push(set);
        }
    }
    taken
}

/// A sampled space's first pool: this many uniform draws per inference of the budget (at most
/// [`POOL_MOST`]), besides every valid single concept. A screen tests one set of the pool, so
/// the draws hold many times the sets the budget can screen.
pub const POOL_PER_CALL: u64 = 8;

/// The most uniform draws in a sampled space's first pool.
pub const POOL_MOST: u64 = 20_000;

/// A sampled space's hot patterns: the open patterns likeliest to be cores, this many at each
/// pick. Each joins the pool with [`EXPAND`] draws that hold it, and every union of two or three
/// of them that is a valid set joins it too: so the parts of a failure mode that each carry some
/// of its signal meet in the sets the search can pick.
pub const HOT: usize = 16;

/// Draws holding a hot pattern that join the pool (sizes uniform from one more concept to the
/// largest).
pub const EXPAND: usize = 12;

/// A sampled space: one pick in this many (rounded up) screens a set of the concepts likeliest to
/// carry a failure mode's signal ([`PatternSearcher::concept_sets`]).
pub const CONCEPT_SHARE: usize = 2;

/// A concept is hot ([`PatternSearcher::hot_concepts`]) when its effect, one standard deviation
/// below its posterior mean, is at least this many times the base error.
pub const HOT_EFFECT: f64 = 2.0;

/// The prior Beta(a, b) of a concept's own effect in [`PatternSearcher::concept_effects`]: mean
/// 0.05, as strong as two answers.
pub const EFFECT_PRIOR: (f64, f64) = (0.1, 1.9);

/// A concept's effect posterior, Beta(a, b), from the wrong answers it is expected to have caused
/// and the answers of the sets that hold it ([`PatternSearcher::concept_effects`]).
fn effect_posterior((fired, answers): (f64, f64)) -> (f64, f64) {
    let (a0, b0) = EFFECT_PRIOR;
    (a0 + fired, b0 + (answers - fired).max(0.0))
}

/// The weight, in answers, of the pattern surrogate's base error as the prior of the noisy-OR
/// fit's own ([`PatternSearcher::concept_effects`]).
pub const BASE_PRIOR_WEIGHT: f64 = 20.0;

/// EM rounds of the noisy-OR fit of the concepts' effects.
pub const EFFECT_ROUNDS: usize = 20;

/// The pattern surrogate's search state.
pub struct PatternSearcher<'s> {
    params: Params,
    space: &'s Space,
    patterns: Patterns,
    board: Board,
    /// Patterns that are not (and hold no) confirmed core.
    open: Vec<bool>,
    cores: Vec<ConceptSet>,
    /// Every set whose supersets were set aside (cores and explained families).
    closed: Vec<ConceptSet>,
    rng: ChaCha8Rng,
    /// How much of the history the board has marked explored.
    marked: usize,
    /// A sampled space: hot patterns and unions already added to the pool.
    expanded: std::collections::HashSet<ConceptSet>,
    /// The sets being decided on (escalated, explained): fills prefer sets sharing at most one
    /// concept with each.
    focus: Vec<ConceptSet>,
    /// Screened sets that answered wrong, not decided on yet, in the order they were screened.
    hot: VecDeque<ConceptSet>,
    /// Workers deciding on hot sets side by side ([`work_hot`]).
    workers: usize,
    /// A sampled space: the concepts the last picks found hot ([`PatternSearcher::hot_concepts`]),
    /// kept for the hot sets' turns ([`apart`]); empty on a listed space.
    hot_now: ConceptSet,
}

impl<'s> PatternSearcher<'s> {
    pub fn new(params: &Params, space: &'s Space) -> PatternSearcher<'s> {
        let patterns = if space.is_sampled() { Patterns::pooled(space) } else { Patterns::new(space) };
        let mut searcher = PatternSearcher {
            params: params.clone(),
            space,
            open: vec![true; patterns.len()],
            patterns,
            board: Board::new(space),
            cores: Vec::new(),
            closed: Vec::new(),
            rng: ChaCha8Rng::seed_from_u64(params.seed ^ STREAM),
            marked: 0,
            expanded: Default::default(),
            focus: Vec::new(),
            hot: VecDeque::new(),
            workers: 1,
            hot_now: ConceptSet::EMPTY,
        };
        if space.is_sampled() {
            // The first pool: every valid single concept, then uniform draws (their own stream, so
            // the picks' stream is the same whatever the pool's size).
            let mut draws = ChaCha8Rng::seed_from_u64(params.seed ^ STREAM ^ 0x706f_6f6c);
            for c in 0..space.dim as u32 {
                searcher.join(ConceptSet::single(crate::ir::ConceptId(c)));
            }
            let n = (POOL_PER_CALL * params.plan().search).min(POOL_MOST) as usize;
            for s in super::random::distinct_draws(&mut draws, space, n) {
                searcher.join(s);
            }
        }
        searcher
    }

    /// Add a valid set to a sampled space's pool.
    fn join(&mut self, set: ConceptSet) {
        if set.is_empty() || self.board.position(set).is_some() || !self.space.contains(set) {
            return;
        }
        let space = self.space;
        self.board.push(set);
        self.patterns.add(set, space);
        while self.open.len() < self.patterns.len() {
            let p = self.patterns.pattern(self.open.len() as u32);
            self.open.push(!self.closed.iter().any(|c| c.is_subset_of(p)));
        }
    }

    /// Mark every set of `history` explored (a sampled space: and add it to the pool, so that its
    /// sub-patterns are indexed).
    fn catch_up(&mut self, history: &[SetStats]) {
        if self.space.is_sampled() {
            for s in &history[self.marked..] {
                self.join(s.set);
            }
        }
        self.board.explore_since(history, &mut self.marked);
    }

    /// The evaluated sets that fail as tested so far (FR ≥ τ) and hold no set already set aside:
    /// each is being explained (escalated, shrunk, confirmed) as itself, so screening a superset
    /// of it would only measure it again.
    fn failing(&self, history: &[SetStats]) -> Vec<ConceptSet> {
        history
            .iter()
            .filter(|s| s.is_failure_mode(self.params.threshold))
            .map(|s| s.set)
            .filter(|&s| !self.closed.iter().any(|c| c.is_subset_of(s)))
            .collect()
    }

    /// Each concept's own effect under a noisy-OR model of the evaluated sets — a set's answer is
    /// wrong when the base error or any of its concepts "fires", concept c with chance e_c — fitted
    /// by EM ([`EFFECT_ROUNDS`] rounds, a Beta([`EFFECT_PRIOR`]) prior on each e_c), the base
    /// error with them (from `base`, a Beta prior as strong as [`BASE_PRIOR_WEIGHT`] answers
    /// around it): per concept, the wrong answers it is expected to have caused and the answers
    /// of the sets that hold it, and the base error fitted. A concept that only rode along with a
    /// failing one gets little of the blame, and the parts' failures are not read as base error
    /// (the pattern surrogate's base absorbs them: 0.12 for a true 0.05 on the 250-concept bench).
    /// Sets that hold a set aside (a confirmed core, an explained family) are left out: their
    /// failures are explained.
    fn concept_effects(&self, history: &[SetStats], base: f64) -> (Vec<(f64, f64)>, f64) {
        let data: Vec<&SetStats> =
            history.iter().filter(|s| s.answered() > 0 && !self.closed.iter().any(|c| c.is_subset_of(s.set))).collect();
        let (a0, b0) = EFFECT_PRIOR;
        let dim = self.space.dim;
        let mut e = vec![a0 / (a0 + b0); dim];
        let mut acc = vec![(0.0, 0.0); dim];
        let prior = base.clamp(1e-3, 0.5);
        let mut fitted = prior;
        for _ in 0..EFFECT_ROUNDS {
            acc.iter_mut().for_each(|a| *a = (0.0, 0.0));
            let (mut by_base, mut answers) = (0.0, 0.0);
            for s in &data {
                let right = (1.0 - fitted) * s.set.iter().map(|c| 1.0 - e[c.0 as usize]).product::<f64>();
                let p = (1.0 - right).max(1e-12);
                let (w, n) = (f64::from(s.wrong), f64::from(s.answered()));
                for c in s.set.iter() {
                    let a = &mut acc[c.0 as usize];
                    a.0 += w * e[c.0 as usize] / p;
                    a.1 += n;
                }
                by_base += w * fitted / p;
                answers += n;
            }
            for (ec, a) in e.iter_mut().zip(&acc) {
                *ec = (a.0 + a0) / (a.1 + a0 + b0);
            }
            fitted = (by_base + prior * BASE_PRIOR_WEIGHT) / (answers + BASE_PRIOR_WEIGHT);
        }
        (acc, fitted)
    }

    /// A sampled space: up to `n` unexplored open sets made of the concepts likeliest to carry a
    /// failure mode's signal, from each concept's own effect
    /// ([`PatternSearcher::concept_effects`], under the base error `base`). Two kinds:
    ///
    /// - **combinations** (up to half, rounded up): a concept whose effect is established above the base
    ///   error ([`PatternSearcher::hot_concepts`]) is a part of some failure mode, or a mode
    ///   itself; the parts of one mode fail together only when all of them are in one set. Each
    ///   combination holds a pair or triple of hot concepts that no evaluated set has held yet
    ///   (the likeliest first, by their mean effects), and as many more hot concepts as add
    ///   pairs or triples not met yet, so a few sets cover every way the hot concepts may
    ///   combine;
    /// - **discoveries** (the rest): sets of the largest size of the concepts of the highest
    ///   draws from their posteriors (Thompson sampling), drawn afresh per set. Hot concepts are
    ///   left out — a set holding one answers wrong through it, which says nothing about the
    ///   others — and so is a concept tested on its own ([`Params::samples`] answers): its
    ///   effect is known, and the pattern surrogate's heredity takes up the patterns that hold
    ///   it. Concepts never tested have the widest draws and get tried.
    ///
    /// Concepts are taken in turn while they keep the set valid and free of every `blocked` set.
    fn concept_sets(&mut self, history: &[SetStats], base: f64, n: usize, blocked: &[ConceptSet]) -> Vec<ConceptSet> {
        let (effects, base) = self.concept_effects(history, base);
        let size = self.params.max_size;
        let hot = Self::hot_concepts(&effects, base);
        let mut picks = self.combinations(history, &hot, n.div_ceil(2), blocked);
        let hot: ConceptSet = hot.iter().fold(ConceptSet::EMPTY, |s, &(c, _)| s.with(c));
        self.hot_now = hot;
        // Concepts measured on their own: their effect is known, and the pattern surrogate's
        // heredity takes up the patterns that hold them.
        let alone: ConceptSet = history
            .iter()
            .filter(|s| s.set.len() == 1 && s.answered() >= self.params.samples)
            .fold(ConceptSet::EMPTY, |a, s| a.union(s.set));
        let left_out = hot.union(alone);
        for _ in 0..n * 4 {
            if picks.len() >= n {
                break;
            }
            let mut drawn: Vec<(f64, u32)> = effects
                .iter()
                .enumerate()
                .filter(|&(c, _)| !left_out.contains(crate::ir::ConceptId(c as u32)))
                .map(|(c, &effect)| {
                    let (a, b) = effect_posterior(effect);
                    let x = super::surrogate::gamma(&mut self.rng, a);
                    let y = super::surrogate::gamma(&mut self.rng, b);
                    (x / (x + y).max(1e-300), c as u32)
                })
                .collect();
            drawn.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            let mut set = ConceptSet::EMPTY;
            for &(_, c) in &drawn {
                if set.len() == size {
                    break;
                }
                let next = set.with(crate::ir::ConceptId(c));
                if blocked.iter().any(|b| b.is_subset_of(next)) || !self.space.contains(next) {
                    continue;
                }
                set = next;
            }
            self.take(set, &mut picks);
        }
        picks
    }

    /// The concepts whose effect is established above the base error — the lower end of one
    /// standard deviation of its posterior at least [`HOT_EFFECT`] × `base` — with their mean
    /// effects, highest first; at most [`HOT`] of them (their triples are what
    /// [`PatternSearcher::combinations`] covers).
    fn hot_concepts(effects: &[(f64, f64)], base: f64) -> Vec<(crate::ir::ConceptId, f64)> {
        let mut hot: Vec<(crate::ir::ConceptId, f64)> = effects
            .iter()
            .enumerate()
            .filter_map(|(c, &effect)| {
                let (a, b) = effect_posterior(effect);
                let mean = a / (a + b);
                let sd = (a * b / ((a + b).powi(2) * (a + b + 1.0))).sqrt();
                (mean - sd >= HOT_EFFECT * base).then_some((crate::ir::ConceptId(c as u32), mean))
            })
            .collect();
        hot.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.0.cmp(&b.0.0)));
        hot.truncate(HOT);
        hot
    }

    /// Up to `n` combinations of the `hot` concepts ([`PatternSearcher::concept_sets`]): each
    /// starts from the likeliest group (a triple, or a pair while fewer than three concepts are
    /// hot) that no evaluated or picked set has held, and takes on the hot concepts that add
    /// groups not met yet, up to the largest size.
    fn combinations(
        &mut self,
        history: &[SetStats],
        hot: &[(crate::ir::ConceptId, f64)],
        n: usize,
        blocked: &[ConceptSet],
    ) -> Vec<ConceptSet> {
        let k = if hot.len() >= 3 { 3 } else { 2 };
        let mut picks = Vec::new();
        if hot.len() < k || n == 0 {
            return picks;
        }
        let hot_set: ConceptSet = hot.iter().fold(ConceptSet::EMPTY, |s, &(c, _)| s.with(c));
        let mut met: std::collections::HashSet<ConceptSet> = Default::default();
        let meet = |met: &mut std::collections::HashSet<ConceptSet>, set: ConceptSet| {
            for_each_subset_of_size(set.intersection(hot_set), k, |g| {
                met.insert(g);
            });
        };
        for s in history {
            meet(&mut met, s.set);
        }
        let ids: Vec<crate::ir::ConceptId> = hot.iter().map(|&(c, _)| c).collect();
        let fits = |set: ConceptSet| !blocked.iter().any(|b| b.is_subset_of(set)) && self.space.contains(set);
        // Groups in order of their concepts' summed mean effects (ties: concept order).
        let mean = |c: crate::ir::ConceptId| hot.iter().find(|h| h.0 == c).map_or(0.0, |h| h.1);
        let mut targets: Vec<(f64, ConceptSet)> = Vec::new();
        for_each_subset_of_size(hot_set, k, |g| targets.push((g.iter().map(mean).sum::<f64>(), g)));
        targets.sort_by(|a, b| b.0.total_cmp(&a.0));
        for (_, g) in targets {
            if picks.len() == n {
                break;
            }
            if met.contains(&g) || !fits(g) {
                continue;
            }
            let mut set = g;
            for &c in &ids {
                if set.len() == self.params.max_size {
                    break;
                }
                let next = set.with(c);
                if next == set || !fits(next) {
                    continue;
                }
                let mut fresh = false;
                for_each_subset_of_size(next, k, |h| fresh |= !met.contains(&h));
                if fresh {
                    set = next;
                }
            }
            let before = picks.len();
            self.take(set, &mut picks);
            if picks.len() > before {
                meet(&mut met, set);
            } else {
                met.insert(g);
            }
        }
        picks
    }

    /// Join `set` to the pool and pick it when it is a new unexplored open set.
    fn take(&mut self, set: ConceptSet, picks: &mut Vec<ConceptSet>) {
        if set.is_empty() || picks.contains(&set) {
            return;
        }
        self.join(set);
        if self.board.position(set).is_some_and(|i| !self.board.explored[i] && !self.board.covered[i]) {
            picks.push(set);
        }
    }

    /// A sampled space: the hot patterns of `fit` ([`HOT`]) join the pool with sets that hold
    /// them and their unions.
    fn grow(&mut self, fit: &Fit, blocked: &[ConceptSet]) {
        let mut ranked: Vec<(f64, u32)> = (0..self.patterns.len() as u32)
            .filter(|&j| self.open[j as usize])
            .filter(|&j| !blocked.iter().any(|b| b.is_subset_of(self.patterns.pattern(j))))
            .map(|j| (fit.q_mean(&self.patterns, j), j))
            .filter(|(q, _)| *q > 0.0)
            .collect();
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let hot: Vec<ConceptSet> = ranked.iter().take(HOT).map(|&(_, j)| self.patterns.pattern(j)).collect();
        let max = self.params.max_size;
        let mut new = Vec::new();
        for (i, &h) in hot.iter().enumerate() {
            if self.expanded.insert(h) && h.len() < max {
                for _ in 0..EXPAND {
                    let size = self.rng.random_range(h.len() + 1..=max);
                    new.extend(self.space.draw_containing(h, size, &mut self.rng));
                }
            }
            for (k, &g) in hot.iter().enumerate().skip(i + 1) {
                let two = h.union(g);
                if two.len() <= max && self.expanded.insert(two) {
                    new.push(two);
                }
                for &f in hot.iter().skip(k + 1) {
                    let three = two.union(f);
                    if three.len() <= max && self.expanded.insert(three) {
                        new.push(three);
                    }
                }
            }
        }
        new.into_iter().for_each(|s| self.join(s));
    }

    /// Asks of at most `room` observations to fill a call beside its `asks` (a narrow step of the
    /// search): first the escalation of the hot sets waiting to be decided on, in the order they
    /// were screened, each off the families of the sets being decided on and of those escalated
    /// before it in the fill ([`apart`]), and no more escalated ahead
    /// than there are workers (the sets they take next; a set escalated further ahead may be
    /// covered by a core before its turn) plus one in [`AHEAD_SHARE`] of the waiting sets; then
    /// screens of the best picks among the sets off the same families (the others would answer
    /// wrong through the very failure mode being explained, and be escalated before its core
    /// covers them), apart from one another first ([`SPREAD`]), the asked sets left out; the best
    /// of the rest only when those are too few. Screens fill a listed space's call to
    /// [`FILL_SHARE`] of its width, no further, each picked as if the call's other observations
    /// (`asks` and the escalations) had answered right ([`believe_right`]). (A sampled space:
    /// [`PatternSearcher::pick`]'s concept sets and picks, those off the families first, to the
    /// whole width.)
    pub fn fill(&mut self, history: &[SetStats], asks: &[super::Ask], room: usize) -> Vec<super::Ask> {
        asks.iter().for_each(|a| self.board.explore(a.set));
        let hot_now = self.hot_now;
        let mut out = Vec::new();
        let mut left = room;
        let mut focus = self.focus.clone();
        let escalated = ESCALATE.min(self.params.samples);
        let observed = |set: ConceptSet| history.iter().find(|s| s.set == set).map(SetStats::observations);
        // At most as many escalated ahead as the workers take next, and a quarter of a long
        // queue (a flood of hot sets is worked through rather than screened past).
        let limit = self.workers + self.hot.len() / AHEAD_SHARE;
        let mut ahead = self.hot.iter().filter(|&&h| observed(h).is_some_and(|n| n >= escalated)).count();
        for &h in &self.hot {
            if left == 0 || ahead >= limit {
                break;
            }
            if asks.iter().any(|a| a.set == h) || self.board.is_covered(h) || !apart(&focus, h, hot_now) {
                continue;
            }
            let Some(n) = observed(h) else { continue };
            let want = escalated.saturating_sub(n) as usize;
            if want > 0 && want <= left {
                out.push(super::Ask { set: h, obs: n..n + want as u32 });
                left -= want;
                focus.push(h);
                ahead += 1;
            }
        }
        // The screens leave the call's spare room empty ([`FILL_SHARE`]). A sampled space fills
        // it: there the spare room took the 250-concept bench's pair / triple from 44 / 20 to
        // 30 / 22 of 60 seeds.
        if !self.space.is_sampled() {
            left = left.saturating_sub(fill_spare(self.params.batch));
        }
        if left == 0 {
            return out;
        }
        let screen = |set| super::Ask { set, obs: 0..SCREEN };
        // A listed space's picks believe the call's other observations answered right
        // ([`believe_right`]). A sampled space's do not: there the belief took the 250-concept
        // bench's pair / triple from 16 / 12 to 19 / 7 of 30 seeds.
        let pending: Vec<super::Ask> =
            if self.space.is_sampled() { Vec::new() } else { asks.iter().chain(&out).cloned().collect() };
        if focus.is_empty() {
            out.extend(self.pick(history, &pending, left).into_iter().map(screen));
            return out;
        }
        if self.space.is_sampled() {
            // The concept sets and picks of a round of twice the room, those off the families
            // first. (Picking off the families as below found the 250-concept bench's planted
            // pair / triple in 36 / 9 of 60 seeds instead of 44 / 20: there the screens on a
            // family hold hot concepts, the parts of the modes not found yet.)
            let (off, on): (Vec<ConceptSet>, Vec<ConceptSet>) =
                self.pick(history, &pending, 2 * left).into_iter().partition(|&p| apart(&focus, p, hot_now));
            out.extend(off.into_iter().chain(on).take(left).map(screen));
            return out;
        }
        // The best picks off the families; only when there are too few, the call is filled to its
        // width from the best picks of all. (Taking the best picks of all first and the screens
        // off the families among them, the calls were filled with sets of the families: the
        // ranking puts a family's supersets first while it is explained.)
        let ranked = self.pick_where(history, &pending, SPREAD * left, |p| apart(&focus, p, hot_now));
        let off = spread(&ranked, left);
        let short = left - off.len();
        out.extend(off.into_iter().map(screen));
        if short > 0 {
            let asked: Vec<ConceptSet> = out.iter().map(|a| a.set).collect();
            let rest = self.pick(history, &pending, short + asked.len()).into_iter().filter(|p| !asked.contains(p));
            out.extend(rest.take(short).map(screen));
        }
        out
    }

    pub fn explored(&mut self, set: ConceptSet) {
        self.board.explore(set);
    }

    pub fn is_covered(&self, set: ConceptSet) -> bool {
        self.board.is_covered(set)
    }

    /// A confirmed core: it and its supersets are no longer open patterns, and (unless supersets
    /// are kept) its supersets leave the sets to pick. A core confirmed before changes nothing.
    pub fn confirm(&mut self, core: ConceptSet) {
        if self.cores.contains(&core) {
            return;
        }
        self.cores.push(core);
        self.set_aside(core);
    }

    /// A passing set near τ that its failing supersets do not significantly exceed
    /// ([`Shrunk::NotDistinct`]): its supersets fail at its borderline rate, not through a new
    /// core. They are set aside as a core's are, so the search stops re-finding the same
    /// borderline family; nothing is reported.
    pub fn explain(&mut self, by: ConceptSet) {
        self.set_aside(by);
    }

    /// `set` and its supersets are no longer open patterns, and (unless supersets are kept) its
    /// supersets leave the sets to pick.
    fn set_aside(&mut self, set: ConceptSet) {
        self.closed.push(set);
        for j in 0..self.patterns.len() {
            if set.is_subset_of(self.patterns.pattern(j as u32)) {
                self.open[j] = false;
            }
        }
        if self.params.supersets != Supersets::Keep {
            self.board.cover(set);
        }
    }

    pub fn fit(&self, history: &[SetStats]) -> Fit {
        self.patterns.fit(self.space, history, &self.cores, self.params.threshold)
    }

    /// `batch` picks, each the unexplored open set with the best discovery chance per expected
    /// observation under a dilution drawn from its posterior.
    pub fn propose(&mut self, history: &[SetStats]) -> Vec<ConceptSet> {
        self.pick(history, &[], self.params.batch)
    }

    /// `n` picks ([`PatternSearcher::propose`]), with the `pending` observations believed
    /// answered right.
    fn pick(&mut self, history: &[SetStats], pending: &[super::Ask], n: usize) -> Vec<ConceptSet> {
        self.pick_where(history, pending, n, |_| true)
    }

    /// `n` picks, the open sets ranked among those `keep` takes (a sampled space's concept sets
    /// are drawn as by [`PatternSearcher::pick`]), each made as if the `pending` observations
    /// (asked in the same call, not answered yet) and the picks before it had answered right
    /// ([`believe_right`]).
    fn pick_where(
        &mut self,
        history: &[SetStats],
        pending: &[super::Ask],
        n: usize,
        keep: impl Fn(ConceptSet) -> bool,
    ) -> Vec<ConceptSet> {
        self.catch_up(history);
        // The history with what is believed answered right: the pending observations, then the
        // round's picks so far; `version` counts the picks (a queued score of an older version
        // is stale).
        let mut believed: Vec<SetStats> = if n > 1 || !pending.is_empty() { history.to_vec() } else { Vec::new() };
        for a in pending {
            believe_right(&mut believed, a.set, a.len());
        }
        let mut fit = self.fit(if pending.is_empty() { history } else { &believed });
        let mut picks: Vec<ConceptSet> = Vec::with_capacity(n);
        // A sampled space: the sets that fail as tested (being explained) and those set aside; a
        // superset of one is not screened.
        let mut blocked: Vec<ConceptSet> = Vec::new();
        if self.space.is_sampled() {
            blocked = self.failing(history);
            blocked.extend(self.board.asides.iter().copied());
            let before = self.board.sets.len();
            self.grow(&fit, &blocked);
            picks.extend(self.concept_sets(history, fit.base, n.div_ceil(CONCEPT_SHARE), &blocked));
            if self.board.sets.len() > before {
                fit = self.fit(history);
            }
        }
        let holds_blocked = |set: ConceptSet| blocked.iter().any(|b| b.is_subset_of(set));
        let (screen, samples, tau) = (SCREEN.min(self.params.samples), self.params.samples, self.params.threshold);
        let mut version = 0u32;
        // Per dilution drawn, its unexplored open sets in a queue, scored in one pass over the
        // lattice: each pick is the best of its draw's queue not picked yet. A score from before
        // a believed pick is computed again when it reaches the top, and the set goes back in
        // (lazy greedy, Minoux 1978): a believed right answer lowers the sets that hold the
        // pick's patterns and moves the others little (the base rate and the dilution posterior
        // shift a hair), so a pass over the whole lattice per pick (4-6 times the search's CPU,
        // on the calls' critical path) is not needed.
        let mut queues: Vec<(usize, BinaryHeap<Queued>)> = Vec::new();
        while picks.len() < n {
            let di = fit.draw_dilution(self.rng.random::<f64>());
            let at = match queues.iter().position(|(d, _)| *d == di) {
                Some(at) => at,
                None => {
                    let scorer = fit.scorer(&self.patterns, &self.open, di, screen, samples, tau);
                    let queue = self.board.queue_at(version, |i, set| {
                        if holds_blocked(set) || !keep(set) {
                            f64::NEG_INFINITY
                        } else {
                            scorer.score(&self.patterns, i)
                        }
                    });
                    queues.push((di, queue));
                    queues.len() - 1
                }
            };
            let queue = &mut queues[at].1;
            let mut open = None;
            while let Some(q) = queue.pop() {
                let set = self.board.sets[q.at];
                if picks.contains(&set) {
                    continue;
                }
                if q.version == version {
                    open = Some((set, 0.0));
                    break;
                }
                let score = fit.score_one(&self.patterns, &self.open, di, screen, samples, tau, q.at);
                queue.push(Queued { score, at: q.at, version });
            }
            // No open set left (a small lattice): under `fallback`, measure the known families'
            // extent, the superset likeliest to fail first.
            let pick = match open {
                None if self.params.supersets == Supersets::Fallback => {
                    let rate = |s: ConceptSet| {
                        self.cores
                            .iter()
                            .filter(|c| c.is_subset_of(s))
                            .map(|c| fit.core_rate(di, s.len() - c.len()))
                            .fold(0.0, f64::max)
                    };
                    self.board
                        .argmax(true, |s| if picks.contains(&s) || !keep(s) { f64::NEG_INFINITY } else { rate(s) })
                        .filter(|(_, v)| *v > f64::NEG_INFINITY)
                }
                open => open,
            };
            let Some((set, _)) = pick else { break };
            picks.push(set);
            if picks.len() < n {
                believe_right(&mut believed, set, 1);
                fit = self.fit(&believed);
                version += 1;
            }
        }
        picks
    }

    /// The sub-patterns of a failing set, most probably a core first (ties: pattern order), that
    /// are still open.
    pub fn candidates(&self, fit: &Fit, set: ConceptSet) -> Vec<ConceptSet> {
        let Some(i) = self.patterns.pool_position(set) else { return Vec::new() };
        let mut subs: Vec<(f64, u32)> = self
            .patterns
            .subs(i)
            .iter()
            .filter(|&&j| self.open[j as usize])
            .map(|&j| (fit.q_mean(&self.patterns, j), j))
            .collect();
        subs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        subs.into_iter().map(|(_, j)| self.patterns.pattern(j)).collect()
    }
}

/// A set waiting in a pick's queue: its score under the fit of `version` and its position in
/// the space. The best score first; ties to the earliest position.
#[derive(Debug, Clone, Copy)]
struct Queued {
    score: f64,
    at: usize,
    version: u32,
}

impl PartialEq for Queued {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}

impl Eq for Queued {}

impl PartialOrd for Queued {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Queued {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.score.total_cmp(&other.score).then(other.at.cmp(&self.at))
    }
}

/// A round's next pick is made as if the picks before it had been screened and answered right:
/// `n` correct answers added to `history` for `set` (the "constant liar" of batch Bayesian
/// optimisation, Ginsbourger, Le Riche and Carraro 2010, at its most pessimistic value). A
/// pick's patterns then lose some of their chance, so the round's later picks go to other
/// patterns instead of the same ones over again, as one pick at a time would once the first had
/// answered right. A fill believes the same of the observations its call already holds (the
/// lanes' escalations and tests, asked and not answered yet): the liar for pending evaluations,
/// so a set that answered wrong once draws fewer of a fill's screens to its concepts while the
/// escalation that most often clears it is in the same call (docs/search.md, parallel interact).
fn believe_right(history: &mut Vec<SetStats>, set: ConceptSet, n: u32) {
    if n == 0 {
        return;
    }
    let at = match history.iter().position(|s| s.set == set) {
        Some(i) => i,
        None => {
            history.push(SetStats::new(set));
            history.len() - 1
        }
    };
    for _ in 0..n {
        history[at].add(crate::outcome::Outcome::Correct);
    }
}

/// Whether `set` is off the families of the sets in `focus` (being decided on): it shares at
/// most one concept with each, or it holds, outside that set, two of the concepts found `hot` (a
/// sampled space: [`PatternSearcher::hot_concepts`]) — a group that can fail of its own, whatever
/// the set being decided on holds. On a sampled space the combinations put the hot concepts
/// together, so most hot sets share two of them with the one being explained.
fn apart(focus: &[ConceptSet], set: ConceptSet, hot: ConceptSet) -> bool {
    focus.iter().all(|f| f.intersection(set).len() < 2 || set.difference(*f).intersection(hot).len() >= 2)
}

/// What one shrink tells the search: the core it found, if any. A not-distinct set adds to `flat`
/// the family to set aside: its passing part's, or, when the lift test's observations took the
/// set itself below τ, the set's own.
fn sort_out(shrunk: &Shrunk, tau: f64, flat: &mut Vec<ConceptSet>) -> Option<ConceptSet> {
    match shrunk {
        Shrunk::Core(c) => Some(c.stats.set),
        // An undecided lift (the budget ran out) is treated the same: taking it as unaffordable
        // (nothing set aside, the explaining stopped) recovered 1.9 [-0.8, 4.5] points less
        // (release, 20 seeds of seven of the shipped profiles, width 16).
        Shrunk::NotDistinct { stats, by } | Shrunk::Undecided { stats, by } => {
            flat.push(if stats.is_failure_mode(tau) { *by } else { stats.set });
            None
        }
        Shrunk::Refuted(_) | Shrunk::Unaffordable => None,
    }
}

/// The group-testing search: screen, escalate, jump to the likeliest core, shrink.
///
/// Rounds of `batch` picks (the width: by default the concurrency at the run's start, recorded in
/// the run). The sets that answered wrong are decided on by `width ÷ m` workers side by side
/// ([`lanes`], [`work_hot`]): each takes the next hot set off the families of the sets the
/// others hold ([`apart`]), escalates it and explains it when it fails, so a call holds several
/// explaining steps, and a set a core found meanwhile covers is dropped unescalated. What a call
/// still has room for is filled ([`Driver::fill_to`], [`PatternSearcher::fill`]): first with the
/// escalation of hot sets waiting their turn, then with screens off the families being decided
/// on, up to [`FILL_SHARE`] of the width; a screen that answers wrong joins the hot sets. A
/// shrink's lookahead is its lane's share of the width ([`lanes::Lane`]). At width 1 this is the
/// one-pick-at-a-time search, unchanged. Every decision is a pure function of the seed and the
/// answers.
async fn run_patterns<'d, E: Evaluate>(
    params: &Params,
    space: &'d Space,
    driver: &mut Driver<'d, E>,
) -> Searched<(), E> {
    let result = search_patterns(params, space, driver).await;
    driver.clear_fill();
    driver.set_rule(params.rule());
    driver.purpose = None;
    result
}

async fn search_patterns<'d, E: Evaluate>(
    params: &Params,
    space: &'d Space,
    driver: &mut Driver<'d, E>,
) -> Searched<(), E> {
    let tau = params.threshold;
    let screen = Rule::fixed(SCREEN.min(params.samples), tau);
    // The confirmation decides with the anytime-valid test and its indifference zone (a core
    // is established above τ − δ, its parts are not). The triage before it is a fixed-n Wilson
    // test at 80 % against the same zone, a heuristic that only picks what to confirm: a set at
    // 0.5 passes it in about 15 observations, where testing it against τ itself took 40.
    let confirm = params.confirm_rule().with_zone(params.delta);
    let triage = confirm.with_z(TRIAGE_Z);
    let escalate = Rule { samples: ESCALATE.min(params.samples), ..triage };
    let searcher = Rc::new(RefCell::new(PatternSearcher::new(params, space)));
    if params.batch > 1 {
        let filler = searcher.clone();
        driver.fill_to(
            params.batch,
            screen.samples,
            Box::new(move |history, asks, room| filler.borrow_mut().fill(history, asks, room)),
        );
    }
    let plan = params.plan();
    let wrong = |stats: Option<&SetStats>| stats.is_some_and(|s| s.wrong > 0);
    // Workers side by side: as many as a call of the width holds explaining steps of m.
    let workers = (params.batch / triage.samples.max(1) as usize).max(1);
    searcher.borrow_mut().workers = workers;
    loop {
        let cap = search_cap(&plan, &driver.history, space, tau, &searcher.borrow().cores);
        driver.set_budget(cap);
        driver.set_rule(screen);
        driver.set_purpose(Some(Purpose::Screening));
        let filled = driver.take_filled();
        searcher.borrow_mut().hot.extend(filled.into_iter().filter(|&s| wrong(driver.stats(s))));
        if searcher.borrow().hot.is_empty() {
            if !driver.can_start() {
                break;
            }
            let picks = searcher.borrow_mut().propose(&driver.history);
            if picks.is_empty() {
                break;
            }
            driver.evaluate(&picks).await?;
            let filled = driver.take_filled();
            let screened = picks.into_iter().chain(filled);
            searcher.borrow_mut().hot.extend(screened.filter(|&s| wrong(driver.stats(s))));
            continue;
        }
        let rules = Rules { tau, escalate, triage, confirm };
        let hub = lanes::Hub::new(driver, workers);
        let work: Vec<lanes::LaneWork<'_, (), E>> = (0..workers)
            .map(|_| {
                let (hub, searcher, plan) = (&hub, &searcher, &plan);
                Box::pin(async move {
                    let mut lane = hub.lane(escalate);
                    work_hot(&mut lane, space, searcher, rules, plan).await
                }) as lanes::LaneWork<'_, (), E>
            })
            .collect();
        hub.run(work).await?;
    }
    Ok(())
}

/// The rules a hot set is decided by: escalated under `escalate`, explained under `triage`, its
/// core confirmed under `confirm`, failing at `tau`.
#[derive(Clone, Copy)]
struct Rules {
    tau: f64,
    escalate: Rule,
    triage: Rule,
    confirm: Rule,
}

/// One worker: takes the first hot set off the families of the sets the other workers are
/// deciding on ([`apart`]: a set of the same family waits, and is dropped once a core covers it),
/// escalates it, explains it when it fails, and takes the next, until none is left to take.
/// Sets the calls were filled with meanwhile join the hot ones when they answered wrong.
async fn work_hot<'d, E: Evaluate>(
    lane: &mut lanes::Lane<'_, '_, '_, E>,
    space: &'d Space,
    searcher: &RefCell<PatternSearcher<'d>>,
    r: Rules,
    plan: &super::budget::Plan,
) -> Searched<(), E> {
    loop {
        let filled = lane.take_filled();
        let next = {
            let mut s = searcher.borrow_mut();
            s.hot.extend(filled.into_iter().filter(|&set| lane.get(set).is_some_and(|st| st.wrong > 0)));
            let PatternSearcher { hot, focus, board, hot_now, .. } = &mut *s;
            hot.retain(|&set| !board.is_covered(set));
            let free = hot.iter().position(|&set| apart(focus, set, *hot_now));
            let next = free.and_then(|i| hot.remove(i));
            focus.extend(next);
            next
        };
        let Some(set) = next else {
            // Nothing free now: wait for what the others' calls bring.
            if searcher.borrow().focus.is_empty() || !lane.idle().await {
                return Ok(());
            }
            continue;
        };
        lane.set_rule(r.escalate);
        lane.set_purpose(Some(Purpose::Escalation));
        lane.top_up(&[set]).await?;
        let failing = lane.get(set).is_some_and(|s| s.is_failure_mode(r.tau));
        let mut go_on = true;
        if failing && !searcher.borrow().is_covered(set) {
            lane.set_rule(r.triage);
            go_on = lane.can_start();
            if go_on {
                explain_one(lane, space, searcher, set, (r.tau, r.triage, r.confirm), plan).await?;
            }
        }
        let mut s = searcher.borrow_mut();
        s.focus.retain(|&f| f != set);
        if !go_on {
            // The budget cannot start explaining: what is hot is left, and the search screens on
            // with what remains.
            s.hot.clear();
            return Ok(());
        }
    }
}

/// The search's cap now ([`super::budget::Plan::search_cap`]): confirmation's share for the
/// confirmed `cores` and one more, and for the minimal failure modes of `history` none of them
/// explains.
fn search_cap(plan: &super::budget::Plan, history: &[SetStats], space: &Space, tau: f64, cores: &[ConceptSet]) -> u64 {
    plan.search_cap(cores.len(), shrink::unexplained_failures(history, space, tau, cores).len())
}

/// [`explain`] `set`, and take the core it finds, if new: the searcher sets its family aside.
/// The search's cap then keeps fresh confirmation's share for the cores and the loose minimal
/// failure modes found so far ([`search_cap`]).
async fn explain_one<'d, D: Drive>(
    driver: &mut D,
    space: &'d Space,
    searcher: &RefCell<PatternSearcher<'d>>,
    set: ConceptSet,
    rules: (f64, Rule, Rule),
    plan: &super::budget::Plan,
) -> Searched<(), D::Eval> {
    if let Some(c) = explain(driver, space, searcher, set, rules).await? {
        searcher.borrow_mut().confirm(c);
    }
    let s = searcher.borrow();
    driver.set_budget(driver.with_history(|history| search_cap(plan, history, space, rules.0, &s.cores)));
    Ok(())
}

/// Explain the failing set `set`: its likeliest sub-patterns first (at most [`JUMPS`]), shrunk
/// under the triage rule, else the set itself; a core the triage finds is confirmed (and its
/// parts' passing) under the full rule, shrinking on if a part fails after all. Fills made
/// meanwhile keep off its family ([`PatternSearcher::fill`]); the passing near-τ families met
/// are set aside in the searcher. The core found, if any (the caller confirms it there).
async fn explain<'d, D: Drive>(
    driver: &mut D,
    space: &'d Space,
    searcher: &RefCell<PatternSearcher<'d>>,
    set: ConceptSet,
    (tau, triage, confirm): (f64, Rule, Rule),
) -> Searched<Option<ConceptSet>, D::Eval> {
    driver.set_purpose(Some(Purpose::Explaining));
    let candidates = {
        let s = searcher.borrow();
        let fit = driver.with_history(|history| s.fit(history));
        s.candidates(&fit, set)
    };
    let mut core = None;
    // Passing subsets near τ that a failing set did not significantly exceed.
    let mut flat = Vec::new();
    let mut tried = 0;
    for p in candidates {
        if tried == JUMPS {
            break;
        }
        if driver.get(p).is_some_and(|s| !s.is_failure_mode(tau) && triage.settled(&s)) {
            continue;
        }
        tried += 1;
        let shrunk = shrink::shrink(driver, space, p).await?;
        core = sort_out(&shrunk, tau, &mut flat);
        if core.is_some() || shrunk == Shrunk::Unaffordable {
            break;
        }
    }
    if core.is_none() && driver.can_start() {
        core = sort_out(&shrink::shrink(driver, space, set).await?, tau, &mut flat);
    }
    // The triage found a core: confirm it, and its parts' passing, under the full rule
    // (shrinking on if a part fails after all).
    if let Some(c) = core {
        let confirm = Rule { max_samples: confirm.max_samples * CORE_TEST_STRETCH, ..confirm };
        driver.set_rule(confirm);
        driver.set_purpose(Some(Purpose::Confirmation));
        let shrunk = shrink::shrink(driver, space, c).await?;
        core = sort_out(&shrunk, tau, &mut flat);
        // Undecided at the cap: a family near τ, set aside as a not-distinct set's is.
        if let Shrunk::Refuted(stats) = &shrunk
            && confirm.straddles(stats.wrong, stats.answered())
        {
            flat.push(c);
        }
    }
    let mut s = searcher.borrow_mut();
    driver.with_history(|history| s.catch_up(history));
    flat.into_iter().for_each(|by| s.explain(by));
    Ok(core)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bits(ids: &[u32]) -> ConceptSet {
        ConceptSet::from_ids(ids.iter().map(|&i| crate::ir::ConceptId(i)))
    }

    fn stats(set: ConceptSet, wrong: u32, correct: u32) -> SetStats {
        SetStats { wrong, correct, ..SetStats::new(set) }
    }

    /// Concepts 10, 11 and 12 each fail about a third of the time in sets of four with others
    /// that pass: they are hot, and the first combination holds all three (the likeliest
    /// triple), where no evaluated set held them together; the discoveries (the other picks)
    /// leave every hot concept out. A set holding the triple already evaluated makes the first combination
    /// another one.
    #[test]
    fn hot_concepts_meet_in_combinations_and_stay_out_of_discoveries() {
        let space = super::super::tests::sampled(40);
        let params = Params { algo: super::super::Algo::Interact, budget: 400, max_size: 4, ..Params::default() };
        let mut history = Vec::new();
        let mut filler = 13u32;
        let mut next = || {
            let f = [filler, filler + 1, filler + 2];
            filler = if filler + 5 >= 40 { 13 } else { filler + 3 };
            f
        };
        for part in [10u32, 11, 12] {
            for i in 0..6 {
                let f = next();
                history.push(stats(bits(&[part, f[0], f[1], f[2]]), u32::from(i % 2 == 0), 2));
            }
        }
        for _ in 0..20 {
            let f = next();
            history.push(stats(bits(&[2, f[0], f[1]]), 0, 3));
        }
        let mut searcher = PatternSearcher::new(&params, &space);
        let (effects, base) = searcher.concept_effects(&history, 0.05);
        let hot: Vec<_> = PatternSearcher::hot_concepts(&effects, base).into_iter().map(|(c, _)| c.0).collect();
        assert_eq!(hot.iter().copied().collect::<std::collections::BTreeSet<_>>(), [10, 11, 12].into());
        let picks = searcher.concept_sets(&history, 0.05, 6, &[]);
        assert_eq!(picks.len(), 6);
        assert_eq!(searcher.hot_now, bits(&[10, 11, 12]), "kept for the hot sets' turns");
        assert!(bits(&[10, 11, 12]).is_subset_of(picks[0]), "{picks:?}");
        // One triple of hot concepts, so one combination; the rest are discoveries.
        assert!(picks[1..].iter().all(|p| !p.intersects(bits(&[10, 11, 12]))), "{picks:?}");
        // Once the triple was tested together, no combination repeats it.
        history.push(stats(bits(&[10, 11, 12]), 0, 5));
        let mut searcher = PatternSearcher::new(&params, &space);
        let picks = searcher.concept_sets(&history, 0.05, 6, &[]);
        assert!(picks.iter().all(|p| !bits(&[10, 11, 12]).is_subset_of(*p)), "{picks:?}");
    }

    /// While a family is explained, the ranking puts its supersets first: a call's screens are
    /// still the best sets off it (sharing at most one concept with the set being decided on)
    /// as long as there are enough of those, each screened once, up to four fifths of the width.
    #[test]
    fn a_fill_screens_the_best_sets_off_the_families_being_explained() {
        let lattice = crate::ir::testkit::lattice(12, 4);
        let space = Space::new(lattice.clone(), 12);
        let params = Params { algo: super::super::Algo::Interact, budget: 1000, batch: 16, ..Params::default() };
        let mut searcher = PatternSearcher::new(&params, &space);
        // {2, 5} and its supersets fail; sets without both pass.
        let mut history: Vec<SetStats> = lattice
            .iter()
            .filter(|s| s.len() <= 2)
            .map(|&s| if bits(&[2, 5]).is_subset_of(s) { stats(s, 5, 0) } else { stats(s, 0, 5) })
            .collect();
        history.push(stats(bits(&[2, 5, 7]), 3, 0));
        history.iter().for_each(|s| searcher.explored(s.set));
        searcher.focus = vec![bits(&[2, 5, 7])];
        // Of a call's room of 16, three are left empty (filled to 13, four fifths of the width),
        // and a room of three gets no screen.
        assert!(searcher.fill(&history, &[], 3).is_empty());
        let fill = searcher.fill(&history, &[], 16);
        assert_eq!(fill.len(), 13, "{fill:?}");
        let sets: Vec<ConceptSet> = fill.iter().map(|a| a.set).collect();
        assert!(fill.iter().all(|a| a.obs == (0..SCREEN)), "{fill:?}");
        assert!(sets.iter().all(|&s| bits(&[2, 5, 7]).intersection(s).len() < 2), "{sets:?}");
        assert!(sets.iter().enumerate().all(|(i, s)| !sets[..i].contains(s)), "{sets:?}");
    }

    /// A round's picks are made as if the ones before them had answered right: after a wrong
    /// answer of {2, 5} the first pick is one of its supersets, and the later ones leave it for
    /// other patterns, as one pick at a time would once the first had answered right — not every
    /// pick of the round a superset of the one suspect pair (all twelve without the belief).
    #[test]
    fn a_rounds_picks_believe_the_picks_before_them_answered_right() {
        let lattice = crate::ir::testkit::lattice(12, 4);
        let space = Space::new(lattice.clone(), 12);
        let params = Params { algo: super::super::Algo::Interact, budget: 1000, batch: 12, ..Params::default() };
        let mut history: Vec<SetStats> = lattice.iter().filter(|s| s.len() == 1).map(|&s| stats(s, 0, 2)).collect();
        history.push(stats(bits(&[2, 5]), 1, 0));
        let mut searcher = PatternSearcher::new(&params, &space);
        history.iter().for_each(|s| searcher.explored(s.set));
        let picks = searcher.propose(&history);
        assert_eq!(picks.len(), 12);
        assert!(picks.iter().enumerate().all(|(i, p)| !picks[..i].contains(p)), "{picks:?}");
        let on_pair = |p: &ConceptSet| bits(&[2, 5]).is_subset_of(*p);
        assert!(on_pair(&picks[0]), "{picks:?}");
        let held = picks.iter().filter(|p| on_pair(p)).count();
        assert!(held < picks.len(), "{held} of 12 picks hold {{2, 5}}: {picks:?}");
        // `believe_right` adds one right answer, to a set's entry or a new one.
        let mut h = vec![stats(bits(&[1]), 1, 0)];
        believe_right(&mut h, bits(&[1]), 1);
        believe_right(&mut h, bits(&[3, 4]), 1);
        assert_eq!((h[0].wrong, h[0].correct, h[1].set, h[1].correct), (1, 1, bits(&[3, 4]), 1));
        believe_right(&mut h, bits(&[1]), 2);
        believe_right(&mut h, bits(&[6]), 0);
        assert_eq!((h[0].correct, h.len()), (3, 2), "n answers; none adds no entry");
    }

    /// A fill believes the observations its call already holds answered right: while {2, 5, 7},
    /// wrong once, is escalated in the same call, the fill's screens go to other patterns too
    /// (8 of 13 hold one of its concepts) instead of each testing one of them (13 of 13), as one
    /// pick at a time would once the escalation had cleared it.
    #[test]
    fn a_fill_believes_the_calls_pending_observations_answered_right() {
        let lattice = crate::ir::testkit::lattice(20, 3);
        let space = Space::new(lattice.clone(), 20);
        let params = Params { algo: super::super::Algo::Interact, budget: 1000, batch: 16, ..Params::default() };
        let suspect = bits(&[2, 5, 7]);
        let mut history: Vec<SetStats> = lattice.iter().filter(|s| s.len() == 1).map(|&s| stats(s, 0, 2)).collect();
        history.push(stats(suspect, 1, 0));
        let escalation = [super::super::Ask { set: suspect, obs: 1..3 }];
        let held = |pending: &[super::super::Ask]| {
            let mut searcher = PatternSearcher::new(&params, &space);
            history.iter().for_each(|s| searcher.explored(s.set));
            searcher.focus = vec![suspect];
            let fill = searcher.fill(&history, pending, 16);
            assert_eq!(fill.len(), 13, "{fill:?}");
            fill.iter().filter(|a| a.set.intersects(suspect)).count()
        };
        let (believing, not) = (held(&escalation), held(&[]));
        assert_eq!(not, 13, "without the belief every screen holds one of its concepts");
        assert!(believing <= 9, "{believing} of 13 screens hold one of its concepts");
    }

    /// A pick's queue: the best score first, ties to the earliest position in the space.
    #[test]
    fn a_pick_queue_serves_the_best_score_then_the_earliest_set() {
        let mut q: BinaryHeap<Queued> = [(0.2, 4), (0.5, 7), (0.5, 3), (0.1, 0)]
            .into_iter()
            .map(|(score, at)| Queued { score, at, version: 0 })
            .collect();
        let order: Vec<usize> = std::iter::from_fn(|| q.pop().map(|e| e.at)).collect();
        assert_eq!(order, vec![3, 7, 4, 0]);
    }

    /// A fill's screens: those sharing at most one concept with every one taken before come
    /// first, in rank order, then the best of the rest.
    #[test]
    fn a_fill_spreads_its_screens_over_different_patterns_first() {
        let ranked = [bits(&[1, 2, 3]), bits(&[1, 2, 4]), bits(&[5, 6]), bits(&[1, 5]), bits(&[2, 3, 7])];
        assert_eq!(spread(&ranked, 3), vec![bits(&[1, 2, 3]), bits(&[5, 6]), bits(&[1, 5])]);
        assert_eq!(spread(&ranked, 4)[3], bits(&[1, 2, 4]), "then the best of the rest");
        assert_eq!(spread(&ranked, 9).len(), 5);
        assert!(spread(&ranked, 0).is_empty());
    }

    /// A hot set that shares two concepts with a set being decided on waits for it (it may fail
    /// through the same core), unless it holds, outside that set, two concepts found hot: a group
    /// that can fail of its own. Without hot concepts (a listed space) only the first holds.
    #[test]
    fn a_hot_set_waits_for_a_family_it_may_fail_through_unless_it_holds_a_hot_group_of_its_own() {
        let focus = [bits(&[5, 9, 17, 66])];
        let none = ConceptSet::EMPTY;
        assert!(apart(&focus, bits(&[5, 40, 41]), none), "one concept shared");
        assert!(!apart(&focus, bits(&[5, 17, 40, 41]), none), "two shared");
        let hot = bits(&[5, 9, 13, 17, 21]);
        assert!(apart(&focus, bits(&[5, 13, 17, 21]), hot), "13 + 21 outside the focus, both hot");
        assert!(!apart(&focus, bits(&[5, 13, 17, 40]), hot), "one hot concept outside");
        assert!(
            !apart(&[bits(&[13, 17, 21]), focus[0]], bits(&[5, 13, 17, 21]), hot),
            "holds 13 + 17 + 21, decided on"
        );
        assert!(apart(&[], bits(&[5, 9]), none), "nothing decided on");
    }
}

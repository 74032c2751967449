//! `--algo interact`: Thompson sampling over the valid lattice with an interaction-aware
//! surrogate ([`super::surrogate`]), shrinking each failure it finds to its core and then looking
//! for the next family.
//!
//! A round: a few Gibbs sweeps of the surrogate on every evaluated set (warm-started from the
//! previous round), `batch` Thompson draws, and for each the unexplored valid set with the highest
//! drawn failure rate among the *open* sets — those that hold no confirmed core. When a picked
//! open set fails, it is shrunk at once by [`super::shrink::shrink`] under the shrink phase's
//! sequential rule ([`Params::shrink_rule`]): re-tested (a failure that does not hold up is
//! refuted and only feeds the surrogate), then reduced one concept at a time to a set whose every
//! one-smaller valid subset passes. That set is a confirmed core: its supersets leave the open
//! sets (exclusion), and the surrogate gets an indicator feature for it (conditioning), so its
//! effect is not smeared over the pairs it contains. The shrink spends the search's budget: the
//! run as a whole stays within `--budget`.
//!
//! When a draw finds no open set with a drawn failure rate of at least τ — it believes every
//! family has been found — every other such draw picks the best unexplored superset of a
//! confirmed core instead: the known families' extent (which contexts still fail, which cancel
//! them) is worth measuring and fails often, while the other draws keep exploring the open sets,
//! where a mode whose parts carry no signal (a triple of silent pairs) can only be found by
//! trying it.
//!
//! Every decision is a pure function of the seed and the observed failure rates, so a resumed run
//! replays exactly.
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::ir::ConceptSet;

use super::shrink::{self, Shrunk};
use super::surrogate::{Basis, Data, Draw, Gibbs, Order, Prior};
use super::{Driver, Evaluate, Params, SetStats, Space};

/// Salt for the interact random stream.
const STREAM: u64 = 0x696e_7465_7261_6374;

/// Gibbs sweeps per round (the chain is warm-started from the previous round).
const SWEEPS: usize = 4;

/// The surrogate variants compared in `docs/search.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Surrogate {
    /// Pairwise regression, horseshoe prior (BOCS).
    #[default]
    Horseshoe,
    /// Pairwise regression, one learned Gaussian variance per group.
    Ridge,
    /// Concept indicators only, horseshoe prior.
    Linear,
}

impl Surrogate {
    pub const ALL: [Surrogate; 3] = [Surrogate::Horseshoe, Surrogate::Ridge, Surrogate::Linear];

    pub fn name(self) -> &'static str {
        match self {
            Surrogate::Horseshoe => "horseshoe",
            Surrogate::Ridge => "ridge",
            Surrogate::Linear => "linear",
        }
    }

    fn parts(self) -> (Order, Prior) {
        match self {
            Surrogate::Horseshoe => (Order::Pairwise, Prior::Horseshoe),
            Surrogate::Ridge => (Order::Pairwise, Prior::Ridge),
            Surrogate::Linear => (Order::Linear, Prior::Horseshoe),
        }
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
    /// Picked only when a draw sees no open set failing (the default).
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

/// The lattice as the search sees it: which sets were evaluated, which hold a confirmed core.
struct Board<'s> {
    space: &'s Space,
    explored: Vec<bool>,
    covered: Vec<bool>,
}

impl<'s> Board<'s> {
    fn new(space: &'s Space) -> Board<'s> {
        Board { space, explored: vec![false; space.sets.len()], covered: vec![false; space.sets.len()] }
    }

    fn explore(&mut self, set: ConceptSet) {
        if let Some(i) = self.space.position(set) {
            self.explored[i] = true;
        }
    }

    fn cover(&mut self, core: ConceptSet) {
        for (i, s) in self.space.sets.iter().enumerate() {
            if core.is_subset_of(*s) {
                self.covered[i] = true;
            }
        }
    }

    fn is_covered(&self, set: ConceptSet) -> bool {
        self.space.position(set).is_some_and(|i| self.covered[i])
    }

    /// The unexplored set with the highest score among the open (`covered == false`) or the
    /// covered sets; ties go to the earliest in lattice order.
    fn argmax(&self, covered: bool, score: impl Fn(ConceptSet) -> f64) -> Option<(ConceptSet, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for (i, set) in self.space.sets.iter().enumerate() {
            if self.explored[i] || self.covered[i] != covered {
                continue;
            }
            let v = score(*set);
            if best.is_none_or(|(_, b)| v > b) {
                best = Some((i, v));
            }
        }
        best.map(|(i, v)| (self.space.sets[i], v))
    }
}

/// The search state between rounds: surrogate, Gibbs chain, lattice bookkeeping, random stream.
pub struct Searcher<'s> {
    params: Params,
    basis: Basis,
    gibbs: Gibbs,
    board: Board<'s>,
    rng: ChaCha8Rng,
    /// Draws so far that saw no open set failing: every other one explores the open sets anyway.
    idle: u64,
}

impl<'s> Searcher<'s> {
    pub fn new(params: &Params, space: &'s Space) -> Searcher<'s> {
        let (order, prior) = params.surrogate.parts();
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

pub async fn run<E: Evaluate>(params: &Params, space: &Space, driver: &mut Driver<'_, E>) -> Result<(), String> {
    let mut searcher = Searcher::new(params, space);
    let mut marked = 0;
    let mark = |searcher: &mut Searcher<'_>, history: &[SetStats], marked: &mut usize| {
        for s in &history[*marked..] {
            searcher.explored(s.set);
        }
        *marked = history.len();
    };
    while driver.can_start() {
        let picks = searcher.propose(&driver.history);
        if picks.is_empty() {
            break;
        }
        let stats = driver.evaluate(&picks).await?;
        mark(&mut searcher, &driver.history, &mut marked);
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
            mark(&mut searcher, &driver.history, &mut marked);
            if let Shrunk::Core(core) = shrunk? {
                searcher.confirm(core.stats.set);
            }
        }
    }
    Ok(())
}

//! The search runtime: Random, diversity-aware Beam search (paper Algorithm 1) and GP Thompson
//! sampling (Algorithm 2) over the valid concept lattice.
//!
//! Every decision an algorithm makes is a pure function of the run seed and the failure rates it
//! has observed: candidate orders are fixed, ties break on the canonical set order, and random
//! draws come from a ChaCha stream seeded by the run seed. Resuming a run therefore replays the
//! algorithm from the start against the journal ([`crate::journal`]): finished observations are
//! served from it, and the run continues exactly where the killed one stopped.
//!
//! Budgets count inferences; an algorithm evaluates at most `budget / samples` sets, each with
//! `samples` observations. No set is evaluated twice.

pub mod beam;
pub mod gp;
pub mod gpts;
pub mod interact;
pub mod metrics;
pub mod random;
pub mod space;
pub mod surrogate;

use std::collections::{HashMap, HashSet};
use std::future::Future;

use serde::{Deserialize, Serialize};

use crate::ir::ConceptSet;
pub use metrics::SetStats;
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
    /// Inference budget.
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
    pub seed: u64,
    /// Largest set size in the lattice.
    pub max_size: usize,
    /// Interact: the surrogate.
    #[serde(default)]
    pub surrogate: interact::Surrogate,
    /// Interact: what happens to the supersets of a confirmed core.
    #[serde(default)]
    pub supersets: interact::Supersets,
}

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
            seed: 0,
            max_size: 5,
            surrogate: interact::Surrogate::default(),
            supersets: interact::Supersets::default(),
        }
    }
}

impl Params {
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
        if self.beam_budget > self.budget {
            return bad("beam-budget", &format!("{} exceeds the budget {}", self.beam_budget, self.budget));
        }
        if self.batch == 0 {
            return bad("batch", "must be at least 1");
        }
        if self.max_size == 0 || self.max_size > crate::ir::MAX_CONCEPTS {
            return bad("max-size", "must be between 1 and 128");
        }
        Ok(())
    }

    /// Sets the budget pays for.
    pub fn max_sets(&self) -> usize {
        (self.budget / u64::from(self.samples)) as usize
    }
}

/// Evaluates concept sets: `samples` observations each, run concurrently.
pub trait Evaluate {
    /// Evaluate `sets` (distinct, never evaluated before); stats come back in the same order.
    fn evaluate(&mut self, sets: &[ConceptSet]) -> impl Future<Output = Result<Vec<SetStats>, String>>;
}

/// Budget and history bookkeeping shared by the algorithms.
pub struct Driver<'e, E> {
    eval: &'e mut E,
    /// Every evaluated set, in evaluation order.
    pub history: Vec<SetStats>,
    /// Index into `history` of every evaluated set.
    seen: HashMap<ConceptSet, usize>,
    max_sets: usize,
}

impl<'e, E: Evaluate> Driver<'e, E> {
    pub fn new(eval: &'e mut E, max_sets: usize) -> Self {
        Driver { eval, history: Vec::new(), seen: HashMap::new(), max_sets }
    }

    pub fn remaining(&self) -> usize {
        self.max_sets.saturating_sub(self.history.len())
    }

    pub fn seen(&self, set: ConceptSet) -> bool {
        self.seen.contains_key(&set)
    }

    /// Change the set budget (GPTS moves from its beam phase to the full budget).
    pub fn set_max_sets(&mut self, max_sets: usize) {
        self.max_sets = max_sets;
    }

    /// Evaluate the sets not evaluated yet, in order, as far as the budget goes; returns the
    /// stats of every requested set that has been evaluated (now or before), in request order.
    pub async fn evaluate(&mut self, sets: &[ConceptSet]) -> Result<Vec<SetStats>, String> {
        let mut fresh = Vec::new();
        let mut batch = HashSet::new();
        for &s in sets {
            if !self.seen.contains_key(&s) && batch.insert(s) {
                fresh.push(s);
            }
        }
        fresh.truncate(self.remaining());
        let stats = self.eval.evaluate(&fresh).await?;
        for s in stats {
            self.seen.insert(s.set, self.history.len());
            self.history.push(s);
        }
        Ok(sets.iter().filter_map(|s| self.seen.get(s).map(|&i| self.history[i].clone())).collect())
    }
}

/// Run the chosen algorithm; returns every evaluated set in evaluation order.
pub async fn run<E: Evaluate>(params: &Params, space: &Space, eval: &mut E) -> Result<Vec<SetStats>, String> {
    let mut driver = Driver::new(eval, params.max_sets());
    match params.algo {
        Algo::Random => random::run(params, space, &mut driver).await?,
        Algo::Beam => beam::run(params, space, &mut driver).await?,
        Algo::Gpts => gpts::run(params, space, &mut driver).await?,
        Algo::Interact => interact::run(params, space, &mut driver).await?,
    }
    Ok(driver.history)
}

#[cfg(test)]
mod tests;

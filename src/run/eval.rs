//! The evaluator: observations of concept sets through the one observe pipeline
//! ([`super::observe`]), concurrently up to the run's concurrency, each journaled the moment it
//! ends; observations already in the journal are replayed instead of asked again.
//!
//! Observations are addressed by [`ObsKey`] (phase, set, observation index), and
//! [`Evaluator::observe_sets`] evaluates any index range of any set: `0..m` for a search step,
//! `k..n` for more observations of a set already evaluated (sequential sampling, [`Ask`]), another
//! phase for validation or shrinking. Each observation's scene seed is a pure function of the run
//! seed and its key ([`observation_seed`]), so a range extended later sees the scenes it would
//! have seen in one go.
//!
//! Distinct scenes: the evaluator keeps the run's [`Shown`] register (from the journal on
//! resume) and draws each observation's scene with [`Observer::distinct_stimulus`], in per-set
//! [`Turns`], so no set is shown an image twice in the run and which observation re-draws is the
//! same in every run (see [`super::distinct`]). Observations that could not find a new scene
//! (`repeated`) are counted per set in [`Evaluator::repeated`].
//!
//! Stopping: after `max_api_errors` model calls in a row end in `api_error`, or when the
//! [`Stop`] handle is triggered (Ctrl-C), no new call starts; calls in flight finish and are
//! journaled, the journal is synced, and the evaluation ends with [`RunError::Stopped`].
use std::collections::{HashMap, HashSet};
use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use tokio::sync::Semaphore;

use crate::ir::ConceptSet;
use crate::journal::{Journal, Phase};
use crate::outcome::{Outcome, Usage};
use crate::search::{Ask, Evaluate, SetStats};
use crate::vlm::Model;

use super::distinct::{Shown, Turns};
use super::observe::{ObsKey, Observation, ObserveError, Observer};
// Where these lived before the observe pipeline had its own module.
pub use super::observe::{DomainWorld, Task, World};
use super::progress::Progress;
use super::stop::{Stop, StopReason};
use super::summary::Spend;
use super::{ResumeError, RunError};

/// SplitMix64 finaliser: mixes run seed, phase, set and observation index into one seed.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The scene seed of one observation: a pure function of the run seed and the observation's key,
/// so a resumed run samples the same scenes. Each phase has its own stream (validation sees
/// fresh scenes of the same sets).
pub fn observation_seed(run_seed: u64, key: ObsKey) -> u64 {
    let p = match key.phase {
        Phase::Search => 0x5345_4152_4348,
        Phase::Validate => 0x5641_4c49_4441,
        Phase::Shrink => 0x5348_5249_4e4b,
        Phase::Probe => 0x0050_524f_4245,
        Phase::Transfer => 0x5452_414e_5346,
        Phase::Confirm => 0x434f_4e46_524d,
    };
    let mut h = mix(run_seed ^ p);
    h = mix(h ^ key.set.words()[0]);
    h = mix(h ^ key.set.words()[1]);
    if !key.set.fits_128() {
        // Sets past 128 concepts mix in their other words; narrower sets keep their old seeds.
        h = key.set.words()[2..].iter().fold(h, |h, w| mix(h ^ w));
    }
    mix(h ^ u64::from(key.index))
}

/// Counts model calls that end in `api_error` in a row, as they finish (before the next call
/// starts), and requests the stop when there are `max` of them.
struct ApiErrorWatch {
    max: u32,
    in_a_row: std::sync::Mutex<u32>,
    stop: Stop,
}

impl ApiErrorWatch {
    fn record(&self, outcome: Outcome, raw: &str) {
        let mut n = self.in_a_row.lock().unwrap_or_else(|p| p.into_inner());
        match outcome {
            Outcome::ApiError => *n += 1,
            // No model call was made: it says nothing about the model's API.
            Outcome::ImageBlocked | Outcome::Invisible | Outcome::Repeated => return,
            _ => *n = 0,
        }
        if self.max > 0 && *n >= self.max {
            self.stop.request(StopReason::ApiErrors { count: *n, last: raw.to_string() });
        }
    }
}

/// A finished observation and where its outcome goes: (request, index within the request).
type Placed = (usize, usize, Observation);

/// A journaled observation served again on resume.
#[derive(Debug, Clone, Copy)]
struct Replayed {
    outcome: Outcome,
    usage: Usage,
    cached: bool,
    /// Attempts, rate-limited retries, milliseconds waited.
    retries: (u32, u32, u64),
}

pub struct EvaluatorConfig {
    pub observer: Arc<Observer>,
    pub model: Arc<dyn Model>,
    pub journal: Arc<Journal>,
    pub seed: u64,
    pub threshold: f64,
    /// Observations in flight at once (the run's effective concurrency).
    pub concurrency: usize,
    /// The phase [`Evaluate::evaluate`] observes in.
    pub phase: Phase,
    pub stop: Stop,
    /// Stop after this many model calls in a row end in `api_error` (0: never).
    pub max_api_errors: u32,
    /// A concurrency limit shared with other runs (a campaign); `None`: `concurrency` alone.
    pub gate: Option<Arc<Semaphore>>,
}

pub struct Evaluator {
    observer: Arc<Observer>,
    model: Arc<dyn Model>,
    journal: Arc<Journal>,
    seed: u64,
    semaphore: Arc<Semaphore>,
    replay: HashMap<ObsKey, Replayed>,
    pub phase: Phase,
    pub threshold: f64,
    /// Shown as observations finish (set by the runner).
    pub progress: Option<Progress>,
    stop: Stop,
    api_errors: Arc<ApiErrorWatch>,
    /// Outcomes so far per set (this evaluator's observations, replayed ones included), for the
    /// progress line's failure-mode count.
    tally: HashMap<(Phase, ConceptSet), SetStats>,
    failing: HashSet<(Phase, ConceptSet)>,
    /// Observations served from the journal instead of the model.
    pub replayed: u64,
    /// Tokens and money of every observation evaluated (replayed ones as journaled).
    pub spend: Spend,
    /// The images each set has shown in the run.
    shown: Arc<Shown>,
    /// Per set, the observations (every phase, replayed ones included) that could only have
    /// shown an image the set had already shown (outcome `repeated`).
    pub repeated: std::collections::BTreeMap<ConceptSet, u32>,
}

impl Evaluator {
    pub fn new(c: EvaluatorConfig) -> Result<Evaluator, RunError> {
        let domain = c.observer.domain().clone();
        let mut replay = HashMap::new();
        for (i, r) in c.journal.records.iter().enumerate() {
            // A failed call is not a paid answer: a resumed run asks again (the newer line wins).
            if r.outcome == Outcome::ApiError {
                continue;
            }
            // Probe and transfer replies are read by their own commands (another prompt, or
            // another model), never replayed as this evaluator's answers.
            if matches!(r.phase, Phase::Probe | Phase::Transfer) {
                continue;
            }
            let set = domain.parse_set(&r.set).map_err(|e| ResumeError::UnknownSet {
                dir: c.journal.dir().to_path_buf(),
                line: i + 1,
                message: e.to_string(),
            })?;
            replay.insert(
                ObsKey { phase: r.phase, set, index: r.obs },
                Replayed {
                    outcome: r.outcome,
                    usage: r.usage,
                    cached: r.cached,
                    retries: (r.attempts, r.rate_limited, r.waited_ms),
                },
            );
        }
        let shown = Arc::new(Shown::from_journal(&domain, &c.journal.records));
        Ok(Evaluator {
            shown,
            repeated: std::collections::BTreeMap::new(),
            observer: c.observer,
            model: c.model,
            journal: c.journal,
            seed: c.seed,
            semaphore: c.gate.unwrap_or_else(|| Arc::new(Semaphore::new(c.concurrency.max(1)))),
            replay,
            phase: c.phase,
            threshold: c.threshold,
            progress: None,
            // Its own stop: a resume in the same process starts with a clean slate.
            api_errors: Arc::new(ApiErrorWatch {
                max: c.max_api_errors,
                in_a_row: std::sync::Mutex::new(0),
                stop: Stop::default(),
            }),
            stop: c.stop,
            tally: HashMap::new(),
            failing: HashSet::new(),
            replayed: 0,
            spend: Spend::default(),
        })
    }

    /// The sets with `repeated` observations, with how many distinct images each showed.
    pub fn repeated_rows(&self) -> Vec<super::summary::RepeatedRow> {
        let domain = self.observer.domain();
        self.repeated
            .iter()
            .map(|(&set, &repeated)| super::summary::RepeatedRow {
                concepts: domain.set_names(set).into_iter().map(String::from).collect(),
                repeated,
                distinct: self.shown.count(set) as u32,
            })
            .collect()
    }

    /// Book one finished observation: spend, progress, the failure-mode count (the shrink phase
    /// re-tests failure modes and their subsets: not counted as new ones).
    fn finished(&mut self, key: ObsKey, outcome: Outcome, usage: &Usage, cached: bool, retries: (u32, u32, u64)) {
        // A blocked image or an invisible scene made no model call.
        if outcome.asked_a_model() {
            self.spend.add(usage, cached);
            self.spend.add_retries(retries.0, retries.1, retries.2);
        }
        if outcome == Outcome::Repeated {
            *self.repeated.entry(key.set).or_default() += 1;
        }
        if matches!(key.phase, Phase::Shrink | Phase::Confirm) {
            if let Some(p) = &self.progress {
                p.inc(&self.spend);
            }
            return;
        }
        let stats = self.tally.entry((key.phase, key.set)).or_insert_with(|| SetStats::new(key.set));
        stats.add(outcome);
        let failing = stats.is_failure_mode(self.threshold);
        let changed = if failing {
            self.failing.insert((key.phase, key.set))
        } else {
            self.failing.remove(&(key.phase, key.set))
        };
        if let Some(p) = &self.progress {
            p.inc(&self.spend);
            if changed {
                p.set_failure_modes(self.failing.len());
            }
        }
    }

    /// Observations `range` of each set in `phase`, concurrently; returns each request's outcomes
    /// in index order. Journaled observations are replayed; the rest are asked and journaled.
    pub async fn observe_sets(
        &mut self,
        phase: Phase,
        requests: &[(ConceptSet, Range<u32>)],
    ) -> Result<Vec<Vec<Outcome>>, RunError> {
        let mut out: Vec<Vec<Option<Outcome>>> = requests.iter().map(|(_, r)| vec![None; r.len()]).collect();
        let halt = Arc::new(AtomicBool::new(false));
        let mut tasks: tokio::task::JoinSet<Result<Option<Placed>, ObserveError>> = tokio::task::JoinSet::new();
        let mut turns = Turns::default();
        for (i, (set, range)) in requests.iter().enumerate() {
            let task = Arc::new(self.observer.task(*set)?);
            for index in range.clone() {
                let key = ObsKey { phase, set: *set, index };
                let slot = (index - range.start) as usize;
                if let Some(r) = self.replay.get(&key).copied() {
                    out[i][slot] = Some(r.outcome);
                    self.replayed += 1;
                    self.finished(key, r.outcome, &r.usage, r.cached, r.retries);
                    continue;
                }
                let seed = observation_seed(self.seed, key);
                let (observer, model, journal) = (self.observer.clone(), self.model.clone(), self.journal.clone());
                let (sem, stop, halt, task) = (self.semaphore.clone(), self.stop.clone(), halt.clone(), task.clone());
                let (watch, shown) = (self.api_errors.clone(), self.shown.clone());
                let mut turn = turns.next(*set);
                tasks.spawn(async move {
                    // The set's earlier observations claim their scenes first (before this one
                    // holds a permit, so they can always get one).
                    turn.wait().await;
                    let _permit = sem.acquire_owned().await.expect("the semaphore is never closed");
                    if stop.requested() || watch.stop.requested() || halt.load(Ordering::SeqCst) {
                        return Ok(None);
                    }
                    let stimulus = observer.distinct_stimulus(key.set, seed, Some(&shown)).await?;
                    turn.pass();
                    let o = observer.show(model.as_ref(), key, &stimulus, &task, Some(&journal), None).await?;
                    watch.record(o.outcome, &o.record.raw);
                    Ok(Some((i, slot, o)))
                });
            }
        }
        let mut first_error: Option<RunError> = None;
        while let Some(joined) = tasks.join_next().await {
            match joined {
                Ok(Ok(Some((i, slot, o)))) => {
                    out[i][slot] = Some(o.outcome);
                    let retries = (o.record.attempts, o.record.rate_limited, o.record.waited_ms);
                    self.finished(o.key, o.outcome, &o.record.usage, o.record.cached, retries);
                }
                Ok(Ok(None)) => {}
                Ok(Err(e)) => {
                    // Let the calls in flight finish and be journaled; start no new one.
                    halt.store(true, Ordering::SeqCst);
                    first_error.get_or_insert(e.into());
                }
                Err(e) => {
                    halt.store(true, Ordering::SeqCst);
                    first_error.get_or_insert(RunError::Search(format!("an observation task failed: {e}")));
                }
            }
        }
        self.journal.sync()?;
        if let Some(e) = first_error {
            return Err(e);
        }
        if let Some(reason) = self.api_errors.stop.reason().or_else(|| self.stop.reason()) {
            return Err(RunError::Stopped(reason));
        }
        Ok(out.into_iter().map(|v| v.into_iter().map(|o| o.expect("every observation ended")).collect()).collect())
    }
}

impl Evaluate for Evaluator {
    type Error = RunError;

    async fn evaluate(&mut self, asks: &[Ask]) -> Result<Vec<SetStats>, RunError> {
        let requests: Vec<(ConceptSet, Range<u32>)> = asks.iter().map(|a| (a.set, a.obs.clone())).collect();
        let outcomes = self.observe_sets(self.phase, &requests).await?;
        Ok(asks
            .iter()
            .zip(outcomes)
            .map(|(a, os)| {
                let mut s = SetStats::new(a.set);
                os.into_iter().for_each(|o| s.add(o));
                s
            })
            .collect())
    }
}

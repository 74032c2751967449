//! Asking a finished run's sets again through the one observe pipeline (`run::observe`): with
//! the probe prompt (`revelio probe`), or of other models (`revelio transfer`). Each observation
//! is journaled in the run folder the moment it ends (phase `probe` or `transfer`, the latter
//! with its model), and a second invocation serves what the journal holds instead of asking
//! again. Scene seeds are a pure function of the run seed and (phase, set, index), never of the
//! model: every target of a transfer sees the same images, rendered once.
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tokio::sync::Semaphore;

use crate::ir::{ConceptSet, Domain};
use crate::journal::{Journal, Phase, Record};
use crate::outcome::Outcome;
use crate::run::eval::observation_seed;
use crate::run::progress::{Progress, ProgressTo};
use crate::run::summary::Spend;
use crate::run::{ObsKey, Observer, RunError, Stimulus, Stop, StopReason};
use crate::search::SetStats;
use crate::vlm::{Model, Statement};

use super::probe::ProbedSet;

/// What re-asking needs: the run's observe pipeline, its journal and seed.
pub struct Reask {
    pub observer: Arc<Observer>,
    pub journal: Arc<Journal>,
    /// The run seed (`config.json`).
    pub seed: u64,
    pub concurrency: usize,
    pub stop: Stop,
    pub progress: ProgressTo,
}

/// The probe statements of a set's observation, in prompt order: each concept's positive
/// statement and its counterfactual, shuffled by the observation's seed so a statement's
/// position says nothing about its truth. Concepts without a probe are left out.
pub fn statements(domain: &Domain, set: ConceptSet, seed: u64) -> Vec<Statement> {
    let mut out = Vec::new();
    for id in set.iter() {
        let c = &domain.concepts[id.index()];
        if c.probe.positive.trim().is_empty() || c.probe.negative.trim().is_empty() {
            continue;
        }
        out.push(Statement { concept: c.name.clone(), positive: true, text: c.probe.positive.clone() });
        out.push(Statement { concept: c.name.clone(), positive: false, text: c.probe.negative.clone() });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5354_4154_454d_454e);
    for i in (1..out.len()).rev() {
        let j = rng.random_range(0..=i);
        out.swap(i, j);
    }
    out
}

/// A journal line's place: (phase, set names, index, model).
type LineKey = (Phase, Vec<String>, u32, Option<String>);

/// The journaled lines of `phase`, last one winning; failed calls are left out (asked again).
fn journaled(journal: &Journal, phase: Phase) -> HashMap<LineKey, Record> {
    journal
        .records
        .iter()
        .filter(|r| r.phase == phase && r.outcome != Outcome::ApiError)
        .map(|r| ((r.phase, r.set.clone(), r.obs, r.model.clone()), r.clone()))
        .collect()
}

/// Whether a model was asked for the line: not for a scene the image generator blocked or one
/// whose entity stayed invisible or whose image repeated one already shown (none costs a call).
fn asked(rec: &Record) -> bool {
    rec.outcome.asked_a_model()
}

fn stopped(stop: &Stop) -> Result<(), RunError> {
    match stop.reason() {
        Some(r) => Err(RunError::Stopped(r)),
        None => Ok(()),
    }
}

/// What ends a run of tasks: the first task's error, kept, stops the others (its stop reason, or
/// an interruption); a task that could not finish (`what` names it) is an error of its own.
#[derive(Default)]
struct FirstError(Option<RunError>);

impl FirstError {
    fn failed(&mut self, stop: &Stop, e: RunError) {
        stop.request(match &e {
            RunError::Stopped(reason) => reason.clone(),
            _ => StopReason::Interrupted,
        });
        self.0.get_or_insert(e);
    }

    fn join_failed(&mut self, what: &str, e: tokio::task::JoinError) {
        self.0.get_or_insert(RunError::Search(format!("a {what} task failed: {e}")));
    }

    /// After every task: the journal synced, then the first error or the stop's reason.
    fn finish(self, progress: &mut Progress, journal: &Journal, stop: &Stop) -> Result<(), RunError> {
        progress.finish();
        journal.sync()?;
        if let Some(e) = self.0 {
            return Err(e);
        }
        stopped(stop)
    }
}

/// One finished probe observation: its outcome and its statement marks.
struct ProbeObs {
    set: usize,
    outcome: Outcome,
    statements: Vec<Statement>,
    marks: Vec<Option<bool>>,
}

/// Ask `samples` observations of each set with the probe prompt (phase `probe`).
pub async fn probe(
    r: &Reask,
    model: Arc<dyn Model>,
    sets: &[ConceptSet],
    samples: u32,
) -> Result<(Vec<ProbedSet>, Spend), RunError> {
    let domain = r.observer.domain().clone();
    let done = journaled(&r.journal, Phase::Probe);
    let mut spend = Spend::default();
    let mut progress = Progress::start(&r.progress, "probe", sets.len() as u64 * u64::from(samples), r.concurrency);
    let semaphore = Arc::new(Semaphore::new(r.concurrency.max(1)));
    let mut tasks: tokio::task::JoinSet<Result<Option<(ProbeObs, Record)>, RunError>> = tokio::task::JoinSet::new();
    let mut finished: Vec<ProbeObs> = Vec::new();
    for (i, &set) in sets.iter().enumerate() {
        let names: Vec<String> = domain.set_names(set).into_iter().map(String::from).collect();
        let task = Arc::new(r.observer.task(set)?);
        for index in 0..samples {
            let key = ObsKey { phase: Phase::Probe, set, index };
            let seed = observation_seed(r.seed, key);
            let st = statements(&domain, set, seed);
            if let Some(rec) = done.get(&(Phase::Probe, names.clone(), index, None)) {
                let marks = crate::vlm::statements::parse(&rec.raw, st.len());
                if asked(rec) {
                    spend.add(&rec.usage, rec.cached);
                    spend.add_retries(rec.attempts, rec.rate_limited, rec.waited_ms);
                }
                progress.inc(&spend);
                finished.push(ProbeObs { set: i, outcome: rec.outcome, statements: st, marks });
                continue;
            }
            let (observer, model, journal, task) = (r.observer.clone(), model.clone(), r.journal.clone(), task.clone());
            let (sem, stop) = (semaphore.clone(), r.stop.clone());
            tasks.spawn(async move {
                let _permit = sem.acquire_owned().await.expect("the semaphore is never closed");
                if stop.requested() {
                    return Ok(None);
                }
                let stimulus = observer.stimulus(set, seed).await?;
                if let Some(png) = &stimulus.image {
                    journal.store_image(png)?;
                }
                let mut query = observer.query(&stimulus, &task);
                let texts: Vec<String> = st.iter().map(|s| s.text.clone()).collect();
                query.prompt = crate::vlm::prompt::build_probe(&task.question, &task.options, &texts);
                if let Some(t) = query.truth.as_mut() {
                    t.statements = st.clone();
                }
                // The visibility guard: a scene the image generator blocked, or one whose entity
                // stayed invisible, is recorded as such and shown to no model.
                let reply = match (&stimulus.blocked, &stimulus.invisible) {
                    (None, None) => Some(observer.ask(model.as_ref(), &query).await?),
                    _ => None,
                };
                let o = observer.record(key, &stimulus, &task, &query, reply);
                journal.append(&o.record)?;
                let marks = match &o.reply {
                    Some(rep) => crate::vlm::statements::parse(&rep.raw, st.len()),
                    None => vec![None; st.len()],
                };
                Ok(Some((ProbeObs { set: i, outcome: o.outcome, statements: st, marks }, o.record)))
            });
        }
    }
    let mut first_error = FirstError::default();
    while let Some(joined) = tasks.join_next().await {
        match joined {
            Ok(Ok(Some((o, rec)))) => {
                if asked(&rec) {
                    spend.add(&rec.usage, rec.cached);
                    spend.add_retries(rec.attempts, rec.rate_limited, rec.waited_ms);
                }
                progress.inc(&spend);
                finished.push(o);
            }
            Ok(Ok(None)) => {}
            Ok(Err(e)) => first_error.failed(&r.stop, e),
            Err(e) => first_error.join_failed("probe", e),
        }
    }
    first_error.finish(&mut progress, &r.journal, &r.stop)?;
    let mut out: Vec<ProbedSet> = sets
        .iter()
        .map(|&s| ProbedSet {
            concepts: domain.set_names(s).into_iter().map(String::from).collect(),
            ..ProbedSet::default()
        })
        .collect();
    for o in finished {
        let p = &mut out[o.set];
        match o.outcome {
            Outcome::Wrong => {
                p.wrong += 1;
                p.answered += 1;
            }
            Outcome::Correct => p.answered += 1,
            _ => {}
        }
        for (s, m) in o.statements.iter().zip(&o.marks) {
            p.marks.entry(s.concept.clone()).or_default().add(s.positive, *m);
        }
    }
    Ok((out, spend))
}

/// Ask `samples` observations of each set of each model (phase `transfer`, the model recorded on
/// every line). Each scene is rendered once and shown to every model that has not answered it
/// yet. Returns, per model, the stats of each set, and per model the spend.
pub async fn transfer(
    r: &Reask,
    models: &[Arc<dyn Model>],
    sets: &[ConceptSet],
    samples: u32,
) -> Result<(Vec<Vec<SetStats>>, Vec<Spend>), RunError> {
    let domain = r.observer.domain().clone();
    let done = journaled(&r.journal, Phase::Transfer);
    let ids: Vec<String> = models.iter().map(|m| m.id()).collect();
    let mut stats: Vec<Vec<SetStats>> =
        models.iter().map(|_| sets.iter().map(|&s| SetStats::new(s)).collect()).collect();
    let mut spend = vec![Spend::default(); models.len()];
    let mut total = Spend::default();
    let mut progress = Progress::start(
        &r.progress,
        "transfer",
        (models.len() * sets.len()) as u64 * u64::from(samples),
        r.concurrency,
    );
    let semaphore = Arc::new(Semaphore::new(r.concurrency.max(1)));
    type Done = Vec<(usize, Record)>;
    let mut tasks: tokio::task::JoinSet<Result<(usize, Done), RunError>> = tokio::task::JoinSet::new();
    for (i, &set) in sets.iter().enumerate() {
        let names: Vec<String> = domain.set_names(set).into_iter().map(String::from).collect();
        let task = Arc::new(r.observer.task(set)?);
        for index in 0..samples {
            let mut missing = Vec::new();
            for (m, id) in ids.iter().enumerate() {
                match done.get(&(Phase::Transfer, names.clone(), index, Some(id.clone()))) {
                    Some(rec) => {
                        stats[m][i].add(rec.outcome);
                        if asked(rec) {
                            spend[m].add(&rec.usage, rec.cached);
                            spend[m].add_retries(rec.attempts, rec.rate_limited, rec.waited_ms);
                            total.add(&rec.usage, rec.cached);
                        }
                        progress.inc(&total);
                    }
                    None => missing.push(m),
                }
            }
            if missing.is_empty() {
                continue;
            }
            let key = ObsKey { phase: Phase::Transfer, set, index };
            let seed = observation_seed(r.seed, key);
            let targets: Vec<(usize, Arc<dyn Model>, String)> =
                missing.iter().map(|&m| (m, models[m].clone(), ids[m].clone())).collect();
            let (observer, journal, task) = (r.observer.clone(), r.journal.clone(), task.clone());
            let (sem, stop) = (semaphore.clone(), r.stop.clone());
            tasks.spawn(async move {
                let _permit = sem.acquire_owned().await.expect("the semaphore is never closed");
                if stop.requested() {
                    return Ok((i, Vec::new()));
                }
                // One scene, one render, every target model.
                let stimulus: Stimulus = observer.stimulus(set, seed).await?;
                if let Some(png) = &stimulus.image {
                    journal.store_image(png)?;
                }
                let query = observer.query(&stimulus, &task);
                let shown = stimulus.blocked.is_none() && stimulus.invisible.is_none();
                let asked = futures_all(&observer, &targets, &query, !shown).await;
                let mut out = Vec::new();
                let mut capped = None;
                for ((m, _, id), reply) in targets.iter().zip(asked) {
                    // A call the spend cap kept back is not an observation: nothing is journaled.
                    let reply = match reply {
                        Ok(r) => r,
                        Err(e) => {
                            capped.get_or_insert(e);
                            continue;
                        }
                    };
                    let mut o = observer.record(key, &stimulus, &task, &query, reply);
                    o.record.model = Some(id.clone());
                    journal.append(&o.record)?;
                    out.push((*m, o.record));
                }
                match capped {
                    // The other targets' answers are journaled; the cap ends the command.
                    Some(e) if out.is_empty() => Err(e.into()),
                    Some(e) => {
                        stop.request(match RunError::from(e) {
                            RunError::Stopped(r) => r,
                            _ => StopReason::Interrupted,
                        });
                        Ok((i, out))
                    }
                    None => Ok((i, out)),
                }
            });
        }
    }
    let mut first_error = FirstError::default();
    while let Some(joined) = tasks.join_next().await {
        match joined {
            Ok(Ok((i, recs))) => {
                for (m, rec) in recs {
                    stats[m][i].add(rec.outcome);
                    if asked(&rec) {
                        spend[m].add(&rec.usage, rec.cached);
                        spend[m].add_retries(rec.attempts, rec.rate_limited, rec.waited_ms);
                        total.add(&rec.usage, rec.cached);
                    }
                    progress.inc(&total);
                }
            }
            Ok(Err(e)) => first_error.failed(&r.stop, e),
            Err(e) => first_error.join_failed("transfer", e),
        }
    }
    first_error.finish(&mut progress, &r.journal, &r.stop)?;
    Ok((stats, spend))
}

/// Ask every target concurrently (a scene that is not shown asks none), each under the spend
/// cap (a call it keeps back is an error in its place).
async fn futures_all(
    observer: &Arc<Observer>,
    targets: &[(usize, Arc<dyn Model>, String)],
    query: &crate::vlm::Query,
    not_shown: bool,
) -> Vec<Result<Option<crate::vlm::Reply>, crate::run::ObserveError>> {
    if not_shown {
        return targets.iter().map(|_| Ok(None)).collect();
    }
    let mut set = tokio::task::JoinSet::new();
    for (k, (_, model, _)) in targets.iter().enumerate() {
        let (model, query, observer) = (model.clone(), query.clone(), observer.clone());
        set.spawn(async move { (k, observer.ask(model.as_ref(), &query).await) });
    }
    let mut out: BTreeMap<usize, Result<crate::vlm::Reply, crate::run::ObserveError>> = BTreeMap::new();
    while let Some(j) = set.join_next().await {
        if let Ok((k, reply)) = j {
            out.insert(k, reply);
        }
    }
    // `Model::ask` never fails; a task that died anyway is a failed call, asked again on resume.
    (0..targets.len())
        .map(|k| {
            out.remove(&k).map(|r| r.map(Some)).unwrap_or_else(|| {
                Ok(Some(crate::vlm::Reply {
                    raw: "the model call ended abnormally".into(),
                    thinking: None,
                    answer: crate::outcome::Answer::ApiError,
                    usage: Default::default(),
                    latency_ms: 0,
                    cached: false,
                    attempts: 0,
                    rate_limited: 0,
                    waited_ms: 0,
                }))
            })
        })
        .collect()
}

//! A whole run on a run folder: configuration check, search (then its shrink phase) or
//! validation through the journaled evaluator, and the summary. Shared by `revelio search`,
//! `revelio validate` and `revelio bench search`.
//!
//! Resuming: the same command on an existing folder replays the journal and continues. A
//! different configuration is refused, naming the differing fields, except for fields that say
//! where things are rather than what the run is (the domain file's path, the `--model` spelling,
//! the recorded model flags) and the budget: a higher `--budget` extends the run — the algorithm
//! replays its decisions against the journal (sequential top-ups included) and goes on where the
//! smaller budget stopped, then the shrink phase shrinks the failure modes of the extended search
//! again, served from the journal where it asks what it asked before. A lower one is refused
//! ([`check_resume`]). The CLI fills the flags a resume leaves out from the record, so the same
//! command (or a shorter one) never changes the plan.
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::ir::{ConceptSet, Domain};
use crate::journal::{Journal, OnCorrupt, Phase};
use crate::render::Renderer;
use crate::vlm::Model;
use crate::vlm::cost::Purse;

use super::eval::{Evaluator, EvaluatorConfig};
use super::observe::{Observer, World};
use super::progress::{Progress, ProgressTo};
use super::setup::DEFAULT_CONCURRENCY;
use super::stop::Stop;
use super::summary::{
    CONSISTENT_FR, CheckedRow, ConfirmSummary, CoreRow, NotDistinctRow, RUN_FORMAT, RunConfig, SetRow, ShrinkSummary,
    Spend, Summary, Triage, ValidatedSet, Validation, spaced, upgrade, validation_file,
};
use super::{MAX_API_ERRORS, ResumeError, RunError};
use crate::search::confirm::{self, Candidate, Checked, Status};
use crate::search::interval::mean_sd;
use crate::search::metrics::{metrics, ranked};
use crate::search::shrink::{self, Core, Found};
use crate::search::{CallsBy, Drive, Driver, Params, Rule, SearchError, Searched, SetStats, Space};

/// Fields of `config.json` a resume may change: where things are, not what the run is (and the
/// format, which [`upgrade`] reads in today's terms).
const LOCATION_FIELDS: &[&str] = &["domain_file", "model_spec", "model_settings", "format"];

/// Check that `new` may continue the run whose `config.json` is `old`, holding `made` model
/// calls of the search, its shrink phase and fresh confirmation. A larger `--budget` extends the
/// run (the search replays its decisions against the journal and goes on where the smaller
/// budget stopped; the shrink phase then starts over from the larger search's failure modes,
/// served from the journal wherever it asks again); a smaller one is refused, and so is a plan
/// that would give the search phase less than it had.
pub fn check_resume(dir: &Path, old: &serde_json::Value, new: &RunConfig, made: u64) -> Result<(), ResumeError> {
    let was = upgrade(dir, old.clone())?;
    let view = |c: &RunConfig| {
        let mut v = serde_json::to_value(c).expect("configurations serialise");
        if let Some(o) = v.as_object_mut() {
            for f in LOCATION_FIELDS {
                o.remove(*f);
            }
        }
        for field in ["budget", "shrink", "beam_budget"] {
            v["params"][field] = serde_json::Value::Null;
        }
        v
    };
    let mut diffs = differences(&view(&was), &view(new));
    // GPTS's beam phase is part of the plan; it may only move when no budget moves it.
    if was.params.algo == crate::search::Algo::Gpts && was.params.beam_budget != new.params.beam_budget {
        diffs.push(format!("`params.beam_budget` was {}, now {}", was.params.beam_budget, new.params.beam_budget));
    }
    if !diffs.is_empty() {
        return Err(ResumeError::Differs { dir: dir.to_path_buf(), diffs });
    }
    let (old_p, new_p) = (&was.params, &new.params);
    if was.format < RUN_FORMAT && new_p.budget < old_p.budget {
        return Err(ResumeError::OldBudgetRule {
            dir: dir.to_path_buf(),
            search: old_p.budget - old_p.shrink,
            shrink: old_p.shrink,
            now: new_p.budget,
        });
    }
    if new_p.budget < old_p.budget {
        return Err(ResumeError::BudgetLowered { dir: dir.to_path_buf(), was: old_p.budget, now: new_p.budget, made });
    }
    if new_p.shrink < old_p.shrink || new_p.plan().search < old_p.plan().search {
        return Err(ResumeError::SearchCut {
            dir: dir.to_path_buf(),
            shrink: (old_p.shrink, new_p.shrink),
            search: (old_p.plan().search, new_p.plan().search),
        });
    }
    Ok(())
}

/// The line a resume that raises `--budget` prints before its first model call; `None` when
/// it does not.
pub fn extension_note(dir: &Path, was: &RunConfig, now: &Params) -> Option<String> {
    (now.budget > was.params.budget).then(|| {
        format!("extending {} from {} to {} model calls", dir.display(), spaced(was.params.budget), spaced(now.budget))
    })
}

/// The note a resume of a run written under the old budget rule (format 2) prints: what its
/// numbers mean now.
pub fn old_rule_note(dir: &Path, was: &RunConfig) -> Option<String> {
    (was.format < RUN_FORMAT).then(|| {
        let p = &was.params;
        format!(
            "note: `{}` was written when `--budget` left out the shrink phase: its {} search and {} shrink calls are `--budget {} --shrink {}` now (every phase within {} model calls); a larger `--budget` extends it",
            dir.display(),
            spaced(p.budget - p.shrink),
            spaced(p.shrink),
            p.budget,
            p.shrink,
            spaced(p.budget)
        )
    })
}

/// Top-level fields (and nested ones, dotted) that differ between two configurations.
fn differences(old: &serde_json::Value, new: &serde_json::Value) -> Vec<String> {
    fn walk(prefix: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
        match (a, b) {
            (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
                let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
                for k in keys {
                    let name = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                    let null = serde_json::Value::Null;
                    walk(&name, x.get(k).unwrap_or(&null), y.get(k).unwrap_or(&null), out);
                }
            }
            _ if a != b => out.push(format!("`{prefix}` was {a}, now {b}")),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk("", old, new, &mut out);
    out
}

/// Open the run folder for `config`: a new folder gets the configuration, an existing one must
/// match it (a raised budget is written back).
fn open_run(out: &Path, config: &RunConfig, corrupt: OnCorrupt) -> Result<Arc<Journal>, RunError> {
    // A folder of an older format is rewritten in today's terms.
    let config = &RunConfig { format: RUN_FORMAT, ..config.clone() };
    let journal = Journal::open_with(out, corrupt)?;
    if let Some(note) = journal.set_aside_note() {
        eprintln!("{note}");
    }
    let write = match journal.config() {
        None => true,
        Some(old) => {
            let made = journal
                .records
                .iter()
                .filter(|r| matches!(r.phase, Phase::Search | Phase::Shrink | Phase::Confirm))
                .count();
            check_resume(out, old, config, made as u64)?;
            *old != serde_json::to_value(config).expect("configurations serialise")
        }
    };
    if write {
        journal.write_config(config)?;
    }
    Ok(Arc::new(journal))
}

/// Everything a run needs besides its configuration.
pub struct Setup {
    pub domain: Arc<Domain>,
    pub world: Arc<dyn World>,
    pub model: Arc<dyn Model>,
    pub renderer: Option<Arc<dyn Renderer>>,
    /// The effective concurrency (see `run::setup`).
    pub concurrency: usize,
    pub out: PathBuf,
    pub progress: ProgressTo,
    /// Triggered by Ctrl-C (the CLI wires it) or by the run itself.
    pub stop: Stop,
    /// Stop after this many model calls in a row end in `api_error` (0: never).
    pub max_api_errors: u32,
    /// What a corrupt journal line does (`--set-aside-corrupt`).
    pub on_corrupt: OnCorrupt,
    /// `--max-cost`: the spend cap every model call reserves its worst case in (a campaign
    /// shares one among its cells). The run folder's earlier spend is counted in when it opens.
    pub purse: Option<Arc<Purse>>,
    /// A concurrency limit shared with other runs (a campaign's cells); `None`: the run's own.
    pub gate: Option<Arc<tokio::sync::Semaphore>>,
}

impl Setup {
    /// A setup with the defaults: concurrency [`DEFAULT_CONCURRENCY`], no progress output, no
    /// Ctrl-C handling, [`MAX_API_ERRORS`].
    pub fn new(
        domain: Arc<Domain>,
        world: Arc<dyn World>,
        model: Arc<dyn Model>,
        renderer: Option<Arc<dyn Renderer>>,
        out: impl Into<PathBuf>,
    ) -> Setup {
        Setup {
            domain,
            world,
            model,
            renderer,
            concurrency: DEFAULT_CONCURRENCY,
            out: out.into(),
            progress: ProgressTo::Off,
            stop: Stop::default(),
            max_api_errors: MAX_API_ERRORS,
            on_corrupt: OnCorrupt::Refuse,
            purse: None,
            gate: None,
        }
    }

    fn evaluator(&self, journal: Arc<Journal>, seed: u64, threshold: f64, phase: Phase) -> Result<Evaluator, RunError> {
        Evaluator::new(EvaluatorConfig {
            observer: Arc::new(
                Observer::new(self.domain.clone(), self.world.clone(), self.renderer.clone())
                    .with_purse(self.purse.clone()),
            ),
            model: self.model.clone(),
            journal,
            seed,
            threshold,
            concurrency: self.concurrency,
            phase,
            stop: self.stop.clone(),
            max_api_errors: self.max_api_errors,
            gate: self.gate.clone(),
        })
    }

    /// Open the run folder for `config` and count its earlier spend into the cap.
    fn open(&self, config: &RunConfig) -> Result<Arc<Journal>, RunError> {
        let journal = open_run(&self.out, config, self.on_corrupt)?;
        if let Some(p) = &self.purse {
            p.add_spent(journal_spend(&journal));
        }
        Ok(journal)
    }
}

/// Dollars the model calls journaled in a run folder cost (every phase and model; cache hits
/// are free).
pub fn journal_spend(journal: &Journal) -> f64 {
    journal.records.iter().filter(|r| !r.cached).map(|r| r.usage.cost_usd).sum()
}

/// The message for a finished run (or validation) in which at least [`super::API_ERROR_SHARE_LIMIT`]
/// of the observations are failed model calls; `None` below it.
pub fn api_error_warning(api_errors: u64, observations: u64) -> Option<String> {
    if observations == 0 || (api_errors as f64) < super::API_ERROR_SHARE_LIMIT * observations as f64 {
        return None;
    }
    Some(format!(
        "{:.0}% of the observations ({api_errors} of {observations}) are failed model calls (`api_error`): the results are incomplete; run the same command again to retry them",
        100.0 * api_errors as f64 / observations as f64
    ))
}

/// What a finished run did in this process.
pub struct RunReport {
    pub summary: Summary,
    /// The search's evaluated sets (before the shrink phase).
    pub history: Vec<SetStats>,
    /// The reported cores — with confirmation, the confirmed candidates (the shrink phase's
    /// cores and the minimal failure modes no core explains) — and the shrink phase's refuted
    /// failure modes (empty when it was off).
    pub found: Found,
    /// Every candidate core after fresh confirmation, strongest search evidence first (`None`
    /// without a shrink phase).
    pub confirmation: Option<Vec<Checked>>,
    /// Observations served from the journal (a resumed run).
    pub replayed: u64,
    pub dropped_torn_line: bool,
    /// Corrupt journal lines moved into `journal.corrupt` (`--set-aside-corrupt`).
    pub set_aside: usize,
    /// The effective concurrency the run used.
    pub concurrency: usize,
}

/// The valid sets that have a ground truth, in their order, and how many were left out. Sets
/// whose expected answer is undetermined (lint R0102) cannot be scored, so they are left out of
/// the search rather than ending it midway. Judging every set is most of a search's preparation,
/// so the sets are judged on every core.
pub fn search_space(sets: Vec<ConceptSet>, dim: usize, world: &dyn World) -> (Space, usize) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = sets.len().div_ceil(cores).max(1);
    let kept: Vec<ConceptSet> = std::thread::scope(|scope| {
        let parts: Vec<_> = (sets.chunks(chunk))
            .map(|c| scope.spawn(move || c.iter().copied().filter(|s| world.task(*s).is_ok()).collect::<Vec<_>>()))
            .collect();
        parts.into_iter().flat_map(|p| p.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))).collect()
    });
    let dropped = sets.len() - kept.len();
    (Space::new(kept, dim), dropped)
}

/// Run (or resume, or extend) a search into `setup.out`, then its shrink phase
/// (`params.shrink` > 0).
pub async fn search(setup: &Setup, config: &RunConfig, space: &Space) -> Result<RunReport, RunError> {
    let params = &config.params;
    params.validate().map_err(RunError::Usage)?;
    let journal = setup.open(config)?;
    let (dropped_torn_line, set_aside) = (journal.dropped_torn_line, journal.set_aside);
    let mut eval = setup.evaluator(journal.clone(), params.seed, params.threshold, Phase::Search)?;
    eval.progress = Some(Progress::start(&setup.progress, "search", params.max_calls(), setup.concurrency));
    let result = search_and_shrink(params, space, &mut eval).await;
    if let Some(mut p) = eval.progress.take() {
        p.finish();
    }
    let Searched2 { history, mut found, shrink, calls, confirmation } = match result {
        Ok(r) => r,
        Err(e) => return Err(run_error(e)),
    };
    // Only the confirmed candidates are reported as cores.
    if let Some(c) = &confirmation {
        found.cores = c.confirmed_cores();
        found.drop_held_not_distinct();
    }
    let mut summary = summarize(
        &setup.domain,
        config,
        usize::try_from(space.total()).unwrap_or(usize::MAX),
        &history,
        &found,
        eval.spend.clone(),
    );
    if let Some(c) = &confirmation {
        let row = |s: &SetStats| SetRow::new(&setup.domain, s);
        let rows: Vec<CheckedRow> = c
            .checked
            .iter()
            .map(|k| CheckedRow {
                set: row(&k.stats),
                e_value: k.e,
                status: k.status,
                triage: Some(Triage { wrong: k.triage.wrong, answered: k.triage.answered(), weight: k.weight }),
            })
            .collect();
        for (core, found) in summary.cores.iter_mut().zip(&found.cores) {
            if let Some(i) = c.candidates.iter().position(|k| k.stats.set == found.stats.set) {
                core.confirmed = Some(rows[i].set.clone());
                core.part = c.parts[i].as_ref().map(row);
            }
        }
        summary.borderline = rows.iter().filter(|r| r.status == Status::Borderline).cloned().collect();
        let plan = params.confirm_plan(0);
        summary.confirmation = Some(ConfirmSummary {
            q: params.fdr,
            delta: params.delta,
            cap: plan.cap,
            extended: if plan.extended > plan.cap { plan.extended } else { 0 },
            budget: c.budget,
            inferences: c.spent,
            candidates: rows.len(),
            confirmed: rows.iter().filter(|r| r.status == Status::Confirmed).count(),
            unexplained: c.unexplained,
            unpaid: c.unpaid,
            shared: c.shared,
            last: c.last,
            unshrunk: c.unshrunk,
            checked: rows,
        });
    }
    summary.calls = calls;
    summary.shrink = shrink.map(|(budget, inferences, new_sets)| ShrinkSummary {
        budget,
        inferences,
        // Interact shrinks as it searches, under its confirmation rule.
        max_samples: if params.algo == crate::search::Algo::Interact {
            params.confirm_rule().max_samples
        } else {
            params.shrink_rule().max_samples
        },
        new_sets,
        refuted: found.refuted.iter().map(|s| SetRow::new(&setup.domain, s)).collect(),
        not_distinct: found
            .not_distinct
            .iter()
            .map(|(s, by)| NotDistinctRow { set: SetRow::new(&setup.domain, s), by: SetRow::new(&setup.domain, by) })
            .collect(),
    });
    summary.repeated_scenes = eval.repeated_rows();
    journal.write_json("summary.json", &summary)?;
    // A run that finished is no longer stopped (`revelio runs`).
    let _ = std::fs::remove_file(setup.out.join("stopped.json"));
    Ok(RunReport {
        summary,
        history,
        found,
        confirmation: confirmation.map(|c| c.checked),
        replayed: eval.replayed,
        dropped_torn_line,
        set_aside,
        concurrency: setup.concurrency,
    })
}

/// A search that ended early as a run error: the evaluator's own, or the search's reason.
fn run_error(e: SearchError<RunError>) -> RunError {
    match e {
        SearchError::Eval(e) => e,
        SearchError::Search(message) => RunError::Search(message),
    }
}

/// What fresh confirmation gave.
struct Confirmed {
    /// The candidates sent, strongest search evidence first: the shrink phase's cores, then the
    /// failure modes no core explains ([`unexplained_failures`]).
    candidates: Vec<Core>,
    /// How many of `candidates` are such unexplained failure modes.
    unexplained: usize,
    /// Candidates left out (the weakest) because the budget could not pay for them.
    unpaid: usize,
    /// Failure modes no core explains left out because each shares a concept with a stronger one
    /// and holds a candidate sent.
    shared: usize,
    /// How many of the `unexplained` were sent last, each sharing a concept with a stronger one
    /// ([`Candidate::last`]).
    last: usize,
    /// How many were sent last of all: the other failure modes of the search, holding no core
    /// nor candidate, not shown minimal (mostly their smaller subsets never tested); confirmed,
    /// each is a core not shown minimal.
    unshrunk: usize,
    /// Every candidate after confirmation, in `candidates` order.
    checked: Vec<Checked>,
    /// Inferences spent and given.
    spent: u64,
    budget: u64,
    /// Per candidate, its near-threshold part: the one-smaller subset that fails most, when its
    /// observed rate is at least τ − 2δ (within δ of the zone).
    parts: Vec<Option<SetStats>>,
}

impl Confirmed {
    /// The candidates e-BH confirmed, as reported cores: highest FR first (ties: higher
    /// interval lower bound, more answered observations, canonical order).
    fn confirmed_cores(&self) -> Vec<Core> {
        let mut cores: Vec<Core> = self
            .candidates
            .iter()
            .zip(&self.checked)
            .filter(|(_, k)| k.status == Status::Confirmed)
            .map(|(c, _)| c.clone())
            .collect();
        shrink::sort_cores(&mut cores);
        cores
    }
}

/// What [`search_and_shrink`] hands back.
struct Searched2 {
    /// The search's history.
    history: Vec<SetStats>,
    /// The shrink's findings (its cores are candidates of confirmation).
    found: Found,
    /// When the shrink phase ran: its budget, inferences and the subsets it evaluated beyond
    /// the search.
    shrink: Option<(u64, u64, usize)>,
    /// Interact: where the search's calls went.
    calls: Option<CallsBy>,
    /// Fresh confirmation of the candidates (when the shrink phase ran).
    confirmation: Option<Confirmed>,
}

/// The failure modes of `history` that none of `cores` explains, as candidate cores, strongest
/// search evidence first ([`shrink::roots`]' order): the minimal ones (every valid one-smaller
/// subset was evaluated and passes, holding no core), and those that fail at least 2δ above each
/// failing part ([`shrink::lifted_failures`]: a core with a near-threshold part, which the
/// shrink took for the core) — of those sharing a concept the strongest, then the others, sent
/// last ([`shrink::disjoint_strongest`]). `interact` confirms only some of its cores during the
/// search (the rest ran out of its confirmation rule's budget or triage); on a graded landscape
/// these hold most of the planted modes it reached.
fn unexplained_failures(
    history: &[SetStats],
    space: &Space,
    params: &Params,
    cores: &[Core],
) -> (Vec<Core>, Vec<Core>) {
    let threshold = params.threshold;
    let cores: Vec<ConceptSet> = cores.iter().map(|c| c.stats.set).collect();
    let mut loose = shrink::unexplained_failures(history, space, threshold, &cores);
    loose.extend(shrink::lifted_failures(history, space, threshold, 2.0 * params.delta, &cores));
    let (kept, shared) =
        shrink::disjoint_strongest(shrink::roots(history, threshold).into_iter().filter(|s| loose.contains(s)));
    let as_cores = |sets: Vec<ConceptSet>| {
        sets.into_iter()
            .filter_map(|set| history.iter().find(|h| h.set == set))
            .map(|s| Core { stats: s.clone(), minimal: true, root: s.set })
            .collect()
    };
    (as_cores(kept), as_cores(shared))
}

/// The search, then the shrink phase, then fresh confirmation of the shrink's cores and of the
/// minimal failure modes no core explains, all within `--budget` together.
async fn search_and_shrink(params: &Params, space: &Space, eval: &mut Evaluator) -> Searched<Searched2, Evaluator> {
    let (history, calls) = crate::search::run_counted(params, space, eval).await?;
    if params.shrink == 0 {
        return Ok(Searched2 { history, found: Found::default(), shrink: None, calls, confirmation: None });
    }
    eval.phase = Phase::Shrink;
    if let Some(p) = &eval.progress {
        p.set_label("shrink");
    }
    let spent: u64 = history.iter().map(|s| u64::from(s.observations())).sum();
    // The shrink phase keeps fresh confirmation's share for every core it holds and one more.
    let plan = params.plan();
    let mut driver = Driver::with_history(eval, params.shrink_rule(), plan.shrink_cap(spent, 0), history.clone());
    let roots = shrink::roots(&history, params.threshold);
    let found = shrink::run_capped(&mut driver, space, &roots, |cores| plan.shrink_cap(spent, cores)).await?;
    let shrink = (driver.budget(), driver.spent(), driver.history.len() - history.len());
    let everything = driver.history;
    // Confirmation: what the search and the shrink phase left of `--budget` (at least its share
    // per candidate), on fresh scenes: a phase of its own, indices past every earlier observation.
    let budget = plan.confirm_budget(spent + shrink.1);
    eval.phase = Phase::Confirm;
    if let Some(p) = &eval.progress {
        p.set_label("confirm");
    }
    let of = |set: ConceptSet| everything.iter().find(|s| s.set == set);
    // The family: the shrink's cores, then the unexplained minimal failure modes, as many as
    // the budget pays, then the ones sharing a concept with a stronger one, sent last (all
    // decided before any fresh observation).
    let (loose, shared) = unexplained_failures(&everything, space, params, &found.cores);
    let mut candidates = found.cores.clone();
    candidates.extend(loose);
    let paid = plan.paid(budget, candidates.len());
    let cut = candidates.split_off(paid);
    let unpaid = cut.len();
    // Of those, the ones holding a candidate sent are left out: that candidate, stronger on the
    // search's evidence, stands for them (a set lifting well above a part it holds is sent in
    // turn when it is the stronger of the two). Measured only together with the passes of
    // their own (docs/search.md, "An eighth round").
    let (held, last): (Vec<Core>, Vec<Core>) =
        shared.into_iter().partition(|s| candidates.iter().any(|c| c.stats.set.is_subset_of(s.stats.set)));
    let (shared, last_n) = (held.len(), last.len());
    candidates.extend(last);
    let unexplained = candidates.len().saturating_sub(found.cores.len());
    // Last of all, every other failure mode of the search, not shown minimal, that holds no core
    // nor candidate (sent, or left out for want of budget): mostly sets screened near the
    // search's end whose parts were never tested. Confirmed, each is reported as a core not
    // shown minimal.
    let before = candidates.len();
    for set in shrink::roots(&everything, params.threshold) {
        let holds = |c: &Core| c.stats.set.is_subset_of(set);
        // The shrink's cores are all among `candidates` and `cut`.
        if candidates.iter().chain(&cut).any(holds) {
            continue;
        }
        if let Some(s) = of(set) {
            candidates.push(Core { stats: s.clone(), minimal: false, root: set });
        }
    }
    let unshrunk = candidates.len() - before;
    let confirm_plan = params.confirm_plan(budget);
    let asked: Vec<Candidate> = candidates
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let searched = of(c.stats.set);
            Candidate {
                set: c.stats.set,
                first: searched.map_or(0, SetStats::observations),
                weight: confirm::search_weight(searched.unwrap_or(&c.stats), &confirm_plan),
                last: i >= paid,
            }
        })
        .collect();
    let (checked, confirm_spent) = confirm::confirm(eval, &asked, confirm_plan).await?;
    let near = params.threshold - 2.0 * params.delta;
    let parts = candidates
        .iter()
        .map(|c| {
            c.stats
                .set
                .one_smaller()
                .filter_map(of)
                .filter(|s| s.fr().is_some_and(|f| f >= near))
                .max_by(|a, b| a.value().total_cmp(&b.value()).then(b.set.cmp(&a.set)))
                .cloned()
        })
        .collect();
    let confirmation = Some(Confirmed {
        candidates,
        unexplained,
        unpaid,
        shared,
        last: last_n,
        unshrunk,
        checked,
        spent: confirm_spent,
        budget,
        parts,
    });
    Ok(Searched2 { history, found, shrink: Some(shrink), calls, confirmation })
}

pub fn summarize(
    domain: &Domain,
    config: &RunConfig,
    space: usize,
    history: &[SetStats],
    found: &Found,
    spend: Spend,
) -> Summary {
    let p = &config.params;
    let modes: Vec<&SetStats> = ranked(history).into_iter().filter(|s| s.is_failure_mode(p.threshold)).collect();
    let core_sets: Vec<ConceptSet> = found.cores.iter().map(|c| c.stats.set).collect();
    let (family, supersets) = shrink::families(&modes.iter().map(|s| s.set).collect::<Vec<_>>(), &core_sets);
    let names = |set: ConceptSet| domain.set_names(set).into_iter().map(String::from).collect();
    Summary {
        domain: config.domain.clone(),
        model: config.model.clone(),
        algo: p.algo,
        threshold: p.threshold,
        space,
        metrics: metrics(history, p.threshold),
        cores: found
            .cores
            .iter()
            .zip(supersets)
            .map(|(c, supersets)| CoreRow {
                set: SetRow::new(domain, &c.stats),
                supersets,
                minimal: c.minimal,
                shrunk_from: names(c.root),
                confirmed: None,
                part: None,
            })
            .collect(),
        failure_modes: modes.iter().zip(family).map(|(s, core)| SetRow { core, ..SetRow::new(domain, s) }).collect(),
        sets: history.iter().map(|s| SetRow::new(domain, s)).collect(),
        shrink: None,
        confirmation: None,
        borderline: Vec::new(),
        budget: Some(p.budget),
        calls: None,
        spend,
        repeated_scenes: Vec::new(),
    }
}

/// The top `k` sets of a search, in the order the search table lists them (the same ranking:
/// failure rate, then answered observations, then the canonical set order).
pub fn top_sets(history: &[SetStats], k: usize) -> Vec<SetStats> {
    ranked(history).into_iter().take(k).cloned().collect()
}

/// Re-evaluate the top `top` sets of a finished run with `samples` fresh observations each —
/// with `max_samples`, sequentially: a set whose interval still straddles the run's τ gets more,
/// up to `max_samples` — journaled in the same run folder (so validation resumes too). Written to
/// [`validation_file`]`(top, samples, max_samples)`.
pub async fn validate(
    setup: &Setup,
    config: &RunConfig,
    summary: &Summary,
    top: usize,
    samples: u32,
    max_samples: Option<u32>,
) -> Result<Validation, RunError> {
    if top == 0 {
        return Err(RunError::Usage("invalid `--top`: must be at least 1".into()));
    }
    if samples == 0 {
        return Err(RunError::Usage("invalid `--samples`: must be at least 1".into()));
    }
    if let Some(max) = max_samples.filter(|&m| m < samples) {
        return Err(RunError::Usage(format!(
            "invalid `--max-samples`: must be at least `--samples` ({samples}), got {max}"
        )));
    }
    // Sequential validation stops by the anytime-valid test with the run's indifference zone:
    // a set is topped up while its interval reaches both below τ − δ and above τ + δ.
    let rule = Rule::sequential(samples, max_samples.unwrap_or(samples), config.params.threshold)
        .with_zone(config.params.delta);
    let history = summary
        .sets
        .iter()
        .map(|row| {
            let set = setup.domain.parse_set(&row.concepts).map_err(|e| e.to_string())?;
            let mut s = SetStats::new(set);
            s.wrong = row.wrong;
            s.correct = row.answered - row.wrong;
            s.unanswered = row.unanswered.clone();
            Ok(s)
        })
        .collect::<Result<Vec<_>, String>>()
        .map_err(|e| RunError::Search(format!("cannot validate `{}`: {e}", setup.out.display())))?;
    let chosen = top_sets(&history, top);
    let journal = setup.open(config)?;
    let mut eval = setup.evaluator(journal.clone(), config.params.seed, CONSISTENT_FR, Phase::Validate)?;
    let most = chosen.len() as u64 * u64::from(rule.max_samples);
    eval.progress = Some(Progress::start(&setup.progress, "validate", most, setup.concurrency));
    let sets: Vec<ConceptSet> = chosen.iter().map(|s| s.set).collect();
    // A budget of M per set: every chosen set can reach M, none more.
    let result = Driver::new(&mut eval, rule, most).evaluate(&sets).await;
    if let Some(mut p) = eval.progress.take() {
        p.finish();
    }
    let validated = match result {
        Ok(v) => v,
        Err(e) => return Err(run_error(e)),
    };
    let frs: Vec<f64> = validated.iter().filter_map(SetStats::fr).collect();
    let (mean_fr, sd_fr) = mean_sd(&frs);
    let v = Validation {
        top,
        samples,
        max_samples: max_samples.filter(|_| rule.is_sequential()),
        consistent: frs.iter().filter(|&&f| f >= CONSISTENT_FR).count(),
        sets: chosen
            .iter()
            .zip(&validated)
            .map(|(s, v)| ValidatedSet {
                search: SetRow::new(&setup.domain, s),
                validation: SetRow::new(&setup.domain, v),
            })
            .collect(),
        mean_fr,
        sd_fr,
        spend: eval.spend.clone(),
        repeated_scenes: eval.repeated_rows(),
    };
    journal.write_json(&validation_file(top, samples, v.max_samples), &v)?;
    Ok(v)
}

/// Seconds between plain progress lines for the CLI (see [`super::progress`]).
pub fn cli_progress(quiet: bool) -> ProgressTo {
    if quiet { ProgressTo::Off } else { ProgressTo::Stderr { every: super::progress::PLAIN_EVERY } }
}

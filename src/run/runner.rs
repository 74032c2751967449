//! A whole run on a run folder: configuration check, search (or validation) through the
//! journaled evaluator, and the summary. Shared by `revelio search`, `revelio validate` and
//! `revelio bench search`.
use std::collections::BTreeMap;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::ir::{ConceptSet, Domain};
use crate::journal::{Journal, Phase};
use crate::outcome::Outcome;
use crate::render::Renderer;
use crate::vlm::Model;

use super::eval::{Evaluator, EvaluatorConfig, Spend, World, observation_seed};
use crate::search::metrics::{Metrics, mean_sd, metrics, ranked};
use crate::search::shrink::{self, Found};
use crate::search::{Driver, Params, Rule, SetStats, Space};

/// The resolved configuration of a run (`config.json`): everything that changes its results.
/// Concurrency is not in it: it changes timing, never answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    /// The domain file as given (made absolute), so `revelio validate` can reload it.
    pub domain_file: String,
    pub domain: String,
    /// SHA-256 of the domain's source files.
    pub domain_hash: String,
    /// The `--model` spec and the model's id (which includes answer-changing settings).
    pub model_spec: String,
    pub model: String,
    pub renderer: String,
    pub params: Params,
}

/// Everything a run needs besides its configuration.
pub struct Setup {
    pub domain: Arc<Domain>,
    pub world: Arc<dyn World>,
    pub model: Arc<dyn Model>,
    pub renderer: Option<Arc<dyn Renderer>>,
    pub concurrency: usize,
    pub out: PathBuf,
    /// Draw a progress bar on stderr (only when it is a terminal).
    pub progress: bool,
}

/// One evaluated set, by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetRow {
    pub concepts: Vec<String>,
    /// Failure rate over answered observations (`None`: nothing answered).
    pub fr: Option<f64>,
    /// 95 % Wilson interval of the failure rate (`[0, 1]` when nothing was answered).
    #[serde(default = "unit_interval")]
    pub ci95: [f64; 2],
    pub wrong: u32,
    pub answered: u32,
    pub observations: u32,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub unanswered: BTreeMap<Outcome, u32>,
    /// For a failure mode: the index in `cores` of the first core it contains.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub core: Option<usize>,
}

fn unit_interval() -> [f64; 2] {
    [0.0, 1.0]
}

impl SetRow {
    pub fn new(domain: &Domain, s: &SetStats) -> SetRow {
        SetRow {
            concepts: domain.set_names(s.set).into_iter().map(String::from).collect(),
            fr: s.fr(),
            ci95: s.ci95(),
            wrong: s.wrong,
            answered: s.answered(),
            observations: s.observations(),
            unanswered: s.unanswered.clone(),
            core: None,
        }
    }
}

/// A minimal failure mode: every observation of it (search and shrink phases), how many failure
/// modes of the search contain it, and what it was shrunk from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CoreRow {
    #[serde(flatten)]
    pub set: SetRow,
    /// Failure modes of the search (`failure_modes`) that contain this core, itself included.
    pub supersets: usize,
    /// Whether every one-smaller valid subset was tested and passes (false: the shrink budget
    /// ran out first).
    pub minimal: bool,
    /// The failure mode it was shrunk from.
    pub shrunk_from: Vec<String>,
}

/// The shrink phase in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShrinkSummary {
    /// Inferences it was given (`--shrink`) and spent.
    pub budget: u64,
    pub inferences: u64,
    /// Most observations per set in its sequential test.
    pub max_samples: u32,
    /// Subsets it evaluated that the search had not.
    pub new_sets: usize,
    /// Failure modes of the search that did not fail when re-tested (with all their
    /// observations).
    pub refuted: Vec<SetRow>,
}

/// `summary.json`: a pure function of the configuration and the observations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub domain: String,
    pub model: String,
    pub algo: crate::search::Algo,
    pub threshold: f64,
    /// Valid sets in the search space.
    pub space: usize,
    pub metrics: Metrics,
    /// Distinct minimal failure modes from the shrink phase, highest failure rate first (empty
    /// when shrinking was off).
    #[serde(default)]
    pub cores: Vec<CoreRow>,
    /// Failure modes of the search (its observations only), highest failure rate first.
    pub failure_modes: Vec<SetRow>,
    /// Every set the search evaluated, in evaluation order, with the search's observations.
    pub sets: Vec<SetRow>,
    /// The shrink phase (absent when it was off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shrink: Option<ShrinkSummary>,
    /// Tokens and money of the run's observations, every phase (its model's usage and
    /// configured prices).
    #[serde(default)]
    pub spend: Spend,
}

/// What a finished run did in this process.
pub struct RunReport {
    pub summary: Summary,
    /// The search's evaluated sets (before the shrink phase).
    pub history: Vec<SetStats>,
    /// The shrink phase's cores and refuted failure modes (empty when it was off).
    pub found: Found,
    /// Observations served from the journal (a resumed run).
    pub replayed: u64,
    pub dropped_torn_line: bool,
}

/// The valid sets that have a ground truth. Sets whose expected answer is undetermined (lint
/// R0102) cannot be scored, so they are left out of the search rather than ending it midway.
pub fn search_space(sets: Vec<ConceptSet>, dim: usize, world: &dyn World) -> (Space, usize) {
    let before = sets.len();
    let kept: Vec<ConceptSet> = sets.into_iter().filter(|s| world.task(*s).is_ok()).collect();
    let dropped = before - kept.len();
    (Space::new(kept, dim), dropped)
}

fn progress_bar(enabled: bool, len: u64) -> indicatif::ProgressBar {
    if !enabled || !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} inferences · {msg} · ETA {eta}")
            .expect("the template is valid"),
    );
    bar.set_message("0 failure modes · 0 tokens · $0.0000");
    bar
}

/// Run (or resume) a search into `setup.out`, then its shrink phase (`params.shrink` > 0).
pub async fn search(setup: &Setup, config: &RunConfig, space: &Space) -> Result<RunReport, String> {
    let params = &config.params;
    params.validate()?;
    let journal = Arc::new(Journal::open(&setup.out, config)?);
    let dropped_torn_line = journal.dropped_torn_line;
    let mut eval = Evaluator::new(EvaluatorConfig {
        domain: setup.domain.clone(),
        world: setup.world.clone(),
        model: setup.model.clone(),
        renderer: setup.renderer.clone(),
        journal: journal.clone(),
        seed: params.seed,
        threshold: params.threshold,
        concurrency: setup.concurrency,
        phase: Phase::Search,
    })?;
    eval.progress = progress_bar(setup.progress, params.budget + params.shrink);
    let result = search_and_shrink(params, space, &mut eval).await;
    eval.progress.finish_and_clear();
    let (history, found, shrink) = result?;
    let mut summary = summarize(&setup.domain, config, space.sets.len(), &history, &found, eval.spend.clone());
    summary.shrink = shrink.map(|(inferences, new_sets)| ShrinkSummary {
        budget: params.shrink,
        inferences,
        max_samples: params.shrink_rule().max_samples,
        new_sets,
        refuted: found.refuted.iter().map(|s| SetRow::new(&setup.domain, s)).collect(),
    });
    journal.write_json("summary.json", &summary)?;
    Ok(RunReport { summary, history, found, replayed: eval.replayed, dropped_torn_line })
}

/// The search, then the shrink phase: the search's history, the shrink's findings, and (when it
/// ran) the shrink's inferences and the subsets it evaluated beyond the search.
async fn search_and_shrink(
    params: &Params,
    space: &Space,
    eval: &mut Evaluator,
) -> Result<(Vec<SetStats>, Found, Option<(u64, usize)>), String> {
    let history = crate::search::run(params, space, eval).await?;
    if params.shrink == 0 {
        return Ok((history, Found::default(), None));
    }
    eval.phase = Phase::Shrink;
    let mut driver = Driver::with_history(eval, params.shrink_rule(), params.shrink, history.clone());
    let found = shrink::run(&mut driver, space, &shrink::roots(&history, params.threshold)).await?;
    let shrink = (driver.spent(), driver.history.len() - history.len());
    Ok((history, found, Some(shrink)))
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
            })
            .collect(),
        failure_modes: modes.iter().zip(family).map(|(s, core)| SetRow { core, ..SetRow::new(domain, s) }).collect(),
        sets: history.iter().map(|s| SetRow::new(domain, s)).collect(),
        shrink: None,
        spend,
    }
}

/// `validation.json`: the top-k sets of a run re-evaluated with fresh scenes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Validation {
    pub top: usize,
    pub samples: u32,
    /// Sequential validation: the most observations a set could get (absent: exactly
    /// `samples`). The interval is tested against the run's threshold τ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_samples: Option<u32>,
    pub sets: Vec<ValidatedSet>,
    /// Mean and sample standard deviation of the validated failure rates.
    pub mean_fr: f64,
    pub sd_fr: f64,
    /// How many validated sets reach FR ≥ 0.8.
    pub consistent: usize,
    /// Tokens and money of the validation's observations.
    #[serde(default)]
    pub spend: Spend,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidatedSet {
    pub search: SetRow,
    pub validation: SetRow,
}

/// FR a validated failure mode must reach to count as consistent (paper section 4).
pub const CONSISTENT_FR: f64 = 0.8;

/// The top `k` sets of a search by failure rate; ties in failure rate are broken by a seeded
/// shuffle (the paper picks randomly among equally ranked sets), then by set order.
pub fn top_sets(history: &[SetStats], k: usize, seed: u64) -> Vec<SetStats> {
    let mut v: Vec<&SetStats> = ranked(history);
    let tie = |s: &SetStats| observation_seed(seed, Phase::Validate, s.set, u32::MAX);
    v.sort_by(|a, b| b.value().total_cmp(&a.value()).then(tie(a).cmp(&tie(b))).then(a.set.cmp(&b.set)));
    v.into_iter().take(k).cloned().collect()
}

/// Read a run folder's configuration and summary.
pub fn load_run(dir: &Path) -> Result<(RunConfig, Summary), String> {
    let read = |name: &str| {
        let p = dir.join(name);
        std::fs::read_to_string(&p).map_err(|e| {
            format!(
                "cannot read `{}`: {} (is `{}` a finished run folder?)",
                p.display(),
                e.to_string().to_lowercase(),
                dir.display()
            )
        })
    };
    let config: RunConfig = serde_json::from_str(&read("config.json")?)
        .map_err(|e| format!("invalid `config.json` in `{}`: {e}", dir.display()))?;
    let summary: Summary = serde_json::from_str(&read("summary.json")?)
        .map_err(|e| format!("invalid `summary.json` in `{}`: {e}", dir.display()))?;
    Ok((config, summary))
}

/// Re-evaluate the top `top` sets of a finished run with `samples` fresh observations each —
/// with `max_samples`, sequentially: a set whose interval still straddles the run's τ gets more,
/// up to `max_samples` — journaled in the same run folder (so validation resumes too).
pub async fn validate(
    setup: &Setup,
    config: &RunConfig,
    summary: &Summary,
    top: usize,
    samples: u32,
    max_samples: Option<u32>,
) -> Result<Validation, String> {
    if samples == 0 {
        return Err("invalid `--samples`: must be at least 1".into());
    }
    if let Some(max) = max_samples.filter(|&m| m < samples) {
        return Err(format!("invalid `--max-samples`: must be at least `--samples` ({samples}), got {max}"));
    }
    let rule = Rule { samples, max_samples: max_samples.unwrap_or(samples), threshold: config.params.threshold };
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
        .map_err(|e| format!("cannot validate `{}`: {e}", setup.out.display()))?;
    let chosen = top_sets(&history, top, config.params.seed);
    let journal = Arc::new(Journal::open(&setup.out, config)?);
    let mut eval = Evaluator::new(EvaluatorConfig {
        domain: setup.domain.clone(),
        world: setup.world.clone(),
        model: setup.model.clone(),
        renderer: setup.renderer.clone(),
        journal: journal.clone(),
        seed: config.params.seed,
        threshold: CONSISTENT_FR,
        concurrency: setup.concurrency,
        phase: Phase::Validate,
    })?;
    let most = chosen.len() as u64 * u64::from(rule.max_samples);
    eval.progress = progress_bar(setup.progress, most);
    let sets: Vec<ConceptSet> = chosen.iter().map(|s| s.set).collect();
    // A budget of M per set: every chosen set can reach M, none more.
    let result = Driver::new(&mut eval, rule, most).evaluate(&sets).await;
    eval.progress.finish_and_clear();
    let validated = result?;
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
    };
    journal.write_json("validation.json", &v)?;
    Ok(v)
}

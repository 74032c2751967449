//! The run folder's format: what a run writes beside its journal (`config.json`, `summary.json`,
//! the validation files) and what the report, the analyses and a resume read back, with the
//! checks a file read from a run folder must pass before anything is sized by it. The code that
//! drives a run is in [`super::runner`]; this module only says what its files hold.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::ir::Domain;
use crate::journal::{JournalError, safe};
use crate::outcome::{Outcome, Usage};
use crate::search::metrics::Metrics;
use crate::search::{Params, SetStats};
use crate::vlm::Model;

use super::setup::ModelSettings;
use super::{ResumeError, RunError};

/// Tokens and money of a run's observations: the model's usage summed over the journal, so a
/// resumed run reports what the uninterrupted one would.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Spend {
    /// Observations answered by a model call (cache hits included).
    pub calls: u64,
    /// Of the calls, how many the reply cache served (free).
    pub cached: u64,
    pub input_tokens: u64,
    /// Output tokens, thinking included.
    pub output_tokens: u64,
    pub thinking_tokens: u64,
    pub cost_usd: f64,
    /// Attempts beyond the first, over all calls (absent in runs written before they were
    /// counted).
    #[serde(default)]
    pub retries: u64,
    /// Of the retries, those after a rate limit (HTTP 429).
    #[serde(default)]
    pub rate_limited: u64,
    /// Seconds spent waiting between attempts.
    #[serde(default)]
    pub retry_wait_s: f64,
}

impl Spend {
    /// Count one call's retries and waits (from its journal line).
    pub fn add_retries(&mut self, attempts: u32, rate_limited: u32, waited_ms: u64) {
        self.retries += u64::from(attempts.saturating_sub(1));
        self.rate_limited += u64::from(rate_limited);
        self.retry_wait_s += waited_ms as f64 / 1000.0;
    }

    pub fn add(&mut self, u: &Usage, cached: bool) {
        self.calls += 1;
        self.cached += u64::from(cached);
        self.input_tokens += u.input_tokens;
        self.output_tokens += u.output_tokens;
        self.thinking_tokens += u.thinking_tokens;
        self.cost_usd += u.cost_usd;
    }

    /// `1 234 input / 567 output tokens, $0.0123` (and the cache hits, if any).
    pub fn line(&self) -> String {
        let cached = if self.cached > 0 { format!(" ({} cached)", self.cached) } else { String::new() };
        let retries = if self.retries > 0 {
            format!(
                "; {} retries ({} after a rate limit), {:.1} s waiting",
                self.retries, self.rate_limited, self.retry_wait_s
            )
        } else {
            String::new()
        };
        format!(
            "{} calls{cached}, {} input / {} output tokens ({} thinking), ${:.4}{retries}",
            self.calls, self.input_tokens, self.output_tokens, self.thinking_tokens, self.cost_usd
        )
    }
}

/// The run folder format this revelio writes and reads. Format 1 (no `format` field) seeded its
/// scenes from the domain file's path as typed; its scenes cannot be reproduced, so such folders
/// are refused with a message rather than resumed with different scenes. Format 2 spent
/// `--shrink` on top of `--budget`; format 3 counts every phase in `--budget`. A format 2 folder
/// reads as the same run in today's terms ([`upgrade`]): its budget plus its shrink budget.
pub const RUN_FORMAT: u64 = 3;

/// The oldest run folder format this revelio reads ([`upgrade`]).
pub const OLDEST_READ_FORMAT: u64 = 2;

/// A `config.json` of any format this revelio reads, as a configuration in today's terms; its
/// `format` stays the one it was written in. Format 2's `budget` was the search's alone (the
/// shrink phase's `shrink` came on top; `interact` spent both in its search): the same run has
/// `budget + shrink` now, with `shrink` set aside for shrinking.
pub fn upgrade(dir: &Path, value: serde_json::Value) -> Result<RunConfig, ResumeError> {
    let found = value.get("format").and_then(serde_json::Value::as_u64).unwrap_or(1);
    if !(OLDEST_READ_FORMAT..=RUN_FORMAT).contains(&found) {
        return Err(ResumeError::Format { dir: dir.to_path_buf(), found, expected: RUN_FORMAT });
    }
    let mut config: RunConfig = serde_json::from_value(value)
        .map_err(|e| ResumeError::BadConfig { dir: dir.to_path_buf(), message: e.to_string() })?;
    if found == 2 {
        config.params.budget = config.params.budget.saturating_add(config.params.shrink);
    }
    Ok(config)
}

fn run_format_1() -> u64 {
    1
}

/// The resolved configuration of a run (`config.json`): everything that changes its results,
/// and how to rebuild its model. Concurrency is not in it: it changes timing, never answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    #[serde(default = "run_format_1")]
    pub format: u64,
    /// The domain file (made absolute), so `revelio validate` can reload it.
    pub domain_file: String,
    pub domain: String,
    /// The domain's identity ([`Domain::identity`]): canonical module names and texts.
    pub domain_hash: String,
    /// The `--model` spec and the model's id (which includes answer-changing settings).
    pub model_spec: String,
    pub model: String,
    /// The base URL the model's requests go to (never a key); `None` for `sim`.
    #[serde(default)]
    pub endpoint: Option<String>,
    /// The model flags the run was started with; `validate` and resumes reuse them.
    #[serde(default)]
    pub model_settings: ModelSettings,
    pub renderer: String,
    pub params: Params,
}

impl RunConfig {
    /// The configuration of a run of `model` on `domain`.
    pub fn new(
        domain: &Domain,
        domain_file: &Path,
        model_spec: &str,
        model: &dyn Model,
        model_settings: ModelSettings,
        renderer: &str,
        params: Params,
    ) -> RunConfig {
        RunConfig {
            format: RUN_FORMAT,
            domain_file: super::setup::absolute(domain_file),
            domain: domain.name.clone(),
            domain_hash: domain.identity().to_string(),
            model_spec: model_spec.to_string(),
            model: model.id(),
            endpoint: model.endpoint(),
            model_settings,
            renderer: renderer.to_string(),
            params,
        }
    }
}

/// Read a run folder's `config.json`, if it has one (to reuse its settings), in today's terms
/// ([`upgrade`]).
pub fn read_config(dir: &Path) -> Result<Option<RunConfig>, RunError> {
    let path = dir.join("config.json");
    if !path.exists() {
        return Ok(None);
    }
    let text = safe::read_text(&path, safe::MAX_JSON_BYTES).map_err(|source| JournalError::Io {
        action: "read",
        path: path.clone(),
        source,
    })?;
    let value: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| JournalError::BadConfig { dir: dir.to_path_buf(), message: e.to_string() })?;
    Ok(Some(upgrade(dir, value)?))
}

/// One evaluated set, by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetRow {
    pub concepts: Vec<String>,
    /// Failure rate over answered observations (`None`: nothing answered).
    pub fr: Option<f64>,
    /// 95 % interval of the failure rate: anytime-valid ([`crate::search::cs`]) in runs written
    /// since it existed, Wilson's before (`[0, 1]` when nothing was answered).
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

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn is_zero_u32(n: &u32) -> bool {
    *n == 0
}

fn unit_interval() -> [f64; 2] {
    [0.0, 1.0]
}

impl SetRow {
    /// A row from counts alone, every observation answered (tests' fixtures).
    #[cfg(test)]
    pub(crate) fn from_counts(concepts: &[&str], wrong: u32, answered: u32) -> SetRow {
        SetRow {
            concepts: concepts.iter().map(|c| c.to_string()).collect(),
            fr: (answered > 0).then(|| f64::from(wrong) / f64::from(answered)),
            ci95: crate::search::cs::interval(wrong, answered),
            wrong,
            answered,
            observations: answered,
            unanswered: BTreeMap::new(),
            core: None,
        }
    }

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
    /// Its fresh confirmation: the observations made after it was selected, alone, with their
    /// anytime-valid interval (absent in runs without confirmation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confirmed: Option<SetRow>,
    /// Its one-smaller subset that fails most, when that part's observed rate is at least
    /// τ − 2δ (within δ of the zone): the core owes part of its rate to it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<SetRow>,
}

/// Fresh confirmation in `summary.json`: the candidate cores, each confirmed on observations
/// made after it was selected, and e-BH across them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConfirmSummary {
    /// The false discovery rate e-BH held the confirmed cores to.
    pub q: f64,
    /// The indifference zone δ around τ.
    pub delta: f64,
    /// Most fresh observations a candidate got while the others waited for their turn (the
    /// per-set cap).
    pub cap: u32,
    /// Most it got once every candidate had had its turn and calls were left
    /// ([`crate::search::confirm::EXTEND_FACTOR`] × the cap; 0: no such pass, as in runs
    /// written before it or under `--max-samples`).
    #[serde(default, skip_serializing_if = "is_zero_u32")]
    pub extended: u32,
    /// Inferences it was given and spent.
    pub budget: u64,
    pub inferences: u64,
    /// Candidates sent to confirmation, and how many of them e-BH confirmed.
    pub candidates: usize,
    pub confirmed: usize,
    /// How many of the candidates are failure modes of the search that no core of the shrink
    /// phase explains — minimal, or lifting well above a failing part (the rest are its cores).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unexplained: usize,
    /// Candidates not sent (the weakest): the budget paid for the ones before them only.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unpaid: usize,
    /// Failure modes no core explains that were not sent because each shares a concept with a
    /// stronger one (which stands for them: they mostly fail through that concept) and holds a
    /// candidate sent. In runs written before the others were sent last (`last`): every failure
    /// mode no core explains that shares a concept with a stronger one.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub shared: usize,
    /// How many of the `unexplained` were sent last because each shares a concept with a
    /// stronger one (holding no candidate sent): not triaged, observed once every other
    /// candidate was settled.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub last: usize,
    /// Candidates sent last of all (after the `last`): the other failure modes of the search,
    /// holding no core nor candidate (sent or unpaid) and not shown minimal — mostly sets
    /// screened near the search's end whose parts were never tested. Confirmed, each is
    /// reported as a core not shown minimal (`minimal: false`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub unshrunk: usize,
    /// Every candidate with its fresh observations, e-value and status.
    pub checked: Vec<CheckedRow>,
}

/// One candidate after confirmation: its confirmation's observations (its triage's beside them).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckedRow {
    #[serde(flatten)]
    pub set: SetRow,
    /// The e-value against "its rate is ≤ τ − δ" from the confirmation's observations (after
    /// its triage's).
    pub e_value: f64,
    pub status: crate::search::confirm::Status,
    /// Its triage: the first m fresh observations, which set its e-BH weight (absent in runs
    /// written before the triage).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triage: Option<Triage>,
}

/// A candidate's triage in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Triage {
    pub wrong: u32,
    pub answered: u32,
    /// Its e-BH weight before scaling: the search's likelihood ratio (at most 20) times the
    /// triage's, each of a mode at τ + δ against a set at τ − δ.
    pub weight: f64,
}

/// The shrink phase in `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShrinkSummary {
    /// Inferences it was given (what the search left of `--budget`) and spent.
    pub budget: u64,
    pub inferences: u64,
    /// Most observations per set in its sequential test (interact: its confirmation rule's, the
    /// rule it shrinks with as it searches); the lift test goes to twice that.
    pub max_samples: u32,
    /// Subsets it evaluated that the search had not.
    pub new_sets: usize,
    /// Failure modes of the search that did not fail when re-tested (with all their
    /// observations).
    pub refuted: Vec<SetRow>,
    /// Failing sets the shrink reached that fail no more than a one-smaller subset that passes
    /// (the lift test): no distinct failure mode, the subset's rate near τ.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_distinct: Vec<NotDistinctRow>,
}

/// A failing set that does not fail significantly more than its passing subset `by`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NotDistinctRow {
    #[serde(flatten)]
    pub set: SetRow,
    /// The one-smaller subset, with all its observations.
    pub by: SetRow,
}

/// A set that could not show a new scene for some of its observations: each of them drew only
/// images the set had already shown in the run (outcome `repeated`), so its n counts its
/// distinct images only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RepeatedRow {
    pub concepts: Vec<String>,
    /// Observations recorded `repeated` (no model asked).
    pub repeated: u32,
    /// Distinct images the set showed in the run (every phase).
    pub distinct: u32,
}

/// The line a run prints for its `repeated_scenes` (`None`: every observation had a new scene).
pub fn repeated_line(rows: &[RepeatedRow]) -> Option<String> {
    if rows.is_empty() {
        return None;
    }
    let shown: Vec<String> = rows
        .iter()
        .take(3)
        .map(|r| format!("{{{}}} {} distinct, {} repeated", r.concepts.join(", "), r.distinct, r.repeated))
        .collect();
    let more = if rows.len() > 3 { format!(", … {} more", rows.len() - 3) } else { String::new() };
    Some(format!(
        "{} set{} could not show distinct scenes (n counts distinct images only; `repeated_scenes` in the summary): {}{more}",
        rows.len(),
        if rows.len() == 1 { "" } else { "s" },
        shown.join("; ")
    ))
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
    /// Fresh confirmation of the candidate cores (absent without a shrink phase, and in runs
    /// written before it existed: their `cores` are unconfirmed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confirmation: Option<ConfirmSummary>,
    /// Candidates that reached the confirmation cap with their interval straddling the zone
    /// around τ: near the threshold, neither cores nor passing (fresh observations).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub borderline: Vec<CheckedRow>,
    /// `--budget`: the most model calls of the run, every phase (absent in older runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub budget: Option<u64>,
    /// Interact: where the search's calls went (screening, escalation, explaining,
    /// confirmation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calls: Option<crate::search::CallsBy>,
    /// Tokens and money of the run's observations, every phase (its model's usage and
    /// configured prices).
    #[serde(default)]
    pub spend: Spend,
    /// Sets some of whose observations found no scene they had not shown (absent: none; and in
    /// runs made before scenes were kept distinct).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub repeated_scenes: Vec<RepeatedRow>,
}

/// A count with spaces between thousands groups: `1 000`.
pub fn spaced(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(ch);
    }
    out
}

impl Summary {
    /// Model calls the run made: its search, its shrink phase and fresh confirmation.
    pub fn calls_made(&self) -> u64 {
        self.metrics.inferences
            + self.shrink.as_ref().map_or(0, |s| s.inferences)
            + self.confirmation.as_ref().map_or(0, |c| c.inferences)
    }

    /// Where the cores came from and what it cost: for the paper's algorithms the shrink phase
    /// (`shrink: 3 candidate cores from 243 inferences of 250 …`); for interact, which shrinks
    /// each failure as it finds it, the calls it spent on that during the search and what the
    /// shrink phase after it added.
    pub fn shrink_text(&self, sh: &ShrinkSummary) -> String {
        // The shrink's own: the candidates sent less the failure modes no core explained and
        // those sent last of all.
        let candidates = self
            .confirmation
            .as_ref()
            .map_or(self.cores.len(), |c| c.candidates.saturating_sub(c.unexplained + c.unshrunk));
        let noun = if self.confirmation.is_some() { "candidate cores" } else { "cores" };
        let refuted = match sh.refuted.len() {
            0 => String::new(),
            n => format!("; {n} failure mode{} refuted when re-tested", if n == 1 { "" } else { "s" }),
        };
        let lift = crate::search::shrink::LIFT_MAX_FACTOR * sh.max_samples;
        // Interact tests a core it found with up to CORE_TEST_STRETCH times as many.
        let stretch = crate::search::interact::CORE_TEST_STRETCH;
        match &self.calls {
            Some(c) => format!(
                "shrink: {candidates} {noun}, shrunk and tested during the search ({} calls explaining failures, {} calls in core tests; up to {} observations per set, {} to test a core found, {} its lift); the shrink phase after it: {} calls of {}{refuted}",
                spaced(c.explaining),
                spaced(c.confirmation),
                sh.max_samples,
                stretch * sh.max_samples,
                stretch * lift,
                spaced(sh.inferences),
                spaced(sh.budget),
            ),
            None => format!(
                "shrink: {candidates} {noun} from {} inferences of {} (up to {} observations per set, {lift} to test a core's lift){refuted}",
                spaced(sh.inferences),
                spaced(sh.budget),
                sh.max_samples,
            ),
        }
    }

    /// Where the calls went, against `budget`: `1 000 of 1 000 model calls (screening 402,
    /// escalation 188, explaining 260, core tests 90, fresh confirmation 60)`, or `(search 750,
    /// shrink 180, fresh confirmation 62)`. Interact's core tests (its cores re-tested under the
    /// full rule while it searches) are not the fresh confirmation after the search.
    pub fn budget_text(&self, budget: u64) -> String {
        let shrink = self.shrink.as_ref().map_or(0, |s| s.inferences);
        let mut parts: Vec<String> = match &self.calls {
            Some(c) => [
                ("screening", c.screening),
                ("escalation", c.escalation),
                ("explaining", c.explaining),
                ("core tests", c.confirmation),
            ]
            .iter()
            .map(|(what, n)| format!("{what} {}", spaced(*n)))
            .collect(),
            None if self.shrink.is_some() => vec![format!("search {}", spaced(self.metrics.inferences))],
            None => vec![],
        };
        if self.shrink.is_some() && (self.calls.is_none() || shrink > 0) {
            parts.push(format!("shrink {}", spaced(shrink)));
        }
        if let Some(c) = &self.confirmation {
            parts.push(format!("fresh confirmation {}", spaced(c.inferences)));
        }
        let parts = if parts.is_empty() { String::new() } else { format!(" ({})", parts.join(", ")) };
        format!("{} of {} model calls{parts}", spaced(self.calls_made()), spaced(budget))
    }

    /// `(api_error observations, all observations)`.
    pub fn api_errors(&self) -> (u64, u64) {
        (self.metrics.unanswered.get(&Outcome::ApiError).copied().unwrap_or(0), self.metrics.inferences)
    }
}

/// A validation's result (`validation-top{K}-samples{M}.json`): the top-k sets of a run
/// re-evaluated with fresh scenes.
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
    /// Sets some of whose validation observations found no scene the set had not shown in the
    /// run (absent: none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub repeated_scenes: Vec<RepeatedRow>,
}

impl Validation {
    /// `(api_error observations, all observations)` of the validation.
    pub fn api_errors(&self) -> (u64, u64) {
        let rows = self.sets.iter().map(|s| &s.validation);
        let errors = rows.clone().map(|r| u64::from(r.unanswered.get(&Outcome::ApiError).copied().unwrap_or(0))).sum();
        (errors, rows.map(|r| u64::from(r.observations)).sum())
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValidatedSet {
    pub search: SetRow,
    pub validation: SetRow,
}

/// FR a validated failure mode must reach to count as consistent (paper section 4).
pub const CONSISTENT_FR: f64 = 0.8;

/// The file a validation with these options is written to: one per setting, so validating
/// again with other options never overwrites an earlier result. A sequential validation
/// (`max_samples` above `samples`) is a setting of its own: `…-samples{m}-max{M}.json`.
pub fn validation_file(top: usize, samples: u32, max_samples: Option<u32>) -> String {
    match max_samples.filter(|&m| m > samples) {
        Some(max) => format!("validation-top{top}-samples{samples}-max{max}.json"),
        None => format!("validation-top{top}-samples{samples}.json"),
    }
}

/// Read a run folder's configuration and summary.
pub fn load_run(dir: &Path) -> Result<(RunConfig, Summary), RunError> {
    let config = read_config(dir)?
        .ok_or_else(|| RunError::Usage(format!("`{}` is not a run folder (it has no config.json)", dir.display())))?;
    let path = dir.join("summary.json");
    let text = safe::read_text(&path, safe::MAX_JSON_BYTES).map_err(|e| {
        RunError::Usage(format!(
            "cannot read `{}`: {} (is `{}` a finished run folder?)",
            path.display(),
            crate::journal::io_message(&e),
            dir.display()
        ))
    })?;
    let summary: Summary = serde_json::from_str(&text).map_err(|e| JournalError::BadConfig {
        dir: dir.to_path_buf(),
        message: format!("invalid `summary.json`: {e}"),
    })?;
    check_summary(dir, &summary, None)?;
    Ok((config, summary))
}

/// Every set a summary lists, wherever it lists it.
fn summary_sets(summary: &Summary) -> impl Iterator<Item = &SetRow> {
    let shrink =
        summary.shrink.iter().flat_map(|s| s.refuted.iter().chain(s.not_distinct.iter().flat_map(|n| [&n.set, &n.by])));
    let confirmed = summary.confirmation.iter().flat_map(|c| c.checked.iter().map(|r| &r.set));
    let parts = summary.cores.iter().flat_map(|c| c.confirmed.iter().chain(&c.part));
    summary
        .sets
        .iter()
        .chain(&summary.failure_modes)
        .chain(summary.cores.iter().map(|c| &c.set))
        .chain(shrink)
        .chain(confirmed)
        .chain(parts)
        .chain(summary.borderline.iter().map(|r| &r.set))
}

/// A summary read from a run folder sizes what is computed from it (the report's pair matrix
/// is the square of its concepts): its concept names must be the domain's, when the domain is
/// at hand, and are never more than a domain may declare ([`crate::ir::MAX_CONCEPTS`]).
pub fn check_summary(dir: &Path, summary: &Summary, domain: Option<&Domain>) -> Result<(), RunError> {
    let bad = |message: String| JournalError::BadConfig { dir: dir.to_path_buf(), message };
    let mut names = std::collections::BTreeSet::new();
    for row in summary_sets(summary) {
        if row.wrong > row.answered {
            return Err(bad(format!(
                "invalid `summary.json`: a set has {} wrong answers of {} answered",
                row.wrong, row.answered
            ))
            .into());
        }
        let mut seen = std::collections::BTreeSet::new();
        if row.concepts.len() > crate::ir::MAX_CONCEPTS || !row.concepts.iter().all(|c| seen.insert(c)) {
            return Err(bad(format!(
                "invalid `summary.json`: a set of {} names repeats one or is larger than any domain allows",
                row.concepts.len()
            ))
            .into());
        }
        for name in &row.concepts {
            if let Some(d) = domain
                && d.concept_by_name(name).is_none()
            {
                return Err(bad(format!(
                    "invalid `summary.json`: concept `{}` is not in domain `{}`",
                    crate::diag::terminal_safe(name),
                    crate::diag::terminal_safe(&d.name)
                ))
                .into());
            }
            if names.insert(name.as_str()) && names.len() > crate::ir::MAX_CONCEPTS {
                return Err(bad(format!(
                    "invalid `summary.json`: it names more than {} concepts, more than any domain declares",
                    crate::ir::MAX_CONCEPTS
                ))
                .into());
            }
        }
    }
    Ok(())
}

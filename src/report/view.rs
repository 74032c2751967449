//! The report page's view model: the run's data formatted for reading — rates as percentages,
//! intervals in brackets, counts grouped, verdicts and observations in words — with no markup.
//! [`super::page`] writes it as HTML; keeping the two apart means every text is plain until the
//! writer escapes it.

use std::collections::{BTreeMap, BTreeSet};

use super::files::ImageRef;
use super::scale::TABLE_ROWS;
use super::{Core, Findings, Run, outcome_name, phase_name};
use crate::analysis::probe::ProbeReport;
use crate::analysis::transfer::TransferReport;
use crate::analysis::{SceneVisibility, wilson95};
use crate::date::utc;
use crate::ir::{Domain, Question};
use crate::journal::{Phase, Record};
use crate::oracle::{self, option_letter};
use crate::outcome::{Answer, Outcome};
use crate::run::summary::{CONSISTENT_FR, SetRow};
use crate::search::Algo;
use crate::search::interact::Surrogate;
use crate::search::interval::pct;

/// Replies longer than this many characters show a preview and the full text on demand.
const PREVIEW_CHARS: usize = 180;

pub struct Metric {
    pub label: String,
    pub value: String,
    pub detail: String,
}

pub struct VerdictView {
    pub question: String,
    pub expected: String,
    pub rule: String,
    pub rationale: String,
    pub explanation: String,
}

pub struct ObsView {
    pub phase: String,
    pub obs: u32,
    pub image: Option<ImageRef>,
    pub no_image: String,
    pub class: &'static str,
    pub outcome: String,
    pub expected: String,
    pub given: String,
    pub reply: String,
    pub full: Option<String>,
    pub chars: usize,
    /// The measured visibility of each entity a concept placed: `debris (debris_far): 412 px ·
    /// contrast 0.213` (the entity's name alone when the concept's is the same).
    pub seen: Vec<String>,
    /// Scenes drawn again before this one because an entity was not visible.
    pub resamples: u32,
}

pub struct ModeRow {
    pub rank: usize,
    pub concepts: Vec<String>,
    pub fr: String,
    pub ci: String,
    pub answered: u32,
    pub validated: String,
}

pub struct CoreView {
    pub anchor: String,
    pub rank: usize,
    /// The concepts joined by ` + ` (the `data-concepts` attribute, and image alt texts).
    pub key: String,
    pub title: String,
    pub concepts: Vec<String>,
    /// The headline rate, interval and counts: the fresh confirmation's when the run confirmed
    /// its cores, else the search's.
    pub fr: String,
    pub ci: String,
    pub wrong: u32,
    pub answered: u32,
    /// Whose evidence the headline is: "confirmed on fresh scenes" or "search".
    pub basis: &'static str,
    pub validated: String,
    /// Failure modes of the search that contain the core, itself included.
    pub supersets: usize,
    pub shrunk_from: Option<String>,
    pub minimal: bool,
    pub superset_rows: Vec<ModeRow>,
    pub verdict: Option<VerdictView>,
    /// Why the oracle gave no verdict (the domain is there but the set has no ground truth).
    pub verdict_error: Option<String>,
    pub observations: Vec<ObsView>,
    /// Where the visibility guard had to redraw or withhold this core's scenes.
    pub visibility: Option<String>,
    /// The search's own evidence, apart from the confirmed headline (runs with confirmation).
    pub evidence: Option<String>,
    /// The core's near-threshold part and its own rate.
    pub part: Option<String>,
}

pub struct ConceptRow {
    pub concept: String,
    pub f: String,
    pub bar: String,
    pub n: u32,
    pub failure_modes: u32,
}

pub struct OutcomeRow {
    pub outcome: String,
    pub class: &'static str,
    pub counts: Vec<u64>,
}

pub struct PairRow {
    pub pair: String,
    pub fr: String,
    pub n: u32,
}

pub struct IndexPage<'a> {
    pub title: String,
    pub subtitle: String,
    pub header: Vec<(String, String)>,
    pub params: String,
    pub metrics: Vec<Metric>,
    pub metrics_note: String,
    pub threshold: f64,
    pub cores_note: String,
    pub cores: Vec<CoreView>,
    pub others: Vec<ModeRow>,
    /// Failure modes of the search that passed when the shrink phase re-tested them.
    pub refuted: Vec<ModeRow>,
    /// Failing sets that do not fail more than a passing part, each with that part's row.
    pub not_distinct: Vec<(ModeRow, ModeRow)>,
    /// Confirmation candidates left near τ at the per-set cap (fresh observations).
    pub borderline: Vec<ModeRow>,
    /// The cap they reached, in words: "the per-set cap of 40 observations (80 once every
    /// candidate had had its turn and calls were left)".
    pub borderline_cap: String,
    /// The first [`TABLE_ROWS`] concepts, highest F(c) first.
    pub concepts: Vec<ConceptRow>,
    /// Concepts in all (`concepts.csv` holds every one).
    pub concepts_total: usize,
    pub heatmap: &'a str,
    /// What the heatmap leaves out, when it cannot draw every concept.
    pub heatmap_note: Option<String>,
    /// The first [`TABLE_ROWS`] evaluated pairs, highest rate first: the heatmap's numbers.
    pub pairs: Vec<PairRow>,
    /// Evaluated pairs in all (`pairs.csv` holds every one).
    pub pairs_total: usize,
    pub discovery: &'a str,
    pub outcome_phases: Vec<String>,
    pub outcome_rows: Vec<OutcomeRow>,
    pub visibility: VisibilityView,
    pub probe: Option<&'a ProbeReport>,
    pub transfer: Option<&'a TransferReport>,
    pub files: Vec<(String, String)>,
    pub notes: Vec<String>,
    /// The validation file the page shows, if the run was validated.
    pub validation_file: Option<String>,
    pub version: &'static str,
}

/// The visibility guard's figures: per phase, per core that needed it, per concept.
pub struct VisibilityView {
    pub phases: Vec<(String, SceneVisibility)>,
    /// Cores whose scenes were redrawn or withheld: anchor, concepts, counts.
    pub cores: Vec<(String, String, SceneVisibility)>,
    pub concepts: Vec<crate::analysis::ConceptVisibility>,
}

pub(super) fn interval(c: Option<(f64, f64)>) -> String {
    c.map_or_else(|| "–".into(), |(lo, hi)| format!("[{:.0}–{:.0}%]", 100.0 * lo, 100.0 * hi))
}

/// A count with thin-space thousands groups: 115 144.
fn grouped(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push('\u{202f}');
        }
        out.push(ch);
    }
    out
}

fn validated_text(row: Option<&SetRow>) -> String {
    match row {
        None => "–".into(),
        Some(v) => format!("{} {} of {}", pct(v.fr), interval(super::row_ci(v)), v.answered),
    }
}

fn outcome_class(o: Outcome) -> &'static str {
    match o {
        Outcome::Correct => "o-correct",
        Outcome::Wrong => "o-wrong",
        _ => "o-other",
    }
}

/// `C · go`: the option's letter and short name (just the letter without the domain).
fn option_label(q: Option<&Question>, i: u32) -> String {
    match q.and_then(|q| q.options.get(i as usize)) {
        Some(o) => format!("{} · {}", option_letter(i), o.name),
        None => option_letter(i),
    }
}

fn given_label(q: Option<&Question>, r: &Record) -> String {
    match r.answer {
        Some(Answer::Option(i)) => option_label(q, i),
        _ => outcome_name(r.outcome),
    }
}

fn observation(r: &Record, q: Option<&Question>, images: &BTreeMap<String, ImageRef>, renderer: &str) -> ObsView {
    let (text, thinking) = crate::vlm::parse::split_thinking(&r.raw);
    let chars = r.raw.chars().count();
    let long = text.chars().count() > PREVIEW_CHARS;
    let reply = if long {
        let cut: String = text.chars().take(PREVIEW_CHARS - 30).collect();
        format!("{} …", cut.trim_end())
    } else if text.is_empty() {
        "(empty reply)".into()
    } else {
        text
    };
    let no_image = if renderer == "none" {
        "no image (renderer none)".to_string()
    } else {
        "image not in the run folder".to_string()
    };
    ObsView {
        phase: phase_name(r.phase),
        obs: r.obs,
        image: images.get(&r.image).cloned(),
        no_image,
        class: outcome_class(r.outcome),
        outcome: outcome_name(r.outcome),
        expected: option_label(q, r.expected),
        given: given_label(q, r),
        reply,
        full: (long || thinking.is_some()).then(|| r.raw.clone()),
        chars,
        seen: r
            .visibility
            .iter()
            .filter_map(|v| {
                let concept = v.concept.as_ref()?;
                let who = if *concept == v.entity { v.entity.clone() } else { format!("{} ({concept})", v.entity) };
                Some(format!("{who}: {} px · contrast {:.3}", v.pixels, v.contrast))
            })
            .collect(),
        resamples: r.resamples,
    }
}

/// Where the guard redrew or withheld scenes, in words (`None`: never).
fn visibility_text(v: &SceneVisibility) -> Option<String> {
    if v.resampled == 0 && v.invisible == 0 {
        return None;
    }
    let mut parts = Vec::new();
    if v.resampled > 0 {
        let redrawn = if v.redraws == 1 { "1 scene".to_string() } else { format!("{} scenes", v.redraws) };
        parts.push(format!("{} of {} observations needed resampling ({redrawn} redrawn)", v.resampled, v.scenes));
    }
    if v.invisible > 0 {
        parts.push(format!("{} stayed invisible (never shown to the model)", v.invisible));
    }
    Some(parts.join("; "))
}

fn verdict<'d>(domain: &'d Domain, concepts: &[String]) -> Result<(VerdictView, &'d Question), String> {
    let set = domain.parse_set(concepts).map_err(|e| e.to_string())?;
    let v = oracle::evaluate(domain, set).map_err(|e| e.to_string())?;
    let q = &domain.questions[v.question.index()];
    let rule = &domain.rules[v.rule.index()];
    let expected = &q.options[v.expected as usize];
    let mut question = q.text.clone();
    for (i, o) in q.options.iter().enumerate() {
        question.push_str(&format!("\n{}. {}", option_letter(i as u32), o.text));
    }
    let view = VerdictView {
        question,
        expected: format!("{}. {} ({})", v.letter(), expected.text, expected.name),
        rule: rule.name.clone(),
        rationale: rule.rationale.clone(),
        explanation: v.explanation.clone(),
    };
    Ok((view, q))
}

fn mode_row(run: &Run, i: usize) -> ModeRow {
    let m = &run.summary.failure_modes[i];
    ModeRow {
        rank: i + 1,
        concepts: m.concepts.clone(),
        fr: pct(m.fr),
        ci: interval(run.mode_ci(i)),
        answered: m.answered,
        validated: validated_text(run.validated(&m.concepts)),
    }
}

/// The summary's core row with these concepts, and the confirmation's q (runs with
/// confirmation only).
fn confirmed_row<'r>(run: &'r Run, concepts: &[String]) -> Option<(&'r crate::run::summary::CoreRow, f64)> {
    let q = run.summary.confirmation.as_ref()?.q;
    run.summary.cores.iter().find(|c| crate::analysis::same_set(&c.set.concepts, concepts)).map(|c| (c, q))
}

fn core_view(
    run: &Run,
    domain: Option<&Domain>,
    f: &Findings<'_>,
    images: &BTreeMap<String, ImageRef>,
    i: usize,
    c: &Core,
) -> CoreView {
    let (verdict, question, verdict_error) = match domain.map(|d| verdict(d, &c.concepts)) {
        Some(Ok((v, q))) => (Some(v), Some(q), None),
        Some(Err(e)) => (None, None, Some(format!("no ground truth: {e}"))),
        None => (None, None, None),
    };
    let observations: Vec<ObsView> =
        f.core_observations[i].iter().map(|r| observation(r, question, images, &run.config.renderer)).collect();
    let superset_rows = (0..run.summary.failure_modes.len())
        .filter(|&m| {
            let concepts = &run.summary.failure_modes[m].concepts;
            concepts.len() > c.concepts.len() && crate::analysis::is_subset(&c.concepts, concepts)
        })
        .map(|m| mode_row(run, m))
        .collect();
    let key = c.concepts.join(" + ");
    // Confirmed first: the headline is the fresh observations' when there are any.
    let confirmed = confirmed_row(run, &c.concepts).and_then(|(core, q)| core.confirmed.as_ref().map(|r| (core, r, q)));
    let (fr, ci, wrong, answered, basis) = match confirmed {
        Some((_, r, _)) => {
            (pct(r.fr), interval(Some((r.ci95[0], r.ci95[1]))), r.wrong, r.answered, "confirmed on fresh scenes")
        }
        None => (pct(c.fr), interval(c.ci95), c.wrong, c.answered, "search"),
    };
    CoreView {
        anchor: format!("core-{}", i + 1),
        rank: i + 1,
        title: key.clone(),
        key,
        concepts: c.concepts.clone(),
        fr,
        ci,
        wrong,
        answered,
        basis,
        validated: match (&run.validation, run.validated(&c.concepts)) {
            (None, _) => "run not validated".into(),
            (Some(v), None) => format!("not among the top {} validated", v.top),
            (Some(_), row) => validated_text(row),
        },
        supersets: c.supersets,
        shrunk_from: (!c.shrunk_from.is_empty()).then(|| c.shrunk_from.join(" + ")),
        minimal: c.minimal,
        superset_rows,
        verdict,
        verdict_error,
        observations,
        visibility: visibility_text(&crate::analysis::visibility(&f.core_observations[i])),
        evidence: confirmed.map(|(core, r, q)| {
            format!(
                "Confirmed on {} fresh observations made after it was selected (anytime-valid 95%; e-BH at q = {q}). The search's own evidence, which selected it and is not counted above: {} {} of {}.",
                r.answered,
                pct(core.set.fr),
                interval(Some((core.set.ci95[0], core.set.ci95[1]))),
                core.set.answered
            )
        }),
        part: confirmed_row(run, &c.concepts).and_then(|(core, _)| core.part.as_ref()).map(|p| {
            format!(
                "Near-threshold part: {} alone fails {} {} of {}; the core adds what lifts it.",
                p.concepts.join(" + "),
                pct(p.fr),
                interval(Some((p.ci95[0], p.ci95[1]))),
                p.answered
            )
        }),
    }
}

fn visibility_view(f: &Findings<'_>, all: &[&Record]) -> VisibilityView {
    let cores = f
        .cores
        .iter()
        .enumerate()
        .map(|(i, c)| {
            (format!("core-{}", i + 1), c.concepts.join(" + "), crate::analysis::visibility(&f.core_observations[i]))
        })
        .filter(|(_, _, v)| v.resampled > 0 || v.invisible > 0)
        .collect();
    VisibilityView {
        phases: crate::analysis::visibility_by_phase(all).into_iter().map(|(p, v)| (phase_name(p), v)).collect(),
        cores,
        concepts: crate::analysis::concept_visibility(all),
    }
}

fn algorithm_text(run: &Run) -> String {
    let p = &run.config.params;
    match p.algo {
        Algo::Random => "random (uniform over the valid lattice)".into(),
        Algo::Beam => format!("beam (width {}, depth {}, λ = {})", p.beam_width, p.max_depth, p.lambda),
        Algo::Gpts => format!(
            "gpts ({} inferences of beam warm-up, then Thompson sampling on a {} GP, {} per round)",
            grouped(p.beam_budget),
            p.kernel.formula(),
            p.batch
        ),
        Algo::Interact if p.surrogate == Surrogate::Patterns => format!(
            "interact (group testing over patterns of up to three concepts, {} per round: a set screened with one \
             observation, a failure explained at once by its likeliest sub-patterns and shrinking; supersets of a \
             core: {})",
            p.batch,
            super::snake(p.supersets)
        ),
        Algo::Interact => format!(
            "interact ({} regression surrogate, {} per round; confirmed cores shrunk at once; supersets of a core: {})",
            super::snake(p.surrogate),
            p.batch,
            super::snake(p.supersets)
        ),
    }
}

/// The recorded parameters that steer the run's algorithm (a GPTS run does not list interact's
/// surrogate).
fn params_text(run: &Run) -> String {
    let algo = run.config.params.algo;
    let parts: Vec<String> = run
        .params
        .iter()
        .filter(|(k, _)| crate::search::Params::applies(k, algo))
        .map(|(k, v)| match v {
            serde_json::Value::String(s) => format!("{k} {s}"),
            other => format!("{k} {other}"),
        })
        .collect();
    format!("parameters: {}", parts.join(" · "))
}

fn header(run: &Run) -> Vec<(String, String)> {
    let s = &run.summary;
    let p = &run.config.params;
    let file = std::path::Path::new(&run.config.domain_file)
        .file_name()
        .map_or_else(String::new, |n| format!(" ({})", n.to_string_lossy()));
    let mut h = vec![
        ("Domain".to_string(), format!("{}{file}", s.domain)),
        ("Model".into(), s.model.clone()),
        ("Algorithm".into(), algorithm_text(run)),
        ("Budget".into(), format!("{} · m = {} per set · τ = {}", s.budget_text(p.budget), p.samples, s.threshold)),
        ("Seed".into(), p.seed.to_string()),
        ("Finished".into(), run.finished.map_or_else(|| "–".into(), utc)),
        ("Renderer".into(), run.config.renderer.clone()),
        ("Spend".into(), s.spend.line()),
    ];
    h.push(match &run.validation {
        Some(v) => {
            let samples = match v.max_samples {
                Some(max) => format!("{}–{max} fresh samples (sequential)", v.samples),
                None => format!("{} fresh samples", v.samples),
            };
            ("Validation".into(), format!("top {} × {samples}; {}", v.top, v.spend.line()))
        }
        None => ("Validation".into(), "not validated (revelio validate re-checks the top sets)".into()),
    });
    h
}

fn metrics(run: &Run, f: &Findings<'_>) -> Vec<Metric> {
    let m = &run.summary.metrics;
    let mut v = vec![
        Metric {
            label: "Failure modes".into(),
            value: m.failure_modes.to_string(),
            detail: format!("of {} sets at FR ≥ {}", grouped(m.sets as u64), run.summary.threshold),
        },
        Metric {
            label: "Distinct cores".into(),
            value: f.cores.len().to_string(),
            detail: match (&run.summary.calls, &run.extras.shrink) {
                (Some(c), _) => {
                    format!("shrunk and tested as found, in {} inferences", grouped(c.explaining + c.confirmation))
                }
                (None, Some(sh)) => format!("shrunk in {} inferences", grouped(sh.inferences)),
                (None, None) if f.shrunk => "minimal failing subsets".into(),
                (None, None) => "minimal failure modes found".into(),
            },
        },
        Metric {
            label: "PFM".into(),
            value: format!("{:.1}%", m.pfm),
            detail: format!("95% CI {}", interval(wilson95(m.failure_modes as u64, m.sets as u64))),
        },
        Metric {
            label: "MFR".into(),
            value: format!("{:.1}%", m.mfr),
            detail: format!("95% CI {}", interval(wilson95(m.failures, m.inferences))),
        },
        Metric {
            label: "Div".into(),
            value: m.div.map_or_else(|| "–".into(), |d| format!("{d:.2}")),
            detail: "mean Jaccard distance between failure modes".into(),
        },
        Metric {
            label: "Inferences".into(),
            value: grouped(m.inferences),
            detail: format!("{} sets of {} valid", grouped(m.sets as u64), grouped(run.summary.space as u64)),
        },
    ];
    let unanswered: u64 = m.unanswered.values().sum();
    let parts: Vec<String> = m.unanswered.iter().map(|(o, n)| format!("{n} {}", outcome_name(*o))).collect();
    v.push(Metric {
        label: "Not answered".into(),
        value: grouped(unanswered),
        detail: if parts.is_empty() { "every reply named one option".into() } else { parts.join(", ") },
    });
    if let Some(val) = &run.validation {
        v.push(Metric {
            label: "Validated FR".into(),
            value: format!("{:.0}%", 100.0 * val.mean_fr),
            detail: format!(
                "± {:.0}% sd; {} of {} reach FR ≥ {:.0}%",
                100.0 * val.sd_fr,
                val.consistent,
                val.sets.len(),
                100.0 * CONSISTENT_FR
            ),
        });
    }
    v
}

fn outcome_table(f: &Findings<'_>) -> (Vec<String>, Vec<OutcomeRow>) {
    let counts = crate::analysis::outcome_counts(&f.observations);
    let phases: Vec<Phase> = counts.keys().copied().collect();
    let outcomes: BTreeSet<Outcome> = counts.values().flat_map(|m| m.keys().copied()).collect();
    let mut columns: Vec<String> = phases.iter().map(|p| phase_name(*p)).collect();
    columns.push("total".into());
    let rows = outcomes
        .into_iter()
        .map(|o| {
            let mut n: Vec<u64> = phases.iter().map(|p| counts[p].get(&o).copied().unwrap_or(0)).collect();
            n.push(n.iter().sum());
            OutcomeRow { outcome: outcome_name(o), class: outcome_class(o), counts: n }
        })
        .collect();
    (columns, rows)
}

/// The page's data, formatted for reading.
pub fn index_page<'a>(
    run: &'a Run,
    domain: Option<&Domain>,
    f: &Findings<'_>,
    images: &BTreeMap<String, ImageRef>,
    discovery: &'a str,
    heatmap: &'a str,
) -> IndexPage<'a> {
    let s = &run.summary;
    let cores: Vec<CoreView> =
        f.cores.iter().enumerate().map(|(i, c)| core_view(run, domain, f, images, i, c)).collect();
    let others = (0..s.failure_modes.len()).filter(|&i| f.mode_core[i].is_none()).map(|i| mode_row(run, i)).collect();
    let concepts = f
        .concepts
        .iter()
        .take(TABLE_ROWS)
        .map(|c| ConceptRow {
            concept: c.concept.clone(),
            f: pct(Some(c.f)),
            bar: format!("{:.1}", 100.0 * c.f),
            n: c.n,
            failure_modes: c.failure_modes,
        })
        .collect();
    let row = |i: usize, r: &crate::run::summary::SetRow| ModeRow {
        rank: i + 1,
        concepts: r.concepts.clone(),
        fr: pct(r.fr),
        ci: interval(super::row_ci(r)),
        answered: r.answered,
        validated: validated_text(run.validated(&r.concepts)),
    };
    let refuted = run.extras.shrink.iter().flat_map(|sh| &sh.refuted).enumerate().map(|(i, r)| row(i, r)).collect();
    let not_distinct = run
        .extras
        .shrink
        .iter()
        .flat_map(|sh| &sh.not_distinct)
        .enumerate()
        .map(|(i, r)| (row(i, &r.set), row(i, &r.by)))
        .collect();
    let borderline = s.borderline.iter().enumerate().map(|(i, r)| row(i, &r.set)).collect();
    let borderline_cap = match &s.confirmation {
        Some(c) if c.extended > 0 => format!(
            "the per-set cap of {} observations ({} once every candidate had had its turn and calls were left)",
            c.cap, c.extended
        ),
        Some(c) => format!("the per-set cap of {} observations", c.cap),
        None => "the per-set cap".into(),
    };
    let (outcome_phases, outcome_rows) = outcome_table(f);
    let (pairs, pairs_total) = pair_rows(&f.pairs);
    let drawn = super::scale::heatmap_concepts(f).len();
    let heatmap_note = (drawn < f.pairs.concepts.len()).then(|| {
        format!(
            "The plot draws {drawn} of the {} concepts: those of the cores, then those in the most failure modes, then by F(c); the other {} are left out here, and every concept's and pair's rate is in concepts.csv and pairs.csv.",
            f.pairs.concepts.len(),
            f.pairs.concepts.len() - drawn
        )
    });
    let cores_note = if let Some(c) = &s.confirmation {
        format!(
            "{} of {} candidate cores confirmed. Each candidate is a set the search found failing whose parts one concept smaller did not fail, or failed at least 2δ less (a core it established above τ − δ = {:.2} by an anytime-valid test, or a failure mode no such core explains), or, last of all, another failure mode of the search not shown minimal (marked so below); it is then asked again on fresh scenes, after it was selected, and reported only if e-BH across all candidates confirms it at a false discovery rate of q = {} (a core is false when its true rate is ≤ τ − δ). Its rate and interval below are the fresh observations' alone.",
            c.confirmed,
            c.candidates,
            s.threshold - c.delta,
            c.q
        )
    } else if f.shrunk {
        "Each core is a smallest set that still fails by the sequential test and fails significantly more often than each of its parts one concept smaller (found by shrinking the strongest failure families); every failure mode is listed under the first core it contains."
            .to_string()
    } else {
        "This run has no shrink phase: the cores shown are its minimal failure modes — failure modes none of whose evaluated subsets failed. A smaller failing subset may exist that the search never evaluated."
            .to_string()
    };
    let mut notes: Vec<String> = run.unreadable.iter().map(|e| format!("Left out: {e}.")).collect();
    let all = crate::analysis::latest_observations(&run.records);
    let mut files = vec![
        ("failure_modes.csv".to_string(), "every failure mode with its interval, core and validated FR".to_string()),
        ("sets.csv".into(), "every evaluated set, in evaluation order".into()),
        ("discovery.svg".into(), "the discovery curve".into()),
        ("heatmap.svg".into(), "the pair failure-rate heatmap".into()),
        ("concepts.csv".into(), "F(c), n and failure modes of every concept".into()),
        ("pairs.csv".into(), "the mean failure rate and n of every evaluated pair".into()),
    ];
    if run.probe.is_some() {
        files.push(("recognition.csv".into(), "R(c), F(c), n and the mechanism per probed concept".into()));
    }
    if run.transfer.is_some() {
        files.push(("transfer.csv".into(), "each transferred and random set's FR on every model".into()));
    }
    if domain.is_none() {
        notes.push("The domain file could not be loaded unchanged, so the oracle's explanations and the options' names are left out.".to_string());
    }
    IndexPage {
        title: format!("Revelio · {} · {}", s.domain, s.model),
        subtitle: format!("{} on {} with {}", s.algo.name(), s.domain, s.model),
        header: header(run),
        params: params_text(run),
        metrics: metrics(run, f),
        metrics_note: "Brackets are 95% Wilson intervals. For PFM and MFR they treat sets and inferences as independent draws, which an adaptive search only approximates.".into(),
        threshold: s.threshold,
        cores_note,
        cores,
        others,
        refuted,
        not_distinct,
        borderline,
        borderline_cap,
        concepts,
        concepts_total: f.concepts.len(),
        heatmap,
        heatmap_note,
        pairs,
        pairs_total,
        discovery,
        outcome_phases,
        outcome_rows,
        visibility: visibility_view(f, &all),
        probe: run.probe.as_ref(),
        transfer: run.transfer.as_ref(),
        files,
        notes,
        validation_file: run.validation.as_ref().and(run.validation_file.clone()),
        version: env!("CARGO_PKG_VERSION"),
    }
}

/// The first [`TABLE_ROWS`] pairs, highest rate first, and how many there are in all.
fn pair_rows(p: &crate::analysis::PairRates) -> (Vec<PairRow>, usize) {
    let ranked = super::scale::ranked_pairs(p);
    let total = ranked.len();
    let rows =
        ranked.into_iter().take(TABLE_ROWS).map(|(pair, c)| PairRow { pair, fr: pct(Some(c.fr)), n: c.n }).collect();
    (rows, total)
}

#[cfg(test)]
mod tests {
    use std::time::SystemTime;

    use super::*;

    #[test]
    fn dates_and_counts_read_naturally() {
        let t = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_795_444_140);
        assert_eq!(utc(t), "2026-11-23 14:29 UTC");
        assert_eq!(utc(SystemTime::UNIX_EPOCH), "1970-01-01 00:00 UTC");
        assert_eq!(grouped(115_144), "115\u{202f}144");
        assert_eq!(grouped(999), "999");
        assert_eq!(interval(Some((0.5655, 1.0))), "[57–100%]");
    }
}

//! The run report: a static folder (`RUN_DIR/report/` by default) with `index.html`, the plots
//! as SVG, `failure_modes.csv`, `sets.csv`, `concepts.csv` and `pairs.csv`, and the images its
//! failure modes show. A domain of hundreds of concepts gets a page that summarises (`scale`):
//! the heatmap draws the concepts most involved, the concept and pair tables their first rows.
//!
//! The page needs no network and runs no script: "full reply" is a `<details>` element, plots are
//! inline SVG. Images are hard-linked (copied where linking fails) into the report's `images/`,
//! with small `thumbs/` beside them, so the folder can be moved, zipped or served on its own and
//! costs no extra disk on the run's file system. Every text taken from the run — replies above
//! all — is escaped: by the page's one escaping helper in `index.html`, by plotters in the SVGs.
//!
//! What it shows comes from [`crate::analysis`]: cores first (the summary's `cores` when the run
//! was shrunk; otherwise the minimal failure modes stand in), each with its observations, the
//! oracle's deciding rule, FR with its 95 % interval, the validated FR and the failure modes that
//! contain it; then F(c), pair rates, the discovery curve and the outcome breakdown; how often
//! the visibility guard redrew or withheld a scene; and, once `revelio probe` and `revelio
//! transfer` have written `probe.json` and `transfer.json`, recognition vs. reasoning and the
//! transfer table (with `recognition.csv` and `transfer.csv`).

mod csv;
mod files;
mod page;
mod scale;
pub mod svg;
mod view;

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde::Deserialize;

use crate::analysis::probe::ProbeReport;
use crate::analysis::transfer::TransferReport;
use crate::analysis::{self, anytime95, is_subset, same_set};
use crate::ir::Domain;
use crate::journal::{Phase, Record, safe};
use crate::outcome::Outcome;
use crate::run::summary;
use crate::run::summary::{RunConfig, SetRow, Summary, Validation};

/// Everything a report is made from: a run folder's files, read once.
pub struct Run {
    pub dir: PathBuf,
    pub config: RunConfig,
    /// `config.json`'s `params`, listed as they are (so new parameters show without code here).
    pub params: serde_json::Map<String, serde_json::Value>,
    pub summary: Summary,
    pub extras: Extras,
    pub validation: Option<Validation>,
    /// The file `validation` was read from (the run's most recent validation).
    pub validation_file: Option<String>,
    pub records: Vec<Record>,
    /// When `summary.json` was last written.
    pub finished: Option<SystemTime>,
    /// `probe.json`, once `revelio probe` has run.
    pub probe: Option<ProbeReport>,
    /// `transfer.json`, once `revelio transfer` has run.
    pub transfer: Option<TransferReport>,
    /// Files of the run folder the report could not read (it shows the rest and says so).
    pub unreadable: Vec<String>,
}

/// Fields of `summary.json` that only newer runs carry: intervals per set, the cores found by
/// shrinking and the shrink phase. Absent fields fall back to what the report can compute.
#[derive(Debug, Clone, Default, Deserialize)]
pub struct Extras {
    #[serde(default)]
    pub cores: Vec<CoreRow>,
    #[serde(default)]
    pub shrink: Option<ShrinkRow>,
    #[serde(default)]
    pub failure_modes: Vec<Interval>,
    #[serde(default)]
    pub sets: Vec<Interval>,
}

#[derive(Debug, Clone, Default, Deserialize)]
pub struct Interval {
    #[serde(default)]
    pub ci95: Option<(f64, f64)>,
}

/// One entry of `summary.json`'s `cores`.
#[derive(Debug, Clone, Deserialize)]
pub struct CoreRow {
    pub concepts: Vec<String>,
    #[serde(default)]
    pub fr: Option<f64>,
    #[serde(default)]
    pub ci95: Option<(f64, f64)>,
    #[serde(default)]
    pub wrong: Option<u32>,
    #[serde(default)]
    pub answered: u32,
    /// Failure modes of the search containing the core, itself included.
    #[serde(default)]
    pub supersets: Option<usize>,
    /// Whether every one-smaller valid subset was tested and passed.
    #[serde(default = "yes")]
    pub minimal: bool,
    #[serde(default)]
    pub shrunk_from: Vec<String>,
}

fn yes() -> bool {
    true
}

/// `summary.json`'s `shrink`: the phase that shrank failure modes to cores.
#[derive(Debug, Clone, Default, Deserialize)]
pub struct ShrinkRow {
    #[serde(default)]
    pub inferences: u64,
    /// Failure modes of the search that did not fail when re-tested.
    #[serde(default)]
    pub refuted: Vec<SetRow>,
    /// Failing sets that fail no more than a passing one-smaller part (the lift test).
    #[serde(default)]
    pub not_distinct: Vec<summary::NotDistinctRow>,
}

/// A JSON file of the run folder; `None` when absent. Read through [`safe`]: a regular file (a
/// FIFO would block the report forever, `/dev/zero` would never end), no link followed, bounded.
fn read_json<T: serde::de::DeserializeOwned>(dir: &Path, name: &str) -> Result<Option<T>, String> {
    let path = dir.join(name);
    let text = match safe::read_text(&path, safe::MAX_JSON_BYTES) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("cannot read `{}`: {}", path.display(), crate::journal::io_message(&e))),
    };
    serde_json::from_str(&text).map(Some).map_err(|e| format!("invalid `{name}` in `{}`: {e}", dir.display()))
}

/// The run's most recent validation file: `revelio validate` writes one per setting
/// ([`summary::validation_file`]) and refreshes the report right after, so the report shows the
/// validation just made. Ties in time go to the later name; `validation.json` is what runs from
/// before one file per setting wrote.
fn latest_validation(dir: &Path) -> Option<String> {
    let entries = std::fs::read_dir(dir).ok()?;
    entries
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_str()?.to_string();
            let is_validation =
                name == "validation.json" || (name.starts_with("validation-top") && name.ends_with(".json"));
            let modified = e.metadata().and_then(|m| m.modified()).ok()?;
            is_validation.then_some((modified, name))
        })
        .max()
        .map(|(_, name)| name)
}

/// Read a finished run folder.
pub fn load(dir: &Path) -> Result<Run, String> {
    let (config, summary) = summary::load_run(dir).map_err(|e| e.to_string())?;
    let extras: Extras = read_json(dir, "summary.json")?.unwrap_or_default();
    let raw: Option<serde_json::Value> = read_json(dir, "config.json")?;
    let params = raw.and_then(|v| v.get("params").and_then(|p| p.as_object().cloned())).unwrap_or_default();
    let validation_file = latest_validation(dir);
    let validation = match &validation_file {
        Some(name) => read_json(dir, name)?,
        None => None,
    };
    let records = crate::journal::read(dir).map_err(|e| e.to_string())?;
    let finished = std::fs::metadata(dir.join("summary.json")).and_then(|m| m.modified()).ok();
    // What `probe` and `transfer` wrote is an addition: a damaged file costs its section only.
    let mut unreadable = Vec::new();
    let probe: Option<ProbeReport> = read_json(dir, "probe.json").unwrap_or_else(|e| {
        unreadable.push(e);
        None
    });
    let transfer: Option<TransferReport> = read_json(dir, "transfer.json").unwrap_or_else(|e| {
        unreadable.push(e);
        None
    });
    Ok(Run {
        dir: dir.to_path_buf(),
        config,
        params,
        summary,
        extras,
        validation,
        validation_file,
        records,
        finished,
        probe,
        transfer,
        unreadable,
    })
}

/// A core as the report shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Core {
    pub concepts: Vec<String>,
    pub fr: Option<f64>,
    pub ci95: Option<(f64, f64)>,
    pub wrong: u32,
    pub answered: u32,
    /// Failure modes of the search that contain the core, itself included.
    pub supersets: usize,
    /// False when shrinking stopped (out of budget) before testing every smaller subset.
    pub minimal: bool,
    /// The failure mode it was shrunk from (empty for a minimal failure mode standing in).
    pub shrunk_from: Vec<String>,
}

/// The analysis of a run the page and the tables share.
pub struct Findings<'r> {
    /// Whether the cores come from the run's shrink phase (else: minimal failure modes).
    pub shrunk: bool,
    pub cores: Vec<Core>,
    /// The observations that count (newest line per observation), in journal order.
    pub observations: Vec<&'r Record>,
    /// Per core, its own observations (every phase), in phase then index order.
    pub core_observations: Vec<Vec<&'r Record>>,
    /// Per failure mode (summary order), the first core it contains.
    pub mode_core: Vec<Option<usize>>,
    pub concepts: Vec<analysis::ConceptRate>,
    pub pairs: analysis::PairRates,
    pub discovery: analysis::Discovery,
}

impl Run {
    /// The 95 % interval of a failure mode (by its index in the summary).
    pub fn mode_ci(&self, i: usize) -> Option<(f64, f64)> {
        let row = &self.summary.failure_modes[i];
        self.extras.failure_modes.get(i).and_then(|x| x.ci95).or_else(|| row_ci(row))
    }

    /// The 95 % interval of an evaluated set (by its index in the summary).
    pub fn set_ci(&self, i: usize) -> Option<(f64, f64)> {
        let row = &self.summary.sets[i];
        self.extras.sets.get(i).and_then(|x| x.ci95).or_else(|| row_ci(row))
    }

    /// The validation row of a set, when the run was validated and the set was among the top.
    pub fn validated(&self, concepts: &[String]) -> Option<&SetRow> {
        let v = self.validation.as_ref()?;
        v.sets.iter().find(|s| same_set(&s.search.concepts, concepts)).map(|s| &s.validation)
    }

    pub fn findings(&self) -> Findings<'_> {
        let modes = &self.summary.failure_modes;
        // A run that was shrunk lists its cores (none, if every failure mode was refuted);
        // otherwise the minimal failure modes stand in.
        let shrunk = self.extras.shrink.is_some() || !self.extras.cores.is_empty();
        let cores: Vec<Core> = if shrunk {
            self.extras
                .cores
                .iter()
                .map(|c| {
                    let wrong =
                        c.wrong.unwrap_or_else(|| c.fr.map_or(0, |f| (f * f64::from(c.answered)).round() as u32));
                    Core {
                        concepts: c.concepts.clone(),
                        fr: c.fr,
                        ci95: c.ci95.or_else(|| anytime95(u64::from(wrong), u64::from(c.answered))),
                        wrong,
                        answered: c.answered,
                        supersets: c.supersets.unwrap_or_else(|| analysis::supersets(&c.concepts, modes)),
                        minimal: c.minimal,
                        shrunk_from: c.shrunk_from.clone(),
                    }
                })
                .collect()
        } else {
            analysis::minimal_failure_modes(modes)
                .into_iter()
                .map(|i| Core {
                    concepts: modes[i].concepts.clone(),
                    fr: modes[i].fr,
                    ci95: self.mode_ci(i),
                    wrong: modes[i].wrong,
                    answered: modes[i].answered,
                    supersets: analysis::supersets(&modes[i].concepts, modes),
                    minimal: true,
                    shrunk_from: Vec::new(),
                })
                .collect()
        };
        // `transfer` journals other models' answers in the run: the report is about its own model.
        let observations: Vec<&Record> =
            analysis::latest_observations(&self.records).into_iter().filter(|r| r.model.is_none()).collect();
        let core_observations = cores
            .iter()
            .map(|c| {
                let mut v: Vec<&Record> =
                    observations.iter().copied().filter(|r| same_set(&r.set, &c.concepts)).collect();
                v.sort_by_key(|r| (r.phase, r.obs));
                v
            })
            .collect();
        let mode_core = modes.iter().map(|m| cores.iter().position(|c| is_subset(&c.concepts, &m.concepts))).collect();
        let concepts = analysis::concept_rates(&self.summary.sets, self.summary.threshold);
        let order: Vec<String> = concepts.iter().map(|c| c.concept.clone()).collect();
        let pairs = analysis::pair_rates(&self.summary.sets, &order);
        let mode_sets: Vec<Vec<String>> = modes.iter().map(|m| m.concepts.clone()).collect();
        let core_sets: Vec<Vec<String>> = cores.iter().map(|c| c.concepts.clone()).collect();
        let discovery = analysis::discovery(&observations, &mode_sets, &core_sets);
        Findings { shrunk, cores, observations, core_observations, mode_core, concepts, pairs, discovery }
    }
}

/// A row's interval as its run wrote it (Wilson in older runs, anytime-valid since); from the
/// counts (anytime-valid) when the run wrote none.
fn row_ci(row: &SetRow) -> Option<(f64, f64)> {
    if row.answered > 0 && row.ci95 != [0.0, 1.0] {
        return Some((row.ci95[0], row.ci95[1]));
    }
    anytime95(u64::from(row.wrong), u64::from(row.answered))
}

/// What `write` produced.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    pub index: PathBuf,
    /// Images shown (each linked or copied once, with a thumbnail).
    pub images: usize,
}

/// Write the report of `run` into `out` (created if needed). `domain` (the run's, unchanged)
/// adds the oracle's explanation and the answer options' names; without it the page shows option
/// letters only.
pub fn write(run: &Run, domain: Option<&Domain>, out: &Path) -> Result<Written, String> {
    if same_dir(out, &run.dir) {
        return Err(format!(
            "the report cannot be written into the run folder `{}` itself; choose a subfolder",
            out.display()
        ));
    }
    // The default report folder lies in the run folder: a planted link there must not send
    // `index.html` and the rest into another folder.
    if safe::is_link(out) {
        return Err(format!(
            "cannot write the report into `{}`: it is a symbolic link (revelio follows no link in a run folder or a report); name the folder it points to with `--out`",
            out.display()
        ));
    }
    std::fs::create_dir_all(out)
        .and_then(|()| safe::ensure_dir(out))
        .map_err(|e| format!("cannot create `{}`: {}", out.display(), crate::journal::io_message(&e)))?;
    // What the run folder says is checked against the domain before it sizes anything (the pair
    // matrix is the square of the concepts named); `load` already bounded their number.
    if let Some(d) = domain {
        summary::check_summary(&run.dir, &run.summary, Some(d)).map_err(|e| e.to_string())?;
    }
    let findings = run.findings();
    let wanted: Vec<&str> = findings.core_observations.iter().flatten().map(|r| r.image.as_str()).collect();
    let images = files::materialize(&run.dir.join("images"), out, &wanted)?;
    let discovery = svg::discovery(&findings.discovery)?;
    // Past a few dozen concepts the heatmap draws the most involved ones (see `scale`).
    let drawn = scale::heatmap_concepts(&findings);
    let hidden = findings.pairs.concepts.len() - drawn.len();
    let heatmap = svg::heatmap(&scale::restrict(&findings.pairs, &drawn), hidden)?;
    let html = page::render(run, domain, &findings, &images, &discovery, &heatmap)?;
    let put = |name: &str, text: &str| {
        crate::journal::write_atomic(&out.join(name), text.as_bytes()).map_err(|e| e.to_string())
    };
    put("discovery.svg", &discovery)?;
    put("heatmap.svg", &heatmap)?;
    put("failure_modes.csv", &csv::failure_modes(run, &findings))?;
    put("sets.csv", &csv::sets(run))?;
    put("concepts.csv", &csv::concepts(&findings))?;
    put("pairs.csv", &csv::pairs(&findings))?;
    for (name, table) in [
        ("recognition.csv", run.probe.as_ref().map(csv::recognition)),
        ("transfer.csv", run.transfer.as_ref().map(|t| csv::transfer(&t.transfer))),
    ] {
        match table {
            Some(t) => put(name, &t)?,
            // A table of an earlier probe or transfer that the run folder no longer holds.
            None => match std::fs::remove_file(out.join(name)) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(format!(
                        "cannot remove `{}`: {}",
                        out.join(name).display(),
                        e.to_string().to_lowercase()
                    ));
                }
                _ => {}
            },
        }
    }
    put("index.html", &html)?;
    Ok(Written { index: out.join("index.html"), images: images.len() })
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => std::path::absolute(a).ok() == std::path::absolute(b).ok(),
    }
}

/// A serialisable unit enum's name as its JSON spells it (`api_error`, `validate`).
fn snake<T: serde::Serialize>(v: T) -> String {
    serde_json::to_value(v).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default()
}

pub fn phase_name(p: Phase) -> String {
    snake(p)
}

/// An outcome as the report shows it: its name with spaces (`api error`).
pub fn outcome_name(o: Outcome) -> String {
    o.name().replace('_', " ")
}

#[cfg(test)]
mod tests;

//! `revelio probe RUN_DIR [--top k] [--samples n]`: recognition vs. reasoning (paper appendix
//! G). Re-asks a finished run's cores and top sets with the safety prompt extended by each present
//! concept's probe statement and its counterfactual, answered True/False in the same reply as
//! the option; prints R(c), F(c), n and the mechanism per concept and the lift of concept pairs;
//! writes `probe.json`. Observations are journaled under phase `probe`, so the same command
//! resumes. Exit codes as for `search`.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::analysis::probe::{Analysis, ProbedSet, Thresholds, analyse};
use crate::analysis::reask::{self, Reask};
use crate::ir::{ConceptSet, Domain};
use crate::journal::Journal;
use crate::run::eval::Spend;
use crate::run::observe::{DomainWorld, Observer, World};
use crate::run::runner::{self, RunConfig, Summary};
use crate::run::setup::{self, Parts, SetupError};
use crate::run::{RunError, Stop};
use crate::search::SetStats;
use crate::vlm::Model;

use super::search::{ModelFlags, RunFlags, fail_run, runtime, watch_ctrl_c};

#[derive(clap::Args, Debug)]
pub struct ProbeArgs {
    /// A finished `revelio search` run folder
    pub run_dir: PathBuf,
    /// Sets to probe: the run's cores first (when it shrank), then the search's table in order
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..))]
    pub top: u64,
    /// Probe observations per set
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    pub samples: u32,
    /// Recognition rate at or above which a concept's failures are reasoning failures
    #[arg(long, default_value_t = 0.7)]
    pub high: f64,
    /// Recognition rate at or below which a concept's failures are recognition failures
    #[arg(long, default_value_t = 0.3)]
    pub low: f64,
    /// Probed sets each concept of a pair must appear in for the pair's lift to be reported
    #[arg(long, default_value_t = 10)]
    pub min_n: usize,
    #[command(flatten)]
    pub run: RunFlags,
    #[command(flatten)]
    pub model_opts: ModelFlags,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

/// `probe.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProbeReport {
    pub model: String,
    pub top: usize,
    pub samples: u32,
    /// The probed sets' safety failure rates (from the probe replies).
    pub sets: Vec<ProbedRow>,
    pub analysis: Analysis,
    /// Statements the replies left unmarked (never guessed).
    pub unanswered_statements: u32,
    pub spend: Spend,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProbedRow {
    pub concepts: Vec<String>,
    pub fr: Option<f64>,
    pub wrong: u32,
    pub answered: u32,
}

/// A finished run opened for more observations: its configuration, summary, domain, the
/// pipeline and the journal (locked).
pub(crate) struct OpenRun {
    pub config: RunConfig,
    pub summary: Summary,
    pub domain: Arc<Domain>,
    pub model: Arc<dyn Model>,
    pub reask: Reask,
}

/// Open `dir` as `validate` does: the recorded domain (unchanged), model (flags override the
/// recorded settings, the model must stay the same) and renderer.
pub(crate) fn open_run(dir: &Path, model_opts: &ModelFlags, run: &RunFlags, quiet: bool) -> Result<OpenRun, ExitCode> {
    let (config, summary) = runner::load_run(dir).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(e.exit_code())
    })?;
    let domain = crate::cli::load_domain(Path::new(&config.domain_file))?;
    let setup_error = |e: SetupError| {
        eprintln!("error: {e}");
        ExitCode::from(e.exit_code())
    };
    if domain.identity().to_string() != config.domain_hash {
        return Err(setup_error(SetupError::DomainChanged { file: config.domain_file.clone(), dir: dir.into() }));
    }
    let settings = model_opts.settings().or(&config.model_settings);
    let cache = model_opts.cache();
    let Parts { model, renderer, concurrency } = setup::build_parts(
        &domain,
        &config.model_spec,
        &config.renderer,
        &settings,
        cache.as_deref(),
        run.concurrency.map(|c| c as usize),
    )
    .map_err(setup_error)?;
    if model.id() != config.model {
        return Err(setup_error(SetupError::ModelChanged { now: model.id(), was: config.model.clone() }));
    }
    let journal = Journal::open(dir).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(1)
    })?;
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let domain = Arc::new(domain);
    let reask = Reask {
        observer: Arc::new(Observer::new(domain.clone(), world, renderer)),
        journal: Arc::new(journal),
        seed: config.params.seed,
        concurrency,
        stop: Stop::default(),
        progress: runner::cli_progress(quiet),
    };
    Ok(OpenRun { config, summary, domain, model, reask })
}

/// The `k` sets to probe: the run's distinct cores first (`summary.json`'s `cores`, when the
/// run shrank its failure modes), as they are what a failure mode comes down to, then its top
/// sets in the order of its table, each set once.
pub(crate) fn probe_order(domain: &Domain, summary: &Summary, k: usize) -> Result<Vec<ConceptSet>, RunError> {
    let mut sets = Vec::with_capacity(k);
    for core in &summary.cores {
        let set = domain.parse_set(&core.set.concepts).map_err(|e| RunError::Search(e.to_string()))?;
        if sets.len() < k && !sets.contains(&set) {
            sets.push(set);
        }
    }
    for set in top_sets(domain, summary, k)? {
        if sets.len() < k && !sets.contains(&set) {
            sets.push(set);
        }
    }
    Ok(sets)
}

/// The run's top `k` sets, in the order of its table.
pub(crate) fn top_sets(domain: &Domain, summary: &Summary, k: usize) -> Result<Vec<ConceptSet>, RunError> {
    let history = summary
        .sets
        .iter()
        .map(|row| {
            let set = domain.parse_set(&row.concepts).map_err(|e| RunError::Search(e.to_string()))?;
            let mut s = SetStats::new(set);
            s.wrong = row.wrong;
            s.correct = row.answered - row.wrong;
            s.unanswered = row.unanswered.clone();
            Ok(s)
        })
        .collect::<Result<Vec<_>, RunError>>()?;
    Ok(runner::top_sets(&history, k).into_iter().map(|s| s.set).collect())
}

/// Probe `sets` and analyse the replies.
pub async fn probe_sets(
    r: &Reask,
    model: Arc<dyn Model>,
    sets: &[ConceptSet],
    samples: u32,
    t: &Thresholds,
) -> Result<ProbeReport, RunError> {
    t.validate().map_err(RunError::Usage)?;
    let (probed, spend) = reask::probe(r, model.clone(), sets, samples).await?;
    let unanswered_statements = probed.iter().flat_map(|p| p.marks.values()).map(|m| m.unanswered).sum();
    Ok(ProbeReport {
        model: model.id(),
        top: sets.len(),
        samples,
        sets: probed
            .iter()
            .map(|p: &ProbedSet| ProbedRow {
                concepts: p.concepts.clone(),
                fr: p.fr(),
                wrong: p.wrong,
                answered: p.answered,
            })
            .collect(),
        analysis: analyse(&probed, t),
        unanswered_statements,
        spend,
    })
}

pub fn run(args: ProbeArgs) -> ExitCode {
    let t = Thresholds { high: args.high, low: args.low, min_n: args.min_n };
    if let Err(e) = t.validate() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let open = match open_run(&args.run_dir, &args.model_opts, &args.run, args.json) {
        Ok(o) => o,
        Err(code) => return code,
    };
    let sets = match probe_order(&open.domain, &open.summary, args.top as usize) {
        Ok(s) => s,
        Err(e) => return fail_run(&e, &args.run_dir),
    };
    let rt = runtime();
    watch_ctrl_c(&rt, &open.reask.stop);
    let report = match rt.block_on(probe_sets(&open.reask, open.model.clone(), &sets, args.samples, &t)) {
        Ok(r) => r,
        Err(e) => return fail_run(&e, &args.run_dir),
    };
    if let Err(e) = open.reask.journal.write_json("probe.json", &report) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &report).map_err(std::io::Error::from).and_then(|_| writeln!(out))
    } else {
        print_probe(&mut out, &report)
            .and_then(|()| writeln!(out, "written to {}", args.run_dir.join("probe.json").display()))
    };
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the report: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

fn pct(f: Option<f64>) -> String {
    f.map_or_else(|| "-".into(), |f| format!("{:.0}%", 100.0 * f))
}

pub fn print_probe(w: &mut impl Write, r: &ProbeReport) -> std::io::Result<()> {
    let a = &r.analysis;
    let width = a.concepts.iter().map(|c| c.concept.len()).max().unwrap_or(7).max(7);
    writeln!(
        w,
        "{} sets × {} probe observations on {}; mechanism: reasoning R ≥ {:.0}%, recognition R ≤ {:.0}%",
        r.top,
        r.samples,
        r.model,
        100.0 * a.thresholds.high,
        100.0 * a.thresholds.low
    )?;
    writeln!(w, "{:<width$}  {:>5}  {:>5}  {:>4}  mechanism", "concept", "R", "F", "n")?;
    for c in &a.concepts {
        writeln!(
            w,
            "{:<width$}  {:>5}  {:>5}  {:>4}  {}",
            c.concept,
            pct(c.recognition),
            pct(c.failure),
            c.n,
            c.mechanism.map_or("-", |m| m.name())
        )?;
    }
    if a.pairs.is_empty() {
        writeln!(w, "no concept pair has both concepts in ≥ {} probed sets (see `--min-n`)", a.thresholds.min_n)?;
    } else {
        writeln!(w, "pairs (both concepts in ≥ {} probed sets), largest |lift| first:", a.thresholds.min_n)?;
        writeln!(w, "{:>6}  {:>6}  {:>6}  {:>4}  pair", "joint", "indep.", "lift", "n")?;
        for p in &a.pairs {
            writeln!(
                w,
                "{:>6}  {:>6}  {:>+6.1}  {:>4}  {} + {}",
                pct(Some(p.joint)),
                pct(Some(p.independent)),
                100.0 * p.lift,
                p.n,
                p.a,
                p.b
            )?;
        }
    }
    if r.unanswered_statements > 0 {
        writeln!(
            w,
            "{} statements were left unmarked by the replies (counted as unanswered)",
            r.unanswered_statements
        )?;
    }
    writeln!(w, "spend: {}", r.spend.line())
}

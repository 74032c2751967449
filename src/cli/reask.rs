//! What `revelio probe` and `revelio transfer` share: opening a finished run for more
//! observations (the recorded domain, model and renderer, the journal locked), the sets they
//! ask again, running the asking with Ctrl-C watched, and finishing — the result file written,
//! the run report refreshed, the table (or JSON) printed.
use std::io::Write;
use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;

use crate::analysis::reask::Reask;
use crate::diag::TerminalSafe;
use crate::ir::{ConceptSet, Domain};
use crate::journal::Journal;
use crate::run::observe::{DomainWorld, Observer, World};
use crate::run::runner::{self};
use crate::run::setup::{self, Parts, SetupError};
use crate::run::summary;
use crate::run::summary::{RunConfig, Summary};
use crate::run::{RunError, Stop};
use crate::search::SetStats;
use crate::vlm::Model;

use super::common::{ModelFlags, RunFlags, fail_run, runtime, watch_ctrl_c};

/// A finished run opened for more observations: its configuration, summary, domain, the
/// pipeline and the journal (locked).
pub(crate) struct OpenRun {
    pub config: RunConfig,
    pub summary: Summary,
    pub domain: Arc<Domain>,
    pub model: Arc<dyn Model>,
    pub reask: Reask,
}

/// A finished run's configuration, domain, model and renderer, before its journal is opened (a
/// dry run stops here: nothing is written); [`RunParts::journal`] opens it.
pub(crate) struct RunParts {
    pub config: RunConfig,
    pub summary: Summary,
    pub domain: Domain,
    pub model: Arc<dyn Model>,
    renderer: Option<Arc<dyn crate::render::Renderer>>,
    concurrency: usize,
}

/// Open `dir` as `validate` does, but for the journal: the recorded domain (unchanged), model
/// and renderer, with where their requests go taken from `model_opts` and the environment only
/// (the model must stay the same, its endpoint too unless `--base-url` is given). `names`
/// spells the flags of `model_opts` in messages.
pub(crate) fn open_parts(
    dir: &Path,
    model_opts: &ModelFlags,
    names: setup::FlagNames,
    run: &RunFlags,
) -> Result<RunParts, ExitCode> {
    let (config, summary) = summary::load_run(dir).map_err(|e| {
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
    let mut settings = model_opts.settings().resume(&config.model_settings, names).map_err(setup_error)?;
    settings.batch = run.batch_api.then(|| dir.to_path_buf());
    settings.dry_run = run.dry_run;
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
        let was = crate::diag::terminal_safe(&config.model).into_owned();
        return Err(setup_error(SetupError::ModelChanged { now: model.id(), was }));
    }
    setup::check_endpoint(&settings, config.endpoint.as_deref(), model.as_ref(), names).map_err(setup_error)?;
    Ok(RunParts { config, summary, domain, model, renderer, concurrency })
}

impl RunParts {
    /// The run's oracle and sampler (a dry run reads its prompts).
    pub(crate) fn world(&self) -> DomainWorld {
        DomainWorld::new(&self.domain)
    }

    /// The image the run's renderer draws (`None`: no image).
    pub(crate) fn image_size(&self) -> Option<(u32, u32)> {
        crate::run::estimate::image_size(&self.config.renderer, &self.domain)
    }

    /// The journal opened (and locked): the run ready for more observations, under the spend
    /// cap of `--max-cost` with the folder's earlier spend counted in.
    pub(crate) fn journal(self, dir: &Path, run: &RunFlags, quiet: bool) -> Result<OpenRun, ExitCode> {
        let RunParts { config, summary, domain, model, renderer, concurrency } = self;
        let journal = Journal::open_with(dir, run.on_corrupt()).map_err(|e| {
            eprintln!("error: {e}");
            ExitCode::from(1)
        })?;
        if let Some(note) = journal.set_aside_note() {
            eprintln!("{note}");
        }
        let purse = run.purse();
        if let Some(p) = &purse {
            p.add_spent(runner::journal_spend(&journal));
        }
        let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
        let domain = Arc::new(domain);
        let reask = Reask {
            observer: Arc::new(Observer::new(domain.clone(), world, renderer).with_purse(purse)),
            journal: Arc::new(journal),
            seed: config.params.seed,
            concurrency,
            stop: Stop::default(),
            progress: runner::cli_progress(quiet),
        };
        Ok(OpenRun { config, summary, domain, model, reask })
    }
}

impl OpenRun {
    /// Run `asking` (journaling as it goes) with Ctrl-C watched; a failure is reported as
    /// `search` reports one (resumable runs say so).
    pub(crate) fn ask<T>(&self, dir: &Path, asking: impl Future<Output = Result<T, RunError>>) -> Result<T, ExitCode> {
        let rt = runtime();
        watch_ctrl_c(&rt, &self.reask.stop);
        rt.block_on(asking).map_err(|e| fail_run(&e, dir))
    }

    /// Write `result` to `dir/file`, refresh the run report (which shows it), and print it:
    /// as JSON with `json`, else by `print` followed by where it was written.
    pub(crate) fn finish<T: serde::Serialize>(
        &self,
        dir: &Path,
        file: &str,
        result: &T,
        json: bool,
        print: impl FnOnce(&mut TerminalSafe<&mut std::io::StdoutLock<'static>>) -> std::io::Result<()>,
    ) -> ExitCode {
        if let Err(e) = self.reask.journal.write_json(file, result) {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
        let mut out = std::io::stdout().lock();
        let written = if json {
            serde_json::to_writer_pretty(&mut out, result).map_err(std::io::Error::from).and_then(|_| writeln!(out))
        } else {
            let mut safe = TerminalSafe(&mut out);
            print(&mut safe).and_then(|()| writeln!(safe, "written to {}", dir.join(file).display()))
        };
        drop(out);
        if written.is_ok() {
            super::report::refresh(dir, &self.domain, json);
        }
        match written {
            Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
                eprintln!("error: cannot write the report: {e}");
                ExitCode::from(1)
            }
            _ => ExitCode::SUCCESS,
        }
    }
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

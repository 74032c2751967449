//! `revelio search FILE --model M …`: search a domain for failure modes of a model, into a
//! resumable run folder; prints the top failure modes (or `--json`).
//!
//! Exit codes: 0 done, 1 an error in the domain or the run (or a run whose share of failed model
//! calls reaches 10 %), 2 a usage error, 130 interrupted by Ctrl-C (the calls in flight are
//! journaled; the same command resumes).
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use crate::diag::TerminalSafe;
use crate::ir::ConceptSet;
use crate::lattice::Lattice;
use crate::run::RunError;
use crate::run::estimate::{self, Estimate};
use crate::run::observe::{DomainWorld, World};
use crate::run::runner::{self, Setup};
use crate::run::setup::{self, Parts, SetupError};
use crate::run::summary;
use crate::run::summary::{RunConfig, Summary};
use crate::search::gp::Kernel;
use crate::search::interval::pct;
use crate::search::{Algo, Params};

use super::common::{ModelFlags, RunFlags, SearchFlags, algo_parser, fail_run, fr_ci_text, runtime, watch_ctrl_c};

#[derive(clap::Args, Debug)]
pub struct SearchArgs {
    /// The domain file (`.rev`)
    pub file: PathBuf,
    /// The model: `sim:PROFILE.toml`, `openai:MODEL`, `anthropic:MODEL`, `gemini:MODEL`, `bedrock:MODEL_ID`
    #[arg(long)]
    pub model: String,
    /// The search: interact (every distinct failure mode once as its core, shrinking as it
    /// goes), or the paper's random, beam or gpts [default: interact]
    #[arg(long, value_parser = algo_parser())]
    pub algo: Option<Algo>,
    #[command(flatten)]
    pub search: SearchFlags,
    /// Sequential sampling: a set whose 95 % interval still straddles τ after m observations
    /// gets more, a batch at a time, up to M [default: m, the paper's fixed count]
    #[arg(long, value_name = "M")]
    pub max_samples: Option<u32>,
    /// The part of the budget set aside for shrinking failure modes to minimal cores (the
    /// paper's algorithms search with the rest; interact keeps it for confirming the minimal
    /// failure modes no core of its explains); 0 turns it off, the paper's setting
    /// [default: budget / 4]
    #[arg(long, value_name = "B")]
    pub shrink: Option<u64>,
    /// GPTS: inferences for the beam phase [default: half the search phase's budget]
    #[arg(long)]
    pub beam_budget: Option<u64>,
    /// The run's seed [default: 0]
    #[arg(long)]
    pub seed: Option<u64>,
    /// Most valid concept sets listed for a search; past it `interact` and `random` draw from the
    /// lattice, and `beam` and `gpts` are refused with the ways out
    #[arg(long, default_value_t = crate::lattice::DEFAULT_MAX_SETS)]
    pub max_sets: u64,
    #[command(flatten)]
    pub run: RunFlags,
    /// Run folder; running the same command again resumes it [default:
    /// runs/DOMAIN-MODEL-ALGO-sSEED, or an existing runs/DOMAIN-ALGO-sSEED of the same model]
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// `builtin` (wgpu), `none` (no image), `imagegen:gemini:MODEL`, `imagegen:openai:MODEL`
    /// [default: builtin]
    #[arg(long)]
    pub renderer: Option<String>,
    #[command(flatten)]
    pub model_opts: ModelFlags,
    /// Failure modes shown in the table
    #[arg(long, default_value_t = 10)]
    pub top: usize,
    /// Print the summary as JSON
    #[arg(long)]
    pub json: bool,
}

/// A search ready to run: its setup, configuration and search space, and what it would spend
/// (`--dry-run` prints it). `revelio campaign` prepares each of its cells this way.
pub(crate) struct Prepared {
    pub setup: Setup,
    pub config: RunConfig,
    /// Shared by the cells of a campaign that search one domain (a listed space is built once).
    pub space: Arc<crate::search::Space>,
    pub estimate: Estimate,
    /// The configuration an existing run folder recorded (a resume).
    pub previous: Option<RunConfig>,
}

/// The run folder a search writes to: `--out`, else `runs/DOMAIN-MODEL-ALGO-sSEED` (the model
/// as a campaign names it, [`crate::run::campaign::model_slug`]). A folder under the old default
/// name, `runs/DOMAIN-ALGO-sSEED`, that holds a run of the same model spec is still found, so an
/// old command resumes its run rather than starting a second paid one.
fn out_dir(args: &SearchArgs, domain: &crate::ir::Domain) -> PathBuf {
    if let Some(out) = &args.out {
        return out.clone();
    }
    let (algo, seed) = (args.algo.unwrap_or(Algo::Interact).name(), args.seed.unwrap_or(0));
    let model = crate::run::campaign::model_slug(&args.model);
    let new = PathBuf::from("runs").join(format!("{}-{model}-{algo}-s{seed}", domain.name));
    let old = PathBuf::from("runs").join(format!("{}-{algo}-s{seed}", domain.name));
    match summary::read_config(&old) {
        Ok(Some(c)) if !new.exists() && c.model_spec == args.model && c.domain == domain.name => old,
        _ => new,
    }
}

/// The space of the valid sets of `domain` up to `max_size` that have a ground truth, and how
/// many valid sets were left out for having none: enumerated, judged and indexed once per process
/// for each domain and limit. A campaign prepares many cells of one domain, on several threads at
/// once; judging and indexing every set is most of a cell's preparation, so the first cell of a
/// domain does it, the others wait for it and share the space it built.
fn listed_space(
    domain: &crate::ir::Domain,
    world: &dyn World,
    max_size: usize,
    max_sets: u64,
) -> Result<(Arc<crate::search::Space>, usize), ExitCode> {
    type Key = (String, usize, u64);
    type Listed = Arc<std::sync::OnceLock<Result<(Arc<crate::search::Space>, usize), String>>>;
    static SEEN: std::sync::OnceLock<std::sync::Mutex<std::collections::HashMap<Key, Listed>>> =
        std::sync::OnceLock::new();
    let key = (domain.identity().to_string(), max_size, max_sets);
    let once =
        SEEN.get_or_init(Default::default).lock().unwrap_or_else(|p| p.into_inner()).entry(key).or_default().clone();
    let listed = once.get_or_init(|| {
        let mut work = super::progress::Work::new();
        let lattice = Lattice::build(domain, max_size, max_sets, &mut |w, d, t| work.report(w, d, t))
            .map_err(|too_large| too_large.plain())?;
        let (space, dropped) = runner::search_space(lattice.sets, domain.concepts.len(), world);
        Ok((Arc::new(space), dropped))
    });
    listed.clone().map_err(|message| {
        eprintln!("{message}");
        ExitCode::from(1)
    })
}

/// A lattice past `--max-sets` (counted exactly by its diagram, not listed): a sampled space
/// for `interact` (its pattern surrogate) and `random`, which draw from it; for `beam`, `gpts` and
/// interact's regression surrogates, which score every listed set, the limit is theirs (R0070),
/// and the message names the algorithms that go beyond it. `None`: the lattice fits, list it.
fn search_space(
    domain: &crate::ir::Domain,
    world: &Arc<dyn World>,
    params: &Params,
    max_sets: u64,
) -> Result<Option<crate::search::Space>, ExitCode> {
    let validity = crate::lattice::Validity::new(domain);
    let diagram = crate::lattice::Diagram::build(&validity, params.max_size);
    let total = diagram.total();
    if total <= u128::from(max_sets) {
        return Ok(None);
    }
    let samples = params.algo == Algo::Random
        || (params.algo == Algo::Interact && params.surrogate == crate::search::interact::Surrogate::Patterns);
    if !samples {
        let what = match params.algo {
            Algo::Interact => format!("`--algo interact --surrogate {}`", params.surrogate.name()),
            algo => format!("`--algo {}`", algo.name()),
        };
        eprintln!(
            "error[{}]: {what} scores every valid set, and domain `{}` has {total} of up to {} concepts, more than `--max-sets` ({max_sets})\n  help: `--algo interact` (its default surrogate) and `--algo random` draw from a lattice of any size; or raise `--max-sets`, or add constraints",
            crate::diag::codes::LATTICE_TOO_LARGE,
            domain.name,
            params.max_size,
        );
        return Err(ExitCode::from(1));
    }
    let world = world.clone();
    let keep: crate::search::space::Keep = Arc::new(move |s| world.task(s).is_ok());
    Ok(Some(crate::search::Space::sampled(Arc::new(diagram), keep, domain.concepts.len())))
}

/// Everything a search does before its first model call: the domain compiled, the parameters
/// checked (a flag left out takes the value an existing run folder recorded, so the same command,
/// or a shorter one, never changes the plan of a run), the model and renderer built, the lattice
/// enumerated. Nothing is written.
pub(crate) fn prepare(args: &SearchArgs) -> Result<Prepared, ExitCode> {
    let domain = crate::cli::load_domain(&args.file)?;
    let out = out_dir(args, &domain);
    let previous = summary::read_config(&out).map_err(|e| fail(&e))?;
    let recorded = previous.as_ref().map(|p| &p.params);
    let renderer = args.renderer.clone().or(previous.as_ref().map(|p| p.renderer.clone())).unwrap_or("builtin".into());
    let algo = args.algo.or(recorded.map(|p| p.algo)).unwrap_or(Algo::Interact);
    let params = args.search.params(algo, recorded, 1);
    let shrink = args.shrink.or(recorded.map(|p| p.shrink)).unwrap_or_else(|| Params::default_shrink(params.budget));
    let mut params = Params {
        seed: args.seed.or(recorded.map(|p| p.seed)).unwrap_or(0),
        max_samples: args.max_samples.or(recorded.and_then(|p| p.max_samples)),
        shrink,
        ..params
    };
    params.beam_budget = args
        .beam_budget
        .or(recorded.map(|p| p.beam_budget))
        .unwrap_or(params.plan().search / 2)
        .min(params.plan().search);
    if let Err(e) = params.validate() {
        eprintln!("error: {e}");
        return Err(ExitCode::from(2));
    }
    if params.kernel != Kernel::Dot && params.algo != Algo::Gpts {
        eprintln!("error: invalid `--kernel`: the GP kernel is GPTS's; `--algo {}` has no GP", params.algo.name());
        return Err(ExitCode::from(2));
    }
    if args.run.batch_api && params.algo != Algo::Random {
        eprintln!(
            "error: `--batch-api` needs `--algo random`: `--algo {}` picks each set from the answers to the last, which a batch gives hours later",
            params.algo.name()
        );
        return Err(ExitCode::from(2));
    }
    let setup_error = |e: SetupError| {
        eprintln!("error: {e}");
        ExitCode::from(e.exit_code())
    };
    let mut settings = match &previous {
        Some(p) => args.model_opts.settings().resume(&p.model_settings, setup::FLAGS).map_err(setup_error)?,
        None => args.model_opts.settings(),
    };
    settings.batch = args.run.batch_api.then(|| out.clone());
    settings.dry_run = args.run.dry_run;
    let cache = args.model_opts.cache();
    let concurrency = args.run.concurrency.map(|c| c as usize);
    let Parts { model, renderer: renderer_parts, concurrency } =
        setup::build_parts(&domain, &args.model, &renderer, &settings, cache.as_deref(), concurrency)
            .map_err(setup_error)?;
    // Interact's width: the concurrency at the run's start, recorded so that a resume at another
    // concurrency replays the same decisions.
    if algo == Algo::Interact && args.search.batch.is_none() && recorded.is_none() {
        params.batch = concurrency;
    }
    if let Some(p) = &previous {
        setup::check_endpoint(&settings, p.endpoint.as_deref(), model.as_ref(), setup::FLAGS).map_err(setup_error)?;
    }
    let config = RunConfig::new(&domain, &args.file, &args.model, model.as_ref(), settings, &renderer, params);
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let (space, dropped) = match search_space(&domain, &world, &config.params, args.max_sets)? {
        Some(space) => (Arc::new(space), 0),
        None => listed_space(&domain, world.as_ref(), config.params.max_size, args.max_sets)?,
    };
    if dropped > 0 {
        eprintln!(
            "note: {dropped} valid sets have no determined ground truth and are not searched (see `revelio check`)"
        );
    }
    if space.total() == 0 {
        eprintln!("error: domain `{}` has no valid concept set with a ground truth to search", domain.name);
        return Err(ExitCode::from(1));
    }
    let drawn: Vec<ConceptSet> = if space.is_sampled() {
        let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(0);
        (0..64).filter_map(|_| space.draw(&mut rng)).collect()
    } else {
        Vec::new()
    };
    let prompts = estimate::sample_prompts(world.as_ref(), if space.is_sampled() { &drawn } else { &space.sets });
    let image = estimate::image_size(&renderer, &domain);
    // The budget caps every phase; a search may stop short of it.
    let estimate = Estimate::new("search", model.as_ref(), config.params.max_calls(), true, &prompts, image);
    let mut setup = Setup::new(Arc::new(domain), world, model, renderer_parts, out);
    setup.concurrency = concurrency;
    setup.progress = runner::cli_progress(args.json);
    setup.max_api_errors = args.run.max_api_errors;
    setup.on_corrupt = args.run.on_corrupt();
    setup.purse = args.run.purse();
    Ok(Prepared { setup, config, space, estimate, previous })
}

pub fn run(args: SearchArgs) -> ExitCode {
    let Prepared { setup, config, space, estimate, previous } = match prepare(&args) {
        Ok(p) => p,
        Err(code) => return code,
    };
    if args.run.dry_run {
        return args.run.print_dry_run(&[estimate], args.json);
    }
    let out = setup.out.clone();
    // Said before the first model call: what an old run's numbers mean now, and an extension.
    if let Some(p) = &previous {
        let notes = [runner::old_rule_note(&out, p), runner::extension_note(&out, p, &config.params)];
        notes.into_iter().flatten().for_each(|n| eprintln!("{}", crate::diag::terminal_safe(&n)));
    }
    let started = std::time::Instant::now();
    let rt = runtime();
    watch_ctrl_c(&rt, &setup.stop);
    let report = match rt.block_on(runner::search(&setup, &config, &space)) {
        Ok(r) => r,
        Err(e) => return fail_run(&e, &out),
    };
    if report.dropped_torn_line {
        eprintln!("note: dropped a torn last line of the journal (the previous run was killed mid-write)");
    }
    if report.replayed > 0 {
        eprintln!("resumed `{}`: {} observations replayed from the journal", out.display(), report.replayed);
    }
    let mut stdout = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut stdout, &report.summary)
            .map_err(std::io::Error::from)
            .and_then(|_| writeln!(stdout))
    } else {
        print_summary(&mut TerminalSafe(&mut stdout), &report.summary, args.top, &out, started.elapsed())
    };
    if written.is_ok() {
        super::report::refresh(&out, &setup.domain, args.json);
    }
    match written {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        Err(e) => {
            eprintln!("error: cannot write the summary: {e}");
            return ExitCode::from(1);
        }
    }
    let (errors, all) = report.summary.api_errors();
    match runner::api_error_warning(errors, all) {
        Some(w) => {
            eprintln!("error: {w}");
            ExitCode::from(1)
        }
        None => ExitCode::SUCCESS,
    }
}

fn fail(e: &RunError) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(e.exit_code())
}

/// Where the candidates came from, when some are failure modes no core explains:
/// `2 of them failure modes no core explained, 1 of those sent last as each shares a concept with
/// a stronger one, 1 of them failure modes of the search not shown minimal, sent last of all, 4
/// more the budget could not pay; `.
fn candidates_note(c: &crate::run::summary::ConfirmSummary) -> String {
    let mut parts = Vec::new();
    if c.unexplained > 0 {
        parts.push(format!("{} of them failure modes no core explained", c.unexplained));
    }
    if c.last > 0 {
        parts.push(format!("{} of those sent last as each shares a concept with a stronger one", c.last));
    }
    if c.unshrunk > 0 {
        parts.push(format!("{} of them failure modes of the search not shown minimal, sent last of all", c.unshrunk));
    }
    if c.shared > 0 {
        parts.push(format!("{} more left out as each shares a concept with a stronger one", c.shared));
    }
    if c.unpaid > 0 {
        parts.push(format!("{} more the budget could not pay", c.unpaid));
    }
    if parts.is_empty() { String::new() } else { format!("{}; ", parts.join(", ")) }
}

/// The human summary: metrics, then the distinct cores (with their supersets) and the failure
/// modes no core explains.
pub fn print_summary(
    w: &mut impl Write,
    s: &Summary,
    top: usize,
    out: &Path,
    elapsed: std::time::Duration,
) -> std::io::Result<()> {
    let m = &s.metrics;
    writeln!(
        w,
        "{} on `{}` with {}: {} sets ({} inferences) of {} valid, in {:.1}s",
        s.algo.name(),
        s.domain,
        s.model,
        m.sets,
        m.inferences,
        s.space,
        elapsed.as_secs_f64()
    )?;
    let div = m.div.map_or_else(|| "-".into(), |d| format!("{d:.2}"));
    writeln!(
        w,
        "PFM {:.1}%  MFR {:.1}%  Div {div}  ({} failure modes at FR ≥ {})",
        m.pfm, m.mfr, m.failure_modes, s.threshold
    )?;
    if !m.unanswered.is_empty() {
        let parts: Vec<String> = m.unanswered.iter().map(|(o, n)| format!("{n} {}", o.name())).collect();
        writeln!(w, "not answered (excluded from FR): {}", parts.join(", "))?;
    }
    if let Some(sh) = &s.shrink {
        writeln!(w, "{}", s.shrink_text(sh))?;
    }
    if let Some(c) = &s.confirmation {
        writeln!(
            w,
            "confirm: {} of {} candidate cores confirmed on fresh scenes at FDR q = {} ({}zone τ ± {}, up to {} observations each{}, {} inferences of {}){}",
            c.confirmed,
            c.candidates,
            c.q,
            candidates_note(c),
            c.delta,
            c.cap,
            match c.extended {
                0 => String::new(),
                n => format!(" ({n} with calls left)"),
            },
            c.inferences,
            c.budget,
            match s.borderline.len() {
                0 => String::new(),
                n => format!("; {n} borderline"),
            }
        )?;
    }
    if let Some(budget) = s.budget {
        writeln!(w, "budget: {}", s.budget_text(budget))?;
    }
    writeln!(w, "spend: {}", s.spend.line())?;
    if let Some(line) = crate::run::summary::repeated_line(&s.repeated_scenes) {
        writeln!(w, "{line}")?;
    }
    let refuted: Vec<&Vec<String>> = s.shrink.iter().flat_map(|sh| sh.refuted.iter().map(|r| &r.concepts)).collect();
    let flat: Vec<&crate::run::summary::NotDistinctRow> = s.shrink.iter().flat_map(|sh| &sh.not_distinct).collect();
    // Refuted and not-distinct failure modes are listed with their reason, not as loose ends.
    let rest: Vec<&crate::run::summary::SetRow> = s
        .failure_modes
        .iter()
        .filter(|r| r.core.is_none() && !refuted.contains(&&r.concepts))
        .filter(|r| !flat.iter().any(|f| f.set.concepts == r.concepts))
        .collect();
    if s.cores.is_empty() && s.failure_modes.is_empty() {
        writeln!(w, "no failure modes found")?;
    }
    if !s.cores.is_empty() {
        // With fresh confirmation: the confirmed FR and interval (the fresh observations alone)
        // first, the search's own evidence (which selected the core) beside it.
        let confirmed = s.confirmation.is_some();
        let (head, title) = match confirmed {
            true => (
                format!("{:<14}  {:>4}  {:<14}  {:>4}", "confirmed FR", "n", "search FR", "n"),
                "confirmed minimal failure modes (cores)",
            ),
            false => (format!("{:<14}  {:>4}", "FR [95% CI]", "n"), "minimal failure modes (cores)"),
        };
        writeln!(w)?;
        writeln!(w, "{:>4}  {head}  {:>9}  {title}", "#", "supersets")?;
        for (i, c) in s.cores.iter().take(top).enumerate() {
            let star = if c.minimal { "" } else { "  (not fully shrunk)" };
            let search = format!("{:<14}  {:>4}", fr_ci_text(c.set.fr, c.set.ci95), c.set.answered);
            let evidence = match (confirmed, &c.confirmed) {
                (false, _) => search,
                (true, Some(r)) => format!("{:<14}  {:>4}  {search}", fr_ci_text(r.fr, r.ci95), r.answered),
                (true, None) => format!("{:<14}  {:>4}  {search}", "–", 0),
            };
            let part = c.part.as_ref().map_or_else(String::new, |p| {
                format!("  (part {} alone: {} of {})", p.concepts.join(" + "), pct(p.fr), p.answered)
            });
            writeln!(w, "{:>4}  {evidence}  {:>9}  {}{star}{part}", i + 1, c.supersets, c.set.concepts.join(" + "))?;
        }
        if s.cores.len() > top {
            writeln!(w, "      … {} more cores in summary.json", s.cores.len() - top)?;
        }
    }
    if !s.borderline.is_empty() {
        writeln!(w)?;
        writeln!(
            w,
            "{:>4}  {:<14}  {:>4}  borderline: near τ after the confirmation cap, neither a core nor passing",
            "#", "FR [95% CI]", "n"
        )?;
        for (i, r) in s.borderline.iter().take(top).enumerate() {
            writeln!(
                w,
                "{:>4}  {:<14}  {:>4}  {}",
                i + 1,
                fr_ci_text(r.set.fr, r.set.ci95),
                r.set.answered,
                r.set.concepts.join(" + ")
            )?;
        }
        if s.borderline.len() > top {
            writeln!(w, "      … {} more in summary.json (`borderline`)", s.borderline.len() - top)?;
        }
    }
    if !rest.is_empty() {
        writeln!(w)?;
        let title = if s.cores.is_empty() { "failure modes" } else { "failure modes no core explains" };
        writeln!(w, "{:>4}  {:<14}  {:>4}  {title}", "#", "FR [95% CI]", "n")?;
        for (i, row) in rest.iter().take(top).enumerate() {
            writeln!(
                w,
                "{:>4}  {:<14}  {:>4}  {}",
                i + 1,
                fr_ci_text(row.fr, row.ci95),
                row.answered,
                row.concepts.join(" + ")
            )?;
        }
        if rest.len() > top {
            writeln!(w, "      … {} more in summary.json", rest.len() - top)?;
        }
    }
    if !flat.is_empty() {
        writeln!(w)?;
        writeln!(
            w,
            "{:>4}  {:<14}  {:>4}  failing sets no more likely to fail than a part that passes (not distinct)",
            "#", "FR [95% CI]", "n"
        )?;
        for (i, row) in flat.iter().take(top).enumerate() {
            writeln!(
                w,
                "{:>4}  {:<14}  {:>4}  {}  ≈  {} {} (n {})",
                i + 1,
                fr_ci_text(row.set.fr, row.set.ci95),
                row.set.answered,
                row.set.concepts.join(" + "),
                row.by.concepts.join(" + "),
                row.by.fr.map_or_else(|| "-".to_string(), |f| format!("{:.0}%", 100.0 * f)),
                row.by.answered
            )?;
        }
        if flat.len() > top {
            writeln!(w, "      … {} more in summary.json (`shrink.not_distinct`)", flat.len() - top)?;
        }
    }
    if !refuted.is_empty() {
        writeln!(
            w,
            "      ({} failure mode{} of the search failed less than τ when re-tested: `shrink.refuted` in summary.json)",
            refuted.len(),
            if refuted.len() == 1 { "" } else { "s" }
        )?;
    }
    writeln!(w)?;
    writeln!(
        w,
        "run folder: {} (journal.jsonl, summary.json; `revelio validate {}` re-checks the top sets)",
        out.display(),
        out.display()
    )
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use std::time::Duration;

    use super::*;
    use crate::outcome::Outcome;
    use crate::run::summary::{CoreRow, SetRow, ShrinkSummary};
    use crate::search::metrics::Metrics;

    fn row(concepts: &[&str], wrong: u32, answered: u32) -> SetRow {
        SetRow { observations: 5, ..SetRow::from_counts(concepts, wrong, answered) }
    }

    fn summary(failure_modes: Vec<SetRow>, cores: Vec<CoreRow>, shrink: Option<ShrinkSummary>) -> Summary {
        Summary {
            domain: "driving".into(),
            model: "sim:driving-paper@3daf41a26cd5".into(),
            algo: Algo::Gpts,
            threshold: 0.6,
            space: 115_144,
            metrics: Metrics {
                sets: 200,
                inferences: 1000,
                failures: 212,
                failure_modes: failure_modes.len(),
                pfm: 1.0,
                mfr: 21.2,
                div: Some(1.0),
                unanswered: BTreeMap::from([(Outcome::Unparsed, 1)]),
            },
            cores,
            sets: failure_modes.clone(),
            failure_modes,
            shrink,
            confirmation: None,
            borderline: vec![],
            budget: None,
            calls: None,
            spend: crate::run::summary::Spend {
                calls: 1000,
                cached: 12,
                input_tokens: 1_290_000,
                output_tokens: 262_000,
                thinking_tokens: 250_000,
                cost_usd: 1.43,
                ..Default::default()
            },
            repeated_scenes: Vec::new(),
        }
    }

    #[test]
    fn summary_table() {
        let modes = vec![row(&["debris_far", "town_town02"], 5, 5), row(&["obstruction_near", "light_green"], 3, 4)];
        let mut out = Vec::new();
        print_summary(&mut out, &summary(modes, vec![], None), 1, Path::new("runs/x"), Duration::from_millis(1500))
            .unwrap();
        insta::assert_snapshot!(String::from_utf8(out).unwrap());
    }

    #[test]
    fn summary_table_lists_cores_first_then_the_rest() {
        let in_core = |c: &[&str], w, n, core| SetRow { core: Some(core), ..row(c, w, n) };
        let modes = vec![
            in_core(&["light_green", "obstruction_near", "weather_wet"], 5, 5, 0),
            in_core(&["debris_far", "town_town02", "pedestrian"], 5, 5, 1),
            row(&["bus_stop", "cone"], 4, 5),
            in_core(&["light_green", "obstruction_near", "cyclist"], 4, 5, 0),
            row(&["chain_barrier_far", "far"], 3, 5),
            row(&["cone", "weather_foggy"], 3, 5),
        ];
        let core = |c: &[&str], w, n, supersets, minimal| CoreRow {
            set: SetRow { observations: n, ..row(c, w, n) },
            supersets,
            minimal,
            shrunk_from: vec![],
            confirmed: None,
            part: None,
        };
        let cores =
            vec![core(&["light_green", "obstruction_near"], 19, 20, 2, true), core(&["debris_far"], 7, 9, 1, false)];
        let shrink = ShrinkSummary {
            budget: 250,
            inferences: 243,
            max_samples: 20,
            new_sets: 9,
            refuted: vec![row(&["cone", "weather_foggy"], 4, 20)],
            not_distinct: vec![crate::run::summary::NotDistinctRow {
                set: row(&["bus_stop", "cone"], 24, 40),
                by: row(&["bus_stop"], 22, 40),
            }],
        };
        let mut out = Vec::new();
        let s = summary(modes, cores, Some(shrink));
        print_summary(&mut out, &s, 2, Path::new("runs/x"), Duration::from_millis(1500)).unwrap();
        insta::assert_snapshot!(String::from_utf8(out).unwrap());
    }

    #[test]
    fn summary_table_shows_confirmed_and_search_evidence_and_borderline_sets() {
        use crate::run::summary::{CheckedRow, ConfirmSummary};
        use crate::search::confirm::Status;
        let modes = vec![SetRow { core: Some(0), ..row(&["pedestrian", "weather_foggy"], 5, 5) }];
        let core = CoreRow {
            set: row(&["pedestrian", "weather_foggy"], 14, 15),
            supersets: 1,
            minimal: true,
            shrunk_from: vec![],
            confirmed: Some(row(&["pedestrian", "weather_foggy"], 15, 17)),
            part: Some(row(&["pedestrian"], 9, 18)),
        };
        let checked = |c: &[&str], w, n, status| CheckedRow { set: row(c, w, n), e_value: 1.0, status, triage: None };
        let rows = vec![
            checked(&["pedestrian", "weather_foggy"], 15, 17, Status::Confirmed),
            checked(&["cyclist", "light_red"], 22, 40, Status::Borderline),
            checked(&["cone"], 1, 10, Status::Passes),
        ];
        // The shrink line counts the shrink's own candidates: 3 sent less 1 unexplained and 1
        // sent last of all.
        let shrink = ShrinkSummary {
            budget: 250,
            inferences: 100,
            max_samples: 20,
            new_sets: 3,
            refuted: vec![],
            not_distinct: vec![],
        };
        let mut s = summary(modes, vec![core], Some(shrink));
        s.borderline = vec![rows[1].clone()];
        s.confirmation = Some(ConfirmSummary {
            q: 0.05,
            delta: 0.1,
            cap: 40,
            extended: 80,
            budget: 125,
            inferences: 67,
            candidates: 3,
            confirmed: 1,
            unexplained: 1,
            unpaid: 4,
            shared: 0,
            last: 1,
            unshrunk: 1,
            checked: rows,
        });
        let mut out = Vec::new();
        print_summary(&mut out, &s, 5, Path::new("runs/x"), Duration::from_millis(1500)).unwrap();
        insta::assert_snapshot!(String::from_utf8(out).unwrap());
    }
}

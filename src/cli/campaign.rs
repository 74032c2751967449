//! `revelio campaign FILE.toml [--shard I/N] [--dry-run] [--max-cost USD] [--concurrency C]`:
//! run a grid of searches (domains × models × algorithms × seeds, [`crate::run::campaign`]).
//! Every cell is prepared exactly as `revelio search` prepares a run (its flags are parsed by
//! the same definitions; the cells of one domain share its search space), then the cells run in
//! this process, up to `--concurrency` at once (each on a thread of its own), under one
//! concurrency limit and one spend cap. Each cell is an ordinary run folder under the file's
//! `out`, so the same command resumes, and `report`, `validate`, `compare` work on each. A cell
//! that fails, by an error or a panic, fails alone: the others go on. `--shard I/N` runs a
//! fixed, disjoint part of the cells (a Slurm job array, a Kubernetes Indexed Job:
//! `docs/campaigns.md`); a run without `--shard` whose cells are all finished writes
//! `index.html` and `compare.csv` into `out`.
//!
//! Exit codes: 0 every cell finished, 1 a cell failed (a panic included) or the spend cap
//! stopped the campaign (what was asked is journaled; a rerun with a larger cap resumes), 2 a
//! usage error, 130 interrupted.
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::{Arc, PoisonError};

use clap::Parser;

use crate::diag::terminal_safe;
use crate::run::campaign::{Campaign, Cell, Shard};
use crate::run::estimate::{Estimate, thousands, total_line};
use crate::run::progress::ProgressTo;
use crate::run::runner;
use crate::run::summary::Summary;
use crate::run::{RunError, Stop, StopReason};

use super::common::{parse_usd, runtime, write_stdout};
use super::search::{Prepared, prepare};

#[derive(clap::Args, Debug)]
pub struct CampaignArgs {
    /// The campaign file (TOML: out, budget, domains, models, algos, seeds; see
    /// `docs/campaigns.md`)
    pub file: PathBuf,
    /// Run only shard I of N (I from 0): a fixed, disjoint part of the cells
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Print each cell's model calls, tokens and dollars, and stop (nothing written, no call)
    #[arg(long)]
    pub dry_run: bool,
    /// Stop before the campaign's cells together spend more than this many US dollars (their
    /// earlier spend included)
    #[arg(long, value_name = "USD", value_parser = parse_usd)]
    pub max_cost: Option<f64>,
    /// Model calls in flight at once, over all cells
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..))]
    pub concurrency: u32,
    /// The reply and image cache shared by all runs [default: as for `search`]
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
    /// Do not use the reply and image cache
    #[arg(long)]
    pub no_cache: bool,
    /// Allow plain `http://` base URLs for a server other than this machine (as for `search`)
    #[arg(long)]
    pub allow_http: bool,
    /// Append a JSON line per HTTP attempt of every cell to FILE (as for `search`) [default:
    /// the `REVELIO_LOG` variable, else none]
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
}

/// The `search` arguments of one cell, parsed by `search`'s own definitions.
fn cell_args(args: &CampaignArgs, campaign: &Campaign, cell: &Cell) -> Result<super::search::SearchArgs, String> {
    let mut argv: Vec<String> = vec!["revelio".into(), "search".into()];
    argv.extend(campaign.search_args(cell));
    argv.extend(["--concurrency".into(), args.concurrency.to_string(), "--json".into()]);
    if let Some(d) = &args.cache_dir {
        argv.extend(["--cache-dir".into(), d.display().to_string()]);
    }
    if args.no_cache {
        argv.push("--no-cache".into());
    }
    if args.allow_http {
        argv.push("--allow-http".into());
    }
    // A dry run's cells build their models without keys: nothing is sent.
    if args.dry_run {
        argv.push("--dry-run".into());
    }
    match super::Cli::try_parse_from(&argv) {
        Ok(super::Cli { command: super::Command::Search(a) }) => Ok(*a),
        Ok(_) => unreachable!("the argument list starts with `search`"),
        Err(e) => Err(format!("cell `{}`: {}", cell.name, e.to_string().lines().next().unwrap_or_default())),
    }
}

pub fn run(args: CampaignArgs) -> ExitCode {
    run_with(&args, &search_cell, &|line| eprintln!("{line}"))
}

/// One cell's search, on the cell's own thread: a search's state is not `Send` (interact's
/// surrogate), so the thread drives it, while its observations, model calls and timers run on
/// the shared runtime's workers.
type SearchCell<'a> = dyn Fn(&tokio::runtime::Handle, &Prepared) -> Result<Summary, RunError> + Sync + 'a;

/// Where the campaign's own lines go: stderr (a test collects them).
type Say<'a> = dyn Fn(&str) + Sync + 'a;

fn search_cell(rt: &tokio::runtime::Handle, p: &Prepared) -> Result<Summary, RunError> {
    let local = tokio::task::LocalSet::new();
    rt.block_on(local.run_until(runner::search(&p.setup, &p.config, &p.space))).map(|r| r.summary)
}

/// Why a cell did not finish.
enum Failed {
    Run(RunError),
    /// A panic in the cell (a bug): the other cells go on, and the cell's folder holds every
    /// observation journaled before it, so the same command resumes it.
    Panicked(String),
}

impl Failed {
    fn resumable(&self) -> bool {
        match self {
            Failed::Run(e) => e.resumable(),
            Failed::Panicked(_) => true,
        }
    }

    fn exit_code(&self) -> u8 {
        match self {
            Failed::Run(e) => e.exit_code(),
            Failed::Panicked(_) => 1,
        }
    }
}

impl std::fmt::Display for Failed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failed::Run(e) => e.fmt(f),
            Failed::Panicked(m) => write!(f, "the cell's search panicked (a bug in revelio; please report it): {m}"),
        }
    }
}

fn run_with(args: &CampaignArgs, search: &SearchCell<'_>, say: &Say<'_>) -> ExitCode {
    let text = match crate::journal::safe::read_text(&args.file, 1 << 20) {
        Ok(t) => t,
        Err(e) => {
            say(&format!("error: cannot read `{}`: {}", args.file.display(), crate::journal::io_message(&e)));
            return ExitCode::from(1);
        }
    };
    let campaign = match Campaign::parse(&text, &args.file.display().to_string()) {
        Ok(c) => c,
        Err(e) => {
            say(&format!("error: {e}"));
            return ExitCode::from(1);
        }
    };
    let cells = campaign.shard(args.shard);
    let mut prepared = match prepare_cells(args, &campaign, &cells, say) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let scope = match args.shard {
        Some(s) => format!("shard {}/{}: {} of {} cells", s.index, s.count, cells.len(), campaign.cells().len()),
        None => format!("{} cells", cells.len()),
    };
    if args.dry_run {
        let all: Vec<Estimate> = prepared.iter().map(|(_, p)| p.estimate.clone()).collect();
        let mut text = format!("campaign `{}`, {scope}\n", args.file.display());
        for e in &all {
            text.push_str(&terminal_safe(&e.line()));
            text.push('\n');
        }
        text.push_str(&total_line(&all));
        text.push('\n');
        write_stdout(&text);
        return ExitCode::SUCCESS;
    }
    say(&format!("campaign `{}`: {scope}, concurrency {} over all cells", args.file.display(), args.concurrency));
    let gate = Arc::new(tokio::sync::Semaphore::new(args.concurrency as usize));
    let purse = args.max_cost.map(|cap| Arc::new(crate::vlm::cost::Purse::new(cap, 0.0)));
    let stop = Stop::default();
    let rt = runtime();
    super::common::watch_ctrl_c(&rt, &stop);
    for (_, p) in &mut prepared {
        p.setup.gate = Some(gate.clone());
        p.setup.purse = purse.clone();
        p.setup.stop = stop.clone();
        p.setup.progress = ProgressTo::Off;
    }
    // More cells at once than calls in flight would only wait on the gate.
    let handle = rt.handle().clone();
    let results = each(prepared, args.concurrency as usize, &|(cell, p): (Cell, Prepared)| {
        run_cell(&handle, &cell, &p, search, say)
    });
    let mut failed: Vec<(&Cell, Failed)> = Vec::new();
    for (cell, result) in cells.iter().zip(results) {
        match result {
            Ok(Ok(())) => {}
            Ok(Err(e)) => failed.push((cell, e)),
            // `run_cell` catches its search's panics; this is one in its own lines.
            Err(panic) => {
                let e = Failed::Panicked(panic);
                say(&format!("{}: error: {}", cell.name, terminal_safe(&e.to_string())));
                failed.push((cell, e));
            }
        }
    }
    if let Some(p) = &purse {
        say(&format!("campaign spend: ${:.4} of `--max-cost {}`", p.spent(), p.cap()));
    }
    if !failed.is_empty() {
        let names: Vec<&str> = failed.iter().map(|(c, _)| c.name.as_str()).collect();
        say(&format!(
            "error: {} of {} cells did not finish ({}){}",
            failed.len(),
            cells.len(),
            names.join(", "),
            if failed.iter().all(|(_, e)| e.resumable()) {
                "; their folders hold every finished observation and the same command resumes them"
            } else {
                ""
            }
        ));
        if failed.iter().any(|(_, e)| matches!(e, Failed::Run(RunError::Stopped(StopReason::CostCap { .. })))) {
            say("note: the spend cap stopped the campaign; rerun with a larger `--max-cost` to go on");
        }
        return ExitCode::from(if failed.iter().all(|(_, e)| e.exit_code() == 130) { 130 } else { 1 });
    }
    if args.shard.is_some() {
        say(&format!(
            "shard done; once every shard is, `revelio campaign {}` (no `--shard`) writes the comparison",
            args.file.display()
        ));
        return ExitCode::SUCCESS;
    }
    match write_comparison(&campaign.out, &cells) {
        Ok(index) => {
            write_stdout(&format!("comparison: {}\n", index.display()));
            ExitCode::SUCCESS
        }
        Err(e) => {
            say(&format!("error: {e}"));
            ExitCode::from(1)
        }
    }
}

/// Every cell prepared as `revelio search` prepares a run. The first cell of each domain and of
/// each model is prepared first, one after another: a domain or model that cannot start is said
/// once, and the first cell of a domain builds the space its other cells share (judging every
/// valid set, most of a cell's preparation). The other cells follow on as many threads as this
/// machine has cores. A cell that cannot start stops the campaign before any model call, so a
/// typo in one model spec spends nothing.
fn prepare_cells(
    args: &CampaignArgs,
    campaign: &Campaign,
    cells: &[Cell],
    say: &Say<'_>,
) -> Result<Vec<(Cell, Prepared)>, ExitCode> {
    let (mut first, mut rest) = (Vec::new(), Vec::new());
    let (mut domains, mut models) = (std::collections::HashSet::new(), std::collections::HashSet::new());
    for cell in cells {
        match cell_args(args, campaign, cell) {
            Ok(a) => {
                let new = domains.insert(&cell.domain) | models.insert(&cell.model);
                if new { &mut first } else { &mut rest }.push((cell.clone(), a));
            }
            Err(e) => {
                say(&format!("error: {e}"));
                return Err(ExitCode::from(2));
            }
        }
    }
    let prepare_one = |(cell, a): (Cell, super::search::SearchArgs)| {
        prepare(&a).map(|mut p| {
            p.estimate.what = cell.name.clone();
            (cell, p)
        })
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut out = Vec::with_capacity(cells.len());
    for (batch, workers) in [(first, 1), (rest, cores)] {
        let names: Vec<String> = batch.iter().map(|(c, _)| c.name.clone()).collect();
        for (name, p) in names.into_iter().zip(each(batch, workers, &prepare_one)) {
            match p {
                Ok(Ok(p)) => out.push(p),
                Ok(Err(code)) => {
                    say(&format!("error: cell `{name}` cannot start (above)"));
                    return Err(code);
                }
                Err(panic) => {
                    say(&format!(
                        "error: cell `{name}` cannot start: its preparation panicked (a bug in revelio): {}",
                        terminal_safe(&panic)
                    ));
                    return Err(ExitCode::from(1));
                }
            }
        }
    }
    // In the file's order, as the cells are run and reported.
    out.sort_by_key(|(c, _)| cells.iter().position(|d| d.name == c.name));
    Ok(out)
}

/// Run one prepared cell on this thread and say how it ended; a finished cell's report is
/// written here, while the other cells go on. A panic in the search is the cell's failure, not
/// the campaign's: the other cells go on, and what the cell journaled stays for a rerun.
fn run_cell(
    rt: &tokio::runtime::Handle,
    cell: &Cell,
    p: &Prepared,
    search: &SearchCell<'_>,
    say: &Say<'_>,
) -> Result<(), Failed> {
    let ran = match caught(|| search(rt, p)) {
        Ok(r) => r.map_err(Failed::Run),
        Err(panic) => Err(Failed::Panicked(panic)),
    };
    match &ran {
        Ok(s) => {
            say(&format!(
                "{}: {} calls, ${:.4}, {} cores, {} failure modes",
                cell.name,
                thousands(s.spend.calls),
                s.spend.cost_usd,
                s.cores.len(),
                s.failure_modes.len()
            ));
            super::report::refresh(&p.setup.out, &p.setup.domain, true);
        }
        Err(e) => {
            say(&format!("{}: error: {}", cell.name, terminal_safe(&e.to_string())));
            let note = match e {
                Failed::Run(e) => e,
                Failed::Panicked(_) => &RunError::Search(e.to_string()),
            };
            super::common::record_stop(note, &p.setup.out);
        }
    }
    ran.map(drop)
}

/// `work` on every item, on up to `workers` threads at once (an item's work on one thread), the
/// results in the items' order. A panic in one item's work is that item's `Err` (the panic's
/// message) and the other items go on.
fn each<T: Send, R: Send>(items: Vec<T>, workers: usize, work: &(dyn Fn(T) -> R + Sync)) -> Vec<Result<R, String>> {
    let n = items.len();
    let queue = std::sync::Mutex::new(items.into_iter().enumerate());
    let done = std::sync::Mutex::new(Vec::with_capacity(n));
    std::thread::scope(|scope| {
        for _ in 0..workers.clamp(1, n.max(1)) {
            scope.spawn(|| {
                loop {
                    let next = queue.lock().unwrap_or_else(PoisonError::into_inner).next();
                    let Some((i, item)) = next else { break };
                    let r = caught(|| work(item));
                    done.lock().unwrap_or_else(PoisonError::into_inner).push((i, r));
                }
            });
        }
    });
    let mut out = done.into_inner().unwrap_or_else(PoisonError::into_inner);
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, r)| r).collect()
}

/// `f()`, or the message of the panic that ended it (the panic hook has printed where).
fn caught<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".into())
    })
}

/// `index.html` (the comparison table, spend per model, a link to every cell's report) and
/// `compare.csv` in the campaign folder.
fn write_comparison(out: &Path, cells: &[Cell]) -> Result<PathBuf, String> {
    let dirs: Vec<PathBuf> = cells.iter().map(|c| out.join(&c.name)).collect();
    let rows = super::compare::rows(&dirs).map_err(|e| e.to_string())?;
    let write = |name: &str, text: String| {
        let p = out.join(name);
        std::fs::write(&p, text)
            .map_err(|e| format!("cannot write `{}`: {}", p.display(), e.to_string().to_lowercase()))?;
        Ok::<PathBuf, String>(p)
    };
    write("compare.csv", super::compare::csv(&rows))?;
    write("index.html", super::compare::html_in(&rows, out, "Campaign"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::observe::{Task, World};
    use std::sync::Mutex;

    #[test]
    fn a_panic_in_one_items_work_is_that_items_error() {
        let work = |i: u32| if i == 2 { panic!("item {i} broke") } else { i * 10 };
        let r = each((0..6).collect(), 3, &work);
        assert_eq!(r[2], Err("item 2 broke".to_string()));
        let ok: Vec<u32> = r.iter().filter_map(|r| r.as_ref().ok().copied()).collect();
        assert_eq!(ok, [0, 10, 30, 40, 50], "the other items ran, in order");
    }

    /// The domain's world, except that the search panics (a bug) at the first task it asks for
    /// once the run folder `out` journaled an observation: in the middle of the search (interact asks for the
    /// tasks of one batch of sets at a time), with the run folder open.
    struct PanicsLater {
        world: Arc<dyn World>,
        out: PathBuf,
    }

    impl World for PanicsLater {
        fn task(&self, set: crate::ir::ConceptSet) -> Result<Task, String> {
            if journal_lines(&self.out) > 0 {
                panic!("a bug in the middle of the search");
            }
            self.world.task(set)
        }
        fn scene(&self, set: crate::ir::ConceptSet, seed: u64) -> Result<crate::scene::Scene, String> {
            self.world.scene(set, seed)
        }
    }

    const BROKEN: &str = "driving-sim-driving_paper-interact-s0";

    /// `search_cell`, except that cell `BROKEN`'s search panics midway.
    fn broken_search(rt: &tokio::runtime::Handle, p: &Prepared) -> Result<Summary, RunError> {
        if !p.setup.out.ends_with(BROKEN) {
            return search_cell(rt, p);
        }
        let world = Arc::new(PanicsLater { world: p.setup.world.clone(), out: p.setup.out.clone() });
        let s = &p.setup;
        let mut setup = runner::Setup::new(s.domain.clone(), world, s.model.clone(), s.renderer.clone(), s.out.clone());
        (setup.concurrency, setup.gate, setup.purse, setup.stop) =
            (s.concurrency, s.gate.clone(), s.purse.clone(), s.stop.clone());
        let local = tokio::task::LocalSet::new();
        rt.block_on(local.run_until(runner::search(&setup, &p.config, &p.space))).map(|r| r.summary)
    }

    fn args(file: &Path) -> CampaignArgs {
        CampaignArgs {
            file: file.to_path_buf(),
            shard: None,
            dry_run: false,
            max_cost: None,
            concurrency: 2,
            cache_dir: None,
            no_cache: true,
            allow_http: false,
            log: None,
        }
    }

    fn campaign(out: &Path) -> PathBuf {
        let file = out.with_extension("toml");
        let text = format!(
            "out = {:?}\nbudget = 40\nsamples = 2\nrenderer = \"none\"\ndomains = [\"domains/driving.rev\"]\nmodels = [\"sim:examples/sim/driving_paper.toml\"]\nalgos = [\"interact\", \"beam\"]\n",
            out.display().to_string()
        );
        std::fs::write(&file, text).unwrap();
        file
    }

    fn run_collecting(file: &Path, search: &SearchCell<'_>) -> (ExitCode, String) {
        let lines = Mutex::new(Vec::<String>::new());
        let code = run_with(&args(file), search, &|l| lines.lock().unwrap().push(l.to_string()));
        (code, lines.into_inner().unwrap().join("\n"))
    }

    fn journal_lines(dir: &Path) -> usize {
        std::fs::read_to_string(dir.join("journal.jsonl")).map_or(0, |t| t.lines().count())
    }

    /// A cell whose search panics is that cell's failure: the other cell finishes, the campaign
    /// names the failed cell and the panic's message and exits 1, and the same command resumes
    /// the cell from its journal to the result an unbroken campaign gets.
    #[test]
    fn a_panicking_cell_fails_alone_and_the_same_command_resumes_it() {
        let tmp = tempfile::tempdir().unwrap();
        let (out, clean) = (tmp.path().join("grid"), tmp.path().join("clean"));
        let (file, clean_file) = (campaign(&out), campaign(&clean));
        let (code, said) = run_collecting(&file, &broken_search);
        assert_eq!(code, ExitCode::from(1), "{said}");
        assert!(
            said.contains(&format!(
                "{BROKEN}: error: the cell's search panicked (a bug in revelio; please report it): a bug in the middle of the search"
            )),
            "{said}"
        );
        assert!(said.contains(&format!("error: 1 of 2 cells did not finish ({BROKEN}); their folders hold")), "{said}");
        assert!(out.join("driving-sim-driving_paper-beam-s0/summary.json").is_file(), "the other cell finished");
        assert!(!out.join(BROKEN).join("summary.json").exists());
        let before = journal_lines(&out.join(BROKEN));
        assert!(before > 0, "the broken cell journaled observations before its panic");
        let stopped = std::fs::read_to_string(out.join(BROKEN).join(super::super::common::STOPPED_FILE)).unwrap();
        assert!(stopped.contains("a bug in the middle of the search"), "{stopped}");

        let (code, said) = run_collecting(&file, &search_cell);
        assert_eq!(code, ExitCode::SUCCESS, "{said}");
        assert!(journal_lines(&out.join(BROKEN)) > before, "the rerun went on from the journal");
        let (code, said) = run_collecting(&clean_file, &search_cell);
        assert_eq!(code, ExitCode::SUCCESS, "{said}");
        for cell in [BROKEN, "driving-sim-driving_paper-beam-s0"] {
            let read = |d: &Path| std::fs::read_to_string(d.join(cell).join("summary.json")).unwrap();
            assert_eq!(read(&out), read(&clean), "{cell}");
            assert_eq!(journal_lines(&out.join(cell)), journal_lines(&clean.join(cell)), "{cell}");
        }
    }
}

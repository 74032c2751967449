//! `revelio campaign FILE.toml [--shard I/N] [--dry-run] [--max-cost USD] [--concurrency C]`:
//! run a grid of searches (domains × models × algorithms × seeds, [`crate::run::campaign`]).
//! Every cell is prepared exactly as `revelio search` prepares a run (its flags are parsed by
//! the same definitions), then the cells run in this process, up to `--concurrency` at once
//! (each on a thread of its own), under one concurrency limit and one spend cap. Each cell is an
//! ordinary run folder under the file's `out`, so the same command resumes, and `report`,
//! `validate`, `compare` work on each. `--shard I/N` runs a
//! fixed, disjoint part of the cells (a Slurm job array, a Kubernetes Indexed Job:
//! `docs/campaigns.md`); a run without `--shard` whose cells are all finished writes
//! `index.html` and `compare.csv` into `out`.
//!
//! Exit codes: 0 every cell finished, 1 a cell failed or the spend cap stopped the campaign
//! (what was asked is journaled; a rerun with a larger cap resumes), 2 a usage error, 130
//! interrupted.
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

use clap::Parser;

use crate::diag::terminal_safe;
use crate::run::campaign::{Campaign, Cell, Shard};
use crate::run::estimate::{Estimate, thousands, total_line};
use crate::run::progress::ProgressTo;
use crate::run::runner;
use crate::run::{RunError, Stop};

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
    let text = match crate::journal::safe::read_text(&args.file, 1 << 20) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: cannot read `{}`: {}", args.file.display(), crate::journal::io_message(&e));
            return ExitCode::from(1);
        }
    };
    let campaign = match Campaign::parse(&text, &args.file.display().to_string()) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let cells = campaign.shard(args.shard);
    let mut prepared: Vec<(Cell, Prepared)> = Vec::with_capacity(cells.len());
    for cell in &cells {
        let a = match cell_args(&args, &campaign, cell) {
            Ok(a) => a,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        };
        match prepare(&a) {
            Ok(mut p) => {
                p.estimate.what = cell.name.clone();
                prepared.push((cell.clone(), p));
            }
            Err(code) => {
                eprintln!("error: cell `{}` cannot start (above)", cell.name);
                return code;
            }
        }
    }
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
    eprintln!("campaign `{}`: {scope}, concurrency {} over all cells", args.file.display(), args.concurrency);
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
    let results = run_cells(&rt, prepared, args.concurrency as usize);
    let mut failed: Vec<(String, RunError)> = Vec::new();
    for (_, cell, setup, result) in results {
        match result {
            Ok(s) => {
                eprintln!(
                    "{}: {} calls, ${:.4}, {} cores, {} failure modes",
                    cell.name,
                    thousands(s.spend.calls),
                    s.spend.cost_usd,
                    s.cores.len(),
                    s.failure_modes.len()
                );
                super::report::refresh(&setup.out, &setup.domain, true);
            }
            Err(e) => {
                eprintln!("{}: error: {}", cell.name, terminal_safe(&e.to_string()));
                super::common::record_stop(&e, &setup.out);
                failed.push((cell.name, e));
            }
        }
    }
    if let Some(p) = &purse {
        eprintln!("campaign spend: ${:.4} of `--max-cost {}`", p.spent(), p.cap());
    }
    if let Some((_, e)) = failed.first() {
        let resumable = failed.iter().all(|(_, e)| e.resumable());
        eprintln!(
            "error: {} of {} cells did not finish{}",
            failed.len(),
            cells.len(),
            if resumable {
                "; their folders hold every finished observation and the same command resumes them"
            } else {
                ""
            }
        );
        if matches!(e, RunError::Stopped(crate::run::StopReason::CostCap { .. })) {
            eprintln!("note: the spend cap stopped the campaign; rerun with a larger `--max-cost` to go on");
        }
        return ExitCode::from(if failed.iter().all(|(_, e)| e.exit_code() == 130) { 130 } else { 1 });
    }
    if args.shard.is_some() {
        eprintln!(
            "shard done; once every shard is, `revelio campaign {}` (no `--shard`) writes the comparison",
            args.file.display()
        );
        return ExitCode::SUCCESS;
    }
    match write_comparison(&campaign.out, &cells) {
        Ok(index) => {
            write_stdout(&format!("comparison: {}\n", index.display()));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// What one cell's search came to.
type Ran = (usize, Cell, crate::run::runner::Setup, Result<crate::run::summary::Summary, RunError>);

/// Run the cells, at most `concurrency` at once, each on a thread of its own, and return their
/// results in the file's order.
///
/// A search's state is not `Send` (interact's surrogate), so a cell's search is driven on the
/// thread that started it; its observations, model calls and timers run on the shared runtime's
/// workers. All cells on one thread made every search step (a surrogate fit, a journal sync)
/// wait for every other cell's: with a slow model that thread, not the concurrency limit, set
/// how long a campaign took. More threads than calls in flight would only wait on the gate.
fn run_cells(rt: &tokio::runtime::Runtime, prepared: Vec<(Cell, Prepared)>, concurrency: usize) -> Vec<Ran> {
    let workers = prepared.len().min(concurrency.max(1));
    let queue = std::sync::Mutex::new(prepared.into_iter().enumerate().collect::<std::collections::VecDeque<_>>());
    let done = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            let (queue, done, handle) = (&queue, &done, rt.handle().clone());
            scope.spawn(move || {
                loop {
                    let next = queue.lock().unwrap_or_else(|p| p.into_inner()).pop_front();
                    let Some((i, (cell, p))) = next else { break };
                    let local = tokio::task::LocalSet::new();
                    let r = handle.block_on(local.run_until(runner::search(&p.setup, &p.config, &p.space)));
                    done.lock().unwrap_or_else(|p| p.into_inner()).push((i, cell, p.setup, r.map(|r| r.summary)));
                }
            });
        }
    });
    let mut out = done.into_inner().unwrap_or_else(|p| p.into_inner());
    out.sort_by_key(|(i, ..)| *i);
    out
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

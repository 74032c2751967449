//! `revelio runs [DIR]`: every run folder under DIR (default `runs`), with its state — running
//! (a process holds its lock), finished (it has a `summary.json`), stopped and why (the last
//! command's `stopped.json`), or incomplete (killed before it could say) — and its domain,
//! model, algorithm, budget, seed, model calls, spend and cores. Calls and spend are the
//! journal's, every command on the folder included; cores as `compare` counts them.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde::Serialize;

use crate::diag::terminal_safe;
use crate::run::estimate::thousands;
use crate::run::summary::{self, Summary};

#[derive(clap::Args, Debug)]
pub struct RunsArgs {
    /// The folder to look in (run folders are found up to three levels down)
    #[arg(default_value = "runs")]
    pub dir: PathBuf,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

/// One run folder's line.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RunLine {
    pub run: String,
    /// `running`, `finished`, `stopped: WHY`, `incomplete`, or `unreadable: WHY`.
    pub state: String,
    pub domain: String,
    pub model: String,
    pub algo: String,
    /// The run's total budget of observations, its shrink share included (run format 3's
    /// `--budget`; a format 2 run's reads as its `--budget` plus its `--shrink`).
    pub budget: u64,
    /// The share of `budget` set aside for shrinking.
    pub shrink: u64,
    /// The run folder's format ([`summary::RUN_FORMAT`] for runs written now).
    pub format: u64,
    pub seed: u64,
    pub calls: u64,
    pub cost_usd: f64,
    /// `None` before the run finished.
    pub cores: Option<usize>,
}

/// Folders under `dir` (itself included) that hold a `config.json`, up to `depth` levels down.
fn run_folders(dir: &Path, depth: usize, out: &mut Vec<PathBuf>) {
    if dir.join("config.json").is_file() {
        out.push(dir.to_path_buf());
        return;
    }
    if depth == 0 {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut dirs: Vec<PathBuf> =
        entries.filter_map(Result::ok).filter(|e| e.file_type().is_ok_and(|t| t.is_dir())).map(|e| e.path()).collect();
    dirs.sort();
    for d in dirs {
        run_folders(&d, depth - 1, out);
    }
}

fn stopped_reason(dir: &Path) -> Option<String> {
    let text = crate::journal::safe::read_text(&dir.join(super::common::STOPPED_FILE), 1 << 16).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["reason"].as_str().map(String::from)
}

/// The line of one run folder.
pub fn line(dir: &Path) -> RunLine {
    let run = dir.display().to_string();
    let config = match summary::read_config(dir) {
        Ok(Some(c)) => c,
        Ok(None) => unreachable!("listed folders hold a config.json"),
        Err(e) => {
            return RunLine {
                run,
                state: format!("unreadable: {e}"),
                domain: String::new(),
                model: String::new(),
                algo: String::new(),
                budget: 0,
                shrink: 0,
                format: 0,
                seed: 0,
                calls: 0,
                cost_usd: 0.0,
                cores: None,
            };
        }
    };
    let finished: Option<Summary> = summary::load_run(dir).ok().map(|(_, s)| s);
    let records = crate::journal::read(dir).unwrap_or_default();
    let calls = records.iter().filter(|r| r.outcome.asked_a_model() && !r.cached).count() as u64;
    let cost_usd = records.iter().filter(|r| !r.cached).map(|r| r.usage.cost_usd).sum();
    let state = if crate::journal::lock::held(dir) {
        "running".to_string()
    } else if let Some(why) = stopped_reason(dir) {
        format!("stopped: {why}")
    } else if finished.is_some() {
        "finished".to_string()
    } else {
        "incomplete: no summary (killed, or still starting)".to_string()
    };
    let cores = finished.as_ref().map(|s| match &s.shrink {
        Some(_) => s.cores.len(),
        None => {
            crate::analysis::compare::cores(&s.failure_modes.iter().map(|r| r.concepts.clone()).collect::<Vec<_>>())
        }
    });
    RunLine {
        run,
        state,
        domain: config.domain.clone(),
        model: config.model.clone(),
        algo: config.params.algo.name().to_string(),
        budget: config.params.budget,
        shrink: config.params.shrink,
        format: config.format,
        seed: config.params.seed,
        calls,
        cost_usd,
        cores,
    }
}

pub fn run(args: RunsArgs) -> ExitCode {
    if !args.dir.is_dir() {
        eprintln!("error: `{}` is not a folder", args.dir.display());
        return ExitCode::from(1);
    }
    let mut dirs = Vec::new();
    run_folders(&args.dir, 3, &mut dirs);
    let lines: Vec<RunLine> = dirs.iter().map(|d| line(d)).collect();
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &lines).map_err(std::io::Error::from).and_then(|_| writeln!(out))
    } else {
        print(&mut out, &lines)
    };
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the list: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

/// The table; names come from run folders, so each is escaped before it is printed.
pub fn print(w: &mut impl Write, lines: &[RunLine]) -> std::io::Result<()> {
    if lines.is_empty() {
        return writeln!(w, "no run folders");
    }
    writeln!(
        w,
        "{:<10}  {:<8}  {:<8}  {:>11}  {:>4}  {:>7}  {:>9}  {:>5}  run, model (why it stopped)",
        "state", "domain", "algo", "budget", "seed", "calls", "spend", "cores"
    )?;
    for l in lines {
        let (state, mut why) = match l.state.split_once(": ") {
            Some((s, why)) => (s.to_string(), format!("  ({why})")),
            None => (l.state.clone(), String::new()),
        };
        // The budget is the total cap, shrink included; a format 2 run was started with the
        // search's share alone and the shrink on top, which the note keeps.
        if l.format == 2 && l.shrink > 0 {
            why.push_str(&format!(
                "  (format 2: --budget {} --shrink {})",
                l.budget.saturating_sub(l.shrink),
                l.shrink
            ));
        }
        let budget = l.budget.to_string();
        writeln!(
            w,
            "{:<10}  {:<8}  {:<8}  {:>11}  {:>4}  {:>7}  {:>9}  {:>5}  {}  {}{}",
            terminal_safe(&state),
            terminal_safe(&l.domain),
            l.algo,
            budget,
            l.seed,
            thousands(l.calls),
            format!("${:.4}", l.cost_usd),
            l.cores.map_or_else(|| "-".into(), |c| c.to_string()),
            terminal_safe(&l.run),
            terminal_safe(&l.model),
            terminal_safe(&why)
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run folder's `config.json` with `--budget 300 --shrink 75` as written by format `format`.
    fn config(format: u64, budget: u64) -> String {
        serde_json::json!({
            "format": format, "domain_file": "aisle.rev", "domain": "aisle", "domain_hash": "0",
            "model_spec": "sim:aisle/sim.toml", "model": "sim:aisle@0", "renderer": "none",
            "params": {
                "algo": "interact", "budget": budget, "samples": 5, "threshold": 0.6, "beam_width": 5,
                "max_depth": 5, "lambda": 0.5, "beam_budget": 102, "batch": 16, "seed": 0, "max_size": 5,
                "surrogate": "patterns", "supersets": "fallback", "shrink": 75
            }
        })
        .to_string()
    }

    /// Issue 31: `--budget 300` is the total now (shrink included), so the list says 300, not
    /// the old rule's `300+75`; a format 2 folder (shrink on top) lists its sum and notes both.
    #[test]
    fn the_budget_listed_is_the_total_and_format_2_is_noted() {
        let dir = tempfile::tempdir().unwrap();
        for (name, format, budget) in [("new", 3, 300), ("old", 2, 225)] {
            std::fs::create_dir(dir.path().join(name)).unwrap();
            std::fs::write(dir.path().join(name).join("config.json"), config(format, budget)).unwrap();
        }
        let (new, old) = (line(&dir.path().join("new")), line(&dir.path().join("old")));
        assert_eq!((new.budget, new.shrink, new.format), (300, 75, 3));
        assert_eq!((old.budget, old.shrink, old.format), (300, 75, 2));
        let mut out = Vec::new();
        print(&mut out, &[new, old]).unwrap();
        let out = String::from_utf8(out).unwrap();
        let rows: Vec<&str> = out.lines().skip(1).collect();
        assert_eq!(rows.len(), 2, "{out}");
        assert!(rows.iter().all(|r| r.split_whitespace().nth(3) == Some("300")), "{out}");
        assert!(!out.contains('+'), "{out}");
        assert!(!rows[0].contains("format 2"), "{out}");
        assert!(rows[1].ends_with("(format 2: --budget 225 --shrink 75)"), "{out}");
    }
}

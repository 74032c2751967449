//! The `revelio` command line. Each subcommand lives in its own file with its clap `Args` and a
//! `run` function returning the process exit code (0 ok, 1 findings/errors, 2 usage errors).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod ask;
pub mod bench;
pub mod campaign;
pub mod check;
pub mod common;
pub mod compare;
pub mod describe;
pub mod emit;
pub mod fmt;
pub mod lattice;
pub mod lsp;
pub mod new;
pub mod oracle;
pub mod probe;
pub mod progress;
pub mod reask;
#[cfg(feature = "render")]
pub mod render;
pub mod report;
pub mod runs;
pub mod search;
pub mod transfer;
pub mod validate;

#[derive(Parser, Debug)]
#[command(name = "revelio", version, about = "Find interpretable failure modes of vision-language models")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Type-check `.rev` files and report every problem
    Check(check::CheckArgs),
    /// Scaffold a new domain (domain file, world, looks, sim profile) that checks and searches
    New(new::NewArgs),
    /// Rewrite `.rev` files in the canonical layout (`--check` only reports)
    Fmt(fmt::FmtArgs),
    /// Run the language server on standard input/output (for editors)
    Lsp(lsp::LspArgs),
    /// Show what a domain file compiles to (concepts, constraints, questions, rules)
    Describe(describe::DescribeArgs),
    /// Count or list the valid concept sets of a domain
    Lattice(lattice::LatticeArgs),
    /// Show the ground truth (question, expected answer, deciding rule) of a concept set
    Oracle(oracle::OracleArgs),
    /// Emit one sampled scene of a concept set: a Scenic program, an image prompt, or JSON
    Emit(emit::EmitArgs),
    /// Search a domain for failure modes of a model (resumable run folder)
    Search(Box<search::SearchArgs>),
    /// Re-evaluate a search run's top concept sets with fresh scenes
    Validate(validate::ValidateArgs),
    /// Benchmarks: `bench search` compares the search algorithms against a sim profile
    Bench(bench::BenchArgs),
    /// Render one scene of a concept set, ask a model once, and show the verdict
    Ask(ask::AskArgs),
    /// Draw a concept set with the builtin renderer (or a contact sheet)
    #[cfg(feature = "render")]
    Render(render::RenderArgs),
    /// Recognition vs. reasoning: re-ask a run's top sets with true/false probe statements
    Probe(probe::ProbeArgs),
    /// Replay a run's top sets on other models with the same images (failure-mode transfer)
    Transfer(transfer::TransferArgs),
    /// Run a grid of searches (domains × models × algorithms × seeds) from a TOML file
    Campaign(campaign::CampaignArgs),
    /// Compare finished runs: PFM, MFR and Div with intervals (terminal, CSV, HTML)
    Compare(compare::CompareArgs),
    /// List the run folders under a folder: state (running, finished, stopped and why), model,
    /// algorithm, budget, seed, calls, spend, cores
    Runs(runs::RunsArgs),
    /// Write a run's static HTML report (images, replies, cores, plots) and CSV tables
    Report(report::ReportArgs),
}

pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    if let Err(code) = request_log(&cli.command) {
        return code;
    }
    match cli.command {
        Command::Check(a) => check::run(a),
        Command::New(a) => new::run(a),
        Command::Fmt(a) => fmt::run(a),
        Command::Lsp(a) => lsp::run(a),
        Command::Describe(a) => describe::run(a),
        Command::Lattice(args) => lattice::run(args),
        Command::Oracle(args) => oracle::run(args),
        Command::Emit(a) => emit::run(a),
        Command::Search(a) => search::run(*a),
        Command::Validate(a) => validate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Ask(a) => ask::run(a),
        #[cfg(feature = "render")]
        Command::Render(args) => render::run(args),
        Command::Probe(a) => probe::run(a),
        Command::Transfer(a) => transfer::run(a),
        Command::Campaign(a) => campaign::run(a),
        Command::Compare(a) => compare::run(a),
        Command::Report(a) => report::run(a),
        Command::Runs(a) => runs::run(a),
    }
}

/// Open the request log of a command that calls a model (`--log`, `REVELIO_LOG`).
fn request_log(command: &Command) -> Result<(), ExitCode> {
    let (flag, dry_run) = match command {
        Command::Search(a) => (&a.model_opts.log, a.run.dry_run),
        Command::Validate(a) => (&a.model_opts.log, a.run.dry_run),
        Command::Probe(a) => (&a.model_opts.log, a.run.dry_run),
        Command::Transfer(a) => (&a.model_opts.log, a.run.dry_run),
        Command::Ask(a) => (&a.model_opts.log, false),
        Command::Campaign(a) => (&a.log, a.dry_run),
        _ => return Ok(()),
    };
    common::open_log(flag.as_deref(), dry_run)
}

/// Compile a domain file for a subcommand. Diagnostics (errors and warnings) go to stderr as
/// human output; on errors the subcommand should exit with the returned code (1).
pub fn load_domain(path: &std::path::Path) -> Result<crate::ir::Domain, ExitCode> {
    // No lattice lints here: they enumerate the lattice, which is `check`'s job.
    let compiled = common::compile_path(path, false);
    let theme = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        miette::GraphicalTheme::unicode()
    } else {
        miette::GraphicalTheme::unicode_nocolor()
    };
    eprint!("{}", check::render_human(&compiled, &theme));
    match compiled.domain {
        Some(d) if d.name.is_empty() => {
            eprintln!("error: `{}` is a library module, not a domain (it has no `domain NAME` line)", path.display());
            Err(ExitCode::from(1))
        }
        Some(d) => Ok(d),
        None => Err(ExitCode::from(1)),
    }
}

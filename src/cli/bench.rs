//! `revelio bench search --profile P --seeds K --budget N [--domain FILE]`: Random, Beam and
//! GPTS over K seeds against a sim profile (no renderer), reporting mean ± sd of PFM, MFR, Div,
//! the fraction of the profile's planted failure modes recovered, and Revelio's own time per
//! inference. `revelio bench lsp [--domain FILE] [--rounds N]`: the language server's diagnostic
//! latencies (see `src/lsp/bench.rs`).
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::ir::Domain;
use crate::lattice::Lattice;
use crate::run::observe::{DomainWorld, World};
use crate::run::runner::{self, RunConfig, Setup};
use crate::run::setup::ModelSettings;
use crate::search::metrics::mean_sd;
use crate::search::{Algo, Params, SetStats, Space};
use crate::vlm::Model;
use crate::vlm::sim::{Profile, SimModel};

use super::search::runtime;

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchWhat,
}

#[derive(clap::Subcommand, Debug)]
pub enum BenchWhat {
    /// Compare the search algorithms against a sim profile
    Search(SearchBenchArgs),
    /// How long an editor waits for diagnostics from `revelio lsp` (front end per edit, lattice
    /// lints per save)
    Lsp(LspBenchArgs),
}

#[derive(clap::Args, Debug)]
pub struct LspBenchArgs {
    /// The domain file to edit
    #[arg(long, default_value = "domains/driving.rev")]
    pub domain: PathBuf,
    /// Edits (each followed by a save)
    #[arg(long, default_value_t = 20)]
    pub rounds: usize,
}

#[derive(clap::Args, Debug)]
pub struct SearchBenchArgs {
    /// A sim model profile (TOML)
    #[arg(long)]
    pub profile: PathBuf,
    /// The domain file the profile is written for
    #[arg(long, default_value = "domains/driving.rev")]
    pub domain: PathBuf,
    /// Seeds per algorithm (0..K)
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    #[arg(long, default_value_t = 1000)]
    pub budget: u64,
    #[arg(long, default_value_t = 5)]
    pub samples: u32,
    #[arg(long, default_value_t = 0.6)]
    pub threshold: f64,
    /// Beam diversity weight λ (beam and the beam phase of GPTS)
    #[arg(long, default_value_t = crate::search::DEFAULT_LAMBDA)]
    pub lambda: f64,
    #[arg(long, default_value_t = 5)]
    pub beam_width: usize,
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    pub concurrency: u32,
    /// Ablation: run every algorithm at each value of one parameter (beam_width, beam_budget,
    /// samples, threshold, lambda), e.g. `beam_width=1,5,10`; prints a table and writes an SVG plot
    #[arg(long, value_name = "PARAM=V1,V2,…")]
    pub sweep: Option<crate::analysis::sweep::Sweep>,
    /// Where `--sweep` writes its plot [default: sweep-PARAM.svg]
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: BenchArgs) -> ExitCode {
    match args.what {
        BenchWhat::Search(a) => search(a),
        BenchWhat::Lsp(a) => lsp(a),
    }
}

fn lsp(args: LspBenchArgs) -> ExitCode {
    let l = match crate::lsp::bench::measure(&args.domain, args.rounds) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let ms = |d: std::time::Duration| d.as_secs_f64() * 1000.0;
    let (fe, fe90) = crate::lsp::bench::summary(&l.front_end);
    let (li, li90) = crate::lsp::bench::summary(&l.lints_on_save);
    println!("revelio lsp on {} ({} edits)", args.domain.display(), l.front_end.len());
    println!("  diagnostics after an edit (front end):   median {:7.1} ms, p90 {:7.1} ms", ms(fe), ms(fe90));
    println!("  lattice lints after a save:              median {:7.1} ms, p90 {:7.1} ms", ms(li), ms(li90));
    println!(
        "  lattice lints after an edit (debounced): median {:7.1} ms ({} ms quiet, then the lints)",
        ms(l.debounce + li),
        l.debounce.as_millis()
    );
    ExitCode::SUCCESS
}

/// Mean and sample sd of one metric over seeds.
#[derive(Debug, Serialize)]
pub struct Stat {
    pub mean: f64,
    pub sd: f64,
    /// Seeds the metric was defined for (Div needs two failure modes).
    pub n: usize,
}

impl Stat {
    fn of(xs: &[f64]) -> Stat {
        let (mean, sd) = mean_sd(xs);
        Stat { mean, sd, n: xs.len() }
    }
}

#[derive(Debug, Serialize)]
pub struct AlgoResult {
    pub algo: Algo,
    pub pfm: Stat,
    pub mfr: Stat,
    pub div: Stat,
    /// Fraction of planted modes (error ≥ τ) recovered.
    pub recovered: Stat,
    /// Wall time per inference, microseconds (with a zero-latency profile: Revelio's overhead).
    pub us_per_inference: Stat,
}

fn search(args: SearchBenchArgs) -> ExitCode {
    let domain = match crate::cli::load_domain(&args.domain) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let text = match std::fs::read_to_string(&args.profile) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: cannot read sim profile `{}`: {}", args.profile.display(), e.to_string().to_lowercase());
            return ExitCode::from(2);
        }
    };
    let profile = match Profile::parse(&text, &args.profile.display().to_string(), &domain) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let base = Params {
        budget: args.budget,
        samples: args.samples,
        threshold: args.threshold,
        lambda: args.lambda,
        beam_width: args.beam_width,
        beam_budget: args.budget / 2,
        ..Params::default()
    };
    if let Err(e) = base.validate() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let lattice = Lattice::enumerate(&domain, base.max_size);
    let (space, _) = runner::search_space(lattice.sets, domain.concepts.len(), world.as_ref());
    let tmp = std::env::temp_dir().join(format!("revelio-bench-{}", std::process::id()));
    let planted: Vec<_> = profile.modes.iter().filter(|m| m.error >= args.threshold).map(|m| m.concepts).collect();
    let model: Arc<dyn Model> = Arc::new(SimModel { profile });
    let domain = Arc::new(domain);
    if let Some(sweep) = &args.sweep {
        let code = super::sweep::run(
            &args,
            sweep,
            &base,
            &super::sweep::Bench { domain, world, model, space, planted, tmp: tmp.clone() },
        );
        let _ = std::fs::remove_dir_all(&tmp);
        return code;
    }
    let mut results = Vec::new();
    for algo in Algo::ALL {
        let mut rows: Vec<[Option<f64>; 5]> = Vec::new();
        for seed in 0..args.seeds {
            let params = Params { algo, seed, ..base.clone() };
            let out = tmp.join(format!("{}-{seed}", algo.name()));
            match bench_one(&args, &domain, &world, &model, &space, params, out, &planted) {
                Ok(r) => rows.push(r),
                Err(e) => {
                    eprintln!("error: {e}");
                    let _ = std::fs::remove_dir_all(&tmp);
                    return ExitCode::from(1);
                }
            }
        }
        let col = |i: usize| Stat::of(&rows.iter().filter_map(|r| r[i]).collect::<Vec<_>>());
        results.push(AlgoResult {
            algo,
            pfm: col(0),
            mfr: col(1),
            div: col(2),
            recovered: col(3),
            us_per_inference: col(4),
        });
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let mut w = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut w, &results).map_err(std::io::Error::from).and_then(|_| writeln!(w))
    } else {
        print(&mut w, &args, &results, planted.len())
    };
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the report: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn bench_one(
    args: &SearchBenchArgs,
    domain: &Arc<Domain>,
    world: &Arc<dyn World>,
    model: &Arc<dyn Model>,
    space: &Space,
    params: Params,
    out: PathBuf,
    planted: &[crate::ir::ConceptSet],
) -> Result<[Option<f64>; 5], String> {
    let spec = format!("sim:{}", args.profile.display());
    let config = RunConfig::new(domain, &args.domain, &spec, model.as_ref(), ModelSettings::default(), "none", params);
    let mut setup = Setup::new(domain.clone(), world.clone(), model.clone(), None, out);
    setup.concurrency = args.concurrency as usize;
    let started = Instant::now();
    let r = runtime().block_on(runner::search(&setup, &config, space)).map_err(|e| e.to_string())?;
    let elapsed = started.elapsed();
    let m = &r.summary.metrics;
    let rec = recovered(&r.history, planted, args.threshold);
    let us = 1e6 * elapsed.as_secs_f64() / (m.inferences.max(1) as f64);
    Ok([Some(m.pfm), Some(m.mfr), m.div, rec, Some(us)])
}

/// Fraction of planted modes contained in some evaluated set with observed FR ≥ τ (`None` when
/// the profile plants none at or above τ).
pub fn recovered(history: &[SetStats], planted: &[crate::ir::ConceptSet], threshold: f64) -> Option<f64> {
    if planted.is_empty() {
        return None;
    }
    let found = planted
        .iter()
        .filter(|p| history.iter().any(|s| s.is_failure_mode(threshold) && p.is_subset_of(s.set)))
        .count();
    Some(found as f64 / planted.len() as f64)
}

fn print(w: &mut impl Write, args: &SearchBenchArgs, results: &[AlgoResult], planted: usize) -> std::io::Result<()> {
    writeln!(
        w,
        "{} seeds × budget {} (m = {}, τ = {}, λ = {}, w = {}) against `{}`, renderer none",
        args.seeds,
        args.budget,
        args.samples,
        args.threshold,
        args.lambda,
        args.beam_width,
        args.profile.display()
    )?;
    writeln!(
        w,
        "{:<7} {:>15} {:>15} {:>13} {:>15} {:>14}",
        "algo", "PFM %", "MFR %", "Div", "planted found", "µs/inference"
    )?;
    let f = |s: &Stat, scale: f64, digits: usize| {
        if s.n == 0 { "-".to_string() } else { format!("{:.*} ± {:.*}", digits, s.mean * scale, digits, s.sd * scale) }
    };
    for r in results {
        writeln!(
            w,
            "{:<7} {:>15} {:>15} {:>13} {:>15} {:>14}",
            r.algo.name(),
            f(&r.pfm, 1.0, 1),
            f(&r.mfr, 1.0, 1),
            f(&r.div, 1.0, 2),
            if planted == 0 { "-".into() } else { f(&r.recovered, 100.0, 0) + "%" },
            f(&r.us_per_inference, 1.0, 0)
        )?;
    }
    let pfm = |a: Algo| results.iter().find(|r| r.algo == a).map_or(0.0, |r| r.pfm.mean);
    if pfm(Algo::Random) > 0.0 {
        writeln!(
            w,
            "PFM vs random: beam {:.1}×, gpts {:.1}×",
            pfm(Algo::Beam) / pfm(Algo::Random),
            pfm(Algo::Gpts) / pfm(Algo::Random)
        )?;
    }
    Ok(())
}

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

use crate::ir::ConceptSet;
use crate::ir::Domain;
use crate::journal::domain_hash;
use crate::lattice::Lattice;
use crate::run::eval::{DomainWorld, World};
use crate::run::runner::{self, RunConfig, Setup};
use crate::search::interact::{Supersets, Surrogate};
use crate::search::metrics::mean_sd;
use crate::search::{Algo, Params, SetStats, Space};
use crate::vlm::Model;
use crate::vlm::sim::{Profile, SimModel};

use super::search::{absolute, runtime};

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
    #[arg(long, default_value_t = 8)]
    pub concurrency: usize,
    /// Algorithms to run, comma-separated [default: all]
    #[arg(long, value_delimiter = ',', value_parser = super::search::algo_parser())]
    pub algos: Vec<Algo>,
    /// Interact: the surrogate (horseshoe, ridge, linear)
    #[arg(long, default_value = "horseshoe")]
    pub surrogate: Surrogate,
    /// Interact: supersets of a confirmed core (exclude, fallback, keep)
    #[arg(long, default_value = "fallback")]
    pub supersets: Supersets,
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
    /// Share of planted modes (error ≥ τ) that some reported core with observed FR ≥ τ contains.
    pub recovered: Stat,
    /// Share of planted modes reported exactly as a core.
    pub exact: Stat,
    /// Share of reported cores whose true error under the profile is ≥ τ.
    pub precision: Stat,
    /// Number of distinct cores reported.
    pub cores: Stat,
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
        surrogate: args.surrogate,
        supersets: args.supersets,
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
    let truth = profile.clone();
    let model: Arc<dyn Model> = Arc::new(SimModel { profile });
    let domain = Arc::new(domain);
    let mut results = Vec::new();
    let algos = if args.algos.is_empty() { Algo::ALL.to_vec() } else { args.algos.clone() };
    for algo in algos {
        let mut rows: Vec<[Option<f64>; 8]> = Vec::new();
        for seed in 0..args.seeds {
            let params = Params { algo, seed, ..base.clone() };
            let out = tmp.join(format!("{}-{seed}", algo.name()));
            match bench_one(&args, &domain, &world, &model, &space, params, out, &planted, &truth) {
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
            exact: col(4),
            precision: col(5),
            cores: col(6),
            us_per_inference: col(7),
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
fn bench_one(
    args: &SearchBenchArgs,
    domain: &Arc<Domain>,
    world: &Arc<dyn World>,
    model: &Arc<dyn Model>,
    space: &Space,
    params: Params,
    out: PathBuf,
    planted: &[ConceptSet],
    truth: &Profile,
) -> Result<[Option<f64>; 8], String> {
    let config = RunConfig {
        domain_file: absolute(&args.domain),
        domain: domain.name.clone(),
        domain_hash: domain_hash(domain),
        model_spec: format!("sim:{}", args.profile.display()),
        model: model.id(),
        renderer: "none".into(),
        params,
    };
    let setup = Setup {
        domain: domain.clone(),
        world: world.clone(),
        model: model.clone(),
        renderer: None,
        concurrency: args.concurrency,
        out,
        progress: false,
    };
    let started = Instant::now();
    let r = runtime().block_on(runner::search(&setup, &config, space))?;
    let elapsed = started.elapsed();
    let m = &r.summary.metrics;
    let cores = reported_cores(&r.history, space, args.threshold);
    let q = quality(&cores, planted, truth, args.threshold);
    let us = 1e6 * elapsed.as_secs_f64() / (m.inferences.max(1) as f64);
    Ok([Some(m.pfm), Some(m.mfr), m.div, q.recovered, q.exact, q.precision, Some(cores.len() as f64), Some(us)])
}

/// The cores a run reports: evaluated sets with FR ≥ τ whose every valid one-smaller subset was
/// evaluated and has FR < τ.
pub fn reported_cores<'h>(history: &'h [SetStats], space: &Space, threshold: f64) -> Vec<&'h SetStats> {
    let by_set: std::collections::HashMap<ConceptSet, &SetStats> = history.iter().map(|s| (s.set, s)).collect();
    history
        .iter()
        .filter(|s| s.is_failure_mode(threshold))
        .filter(|s| {
            s.set
                .iter()
                .map(|c| s.set.without(c))
                .filter(|sub| !sub.is_empty() && space.contains(*sub))
                .all(|sub| by_set.get(&sub).is_some_and(|t| t.fr().is_some() && !t.is_failure_mode(threshold)))
        })
        .collect()
}

/// How well reported cores match the planted modes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quality {
    /// Share of planted modes that some core with observed FR ≥ τ contains (`None`: none planted).
    pub recovered: Option<f64>,
    /// Share of planted modes reported exactly as a core.
    pub exact: Option<f64>,
    /// Share of cores whose true error is ≥ τ (`None`: no cores).
    pub precision: Option<f64>,
}

pub fn quality(cores: &[&SetStats], planted: &[ConceptSet], truth: &Profile, threshold: f64) -> Quality {
    let share = |k: usize, n: usize| (n > 0).then(|| k as f64 / n as f64);
    let recovered =
        planted.iter().filter(|p| cores.iter().any(|c| c.is_failure_mode(threshold) && p.is_subset_of(c.set))).count();
    let exact = planted.iter().filter(|p| cores.iter().any(|c| c.set == **p)).count();
    let true_cores = cores.iter().filter(|c| truth.error_for(c.set) >= threshold).count();
    Quality {
        recovered: share(recovered, planted.len()),
        exact: share(exact, planted.len()),
        precision: share(true_cores, cores.len()),
    }
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
    writeln!(w, "planted failure modes (error ≥ τ): {planted}")?;
    writeln!(
        w,
        "{:<9} {:>12} {:>12} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
        "algo", "PFM %", "MFR %", "Div", "recovered", "exact", "precision", "cores", "µs/inf"
    )?;
    let f = |s: &Stat, scale: f64, digits: usize| {
        if s.n == 0 { "-".to_string() } else { format!("{:.*} ± {:.*}", digits, s.mean * scale, digits, s.sd * scale) }
    };
    for r in results {
        writeln!(
            w,
            "{:<9} {:>12} {:>12} {:>11} {:>11} {:>11} {:>11} {:>11} {:>11}",
            r.algo.name(),
            f(&r.pfm, 1.0, 1),
            f(&r.mfr, 1.0, 1),
            f(&r.div, 1.0, 2),
            f(&r.recovered, 1.0, 2),
            f(&r.exact, 1.0, 2),
            f(&r.precision, 1.0, 2),
            f(&r.cores, 1.0, 1),
            format!("{:.0}", r.us_per_inference.mean),
        )?;
    }
    let pfm = |a: Algo| results.iter().find(|r| r.algo == a).map(|r| r.pfm.mean);
    if let Some(random) = pfm(Algo::Random).filter(|r| *r > 0.0) {
        let ratios: Vec<String> = results
            .iter()
            .filter(|r| r.algo != Algo::Random)
            .map(|r| format!("{} {:.1}×", r.algo.name(), r.pfm.mean / random))
            .collect();
        writeln!(w, "PFM vs random: {}", ratios.join(", "))?;
    }
    Ok(())
}

//! `revelio bench search --profile P --seeds K --budget N [--domain FILE] [--max-samples M]
//! [--shrink B]`: Random, Beam and GPTS over K seeds against a sim profile (no renderer),
//! reporting the mean and 95 % interval over seeds of PFM, MFR, Div, the failure modes reported
//! and how many of them are false (true error under the profile below τ), their precision, the
//! fraction of the profile's planted failure modes recovered, and Revelio's own time per
//! inference. With `--max-samples` every algorithm runs twice at the same budget: with the
//! paper's fixed m and with sequential sampling up to M. With `--shrink` every run shrinks its
//! failure modes to cores. Every run reports its cores — the shrink phase's, or without one the
//! evaluated failure modes whose every valid one-smaller subset was evaluated and passes (what
//! `--algo interact` confirms as it searches) — with their precision, the share of planted modes
//! some core holds (recovered) and the share reported exactly as a core (exact). Then, per planted
//! mode, each algorithm's share of seeds that recovered it, and the mode's [`reach`]: how often
//! any search could recover it at this budget were its smaller parts silent.
//! `revelio bench lsp [--domain FILE] [--rounds N]`: the language server's diagnostic
//! latencies (see `src/lsp/bench.rs`).
//! `revelio bench scale [--concepts 30,60,120,250]`: `check` and `lattice` on generated domains
//! of many concepts (see `bench/scale.rs`).
pub mod scale;
mod sweep;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::ir::Domain;
use crate::lattice::Lattice;
use crate::run::observe::{DomainWorld, World};
use crate::run::runner::{self, Setup};
use crate::run::setup::ModelSettings;
use crate::run::summary::RunConfig;
use crate::search::interval::{mean_ci95, mean_sd};
use crate::search::{Algo, Params, SetStats, Space};
use crate::vlm::Model;
use crate::vlm::sim::{Profile, SimModel};

use super::common::{SearchFlags, runtime};

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
    /// `check` (with the lattice lints) and `lattice` on generated domains of many concepts
    Scale(scale::ScaleBenchArgs),
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
    #[command(flatten)]
    pub search: SearchFlags,
    /// Also run every algorithm with sequential sampling up to M observations per set, at the
    /// same budget
    #[arg(long, value_name = "M")]
    pub max_samples: Option<u32>,
    /// Shrink each run's failure modes to cores with this many extra inferences (0: off)
    #[arg(long, value_name = "B", default_value_t = 0)]
    pub shrink: u64,
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    pub concurrency: u32,
    /// Algorithms to run, comma-separated [default: all]
    #[arg(long, value_delimiter = ',', value_parser = super::common::algo_parser())]
    pub algos: Vec<Algo>,
    /// Ablation: run every algorithm at each value of one parameter (beam_width, beam_budget,
    /// samples, threshold, lambda; or GPTS at each GP kernel: kernel=dot,rbf), e.g.
    /// `beam_width=1,5,10`; prints a table and writes an SVG plot
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
        BenchWhat::Scale(a) => scale::run(&a),
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

/// Mean, sample sd and 95 % interval of the mean (Student's t) of one metric over seeds.
#[derive(Debug, Serialize)]
pub struct Stat {
    pub mean: f64,
    pub sd: f64,
    pub ci95: [f64; 2],
    /// Seeds the metric was defined for (Div needs two failure modes, precision one).
    pub n: usize,
}

impl Stat {
    /// The t interval, clipped to the metric's range `[lo, hi]` (a share cannot exceed 100 %
    /// however few the seeds).
    fn of(xs: &[f64], [lo, hi]: [f64; 2]) -> Stat {
        let (mean, sd) = mean_sd(xs);
        let ci95 = mean_ci95(xs).map_or([0.0, 0.0], |(_, ci)| [ci[0].max(lo), ci[1].min(hi)]);
        Stat { mean, sd, ci95, n: xs.len() }
    }
}

#[derive(Debug, Serialize)]
pub struct AlgoResult {
    pub algo: Algo,
    /// Most observations per set: `samples` for the paper's fixed count.
    pub max_samples: u32,
    pub pfm: Stat,
    pub mfr: Stat,
    pub div: Stat,
    /// Failure modes reported per run.
    pub failure_modes: Stat,
    /// Of them, how many have a true error (under the profile) below τ.
    pub false_modes: Stat,
    /// Share of reported failure modes whose true error is ≥ τ.
    pub precision: Stat,
    /// Fraction of planted modes (error ≥ τ) recovered.
    pub recovered: Stat,
    /// Cores per run (the shrink phase's, or without one the failure modes whose every valid
    /// one-smaller subset was evaluated and passes) and the share whose true error is ≥ τ.
    pub cores: Stat,
    pub core_precision: Stat,
    /// Share of planted modes that some core with observed FR ≥ τ contains.
    pub core_recovered: Stat,
    /// Share of planted modes reported exactly as a core.
    pub exact: Stat,
    /// Wall time per inference, microseconds (with a zero-latency profile: Revelio's overhead).
    pub us_per_inference: Stat,
    /// Per planted mode, in the profile's order: how often this algorithm recovered it.
    pub planted: Vec<ModeRecovery>,
}

/// One planted mode across an algorithm's seeds.
#[derive(Debug, Serialize)]
pub struct ModeRecovery {
    pub concepts: Vec<String>,
    /// Its error under the profile.
    pub error: f64,
    /// The most any search can recover of such a mode, averaged over where it lies, when its
    /// smaller parts carry no signal ([`reach`]).
    pub reach: f64,
    /// Share of seeds in which some core with observed FR ≥ τ holds it.
    pub recovered: f64,
    /// Share of seeds in which it is reported exactly as a core.
    pub exact: f64,
}

/// The share of the search space's `k`-concept sets that `inferences` observations can touch:
/// each observation is of one set, and a set of at most `max_size` concepts holds at most
/// C(max_size, k) of them. A mode of k concepts whose smaller parts fail no more than any other
/// set gives a search nothing to steer by until a tested set holds it, so no search, however
/// adaptive, recovers such a mode more often than this, averaged over the k-sets it could be
/// (capped at 1). On `driving_robust.toml` (a silent four-concept mode) at 1 250 inferences: 31 %.
pub fn reach(space: &Space, k: usize, max_size: usize, inferences: u64) -> f64 {
    let n = space.sets.iter().filter(|s| s.len() == k).count();
    if n == 0 {
        return 0.0;
    }
    let per_set = binomial(max_size, k) as f64;
    (inferences as f64 * per_set / n as f64).min(1.0)
}

/// C(n, k).
fn binomial(n: usize, k: usize) -> u64 {
    if k > n {
        return 0;
    }
    (0..k).fold(1u64, |c, i| c * (n - i) as u64 / (i + 1) as u64)
}

/// One run's figures (`None`: undefined for this run).
pub(crate) struct RunFigures {
    pub(crate) pfm: f64,
    pub(crate) mfr: f64,
    pub(crate) div: Option<f64>,
    failure_modes: f64,
    false_modes: f64,
    precision: Option<f64>,
    recovered: Option<f64>,
    cores: f64,
    core_precision: Option<f64>,
    core_recovered: Option<f64>,
    exact: Option<f64>,
    us: f64,
    /// Per planted mode: (some core holds it, it is a core).
    per_mode: Vec<(bool, bool)>,
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
    let base = Params { shrink: args.shrink, ..args.search.params() };
    let sequential = Params { max_samples: args.max_samples, ..base.clone() };
    if let Err(e) = base.validate().and_then(|_| sequential.validate()) {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let mut modes = vec![base.clone()];
    if args.max_samples.is_some_and(|m| m > args.search.samples) {
        modes.push(sequential);
    }
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let lattice = Lattice::enumerate(&domain, base.max_size);
    let (space, _) = runner::search_space(lattice.sets, domain.concepts.len(), world.as_ref());
    let tmp = std::env::temp_dir().join(format!("revelio-bench-{}", std::process::id()));
    let planted = profile.planted(args.search.threshold, |s| space.contains(s));
    let truth = profile.clone();
    let model: Arc<dyn Model> = Arc::new(SimModel { profile });
    let domain = Arc::new(domain);
    if let Some(sweep) = &args.sweep {
        let code = sweep::run(
            &args,
            sweep,
            &base,
            &sweep::Bench { domain, world, model, space, planted, truth, tmp: tmp.clone() },
        );
        let _ = std::fs::remove_dir_all(&tmp);
        return code;
    }
    // Per planted mode, its error and reach: the same for every algorithm and sampling mode.
    let truths: Vec<(f64, f64)> = planted
        .iter()
        .map(|p| (truth.error_for(*p), reach(&space, p.len(), base.max_size, base.budget + base.shrink)))
        .collect();
    let mut results = Vec::new();
    let algos = if args.algos.is_empty() { Algo::ALL.to_vec() } else { args.algos.clone() };
    for algo in algos {
        for mode in &modes {
            let mut rows: Vec<RunFigures> = Vec::new();
            for seed in 0..args.seeds {
                let params = Params { algo, seed, ..mode.clone() };
                let out = tmp.join(format!("{}-{}-{seed}", algo.name(), params.rule().max_samples));
                match bench_one(&args, &domain, &world, &model, &space, params, out, &planted, &truth) {
                    Ok(r) => rows.push(r),
                    Err(e) => {
                        eprintln!("error: {e}");
                        let _ = std::fs::remove_dir_all(&tmp);
                        return ExitCode::from(1);
                    }
                }
            }
            let col = |f: &dyn Fn(&RunFigures) -> Option<f64>, range: [f64; 2]| {
                Stat::of(&rows.iter().filter_map(f).collect::<Vec<_>>(), range)
            };
            let (percent, share, count) = ([0.0, 100.0], [0.0, 1.0], [0.0, f64::INFINITY]);
            results.push(AlgoResult {
                algo,
                max_samples: mode.rule().max_samples,
                pfm: col(&|r| Some(r.pfm), percent),
                mfr: col(&|r| Some(r.mfr), percent),
                div: col(&|r| r.div, share),
                failure_modes: col(&|r| Some(r.failure_modes), count),
                false_modes: col(&|r| Some(r.false_modes), count),
                precision: col(&|r| r.precision, share),
                recovered: col(&|r| r.recovered, share),
                cores: col(&|r| Some(r.cores), count),
                core_precision: col(&|r| r.core_precision, share),
                core_recovered: col(&|r| r.core_recovered, share),
                exact: col(&|r| r.exact, share),
                us_per_inference: col(&|r| Some(r.us), count),
                planted: planted
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let of = |f: fn(&(bool, bool)) -> bool| {
                            rows.iter().filter(|r| f(&r.per_mode[i])).count() as f64 / rows.len().max(1) as f64
                        };
                        ModeRecovery {
                            concepts: names(&domain, *p),
                            error: truths[i].0,
                            reach: truths[i].1,
                            recovered: of(|m| m.0),
                            exact: of(|m| m.1),
                        }
                    })
                    .collect(),
            });
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    let mut w = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut w, &results).map_err(std::io::Error::from).and_then(|_| writeln!(w))
    } else {
        print(&mut w, &args, &results, planted.len())
            .and_then(|()| print_planted(&mut w, &results, args.search.samples, base.budget + base.shrink))
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
    truth: &Profile,
) -> Result<RunFigures, String> {
    let spec = format!("sim:{}", args.profile.display());
    let config = RunConfig::new(domain, &args.domain, &spec, model.as_ref(), ModelSettings::default(), "none", params);
    let mut setup = Setup::new(domain.clone(), world.clone(), model.clone(), None, out);
    setup.concurrency = args.concurrency as usize;
    let started = Instant::now();
    let r = runtime().block_on(runner::search(&setup, &config, space)).map_err(|e| e.to_string())?;
    let elapsed = started.elapsed();
    let m = &r.summary.metrics;
    let modes: Vec<_> = r.history.iter().filter(|s| s.is_failure_mode(args.search.threshold)).map(|s| s.set).collect();
    let cores: Vec<_> = if r.summary.shrink.is_some() {
        r.found.cores.iter().map(|c| c.stats.set).collect()
    } else {
        crate::search::shrink::minimal_failures(&r.history, space, args.search.threshold)
    };
    let share = |k: usize| (!planted.is_empty()).then(|| k as f64 / planted.len() as f64);
    let per_mode: Vec<(bool, bool)> =
        planted.iter().map(|p| (cores.iter().any(|c| p.is_subset_of(*c)), cores.contains(p))).collect();
    let spent = m.inferences + r.summary.shrink.as_ref().map_or(0, |s| s.inferences);
    Ok(RunFigures {
        pfm: m.pfm,
        mfr: m.mfr,
        div: m.div,
        failure_modes: modes.len() as f64,
        false_modes: (modes.len() - true_modes(truth, &modes, args.search.threshold)) as f64,
        precision: precision(truth, &modes, args.search.threshold),
        recovered: recovered(&r.history, planted, args.search.threshold),
        cores: cores.len() as f64,
        core_precision: precision(truth, &cores, args.search.threshold),
        // Every core failed when it was confirmed (the shrink keeps failing subsets only).
        core_recovered: share(per_mode.iter().filter(|m| m.0).count()),
        exact: share(per_mode.iter().filter(|m| m.1).count()),
        us: 1e6 * elapsed.as_secs_f64() / (spent.max(1) as f64),
        per_mode,
    })
}

/// How many of `sets` truly fail: their error under the profile is ≥ τ.
pub fn true_modes(truth: &Profile, sets: &[crate::ir::ConceptSet], threshold: f64) -> usize {
    sets.iter().filter(|s| truth.error_for(**s) >= threshold).count()
}

/// The share of `sets` that truly fail (`None` for no sets).
pub fn precision(truth: &Profile, sets: &[crate::ir::ConceptSet], threshold: f64) -> Option<f64> {
    (!sets.is_empty()).then(|| true_modes(truth, sets, threshold) as f64 / sets.len() as f64)
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
    let seq = args.max_samples.map_or_else(String::new, |m| format!(", sequential up to M = {m}"));
    let shrink = if args.shrink > 0 { format!(", shrink {}", args.shrink) } else { String::new() };
    writeln!(
        w,
        "{} seeds × budget {} (m = {}{seq}, τ = {}, λ = {}, w = {}{shrink}) against `{}`, renderer none",
        args.seeds,
        args.search.budget,
        args.search.samples,
        args.search.threshold,
        args.search.lambda,
        args.search.beam_width,
        args.profile.display()
    )?;
    writeln!(
        w,
        "mean [95% interval over seeds]; FMs: failure modes reported, false: true error < τ, precision: share ≥ τ; \
         planted found: held by a failure mode; recovered: held by a core; exact: reported as a core"
    )?;
    let f = |s: &Stat, scale: f64, digits: usize| {
        if s.n == 0 {
            "-".to_string()
        } else {
            format!("{:.*} [{:.*}–{:.*}]", digits, s.mean * scale, digits, s.ci95[0] * scale, digits, s.ci95[1] * scale)
        }
    };
    let planted_col = |s: &Stat| if planted == 0 { "-".to_string() } else { f(s, 100.0, 0) };
    writeln!(
        w,
        "{:<12} {:>18} {:>18} {:>17} {:>18} {:>18} {:>14} {:>15} {:>18} {:>16} {:>14} {:>14}  µs/inference",
        "algo",
        "PFM %",
        "MFR %",
        "Div",
        "FMs",
        "false FMs",
        "precision %",
        "planted found %",
        "cores",
        "core precision %",
        "recovered %",
        "exact %"
    )?;
    for r in results {
        let name = label(r, args.search.samples);
        writeln!(
            w,
            "{:<12} {:>18} {:>18} {:>17} {:>18} {:>18} {:>14} {:>15} {:>18} {:>16} {:>14} {:>14}  {:.0}",
            name,
            f(&r.pfm, 1.0, 1),
            f(&r.mfr, 1.0, 1),
            f(&r.div, 1.0, 2),
            f(&r.failure_modes, 1.0, 1),
            f(&r.false_modes, 1.0, 1),
            f(&r.precision, 100.0, 0),
            planted_col(&r.recovered),
            f(&r.cores, 1.0, 1),
            f(&r.core_precision, 100.0, 0),
            planted_col(&r.core_recovered),
            planted_col(&r.exact),
            r.us_per_inference.mean
        )?;
    }
    let pfm =
        |a: Algo| results.iter().find(|r| r.algo == a && r.max_samples == args.search.samples).map(|r| r.pfm.mean);
    if let Some(random) = pfm(Algo::Random).filter(|r| *r > 0.0) {
        let ratios: Vec<String> = Algo::ALL
            .iter()
            .filter(|a| **a != Algo::Random)
            .filter_map(|a| pfm(*a).map(|p| format!("{} {:.1}×", a.name(), p / random)))
            .collect();
        writeln!(w, "PFM vs random (fixed m): {}", ratios.join(", "))?;
    }
    Ok(())
}

/// An algorithm's row or column name: `gpts`, or `gpts ≤20` for its sequential run.
fn label(r: &AlgoResult, samples: u32) -> String {
    if r.max_samples > samples { format!("{} ≤{}", r.algo.name(), r.max_samples) } else { r.algo.name().into() }
}

/// A set's concept names.
fn names(domain: &Domain, set: crate::ir::ConceptSet) -> Vec<String> {
    domain.set_names(set).into_iter().map(String::from).collect()
}

/// Per planted mode: its error, its reach, and per algorithm the share of seeds that recovered
/// it (some core holds it) / reported it exactly.
fn print_planted(w: &mut impl Write, results: &[AlgoResult], samples: u32, inferences: u64) -> std::io::Result<()> {
    let Some(first) = results.first().filter(|r| !r.planted.is_empty()) else { return Ok(()) };
    writeln!(
        w,
        "\nplanted modes: share of seeds recovered / exact; reach: the most any search recovers of a mode whose \
         parts carry no signal ({inferences} inferences)"
    )?;
    let width = first.planted.iter().map(|p| p.concepts.join(" + ").chars().count()).max().unwrap_or(0).max(4);
    write!(w, "{:<width$} {:>5} {:>6}", "mode", "error", "reach")?;
    for r in results {
        write!(w, " {:>16}", label(r, samples))?;
    }
    writeln!(w)?;
    for (i, p) in first.planted.iter().enumerate() {
        write!(w, "{:<width$} {:>5.2} {:>5.0}%", p.concepts.join(" + "), p.error, 100.0 * p.reach)?;
        for r in results {
            let m = &r.planted[i];
            write!(w, " {:>16}", format!("{:.0}% / {:.0}%", 100.0 * m.recovered, 100.0 * m.exact))?;
        }
        writeln!(w)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::testkit::lattice;
    use crate::ir::{ConceptId, ConceptSet};
    use crate::outcome::Outcome;

    fn set(ids: &[u32]) -> ConceptSet {
        ConceptSet::from_ids(ids.iter().map(|&i| ConceptId(i)))
    }

    fn stats(ids: &[u32], wrong: u32) -> SetStats {
        let mut s = SetStats::new(set(ids));
        (0..5).for_each(|i| s.add(if i < wrong { Outcome::Wrong } else { Outcome::Correct }));
        s
    }

    #[test]
    fn a_core_is_a_failure_whose_every_valid_one_smaller_subset_was_seen_passing() {
        // Concepts 0 and 1 exclude each other, so {0, 1, …} is not in the space.
        let space = Space::new(lattice(5, 3), 5);
        let history = vec![
            stats(&[2], 1),
            stats(&[3], 0),
            stats(&[2, 3], 5),    // a core: {2} and {3} pass
            stats(&[2, 3, 4], 5), // holds the core: {2, 3} fails
            stats(&[0, 4], 4),    // {0} was never evaluated: not a core
            stats(&[1], 3),       // a singleton that fails is a core
            stats(&[4], 2),
            stats(&[2, 4], 1),
        ];
        let mut cores = crate::search::shrink::minimal_failures(&history, &space, 0.6);
        cores.sort();
        assert_eq!(cores, vec![set(&[1]), set(&[2, 3])]);
    }

    #[test]
    fn reach_is_the_share_of_k_sets_the_inferences_can_hold() {
        // Five concepts, 0 and 1 exclusive, sets of up to three: 9 valid pairs, 7 valid triples.
        let space = Space::new(lattice(5, 3), 5);
        // Each observed set holds at most C(3, 2) = 3 pairs: two observations touch 6 of 9.
        assert!((reach(&space, 2, 3, 2) - 6.0 / 9.0).abs() < 1e-12);
        assert!((reach(&space, 3, 3, 3) - 3.0 / 7.0).abs() < 1e-12);
        assert_eq!(reach(&space, 2, 3, 100), 1.0, "capped at every pair");
        assert_eq!(reach(&space, 4, 3, 100), 0.0, "no set of four in the space");
        assert_eq!((binomial(5, 4), binomial(5, 0), binomial(3, 4)), (5, 1, 0));
    }
}

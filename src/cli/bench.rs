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

// Parsed once per process: the size of the search variant's flags costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(clap::Subcommand, Debug)]
pub enum BenchWhat {
    /// Compare the search algorithms against a sim profile
    Search(Box<SearchBenchArgs>),
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
    /// Render every observation's scene with this renderer (`none`, `builtin`), so repeated
    /// scenes are measured [default: the profile's `renderer`, else none]
    #[arg(long, value_name = "RENDERER")]
    pub renderer: Option<String>,
    /// The part of the budget set aside for shrinking each run's failure modes to cores (0: off)
    #[arg(long, value_name = "B", default_value_t = 0)]
    pub shrink: u64,
    /// Model calls in flight (interact's width unless `--batch` is given)
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..))]
    pub concurrency: u32,
    /// The sim model's delay per call in milliseconds [default: the profile's `latency_ms`]; the
    /// timing table compares each run's wall time with the latency limit, budget ÷ concurrency
    /// × latency
    #[arg(long, value_name = "MS")]
    pub latency_ms: Option<u64>,
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
    /// The parameters the search flags resolve to (set by the command, not a flag).
    #[arg(skip)]
    pub params: Params,
}

pub fn run(args: BenchArgs) -> ExitCode {
    match args.what {
        BenchWhat::Search(a) => search(*a),
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
    /// Core precision pooled over seeds (true cores / all cores): a core is false when its true
    /// error is ≤ τ − δ.
    pub pooled_core_precision: Option<f64>,
    /// Share of a run's cores whose reported interval (the confirmed one, when confirmation ran)
    /// holds the core's true error.
    pub coverage: Stat,
    /// Borderline sets per run (confirmation candidates that reached the cap near τ).
    pub borderline: Stat,
    /// Realised false discovery proportion per run: false cores (true error ≤ τ − δ) over
    /// cores, 0 without cores.
    pub fdp: Stat,
    /// Share of planted modes that some core with observed FR ≥ τ contains.
    pub core_recovered: Stat,
    /// Share of planted modes reported exactly as a core.
    pub exact: Stat,
    /// `core_recovered` over the planted modes a search must find — those whose error is at
    /// least τ + δ (issue 28's target); a mode inside the zone may go either way. `n` is 0 when
    /// the profile plants none.
    pub must_find: Stat,
    /// Where the modes a search must find were lost, as shares of all their runs (mode × seed);
    /// `None` when the profile plants none.
    pub must_find_lost: Option<Lost>,
    /// Wall time per inference, microseconds (with a zero-latency profile: Revelio's overhead).
    pub us_per_inference: Stat,
    /// Sets picked per round (interact: the width every call is filled to).
    pub batch: usize,
    /// Model calls per run, every phase.
    pub calls: Stat,
    /// Wall time per run, seconds.
    pub wall_s: Stat,
    /// Observations per run that found no scene their set had not shown (outcome `repeated`:
    /// not asked, not counted in n).
    pub repeated: Stat,
    /// Per planted mode, in the profile's order: how often this algorithm recovered it.
    pub planted: Vec<ModeRecovery>,
    /// Per seed (0, 1, …): the share of planted modes recovered and found exactly as a core, so
    /// two settings on the same seeds can be compared pair by pair.
    pub per_seed: Vec<[Option<f64>; 2]>,
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
    /// Where it was lost in the other seeds ([`Fate`]).
    pub lost: Lost,
}

/// Where a planted mode ended in one run: the first of these that holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    /// Some reported core holds it.
    Recovered,
    /// A confirmation candidate held it and was not confirmed (borderline, passing or
    /// unfinished).
    Unconfirmed,
    /// A failure mode of the search held it; no candidate core did (without confirmation: no
    /// core did).
    NotSent,
    /// Sets the search tested held it; none was failing (observed FR ≥ τ) when the search
    /// ended.
    NotFailing,
    /// No set the search tested held it.
    Untested,
}

impl Fate {
    /// Where `mode` ended in a run whose search tested `history`, that sent `candidates` to
    /// confirmation and reported `cores`.
    pub fn of(
        mode: crate::ir::ConceptSet,
        cores: &[crate::ir::ConceptSet],
        candidates: &[crate::ir::ConceptSet],
        history: &[SetStats],
        threshold: f64,
    ) -> Fate {
        let holds = |set: &crate::ir::ConceptSet| mode.is_subset_of(*set);
        if cores.iter().any(holds) {
            Fate::Recovered
        } else if candidates.iter().any(holds) {
            Fate::Unconfirmed
        } else if history.iter().any(|s| holds(&s.set) && s.is_failure_mode(threshold)) {
            Fate::NotSent
        } else if history.iter().any(|s| holds(&s.set)) {
            Fate::NotFailing
        } else {
            Fate::Untested
        }
    }
}

/// Shares of runs (or of mode-runs) a planted mode was lost in, by where ([`Fate`]); with the
/// share recovered they sum to 1.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Lost {
    pub untested: f64,
    pub not_failing: f64,
    pub not_sent: f64,
    pub unconfirmed: f64,
}

impl Lost {
    /// The shares of `fates` lost at each step.
    pub fn of(fates: &[Fate]) -> Lost {
        let share = |f: Fate| fates.iter().filter(|&&x| x == f).count() as f64 / fates.len().max(1) as f64;
        Lost {
            untested: share(Fate::Untested),
            not_failing: share(Fate::NotFailing),
            not_sent: share(Fate::NotSent),
            unconfirmed: share(Fate::Unconfirmed),
        }
    }
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
    /// (true cores, cores): for the pooled precision.
    core_counts: (usize, usize),
    coverage: Option<f64>,
    borderline: f64,
    fdp: f64,
    core_recovered: Option<f64>,
    exact: Option<f64>,
    us: f64,
    calls: f64,
    wall_s: f64,
    repeated: f64,
    /// Per planted mode: where it ended (recovered: some core holds it), and whether it is a
    /// core itself.
    per_mode: Vec<(Fate, bool)>,
}

/// One benchmark run's parameters: `algo` and `seed` on `at`; interact's width is the
/// concurrency unless `--batch` says otherwise, and GPTS's beam phase half its search budget.
pub(crate) fn run_params(args: &SearchBenchArgs, at: &Params, algo: Algo, seed: u64) -> Params {
    let batch = args.search.batch.unwrap_or(if algo == Algo::Interact { args.concurrency as usize } else { at.batch });
    let p = Params { algo, seed, batch, ..at.clone() };
    Params { beam_budget: p.beam_budget.min(p.plan().search), ..p }
}

fn search(mut args: SearchBenchArgs) -> ExitCode {
    args.params = args.search.params(Algo::Random, None, 1);
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
        Ok(p) => Profile { latency_ms: args.latency_ms.unwrap_or(p.latency_ms), ..p },
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let renderer = args.renderer.clone().unwrap_or_else(|| profile.renderer.clone());
    if !matches!(renderer.as_str(), "none" | "builtin") {
        eprintln!("error: invalid `--renderer` `{renderer}`: `revelio bench search` renders with `none` or `builtin`");
        return ExitCode::from(2);
    }
    args.renderer = Some(renderer);
    let base = Params { shrink: args.shrink, ..args.params.clone() };
    let base = Params { beam_budget: base.plan().search / 2, ..base };
    let sequential = Params { max_samples: args.max_samples, ..base.clone() };
    if let Err(e) = base.validate().and_then(|_| sequential.validate()) {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let mut modes = vec![base.clone()];
    if args.max_samples.is_some_and(|m| m > args.params.samples) {
        modes.push(sequential);
    }
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let lattice = Lattice::enumerate(&domain, base.max_size);
    let (space, _) = runner::search_space(lattice.sets, domain.concepts.len(), world.as_ref());
    let tmp = std::env::temp_dir().join(format!("revelio-bench-{}", std::process::id()));
    let planted = profile.planted(args.params.threshold, |s| space.contains(s));
    let truth = profile.clone();
    let latency_ms = profile.latency_ms;
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
        .map(|p| (truth.error_for(*p), reach(&space, p.len(), base.max_size, base.max_calls())))
        .collect();
    // The planted modes a search must find: error ≥ τ + δ (inside the zone either answer is
    // acceptable).
    let must: Vec<usize> =
        (0..planted.len()).filter(|&i| truths[i].0 >= args.params.threshold + args.params.delta - 1e-9).collect();
    let mut results = Vec::new();
    let algos = if args.algos.is_empty() { Algo::ALL.to_vec() } else { args.algos.clone() };
    for algo in algos {
        for mode in &modes {
            let mut rows: Vec<RunFigures> = Vec::new();
            for seed in 0..args.seeds {
                let params = run_params(&args, mode, algo, seed);
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
                pooled_core_precision: {
                    let (t, n) = rows.iter().fold((0, 0), |(t, n), r| (t + r.core_counts.0, n + r.core_counts.1));
                    (n > 0).then(|| t as f64 / n as f64)
                },
                coverage: col(&|r| r.coverage, share),
                borderline: col(&|r| Some(r.borderline), count),
                fdp: col(&|r| Some(r.fdp), share),
                core_recovered: col(&|r| r.core_recovered, share),
                exact: col(&|r| r.exact, share),
                must_find_lost: (!must.is_empty()).then(|| {
                    Lost::of(&rows.iter().flat_map(|r| must.iter().map(|&i| r.per_mode[i].0)).collect::<Vec<_>>())
                }),
                must_find: col(
                    &|r| {
                        let held = must.iter().filter(|&&i| r.per_mode[i].0 == Fate::Recovered).count();
                        (!must.is_empty()).then(|| held as f64 / must.len() as f64)
                    },
                    share,
                ),
                us_per_inference: col(&|r| Some(r.us), count),
                batch: run_params(&args, mode, algo, 0).batch,
                calls: col(&|r| Some(r.calls), count),
                wall_s: col(&|r| Some(r.wall_s), count),
                repeated: col(&|r| Some(r.repeated), count),
                per_seed: rows.iter().map(|r| [r.core_recovered, r.exact]).collect(),
                planted: planted
                    .iter()
                    .enumerate()
                    .map(|(i, p)| {
                        let of = |f: fn(&(Fate, bool)) -> bool| {
                            rows.iter().filter(|r| f(&r.per_mode[i])).count() as f64 / rows.len().max(1) as f64
                        };
                        ModeRecovery {
                            concepts: names(&domain, *p),
                            error: truths[i].0,
                            reach: truths[i].1,
                            recovered: of(|m| m.0 == Fate::Recovered),
                            exact: of(|m| m.1),
                            lost: Lost::of(&rows.iter().map(|r| r.per_mode[i].0).collect::<Vec<_>>()),
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
            .and_then(|()| print_timing(&mut w, &args, &results, latency_ms))
            .and_then(|()| {
                print_planted(
                    &mut w,
                    &results,
                    args.params.samples,
                    base.max_calls(),
                    args.params.threshold + args.params.delta,
                )
            })
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
    let renderer_spec = bench_renderer(args);
    let renderer = crate::render::build_renderer(renderer_spec, &Default::default())?;
    let config =
        RunConfig::new(domain, &args.domain, &spec, model.as_ref(), ModelSettings::default(), renderer_spec, params);
    let mut setup = Setup::new(domain.clone(), world.clone(), model.clone(), renderer, out);
    setup.concurrency = args.concurrency as usize;
    let started = Instant::now();
    let r = runtime().block_on(runner::search(&setup, &config, space)).map_err(|e| e.to_string())?;
    let elapsed = started.elapsed();
    let m = &r.summary.metrics;
    let modes: Vec<_> = r.history.iter().filter(|s| s.is_failure_mode(args.params.threshold)).map(|s| s.set).collect();
    // With confirmation, the reported cores are the confirmed ones and their interval is the
    // fresh observations' (summary.json `cores[].confirmed`).
    let intervals: Vec<[f64; 2]> = if r.summary.shrink.is_some() {
        r.summary.cores.iter().map(|c| c.confirmed.as_ref().unwrap_or(&c.set).ci95).collect()
    } else {
        Vec::new()
    };
    let cores: Vec<_> = if r.summary.shrink.is_some() {
        r.found.cores.iter().map(|c| c.stats.set).collect()
    } else {
        crate::search::shrink::minimal_failures(&r.history, space, args.params.threshold)
    };
    let share = |k: usize| (!planted.is_empty()).then(|| k as f64 / planted.len() as f64);
    // A core is true when its error is above τ − δ (inside the zone either answer is right).
    let zone_low = args.params.threshold - args.params.delta + 1e-9;
    let candidates: Vec<_> = r.confirmation.iter().flatten().map(|c| c.stats.set).collect();
    let per_mode: Vec<(Fate, bool)> = planted
        .iter()
        .map(|&p| (Fate::of(p, &cores, &candidates, &r.history, args.params.threshold), cores.contains(&p)))
        .collect();
    let spent = r.summary.calls_made();
    Ok(RunFigures {
        pfm: m.pfm,
        mfr: m.mfr,
        div: m.div,
        failure_modes: modes.len() as f64,
        false_modes: (modes.len() - true_modes(truth, &modes, args.params.threshold)) as f64,
        precision: precision(truth, &modes, args.params.threshold),
        recovered: recovered(&r.history, planted, args.params.threshold),
        cores: cores.len() as f64,
        core_precision: precision(truth, &cores, zone_low),
        core_counts: (true_modes(truth, &cores, zone_low), cores.len()),
        coverage: (!cores.is_empty()).then(|| {
            let held = cores
                .iter()
                .enumerate()
                .filter(|(i, c)| {
                    let [lo, hi] = intervals
                        .get(*i)
                        .copied()
                        .unwrap_or_else(|| r.history.iter().find(|s| s.set == **c).map_or([0.0, 1.0], SetStats::ci95));
                    let e = truth.error_for(**c);
                    lo <= e && e <= hi
                })
                .count();
            held as f64 / cores.len() as f64
        }),
        borderline: r.summary.borderline.len() as f64,
        fdp: if cores.is_empty() {
            0.0
        } else {
            (cores.len() - true_modes(truth, &cores, zone_low)) as f64 / cores.len() as f64
        },
        // Every core failed when it was confirmed (the shrink keeps failing subsets only).
        core_recovered: share(per_mode.iter().filter(|m| m.0 == Fate::Recovered).count()),
        exact: share(per_mode.iter().filter(|m| m.1).count()),
        us: 1e6 * elapsed.as_secs_f64() / (spent.max(1) as f64),
        calls: spent as f64,
        wall_s: elapsed.as_secs_f64(),
        repeated: r.summary.repeated_scenes.iter().map(|row| f64::from(row.repeated)).sum(),
        per_mode,
    })
}

/// The renderer a bench draws with: `--renderer`, else the profile's (resolved in `search`).
pub(crate) fn bench_renderer(args: &SearchBenchArgs) -> &str {
    args.renderer.as_deref().unwrap_or("none")
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
        "{} seeds × budget {} (m = {}{seq}, τ = {}, λ = {}, w = {}{shrink}) against `{}`, renderer {}",
        args.seeds,
        args.params.budget,
        args.params.samples,
        args.params.threshold,
        args.params.lambda,
        args.params.beam_width,
        args.profile.display(),
        bench_renderer(args)
    )?;
    writeln!(
        w,
        "mean [95% interval over seeds]; FMs: failure modes reported, false: true error < τ, precision: share ≥ τ; \
         planted found: held by a failure mode; recovered: held by a core; exact: reported as a core; \
         a core is false when its true error is ≤ τ − δ (δ = {}): core precision (pooled over seeds in \
         parentheses), FDP: false cores / cores per run; coverage: cores whose interval holds the true error; \
         borderline: candidates left near τ at the confirmation cap",
        args.params.delta
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
        "{:<12} {:>18} {:>18} {:>17} {:>18} {:>18} {:>14} {:>15} {:>18} {:>16} {:>14} {:>14} {:>16} {:>16} {:>14}  µs/inference",
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
        "exact %",
        "FDP %",
        "coverage %",
        "borderline"
    )?;
    for r in results {
        let name = label(r, args.params.samples);
        writeln!(
            w,
            "{:<12} {:>18} {:>18} {:>17} {:>18} {:>18} {:>14} {:>15} {:>18} {:>16} {:>14} {:>14} {:>16} {:>16} {:>14}  {:.0}",
            name,
            f(&r.pfm, 1.0, 1),
            f(&r.mfr, 1.0, 1),
            f(&r.div, 1.0, 2),
            f(&r.failure_modes, 1.0, 1),
            f(&r.false_modes, 1.0, 1),
            f(&r.precision, 100.0, 0),
            planted_col(&r.recovered),
            f(&r.cores, 1.0, 1),
            format!(
                "{} ({})",
                f(&r.core_precision, 100.0, 0),
                r.pooled_core_precision.map_or_else(|| "-".into(), |p| format!("{:.0}", 100.0 * p))
            ),
            planted_col(&r.core_recovered),
            planted_col(&r.exact),
            f(&r.fdp, 100.0, 0),
            f(&r.coverage, 100.0, 0),
            f(&r.borderline, 1.0, 1),
            r.us_per_inference.mean
        )?;
    }
    if bench_renderer(args) != "none" {
        let rows: Vec<String> =
            results.iter().map(|r| format!("{} {:.1}", label(r, args.params.samples), r.repeated.mean + 0.0)).collect();
        writeln!(w, "repeated scenes per run (not asked, not in n): {}", rows.join(", "))?;
    }
    let pfm =
        |a: Algo| results.iter().find(|r| r.algo == a && r.max_samples == args.params.samples).map(|r| r.pfm.mean);
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

/// The timing table: per algorithm its concurrency and batch, its calls and wall time per run,
/// and the latency limit — budget ÷ concurrency × latency, the least time `--budget` calls take
/// at that concurrency when each takes `latency_ms` — with the wall time's ratio to it.
fn print_timing(
    w: &mut impl Write,
    args: &SearchBenchArgs,
    results: &[AlgoResult],
    latency_ms: u64,
) -> std::io::Result<()> {
    let limit = args.params.budget as f64 / f64::from(args.concurrency) * latency_ms as f64 / 1000.0;
    writeln!(
        w,
        "
wall time per run at {latency_ms} ms a call; limit: budget ÷ concurrency × latency = {limit:.1} s"
    )?;
    writeln!(
        w,
        "{:<12} {:>11} {:>5} {:>8} {:>18} {:>8}",
        "algo", "concurrency", "batch", "calls", "wall s", "× limit"
    )?;
    for r in results {
        let ratio = if limit > 0.0 { format!("{:.2}", r.wall_s.mean / limit) } else { "-".into() };
        writeln!(
            w,
            "{:<12} {:>11} {:>5} {:>8.0} {:>18} {:>8}",
            label(r, args.params.samples),
            args.concurrency,
            r.batch,
            r.calls.mean,
            format!("{:.1} [{:.1}–{:.1}]", r.wall_s.mean, r.wall_s.ci95[0], r.wall_s.ci95[1]),
            ratio
        )?;
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
fn print_planted(
    w: &mut impl Write,
    results: &[AlgoResult],
    samples: u32,
    inferences: u64,
    zone_high: f64,
) -> std::io::Result<()> {
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
    if first.must_find.n > 0 {
        write!(w, "{:<width$} {:>12}", format!("error ≥ τ + δ ({zone_high:.2}): recovered"), "")?;
        for r in results {
            write!(w, " {:>16}", format!("{:.0}%", 100.0 * r.must_find.mean))?;
        }
        writeln!(w)?;
        writeln!(
            w,
            "\nerror ≥ τ + δ, where the modes not recovered were lost, as shares of mode-runs (untested: in no \
             set the search tested)"
        )?;
        writeln!(
            w,
            "{:<16} {:>10} {:>20} {:>18} {:>20}",
            "", "untested", "tested, not failing", "failing, not sent", "sent, not confirmed"
        )?;
        for r in results {
            if let Some(l) = &r.must_find_lost {
                let pc = |x: f64| format!("{:.0}%", 100.0 * x);
                writeln!(
                    w,
                    "{:<16} {:>10} {:>20} {:>18} {:>20}",
                    label(r, samples),
                    pc(l.untested),
                    pc(l.not_failing),
                    pc(l.not_sent),
                    pc(l.unconfirmed)
                )?;
            }
        }
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
    fn a_planted_mode_is_placed_at_the_first_step_that_lost_it() {
        let (mode, tau) = (set(&[2, 3]), 0.6);
        let history = vec![stats(&[2, 3, 4], 1), stats(&[1, 2], 5)];
        let fate = |cores: &[ConceptSet], candidates: &[ConceptSet], history: &[SetStats]| {
            Fate::of(mode, cores, candidates, history, tau)
        };
        assert_eq!(fate(&[], &[], &history[1..]), Fate::Untested, "{{1, 2}} does not hold it");
        assert_eq!(fate(&[], &[], &history), Fate::NotFailing, "{{2, 3, 4}} holds it, 1 of 5 wrong");
        let failing = [stats(&[2, 3, 4], 4)];
        assert_eq!(fate(&[], &[], &failing), Fate::NotSent);
        assert_eq!(fate(&[], &[set(&[2, 3, 4])], &failing), Fate::Unconfirmed);
        assert_eq!(fate(&[], &[set(&[2])], &failing), Fate::NotSent, "a candidate that does not hold it");
        assert_eq!(fate(&[set(&[2, 3, 4])], &[set(&[2, 3, 4])], &failing), Fate::Recovered);
        let lost = Lost::of(&[Fate::Recovered, Fate::Untested, Fate::Untested, Fate::Unconfirmed]);
        assert_eq!(lost, Lost { untested: 0.5, not_failing: 0.0, not_sent: 0.0, unconfirmed: 0.25 });
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

//! `revelio transfer RUN_DIR --model M2 [--model M3 …] [--top k] [--samples n]`: the paper's
//! RQ3. Evaluates a finished run's top sets on other models with the same scenes (the same scene
//! seeds, so identical images, rendered once for all models), plus as many random valid sets as
//! a baseline; the run's own model is asked on the same scenes too, so every column compares
//! like with like. Prints the transfer table and writes `transfer.json`. Every observation is
//! journaled in the run folder under phase `transfer` with its model, so the same command (or one
//! with more models) resumes. Exit codes as for `search`.
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::analysis::reask;
use crate::analysis::transfer::{Transfer, TransferReport, table};
use crate::ir::ConceptSet;
use crate::lattice::Lattice;
use crate::run::runner;
use crate::run::setup;
use crate::search::interval::pct;
use crate::vlm::Model;

use super::common::{ModelFlags, RunFlags, fail_run};
use super::reask::{RunParts, open_parts, top_sets};
use crate::run::estimate::{self, Estimate};

#[derive(clap::Args, Debug)]
pub struct TransferArgs {
    /// A finished `revelio search` run folder
    pub run_dir: PathBuf,
    /// A target model (repeat for more), as for `search --model`
    #[arg(long = "model", required = true)]
    pub models: Vec<String>,
    /// Sets to transfer (in the order of the search's table)
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..))]
    pub top: u64,
    /// Observations per set and model
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    pub samples: u32,
    /// Random valid sets for the baseline [default: as many as transferred]
    #[arg(long)]
    pub random: Option<usize>,
    #[command(flatten)]
    pub run: RunFlags,
    /// Flags for the target models; `--renderer-base-url`, `--allow-http` and the cache flags
    /// serve the run's own model and renderer too
    #[command(flatten)]
    pub model_opts: ModelFlags,
    /// The run's own model's endpoint, when the run was made with `--base-url` (a run folder
    /// never chooses where a key goes)
    #[arg(long, value_name = "URL")]
    pub run_base_url: Option<String>,
    /// The run's own model's settings (TOML), when the run was made with `--model-config`
    #[arg(long, value_name = "FILE")]
    pub run_model_config: Option<PathBuf>,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

/// `k` random sets of `space` not in `exclude`, drawn by `seed`.
fn random_sets(space: &[ConceptSet], exclude: &[ConceptSet], k: usize, seed: u64) -> Vec<ConceptSet> {
    let mut pool: Vec<ConceptSet> = space.iter().copied().filter(|s| !exclude.contains(s)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5241_4e44_4f4d);
    let k = k.min(pool.len());
    for i in 0..k {
        let j = rng.random_range(i..pool.len());
        pool.swap(i, j);
    }
    pool.truncate(k);
    pool
}

/// `--dry-run`: every model's calls (the run's own included) and what they come to.
fn dry_run(args: &TransferArgs, parts: &RunParts) -> ExitCode {
    let cache = args.model_opts.cache();
    let settings = setup::ModelSettings { dry_run: true, ..args.model_opts.settings() };
    let mut models: Vec<Arc<dyn Model>> = vec![parts.model.clone()];
    for spec in &args.models {
        match setup::build_parts(&parts.domain, spec, "none", &settings, cache.as_deref(), None) {
            Ok(p) => models.push(p.model),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(e.exit_code());
            }
        }
    }
    let sets = match top_sets(&parts.domain, &parts.summary, args.top as usize) {
        Ok(s) => s,
        Err(e) => return fail_run(&e, &args.run_dir),
    };
    let world = parts.world();
    let lattice = Lattice::enumerate(&parts.domain, parts.config.params.max_size);
    let (space, _) = runner::search_space(lattice.sets, parts.domain.concepts.len(), &world);
    let random = random_sets(&space.sets, &sets, args.random.unwrap_or(sets.len()), parts.config.params.seed);
    let all: Vec<ConceptSet> = sets.iter().chain(&random).copied().collect();
    let prompts = estimate::sample_prompts(&world, &all);
    let calls = all.len() as u64 * u64::from(args.samples);
    let estimates: Vec<Estimate> = models
        .iter()
        .map(|m| Estimate::new("transfer", m.as_ref(), calls, false, &prompts, parts.image_size()))
        .collect();
    args.run.print_dry_run(&estimates, args.json)
}

pub fn run(args: TransferArgs) -> ExitCode {
    let source_flags = ModelFlags {
        base_url: args.run_base_url.clone(),
        renderer_base_url: args.model_opts.renderer_base_url.clone(),
        model_config: args.run_model_config.clone(),
        allow_http: args.model_opts.allow_http,
        cache_dir: args.model_opts.cache_dir.clone(),
        no_cache: args.model_opts.no_cache,
        ..Default::default()
    };
    let parts = match open_parts(&args.run_dir, &source_flags, setup::RUN_FLAGS, &args.run) {
        Ok(o) => o,
        Err(code) => return code,
    };
    if args.run.dry_run {
        return dry_run(&args, &parts);
    }
    let open = match parts.journal(&args.run_dir, &args.run, args.json) {
        Ok(o) => o,
        Err(code) => return code,
    };
    let cache = args.model_opts.cache();
    let mut settings = args.model_opts.settings();
    settings.batch = args.run.batch_api.then(|| args.run_dir.clone());
    let mut models: Vec<Arc<dyn Model>> = vec![open.model.clone()];
    for spec in &args.models {
        match setup::build_parts(&open.domain, spec, "none", &settings, cache.as_deref(), None) {
            Ok(p) => models.push(p.model),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(e.exit_code());
            }
        }
    }
    let ids: Vec<String> = models.iter().map(|m| m.id()).collect();
    for (i, id) in ids.iter().enumerate() {
        if ids[..i].contains(id) {
            eprintln!("error: `--model` names `{id}` twice (the run's own model is always asked)");
            return ExitCode::from(2);
        }
    }
    let sets = match top_sets(&open.domain, &open.summary, args.top as usize) {
        Ok(s) => s,
        Err(e) => return fail_run(&e, &args.run_dir),
    };
    let world = crate::run::observe::DomainWorld::new(&open.domain);
    let lattice = Lattice::enumerate(&open.domain, open.config.params.max_size);
    let (space, _) = runner::search_space(lattice.sets, open.domain.concepts.len(), &world);
    let random = random_sets(&space.sets, &sets, args.random.unwrap_or(sets.len()), open.config.params.seed);
    let all: Vec<ConceptSet> = sets.iter().chain(&random).copied().collect();
    let what = format!("{} sets × {} observations × {} models", all.len(), args.samples, models.len());
    let most = all.len() as u64 * u64::from(args.samples) * models.len() as u64;
    super::common::say_most_calls("transfer", most, &what);
    let (stats, spend) = match open.ask(&args.run_dir, reask::transfer(&open.reask, &models, &all, args.samples)) {
        Ok(x) => x,
        Err(code) => return code,
    };
    let names = |s: &ConceptSet| open.domain.set_names(*s).into_iter().map(String::from).collect::<Vec<_>>();
    let source_fr: Vec<Option<f64>> =
        sets.iter().map(|s| open.summary.sets.iter().find(|r| r.concepts == names(s)).and_then(|r| r.fr)).collect();
    let n = sets.len();
    let transferred: Vec<Vec<_>> = stats.iter().map(|m| m[..n].to_vec()).collect();
    let baseline: Vec<Vec<_>> = stats.iter().map(|m| m[n..].to_vec()).collect();
    let report = TransferReport {
        transfer: table(
            &open.config.model,
            &ids,
            open.config.params.threshold,
            args.samples,
            &sets.iter().map(names).collect::<Vec<_>>(),
            &source_fr,
            &transferred,
            &random.iter().map(names).collect::<Vec<_>>(),
            &baseline,
        ),
        spend,
    };
    open.finish(&args.run_dir, "transfer.json", &report, args.json, |w| print_transfer(w, &report.transfer))
}

pub fn print_transfer(w: &mut impl Write, t: &Transfer) -> std::io::Result<()> {
    writeln!(w, "models (M1 is the run's own):")?;
    for (i, m) in t.models.iter().enumerate() {
        writeln!(w, "  M{}  {m}", i + 1)?;
    }
    let heads: String = (1..=t.models.len()).map(|i| format!("  {:>5}", format!("M{i}"))).collect();
    writeln!(w, "{:>4}  {:>6}{heads}  concepts", "#", "search")?;
    for (i, s) in t.sets.iter().enumerate() {
        let cells: String = s.target_fr.iter().map(|f| format!("  {:>5}", pct(*f))).collect();
        writeln!(w, "{:>4}  {:>6}{cells}  {}", i + 1, pct(s.source_fr), s.concepts.join(" + "))?;
    }
    writeln!(
        w,
        "{} transferred and {} random sets × {} observations; transfers: FR ≥ {:.0}%",
        t.sets.len(),
        t.random.len(),
        t.samples,
        100.0 * t.threshold
    )?;
    writeln!(w, "{:>5}  {:>11}  {:>10}  {:>6}  {:>9}", "model", "transferred", "random", "ratio", "transfers")?;
    for (i, r) in t.targets.iter().enumerate() {
        writeln!(
            w,
            "{:>5}  {:>11}  {:>10}  {:>6}  {:>9}",
            format!("M{}", i + 1),
            pct(r.transferred_mfr),
            pct(r.random_mfr),
            r.ratio.map_or_else(|| "-".into(), |x| format!("{x:.1}×")),
            format!("{}/{}", r.transfers, t.sets.len())
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_sets_are_seeded_distinct_and_exclude_the_transferred() {
        let space: Vec<ConceptSet> = (1..30u128).map(ConceptSet::from_bits).collect();
        let a = random_sets(&space, &space[..3], 10, 1);
        assert_eq!(a, random_sets(&space, &space[..3], 10, 1));
        assert_eq!(a.len(), 10);
        assert!(a.iter().all(|s| !space[..3].contains(s)));
        let mut d = a.clone();
        d.sort();
        d.dedup();
        assert_eq!(d.len(), 10);
        assert_eq!(random_sets(&space, &[], 100, 1).len(), space.len());
    }
}

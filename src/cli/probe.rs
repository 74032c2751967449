//! `revelio probe RUN_DIR [--top k] [--samples n]`: recognition vs. reasoning (paper appendix
//! G). Re-asks a finished run's cores and top sets with the safety prompt extended by each present
//! concept's probe statement and its counterfactual, answered True/False in the same reply as
//! the option; prints R(c), F(c), n and the mechanism per concept and the lift of concept pairs;
//! writes `probe.json`. Observations are journaled under phase `probe`, so the same command
//! resumes. Exit codes as for `search`.
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use crate::analysis::probe::{ProbeReport, Thresholds};
use crate::analysis::reask::{self, Reask};
use crate::ir::ConceptSet;
use crate::run::RunError;
use crate::search::interval::pct;
use crate::vlm::Model;

use super::common::{ModelFlags, RunFlags, fail_run};
use super::reask::{open_parts, probe_order};
use crate::run::estimate::Estimate;

#[derive(clap::Args, Debug)]
pub struct ProbeArgs {
    /// A finished `revelio search` run folder
    pub run_dir: PathBuf,
    /// Sets to probe: the run's cores first (when it shrank), then the search's table in order
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..))]
    pub top: u64,
    /// Probe observations per set
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    pub samples: u32,
    /// Recognition rate at or above which a concept's failures are reasoning failures
    #[arg(long, default_value_t = 0.7)]
    pub high: f64,
    /// Recognition rate at or below which a concept's failures are recognition failures
    #[arg(long, default_value_t = 0.3)]
    pub low: f64,
    /// Probed sets each concept of a pair must appear in for the pair's lift to be reported
    #[arg(long, default_value_t = 10)]
    pub min_n: usize,
    #[command(flatten)]
    pub run: RunFlags,
    #[command(flatten)]
    pub model_opts: ModelFlags,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

/// Probe `sets` and analyse the replies.
pub async fn probe_sets(
    r: &Reask,
    model: Arc<dyn Model>,
    sets: &[ConceptSet],
    samples: u32,
    t: &Thresholds,
) -> Result<ProbeReport, RunError> {
    t.validate().map_err(RunError::Usage)?;
    let (probed, spend) = reask::probe(r, model.clone(), sets, samples).await?;
    Ok(ProbeReport::new(model.id(), &probed, samples, t, spend))
}

pub fn run(args: ProbeArgs) -> ExitCode {
    let t = Thresholds { high: args.high, low: args.low, min_n: args.min_n };
    if let Err(e) = t.validate() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    let parts = match open_parts(&args.run_dir, &args.model_opts, crate::run::setup::FLAGS, &args.run) {
        Ok(o) => o,
        Err(code) => return code,
    };
    if args.run.dry_run {
        let sets = match probe_order(&parts.domain, &parts.summary, args.top as usize) {
            Ok(s) => s,
            Err(e) => return fail_run(&e, &args.run_dir),
        };
        let world = parts.world();
        let prompts: Vec<String> = sets
            .iter()
            .filter_map(|&set| {
                let t = crate::run::World::task(&world, set).ok()?;
                let st = reask::statements(&parts.domain, set, parts.config.params.seed);
                let texts: Vec<String> = st.into_iter().map(|s| s.text).collect();
                Some(crate::vlm::prompt::build_probe(&t.question, &t.options, &texts))
            })
            .collect();
        let calls = sets.len() as u64 * u64::from(args.samples);
        let e = Estimate::new("probe", parts.model.as_ref(), calls, false, &prompts, parts.image_size());
        return args.run.print_dry_run(&[e], args.json);
    }
    let open = match parts.journal(&args.run_dir, &args.run, args.json) {
        Ok(o) => o,
        Err(code) => return code,
    };
    let sets = match probe_order(&open.domain, &open.summary, args.top as usize) {
        Ok(s) => s,
        Err(e) => return fail_run(&e, &args.run_dir),
    };
    let what = format!("{} sets × {} probe observations", sets.len(), args.samples);
    super::common::say_most_calls("probe", sets.len() as u64 * u64::from(args.samples), &what);
    let asked = open.ask(&args.run_dir, probe_sets(&open.reask, open.model.clone(), &sets, args.samples, &t));
    match asked {
        Ok(report) => open.finish(&args.run_dir, "probe.json", &report, args.json, |w| print_probe(w, &report)),
        Err(code) => code,
    }
}

pub fn print_probe(w: &mut impl Write, r: &ProbeReport) -> std::io::Result<()> {
    let a = &r.analysis;
    let width = a.concepts.iter().map(|c| c.concept.len()).max().unwrap_or(7).max(7);
    writeln!(
        w,
        "{} sets × {} probe observations on {}; mechanism: reasoning R ≥ {:.0}%, recognition R ≤ {:.0}%",
        r.top,
        r.samples,
        r.model,
        100.0 * a.thresholds.high,
        100.0 * a.thresholds.low
    )?;
    writeln!(w, "{:<width$}  {:>5}  {:>5}  {:>4}  mechanism", "concept", "R", "F", "n")?;
    for c in &a.concepts {
        writeln!(
            w,
            "{:<width$}  {:>5}  {:>5}  {:>4}  {}",
            c.concept,
            pct(c.recognition),
            pct(c.failure),
            c.n,
            c.mechanism.map_or("-", |m| m.name())
        )?;
    }
    if a.pairs.is_empty() {
        writeln!(w, "no concept pair has both concepts in ≥ {} probed sets (see `--min-n`)", a.thresholds.min_n)?;
    } else {
        writeln!(w, "pairs (both concepts in ≥ {} probed sets), largest |lift| first:", a.thresholds.min_n)?;
        writeln!(w, "{:>6}  {:>6}  {:>6}  {:>4}  pair", "joint", "indep.", "lift", "n")?;
        for p in &a.pairs {
            writeln!(
                w,
                "{:>6}  {:>6}  {:>+6.1}  {:>4}  {} + {}",
                pct(Some(p.joint)),
                pct(Some(p.independent)),
                100.0 * p.lift,
                p.n,
                p.a,
                p.b
            )?;
        }
    }
    if r.unanswered_statements > 0 {
        writeln!(
            w,
            "{} statements were left unmarked by the replies (counted as unanswered)",
            r.unanswered_statements
        )?;
    }
    writeln!(w, "spend: {}", r.spend.line())
}

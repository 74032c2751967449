//! `revelio validate RUN_DIR --top 10 --samples 20 [--max-samples M]`: re-evaluate a run's top
//! sets with fresh scenes (paper section 4) — sequentially with `--max-samples`: a set whose
//! anytime-valid 95 % interval still reaches both below τ − δ and above τ + δ (the run's τ and
//! δ) gets more, up to M — journaled in the run folder;
//! reports each validated FR with its interval, mean ± sd FR and how many reach FR ≥ 0.8, then
//! refreshes the run report.
//!
//! The sets are taken in the order of the search's table. The model is rebuilt from the recorded
//! `--model` and renderer, but where its requests go — `--base-url`, `--renderer-base-url`,
//! `--model-config` — only from the flags given here and the environment, never from
//! `config.json` (see `run::setup`); the model must stay the same. Each setting writes its own file, `validation-top{K}-samples{m}.json` (with
//! `-max{M}` before `.json` when sequential), so validating again with other options never
//! overwrites an earlier result; the observations themselves are shared through the journal (the
//! first 20 of `--samples 40` are those of `--samples 20`). Exit codes as for `search`.
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use crate::diag::TerminalSafe;
use crate::run::observe::{DomainWorld, World};
use crate::run::runner::{self, Setup};
use crate::run::setup::{self, Parts, SetupError};
use crate::run::summary;
use crate::run::summary::{CONSISTENT_FR, Validation};
use crate::search::interval::pct;

use super::common::{ModelFlags, RunFlags, fail_run, fr_ci_text, runtime, watch_ctrl_c};

#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// A finished `revelio search` run folder
    pub run_dir: PathBuf,
    /// Sets to validate (in the order of the search's table)
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..))]
    pub top: u64,
    /// Fresh observations per set
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..))]
    pub samples: u32,
    /// Sequential validation: a set whose anytime-valid 95 % interval still reaches both below
    /// τ − δ and above τ + δ (the run's) gets more observations, up to M [default: --samples]
    #[arg(long, value_name = "M")]
    pub max_samples: Option<u32>,
    #[command(flatten)]
    pub run: RunFlags,
    #[command(flatten)]
    pub model_opts: ModelFlags,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: ValidateArgs) -> ExitCode {
    let (config, summary) = match summary::load_run(&args.run_dir) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(e.exit_code());
        }
    };
    let domain = match crate::cli::load_domain(std::path::Path::new(&config.domain_file)) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let setup_error = |e: SetupError| {
        eprintln!("error: {e}");
        ExitCode::from(e.exit_code())
    };
    if domain.identity().to_string() != config.domain_hash {
        return setup_error(SetupError::DomainChanged { file: config.domain_file.clone(), dir: args.run_dir.clone() });
    }
    let mut settings = match args.model_opts.settings().resume(&config.model_settings, setup::FLAGS) {
        Ok(s) => s,
        Err(e) => return setup_error(e),
    };
    settings.batch = args.run.batch_api.then(|| args.run_dir.clone());
    settings.dry_run = args.run.dry_run;
    let cache = args.model_opts.cache();
    let concurrency = args.run.concurrency.map(|c| c as usize);
    let Parts { model, renderer, concurrency } = match setup::build_parts(
        &domain,
        &config.model_spec,
        &config.renderer,
        &settings,
        cache.as_deref(),
        concurrency,
    ) {
        Ok(p) => p,
        Err(e) => return setup_error(e),
    };
    if model.id() != config.model {
        let was = crate::diag::terminal_safe(&config.model).into_owned();
        return setup_error(SetupError::ModelChanged { now: model.id(), was });
    }
    if let Err(e) = setup::check_endpoint(&settings, config.endpoint.as_deref(), model.as_ref(), setup::FLAGS) {
        return setup_error(e);
    }
    if args.run.dry_run {
        let sets = match super::reask::top_sets(&domain, &summary, args.top as usize) {
            Ok(s) => s,
            Err(e) => return fail_run(&e, &args.run_dir),
        };
        let world = DomainWorld::new(&domain);
        let prompts = crate::run::estimate::sample_prompts(&world, &sets);
        let most = args.max_samples.unwrap_or(args.samples).max(args.samples);
        let calls = sets.len() as u64 * u64::from(most);
        let image = crate::run::estimate::image_size(&config.renderer, &domain);
        let e = crate::run::estimate::Estimate::new(
            "validate",
            model.as_ref(),
            calls,
            most > args.samples,
            &prompts,
            image,
        );
        return args.run.print_dry_run(&[e], args.json);
    }
    let mut config = config;
    config.model_settings = settings;
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let mut setup = Setup::new(Arc::new(domain), world, model, renderer, args.run_dir.clone());
    setup.concurrency = concurrency;
    setup.progress = runner::cli_progress(args.json);
    setup.max_api_errors = args.run.max_api_errors;
    setup.on_corrupt = args.run.on_corrupt();
    if args.top > 0 && args.samples > 0 {
        let sets = (args.top as usize).min(summary.sets.len()) as u64;
        let max = args.max_samples.unwrap_or(args.samples).max(args.samples);
        let how = if max > args.samples { "up to " } else { "" };
        let what = format!("{sets} sets × {how}{max} observations");
        super::common::say_most_calls("validate", sets * u64::from(max), &what);
    }
    setup.purse = args.run.purse();
    let rt = runtime();
    watch_ctrl_c(&rt, &setup.stop);
    let v = match rt.block_on(runner::validate(
        &setup,
        &config,
        &summary,
        args.top as usize,
        args.samples,
        args.max_samples,
    )) {
        Ok(v) => v,
        Err(e) => return fail_run(&e, &args.run_dir),
    };
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &v).map_err(std::io::Error::from).and_then(|_| writeln!(out))
    } else {
        print_validation(&mut TerminalSafe(&mut out), &v).and_then(|()| {
            writeln!(
                out,
                "written to {}",
                args.run_dir.join(summary::validation_file(v.top, v.samples, v.max_samples)).display()
            )
        })
    };
    if written.is_ok() {
        super::report::refresh(&args.run_dir, &setup.domain, args.json);
    }
    if let Err(e) = written
        && e.kind() != std::io::ErrorKind::BrokenPipe
    {
        eprintln!("error: cannot write the report: {e}");
        return ExitCode::from(1);
    }
    let (errors, all) = v.api_errors();
    match runner::api_error_warning(errors, all) {
        Some(w) => {
            eprintln!("error: {w}");
            ExitCode::from(1)
        }
        None => ExitCode::SUCCESS,
    }
}

pub fn print_validation(w: &mut impl Write, v: &Validation) -> std::io::Result<()> {
    writeln!(w, "{:>4}  {:>9}  {:<18}  {:>4}  concepts", "#", "search FR", "valid. FR [95% CI]", "n")?;
    for (i, s) in v.sets.iter().enumerate() {
        writeln!(
            w,
            "{:>4}  {:>9}  {:<18}  {:>4}  {}",
            i + 1,
            pct(s.search.fr),
            fr_ci_text(s.validation.fr, s.validation.ci95),
            s.validation.answered,
            s.search.concepts.join(" + ")
        )?;
    }
    let samples = match v.max_samples {
        Some(max) => format!("{}–{max} samples (sequential)", v.samples),
        None => format!("{} samples", v.samples),
    };
    writeln!(
        w,
        "validated FR {:.1}% ± {:.1}% over {} sets × {samples}; {} of {} reach FR ≥ {:.0}%",
        100.0 * v.mean_fr,
        100.0 * v.sd_fr,
        v.sets.len(),
        v.consistent,
        v.sets.len(),
        100.0 * CONSISTENT_FR
    )?;
    writeln!(w, "spend: {}", v.spend.line())?;
    match crate::run::summary::repeated_line(&v.repeated_scenes) {
        Some(line) => writeln!(w, "{line}"),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::summary::{SetRow, ValidatedSet};

    fn row(concepts: &[&str], wrong: u32, answered: u32) -> SetRow {
        SetRow::from_counts(concepts, wrong, answered)
    }

    #[test]
    fn validation_report() {
        let v = Validation {
            top: 2,
            samples: 20,
            max_samples: None,
            sets: vec![
                ValidatedSet {
                    search: row(&["debris_far", "town_town02"], 5, 5),
                    validation: row(&["debris_far", "town_town02"], 18, 20),
                },
                ValidatedSet { search: row(&["cone", "far"], 3, 5), validation: row(&["cone", "far"], 7, 20) },
            ],
            mean_fr: 0.625,
            sd_fr: 0.3889,
            consistent: 1,
            spend: crate::run::summary::Spend {
                calls: 40,
                input_tokens: 51_600,
                output_tokens: 1_280,
                cost_usd: 0.0542,
                ..Default::default()
            },
            repeated_scenes: Vec::new(),
        };
        let mut out = Vec::new();
        print_validation(&mut out, &v).unwrap();
        insta::assert_snapshot!(String::from_utf8(out).unwrap());
    }
}

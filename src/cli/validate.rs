//! `revelio validate RUN_DIR --top 10 --samples 20`: re-evaluate a run's top sets with fresh
//! scenes (paper section 4), journaled in the run folder; reports mean ± sd FR and how many
//! reach FR ≥ 0.8.
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use crate::journal::domain_hash;
use crate::run::eval::{DomainWorld, World};
use crate::run::runner::{self, CONSISTENT_FR, Setup, Validation};

use super::search::{ModelFlags, build_parts, fr_ci_text, runtime};

#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// A finished `revelio search` run folder
    pub run_dir: PathBuf,
    /// Sets to validate (highest failure rate first)
    #[arg(long, default_value_t = 10)]
    pub top: usize,
    /// Fresh observations per set
    #[arg(long, default_value_t = 20)]
    pub samples: u32,
    /// Sequential validation: a set whose 95 % interval still straddles the run's τ gets more
    /// observations, up to M [default: --samples]
    #[arg(long, value_name = "M")]
    pub max_samples: Option<u32>,
    #[arg(long, default_value_t = 8)]
    pub concurrency: usize,
    #[command(flatten)]
    pub model_opts: ModelFlags,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: ValidateArgs) -> ExitCode {
    let (config, summary) = match runner::load_run(&args.run_dir) {
        Ok(x) => x,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let domain = match crate::cli::load_domain(std::path::Path::new(&config.domain_file)) {
        Ok(d) => d,
        Err(code) => return code,
    };
    if domain_hash(&domain) != config.domain_hash {
        eprintln!(
            "error: `{}` changed since the run in `{}`; validation needs the domain the search used",
            config.domain_file,
            args.run_dir.display()
        );
        return ExitCode::from(1);
    }
    let (model, renderer) =
        match build_parts(&domain, &config.model_spec, &config.renderer, &args.model_opts, &args.run_dir) {
            Ok(p) => p,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(2);
            }
        };
    if model.id() != config.model {
        eprintln!(
            "error: the model now resolves to `{}`, but the run used `{}`; pass the same model flags as the search",
            model.id(),
            config.model
        );
        return ExitCode::from(2);
    }
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let setup = Setup {
        domain: Arc::new(domain),
        world,
        model,
        renderer,
        concurrency: args.concurrency,
        out: args.run_dir.clone(),
        progress: !args.json,
    };
    let v =
        match runtime().block_on(runner::validate(&setup, &config, &summary, args.top, args.samples, args.max_samples))
        {
            Ok(v) => v,
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
        };
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &v).map_err(std::io::Error::from).and_then(|_| writeln!(out))
    } else {
        print_validation(&mut out, &v)
    };
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the report: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

fn pct(f: Option<f64>) -> String {
    f.map_or_else(|| "-".into(), |f| format!("{:.0}%", 100.0 * f))
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
    writeln!(w, "spend: {}", v.spend.line())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::run::runner::{SetRow, ValidatedSet};

    fn row(concepts: &[&str], wrong: u32, answered: u32) -> SetRow {
        SetRow {
            concepts: concepts.iter().map(|c| c.to_string()).collect(),
            fr: Some(f64::from(wrong) / f64::from(answered)),
            ci95: crate::search::interval::wilson(wrong, answered),
            wrong,
            answered,
            observations: answered,
            unanswered: Default::default(),
            core: None,
        }
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
            spend: crate::run::eval::Spend {
                calls: 40,
                input_tokens: 51_600,
                output_tokens: 1_280,
                cost_usd: 0.0542,
                ..Default::default()
            },
        };
        let mut out = Vec::new();
        print_validation(&mut out, &v).unwrap();
        insta::assert_snapshot!(String::from_utf8(out).unwrap());
    }
}

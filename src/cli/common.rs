//! What the commands share: the model and run flags, the Tokio runtime and Ctrl-C handling, how
//! a run that ended early is reported, compiling a domain from a path, and writing to standard
//! output. One home for each, so `search`, `validate`, `probe`, `transfer`, `ask`, `bench` and
//! the rest cannot drift apart.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::check::{self, Compiled};
use crate::diag::terminal_safe;
use crate::run::RunError;
use crate::run::setup::{self, ModelSettings};
use crate::search::gp::Kernel;
use crate::search::interact::{Supersets, Surrogate};
use crate::search::{Algo, Params};
use crate::source::{file_kind, io_reason};

/// Flags that shape how a run calls the model (shared with `validate`).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct RunFlags {
    /// Model calls (and observations) in flight at once [default: the model config's
    /// `concurrency`, else 16]
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub concurrency: Option<u32>,
    /// Stop the run after this many model calls in a row fail (0: never)
    #[arg(long, default_value_t = crate::run::MAX_API_ERRORS)]
    pub max_api_errors: u32,
    /// Ask through the provider's batch API (OpenAI Batch, Anthropic Message Batches, Gemini
    /// batch mode) at half price: answers come within hours, not seconds. `openai:`,
    /// `anthropic:` and `gemini:` models; `--concurrency` is then the most requests per batch
    /// [default: 1000]. Batches are journaled in the run folder (`batches.jsonl`): a killed
    /// command run again waits for its pending batch instead of paying twice
    #[arg(long)]
    pub batch_api: bool,
    /// Move complete journal lines that do not parse into `journal.corrupt` beside the journal
    /// and go on (without it, such a line stops the command and the journal is left as it is)
    #[arg(long)]
    pub set_aside_corrupt: bool,
    /// Stop before spending more than this many US dollars on model calls in this run folder
    /// (its earlier commands included): each call reserves its worst case first; a run stopped
    /// at the cap resumes with a larger one
    #[arg(long, value_name = "USD", value_parser = parse_usd)]
    pub max_cost: Option<f64>,
    /// Print the model calls, tokens and dollars the command would spend, and stop (nothing is
    /// written, no model is called)
    #[arg(long)]
    pub dry_run: bool,
}

/// `--max-cost`: a non-negative, finite number of dollars.
pub(crate) fn parse_usd(s: &str) -> Result<f64, String> {
    match s.trim_start_matches('$').parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a number of US dollars, like `5` or `0.50`, got `{s}`")),
    }
}

impl RunFlags {
    /// The spend cap `--max-cost` sets (the run folder's earlier spend is added when it opens).
    pub fn purse(&self) -> Option<std::sync::Arc<crate::vlm::cost::Purse>> {
        self.max_cost.map(|cap| std::sync::Arc::new(crate::vlm::cost::Purse::new(cap, 0.0)))
    }

    /// Print a dry run's estimates (to stdout, or as JSON) and the total line.
    pub fn print_dry_run(&self, all: &[crate::run::estimate::Estimate], json: bool) -> ExitCode {
        if json {
            write_stdout(&format!("{}\n", serde_json::to_string_pretty(all).expect("estimates serialise")));
        } else {
            let mut text = String::new();
            for e in all {
                text.push_str(&terminal_safe(&e.line()));
                text.push('\n');
            }
            text.push_str(&crate::run::estimate::total_line(all));
            text.push('\n');
            write_stdout(&text);
        }
        ExitCode::SUCCESS
    }

    /// What a corrupt journal line does.
    pub fn on_corrupt(&self) -> crate::journal::OnCorrupt {
        if self.set_aside_corrupt { crate::journal::OnCorrupt::SetAside } else { crate::journal::OnCorrupt::Refuse }
    }
}

/// Flags that configure the model and image-generation clients (shared with `validate`, `probe`,
/// `transfer` and `ask`). On an existing run folder only `--thinking` is taken from its
/// `config.json` when not given: where keys go is never read from a run folder
/// ([`ModelSettings::resume`]).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ModelFlags {
    /// Override the model provider's endpoint (the model only; never the renderer's)
    #[arg(long)]
    pub base_url: Option<String>,
    /// Override the image-generation provider's endpoint (else `GEMINI_BASE_URL` or
    /// `OPENAI_BASE_URL`)
    #[arg(long)]
    pub renderer_base_url: Option<String>,
    /// Per-model settings (TOML)
    #[arg(long)]
    pub model_config: Option<PathBuf>,
    /// Allow plain `http://` base URLs for a server other than this machine (a model server on
    /// your own network); never for a provider's own host. The key goes out unencrypted
    #[arg(long)]
    pub allow_http: bool,
    /// Thinking level: minimal, low, medium, high
    #[arg(long)]
    pub thinking: Option<String>,
    /// The reply and image cache shared by all runs [default: $XDG_CACHE_HOME/revelio, else
    /// ~/.cache/revelio]
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
    /// Do not use the reply and image cache
    #[arg(long)]
    pub no_cache: bool,
    /// Append a JSON line per HTTP attempt to FILE: time, provider, model, status, latency,
    /// attempt, retry reason, waits; never a key, prompt, image or reply [default: the
    /// `REVELIO_LOG` variable, else none]
    #[arg(long, value_name = "FILE")]
    pub log: Option<PathBuf>,
}

impl ModelFlags {
    /// The model settings these flags give (to be completed from a run folder's record).
    pub fn settings(&self) -> ModelSettings {
        ModelSettings {
            base_url: self.base_url.clone(),
            renderer_base_url: self.renderer_base_url.clone(),
            model_config: self.model_config.as_deref().map(setup::absolute),
            thinking: self.thinking.clone(),
            allow_http: self.allow_http,
            batch: None,
            dry_run: false,
        }
    }

    /// The cache root these flags choose (`None`: no cache).
    pub fn cache(&self) -> Option<PathBuf> {
        setup::cache_root(self.cache_dir.as_deref(), self.no_cache)
    }
}

/// Open the request log (`--log FILE`, else the `REVELIO_LOG` variable) before a command's
/// first model call ([`crate::net::log`]). A dry run sends nothing and writes nothing, so it
/// opens no log.
pub(crate) fn open_log(flag: Option<&Path>, dry_run: bool) -> Result<(), ExitCode> {
    if dry_run {
        return Ok(());
    }
    let env = std::env::var_os(crate::net::log::ENV).filter(|v| !v.is_empty()).map(PathBuf::from);
    let Some(path) = flag.map(Path::to_path_buf).or(env) else { return Ok(()) };
    crate::net::log::open(&path).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(1)
    })
}

/// Say, before a command's first model call, the most calls it can make (`what`: how that
/// number comes about). Calls the journal already holds are served from it, not made again.
pub(crate) fn say_most_calls(command: &str, most: u64, what: &str) {
    eprintln!("{command}: at most {} model calls ({what})", crate::run::summary::spaced(most));
}

/// Report a run that ended early; a stopped run says how to go on.
pub(crate) fn fail_run(e: &RunError, out: &Path) -> ExitCode {
    // A run error may quote what a run folder holds (names, paths, a provider's reply).
    eprintln!("error: {}", terminal_safe(&e.to_string()));
    record_stop(e, out);
    if matches!(e, RunError::Stopped(crate::run::StopReason::CostCap { .. })) {
        eprintln!(
            "note: `{}` holds every finished observation; the same command with a larger `--max-cost` resumes it",
            out.display()
        );
    } else if e.resumable() {
        eprintln!("note: `{}` holds every finished observation; the same command resumes it", out.display());
    }
    ExitCode::from(e.exit_code())
}

/// The file in a run folder that says why the last command on it stopped (`revelio runs` reads
/// it; a search that finishes removes it).
pub const STOPPED_FILE: &str = "stopped.json";

/// Say in `out` why a command on it stopped early (only in a run folder: one with a
/// `config.json`). Best effort: the error itself is already reported.
pub(crate) fn record_stop(e: &RunError, out: &Path) {
    if out.join("config.json").is_file() {
        let note = serde_json::json!({ "reason": e.to_string(), "resumable": e.resumable() });
        let _ = crate::journal::write_atomic(&out.join(STOPPED_FILE), note.to_string().as_bytes());
    }
}

/// First Ctrl-C: stop starting model calls, journal the ones in flight, exit 130. Second: exit
/// 130 at once (the journal is safe at any byte).
pub(crate) fn watch_ctrl_c(rt: &tokio::runtime::Runtime, stop: &crate::run::Stop) {
    let _guard = rt.enter();
    stop.on_ctrl_c(|| std::process::exit(130));
}

/// `--algo`: the search algorithms by name, listed in `--help`.
pub(crate) fn kernel_parser() -> impl clap::builder::TypedValueParser<Value = Kernel> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(Kernel::ALL.map(Kernel::name))
        .map(|name| name.parse::<Kernel>().expect("the parser only lets listed names through"))
}

pub(crate) fn algo_parser() -> impl clap::builder::TypedValueParser<Value = Algo> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(Algo::ALL.map(Algo::name))
        .map(|name| name.parse::<Algo>().expect("the parser only lets listed names through"))
}

pub(crate) fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread().enable_all().build().expect("a tokio runtime starts")
}

fn fr_text(fr: Option<f64>) -> String {
    fr.map_or_else(|| "-".into(), |f| format!("{:.0}%", 100.0 * f))
}

/// `FR [lo–hi]`, e.g. ` 80% [38–96]`: the failure rate and its 95 % interval, in percent.
pub(crate) fn fr_ci_text(fr: Option<f64>, ci: [f64; 2]) -> String {
    format!("{:>4} [{:.0}–{:.0}]", fr_text(fr), 100.0 * ci[0], 100.0 * ci[1])
}

/// Print to stdout; a closed pipe (`revelio check … | head`) is not an error worth a panic.
pub fn write_stdout(s: &str) {
    use std::io::Write as _;
    let _ = std::io::stdout().lock().write_all(s.as_bytes());
}

/// Compile one file from disk (`use "…"` paths are read relative to it, under the policy of
/// [`crate::source`]). With `lints`, the lattice lints run on domain files that compiled without
/// errors.
pub fn compile_path(path: &Path, lints: bool) -> Compiled {
    compile_path_with(path, lints.then(crate::lint::Limits::default))
}

/// [`compile_path`] with the lattice lints' limits (none: no lints), showing their progress.
pub fn compile_path_with(path: &Path, lints: Option<crate::lint::Limits>) -> Compiled {
    with_lints(crate::source::compile_file(path), lints)
}

/// Compile `text` as the file `path` (standard input named by `--stdin-filename`): its
/// `use "…"` paths are read from disk relative to it, under the policy of [`crate::source`];
/// lints as [`compile_path_with`].
pub fn compile_text_with(path: &Path, text: &str, lints: Option<crate::lint::Limits>) -> Compiled {
    with_lints(crate::source::compile_text(path, text, &|_| None), lints)
}

/// `compiled` with the lattice lints' diagnostics added (none: as it is), showing their progress.
fn with_lints(mut compiled: Compiled, lints: Option<crate::lint::Limits>) -> Compiled {
    if let (Some(domain), Some(limits)) = (compiled.domain.as_ref().filter(|d| !d.name.is_empty()), lints) {
        let mut work = super::progress::Work::new();
        compiled.diagnostics.extend(crate::lint::lint_domain_with(domain, limits, &mut |w, d, t| work.report(w, d, t)));
        check::sort_diagnostics(&mut compiled.diagnostics);
    }
    compiled
}

/// The `.rev` files named by `paths`, folders searched recursively, sorted within a folder.
pub fn collect_rev_files(paths: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let mut out = Vec::new();
    for p in paths {
        match std::fs::metadata(p) {
            Ok(m) if m.is_dir() => {
                walk(p, &mut out).map_err(|e| format!("cannot read folder `{}`: {}", p.display(), io_reason(&e)))?;
            }
            Ok(m) if m.is_file() => out.push(p.clone()),
            Ok(m) => return Err(format!("`{}` is {}, not a `.rev` file or a folder", p.display(), file_kind(&m))),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(format!("`{}` does not exist", p.display()));
            }
            Err(e) => return Err(format!("cannot read `{}`: {}", p.display(), io_reason(&e))),
        }
    }
    Ok(out)
}

/// The `.rev` files below `dir`. Links to folders are not followed (a link to `..` would never
/// end); links to files are listed, and [`crate::source`] judges where they lead.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> std::io::Result<()> {
    let mut entries = Vec::new();
    for e in std::fs::read_dir(dir)? {
        let e = e?;
        entries.push((e.path(), e.file_type()?.is_dir()));
    }
    entries.sort();
    for (path, is_dir) in entries {
        if is_dir {
            walk(&path, out)?;
        } else if path.extension().is_some_and(|x| x == "rev") {
            out.push(path);
        }
    }
    Ok(())
}

/// The search parameters `search` and `bench search` share: one declaration, one set of
/// defaults (each command adds its own: the algorithm and seed of one run, or the algorithms
/// and seeds of a benchmark). Each is optional so that a resumed run can tell a flag left out,
/// which takes the value the run recorded, from one given ([`SearchFlags::params`]).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SearchFlags {
    /// The most model calls the search makes, every phase included (search, sequential top-ups,
    /// confirmation, shrink); raise it on an existing run folder to extend the run [default: 1000]
    #[arg(long)]
    pub budget: Option<u64>,
    /// Observations per concept set (m) [default: 5]
    #[arg(long)]
    pub samples: Option<u32>,
    /// Failure threshold τ: a set with failure rate ≥ τ is a failure mode [default: 0.6]
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Beam width (beam and the beam phase of GPTS) [default: 5]
    #[arg(long)]
    pub beam_width: Option<usize>,
    /// Beam depth (beam and the beam phase of GPTS) [default: 5]
    #[arg(long)]
    pub max_depth: Option<usize>,
    /// Beam diversity weight λ in FR − λ·max Jaccard [default: 0.5]
    #[arg(long)]
    pub lambda: Option<f64>,
    /// GPTS and interact: sets picked per round, evaluated in parallel (interact fills its calls
    /// to this width; on a listed lattice its screens stop at four fifths of it) [default: GPTS
    /// 1; interact the concurrency at the run's start]
    #[arg(long)]
    pub batch: Option<usize>,
    /// GPTS: the GP kernel, `dot` (the paper's DotProduct + White) or `rbf` (RBF + White, the
    /// paper's kernel ablation) [default: dot]
    #[arg(long, value_parser = kernel_parser())]
    pub kernel: Option<Kernel>,
    /// Largest concept set searched [default: 5]
    #[arg(long)]
    pub max_size: Option<usize>,
    /// Interact: the surrogate (patterns, horseshoe, ridge, linear) [default: patterns]
    #[arg(long)]
    pub surrogate: Option<Surrogate>,
    /// Interact: supersets of a confirmed core (exclude, fallback, keep) [default: fallback]
    #[arg(long)]
    pub supersets: Option<Supersets>,
    /// Indifference zone δ around τ: a reported core is established to fail above τ − δ, a set
    /// passes once established below τ + δ; in between it is borderline [default: 0.1]
    #[arg(long)]
    pub delta: Option<f64>,
    /// False discovery rate q of the confirmed cores (e-BH over the candidates' fresh
    /// confirmation observations) [default: 0.05]
    #[arg(long)]
    pub fdr: Option<f64>,
}

impl SearchFlags {
    /// The parameters these flags set for `algo`: a flag left out takes the value of `recorded`
    /// (a resumed run's), else its default. `batch` is `default_batch` when neither gives one;
    /// the shrink budget, GPTS's beam budget and sequential sampling are each command's own.
    pub fn params(&self, algo: Algo, recorded: Option<&Params>, default_batch: usize) -> Params {
        let d = Params::default();
        macro_rules! pick {
            ($f:ident, $default:expr) => {
                self.$f.or(recorded.map(|r| r.$f)).unwrap_or($default)
            };
        }
        let budget = pick!(budget, d.budget);
        Params {
            algo,
            budget,
            samples: pick!(samples, d.samples),
            threshold: pick!(threshold, d.threshold),
            beam_width: pick!(beam_width, d.beam_width),
            max_depth: pick!(max_depth, d.max_depth),
            lambda: pick!(lambda, d.lambda),
            beam_budget: budget / 2,
            batch: pick!(batch, default_batch),
            kernel: pick!(kernel, d.kernel),
            max_size: pick!(max_size, crate::lattice::DEFAULT_MAX_SIZE),
            surrogate: pick!(surrogate, d.surrogate),
            supersets: pick!(supersets, d.supersets),
            delta: pick!(delta, d.delta),
            fdr: pick!(fdr, d.fdr),
            ..d
        }
    }
}

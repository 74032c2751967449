//! Model and renderer setup for a run, with the rules that decide what a run uses:
//!
//! - **Concurrency**: one setting with one precedence — `--concurrency`, else the model
//!   config's `concurrency` (`[model."…"]`, then `[default]`), else [`DEFAULT_CONCURRENCY`]. The
//!   effective value bounds the run's observations in flight *and* the provider's request gate,
//!   and the progress line shows it.
//! - **Model settings** (`--base-url`, `--renderer-base-url`, `--model-config`, `--thinking`)
//!   are recorded in `config.json`, but a run folder is untrusted input (shared, downloaded,
//!   edited): nothing that decides where a key goes is ever read back from it. `validate`,
//!   `probe`, `transfer` and a resumed `search` take the base URLs and the model config from
//!   their own flags and the environment; one the run recorded and the command does not give
//!   is refused, naming it, and so is a model endpoint that differs from the recorded one
//!   unless `--base-url` is given ([`ModelSettings::resume`], [`check_endpoint`]).
//!   `--allow-http` is never recorded.
//! - **Reply cache**: shared by every run, under `$XDG_CACHE_HOME/revelio` (else
//!   `~/.cache/revelio`); `--cache-dir` moves it, `--no-cache` turns it off. Entries are written
//!   to a temporary file and renamed, so concurrent processes never read half an entry.
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::diag::terminal_safe;
use crate::ir::Domain;
use crate::render::{Renderer, RendererOptions, build_renderer};
use crate::vlm::Model;
use crate::vlm::registry::{ModelOptions, build_model};

/// Observations (and model requests) in flight when neither `--concurrency` nor the model config
/// sets it.
pub const DEFAULT_CONCURRENCY: usize = 16;

/// How the model was built, as recorded in `config.json`.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModelSettings {
    /// `--base-url` as given (the endpoint actually used is `RunConfig::endpoint`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub base_url: Option<String>,
    /// `--renderer-base-url`: the image generator's endpoint (never the model's `--base-url`,
    /// which must not carry an image-generation key to another host).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub renderer_base_url: Option<String>,
    /// `--model-config`, made absolute.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model_config: Option<String>,
    /// `--thinking`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thinking: Option<String>,
    /// `--allow-http`: a choice of the person running the command, never written to or read
    /// from a run folder.
    #[serde(skip)]
    pub allow_http: bool,
    /// `--batch-api`: the run folder whose `batches.jsonl` journals the batches. A choice of the
    /// command, never recorded: the batch API answers as the live one does.
    #[serde(skip)]
    pub batch: Option<PathBuf>,
    /// `--dry-run`: nothing is sent, so the model and image generator are built without their
    /// keys. Never recorded (a dry run writes nothing).
    #[serde(skip)]
    pub dry_run: bool,
}

/// How a command spells the flags that choose a model's destinations, for the messages that ask
/// for them: [`FLAGS`], except for the run's own model in `transfer` ([`RUN_FLAGS`]), whose
/// `--base-url` and `--model-config` are the target models'.
#[derive(Debug, Clone, Copy)]
pub struct FlagNames {
    pub base_url: &'static str,
    pub model_config: &'static str,
}

pub const FLAGS: FlagNames = FlagNames { base_url: "--base-url", model_config: "--model-config" };
pub const RUN_FLAGS: FlagNames = FlagNames { base_url: "--run-base-url", model_config: "--run-model-config" };

impl ModelSettings {
    /// The settings for another command on a recorded run (a resumed `search`, `validate`,
    /// `probe`, `transfer`): `self` holds the flags given now, `recorded` what the run's
    /// `config.json` says. Where a key goes — the model's base URL, the renderer's, the model
    /// config file — comes from `self` (and the environment) alone. One the run was made with
    /// and that is not given again is refused, naming it, rather than silently dropped; an
    /// endpoint that came from the environment is compared once the model is built
    /// ([`check_endpoint`]).
    /// Only `--thinking`, which sends nothing anywhere, is taken from the record when not given.
    pub fn resume(self, recorded: &ModelSettings, names: FlagNames) -> Result<ModelSettings, SetupError> {
        for (what, flag, given, was) in [
            ("the model endpoint", names.base_url, &self.base_url, &recorded.base_url),
            ("the image endpoint", "--renderer-base-url", &self.renderer_base_url, &recorded.renderer_base_url),
            ("the model config", names.model_config, &self.model_config, &recorded.model_config),
        ] {
            if let (None, Some(was)) = (given, was) {
                return Err(SetupError::NotGivenAgain { what, flag, was: terminal_safe(was).into_owned() });
            }
        }
        Ok(ModelSettings { thinking: self.thinking.or_else(|| recorded.thinking.clone()), ..self })
    }

    /// Refuse base URLs that carry credentials before anything is built from them or recorded
    /// (the renderer's is checked even when no image generator uses it: it is recorded too).
    fn check(&self) -> Result<(), SetupError> {
        for url in [&self.base_url, &self.renderer_base_url].into_iter().flatten() {
            crate::net::refuse_url_credentials(url).map_err(SetupError::Model)?;
        }
        Ok(())
    }
}

/// Refuse to go on with a run whose model now resolves to another endpoint than the one the run
/// recorded (`recorded`, its `config.json`'s `endpoint`), unless `--base-url` was given now:
/// with the endpoint coming from the provider's variables or its default, a changed
/// environment would otherwise mix answers from two servers in one run without a word. A
/// resumed `search` refuses a changed endpoint even then: the endpoint is part of what a run is.
pub fn check_endpoint(
    settings: &ModelSettings,
    recorded: Option<&str>,
    model: &dyn Model,
    names: FlagNames,
) -> Result<(), SetupError> {
    let now = model.endpoint();
    if settings.base_url.is_some() || now.as_deref() == recorded {
        return Ok(());
    }
    let name = |e: Option<&str>| e.map_or_else(|| "none".to_string(), |e| format!("`{}`", terminal_safe(e)));
    Err(SetupError::EndpointChanged { flag: names.base_url, was: name(recorded), now: name(now.as_deref()) })
}

/// Where the reply cache lives: `flag`, else `$XDG_CACHE_HOME/revelio`, else
/// `$HOME/.cache/revelio`; `None` when disabled or when no home is known.
pub fn cache_root(flag: Option<&Path>, disabled: bool) -> Option<PathBuf> {
    if disabled {
        return None;
    }
    if let Some(f) = flag {
        return Some(f.to_path_buf());
    }
    let var = |n: &str| std::env::var_os(n).filter(|v| !v.is_empty()).map(PathBuf::from);
    // The XDG spec ignores a relative XDG_CACHE_HOME.
    if let Some(x) = var("XDG_CACHE_HOME").filter(|p| p.is_absolute()) {
        return Some(x.join("revelio"));
    }
    var("HOME").map(|h| h.join(".cache").join("revelio"))
}

/// The image cache in the cache folder `root`: generated images, and the builtin renderer's
/// drawn scenes (`crate::render::scene_cache`).
pub fn images_dir(root: &Path) -> PathBuf {
    root.join("images")
}

/// Why a run's model or renderer could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// A bad `--model` spec, a missing key, a bad model config or sim profile.
    #[error("{0}")]
    Model(String),
    /// An unknown `--renderer` spec.
    #[error("{0}")]
    RendererSpec(String),
    /// A renderer that cannot start here (no graphics adapter, no key).
    #[error("{0}")]
    Renderer(String),
    #[error("`{file}` changed since the run in `{}`; validation needs the domain the search used", dir.display())]
    DomainChanged { file: String, dir: PathBuf },
    #[error("the model now resolves to `{now}`, but the run used `{was}`; pass the model flags the search used")]
    ModelChanged { now: String, was: String },
    /// A destination the run recorded, not given again (a run folder never chooses one).
    #[error(
        "the run was made with {what} `{was}`; a run folder does not choose where keys go: pass `{flag}` to use it"
    )]
    NotGivenAgain { what: &'static str, flag: &'static str, was: String },
    /// The model's endpoint differs from the recorded one and `--base-url` was not given.
    #[error(
        "the run's model was called at {was}, but it now resolves to {now} (from the provider's variables or its default); a run folder does not choose where keys go: pass `{flag}` to say where to call it"
    )]
    EndpointChanged { flag: &'static str, was: String, now: String },
}

impl SetupError {
    /// 2 for what the user typed, 1 for what the machine lacks or the files changed.
    pub fn exit_code(&self) -> u8 {
        match self {
            SetupError::Model(_)
            | SetupError::RendererSpec(_)
            | SetupError::ModelChanged { .. }
            | SetupError::NotGivenAgain { .. }
            | SetupError::EndpointChanged { .. } => 2,
            SetupError::Renderer(_) | SetupError::DomainChanged { .. } => 1,
        }
    }
}

/// A run's model and renderer, and its effective concurrency.
pub struct Parts {
    pub model: Arc<dyn Model>,
    pub renderer: Option<Arc<dyn Renderer>>,
    pub concurrency: usize,
}

/// Build the model and renderer of a run. `concurrency` is `--concurrency` (see the module docs
/// for the precedence); `cache` the reply cache's root ([`cache_root`]).
pub fn build_parts(
    domain: &Domain,
    model_spec: &str,
    renderer_spec: &str,
    settings: &ModelSettings,
    cache: Option<&Path>,
    concurrency: Option<usize>,
) -> Result<Parts, SetupError> {
    settings.check()?;
    let options = ModelOptions {
        base_url: settings.base_url.clone(),
        allow_http: settings.allow_http,
        config: settings.model_config.as_ref().map(PathBuf::from),
        thinking: settings.thinking.clone(),
        no_cache: cache.is_none(),
        cache_dir: cache.map(|c| c.join("replies")),
        concurrency,
        batch: settings.batch.clone(),
        dry_run: settings.dry_run,
    };
    let model = build_model(model_spec, domain, &options).map_err(SetupError::Model)?;
    let renderer = build_renderer(
        renderer_spec,
        &RendererOptions {
            size: None,
            cache_dir: cache.map(images_dir),
            base_url: settings.renderer_base_url.clone(),
            allow_http: settings.allow_http,
            dry_run: settings.dry_run,
        },
    )
    .map_err(|e| if known_renderer(renderer_spec) { SetupError::Renderer(e) } else { SetupError::RendererSpec(e) })?;
    let concurrency = effective_concurrency(concurrency, model.as_ref());
    Ok(Parts { model, renderer, concurrency })
}

/// `--concurrency`, else the model's configured concurrency, else [`DEFAULT_CONCURRENCY`].
pub fn effective_concurrency(flag: Option<usize>, model: &dyn Model) -> usize {
    flag.or_else(|| model.concurrency()).unwrap_or(DEFAULT_CONCURRENCY).max(1)
}

fn known_renderer(spec: &str) -> bool {
    matches!(spec, "none" | "builtin") || spec.starts_with("imagegen:gemini:") || spec.starts_with("imagegen:openai:")
}

/// A path as an absolute string, for `config.json` (a later command may run elsewhere).
pub fn absolute(p: &Path) -> String {
    std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf()).display().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recorded() -> ModelSettings {
        ModelSettings {
            base_url: Some("https://elsewhere.example/v1".into()),
            renderer_base_url: Some("https://images.example".into()),
            model_config: Some("/theirs/models.toml".into()),
            thinking: Some("low".into()),
            allow_http: false,
            batch: None,
            dry_run: false,
        }
    }

    #[test]
    fn a_recorded_destination_is_named_never_used() {
        let e = ModelSettings::default().resume(&recorded(), FLAGS).unwrap_err();
        assert_eq!(
            e.to_string(),
            "the run was made with the model endpoint `https://elsewhere.example/v1`; a run folder does not choose where keys go: pass `--base-url` to use it"
        );
        assert_eq!(e.exit_code(), 2);
        let given = ModelSettings { base_url: Some("http://localhost:8000/v1".into()), ..Default::default() };
        let e = given.clone().resume(&recorded(), FLAGS).unwrap_err().to_string();
        assert!(
            e.contains("the image endpoint `https://images.example`") && e.contains("`--renderer-base-url`"),
            "{e}"
        );
        let e = ModelSettings { renderer_base_url: Some("https://mine.example".into()), ..given.clone() }
            .resume(&recorded(), RUN_FLAGS)
            .unwrap_err()
            .to_string();
        assert!(e.contains("the model config `/theirs/models.toml`") && e.contains("`--run-model-config`"), "{e}");
        // Given: the flags win; only `--thinking` comes from the record.
        let mine = ModelSettings {
            renderer_base_url: Some("https://mine.example".into()),
            model_config: Some("/mine.toml".into()),
            allow_http: true,
            ..given
        };
        let resumed = mine.clone().resume(&recorded(), FLAGS).unwrap();
        assert_eq!(resumed, ModelSettings { thinking: Some("low".into()), ..mine });
    }

    #[test]
    fn allow_http_is_never_recorded_or_read() {
        let s = ModelSettings { allow_http: true, ..Default::default() };
        assert_eq!(serde_json::to_string(&s).unwrap(), "{}");
        let read: ModelSettings = serde_json::from_str(r#"{"allow_http": true}"#).unwrap();
        assert!(!read.allow_http);
    }

    #[test]
    fn recorded_text_is_escaped_in_messages() {
        let r = ModelSettings { base_url: Some("https://x\u{1b}[2J".into()), ..Default::default() };
        let e = ModelSettings::default().resume(&r, FLAGS).unwrap_err().to_string();
        assert!(!e.contains('\u{1b}') && e.contains("\\u{1b}[2J"), "{e}");
    }
}

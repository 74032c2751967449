//! Model and renderer setup for a run, with the rules that decide what a run uses:
//!
//! - **Concurrency**: one setting with one precedence — `--concurrency`, else the model
//!   config's `concurrency` (`[model."…"]`, then `[default]`), else [`DEFAULT_CONCURRENCY`]. The
//!   effective value bounds the run's observations in flight *and* the provider's request gate,
//!   and the progress line shows it.
//! - **Model settings** (`--base-url`, `--renderer-base-url`, `--model-config`, `--thinking`)
//!   are recorded in `config.json`; `validate` and a resumed `search` reuse the recorded ones
//!   unless a flag overrides them.
//! - **Reply cache**: shared by every run, under `$XDG_CACHE_HOME/revelio` (else
//!   `~/.cache/revelio`); `--cache-dir` moves it, `--no-cache` turns it off. Entries are written
//!   to a temporary file and renamed, so concurrent processes never read half an entry.
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

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
}

impl ModelSettings {
    /// These settings, with each one not given taken from `recorded`.
    pub fn or(self, recorded: &ModelSettings) -> ModelSettings {
        ModelSettings {
            base_url: self.base_url.or_else(|| recorded.base_url.clone()),
            renderer_base_url: self.renderer_base_url.or_else(|| recorded.renderer_base_url.clone()),
            model_config: self.model_config.or_else(|| recorded.model_config.clone()),
            thinking: self.thinking.or_else(|| recorded.thinking.clone()),
        }
    }
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
}

impl SetupError {
    /// 2 for what the user typed, 1 for what the machine lacks or the files changed.
    pub fn exit_code(&self) -> u8 {
        match self {
            SetupError::Model(_) | SetupError::RendererSpec(_) | SetupError::ModelChanged { .. } => 2,
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
    let options = ModelOptions {
        base_url: settings.base_url.clone(),
        config: settings.model_config.as_ref().map(PathBuf::from),
        thinking: settings.thinking.clone(),
        no_cache: cache.is_none(),
        cache_dir: cache.map(|c| c.join("replies")),
        concurrency,
    };
    let model = build_model(model_spec, domain, &options).map_err(SetupError::Model)?;
    let renderer = build_renderer(
        renderer_spec,
        &RendererOptions {
            size: None,
            cache_dir: cache.map(|c| c.join("images")),
            base_url: settings.renderer_base_url.clone(),
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

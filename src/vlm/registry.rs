//! `--model` specs → models: `sim:PATH.toml`, `openai:MODEL`, `anthropic:MODEL`,
//! `gemini:MODEL`, `bedrock:MODEL_ID`.
use std::path::PathBuf;
use std::sync::Arc;

use crate::ir::Domain;
use crate::vlm::Model;

/// Options that apply to building any model (from CLI flags and the environment).
#[derive(Debug, Clone, Default)]
pub struct ModelOptions {
    /// `--base-url`: overrides every provider's endpoint.
    pub base_url: Option<String>,
    /// `--model-config`: per-model settings TOML.
    pub config: Option<PathBuf>,
    /// `--thinking minimal|low|medium|high`.
    pub thinking: Option<String>,
    /// `--no-cache`.
    pub no_cache: bool,
    /// Where the response cache lives (a run folder's `cache/` or a user cache dir).
    pub cache_dir: Option<PathBuf>,
}

pub fn build_model(spec: &str, domain: &Domain, _opts: &ModelOptions) -> Result<Arc<dyn Model>, String> {
    let (provider, rest) = spec.split_once(':').ok_or_else(|| {
        format!("invalid model `{spec}`: expected PROVIDER:NAME, e.g. `sim:examples/sim/driving_fog.toml`")
    })?;
    match provider {
        "sim" => crate::vlm::sim::load(std::path::Path::new(rest), domain),
        other => Err(format!(
            "unknown model provider `{other}` in `{spec}`: expected `sim`, `openai`, `anthropic`, `gemini` or `bedrock`"
        )),
    }
}

//! `--model` specs → models: `sim:PATH.toml`, `openai:MODEL`, `anthropic:MODEL`,
//! `gemini:MODEL`, `bedrock:MODEL_ID`.
use std::path::PathBuf;
use std::sync::Arc;

use crate::ir::Domain;
use crate::vlm::Model;
#[cfg(feature = "net")]
use crate::vlm::config::settings_for;
#[cfg(feature = "net")]
use crate::vlm::{anthropic, bedrock, gemini, openai};

/// Options that apply to building any model (from CLI flags and the environment).
#[derive(Debug, Clone, Default)]
pub struct ModelOptions {
    /// `--base-url`: overrides the model provider's endpoint (the renderer has its own).
    pub base_url: Option<String>,
    /// `--allow-http`: plain `http://` to a named server other than this machine (never to a
    /// provider's own host).
    pub allow_http: bool,
    /// `--model-config`: per-model settings TOML.
    pub config: Option<PathBuf>,
    /// `--thinking minimal|low|medium|high`.
    pub thinking: Option<String>,
    /// `--no-cache`.
    pub no_cache: bool,
    /// Where the response cache lives (the shared user cache by default).
    pub cache_dir: Option<PathBuf>,
    /// `--batch-api`: ask through the provider's batch API, journaling the batches in this run
    /// folder (`batches.jsonl`).
    pub batch: Option<PathBuf>,
    /// `--concurrency`: overrides the model config's `concurrency` (one setting for the run's
    /// observations and the provider's request gate).
    pub concurrency: Option<usize>,
    /// `--dry-run`: nothing will be sent, so the model is built without its key.
    pub dry_run: bool,
}

pub fn build_model(spec: &str, domain: &Domain, opts: &ModelOptions) -> Result<Arc<dyn Model>, String> {
    let (provider, rest) = spec.split_once(':').ok_or_else(|| {
        format!("invalid model `{spec}`: expected PROVIDER:NAME, e.g. `sim:examples/sim/driving_fog.toml`")
    })?;
    match provider {
        // A simulated model answers at once and costs nothing: `--batch-api` changes nothing.
        "sim" => crate::vlm::sim::load(std::path::Path::new(rest), domain),
        "openai" | "anthropic" | "gemini" | "bedrock" => build_api_model(spec, opts),
        other => Err(format!(
            "unknown model provider `{other}` in `{spec}`: expected `sim`, `openai`, `anthropic`, `gemini` or `bedrock`"
        )),
    }
}

/// Build an API model (`openai:`, `anthropic:`, `gemini:`, `bedrock:`); needs no domain.
#[cfg(not(feature = "net"))]
pub fn build_api_model(spec: &str, _: &ModelOptions) -> Result<Arc<dyn Model>, String> {
    Err(format!(
        "model `{spec}` is not in this build of revelio (built without the `net` feature); use a `sim:` model or a default build"
    ))
}

/// Build an API model (`openai:`, `anthropic:`, `gemini:`, `bedrock:`); needs no domain.
#[cfg(feature = "net")]
pub fn build_api_model(spec: &str, opts: &ModelOptions) -> Result<Arc<dyn Model>, String> {
    let (provider, rest) =
        spec.split_once(':').ok_or_else(|| format!("invalid model `{spec}`: expected PROVIDER:NAME"))?;
    let mut settings = settings_for(spec, opts.config.as_deref(), opts.thinking.as_deref())?;
    if let Some(c) = opts.concurrency {
        settings.concurrency = c.max(1);
    }
    let base = crate::net::EndpointFlags {
        base_url: opts.base_url.as_deref(),
        allow_http: opts.allow_http,
        dry_run: opts.dry_run,
    };
    let cache = if opts.no_cache { None } else { opts.cache_dir.as_deref() };
    if let Some(dir) = &opts.batch {
        use crate::vlm::batch::{BatchModel, anthropic::AnthropicBatch, gemini::GeminiBatch, openai::OpenAiBatch};
        return Ok(match provider {
            "openai" => {
                let live = openai::build(spec, rest, settings, base, cache)?;
                let wire = OpenAiBatch::new(live.proto());
                Arc::new(BatchModel::new(live, wire, dir)?)
            }
            "anthropic" => {
                let live = anthropic::build(spec, rest, settings, base, cache)?;
                let wire = AnthropicBatch::new(live.proto());
                Arc::new(BatchModel::new(live, wire, dir)?)
            }
            "gemini" => {
                let live = gemini::build(spec, rest, settings, base, cache)?;
                let wire = GeminiBatch::new(live.proto());
                Arc::new(BatchModel::new(live, wire, dir)?)
            }
            _ => {
                return Err(format!(
                    "`--batch-api` is not available for `{spec}`: batches go to `openai:`, `anthropic:` and `gemini:` models (Bedrock's batch inference reads its input from S3)"
                ));
            }
        });
    }
    Ok(match provider {
        "openai" => Arc::new(openai::build(spec, rest, settings, base, cache)?),
        "anthropic" => Arc::new(anthropic::build(spec, rest, settings, base, cache)?),
        "gemini" => Arc::new(gemini::build(spec, rest, settings, base, cache)?),
        "bedrock" => Arc::new(bedrock::build(spec, rest, settings, base, cache)?),
        other => {
            return Err(format!(
                "unknown API provider `{other}` in `{spec}`: expected `openai`, `anthropic`, `gemini` or `bedrock`"
            ));
        }
    })
}

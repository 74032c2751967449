//! Per-model settings (`--model-config FILE.toml`): generation parameters, image encoding,
//! rate limits, retry bounds and prices. See `examples/models/paper.toml`. A model the docs name
//! that is given no price here is priced at its list price ([`crate::vlm::cost`]).
//!
//! ```toml
//! [default]                      # applies to every model
//! timeout_s = 120
//!
//! [model."gemini:gemini-3-flash-preview"]   # the `--model` spec, or just the model name
//! thinking = "low"
//! price_input_per_mtok = 0.5
//! ```

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Duration;

use serde::Deserialize;

/// Default per-attempt timeout: long enough for a non-streamed reply with high thinking.
pub const DEFAULT_TIMEOUT_S: f64 = 120.0;
/// Default wait for more of a started reply body: a server that sends nothing for this long
/// has stalled.
pub const DEFAULT_STALL_TIMEOUT_S: f64 = 30.0;
/// Default bound on a whole call, every attempt and wait included: a stalled endpoint costs at
/// most this per observation (it was 900 s).
pub const DEFAULT_RETRY_DEADLINE_S: f64 = 300.0;
/// Default largest reply body: model replies are a few kilobytes of JSON.
pub const DEFAULT_MAX_REPLY_BYTES: usize = crate::net::DEFAULT_MAX_BODY;

/// Image encoding sent to the provider.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    Png,
    Jpeg,
}

/// Settings as written in the file; every field optional so tables can be layered.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    pub max_tokens: Option<u32>,
    pub temperature: Option<f64>,
    /// Provider-specific thinking level (`minimal`, `low`, `medium`, `high`, `max`, `off`).
    pub thinking: Option<String>,
    /// Fixed thinking budget in tokens (Anthropic `budget_tokens`, Gemini 2.5 `thinkingBudget`).
    pub thinking_budget: Option<u32>,
    pub image_format: Option<ImageFormat>,
    /// Longest image side in pixels; larger images are downscaled (aspect kept).
    pub image_max_side: Option<u32>,
    pub jpeg_quality: Option<u8>,
    /// Requests in flight at once for this provider endpoint.
    pub concurrency: Option<usize>,
    pub requests_per_minute: Option<u32>,
    /// OpenAI-compatible servers: the request field of the output cap, `max_tokens` or
    /// `max_completion_tokens` (which OpenAI's reasoning models require). By default
    /// `max_completion_tokens` on OpenAI's host and for OpenAI reasoning models (`o1`, `o3`,
    /// `o4`, `gpt-5` families) behind any gateway, else `max_tokens`.
    pub max_tokens_field: Option<String>,
    /// Per-attempt timeout, from sending the request to the reply's last byte.
    pub timeout_s: Option<f64>,
    /// Longest wait for more of a reply body once it has started.
    pub stall_timeout_s: Option<f64>,
    /// Largest reply body read, in MiB; a larger reply is an `api_error`.
    pub max_reply_mb: Option<f64>,
    /// Attempts per call, the first included.
    pub retry_attempts: Option<u32>,
    /// Total time a call may take across all its attempts and waits.
    pub retry_deadline_s: Option<f64>,
    /// First backoff step between attempts (doubles per retry) when the server gives no
    /// `Retry-After`.
    pub retry_backoff_s: Option<f64>,
    pub price_input_per_mtok: Option<f64>,
    pub price_output_per_mtok: Option<f64>,
    /// `--batch-api`: the first wait between two looks at a pending batch (doubles up to 20
    /// times this, at most 10 minutes).
    pub batch_poll_s: Option<f64>,
    /// `--batch-api`: how long requests are collected after the last one arrived before they go
    /// out as one batch.
    pub batch_collect_s: Option<f64>,
    /// Extra top-level JSON fields merged into the request body (like the SDKs' `extra_body`),
    /// e.g. `extra = { chat_template_kwargs = { enable_thinking = false } }` for vLLM.
    pub extra: Option<toml::Table>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    default: Settings,
    #[serde(default)]
    model: BTreeMap<String, Settings>,
}

/// Settings with every default filled in.
#[derive(Debug, Clone, PartialEq)]
pub struct Resolved {
    pub max_tokens: u32,
    pub temperature: Option<f64>,
    pub thinking: Option<String>,
    pub thinking_budget: Option<u32>,
    pub image_format: ImageFormat,
    pub image_max_side: Option<u32>,
    pub jpeg_quality: u8,
    pub concurrency: usize,
    pub requests_per_minute: Option<u32>,
    pub max_tokens_field: Option<String>,
    pub timeout: Duration,
    pub stall_timeout: Duration,
    pub max_reply_bytes: usize,
    pub retry_attempts: u32,
    pub retry_deadline: Duration,
    pub retry_backoff: Duration,
    pub price_input_per_mtok: f64,
    pub price_output_per_mtok: f64,
    pub batch_poll: Duration,
    pub batch_collect: Duration,
    pub extra: Option<serde_json::Map<String, serde_json::Value>>,
}

impl Settings {
    fn layer(self, over: Settings) -> Settings {
        Settings {
            max_tokens: over.max_tokens.or(self.max_tokens),
            temperature: over.temperature.or(self.temperature),
            thinking: over.thinking.or(self.thinking),
            thinking_budget: over.thinking_budget.or(self.thinking_budget),
            image_format: over.image_format.or(self.image_format),
            image_max_side: over.image_max_side.or(self.image_max_side),
            jpeg_quality: over.jpeg_quality.or(self.jpeg_quality),
            concurrency: over.concurrency.or(self.concurrency),
            requests_per_minute: over.requests_per_minute.or(self.requests_per_minute),
            max_tokens_field: over.max_tokens_field.or(self.max_tokens_field),
            timeout_s: over.timeout_s.or(self.timeout_s),
            stall_timeout_s: over.stall_timeout_s.or(self.stall_timeout_s),
            max_reply_mb: over.max_reply_mb.or(self.max_reply_mb),
            retry_attempts: over.retry_attempts.or(self.retry_attempts),
            retry_deadline_s: over.retry_deadline_s.or(self.retry_deadline_s),
            retry_backoff_s: over.retry_backoff_s.or(self.retry_backoff_s),
            price_input_per_mtok: over.price_input_per_mtok.or(self.price_input_per_mtok),
            price_output_per_mtok: over.price_output_per_mtok.or(self.price_output_per_mtok),
            batch_poll_s: over.batch_poll_s.or(self.batch_poll_s),
            batch_collect_s: over.batch_collect_s.or(self.batch_collect_s),
            extra: over.extra.or(self.extra),
        }
    }

    fn resolve(self, what: &str) -> Result<Resolved, String> {
        let bad = |field: &str, why: &str| format!("invalid `{field}` for `{what}`: {why}");
        let positive = |field: &str, v: Option<f64>, default: f64| -> Result<Duration, String> {
            let v = v.unwrap_or(default);
            if v.is_finite() && v > 0.0 && v < 1e7 {
                Ok(Duration::from_secs_f64(v))
            } else {
                Err(bad(field, "expected a positive number of seconds"))
            }
        };
        if let Some(t) = self.temperature
            && !(0.0..=2.0).contains(&t)
        {
            return Err(bad("temperature", "expected a number from 0 to 2"));
        }
        if self.max_tokens == Some(0) {
            return Err(bad("max_tokens", "expected at least 1"));
        }
        if self.concurrency == Some(0) {
            return Err(bad("concurrency", "expected at least 1"));
        }
        if self.requests_per_minute == Some(0) {
            return Err(bad("requests_per_minute", "expected at least 1 (leave it out for no limit)"));
        }
        if self.retry_attempts == Some(0) {
            return Err(bad("retry_attempts", "expected at least 1 (1 means no retry)"));
        }
        if self.image_max_side.is_some_and(|s| s < 16) {
            return Err(bad("image_max_side", "expected at least 16 pixels"));
        }
        if self.jpeg_quality.is_some_and(|q| !(1..=100).contains(&q)) {
            return Err(bad("jpeg_quality", "expected 1 to 100"));
        }
        for (field, p) in
            [("price_input_per_mtok", self.price_input_per_mtok), ("price_output_per_mtok", self.price_output_per_mtok)]
        {
            if p.is_some_and(|p| !(p.is_finite() && p >= 0.0)) {
                return Err(bad(field, "expected a non-negative number of US dollars"));
            }
        }
        if let Some(f) = &self.max_tokens_field
            && !matches!(f.as_str(), "max_tokens" | "max_completion_tokens")
        {
            return Err(bad("max_tokens_field", "expected `max_tokens` or `max_completion_tokens`"));
        }
        let max_reply_bytes = match self.max_reply_mb {
            None => DEFAULT_MAX_REPLY_BYTES,
            Some(mb) if mb.is_finite() && (0.001..=1024.0).contains(&mb) => (mb * f64::from(1u32 << 20)) as usize,
            Some(_) => return Err(bad("max_reply_mb", "expected a number of MiB from 0.001 to 1024")),
        };
        let extra = match self.extra {
            None => None,
            Some(t) => match serde_json::to_value(t) {
                Ok(serde_json::Value::Object(m)) => Some(m),
                _ => return Err(bad("extra", "expected a table of JSON-compatible values")),
            },
        };
        Ok(Resolved {
            max_tokens: self.max_tokens.unwrap_or(8192),
            temperature: self.temperature,
            thinking: self.thinking,
            thinking_budget: self.thinking_budget,
            image_format: self.image_format.unwrap_or(ImageFormat::Png),
            image_max_side: self.image_max_side,
            jpeg_quality: self.jpeg_quality.unwrap_or(90),
            concurrency: self.concurrency.unwrap_or(16),
            requests_per_minute: self.requests_per_minute,
            max_tokens_field: self.max_tokens_field,
            timeout: positive("timeout_s", self.timeout_s, DEFAULT_TIMEOUT_S)?,
            stall_timeout: positive("stall_timeout_s", self.stall_timeout_s, DEFAULT_STALL_TIMEOUT_S)?,
            max_reply_bytes,
            retry_attempts: self.retry_attempts.unwrap_or(6),
            retry_deadline: positive("retry_deadline_s", self.retry_deadline_s, DEFAULT_RETRY_DEADLINE_S)?,
            retry_backoff: positive("retry_backoff_s", self.retry_backoff_s, 0.5)?,
            price_input_per_mtok: self.price_input_per_mtok.unwrap_or(0.0),
            price_output_per_mtok: self.price_output_per_mtok.unwrap_or(0.0),
            batch_poll: positive("batch_poll_s", self.batch_poll_s, 30.0)?,
            batch_collect: positive("batch_collect_s", self.batch_collect_s, 2.0)?,
            extra,
        })
    }
}

/// Resolve the settings for `spec` (`provider:model`) from an optional config file and an
/// optional `--thinking` flag (which wins over the file).
pub fn settings_for(spec: &str, file: Option<&Path>, thinking: Option<&str>) -> Result<Resolved, String> {
    let parsed = match file {
        None => File::default(),
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| format!("cannot read model config `{}`: {e}", path.display()))?;
            parse_file(&text).map_err(|e| format!("invalid model config `{}`: {e}", path.display()))?
        }
    };
    select(parsed, spec, thinking)
}

fn parse_file(text: &str) -> Result<File, String> {
    toml::from_str::<File>(text).map_err(|e| e.message().to_string())
}

fn select(file: File, spec: &str, thinking: Option<&str>) -> Result<Resolved, String> {
    let name = spec.split_once(':').map_or(spec, |(_, n)| n);
    let mut model = file.model;
    let own = model.remove(spec).or_else(|| model.remove(name)).unwrap_or_default();
    let mut s = file.default.layer(own);
    if let Some(t) = thinking {
        s.thinking = Some(t.to_string());
    }
    // A documented model's list price when the file gives neither price.
    if let (None, None, Some(p)) =
        (s.price_input_per_mtok, s.price_output_per_mtok, crate::vlm::cost::builtin_prices(spec))
    {
        s.price_input_per_mtok = Some(p.input_per_mtok);
        s.price_output_per_mtok = Some(p.output_per_mtok);
    }
    s.resolve(spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn resolve(text: &str, spec: &str) -> Result<Resolved, String> {
        select(parse_file(text)?, spec, None)
    }

    #[test]
    fn defaults_without_a_file() {
        let r = select(File::default(), "openai:gpt", None).unwrap();
        assert_eq!(r.max_tokens, 8192);
        assert_eq!(r.image_format, ImageFormat::Png);
        assert_eq!(r.retry_attempts, 6);
        assert_eq!(r.temperature, None);
        assert_eq!((r.timeout.as_secs(), r.stall_timeout.as_secs(), r.retry_deadline.as_secs()), (120, 30, 300));
        assert_eq!(r.max_reply_bytes, 4 << 20);
    }

    #[test]
    fn model_table_overrides_default_and_flag_overrides_both() {
        let text = r#"
            [default]
            temperature = 0.0
            thinking = "high"
            concurrency = 4
            [model."gemini:gemini-3-flash-preview"]
            thinking = "low"
            image_format = "jpeg"
            image_max_side = 768
            price_input_per_mtok = 0.5
            [model."claude-haiku-4-5"]
            max_tokens = 1024
        "#;
        let g = resolve(text, "gemini:gemini-3-flash-preview").unwrap();
        assert_eq!(g.thinking.as_deref(), Some("low"));
        assert_eq!(g.concurrency, 4);
        assert_eq!(g.image_format, ImageFormat::Jpeg);
        assert_eq!(g.image_max_side, Some(768));
        assert_eq!(g.price_input_per_mtok, 0.5);
        // Matched by the bare model name too.
        assert_eq!(resolve(text, "anthropic:claude-haiku-4-5").unwrap().max_tokens, 1024);
        let flagged = select(parse_file(text).unwrap(), "gemini:gemini-3-flash-preview", Some("minimal")).unwrap();
        assert_eq!(flagged.thinking.as_deref(), Some("minimal"));
    }

    #[test]
    fn extra_body_becomes_json() {
        let r =
            resolve("[default]\nextra = { chat_template_kwargs = { enable_thinking = false } }", "openai:q").unwrap();
        assert_eq!(
            serde_json::Value::Object(r.extra.unwrap()),
            serde_json::json!({"chat_template_kwargs": {"enable_thinking": false}})
        );
    }

    #[test]
    fn bad_values_get_specific_errors() {
        assert_eq!(
            resolve("[default]\ntemperature = 3.0", "openai:m").unwrap_err(),
            "invalid `temperature` for `openai:m`: expected a number from 0 to 2"
        );
        assert!(resolve("[default]\nconcurrency = 0", "openai:m").unwrap_err().contains("`concurrency`"));
        assert!(resolve("[default]\ntimeout_s = -1", "openai:m").unwrap_err().contains("`timeout_s`"));
        assert!(resolve("[default]\nimage_format = \"gif\"", "openai:m").unwrap_err().contains("unknown variant"));
        assert!(resolve("[default]\nmax_tokenz = 3", "openai:m").unwrap_err().contains("unknown field `max_tokenz`"));
        assert!(resolve("[default]\nmax_reply_mb = 0", "openai:m").unwrap_err().contains("`max_reply_mb`"));
        assert!(resolve("[default]\nstall_timeout_s = 0", "openai:m").unwrap_err().contains("`stall_timeout_s`"));
        assert!(
            resolve("[default]\nmax_tokens_field = \"tokens\"", "openai:m").unwrap_err().contains("`max_tokens_field`")
        );
        assert_eq!(resolve("[default]\nmax_reply_mb = 0.5", "openai:m").unwrap().max_reply_bytes, 1 << 19);
    }

    #[test]
    fn the_example_config_is_valid() {
        let text = include_str!("../../examples/models/paper.toml");
        let file = parse_file(text).unwrap();
        let specs: Vec<String> = file.model.keys().cloned().collect();
        for spec in specs {
            let r = select(parse_file(text).unwrap(), &spec, None).unwrap_or_else(|e| panic!("{spec}: {e}"));
            assert!(r.concurrency >= 1);
        }
        let g = select(file, "gemini:gemini-3-flash-preview", Some("high")).unwrap();
        assert_eq!((g.thinking.as_deref(), g.concurrency), (Some("high"), 32));
    }

    #[test]
    fn missing_file_is_a_clear_error() {
        let e = settings_for("openai:m", Some(Path::new("/nonexistent/models.toml")), None).unwrap_err();
        assert!(e.starts_with("cannot read model config `/nonexistent/models.toml`"), "{e}");
    }
}

//! `openai:MODEL` — the Chat Completions API, as spoken by OpenAI and by vLLM, SGLang, Ollama
//! and llama.cpp servers. The image goes first as a base64 data URL, then the prompt text.
//!
//! Reasoning text (`reasoning_content` from vLLM/SGLang reasoning parsers, `reasoning` from
//! Ollama and OpenRouter) is kept as thinking and never parsed for the answer.

use serde_json::{Value, json};

use crate::net::http::{Request, snippet};
use crate::net::secret::Secret;
use crate::net::{EndpointFlags, ProviderError, json as j};
use crate::vlm::api::{ApiModel, Parsed, Protocol, Provider, Stop, start};
use crate::vlm::config::Resolved;
use crate::vlm::image::Encoded;

pub use crate::net::openai::DEFAULT_BASE_URL;

pub const PROVIDER: Provider = Provider {
    host: crate::net::openai::HOST,
    usage: "`openai:MODEL`, e.g. `openai:gpt-4.1-mini`",
    owned: &[
        "model",
        "messages",
        "max_tokens",
        "max_completion_tokens",
        "temperature",
        "reasoning_effort",
        "stream",
        "stream_options",
        "n",
    ],
};

/// Reasoning efforts the Chat Completions API accepts.
const EFFORTS: &[&str] = &["none", "minimal", "low", "medium", "high", "xhigh", "max"];

pub struct OpenAi {
    base: String,
    url: String,
    model: String,
    key: Option<Secret>,
    /// OpenAI's reasoning models reject `max_tokens` and want `max_completion_tokens`, on
    /// OpenAI's host and behind gateways; the open-source servers read `max_tokens`.
    max_tokens_field: &'static str,
    settings: Resolved,
}

/// OpenAI model families that reason, and so take only `max_completion_tokens`.
fn is_openai_reasoning_model(model: &str) -> bool {
    let name = model.rsplit('/').next().unwrap_or(model);
    ["o1", "o3", "o4", "gpt-5"].iter().any(|f| name == *f || name.starts_with(&format!("{f}-")))
}

/// The request field of the output cap: the model config's `max_tokens_field`, else chosen by
/// host and model.
fn max_tokens_field(settings: &Resolved, official: bool, model: &str) -> &'static str {
    match settings.max_tokens_field.as_deref() {
        Some("max_completion_tokens") => "max_completion_tokens",
        Some(_) => "max_tokens",
        None if official || is_openai_reasoning_model(model) => "max_completion_tokens",
        None => "max_tokens",
    }
}

pub fn build(
    spec: &str,
    model: &str,
    settings: Resolved,
    base: EndpointFlags<'_>,
    cache: Option<&std::path::Path>,
) -> Result<ApiModel<OpenAi>, String> {
    let endpoint = start(&PROVIDER, spec, model, &settings, base, DEFAULT_BASE_URL)?;
    if let Some(t) = &settings.thinking
        && !EFFORTS.contains(&t.as_str())
    {
        return Err(format!(
            "invalid thinking level `{t}` for `{spec}`: OpenAI-compatible models take {}",
            EFFORTS.iter().map(|e| format!("`{e}`")).collect::<Vec<_>>().join(", ")
        ));
    }
    let base = endpoint.base;
    let official = base.starts_with("https://api.openai.com");
    let proto = OpenAi {
        base: base.clone(),
        url: format!("{base}/chat/completions"),
        model: model.to_string(),
        key: endpoint.key,
        max_tokens_field: max_tokens_field(&settings, official, model),
        settings: settings.clone(),
    };
    ApiModel::new(spec, &PROVIDER.host, &base, proto, settings, cache)
}

impl OpenAi {
    /// The base URL (`…/v1`) every request of this model goes to, the batch API's included.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// The credential headers of a request to [`OpenAi::base`].
    pub fn auth(&self) -> Vec<(String, String)> {
        self.key.iter().map(|k| ("authorization".to_string(), format!("Bearer {}", k.0))).collect()
    }
}

impl Protocol for OpenAi {
    fn request(&self, prompt: &str, image: Option<&Encoded>) -> Result<Request, String> {
        let mut content = Vec::new();
        if let Some(img) = image {
            let url = format!("data:{};base64,{}", img.mime(), img.base64());
            content.push(json!({"type": "image_url", "image_url": {"url": url}}));
        }
        content.push(json!({"type": "text", "text": prompt}));
        let mut body = json!({
            "model": self.model,
            "messages": [{"role": "user", "content": content}],
        });
        body[self.max_tokens_field] = json!(self.settings.max_tokens);
        if let Some(t) = self.settings.temperature {
            body["temperature"] = json!(t);
        }
        if let Some(effort) = &self.settings.thinking {
            body["reasoning_effort"] = json!(effort);
        }
        j::merge(&mut body, self.settings.extra.as_ref());
        let mut headers = vec![("content-type".to_string(), "application/json".to_string())];
        if let Some(k) = &self.key {
            headers.push(("authorization".into(), format!("Bearer {}", k.0)));
        }
        Ok(Request { url: self.url.clone(), headers, body: body.to_string().into_bytes() })
    }

    fn parse(&self, body: &[u8]) -> Result<Parsed, String> {
        let v = j::object(body)?;
        let choice = j::at(&v, &["choices", "0"]).ok_or("no `choices` in the response")?;
        let msg = choice.get("message").ok_or("no `message` in the first choice")?;
        let text = match msg.get("content") {
            Some(Value::String(s)) => s.clone(),
            // Some servers return content parts.
            Some(Value::Array(parts)) => parts.iter().filter_map(|p| p.get("text").and_then(Value::as_str)).collect(),
            _ => String::new(),
        };
        let thinking = ["reasoning_content", "reasoning"]
            .iter()
            .find_map(|k| msg.get(*k).and_then(Value::as_str))
            .filter(|s| !s.trim().is_empty())
            .map(str::to_string);
        let refusal = msg.get("refusal").and_then(Value::as_str).filter(|s| !s.trim().is_empty());
        let stop = match (refusal, choice.get("finish_reason").and_then(Value::as_str)) {
            (Some(r), _) => Stop::Refusal(r.to_string()),
            (None, Some("length")) => Stop::Truncated,
            (None, Some("content_filter")) => Stop::Blocked("content_filter".into()),
            _ => Stop::Complete,
        };
        let thinking_tokens = j::u64_at(&v, &["usage", "completion_tokens_details", "reasoning_tokens"]);
        Ok(Parsed {
            text,
            thinking,
            stop,
            input_tokens: j::u64_at(&v, &["usage", "prompt_tokens"]),
            output_tokens: j::u64_at(&v, &["usage", "completion_tokens"]),
            thinking_tokens,
        })
    }

    fn secrets(&self) -> Vec<&str> {
        self.key.iter().map(|k| k.0.as_str()).collect()
    }

    fn error(&self, _status: u16, body: &[u8]) -> ProviderError {
        let v: Value = serde_json::from_slice(body).unwrap_or(Value::Null);
        let code = j::str_at(&v, &["error", "code"]).or_else(|| j::str_at(&v, &["error", "type"])).unwrap_or("");
        // A spend limit does not lift by retrying (OpenAI sends it as a 429).
        let permanent = matches!(code, "insufficient_quota" | "billing_hard_limit_reached" | "billing_not_active");
        let message = j::str_at(&v, &["error", "message"])
            .or_else(|| j::str_at(&v, &["message"]))
            .or_else(|| j::str_at(&v, &["error"]))
            .map(|m| snippet(m.as_bytes()))
            .unwrap_or_else(|| snippet(body));
        let message = if code.is_empty() { message } else { format!("{message} ({code})") };
        ProviderError { message, permanent, retry_after: None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn proto() -> OpenAi {
        let settings = crate::vlm::config::settings_for("openai:m", None, None).unwrap();
        OpenAi {
            base: "http://x/v1".into(),
            url: "http://x/v1/chat/completions".into(),
            model: "m".into(),
            key: None,
            max_tokens_field: "max_tokens",
            settings,
        }
    }

    #[test]
    fn reads_content_reasoning_and_usage() {
        let body = br#"{"id":"chatcmpl-1","object":"chat.completion","choices":[{"index":0,"message":{"role":"assistant","content":"Answer: B","reasoning_content":"The car is far."},"finish_reason":"stop"}],"usage":{"prompt_tokens":812,"completion_tokens":40,"total_tokens":852,"completion_tokens_details":{"reasoning_tokens":31}}}"#;
        let p = proto().parse(body).unwrap();
        assert_eq!(p.text, "Answer: B");
        assert_eq!(p.thinking.as_deref(), Some("The car is far."));
        assert_eq!((p.input_tokens, p.output_tokens, p.thinking_tokens), (812, 40, 31));
        assert_eq!(p.stop, Stop::Complete);
    }

    #[test]
    fn finish_reasons_and_refusals() {
        let len = br#"{"choices":[{"message":{"content":"<think>long"},"finish_reason":"length"}]}"#;
        assert_eq!(proto().parse(len).unwrap().stop, Stop::Truncated);
        let filt = br#"{"choices":[{"message":{"content":null},"finish_reason":"content_filter"}]}"#;
        assert_eq!(proto().parse(filt).unwrap().stop, Stop::Blocked("content_filter".into()));
        let refusal =
            br#"{"choices":[{"message":{"content":null,"refusal":"I can't help with that."},"finish_reason":"stop"}]}"#;
        assert_eq!(proto().parse(refusal).unwrap().stop, Stop::Refusal("I can't help with that.".into()));
    }

    #[test]
    fn reasoning_models_get_max_completion_tokens_unless_configured() {
        let mut s = crate::vlm::config::settings_for("openai:m", None, None).unwrap();
        assert_eq!(max_tokens_field(&s, true, "gpt-4.1-mini"), "max_completion_tokens");
        assert_eq!(max_tokens_field(&s, false, "qwen3-vl-8b"), "max_tokens");
        for m in ["o3", "o4-mini", "openai/gpt-5-mini", "gpt-5", "o1-2024-12-17"] {
            assert_eq!(max_tokens_field(&s, false, m), "max_completion_tokens", "{m}");
        }
        assert_eq!(max_tokens_field(&s, false, "gpt-50x"), "max_tokens");
        s.max_tokens_field = Some("max_tokens".into());
        assert_eq!(max_tokens_field(&s, false, "o3"), "max_tokens");
        s.max_tokens_field = Some("max_completion_tokens".into());
        assert_eq!(max_tokens_field(&s, false, "qwen3-vl-8b"), "max_completion_tokens");
    }

    #[test]
    fn malformed_bodies_are_errors() {
        assert!(proto().parse(b"{\"choices\": [").is_err());
        assert!(proto().parse(b"{\"choices\": []}").is_err());
        assert!(proto().parse(b"[]").is_err());
    }

    #[test]
    fn quota_errors_are_permanent() {
        let body = br#"{"error":{"message":"You exceeded your current quota.","type":"insufficient_quota","param":null,"code":"insufficient_quota"}}"#;
        let e = proto().error(429, body);
        assert!(e.permanent);
        assert_eq!(e.message, "You exceeded your current quota. (insufficient_quota)");
        let rate = br#"{"error":{"message":"Rate limit reached","type":"requests","code":"rate_limit_exceeded"}}"#;
        assert!(!proto().error(429, rate).permanent);
        // vLLM's error shape.
        let vllm = br#"{"object":"error","message":"The model `x` does not exist.","type":"NotFoundError","code":404}"#;
        assert_eq!(proto().error(404, vllm).message, "The model `x` does not exist.");
    }
}

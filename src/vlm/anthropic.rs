//! `anthropic:MODEL` — the Messages API (`POST /v1/messages`, `x-api-key`,
//! `anthropic-version: 2023-06-01`). The image block goes before the text block.
//!
//! Thinking: `thinking_budget = N` sends extended thinking with a fixed budget
//! (`{"type": "enabled", "budget_tokens": N}`); `--thinking low|medium|high|max` sends adaptive
//! thinking with that effort (`{"type": "adaptive"}` and `output_config.effort`, Claude 4.6 and
//! later); `--thinking adaptive` leaves the effort to the model. Only `text` blocks are parsed.
//!
//! No `temperature` is sent: the Messages API takes none (the official SDK's request type,
//! `anthropic` 2.12, has no sampling fields), so a configured temperature applies to the other
//! providers only.

use serde_json::{Value, json};

use crate::net::http::{Request, snippet};
use crate::net::secret::Secret;
use crate::net::{EndpointFlags, Host, ProviderError, json as j};
use crate::vlm::api::{ApiModel, Parsed, Protocol, Provider, Stop, start};
use crate::vlm::config::Resolved;
use crate::vlm::image::Encoded;

pub const DEFAULT_BASE_URL: &str = "https://api.anthropic.com";
pub const VERSION: &str = "2023-06-01";

pub const PROVIDER: Provider = Provider {
    host: Host { provider: "anthropic", base_env: &["ANTHROPIC_BASE_URL"], key_env: &["ANTHROPIC_API_KEY"] },
    usage: "`anthropic:MODEL`, e.g. `anthropic:claude-sonnet-4-6`",
    owned: &["model", "messages", "max_tokens", "temperature", "thinking", "output_config", "stream"],
};

pub struct Anthropic {
    base: String,
    url: String,
    model: String,
    /// Required on Anthropic's host; a proxy behind `--base-url` may not need one.
    key: Option<Secret>,
    settings: Resolved,
}

/// The `thinking` (and `output_config`) request fields for the settings; shared with Bedrock,
/// whose Anthropic models take the same fields.
pub fn thinking_fields(spec: &str, s: &Resolved) -> Result<Vec<(&'static str, Value)>, String> {
    let adaptive_effort = |effort: Option<&str>| {
        let mut f = vec![("thinking", json!({"type": "adaptive"}))];
        if let Some(e) = effort {
            f.push(("output_config", json!({"effort": e})));
        }
        f
    };
    let fields = match (s.thinking.as_deref(), s.thinking_budget) {
        (Some(_), Some(_)) => {
            return Err(format!("`{spec}` has both `thinking` and `thinking_budget`: set one of them"));
        }
        (None | Some("off"), None) => Vec::new(),
        (None, Some(budget)) => {
            if budget < 1024 || budget >= s.max_tokens {
                return Err(format!(
                    "invalid `thinking_budget` {budget} for `{spec}`: Anthropic needs at least 1024 and less than `max_tokens` ({})",
                    s.max_tokens
                ));
            }
            vec![("thinking", json!({"type": "enabled", "budget_tokens": budget}))]
        }
        (Some("adaptive"), None) => adaptive_effort(None),
        (Some(e @ ("low" | "medium" | "high" | "xhigh" | "max")), None) => adaptive_effort(Some(e)),
        (Some(other), None) => {
            return Err(format!(
                "invalid thinking level `{other}` for `{spec}`: Anthropic models take `off`, `adaptive`, `low`, `medium`, `high`, `xhigh` or `max` (or `thinking_budget` in the model config)"
            ));
        }
    };
    Ok(fields)
}

pub fn build(
    spec: &str,
    model: &str,
    settings: Resolved,
    base: EndpointFlags<'_>,
    cache: Option<&std::path::Path>,
) -> Result<ApiModel<Anthropic>, String> {
    let endpoint = start(&PROVIDER, spec, model, &settings, base, DEFAULT_BASE_URL)?;
    thinking_fields(spec, &settings)?;
    let base = endpoint.base;
    let proto = Anthropic {
        base: base.clone(),
        url: format!("{base}/v1/messages"),
        model: model.to_string(),
        key: endpoint.key,
        settings: settings.clone(),
    };
    ApiModel::new(spec, &PROVIDER.host, &base, proto, settings, cache)
}

/// Read the Messages-format content blocks: `text` blocks are the reply, `thinking` blocks the
/// thinking; `redacted_thinking` carries nothing readable.
pub fn read_blocks(blocks: &[Value]) -> (String, Option<String>) {
    let mut text = String::new();
    let mut thinking = String::new();
    for b in blocks {
        match b.get("type").and_then(Value::as_str) {
            Some("text") => text.push_str(b.get("text").and_then(Value::as_str).unwrap_or("")),
            Some("thinking") => thinking.push_str(b.get("thinking").and_then(Value::as_str).unwrap_or("")),
            _ => {}
        }
    }
    (text, Some(thinking).filter(|t| !t.trim().is_empty()))
}

impl Anthropic {
    /// The base URL every request of this model goes to, the batch API's included.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// The version and credential headers of a request to [`Anthropic::base`].
    pub fn auth(&self) -> Vec<(String, String)> {
        let mut h = vec![("anthropic-version".to_string(), VERSION.to_string())];
        h.extend(self.key.iter().map(|k| ("x-api-key".to_string(), k.0.clone())));
        h
    }
}

impl Protocol for Anthropic {
    fn request(&self, prompt: &str, image: Option<&Encoded>) -> Result<Request, String> {
        let mut content = Vec::new();
        if let Some(img) = image {
            content.push(
                json!({"type": "image", "source": {"type": "base64", "media_type": img.mime(), "data": img.base64()}}),
            );
        }
        content.push(json!({"type": "text", "text": prompt}));
        let mut body = json!({
            "model": self.model,
            "max_tokens": self.settings.max_tokens,
            "messages": [{"role": "user", "content": content}],
        });
        for (k, v) in thinking_fields(&self.model, &self.settings)? {
            body[k] = v;
        }
        j::merge(&mut body, self.settings.extra.as_ref());
        let mut headers = vec![
            ("content-type".to_string(), "application/json".to_string()),
            ("anthropic-version".to_string(), VERSION.to_string()),
        ];
        if let Some(k) = &self.key {
            headers.push(("x-api-key".into(), k.0.clone()));
        }
        Ok(Request { url: self.url.clone(), headers, body: body.to_string().into_bytes() })
    }

    fn parse(&self, body: &[u8]) -> Result<Parsed, String> {
        let v = j::object(body)?;
        let blocks = v.get("content").and_then(Value::as_array).ok_or("no `content` in the response")?;
        let (text, thinking) = read_blocks(blocks);
        let stop = match v.get("stop_reason").and_then(Value::as_str) {
            Some("max_tokens" | "model_context_window_exceeded") => Stop::Truncated,
            Some("refusal") => Stop::Refusal("the model declined to answer (stop_reason: refusal)".into()),
            _ => Stop::Complete,
        };
        let input = j::u64_at(&v, &["usage", "input_tokens"])
            + j::u64_at(&v, &["usage", "cache_read_input_tokens"])
            + j::u64_at(&v, &["usage", "cache_creation_input_tokens"]);
        Ok(Parsed {
            text,
            thinking,
            stop,
            input_tokens: input,
            output_tokens: j::u64_at(&v, &["usage", "output_tokens"]),
            // The Messages API bills thinking as output without a separate count.
            thinking_tokens: 0,
        })
    }

    fn secrets(&self) -> Vec<&str> {
        self.key.iter().map(|k| k.0.as_str()).collect()
    }

    fn error(&self, _status: u16, body: &[u8]) -> ProviderError {
        let v: Value = serde_json::from_slice(body).unwrap_or(Value::Null);
        let kind = j::str_at(&v, &["error", "type"]).unwrap_or("");
        let message =
            j::str_at(&v, &["error", "message"]).map(|m| snippet(m.as_bytes())).unwrap_or_else(|| snippet(body));
        let message = if kind.is_empty() { message } else { format!("{message} ({kind})") };
        ProviderError { message, permanent: kind == "billing_error", retry_after: None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(thinking: Option<&str>) -> Resolved {
        crate::vlm::config::settings_for("anthropic:m", None, thinking).unwrap()
    }

    fn proto() -> Anthropic {
        Anthropic {
            base: "http://x".into(),
            url: "http://x/v1/messages".into(),
            model: "m".into(),
            key: Some(Secret("k".into())),
            settings: settings(None),
        }
    }

    #[test]
    fn thinking_modes() {
        assert!(thinking_fields("a", &settings(None)).unwrap().is_empty());
        let f = thinking_fields("a", &settings(Some("high"))).unwrap();
        assert_eq!(f, vec![("thinking", json!({"type": "adaptive"})), ("output_config", json!({"effort": "high"}))]);
        let mut s = settings(None);
        s.thinking_budget = Some(2048);
        assert_eq!(
            thinking_fields("a", &s).unwrap(),
            vec![("thinking", json!({"type": "enabled", "budget_tokens": 2048}))]
        );
        s.thinking_budget = Some(512);
        assert!(thinking_fields("a", &s).unwrap_err().contains("at least 1024"));
        assert!(thinking_fields("a", &settings(Some("minimal"))).unwrap_err().contains("`minimal`"));
    }

    #[test]
    fn no_temperature_is_sent() {
        let mut p = proto();
        p.settings.temperature = Some(0.0);
        let body: Value = serde_json::from_slice(&p.request("q", None).unwrap().body).unwrap();
        assert!(body.get("temperature").is_none(), "{body}");
    }

    #[test]
    fn only_text_blocks_are_the_reply() {
        let body = br#"{"id":"msg_01","type":"message","role":"assistant","model":"claude-sonnet-4-6","content":[{"type":"thinking","thinking":"Answer: A? no.","signature":"EqQB"},{"type":"redacted_thinking","data":"abc"},{"type":"text","text":"The lane is blocked.\n\nAnswer: A"}],"stop_reason":"end_turn","stop_sequence":null,"usage":{"input_tokens":1500,"cache_read_input_tokens":10,"output_tokens":300}}"#;
        let p = proto().parse(body).unwrap();
        assert_eq!(p.text, "The lane is blocked.\n\nAnswer: A");
        assert_eq!(p.thinking.as_deref(), Some("Answer: A? no."));
        assert_eq!((p.input_tokens, p.output_tokens), (1510, 300));
    }

    #[test]
    fn stop_reasons() {
        let t = br#"{"content":[{"type":"text","text":"The"}],"stop_reason":"max_tokens","usage":{}}"#;
        assert_eq!(proto().parse(t).unwrap().stop, Stop::Truncated);
        let r = br#"{"content":[],"stop_reason":"refusal","usage":{}}"#;
        assert!(matches!(proto().parse(r).unwrap().stop, Stop::Refusal(_)));
    }

    #[test]
    fn errors() {
        let e = proto().error(529, br#"{"type":"error","error":{"type":"overloaded_error","message":"Overloaded"}}"#);
        assert_eq!(e.message, "Overloaded (overloaded_error)");
        assert!(!e.permanent);
        assert!(proto().error(400, br#"{"type":"error","error":{"type":"billing_error","message":"x"}}"#).permanent);
    }
}

//! `gemini:MODEL` — the Gemini API `models/MODEL:generateContent` with the image as
//! `inlineData` (raw base64 and its MIME type) before the text, key in `x-goog-api-key`.
//!
//! `--thinking minimal|low|medium|high` sets `generationConfig.thinkingConfig.thinkingLevel`
//! (Gemini 3); `thinking_budget` sets `thinkingBudget` (Gemini 2.5). Parts marked
//! `thought: true` are thinking and never parsed; thinking tokens count as output.

use serde_json::{Value, json};

use crate::net::gemini::{DEFAULT_BASE_URL, HOST, endpoint, error, headers};
use crate::net::http::Request;
use crate::net::secret::Secret;
use crate::net::{EndpointFlags, ProviderError, json as j};
use crate::vlm::api::{ApiModel, Parsed, Protocol, Provider, Stop, start};
use crate::vlm::config::Resolved;
use crate::vlm::image::Encoded;

/// Finish reasons that mean the provider's filters stopped the reply (`MODEL_ARMOR`: a Model
/// Armor template on the project screened it).
pub const BLOCKING: &[&str] = &[
    "SAFETY",
    "RECITATION",
    "BLOCKLIST",
    "PROHIBITED_CONTENT",
    "SPII",
    "IMAGE_SAFETY",
    "IMAGE_PROHIBITED_CONTENT",
    "IMAGE_RECITATION",
    "MODEL_ARMOR",
];

pub const PROVIDER: Provider = Provider {
    host: HOST,
    usage: "`gemini:MODEL`, e.g. `gemini:gemini-3-flash-preview`",
    owned: &["contents", "generationConfig", "generation_config"],
};

pub struct Gemini {
    base: String,
    model: String,
    url: String,
    key: Option<Secret>,
    settings: Resolved,
}

pub fn build(
    spec: &str,
    model: &str,
    settings: Resolved,
    base: EndpointFlags<'_>,
    cache: Option<&std::path::Path>,
) -> Result<ApiModel<Gemini>, String> {
    let ep = start(&PROVIDER, spec, model, &settings, base, DEFAULT_BASE_URL)?;
    match (settings.thinking.as_deref(), settings.thinking_budget) {
        (Some(_), Some(_)) => {
            return Err(format!("`{spec}` has both `thinking` and `thinking_budget`: set one of them"));
        }
        (Some("minimal" | "low" | "medium" | "high" | "xhigh") | None, _) => {}
        (Some(other), _) => {
            return Err(format!(
                "invalid thinking level `{other}` for `{spec}`: Gemini models take `minimal`, `low`, `medium`, `high` or `xhigh`"
            ));
        }
    }
    let proto = Gemini {
        base: ep.base.clone(),
        model: model.strip_prefix("models/").unwrap_or(model).to_string(),
        url: endpoint(&ep.base, model),
        key: ep.key,
        settings: settings.clone(),
    };
    ApiModel::new(spec, &PROVIDER.host, &ep.base, proto, settings, cache)
}

impl Gemini {
    /// The base URL every request of this model goes to, the batch API's included.
    pub fn base(&self) -> &str {
        &self.base
    }

    /// The model name, without a `models/` prefix.
    pub fn model(&self) -> &str {
        &self.model
    }

    /// The headers of a request to [`Gemini::base`] (the key among them).
    pub fn auth(&self) -> Vec<(String, String)> {
        headers(self.key.as_ref())
    }
}

impl Protocol for Gemini {
    fn request(&self, prompt: &str, image: Option<&Encoded>) -> Result<Request, String> {
        let mut parts = Vec::new();
        if let Some(img) = image {
            parts.push(json!({"inlineData": {"mimeType": img.mime(), "data": img.base64()}}));
        }
        parts.push(json!({"text": prompt}));
        let s = &self.settings;
        let mut gen_config = json!({"maxOutputTokens": s.max_tokens});
        if let Some(t) = s.temperature {
            gen_config["temperature"] = json!(t);
        }
        if let Some(level) = &s.thinking {
            // The API documents the levels in upper case (`ThinkingLevel` enum values).
            gen_config["thinkingConfig"] = json!({"thinkingLevel": level.to_uppercase()});
        } else if let Some(b) = s.thinking_budget {
            gen_config["thinkingConfig"] = json!({"thinkingBudget": b});
        }
        let mut body = json!({"contents": [{"role": "user", "parts": parts}], "generationConfig": gen_config});
        j::merge(&mut body, s.extra.as_ref());
        Ok(Request { url: self.url.clone(), headers: headers(self.key.as_ref()), body: body.to_string().into_bytes() })
    }

    fn parse(&self, body: &[u8]) -> Result<Parsed, String> {
        let v = j::object(body)?;
        let usage = |k: &str| j::u64_at(&v, &["usageMetadata", k]);
        let thoughts = usage("thoughtsTokenCount");
        let mut parsed = Parsed {
            text: String::new(),
            thinking: None,
            stop: Stop::Complete,
            input_tokens: usage("promptTokenCount"),
            output_tokens: usage("candidatesTokenCount") + thoughts,
            thinking_tokens: thoughts,
        };
        if let Some(reason) = j::str_at(&v, &["promptFeedback", "blockReason"]) {
            parsed.stop = Stop::Blocked(format!("prompt blocked ({reason})"));
            return Ok(parsed);
        }
        let Some(cand) = j::at(&v, &["candidates", "0"]) else {
            if v.get("usageMetadata").is_none() {
                return Err("no `candidates` in the response".into());
            }
            return Ok(parsed);
        };
        let mut thinking = String::new();
        for part in cand.pointer("/content/parts").and_then(Value::as_array).into_iter().flatten() {
            let text = part.get("text").and_then(Value::as_str).unwrap_or("");
            if part.get("thought").and_then(Value::as_bool) == Some(true) {
                thinking.push_str(text);
            } else {
                parsed.text.push_str(text);
            }
        }
        parsed.thinking = Some(thinking).filter(|t| !t.trim().is_empty());
        parsed.stop = match cand.get("finishReason").and_then(Value::as_str) {
            Some("MAX_TOKENS") => Stop::Truncated,
            Some(r) if BLOCKING.contains(&r) => Stop::Blocked(r.to_string()),
            _ => Stop::Complete,
        };
        Ok(parsed)
    }

    fn secrets(&self) -> Vec<&str> {
        self.key.iter().map(|k| k.0.as_str()).collect()
    }

    fn error(&self, _status: u16, body: &[u8]) -> ProviderError {
        error(body)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn proto() -> Gemini {
        Gemini {
            base: "http://x".into(),
            model: "g".into(),
            url: endpoint("http://x", "g"),
            key: None,
            settings: crate::vlm::config::settings_for("gemini:g", None, None).unwrap(),
        }
    }

    #[test]
    fn epstrips_models_prefix() {
        assert_eq!(
            endpoint("https://h", "models/gemini-3-flash-preview"),
            "https://h/v1beta/models/gemini-3-flash-preview:generateContent"
        );
    }

    #[test]
    fn thought_parts_are_thinking_and_count_as_output() {
        let body = br#"{"candidates":[{"content":{"parts":[{"text":"Considering the fog...","thought":true},{"text":"Debris ahead.\nAnswer: A"}],"role":"model"},"finishReason":"STOP","index":0}],"usageMetadata":{"promptTokenCount":1290,"candidatesTokenCount":12,"thoughtsTokenCount":250,"totalTokenCount":1552},"modelVersion":"gemini-3-flash-preview"}"#;
        let p = proto().parse(body).unwrap();
        assert_eq!(p.text, "Debris ahead.\nAnswer: A");
        assert_eq!(p.thinking.as_deref(), Some("Considering the fog..."));
        assert_eq!((p.input_tokens, p.output_tokens, p.thinking_tokens), (1290, 262, 250));
    }

    #[test]
    fn blocks_and_truncation() {
        let prompt = br#"{"promptFeedback":{"blockReason":"SAFETY","safetyRatings":[]},"usageMetadata":{"promptTokenCount":10}}"#;
        assert_eq!(proto().parse(prompt).unwrap().stop, Stop::Blocked("prompt blocked (SAFETY)".into()));
        let armor = br#"{"promptFeedback":{"blockReason":"MODEL_ARMOR"},"usageMetadata":{"promptTokenCount":10}}"#;
        assert_eq!(proto().parse(armor).unwrap().stop, Stop::Blocked("prompt blocked (MODEL_ARMOR)".into()));
        for r in ["SAFETY", "RECITATION", "BLOCKLIST", "PROHIBITED_CONTENT", "SPII", "MODEL_ARMOR"] {
            let body = format!(r#"{{"candidates":[{{"finishReason":"{r}","index":0}}]}}"#);
            assert_eq!(proto().parse(body.as_bytes()).unwrap().stop, Stop::Blocked(r.into()));
        }
        let t = br#"{"candidates":[{"content":{"parts":[{"text":"The"}]},"finishReason":"MAX_TOKENS"}]}"#;
        assert_eq!(proto().parse(t).unwrap().stop, Stop::Truncated);
        assert!(proto().parse(b"{}").is_err());
    }

    #[test]
    fn quota_errors() {
        let per_minute = br#"{"error":{"code":429,"message":"Resource has been exhausted","status":"RESOURCE_EXHAUSTED","details":[{"@type":"type.googleapis.com/google.rpc.QuotaFailure","violations":[{"quotaMetric":"generativelanguage.googleapis.com/generate_content_requests","quotaId":"GenerateRequestsPerMinutePerProjectPerModel"}]},{"@type":"type.googleapis.com/google.rpc.RetryInfo","retryDelay":"17s"}]}}"#;
        let e = error(per_minute);
        assert!(!e.permanent);
        assert_eq!(e.retry_after, Some(std::time::Duration::from_secs(17)));
        assert_eq!(e.message, "Resource has been exhausted (RESOURCE_EXHAUSTED)");
        let daily = br#"{"error":{"code":429,"message":"Quota exceeded","status":"RESOURCE_EXHAUSTED","details":[{"@type":"type.googleapis.com/google.rpc.QuotaFailure","violations":[{"quotaId":"GenerateRequestsPerDayPerProjectPerModel-FreeTier"}]}]}}"#;
        assert!(error(daily).permanent);
    }
}

//! What Google's Gemini API host expects of every Revelio client that calls it (the VLM client
//! `vlm::gemini` and the image generator `render::imagegen`): its default host, the variables its
//! base URL and key come from ([`HOST`]), the endpoint of a model, the key header, and its error
//! bodies.

use std::time::Duration;

use serde_json::Value;

use super::ProviderError;
use super::http::snippet;
use super::json as j;
use super::secret::Secret;

pub const DEFAULT_BASE_URL: &str = "https://generativelanguage.googleapis.com";

pub const HOST: super::Host = super::Host {
    provider: "gemini",
    base_env: &["GEMINI_BASE_URL", "GOOGLE_GEMINI_BASE_URL"],
    key_env: &["GEMINI_API_KEY", "GOOGLE_API_KEY"],
};

/// `https://…/v1beta/models/MODEL:generateContent` (a `models/` prefix on the name is allowed).
pub fn endpoint(base: &str, model: &str) -> String {
    let model = model.strip_prefix("models/").unwrap_or(model);
    format!("{base}/v1beta/models/{model}:generateContent")
}

/// Headers for a Gemini call.
pub fn headers(key: Option<&Secret>) -> Vec<(String, String)> {
    let mut h = vec![("content-type".to_string(), "application/json".to_string())];
    if let Some(k) = key {
        h.push(("x-goog-api-key".into(), k.0.clone()));
    }
    h
}

/// A Gemini error body (`{"error": {"code", "message", "status", "details"}}`). A daily quota
/// does not lift by retrying; a per-minute one says when to come back in `RetryInfo`.
pub fn error(body: &[u8]) -> ProviderError {
    let v: Value = serde_json::from_slice(body).unwrap_or(Value::Null);
    let status = j::str_at(&v, &["error", "status"]).unwrap_or("");
    let message = j::str_at(&v, &["error", "message"]).map(|m| snippet(m.as_bytes())).unwrap_or_else(|| snippet(body));
    let details = j::at(&v, &["error", "details"]).and_then(Value::as_array).cloned().unwrap_or_default();
    let mut retry_after = None;
    let mut daily = false;
    for d in &details {
        if let Some(delay) = d.get("retryDelay").and_then(Value::as_str) {
            retry_after = delay
                .strip_suffix('s')
                .and_then(|s| s.parse::<f64>().ok())
                .filter(|s| s.is_finite() && *s >= 0.0)
                .map(Duration::from_secs_f64);
        }
        if let Some(vs) = d.get("violations").and_then(Value::as_array) {
            daily |=
                vs.iter().any(|q| q.get("quotaId").and_then(Value::as_str).is_some_and(|id| id.contains("PerDay")));
        }
    }
    let message = if status.is_empty() { message } else { format!("{message} ({status})") };
    ProviderError { message, permanent: daily, retry_after }
}

//! `bedrock:MODEL_ID` — Amazon Bedrock Runtime through the **Converse** API
//! (`POST /model/{modelId}/converse`), one request format for every model family (Anthropic
//! Claude, Qwen3-VL, …), signed with SigV4 (`vlm::sigv4`) from the standard AWS variables.
//!
//! Converse rather than InvokeModel: InvokeModel's body differs per model family, Converse's
//! does not, and it reports usage and stop reasons uniformly. Anthropic models' thinking goes in
//! `additionalModelRequestFields` (the same fields as the Messages API).

use std::time::SystemTime;

use serde_json::{Value, json};

use crate::net::http::{Request, snippet};
use crate::net::secret::env_any;
use crate::net::{EndpointFlags, Host, ProviderError, json as j};
use crate::vlm::anthropic::thinking_fields;
use crate::vlm::api::{ApiModel, Parsed, Protocol, Provider, Stop, check_extra, check_request};
use crate::vlm::config::Resolved;
use crate::vlm::image::Encoded;
use crate::vlm::sigv4::{self, Credentials, Scope, SignRequest, uri_encode};

/// Credentials are the AWS variables ([`Credentials::from_env`]), not an API key.
pub const PROVIDER: Provider = Provider {
    host: Host {
        provider: "bedrock",
        base_env: &["BEDROCK_BASE_URL", "AWS_ENDPOINT_URL_BEDROCK_RUNTIME"],
        key_env: &[],
    },
    usage: "`bedrock:MODEL_ID`, e.g. `bedrock:us.anthropic.claude-haiku-4-5-20251001-v1:0`",
    owned: &["messages", "inferenceConfig"],
};

pub struct Bedrock {
    url: String,
    host: String,
    /// The canonical URI for signing: each path segment encoded once more than on the wire, as
    /// AWS requires for every service but S3.
    canonical_uri: String,
    region: String,
    creds: Credentials,
    settings: Resolved,
    /// `additionalModelRequestFields` (thinking for Anthropic models).
    extra_fields: Option<Value>,
}

pub fn build(
    spec: &str,
    model: &str,
    settings: Resolved,
    base: EndpointFlags<'_>,
    cache: Option<&std::path::Path>,
) -> Result<ApiModel<Bedrock>, String> {
    check_request(&PROVIDER, spec, model, &settings)?;
    let region = env_any(&["AWS_REGION", "AWS_DEFAULT_REGION"])
        .ok_or_else(|| format!("`{spec}` needs an AWS region: set `AWS_REGION` (or `AWS_DEFAULT_REGION`)"))?;
    if !region.chars().all(|c| c.is_ascii_alphanumeric() || c == '-') {
        return Err(format!("invalid AWS region `{region}`"));
    }
    // A dry run sends nothing, so it signs nothing.
    let creds = match Credentials::from_env() {
        Ok(c) => c,
        Err(_) if base.dry_run => Credentials::default(),
        Err(e) => return Err(e),
    };
    let is_anthropic = model.contains("anthropic.");
    let thinking = thinking_fields(spec, &settings)?;
    if !thinking.is_empty() && !is_anthropic {
        return Err(format!(
            "`{spec}` takes no thinking settings: Revelio sends thinking only to Anthropic models on Bedrock"
        ));
    }
    if !thinking.is_empty() {
        check_extra(spec, &settings, &["additionalModelRequestFields"])?;
        // Converse sends `inferenceConfig.temperature`, which Claude's thinking needs at 1.
        if settings.temperature.is_some_and(|t| t != 1.0) {
            return Err(format!("`{spec}` uses thinking, which needs `temperature` unset or 1"));
        }
    }
    let extra_fields =
        (!thinking.is_empty()).then(|| Value::Object(thinking.into_iter().map(|(k, v)| (k.to_string(), v)).collect()));
    let default = format!("https://bedrock-runtime.{region}.amazonaws.com");
    let base = PROVIDER.host.endpoint(spec, base, &default)?.base;
    let parsed = reqwest::Url::parse(&base).map_err(|e| format!("invalid base URL `{base}`: {e}"))?;
    let host = match (parsed.host_str(), parsed.port()) {
        (Some(h), Some(p)) => format!("{h}:{p}"),
        (Some(h), None) => h.to_string(),
        (None, _) => return Err(format!("invalid base URL `{base}`: no host")),
    };
    let base_path = parsed.path().trim_end_matches('/');
    let wire_path = format!("{base_path}/model/{}/converse", uri_encode(model));
    let canonical_uri = wire_path.split('/').map(uri_encode).collect::<Vec<_>>().join("/");
    let proto = Bedrock {
        url: format!("{}://{host}{wire_path}", parsed.scheme()),
        host,
        canonical_uri,
        region,
        creds,
        settings: settings.clone(),
        extra_fields,
    };
    ApiModel::new(spec, &PROVIDER.host, &base, proto, settings, cache)
}

impl Bedrock {
    fn body(&self, prompt: &str, image: Option<&Encoded>) -> Value {
        let mut content = Vec::new();
        if let Some(img) = image {
            content.push(json!({"image": {"format": img.short(), "source": {"bytes": img.base64()}}}));
        }
        content.push(json!({"text": prompt}));
        let mut inference = json!({"maxTokens": self.settings.max_tokens});
        if let Some(t) = self.settings.temperature {
            inference["temperature"] = json!(t);
        }
        let mut body = json!({"messages": [{"role": "user", "content": content}], "inferenceConfig": inference});
        if let Some(f) = &self.extra_fields {
            body["additionalModelRequestFields"] = f.clone();
        }
        j::merge(&mut body, self.settings.extra.as_ref());
        body
    }

    /// The signed headers for `payload` at time `now`.
    pub fn signed_headers(&self, payload: &[u8], now: SystemTime) -> Vec<(String, String)> {
        let (_, amz_date) = sigv4::amz_date(now);
        let mut headers = vec![
            ("content-type".to_string(), "application/json".to_string()),
            ("host".to_string(), self.host.clone()),
            ("x-amz-date".to_string(), amz_date.clone()),
        ];
        if let Some(t) = &self.creds.session_token {
            headers.push(("x-amz-security-token".into(), t.0.clone()));
        }
        let req =
            SignRequest { method: "POST", canonical_uri: &self.canonical_uri, query: &[], headers: &headers, payload };
        let scope = Scope { region: &self.region, service: "bedrock", amz_date: &amz_date };
        let auth = sigv4::authorization(&self.creds, &scope, &req);
        // reqwest sets `Host` itself from the URL (the same value that was signed).
        headers.retain(|(k, _)| k != "host");
        headers.push(("authorization".into(), auth));
        headers
    }
}

impl Protocol for Bedrock {
    fn request(&self, prompt: &str, image: Option<&Encoded>) -> Result<Request, String> {
        let body = self.body(prompt, image).to_string().into_bytes();
        let headers = self.signed_headers(&body, SystemTime::now());
        Ok(Request { url: self.url.clone(), headers, body })
    }

    fn parse(&self, body: &[u8]) -> Result<Parsed, String> {
        let v = j::object(body)?;
        let blocks = j::at(&v, &["output", "message", "content"])
            .and_then(Value::as_array)
            .ok_or("no `output.message.content` in the response")?;
        let mut text = String::new();
        let mut thinking = String::new();
        for b in blocks {
            if let Some(t) = b.get("text").and_then(Value::as_str) {
                text.push_str(t);
            } else if let Some(t) = b.pointer("/reasoningContent/reasoningText/text").and_then(Value::as_str) {
                thinking.push_str(t);
            }
        }
        let stop = match v.get("stopReason").and_then(Value::as_str) {
            Some("max_tokens" | "model_context_window_exceeded") => Stop::Truncated,
            Some(r @ ("guardrail_intervened" | "content_filtered")) => Stop::Blocked(r.to_string()),
            Some("refusal") => Stop::Refusal("the model declined to answer (stopReason: refusal)".into()),
            _ => Stop::Complete,
        };
        Ok(Parsed {
            text,
            thinking: Some(thinking).filter(|t| !t.trim().is_empty()),
            stop,
            input_tokens: j::u64_at(&v, &["usage", "inputTokens"]),
            output_tokens: j::u64_at(&v, &["usage", "outputTokens"]),
            thinking_tokens: 0,
        })
    }

    fn secrets(&self) -> Vec<&str> {
        let mut s = vec![self.creds.secret_access_key.0.as_str()];
        s.extend(self.creds.session_token.iter().map(|t| t.0.as_str()));
        s
    }

    fn error(&self, _status: u16, body: &[u8]) -> ProviderError {
        let v: Value = serde_json::from_slice(body).unwrap_or(Value::Null);
        let message = j::str_at(&v, &["message"])
            .or_else(|| j::str_at(&v, &["Message"]))
            .map(|m| snippet(m.as_bytes()))
            .unwrap_or_else(|| snippet(body));
        // `__type` is e.g. `com.amazon.bedrock#ThrottlingException`; the status already says
        // whether it is transient (quota exceptions are 4xx).
        let kind = j::str_at(&v, &["__type"]).map(|t| t.rsplit('#').next().unwrap_or(t).to_string());
        let message = match kind {
            Some(k) => format!("{message} ({k})"),
            None => message,
        };
        ProviderError { message, permanent: false, retry_after: None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::secret::Secret;

    fn proto(model: &str, base: &str) -> Bedrock {
        let parsed = reqwest::Url::parse(base).unwrap();
        let wire_path = format!("/model/{}/converse", uri_encode(model));
        Bedrock {
            url: format!("{base}{wire_path}"),
            host: parsed.host_str().unwrap().to_string(),
            canonical_uri: wire_path.split('/').map(uri_encode).collect::<Vec<_>>().join("/"),
            region: "us-east-1".into(),
            creds: Credentials {
                access_key_id: "AKIDEXAMPLE".into(),
                secret_access_key: Secret("wJalrXUtnFEMI/K7MDENG+bPxRfiCYEXAMPLEKEY".into()),
                session_token: Some(Secret("SESSION".into())),
            },
            settings: crate::vlm::config::settings_for("bedrock:m", None, None).unwrap(),
            extra_fields: None,
        }
    }

    #[test]
    fn model_ids_are_encoded_once_on_the_wire_and_twice_for_signing() {
        let p = proto("us.anthropic.claude-haiku-4-5-20251001-v1:0", "https://bedrock-runtime.us-east-1.amazonaws.com");
        assert!(p.url.ends_with("/model/us.anthropic.claude-haiku-4-5-20251001-v1%3A0/converse"), "{}", p.url);
        assert_eq!(p.canonical_uri, "/model/us.anthropic.claude-haiku-4-5-20251001-v1%253A0/converse");
    }

    #[test]
    fn signed_headers_carry_date_token_and_authorization() {
        let p = proto("qwen.qwen3-vl-235b-a22b", "https://bedrock-runtime.us-east-1.amazonaws.com");
        let t = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_440_938_160);
        let h = p.signed_headers(b"{}", t);
        let get = |k: &str| h.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone()).unwrap();
        assert_eq!(get("x-amz-date"), "20150830T123600Z");
        assert_eq!(get("x-amz-security-token"), "SESSION");
        let auth = get("authorization");
        assert!(auth.starts_with("AWS4-HMAC-SHA256 Credential=AKIDEXAMPLE/20150830/us-east-1/bedrock/aws4_request, SignedHeaders=content-type;host;x-amz-date;x-amz-security-token, Signature="), "{auth}");
        // Signing is deterministic for a fixed time and body, and depends on the body.
        assert_eq!(auth, get_auth(&p, b"{}", t));
        assert_ne!(auth, get_auth(&p, b"{\"x\":1}", t));
    }

    fn get_auth(p: &Bedrock, body: &[u8], t: SystemTime) -> String {
        p.signed_headers(body, t).into_iter().find(|(k, _)| k == "authorization").unwrap().1
    }

    #[test]
    fn converse_responses() {
        let p = proto("m", "https://h");
        let body = br#"{"output":{"message":{"role":"assistant","content":[{"reasoningContent":{"reasoningText":{"text":"Fog, debris.","signature":"x"}}},{"text":"Answer: A"}]}},"stopReason":"end_turn","usage":{"inputTokens":1600,"outputTokens":210,"totalTokens":1810},"metrics":{"latencyMs":2100}}"#;
        let r = p.parse(body).unwrap();
        assert_eq!((r.text.as_str(), r.thinking.as_deref()), ("Answer: A", Some("Fog, debris.")));
        assert_eq!((r.input_tokens, r.output_tokens), (1600, 210));
        let g = br#"{"output":{"message":{"role":"assistant","content":[{"text":"Sorry, the model cannot answer this question."}]}},"stopReason":"guardrail_intervened","usage":{}}"#;
        assert_eq!(p.parse(g).unwrap().stop, Stop::Blocked("guardrail_intervened".into()));
        let t = br#"{"output":{"message":{"content":[{"text":"The"}]}},"stopReason":"max_tokens","usage":{}}"#;
        assert_eq!(p.parse(t).unwrap().stop, Stop::Truncated);
        assert_eq!(
            p.error(429, br#"{"message":"Too many requests, please wait before trying again."}"#).message,
            "Too many requests, please wait before trying again."
        );
    }
}

//! The generic API model: cache lookup, image encoding, the resilient HTTP call, answer parsing,
//! usage and cost. Each provider supplies only its wire format as a [`Protocol`].

use std::sync::Arc;
use std::time::Duration;

use crate::net::http::{self, Gate, Limits, Request, Response, Transport, Verdict};
use crate::net::secret::redact;
use crate::net::{Endpoint, EndpointFlags, Host, ProviderError};
use crate::outcome::{Answer, Usage};
use crate::vlm::cache::ReplyCache;
use crate::vlm::config::{ImageFormat, Resolved};
use crate::vlm::cost::{Ledger, Prices, Spend};
use crate::vlm::image::{self, Encoded};
use crate::vlm::{BoxFuture, Model, Query, Reply, parse};

/// What a provider's `build` starts from, beyond its wire format.
pub struct Provider {
    pub host: Host,
    /// How a `--model` value for it looks, for the message when the name is missing:
    /// `` `openai:MODEL`, e.g. `openai:gpt-4.1-mini` ``.
    pub usage: &'static str,
    /// Top-level request fields Revelio sets (or that would change how it reads the reply,
    /// like `stream`): a model config's `extra` may not replace them.
    pub owned: &'static [&'static str],
}

/// The start every provider's `build` shares: the model is named, `extra` leaves Revelio's
/// request fields alone, and the endpoint is resolved (`--base-url`, then the provider's
/// variables, then `default`) and checked ([`Host::endpoint`]) with the provider's key.
pub fn start(
    p: &Provider,
    spec: &str,
    model: &str,
    settings: &Resolved,
    base: EndpointFlags<'_>,
    default: &str,
) -> Result<Endpoint, String> {
    check_request(p, spec, model, settings)?;
    p.host.endpoint(spec, base, default)
}

/// The first half of [`start`], for providers whose default host needs more settings first:
/// the model is named and `extra` leaves Revelio's fields alone.
pub fn check_request(p: &Provider, spec: &str, model: &str, settings: &Resolved) -> Result<(), String> {
    if model.is_empty() {
        return Err(format!("invalid model `{spec}`: expected {}", p.usage));
    }
    check_extra(spec, settings, p.owned)
}

/// Refuse `extra` keys that would replace what Revelio sends.
pub fn check_extra(spec: &str, settings: &Resolved, owned: &[&str]) -> Result<(), String> {
    let Some(extra) = &settings.extra else { return Ok(()) };
    match extra.keys().find(|k| owned.contains(&k.as_str())) {
        Some(k) => Err(format!(
            "`extra` for `{spec}` sets `{k}`, which Revelio sets itself: use the model config's own settings (`max_tokens`, `temperature`, `thinking`, …) or leave it out"
        )),
        None => Ok(()),
    }
}

/// The longest reply text (and thinking text) kept in a [`Reply`], so the journal and the
/// caches hold a bounded prefix of what a model said: 32 KiB, many times a real answer.
pub const MAX_RAW_BYTES: usize = 32 << 10;

/// `text` cut to [`MAX_RAW_BYTES`] at a character boundary, with a marker saying how much was
/// cut.
pub fn bound_text(text: String) -> String {
    if text.len() <= MAX_RAW_BYTES {
        return text;
    }
    let mut end = MAX_RAW_BYTES;
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}\n[cut by Revelio: {} more bytes]", &text[..end], text.len() - end)
}

/// How a successful response ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Stop {
    Complete,
    Truncated,
    /// Blocked by the provider's filters, with the provider's reason.
    Blocked(String),
    /// The provider reported a refusal (OpenAI `refusal`, Anthropic `stop_reason: refusal`).
    Refusal(String),
}

/// A provider response reduced to what Revelio needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Parsed {
    /// Final text only (thinking parts left out where the provider separates them).
    pub text: String,
    pub thinking: Option<String>,
    pub stop: Stop,
    pub input_tokens: u64,
    /// Output tokens including thinking.
    pub output_tokens: u64,
    pub thinking_tokens: u64,
}

/// One provider's wire format.
pub trait Protocol: Send + Sync + 'static {
    /// Build the request for one attempt.
    fn request(&self, prompt: &str, image: Option<&Encoded>) -> Result<Request, String>;
    /// Read a 2xx body; an error means the body is malformed (retried).
    fn parse(&self, body: &[u8]) -> Result<Parsed, String>;
    /// Read a non-2xx body.
    fn error(&self, status: u16, body: &[u8]) -> ProviderError;
    /// The credentials this protocol sends, scrubbed from every message and reply text in case
    /// a server echoes them back.
    fn secrets(&self) -> Vec<&str>;
}

/// Judge a response with the provider's parser and the standard retry rules.
pub fn judge<P: Protocol + ?Sized>(proto: &P, resp: Response) -> Verdict<Parsed> {
    if (200..300).contains(&resp.status) {
        return match proto.parse(&resp.body) {
            Ok(p) => Verdict::Done(p),
            Err(e) => Verdict::Retry { reason: format!("malformed response: {e}"), after: None },
        };
    }
    let err = proto.error(resp.status, &resp.body);
    let reason = format!("HTTP {}: {}", resp.status, err.message);
    if err.permanent || !http::is_transient(resp.status) {
        Verdict::Fail(reason)
    } else {
        Verdict::Retry { reason, after: resp.retry_after.or(err.retry_after) }
    }
}

/// A model behind an HTTP API.
pub struct ApiModel<P: Protocol> {
    id: String,
    proto: P,
    transport: Transport,
    settings: Resolved,
    cache: Option<ReplyCache>,
    ledger: Arc<Ledger>,
    /// The provider's base URL (no credentials).
    base_url: String,
}

/// The model id: the spec plus the settings that change answers.
pub fn model_id(spec: &str, s: &Resolved) -> String {
    let mut parts = Vec::new();
    if let Some(t) = &s.thinking {
        parts.push(format!("thinking={t}"));
    }
    if let Some(b) = s.thinking_budget {
        parts.push(format!("thinking_budget={b}"));
    }
    if let Some(t) = s.temperature {
        parts.push(format!("temperature={t}"));
    }
    if s.max_tokens != 8192 {
        parts.push(format!("max_tokens={}", s.max_tokens));
    }
    if s.image_format == ImageFormat::Jpeg {
        parts.push(format!("image=jpeg{}", s.jpeg_quality));
    }
    if let Some(m) = s.image_max_side {
        parts.push(format!("max_side={m}"));
    }
    if let Some(e) = &s.extra {
        let json = serde_json::Value::Object(e.clone()).to_string();
        parts.push(format!("extra={}", &crate::hash::parts_hex([json.as_bytes()])[..8]));
    }
    if parts.is_empty() { spec.to_string() } else { format!("{spec}@{}", parts.join(",")) }
}

impl<P: Protocol> ApiModel<P> {
    /// `host` and `base` key the shared concurrency gate.
    pub fn new(
        spec: &str,
        host: &Host,
        base: &str,
        proto: P,
        settings: Resolved,
        cache_dir: Option<&std::path::Path>,
    ) -> Result<ApiModel<P>, String> {
        let id = model_id(spec, &settings);
        let gate =
            Gate::shared(&format!("{} {base}", host.provider), settings.concurrency, settings.requests_per_minute);
        let mut limits = Limits::new(settings.timeout, settings.retry_attempts, settings.retry_deadline);
        limits.backoff_base = settings.retry_backoff;
        limits.max_body = settings.max_reply_bytes;
        limits.stall = settings.stall_timeout;
        let transport = Transport::new(gate, limits)?.labelled(host.provider, &id, &proto.secrets());
        let base_url = public_url(base);
        // The cache is shared by every run: the same model name served elsewhere (another
        // vLLM server, a proxy) may answer differently, so the endpoint is part of its identity.
        let cache = cache_dir.map(|d| ReplyCache::new(d, &format!("{id} at {base_url}")));
        Ok(ApiModel { id, proto, transport, settings, cache, ledger: Arc::new(Ledger::default()), base_url })
    }

    /// The provider's wire format.
    pub fn proto(&self) -> &P {
        &self.proto
    }

    /// The resolved model settings.
    pub fn settings(&self) -> &Resolved {
        &self.settings
    }

    /// The query's image encoded as the model config asks (`None` without an image).
    pub fn encode(&self, q: &Query) -> Result<Option<Encoded>, String> {
        let Some(bytes) = &q.image else { return Ok(None) };
        let s = &self.settings;
        image::encode(bytes, s.image_format, s.image_max_side, s.jpeg_quality).map(Some)
    }

    /// The model config's prices (a batch call pays [`Prices::batch`] of them).
    pub fn prices(&self) -> Prices {
        Prices {
            input_per_mtok: self.settings.price_input_per_mtok,
            output_per_mtok: self.settings.price_output_per_mtok,
        }
    }

    async fn ask_uncached(&self, q: &Query) -> Reply {
        let image = match self.encode(q) {
            Ok(i) => i,
            Err(e) => return error_reply(e, 0, Duration::ZERO),
        };
        let called =
            self.transport.call(|| self.proto.request(&q.prompt, image.as_ref()), |r| judge(&self.proto, r)).await;
        match called.result {
            Err(e) => {
                let mut r = error_reply(e, called.attempts, called.latency);
                (r.rate_limited, r.waited_ms) = (called.rate_limited, called.waited.as_millis() as u64);
                r
            }
            Ok(p) => {
                let mut r = reply_from(q, p, self.prices(), called.latency, called.attempts);
                (r.rate_limited, r.waited_ms) = (called.rate_limited, called.waited.as_millis() as u64);
                r
            }
        }
    }

    /// A reply from the reply cache, booked as cached (`None`: not cached, or no cache).
    pub fn cached(&self, q: &Query) -> Option<Reply> {
        let c = self.cache.as_ref()?;
        let hit = c.get(&c.key(&q.image_hash, &q.prompt))?;
        self.ledger.record(&hit.usage, true, false);
        Some(hit)
    }

    /// Keep a fresh reply: its texts scrubbed of credentials and bounded, booked, cached.
    pub fn keep(&self, q: &Query, mut reply: Reply) -> Reply {
        let secrets = self.proto.secrets();
        // Parsed already: from here on the text is only kept (journal, cache), so a bounded
        // prefix of it.
        reply.raw = bound_text(redact(std::mem::take(&mut reply.raw), &secrets));
        reply.thinking = reply.thinking.map(|t| bound_text(redact(t, &secrets)));
        self.ledger.record(&reply.usage, false, reply.answer == Answer::ApiError);
        if let Some(c) = &self.cache
            && let Err(e) = c.put(&c.key(&q.image_hash, &q.prompt), &reply)
        {
            warn_once(&e);
        }
        reply
    }
}

/// The reply to `q` a provider's parsed response makes, priced at `prices`.
pub fn reply_from(q: &Query, p: Parsed, prices: Prices, latency: Duration, attempts: u32) -> Reply {
    let usage = Usage {
        input_tokens: p.input_tokens,
        output_tokens: p.output_tokens,
        thinking_tokens: p.thinking_tokens,
        cost_usd: prices.cost(p.input_tokens, p.output_tokens),
    };
    let (text, inline) = parse::split_thinking(&p.text);
    let thinking = match (p.thinking, inline) {
        (Some(a), Some(b)) => Some(format!("{a}\n{b}")),
        (a, b) => a.or(b),
    };
    let (raw, answer) = match p.stop {
        Stop::Complete => {
            let a = parse::parse(&text, &q.options);
            (text, a)
        }
        Stop::Truncated => (text, Answer::Truncated),
        Stop::Blocked(why) if text.is_empty() => (format!("blocked by the provider: {why}"), Answer::Blocked),
        Stop::Blocked(_) => (text, Answer::Blocked),
        Stop::Refusal(msg) => (if text.is_empty() { msg } else { text }, Answer::Refusal),
    };
    Reply {
        raw,
        thinking,
        answer,
        usage,
        latency_ms: latency.as_millis() as u64,
        cached: false,
        attempts,
        rate_limited: 0,
        waited_ms: 0,
    }
}

/// The reply of a call that got no answer: an `api_error` carrying the message.
pub fn error_reply(message: String, attempts: u32, latency: Duration) -> Reply {
    Reply {
        raw: message,
        thinking: None,
        answer: Answer::ApiError,
        usage: Usage::default(),
        latency_ms: latency.as_millis() as u64,
        cached: false,
        attempts,
        rate_limited: 0,
        waited_ms: 0,
    }
}

impl<P: Protocol> Model for ApiModel<P> {
    fn id(&self) -> String {
        self.id.clone()
    }

    fn ask<'a>(&'a self, query: &'a Query) -> BoxFuture<'a, Reply> {
        Box::pin(async move {
            if let Some(hit) = self.cached(query) {
                return hit;
            }
            let reply = self.ask_uncached(query).await;
            self.keep(query, reply)
        })
    }

    fn spend(&self) -> Option<Spend> {
        Some(self.ledger.snapshot())
    }

    fn pricing(&self) -> Option<crate::vlm::cost::Pricing> {
        let s = &self.settings;
        Some(crate::vlm::cost::Pricing {
            prices: Prices { input_per_mtok: s.price_input_per_mtok, output_per_mtok: s.price_output_per_mtok },
            max_output_tokens: u64::from(s.max_tokens),
            thinking_budget: s.thinking_budget.map_or(0, u64::from),
            image_max_side: s.image_max_side,
            thinking: s.thinking.as_deref().is_some_and(|t| t != "off" && t != "none"),
        })
    }

    fn concurrency(&self) -> Option<usize> {
        Some(self.settings.concurrency)
    }

    fn endpoint(&self) -> Option<String> {
        Some(self.base_url.clone())
    }
}

/// A URL without user name, password, query or fragment: safe to record in a run folder.
fn public_url(url: &str) -> String {
    match reqwest::Url::parse(url) {
        Ok(mut u) => {
            let _ = u.set_username("");
            let _ = u.set_password(None);
            u.set_query(None);
            u.set_fragment(None);
            u.as_str().trim_end_matches('/').to_string()
        }
        Err(_) => url.split(['?', '#']).next().unwrap_or_default().to_string(),
    }
}

/// A cache that cannot be written makes the run slower on resume but not wrong: say so once.
fn warn_once(msg: &str) {
    static WARNED: std::sync::Once = std::sync::Once::new();
    WARNED.call_once(|| eprintln!("warning: {msg}; replies will not be cached"));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kept_text_is_a_bounded_prefix_with_a_marker() {
        assert_eq!(bound_text("Answer: B".into()), "Answer: B");
        let long = "é".repeat(MAX_RAW_BYTES);
        let cut = bound_text(long.clone());
        assert!(cut.len() < MAX_RAW_BYTES + 64);
        assert!(cut.starts_with(&long[..MAX_RAW_BYTES]));
        assert!(cut.ends_with(&format!("[cut by Revelio: {} more bytes]", long.len() - MAX_RAW_BYTES)));
    }

    #[test]
    fn extra_may_not_replace_owned_fields() {
        let mut s = crate::vlm::config::settings_for("openai:m", None, None).unwrap();
        s.extra = Some(serde_json::json!({"stream": true, "top_p": 0.9}).as_object().unwrap().clone());
        let e = check_extra("openai:m", &s, &["messages", "stream"]).unwrap_err();
        assert!(e.starts_with("`extra` for `openai:m` sets `stream`, which Revelio sets itself"), "{e}");
        s.extra = Some(serde_json::json!({"top_p": 0.9}).as_object().unwrap().clone());
        assert!(check_extra("openai:m", &s, &["messages", "stream"]).is_ok());
    }

    #[test]
    fn ids_carry_answer_changing_settings() {
        let mut s = crate::vlm::config::settings_for("gemini:g", None, Some("low")).unwrap();
        assert_eq!(model_id("gemini:g", &s), "gemini:g@thinking=low");
        s.temperature = Some(0.0);
        s.image_format = ImageFormat::Jpeg;
        assert_eq!(model_id("gemini:g", &s), "gemini:g@thinking=low,temperature=0,image=jpeg90");
    }

    #[test]
    fn recorded_endpoints_carry_no_credentials() {
        assert_eq!(public_url("https://user:sk-secret@host.example/v1?key=abc#x"), "https://host.example/v1");
        assert_eq!(public_url("http://localhost:8000/v1"), "http://localhost:8000/v1");
    }
}

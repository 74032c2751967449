//! The model clients against local mock servers speaking each provider's wire format: the
//! requests Revelio sends, replies of every kind, errors and retries, a fault-injection run, the
//! cache, and that API keys never leak.

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use base64::Engine;
use revelio::outcome::Answer;
use revelio::vlm::registry::{ModelOptions, build_api_model};
use revelio::vlm::{Model, Query};
use serde_json::{Value, json};
use wiremock::matchers::{method, path};
use wiremock::{Mock, MockServer, Request, Respond, ResponseTemplate};

mod common;
use common::{FakeAws, png, walk};

/// Distinctive fake credentials, grepped for in every output.
const KEY: &str = "sk-revelio-CANARY-5e1f0c9d";
const AWS_SECRET: &str = "aws-secret-CANARY-77ab19";
const AWS_TOKEN: &str = "aws-token-CANARY-c0ffee";

fn init_env() {
    let aws = FakeAws { access_key_id: "AKIDCANARY", secret_access_key: AWS_SECRET, session_token: Some(AWS_TOKEN) };
    common::mock_provider_env(KEY, Some(aws));
}

fn options() -> Vec<String> {
    vec!["Stop".into(), "Slow down".into(), "Continue at the same speed".into()]
}

/// A query whose prompt carries `tag`, so mock responders can tell queries apart.
fn query(tag: &str) -> Query {
    common::image_query(&format!("tag:{tag}; What should the ego vehicle do?"), options(), png(64, 48))
}

/// A model config with fast retries and known prices; `extra` lines go to the model's own table.
fn config(dir: &Path, spec: &str, extra: &str) -> PathBuf {
    let p = dir.join("models.toml");
    let text = format!(
        "[default]\ntimeout_s = 0.5\nretry_attempts = 4\nretry_deadline_s = 20\nretry_backoff_s = 0.001\nconcurrency = 32\nprice_input_per_mtok = 1.0\nprice_output_per_mtok = 2.0\n\n[model.\"{spec}\"]\n{extra}\n"
    );
    std::fs::write(&p, text).unwrap();
    p
}

struct Setup {
    model: Arc<dyn Model>,
    dir: tempfile::TempDir,
}

fn model(spec: &str, server: &MockServer, extra: &str, thinking: Option<&str>, cache: bool) -> Setup {
    init_env();
    let dir = tempfile::tempdir().unwrap();
    let opts = ModelOptions {
        base_url: Some(server.uri()),
        config: Some(config(dir.path(), spec, extra)),
        thinking: thinking.map(str::to_string),
        no_cache: !cache,
        cache_dir: Some(dir.path().join("cache")),
        concurrency: None,
        allow_http: false,
        batch: None,
        dry_run: false,
    };
    Setup { model: build_api_model(spec, &opts).unwrap(), dir }
}

fn body_of(r: &Request) -> Value {
    serde_json::from_slice(&r.body).unwrap()
}

/// The tag inside a request's prompt (`tag:NAME; …`), whatever the provider's body shape.
fn tag_of(r: &Request) -> String {
    let text = String::from_utf8_lossy(&r.body);
    let start = text.find("tag:").map_or(0, |i| i + 4);
    text[start..].split(';').next().unwrap_or("").to_string()
}

/// Answers by prompt tag.
struct ByTag(HashMap<&'static str, ResponseTemplate>);

impl Respond for ByTag {
    fn respond(&self, r: &Request) -> ResponseTemplate {
        self.0.get(tag_of(r).as_str()).cloned().unwrap_or_else(|| ResponseTemplate::new(418))
    }
}

/// Serves the templates in order, then the last one forever.
struct Sequence(Mutex<VecDeque<ResponseTemplate>>);

impl Sequence {
    fn new(items: Vec<ResponseTemplate>) -> Sequence {
        Sequence(Mutex::new(items.into()))
    }
}

impl Respond for Sequence {
    fn respond(&self, _: &Request) -> ResponseTemplate {
        let mut q = self.0.lock().unwrap();
        if q.len() > 1 { q.pop_front().unwrap() } else { q.front().cloned().unwrap() }
    }
}

fn ok(body: Value) -> ResponseTemplate {
    ResponseTemplate::new(200).set_body_json(body)
}

fn chat(content: Value, finish: &str) -> ResponseTemplate {
    ok(json!({
        "id": "chatcmpl-1", "object": "chat.completion", "model": "vlm-test",
        "choices": [{"index": 0, "message": {"role": "assistant", "content": content}, "finish_reason": finish}],
        "usage": {"prompt_tokens": 1000, "completion_tokens": 500, "total_tokens": 1500}
    }))
}

async fn mount(server: &MockServer, route: &str, responder: impl Respond + 'static) {
    Mock::given(method("POST")).and(path(route)).respond_with(responder).mount(server).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn openai_request_shape_and_reply_kinds() {
    let server = common::mock_server().await;
    let mut replies: HashMap<&'static str, ResponseTemplate> = HashMap::new();
    replies.insert("strict", chat(json!("The lane is blocked by debris.\n\nAnswer: A"), "stop"));
    replies.insert("letter", chat(json!("(C)"), "stop"));
    replies.insert("think", chat(json!("<think>Maybe Answer: C</think>\nAnswer: B"), "stop"));
    replies.insert("ambiguous", chat(json!("Answer: A or B"), "stop"));
    replies.insert("unparsed", chat(json!("I see a road in fog."), "stop"));
    replies.insert("refusal-text", chat(json!("I'm sorry, but I can't help with that."), "stop"));
    replies.insert("length", chat(json!("<think>The scene shows"), "length"));
    replies.insert("filtered", chat(Value::Null, "content_filter"));
    replies.insert(
        "refusal",
        ok(json!({"choices": [{"index": 0, "message": {"role": "assistant", "content": null, "refusal": "I can't assist with that request."}, "finish_reason": "stop"}]})),
    );
    replies.insert(
        "reasoning",
        ok(json!({"choices": [{"index": 0, "message": {"role": "assistant", "content": "\n\nAnswer: C", "reasoning_content": "Answer: A would be wrong; the road is clear."}, "finish_reason": "stop"}],
                  "usage": {"prompt_tokens": 10, "completion_tokens": 20, "completion_tokens_details": {"reasoning_tokens": 15}}})),
    );
    mount(&server, "/v1/chat/completions", ByTag(replies)).await;
    let base = format!("{}/v1", server.uri());
    init_env();
    let dir = tempfile::tempdir().unwrap();
    let opts = ModelOptions {
        base_url: Some(base),
        config: Some(config(dir.path(), "openai:vlm-test", "")),
        ..Default::default()
    };
    let m = build_api_model("openai:vlm-test", &opts).unwrap();

    let cases = [
        ("strict", Answer::Option(0)),
        ("letter", Answer::Option(2)),
        ("think", Answer::Option(1)),
        ("ambiguous", Answer::Ambiguous),
        ("unparsed", Answer::Unparsed),
        ("refusal-text", Answer::Refusal),
        ("length", Answer::Truncated),
        ("filtered", Answer::Blocked),
        ("refusal", Answer::Refusal),
        ("reasoning", Answer::Option(2)),
    ];
    for (tag, want) in cases {
        let r = m.ask(&query(tag)).await;
        assert_eq!(r.answer, want, "{tag}: {r:?}");
        assert_eq!(r.attempts, 1, "{tag}");
        assert!(!r.cached);
    }
    let r = m.ask(&query("think")).await;
    assert_eq!(r.raw, "Answer: B");
    assert_eq!(r.thinking.as_deref(), Some("Maybe Answer: C"));
    let r = m.ask(&query("reasoning")).await;
    assert_eq!(r.thinking.as_deref(), Some("Answer: A would be wrong; the road is clear."));
    assert_eq!(r.usage.thinking_tokens, 15);
    let r = m.ask(&query("strict")).await;
    assert_eq!((r.usage.input_tokens, r.usage.output_tokens), (1000, 500));
    assert!((r.usage.cost_usd - 0.002).abs() < 1e-12, "{}", r.usage.cost_usd);
    assert!(m.spend().unwrap().cost_usd > 0.0);

    let reqs = server.received_requests().await.unwrap();
    let req = &reqs[0];
    assert_eq!(req.url.path(), "/v1/chat/completions");
    assert_eq!(req.headers.get("authorization").unwrap(), &format!("Bearer {KEY}"));
    let b = body_of(req);
    assert_eq!(b["model"], "vlm-test");
    assert_eq!(b["max_tokens"], 8192);
    assert!(b.get("reasoning_effort").is_none());
    let content = b["messages"][0]["content"].as_array().unwrap();
    let url = content[0]["image_url"]["url"].as_str().unwrap();
    let data = url.strip_prefix("data:image/png;base64,").expect("a PNG data URL");
    assert_eq!(base64::engine::general_purpose::STANDARD.decode(data).unwrap(), png(64, 48));
    assert_eq!(content[1]["type"], "text");
    assert_eq!(content[1]["text"], query("strict").prompt);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn openai_retries_are_bounded_and_selective() {
    let quota = ResponseTemplate::new(429).set_body_json(json!({"error": {"message": "You exceeded your current quota, please check your plan and billing details.", "type": "insufficient_quota", "param": null, "code": "insufficient_quota"}}));
    let limited = ResponseTemplate::new(429).insert_header("retry-after", "0").set_body_json(
        json!({"error": {"message": "Rate limit reached", "type": "requests", "code": "rate_limit_exceeded"}}),
    );
    let unavailable = ResponseTemplate::new(503).set_body_string("upstream connect error");
    let answer = chat(json!("Answer: B"), "stop");
    let cases: Vec<(&str, Vec<ResponseTemplate>, Answer, u32, &str)> = vec![
        ("429 then 503 then ok", vec![limited.clone(), unavailable.clone(), answer.clone()], Answer::Option(1), 3, ""),
        ("past http date", vec![limited.clone().insert_header("retry-after", "Wed, 21 Oct 2015 07:28:00 GMT"), answer.clone()], Answer::Option(1), 2, ""),
        ("malformed json then ok", vec![ResponseTemplate::new(200).set_body_string("{\"choices\": [{"), answer.clone()], Answer::Option(1), 2, ""),
        ("timeout then ok", vec![answer.clone().set_delay(Duration::from_secs(3)), answer.clone()], Answer::Option(1), 2, ""),
        ("quota is never retried", vec![quota, answer.clone()], Answer::ApiError, 1, "insufficient_quota"),
        ("401 is never retried", vec![ResponseTemplate::new(401).set_body_json(json!({"error": {"message": "Incorrect API key provided", "type": "invalid_request_error", "code": "invalid_api_key"}})), answer.clone()], Answer::ApiError, 1, "HTTP 401"),
        ("400 is never retried", vec![ResponseTemplate::new(400).set_body_json(json!({"error": {"message": "Invalid image", "type": "invalid_request_error"}})), answer.clone()], Answer::ApiError, 1, "Invalid image"),
        ("404 is never retried", vec![ResponseTemplate::new(404).set_body_json(json!({"object": "error", "message": "The model `vlm-test` does not exist.", "type": "NotFoundError", "code": 404})), answer.clone()], Answer::ApiError, 1, "does not exist"),
        ("500s run out of attempts", vec![ResponseTemplate::new(500).set_body_string("boom")], Answer::ApiError, 4, "gave up after 4 attempts"),
        ("retry-after past the deadline", vec![limited.clone().insert_header("retry-after", "600"), answer.clone()], Answer::ApiError, 1, "deadline"),
    ];
    for (name, seq, want, attempts, msg) in cases {
        let server = common::mock_server().await;
        mount(&server, "/chat/completions", Sequence::new(seq)).await;
        let s = model("openai:vlm-test", &server, "", None, false);
        let r = s.model.ask(&query("q")).await;
        assert_eq!(r.answer, want, "{name}: {r:?}");
        assert_eq!(r.attempts, attempts, "{name}: {r:?}");
        assert!(r.raw.contains(msg), "{name}: {}", r.raw);
        assert_eq!(server.received_requests().await.unwrap().len() as u32, attempts, "{name}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn anthropic_messages_api() {
    let server = common::mock_server().await;
    let msg = |content: Value, stop: &str| {
        ok(json!({"id": "msg_01", "type": "message", "role": "assistant", "model": "claude-test", "content": content,
                  "stop_reason": stop, "stop_sequence": null, "usage": {"input_tokens": 1200, "output_tokens": 90}}))
    };
    let overloaded = ResponseTemplate::new(529)
        .set_body_json(json!({"type": "error", "error": {"type": "overloaded_error", "message": "Overloaded"}}));
    let mut replies: HashMap<&'static str, ResponseTemplate> = HashMap::new();
    replies.insert(
        "thinking",
        msg(json!([{"type": "thinking", "thinking": "Answer: C seems wrong.", "signature": "EqQBCkgI"}, {"type": "text", "text": "Debris blocks the lane.\n\nAnswer: A"}]), "end_turn"),
    );
    replies.insert("truncated", msg(json!([{"type": "text", "text": "Looking at the"}]), "max_tokens"));
    replies.insert("refusal", msg(json!([]), "refusal"));
    mount(&server, "/v1/messages", ByTag(replies)).await;
    let s = model("anthropic:claude-test", &server, "", Some("high"), false);
    let r = s.model.ask(&query("thinking")).await;
    assert_eq!(r.answer, Answer::Option(0), "{r:?}");
    assert_eq!(r.thinking.as_deref(), Some("Answer: C seems wrong."));
    assert_eq!(s.model.ask(&query("truncated")).await.answer, Answer::Truncated);
    assert_eq!(s.model.ask(&query("refusal")).await.answer, Answer::Refusal);
    assert_eq!(s.model.id(), "anthropic:claude-test@thinking=high");

    let req = &server.received_requests().await.unwrap()[0];
    assert_eq!(req.headers.get("x-api-key").unwrap(), KEY);
    assert_eq!(req.headers.get("anthropic-version").unwrap(), "2023-06-01");
    let b = body_of(req);
    assert_eq!(b["model"], "claude-test");
    assert_eq!(b["thinking"], json!({"type": "adaptive"}));
    assert_eq!(b["output_config"], json!({"effort": "high"}));
    let content = &b["messages"][0]["content"];
    assert_eq!(content[0]["type"], "image", "the image block comes before the text");
    assert_eq!(content[0]["source"]["type"], "base64");
    assert_eq!(content[0]["source"]["media_type"], "image/png");
    assert_eq!(content[1]["type"], "text");

    // 529 overloaded is retried.
    let server = common::mock_server().await;
    mount(
        &server,
        "/v1/messages",
        Sequence::new(vec![overloaded, msg(json!([{"type": "text", "text": "Answer: B"}]), "end_turn")]),
    )
    .await;
    let s = model("anthropic:claude-test", &server, "thinking_budget = 2048", None, false);
    let r = s.model.ask(&query("q")).await;
    assert_eq!((r.answer, r.attempts), (Answer::Option(1), 2));
    let b = body_of(&server.received_requests().await.unwrap()[0]);
    assert_eq!(b["thinking"], json!({"type": "enabled", "budget_tokens": 2048}));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gemini_generate_content() {
    let server = common::mock_server().await;
    let cand = |parts: Value, finish: &str| {
        ok(json!({"candidates": [{"content": {"parts": parts, "role": "model"}, "finishReason": finish, "index": 0}],
                  "usageMetadata": {"promptTokenCount": 1300, "candidatesTokenCount": 10, "thoughtsTokenCount": 240, "totalTokenCount": 1550},
                  "modelVersion": "gemini-test"}))
    };
    let mut replies: HashMap<&'static str, ResponseTemplate> = HashMap::new();
    replies.insert(
        "thought",
        cand(json!([{"text": "Answer: C is tempting.", "thought": true}, {"text": "**Answer: B**"}]), "STOP"),
    );
    replies.insert("safety", ok(json!({"candidates": [{"finishReason": "SAFETY", "index": 0, "safetyRatings": [{"category": "HARM_CATEGORY_DANGEROUS_CONTENT", "probability": "HIGH"}]}]})));
    replies.insert("prompt-blocked", ok(json!({"promptFeedback": {"blockReason": "PROHIBITED_CONTENT"}, "usageMetadata": {"promptTokenCount": 1300}})));
    replies.insert("max-tokens", cand(json!([{"text": "Considering", "thought": true}]), "MAX_TOKENS"));
    mount(&server, "/v1beta/models/gemini-test:generateContent", ByTag(replies)).await;
    let s =
        model("gemini:gemini-test", &server, "image_format = \"jpeg\"\nimage_max_side = 32", Some("minimal"), false);
    let r = s.model.ask(&query("thought")).await;
    assert_eq!(r.answer, Answer::Option(1), "{r:?}");
    assert_eq!(r.thinking.as_deref(), Some("Answer: C is tempting."));
    assert_eq!((r.usage.output_tokens, r.usage.thinking_tokens), (250, 240));
    assert_eq!(s.model.ask(&query("safety")).await.answer, Answer::Blocked);
    let blocked = s.model.ask(&query("prompt-blocked")).await;
    assert_eq!(blocked.answer, Answer::Blocked);
    assert!(blocked.raw.contains("PROHIBITED_CONTENT"), "{}", blocked.raw);
    assert_eq!(s.model.ask(&query("max-tokens")).await.answer, Answer::Truncated);

    let req = &server.received_requests().await.unwrap()[0];
    assert_eq!(req.headers.get("x-goog-api-key").unwrap(), KEY);
    let b = body_of(req);
    assert_eq!(b["generationConfig"]["thinkingConfig"], json!({"thinkingLevel": "MINIMAL"}));
    let inline = &b["contents"][0]["parts"][0]["inlineData"];
    assert_eq!(inline["mimeType"], "image/jpeg");
    let bytes = base64::engine::general_purpose::STANDARD.decode(inline["data"].as_str().unwrap()).unwrap();
    let img = image::load_from_memory(&bytes).unwrap();
    assert_eq!((img.width(), img.height()), (32, 24), "downscaled to the max side, aspect kept");
    assert_eq!(b["contents"][0]["parts"][1]["text"], query("thought").prompt);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gemini_rate_limit_with_retry_info_then_ok() {
    let server = common::mock_server().await;
    let limited = ResponseTemplate::new(429).set_body_json(json!({"error": {"code": 429, "message": "Resource has been exhausted (e.g. check quota).", "status": "RESOURCE_EXHAUSTED",
        "details": [{"@type": "type.googleapis.com/google.rpc.RetryInfo", "retryDelay": "0s"}]}}));
    let daily = ResponseTemplate::new(429).set_body_json(json!({"error": {"code": 429, "message": "Quota exceeded", "status": "RESOURCE_EXHAUSTED",
        "details": [{"@type": "type.googleapis.com/google.rpc.QuotaFailure", "violations": [{"quotaId": "GenerateRequestsPerDayPerProjectPerModel-FreeTier"}]}]}}));
    let good = ok(json!({"candidates": [{"content": {"parts": [{"text": "Answer: A"}]}, "finishReason": "STOP"}]}));
    mount(&server, "/v1beta/models/g:generateContent", Sequence::new(vec![limited, good.clone(), daily, good])).await;
    let s = model("gemini:g", &server, "", None, false);
    let r = s.model.ask(&query("a")).await;
    assert_eq!((r.answer, r.attempts), (Answer::Option(0), 2));
    let r = s.model.ask(&query("b")).await;
    assert_eq!((r.answer, r.attempts), (Answer::ApiError, 1), "a daily quota is not retried: {r:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bedrock_converse_signed_requests() {
    use revelio::vlm::sigv4::{Credentials, Scope, SignRequest, authorization, uri_encode};
    let server = common::mock_server().await;
    let model_id = "us.anthropic.claude-haiku-4-5-20251001-v1:0";
    let route = format!("/model/{}/converse", uri_encode(model_id));
    let reply = ok(json!({"output": {"message": {"role": "assistant", "content": [
            {"reasoningContent": {"reasoningText": {"text": "Answer: A? The cone is off the road.", "signature": "sig"}}},
            {"text": "Answer: C"}]}},
        "stopReason": "end_turn", "usage": {"inputTokens": 1600, "outputTokens": 120, "totalTokens": 1720}, "metrics": {"latencyMs": 1900}}));
    let throttled = ResponseTemplate::new(429)
        .set_body_json(json!({"message": "Too many requests, please wait before trying again."}));
    mount(&server, &route, Sequence::new(vec![throttled, reply])).await;
    let s = model(&format!("bedrock:{model_id}"), &server, "thinking_budget = 1024", None, false);
    let r = s.model.ask(&query("q")).await;
    assert_eq!((r.answer, r.attempts), (Answer::Option(2), 2), "{r:?}");
    assert_eq!(r.thinking.as_deref(), Some("Answer: A? The cone is off the road."));

    let req = &server.received_requests().await.unwrap()[1];
    let b = body_of(req);
    assert_eq!(b["messages"][0]["content"][0]["image"]["format"], "png");
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(b["messages"][0]["content"][0]["image"]["source"]["bytes"].as_str().unwrap())
        .unwrap();
    assert_eq!(bytes, png(64, 48));
    assert_eq!(b["inferenceConfig"]["maxTokens"], 8192);
    assert_eq!(b["additionalModelRequestFields"]["thinking"], json!({"type": "enabled", "budget_tokens": 1024}));

    // Recompute the signature from what arrived on the wire: the server-side check AWS does.
    let h = |k: &str| req.headers.get(k).unwrap().to_str().unwrap().to_string();
    assert_eq!(h("x-amz-security-token"), AWS_TOKEN);
    let amz_date = h("x-amz-date");
    let signed: Vec<(String, String)> =
        ["content-type", "host", "x-amz-date", "x-amz-security-token"].iter().map(|k| (k.to_string(), h(k))).collect();
    let canonical_uri = req.url.path().split('/').map(uri_encode).collect::<Vec<_>>().join("/");
    let creds = Credentials {
        access_key_id: "AKIDCANARY".into(),
        secret_access_key: revelio::net::secret::Secret(AWS_SECRET.into()),
        session_token: None,
    };
    let expected = authorization(
        &creds,
        &Scope { region: "us-east-1", service: "bedrock", amz_date: &amz_date },
        &SignRequest {
            method: "POST",
            canonical_uri: &canonical_uri,
            query: &[],
            headers: &signed,
            payload: &req.body,
        },
    );
    assert_eq!(h("authorization"), expected);
    assert!(expected.contains("Credential=AKIDCANARY/") && expected.contains("/us-east-1/bedrock/aws4_request"));
}

/// Fails 20% of calls with 429 (Retry-After: 0), 10% with 500, 5% with a timeout and 5% with a
/// malformed body, chosen by a request counter; counts successful answers per prompt. Clients
/// use a 1.5 s per-attempt timeout: short enough to cut the 5 s stall, long enough that a
/// loaded machine does not time out (and so repeat) an attempt the server already answered.
struct Faulty {
    n: AtomicU64,
    successes: Mutex<HashMap<String, u32>>,
}

impl Respond for Faulty {
    fn respond(&self, r: &Request) -> ResponseTemplate {
        let i = self.n.fetch_add(1, Ordering::SeqCst);
        // A stride coprime with 20 spreads the faults so one call does not meet them all in a row.
        match (i * 7) % 20 {
            0..=3 => ResponseTemplate::new(429)
                .insert_header("retry-after", "0")
                .set_body_json(json!({"error": {"message": "Rate limit reached", "code": "rate_limit_exceeded"}})),
            4 | 5 => ResponseTemplate::new(500).set_body_json(json!({"error": {"message": "The server had an error"}})),
            6 => ResponseTemplate::new(503).set_delay(Duration::from_secs(5)),
            7 => ResponseTemplate::new(200).set_body_string("{\"id\": \"chatcmpl-\", \"choices\": [{\"message\""),
            _ => {
                *self.successes.lock().unwrap().entry(tag_of(r)).or_default() += 1;
                chat(json!("Answer: A"), "stop")
            }
        }
    }
}

/// A mock OpenAI-compatible server answering through one shared [`Faulty`].
async fn faulty_server() -> (MockServer, Arc<Faulty>) {
    struct Shared(Arc<Faulty>);
    impl Respond for Shared {
        fn respond(&self, r: &Request) -> ResponseTemplate {
            self.0.respond(r)
        }
    }
    let server = common::mock_server().await;
    let faulty = Arc::new(Faulty { n: AtomicU64::new(0), successes: Mutex::new(HashMap::new()) });
    mount(&server, "/chat/completions", Shared(faulty.clone())).await;
    (server, faulty)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fault_injection_1000_calls() {
    let (server, faulty) = faulty_server().await;
    let s = model("openai:vlm-test", &server, "retry_attempts = 12\ntimeout_s = 1.5", None, false);
    let queries: Vec<Query> = (0..1000).map(|i| query(&format!("call-{i}"))).collect();
    let replies = futures_join_all(&s.model, &queries).await;
    assert_eq!(replies.len(), 1000, "every call has exactly one reply");
    for (i, r) in replies.iter().enumerate() {
        assert_eq!(r.answer, Answer::Option(0), "call {i}: {r:?}");
        assert!(r.attempts >= 1);
    }
    let successes = faulty.successes.lock().unwrap();
    assert_eq!(successes.len(), 1000);
    assert!(successes.values().all(|&n| n == 1), "a successful call was repeated");
    let total: u32 = replies.iter().map(|r| r.attempts).sum();
    assert_eq!(total as u64, faulty.n.load(Ordering::SeqCst), "attempts account for every request");
    let spend = s.model.spend().unwrap();
    assert_eq!((spend.calls, spend.errors), (1000, 0));
}

/// Run every query concurrently (the model bounds concurrency itself).
async fn futures_join_all(m: &Arc<dyn Model>, qs: &[Query]) -> Vec<revelio::vlm::Reply> {
    let mut set = tokio::task::JoinSet::new();
    for (i, q) in qs.iter().enumerate() {
        let (m, q) = (m.clone(), q.clone());
        set.spawn(async move { (i, m.ask(&q).await) });
    }
    let mut out: Vec<Option<revelio::vlm::Reply>> = vec![None; qs.len()];
    while let Some(res) = set.join_next().await {
        let (i, r) = res.unwrap();
        assert!(out[i].replace(r).is_none());
    }
    out.into_iter().map(Option::unwrap).collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cache_serves_parsed_replies_for_free() {
    let server = common::mock_server().await;
    let mut replies: HashMap<&'static str, ResponseTemplate> = HashMap::new();
    replies.insert("good", chat(json!("Answer: B"), "stop"));
    replies.insert("bad", chat(json!("no idea"), "stop"));
    mount(&server, "/chat/completions", ByTag(replies)).await;
    let s = model("openai:vlm-test", &server, "", None, true);
    let first = s.model.ask(&query("good")).await;
    let second = s.model.ask(&query("good")).await;
    assert!(!first.cached && second.cached);
    assert_eq!(second.answer, Answer::Option(1));
    assert_eq!(second.usage.cost_usd, 0.0);
    // Unparsed replies are asked again.
    s.model.ask(&query("bad")).await;
    s.model.ask(&query("bad")).await;
    assert_eq!(server.received_requests().await.unwrap().len(), 3);
    let spend = s.model.spend().unwrap();
    assert_eq!((spend.calls, spend.cached), (3, 1));
    // `--no-cache` asks every time.
    let server2 = common::mock_server().await;
    mount(&server2, "/chat/completions", ByTag(HashMap::from([("good", chat(json!("Answer: B"), "stop"))]))).await;
    let s2 = model("openai:vlm-test", &server2, "", None, false);
    s2.model.ask(&query("good")).await;
    s2.model.ask(&query("good")).await;
    assert_eq!(server2.received_requests().await.unwrap().len(), 2);
}

/// Echoes every request header back, in an error body and in a reply, like a badly behaved
/// proxy would.
struct Echo;

impl Respond for Echo {
    fn respond(&self, r: &Request) -> ResponseTemplate {
        let headers: String = r.headers.iter().map(|(k, v)| format!("{k}: {}\n", v.to_str().unwrap_or(""))).collect();
        if tag_of(r) == "error" {
            ResponseTemplate::new(401).set_body_json(
                json!({"error": {"message": format!("bad credentials in {headers}"), "type": "authentication_error"}}),
            )
        } else {
            let text = format!("Headers seen:\n{headers}\nAnswer: A");
            ok(json!({
                "choices": [{"message": {"content": text, "reasoning_content": headers.clone()}, "finish_reason": "stop"}],
                "content": [{"type": "text", "text": text}], "stop_reason": "end_turn",
                "candidates": [{"content": {"parts": [{"text": text}]}, "finishReason": "STOP"}],
                "output": {"message": {"content": [{"text": text}]}}, "stopReason": "end_turn",
            }))
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn keys_never_leak_into_replies_ids_or_cache() {
    for spec in ["openai:m", "anthropic:m", "gemini:m", "bedrock:m"] {
        let server = common::mock_server().await;
        Mock::given(method("POST")).respond_with(Echo).mount(&server).await;
        let s = model(spec, &server, "", None, true);
        let mut outputs = vec![s.model.id(), format!("{:?}", s.model.spend())];
        for tag in ["error", "ok", "ok"] {
            let r = s.model.ask(&query(tag)).await;
            outputs.push(serde_json::to_string(&r).unwrap());
            outputs.push(format!("{r:?}"));
        }
        // The key did reach the server (the echo shows it was sent) …
        let sent: String =
            server.received_requests().await.unwrap().iter().map(|r| format!("{:?}", r.headers)).collect();
        assert!(sent.contains(KEY) || sent.contains(AWS_TOKEN), "{spec}: no credentials were sent");
        // … but appears in no output and no cache file.
        for f in walk(s.dir.path()) {
            outputs.push(String::from_utf8_lossy(&std::fs::read(&f).unwrap()).into_owned());
        }
        for o in &outputs {
            for secret in [KEY, AWS_SECRET, AWS_TOKEN] {
                assert!(!o.contains(secret), "{spec} leaked a credential: {o}");
            }
        }
        assert!(outputs.iter().any(|o| o.contains("[redacted]")), "{spec}: the echo was not redacted");
    }
}

#[test]
fn missing_keys_and_bad_specs_are_clear_errors() {
    init_env();
    let opts = ModelOptions::default();
    let err = |spec: &str, o: &ModelOptions| build_api_model(spec, o).err().unwrap();
    assert_eq!(err("openai:", &opts), "invalid model `openai:`: expected `openai:MODEL`, e.g. `openai:gpt-4.1-mini`");
    assert!(
        err("gemini:g", &ModelOptions { thinking: Some("extreme".into()), ..Default::default() })
            .contains("invalid thinking level `extreme`")
    );
    assert!(
        err("bedrock:qwen.qwen3-vl-235b-a22b", &ModelOptions { thinking: Some("high".into()), ..Default::default() })
            .contains("takes no thinking")
    );
    assert!(
        err("openai:m", &ModelOptions { base_url: Some("ftp://x".into()), ..Default::default() })
            .contains("invalid base URL `ftp://x`")
    );
}

fn scene() -> revelio::scene::Scene {
    revelio::scene::Scene {
        domain: "driving".into(),
        domain_hash: "0".repeat(64),
        concepts: vec!["debris_far".into()],
        seed: 1,
        world: Default::default(),
        environment: Default::default(),
        entities: vec![],
        extras: vec![],
        stage: vec![],
        camera: Default::default(),
    }
}

fn renderer(spec: &str, server: &MockServer, cache: &Path) -> Arc<dyn revelio::render::Renderer> {
    init_env();
    let opts = revelio::render::RendererOptions {
        size: Some((96, 54)),
        cache_dir: Some(cache.to_path_buf()),
        base_url: Some(server.uri()),
        allow_http: false,
        dry_run: false,
    };
    revelio::render::build_renderer(spec, &opts).unwrap().unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn imagegen_gemini_and_openai() {
    let b64 = base64::engine::general_purpose::STANDARD.encode(png(160, 90));
    let prompt = "A foggy two-lane road with debris far ahead, photographed from the driver's seat.";

    // Gemini: 503 first (retried), then an image; the second render comes from the cache.
    let server = common::mock_server().await;
    let image = ok(
        json!({"candidates": [{"content": {"parts": [{"text": "Here is the image."}, {"inlineData": {"mimeType": "image/png", "data": b64}}], "role": "model"}, "finishReason": "STOP"}]}),
    );
    mount(
        &server,
        "/v1beta/models/gemini-image-test:generateContent",
        Sequence::new(vec![ResponseTemplate::new(503), image]),
    )
    .await;
    let dir = tempfile::tempdir().unwrap();
    let r = renderer("imagegen:gemini:gemini-image-test", &server, dir.path());
    let first = r.render(&scene(), prompt).await.unwrap();
    let img = image::load_from_memory_with_format(&first.png, image::ImageFormat::Png).unwrap();
    assert_eq!((img.width(), img.height()), (96, 54), "resized to the requested size");
    let second = r.render(&scene(), prompt).await.unwrap();
    assert!(!first.cached && second.cached);
    assert_eq!(first.png, second.png);
    let reqs = server.received_requests().await.unwrap();
    assert_eq!(reqs.len(), 2);
    assert_eq!(reqs[1].headers.get("x-goog-api-key").unwrap(), KEY);
    let b = body_of(&reqs[1]);
    assert_eq!(b["generationConfig"]["responseModalities"], json!(["IMAGE"]));
    assert_eq!(b["generationConfig"]["imageConfig"]["aspectRatio"], "16:9");
    assert_eq!(b["contents"][0]["parts"][0]["text"], prompt);

    // Gemini: a safety block is an error that says so, and is not retried.
    let server = common::mock_server().await;
    mount(
        &server,
        "/v1beta/models/g:generateContent",
        Sequence::new(vec![ok(json!({"candidates": [{"finishReason": "IMAGE_SAFETY", "index": 0}]}))]),
    )
    .await;
    let err = renderer("imagegen:gemini:g", &server, dir.path()).render(&scene(), prompt).await.unwrap_err();
    assert!(err.blocked && err.message.contains("blocked by the provider (IMAGE_SAFETY)"), "{err:?}");
    assert_eq!(server.received_requests().await.unwrap().len(), 1);

    // OpenAI images API: b64_json output; a moderation block is reported as such.
    let server = common::mock_server().await;
    let mut replies: HashMap<&'static str, ResponseTemplate> = HashMap::new();
    replies.insert("ok", ok(json!({"created": 1_700_000_000, "data": [{"b64_json": b64}], "usage": {"input_tokens": 50, "output_tokens": 4000}})));
    replies.insert(
        "bad",
        ResponseTemplate::new(400).set_body_json(json!({"error": {"message": "Your request was rejected by the safety system.", "type": "image_generation_user_error", "code": "moderation_blocked"}})),
    );
    mount(&server, "/images/generations", ByTag(replies)).await;
    let r = renderer("imagegen:openai:gpt-image-1", &server, dir.path());
    let got = r.render(&scene(), "tag:ok; a road").await.unwrap();
    assert!(!got.cached);
    let err = r.render(&scene(), "tag:bad; a road").await.unwrap_err();
    assert!(err.blocked && err.message.contains("blocked by the provider's safety system"), "{err:?}");
    let b = body_of(&server.received_requests().await.unwrap()[0]);
    assert_eq!(
        (b["model"].as_str(), b["size"].as_str(), b["n"].as_u64()),
        (Some("gpt-image-1"), Some("1536x1024"), Some(1))
    );
    assert!(b.get("response_format").is_none(), "GPT image models reject response_format");
    for f in walk(dir.path()) {
        assert!(!String::from_utf8_lossy(&std::fs::read(f).unwrap()).contains(KEY));
    }
}

#[test]
fn the_example_config_builds_every_model_it_names() {
    init_env();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/models/paper.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let specs: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix("[model.\"")?.strip_suffix("\"]")).collect();
    assert!(specs.len() >= 8, "{specs:?}");
    for spec in specs {
        let opts = ModelOptions {
            base_url: Some("http://127.0.0.1:9".into()),
            config: Some(path.clone()),
            ..Default::default()
        };
        let m = build_api_model(spec, &opts).unwrap_or_else(|e| panic!("{spec}: {e}"));
        assert!(m.id().starts_with(spec));
    }
}

/// The fault-injection run end to end: a 1000-inference search of the driving domain against a
/// provider that fails 40% of requests. Every observation ends with exactly one recorded outcome,
/// every one is answered in the end, and no successful call is paid twice. The search is random:
/// its 1 000 observations go out as one batch, 32 in flight, so the stalled requests' timeouts
/// overlap (GPTS asks one set at a time and waited out about 50 of them one after another, a
/// minute of the suite, for the same journal, retries and accounting).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fault_injection_search_loses_nothing() {
    use revelio::lattice::Lattice;
    use revelio::run::observe::{DomainWorld, World};
    use revelio::run::runner::{self};
    use revelio::run::summary::RunConfig;
    use revelio::search::{Algo, Params};

    let (server, faulty) = faulty_server().await;
    let s = model("openai:vlm-test", &server, "retry_attempts = 12\ntimeout_s = 1.5", None, false);

    let path = format!("{}/domains/driving.rev", env!("CARGO_MANIFEST_DIR"));
    let d = revelio::check::compile_source(&path, &std::fs::read_to_string(&path).unwrap()).unwrap();
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&d));
    let (space, _) = runner::search_space(Lattice::enumerate(&d, 5).sets, d.concepts.len(), world.as_ref());
    let params = Params { algo: Algo::Random, budget: 1000, ..Params::default() };
    let config =
        RunConfig::new(&d, Path::new(&path), "openai:vlm-test", s.model.as_ref(), Default::default(), "none", params);
    let out = s.dir.path().join("run");
    let mut setup = runner::Setup::new(Arc::new(d.clone()), world, s.model.clone(), None, out.clone());
    setup.concurrency = 32;
    let report = runner::search(&setup, &config, &space).await.unwrap();

    let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    let records: Vec<Value> = journal.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(records.len(), 1000, "one journal line per inference");
    let keys: std::collections::HashSet<(String, u64)> =
        records.iter().map(|r| (r["set"].to_string(), r["obs"].as_u64().unwrap())).collect();
    assert_eq!(keys.len(), 1000, "no observation is recorded twice");
    for r in &records {
        let outcome = r["outcome"].as_str().unwrap();
        assert!(outcome == "correct" || outcome == "wrong", "an observation was lost to a fault: {r}");
    }
    let m = &report.summary.metrics;
    assert_eq!(m.inferences, 1000);
    let served: u32 = faulty.successes.lock().unwrap().values().sum();
    assert_eq!(served, 1000, "each observation was answered by exactly one successful request");
    let spend = s.model.spend().unwrap();
    assert_eq!((spend.calls, spend.errors), (1000, 0));
}

/// `revelio search` and `revelio validate` end to end against a server that echoes every
/// request header into its replies: the credentials reach the server, and appear nowhere in
/// what a run leaves behind — stdout, stderr, config, journal, summary, validation, cache.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn keys_never_reach_any_output_of_a_run() {
    init_env();
    let domain = format!("{}/domains/driving.rev", env!("CARGO_MANIFEST_DIR"));
    for spec in ["openai:m", "anthropic:m", "gemini:m", "bedrock:m"] {
        let server = common::mock_server().await;
        Mock::given(method("POST")).respond_with(Echo).mount(&server).await;
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let (out_s, uri, domain) = (out.to_string_lossy().into_owned(), server.uri(), domain.clone());
        // The shared reply cache goes into the test's folder, where the leak check reads it too.
        let cache = dir.path().join("cache").to_string_lossy().into_owned();
        let outputs = tokio::task::spawn_blocking(move || {
            let run = |args: &[&str]| {
                let o = std::process::Command::new(env!("CARGO_BIN_EXE_revelio")).args(args).output().unwrap();
                assert!(o.status.success(), "{spec}: {args:?} failed: {}", String::from_utf8_lossy(&o.stderr));
                [String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned()]
            };
            let mut outputs = Vec::new();
            outputs.extend(run(&[
                "search",
                &domain,
                "--model",
                spec,
                "--base-url",
                &uri,
                "--renderer",
                "none",
                "--algo",
                "random",
                "--budget",
                "12",
                "--samples",
                "2",
                "--concurrency",
                "4",
                "--cache-dir",
                &cache,
                "--out",
                &out_s,
            ]));
            outputs.extend(run(&[
                "validate",
                &out_s,
                "--top",
                "2",
                "--samples",
                "2",
                "--base-url",
                &uri,
                "--cache-dir",
                &cache,
            ]));
            outputs
        })
        .await
        .unwrap();
        let sent: String =
            server.received_requests().await.unwrap().iter().map(|r| format!("{:?}", r.headers)).collect();
        assert!(sent.contains(KEY) || sent.contains(AWS_TOKEN), "{spec}: no credentials were sent");
        let mut outputs = outputs;
        let files = walk(dir.path());
        assert!(
            files.iter().any(|f| f.ends_with("journal.jsonl"))
                && files.iter().any(|f| f.ends_with("validation-top2-samples2.json"))
                && files.iter().any(|f| f.starts_with(dir.path().join("cache"))),
            "{files:?}"
        );
        for f in files {
            outputs.push(String::from_utf8_lossy(&std::fs::read(&f).unwrap()).into_owned());
        }
        for o in &outputs {
            for secret in [KEY, AWS_SECRET, AWS_TOKEN] {
                assert!(!o.contains(secret), "{spec} leaked a credential into a run's output: {o}");
            }
        }
        assert!(outputs.iter().any(|o| o.contains("[redacted]")), "{spec}: the echoed headers were not journaled");
    }
}

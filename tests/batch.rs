//! `--batch-api` against local mocks of the exact batch wire formats: OpenAI Batch (file upload,
//! `/v1/batches`, output and error files), Anthropic Message Batches (`/v1/messages/batches`,
//! results from the configured host only, never a reply's `results_url`) and Gemini batch mode
//! (`batchGenerateContent` with inline requests). A killed `revelio search --batch-api` run
//! again looks at its journaled batch instead of submitting it again. The request bodies sent
//! and the reply fixtures served here are checked against the official SDKs' types
//! (`tests/sdk/check_batch_shapes.py`, in the venv of `tests/sdk.rs`; skipped with a note
//! without it, a failure under `REVELIO_REQUIRE_PEERS`).

mod common;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use revelio::outcome::Answer;
use revelio::vlm::registry::{ModelOptions, build_api_model};
use revelio::vlm::{Model, Query, Reply};
use serde_json::{Value, json};
use wiremock::matchers::{method, path, path_regex};
use wiremock::{Match, Mock, MockServer, Request, ResponseTemplate};

const KEY: &str = "sk-revelio-BATCH-CANARY-41c2";

fn init_env() {
    common::mock_provider_env(KEY, None);
}

/// A mock provider's batch service: what was submitted, whether its batches have ended, and
/// every request that reached it.
#[derive(Default)]
struct Service {
    /// Polls report the batch as ended (else still running).
    ended: AtomicBool,
    polls: AtomicUsize,
    /// Per submitted batch: its requests' `(custom_id, body)`.
    batches: Mutex<Vec<Vec<(String, Value)>>>,
    /// Bodies of the create calls (and OpenAI's uploaded lines), for the SDK check.
    sent: Mutex<Vec<Value>>,
    /// Replies served (status bodies, result lines), for the SDK check.
    served: Mutex<Vec<Value>>,
}

impl Service {
    fn keys(&self, batch: usize) -> Vec<(String, Value)> {
        self.batches.lock().unwrap()[batch].clone()
    }

    fn serve(&self, v: Value) -> Value {
        self.served.lock().unwrap().push(v.clone());
        v
    }

    fn all_keys(&self) -> Vec<String> {
        self.batches.lock().unwrap().iter().flatten().map(|(k, _)| k.clone()).collect()
    }

    /// Records a submitted batch, its requests' `(custom_id, body)`, and what was `sent` for it;
    /// the batch's index.
    fn submit(&self, items: Vec<(String, Value)>, sent: Value) -> usize {
        self.sent.lock().unwrap().push(sent);
        let mut b = self.batches.lock().unwrap();
        b.push(items);
        b.len() - 1
    }

    /// A results file of JSON `lines`, each recorded as served.
    fn serve_lines(&self, lines: impl IntoIterator<Item = Value>, content_type: &str) -> ResponseTemplate {
        let mut out = String::new();
        for line in lines {
            out.push_str(&self.serve(line).to_string());
            out.push('\n');
        }
        ResponseTemplate::new(200).set_body_raw(out, content_type)
    }
}

/// The `(key, body)` of each request of a batch: the string at the JSON pointer `key` and the
/// field `body` of each item of `requests`.
fn items(requests: &[Value], key: &str, body: &str) -> Vec<(String, Value)> {
    requests.iter().map(|q| (q.pointer(key).unwrap().as_str().unwrap().to_string(), q[body].clone())).collect()
}

/// Mounts `respond` for `verb` requests matching `route`, with the service it records into.
async fn on(
    server: &MockServer,
    verb: &str,
    route: impl Match + 'static,
    svc: &Arc<Service>,
    respond: impl Fn(&Service, &Request) -> ResponseTemplate + Send + Sync + 'static,
) {
    let s = svc.clone();
    Mock::given(method(verb)).and(route).respond_with(move |r: &Request| respond(&s, r)).mount(server).await;
}

/// Whether a request body asks about the scene a test wants to fail.
fn failing(body: &Value) -> bool {
    body.to_string().contains("FAIL")
}

fn config(dir: &Path) -> PathBuf {
    let p = dir.join("models.toml");
    std::fs::write(
        &p,
        "[default]\nretry_attempts = 2\nretry_backoff_s = 0.01\nbatch_poll_s = 0.02\nbatch_collect_s = 0.1\nprice_input_per_mtok = 2.0\nprice_output_per_mtok = 8.0\n",
    )
    .unwrap();
    p
}

fn model(spec: &str, base: &str, dir: &Path) -> Arc<dyn Model> {
    let opts = ModelOptions {
        base_url: Some(base.to_string()),
        config: Some(config(dir)),
        no_cache: true,
        batch: Some(dir.join("run")),
        ..ModelOptions::default()
    };
    build_api_model(spec, &opts).unwrap_or_else(|e| panic!("{spec}: {e}"))
}

fn query(question: &str) -> Query {
    common::image_query(question, vec!["Stop".into(), "Slow down".into(), "Continue".into()], common::png(24, 16))
}

/// Ask all `questions` at once, as the evaluator does.
async fn ask_all(model: &Arc<dyn Model>, questions: &[&str]) -> Vec<Reply> {
    let tasks: Vec<_> = questions
        .iter()
        .map(|q| {
            let (m, q) = (model.clone(), query(q));
            tokio::spawn(async move { m.ask(&q).await })
        })
        .collect();
    let mut out = Vec::new();
    for t in tasks {
        out.push(t.await.unwrap());
    }
    out
}

fn header(r: &Request, name: &str) -> Option<String> {
    r.headers.get(name).and_then(|v| v.to_str().ok()).map(str::to_string)
}

// ---- OpenAI Batch --------------------------------------------------------------------------

fn openai_completion(body: &Value) -> Value {
    json!({"id": "chatcmpl-b1", "object": "chat.completion", "created": 1_760_000_000, "model": body["model"],
           "choices": [{"index": 0, "message": {"role": "assistant", "content": "Debris ahead.\nAnswer: A", "refusal": null},
                        "finish_reason": "stop", "logprobs": null}],
           "usage": {"prompt_tokens": 1000, "completion_tokens": 100, "total_tokens": 1100}})
}

fn openai_batch(id: &str, status: &str, svc: &Service) -> Value {
    let n = svc.batches.lock().unwrap().len() as u64;
    let mut b = json!({"id": id, "object": "batch", "endpoint": "/v1/chat/completions", "errors": null,
        "input_file_id": "file-in0", "completion_window": "24h", "status": status, "output_file_id": null,
        "error_file_id": null, "created_at": 1_760_000_000, "in_progress_at": null, "expires_at": 1_760_086_400,
        "request_counts": {"total": n, "completed": 0, "failed": 0}, "metadata": null});
    if status == "completed" {
        b["output_file_id"] = json!(format!("file-out{}", &id[6..]));
        b["error_file_id"] = json!(format!("file-err{}", &id[6..]));
    }
    b
}

/// The `jsonl` file inside a `multipart/form-data` upload, and its `purpose`.
fn multipart_file(r: &Request) -> (String, String) {
    let text = String::from_utf8_lossy(&r.body).to_string();
    let boundary = header(r, "content-type").unwrap().split("boundary=").nth(1).unwrap().to_string();
    let mut purpose = String::new();
    let mut file = String::new();
    for part in text.split(&format!("--{boundary}")) {
        let Some((head, body)) = part.split_once("\r\n\r\n") else { continue };
        let body = body.strip_suffix("\r\n").unwrap_or(body).to_string();
        if head.contains("name=\"purpose\"") {
            purpose = body;
        } else if head.contains("name=\"file\"") {
            file = body;
        }
    }
    (purpose, file)
}

async fn openai_service(server: &MockServer, svc: &Arc<Service>) {
    on(server, "POST", path("/v1/files"), svc, move |s, r| {
        assert_eq!(header(r, "authorization").as_deref(), Some(format!("Bearer {KEY}").as_str()));
        let (purpose, file) = multipart_file(r);
        assert_eq!(purpose, "batch");
        let lines: Vec<Value> = file.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        let n = s.submit(items(&lines, "/custom_id", "body"), json!({"purpose": purpose, "lines": lines}));
        ResponseTemplate::new(200).set_body_json(s.serve(json!({"id": format!("file-in{n}"), "object": "file",
            "bytes": file.len(), "created_at": 1_760_000_000, "filename": "revelio-batch.jsonl", "purpose": "batch", "status": "processed"})))
    })
    .await;
    on(server, "POST", path("/v1/batches"), svc, move |s, r| {
        let body: Value = serde_json::from_slice(&r.body).unwrap();
        s.sent.lock().unwrap().push(json!({"create": body}));
        let n = body["input_file_id"].as_str().unwrap().trim_start_matches("file-in").to_string();
        ResponseTemplate::new(200).set_body_json(s.serve(openai_batch(&format!("batch_{n}"), "validating", s)))
    })
    .await;
    on(server, "GET", path_regex("^/v1/batches/batch_[0-9]+$"), svc, move |s, r| {
        s.polls.fetch_add(1, Ordering::SeqCst);
        let id = r.url.path().rsplit('/').next().unwrap().to_string();
        let status = if s.ended.load(Ordering::SeqCst) { "completed" } else { "in_progress" };
        ResponseTemplate::new(200).set_body_json(s.serve(openai_batch(&id, status, s)))
    })
    .await;
    on(server, "GET", path_regex("^/v1/files/file-(out|err)[0-9]+/content$"), svc, move |s, r| {
        let file = r.url.path().split('/').nth(3).unwrap().to_string();
        let errors = file.starts_with("file-err");
        let n: usize = file.trim_start_matches("file-out").trim_start_matches("file-err").parse().unwrap();
        let keys = s.keys(n);
        let lines = keys.iter().enumerate().filter_map(|(i, (key, body))| match (failing(body), errors) {
            (false, false) => Some(json!({"id": format!("batch_req_{i}"), "custom_id": key,
                "response": {"status_code": 200, "request_id": format!("req_{i}"), "body": openai_completion(body)}, "error": null})),
            (true, true) => Some(json!({"id": format!("batch_req_{i}"), "custom_id": key,
                "response": {"status_code": 400, "request_id": format!("req_{i}"),
                             "body": {"error": {"message": "Invalid image.", "type": "invalid_request_error", "param": null, "code": "invalid_image"}}},
                "error": null})),
            _ => None,
        });
        s.serve_lines(lines, "application/jsonl")
    })
    .await;
}

/// An OpenAI batch service whose batches have ended, but whose first `looks` at `batch_0` get
/// `first` instead.
async fn openai_service_after(server: &MockServer, first: ResponseTemplate, looks: u64) -> Arc<Service> {
    Mock::given(method("GET"))
        .and(path("/v1/batches/batch_0"))
        .respond_with(first)
        .up_to_n_times(looks)
        .with_priority(1)
        .mount(server)
        .await;
    let svc = Arc::new(Service::default());
    svc.ended.store(true, Ordering::SeqCst);
    openai_service(server, &svc).await;
    svc
}

/// An OpenAI batch: the answers at half price, one failed request named, every call with the
/// key on the configured host, the batch and the failure journaled.
async fn openai_round_trip() -> Arc<Service> {
    init_env();
    let server = common::mock_server().await;
    let svc = Arc::new(Service::default());
    svc.ended.store(true, Ordering::SeqCst);
    openai_service(&server, &svc).await;
    let dir = tempfile::tempdir().unwrap();
    let m = model("openai:gpt-4.1-mini", &format!("{}/v1", server.uri()), dir.path());
    let replies = ask_all(&m, &["Is the lane clear?", "What now?", "FAIL: what now?"]).await;
    assert_eq!(svc.batches.lock().unwrap().len(), 1, "one batch for all three");
    for r in &replies[..2] {
        assert_eq!(r.answer, Answer::Option(0), "{}", r.raw);
        // 1000 input and 100 output tokens at half of $2 and $8 per million.
        assert!((r.usage.cost_usd - (1000.0 * 1.0 + 100.0 * 4.0) / 1e6).abs() < 1e-12, "{:?}", r.usage);
    }
    assert_eq!(replies[2].answer, Answer::ApiError);
    assert!(
        replies[2].raw.starts_with("this request failed in batch `batch_0`: HTTP 400: Invalid image. (invalid_image); not answered: the same command sends it again in a new batch"),
        "{}",
        replies[2].raw
    );
    let spend = m.spend().unwrap();
    assert_eq!((spend.calls, spend.errors), (3, 1));
    let log = std::fs::read_to_string(dir.path().join("run/batches.jsonl")).unwrap();
    let lines: Vec<Value> = log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 2, "{log}");
    assert_eq!(lines[0]["batch"], "batch_0");
    assert_eq!(lines[0]["submitted"].as_array().unwrap().len(), 3);
    assert_eq!(lines[1]["failed"].as_array().unwrap().len(), 1);
    svc
}

#[tokio::test(flavor = "multi_thread")]
async fn openai_batches_answer_at_half_price_and_journal_failed_requests() {
    openai_round_trip().await;
}

// ---- Anthropic Message Batches ---------------------------------------------------------------

fn anthropic_batch(id: &str, status: &str, results_url: Option<&str>) -> Value {
    json!({"id": id, "type": "message_batch", "processing_status": status,
           "request_counts": {"processing": if status == "ended" { 0 } else { 3 }, "succeeded": 0, "errored": 0, "canceled": 0, "expired": 0},
           "ended_at": null, "created_at": "2026-11-27T15:00:00Z", "expires_at": "2026-11-28T15:00:00Z",
           "archived_at": null, "cancel_initiated_at": null, "results_url": results_url})
}

fn anthropic_message() -> Value {
    json!({"id": "msg_b1", "type": "message", "role": "assistant", "model": "claude-sonnet-4-6",
           "content": [{"type": "text", "text": "The lane is blocked.\n\nAnswer: A"}],
           "stop_reason": "end_turn", "stop_sequence": null, "usage": {"input_tokens": 1000, "output_tokens": 100}})
}

/// `results_url`: where the mock's status replies say the results are.
async fn anthropic_service(server: &MockServer, svc: &Arc<Service>, results_url: Option<String>, id: &'static str) {
    on(server, "POST", path("/v1/messages/batches"), svc, move |s, r| {
        assert_eq!(header(r, "x-api-key").as_deref(), Some(KEY));
        assert_eq!(header(r, "anthropic-version").as_deref(), Some("2023-06-01"));
        let body: Value = serde_json::from_slice(&r.body).unwrap();
        s.submit(items(body["requests"].as_array().unwrap(), "/custom_id", "params"), body);
        ResponseTemplate::new(200).set_body_json(s.serve(anthropic_batch(id, "in_progress", None)))
    })
    .await;
    on(server, "GET", path(format!("/v1/messages/batches/{id}")), svc, move |s, r| {
        assert_eq!(header(r, "x-api-key").as_deref(), Some(KEY));
        s.polls.fetch_add(1, Ordering::SeqCst);
        let ended = s.ended.load(Ordering::SeqCst);
        let b =
            anthropic_batch(id, if ended { "ended" } else { "in_progress" }, results_url.as_deref().filter(|_| ended));
        ResponseTemplate::new(200).set_body_json(s.serve(b))
    })
    .await;
    on(server, "GET", path(format!("/v1/messages/batches/{id}/results")), svc, move |s, r| {
        assert_eq!(header(r, "x-api-key").as_deref(), Some(KEY));
        let lines = s.keys(0).into_iter().map(|(key, body)| {
            let result = if failing(&body) {
                json!({"type": "errored", "error": {"type": "error", "error": {"type": "invalid_request_error", "message": "Could not process image"}}})
            } else if body.to_string().contains("LATE") {
                json!({"type": "expired"})
            } else {
                json!({"type": "succeeded", "message": anthropic_message()})
            };
            json!({"custom_id": key, "result": result})
        });
        s.serve_lines(lines, "application/binary")
    })
    .await;
}

/// Anthropic: the results come from the configured host even when the batch names another
/// host in `results_url`; that host is never called (the key never goes there).
async fn anthropic_round_trip() -> Arc<Service> {
    init_env();
    let server = common::mock_server().await;
    let foreign = common::mock_server().await;
    Mock::given(wiremock::matchers::any())
        .respond_with(ResponseTemplate::new(200).set_body_string(""))
        .mount(&foreign)
        .await;
    let svc = Arc::new(Service::default());
    let results_url = format!("{}/v1/messages/batches/msgbatch_01abc/results", foreign.uri());
    anthropic_service(&server, &svc, Some(results_url), "msgbatch_01abc").await;
    let dir = tempfile::tempdir().unwrap();
    let m = model("anthropic:claude-sonnet-4-6", &server.uri(), dir.path());
    let asking = {
        let m = m.clone();
        tokio::spawn(async move { ask_all(&m, &["Is the lane clear?", "FAIL: what now?", "LATE: what now?"]).await })
    };
    wait_until("the batch's first look", || svc.polls.load(Ordering::SeqCst) >= 1).await;
    svc.ended.store(true, Ordering::SeqCst);
    let replies = asking.await.unwrap();
    assert_eq!(replies[0].answer, Answer::Option(0), "{}", replies[0].raw);
    assert!((replies[0].usage.cost_usd - 0.0014).abs() < 1e-12, "{:?}", replies[0].usage);
    assert!(replies[1].raw.contains("Could not process image (invalid_request_error)"), "{}", replies[1].raw);
    assert!(replies[2].raw.contains("the batch expired (its 24 h window passed)"), "{}", replies[2].raw);
    assert!(foreign.received_requests().await.unwrap().is_empty(), "the reply's results_url was followed");
    svc
}

async fn wait_until(what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(start.elapsed() < Duration::from_secs(60), "timed out waiting for {what}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test(flavor = "multi_thread")]
async fn anthropic_results_come_from_the_configured_host_never_a_replys_url() {
    anthropic_round_trip().await;
}

/// A batch id that could change the URL built from it is refused before anything is built
/// from it; every request of the batch says so.
#[tokio::test(flavor = "multi_thread")]
async fn a_malformed_batch_id_is_a_specific_error() {
    init_env();
    let server = common::mock_server().await;
    Mock::given(method("POST"))
        .and(path("/v1/messages/batches"))
        .respond_with(ResponseTemplate::new(200).set_body_json(anthropic_batch(
            "msgbatch_1/../../evil",
            "in_progress",
            None,
        )))
        .mount(&server)
        .await;
    let dir = tempfile::tempdir().unwrap();
    let m = model("anthropic:claude-sonnet-4-6", &server.uri(), dir.path());
    let replies = ask_all(&m, &["a?", "b?"]).await;
    for r in replies {
        assert_eq!(r.answer, Answer::ApiError);
        assert!(
            r.raw.starts_with("cannot submit a batch of 2 requests: the provider returned a malformed message batch id `msgbatch_1/../../evil`"),
            "{}",
            r.raw
        );
    }
    assert_eq!(server.received_requests().await.unwrap().len(), 1, "nothing built from the bad id");
}

// ---- Gemini batch mode -----------------------------------------------------------------------

fn gemini_batch(svc: &Service, state: &str) -> Value {
    let mut b = json!({"name": "batches/rv123", "metadata": {
        "@type": "type.googleapis.com/google.ai.generativelanguage.v1main.GenerateContentBatch",
        "model": "models/gemini-3-flash-preview", "displayName": "revelio", "name": "batches/rv123",
        "createTime": "2026-11-27T15:00:00Z", "updateTime": "2026-11-27T15:00:01Z", "state": state,
        "batchStats": {"requestCount": "3", "pendingRequestCount": "3"}}});
    if state == "BATCH_STATE_SUCCEEDED" {
        let responses: Vec<Value> = svc
            .keys(0)
            .iter()
            .map(|(key, body)| {
                if failing(body) {
                    json!({"error": {"code": 3, "message": "Unable to process input image."}, "metadata": {"key": key}})
                } else {
                    json!({"response": {"candidates": [{"content": {"parts": [{"text": "Answer: A"}], "role": "model"}, "finishReason": "STOP", "index": 0}],
                                        "usageMetadata": {"promptTokenCount": 1000, "candidatesTokenCount": 100, "totalTokenCount": 1100},
                                        "modelVersion": "gemini-3-flash-preview"},
                           "metadata": {"key": key}})
                }
            })
            .collect();
        b["metadata"]["output"] = json!({"inlinedResponses": {"inlinedResponses": responses}});
        b["done"] = json!(true);
    }
    b
}

async fn gemini_round_trip() -> Arc<Service> {
    init_env();
    let server = common::mock_server().await;
    let svc = Arc::new(Service::default());
    on(&server, "POST", path("/v1beta/models/gemini-3-flash-preview:batchGenerateContent"), &svc, move |s, r| {
        assert_eq!(header(r, "x-goog-api-key").as_deref(), Some(KEY));
        let body: Value = serde_json::from_slice(&r.body).unwrap();
        s.submit(
            items(body["batch"]["inputConfig"]["requests"]["requests"].as_array().unwrap(), "/metadata/key", "request"),
            body,
        );
        ResponseTemplate::new(200).set_body_json(s.serve(gemini_batch(s, "BATCH_STATE_PENDING")))
    })
    .await;
    on(&server, "GET", path("/v1beta/batches/rv123"), &svc, move |s, r| {
        assert_eq!(header(r, "x-goog-api-key").as_deref(), Some(KEY));
        let n = s.polls.fetch_add(1, Ordering::SeqCst);
        let state = if n == 0 { "BATCH_STATE_RUNNING" } else { "BATCH_STATE_SUCCEEDED" };
        ResponseTemplate::new(200).set_body_json(s.serve(gemini_batch(s, state)))
    })
    .await;
    let dir = tempfile::tempdir().unwrap();
    let m = model("gemini:gemini-3-flash-preview", &server.uri(), dir.path());
    let replies = ask_all(&m, &["Is the lane clear?", "What now?", "FAIL: what now?"]).await;
    assert_eq!(replies[0].answer, Answer::Option(0), "{}", replies[0].raw);
    assert_eq!(replies[1].answer, Answer::Option(0), "{}", replies[1].raw);
    assert!((replies[0].usage.cost_usd - 0.0014).abs() < 1e-12, "{:?}", replies[0].usage);
    assert!(replies[2].raw.contains("Unable to process input image. (code 3)"), "{}", replies[2].raw);
    assert_eq!(svc.polls.load(Ordering::SeqCst), 2);
    svc
}

#[tokio::test(flavor = "multi_thread")]
async fn gemini_inline_batches_round_trip() {
    gemini_round_trip().await;
}

// ---- A killed process ------------------------------------------------------------------------

fn revelio(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_revelio"));
    c.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    c.env("XDG_CACHE_HOME", std::env::temp_dir().join("revelio-tests-unused-cache")).env("OPENAI_API_KEY", KEY);
    c
}

/// `revelio search` of the driving domain by `openai:gpt-4.1-mini` at `base`, with `--batch-api`:
/// `budget` random scenes, two samples each, no shrinking, into `out`.
fn batch_search(budget: &str, base: &str, out: &Path, cfg: &Path) -> Command {
    let mut c = revelio(&[
        "search",
        "domains/driving.rev",
        "--model",
        "openai:gpt-4.1-mini",
        "--renderer",
        "none",
        "--algo",
        "random",
        "--budget",
        budget,
        "--samples",
        "2",
        "--shrink",
        "0",
        "--batch-api",
        "--json",
        "--no-cache",
    ]);
    c.arg("--base-url").arg(base).arg("--model-config").arg(cfg).arg("--out").arg(out);
    c
}

/// `revelio search --algo random --batch-api` killed (SIGKILL) while its batch is pending: the
/// same command looks at the journaled batch and submits none of its requests again.
#[tokio::test(flavor = "multi_thread")]
async fn a_killed_batch_run_resumes_its_pending_batch_instead_of_resubmitting() {
    let server = common::mock_server().await;
    let svc = Arc::new(Service::default());
    openai_service(&server, &svc).await;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let cfg = config(dir.path());
    let base = format!("{}/v1", server.uri());
    let cmd = {
        let out = out.clone();
        move || batch_search("8", &base, &out, &cfg)
    };
    let mut first = cmd().stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    // The evaluator asks for all eight observations at once; they may reach the model in more
    // than one collection window (and batch) on a busy machine.
    wait_until("all eight requests in pending batches", || svc.all_keys().len() == 8).await;
    wait_until("a look at the pending batch", || svc.polls.load(Ordering::SeqCst) >= 2).await;
    assert!(std::fs::read_to_string(out.join("batches.jsonl")).unwrap().contains("\"batch_0\""));
    first.kill().unwrap();
    first.wait().unwrap();
    let submitted = svc.all_keys();
    assert_eq!(submitted.len(), 8, "budget 8: four sets, two scenes each");

    svc.ended.store(true, Ordering::SeqCst);
    let done = tokio::task::spawn_blocking(move || cmd().output().unwrap()).await.unwrap();
    let err = String::from_utf8_lossy(&done.stderr);
    assert_eq!(done.status.code(), Some(0), "{err}");
    let keys = svc.all_keys();
    let distinct: HashSet<&String> = keys.iter().collect();
    assert_eq!(distinct.len(), keys.len(), "a request was submitted twice");
    assert_eq!(keys, submitted, "the resumed run submitted a new batch");
    let summary: Value = serde_json::from_slice(&done.stdout).unwrap();
    assert_eq!(summary["spend"]["calls"], 8, "{summary}");
    let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    assert_eq!(journal.lines().count(), 8);
    assert!(err.contains("batch `batch_0` ended: ") && !err.contains("submitted:"), "{err}");
}

/// A whole batch that expired fails each of its requests with the reason, journaled as failed;
/// the next run (a new process) sends them in a new batch.
#[tokio::test(flavor = "multi_thread")]
async fn an_expired_batch_fails_its_requests_and_the_next_run_batches_them_again() {
    init_env();
    let server = common::mock_server().await;
    let first = ResponseTemplate::new(200).set_body_json(json!({"id": "batch_0", "object": "batch",
        "endpoint": "/v1/chat/completions", "input_file_id": "file-in0", "completion_window": "24h", "status": "expired",
        "created_at": 1_760_000_000, "request_counts": {"total": 2, "completed": 0, "failed": 0}}));
    let svc = openai_service_after(&server, first, 1).await;
    let dir = tempfile::tempdir().unwrap();
    let base = format!("{}/v1", server.uri());
    let replies = ask_all(&model("openai:gpt-4.1-mini", &base, dir.path()), &["a?", "b?"]).await;
    for r in &replies {
        assert_eq!(r.answer, Answer::ApiError);
        assert!(
            r.raw.starts_with("batch `batch_0` expired (its 24 h window passed) before this request was answered; not answered: the same command sends it again in a new batch (or live, without `--batch-api`)"),
            "{}",
            r.raw
        );
    }
    let again = ask_all(&model("openai:gpt-4.1-mini", &base, dir.path()), &["a?", "b?"]).await;
    assert!(again.iter().all(|r| r.answer == Answer::Option(0)), "{again:?}");
    assert_eq!(svc.batches.lock().unwrap().len(), 2, "the failed requests went into a second batch");
    // The same requests, in whatever order the two concurrent asks reached the batch.
    let sorted = |i| {
        let mut keys: Vec<String> = svc.keys(i).iter().map(|k| k.0.clone()).collect();
        keys.sort();
        keys
    };
    assert_eq!(sorted(0), sorted(1));
}

/// A status reply that does not parse is a specific error after a few looks; the batch stays
/// journaled, and the next run looks at it again instead of submitting its requests again.
#[tokio::test(flavor = "multi_thread")]
async fn a_malformed_status_reply_keeps_the_batch_journaled_for_the_next_run() {
    init_env();
    let server = common::mock_server().await;
    let first = ResponseTemplate::new(200).set_body_string("{\"id\": \"batch_0\", \"status\":");
    let svc = openai_service_after(&server, first, 3).await;
    let dir = tempfile::tempdir().unwrap();
    let base = format!("{}/v1", server.uri());
    let replies = ask_all(&model("openai:gpt-4.1-mini", &base, dir.path()), &["a?"]).await;
    assert_eq!(replies[0].answer, Answer::ApiError);
    assert!(
        replies[0].raw.starts_with("cannot look at batch `batch_0`: malformed batch status reply: ")
            && replies[0].raw.ends_with("it stays journaled in `batches.jsonl` and the same command looks at it again"),
        "{}",
        replies[0].raw
    );
    let again = ask_all(&model("openai:gpt-4.1-mini", &base, dir.path()), &["a?"]).await;
    assert_eq!(again[0].answer, Answer::Option(0), "{}", again[0].raw);
    assert_eq!(svc.batches.lock().unwrap().len(), 1, "looked at again, not submitted again");
}

/// `validate`, `probe` and `transfer` with `--batch-api` ask through batches too, on the run
/// folder's journal.
#[tokio::test(flavor = "multi_thread")]
async fn validate_probe_and_transfer_ask_through_batches() {
    let server = common::mock_server().await;
    let svc = Arc::new(Service::default());
    svc.ended.store(true, Ordering::SeqCst);
    openai_service(&server, &svc).await;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let cfg = config(dir.path());
    let base = format!("{}/v1", server.uri());
    // Each command after the search: through batches, from the mock, with the test's config.
    let run = |args: &[&str]| {
        let mut c = revelio(args);
        c.args(["--batch-api", "--json", "--no-cache", "--base-url", &base]).arg("--model-config").arg(&cfg);
        c
    };
    let out_s = out.to_str().unwrap();
    let o = batch_search("6", &base, &out, &cfg).output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let after_search = svc.all_keys().len();
    assert_eq!(after_search, 6);
    let o = run(&["validate", out_s, "--top", "2", "--samples", "3"]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert_eq!(svc.all_keys().len(), after_search + 6, "validate: two sets, three fresh scenes each");
    assert!(err.contains("submitted: 6 requests at half price"), "{err}");
    let before_probe = svc.all_keys().len();
    let o = run(&["probe", out_s, "--top", "1", "--samples", "2"]).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(svc.all_keys().len() > before_probe, "probe asked through a batch: {err}");
    let mut c = run(&["transfer", out_s, "--model", "openai:gpt-4.1", "--top", "1", "--samples", "2"]);
    c.arg("--run-base-url").arg(&base).arg("--run-model-config").arg(&cfg);
    let o = c.output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let models: HashSet<String> = svc
        .batches
        .lock()
        .unwrap()
        .iter()
        .flatten()
        .map(|(_, body)| body["model"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(
        models,
        HashSet::from(["gpt-4.1-mini".to_string(), "gpt-4.1".to_string()]),
        "both models asked in batches"
    );
    let log = std::fs::read_to_string(out.join("batches.jsonl")).unwrap();
    assert!(log.lines().count() >= 4, "{log}");
}

/// Searches that choose each set from the last answers cannot wait hours for them.
#[test]
fn batch_api_is_refused_for_adaptive_searches() {
    let o = revelio(&[
        "search",
        "domains/driving.rev",
        "--model",
        "openai:gpt-4.1-mini",
        "--renderer",
        "none",
        "--algo",
        "beam",
        "--batch-api",
    ])
    .output()
    .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.starts_with("error: `--batch-api` needs `--algo random`: `--algo beam` picks each set"), "{err}");
}

// ---- The official SDKs -----------------------------------------------------------------------

#[tokio::test(flavor = "multi_thread")]
async fn batch_requests_and_replies_match_the_official_sdks() {
    let mut data = serde_json::Map::new();
    for (name, svc) in [
        ("openai", openai_round_trip().await),
        ("anthropic", anthropic_round_trip().await),
        ("gemini", gemini_round_trip().await),
    ] {
        let sent = svc.sent.lock().unwrap().clone();
        let served = svc.served.lock().unwrap().clone();
        data.insert(name.into(), json!({"sent": sent, "served": served}));
    }
    let Some(python) = common::sdk_python("the batch SDK shape check") else { return };
    common::assert_sdks_accept(&python, "check_batch_shapes.py", Value::Object(data), "batch shapes");
}

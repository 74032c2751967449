//! The probe prompt against local mock servers speaking each provider's wire format: the
//! statements reach the model in the prompt, and the True/False marks and the option come back
//! out of replies in each provider's style; a statement a reply leaves out is unanswered, never
//! guessed.

use std::sync::Arc;

use revelio::outcome::Answer;
use revelio::vlm::registry::{ModelOptions, build_api_model};
use revelio::vlm::sigv4::uri_encode;
use revelio::vlm::{Model, Query, prompt, statements};
use serde_json::{Value, json};
use wiremock::matchers::{method, path};
use wiremock::{Mock, MockServer, ResponseTemplate};

mod common;

fn init_env() {
    let aws =
        common::FakeAws { access_key_id: "AKIDPROBE", secret_access_key: "aws-secret-probe", session_token: None };
    common::mock_provider_env("sk-probe-test", Some(aws));
}

fn options() -> Vec<String> {
    vec!["Stop".into(), "Slow down".into(), "Continue at the same speed".into()]
}

const STATEMENTS: [&str; 4] = [
    "A cyclist is directly ahead of ego.",
    "No traffic cone is in ego's lane.",
    "No cyclist is directly ahead of ego.",
    "A traffic cone is in ego's lane.",
];

fn query() -> Query {
    let texts: Vec<String> = STATEMENTS.iter().map(|s| s.to_string()).collect();
    Query {
        image: Some(Arc::new(b"not really a png".to_vec())),
        image_hash: "0".repeat(64),
        prompt: prompt::build_probe("What should the ego vehicle do?", &options(), &texts),
        options: options(),
        truth: None,
    }
}

async fn served(spec: &str, route: &str, body: Value) -> (MockServer, Arc<dyn Model>) {
    init_env();
    let server = common::mock_server().await;
    Mock::given(method("POST"))
        .and(path(route))
        .respond_with(ResponseTemplate::new(200).set_body_json(body))
        .mount(&server)
        .await;
    let opts = ModelOptions {
        base_url: Some(server.uri()),
        no_cache: true,
        config: None,
        thinking: None,
        cache_dir: None,
        concurrency: None,
        allow_http: false,
        batch: None,
        dry_run: false,
    };
    (server, build_api_model(spec, &opts).unwrap())
}

/// Text-only queries keep the image encoder out of it: probes are about the prompt and reply.
fn text_query() -> Query {
    Query { image: None, ..query() }
}

async fn check(server: &MockServer, model: &dyn Model, want_marks: &[Option<bool>], want: Answer) {
    let r = model.ask(&text_query()).await;
    assert_eq!(r.answer, want, "{r:?}");
    assert_eq!(statements::parse(&r.raw, STATEMENTS.len()), want_marks, "{}", r.raw);
    let sent = String::from_utf8_lossy(&server.received_requests().await.unwrap()[0].body).to_string();
    let sent: String = serde_json::from_str::<Value>(&sent).unwrap().to_string();
    for (i, s) in STATEMENTS.iter().enumerate() {
        assert!(sent.contains(&format!("S{}. {s}", i + 1)), "statement {} is in the request", i + 1);
    }
    assert!(sent.contains("`S1: True`"), "the statement format is in the request");
}

const T: Option<bool> = Some(true);
const F: Option<bool> = Some(false);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn openai_compatible_reply_with_a_markdown_table() {
    let text = "| Statement | Value |\n|---|---|\n| S1 | True |\n| S2 | False |\n| S3 | False |\n| S4 | True |\n\nThe cyclist and the cone block the lane.\n\nAnswer: A";
    let (server, m) = served(
        "openai:vlm-test",
        "/chat/completions",
        json!({"id": "c", "object": "chat.completion", "model": "vlm-test",
               "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
               "usage": {"prompt_tokens": 10, "completion_tokens": 5, "total_tokens": 15}}),
    )
    .await;
    check(&server, m.as_ref(), &[T, F, F, T], Answer::Option(0)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn anthropic_reply_echoing_statements_with_one_missing() {
    // Claude-style: echoes each statement before its value, and skips S3.
    let text = "S1 (A cyclist is directly ahead of ego.): True\nS2 (No traffic cone is in ego's lane.): True\nS4 (A traffic cone is in ego's lane.): False\n\nAnswer: B";
    let (server, m) = served(
        "anthropic:claude-test",
        "/v1/messages",
        json!({"id": "msg", "type": "message", "role": "assistant", "model": "claude-test",
               "content": [{"type": "thinking", "thinking": "S3: True?", "signature": "x"}, {"type": "text", "text": text}],
               "stop_reason": "end_turn", "stop_sequence": null, "usage": {"input_tokens": 10, "output_tokens": 5}}),
    )
    .await;
    check(&server, m.as_ref(), &[T, T, None, F], Answer::Option(1)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gemini_reply_with_bold_bullets() {
    let text = "* **S1:** True\n* **S2:** False\n* **S3:** False\n* **S4:** True\n\n**Answer: A**";
    let (server, m) = served(
        "gemini:gemini-test",
        "/v1beta/models/gemini-test:generateContent",
        json!({"candidates": [{"content": {"parts": [{"text": text}], "role": "model"}, "finishReason": "STOP", "index": 0}],
               "usageMetadata": {"promptTokenCount": 10, "candidatesTokenCount": 5, "totalTokenCount": 15}}),
    )
    .await;
    check(&server, m.as_ref(), &[T, F, F, T], Answer::Option(0)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bedrock_reply_with_marks_on_one_line() {
    let model_id = "us.anthropic.claude-haiku-4-5-20251001-v1:0";
    let text = "S1: T, S2: F, S3: T, S4: F\nAnswer: C";
    let (server, m) = served(
        &format!("bedrock:{model_id}"),
        &format!("/model/{}/converse", uri_encode(model_id)),
        json!({"output": {"message": {"role": "assistant", "content": [{"text": text}]}},
               "stopReason": "end_turn", "usage": {"inputTokens": 10, "outputTokens": 5, "totalTokens": 15}}),
    )
    .await;
    // S3 marked True and S4 False: the model got the cyclist right and the cone wrong.
    check(&server, m.as_ref(), &[T, F, T, F], Answer::Option(2)).await;
}

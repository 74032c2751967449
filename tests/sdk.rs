//! Request and reply shapes against the official SDKs' types: the bodies Revelio sends to
//! OpenAI-compatible servers, Anthropic and Gemini (with every thinking mode it has), and the
//! reply fixtures its parsers are checked with here, validated by `openai`, `anthropic` and
//! `google-genai` (`tests/sdk/check_shapes.py`). Needs Python 3 with `venv`; the first run
//! installs the pinned SDKs into `target/sdk-venv` from PyPI. Without Python or PyPI the test
//! prints a note and passes (the shapes are also pinned by the unit tests of each provider), or
//! fails with the reason where `REVELIO_REQUIRE_PEERS` is set, as `.ci/run` does.
//! Bedrock is left out (its SDK, boto3, has no request types to check against).

mod common;

use revelio::outcome::Answer;
use revelio::vlm::Query;
use revelio::vlm::registry::{ModelOptions, build_api_model};
use serde_json::{Value, json};
use wiremock::ResponseTemplate;

fn query() -> Query {
    let options = vec!["Stop".into(), "Slow down".into(), "Continue".into()];
    common::image_query("What should the ego vehicle do?", options, common::png(40, 30))
}

/// Ask `spec` (with model-config `settings`) once against a server answering `reply`; the body
/// it sent and the answer it read.
async fn exchange(spec: &str, settings: &str, reply: &Value) -> (Value, Answer) {
    let server = common::mock_server().await;
    wiremock::Mock::given(wiremock::matchers::any())
        .respond_with(ResponseTemplate::new(200).set_body_json(reply.clone()))
        .mount(&server)
        .await;
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("models.toml");
    std::fs::write(&config, format!("[default]\nretry_attempts = 1\n{settings}\n")).unwrap();
    let base = if spec.starts_with("openai:") { format!("{}/v1", server.uri()) } else { server.uri() };
    let opts = ModelOptions { base_url: Some(base), config: Some(config), ..ModelOptions::default() };
    let model = build_api_model(spec, &opts).unwrap_or_else(|e| panic!("{spec} [{settings}]: {e}"));
    let reply = model.ask(&query()).await;
    let sent = server.received_requests().await.unwrap();
    (serde_json::from_slice(&sent[0].body).unwrap(), reply.answer)
}

/// Reply fixtures with the answer Revelio must read from each.
type Replies = Vec<(Value, Answer)>;

fn openai_replies() -> Replies {
    vec![
        (
            json!({"id": "chatcmpl-1", "object": "chat.completion", "created": 1_760_000_000, "model": "gpt-4.1-mini",
                   "choices": [{"index": 0, "message": {"role": "assistant", "content": "Debris in the lane.\nAnswer: A", "refusal": null},
                                "finish_reason": "stop", "logprobs": null}],
                   "usage": {"prompt_tokens": 812, "completion_tokens": 40, "total_tokens": 852,
                             "completion_tokens_details": {"reasoning_tokens": 31}}}),
            Answer::Option(0),
        ),
        (
            json!({"id": "chatcmpl-2", "object": "chat.completion", "created": 1_760_000_000, "model": "o3",
                   "choices": [{"index": 0, "message": {"role": "assistant", "content": null, "refusal": "I can't help with that."},
                                "finish_reason": "stop", "logprobs": null}]}),
            Answer::Refusal,
        ),
        (
            json!({"id": "chatcmpl-3", "object": "chat.completion", "created": 1_760_000_000, "model": "qwen",
                   "choices": [{"index": 0, "message": {"role": "assistant", "content": "The road"}, "finish_reason": "length"}]}),
            Answer::Truncated,
        ),
    ]
}

fn anthropic_replies() -> Replies {
    vec![
        (
            json!({"id": "msg_01", "type": "message", "role": "assistant", "model": "claude-sonnet-4-6",
                   "content": [{"type": "thinking", "thinking": "Answer: B? No.", "signature": "EqQB"},
                               {"type": "text", "text": "The lane is blocked.\n\nAnswer: A"}],
                   "stop_reason": "end_turn", "stop_sequence": null,
                   "usage": {"input_tokens": 1500, "output_tokens": 300}}),
            Answer::Option(0),
        ),
        (
            json!({"id": "msg_02", "type": "message", "role": "assistant", "model": "claude-sonnet-4-6",
                   "content": [], "stop_reason": "refusal", "stop_sequence": null,
                   "usage": {"input_tokens": 1500, "output_tokens": 0}}),
            Answer::Refusal,
        ),
    ]
}

fn gemini_replies() -> Replies {
    vec![
        (
            json!({"candidates": [{"content": {"parts": [{"text": "Fog, debris.", "thought": true}, {"text": "Answer: A"}], "role": "model"},
                                   "finishReason": "STOP", "index": 0}],
                   "usageMetadata": {"promptTokenCount": 1290, "candidatesTokenCount": 12, "thoughtsTokenCount": 250, "totalTokenCount": 1552},
                   "modelVersion": "gemini-3-flash-preview"}),
            Answer::Option(0),
        ),
        (
            json!({"candidates": [{"finishReason": "MODEL_ARMOR", "index": 0}], "usageMetadata": {"promptTokenCount": 1290}}),
            Answer::Blocked,
        ),
        (
            json!({"promptFeedback": {"blockReason": "MODEL_ARMOR"}, "usageMetadata": {"promptTokenCount": 1290}}),
            Answer::Blocked,
        ),
    ]
}

/// One provider: a model spec, the model-config settings whose requests are checked, and the
/// reply fixtures.
struct Case {
    provider: &'static str,
    spec: &'static str,
    settings: &'static [&'static str],
    replies: fn() -> Replies,
}

#[tokio::test(flavor = "multi_thread")]
async fn requests_and_replies_match_the_official_sdks() {
    let cases = [
        Case {
            provider: "openai",
            spec: "openai:o3",
            settings: &[
                "",
                "temperature = 0.0\nmax_tokens = 1024",
                "thinking = \"low\"",
                "max_tokens_field = \"max_completion_tokens\"\nthinking = \"minimal\"",
            ],
            replies: openai_replies,
        },
        Case {
            provider: "anthropic",
            spec: "anthropic:claude-sonnet-4-6",
            settings: &[
                "",
                "thinking = \"high\"",
                "thinking = \"adaptive\"",
                "thinking_budget = 2048\ntemperature = 1.0",
            ],
            replies: anthropic_replies,
        },
        Case {
            provider: "gemini",
            spec: "gemini:gemini-3-flash-preview",
            settings: &[
                "",
                "thinking = \"minimal\"",
                "thinking = \"high\"\ntemperature = 1.0",
                "thinking_budget = 512",
            ],
            replies: gemini_replies,
        },
    ];
    let mut data = serde_json::Map::new();
    for Case { provider, spec, settings, replies } in cases {
        let replies = replies();
        let mut requests = Vec::new();
        for s in settings {
            let (body, answer) = exchange(spec, s, &replies[0].0).await;
            assert_eq!(answer, replies[0].1, "{spec} [{s}]");
            requests.push(body);
        }
        for (reply, expected) in &replies {
            let (_, answer) = exchange(spec, "", reply).await;
            assert_eq!(answer, *expected, "{spec}: {reply}");
        }
        let responses: Vec<Value> = replies.into_iter().map(|(r, _)| r).collect();
        data.insert(provider.to_string(), json!({"requests": requests, "responses": responses}));
    }
    data.insert("gemini_blocking".into(), json!(revelio::vlm::gemini::BLOCKING));

    let Some(python) = common::sdk_python("the SDK shape check") else { return };
    common::assert_sdks_accept(&python, "check_shapes.py", Value::Object(data), "shapes");
}

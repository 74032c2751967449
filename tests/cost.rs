//! Cost control through the `revelio` binary against a mock OpenAI-compatible server that bills
//! like a real one (prompt tokens counted from the request, about 4 bytes a token): a dry run's
//! count is never below the real run's and its dollars are within 10 % of the spend the run
//! reports at fixed sampling; `--max-cost` is never passed, stops with exit 1 naming the spend,
//! and a larger cap resumes; a dry run writes nothing.
mod common;

use std::path::Path;
use std::process::{Command, Output};

use serde_json::{Value, json};
use wiremock::matchers::method;
use wiremock::{Mock, MockServer, Request, Respond, ResponseTemplate};

fn revelio(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_revelio"));
    c.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    c.env("XDG_CACHE_HOME", std::env::temp_dir().join("revelio-tests-unused-cache")).env_remove("OPENAI_API_KEY");
    c
}

fn text(o: &Output) -> (i32, String, String) {
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Bills the request's text at about 4 bytes a token, and a reply in the prompt's answer format.
struct Billing;

const REPLY: &str = "The road ahead looks clear of hazards.\nAnswer: A";

impl Respond for Billing {
    fn respond(&self, req: &Request) -> ResponseTemplate {
        let body: Value = serde_json::from_slice(&req.body).unwrap();
        let mut bytes = 0;
        for m in body["messages"].as_array().unwrap() {
            match &m["content"] {
                Value::String(s) => bytes += s.len(),
                Value::Array(parts) => {
                    bytes += parts.iter().filter_map(|p| p["text"].as_str()).map(str::len).sum::<usize>()
                }
                _ => {}
            }
        }
        ResponseTemplate::new(200).set_body_json(json!({
            "choices": [{"message": {"content": REPLY}, "finish_reason": "stop"}],
            "usage": {"prompt_tokens": bytes.div_ceil(4), "completion_tokens": REPLY.len().div_ceil(4)}
        }))
    }
}

async fn server() -> MockServer {
    let server = common::mock_server().await;
    Mock::given(method("POST")).respond_with(Billing).mount(&server).await;
    server
}

/// Prices that make a call cost about a cent; `max_tokens` small enough that a cap of a few
/// calls' worst case is reachable.
fn model_config(dir: &Path) -> String {
    let p = dir.join("models.toml");
    std::fs::write(
        &p,
        "[model.\"openai:vlm-test\"]\nprice_input_per_mtok = 50.0\nprice_output_per_mtok = 200.0\nmax_tokens = 64\nconcurrency = 4\n",
    )
    .unwrap();
    p.display().to_string()
}

fn search(uri: &str, config: &str, out: &Path, extra: &[&str]) -> (i32, String, String) {
    let o = revelio(&["search", "domains/driving.rev", "--model", "openai:vlm-test", "--renderer", "none"])
        .args(["--algo", "random", "--budget", "40", "--samples", "4", "--shrink", "0", "--no-cache"])
        .args(["--base-url", uri, "--model-config", config, "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    text(&o)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dry_run_estimates_and_the_spend_cap() {
    let server = server().await;
    let dir = tempfile::tempdir().unwrap();
    let config = model_config(dir.path());
    let (uri, d) = (server.uri(), dir.path().to_path_buf());
    let (dry, real, (capped, lines, stopped, finished), resumed) = tokio::task::spawn_blocking(move || {
        let dry = search(&uri, &config, &d.join("dry"), &["--dry-run", "--json"]);
        let real = search(&uri, &config, &d.join("real"), &["--json"]);
        let capped = search(&uri, &config, &d.join("capped"), &["--max-cost", "0.05"]);
        let lines: Vec<Value> = std::fs::read_to_string(d.join("capped/journal.jsonl"))
            .unwrap_or_default()
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        let runs = |d: &Path| {
            let o = revelio(&["runs", "--json"]).arg(d).output().unwrap();
            serde_json::from_slice::<Value>(&o.stdout).unwrap()
        };
        let stopped = runs(&d);
        let resumed = search(&uri, &config, &d.join("capped"), &["--max-cost", "10", "--json"]);
        let finished = runs(&d);
        (dry, real, (capped, lines, stopped, finished), resumed)
    })
    .await
    .unwrap();
    assert_eq!(dry.0, 0, "{}", dry.2);
    assert!(!dir.path().join("dry").exists(), "a dry run writes nothing");
    let estimate: Value = serde_json::from_str(&dry.1).unwrap();
    let estimate = &estimate[0];
    assert_eq!(real.0, 0, "{}", real.2);
    let summary: Value = serde_json::from_str(&real.1).unwrap();
    let (calls, spend) = (summary["spend"]["calls"].as_u64().unwrap(), summary["spend"]["cost_usd"].as_f64().unwrap());
    assert_eq!(estimate["calls"].as_u64().unwrap(), 40);
    assert!(estimate["calls"].as_u64().unwrap() >= calls, "{estimate} vs {calls} calls");
    let estimated = estimate["cost_usd"].as_f64().unwrap();
    assert!((estimated - spend).abs() <= 0.1 * spend, "estimated ${estimated}, spent ${spend}");

    // The cap: stopped with exit 1 naming the spend, never past it; a larger cap resumes.
    assert_eq!(capped.0, 1, "{}", capped.2);
    assert!(capped.2.contains("stopped at the spend cap") && capped.2.contains("larger `--max-cost`"), "{}", capped.2);
    let paid: f64 = lines.iter().map(|l| l["usage"]["cost_usd"].as_f64().unwrap()).sum();
    assert!(!lines.is_empty() && paid <= 0.05, "{} lines cost ${paid}", lines.len());
    // `revelio runs` says why the capped run stopped, then that it finished.
    let state = |list: &Value, name: &str| {
        let run = list.as_array().unwrap().iter().find(|r| r["run"].as_str().unwrap().ends_with(name)).unwrap().clone();
        run["state"].as_str().unwrap().to_string()
    };
    assert!(state(&stopped, "capped").starts_with("stopped: stopped at the spend cap"), "{stopped}");
    assert_eq!(state(&stopped, "real"), "finished");
    assert_eq!(state(&finished, "capped"), "finished", "{finished}");
    assert_eq!(resumed.0, 0, "{}", resumed.2);
    let resumed: Value = serde_json::from_str(&resumed.1).unwrap();
    assert_eq!(resumed["metrics"]["inferences"], json!(40));
}

/// Retries are not invisible: a provider that rate-limits the first three requests shows them
/// in the journal (`attempts`), in `summary.json`'s spend and on the final line.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn retries_and_rate_limit_waits_are_reported() {
    let server = common::mock_server().await;
    Mock::given(method("POST"))
        .respond_with(ResponseTemplate::new(429).insert_header("retry-after", "0"))
        .up_to_n_times(3)
        .with_priority(1)
        .mount(&server)
        .await;
    Mock::given(method("POST")).respond_with(Billing).with_priority(2).mount(&server).await;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("models.toml"), "[model.\"openai:vlm-test\"]\nconcurrency = 1\n").unwrap();
    let config = dir.path().join("models.toml").display().to_string();
    let (uri, d) = (server.uri(), dir.path().to_path_buf());
    let (json, plain) = tokio::task::spawn_blocking(move || {
        let json = search(&uri, &config, &d.join("a"), &["--json"]);
        let plain = search(&uri, &config, &d.join("a"), &[]);
        (json, plain)
    })
    .await
    .unwrap();
    assert_eq!(json.0, 0, "{}", json.2);
    let summary: Value = serde_json::from_str(&json.1).unwrap();
    assert_eq!(summary["spend"]["retries"], json!(3), "{}", summary["spend"]);
    assert_eq!(summary["spend"]["rate_limited"], json!(3));
    let lines: Vec<Value> = std::fs::read_to_string(dir.path().join("a/journal.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(lines.iter().all(|l| l["attempts"].as_u64().is_some()), "every line says its attempts");
    assert_eq!(lines.iter().map(|l| l["attempts"].as_u64().unwrap() - 1).sum::<u64>(), 3);
    assert_eq!(plain.0, 0, "{}", plain.2);
    assert!(plain.1.contains("; 3 retries (3 after a rate limit), "), "the final line, from the journal: {}", plain.1);
}

/// `--log FILE`: one JSON line per HTTP attempt. A 500 then a 200 shows as two lines of one
/// call, the first with its retry reason and wait; the key set in the environment never appears
/// (not even when the server echoes it in an error), nor a prompt or a reply.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_request_log_shows_retries_and_never_a_key() {
    const KEY: &str = "sk-log-CANARY-9b2d41";
    let server = common::mock_server().await;
    let echo = json!({"error": {"message": format!("upstream failed for key {KEY}")}});
    Mock::given(method("POST"))
        .respond_with(ResponseTemplate::new(500).set_body_json(echo))
        .up_to_n_times(1)
        .with_priority(1)
        .mount(&server)
        .await;
    Mock::given(method("POST")).respond_with(Billing).with_priority(2).mount(&server).await;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("models.toml"),
        "[model.\"openai:vlm-test\"]\nconcurrency = 1\nretry_backoff_s = 0.01\n",
    )
    .unwrap();
    let config = dir.path().join("models.toml").display().to_string();
    let (uri, d) = (server.uri(), dir.path().to_path_buf());
    let (searched, asked) = tokio::task::spawn_blocking(move || {
        let log = d.join("requests.jsonl");
        let o = revelio(&["search", "domains/driving.rev", "--model", "openai:vlm-test", "--renderer", "none"])
            .args(["--algo", "random", "--budget", "6", "--samples", "2", "--shrink", "0", "--no-cache", "--json"])
            .args(["--base-url", &uri, "--model-config", &config, "--log"])
            .arg(&log)
            .arg("--out")
            .arg(d.join("run"))
            .env("OPENAI_API_KEY", KEY)
            .output()
            .unwrap();
        // `REVELIO_LOG` names the file when `--log` is not given.
        let env_log = d.join("ask.jsonl");
        let a =
            revelio(&["ask", "domains/driving.rev", "debris_far", "--model", "openai:vlm-test", "--renderer", "none"])
                .args(["--base-url", &uri, "--model-config", &config, "--no-cache"])
                .env("OPENAI_API_KEY", KEY)
                .env("REVELIO_LOG", &env_log)
                .output()
                .unwrap();
        (
            (text(&o), std::fs::read_to_string(&log).unwrap_or_default()),
            (text(&a), std::fs::read_to_string(&env_log).unwrap_or_default()),
        )
    })
    .await
    .unwrap();
    let ((run, log), (ask, ask_log)) = (searched, asked);
    assert_eq!(run.0, 0, "{}", run.2);
    let summary: Value = serde_json::from_str(&run.1).unwrap();
    let calls = summary["spend"]["calls"].as_u64().unwrap();
    let lines: Vec<Value> = log.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len() as u64, calls + 1, "one line per attempt: {log}");
    let first = &lines[0];
    assert_eq!(first["status"], json!(500), "{first}");
    assert_eq!(first["attempt"], json!(1));
    assert_eq!(first["outcome"], json!("retry"));
    assert!(first["reason"].as_str().unwrap().starts_with("HTTP 500: upstream failed for key"), "{first}");
    assert!(first["wait_ms"].as_u64().is_some(), "{first}");
    assert_eq!(first["provider"], json!("openai"));
    assert!(first["model"].as_str().unwrap().starts_with("openai:vlm-test"), "{first}");
    let second = &lines[1];
    assert_eq!((&second["status"], &second["attempt"], &second["outcome"]), (&json!(200), &json!(2), &json!("ok")));
    assert!(lines[2..].iter().all(|l| l["attempt"] == json!(1) && l["outcome"] == json!("ok")), "{log}");
    for l in &lines {
        assert!(l["time"].as_str().unwrap().ends_with('Z') && l["latency_ms"].as_u64().is_some(), "{l}");
        assert!(l["endpoint"].as_str().unwrap().ends_with("/chat/completions"), "{l}");
    }
    assert!(!log.contains(KEY) && log.contains("[redacted]"), "the key is scrubbed: {log}");
    assert!(!log.contains("Answer: A") && !log.contains("road ahead"), "no reply in the log: {log}");
    assert!(!log.contains("What should") && !log.contains("ego vehicle"), "no prompt in the log: {log}");
    assert_eq!(ask.0, 0, "{}", ask.2);
    assert_eq!(ask_log.lines().count(), 1, "{ask_log}");
    assert!(!ask_log.contains(KEY));
}

/// A dry run of an API model sends nothing, so it needs no key; the same command without
/// `--dry-run` asks for one.
#[test]
fn a_dry_run_needs_no_api_key() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extra: &[&str]| {
        let o = revelio(&["search", "domains/driving.rev", "--model", "openai:gpt-4.1-mini", "--renderer", "none"])
            .args(["--budget", "50", "--out"])
            .arg(dir.path().join("run"))
            .args(extra)
            .env_remove("OPENAI_BASE_URL")
            .env("REVELIO_LOG", dir.path().join("log.jsonl"))
            .output()
            .unwrap();
        text(&o)
    };
    let dry = run(&["--dry-run"]);
    assert_eq!(dry.0, 0, "{}", dry.2);
    assert!(dry.1.contains("at most 50 calls") && dry.1.contains('$'), "{}", dry.1);
    assert!(!dir.path().join("run").exists() && !dir.path().join("log.jsonl").exists(), "a dry run writes nothing");
    let real = run(&[]);
    assert_eq!(real.0, 2, "{}", real.2);
    assert!(real.2.contains("needs an API key: set `OPENAI_API_KEY`"), "{}", real.2);
}

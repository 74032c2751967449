//! The run runtime through the `revelio` binary: one concurrency setting, model settings
//! recorded in `config.json` but never taken from it for where a key goes, the shared reply cache under concurrent processes, the run-folder lock,
//! Ctrl-C, and the exit codes of usage errors.
mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::{Value, json};
use wiremock::matchers::method;
use wiremock::{Mock, MockServer, ResponseTemplate};

fn revelio(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_revelio"));
    c.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    // Never the developer's own cache.
    c.env("XDG_CACHE_HOME", std::env::temp_dir().join("revelio-tests-unused-cache")).env_remove("OPENAI_API_KEY");
    c
}

/// `revelio search domains/driving.rev` against `model` without rendering.
fn search(model: &str, algo: &str, budget: &str, samples: &str) -> Command {
    revelio(&[
        "search",
        "domains/driving.rev",
        "--model",
        model,
        "--renderer",
        "none",
        "--algo",
        algo,
        "--budget",
        budget,
        "--samples",
        samples,
    ])
}

fn text(o: &Output) -> (i32, String, String) {
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn journal(dir: &Path) -> Vec<Value> {
    std::fs::read_to_string(dir.join("journal.jsonl"))
        .unwrap_or_default()
        .lines()
        .map(|l| serde_json::from_str(l).expect("every journal line is whole"))
        .collect()
}

/// An OpenAI-compatible server that answers every question with option A.
async fn server() -> MockServer {
    let server = common::mock_server().await;
    let body = json!({"choices": [{"message": {"content": "The lane is clear.\nAnswer: A"}, "finish_reason": "stop"}],
                      "usage": {"prompt_tokens": 900, "completion_tokens": 12}});
    Mock::given(method("POST")).respond_with(ResponseTemplate::new(200).set_body_json(body)).mount(&server).await;
    server
}

/// Bugs 4, 5 and 8 of issue 13 against a mock provider: the model config's concurrency is the
/// run's (the progress line shows it, `--concurrency` overrides it); `validate` rebuilds the
/// model with the flags given again — the base URL and model config the run recorded are named
/// when missing, never taken from `config.json` (issue 27); a second run folder with the same settings is
/// served from the shared cache, also when two processes fill one cache at the same time.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn concurrency_recorded_settings_and_the_shared_cache() {
    let server = server().await;
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("models.toml");
    std::fs::write(&config, "[model.\"openai:vlm-test\"]\nconcurrency = 64\n").unwrap();
    let (uri, d) = (server.uri(), dir.path().to_path_buf());
    let cache = d.join("cache");
    let beam = move |out: &str, extra: &[&str], cache: &Path| {
        let out = d.join(out);
        // 40 calls: a 30-call search and the quarter set aside for its shrink phase.
        let mut cmd = search("openai:vlm-test", "beam", "40", "3");
        cmd.args(extra).arg("--out").arg(&out).arg("--cache-dir").arg(cache);
        (cmd, out)
    };
    let with_config = ["--base-url", uri.as_str(), "--model-config", config.to_str().unwrap()];
    let (cache2, with_config2) = (cache.clone(), with_config.map(String::from));
    let results = tokio::task::spawn_blocking(move || {
        let w: Vec<&str> = with_config2.iter().map(String::as_str).collect();
        let (mut a, a_out) = beam("a", &w, &cache2);
        let a = text(&a.output().unwrap());
        let mut five = w.clone();
        five.extend(["--concurrency", "5"]);
        let (mut b, _) = beam("b", &five, &cache2);
        let b = text(&b.output().unwrap());
        // Each destination the run was made with must be given again; with them, it validates.
        let validate = |flags: &[&str]| {
            text(
                &revelio(&["validate", a_out.to_str().unwrap(), "--top", "2", "--samples", "2"])
                    .args(["--cache-dir", cache2.to_str().unwrap()])
                    .args(flags)
                    .output()
                    .unwrap(),
            )
        };
        let refused = [validate(&[]), validate(&w[..2])];
        (a, b, (validate(&w), refused))
    })
    .await
    .unwrap();
    let ((ca, _, ea), (cb, _, eb), ((cv, vout, ev), [no_flags, no_config])) = results;
    assert_eq!((ca, cb), (0, 0), "{ea}\n{eb}");
    assert!(ea.contains(" · concurrency 64 · "), "the model config's concurrency is the run's: {ea}");
    assert!(eb.contains(" · concurrency 5 · "), "--concurrency wins: {eb}");
    assert_eq!(no_flags.0, 2, "{}", no_flags.2);
    assert!(
        no_flags.2.contains(&format!("the run was made with the model endpoint `{uri}`"))
            && no_flags.2.contains("pass `--base-url` to use it"),
        "{}",
        no_flags.2
    );
    assert_eq!(no_config.0, 2, "{}", no_config.2);
    assert!(
        no_config.2.contains(&format!("the run was made with the model config `{}`", config.display()))
            && no_config.2.contains("pass `--model-config` to use it"),
        "{}",
        no_config.2
    );
    assert_eq!(cv, 0, "validate with the run's base URL and model config given again: {ev}");
    assert!(vout.contains("validated FR"), "{vout}");
    let a_config: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("a/config.json")).unwrap()).unwrap();
    assert_eq!(a_config["endpoint"], json!(server.uri()));
    assert_eq!(a_config["model_settings"]["base_url"], json!(server.uri()));

    // Same settings, new folder: every reply from the shared cache, nothing paid twice (without
    // the shrink phase, so the journal holds the search's 30 lines).
    let before = server.received_requests().await.unwrap().len();
    let d = dir.path().to_path_buf();
    let (c, cache2, w) = (cache.clone(), cache.clone(), with_config.map(String::from));
    let again = tokio::task::spawn_blocking(move || {
        let w: Vec<&str> = w.iter().map(String::as_str).collect();
        let mut cmd = search("openai:vlm-test", "beam", "30", "3");
        cmd.args(["--shrink", "0", "--out"]);
        cmd.arg(d.join("again")).args(&w).args(["--cache-dir", c.to_str().unwrap()]);
        text(&cmd.output().unwrap())
    })
    .await
    .unwrap();
    assert_eq!(again.0, 0, "{}", again.2);
    assert_eq!(server.received_requests().await.unwrap().len(), before, "the second folder paid for nothing");
    let lines = journal(&dir.path().join("again"));
    assert_eq!(lines.len(), 30);
    assert!(lines.iter().all(|l| l["cached"] == json!(true)));

    // Another algorithm, same model and seed: GPTS's beam phase (15 of its 30 inferences) is the
    // beam run's first 5 sets, and only the rest is paid for (no shrink phase: its re-tests would
    // hit the cache or not depending on what the beam run's shrink phase asked).
    let before = server.received_requests().await.unwrap().len();
    let (d, w) = (dir.path().to_path_buf(), with_config.map(String::from));
    let gpts = tokio::task::spawn_blocking(move || {
        let w: Vec<&str> = w.iter().map(String::as_str).collect();
        let mut cmd = search("openai:vlm-test", "gpts", "30", "3");
        cmd.args(["--shrink", "0", "--out"]);
        cmd.arg(d.join("gpts")).args(&w).args(["--cache-dir", cache2.to_str().unwrap()]);
        text(&cmd.output().unwrap())
    })
    .await
    .unwrap();
    assert_eq!(gpts.0, 0, "{}", gpts.2);
    let lines = journal(&dir.path().join("gpts"));
    assert_eq!(lines.iter().filter(|l| l["cached"] == json!(true)).count(), 15, "the beam phase is shared");
    assert_eq!(server.received_requests().await.unwrap().len(), before + 15, "only the GP rounds are paid for");

    // Two processes filling one fresh cache at once: both finish with the same answers.
    let shared = dir.path().join("shared-cache");
    let d = dir.path().to_path_buf();
    let w = with_config.map(String::from);
    let both = tokio::task::spawn_blocking(move || {
        let children: Vec<_> = ["p", "q"]
            .iter()
            .map(|name| {
                let mut cmd = search("openai:vlm-test", "random", "60", "3");
                cmd.args(["--json", "--out"]);
                cmd.arg(d.join(name)).args(&w).args(["--cache-dir", shared.to_str().unwrap()]);
                cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()
            })
            .collect();
        children.into_iter().map(|c| text(&c.wait_with_output().unwrap())).collect::<Vec<_>>()
    })
    .await
    .unwrap();
    assert!(both.iter().all(|(c, _, _)| *c == 0), "{both:?}");
    let summary = |s: &str| {
        let mut v: Value = serde_json::from_str(s).unwrap();
        v["spend"] = Value::Null;
        v
    };
    assert_eq!(summary(&both[0].1), summary(&both[1].1));
}

fn slow_profile(dir: &Path, latency_ms: u64) -> String {
    let p = dir.join("slow.toml");
    std::fs::write(&p, format!("name = \"slow\"\nbase_error = 0.3\nlatency_ms = {latency_ms}\n")).unwrap();
    format!("sim:{}", p.display())
}

fn slow_search(model: &str, out: &Path, budget: &str) -> Command {
    let mut c = search(model, "random", budget, "2");
    c.args(["--concurrency", "2", "--json"]);
    c.arg("--out").arg(out);
    c
}

fn wait_for(what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(start.elapsed() < Duration::from_secs(120), "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn interrupt(child: &std::process::Child) {
    let ok = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success();
    assert!(ok, "kill -INT failed");
}

/// Issue 12: a second process on a run folder in use is refused, naming the holder; nothing is
/// asked twice.
#[test]
fn a_run_folder_in_use_is_refused_naming_its_holder() {
    let dir = tempfile::tempdir().unwrap();
    let model = slow_profile(dir.path(), 100);
    let out = dir.path().join("run");
    let mut first = slow_search(&model, &out, "200").stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    wait_for("the first run's lock", || std::fs::read_to_string(out.join("lock")).is_ok_and(|t| t.contains("pid")));
    let (code, _, err) = text(&slow_search(&model, &out, "200").output().unwrap());
    assert_eq!(code, 1, "{err}");
    assert!(err.contains(&format!("is in use by another revelio process (pid {}", first.id())), "{err}");
    interrupt(&first);
    assert_eq!(first.wait().unwrap().code(), Some(130));
}

/// Ctrl-C: the calls in flight finish and are journaled, the process exits 130, and the same
/// command finishes the run with the summary an uninterrupted run gives.
#[test]
fn ctrl_c_journals_the_calls_in_flight_and_the_run_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let model = slow_profile(dir.path(), 50);
    let out = dir.path().join("run");
    let mut child = slow_search(&model, &out, "60").stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let lines = || std::fs::read(out.join("journal.jsonl")).map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count());
    wait_for("some observations", || lines() >= 6);
    interrupt(&child);
    let status = child.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(err.contains("error: interrupted; the calls in flight were journaled"), "{err}");
    assert!(err.contains("the same command resumes it"), "{err}");
    let kept = journal(&out).len();
    assert!(kept < 60, "it stopped early");
    let (code, resumed, err) = text(&slow_search(&model, &out, "60").output().unwrap());
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(&format!("{kept} observations replayed")), "{err}");
    let (code, fresh, err) = text(&slow_search(&model, &dir.path().join("fresh"), "60").output().unwrap());
    assert_eq!(code, 0, "{err}");
    let summary: Value = serde_json::from_str(&resumed).unwrap();
    assert_eq!(summary, serde_json::from_str::<Value>(&fresh).unwrap());
    // The search's (the budget less the quarter set aside for shrinking), then the shrink
    // phase's and fresh confirmation's: every phase within the budget of 60, each journaled.
    let searched = summary["metrics"]["inferences"].as_u64().unwrap();
    let shrunk = summary["shrink"]["inferences"].as_u64().unwrap_or(0);
    let confirmed = summary["confirmation"]["inferences"].as_u64().unwrap_or(0);
    assert!(searched <= 45 && searched + shrunk + confirmed <= 60, "{summary}");
    assert_eq!(journal(&out).len() as u64, searched + shrunk + confirmed);
}

/// One exit-code policy: a bad flag value is a usage error (2) for every command.
#[test]
fn usage_errors_exit_2_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let run = |args: &[&str]| text(&revelio(args).output().unwrap());
    let base =
        ["search", "domains/driving.rev", "--model", "sim:examples/sim/driving_paper.toml", "--renderer", "none"];
    let (code, _, err) = run(&[&base[..], &["--concurrency", "0"]].concat());
    assert_eq!(code, 2, "{err}");
    let o = out.to_str().unwrap();
    let (code, _, err) = run(&[&base[..], &["--budget", "20", "--algo", "random", "--out", o]].concat());
    assert_eq!(code, 0, "{err}");
    for bad in [["--top", "0"], ["--samples", "0"], ["--concurrency", "0"]] {
        let (code, _, err) = run(&["validate", o, bad[0], bad[1]]);
        assert_eq!(code, 2, "validate {bad:?}: {err}");
    }
    let (code, _, err) = run(&["validate", dir.path().to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is not a run folder (it has no config.json)"), "{err}");
}

/// Issue 12: a run in which every model call failed exited 0 with "no failure modes found".
/// Against an endpoint that refuses every request, the run stops after `--max-api-errors` calls
/// in a row with the last error (exit 1, resumable); with the stop turned off it finishes and
/// still exits 1, saying what share of the observations failed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_whose_model_calls_all_fail_exits_1() {
    let server = common::mock_server().await;
    // 400 is not transient: no retries, so the test stays fast.
    Mock::given(method("POST"))
        .respond_with(ResponseTemplate::new(400).set_body_string("{\"error\": {\"message\": \"model not loaded\"}}"))
        .mount(&server)
        .await;
    let dir = tempfile::tempdir().unwrap();
    let (uri, d) = (server.uri(), dir.path().to_path_buf());
    let outcome = tokio::task::spawn_blocking(move || {
        let run = |out: &str, extra: &[&str]| {
            let mut cmd = search("openai:vlm-test", "random", "40", "2");
            cmd.args(["--concurrency", "2", "--no-cache", "--base-url", &uri, "--shrink", "0"]);
            cmd.args(extra).arg("--out").arg(d.join(out));
            text(&cmd.output().unwrap())
        };
        (run("stops", &[]), run("finishes", &["--max-api-errors", "0"]))
    })
    .await
    .unwrap();
    let ((code, _, err), (code_all, out_all, err_all)) = outcome;
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("error: stopped after 10 model calls in a row failed; the last: "), "{err}");
    assert!(err.contains("model not loaded"), "the last error is shown: {err}");
    assert!(err.contains("the same command resumes it"), "{err}");
    let stopped = journal(&dir.path().join("stops"));
    assert!((10..=12).contains(&stopped.len()), "the calls in flight are journaled: {}", stopped.len());
    assert!(stopped.iter().all(|l| l["outcome"] == json!("api_error")));

    assert_eq!(code_all, 1, "{err_all}");
    assert!(out_all.contains("not answered (excluded from FR): 40 api_error"), "{out_all}");
    assert!(
        err_all.contains("error: 100% of the observations (40 of 40) are failed model calls (`api_error`)"),
        "{err_all}"
    );
    assert_eq!(journal(&dir.path().join("finishes")).len(), 40);
}

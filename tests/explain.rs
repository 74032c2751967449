//! `revelio probe`, `transfer` and `compare` as a user runs them, on a sim search of the driving
//! domain: exit codes, the files they write, the journal phases, and resuming.

mod common;

use std::path::Path;
use std::process::Command;

fn revelio(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("XDG_CACHE_HOME", std::env::temp_dir().join("revelio-explain-test-cache"))
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = revelio(args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

fn phases(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("journal.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["phase"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn probe_transfer_and_compare_on_a_sim_run() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    let profile = "sim:examples/sim/driving_recognition.toml";
    ok(&[
        "search",
        "domains/driving.rev",
        "--model",
        profile,
        "--renderer",
        "none",
        "--algo",
        "beam",
        "--budget",
        "300",
        "--out",
        run_s,
        "--json",
    ]);

    let table = ok(&["probe", run_s, "--top", "12", "--samples", "4", "--min-n", "2"]);
    assert!(table.contains("concept") && table.contains("mechanism"), "{table}");
    let probe: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("probe.json")).unwrap()).unwrap();
    assert_eq!(probe["top"], 12);
    assert!(probe["analysis"]["concepts"].as_array().unwrap().iter().any(|c| c["mechanism"].is_string()));
    let probed = phases(&run).iter().filter(|p| *p == "probe").count();
    assert_eq!(probed, 48);
    // Resumed: nothing asked again.
    ok(&["probe", run_s, "--top", "12", "--samples", "4", "--min-n", "2", "--json"]);
    assert_eq!(phases(&run).iter().filter(|p| *p == "probe").count(), 48);

    let table =
        ok(&["transfer", run_s, "--model", "sim:examples/sim/driving_paper.toml", "--top", "3", "--samples", "4"]);
    assert!(table.contains("M2  sim:driving-paper@"), "{table}");
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("transfer.json")).unwrap()).unwrap();
    assert_eq!(t["models"].as_array().unwrap().len(), 2);
    assert_eq!(t["sets"].as_array().unwrap().len(), 3);
    assert_eq!(t["random"].as_array().unwrap().len(), 3);
    assert_eq!(phases(&run).iter().filter(|p| *p == "transfer").count(), 2 * 6 * 4);

    // A probed and transferred run still validates and compares.
    ok(&["validate", run_s, "--top", "2", "--samples", "2", "--json"]);
    let csv = tmp.path().join("t.csv");
    let html = tmp.path().join("t.html");
    let out = ok(&["compare", run_s, "--csv", csv.to_str().unwrap(), "--html", html.to_str().unwrap()]);
    assert!(out.contains("PFM [95% CI]") && out.contains("beam"), "{out}");
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 2);
    assert!(std::fs::read_to_string(&html).unwrap().contains("<table>"));

    // Bad input: clear errors and exit codes.
    let o = revelio(&["probe", run_s, "--low", "0.9"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("invalid `--low`"));
    let o = revelio(&["compare", tmp.path().join("nope").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not a run folder"));
}

#[test]
fn probe_starts_from_a_shrunk_runs_cores() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    ok(&[
        "search",
        "domains/driving.rev",
        "--model",
        "sim:examples/sim/driving_recognition.toml",
        "--renderer",
        "none",
        "--algo",
        "beam",
        "--budget",
        "500",
        "--shrink",
        "200",
        "--out",
        run_s,
        "--json",
    ]);
    let read = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(run.join(f)).unwrap()).unwrap()
    };
    let summary = read("summary.json");
    let cores: Vec<&serde_json::Value> = summary["cores"].as_array().unwrap().iter().map(|c| &c["concepts"]).collect();
    assert!(!cores.is_empty(), "the sim profile plants modes the shrink confirms");
    let top = cores.len() + 2;
    ok(&["probe", run_s, "--top", &top.to_string(), "--samples", "2", "--min-n", "2", "--json"]);
    let probe = read("probe.json");
    let probed: Vec<&serde_json::Value> = probe["sets"].as_array().unwrap().iter().map(|s| &s["concepts"]).collect();
    assert_eq!(probed.len(), top);
    assert_eq!(probed[..cores.len()], cores[..], "cores first, in the summary's order");
    assert!(probed[cores.len()..].iter().all(|s| !cores.contains(s)), "each set once");

    // Compare counts the shrink's cores, not the minimal failure modes.
    let out = ok(&["compare", run_s, "--json"]);
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(rows[0]["cores"].as_u64().unwrap() as usize, cores.len(), "{out}");
}

/// `--sweep` as a user runs it: the table, the SVG plot and the JSON, for the GP kernel (GPTS
/// alone) and a numeric parameter; an unknown parameter and a kernel sweep of another algorithm
/// are refused with clear messages.
#[test]
fn bench_sweep_writes_its_table_and_plot_and_refuses_what_it_cannot_sweep() {
    let tmp = tempfile::tempdir().unwrap();
    let plot = tmp.path().join("kernel.svg");
    let bench = |extra: &[&str]| {
        let mut args =
            vec!["bench", "search", "--profile", "examples/sim/driving_paper.toml", "--seeds", "2", "--budget", "60"];
        args.extend_from_slice(extra);
        revelio(&args)
    };
    let o = bench(&["--sweep", "kernel=dot,rbf", "--plot", plot.to_str().unwrap()]);
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(table.starts_with("sweep of kernel over 2 seeds × budget 60"), "{table}");
    let rows: Vec<&str> = table.lines().filter(|l| l.contains(" gpts ")).collect();
    assert_eq!(rows.len(), 2, "GPTS alone, once per kernel:\n{table}");
    assert!(rows[0].trim_start().starts_with("dot") && rows[1].trim_start().starts_with("rbf"), "{table}");
    // Div needs two failure modes in a run; with fewer it is `-` (undefined), not a number.
    assert!(
        rows.iter()
            .all(|r| r.matches(" ± ").count() == 3 || (r.matches(" ± ").count() == 2 && r.trim_end().ends_with('-'))),
        "PFM, MFR and Div with their sd:\n{table}"
    );
    assert!(table.ends_with(&format!("plot: {}\n", plot.display())));
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("PFM (%) vs kernel") && svg.contains("MFR (%) vs kernel"));
    assert!(svg.contains("\nrbf\n"), "the x axis names the kernels");

    let plot = tmp.path().join("lambda.svg");
    let o = bench(&["--sweep", "lambda=0,1", "--algos", "beam", "--json", "--plot", plot.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let points: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let values: Vec<&serde_json::Value> = points.as_array().unwrap().iter().map(|p| &p["value"]).collect();
    assert_eq!(values, [&serde_json::json!(0.0), &serde_json::json!(1.0)]);
    assert!(points[0]["pfm"][0].as_f64().is_some() && plot.is_file());

    let o = bench(&["--sweep", "width=1,2"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(
            "unknown parameter `width`; sweepable: beam_width, beam_budget, samples, threshold, lambda, kernel"
        ),
        "{err}"
    );
    let o = bench(&["--sweep", "kernel=dot,rbf", "--algos", "beam"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("`--sweep kernel` changes only gpts; `--algos` names `beam`"), "{err}");
    let o = bench(&["--sweep", "kernel=dot,matern"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown kernel `matern`: expected one of dot, rbf"));
}

/// The indoor domain (best-fit rules, a question per rule): probe classifies a planted
/// recognition failure and a planted reasoning failure, transfer and compare work, and both
/// refresh the run report with their sections.
#[test]
fn probe_transfer_and_compare_on_the_indoor_domain() {
    let tmp = tempfile::tempdir().unwrap();
    let profile = tmp.path().join("indoor.toml");
    std::fs::write(
        &profile,
        "name = \"indoor-recognition\"\nbase_error = 0.05\nunparsed = 0.0\nlatency_ms = 0\n\
         [[mode]]\nconcepts = [\"scissors_open\"]\nerror = 0.9\n\
         [[mode]]\nconcepts = [\"pan_counter\"]\nerror = 0.9\n\
         [recognition]\nscissors_open = 0.1\n",
    )
    .unwrap();
    let model = format!("sim:{}", profile.display());
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    ok(&[
        "search",
        "domains/indoor.rev",
        "--model",
        &model,
        "--renderer",
        "none",
        "--algo",
        "beam",
        "--budget",
        "200",
        "--out",
        run_s,
        "--json",
    ]);
    let out = ok(&["probe", run_s, "--top", "10", "--samples", "4", "--min-n", "2"]);
    let report = run.join("report").join("index.html");
    assert!(out.ends_with(&format!("report: {}\n", report.display())), "probe refreshes the report:\n{out}");
    let probe: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("probe.json")).unwrap()).unwrap();
    let mechanism = |c: &str| {
        probe["analysis"]["concepts"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["concept"] == c)
            .map(|r| r["mechanism"].clone())
    };
    assert_eq!(mechanism("scissors_open"), Some(serde_json::json!("recognition")), "{probe:#}");
    assert_eq!(mechanism("pan_counter"), Some(serde_json::json!("reasoning")), "{probe:#}");

    let out =
        ok(&["transfer", run_s, "--model", "sim:examples/sim/indoor_stress.toml", "--top", "3", "--samples", "3"]);
    assert!(
        out.contains("M2  sim:indoor-stress@") && out.ends_with(&format!("report: {}\n", report.display())),
        "{out}"
    );
    assert_eq!(phases(&run).iter().filter(|p| *p == "transfer").count(), 2 * 6 * 3);
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(html.contains("<h2>Recognition vs reasoning</h2>") && html.contains("<h2>Transfer to other models</h2>"));
    assert!(html.contains("<td><code>scissors_open</code></td>"), "the concept table lists the probed concepts");
    assert!(std::fs::read_to_string(run.join("report").join("transfer.csv")).unwrap().lines().count() == 1 + 6);

    let out = ok(&["compare", run_s]);
    assert!(out.contains("indoor") && out.contains("beam"), "{out}");
}

/// One local server speaking every provider's wire format, each answering with option A and
/// marks for four statements (what a real reply to the probe prompt looks like).
async fn providers() -> wiremock::MockServer {
    use serde_json::json;
    use wiremock::matchers::{method, path};
    use wiremock::{Mock, ResponseTemplate};
    let text = "S1: True\nS2: False\nS3: True\nS4: False\nThe path is clear.\nAnswer: A";
    let server = common::mock_server().await;
    let routes = [
        (
            "/chat/completions".to_string(),
            json!({"choices": [{"message": {"content": text}, "finish_reason": "stop"}],
                   "usage": {"prompt_tokens": 900, "completion_tokens": 20}}),
        ),
        (
            "/v1/messages".to_string(),
            json!({"id": "m", "type": "message", "role": "assistant", "model": "claude-test",
                   "content": [{"type": "text", "text": text}], "stop_reason": "end_turn",
                   "usage": {"input_tokens": 900, "output_tokens": 20}}),
        ),
        (
            "/v1beta/models/gemini-test:generateContent".to_string(),
            json!({"candidates": [{"content": {"parts": [{"text": text}], "role": "model"}, "finishReason": "STOP"}],
                   "usageMetadata": {"promptTokenCount": 900, "candidatesTokenCount": 20}}),
        ),
        (
            format!("/model/{}/converse", revelio::vlm::sigv4::uri_encode(BEDROCK)),
            json!({"output": {"message": {"role": "assistant", "content": [{"text": text}]}},
                   "stopReason": "end_turn", "usage": {"inputTokens": 900, "outputTokens": 20}}),
        ),
    ];
    for (route, body) in routes {
        Mock::given(method("POST"))
            .and(path(route))
            .respond_with(ResponseTemplate::new(200).set_body_json(body))
            .mount(&server)
            .await;
    }
    server
}

const BEDROCK: &str = "us.anthropic.claude-haiku-4-5-20251001-v1:0";

/// `revelio` with test keys for every provider (never the developer's own).
fn with_keys(args: &[&str]) -> std::process::Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_revelio"));
    c.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    for k in ["OPENAI_API_KEY", "ANTHROPIC_API_KEY", "GEMINI_API_KEY"] {
        c.env(k, "sk-explain-test");
    }
    c.env("AWS_ACCESS_KEY_ID", "AKIDEXPLAIN").env("AWS_SECRET_ACCESS_KEY", "aws-secret-explain");
    c.env("AWS_REGION", "us-east-1").env("XDG_CACHE_HOME", std::env::temp_dir().join("revelio-explain-unused"));
    for k in ["OPENAI_BASE_URL", "ANTHROPIC_BASE_URL", "GEMINI_BASE_URL", "BEDROCK_BASE_URL"] {
        c.env_remove(k);
    }
    c.output().unwrap()
}

/// Probe on a run of every provider (OpenAI-compatible, Anthropic, Gemini, Bedrock) against
/// their mock servers, on both domains; transfer from one run to the three others; compare all.
/// The probe statements reach each provider and its marks come back out of its reply format.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn probe_transfer_and_compare_against_every_providers_mock() {
    let server = providers().await;
    let uri = server.uri();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().to_path_buf();
    let specs = ["openai:vlm-test", "anthropic:claude-test", "gemini:gemini-test", &format!("bedrock:{BEDROCK}")]
        .map(String::from);
    let runs = tokio::task::spawn_blocking(move || {
        let check = |args: &[&str]| {
            let o = with_keys(args);
            assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
            String::from_utf8(o.stdout).unwrap()
        };
        let mut runs = Vec::new();
        for (i, spec) in specs.iter().enumerate() {
            let domain = if i % 2 == 0 { "domains/driving.rev" } else { "domains/indoor.rev" };
            let run = dir.join(format!("run{i}"));
            let r = run.to_str().unwrap();
            check(&[
                "search",
                domain,
                "--model",
                spec,
                "--base-url",
                &uri,
                "--no-cache",
                "--renderer",
                "none",
                "--algo",
                "random",
                "--budget",
                "8",
                "--samples",
                "2",
                "--out",
                r,
                "--json",
            ]);
            // A run folder never says where a key goes: the endpoint is given again.
            check(&[
                "probe",
                r,
                "--top",
                "2",
                "--samples",
                "2",
                "--min-n",
                "1",
                "--no-cache",
                "--json",
                "--base-url",
                &uri,
            ]);
            runs.push(run);
        }
        let source = runs[0].to_str().unwrap();
        let (b, g) = (specs[1].as_str(), specs[2].as_str());
        let bedrock = specs[3].as_str();
        let out = check(&[
            "transfer",
            source,
            "--model",
            b,
            "--model",
            g,
            "--model",
            bedrock,
            "--base-url",
            &uri,
            "--run-base-url",
            &uri,
            "--no-cache",
            "--top",
            "2",
            "--samples",
            "2",
        ]);
        let mut compare: Vec<&str> = vec!["compare", "--json"];
        compare.extend(runs.iter().map(|r| r.to_str().unwrap()));
        let compared = check(&compare);
        (runs, out, compared)
    })
    .await
    .unwrap();
    let (runs, transfer, compare) = runs;
    for run in &runs {
        let probe: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(run.join("probe.json")).unwrap()).unwrap();
        // Every reply marks S1–S4: four statements of each observation are answered (fewer when
        // its sets have fewer), the rest are unanswered — counted, never guessed.
        let concepts = probe["analysis"]["concepts"].as_array().unwrap();
        let count = |k: &str| concepts.iter().map(|c| c["marks"][k].as_u64().unwrap()).sum::<u64>();
        let answered = count("pos_total") + count("neg_total");
        assert!((4..=16).contains(&answered), "{}: {answered} answered statements", run.display());
        assert_eq!(count("unanswered"), probe["unanswered_statements"].as_u64().unwrap());
        assert!(concepts.iter().any(|c| c["recognition"].is_number()), "{probe:#}");
        assert_eq!(phases(run).iter().filter(|p| *p == "probe").count(), 4);
    }
    for (i, model) in ["M2  anthropic:claude-test", "M3  gemini:gemini-test", "M4  bedrock:"].iter().enumerate() {
        assert!(transfer.contains(model), "model {i} missing:\n{transfer}");
    }
    let lines = std::fs::read_to_string(runs[0].join("journal.jsonl")).unwrap();
    let models: std::collections::BTreeSet<String> = lines
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|v| v["phase"] == "transfer")
        .map(|v| v["model"].as_str().unwrap().to_string())
        .collect();
    assert_eq!(models.len(), 4, "the run's own model and three targets: {models:?}");
    let rows: serde_json::Value = serde_json::from_str(&compare).unwrap();
    let domains: Vec<&str> = rows.as_array().unwrap().iter().map(|r| r["domain"].as_str().unwrap()).collect();
    assert_eq!(domains, ["driving", "indoor", "driving", "indoor"]);
    // The statements reached every provider.
    let bodies: Vec<String> = server
        .received_requests()
        .await
        .unwrap()
        .iter()
        .map(|r| String::from_utf8_lossy(&r.body).into_owned())
        .collect();
    for route in ["/chat/completions", "/v1/messages", ":generateContent", "/converse"] {
        let sent = server.received_requests().await.unwrap();
        assert!(
            sent.iter().zip(&bodies).any(|(r, b)| r.url.path().ends_with(route) && b.contains("`S1: True`")),
            "no probe prompt reached {route}"
        );
    }
}

/// `--kernel rbf`: GPTS with the ablation's kernel runs, is recorded in `config.json` (the
/// default `dot` is not written, so older run folders resume), a resume with another kernel is
/// refused naming it, and the kernel of an algorithm without a GP is a usage error.
#[test]
fn gpts_with_the_rbf_kernel_is_recorded_and_checked_on_resume() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    let search = |extra: &[&str]| {
        let mut args = vec![
            "search",
            "domains/driving.rev",
            "--model",
            "sim:examples/sim/driving_paper.toml",
            "--renderer",
            "none",
            "--budget",
            "60",
            "--shrink",
            "0",
            "--out",
            run_s,
            "--json",
        ];
        args.extend_from_slice(extra);
        revelio(&args)
    };
    let o = search(&["--algo", "gpts", "--kernel", "rbf"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let config: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("config.json")).unwrap()).unwrap();
    assert_eq!(config["params"]["kernel"], "rbf");
    assert_eq!(phases(&run).len(), 60);
    // Left out, the kernel is the recorded one (nothing new is asked); another is refused.
    let o = search(&["--algo", "gpts"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(phases(&run).len(), 60);
    let o = search(&["--algo", "gpts", "--kernel", "dot"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("`params.kernel` was \"rbf\", now null"), "{err}");
    let o = search(&["--algo", "beam", "--kernel", "rbf"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("invalid `--kernel`: the GP kernel is GPTS's"));
}

//! Attacks that stay fixed: what a stranger's domain file, a misbehaving endpoint or a hostile
//! configuration could make Revelio do. Every bound is asserted by refusal (a diagnostic, an
//! error outcome, an exit code), never by measuring time or memory; a command that hangs or
//! spins is killed after a generous guard and fails its test.
//!
//! - files: `use` of `/proc/self/environ`, `/dev/zero`, a FIFO, `..`, links out of the tree,
//!   also from standard input (`check -`); a 10 MB comment, in a file or on standard input; one
//!   file by two spellings; `check` on a FIFO;
//! - keys: every (model provider × image provider) pair, each key only at its own host; a
//!   tampered run folder's `config.json` never chooses an endpoint (a capture server sees
//!   nothing); a 307 to a second port is never followed; userinfo and plain `http://` to a
//!   provider's host refused;
//! - run folders: links for `lock`, `journal.jsonl` and `report` never written through; FIFOs
//!   and `/dev/zero` never read; a summary of 40 000 concept names refused; a corrupt journal
//!   line stops the command (or is set aside on request); names with escape sequences printed
//!   escaped by `compare` and `report`;
//! - replies: an endless chunked body, a stalled body, a body that trickles, a 50 MB reply, a
//!   3 MB answer that the journal keeps only a prefix of, escape sequences in replies and errors;
//! - domains: 128 unconstrained concepts refused quickly by `check`, `lattice` and `search`;
//!   10 000 rules checked; 3 000 nested levels refused by `check`, `fmt` and the language
//!   server (R0003); 40 nested `exists` refused before any evaluation (R0034); a `repeat` of
//!   4 000 000 000 refused by `check` (R0035);
//! - configuration: `extra` replacing `messages`/`stream`, `latency_ms` of `i64::MAX`,
//!   `--batch` of `usize::MAX`.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use base64::Engine;
use revelio::outcome::Answer;
use revelio::vlm::registry::{ModelOptions, build_api_model};
use revelio::vlm::{Query, prompt};
use serde_json::{Value, json};
use wiremock::{MockServer, Request, Respond, ResponseTemplate};

mod common;
use common::{root, walk};

/// Long enough for any of these commands in a debug build on a loaded machine; a hang or a spin
/// (what these attacks did before) runs into it.
const GUARD: Duration = Duration::from_secs(240);

/// Run `revelio` with exactly `env` (nothing inherited), killed after [`GUARD`].
fn revelio(args: &[&str], env: &[(&str, &str)]) -> Output {
    revelio_fed(args, env, None)
}

/// [`revelio`] with `input` on its standard input (none: an empty one).
fn revelio_fed(args: &[&str], env: &[(&str, &str)], input: Option<String>) -> Output {
    run_guarded(Command::new(env!("CARGO_BIN_EXE_revelio")), args, env, input)
}

/// [`revelio`] in at most 3 GB of address space (`ulimit -v`), the limit under which the
/// unbounded versions were killed: a bound asserted by the command ending well, not by measuring.
fn revelio_in_3gb(args: &[&str]) -> Output {
    let mut cmd = Command::new("/bin/sh");
    cmd.args(["-c", "ulimit -v 3000000 && exec \"$0\" \"$@\"", env!("CARGO_BIN_EXE_revelio")]);
    run_guarded(cmd, args, &[], None)
}

fn run_guarded(mut cmd: Command, args: &[&str], env: &[(&str, &str)], input: Option<String>) -> Output {
    let stdin = if input.is_some() { Stdio::piped() } else { Stdio::null() };
    cmd.args(args).current_dir(root()).env_clear().stdin(stdin).stdout(Stdio::piped()).stderr(Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().expect("the revelio binary starts");
    if let (Some(input), Some(mut pipe)) = (input, child.stdin.take()) {
        std::thread::spawn(move || {
            let _ = pipe.write_all(input.as_bytes());
        });
    }
    let mut out = child.stdout.take().unwrap();
    let mut err = child.stderr.take().unwrap();
    let read_out = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = out.read_to_end(&mut v);
        v
    });
    let read_err = std::thread::spawn(move || {
        let mut v = Vec::new();
        let _ = err.read_to_end(&mut v);
        v
    });
    let started = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if started.elapsed() > GUARD {
            let _ = child.kill();
            let _ = child.wait();
            panic!("`revelio {}` did not end within {GUARD:?}: it hangs or spins", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output { status, stdout: read_out.join().unwrap(), stderr: read_err.join().unwrap() }
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(&p, text).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn mkfifo(p: &Path) -> bool {
    Command::new("mkfifo").arg(p).status().is_ok_and(|s| s.success())
}

// ---------------------------------------------------------------------------------------------
// Files a domain may read

const ENV_CANARY: &str = "env-CANARY-7f3a";

#[test]
fn use_reads_nothing_outside_the_domain_folder() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "outside.rev", "tag OutsideCanary");
    write(dir.path(), "d/notes.txt", "notes-CANARY");
    #[cfg(unix)]
    std::os::unix::fs::symlink("/proc/self/environ", dir.path().join("d/env.rev")).unwrap();
    for (path, says) in [
        ("/proc/self/environ", "is an absolute path"),
        ("/dev/zero", "is an absolute path"),
        ("/etc/shadow", "is an absolute path"),
        ("../outside.rev", "is outside the domain's folder"),
        ("notes.txt", "is not a `.rev` file"),
        #[cfg(unix)]
        ("env.rev", "is outside the domain's folder"),
    ] {
        let d = write(dir.path(), "d/domain.rev", &format!("use \"{path}\"\ntag T\n"));
        for format in ["human", "json"] {
            let o = revelio(&["check", s(&d), "--format", format], &[("SECRET_TOKEN", ENV_CANARY)]);
            let all = text(&o);
            assert_eq!(o.status.code(), Some(1), "{path}: {all}");
            assert!(all.contains("R0013") && all.contains(says), "{path}: {all}");
            for canary in [ENV_CANARY, "OutsideCanary", "notes-CANARY", "root:"] {
                assert!(!all.contains(canary), "{path}: the output quotes a file it may not read: {all}");
            }
        }
    }
    // An unsaved buffer checked through standard input is held to the same policy.
    let d = dir.path().join("d/domain.rev");
    let o = revelio_fed(
        &["check", "-", "--stdin-filename", s(&d), "--format", "plain"],
        &[("SECRET_TOKEN", ENV_CANARY)],
        Some("use \"/proc/self/environ\"\nuse \"../outside.rev\"\ntag T\n".into()),
    );
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("is an absolute path") && all.contains("is outside the domain's folder"), "{all}");
    assert!(!all.contains(ENV_CANARY) && !all.contains("OutsideCanary"), "{all}");
    // `search` (and every command) loads through the same policy.
    let d = write(dir.path(), "d/domain.rev", "use \"/proc/self/environ\"\ntag T\n");
    let o = revelio(
        &["search", s(&d), "--model", "sim:examples/sim/driving_paper.toml", "--renderer", "none"],
        &[("SECRET_TOKEN", ENV_CANARY)],
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("R0013") && !text(&o).contains(ENV_CANARY), "{}", text(&o));
}

#[cfg(unix)]
#[test]
fn fifos_are_named_not_opened() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("d/pipe.rev");
    std::fs::create_dir_all(fifo.parent().unwrap()).unwrap();
    if !mkfifo(&fifo) {
        common::peer_missing("the FIFO test", "`mkfifo` is not available, so FIFO attacks are not checked");
        return;
    }
    // Reading a FIFO blocks until a writer comes: a refusal that returns is the check.
    let d = write(dir.path(), "d/domain.rev", "use \"pipe.rev\"\ntag T\n");
    let o = revelio(&["check", s(&d)], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("is a FIFO (named pipe), not a `.rev` file"), "{}", text(&o));
    // `check` on the FIFO itself says what it is (it used to say "does not exist").
    let o = revelio(&["check", s(&fifo)], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("is a FIFO (named pipe), not a `.rev` file or a folder"), "{}", text(&o));
    let o = revelio(&["lattice", s(&fifo)], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("is a FIFO (named pipe)"), "{}", text(&o));
    // `fmt` on the folder lists the FIFO among the `.rev` files and must not open it.
    let o = revelio(&["fmt", "--check", s(fifo.parent().unwrap())], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("is a FIFO (named pipe), not a `.rev` file"), "{}", text(&o));
}

#[test]
fn a_ten_megabyte_comment_is_too_large_not_too_deep() {
    let dir = tempfile::tempdir().unwrap();
    let big = write(dir.path(), "big.rev", &format!("// {}\ntag T\n", "x".repeat(10_000_000)));
    let o = revelio(&["check", s(&big), "--format", "plain"], &[]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(all.contains("R0004") && all.contains("is 10.0 MB; a `.rev` file may be at most 1 MiB"), "{all}");
    assert!(!all.contains("R0003"), "{all}");
    // A used file of the same kind is refused at its `use`.
    let d = write(dir.path(), "d.rev", "use \"big.rev\"\ntag U\n");
    let o = revelio(&["check", s(&d), "--format", "plain"], &[]);
    assert!(text(&o).contains("R0004"), "{}", text(&o));
    // Standard input is read no further than the limit (`check - < /dev/zero` used to run on).
    let o = revelio_fed(&["check", "-", "--format", "plain"], &[], Some(format!("// {}\n", "x".repeat(10_000_000))));
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("R0004") && all.contains("`<stdin>` is larger than the most a `.rev` file may be"), "{all}");
    // `fmt` reads under the same bound.
    let o = revelio(&["fmt", "--check", s(&big)], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("is 10.0 MB; a `.rev` file may be at most 1 MiB"), "{}", text(&o));
    let o = revelio_fed(&["fmt", "-"], &[], Some(format!("// {}\n", "x".repeat(10_000_000))));
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("`<stdin>` is larger than the most"), "{}", text(&o));
}

#[test]
fn one_file_by_two_spellings_is_loaded_once() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "d/lib/props.rev", "use \"../domain.rev\"\ntag Prop\n");
    #[cfg(unix)]
    std::os::unix::fs::symlink(dir.path().join("d/lib/props.rev"), dir.path().join("d/alias.rev")).unwrap();
    #[cfg(not(unix))]
    write(dir.path(), "d/alias.rev", "");
    write(
        dir.path(),
        "d/domain.rev",
        "use \"lib/props.rev\"\nuse \"./lib/../lib/props.rev\"\nuse \"alias.rev\"\ntag T\n",
    );
    // The entry spelled with `./` and `..`: the library's `use "../domain.rev"` is the entry.
    let entry = dir.path().join("d/lib/../domain.rev");
    let o = revelio(&["check", s(&entry), "--format", "plain"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!text(&o).contains("R0021"), "{}", text(&o));
}

// ---------------------------------------------------------------------------------------------
// Domain size

fn wide_domain(dir: &Path, concepts: usize) -> PathBuf {
    let mut t = String::from("domain wide\nworld { on: bool = false }\n");
    for i in 0..concepts {
        t.push_str(&format!("concept c{i} {{ description \"c\" probe \"p\" not \"n\" set world.on = true }}\n"));
    }
    t.push_str("question q { text \"q\" option a \"a\" option b \"b\" }\nrules priority { rule r { expect q.a } }\n");
    write(dir, "wide.rev", &t)
}

#[test]
fn an_unconstrained_128_concept_domain_is_checked_counted_and_searched_by_sampling() {
    // 275 million sets of up to five: `check` took 6.5 min and 8.4 GB, `search` sat silent. Now
    // `check` lints from the lattice's diagram and a stated sample, `lattice` counts exactly,
    // the default search draws from the diagram, and what needs every set listed (`lattice
    // --list`, the searches that score every set) refuses with the ways out.
    let dir = tempfile::tempdir().unwrap();
    let wide = wide_domain(dir.path(), 128);
    let profile = write(dir.path(), "sim.toml", "name = \"plain\"\n");
    let model = format!("sim:{}", s(&profile));
    let out = dir.path().join("run");
    let o = revelio_in_3gb(&["check", s(&wide), "--format", "plain"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(!text(&o).contains("R0070"), "{}", text(&o));
    let o = revelio_in_3gb(&["lattice", s(&wide)]);
    assert!(o.status.success() && text(&o).contains("275584032"), "{}", text(&o));
    let o = revelio_in_3gb(&["lattice", s(&wide), "--list"]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("R0070") && all.contains("more than 1000000 valid concept sets of up to 5 concepts"), "{all}");
    assert!(all.contains("`--max-size 3` gives 349632") && all.contains("`--max-sets`"), "{all}");
    let search = |algo: &str, out: &std::path::Path| {
        let args = ["search", s(&wide), "--model", &model, "--renderer", "none", "--budget", "60", "--algo", algo];
        revelio_in_3gb(&[&args[..], &["--out", s(out)]].concat())
    };
    let o = search("gpts", &out);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("R0070") && all.contains("`--algo gpts` scores every valid set"), "{all}");
    assert!(all.contains("`--algo interact` (its default surrogate) and `--algo random`"), "{all}");
    assert!(!out.join("journal.jsonl").exists(), "nothing was asked");
    // The default search and random draw from the diagram, within the budget.
    for algo in ["interact", "random"] {
        let run = dir.path().join(algo);
        let o = search(algo, &run);
        assert!(o.status.success(), "{algo}: {}", text(&o));
        assert!(text(&o).contains("of 275584032 valid"), "{algo}: {}", text(&o));
        let lines = std::fs::read_to_string(run.join("journal.jsonl")).unwrap().lines().count();
        assert!(lines > 0 && lines <= 60, "{algo}: {lines} journal lines");
    }
    // The ways out work: a smaller size, or a raised limit.
    let o = revelio(&["lattice", s(&wide), "--max-size", "2", "--list"], &[]);
    assert!(o.status.success() && text(&o).lines().count() == 8256, "{}", text(&o));
}

#[test]
fn a_domain_past_the_old_128_concept_width_is_checked() {
    // 300 concepts: past the 128-bit sets of earlier versions.
    let dir = tempfile::tempdir().unwrap();
    let wide = wide_domain(dir.path(), 300);
    let o = revelio_in_3gb(&["check", s(&wide), "--format", "plain"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let o = revelio(&["lattice", s(&wide), "--json"], &[]);
    // C(300, k) for k = 1..=5.
    assert!(o.status.success() && text(&o).contains("\"total\":19918128985"), "{}", text(&o));
}

#[test]
fn ten_thousand_rules_are_checked() {
    // The lattice lints kept two rule × rule tables (9.4 GB here); now tallies per rule.
    let dir = tempfile::tempdir().unwrap();
    let mut t = String::from("domain many\nworld { on: bool = false }\n");
    for i in 0..4 {
        t.push_str(&format!("concept c{i} {{ description \"c\" probe \"p\" not \"n\" set world.on = true }}\n"));
    }
    t.push_str("question q { text \"q\" option a \"a\" option b \"b\" }\nrules priority {\n");
    for j in 0..10_000 {
        t.push_str(&format!("  rule r{j} {{ when has c{} expect q.{} }}\n", j % 4, ["a", "b"][j % 2]));
    }
    t.push_str("}\n");
    let d = write(dir.path(), "many.rev", &t);
    let o = revelio_in_3gb(&["check", s(&d), "--format", "json"]);
    let lines = String::from_utf8_lossy(&o.stdout);
    assert_eq!(lines.lines().filter(|l| l.contains("\"R0101\"")).count(), 10_000 - 4, "{}", text(&o));
}

// ---------------------------------------------------------------------------------------------
// Keys go only to their own provider's host

const OPENAI_KEY: &str = "key-openai-CANARY-1";
const ANTHROPIC_KEY: &str = "key-anthropic-CANARY-2";
const GEMINI_KEY: &str = "key-gemini-CANARY-3";
const AWS_ID: &str = "AKIDCANARY4";
const AWS_SECRET: &str = "aws-secret-CANARY-5";

/// The credentials each provider's host may see.
fn secrets_of(provider: &str) -> &'static [&'static str] {
    match provider {
        "openai" => &[OPENAI_KEY],
        "anthropic" => &[ANTHROPIC_KEY],
        "gemini" => &[GEMINI_KEY],
        "bedrock" => &[AWS_ID, AWS_SECRET],
        _ => unreachable!(),
    }
}

fn png_b64() -> String {
    let img = image::RgbImage::from_fn(32, 24, |x, y| image::Rgb([(x * 7) as u8, (y * 9) as u8, 60]));
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    base64::engine::general_purpose::STANDARD.encode(out)
}

/// Speaks every provider's format, model and image, by path.
struct AnyProvider {
    png: String,
}

impl Respond for AnyProvider {
    fn respond(&self, r: &Request) -> ResponseTemplate {
        let p = r.url.path();
        let body = if p.ends_with("/chat/completions") {
            json!({"choices": [{"message": {"content": "Answer: A"}, "finish_reason": "stop"}], "usage": {"prompt_tokens": 1, "completion_tokens": 1}})
        } else if p.ends_with("/v1/messages") {
            json!({"content": [{"type": "text", "text": "Answer: A"}], "stop_reason": "end_turn", "usage": {"input_tokens": 1, "output_tokens": 1}})
        } else if p.ends_with("/converse") {
            json!({"output": {"message": {"role": "assistant", "content": [{"text": "Answer: A"}]}}, "stopReason": "end_turn", "usage": {"inputTokens": 1, "outputTokens": 1}})
        } else if p.ends_with("/models/img:generateContent") {
            json!({"candidates": [{"content": {"parts": [{"inlineData": {"mimeType": "image/png", "data": self.png}}]}, "finishReason": "STOP"}]})
        } else if p.ends_with(":generateContent") {
            json!({"candidates": [{"content": {"parts": [{"text": "Answer: A"}]}, "finishReason": "STOP"}], "usageMetadata": {"promptTokenCount": 1, "candidatesTokenCount": 1}})
        } else if p.ends_with("/images/generations") {
            json!({"data": [{"b64_json": self.png}]})
        } else {
            return ResponseTemplate::new(404);
        };
        ResponseTemplate::new(200).set_body_json(body)
    }
}

/// Everything a server was sent: URLs, headers and bodies.
async fn seen(server: &MockServer) -> String {
    let mut all = String::new();
    for r in server.received_requests().await.unwrap_or_default() {
        all.push_str(r.url.as_str());
        for (k, v) in r.headers.iter() {
            all.push_str(&format!("\n{k}: {}", v.to_str().unwrap_or("")));
        }
        all.push('\n');
        all.push_str(&String::from_utf8_lossy(&r.body));
        all.push('\n');
    }
    all
}

#[tokio::test(flavor = "multi_thread")]
async fn every_key_goes_only_to_its_own_providers_host() {
    let png = png_b64();
    for model_provider in ["openai", "anthropic", "gemini", "bedrock"] {
        for image_provider in ["gemini", "openai"] {
            // The image endpoint from the provider's own variable, then from its own flag.
            for by_flag in [false, true] {
                let model_server = common::mock_server().await;
                let image_server = common::mock_server().await;
                wiremock::Mock::given(wiremock::matchers::any())
                    .respond_with(AnyProvider { png: png.clone() })
                    .mount(&model_server)
                    .await;
                wiremock::Mock::given(wiremock::matchers::any())
                    .respond_with(AnyProvider { png: png.clone() })
                    .mount(&image_server)
                    .await;
                let model = format!("{model_provider}:m");
                let renderer = format!("imagegen:{image_provider}:img");
                let image_base = match image_provider {
                    "openai" => format!("{}/v1", image_server.uri()),
                    _ => image_server.uri(),
                };
                let model_base = match model_provider {
                    "openai" => format!("{}/v1", model_server.uri()),
                    _ => model_server.uri(),
                };
                let mut args =
                    vec!["ask", "domains/driving.rev", "debris_far", "--model", &model, "--renderer", &renderer];
                args.extend(["--base-url", &model_base]);
                let mut env = vec![
                    ("OPENAI_API_KEY", OPENAI_KEY),
                    ("ANTHROPIC_API_KEY", ANTHROPIC_KEY),
                    ("GEMINI_API_KEY", GEMINI_KEY),
                    ("AWS_ACCESS_KEY_ID", AWS_ID),
                    ("AWS_SECRET_ACCESS_KEY", AWS_SECRET),
                    ("AWS_REGION", "us-east-1"),
                ];
                let image_var = if image_provider == "openai" { "OPENAI_BASE_URL" } else { "GEMINI_BASE_URL" };
                if by_flag {
                    args.extend(["--renderer-base-url", &image_base]);
                } else {
                    env.push((image_var, &image_base));
                }
                let what = format!("{model} with {renderer} ({})", if by_flag { "flag" } else { image_var });
                let out = tokio::task::spawn_blocking({
                    let args: Vec<String> = args.iter().map(|a| a.to_string()).collect();
                    let env: Vec<(String, String)> = env.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
                    move || {
                        let args: Vec<&str> = args.iter().map(String::as_str).collect();
                        let env: Vec<(&str, &str)> = env.iter().map(|(k, v)| (k.as_str(), v.as_str())).collect();
                        revelio(&args, &env)
                    }
                })
                .await
                .unwrap();
                assert!(out.status.success(), "{what}: {}", text(&out));
                for (server, provider, role) in
                    [(&model_server, model_provider, "model"), (&image_server, image_provider, "image")]
                {
                    let sent = seen(server).await;
                    assert!(!sent.is_empty(), "{what}: the {role} server got no request");
                    let own = secrets_of(provider);
                    assert!(sent.contains(own[0]), "{what}: the {role} server did not get its own key");
                    for other in ["openai", "anthropic", "gemini", "bedrock"] {
                        for key in secrets_of(other).iter().filter(|k| !own.contains(k)) {
                            assert!(!sent.contains(key), "{what}: the {role} server ({provider}) got {other}'s key");
                        }
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Replies: size, stalls, what is kept, what is printed

#[derive(Clone, Copy)]
enum Misbehave {
    /// `200 OK`, chunked, and chunks forever.
    Endless,
    /// Headers and a first few bytes, then nothing.
    Stall,
    /// 50 MB, chunked (no length to refuse up front).
    Huge,
    /// A byte every 50 ms, for ever: never stalled, never done.
    Trickle,
}

/// A one-trick HTTP/1.1 server on a local port; returns its base URL.
fn misbehaving(mode: Misbehave) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(stream) = stream else { continue };
            std::thread::spawn(move || serve(stream, mode));
        }
    });
    format!("http://{addr}/v1")
}

fn serve(mut s: TcpStream, mode: Misbehave) {
    // Read the request (head, then a body of `content-length` bytes).
    let mut buf = Vec::new();
    let mut tmp = [0u8; 16384];
    let head_end = loop {
        match s.read(&mut tmp) {
            Ok(0) | Err(_) => return,
            Ok(n) => buf.extend_from_slice(&tmp[..n]),
        }
        if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break i + 4;
        }
    };
    let head = String::from_utf8_lossy(&buf[..head_end]).to_lowercase();
    let len: usize = head
        .lines()
        .find_map(|l| l.strip_prefix("content-length:").map(|v| v.trim().parse().unwrap_or(0)))
        .unwrap_or(0);
    while buf.len() < head_end + len {
        match s.read(&mut tmp) {
            Ok(0) | Err(_) => return,
            Ok(n) => buf.extend_from_slice(&tmp[..n]),
        }
    }
    let chunked = "HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ntransfer-encoding: chunked\r\n\r\n";
    let chunk = format!("{:x}\r\n{}\r\n", 65536, "x".repeat(65536));
    match mode {
        Misbehave::Endless => {
            let _ = s.write_all(chunked.as_bytes());
            while s.write_all(chunk.as_bytes()).is_ok() {}
        }
        Misbehave::Huge => {
            let _ = s.write_all(chunked.as_bytes());
            for _ in 0..(50_000_000 / 65536) {
                if s.write_all(chunk.as_bytes()).is_err() {
                    return;
                }
            }
            let _ = s.write_all(b"0\r\n\r\n");
        }
        Misbehave::Trickle => {
            let _ = s.write_all(chunked.as_bytes());
            while s.write_all(b"1\r\n \r\n").and_then(|()| s.flush()).is_ok() {
                std::thread::sleep(Duration::from_millis(50));
            }
        }
        Misbehave::Stall => {
            let _ = s.write_all(
                b"HTTP/1.1 200 OK\r\ncontent-type: application/json\r\ncontent-length: 100000\r\n\r\n{\"choices\": [",
            );
            let _ = s.flush();
            std::thread::sleep(Duration::from_secs(600));
        }
    }
}

fn models_toml(dir: &Path, lines: &str) -> PathBuf {
    write(dir, "models.toml", &format!("[default]\nretry_backoff_s = 0.001\n{lines}\n"))
}

fn query() -> Query {
    let options: Vec<String> = vec!["Stop".into(), "Slow down".into(), "Go".into()];
    Query {
        image: None,
        image_hash: "scene".into(),
        prompt: prompt::build("What should the ego vehicle do?", &options),
        options,
        truth: None,
    }
}

async fn ask_openai(base: &str, config: &Path) -> revelio::vlm::Reply {
    let opts = ModelOptions {
        base_url: Some(base.to_string()),
        config: Some(config.to_path_buf()),
        ..ModelOptions::default()
    };
    let model = build_api_model("openai:m", &opts).unwrap();
    model.ask(&query()).await
}

#[tokio::test(flavor = "multi_thread")]
async fn oversized_and_endless_replies_are_api_errors() {
    // An endless body grew to 5.9 GB in 10 s; a 50 MB one was kept whole.
    let dir = tempfile::tempdir().unwrap();
    let config = models_toml(dir.path(), "retry_attempts = 3");
    for mode in [Misbehave::Endless, Misbehave::Huge] {
        let r = ask_openai(&misbehaving(mode), &config).await;
        assert_eq!(r.answer, Answer::ApiError);
        assert!(r.raw.contains("the reply is larger than 4 MiB"), "{}", r.raw);
        assert_eq!(r.attempts, 1, "a reply too large is not asked for again");
    }
    // With a length, refused before reading.
    let server = common::mock_server().await;
    let big = json!({"choices": [{"message": {"content": "x".repeat(5_000_000)}, "finish_reason": "stop"}]});
    wiremock::Mock::given(wiremock::matchers::any())
        .respond_with(ResponseTemplate::new(200).set_body_json(big))
        .mount(&server)
        .await;
    let r = ask_openai(&format!("{}/v1", server.uri()), &config).await;
    assert_eq!(r.answer, Answer::ApiError);
    assert!(r.raw.contains("the reply is larger than 4 MiB"), "{}", r.raw);
    // The limit is the model config's.
    let config = models_toml(dir.path(), "max_reply_mb = 8");
    let r = ask_openai(&format!("{}/v1", server.uri()), &config).await;
    assert_eq!(r.answer, Answer::Unparsed, "read whole under a raised limit: {}", &r.raw[..80.min(r.raw.len())]);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_stalled_body_ends_the_call() {
    // A body that stops coming held a call for the whole per-attempt timeout, six times over.
    let dir = tempfile::tempdir().unwrap();
    let config = models_toml(dir.path(), "timeout_s = 200\nstall_timeout_s = 0.5\nretry_attempts = 2");
    let r = ask_openai(&misbehaving(Misbehave::Stall), &config).await;
    assert_eq!(r.answer, Answer::ApiError);
    assert!(r.raw.contains("the reply stalled: no data for 0.5 s"), "{}", r.raw);
    assert_eq!(r.attempts, 2, "a stall is retried like a timeout");
}

#[tokio::test(flavor = "multi_thread")]
async fn a_slow_body_ends_at_the_call_deadline() {
    // Bytes that keep coming, too slowly to finish, pass every stall check: the call's deadline
    // bounds them (with the defaults, 300 s a call, not 120 s for each of six attempts).
    let dir = tempfile::tempdir().unwrap();
    let config =
        models_toml(dir.path(), "timeout_s = 200\nstall_timeout_s = 5\nretry_deadline_s = 1\nretry_attempts = 6");
    let r = ask_openai(&misbehaving(Misbehave::Trickle), &config).await;
    assert_eq!(r.answer, Answer::ApiError);
    assert!(r.raw.contains("timed out after 1.0 s") && r.raw.contains("the 1 s deadline"), "{}", r.raw);
    assert_eq!(r.attempts, 1, "{}", r.raw);
}

/// A chat reply with `content`.
fn chat(content: &str) -> ResponseTemplate {
    ResponseTemplate::new(200).set_body_json(json!({
        "choices": [{"message": {"content": content}, "finish_reason": "stop"}],
        "usage": {"prompt_tokens": 10, "completion_tokens": 10}
    }))
}

#[test]
fn the_journal_keeps_a_bounded_prefix_of_long_replies() {
    // A 10-inference search wrote 314 MB of journal from long replies.
    let rt = tokio::runtime::Runtime::new().unwrap();
    let server = rt.block_on(common::mock_server());
    let long = format!("{}\nAnswer: B", "thinking aloud ".repeat(200_000));
    rt.block_on(wiremock::Mock::given(wiremock::matchers::any()).respond_with(chat(&long)).mount(&server));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let base = format!("{}/v1", server.uri());
    let o = revelio(
        &[
            "search",
            "domains/driving.rev",
            "--model",
            "openai:m",
            "--base-url",
            &base,
            "--renderer",
            "none",
            "--algo",
            "random",
            "--budget",
            "6",
            "--samples",
            "1",
            "--shrink",
            "0",
            "--out",
            s(&out),
            "--json",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", text(&o));
    let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    assert_eq!(journal.lines().count(), 6);
    for line in journal.lines() {
        let v: Value = serde_json::from_str(line).unwrap();
        let raw = v["raw"].as_str().unwrap();
        assert!(raw.len() < 33 << 10, "a journal line kept {} bytes of reply", raw.len());
        assert!(raw.contains("[cut by Revelio: "), "the cut is marked");
        assert_eq!(v["answer"], json!({"option": 1}), "parsed before it was cut: {}", v["answer"]);
    }
    for f in walk(&out.join("cache")) {
        assert!(std::fs::metadata(&f).unwrap().len() < 40 << 10, "{} is large", f.display());
    }
}

#[test]
fn escape_sequences_from_a_server_never_reach_the_terminal() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let server = rt.block_on(common::mock_server());
    rt.block_on(
        wiremock::Mock::given(wiremock::matchers::any())
            .respond_with(chat("\u{1b}[2J\u{1b}]0;owned\u{7}The road is clear.\r\u{9b}31mAnswer: C"))
            .mount(&server),
    );
    let base = format!("{}/v1", server.uri());
    let ask = |base: &str| {
        revelio(
            &[
                "ask",
                "domains/driving.rev",
                "debris_far",
                "--model",
                "openai:m",
                "--base-url",
                base,
                "--renderer",
                "none",
            ],
            &[],
        )
    };
    let o = ask(&base);
    assert!(o.status.success(), "{}", text(&o));
    let all = text(&o);
    assert!(!all.contains(['\u{1b}', '\u{7}', '\r', '\u{9b}']), "{all:?}");
    assert!(all.contains("\\u{1b}[2J") && all.contains("The road is clear."), "{all}");
    // An error body's message, in the error line.
    let bad = rt.block_on(common::mock_server());
    rt.block_on(
        wiremock::Mock::given(wiremock::matchers::any())
            .respond_with(
                ResponseTemplate::new(400)
                    .set_body_json(json!({"error": {"message": "bad \u{1b}]0;pwned\u{7} request", "type": "x"}})),
            )
            .mount(&bad),
    );
    let o = ask(&format!("{}/v1", bad.uri()));
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("bad \\u{1b}]0;pwned\\u{7} request") && !all.contains(['\u{1b}', '\u{7}']), "{all:?}");
}

// ---------------------------------------------------------------------------------------------
// Configuration

#[test]
fn extra_may_not_replace_what_revelio_sends() {
    let dir = tempfile::tempdir().unwrap();
    for (spec, key) in [
        ("openai:m", "messages"),
        ("openai:m", "stream"),
        ("anthropic:m", "max_tokens"),
        ("gemini:m", "generationConfig"),
        ("bedrock:m", "inferenceConfig"),
    ] {
        let config = models_toml(dir.path(), &format!("extra = {{ {key} = true }}"));
        let opts = ModelOptions {
            base_url: Some("http://127.0.0.1:9".into()),
            config: Some(config),
            ..ModelOptions::default()
        };
        let e = build_api_model(spec, &opts).err().unwrap();
        assert!(e.contains(&format!("`extra` for `{spec}` sets `{key}`, which Revelio sets itself")), "{e}");
    }
}

#[test]
fn a_sim_latency_past_a_minute_is_refused() {
    // `latency_ms = i64::MAX` made `ask` sleep for ever.
    let dir = tempfile::tempdir().unwrap();
    let profile = write(dir.path(), "slow.toml", &format!("name = \"slow\"\nlatency_ms = {}\n", i64::MAX));
    let model = format!("sim:{}", s(&profile));
    let o = revelio(&["ask", "domains/driving.rev", "debris_far", "--model", &model, "--renderer", "none"], &[]);
    assert!(!o.status.success());
    assert!(text(&o).contains("`latency_ms` must be at most 60000 (one minute)"), "{}", text(&o));
}

#[test]
fn a_huge_batch_is_bounded_by_the_candidates() {
    // `--batch 100000` made 100 000 draws a round, each a pass over the lattice (110 s of CPU);
    // `usize::MAX` never ended.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let max = usize::MAX.to_string();
    let o = revelio(
        &[
            "search",
            "domains/driving.rev",
            "--model",
            "sim:examples/sim/driving_paper.toml",
            "--renderer",
            "none",
            "--algo",
            "gpts",
            "--budget",
            "40",
            "--samples",
            "2",
            "--batch",
            &max,
            "--shrink",
            "0",
            "--out",
            s(&out),
            "--json",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", text(&o));
    let summary: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["metrics"]["inferences"], 40, "{summary}");
}

// --- keys and endpoints (issue 27) ---

/// The search flags of a small run against an OpenAI-compatible server (`base`, or the
/// environment's when `None`).
fn small_run(out: &Path, base: Option<&str>) -> Vec<String> {
    let mut a: Vec<String> = ["search", "domains/driving.rev", "--model", "openai:m", "--renderer", "none"]
        .into_iter()
        .chain(["--algo", "random", "--budget", "4", "--samples", "1", "--shrink", "0", "--out", s(out)])
        .map(String::from)
        .collect();
    if let Some(b) = base {
        a.extend(["--base-url".to_string(), b.to_string()]);
    }
    a
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// A copied run folder whose `config.json` was edited to send the model's, the renderer's and
/// the model config's requests to a stranger's server: no command that opens the folder sends a
/// key there. Each is refused, naming the recorded destination, until the user gives it on the
/// command line; given flags are what is used, whatever the folder says.
#[test]
fn a_tampered_run_folder_never_chooses_where_a_key_goes() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let own = rt.block_on(common::mock_server());
    let capture = rt.block_on(common::mock_server());
    rt.block_on(wiremock::Mock::given(wiremock::matchers::any()).respond_with(chat("Answer: A")).mount(&own));
    rt.block_on(wiremock::Mock::given(wiremock::matchers::any()).respond_with(chat("Answer: A")).mount(&capture));
    let (own_base, stolen) = (format!("{}/v1", own.uri()), format!("{}/v1", capture.uri()));
    let env = [("OPENAI_API_KEY", OPENAI_KEY), ("GEMINI_API_KEY", GEMINI_KEY)];
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let o = revelio(&strs(&small_run(&run, Some(&own_base))), &env);
    assert!(o.status.success(), "{}", text(&o));

    // The stranger's edit: every destination in `config.json`, and a model config of theirs.
    let theirs = write(dir.path(), "theirs.toml", "[default]\nconcurrency = 1\n");
    let path = run.join("config.json");
    let mut config: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    config["endpoint"] = json!(stolen);
    config["model_settings"] =
        json!({"base_url": stolen, "renderer_base_url": capture.uri(), "model_config": s(&theirs)});
    std::fs::write(&path, serde_json::to_string_pretty(&config).unwrap()).unwrap();

    let r = s(&run).to_string();
    let opened: [Vec<String>; 5] = [
        small_run(&run, None),
        ["validate", &r, "--top", "1", "--samples", "1"].map(String::from).to_vec(),
        ["probe", &r, "--top", "1", "--samples", "1"].map(String::from).to_vec(),
        ["transfer", &r, "--model", "openai:other", "--base-url", &own_base, "--top", "1", "--samples", "1"]
            .map(String::from)
            .to_vec(),
        // Some flags given: the first one missing is still named.
        ["validate", &r, "--base-url", &own_base, "--top", "1", "--samples", "1"].map(String::from).to_vec(),
    ];
    for args in &opened {
        let o = revelio(&strs(args), &env);
        let all = text(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {all}");
        assert!(all.contains("a run folder does not choose where keys go"), "{args:?}: {all}");
        let named = all.contains("base-url") && all.contains(&capture.address().to_string());
        assert!(named || all.contains("model-config"), "{args:?}: {all}");
    }
    // A recorded endpoint from the environment: refused when the environment now says another.
    let mut from_env = config.clone();
    from_env["model_settings"] = json!({});
    std::fs::write(&path, serde_json::to_string_pretty(&from_env).unwrap()).unwrap();
    let o = revelio(&["validate", &r, "--top", "1", "--samples", "1"], &[("OPENAI_BASE_URL", &own_base), env[0]]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(2), "{all}");
    assert!(all.contains(&format!("was called at `{stolen}`, but it now resolves to `{own_base}`")), "{all}");

    // The user's own flags: used, whatever the folder recorded.
    std::fs::write(&path, serde_json::to_string_pretty(&config).unwrap()).unwrap();
    let flags = ["--base-url", &own_base, "--renderer-base-url", &own_base, "--model-config", s(&theirs)];
    let mut validate = vec!["validate", &r, "--top", "1", "--samples", "1"];
    validate.extend(flags);
    let o = revelio(&validate, &env);
    assert!(o.status.success(), "{}", text(&o));
    let mut transfer = vec!["transfer", &r, "--model", "openai:other", "--base-url", &own_base, "--top", "1"];
    transfer.extend(["--samples", "1", "--run-base-url", &own_base, "--run-model-config", s(&theirs)]);
    transfer.extend(["--renderer-base-url", &own_base]);
    let o = revelio(&transfer, &env);
    assert!(o.status.success(), "{}", text(&o));

    let stolen_requests = rt.block_on(capture.received_requests()).unwrap_or_default();
    assert!(stolen_requests.is_empty(), "the stranger's server got {} requests", stolen_requests.len());
    assert!(rt.block_on(seen(&own)).contains(OPENAI_KEY), "the user's own server got the key");
}

/// Answers every request with a redirect to `to`.
struct Redirect(String);

impl Respond for Redirect {
    fn respond(&self, _: &Request) -> ResponseTemplate {
        ResponseTemplate::new(307).insert_header("location", format!("{}/stolen?key=x", self.0).as_str())
    }
}

/// A 307 to a second local port: no client follows it, so the second port never sees a key
/// header (`authorization`, `x-api-key`, `x-goog-api-key`, Bedrock's signature and session
/// token) or the body; the error names the host it pointed to and the call is not retried.
#[test]
fn a_redirect_is_never_followed_with_a_key() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let env = [
        ("OPENAI_API_KEY", OPENAI_KEY),
        ("ANTHROPIC_API_KEY", ANTHROPIC_KEY),
        ("GEMINI_API_KEY", GEMINI_KEY),
        ("AWS_ACCESS_KEY_ID", AWS_ID),
        ("AWS_SECRET_ACCESS_KEY", AWS_SECRET),
        ("AWS_SESSION_TOKEN", "aws-token-CANARY-6"),
        ("AWS_REGION", "us-east-1"),
    ];
    let sim = "sim:examples/sim/driving_paper.toml";
    let cases = [
        ("openai:m", "none", true),
        ("anthropic:m", "none", true),
        ("gemini:m", "none", true),
        ("bedrock:m", "none", true),
        (sim, "imagegen:gemini:img", false),
        (sim, "imagegen:openai:img", false),
    ];
    for (model, renderer, model_redirects) in cases {
        let (first, second) = (rt.block_on(common::mock_server()), rt.block_on(common::mock_server()));
        rt.block_on(
            wiremock::Mock::given(wiremock::matchers::any()).respond_with(Redirect(second.uri())).mount(&first),
        );
        rt.block_on(
            wiremock::Mock::given(wiremock::matchers::any())
                .respond_with(AnyProvider { png: png_b64() })
                .mount(&second),
        );
        let base = if model.starts_with("openai") || renderer.ends_with("openai:img") {
            format!("{}/v1", first.uri())
        } else {
            first.uri()
        };
        let flag = if model_redirects { "--base-url" } else { "--renderer-base-url" };
        let o = revelio(
            &["ask", "domains/driving.rev", "debris_far", "--model", model, "--renderer", renderer, flag, &base],
            &env,
        );
        let all = text(&o);
        let what = format!("{model} / {renderer}");
        assert_eq!(o.status.code(), Some(1), "{what}: {all}");
        let port = second.address().port();
        assert!(all.contains(&format!("redirected (HTTP 307) to `127.0.0.1:{port}`")), "{what}: {all}");
        assert!(!all.contains("stolen?key"), "{what}: the location's path and query are not shown: {all}");
        let followed = rt.block_on(second.received_requests()).unwrap_or_default();
        assert!(followed.is_empty(), "{what}: the redirect was followed: {}", rt.block_on(seen(&second)));
        let asked = rt.block_on(first.received_requests()).unwrap_or_default();
        assert_eq!(asked.len(), 1, "{what}: a redirect is not retried");
    }
}

/// A user name or password in a base URL (flag or variable) is refused before anything is sent
/// or recorded, and the message never shows it.
#[test]
fn userinfo_in_a_base_url_is_refused() {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let server = rt.block_on(common::mock_server());
    rt.block_on(wiremock::Mock::given(wiremock::matchers::any()).respond_with(chat("Answer: A")).mount(&server));
    let with_userinfo = format!("http://user:pass-CANARY-7@{}/v1", server.address());
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let sim = "sim:examples/sim/driving_paper.toml";
    let ask = |extra: &[&str], env: &[(&str, &str)]| {
        let mut a = vec!["ask", "domains/driving.rev", "debris_far", "--renderer", "none"];
        a.extend(extra);
        revelio(&a, env)
    };
    let search_args = small_run(&run, None);
    let mut search = strs(&search_args);
    search[3] = sim;
    search.extend(["--renderer-base-url", &with_userinfo]);
    for o in [
        ask(&["--model", "openai:m", "--base-url", &with_userinfo], &[("OPENAI_API_KEY", OPENAI_KEY)]),
        ask(&["--model", "openai:m"], &[("OPENAI_API_KEY", OPENAI_KEY), ("OPENAI_BASE_URL", &with_userinfo)]),
        ask(&["--model", "gemini:m", "--base-url", &with_userinfo.replace("/v1", "")], &[]),
        // An unused renderer URL would still be written into `config.json`.
        revelio(&search, &[]),
    ] {
        let all = text(&o);
        assert_eq!(o.status.code(), Some(2), "{all}");
        assert!(all.contains("holds a user name or password") && !all.contains("pass-CANARY-7"), "{all}");
    }
    assert!(!run.join("config.json").exists(), "nothing was recorded");
    assert!(rt.block_on(server.received_requests()).unwrap_or_default().is_empty());
}

/// Plain `http://` is refused for a provider's own host (even with `--allow-http`) and for any
/// other host that is not this machine without `--allow-http`, saying why; loopback is allowed.
#[test]
fn plain_http_is_refused_for_a_providers_host() {
    let env = [("OPENAI_API_KEY", OPENAI_KEY), ("ANTHROPIC_API_KEY", ANTHROPIC_KEY), ("GEMINI_API_KEY", GEMINI_KEY)];
    let ask = |model: &str, base: &str, extra: &[&str]| {
        let mut a = vec!["ask", "domains/driving.rev", "debris_far", "--model", model, "--renderer", "none"];
        a.extend(["--base-url", base]);
        a.extend(extra);
        revelio(&a, &env)
    };
    for (model, base) in [
        ("openai:m", "http://api.openai.com/v1"),
        ("anthropic:m", "http://api.anthropic.com"),
        ("gemini:m", "http://generativelanguage.googleapis.com"),
    ] {
        for extra in [&[][..], &["--allow-http"][..]] {
            let o = ask(model, base, extra);
            let all = text(&o);
            assert_eq!(o.status.code(), Some(2), "{base} {extra:?}: {all}");
            assert!(all.contains("to a provider's host would send the key in cleartext; use `https://`"), "{all}");
        }
    }
    // The image generator's own variable too (exit 1: the renderer cannot start in this
    // environment, as without its key).
    let o = revelio(
        &["ask", "domains/driving.rev", "debris_far", "--model", "sim:examples/sim/driving_paper.toml"]
            .into_iter()
            .chain(["--renderer", "imagegen:gemini:img"])
            .collect::<Vec<_>>(),
        &[("GEMINI_API_KEY", GEMINI_KEY), ("GEMINI_BASE_URL", "http://generativelanguage.googleapis.com")],
    );
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("provider's host would send the key in cleartext"), "{}", text(&o));
    // A server elsewhere on the network: only when named with `--allow-http`.
    let o = ask("openai:m", "http://gpu-box.invalid:8000/v1", &[]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("pass `--allow-http` if `gpu-box.invalid` is a server on your own network"),
        "{}",
        text(&o)
    );
    // This machine: allowed (every mock server of these tests is one).
    let rt = tokio::runtime::Runtime::new().unwrap();
    let server = rt.block_on(common::mock_server());
    rt.block_on(wiremock::Mock::given(wiremock::matchers::any()).respond_with(chat("Answer: A")).mount(&server));
    let local = format!("http://localhost:{}/v1", server.address().port());
    let o = ask("openai:m", &local, &[]);
    assert!(o.status.success(), "{}", text(&o));
}

// --- run folders (issue 27) ---
// A run folder is untrusted input (shared, downloaded): its names may be links, FIFOs or
// devices, its files huge or crafted. Nothing in it may make Revelio write outside it, hang,
// read without end, allocate by a number it chose, or silently destroy a damaged journal line.

/// The arguments of a small `search` into `out` (sim model, no renderer); run again, they resume.
fn small_search(out: &Path) -> Vec<String> {
    [
        "search",
        "domains/driving.rev",
        "--model",
        "sim:examples/sim/driving_paper.toml",
        "--renderer",
        "none",
        "--algo",
        "gpts",
        "--budget",
        "12",
        "--samples",
        "2",
        "--shrink",
        "0",
        "--out",
        s(out),
    ]
    .map(String::from)
    .to_vec()
}

fn args(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

/// A finished run folder (with its report) in `dir/name`.
fn finished_run(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    let o = revelio(&args(&small_search(&out)), &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(out.join("report/index.html").is_file(), "{}", text(&o));
    out
}

/// Replace `path` (file or folder) by a link to `target`.
#[cfg(unix)]
fn link_over(path: &Path, target: &Path) {
    if path.is_dir() {
        std::fs::remove_dir_all(path).unwrap();
    } else {
        std::fs::remove_file(path).unwrap();
    }
    std::os::unix::fs::symlink(target, path).unwrap();
}

#[cfg(unix)]
#[test]
fn links_in_a_run_folder_are_never_written_through() {
    let dir = tempfile::tempdir().unwrap();
    let victim = write(dir.path(), "victim.txt", "precious");
    let victim_dir = dir.path().join("elsewhere");
    write(&victim_dir, "index.html", "precious page");
    for name in ["lock", "journal.jsonl", "report"] {
        let run = finished_run(dir.path(), &format!("run-{}", name.replace('.', "-")));
        let target = if name == "report" { victim_dir.clone() } else { victim.clone() };
        link_over(&run.join(name), &target);
        // A resume writes the lock, the journal and the report; `report` reads the journal and
        // writes the report (it takes no lock).
        let resume = revelio(&args(&small_search(&run)), &[]);
        let refused = |o: &Output| text(o).contains("symbolic link") && text(o).contains(name);
        assert!(!resume.status.success() || name == "report", "{name}: {}", text(&resume));
        assert!(refused(&resume), "{name}: {}", text(&resume));
        let report = revelio(&["report", s(&run)], &[]);
        if name == "lock" {
            assert!(report.status.success(), "{}", text(&report));
        } else {
            assert!(!report.status.success() && refused(&report), "{name}: {}", text(&report));
        }
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious", "{name}: the link's target was written");
        let names: Vec<_> = std::fs::read_dir(&victim_dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["index.html"], "{name}: files were written into the linked folder");
        assert_eq!(std::fs::read_to_string(victim_dir.join("index.html")).unwrap(), "precious page");
        assert!(std::fs::symlink_metadata(run.join(name)).unwrap().file_type().is_symlink(), "{name}");
    }
}

/// The run's report page (it lists the run files it could not read).
fn page(run: &Path) -> String {
    std::fs::read_to_string(run.join("report/index.html")).unwrap_or_default()
}

#[cfg(unix)]
#[test]
fn fifos_and_devices_in_a_run_folder_are_refused_without_hanging() {
    let dir = tempfile::tempdir().unwrap();
    let run = finished_run(dir.path(), "run");
    let keep = dir.path().join("keep");
    std::fs::create_dir(&keep).unwrap();
    for name in ["config.json", "summary.json", "journal.jsonl", "probe.json"] {
        let at = run.join(name);
        if at.exists() {
            std::fs::rename(&at, keep.join(name)).unwrap();
        }
        if !mkfifo(&at) {
            eprintln!("note: `mkfifo` is not available; FIFO attacks are not checked");
            return;
        }
        // Reading a FIFO blocks until a writer comes: a command that returns is the check.
        let o = revelio(&["report", s(&run)], &[]);
        let all = format!("{}{}", text(&o), page(&run));
        assert!(all.contains("is a FIFO (named pipe), not a regular file"), "{name}: {all}");
        // `probe.json` is an addition: the report goes on without its section.
        assert_eq!(o.status.success(), name == "probe.json", "{name}: {all}");
        if name != "probe.json" {
            let o = revelio(&args(&small_search(&run)), &[]);
            assert!(!o.status.success(), "{name}: {}", text(&o));
        }
        std::fs::remove_file(&at).unwrap();
        // `/dev/zero` behind a link: refused by what it is, in the memory `report` was killed in.
        std::os::unix::fs::symlink("/dev/zero", &at).unwrap();
        let o = revelio_in_3gb(&["report", s(&run)]);
        assert!(format!("{}{}", text(&o), page(&run)).contains("symbolic link"), "{name}: {}", text(&o));
        assert_eq!(o.status.success(), name == "probe.json", "{name}: {}", text(&o));
        std::fs::remove_file(&at).unwrap();
        if keep.join(name).exists() {
            std::fs::rename(keep.join(name), &at).unwrap();
        }
    }
    let o = revelio(&["report", s(&run)], &[]);
    assert!(o.status.success(), "the restored folder reports again: {}", text(&o));
}

#[test]
fn a_summary_naming_forty_thousand_concepts_is_refused() {
    // 40 000 names made `report` allocate their square (about 25 GB) for the pair matrix.
    let dir = tempfile::tempdir().unwrap();
    let run = finished_run(dir.path(), "run");
    let path = run.join("summary.json");
    let original: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let names: Vec<String> = (0..40_000).map(|i| format!("c{i}")).collect();
    let row = original["sets"][0].clone();
    let in_one_set = {
        let mut v = original.clone();
        v["sets"][0]["concepts"] = json!(names);
        v
    };
    let in_pairs = {
        let mut v = original.clone();
        v["sets"] = names
            .chunks(2)
            .map(|pair| {
                let mut r = row.clone();
                r["concepts"] = json!(pair);
                r
            })
            .collect();
        v
    };
    for (summary, says) in [
        (in_one_set, "a set of 40000 names repeats one or is larger than any domain allows"),
        (in_pairs, "it names more than 512 concepts"),
    ] {
        std::fs::write(&path, summary.to_string()).unwrap();
        let o = revelio_in_3gb(&["report", s(&run)]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(text(&o).contains(says), "{}", text(&o));
    }
    // A name the domain does not declare is refused too, when the domain is at hand.
    let mut summary = original;
    summary["sets"][0]["concepts"] = json!(["ghost\u{1b}[2J"]);
    std::fs::write(&path, summary.to_string()).unwrap();
    let o = revelio(&["report", s(&run)], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("concept `ghost\\u{1b}[2J` is not in domain `driving`"), "{}", text(&o));
    assert!(!text(&o).contains('\u{1b}'), "{}", text(&o));
}

#[test]
fn a_corrupt_journal_line_stops_the_command_and_can_be_set_aside() {
    let dir = tempfile::tempdir().unwrap();
    let run = finished_run(dir.path(), "run");
    let path = run.join("journal.jsonl");
    let good = std::fs::read_to_string(&path).unwrap();
    let (first, rest) = good.split_at(good.find('\n').unwrap() + 1);
    // A complete line that does not parse, then the rest, ending in a complete bad line.
    let damaged = format!("{first}{{\"phase\": oops\n{rest}not json\n");
    std::fs::write(&path, &damaged).unwrap();
    for cmd in [args(&small_search(&run)), vec!["report", s(&run)]] {
        let o = revelio(&cmd, &[]);
        assert!(!o.status.success(), "{}", text(&o));
        assert!(text(&o).contains(&format!("corrupt journal line 2 in `{}`", path.display())), "{}", text(&o));
        assert!(text(&o).contains("--set-aside-corrupt"), "{}", text(&o));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), damaged, "the journal is left as it is");
        assert!(!run.join("journal.corrupt").exists());
    }
    let mut cmd = small_search(&run);
    cmd.push("--set-aside-corrupt".into());
    let o = revelio(&args(&cmd), &[]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("moved 2 corrupt line(s)"), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(run.join("journal.corrupt")).unwrap(), "{\"phase\": oops\nnot json\n");
    assert_eq!(std::fs::read_to_string(&path).unwrap(), good, "the good lines stay, nothing asked again");
    assert!(revelio(&["report", s(&run)], &[]).status.success());
}

// --- front end and compare (issue 27) ---

/// A domain whose one rule condition is `exists … where` nested `depth` deep.
fn nested_exists_domain(depth: usize) -> String {
    let mut t = String::from(
        "domain deep\nkind Cone {}\nregion lane { x 5m..20m  y -1m..1m  z 0m }\n\
         concept cone { description \"c\" probe \"p\" not \"n\" add cone: Cone in lane ahead_of ego }\n\
         question q { text \"q\" option a \"a\" option b \"b\" }\nrules priority {\n  rule r {\n    when ",
    );
    for i in 0..depth {
        t.push_str(&format!("exists e{i}: Cone where "));
    }
    t.push_str("true\n    expect q.a\n  }\n}\n");
    t
}

/// An LSP session on standard input: open `text`, then shut down.
fn lsp_session(uri: &str, text: &str) -> String {
    let messages = [
        json!({ "jsonrpc": "2.0", "id": 1, "method": "initialize", "params": { "capabilities": {} } }),
        json!({ "jsonrpc": "2.0", "method": "initialized", "params": {} }),
        json!({ "jsonrpc": "2.0", "method": "textDocument/didOpen", "params": { "textDocument": {
            "uri": uri, "languageId": "revelio", "version": 1, "text": text } } }),
        json!({ "jsonrpc": "2.0", "id": 2, "method": "shutdown", "params": null }),
        json!({ "jsonrpc": "2.0", "method": "exit", "params": null }),
    ];
    messages
        .iter()
        .map(|m| {
            let body = m.to_string();
            format!("Content-Length: {}\r\n\r\n{body}", body.len())
        })
        .collect()
}

#[test]
fn a_3000_deep_domain_is_refused_by_check_fmt_and_the_language_server() {
    // `exists … where` 3 000 deep (84 KB) overflowed the parser's stack: `check`, `fmt` and
    // `revelio lsp` died of SIGABRT. Now one nesting budget, counted before parsing, refuses it.
    let dir = tempfile::tempdir().unwrap();
    let shapes = [
        nested_exists_domain(3000),
        nested_exists_domain(40_000),
        nested_exists_domain(60).replace("where ", "where not not "),
        nested_exists_domain(120).replace("exists", "(exists").replace("true", &format!("true{}", ")".repeat(120))),
    ];
    for (i, t) in shapes.iter().enumerate() {
        let d = write(dir.path(), &format!("deep{i}.rev"), t);
        let o = revelio(&["check", s(&d), "--format", "plain"], &[]);
        let all = text(&o);
        assert_eq!(o.status.code(), Some(1), "shape {i}: {all}");
        assert!(all.contains("R0003") && all.contains("nests too deeply"), "shape {i}: {all}");
        let o = revelio(&["fmt", "--check", s(&d)], &[]);
        assert_eq!(o.status.code(), Some(1), "shape {i}: {}", text(&o));
        assert!(text(&o).contains("nests too deeply"), "shape {i}: {}", text(&o));
    }
    let cache = dir.path().join("cache");
    let uri = format!("file://{}", s(&dir.path().join("deep0.rev")));
    let o = revelio_fed(&["lsp"], &[("XDG_CACHE_HOME", s(&cache))], Some(lsp_session(&uri, &shapes[0])));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "the server ends cleanly: {:?} {}", o.status, text(&o));
    assert!(out.contains("publishDiagnostics") && out.contains("R0003"), "{out}");
    // Within the budget, the same shapes check (a 3-deep condition is fine).
    let o = revelio(&["check", s(&write(dir.path(), "ok.rev", &nested_exists_domain(3))), "--format", "plain"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

#[test]
fn a_40_deep_condition_is_refused_before_any_evaluation() {
    // 40 nested `exists` passed `check`, and deciding one set visited entities^40 bindings (it
    // did not end in a minute). Past three, `check` refuses it, so no command evaluates it.
    let dir = tempfile::tempdir().unwrap();
    let d = write(dir.path(), "deep.rev", &nested_exists_domain(40));
    let o = revelio(&["check", s(&d), "--format", "plain"], &[]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(all.contains("R0034") && all.contains("`exists e3` nests more than 3 quantifiers deep"), "{all}");
    assert!(!all.contains("R0003"), "within the nesting budget: {all}");
    let o = revelio(&["oracle", s(&d), "cone"], &[]);
    assert_ne!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("R0034"), "{}", text(&o));
}

#[test]
fn a_huge_repeat_is_refused_by_check() {
    // `repeat 4000000000` passed `check`; `emit scene` then asked for 960 GB and aborted.
    let dir = tempfile::tempdir().unwrap();
    let t = nested_exists_domain(1)
        + "stage dashes repeat 4000000000 step (1m, 0m, 0m) { box size (1m, 0.1m, 0.01m) color #ffffff }\n";
    let d = write(dir.path(), "huge.rev", &t);
    let o = revelio(&["check", s(&d), "--format", "plain"], &[]);
    let all = text(&o);
    assert_eq!(o.status.code(), Some(1), "{all}");
    assert!(
        all.contains("R0035") && all.contains("`repeat 4000000000` is over the most a stage item repeats"),
        "{all}"
    );
    let o = revelio_in_3gb(&["emit", "scene", s(&d), "cone"]);
    assert_eq!(o.status.code(), Some(1), "refused, not aborted: {}", text(&o));
    // Every count a file chooses is bounded: stage parts with repeats, parts in a block, entities.
    let parts = |n: usize| "box size (1m, 1m, 1m) color #ffffff ".repeat(n);
    let cases = [
        (format!("stage a repeat 1000 step (1m, 0m, 0m) {{ {} }}\n", parts(5)), "past 4096 stage parts"),
        (format!("stage b {{ {} }}\n", parts(300)), "a block may list at most 256 parts; this one lists 300"),
        (
            (0..65)
                .map(|i| format!("concept c{i} {{ description \"c\" probe \"p\" not \"n\" add x: Cone in lane add y: Cone in lane }}\n"))
                .collect(),
            "the concepts add 131 entities; a domain may add at most 128",
        ),
    ];
    for (extra, message) in cases {
        let d = write(dir.path(), "counts.rev", &(nested_exists_domain(1) + &extra));
        let o = revelio(&["check", s(&d), "--format", "plain"], &[]);
        let all = text(&o);
        assert!(all.contains("R0035") && all.contains(message), "{message}: {all}");
    }
}

#[test]
fn escapes_in_a_run_folder_never_reach_the_terminal_from_compare_or_report() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run\u{1b}[2J");
    let o = revelio(
        &[
            "search",
            "domains/driving.rev",
            "--model",
            "sim:examples/sim/driving_paper.toml",
            "--renderer",
            "none",
            "--algo",
            "gpts",
            "--budget",
            "8",
            "--samples",
            "1",
            "--out",
            s(&run),
            "--json",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", text(&o));
    let config_path = run.join("config.json");
    let mut config: Value = serde_json::from_str(&std::fs::read_to_string(&config_path).unwrap()).unwrap();
    config["model"] = json!("evil\u{1b}]0;owned\u{7}\u{9b}31m");
    config["domain_file"] = json!("/gone/\u{1b}[2Jdomain.rev");
    std::fs::write(&config_path, serde_json::to_string_pretty(&config).unwrap()).unwrap();
    for args in [vec!["compare", s(&run)], vec!["report", s(&run)]] {
        let o = revelio(&args, &[]);
        let all = text(&o);
        assert!(o.status.success(), "{args:?}: {all}");
        assert!(!all.contains(['\u{1b}', '\u{7}', '\u{9b}']), "{args:?}: raw escapes: {all:?}");
        assert!(all.contains("\\u{1b}[2J"), "{args:?}: {all}");
    }
    let o = revelio(&["compare", s(&run)], &[]);
    assert!(text(&o).contains("evil\\u{1b}]0;owned\\u{7}\\u{9b}31m"), "{}", text(&o));
}

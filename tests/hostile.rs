//! Attacks that stay fixed: what a stranger's domain file, a misbehaving endpoint or a hostile
//! configuration could make Revelio do. Every bound is asserted by refusal (a diagnostic, an
//! error outcome, an exit code), never by measuring time or memory; a command that hangs or
//! spins is killed after a generous guard and fails its test.
//!
//! - files: `use` of `/proc/self/environ`, `/dev/zero`, a FIFO, `..`, links out of the tree,
//!   also from standard input (`check -`); a 10 MB comment, in a file or on standard input; one
//!   file by two spellings; `check` on a FIFO;
//! - keys: every (model provider × image provider) pair, each key only at its own host;
//! - replies: an endless chunked body, a stalled body, a body that trickles, a 50 MB reply, a
//!   3 MB answer that the journal keeps only a prefix of, escape sequences in replies and errors;
//! - domains: 128 unconstrained concepts refused quickly by `check`, `lattice` and `search`;
//!   10 000 rules checked;
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
fn an_unconstrained_128_concept_domain_is_refused_with_the_ways_out() {
    // 275 million sets of up to five: `check` took 6.5 min and 8.4 GB, `search` sat silent.
    let dir = tempfile::tempdir().unwrap();
    let wide = wide_domain(dir.path(), 128);
    let profile = write(dir.path(), "sim.toml", "name = \"plain\"\n");
    let model = format!("sim:{}", s(&profile));
    let out = dir.path().join("run");
    for args in [
        vec!["check", s(&wide), "--format", "plain"],
        vec!["lattice", s(&wide)],
        vec!["search", s(&wide), "--model", &model, "--renderer", "none", "--out", s(&out)],
    ] {
        let o = revelio_in_3gb(&args);
        let all = text(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {all}");
        assert!(all.contains("R0070"), "{args:?}: {all}");
        assert!(all.contains("more than 1000000 valid concept sets of up to 5 concepts"), "{args:?}: {all}");
        assert!(all.contains("`--max-size 3` gives 349632") && all.contains("`--max-sets`"), "{args:?}: {all}");
    }
    assert!(!out.join("journal.jsonl").exists(), "nothing was asked");
    // The ways out work: a smaller size, or a raised limit for counting.
    let o = revelio(&["lattice", s(&wide), "--max-size", "2"], &[]);
    assert!(o.status.success() && text(&o).contains("8256"), "{}", text(&o));
    let o = revelio(&["check", s(&wide), "--max-size", "2", "--format", "plain"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
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
                let model_server = MockServer::start().await;
                let image_server = MockServer::start().await;
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
    let server = MockServer::start().await;
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
    let server = rt.block_on(MockServer::start());
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
    let server = rt.block_on(MockServer::start());
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
    let bad = rt.block_on(MockServer::start());
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

//! The run report of a real run (builtin renderer, sim model): `revelio search`, `validate`,
//! `probe` and `transfer` refresh it and print its path, every file the page links exists, every
//! core has its card with the renderer's visibility figures, the probe and transfer sections are
//! there — and a real browser (headless Chromium) opens it with every image loaded and no error
//! logged. Without Chromium the browser test says so and skips, or fails where
//! `REVELIO_REQUIRE_PEERS` is set (`.ci/run` installs Chromium and sets it).

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serde_json::{Value, json};

fn revelio(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("revelio runs");
    assert!(
        out.status.success(),
        "revelio {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// One searched and validated run with images, shared by the tests of this file.
fn run_dir() -> &'static Path {
    static RUN: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_, dir) = RUN.get_or_init(|| {
        let tmp = tempfile::tempdir().unwrap();
        // One strong planted mode, so that beam's singletons already find a core and its first
        // pairs extend it; some replies unparsed, so the outcome table has more than two rows.
        let profile = tmp.path().join("profile.toml");
        std::fs::write(
            &profile,
            "name = \"report-test\"\nbase_error = 0.05\nunparsed = 0.05\nlatency_ms = 0\n[[mode]]\nconcepts = [\"debris_far\"]\nerror = 0.95\n",
        )
        .unwrap();
        let model = format!("sim:{}", profile.display());
        let dir = tmp.path().join("run");
        let d = dir.to_str().unwrap();
        let out = revelio(&[
            "search",
            "domains/driving.rev",
            "--model",
            &model,
            "--algo",
            "beam",
            "--budget",
            "120",
            "--samples",
            "3",
            "--concurrency",
            "4",
            "--out",
            d,
        ]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        let index = dir.join("report").join("index.html");
        assert!(stdout.ends_with(&format!("report: {}\n", index.display())), "search printed no report path:\n{stdout}");
        let before = std::fs::metadata(&index).unwrap().modified().unwrap();
        let out = revelio(&["validate", d, "--top", "3", "--samples", "4", "--concurrency", "4"]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.ends_with(&format!("report: {}\n", index.display())), "validate printed no report path:\n{stdout}");
        assert!(std::fs::metadata(&index).unwrap().modified().unwrap() >= before);
        let probed = revelio(&["probe", d, "--top", "3", "--samples", "2", "--min-n", "1", "--concurrency", "4"]);
        let transferred = revelio(&[
            "transfer",
            d,
            "--model",
            "sim:examples/sim/driving_paper.toml",
            "--top",
            "2",
            "--samples",
            "2",
            "--concurrency",
            "4",
        ]);
        for (what, out) in [("probe", probed), ("transfer", transferred)] {
            let stdout = String::from_utf8_lossy(&out.stdout);
            assert!(stdout.ends_with(&format!("report: {}\n", index.display())), "{what} printed no report path:\n{stdout}");
        }
        (tmp, dir)
    });
    dir
}

/// `src` and `href` values of the page that name files (not anchors).
fn linked_files(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in [" src=\"", " href=\""] {
        for part in html.split(attr).skip(1) {
            let value = part.split('"').next().unwrap();
            if !value.starts_with('#') && !value.starts_with("data:") {
                out.push(value.to_string());
            }
        }
    }
    out
}

fn check_report(run: &Path, out: &Path) {
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let links = linked_files(&html);
    assert!(links.iter().any(|l| l.starts_with("thumbs/")), "the page shows no image");
    for l in &links {
        assert!(!l.contains("..") && !l.starts_with('/') && !l.contains(':'), "a link leaves the report folder: `{l}`");
        assert!(out.join(l).is_file(), "the page links a missing file `{l}`");
    }
    // Every core of the run has its card, in order.
    let loaded = revelio::report::load(run).unwrap();
    let findings = loaded.findings();
    assert!(!findings.cores.is_empty(), "the run found no failure mode; the test needs one");
    let cards: Vec<&str> = html.split("data-concepts=\"").skip(1).map(|p| p.split('"').next().unwrap()).collect();
    let cores: Vec<String> = findings.cores.iter().map(|c| c.concepts.join(" + ")).collect();
    assert_eq!(cards, cores);
    // The validated sets show their validated FR.
    let validation = loaded.validation.as_ref().expect("validation.json");
    for v in &validation.sets {
        if findings.cores.iter().any(|c| c.concepts == v.search.concepts) {
            assert!(html.contains(&format!(" of {}</b>", v.validation.answered)), "validated FR of a core missing");
        }
    }
    for name in ["failure_modes.csv", "sets.csv", "discovery.svg", "heatmap.svg", "recognition.csv", "transfer.csv"] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    // The builtin renderer's visibility figures on the cards, the guard's counts per phase, and
    // the sections of `probe` and `transfer`.
    assert!(html.contains(" px · contrast 0."), "no observation shows its visibility figures");
    let visibility = html.split("<section id=\"visibility\">").nth(1).expect("a visibility section");
    for phase in ["search", "validate", "probe", "transfer"] {
        assert!(visibility.contains(&format!("<tr><td>{phase}</td>")), "no visibility row for {phase}");
    }
    assert!(html.contains("<section id=\"probe\">") && html.contains("<section id=\"transfer\">"));
    let probe = loaded.probe.as_ref().expect("probe.json");
    assert!(probe.analysis.concepts.iter().all(|c| html.contains(&format!("<td><code>{}</code></td>", c.concept))));
    let transfer = &loaded.transfer.as_ref().expect("transfer.json").transfer;
    assert!(html.contains(&format!("<code>{}</code>", transfer.models[1])));
    let sets = std::fs::read_to_string(out.join("sets.csv")).unwrap();
    assert_eq!(sets.lines().count(), 1 + loaded.summary.sets.len());
}

#[test]
fn every_linked_image_exists_and_every_core_appears() {
    let run = run_dir();
    check_report(run, &run.join("report"));
    // `revelio report -o` writes the same page elsewhere, self-contained.
    let other = run.parent().unwrap().join("elsewhere");
    let out = revelio(&["report", run.to_str().unwrap(), "-o", other.to_str().unwrap()]);
    assert_eq!(String::from_utf8_lossy(&out.stdout), format!("report: {}\n", other.join("index.html").display()));
    check_report(run, &other);
}

#[test]
fn a_broken_run_folder_gets_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let out =
        Command::new(env!("CARGO_BIN_EXE_revelio")).args(["report", tmp.path().to_str().unwrap()]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: `") && err.contains("` is not a run folder (it has no config.json)"), "{err}");
}

/// A Chromium found on the PATH.
fn chromium() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |dir| dir.join(name)))
        .find(|p| p.is_file())
}

/// A headless Chromium driven over the DevTools protocol on a pipe (`--remote-debugging-pipe`:
/// commands on its fd 3, replies and events on its fd 4, each message ending in a NUL byte).
struct Browser {
    child: Child,
    to: std::process::ChildStdin,
    from: mpsc::Receiver<Value>,
    next_id: u64,
    /// Events seen while waiting for replies.
    events: Vec<Value>,
    deadline: Instant,
}

impl Browser {
    fn launch(exe: &Path, profile: &Path, log: &Path) -> Browser {
        // The shell moves our pipes to fds 3 and 4, where Chromium expects them.
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(r#"exec "$0" "$@" 3<&0 4>&1 </dev/null >/dev/null"#)
            .arg(exe)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--remote-debugging-pipe",
                "--window-size=1280,900",
            ])
            .arg(format!("--user-data-dir={}", profile.display()))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(log).unwrap())
            .spawn()
            .expect("chromium starts");
        let to = child.stdin.take().unwrap();
        let mut from_chrome = BufReader::new(child.stdout.take().unwrap());
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            loop {
                let mut buf = Vec::new();
                match from_chrome.read_until(0, &mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(_) => {
                        buf.pop();
                        if let Ok(v) = serde_json::from_slice::<Value>(&buf)
                            && tx.send(v).is_err()
                        {
                            break;
                        }
                    }
                }
            }
        });
        Browser {
            child,
            to,
            from: rx,
            next_id: 0,
            events: Vec::new(),
            deadline: Instant::now() + Duration::from_secs(120),
        }
    }

    fn recv(&mut self, log: &Path) -> Value {
        let left = self.deadline.saturating_duration_since(Instant::now());
        match self.from.recv_timeout(left) {
            Ok(v) => v,
            Err(e) => {
                let mut text = String::new();
                let _ = std::fs::File::open(log).and_then(|mut f| f.read_to_string(&mut text));
                panic!("no answer from chromium ({e}); its log:\n{text}");
            }
        }
    }

    /// Send a command (to a page session when given) and wait for its result.
    fn call(&mut self, session: Option<&str>, method: &str, params: Value, log: &Path) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if let Some(s) = session {
            msg["sessionId"] = json!(s);
        }
        let mut bytes = serde_json::to_vec(&msg).unwrap();
        bytes.push(0);
        self.to.write_all(&bytes).and_then(|()| self.to.flush()).expect("chromium reads its pipe");
        loop {
            let v = self.recv(log);
            if v.get("id").and_then(Value::as_u64) == Some(id) {
                if let Some(err) = v.get("error") {
                    panic!("chromium refused {method}: {err}");
                }
                return v["result"].clone();
            }
            self.events.push(v);
        }
    }

    /// Wait for an event of a page session.
    fn wait_for(&mut self, method: &str, log: &Path) {
        if self.events.iter().any(|e| e["method"] == method) {
            return;
        }
        loop {
            let v = self.recv(log);
            let done = v["method"] == method;
            self.events.push(v);
            if done {
                return;
            }
        }
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Errors the page raised or logged: uncaught exceptions, `console.error`, and error entries of
/// the browser log (a resource that failed to load, a blocked request).
fn page_errors(events: &[Value]) -> Vec<String> {
    events
        .iter()
        .filter_map(|e| match e["method"].as_str()? {
            "Runtime.exceptionThrown" => Some(format!("exception: {}", e["params"]["exceptionDetails"])),
            "Runtime.consoleAPICalled" if matches!(e["params"]["type"].as_str(), Some("error" | "assert")) => {
                Some(format!("console.error: {}", e["params"]["args"]))
            }
            "Log.entryAdded" if e["params"]["entry"]["level"] == "error" => {
                Some(format!("log: {} {}", e["params"]["entry"]["text"], e["params"]["entry"]["url"]))
            }
            _ => None,
        })
        .collect()
}

#[test]
fn chromium_loads_every_image_without_errors() {
    let Some(exe) = chromium() else {
        common::peer_missing(
            "the browser test",
            "no chromium on the PATH, so the report was not opened in a browser (`.ci/run` installs Debian's `chromium`; or `apt-get install chromium`)",
        );
        return;
    };
    let run = run_dir();
    let index = run.join("report").join("index.html").canonicalize().unwrap();
    let scratch = tempfile::tempdir().unwrap();
    let log = scratch.path().join("chromium.log");
    let mut b = Browser::launch(&exe, &scratch.path().join("profile"), &log);
    let target = b.call(None, "Target.createTarget", json!({"url": "about:blank"}), &log);
    let attached =
        b.call(None, "Target.attachToTarget", json!({"targetId": target["targetId"], "flatten": true}), &log);
    let session = attached["sessionId"].as_str().expect("a session").to_string();
    let s = Some(session.as_str());
    for domain in ["Runtime", "Log", "Page"] {
        b.call(s, &format!("{domain}.enable"), json!({}), &log);
    }
    let url = format!("file://{}", index.display());
    b.call(s, "Page.navigate", json!({"url": url}), &log);
    b.wait_for("Page.loadEventFired", &log);
    let probe = "JSON.stringify({images: Array.from(document.images, i => [i.getAttribute('src'), i.complete, i.naturalWidth]), cores: document.querySelectorAll('article.core').length, svgs: document.querySelectorAll('svg').length})";
    let result = b.call(s, "Runtime.evaluate", json!({"expression": probe, "returnByValue": true}), &log);
    let page: Value =
        serde_json::from_str(result["result"]["value"].as_str().expect("the probe returns a string")).unwrap();
    // Late events (an error logged as the load finished) arrive before this reply.
    b.call(s, "Runtime.evaluate", json!({"expression": "1"}), &log);
    let _ = b.call(None, "Browser.close", json!({}), &log);

    let images = page["images"].as_array().unwrap();
    assert!(!images.is_empty(), "the page has no image");
    let broken: Vec<&Value> = images.iter().filter(|i| !(i[1] == true && i[2].as_u64().unwrap_or(0) > 0)).collect();
    assert!(broken.is_empty(), "images that did not load in chromium: {broken:?}");
    let findings = revelio::report::load(run).unwrap();
    assert_eq!(page["cores"].as_u64(), Some(findings.findings().cores.len() as u64));
    assert_eq!(page["svgs"].as_u64(), Some(2), "both plots are inline");
    let errors = page_errors(&b.events);
    assert!(errors.is_empty(), "the page logged errors in chromium: {errors:#?}");
}

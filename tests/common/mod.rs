//! What several integration tests share: the checkout's root and walks over its files, the
//! environment of the tests that talk to mock providers, and the Python of the SDK shape checks.
//! Each test binary uses a part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::{Once, OnceLock};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A `.rev` file of the checkout (`domains/driving.rev`), compiled from disk as the CLI does, so
/// the files it `use`s load too.
pub fn compile_shipped(path: &str) -> revelio::ir::Domain {
    let c = revelio::cli::common::compile_path(&root().join(path), false);
    c.domain.unwrap_or_else(|| panic!("`{path}` does not compile: {:?}", c.diagnostics))
}

/// Every `.rev` file under `dir`, in a stable order.
pub fn rev_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    let mut entries: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            out.extend(rev_files(&p));
        } else if p.extension().is_some_and(|e| e == "rev") {
            out.push(p);
        }
    }
    out
}

/// Every file under `dir`, recursively (none when it does not exist).
pub fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let p = e.path();
        if p.is_dir() { out.extend(walk(&p)) } else { out.push(p) }
    }
    out
}

/// The folder `cargo test` builds into: `$CARGO_TARGET_DIR` (relative to the checkout when
/// relative), else `target/`.
pub fn target_dir() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target"));
    if target.is_absolute() { target } else { root().join(target) }
}

/// The Python of a virtual environment `target/NAME` holding `packages` (pinned pip specs), made
/// from PyPI when it is missing; `probe` is Python code that runs only where they are installed.
///
/// Two tests (or two test processes) may ask at once, and an earlier run may have been killed
/// halfway: an exclusive lock on `target/NAME.lock` (the OS drops it when its process dies) lets
/// one caller make the venv while the others wait, and a stamp written only after a complete
/// install names its packages. A venv without that stamp, with other packages, or whose
/// `probe` fails is made anew (`venv --clear`). Callers keep the answer in a `OnceLock`, so a
/// test binary makes or checks its venv once.
pub fn python_venv(name: &str, packages: &[&str], probe: &str) -> Result<PathBuf, String> {
    use std::process::{Command, Stdio};
    let target = target_dir();
    std::fs::create_dir_all(&target).map_err(|e| format!("cannot create `{}`: {e}", target.display()))?;
    let lock_path = target.join(format!("{name}.lock"));
    let lock = std::fs::File::options()
        .create(true)
        .write(true)
        .truncate(false)
        .open(&lock_path)
        .map_err(|e| format!("cannot open `{}`: {e}", lock_path.display()))?;
    lock.lock().map_err(|e| format!("cannot lock `{}`: {e}", lock_path.display()))?;

    let venv = target.join(name);
    let python = venv.join("bin").join("python");
    let stamp = venv.join(".revelio-installed");
    let wanted = packages.join("\n");
    let works = |python: &Path| {
        Command::new(python).args(["-c", probe]).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
    };
    if std::fs::read_to_string(&stamp).is_ok_and(|s| s == wanted) && works(&python) {
        return Ok(python);
    }
    let made = Command::new("python3").args(["-m", "venv", "--clear"]).arg(&venv).output();
    match made {
        Ok(out) if out.status.success() => {}
        Ok(out) => {
            return Err(format!(
                "cannot create a Python venv at `{}` ({}): {}",
                venv.display(),
                out.status,
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Err(e) => return Err(format!("cannot run `python3 -m venv`: {e}")),
    }
    let pip = Command::new(&python)
        // `--no-compile`: byte-compiling every module of every package (SciPy's, Matplotlib's…)
        // cost more CPU than the rest of the install (Scenic: 38 s with it, 15 s without);
        // Python compiles what it imports.
        .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-compile"])
        .args(packages)
        .status();
    if !pip.as_ref().is_ok_and(|s| s.success()) {
        return Err(format!("`pip install {}` failed ({pip:?}): PyPI cannot be reached?", packages.join(" ")));
    }
    if !works(&python) {
        return Err(format!("`{probe}` fails in `{}` after installing {}", venv.display(), packages.join(" ")));
    }
    std::fs::write(&stamp, &wanted).map_err(|e| format!("cannot write `{}`: {e}", stamp.display()))?;
    Ok(python)
}

/// Whether a missing real peer (a browser, an editor, a packager, an SDK, a system tool) fails
/// the test instead of skipping it: `REVELIO_REQUIRE_PEERS=1`, which `.ci/run` sets so that CI
/// cannot pass without running them.
pub fn peers_required() -> bool {
    std::env::var_os("REVELIO_REQUIRE_PEERS").is_some_and(|v| !v.is_empty() && v != "0")
}

/// A test's real peer is missing, for `reason`: with `REVELIO_REQUIRE_PEERS` set this panics
/// with the reason; otherwise it prints a note and the caller returns (the test skips).
#[track_caller]
pub fn peer_missing(test: &str, reason: &str) {
    assert!(!peers_required(), "{test}: {reason} (REVELIO_REQUIRE_PEERS is set, so a missing peer fails the test)");
    eprintln!("note: skipping {test}: {reason}");
}

/// Fake AWS credentials for the Bedrock client: an access key id, a secret and, when some, a
/// session token.
pub struct FakeAws {
    pub access_key_id: &'static str,
    pub secret_access_key: &'static str,
    pub session_token: Option<&'static str>,
}

/// A mock provider server of the test's own, on a port no other test has used.
///
/// wiremock's `MockServer::start` lends servers from a pool shared by the binary's tests, while
/// every client shares one process-wide connection pool ([`revelio::net::http::client`]). A
/// server handed back by one test and lent to the next keeps its port, so the next test's
/// request could go out on a keep-alive connection the first test's runtime still drives; when
/// that test ends, its runtime drops the connection mid-reply and the request is retried — the
/// server then counts two requests for one call (seen once in CI, `imagegen_gemini_and_openai`).
pub async fn mock_server() -> wiremock::MockServer {
    wiremock::MockServer::builder().start().await
}

/// The environment of a test binary whose model clients talk to local mock servers: `api_key`
/// as `OPENAI_API_KEY`, `ANTHROPIC_API_KEY` and `GEMINI_API_KEY`, the `aws` credentials (in
/// `us-east-1`) when given, and no base-URL override or default region left from the caller's
/// shell, so a client reaches only the mock it is given. Set once per binary: every test calls
/// it first, with the same values.
#[allow(unsafe_code)]
pub fn mock_provider_env(api_key: &'static str, aws: Option<FakeAws>) {
    static ENV: Once = Once::new();
    ENV.call_once(|| {
        // SAFETY: every test calls this first and `Once` makes the others wait until it is
        // done, so no thread reads the environment while it is being written.
        unsafe {
            for k in ["OPENAI_API_KEY", "ANTHROPIC_API_KEY", "GEMINI_API_KEY"] {
                std::env::set_var(k, api_key);
            }
            if let Some(aws) = aws {
                std::env::set_var("AWS_ACCESS_KEY_ID", aws.access_key_id);
                std::env::set_var("AWS_SECRET_ACCESS_KEY", aws.secret_access_key);
                if let Some(token) = aws.session_token {
                    std::env::set_var("AWS_SESSION_TOKEN", token);
                }
                std::env::set_var("AWS_REGION", "us-east-1");
            }
            for k in
                ["OPENAI_BASE_URL", "ANTHROPIC_BASE_URL", "GEMINI_BASE_URL", "BEDROCK_BASE_URL", "AWS_DEFAULT_REGION"]
            {
                std::env::remove_var(k);
            }
        }
    });
}

/// A `w`×`h` PNG with a gradient, the image of the queries sent to mock providers.
pub fn png(w: u32, h: u32) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([(x * 5) as u8, (y * 3) as u8, 90]));
    let mut out = Vec::new();
    image::DynamicImage::ImageRgb8(img).write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    out
}

/// A query about `image` with its multiple-choice `options`, its prompt built from `question` as
/// the search builds it.
pub fn image_query(question: &str, options: Vec<String>, image: Vec<u8>) -> revelio::vlm::Query {
    revelio::vlm::Query {
        image_hash: revelio::hash::sha256_hex(&image),
        image: Some(std::sync::Arc::new(image)),
        prompt: revelio::vlm::prompt::build(question, &options),
        options,
        truth: None,
    }
}

/// The official SDKs, pinned, that `tests/sdk/*.py` check request and reply shapes against.
pub const SDKS: &[&str] = &["openai==3.54.0", "anthropic==2.12.0", "google-genai==3.4.0"];

/// A Python with the pinned [`SDKS`] (`target/sdk-venv`), made on first use; `None` after
/// [`peer_missing`] for `test` when that cannot be.
pub fn sdk_python(test: &str) -> Option<PathBuf> {
    static PYTHON: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    match PYTHON.get_or_init(|| python_venv("sdk-venv", SDKS, "import openai, anthropic, google.genai")) {
        Ok(python) => Some(python.clone()),
        Err(e) => {
            peer_missing(test, e);
            None
        }
    }
}

/// Runs the shape check `script` (under `tests/sdk/`) with `python`, `data` as JSON on its
/// stdin, and asserts that the SDKs accept Revelio's `shapes` (else the problems it printed).
pub fn assert_sdks_accept(python: &Path, script: &str, data: serde_json::Value, shapes: &str) {
    use std::io::Write;
    use std::process::{Command, Stdio};
    let mut child = Command::new(python)
        .arg(root().join("tests/sdk").join(script))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(data.to_string().as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "the SDKs reject Revelio's {shapes}:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

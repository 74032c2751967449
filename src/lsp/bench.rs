//! `revelio bench lsp`: how long an editor waits for diagnostics. The server runs in this
//! process on an in-memory connection; a client opens a domain file, then edits it again and
//! again (appending a comment), timing each edit until the front end's diagnostics for that
//! version arrive, and saves after each edit, timing the save until the lattice lints arrive.
//! Lints also run after an edit once the debounce has passed; that wait is the debounce plus
//! the save figure.

use std::path::Path;
use std::time::{Duration, Instant};

use lsp_server::{Connection, Message, Notification, Request, RequestId};
use lsp_types::notification::Notification as _;
use lsp_types::request::Request as _;
use lsp_types::{notification as notif, request as req};
use serde_json::json;

use super::Options;

/// Measured latencies, one per edit.
#[derive(Debug, Clone, Default)]
pub struct Latencies {
    /// From `didChange` to the diagnostics of that version (front end only).
    pub front_end: Vec<Duration>,
    /// From `didSave` to the diagnostics with the lattice lints.
    pub lints_on_save: Vec<Duration>,
    /// The debounce the lints wait after the last edit.
    pub debounce: Duration,
}

/// Edit `path` `rounds` times through an in-memory server.
pub fn measure(path: &Path, rounds: usize) -> Result<Latencies, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read `{}`: {e}", path.display()))?;
    let abs = std::path::absolute(path).map_err(|e| e.to_string())?;
    let uri = lsp_types::Url::from_file_path(&abs).map_err(|()| format!("`{}` has no file URI", abs.display()))?;
    let (server, client) = Connection::memory();
    let options = Options { cache: None, ..Options::default() };
    let debounce = options.lint_delay;
    let handle = std::thread::spawn(move || super::serve(&server, options));
    let send = |m: Message| client.sender.send(m).map_err(|e| format!("the server stopped: {e}"));
    let notify = |method: &str, params: serde_json::Value| {
        send(Message::Notification(Notification::new(method.to_string(), params)))
    };
    send(Message::Request(Request::new(
        RequestId::from(1),
        req::Initialize::METHOD.to_string(),
        json!({ "capabilities": {} }),
    )))?;
    wait(&client, |m| matches!(m, Message::Response(_)))?;
    notify(notif::Initialized::METHOD, json!({}))?;
    notify(
        notif::DidOpenTextDocument::METHOD,
        json!({ "textDocument": { "uri": uri, "languageId": "revelio", "version": 0, "text": text } }),
    )?;
    // The first lint pass (after the debounce) settles before measuring.
    wait_version(&client, 0)?;
    wait_version(&client, 0)?;
    let mut out = Latencies { debounce, ..Latencies::default() };
    for round in 1..=rounds {
        let version = round as i32;
        let edited = format!("{text}\n// edit {round}\n");
        let t0 = Instant::now();
        notify(
            notif::DidChangeTextDocument::METHOD,
            json!({ "textDocument": { "uri": uri, "version": version }, "contentChanges": [{ "text": edited }] }),
        )?;
        wait_version(&client, version)?;
        out.front_end.push(t0.elapsed());
        let t1 = Instant::now();
        notify(notif::DidSaveTextDocument::METHOD, json!({ "textDocument": { "uri": uri } }))?;
        wait_version(&client, version)?;
        out.lints_on_save.push(t1.elapsed());
    }
    send(Message::Request(Request::new(RequestId::from(2), req::Shutdown::METHOD.to_string(), json!(null))))?;
    wait(&client, |m| matches!(m, Message::Response(_)))?;
    notify(notif::Exit::METHOD, json!(null))?;
    drop(client);
    handle.join().map_err(|_| "the server thread panicked".to_string())??;
    Ok(out)
}

fn wait(client: &Connection, want: impl Fn(&Message) -> bool) -> Result<Message, String> {
    loop {
        let m = client
            .receiver
            .recv_timeout(Duration::from_secs(120))
            .map_err(|_| "no answer from the server within 120 s".to_string())?;
        if want(&m) {
            return Ok(m);
        }
    }
}

fn wait_version(client: &Connection, version: i32) -> Result<(), String> {
    wait(client, |m| match m {
        Message::Notification(n) if n.method == notif::PublishDiagnostics::METHOD => {
            n.params.get("version").and_then(|v| v.as_i64()) == Some(i64::from(version))
        }
        _ => false,
    })
    .map(drop)
}

/// The median and the 90th percentile.
pub fn summary(v: &[Duration]) -> (Duration, Duration) {
    let mut s = v.to_vec();
    s.sort();
    if s.is_empty() {
        return (Duration::ZERO, Duration::ZERO);
    }
    (s[s.len() / 2], s[(s.len() * 9 / 10).min(s.len() - 1)])
}

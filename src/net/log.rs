//! The request log (`--log FILE`, or the `REVELIO_LOG` variable): one JSON line per HTTP attempt
//! of every model, batch and image-generation call, for reading when a provider misbehaves —
//! when it was sent, to which provider, model and endpoint, its status, how long it took, which
//! attempt it was, why it was retried and how long Revelio waited (the gate and rate limiter
//! before it, the backoff or `Retry-After` after it).
//!
//! What a line never holds: a key or any header (the endpoint is logged without user name,
//! query or fragment), a prompt, an image, a reply body. A retry reason is the provider's error
//! message as the journal keeps it for a failed call, scrubbed of the call's credentials.
//!
//! The log is process-wide (one file per command, like the request gates): it is opened once
//! by the command line before the first call, and lines from concurrent calls are written whole
//! under a lock, so they never interleave.

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, SystemTime};

use serde::Serialize;

/// The variable that names a log file when `--log` is not given.
pub const ENV: &str = "REVELIO_LOG";

static SINK: OnceLock<Mutex<File>> = OnceLock::new();

/// Open (append to, creating it) the log file `path` for the rest of the process. A second call
/// keeps the first file.
pub fn open(path: &Path) -> Result<(), String> {
    if SINK.get().is_some() {
        return Ok(());
    }
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(|e| format!("cannot open the log file `{}`: {}", path.display(), e.to_string().to_lowercase()))?;
    let _ = SINK.set(Mutex::new(file));
    Ok(())
}

/// Whether a log file is open (a call builds no log line otherwise).
pub fn enabled() -> bool {
    SINK.get().is_some()
}

/// Who makes the calls of a transport: what its lines name, and the credentials scrubbed from
/// their reasons.
#[derive(Clone, Default)]
pub struct Label {
    pub provider: String,
    pub model: String,
    pub secrets: Vec<String>,
}

impl std::fmt::Debug for Label {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Label").field("provider", &self.provider).field("model", &self.model).finish_non_exhaustive()
    }
}

/// How an attempt ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// The call is done with this attempt's answer.
    Ok,
    /// Another attempt follows after `wait_ms`.
    Retry,
    /// The call ends without an answer (a permanent error, or the retries ran out).
    Failed,
}

/// One attempt, as written.
#[derive(Debug, Serialize)]
pub struct Line<'a> {
    /// RFC 3339 UTC with milliseconds, when the attempt was sent.
    pub time: String,
    pub provider: &'a str,
    pub model: &'a str,
    pub method: &'a str,
    /// The URL without user name, query or fragment.
    pub endpoint: String,
    /// 1 for the first attempt of a call.
    pub attempt: u32,
    /// The HTTP status; `null` when no response came (timeout, connection error).
    pub status: Option<u16>,
    /// From sending the request to judging the reply.
    pub latency_ms: u64,
    pub outcome: Outcome,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Time waited for the request gate and the requests-per-minute limiter before sending.
    pub queued_ms: u64,
    /// With `retry`: the wait before the next attempt (backoff or `Retry-After`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wait_ms: Option<u64>,
    /// The attempt was refused by a rate limit (HTTP 429).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub rate_limited: bool,
}

/// Write one line (nothing without an open log). A failed write is dropped: the log must never
/// stop a paid run.
pub fn write(line: &Line<'_>, label: &Label) {
    let Some(sink) = SINK.get() else { return };
    let mut text = match serde_json::to_string(line) {
        Ok(t) => t,
        Err(_) => return,
    };
    // As `secret::redact` (which needs the `net` feature this module does not).
    for s in label.secrets.iter().filter(|s| s.len() >= 4) {
        if text.contains(s.as_str()) {
            text = text.replace(s.as_str(), "[redacted]");
        }
    }
    text.push('\n');
    let mut f = sink.lock().unwrap_or_else(|p| p.into_inner());
    let _ = f.write_all(text.as_bytes());
}

/// `2026-11-27T18:42:01.123Z`.
pub fn rfc3339(t: SystemTime) -> String {
    let d = t.duration_since(SystemTime::UNIX_EPOCH).unwrap_or(Duration::ZERO);
    let secs = d.as_secs();
    let (days, rem) = ((secs / 86_400) as i64, secs % 86_400);
    let (y, m, day) = crate::date::civil_from_days(days);
    format!("{y:04}-{m:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z", rem / 3600, rem % 3600 / 60, rem % 60, d.subsec_millis())
}

/// A URL as logged: scheme, host, port and path only (no user name, password, query or
/// fragment).
pub fn public(url: &str) -> String {
    let url = url.split(['?', '#']).next().unwrap_or_default();
    match url.split_once("://") {
        Some((scheme, rest)) => {
            let end = rest.find('/').unwrap_or(rest.len());
            let (authority, path) = rest.split_at(end);
            let host = authority.rsplit_once('@').map_or(authority, |(_, h)| h);
            format!("{scheme}://{host}{path}")
        }
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_urls_as_logged() {
        let t = SystemTime::UNIX_EPOCH + Duration::from_millis(1_445_412_480_123);
        assert_eq!(rfc3339(t), "2015-10-21T07:28:00.123Z");
        assert_eq!(public("https://u:p@h.example:8443/v1/x?key=k#f"), "https://h.example:8443/v1/x");
        assert_eq!(public("not a url"), "");
    }
}

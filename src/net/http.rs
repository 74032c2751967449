//! The one HTTP path every provider client goes through: a concurrency gate and a
//! requests-per-minute limiter shared per provider endpoint, a per-attempt timeout, and retries
//! with exponential backoff that honour `Retry-After` — bounded by an attempt count and by a
//! total deadline, so a call always ends.
//!
//! A reply body is read in chunks against two more bounds: its size (a body past
//! [`Limits::max_body`] ends the call with an error, never retried, before more is read — an
//! endless chunked body cannot grow memory) and the gap between chunks (a body that stalls for
//! [`Limits::stall`] ends the attempt, which is retried like a timeout).
//!
//! No redirect is followed: a request carries a key (`Authorization`, `x-api-key`,
//! `x-goog-api-key`, Bedrock's signature and `x-amz-security-token`) and the prompt and image,
//! and the HTTP client would re-send all but `Authorization` to wherever a `Location` points. A
//! 3xx reply ends the call with an error naming the host it pointed to, never retried.

use std::collections::HashMap;
use std::num::NonZeroU32;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant, SystemTime};

use governor::{DefaultDirectRateLimiter, Quota, RateLimiter};
use tokio::sync::Semaphore;

use super::log::Outcome;
use crate::date::days_from_civil;
use crate::diag::terminal_safe;

/// One HTTP request, rebuilt for every attempt (Bedrock signs with the attempt's time).
pub struct Request {
    pub url: String,
    /// Header names and values; values may be secrets and are never put into messages.
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

/// What came back from the server.
pub struct Response {
    pub status: u16,
    pub retry_after: Option<Duration>,
    pub body: Vec<u8>,
}

/// How the caller judges a response.
pub enum Verdict<T> {
    Done(T),
    /// Worth another attempt; `after` overrides the backoff (from `Retry-After` or the body).
    Retry {
        reason: String,
        after: Option<Duration>,
    },
    /// Permanent failure (bad request, auth, quota/spend limit).
    Fail(String),
}

/// The result of a call with its bookkeeping.
pub struct Called<T> {
    pub result: Result<T, String>,
    pub attempts: u32,
    /// From the first byte sent to the final result, retries and waits included.
    pub latency: Duration,
    /// Retries after a rate limit (HTTP 429).
    pub rate_limited: u32,
    /// Time spent waiting between attempts (backoff and `Retry-After`).
    pub waited: Duration,
}

/// Retry, timeout and size bounds.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// One attempt, from sending the request to the last byte of the reply.
    pub timeout: Duration,
    pub attempts: u32,
    /// The whole call, every attempt and wait included.
    pub deadline: Duration,
    /// First backoff step; doubles per retry up to `backoff_max`.
    pub backoff_base: Duration,
    pub backoff_max: Duration,
    /// The largest reply body read, in bytes.
    pub max_body: usize,
    /// The longest wait for the next chunk of a reply body once it has started.
    pub stall: Duration,
}

pub use super::DEFAULT_MAX_BODY;

/// Default [`Limits::stall`].
pub const DEFAULT_STALL: Duration = Duration::from_secs(30);

impl Limits {
    pub fn new(timeout: Duration, attempts: u32, deadline: Duration) -> Limits {
        Limits {
            timeout,
            attempts,
            deadline,
            backoff_base: Duration::from_millis(500),
            backoff_max: Duration::from_secs(60),
            max_body: DEFAULT_MAX_BODY,
            stall: DEFAULT_STALL,
        }
    }
}

/// Why an attempt got no response to judge.
enum Failed {
    /// Worth another attempt (connection reset, stalled body).
    Transient(String),
    /// Not worth one (a reply past the size limit would be again).
    Permanent(String),
}

/// Concurrency and rate gate, shared by every client of one provider endpoint.
pub struct Gate {
    sem: Arc<Semaphore>,
    rpm: Option<Arc<DefaultDirectRateLimiter>>,
}

type GateKey = (String, usize, Option<u32>);

impl Gate {
    /// The gate for `key` (provider and endpoint). Clients asking for the same endpoint with the
    /// same limits share one gate, so two models on one server do not double its load.
    pub fn shared(key: &str, concurrency: usize, rpm: Option<u32>) -> Arc<Gate> {
        static GATES: OnceLock<Mutex<HashMap<GateKey, Arc<Gate>>>> = OnceLock::new();
        let map = GATES.get_or_init(Default::default);
        let mut map = map.lock().unwrap_or_else(|p| p.into_inner());
        map.entry((key.to_string(), concurrency, rpm))
            .or_insert_with(|| {
                Arc::new(Gate {
                    sem: Arc::new(Semaphore::new(concurrency.max(1))),
                    rpm: rpm.and_then(NonZeroU32::new).map(|n| Arc::new(RateLimiter::direct(Quota::per_minute(n)))),
                })
            })
            .clone()
    }
}

/// The shared HTTP client (rustls with the ring provider), following no redirect.
pub fn client() -> Result<reqwest::Client, String> {
    static CLIENT: OnceLock<Result<reqwest::Client, String>> = OnceLock::new();
    CLIENT
        .get_or_init(|| {
            let _ = rustls::crypto::ring::default_provider().install_default();
            reqwest::Client::builder()
                .connect_timeout(Duration::from_secs(20))
                .pool_max_idle_per_host(256)
                .redirect(reqwest::redirect::Policy::none())
                .build()
                .map_err(|e| format!("cannot start the HTTP client: {}", e.without_url()))
        })
        .clone()
}

pub struct Transport {
    client: reqwest::Client,
    gate: Arc<Gate>,
    limits: Limits,
    /// What this transport's lines in the request log name ([`super::log`]).
    label: super::log::Label,
}

impl Transport {
    pub fn new(gate: Arc<Gate>, limits: Limits) -> Result<Transport, String> {
        Ok(Transport { client: client()?, gate, limits, label: super::log::Label::default() })
    }

    /// Name the provider and model in the request log, and the credentials scrubbed from it.
    pub fn labelled(self, provider: &str, model: &str, secrets: &[&str]) -> Transport {
        let label = super::log::Label {
            provider: provider.to_string(),
            model: model.to_string(),
            secrets: secrets.iter().map(|s| s.to_string()).collect(),
        };
        Transport { label, ..self }
    }

    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// POST the request built by `build` until `judge` accepts a response, the attempts run
    /// out, or the deadline would pass.
    pub async fn call<T>(
        &self,
        build: impl Fn() -> Result<Request, String>,
        judge: impl Fn(Response) -> Verdict<T>,
    ) -> Called<T> {
        self.call_as(reqwest::Method::POST, build, judge).await
    }

    /// [`Transport::call`] with another method (`GET` for a batch's status and results; the
    /// body is then empty).
    pub async fn call_as<T>(
        &self,
        method: reqwest::Method,
        build: impl Fn() -> Result<Request, String>,
        judge: impl Fn(Response) -> Verdict<T>,
    ) -> Called<T> {
        let mut started: Option<Instant> = None;
        let mut attempt = 0;
        let (mut rate_limited, mut waited) = (0u32, Duration::ZERO);
        loop {
            attempt += 1;
            let queued = Instant::now();
            let mut sent: Option<(SystemTime, Instant, String)> = None;
            let mut status = None;
            let verdict = {
                let Ok(_permit) = self.gate.sem.acquire().await else {
                    return self.end(
                        Err("the request gate was closed".into()),
                        attempt,
                        started,
                        (rate_limited, waited),
                    );
                };
                if let Some(l) = &self.gate.rpm {
                    l.until_ready().await;
                }
                let start = *started.get_or_insert_with(Instant::now);
                let left = self.limits.deadline.saturating_sub(start.elapsed());
                if left.is_zero() {
                    return self.end(
                        Err(deadline_message(self.limits.deadline)),
                        attempt - 1,
                        started,
                        (rate_limited, waited),
                    );
                }
                let req = match build() {
                    Ok(r) => r,
                    Err(e) => return self.end(Err(e), attempt, started, (rate_limited, waited)),
                };
                let timeout = self.limits.timeout.min(left);
                if super::log::enabled() {
                    sent = Some((SystemTime::now(), Instant::now(), super::log::public(&req.url)));
                }
                match tokio::time::timeout(timeout, self.send(method.clone(), req)).await {
                    Err(_) => Verdict::Retry {
                        reason: format!("timed out after {:.1} s", timeout.as_secs_f64()),
                        after: None,
                    },
                    Ok(Err(Failed::Transient(e))) => Verdict::Retry { reason: e, after: None },
                    Ok(Err(Failed::Permanent(e))) => Verdict::Fail(e),
                    Ok(Ok(resp)) => {
                        status = Some(resp.status);
                        judge(resp)
                    }
                }
            };
            let log = |outcome, reason: Option<&str>, wait: Option<Duration>| {
                if let Some((time, at, endpoint)) = &sent {
                    self.log(&method, (*time, *at, endpoint), attempt, status, queued, outcome, reason, wait);
                }
            };
            let (reason, after) = match verdict {
                Verdict::Done(t) => {
                    log(Outcome::Ok, None, None);
                    return self.end(Ok(t), attempt, started, (rate_limited, waited));
                }
                Verdict::Fail(m) => {
                    log(Outcome::Failed, Some(&m), None);
                    return self.end(Err(m), attempt, started, (rate_limited, waited));
                }
                Verdict::Retry { reason, after } => (reason, after),
            };
            if attempt >= self.limits.attempts {
                let msg = format!("{reason} (gave up after {attempt} attempts)");
                log(Outcome::Failed, Some(&msg), None);
                return self.end(Err(msg), attempt, started, (rate_limited, waited));
            }
            let wait = after.unwrap_or_else(|| backoff(&self.limits, attempt));
            let elapsed = started.map_or(Duration::ZERO, |s| s.elapsed());
            if elapsed + wait >= self.limits.deadline {
                let msg = format!(
                    "{reason} (gave up after {attempt} attempts: waiting {:.1} s more would pass the {:.0} s deadline)",
                    wait.as_secs_f64(),
                    self.limits.deadline.as_secs_f64()
                );
                log(Outcome::Failed, Some(&msg), None);
                return self.end(Err(msg), attempt, started, (rate_limited, waited));
            }
            log(Outcome::Retry, Some(&reason), Some(wait));
            if reason.starts_with("HTTP 429") {
                rate_limited += 1;
            }
            waited += wait;
            tokio::time::sleep(wait).await;
        }
    }

    /// One attempt's line in the request log ([`super::log`]).
    #[allow(clippy::too_many_arguments)]
    fn log(
        &self,
        method: &reqwest::Method,
        (time, at, endpoint): (SystemTime, Instant, &str),
        attempt: u32,
        status: Option<u16>,
        queued: Instant,
        outcome: Outcome,
        reason: Option<&str>,
        wait: Option<Duration>,
    ) {
        let line = super::log::Line {
            time: super::log::rfc3339(time),
            provider: &self.label.provider,
            model: &self.label.model,
            method: method.as_str(),
            endpoint: endpoint.to_string(),
            attempt,
            status,
            latency_ms: at.elapsed().as_millis() as u64,
            outcome,
            reason: reason.map(str::to_string),
            queued_ms: at.saturating_duration_since(queued).as_millis() as u64,
            wait_ms: wait.map(|w| w.as_millis() as u64),
            rate_limited: status == Some(429),
        };
        super::log::write(&line, &self.label);
    }

    fn end<T>(
        &self,
        result: Result<T, String>,
        attempts: u32,
        started: Option<Instant>,
        (rate_limited, waited): (u32, Duration),
    ) -> Called<T> {
        Called {
            result,
            attempts: attempts.max(1),
            latency: started.map_or(Duration::ZERO, |s| s.elapsed()),
            rate_limited,
            waited,
        }
    }

    async fn send(&self, method: reqwest::Method, req: Request) -> Result<Response, Failed> {
        let mut rb = self.client.request(method, &req.url);
        if !req.body.is_empty() {
            rb = rb.body(req.body);
        }
        for (k, v) in &req.headers {
            rb = rb.header(k.as_str(), v.as_str());
        }
        // `without_url`: the message must not carry query strings or hosts with credentials.
        let transient = |e: reqwest::Error| Failed::Transient(describe(&e.without_url()));
        let mut resp = rb.send().await.map_err(transient)?;
        let status = resp.status().as_u16();
        if resp.status().is_redirection() {
            let location = resp.headers().get(reqwest::header::LOCATION).and_then(|v| v.to_str().ok());
            return Err(Failed::Permanent(redirect_message(status, &req.url, location)));
        }
        let retry_after = resp
            .headers()
            .get(reqwest::header::RETRY_AFTER)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| parse_retry_after(v, SystemTime::now()));
        let max = self.limits.max_body;
        if resp.content_length().is_some_and(|n| n > max as u64) {
            return Err(Failed::Permanent(too_large(max)));
        }
        let mut body = Vec::new();
        loop {
            let chunk = match tokio::time::timeout(self.limits.stall, resp.chunk()).await {
                Err(_) => {
                    let s = self.limits.stall.as_secs_f64();
                    return Err(Failed::Transient(format!(
                        "the reply stalled: no data for {s:.1} s after {} bytes",
                        body.len()
                    )));
                }
                Ok(chunk) => chunk.map_err(transient)?,
            };
            let Some(chunk) = chunk else { break };
            if body.len() + chunk.len() > max {
                return Err(Failed::Permanent(too_large(max)));
            }
            body.extend_from_slice(&chunk);
        }
        Ok(Response { status, retry_after, body })
    }
}

/// Why a 3xx reply ends the call: it names where the redirect pointed (its host and port only:
/// a path or query may hold a token) and what to do.
fn redirect_message(status: u16, url: &str, location: Option<&str>) -> String {
    let target = location.and_then(|l| reqwest::Url::parse(url).ok()?.join(l).ok()).and_then(|u| {
        let host = u.host_str()?.to_string();
        Some(match u.port() {
            Some(p) => format!("{host}:{p}"),
            None => host,
        })
    });
    match target {
        Some(host) => format!(
            "the endpoint redirected (HTTP {status}) to `{}`; Revelio follows no redirect, which would carry the key and the request elsewhere: if that host is the right one, give it as the base URL",
            terminal_safe(&host)
        ),
        None => format!(
            "the endpoint answered HTTP {status} (a redirect) without a usable `Location`; Revelio follows no redirect"
        ),
    }
}

fn too_large(max: usize) -> String {
    format!("the reply is larger than {} (`max_reply_mb` in the model config); nothing past that was read", mib(max))
}

/// Bytes as MiB for messages: `4 MiB`, `0.5 MiB`.
fn mib(bytes: usize) -> String {
    let m = bytes as f64 / f64::from(1u32 << 20);
    if m.fract() == 0.0 { format!("{m:.0} MiB") } else { format!("{m} MiB") }
}

fn describe(e: &reqwest::Error) -> String {
    use std::error::Error;
    let mut msg = e.to_string();
    let mut src = e.source();
    while let Some(s) = src {
        msg.push_str(": ");
        msg.push_str(&s.to_string());
        src = s.source();
    }
    terminal_safe(&msg).into_owned()
}

fn deadline_message(deadline: Duration) -> String {
    format!("the call passed its {:.0} s deadline", deadline.as_secs_f64())
}

/// Exponential backoff with jitter, so a burst of throttled calls does not retry in lockstep.
fn backoff(limits: &Limits, attempt: u32) -> Duration {
    let exp = limits.backoff_base.saturating_mul(1u32 << attempt.saturating_sub(1).min(16));
    let capped = exp.min(limits.backoff_max);
    let nanos = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    // Between 50% and 100% of the step.
    capped.mul_f64(0.5 + 0.5 * f64::from(nanos % 1000) / 1000.0)
}

/// The standard retry rule by status: 408, 409 (lock conflicts), 429 and 5xx (incl. Anthropic's
/// 529) are transient; other 4xx are not.
pub fn is_transient(status: u16) -> bool {
    matches!(status, 408 | 409 | 429) || (500..600).contains(&status)
}

/// `Retry-After` as seconds or an HTTP date (RFC 9110 §10.2.3).
pub fn parse_retry_after(v: &str, now: SystemTime) -> Option<Duration> {
    let v = v.trim();
    if let Ok(secs) = v.parse::<f64>() {
        return (secs.is_finite() && secs >= 0.0).then(|| Duration::from_secs_f64(secs.min(86_400.0)));
    }
    let at = parse_http_date(v)?;
    Some(at.duration_since(now).unwrap_or(Duration::ZERO))
}

/// IMF-fixdate, e.g. `Wed, 21 Oct 2015 07:28:00 GMT`.
pub fn parse_http_date(v: &str) -> Option<SystemTime> {
    let parts: Vec<&str> = v.split_whitespace().collect();
    let [_, day, mon, year, time, "GMT"] = parts.as_slice() else { return None };
    const MONTHS: [&str; 12] = ["Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"];
    let month = MONTHS.iter().position(|m| m == mon)? as u32 + 1;
    let day: u32 = day.parse().ok()?;
    let year: i64 = year.parse().ok()?;
    let hms: Vec<u64> = time.split(':').map(|p| p.parse().ok()).collect::<Option<_>>()?;
    let [h, m, s] = hms.as_slice() else { return None };
    if !(1..=31).contains(&day) || *h > 23 || *m > 59 || *s > 60 {
        return None;
    }
    let days = days_from_civil(year, month, day);
    let secs = days.checked_mul(86_400)? + (*h * 3600 + *m * 60 + *s) as i64;
    (secs >= 0).then(|| SystemTime::UNIX_EPOCH + Duration::from_secs(secs as u64))
}

/// A provider error body's message, shortened (error bodies can be long HTML pages) and safe to
/// print (a body's escape sequences must not reach a terminal).
pub fn snippet(body: &[u8]) -> String {
    let text = String::from_utf8_lossy(body);
    let one_line: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
    let short = if one_line.chars().count() > 300 {
        format!("{}…", one_line.chars().take(300).collect::<String>())
    } else {
        one_line
    };
    terminal_safe(&short).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retry_after_seconds_and_dates() {
        let now = SystemTime::UNIX_EPOCH + Duration::from_secs(1_445_412_480); // Wed, 21 Oct 2015 07:28:00 GMT
        assert_eq!(parse_retry_after("0", now), Some(Duration::ZERO));
        assert_eq!(parse_retry_after(" 7 ", now), Some(Duration::from_secs(7)));
        assert_eq!(parse_retry_after("1.5", now), Some(Duration::from_millis(1500)));
        assert_eq!(parse_retry_after("Wed, 21 Oct 2015 07:28:30 GMT", now), Some(Duration::from_secs(30)));
        // A date in the past means "now".
        assert_eq!(parse_retry_after("Wed, 21 Oct 2015 07:00:00 GMT", now), Some(Duration::ZERO));
        assert_eq!(parse_retry_after("-3", now), None);
        assert_eq!(parse_retry_after("soon", now), None);
        assert_eq!(parse_retry_after("Wed, 21 Foo 2015 07:28:30 GMT", now), None);
    }

    #[test]
    fn transient_statuses() {
        for s in [408, 429, 500, 502, 503, 504, 529] {
            assert!(is_transient(s), "{s}");
        }
        for s in [400, 401, 403, 404, 413, 422] {
            assert!(!is_transient(s), "{s}");
        }
    }

    #[test]
    fn backoff_grows_and_is_capped() {
        let l = Limits::new(Duration::from_secs(1), 5, Duration::from_secs(10));
        assert!(backoff(&l, 1) <= Duration::from_millis(500));
        assert!(backoff(&l, 3) >= Duration::from_secs(1));
        assert!(backoff(&l, 30) <= Duration::from_secs(60));
    }

    #[test]
    fn redirects_name_the_host_they_point_to() {
        let m = redirect_message(307, "https://api.example.com/v1/x", Some("https://evil.example:8443/steal?key=k"));
        assert!(m.starts_with("the endpoint redirected (HTTP 307) to `evil.example:8443`;"), "{m}");
        assert!(!m.contains("steal") && !m.contains("key=k"), "{m}");
        let m = redirect_message(302, "http://127.0.0.1:9/v1/x", Some("/elsewhere"));
        assert!(m.contains("to `127.0.0.1:9`"), "{m}");
        assert!(redirect_message(301, "https://h/x", None).contains("without a usable `Location`"));
    }

    #[test]
    fn snippets_are_short_single_lines() {
        assert_eq!(snippet(b"bad\n  request"), "bad request");
        assert_eq!(snippet(&[b'x'; 1000]).chars().count(), 301);
        assert_eq!(snippet(b"\x1b[2Jgone"), "\\u{1b}[2Jgone");
    }
}

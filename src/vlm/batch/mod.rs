//! `--batch-api`: a model whose questions go to its provider's batch API (OpenAI Batch,
//! Anthropic Message Batches, Gemini batch mode) at half the price, for work that needs no
//! answer before the next question (`validate`, `probe`, `transfer`, `random` search).
//!
//! [`BatchModel`] is an ordinary [`Model`]: the evaluator asks it as it asks a live model, many
//! questions in flight. It collects them until no new one has come for `batch_collect_s` (or a
//! batch is full), submits them as one batch, looks at the batch with a bounded backoff
//! (`batch_poll_s`, doubling up to 20 times that and at most 10 minutes), printing its progress,
//! and answers each question from the batch's results.
//!
//! Nothing is paid twice: every submitted batch is journaled in `batches.jsonl` in the run
//! folder (its id and the keys of its requests: a hash of the model, image and prompt) before
//! anything else happens, so a killed process that is run again finds the pending batch and
//! looks at it instead of submitting the same requests again. A request that failed in a batch
//! (an errored, cancelled or expired item, a result that does not parse) is journaled as
//! failed and becomes an `api_error` observation; the same command run again sends it in a new
//! batch (or live, without `--batch-api`).
//!
//! Where requests go: every URL is built from the configured base URL and an id checked to be
//! a plain provider id ([`checked_id`]); a URL in a reply (Anthropic's `results_url`) is never
//! followed, and no redirect either ([`crate::net::http`]), so the key goes nowhere else.

pub mod anthropic;
pub mod gemini;
pub mod openai;

use std::collections::{HashMap, HashSet};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};
use serde_json::Value;
use tokio::sync::oneshot;

use crate::net::ProviderError;
use crate::net::http::{Gate, Limits, Request, Response, Transport, Verdict};
use crate::vlm::api::{ApiModel, Parsed, Protocol, error_reply, reply_from};
use crate::vlm::cost::Spend;
use crate::vlm::{BoxFuture, Model, Query, Reply};

/// The file in the run folder that journals submitted batches.
pub const JOURNAL: &str = "batches.jsonl";

/// Observations in flight with `--batch-api` when `--concurrency` is not given: the most
/// requests one batch collects.
pub const DEFAULT_BATCH_SIZE: usize = 1000;

/// One request of a batch: its key (the batch's `custom_id`) and the live API's request body.
#[derive(Debug, Clone)]
pub struct Item {
    pub key: String,
    pub body: Value,
}

/// The result of one request as a batch reports it.
#[derive(Debug, Clone, PartialEq)]
pub enum ItemResult {
    /// The live API's response body, to be read by the provider's parser.
    Body(Vec<u8>),
    /// Why the request got no answer (an errored, cancelled or expired item).
    Failed(String),
}

/// What a look at a batch found.
#[derive(Debug)]
pub enum Poll {
    /// Still running: a progress text (`in_progress: 120/400 done, 3 failed`).
    Running(String),
    /// Ended: the results by key, and why a request without one got none.
    Ended { results: HashMap<String, ItemResult>, missing: String },
}

/// Why a batch could not be looked at.
#[derive(Debug)]
pub struct PollError {
    pub message: String,
    /// The provider does not know the batch (HTTP 404): looking again will not help.
    pub gone: bool,
}

/// One provider's batch API.
pub trait Wire: Send + Sync + 'static {
    fn provider(&self) -> &'static str;
    /// The most requests and request bytes one batch may hold.
    fn limits(&self) -> (usize, usize);
    /// Submit `items` as one batch; its id.
    fn submit<'a>(&'a self, ops: &'a Ops, items: &'a [Item]) -> BoxFuture<'a, Result<String, String>>;
    /// Look at batch `id`, whose requests' keys are `keys` in submitted order.
    fn poll<'a>(&'a self, ops: &'a Ops, id: &'a str, keys: &'a [String]) -> BoxFuture<'a, Result<Poll, PollError>>;
}

/// `id` if it is a plain provider id: `prefix` then 1 to 128 ASCII letters, digits, `_` or
/// `-` — nothing that could change the host or path of a URL built from it.
pub fn checked_id<'a>(id: &'a str, prefix: &str, what: &str) -> Result<&'a str, String> {
    let rest = id.strip_prefix(prefix).unwrap_or("");
    if !rest.is_empty()
        && rest.len() <= 128
        && rest.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-')
    {
        Ok(id)
    } else {
        let shown = crate::net::http::snippet(&id.as_bytes()[..id.len().min(80)]);
        Err(format!(
            "the provider returned a malformed {what} id `{shown}` (expected `{prefix}` and letters, digits, `_` or `-`)"
        ))
    }
}

/// The provider's reading of an error body (its live protocol's).
type ErrorReader = Box<dyn Fn(u16, &[u8]) -> ProviderError + Send + Sync>;

/// Requests in submitted batches whose result has not been read: key → (batch, the batch's
/// keys in order).
type Pending = HashMap<String, (String, Arc<Vec<String>>)>;

/// The HTTP calls of a batch API (submit, status, results), through the same resilient path as
/// live calls, with room for large result files.
pub struct Ops {
    transport: Transport,
    error: ErrorReader,
}

/// A failed batch API call: its HTTP status (0: none) and message.
#[derive(Debug)]
pub struct OpsError {
    pub status: u16,
    pub message: String,
}

impl From<OpsError> for String {
    fn from(e: OpsError) -> String {
        e.message
    }
}

impl From<OpsError> for PollError {
    fn from(e: OpsError) -> PollError {
        PollError { gone: e.status == 404, message: e.message }
    }
}

impl Ops {
    /// One call: `GET` when `body` is empty, else `POST`; the 2xx body.
    pub async fn send(&self, url: &str, headers: &[(String, String)], body: Vec<u8>) -> Result<Vec<u8>, OpsError> {
        let method = if body.is_empty() { reqwest::Method::GET } else { reqwest::Method::POST };
        let build = || Ok(Request { url: url.to_string(), headers: headers.to_vec(), body: body.clone() });
        let judge = |r: Response| -> Verdict<Result<Vec<u8>, OpsError>> {
            if (200..300).contains(&r.status) {
                return Verdict::Done(Ok(r.body));
            }
            let e = (self.error)(r.status, &r.body);
            let message = format!("HTTP {}: {}", r.status, e.message);
            if e.permanent || !crate::net::http::is_transient(r.status) {
                Verdict::Done(Err(OpsError { status: r.status, message }))
            } else {
                Verdict::Retry { reason: message, after: r.retry_after.or(e.retry_after) }
            }
        };
        let called = self.transport.call_as(method, build, judge).await;
        match called.result {
            Ok(r) => r,
            Err(message) => Err(OpsError { status: 0, message }),
        }
    }
}

/// One line of `batches.jsonl`.
#[derive(Debug, Serialize, Deserialize)]
struct LogLine {
    model: String,
    endpoint: String,
    batch: String,
    /// The keys of the requests submitted in the batch, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    submitted: Vec<String>,
    /// Keys whose request failed in the batch: asked again in a new one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    failed: Vec<String>,
}

/// The batches of one model at one endpoint, journaled in a run folder.
struct BatchLog {
    path: PathBuf,
    model: String,
    endpoint: String,
}

/// One writer at a time in this process (`transfer` asks several models, one log).
static LOG_LOCK: Mutex<()> = Mutex::new(());

impl BatchLog {
    /// The pending batches: key → (batch, the batch's keys in order).
    fn load(&self) -> Result<Pending, String> {
        let text = match std::fs::read_to_string(&self.path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(HashMap::new()),
            Err(e) => return Err(format!("cannot read `{}`: {e}", self.path.display())),
        };
        let mut out = HashMap::new();
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let l: LogLine = match serde_json::from_str(line) {
                Ok(l) => l,
                // A line cut short by a killed process: the batch it named was never read back.
                Err(_) if i + 1 == lines.len() && !text.ends_with('\n') => continue,
                Err(e) => {
                    return Err(format!("line {} of `{}` is not a batch record: {e}", i + 1, self.path.display()));
                }
            };
            if l.model != self.model || l.endpoint != self.endpoint {
                continue;
            }
            let keys = Arc::new(l.submitted.clone());
            for k in l.submitted {
                out.insert(k, (l.batch.clone(), keys.clone()));
            }
            for k in l.failed {
                if out.get(&k).is_some_and(|(b, _)| *b == l.batch) {
                    out.remove(&k);
                }
            }
        }
        Ok(out)
    }

    fn append(&self, batch: &str, submitted: &[String], failed: &[String]) -> Result<(), String> {
        let line = LogLine {
            model: self.model.clone(),
            endpoint: self.endpoint.clone(),
            batch: batch.to_string(),
            submitted: submitted.to_vec(),
            failed: failed.to_vec(),
        };
        let mut text = serde_json::to_string(&line).expect("batch records serialise");
        text.push('\n');
        let _guard = LOG_LOCK.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| format!("cannot create `{}`: {e}", dir.display()))?;
        }
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&self.path)
            .map_err(|e| format!("cannot open `{}`: {e}", self.path.display()))?;
        f.write_all(text.as_bytes())
            .and_then(|()| f.sync_data())
            .map_err(|e| format!("cannot write `{}`: {e}", self.path.display()))
    }
}

/// What became of one request: its batch and its parsed reply, or why it has none.
type Delivered = (String, Result<Parsed, String>);

#[derive(Default)]
struct State {
    /// Requests waiting to be submitted.
    queue: Vec<Item>,
    collecting: bool,
    pending: Pending,
    /// Batches being looked at by a task of this process.
    polling: HashSet<String>,
    waiters: HashMap<String, Vec<oneshot::Sender<Delivered>>>,
    /// Results read before anyone asked for them (a resumed batch holds more than is asked).
    ready: HashMap<String, Delivered>,
    /// Questions asked so far per [`item_key`]: the same image and prompt asked twice (two
    /// observations of one scene) is two requests, as it is live.
    asked: HashMap<String, u32>,
}

struct Inner<P: Protocol, W: Wire> {
    live: Arc<ApiModel<P>>,
    wire: W,
    ops: Ops,
    log: BatchLog,
    state: Mutex<State>,
}

/// A model asked through its provider's batch API (see the module docs).
pub struct BatchModel<P: Protocol, W: Wire> {
    inner: Arc<Inner<P, W>>,
}

impl<P: Protocol, W: Wire> BatchModel<P, W> {
    /// `live` gives the requests, the parsing, the prices, the cache and the endpoint; `dir` is
    /// the run folder whose `batches.jsonl` journals the batches.
    pub fn new(live: ApiModel<P>, wire: W, dir: &Path) -> Result<BatchModel<P, W>, String> {
        let live = Arc::new(live);
        let s = live.settings();
        let endpoint = live.endpoint().unwrap_or_default();
        let mut limits = Limits::new(
            s.timeout.max(Duration::from_secs(600)),
            s.retry_attempts,
            s.retry_deadline.max(Duration::from_secs(900)),
        );
        limits.backoff_base = s.retry_backoff;
        limits.stall = s.stall_timeout;
        // Result files hold every reply of a batch.
        limits.max_body = 1 << 30;
        let gate = Gate::shared(&format!("{} {endpoint} batch", wire.provider()), 4, s.requests_per_minute);
        let errors = live.clone();
        let transport = Transport::new(gate, limits)?.labelled(
            &format!("{} batch", wire.provider()),
            &live.id(),
            &live.proto().secrets(),
        );
        let ops = Ops { transport, error: Box::new(move |s, b| errors.proto().error(s, b)) };
        let log = BatchLog { path: dir.join(JOURNAL), model: live.id(), endpoint };
        let pending = log.load()?;
        let state = Mutex::new(State { pending, ..State::default() });
        Ok(BatchModel { inner: Arc::new(Inner { live, wire, ops, log, state }) })
    }
}

/// The key of a question: a hash of the model, the image and the prompt. The `n`-th question
/// with the same key in a process is request `{key}-{n}` (the batch's `custom_id`: letters,
/// digits and `-`, as every provider takes), so a resumed run finds the same requests again.
pub fn item_key(model: &str, q: &Query) -> String {
    let h = crate::hash::parts_hex([model.as_bytes(), q.image_hash.as_bytes(), q.prompt.as_bytes()]);
    format!("rv{}", &h[..40])
}

impl<P: Protocol, W: Wire> Inner<P, W> {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A line on stderr, scrubbed of credentials (a provider's error body may echo one).
    fn say(&self, text: &str) {
        let text = crate::net::secret::redact(text.to_string(), &self.live.proto().secrets());
        eprintln!("{}: {}", self.wire.provider(), crate::diag::terminal_safe(&text));
    }

    /// The live request body of `q`.
    fn body(&self, q: &Query) -> Result<Value, String> {
        let image = self.live.encode(q)?;
        let req = self.live.proto().request(&q.prompt, image.as_ref())?;
        serde_json::from_slice(&req.body).map_err(|e| format!("cannot read back the request body: {e}"))
    }
}

fn start_polling<P: Protocol, W: Wire>(inner: &Arc<Inner<P, W>>, st: &mut State, batch: &str, keys: Arc<Vec<String>>) {
    if st.polling.insert(batch.to_string()) {
        let inner = inner.clone();
        let batch = batch.to_string();
        tokio::spawn(async move { poll_loop(inner, batch, keys).await });
    }
}

/// Collect requests until none has come for `batch_collect_s` or a batch is full, then submit.
async fn collect<P: Protocol, W: Wire>(inner: Arc<Inner<P, W>>) {
    let (max_items, max_bytes) = inner.wire.limits();
    let window = inner.live.settings().batch_collect;
    let mut seen = 0;
    loop {
        tokio::time::sleep(window).await;
        let items = {
            let mut st = inner.lock();
            let n = st.queue.len();
            if n == 0 {
                st.collecting = false;
                return;
            }
            if n != seen && n < max_items {
                seen = n;
                continue;
            }
            seen = 0;
            std::mem::take(&mut st.queue)
        };
        for chunk in chunks(items, max_items, max_bytes) {
            submit(&inner, chunk).await;
        }
    }
}

/// `items` in batches of at most `max_items` requests and about `max_bytes` of request bodies.
fn chunks(items: Vec<Item>, max_items: usize, max_bytes: usize) -> Vec<Vec<Item>> {
    let mut out: Vec<Vec<Item>> = Vec::new();
    let mut bytes = 0;
    for item in items {
        let size = item.body.to_string().len() + 200;
        match out.last_mut() {
            Some(last) if last.len() < max_items && bytes + size <= max_bytes => {
                bytes += size;
                last.push(item);
            }
            _ => {
                bytes = size;
                out.push(vec![item]);
            }
        }
    }
    out
}

async fn submit<P: Protocol, W: Wire>(inner: &Arc<Inner<P, W>>, items: Vec<Item>) {
    let keys: Vec<String> = items.iter().map(|i| i.key.clone()).collect();
    match inner.wire.submit(&inner.ops, &items).await {
        Ok(id) => {
            if let Err(e) = inner.log.append(&id, &keys, &[]) {
                inner.say(&format!("warning: {e}; a killed run cannot find batch `{id}` again"));
            }
            inner.say(&format!(
                "batch `{id}` submitted: {} requests at half price; waiting for its results",
                keys.len()
            ));
            let keys = Arc::new(keys);
            let mut st = inner.lock();
            for k in keys.iter() {
                st.pending.insert(k.clone(), (id.clone(), keys.clone()));
            }
            start_polling(inner, &mut st, &id, keys);
        }
        Err(e) => {
            let message = format!("cannot submit a batch of {} requests: {e}", keys.len());
            inner.say(&message);
            let mut st = inner.lock();
            for k in keys {
                for tx in st.waiters.remove(&k).unwrap_or_default() {
                    let _ = tx.send((String::new(), Err(message.clone())));
                }
            }
        }
    }
}

/// The next wait between looks: doubled, at most 20 times the first and 10 minutes.
fn next_wait(wait: Duration, first: Duration) -> Duration {
    (wait * 2).min(first * 20).min(Duration::from_secs(600)).max(first)
}

async fn poll_loop<P: Protocol, W: Wire>(inner: Arc<Inner<P, W>>, batch: String, keys: Arc<Vec<String>>) {
    let first = inner.live.settings().batch_poll;
    let mut wait = first;
    let mut errors = 0;
    loop {
        match inner.wire.poll(&inner.ops, &batch, &keys).await {
            Ok(Poll::Running(progress)) => {
                errors = 0;
                inner.say(&format!("batch `{batch}` {progress}; next look in {:.0} s", wait.as_secs_f64()));
            }
            Ok(Poll::Ended { results, missing }) => {
                deliver(&inner, &batch, &keys, results, &missing);
                return;
            }
            Err(e) if e.gone => {
                let why = format!("batch `{batch}` is unknown to the provider ({})", e.message);
                deliver(&inner, &batch, &keys, HashMap::new(), &why);
                return;
            }
            Err(e) => {
                errors += 1;
                if errors >= 3 {
                    let message = format!(
                        "cannot look at batch `{batch}`: {}; it stays journaled in `{JOURNAL}` and the same command looks at it again",
                        e.message
                    );
                    inner.say(&message);
                    let mut st = inner.lock();
                    st.polling.remove(&batch);
                    for k in keys.iter() {
                        for tx in st.waiters.remove(k).unwrap_or_default() {
                            let _ = tx.send((batch.clone(), Err(message.clone())));
                        }
                    }
                    return;
                }
            }
        }
        tokio::time::sleep(wait).await;
        wait = next_wait(wait, first);
    }
}

/// Hand an ended batch's results to the questions waiting for them (or keep them for questions
/// still to come); journal the requests that failed, so they go into a new batch next time.
fn deliver<P: Protocol, W: Wire>(
    inner: &Arc<Inner<P, W>>,
    batch: &str,
    keys: &[String],
    mut results: HashMap<String, ItemResult>,
    missing: &str,
) {
    let again = "not answered: the same command sends it again in a new batch (or live, without `--batch-api`)";
    let mut failed = Vec::new();
    let mut delivered = Vec::new();
    for k in keys {
        let r = match results.remove(k) {
            Some(ItemResult::Body(body)) => inner
                .live
                .proto()
                .parse(&body)
                .map_err(|e| format!("the result of this request in batch `{batch}` is malformed ({e}); {again}")),
            Some(ItemResult::Failed(why)) => Err(format!("this request failed in batch `{batch}`: {why}; {again}")),
            None => Err(format!("{missing}; {again}")),
        };
        if r.is_err() {
            failed.push(k.clone());
        }
        delivered.push((k.clone(), r));
    }
    if !failed.is_empty()
        && let Err(e) = inner.log.append(batch, &[], &failed)
    {
        inner.say(&format!("warning: {e}"));
    }
    inner.say(&format!("batch `{batch}` ended: {} answered, {} failed", keys.len() - failed.len(), failed.len()));
    let mut st = inner.lock();
    st.polling.remove(batch);
    for (k, r) in delivered {
        if st.pending.get(&k).is_some_and(|(b, _)| b == batch) {
            st.pending.remove(&k);
        }
        match st.waiters.remove(&k) {
            Some(txs) => {
                for tx in txs {
                    let _ = tx.send((batch.to_string(), r.clone()));
                }
            }
            None => {
                st.ready.insert(k, (batch.to_string(), r));
            }
        }
    }
}

impl<P: Protocol, W: Wire> BatchModel<P, W> {
    async fn ask_batched(&self, q: &Query) -> Reply {
        let inner = &self.inner;
        if let Some(hit) = inner.live.cached(q) {
            return hit;
        }
        let base = item_key(&inner.live.id(), q);
        let started = Instant::now();
        let (rx, new, key) = {
            let mut st = inner.lock();
            let n = st.asked.entry(base.clone()).or_default();
            let key = format!("{base}-{n}");
            *n += 1;
            if let Some(d) = st.ready.remove(&key) {
                drop(st);
                return self.answer(q, d, started);
            }
            let (tx, rx) = oneshot::channel();
            let first = !st.waiters.contains_key(&key);
            st.waiters.entry(key.clone()).or_default().push(tx);
            let mut new = false;
            if first {
                match st.pending.get(&key).cloned() {
                    Some((batch, keys)) => start_polling(inner, &mut st, &batch, keys),
                    None => new = !st.queue.iter().any(|i| i.key == key),
                }
            }
            (rx, new, key)
        };
        if new {
            match inner.body(q) {
                Ok(body) => {
                    let mut st = inner.lock();
                    st.queue.push(Item { key: key.clone(), body });
                    if !st.collecting {
                        st.collecting = true;
                        tokio::spawn(collect(inner.clone()));
                    }
                }
                Err(e) => {
                    let mut st = inner.lock();
                    for tx in st.waiters.remove(&key).unwrap_or_default() {
                        let _ = tx.send((String::new(), Err(e.clone())));
                    }
                }
            }
        }
        match rx.await {
            Ok(d) => self.answer(q, d, started),
            Err(_) => inner
                .live
                .keep(q, error_reply("the batch ended without an answer to this request".into(), 1, started.elapsed())),
        }
    }

    fn answer(&self, q: &Query, (_, r): Delivered, started: Instant) -> Reply {
        let live = &self.inner.live;
        let reply = match r {
            Ok(p) => reply_from(q, p, live.prices().batch(), started.elapsed(), 1),
            Err(e) => error_reply(e, 1, started.elapsed()),
        };
        live.keep(q, reply)
    }
}

impl<P: Protocol, W: Wire> Model for BatchModel<P, W> {
    fn id(&self) -> String {
        self.inner.live.id()
    }

    fn ask<'a>(&'a self, query: &'a Query) -> BoxFuture<'a, Reply> {
        Box::pin(self.ask_batched(query))
    }

    fn spend(&self) -> Option<Spend> {
        self.inner.live.spend()
    }

    fn concurrency(&self) -> Option<usize> {
        Some(DEFAULT_BATCH_SIZE)
    }

    fn endpoint(&self) -> Option<String> {
        self.inner.live.endpoint()
    }
}

/// The lines of a JSONL results file as JSON objects; a line that is not one is named in
/// `bad` (its request then has no result and fails with that reason).
pub fn jsonl(body: &[u8], bad: &mut Vec<String>) -> Vec<Value> {
    let text = String::from_utf8_lossy(body);
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        match serde_json::from_str::<Value>(line) {
            Ok(v @ Value::Object(_)) => out.push(v),
            Ok(_) => bad.push(format!("line {} is not a JSON object", i + 1)),
            Err(e) => bad.push(format!("line {} is malformed: {e}", i + 1)),
        }
    }
    out
}

/// Why a request of an ended batch has no result, with the malformed lines seen.
pub fn missing_reason(batch: &str, status: &str, bad: &[String]) -> String {
    let mut m = format!("batch `{batch}` ended ({status}) without a result for this request");
    if !bad.is_empty() {
        m.push_str(&format!(" (its results file: {})", bad.join("; ")));
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_checked_before_a_url_is_built_from_them() {
        assert!(checked_id("batch_abc-1", "batch_", "batch").is_ok());
        assert!(checked_id("batches/x1", "batches/", "batch").is_ok());
        for bad in ["batch_", "batch_a/../x", "batch_a?x", "file-1", "batch_a@evil.example", "batch_a b"] {
            let e = checked_id(bad, "batch_", "batch").unwrap_err();
            assert!(e.starts_with("the provider returned a malformed batch id"), "{e}");
        }
        assert!(checked_id(&format!("batch_{}", "a".repeat(129)), "batch_", "batch").is_err());
    }

    #[test]
    fn batches_split_by_count_and_bytes() {
        let item = |k: &str| Item { key: k.into(), body: serde_json::json!({"x": "y".repeat(100)}) };
        let items: Vec<Item> = (0..5).map(|i| item(&i.to_string())).collect();
        let sizes: Vec<usize> = chunks(items.clone(), 2, 1 << 20).iter().map(Vec::len).collect();
        assert_eq!(sizes, vec![2, 2, 1]);
        let sizes: Vec<usize> = chunks(items, 100, 700).iter().map(Vec::len).collect();
        assert_eq!(sizes, vec![2, 2, 1]);
    }

    #[test]
    fn polling_backs_off_within_bounds() {
        let first = Duration::from_secs(30);
        let mut w = first;
        let mut seen = vec![];
        for _ in 0..8 {
            w = next_wait(w, first);
            seen.push(w.as_secs());
        }
        assert_eq!(seen, vec![60, 120, 240, 480, 600, 600, 600, 600]);
        let tiny = Duration::from_millis(10);
        assert_eq!(next_wait(Duration::from_secs(1), tiny), Duration::from_millis(200));
    }

    #[test]
    fn journal_lines_name_pending_and_failed_requests() {
        let dir = tempfile::tempdir().unwrap();
        let log = BatchLog { path: dir.path().join(JOURNAL), model: "m".into(), endpoint: "e".into() };
        log.append("b1", &["k1".into(), "k2".into()], &[]).unwrap();
        log.append("b1", &[], &["k2".into()]).unwrap();
        let other = BatchLog {
            model: "other".into(),
            ..BatchLog { path: log.path.clone(), model: String::new(), endpoint: "e".into() }
        };
        other.append("b9", &["k3".into()], &[]).unwrap();
        let pending = log.load().unwrap();
        assert_eq!(pending.keys().collect::<Vec<_>>(), vec!["k1"]);
        assert_eq!(pending["k1"].0, "b1");
        // A torn last line (a killed write) is left out; a torn line elsewhere is an error.
        std::fs::OpenOptions::new()
            .append(true)
            .open(&log.path)
            .unwrap()
            .write_all(b"{\"model\":\"m\",\"endp")
            .unwrap();
        assert_eq!(log.load().unwrap().len(), 1);
        std::fs::OpenOptions::new().append(true).open(&log.path).unwrap().write_all(b"\n").unwrap();
        assert!(log.load().unwrap_err().contains("is not a batch record"));
    }
}

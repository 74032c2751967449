//! Anthropic Message Batches: `POST /v1/messages/batches` with `{"requests": [{"custom_id",
//! "params"}]}`, looked at with `GET /v1/messages/batches/{id}`, its results read from `GET
//! /v1/messages/batches/{id}/results` — built from the checked id on the configured host. The
//! `results_url` a reply carries is never followed: where it names another host, that is said
//! once and ignored.

use std::collections::HashMap;
use std::sync::Once;

use serde_json::{Value, json};

use super::{ItemResult, Ops, Poll, PollError, Wire, checked_id, jsonl, missing_reason};
use crate::net::json as j;
use crate::vlm::BoxFuture;
use crate::vlm::anthropic::Anthropic;

pub struct AnthropicBatch {
    base: String,
    auth: Vec<(String, String)>,
    foreign: Once,
}

impl AnthropicBatch {
    pub fn new(proto: &Anthropic) -> AnthropicBatch {
        AnthropicBatch { base: proto.base().to_string(), auth: proto.auth(), foreign: Once::new() }
    }

    /// Say once that a reply's `results_url` points away from the configured host.
    fn check_results_url(&self, b: &Value) {
        let Some(url) = j::str_at(b, &["results_url"]) else { return };
        let host = |u: &str| {
            reqwest::Url::parse(u).ok().map(|u| (u.host_str().map(str::to_string), u.port_or_known_default()))
        };
        if host(url) != host(&self.base) {
            self.foreign.call_once(|| {
                let shown = match host(url) {
                    Some((Some(h), Some(p))) => format!("{h}:{p}"),
                    Some((Some(h), None)) => h,
                    _ => "?".into(),
                };
                eprintln!(
                    "anthropic batch: note: the batch names its results at `{}`, not the configured endpoint; Revelio reads them from the configured endpoint only",
                    crate::diag::terminal_safe(&shown)
                );
            });
        }
    }
}

/// The create body.
pub fn create_body(items: &[super::Item]) -> Value {
    let requests: Vec<Value> = items.iter().map(|i| json!({"custom_id": i.key, "params": i.body})).collect();
    json!({ "requests": requests })
}

/// Read result lines (`{"custom_id", "result": {"type": "succeeded" | "errored" | "canceled" |
/// "expired", …}}`).
fn read_lines(body: &[u8], out: &mut HashMap<String, ItemResult>, bad: &mut Vec<String>) {
    for line in jsonl(body, bad) {
        let Some(id) = line.get("custom_id").and_then(Value::as_str) else {
            bad.push("a line without `custom_id`".into());
            continue;
        };
        let result = match j::str_at(&line, &["result", "type"]) {
            Some("succeeded") => match line.pointer("/result/message") {
                Some(m) => ItemResult::Body(m.to_string().into_bytes()),
                None => ItemResult::Failed("a `succeeded` result without `message`".into()),
            },
            Some("errored") => {
                let e = line.pointer("/result/error/error").or_else(|| line.pointer("/result/error"));
                let message = e.and_then(|e| e.get("message")).and_then(Value::as_str).unwrap_or("no message");
                let kind = e.and_then(|e| e.get("type")).and_then(Value::as_str).unwrap_or("error");
                ItemResult::Failed(format!("{} ({kind})", crate::net::http::snippet(message.as_bytes())))
            }
            Some("canceled") => ItemResult::Failed("the batch was canceled before this request was answered".into()),
            Some("expired") => {
                ItemResult::Failed("the batch expired (its 24 h window passed) before this request was answered".into())
            }
            other => ItemResult::Failed(format!(
                "unknown result type `{}`",
                crate::net::http::snippet(other.unwrap_or("").as_bytes())
            )),
        };
        out.insert(id.to_string(), result);
    }
}

impl Wire for AnthropicBatch {
    fn provider(&self) -> &'static str {
        "anthropic batch"
    }

    fn limits(&self) -> (usize, usize) {
        // Anthropic: 100,000 requests or 256 MB per batch.
        (100_000, 250 << 20)
    }

    fn submit<'a>(&'a self, ops: &'a Ops, items: &'a [super::Item]) -> BoxFuture<'a, Result<String, String>> {
        Box::pin(async move {
            let mut headers = vec![("content-type".to_string(), "application/json".to_string())];
            headers.extend(self.auth.iter().cloned());
            let url = format!("{}/v1/messages/batches", self.base);
            let body = ops.send(&url, &headers, create_body(items).to_string().into_bytes()).await?;
            let b = j::object(&body).map_err(|e| format!("malformed batch reply: {e}"))?;
            Ok(checked_id(j::str_at(&b, &["id"]).unwrap_or(""), "msgbatch_", "message batch")?.to_string())
        })
    }

    fn poll<'a>(&'a self, ops: &'a Ops, id: &'a str, _keys: &'a [String]) -> BoxFuture<'a, Result<Poll, PollError>> {
        Box::pin(async move {
            let id =
                checked_id(id, "msgbatch_", "message batch").map_err(|message| PollError { message, gone: true })?;
            let url = format!("{}/v1/messages/batches/{id}", self.base);
            let body = ops.send(&url, &self.auth, Vec::new()).await?;
            let b = j::object(&body)
                .map_err(|e| PollError { message: format!("malformed batch status reply: {e}"), gone: false })?;
            let status = j::str_at(&b, &["processing_status"]).unwrap_or("").to_string();
            let count = |k: &str| j::u64_at(&b, &["request_counts", k]);
            match status.as_str() {
                "in_progress" | "canceling" => Ok(Poll::Running(format!(
                    "{status}: {} processing, {} succeeded, {} errored",
                    count("processing"),
                    count("succeeded"),
                    count("errored")
                ))),
                "ended" => {
                    self.check_results_url(&b);
                    let body = ops.send(&format!("{url}/results"), &self.auth, Vec::new()).await?;
                    let (mut results, mut bad) = (HashMap::new(), Vec::new());
                    read_lines(&body, &mut results, &mut bad);
                    Ok(Poll::Ended { results, missing: missing_reason(id, &status, &bad) })
                }
                other => Err(PollError {
                    message: format!(
                        "malformed batch status reply: unknown `processing_status` `{}`",
                        crate::net::http::snippet(other.as_bytes())
                    ),
                    gone: false,
                }),
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn result_types() {
        let file = br#"{"custom_id":"a","result":{"type":"succeeded","message":{"id":"msg_1","content":[]}}}
{"custom_id":"b","result":{"type":"errored","error":{"type":"error","error":{"type":"invalid_request_error","message":"image too large"}}}}
{"custom_id":"c","result":{"type":"expired"}}
{"custom_id":"d","result":{"type":"canceled"}}
"#;
        let (mut out, mut bad) = (HashMap::new(), Vec::new());
        read_lines(file, &mut out, &mut bad);
        assert!(bad.is_empty());
        assert!(matches!(&out["a"], ItemResult::Body(b) if b.starts_with(b"{\"")));
        assert_eq!(out["b"], ItemResult::Failed("image too large (invalid_request_error)".into()));
        assert!(matches!(&out["c"], ItemResult::Failed(m) if m.contains("expired")));
        assert!(matches!(&out["d"], ItemResult::Failed(m) if m.contains("canceled")));
    }
}

//! Gemini batch mode with inline requests: `POST /v1beta/models/{model}:batchGenerateContent`
//! with `{"batch": {"displayName", "inputConfig": {"requests": {"requests": [{"request",
//! "metadata": {"key"}}]}}}}` (the shape the official SDK sends), looked at with `GET
//! /v1beta/batches/{id}`; when it has ended, its inline responses are read from the batch's
//! `metadata.output.inlinedResponses` (matched by `metadata.key`, else by position). Inline
//! requests are limited to 20 MB per batch, so larger work goes out as several batches.

use std::collections::HashMap;

use serde_json::{Value, json};

use super::{ItemResult, Ops, Poll, PollError, Wire, checked_id, missing_reason};
use crate::net::json as j;
use crate::vlm::BoxFuture;
use crate::vlm::gemini::Gemini;

pub struct GeminiBatch {
    base: String,
    model: String,
    auth: Vec<(String, String)>,
}

impl GeminiBatch {
    pub fn new(proto: &Gemini) -> GeminiBatch {
        GeminiBatch { base: proto.base().to_string(), model: proto.model().to_string(), auth: proto.auth() }
    }
}

/// The create body.
pub fn create_body(items: &[super::Item]) -> Value {
    let requests: Vec<Value> = items.iter().map(|i| json!({"request": i.body, "metadata": {"key": i.key}})).collect();
    json!({"batch": {"displayName": "revelio", "inputConfig": {"requests": {"requests": requests}}}})
}

/// A proto3 JSON integer (int64 counts come as strings).
fn count(v: &Value, path: &[&str]) -> u64 {
    match j::at(v, path) {
        Some(Value::String(s)) => s.parse().unwrap_or(0),
        Some(n) => n.as_u64().unwrap_or(0),
        None => 0,
    }
}

/// The inline responses of an ended batch, by key.
fn read_responses(b: &Value, keys: &[String], bad: &mut Vec<String>) -> HashMap<String, ItemResult> {
    let mut out = HashMap::new();
    let output = b.pointer("/metadata/output").or_else(|| b.get("response"));
    let Some(output) = output else {
        bad.push("the batch has no `output`".into());
        return out;
    };
    if let Some(file) = output.get("responsesFile").and_then(Value::as_str) {
        bad.push(format!(
            "its results are in a file (`{}`), which Revelio does not read: it sends inline requests only",
            crate::net::http::snippet(file.as_bytes())
        ));
        return out;
    }
    let Some(list) = output.pointer("/inlinedResponses/inlinedResponses").and_then(Value::as_array) else {
        bad.push("no `inlinedResponses` in its output".into());
        return out;
    };
    for (i, r) in list.iter().enumerate() {
        let key =
            r.pointer("/metadata/key").and_then(Value::as_str).map(str::to_string).or_else(|| keys.get(i).cloned());
        let Some(key) = key else {
            bad.push(format!("response {} has no key and no request in its place", i + 1));
            continue;
        };
        let result = match (r.get("response"), r.get("error")) {
            (Some(resp), None) => ItemResult::Body(resp.to_string().into_bytes()),
            (_, Some(e)) => {
                let message = e.get("message").and_then(Value::as_str).unwrap_or("no message");
                ItemResult::Failed(format!(
                    "{} (code {})",
                    crate::net::http::snippet(message.as_bytes()),
                    count(e, &["code"])
                ))
            }
            (None, None) => ItemResult::Failed("an inline response with neither `response` nor `error`".into()),
        };
        out.insert(key, result);
    }
    out
}

impl Wire for GeminiBatch {
    fn provider(&self) -> &'static str {
        "gemini batch"
    }

    fn limits(&self) -> (usize, usize) {
        // Inline requests: 20 MB per batch request.
        (10_000, 19 << 20)
    }

    fn submit<'a>(&'a self, ops: &'a Ops, items: &'a [super::Item]) -> BoxFuture<'a, Result<String, String>> {
        Box::pin(async move {
            let mut headers = self.auth.clone();
            if !headers.iter().any(|(k, _)| k == "content-type") {
                headers.push(("content-type".into(), "application/json".into()));
            }
            let url = format!("{}/v1beta/models/{}:batchGenerateContent", self.base, self.model);
            let body = ops.send(&url, &headers, create_body(items).to_string().into_bytes()).await?;
            let b = j::object(&body).map_err(|e| format!("malformed batch reply: {e}"))?;
            Ok(checked_id(j::str_at(&b, &["name"]).unwrap_or(""), "batches/", "batch")?.to_string())
        })
    }

    fn poll<'a>(&'a self, ops: &'a Ops, id: &'a str, keys: &'a [String]) -> BoxFuture<'a, Result<Poll, PollError>> {
        Box::pin(async move {
            let id = checked_id(id, "batches/", "batch").map_err(|message| PollError { message, gone: true })?;
            let headers: Vec<(String, String)> =
                self.auth.iter().filter(|(k, _)| k != "content-type").cloned().collect();
            let body = ops.send(&format!("{}/v1beta/{id}", self.base), &headers, Vec::new()).await?;
            let b = j::object(&body)
                .map_err(|e| PollError { message: format!("malformed batch status reply: {e}"), gone: false })?;
            let state = j::str_at(&b, &["metadata", "state"]).unwrap_or("").to_string();
            let stats = |k: &str| count(&b, &["metadata", "batchStats", k]);
            match state.as_str() {
                "BATCH_STATE_PENDING" | "BATCH_STATE_RUNNING" | "BATCH_STATE_UNSPECIFIED" => {
                    Ok(Poll::Running(format!(
                        "{state}: {}/{} done, {} failed",
                        stats("successfulRequestCount") + stats("failedRequestCount"),
                        stats("requestCount"),
                        stats("failedRequestCount")
                    )))
                }
                "BATCH_STATE_SUCCEEDED" | "BATCH_STATE_FAILED" | "BATCH_STATE_CANCELLED" | "BATCH_STATE_EXPIRED" => {
                    let mut bad = Vec::new();
                    let results = if state == "BATCH_STATE_SUCCEEDED" {
                        read_responses(&b, keys, &mut bad)
                    } else {
                        HashMap::new()
                    };
                    let mut missing = missing_reason(id, &state, &bad);
                    if state == "BATCH_STATE_EXPIRED" {
                        missing = format!("batch `{id}` expired before this request was answered");
                    }
                    if let Some(m) = j::str_at(&b, &["error", "message"]) {
                        missing.push_str(&format!("; the batch reports: {}", crate::net::http::snippet(m.as_bytes())));
                    }
                    Ok(Poll::Ended { results, missing })
                }
                other => Err(PollError {
                    message: format!(
                        "malformed batch status reply: unknown state `{}`",
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
    fn inline_responses_by_key_or_position() {
        let b = json!({"name": "batches/x", "metadata": {"state": "BATCH_STATE_SUCCEEDED", "output": {"inlinedResponses": {"inlinedResponses": [
            {"response": {"candidates": []}, "metadata": {"key": "b"}},
            {"error": {"code": 3, "message": "bad image"}},
        ]}}}});
        let mut bad = Vec::new();
        let out = read_responses(&b, &["a".into(), "x".into()], &mut bad);
        assert_eq!(out["b"], ItemResult::Body(br#"{"candidates":[]}"#.to_vec()));
        assert_eq!(out["x"], ItemResult::Failed("bad image (code 3)".into()));
        let file = json!({"metadata": {"output": {"responsesFile": "files/abc"}}});
        assert!(read_responses(&file, &[], &mut bad).is_empty());
        assert!(bad[0].contains("`files/abc`"), "{bad:?}");
    }
}

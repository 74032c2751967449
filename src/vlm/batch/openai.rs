//! OpenAI Batch: the requests as a JSONL file uploaded to `POST /files` (`purpose=batch`), the
//! batch created with `POST /batches` (`endpoint: /v1/chat/completions`, `completion_window:
//! 24h`), looked at with `GET /batches/{id}`, its results read from `GET
//! /files/{output_file_id}/content` and `GET /files/{error_file_id}/content`. Every URL is the
//! configured base URL and a checked id.

use std::collections::HashMap;

use serde_json::{Value, json};

use super::{ItemResult, Ops, Poll, PollError, Wire, checked_id, jsonl, missing_reason};
use crate::net::json as j;
use crate::vlm::BoxFuture;
use crate::vlm::openai::OpenAi;

/// The endpoint every request line names.
pub const ENDPOINT: &str = "/v1/chat/completions";

pub struct OpenAiBatch {
    base: String,
    auth: Vec<(String, String)>,
}

impl OpenAiBatch {
    pub fn new(proto: &OpenAi) -> OpenAiBatch {
        OpenAiBatch { base: proto.base().to_string(), auth: proto.auth() }
    }

    fn json_headers(&self) -> Vec<(String, String)> {
        let mut h = vec![("content-type".to_string(), "application/json".to_string())];
        h.extend(self.auth.iter().cloned());
        h
    }
}

/// The JSONL input file: one request line per item.
pub fn input_file(items: &[super::Item]) -> Vec<u8> {
    let mut out = Vec::new();
    for i in items {
        let line = json!({"custom_id": i.key, "method": "POST", "url": ENDPOINT, "body": i.body});
        out.extend_from_slice(line.to_string().as_bytes());
        out.push(b'\n');
    }
    out
}

/// A `multipart/form-data` body with `purpose=batch` and the file; its boundary.
fn multipart(file: &[u8]) -> (String, Vec<u8>) {
    // A boundary from the file's hash cannot occur in it.
    let boundary = format!("revelio-{}", &crate::hash::sha256_hex(file)[..32]);
    let mut body = Vec::new();
    body.extend_from_slice(
        format!("--{boundary}\r\ncontent-disposition: form-data; name=\"purpose\"\r\n\r\nbatch\r\n").as_bytes(),
    );
    body.extend_from_slice(
        format!(
            "--{boundary}\r\ncontent-disposition: form-data; name=\"file\"; filename=\"revelio-batch.jsonl\"\r\ncontent-type: application/jsonl\r\n\r\n"
        )
        .as_bytes(),
    );
    body.extend_from_slice(file);
    body.extend_from_slice(format!("\r\n--{boundary}--\r\n").as_bytes());
    (boundary, body)
}

fn object(body: &[u8], what: &str) -> Result<Value, String> {
    j::object(body).map_err(|e| format!("malformed {what} reply: {e}"))
}

/// Read result lines (`{"custom_id", "response": {"status_code", "body"}, "error"}`) into
/// `out`.
fn read_lines(body: &[u8], out: &mut HashMap<String, ItemResult>, bad: &mut Vec<String>) {
    for line in jsonl(body, bad) {
        let Some(id) = line.get("custom_id").and_then(Value::as_str) else {
            bad.push("a line without `custom_id`".into());
            continue;
        };
        let status = j::u64_at(&line, &["response", "status_code"]);
        let result = match (line.get("error").filter(|e| !e.is_null()), line.pointer("/response/body")) {
            (None, Some(body)) if (200..300).contains(&status) => ItemResult::Body(body.to_string().into_bytes()),
            (Some(e), _) => ItemResult::Failed(error_text(e)),
            (None, Some(body)) => ItemResult::Failed(format!(
                "HTTP {status}: {}",
                body.get("error").map_or_else(|| crate::net::http::snippet(body.to_string().as_bytes()), error_text)
            )),
            (None, None) => ItemResult::Failed("the result line has neither `response.body` nor `error`".into()),
        };
        out.insert(id.to_string(), result);
    }
}

/// `{"code", "message"}` as `message (code)`.
fn error_text(e: &Value) -> String {
    let message = e.get("message").and_then(Value::as_str).unwrap_or("no message");
    let message = crate::net::http::snippet(message.as_bytes());
    match e.get("code").and_then(Value::as_str) {
        Some(c) => format!("{message} ({c})"),
        None => message,
    }
}

impl Wire for OpenAiBatch {
    fn provider(&self) -> &'static str {
        "openai batch"
    }

    fn limits(&self) -> (usize, usize) {
        // OpenAI: 50,000 requests and 200 MB per input file.
        (50_000, 190 << 20)
    }

    fn submit<'a>(&'a self, ops: &'a Ops, items: &'a [super::Item]) -> BoxFuture<'a, Result<String, String>> {
        Box::pin(async move {
            let (boundary, body) = multipart(&input_file(items));
            let mut headers = vec![("content-type".to_string(), format!("multipart/form-data; boundary={boundary}"))];
            headers.extend(self.auth.iter().cloned());
            let file = object(&ops.send(&format!("{}/files", self.base), &headers, body).await?, "file upload")?;
            let file_id = checked_id(j::str_at(&file, &["id"]).unwrap_or(""), "file-", "file")?.to_string();
            let create = json!({"input_file_id": file_id, "endpoint": ENDPOINT, "completion_window": "24h"});
            let url = format!("{}/batches", self.base);
            let batch = object(&ops.send(&url, &self.json_headers(), create.to_string().into_bytes()).await?, "batch")?;
            Ok(checked_id(j::str_at(&batch, &["id"]).unwrap_or(""), "batch_", "batch")?.to_string())
        })
    }

    fn poll<'a>(&'a self, ops: &'a Ops, id: &'a str, _keys: &'a [String]) -> BoxFuture<'a, Result<Poll, PollError>> {
        Box::pin(async move {
            let id = checked_id(id, "batch_", "batch").map_err(|message| PollError { message, gone: true })?;
            let body = ops.send(&format!("{}/batches/{id}", self.base), &self.auth, Vec::new()).await?;
            let b = object(&body, "batch status").map_err(|message| PollError { message, gone: false })?;
            let status = j::str_at(&b, &["status"]).unwrap_or("").to_string();
            let count = |k: &str| j::u64_at(&b, &["request_counts", k]);
            match status.as_str() {
                "validating" | "in_progress" | "finalizing" | "cancelling" => Ok(Poll::Running(format!(
                    "{status}: {}/{} done, {} failed",
                    count("completed"),
                    count("total"),
                    count("failed")
                ))),
                "completed" | "expired" | "cancelled" | "failed" => {
                    let mut results = HashMap::new();
                    let mut bad = Vec::new();
                    for field in ["output_file_id", "error_file_id"] {
                        let Some(file) = j::str_at(&b, &[field]) else { continue };
                        let file =
                            checked_id(file, "file-", "file").map_err(|message| PollError { message, gone: false })?;
                        let url = format!("{}/files/{file}/content", self.base);
                        read_lines(&ops.send(&url, &self.auth, Vec::new()).await?, &mut results, &mut bad);
                    }
                    let mut missing = missing_reason(id, &status, &bad);
                    if status == "expired" {
                        missing =
                            format!("batch `{id}` expired (its 24 h window passed) before this request was answered");
                    }
                    if let Some(errors) =
                        j::at(&b, &["errors", "data"]).and_then(Value::as_array).filter(|e| !e.is_empty())
                    {
                        let texts: Vec<String> = errors.iter().take(3).map(error_text).collect();
                        missing.push_str(&format!("; the batch reports: {}", texts.join("; ")));
                    }
                    Ok(Poll::Ended { results, missing })
                }
                other => Err(PollError {
                    message: format!(
                        "malformed batch status reply: unknown status `{}`",
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
    fn result_lines_succeed_fail_or_are_named_malformed() {
        let file = br#"{"id":"batch_req_1","custom_id":"a","response":{"status_code":200,"request_id":"r1","body":{"choices":[]}},"error":null}
{"id":"batch_req_2","custom_id":"b","response":{"status_code":400,"request_id":"r2","body":{"error":{"message":"bad image","type":"invalid_request_error","code":"invalid_image"}}},"error":null}
{"id":"batch_req_3","custom_id":"c","response":null,"error":{"code":"batch_expired","message":"This request could not be executed before the completion window expired."}}
{"custom_id": "d", "resp
"#;
        let (mut out, mut bad) = (HashMap::new(), Vec::new());
        read_lines(file, &mut out, &mut bad);
        assert_eq!(out["a"], ItemResult::Body(br#"{"choices":[]}"#.to_vec()));
        assert_eq!(out["b"], ItemResult::Failed("HTTP 400: bad image (invalid_image)".into()));
        assert!(matches!(&out["c"], ItemResult::Failed(m) if m.ends_with("(batch_expired)")));
        assert!(!out.contains_key("d"));
        assert_eq!(bad.len(), 1);
        assert!(bad[0].starts_with("line 4 is malformed"), "{bad:?}");
    }

    #[test]
    fn the_upload_is_one_multipart_form() {
        let items = [super::super::Item { key: "k".into(), body: json!({"model": "m"}) }];
        let (boundary, body) = multipart(&input_file(&items));
        let text = String::from_utf8(body).unwrap();
        assert!(text.starts_with(&format!("--{boundary}\r\n")));
        assert!(text.contains("name=\"purpose\"\r\n\r\nbatch\r\n"));
        assert!(
            text.contains(r#"{"body":{"model":"m"},"custom_id":"k","method":"POST","url":"/v1/chat/completions"}"#),
            "{text}"
        );
        assert!(text.ends_with(&format!("\r\n--{boundary}--\r\n")));
    }
}

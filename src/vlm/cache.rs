//! Content-addressed caches on disk: model replies (keyed by model id with its settings, image
//! hash and prompt) and generated images. Files are written to a temporary name and renamed, so
//! a killed run never leaves a half-written entry that a resumed run would trust.
//!
//! Within a run the cache never answers a repeat (an observation of a set showing an image the
//! set has already shown): such an observation never reaches a model, the run records it
//! `repeated` instead (`run::distinct`). What the cache serves is another run's replies, and a
//! resumed run's calls that were answered but not journaled (a run killed in flight); the
//! journal, not the cache, replays a resumed run's journaled observations.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::hash::parts_hex;
use crate::net::cache::Store;
use crate::outcome::Answer;
use crate::vlm::Reply;

#[derive(Serialize, Deserialize)]
struct Entry {
    model: String,
    reply: Reply,
}

/// The reply cache of one model.
#[derive(Debug, Clone)]
pub struct ReplyCache {
    store: Store,
    model: String,
}

impl ReplyCache {
    pub fn new(dir: impl Into<PathBuf>, model_id: &str) -> ReplyCache {
        ReplyCache { store: Store::new(dir, "json"), model: model_id.to_string() }
    }

    pub fn key(&self, image_hash: &str, prompt: &str) -> String {
        parts_hex([&b"reply-v1"[..], self.model.as_bytes(), image_hash.as_bytes(), prompt.as_bytes()])
    }

    /// A cached reply, marked as cached and free. Unreadable or foreign entries are misses.
    pub fn get(&self, key: &str) -> Option<Reply> {
        let entry: Entry = serde_json::from_slice(&self.store.get(key)?).ok()?;
        if entry.model != self.model {
            return None;
        }
        let mut reply = entry.reply;
        reply.cached = true;
        reply.usage.cost_usd = 0.0;
        reply.latency_ms = 0;
        reply.attempts = 0;
        reply.rate_limited = 0;
        reply.waited_ms = 0;
        Some(reply)
    }

    /// Store a reply if it is a successful, parsed answer (anything else is worth asking again).
    pub fn put(&self, key: &str, reply: &Reply) -> Result<(), String> {
        if !matches!(reply.answer, Answer::Option(_)) || reply.cached {
            return Ok(());
        }
        let entry = Entry { model: self.model.clone(), reply: reply.clone() };
        let bytes = serde_json::to_vec(&entry).map_err(|e| format!("cannot encode cache entry: {e}"))?;
        self.store.put(key, &bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outcome::Usage;

    fn reply(answer: Answer) -> Reply {
        Reply {
            raw: "Answer: B".into(),
            thinking: None,
            answer,
            usage: Usage { input_tokens: 10, output_tokens: 5, thinking_tokens: 0, cost_usd: 0.01 },
            latency_ms: 1234,
            cached: false,
            attempts: 2,
            rate_limited: 1,
            waited_ms: 500,
        }
    }

    #[test]
    fn parsed_replies_round_trip_as_cached_and_free() {
        let dir = tempfile::tempdir().unwrap();
        let c = ReplyCache::new(dir.path(), "openai:m");
        let k = c.key("img", "prompt");
        assert!(c.get(&k).is_none());
        c.put(&k, &reply(Answer::Option(1))).unwrap();
        let got = c.get(&k).unwrap();
        assert!(got.cached);
        assert_eq!(got.answer, Answer::Option(1));
        assert_eq!(got.usage.cost_usd, 0.0);
        assert_eq!(got.usage.input_tokens, 10);
        // No temporary files left behind.
        let sub = dir.path().join(&k[..2]);
        let names: Vec<_> = std::fs::read_dir(sub).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 1);
    }

    #[test]
    fn failures_and_unparsed_replies_are_not_cached() {
        let dir = tempfile::tempdir().unwrap();
        let c = ReplyCache::new(dir.path(), "openai:m");
        for a in [Answer::ApiError, Answer::Unparsed, Answer::Truncated, Answer::Blocked] {
            let k = c.key("img", &format!("{a:?}"));
            c.put(&k, &reply(a)).unwrap();
            assert!(c.get(&k).is_none());
        }
    }

    #[test]
    fn a_different_model_id_misses() {
        let dir = tempfile::tempdir().unwrap();
        let a = ReplyCache::new(dir.path(), "gemini:m@thinking=low");
        let b = ReplyCache::new(dir.path(), "gemini:m@thinking=high");
        let k = a.key("img", "p");
        a.put(&k, &reply(Answer::Option(0))).unwrap();
        assert_ne!(k, b.key("img", "p"));
        assert!(b.get(&k).is_none(), "a foreign entry under the same key must not be trusted");
    }
}

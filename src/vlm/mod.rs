//! Vision-language model clients behind one trait. The evaluator (`search`) builds a [`Query`]
//! per observation and gets back a [`Reply`]; it never knows which provider answered.
//!
//! Providers: the offline `sim` model (answers from the ground truth it is handed, with planted
//! failure modes), and the real API clients (OpenAI-compatible, Anthropic, Gemini, Bedrock).

use serde::{Deserialize, Serialize};

use crate::ir::ConceptSet;
pub use crate::net::BoxFuture;
use crate::outcome::{Answer, Usage};

/// One question to a model about one image.
#[derive(Debug, Clone)]
pub struct Query {
    /// The encoded image (PNG unless a client re-encodes), or `None` with `--renderer none`.
    pub image: Option<std::sync::Arc<Vec<u8>>>,
    /// SHA-256 hex of the image bytes (or of the scene JSON when there is no image).
    pub image_hash: String,
    /// The full prompt text sent with the image (question, lettered options, answer format).
    pub prompt: String,
    /// Option texts in order; option i has letter `(b'A' + i)`.
    pub options: Vec<String>,
    /// Ground truth, handed over for the `sim` model only; real clients must ignore it.
    pub truth: Option<Truth>,
}

/// What the `sim` model answers from.
#[derive(Debug, Clone)]
pub struct Truth {
    pub set: ConceptSet,
    /// Concept names of the set.
    pub concepts: Vec<String>,
    /// Index of the expected option.
    pub expected: u32,
    /// The options' identifiers in the domain (`stop`, `yes`), in the order of the query's
    /// options: a sim profile's planted `answer` names one.
    pub option_names: Vec<String>,
    /// The scene's key: the first 64 bits of the image hash (the scene hash without a
    /// renderer), so the `sim` model answers the same scene the same way, as a deterministic
    /// model would, and a resumed run sees the same simulated answers.
    pub key: u64,
    /// The recognition statements the prompt lists (`revelio probe`), in prompt order; empty
    /// for the plain safety question.
    pub statements: Vec<Statement>,
}

/// One true/false statement of a probe prompt: a concept's probe or its counterfactual.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Statement {
    /// The concept the statement is about.
    pub concept: String,
    /// `true`: the positive statement (true of the scene); `false`: the counterfactual.
    pub positive: bool,
    pub text: String,
}

/// A model's reply to one query.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reply {
    /// The raw final text (thinking removed), or the error message for `ApiError`.
    pub raw: String,
    /// Thinking/reasoning text when the provider returned it separately.
    pub thinking: Option<String>,
    pub answer: Answer,
    pub usage: Usage,
    pub latency_ms: u64,
    /// Served from the response cache (cost nothing).
    pub cached: bool,
    /// Attempts made (1 = no retry).
    pub attempts: u32,
    /// Of the retries, those after a rate limit (HTTP 429).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rate_limited: u32,
    /// Milliseconds spent waiting between attempts (backoff and `Retry-After`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub waited_ms: u64,
}

fn is_zero<T: Default + PartialEq>(n: &T) -> bool {
    *n == T::default()
}

/// A vision-language model. Implementations must be cheap to share (`Arc<dyn Model>`) and safe
/// to call concurrently; they own their rate limits and retries.
pub trait Model: Send + Sync {
    /// A stable identifier including the settings that change answers (goes into the run
    /// configuration and the cache key), e.g. `gemini:gemini-3-flash@thinking=low`.
    fn id(&self) -> String;
    /// Ask once. Never panics and never returns an error: failures become `Answer::ApiError`
    /// with the message in `raw`.
    fn ask<'a>(&'a self, query: &'a Query) -> BoxFuture<'a, Reply>;
    /// Running token and cost totals of this model's calls so far (`None` for models that
    /// cost nothing, like `sim`).
    fn spend(&self) -> Option<cost::Spend> {
        None
    }
    /// Requests this model lets be in flight at once (its resolved `concurrency` setting);
    /// `None` for models without a limit of their own (`sim`).
    fn concurrency(&self) -> Option<usize> {
        None
    }
    /// Its prices and output bounds, for `--dry-run` and `--max-cost` (`None`: it costs
    /// nothing, like `sim`).
    fn pricing(&self) -> Option<cost::Pricing> {
        None
    }
    /// The base URL the model's requests go to (never a key); `None` for local models (`sim`).
    /// Recorded in a run's `config.json` so a resume against another endpoint is refused.
    fn endpoint(&self) -> Option<String> {
        None
    }
}

// The HTTP clients need the `net` feature; the `sim` model, prompts, parsing, settings and the
// reply cache do not.
#[cfg(feature = "net")]
pub mod anthropic;
#[cfg(feature = "net")]
pub mod api;
#[cfg(feature = "net")]
pub mod batch;
#[cfg(feature = "net")]
pub mod bedrock;
pub mod cache;
pub mod config;
pub mod cost;
#[cfg(feature = "net")]
pub mod gemini;
#[cfg(feature = "net")]
pub mod image;
#[cfg(feature = "net")]
pub mod openai;
pub mod parse;
pub mod prompt;
pub mod registry;
#[cfg(feature = "net")]
pub mod sigv4;
pub mod sim;
pub mod statements;

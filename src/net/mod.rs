//! The network edge shared by the model clients (`vlm`) and the image generators (`render`): the
//! resilient HTTP path ([`http`]), credentials and base URLs ([`secret`]), the content-addressed
//! disk store behind the caches ([`cache`]), and what each provider's host expects of every
//! client that calls it ([`gemini`], [`openai`]).

use std::future::Future;
use std::pin::Pin;
use std::time::Duration;

pub mod cache;
#[cfg(feature = "net")]
pub mod gemini;
#[cfg(feature = "net")]
pub mod http;
#[cfg(feature = "net")]
pub mod json;
#[cfg(feature = "net")]
pub mod openai;
#[cfg(feature = "net")]
pub mod secret;

pub type BoxFuture<'a, T> = Pin<Box<dyn Future<Output = T> + Send + 'a>>;

/// A provider's error response.
#[derive(Debug, Clone, PartialEq)]
pub struct ProviderError {
    pub message: String,
    /// Never worth retrying even on a transient status (quota and spend limits).
    pub permanent: bool,
    /// A retry delay the body asks for (Gemini's `RetryInfo`).
    pub retry_after: Option<Duration>,
}

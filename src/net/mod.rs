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

/// Default `http::Limits::max_body` for model replies: a reply is a few kilobytes of JSON. Here
/// rather than in `http` because the model config (built without the `net` feature too) names
/// it as its default.
pub const DEFAULT_MAX_BODY: usize = 4 << 20;

/// A provider's API host as every client sees it: where its base URL and its key come from.
/// A key is read only from the host's own variables and sent only to the base URL resolved
/// here, so it never reaches another provider's host.
#[cfg(feature = "net")]
#[derive(Debug, Clone, Copy)]
pub struct Host {
    pub provider: &'static str,
    /// Variables that override the base URL, first set wins.
    pub base_env: &'static [&'static str],
    /// Variables that hold the key, first set wins (none: credentials of another form).
    pub key_env: &'static [&'static str],
}

/// Where one client sends its requests, with what key.
#[cfg(feature = "net")]
#[derive(Debug, Clone)]
pub struct Endpoint {
    /// Without a trailing slash.
    pub base: String,
    pub key: Option<secret::Secret>,
}

#[cfg(feature = "net")]
impl Host {
    /// The base URL (`flag`, then the host's variables, then `default`) and the key. The key is
    /// required on the provider's own host (`default`); a server elsewhere (a local model
    /// server, a proxy) may not need one.
    pub fn endpoint(&self, spec: &str, flag: Option<&str>, default: &str) -> Result<Endpoint, String> {
        let base = secret::base_url(flag, self.base_env, default)?;
        let key = secret::env_any(self.key_env).map(secret::Secret);
        if key.is_none() && !self.key_env.is_empty() && base == default.trim_end_matches('/') {
            let names: Vec<String> = self.key_env.iter().map(|k| format!("`{k}`")).collect();
            let alternatives = match names.split_first() {
                Some((first, [])) => first.clone(),
                Some((first, rest)) => format!("{first} (or {})", rest.join(", ")),
                None => String::new(),
            };
            return Err(format!("`{spec}` needs an API key: set {alternatives}"));
        }
        Ok(Endpoint { base, key })
    }
}

/// A provider's error response.
#[derive(Debug, Clone, PartialEq)]
pub struct ProviderError {
    pub message: String,
    /// Never worth retrying even on a transient status (quota and spend limits).
    pub permanent: bool,
    /// A retry delay the body asks for (Gemini's `RetryInfo`).
    pub retry_after: Option<Duration>,
}

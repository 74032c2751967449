//! The network edge shared by the model clients (`vlm`) and the image generators (`render`): the
//! resilient HTTP path ([`http`]) and its request log ([`log`]), credentials and base URLs
//! ([`secret`]), the content-addressed disk store behind the caches ([`cache`]), and what each
//! provider's host expects of every client that calls it ([`gemini`], [`openai`]).

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
pub mod log;
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

/// What the command line says about one client's endpoint: its base URL flag (`--base-url`,
/// `--renderer-base-url`; else the host's variables, else its default) and whether plain
/// `http://` may go to a host other than this machine (`--allow-http`). Never read from a run
/// folder: only the person running Revelio chooses where a key goes.
#[derive(Debug, Clone, Copy, Default)]
pub struct EndpointFlags<'a> {
    pub base_url: Option<&'a str>,
    pub allow_http: bool,
    /// `--dry-run`: no request will be sent, so a missing key is not an error (the URL is
    /// still checked).
    pub dry_run: bool,
}

/// Domains whose hosts are a provider's own: a key for them never goes out over plain `http://`,
/// whatever the flags say (Bedrock's hosts are under `amazonaws.com`).
pub const PROVIDER_DOMAINS: &[&str] = &["openai.com", "anthropic.com", "googleapis.com", "amazonaws.com"];

/// Refuse a base URL that could carry a credential — a user name or password
/// (`https://user:pass@host`), a query (`?key=…`) or a fragment — before it is used or recorded
/// anywhere: credentials belong in the provider's key variable, and a URL's userinfo would be
/// sent as Basic authorization beside the key and written into `config.json` (a base URL has
/// paths appended to it, so a query in it was never of use). Checked on the text itself, so it
/// holds in builds without the HTTP client too; the message shows the URL without the parts
/// that may be secret.
pub fn refuse_url_credentials(url: &str) -> Result<(), String> {
    let Some((scheme, rest)) = url.split_once("://") else { return Ok(()) };
    // Where a URL parser ends the authority (a backslash too, as browsers and `reqwest` read it).
    let end = rest.find(['/', '\\', '?', '#']).unwrap_or(rest.len());
    let (authority, path) = rest.split_at(end);
    let host = authority.rsplit_once('@').map_or(authority, |(_, h)| h);
    let path = path.split(['?', '#']).next().unwrap_or_default();
    let userinfo = if authority.contains('@') { "…@" } else { "" };
    let shown = crate::diag::terminal_safe(&format!("{scheme}://{userinfo}{host}{path}")).into_owned();
    if !userinfo.is_empty() {
        return Err(format!(
            "invalid base URL `{shown}`: it holds a user name or password; put the credentials in the provider's key variable (e.g. `OPENAI_API_KEY`), never in a URL"
        ));
    }
    if rest.contains(['?', '#']) {
        return Err(format!(
            "invalid base URL `{shown}`: it has a query or fragment (`?…`, `#…`); a base URL is the part before the API's paths, and credentials go in the provider's key variable"
        ));
    }
    Ok(())
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
    /// The base URL (`flags.base_url`, then the host's variables, then `default`) and the key.
    /// The key is required on the provider's own host (`default`), except by a dry run, which
    /// sends nothing; a server elsewhere (a local model server, a proxy) may not need one. The URL is refused with userinfo in it, and
    /// over plain `http://` unless it names this machine or `flags.allow_http` is set — and
    /// always for a provider's own host ([`secret::check_base_url`]).
    pub fn endpoint(&self, spec: &str, flags: EndpointFlags<'_>, default: &str) -> Result<Endpoint, String> {
        let base = secret::base_url(flags.base_url, self.base_env, default)?;
        secret::check_base_url(&base, default, flags.allow_http)?;
        let key = secret::env_any(self.key_env).map(secret::Secret);
        if key.is_none() && !flags.dry_run && !self.key_env.is_empty() && base == default.trim_end_matches('/') {
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

//! Credentials and endpoints: where a key comes from (environment variables only), how it is kept
//! out of `Debug` output and scrubbed from any text a server echoes back, and how a provider's
//! base URL is chosen and which base URLs a key may go to (no userinfo; plain `http://` only to
//! this machine, or with `--allow-http` to a named server that is not a provider's own host).

use std::net::IpAddr;

use reqwest::Url;

use super::{PROVIDER_DOMAINS, refuse_url_credentials};

/// Replace every occurrence of the secrets in `text`.
pub fn redact(text: String, secrets: &[&str]) -> String {
    secrets
        .iter()
        .filter(|s| s.len() >= 4)
        .fold(text, |t, s| if t.contains(*s) { t.replace(*s, "[redacted]") } else { t })
}

/// A secret (API key, AWS secret) whose `Debug` never shows the value.
#[derive(Clone, Default)]
pub struct Secret(pub String);

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Secret(***)")
    }
}

/// The first set, non-empty environment variable of `names`.
pub fn env_any(names: &[&str]) -> Option<String> {
    names.iter().find_map(|n| std::env::var(n).ok().filter(|v| !v.trim().is_empty()))
}

/// `--base-url` first, then the provider's environment variables, then the default; without a
/// trailing slash.
pub fn base_url(flag: Option<&str>, env: &[&str], default: &str) -> Result<String, String> {
    let url = flag.map(str::to_string).or_else(|| env_any(env)).unwrap_or_else(|| default.to_string());
    let url = url.trim().trim_end_matches('/').to_string();
    refuse_url_credentials(&url)?;
    match Url::parse(&url) {
        Ok(u) if matches!(u.scheme(), "http" | "https") && u.host().is_some() => Ok(url),
        _ => Err(format!("invalid base URL `{url}`: expected an http:// or https:// URL")),
    }
}

/// Whether a key may go to `base` (a URL [`base_url`] accepted): never with a user name or
/// password in it, and over plain `http://` only to this machine (`localhost`, `127.0.0.0/8`,
/// `::1`, `0.0.0.0`) or, with `allow_http`, to a server the user named — never to a provider's own host
/// (`default`'s, or one under [`PROVIDER_DOMAINS`]), where the key would cross the internet in
/// cleartext.
pub fn check_base_url(base: &str, default: &str, allow_http: bool) -> Result<(), String> {
    refuse_url_credentials(base)?;
    let url = Url::parse(base).map_err(|e| format!("invalid base URL `{base}`: {e}"))?;
    if !url.username().is_empty() || url.password().is_some() {
        return Err(format!("invalid base URL `{}`: it holds a user name or password", public(&url)));
    }
    if url.scheme() != "http" {
        return Ok(());
    }
    let host = url.host_str().unwrap_or_default().to_ascii_lowercase();
    let own = Url::parse(default).ok().and_then(|d| d.host_str().map(str::to_ascii_lowercase));
    let provider = own.as_deref() == Some(host.as_str())
        || PROVIDER_DOMAINS.iter().any(|d| host == *d || host.ends_with(&format!(".{d}")));
    if provider {
        return Err(format!(
            "refused base URL `{}`: plain `http://` to a provider's host would send the key in cleartext; use `https://`",
            public(&url)
        ));
    }
    if is_loopback(&url) || allow_http {
        return Ok(());
    }
    Err(format!(
        "refused base URL `{}`: plain `http://` to `{host}` would send the key in cleartext; use `https://`, or pass `--allow-http` if `{host}` is a server on your own network",
        public(&url)
    ))
}

/// Whether `url` names this machine: a request to it never leaves it. The unspecified address
/// counts (`http://0.0.0.0:8000`, as local model servers print their address, connects here).
fn is_loopback(url: &Url) -> bool {
    let host = url.host_str().unwrap_or_default().to_ascii_lowercase();
    match host.trim_start_matches('[').trim_end_matches(']').parse::<IpAddr>() {
        Ok(IpAddr::V4(ip)) => ip.is_loopback() || ip.is_unspecified(),
        Ok(IpAddr::V6(ip)) => {
            ip.is_loopback() || ip.is_unspecified() || ip.to_ipv4_mapped().is_some_and(|v4| v4.is_loopback())
        }
        Err(_) => host == "localhost" || host.ends_with(".localhost"),
    }
}

/// `url` without query or fragment, for messages (the caller has refused userinfo already).
fn public(url: &Url) -> String {
    let mut u = url.clone();
    u.set_query(None);
    u.set_fragment(None);
    crate::diag::terminal_safe(u.as_str().trim_end_matches('/')).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_url_precedence_and_validation() {
        assert_eq!(base_url(Some("http://localhost:8000/v1/"), &[], "https://x").unwrap(), "http://localhost:8000/v1");
        assert_eq!(
            base_url(None, &["REVELIO_TEST_UNSET_VAR"], "https://api.example.com").unwrap(),
            "https://api.example.com"
        );
        assert_eq!(
            base_url(Some("localhost:8000"), &[], "https://x").unwrap_err(),
            "invalid base URL `localhost:8000`: expected an http:// or https:// URL"
        );
    }

    #[test]
    fn userinfo_is_refused_and_never_echoed() {
        for url in
            ["https://user:pa55word@api.example.com/v1", "https://pa55word@h", "http://u:pa55word@localhost:8000\\x"]
        {
            let e = base_url(Some(url), &[], "https://x").unwrap_err();
            assert!(e.contains("holds a user name or password") && !e.contains("pa55word"), "{e}");
        }
        // An `@` in the path is no userinfo.
        assert!(base_url(Some("https://h.example/v1/@me"), &[], "https://x").is_ok());
        let e = check_base_url("https://u:pa55word@h", "https://x", true).unwrap_err();
        assert!(e.contains("https://…@h") && !e.contains("pa55word"), "{e}");
    }

    #[test]
    fn plain_http_goes_only_to_this_machine_or_a_named_server() {
        let openai = "https://api.openai.com/v1";
        for ok in [
            "http://localhost:8000/v1",
            "http://127.0.0.1:9/v1",
            "http://[::1]:8000",
            "http://a.localhost",
            "http://0.0.0.0:8000/v1",
        ] {
            assert!(check_base_url(ok, openai, false).is_ok(), "{ok}");
        }
        assert!(check_base_url("https://gpu-box:8000/v1", openai, false).is_ok());
        let e = check_base_url("http://gpu-box:8000/v1", openai, false).unwrap_err();
        assert_eq!(
            e,
            "refused base URL `http://gpu-box:8000/v1`: plain `http://` to `gpu-box` would send the key in cleartext; use `https://`, or pass `--allow-http` if `gpu-box` is a server on your own network"
        );
        assert!(check_base_url("http://gpu-box:8000/v1", openai, true).is_ok());
        // A provider's own host: never, whatever the flags.
        for host in [
            "http://api.openai.com/v1",
            "http://API.Anthropic.com",
            "http://generativelanguage.googleapis.com",
            "http://bedrock-runtime.us-east-1.amazonaws.com",
        ] {
            let e = check_base_url(host, openai, true).unwrap_err();
            assert!(e.contains("to a provider's host would send the key in cleartext"), "{e}");
        }
        let e = check_base_url("http://llm.corp.example", "https://llm.corp.example", true).unwrap_err();
        assert!(e.contains("provider's host"), "{e}");
    }

    #[test]
    fn redaction() {
        assert_eq!(redact("bad key sk-abcdef given".into(), &["sk-abcdef"]), "bad key [redacted] given");
        assert_eq!(redact("x".into(), &[""]), "x");
    }

    #[test]
    fn secrets_do_not_debug_print() {
        assert_eq!(format!("{:?}", Secret("sk-123".into())), "Secret(***)");
    }
}

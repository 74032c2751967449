//! Credentials and endpoints: where a key comes from (environment variables only), how it is kept
//! out of `Debug` output and scrubbed from any text a server echoes back, and how a provider's
//! base URL is chosen.

/// Replace every occurrence of the secrets in `text`.
pub fn redact(text: String, secrets: &[&str]) -> String {
    secrets
        .iter()
        .filter(|s| s.len() >= 4)
        .fold(text, |t, s| if t.contains(*s) { t.replace(*s, "[redacted]") } else { t })
}

/// A secret (API key, AWS secret) whose `Debug` never shows the value.
#[derive(Clone)]
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
    match reqwest::Url::parse(&url) {
        Ok(u) if matches!(u.scheme(), "http" | "https") && u.host().is_some() => Ok(url),
        _ => Err(format!("invalid base URL `{url}`: expected an http:// or https:// URL")),
    }
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
    fn redaction() {
        assert_eq!(redact("bad key sk-abcdef given".into(), &["sk-abcdef"]), "bad key [redacted] given");
        assert_eq!(redact("x".into(), &[""]), "x");
    }

    #[test]
    fn secrets_do_not_debug_print() {
        assert_eq!(format!("{:?}", Secret("sk-123".into())), "Secret(***)");
    }
}

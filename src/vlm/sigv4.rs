//! AWS Signature Version 4 for Bedrock Runtime, from the standard AWS environment variables.
//! Checked against AWS's published SigV4 test suite (`get-vanilla`,
//! `get-vanilla-query-order-key-case`, `get-utf8`, `post-vanilla`).

use std::time::SystemTime;

use crate::hash::{sha256, sha256_hex};

use crate::net::secret::{Secret, env_any};

/// AWS credentials; `Debug` never prints the secret or the token.
#[derive(Clone, Default)]
pub struct Credentials {
    pub access_key_id: String,
    pub secret_access_key: Secret,
    pub session_token: Option<Secret>,
}

impl std::fmt::Debug for Credentials {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Credentials").field("access_key_id", &self.access_key_id).finish_non_exhaustive()
    }
}

impl Credentials {
    /// `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY` and optionally `AWS_SESSION_TOKEN`.
    pub fn from_env() -> Result<Credentials, String> {
        let id = env_any(&["AWS_ACCESS_KEY_ID"]);
        let secret = env_any(&["AWS_SECRET_ACCESS_KEY"]);
        match (id, secret) {
            (Some(access_key_id), Some(s)) => Ok(Credentials {
                access_key_id,
                secret_access_key: Secret(s),
                session_token: env_any(&["AWS_SESSION_TOKEN"]).map(Secret),
            }),
            _ => Err("Bedrock needs AWS credentials: set `AWS_ACCESS_KEY_ID` and `AWS_SECRET_ACCESS_KEY` (and `AWS_SESSION_TOKEN` for temporary credentials)".into()),
        }
    }
}

/// HMAC-SHA256 (RFC 2104).
pub fn hmac_sha256(key: &[u8], data: &[u8]) -> [u8; 32] {
    const BLOCK: usize = 64;
    let mut k = [0u8; BLOCK];
    if key.len() > BLOCK {
        k[..32].copy_from_slice(&sha256(key));
    } else {
        k[..key.len()].copy_from_slice(key);
    }
    let inner = sha256(&[&k.map(|b| b ^ 0x36)[..], data].concat());
    sha256(&[&k.map(|b| b ^ 0x5c)[..], &inner[..]].concat())
}

/// URI-encode per SigV4: unreserved characters (`A-Z a-z 0-9 - _ . ~`) stay, everything else
/// becomes `%XX` with upper-case hex.
pub fn uri_encode(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for b in s.bytes() {
        if b.is_ascii_alphanumeric() || matches!(b, b'-' | b'_' | b'.' | b'~') {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// `(YYYYMMDD, YYYYMMDDTHHMMSSZ)` in UTC.
pub fn amz_date(t: SystemTime) -> (String, String) {
    let secs = t.duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (y, m, d) = crate::date::civil_from_days(secs.div_euclid(86_400));
    let rem = secs.rem_euclid(86_400);
    let date = format!("{y:04}{m:02}{d:02}");
    let full = format!("{date}T{:02}{:02}{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60);
    (date, full)
}

/// What to sign.
pub struct SignRequest<'a> {
    pub method: &'a str,
    /// The canonical URI (already encoded as the service wants it).
    pub canonical_uri: &'a str,
    /// `(name, value)` query parameters, unencoded.
    pub query: &'a [(&'a str, &'a str)],
    /// Headers to sign, `(name, value)`; names any case.
    pub headers: &'a [(String, String)],
    pub payload: &'a [u8],
}

/// The signing scope.
pub struct Scope<'a> {
    pub region: &'a str,
    pub service: &'a str,
    /// `YYYYMMDDTHHMMSSZ`.
    pub amz_date: &'a str,
}

pub fn canonical_request(req: &SignRequest) -> (String, String) {
    let mut query: Vec<(String, String)> = req.query.iter().map(|(k, v)| (uri_encode(k), uri_encode(v))).collect();
    query.sort();
    let query = query.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join("&");
    let mut headers: Vec<(String, String)> = req
        .headers
        .iter()
        .map(|(k, v)| (k.to_ascii_lowercase(), v.split_whitespace().collect::<Vec<_>>().join(" ")))
        .collect();
    headers.sort();
    let mut merged: Vec<(String, String)> = Vec::new();
    for (k, v) in headers {
        match merged.last_mut() {
            Some((lk, lv)) if *lk == k => {
                lv.push(',');
                lv.push_str(&v);
            }
            _ => merged.push((k, v)),
        }
    }
    let signed = merged.iter().map(|(k, _)| k.as_str()).collect::<Vec<_>>().join(";");
    let canon_headers: String = merged.iter().map(|(k, v)| format!("{k}:{v}\n")).collect();
    let creq = format!(
        "{}\n{}\n{query}\n{canon_headers}\n{signed}\n{}",
        req.method,
        req.canonical_uri,
        sha256_hex(req.payload)
    );
    (creq, signed)
}

/// The `Authorization` header value.
pub fn authorization(creds: &Credentials, scope: &Scope, req: &SignRequest) -> String {
    let (creq, signed) = canonical_request(req);
    let date = &scope.amz_date[..8.min(scope.amz_date.len())];
    let cred_scope = format!("{date}/{}/{}/aws4_request", scope.region, scope.service);
    let to_sign = format!("AWS4-HMAC-SHA256\n{}\n{cred_scope}\n{}", scope.amz_date, sha256_hex(creq.as_bytes()));
    let k_date = hmac_sha256(format!("AWS4{}", creds.secret_access_key.0).as_bytes(), date.as_bytes());
    let k_region = hmac_sha256(&k_date, scope.region.as_bytes());
    let k_service = hmac_sha256(&k_region, scope.service.as_bytes());
    let k_signing = hmac_sha256(&k_service, b"aws4_request");
    let signature = hex::encode(hmac_sha256(&k_signing, to_sign.as_bytes()));
    format!(
        "AWS4-HMAC-SHA256 Credential={}/{cred_scope}, SignedHeaders={signed}, Signature={signature}",
        creds.access_key_id
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> Credentials {
        Credentials {
            access_key_id: "AKIDEXAMPLE".into(),
            secret_access_key: Secret("wJalrXUtnFEMI/K7MDENG+bPxRfiCYEXAMPLEKEY".into()),
            session_token: None,
        }
    }

    const SCOPE: Scope = Scope { region: "us-east-1", service: "service", amz_date: "20150830T123600Z" };

    fn vanilla_headers() -> Vec<(String, String)> {
        vec![("Host".into(), "example.amazonaws.com".into()), ("X-Amz-Date".into(), "20150830T123600Z".into())]
    }

    fn sign(method: &str, uri: &str, query: &[(&str, &str)]) -> String {
        let headers = vanilla_headers();
        let req = SignRequest { method, canonical_uri: uri, query, headers: &headers, payload: b"" };
        authorization(&example(), &SCOPE, &req)
    }

    #[test]
    fn hmac_rfc4231_case_2() {
        assert_eq!(
            hex::encode(hmac_sha256(b"Jefe", b"what do ya want for nothing?")),
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"
        );
    }

    #[test]
    fn aws_test_suite_get_vanilla() {
        assert_eq!(
            sign("GET", "/", &[]),
            "AWS4-HMAC-SHA256 Credential=AKIDEXAMPLE/20150830/us-east-1/service/aws4_request, SignedHeaders=host;x-amz-date, Signature=5fa00fa31553b73ebf1942676e86291e8372ff2a2260956d9b8aae1d763fbf31"
        );
    }

    #[test]
    fn aws_test_suite_query_order_key_case() {
        assert!(
            sign("GET", "/", &[("Param2", "value2"), ("Param1", "value1")])
                .ends_with("Signature=b97d918cfa904a5beff61c982a1b6f458b799221646efd99d3219ec94cdf2500")
        );
    }

    #[test]
    fn aws_test_suite_get_utf8() {
        let uri = format!("/{}", uri_encode("ሴ"));
        assert_eq!(uri, "/%E1%88%B4");
        assert!(
            sign("GET", &uri, &[])
                .ends_with("Signature=8318018e0b0f223aa2bbf98705b62bb787dc9c0e678f255a891fd03141be5d85")
        );
    }

    #[test]
    fn aws_test_suite_post_vanilla() {
        assert!(
            sign("POST", "/", &[])
                .ends_with("Signature=5da7c1a2acd57cee7505fc6676e4e544621c30862966e37dddb68e92efbe5d6b")
        );
    }

    #[test]
    fn dates() {
        let t = SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_440_938_160);
        assert_eq!(amz_date(t), ("20150830".into(), "20150830T123600Z".into()));
    }

    #[test]
    fn credentials_do_not_debug_print_secrets() {
        let mut c = example();
        c.session_token = Some(Secret("TOKEN-XYZ".into()));
        let d = format!("{c:?}");
        assert!(d.contains("AKIDEXAMPLE") && !d.contains("EXAMPLEKEY") && !d.contains("TOKEN-XYZ"), "{d}");
    }
}

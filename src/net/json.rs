//! JSON helpers for the providers' loosely typed bodies.
use serde_json::Value;

pub fn u64_at(v: &Value, path: &[&str]) -> u64 {
    at(v, path).and_then(Value::as_u64).unwrap_or(0)
}

pub fn str_at<'a>(v: &'a Value, path: &[&str]) -> Option<&'a str> {
    at(v, path).and_then(Value::as_str)
}

pub fn at<'a>(v: &'a Value, path: &[&str]) -> Option<&'a Value> {
    path.iter().try_fold(v, |v, k| match k.parse::<usize>() {
        Ok(i) => v.get(i),
        Err(_) => v.get(*k),
    })
}

/// Parse a body as a JSON object.
pub fn object(body: &[u8]) -> Result<Value, String> {
    match serde_json::from_slice::<Value>(body) {
        Ok(v @ Value::Object(_)) => Ok(v),
        Ok(_) => Err("expected a JSON object".into()),
        Err(e) => Err(format!("invalid JSON: {e}")),
    }
}

/// Merge `extra` fields into a request body (top level, overriding).
pub fn merge(body: &mut Value, extra: Option<&serde_json::Map<String, Value>>) {
    if let (Value::Object(b), Some(e)) = (body, extra) {
        for (k, v) in e {
            b.insert(k.clone(), v.clone());
        }
    }
}

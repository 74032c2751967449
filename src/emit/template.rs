//! `{name}` placeholders in render bindings (`{{` and `}}` stand for literal braces, which
//! Scenic dictionaries need).

/// Fill `text`'s placeholders with `lookup`; an unknown name is an error naming it.
pub(crate) fn fill(text: &str, lookup: impl Fn(&str) -> Option<String>) -> Result<String, String> {
    let mut out = String::with_capacity(text.len() + 32);
    let mut rest = text;
    while let Some(i) = rest.find(['{', '}']) {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        if tail.starts_with("{{") || tail.starts_with("}}") {
            out.push_str(&tail[..1]);
            rest = &tail[2..];
            continue;
        }
        if tail.starts_with('}') {
            return Err("unmatched `}` (write `}}` for a literal brace)".into());
        }
        let Some(end) = tail.find('}') else {
            return Err("unclosed `{` (write `{{` for a literal brace)".into());
        };
        let name = tail[1..end].trim();
        match lookup(name) {
            Some(v) => out.push_str(&v),
            None => return Err(format!("unknown placeholder `{{{name}}}`")),
        }
        rest = &tail[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// A number as Scenic source: millimetre precision, no trailing zeros.
pub(crate) fn num(x: f64) -> String {
    let s = format!("{:.3}", x);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fills_and_escapes() {
        let look = |n: &str| (n == "d").then(|| "3.5".to_owned());
        assert_eq!(fill("at {d} {{'a': 1}}", look).unwrap(), "at 3.5 {'a': 1}");
        assert_eq!(fill("{ d }", look).unwrap(), "3.5");
        assert_eq!(fill("{e}", look).unwrap_err(), "unknown placeholder `{e}`");
        assert!(fill("{d", look).unwrap_err().starts_with("unclosed"));
        assert!(fill("d}", look).unwrap_err().starts_with("unmatched"));
    }

    #[test]
    fn numbers_are_compact() {
        assert_eq!(num(3.0), "3");
        assert_eq!(num(-0.0001), "0");
        assert_eq!(num(6.6007567), "6.601");
        assert_eq!(num(-4.5), "-4.5");
    }
}

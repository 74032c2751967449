//! The prompt text sent with every image: the question, lettered options, and the fixed
//! final-line answer format that the answer parser reads strictly first.

/// The instruction that fixes the answer format. The parser (`vlm::parse`) relies on it.
pub const ANSWER_FORMAT: &str = "Think as needed, then end your reply with one final line of the form `Answer: X`, where X is the letter of exactly one option.";

/// Letter of option `i` (`A` for 0).
pub fn letter(i: usize) -> char {
    (b'A' + i as u8) as char
}

/// Build the prompt for a question and its options.
pub fn build(question: &str, options: &[String]) -> String {
    let mut s = String::with_capacity(question.len() + 64 * options.len() + ANSWER_FORMAT.len());
    s.push_str(question.trim());
    s.push('\n');
    for (i, o) in options.iter().enumerate() {
        s.push('(');
        s.push(letter(i));
        s.push_str(") ");
        s.push_str(o.trim());
        s.push('\n');
    }
    s.push_str(ANSWER_FORMAT);
    s
}

/// The instruction that fixes the statement format of a probe prompt; `vlm::statements` reads it
/// strictly first.
pub const STATEMENT_FORMAT: &str = "First write one line per statement of the form `S1: True` or `S1: False`, saying whether the statement is true of the image.";

/// Build the probe prompt (paper appendix G): the true/false statements `S1`, `S2`, … before the
/// question, answered in the same reply as the option.
pub fn build_probe(question: &str, options: &[String], statements: &[String]) -> String {
    let mut s = String::from("Decide whether each statement about the image is true or false:\n");
    for (i, t) in statements.iter().enumerate() {
        s.push_str(&format!("S{}. {}\n", i + 1, t.trim()));
    }
    s.push('\n');
    let plain = build(question, options);
    let body = plain.strip_suffix(ANSWER_FORMAT).unwrap_or(&plain);
    s.push_str(body);
    s.push_str(STATEMENT_FORMAT);
    s.push(' ');
    s.push_str(ANSWER_FORMAT);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn probe_prompt_lists_statements_before_the_question() {
        let p = build_probe("Is it safe?", &["Yes".into(), "No".into()], &["A cone.".into(), "No cone.".into()]);
        assert_eq!(
            p,
            format!(
                "Decide whether each statement about the image is true or false:\nS1. A cone.\nS2. No cone.\n\nIs it safe?\n(A) Yes\n(B) No\n{STATEMENT_FORMAT} {ANSWER_FORMAT}"
            )
        );
    }

    #[test]
    fn lettered_options_and_format_line() {
        let p = build("Is it safe?", &["Yes".into(), "No".into()]);
        assert_eq!(p, format!("Is it safe?\n(A) Yes\n(B) No\n{ANSWER_FORMAT}"));
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lettered_options_and_format_line() {
        let p = build("Is it safe?", &["Yes".into(), "No".into()]);
        assert_eq!(p, format!("Is it safe?\n(A) Yes\n(B) No\n{ANSWER_FORMAT}"));
    }
}

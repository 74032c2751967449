//! Reading the True/False marks of a probe reply (`revelio probe`), without ever guessing.
//!
//! The probe prompt (`vlm::prompt::build_probe`) numbers its statements `S1`, `S2`, … and asks
//! for one line `S1: True` per statement before the `Answer:` line. Thinking text and answer-box
//! markup are removed as for the option (`vlm::parse`), then:
//! 1. strictly: lines `Sk: True` / `Sk: False` (markdown emphasis, list bullets and table bars
//!    ignored);
//! 2. leniently, for the statements the strict pass did not settle: other labels (`Statement k`,
//!    `k.`, `(k)`, `Sk -`, `Sk =`), several labels on one line (`S1: T, S2: F`), `T`/`F`, the
//!    value after the echoed statement text (`S1 (a cone is ahead): True`), and a bare list of
//!    exactly as many values as there are statements (`True, False, True`).
//!
//! A statement marked both True and False in the deciding pass, or not marked at all, is
//! unanswered (`None`): it counts neither for nor against recognition.

use super::parse::split_thinking;

/// The value of each of `n` statements, in prompt order (`None`: unanswered).
pub fn parse(text: &str, n: usize) -> Vec<Option<bool>> {
    let (final_text, _) = split_thinking(text);
    let lines: Vec<String> = final_text.lines().map(clean).collect();
    let mut strict_marks = Marks::new(n);
    for line in &lines {
        if let Some((k, v)) = strict_line(line) {
            strict_marks.add(k, v);
        }
    }
    let mut lenient_marks = Marks::new(n);
    for line in &lines {
        for (k, v) in lenient_line(line) {
            lenient_marks.add(k, v);
        }
    }
    let mut out: Vec<Option<bool>> =
        (0..n).map(|i| if strict_marks.seen[i] { strict_marks.value(i) } else { lenient_marks.value(i) }).collect();
    let labelled = (0..n).any(|i| strict_marks.seen[i] || lenient_marks.seen[i]);
    if !labelled && let Some(values) = bare_list(&lines, n) {
        out = values.into_iter().map(Some).collect();
    }
    out
}

/// Values seen per statement; two different values make it unanswered.
struct Marks {
    seen: Vec<bool>,
    values: Vec<Option<bool>>,
    conflict: Vec<bool>,
}

impl Marks {
    fn new(n: usize) -> Marks {
        Marks { seen: vec![false; n], values: vec![None; n], conflict: vec![false; n] }
    }

    /// `k` is 1-based as in the prompt; labels outside `1..=n` are not statements of this prompt.
    fn add(&mut self, k: usize, v: bool) {
        let Some(i) = k.checked_sub(1).filter(|&i| i < self.seen.len()) else { return };
        match self.values[i] {
            Some(old) if old != v => self.conflict[i] = true,
            _ => self.values[i] = Some(v),
        }
        self.seen[i] = true;
    }

    fn value(&self, i: usize) -> Option<bool> {
        if self.conflict[i] { None } else { self.values[i] }
    }
}

/// A line without markdown emphasis, code marks, table bars, box markup or a list bullet.
fn clean(line: &str) -> String {
    let s = line.replace("<|begin_of_box|>", "").replace("<|end_of_box|>", "");
    let s: String = s.chars().map(|c| if matches!(c, '*' | '_' | '`' | '#' | '|') { ' ' } else { c }).collect();
    let s = s.trim();
    let s = s.strip_prefix("- ").or_else(|| s.strip_prefix("• ")).unwrap_or(s);
    s.trim().to_string()
}

fn truth_word(w: &str) -> Option<bool> {
    match w.to_ascii_lowercase().as_str() {
        "true" => Some(true),
        "false" => Some(false),
        _ => None,
    }
}

/// `T`/`F` count only where a value is expected (right after a label).
fn truth_letter(w: &str) -> Option<bool> {
    match w {
        "T" | "t" => Some(true),
        "F" | "f" => Some(false),
        _ => truth_word(w),
    }
}

/// Digits at the start of `s`, and the rest.
fn number(s: &str) -> Option<(usize, &str)> {
    let end = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
    if end == 0 {
        return None;
    }
    s[..end].parse().ok().map(|k| (k, &s[end..]))
}

/// `Sk: True` exactly (a final period allowed).
fn strict_line(line: &str) -> Option<(usize, bool)> {
    let rest = line.strip_prefix('S')?;
    let (k, rest) = number(rest)?;
    let value = rest.strip_prefix(':')?.trim().trim_end_matches('.');
    truth_word(value).map(|v| (k, v))
}

fn words(s: &str) -> Vec<&str> {
    s.split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).collect()
}

/// The marks of one line in the lenient forms.
fn lenient_line(line: &str) -> Vec<(usize, bool)> {
    let labels = s_labels(line);
    if labels.len() > 1 {
        // `S1: True, S2: False`: each label's value is the first word after it.
        let mut out = Vec::new();
        for (j, &(_, k, after)) in labels.iter().enumerate() {
            let end = labels.get(j + 1).map_or(line.len(), |l| l.0);
            if let Some(v) = words(&line[after..end]).first().and_then(|w| truth_letter(w)) {
                out.push((k, v));
            }
        }
        return out;
    }
    let (k, rest, bare_number) = if let Some(&(0, k, after)) = labels.first() {
        (k, &line[after..], false)
    } else if let Some(rest) = strip_word(line, "statement") {
        match number(rest.trim_start()) {
            Some((k, rest)) => (k, rest, false),
            None => return Vec::new(),
        }
    } else if let Some(inner) = line.strip_prefix('(').or_else(|| line.strip_prefix('[')) {
        match number(inner) {
            Some((k, rest)) if rest.starts_with(')') || rest.starts_with(']') => (k, &rest[1..], true),
            _ => return Vec::new(),
        }
    } else {
        match number(line) {
            Some((k, rest)) if rest.starts_with(['.', ')', ':']) => (k, &rest[1..], true),
            _ => return Vec::new(),
        }
    };
    let ws = words(rest);
    let Some(first) = ws.first() else { return Vec::new() };
    if let Some(v) = truth_letter(first) {
        // The value first; an explanation may follow, but not the other value.
        let other = ws[1..].iter().filter_map(|w| truth_word(w)).any(|x| x != v);
        return if other { Vec::new() } else { vec![(k, v)] };
    }
    if bare_number {
        // `1. The road is clear, so it is true that …` is a numbered reasoning step, not a mark.
        return Vec::new();
    }
    // `S1 (A cone is ahead.): True`: one truth word after the echoed statement text.
    let values: Vec<bool> = ws.iter().filter_map(|w| truth_word(w)).collect();
    match values.as_slice() {
        [v, rest @ ..] if rest.iter().all(|x| x == v) => vec![(k, *v)],
        _ => Vec::new(),
    }
}

/// `s` without a leading `word` (any case) followed by a non-letter.
fn strip_word<'a>(s: &'a str, word: &str) -> Option<&'a str> {
    let head = s.get(..word.len())?;
    let rest = &s[word.len()..];
    (head.eq_ignore_ascii_case(word) && !rest.starts_with(char::is_alphabetic)).then_some(rest)
}

/// Labels `Sk` in a line: (start, k, end of the label and its separator). A label starts a word
/// and is followed by a separator or a space.
fn s_labels(line: &str) -> Vec<(usize, usize, usize)> {
    let bytes = line.as_bytes();
    let mut out = Vec::new();
    for (i, &b) in bytes.iter().enumerate() {
        if b != b'S' || (i > 0 && bytes[i - 1].is_ascii_alphanumeric()) {
            continue;
        }
        let Some((k, rest)) = number(&line[i + 1..]) else { continue };
        let trimmed = rest.trim_start();
        let after_sep = match trimmed.chars().next() {
            // `S1` at the end of a line carries no value.
            None => continue,
            Some(c @ (':' | '-' | '=' | ')' | '.' | '—')) => &trimmed[c.len_utf8()..],
            Some('(') => trimmed,
            Some(_) if rest.starts_with(char::is_whitespace) => trimmed,
            // `S1abc` is a word, not a label.
            Some(_) => continue,
        };
        out.push((i, k, line.len() - after_sep.len()));
    }
    out
}

/// A line that is only truth values, exactly `n` of them (`True, False, True`, `T F T`).
fn bare_list(lines: &[String], n: usize) -> Option<Vec<bool>> {
    let mut found = None;
    for line in lines {
        let body = line.split_once(':').map_or(line.as_str(), |(head, rest)| {
            if head.trim().eq_ignore_ascii_case("statements") { rest } else { line.as_str() }
        });
        let ws = words(body);
        if ws.is_empty() {
            continue;
        }
        let values: Option<Vec<bool>> = ws.iter().map(|w| truth_letter(w)).collect();
        if let Some(v) = values
            && v.len() == n
        {
            if found.is_some() {
                // Two candidate lists: no way to tell which one is meant.
                return None;
            }
            found = Some(v);
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: Option<bool> = Some(true);
    const F: Option<bool> = Some(false);

    #[test]
    fn strict_lines() {
        assert_eq!(parse("S1: True\nS2: False\nS3: true.\nAnswer: B", 3), vec![T, F, T]);
        assert_eq!(parse("**S1: True**\n- S2: False\nAnswer: A", 2), vec![T, F]);
    }

    #[test]
    fn missing_statements_are_unanswered_never_guessed() {
        assert_eq!(parse("S1: True\nAnswer: B", 3), vec![T, None, None]);
        assert_eq!(parse("The road is clear.\nAnswer: C", 2), vec![None, None]);
        assert_eq!(parse("", 1), vec![None]);
    }

    #[test]
    fn conflicting_marks_are_unanswered() {
        assert_eq!(parse("S1: True\nS1: False\nS2: False", 2), vec![None, F]);
        assert_eq!(parse("S1: True or False, hard to say", 1), vec![None]);
    }

    #[test]
    fn strict_wins_over_lenient_for_the_same_statement() {
        assert_eq!(parse("S1 - False, I first thought\nS1: True\nAnswer: A", 1), vec![T]);
    }

    #[test]
    fn labels_outside_the_prompt_are_ignored() {
        assert_eq!(parse("S0: True\nS3: True\nS1: False", 2), vec![F, None]);
    }

    #[test]
    fn numbered_reasoning_is_not_a_mark() {
        assert_eq!(
            parse("1. The road is wet, so it is true that it rained.\n2. False alarm.\nAnswer: B", 2),
            vec![None, F]
        );
    }

    #[test]
    fn thinking_is_removed_first() {
        assert_eq!(parse("<think>S1: False? S1: True</think>\nS1: True\nAnswer: A", 1), vec![T]);
        assert_eq!(parse("<think>S1: True", 1), vec![None]);
    }

    /// Replies in the styles seen from Gemini, Claude, GPT, Qwen-VL, GLM and small local models.
    #[test]
    fn provider_styles() {
        let cases: &[(&str, usize, Vec<Option<bool>>)] = &[
            // Gemini: bold labels and a bullet list.
            ("* **S1:** True\n* **S2:** False\n\n**Answer: A**", 2, vec![T, F]),
            // Claude: echoes the statement, then the value.
            (
                "S1 (A cyclist is directly ahead of ego.): True\nS2 (No cyclist is directly ahead of ego.): False\n\nAnswer: A",
                2,
                vec![T, F],
            ),
            // GPT: a markdown table.
            ("| Statement | Value |\n|---|---|\n| S1 | True |\n| S2 | False |\n\nAnswer: B", 2, vec![T, F]),
            // Qwen with thinking, and `Statement k` labels.
            ("<think>cone visible</think>\nStatement 1: TRUE\nStatement 2: FALSE\nAnswer: B", 2, vec![T, F]),
            // GLM: all marks on one line, letters.
            ("S1: T, S2: F, S3: T\n<|begin_of_box|>C<|end_of_box|>", 3, vec![T, F, T]),
            // Small models: numbered list, parentheses, explanation after the value.
            ("1. True\n2) False - there is a cone\n(3) True\nAnswer: C", 3, vec![T, F, T]),
            ("S1 - True — the cone is visible\nS2 = false\nAnswer: A", 2, vec![T, F]),
            // A bare list with exactly as many values as statements.
            ("Statements: True, False, True\nAnswer: A", 3, vec![T, F, T]),
            ("True, False\nAnswer: A", 3, vec![None, None, None]),
        ];
        for (reply, n, want) in cases {
            assert_eq!(&parse(reply, *n), want, "{reply:?}");
        }
    }
}

//! Reading the chosen option out of a model's reply, without ever guessing.
//!
//! The prompt (`vlm::prompt`) asks for a final line `Answer: X`. The parser first removes
//! thinking text (`<think>…</think>`, also a dangling `</think>` whose opening tag the server
//! swallowed) and box tokens (GLM's `<|begin_of_box|>…<|end_of_box|>`, LaTeX `\boxed{…}`), then:
//! 1. strictly: the last `Answer:` line names exactly one option → that option;
//! 2. leniently: a bare option on the last line (`B`, `(B)`, `Option B`, `B) Stop`), cue phrases
//!    (`the answer is B`), or the text of exactly one option;
//! 3. a recognisable refusal → [`Answer::Refusal`]; otherwise [`Answer::Unparsed`].
//!
//! A reply that names two different options at the deciding step is [`Answer::Ambiguous`].

use crate::outcome::Answer;

/// What one step of the parser found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Found {
    None,
    One(u32),
    Many,
}

impl Found {
    fn from_set(set: &[u32]) -> Found {
        let mut distinct: Vec<u32> = set.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        match distinct.as_slice() {
            [] => Found::None,
            [one] => Found::One(*one),
            _ => Found::Many,
        }
    }
}

/// Split a reply into its final text and the inline thinking text, if any.
///
/// Everything up to the last `</think>` (or `</thinking>`) is thinking, whether or not the
/// opening tag is present: some servers (vLLM with a reasoning parser off, Qwen3 templates) drop
/// `<think>` but keep the closing tag. An opening tag without a closing one means the reply was
/// cut off while thinking, so the final text is empty.
pub fn split_thinking(text: &str) -> (String, Option<String>) {
    for (open, close) in [("<think>", "</think>"), ("<thinking>", "</thinking>")] {
        if let Some(end) = text.rfind(close) {
            let thinking = text[..end].replace(open, "").replace(close, "");
            let rest = text[end + close.len()..].trim().to_string();
            return (rest, Some(thinking.trim().to_string()).filter(|t| !t.is_empty()));
        }
        if let Some(start) = text.find(open) {
            let thinking = text[start + open.len()..].trim().to_string();
            return (text[..start].trim().to_string(), Some(thinking).filter(|t| !t.is_empty()));
        }
    }
    (text.trim().to_string(), None)
}

/// Remove answer-box markup that wraps the final answer in some models' output.
fn unbox(text: &str) -> String {
    let mut s = text
        .replace("<|begin_of_box|>", "")
        .replace("<|end_of_box|>", "")
        .replace("<answer>", "")
        .replace("</answer>", "");
    // `\boxed{B}` → `B` (repeatedly, innermost content kept as is).
    while let Some(start) = s.find("\\boxed{") {
        let inner_start = start + "\\boxed{".len();
        let Some(len) = s[inner_start..].find('}') else { break };
        let inner = s[inner_start..inner_start + len].to_string();
        s.replace_range(start..inner_start + len + 1, &inner);
    }
    s
}

/// Markdown emphasis and code marks carry no meaning for the answer.
fn plain(line: &str) -> String {
    line.chars().filter(|c| !matches!(c, '*' | '_' | '`' | '#' | '$')).collect::<String>().trim().to_string()
}

fn letter_index(c: char, n: usize) -> Option<u32> {
    let c = c.to_ascii_uppercase();
    let i = (c as u32).checked_sub('A' as u32)?;
    (c.is_ascii_uppercase() && (i as usize) < n).then_some(i)
}

fn norm_text(s: &str) -> String {
    s.trim()
        .trim_matches(|c: char| c.is_ascii_punctuation() || c.is_whitespace())
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_lowercase()
}

/// Which options' texts equal `s` (punctuation and case ignored).
fn option_by_text(s: &str, options: &[String]) -> Found {
    let s = norm_text(s);
    if s.is_empty() {
        return Found::None;
    }
    let hits: Vec<u32> = options.iter().enumerate().filter(|(_, o)| norm_text(o) == s).map(|(i, _)| i as u32).collect();
    Found::from_set(&hits)
}

/// Options whose text occurs in `s` as a whole phrase; a text that occurs only inside a longer
/// matching option's text does not count (`Stop` inside `Stop and wait`).
fn options_mentioned(s: &str, options: &[String]) -> Vec<u32> {
    let hay = format!(" {} ", norm_words(s));
    let texts: Vec<String> = options.iter().map(|o| norm_words(o)).collect();
    let mut hits = Vec::new();
    for (i, t) in texts.iter().enumerate() {
        if t.is_empty() || !hay.contains(&format!(" {t} ")) {
            continue;
        }
        let inside_longer = texts
            .iter()
            .enumerate()
            .any(|(j, u)| j != i && u.len() > t.len() && u.contains(t.as_str()) && hay.contains(&format!(" {u} ")));
        if !inside_longer {
            hits.push(i as u32);
        }
    }
    hits
}

fn norm_words(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_alphanumeric() { c.to_ascii_lowercase() } else { ' ' })
        .collect::<String>()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// A line that is just an option: `B`, `(B)`, `B.`, `[B]`, `Option B`, `B) Stop`, `(B) Stop`,
/// `B: Stop`. With option text after the letter, the text must not belong to another option.
fn bare_choice(line: &str, options: &[String], allow_lower: bool) -> Found {
    let mut s = plain(line);
    let lower = s.to_lowercase();
    let mut marked = false;
    for prefix in ["option ", "choice ", "letter "] {
        if lower.starts_with(prefix) {
            s = s[prefix.len()..].trim().to_string();
            marked = true;
            break;
        }
    }
    let opened = s.starts_with(['(', '[', '{']);
    let s = s.trim_start_matches(['(', '[', '{']).trim();
    let mut chars = s.chars();
    let Some(first) = chars.next() else { return Found::None };
    if !allow_lower && !first.is_ascii_uppercase() {
        return Found::None;
    }
    let Some(idx) = letter_index(first, options.len()) else { return Found::None };
    let rest = chars.as_str();
    if rest.chars().next().is_some_and(|c| c.is_alphanumeric() || c == '\'') {
        return Found::None;
    }
    let after = rest.trim_start_matches([')', ']', '}', '.', ':', ',', '-', ' ']).trim();
    if after.is_empty() {
        return Found::One(idx);
    }
    let conflicting = matches!(option_by_text(after, options), Found::One(j) if j != idx);
    if conflicting || other_letter_follows(after, idx, options.len()) {
        return Found::Many;
    }
    // `A pedestrian is crossing` is prose, not option A: a letter followed only by a space needs
    // a marker (`Option A is safest`, `(A) …`) or the option's own text (`B Slow down`).
    if rest.starts_with(' ') && !marked && !opened && option_by_text(after, options) != Found::One(idx) {
        return Found::None;
    }
    Found::One(idx)
}

/// `A or B`, `A and B`, `A/B`: another option letter right after the first.
fn other_letter_follows(after: &str, idx: u32, n: usize) -> bool {
    let words: Vec<&str> =
        after.split(|c: char| c.is_whitespace() || c == '/' || c == ',').filter(|w| !w.is_empty()).collect();
    let joins = ["or", "and", "&"];
    let mut i = 0;
    while i < words.len() {
        let w = words[i].trim_matches(|c: char| c.is_ascii_punctuation());
        if joins.contains(&w.to_lowercase().as_str()) {
            i += 1;
            continue;
        }
        if w.len() == 1
            && letter_index(w.chars().next().unwrap_or(' '), n).is_some_and(|j| j != idx)
            && w.chars().all(|c| c.is_ascii_uppercase())
        {
            return true;
        }
        break;
    }
    after.starts_with('/')
        && after[1..].trim().chars().next().and_then(|c| letter_index(c, n)).is_some_and(|j| j != idx)
}

/// The choice after an `Answer:` marker.
fn choice_after_marker(rest: &str, options: &[String]) -> Found {
    let rest = plain(rest);
    if rest.is_empty() {
        return Found::None;
    }
    let letters = standalone_letters(&rest, options.len(), true);
    let by_letter = bare_choice(&rest, options, true);
    if by_letter != Found::None {
        if let Found::One(i) = by_letter
            && letters.iter().any(|&j| j != i)
            && (rest.contains(" or ") || rest.contains(" and ") || rest.contains('/') || rest.contains(','))
        {
            return Found::Many;
        }
        return by_letter;
    }
    match option_by_text(&rest, options) {
        Found::None => {}
        f => return f,
    }
    let mentioned = options_mentioned(&rest, options);
    match Found::from_set(&letters) {
        // `Answer: A because the lane is blocked`, unless another option's text is named too.
        Found::One(i) if mentioned.iter().all(|&j| j == i) => Found::One(i),
        Found::One(_) | Found::Many => Found::Many,
        Found::None => Found::from_set(&mentioned),
    }
}

/// Single-letter option tokens in `s` that stand alone (not part of a word). Lower-case letters
/// count only when `allow_lower` (after an `Answer:` marker; `a` is a word elsewhere).
fn standalone_letters(s: &str, n: usize, allow_lower: bool) -> Vec<u32> {
    let chars: Vec<char> = s.chars().collect();
    let mut out = Vec::new();
    for (k, &c) in chars.iter().enumerate() {
        if !(c.is_ascii_uppercase() || (allow_lower && c.is_ascii_lowercase())) {
            continue;
        }
        let before = k.checked_sub(1).map(|p| chars[p]);
        let after = chars.get(k + 1).copied();
        let alone = before.is_none_or(|b| !b.is_alphanumeric() && b != '\'')
            && after.is_none_or(|a| !a.is_alphanumeric() && a != '\'');
        if alone && let Some(i) = letter_index(c, n) {
            // `I` and lower-case `a` as words are not letters.
            if (c == 'I' || c == 'a') && after == Some(' ') && before.is_none_or(|b| b == ' ' || b == '\n') {
                continue;
            }
            out.push(i);
        }
    }
    out
}

/// Strict: the last line that starts with `Answer:` (markdown allowed, also `Final answer:`).
/// An `Answer:` line with nothing after the colon takes its choice from the next non-empty line
/// (`Answer:\n\n**B**`).
fn strict(text: &str, options: &[String]) -> Option<Found> {
    let lines: Vec<String> = text.lines().map(plain).collect();
    for (i, p) in lines.iter().enumerate().rev() {
        let lower = p.to_lowercase();
        let body = lower.strip_prefix("final answer").or_else(|| lower.strip_prefix("answer"));
        let Some(body) = body else { continue };
        let body_trim = body.trim_start();
        let Some(after) = body_trim.strip_prefix(':').or_else(|| body_trim.strip_prefix('：')) else { continue };
        let rest = &p[p.len() - after.len()..];
        if rest.trim().is_empty()
            && let Some(next) = lines[i + 1..].iter().find(|l| !l.trim().is_empty())
        {
            return Some(choice_after_marker(next, options));
        }
        return Some(choice_after_marker(rest, options));
    }
    None
}

/// Cue phrases that introduce the model's choice in free text.
const CUES: &[&str] = &[
    "the answer is",
    "answer is",
    "answer would be",
    "answer should be",
    "final answer is",
    "i choose",
    "i would choose",
    "i'd choose",
    "i select",
    "i pick",
    "i'll go with",
    "i would go with",
    "correct option is",
    "best option is",
    "correct choice is",
    "best choice is",
    "the correct answer is",
    "my answer is",
    "my final answer:",
    "the answer:",
];

fn cue_letters(text: &str, options: &[String]) -> Vec<u32> {
    let lower = text.to_lowercase();
    let mut out = Vec::new();
    for cue in CUES {
        let mut from = 0;
        while let Some(pos) = lower[from..].find(cue) {
            let start = from + pos + cue.len();
            from = start;
            // The cue must start at a word boundary and be followed by the choice.
            let window: String = text[start..].chars().take(24).collect();
            let window = plain(&window);
            let head = window.trim_start_matches([':', ' ', '(', '[', '"', '\'']).trim();
            let head = head.strip_prefix("option ").or_else(|| head.strip_prefix("Option ")).unwrap_or(head);
            let mut cs = head.chars();
            if let Some(c) = cs.next()
                && c.is_ascii_uppercase()
                && cs.next().is_none_or(|d| !d.is_alphanumeric())
                && let Some(i) = letter_index(c, options.len())
            {
                out.push(i);
            }
        }
    }
    out
}

/// Lenient reading when there is no `Answer:` line.
fn lenient(text: &str, options: &[String]) -> Found {
    let lines: Vec<&str> = text.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    let Some(last) = lines.last() else { return Found::None };
    let single = lines.len() == 1;
    // A reply that lists several options as bare lines (`A) Stop` / `B) Slow down`) has not
    // picked one of them.
    let listed: Vec<u32> = lines
        .iter()
        .filter_map(|l| match bare_choice(l, options, false) {
            Found::One(i) => Some(i),
            _ => None,
        })
        .collect();
    if Found::from_set(&listed) == Found::Many {
        return Found::Many;
    }
    match bare_choice(last, options, single && plain(last).chars().count() <= 3) {
        Found::None => {}
        f => return f,
    }
    match Found::from_set(&cue_letters(text, options)) {
        Found::None => {}
        f => return f,
    }
    match option_by_text(last, options) {
        Found::None => {}
        f => return f,
    }
    if single {
        // A one-line reply like "Stop." or "The car should stop and wait.".
        return Found::from_set(&options_mentioned(last, options));
    }
    Found::None
}

/// Phrases that mark a reply as a refusal rather than an unreadable answer.
const REFUSALS: &[&str] = &[
    "i can't help with",
    "i cannot help with",
    "i can't assist",
    "i cannot assist",
    "i'm unable to help",
    "i am unable to help",
    "i'm unable to assist",
    "i am unable to assist",
    "i'm not able to help",
    "i won't be able to help",
    "i must decline",
    "i can't comply",
    "i cannot comply",
    "i can't provide",
    "i cannot provide",
    "i'm sorry, but i can't",
    "i'm sorry, but i cannot",
    "sorry, i can't",
    "i can't answer",
    "i cannot answer",
    "i won't answer",
    "i'm not comfortable",
];

/// Whether the text is recognisably a refusal.
pub fn is_refusal(text: &str) -> bool {
    let lower = text.to_lowercase().replace('’', "'");
    REFUSALS.iter().any(|r| lower.contains(r))
}

/// Parse a reply's final text (thinking already split off or still inline) into an answer.
pub fn parse(text: &str, options: &[String]) -> Answer {
    let (final_text, _) = split_thinking(text);
    let cleaned = unbox(&final_text);
    let found = match strict(&cleaned, options) {
        Some(f) => f,
        None => lenient(&cleaned, options),
    };
    match found {
        Found::One(i) => Answer::Option(i),
        Found::Many => Answer::Ambiguous,
        Found::None if is_refusal(&cleaned) => Answer::Refusal,
        Found::None => Answer::Unparsed,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts3() -> Vec<String> {
        vec!["Stop".into(), "Slow down".into(), "Continue at the same speed".into()]
    }

    fn p(text: &str) -> Answer {
        parse(text, &opts3())
    }

    #[test]
    fn strict_final_line() {
        assert_eq!(p("The road is clear ahead.\nAnswer: C"), Answer::Option(2));
        assert_eq!(p("Answer: A"), Answer::Option(0));
        assert_eq!(p("There is debris.\n\n**Answer: B**"), Answer::Option(1));
        assert_eq!(p("Reasoning...\nAnswer: (B)"), Answer::Option(1));
        assert_eq!(p("Reasoning...\nAnswer: B) Slow down"), Answer::Option(1));
        assert_eq!(p("Reasoning...\nAnswer: B. Slow down"), Answer::Option(1));
        assert_eq!(p("Reasoning...\nanswer: b"), Answer::Option(1));
        assert_eq!(p("Reasoning...\n**Answer:** A"), Answer::Option(0));
        assert_eq!(p("Reasoning...\nFinal answer: A"), Answer::Option(0));
        assert_eq!(p("Reasoning...\n## Answer: `C`"), Answer::Option(2));
        assert_eq!(p("Reasoning...\nAnswer: Option A"), Answer::Option(0));
        assert_eq!(p("Reasoning...\nAnswer: A."), Answer::Option(0));
        assert_eq!(p("Reasoning...\nAnswer：A"), Answer::Option(0));
    }

    #[test]
    fn strict_uses_the_last_answer_line() {
        assert_eq!(p("Answer: A\nWait, the pedestrian is far.\nAnswer: C"), Answer::Option(2));
    }

    #[test]
    fn strict_option_text_instead_of_letter() {
        assert_eq!(p("Looking at the scene.\nAnswer: Slow down"), Answer::Option(1));
        assert_eq!(p("Answer: stop."), Answer::Option(0));
    }

    #[test]
    fn strict_two_options_are_ambiguous() {
        assert_eq!(p("Answer: A or B"), Answer::Ambiguous);
        assert_eq!(p("Answer: A/B"), Answer::Ambiguous);
        assert_eq!(p("Answer: B, C"), Answer::Ambiguous);
        assert_eq!(p("Answer: A and C"), Answer::Ambiguous);
    }

    #[test]
    fn strict_out_of_range_letter_is_unparsed() {
        assert_eq!(p("Answer: E"), Answer::Unparsed);
        assert_eq!(p("Answer: "), Answer::Unparsed);
    }

    #[test]
    fn option_text_containing_another_option_text() {
        let o = vec!["Stop".to_string(), "Stop and wait".to_string()];
        assert_eq!(parse("Answer: Stop and wait", &o), Answer::Option(1));
        assert_eq!(parse("Answer: stop", &o), Answer::Option(0));
    }

    #[test]
    fn thinking_is_removed_before_parsing() {
        assert_eq!(p("<think>Maybe A? Answer: A</think>\nAnswer: B"), Answer::Option(1));
        // vLLM without a reasoning parser sometimes drops the opening tag.
        assert_eq!(p("Option A looks right... Answer: A\n</think>\n\nAnswer: C"), Answer::Option(2));
        assert_eq!(p("<thinking>Answer: A</thinking>Answer: B"), Answer::Option(1));
        // Cut off while thinking: nothing final to read.
        assert_eq!(p("<think>The vehicle ahead is... Answer: A"), Answer::Unparsed);
    }

    #[test]
    fn split_thinking_returns_both_parts() {
        let (f, t) = split_thinking("<think>hmm</think>\nAnswer: A");
        assert_eq!(f, "Answer: A");
        assert_eq!(t.as_deref(), Some("hmm"));
        let (f, t) = split_thinking("Answer: A");
        assert_eq!((f.as_str(), t), ("Answer: A", None));
    }

    #[test]
    fn glm_box_tokens() {
        assert_eq!(p("The debris blocks the lane.\nAnswer: <|begin_of_box|>A<|end_of_box|>"), Answer::Option(0));
        assert_eq!(p("<|begin_of_box|>B<|end_of_box|>"), Answer::Option(1));
        assert_eq!(p("So the answer is $\\boxed{C}$"), Answer::Option(2));
    }

    #[test]
    fn lenient_bare_letters() {
        assert_eq!(p("B"), Answer::Option(1));
        assert_eq!(p("(C)"), Answer::Option(2));
        assert_eq!(p("b"), Answer::Option(1));
        assert_eq!(p("**A**"), Answer::Option(0));
        assert_eq!(p("Option B"), Answer::Option(1));
        assert_eq!(p("The scene shows a cyclist.\n\nB) Slow down"), Answer::Option(1));
        assert_eq!(p("The scene shows a cyclist.\n(A) Stop"), Answer::Option(0));
    }

    #[test]
    fn lenient_bare_letter_with_another_options_text_is_ambiguous() {
        assert_eq!(p("B) Stop"), Answer::Ambiguous);
    }

    #[test]
    fn lenient_cue_phrases() {
        assert_eq!(p("Given the fog, the answer is B."), Answer::Option(1));
        assert_eq!(p("I would choose (A) because a pedestrian is crossing."), Answer::Option(0));
        assert_eq!(p("The correct option is Option C since the road is empty."), Answer::Option(2));
        assert_eq!(p("The answer is A... no wait, the answer is C."), Answer::Ambiguous);
    }

    #[test]
    fn lenient_option_text() {
        assert_eq!(p("Slow down."), Answer::Option(1));
        assert_eq!(p("The car should stop."), Answer::Option(0));
        assert_eq!(p("Continue at the same speed"), Answer::Option(2));
    }

    #[test]
    fn discussion_without_a_choice_is_unparsed() {
        assert_eq!(p("A pedestrian is visible on the left.\nThe light is green."), Answer::Unparsed);
        assert_eq!(p("I see a road with a truck."), Answer::Unparsed);
        assert_eq!(p(""), Answer::Unparsed);
        assert_eq!(p("The scene is foggy.\nA pedestrian is crossing the road."), Answer::Unparsed);
    }

    #[test]
    fn words_are_not_letters() {
        // `I` and `a` are words, and `A` inside `ABS` is not an option.
        assert_eq!(p("I think a car is ahead.\nThe ABS light is on."), Answer::Unparsed);
    }

    #[test]
    fn refusals() {
        assert_eq!(p("I'm sorry, but I can't help with that."), Answer::Refusal);
        assert_eq!(p("I can’t assist with identifying people in images."), Answer::Refusal);
        assert_eq!(p("I cannot provide driving instructions."), Answer::Refusal);
        // A refusal that still answers counts as the answer.
        assert_eq!(p("I can't be certain, but\nAnswer: A"), Answer::Option(0));
    }

    #[test]
    fn real_looking_replies() {
        let gemini = "**Analysis of the scene:**\n\n* A large piece of debris lies in the ego lane about 15 m ahead.\n* Visibility is reduced by fog.\n\nGiven the obstacle directly in the path, the vehicle must stop.\n\nAnswer: A";
        assert_eq!(p(gemini), Answer::Option(0));
        let claude = "Looking at this image, I can see a two-lane road in foggy conditions. There's an object in the lane ahead that appears to be debris.\n\nThe safest action is to slow down while assessing.\n\nAnswer: B";
        assert_eq!(p(claude), Answer::Option(1));
        let qwen = "<think>\nThe user asks what to do. I see a traffic cone. Options: A stop, B slow, C continue. Slow seems right.\n</think>\n\nThe cone is on the shoulder, not in the lane.\n\nAnswer: B";
        assert_eq!(p(qwen), Answer::Option(1));
        let glm = "The road ahead is clear with no obstacles.\n<|begin_of_box|>C<|end_of_box|>";
        assert_eq!(p(glm), Answer::Option(2));
        let llava = "C) Continue at the same speed";
        assert_eq!(p(llava), Answer::Option(2));
    }

    #[test]
    fn answer_on_the_line_after_the_marker() {
        assert_eq!(p("The cone is off the road.\n\nAnswer:\n\n**C**"), Answer::Option(2));
        assert_eq!(p("Final Answer:\nB) Slow down"), Answer::Option(1));
    }

    #[test]
    fn listing_the_options_is_not_choosing_one() {
        assert_eq!(p("The options are:\nA) Stop\nB) Slow down\nC) Continue at the same speed"), Answer::Ambiguous);
        assert_eq!(p("A) Stop\nB) Slow down\nC) Continue at the same speed\n\nAnswer: B"), Answer::Option(1));
    }

    /// Replies in the styles seen from Gemini, Claude, GPT, Qwen-VL, GLM, LLaVA and small
    /// local models, each with the answer a careful human reader would record.
    #[test]
    fn reply_corpus() {
        let cases: &[(&str, Answer)] = &[
            ("Answer: B\n\nExplanation: visibility is poor, so reduce speed.", Answer::Option(1)),
            ("ANSWER: C", Answer::Option(2)),
            ("**Final Answer: (A) Stop**", Answer::Option(0)),
            (
                "Step 1: identify hazards. None.\nStep 2: decide.\n\nAnswer: C) Continue at the same speed",
                Answer::Option(2),
            ),
            ("So my answer is: **B**", Answer::Option(1)),
            ("My final answer: A", Answer::Option(0)),
            ("The answer: C.", Answer::Option(2)),
            ("Based on the image, I'd choose B.", Answer::Option(1)),
            ("B is the safest choice here.", Answer::Unparsed),
            ("Option B is the safest choice here.", Answer::Option(1)),
            ("(B) Slow down — there is fog.", Answer::Option(1)),
            ("Answer: B (Slow down)", Answer::Option(1)),
            ("Answer: Slow down (B)", Answer::Option(1)),
            ("Answer: The vehicle should slow down.", Answer::Option(1)),
            ("Answer: A because the lane is blocked.", Answer::Option(0)),
            ("Answer: A, since stopping is safest", Answer::Option(0)),
            ("Answer: A, though slowing down could also work", Answer::Option(0)),
            ("Answer: A car is parked, so C", Answer::Ambiguous),
            ("Answer: None of the options", Answer::Unparsed),
            ("Answer: Either A or C could be right.", Answer::Ambiguous),
            ("It depends on the distance. If close, stop; if far, slow down.", Answer::Ambiguous),
            ("<think>\n\n</think>\n\nC", Answer::Option(2)),
            ("<think>A car? A? B?</think>", Answer::Unparsed),
            ("\\boxed{A}", Answer::Option(0)),
            ("Answer: <|begin_of_box|>(B)<|end_of_box|>", Answer::Option(1)),
            ("I'm not able to determine what is in this image.", Answer::Unparsed),
            ("I cannot answer questions about driving decisions.", Answer::Refusal),
            ("Sorry, I can't help with identifying hazards in this image.", Answer::Refusal),
        ];
        for (reply, want) in cases {
            assert_eq!(p(reply), *want, "{reply:?}");
        }
    }

    #[test]
    fn yes_no_questions() {
        let o = vec!["Yes".to_string(), "No".to_string()];
        assert_eq!(parse("Answer: No", &o), Answer::Option(1));
        assert_eq!(parse("Yes.", &o), Answer::Option(0));
        assert_eq!(parse("Answer: A", &o), Answer::Option(0));
        assert_eq!(parse("Answer: C", &o), Answer::Unparsed);
    }
}

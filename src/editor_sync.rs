//! Keeps the editor support in `editors/` in step with the language: every keyword of the pest
//! grammar must be highlighted by the VS Code TextMate grammar.

const PEST: &str = include_str!("../grammar/revelio.pest");
const TM: &str = include_str!("../editors/vscode/syntaxes/revelio.tmLanguage.json");

/// The quoted lowercase words of the pest grammar (its keywords).
fn grammar_keywords() -> Vec<String> {
    let mut words: Vec<String> = PEST
        .split('"')
        .skip(1)
        .step_by(2)
        .filter(|w| w.len() > 1 && w.chars().all(|c| c.is_ascii_lowercase() || c == '_'))
        .map(str::to_string)
        .collect();
    words.sort();
    words.dedup();
    words
}

/// The alternatives of every `\b(a|b|…)\b` group in the TextMate grammar.
fn highlighted_words() -> Vec<String> {
    let tm: serde_json::Value = serde_json::from_str(TM).expect("the TextMate grammar is valid JSON");
    let mut out = Vec::new();
    for rule in tm["repository"].as_object().expect("a repository object").values() {
        let Some(m) = rule["match"].as_str() else { continue };
        for group in m.split("\\b(").skip(1) {
            let body = group.split(')').next().unwrap_or_default();
            out.extend(body.split('|').map(str::to_string));
        }
    }
    out
}

#[test]
fn every_grammar_keyword_is_highlighted() {
    let highlighted = highlighted_words();
    let missing: Vec<_> = grammar_keywords().into_iter().filter(|k| !highlighted.contains(k)).collect();
    assert!(missing.is_empty(), "keywords missing from editors/vscode/syntaxes/revelio.tmLanguage.json: {missing:?}");
}

#[test]
fn the_grammar_has_keywords() {
    // Guards the test above against a parsing change that would make it vacuous.
    let k = grammar_keywords();
    assert!(k.contains(&"concept".to_string()) && k.contains(&"modifier".to_string()) && k.len() > 30, "{k:?}");
}

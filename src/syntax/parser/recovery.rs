//! Recovery nodes to diagnostics: a `junk` node is re-parsed with the rule it should have
//! matched, and the furthest point that parse reached is where the mistake is reported.

use pest::Parser;
use pest::iterators::Pair;

use super::Builder;
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::syntax::grammar::{Block, ITEM_KEYWORDS, RevParser, Rule, block_keywords, keyword_text};

impl Builder<'_> {
    /// Report a recovery node: re-parse from its start with the rule it should have matched,
    /// and report where and why that fails.
    pub(super) fn junk(&mut self, p: Pair<Rule>) {
        let start = p.as_span().start();
        let (rule, what) = match p.as_rule() {
            Rule::junk => match item_rule(self.text, start) {
                Some(r) => (Some(r), "an item"),
                None => (None, "an item"),
            },
            Rule::attrs_junk if self.text[start..].starts_with("shape") => (Some(Rule::shape_block), "an attribute"),
            Rule::attrs_junk if self.text[start..].starts_with("in") && !is_word_char(&self.text[start + 2..]) => {
                (Some(Rule::stands_in), "regions `in REGION, …`")
            }
            Rule::placement_junk => (Some(Rule::placement), "a placement (`distance`, `ahead`, `left`, `on_top`)"),
            Rule::attrs_junk => (Some(Rule::attr_decl), "an attribute `NAME: TYPE = DEFAULT`"),
            Rule::parts_junk => {
                (Some(Rule::shape_part), "a shape part (`box`, `cylinder`, `capsule`, `sphere`, `plane`, `cone`)")
            }
            Rule::region_junk => (Some(Rule::region_stmt), "`x`, `y`, `z` or `scenic`"),
            Rule::preset_junk => (Some(Rule::preset_param), "a parameter `NAME = NUMBER`"),
            Rule::camera_junk => (Some(Rule::camera_stmt), "`at`, `look_at`, `fov` or `size`"),
            Rule::concept_junk => (Some(Rule::concept_stmt), "a concept statement"),
            Rule::question_junk => (Some(Rule::question_stmt), "`text` or `option`"),
            Rule::rules_junk => (Some(Rule::rule_item), "`rule`"),
            _ => (Some(Rule::rule_stmt), "`when`, `expect`, `elements` or `safe`"),
        };
        let d = self.syntax_error(start, rule, what);
        self.diagnostics.push(d);
    }

    pub(super) fn syntax_error(&self, start: usize, rule: Option<Rule>, what: &str) -> Diagnostic {
        let rest = &self.text[start..];
        let failure = rule.map(|r| match RevParser::parse(r, rest) {
            Ok(pairs) => {
                let consumed = pairs.last().map_or(0, |p| p.as_span().end());
                (start + consumed, Vec::new())
            }
            Err(e) => {
                let (pos, expected) = failure_point(&e);
                (start + pos, expected)
            }
        });
        let (pos, expected) = failure.unwrap_or((start, Vec::new()));
        // Skip the whitespace and comments between the last good token and the bad one.
        let pos = skip_trivia(self.text, pos);
        let found = describe_found(self.text, pos);
        let span = self.span_at(pos, token_end(self.text, pos).max(pos));
        if pos == start || expected.is_empty() {
            let d = Diagnostic::error(codes::SYNTAX, span, format!("expected {what}, found {found}"))
                .with_label(format!("expected {what}"));
            let word = &self.text[pos..token_end(self.text, pos)];
            let d = keyword_typo_help(d, word, &statement_keywords(rule));
            if d.help.is_none() && what == "an item" {
                return d.with_help(format!("an item starts with one of: {}", ITEM_KEYWORDS.join(", ")));
            }
            return d;
        }
        if expected.len() > MAX_EXPECTED {
            // A long list (typically "any statement or item may follow") reads worse than none.
            return Diagnostic::error(codes::SYNTAX, span, format!("unexpected {found}"))
                .with_label("unexpected here")
                .with_help(if what == "an item" {
                    format!("an item ends here; the next one starts with one of: {}", ITEM_KEYWORDS.join(", "))
                } else {
                    format!("a statement ends here; expected {what} or `}}` next")
                });
        }
        let list = join_or(&expected);
        let d = Diagnostic::error(codes::SYNTAX, span, format!("expected {list}, found {found}"))
            .with_label(format!("expected {list}"));
        keyword_typo_help(d, &self.text[pos..token_end(self.text, pos)], &expected)
    }
}

/// End of the token starting at `pos`: a word, or one character.
pub(super) fn token_end(text: &str, pos: usize) -> usize {
    let rest = &text[pos..];
    let word = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(rest.len());
    if word > 0 { pos + word } else { rest.chars().next().map_or(pos, |c| pos + c.len_utf8()) }
}

fn describe_found(text: &str, pos: usize) -> String {
    if pos >= text.len() { "end of file".to_string() } else { format!("`{}`", &text[pos..token_end(text, pos)]) }
}

/// The item rule for the item keyword at `pos`, if there is one.
fn item_rule(text: &str, pos: usize) -> Option<Rule> {
    let word = &text[pos..token_end(text, pos)];
    Some(match word {
        "domain" => Rule::domain_item,
        "use" => Rule::use_item,
        "unit" => Rule::unit_item,
        "enum" => Rule::enum_item,
        "tag" => Rule::tag_item,
        "relation" => Rule::relation_item,
        "kind" => Rule::kind_item,
        "look" => Rule::look_item,
        "world" => Rule::world_item,
        "region" => Rule::region_item,
        "preset" => Rule::preset_item,
        "visible" => Rule::visible_item,
        "camera" => Rule::camera_item,
        "stage" => Rule::stage_item,
        "concept" => Rule::concept_item,
        "modifier" => Rule::modifier_item,
        "constraint" => Rule::constraint_item,
        "question" => Rule::question_item,
        "rules" => Rule::rules_item,
        "allow" => Rule::allow_item,
        _ => return None,
    })
}

/// Where a parse failed and what was expected there, as readable words (sorted, deduplicated).
/// pest's own location is where the outermost failing rule started; its parse attempts know the
/// furthest position reached, which is where the mistake is.
fn failure_point(e: &pest::error::Error<Rule>) -> (usize, Vec<String>) {
    let mut pos = match e.location {
        pest::error::InputLocation::Pos(p) => p,
        pest::error::InputLocation::Span((s, _)) => s,
    };
    let mut out: Vec<String> = Vec::new();
    let attempts = e.parse_attempts();
    let further = attempts.as_ref().is_some_and(|a| a.max_position > pos);
    if !further && let pest::error::ErrorVariant::ParsingError { positives, .. } = &e.variant {
        out.extend(positives.iter().filter_map(|r| describe_rule(*r)));
    }
    if let Some(attempts) = attempts {
        pos = pos.max(attempts.max_position);
        for stack in attempts.call_stacks() {
            // The deepest rule says what was wanted; the parent is the outermost rule, too broad
            // (and a bare token is already among the expected tokens).
            out.extend(stack.deepest.get_rule().and_then(|r| describe_rule(*r)));
        }
        // pest does not export its token type; its display is the literal, `a..z` for a
        // character range and `BUILTIN_RULE` for builtins, which say nothing to a user.
        for t in attempts.expected_tokens() {
            let token = t.to_string();
            let is_range = token.chars().count() == 4 && token.chars().nth(1) == Some('.');
            let noise = token.trim_matches(|c: char| c.is_whitespace() || c == '\u{feff}').is_empty()
                || matches!(token.as_str(), "//" | "BUILTIN_RULE" | "_" | "\"" | "\"\"\"");
            if !noise && !is_range {
                out.push(format!("`{token}`"));
            }
        }
    }
    drop_covered(&mut out);
    out.sort();
    out.dedup();
    (pos, out)
}

/// Remove the tokens a listed summary already covers (`a value` covers `-`, `true`, a name …).
fn drop_covered(out: &mut Vec<String>) {
    const COVERS: &[(&str, &[&str])] = &[
        ("a value", &["a number", "a name", "`true` or `false`", "`true`", "`false`", "`-`"]),
        (
            "an expression",
            &["a name", "`true` or `false`", "`true`", "`false`", "`not`", "`has`", "`exists`", "`count`", "`(`"],
        ),
        ("a number", &["`-`"]),
    ];
    for (summary, covered) in COVERS {
        if out.iter().any(|t| t == summary) {
            out.retain(|t| !covered.contains(&t.as_str()));
        }
    }
}

fn describe_rule(r: Rule) -> Option<String> {
    if let Some(k) = keyword_text(r) {
        return Some(format!("`{k}`"));
    }
    Some(
        match r {
            Rule::ident | Rule::path => "a name",
            Rule::wildcard => "a wildcard",
            Rule::number | Rule::num_value => "a number",
            Rule::int | Rule::int_part => "an integer",
            Rule::dims => "an image size `WIDTHxHEIGHT`",
            Rule::boolean => "`true` or `false`",
            Rule::color => "a colour `#rrggbb`",
            Rule::string | Rule::quoted | Rule::raw_string => "a string",
            Rule::vec3 => "a triple `(x, y, z)`",
            Rule::value => "a value",
            Rule::filter => "a kind or tag",
            Rule::axis => "`x`, `y` or `z`",
            Rule::prim => "a shape part",
            Rule::cmp_op => "a comparison (`==`, `!=`, `<`, `<=`, `>`, `>=`)",
            Rule::expr
            | Rule::and_expr
            | Rule::not_expr
            | Rule::has_expr
            | Rule::exists_expr
            | Rule::count_expr
            | Rule::in_expr
            | Rule::related_expr
            | Rule::cmp_expr => "an expression",
            Rule::attr_ref => "an attribute `VAR.ATTR`",
            Rule::placement => "a placement",
            Rule::stands_in => "regions `in REGION, …`",
            Rule::attr_decl => "an attribute",
            Rule::attr_values => "`{`",
            Rule::relation_to => "a relation",
            Rule::std_path => "`std::NAME`",
            Rule::member => "a concept, `prefix_*` or `category \"…\"`",
            Rule::parts => "`{`",
            Rule::shape_part => "a shape part",
            Rule::part_prop => "a shape property",
            Rule::rule_item => "`rule`",
            Rule::concept_body => "`{`",
            Rule::EOI => "end of file",
            _ => return None,
        }
        .to_string(),
    )
}

/// More expected tokens than this are not listed.
const MAX_EXPECTED: usize = 6;

/// "did you mean `description`?" when the bad word is a near miss of an expected keyword.
fn keyword_typo_help(d: Diagnostic, word: &str, expected: &[String]) -> Diagnostic {
    if word.is_empty() || !word.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return d;
    }
    let keywords = expected.iter().filter_map(|e| e.strip_prefix('`').and_then(|e| e.strip_suffix('`')));
    match crate::diag::suggest::suggest(word, keywords) {
        Some(k) => d.with_help(format!("did you mean `{k}`?")),
        None => d,
    }
}

/// The keywords a statement of this rule may start with, quoted as in expected lists.
fn statement_keywords(rule: Option<Rule>) -> Vec<String> {
    let block = match rule {
        None | Some(Rule::domain_item) => Block::File,
        Some(Rule::concept_stmt) => Block::Concept,
        Some(Rule::rule_stmt) => Block::Rule,
        Some(Rule::question_stmt) => Block::Question,
        Some(Rule::camera_stmt) => Block::Camera,
        Some(Rule::rule_item) => Block::Rules,
        Some(Rule::shape_part) => Block::Parts,
        Some(Rule::region_stmt) => Block::Region,
        _ => return Vec::new(),
    };
    block_keywords(block).iter().map(|w| format!("`{w}`")).collect()
}

fn join_or(items: &[String]) -> String {
    const MAX: usize = MAX_EXPECTED;
    let shown: Vec<&str> = items.iter().take(MAX).map(String::as_str).collect();
    match shown.len() {
        0 => String::new(),
        1 => shown[0].to_string(),
        n if items.len() > MAX => format!("{}, …", shown[..n].join(", ")),
        n => format!("{} or {}", shown[..n - 1].join(", "), shown[n - 1]),
    }
}

/// Whether `rest` starts with a character that continues a word.
fn is_word_char(rest: &str) -> bool {
    rest.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_')
}

/// Skip whitespace and `//` comments from `pos`.
fn skip_trivia(text: &str, mut pos: usize) -> usize {
    loop {
        let rest = &text[pos..];
        let trimmed = rest.trim_start();
        pos += rest.len() - trimmed.len();
        if trimmed.starts_with("//") {
            pos += trimmed.find('\n').unwrap_or(trimmed.len());
        } else {
            return pos;
        }
    }
}

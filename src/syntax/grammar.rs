//! The pest grammar (`grammar/revelio.pest`) and facts about its rules: which rules are keyword
//! tokens and what they spell, and which rule parses the item a keyword starts. The parser and
//! the formatter both walk the tree pest builds from these rules.

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/revelio.pest"]
pub struct RevParser;

pub fn is_keyword(r: Rule) -> bool {
    keyword_text(r).is_some()
}

/// The source text of a keyword rule.
pub fn keyword_text(r: Rule) -> Option<&'static str> {
    use Rule::*;
    Some(match r {
        kw_domain => "domain",
        kw_use => "use",
        kw_unit => "unit",
        kw_enum => "enum",
        kw_tag => "tag",
        kw_relation => "relation",
        kw_kind => "kind",
        kw_look => "look",
        kw_world => "world",
        kw_region => "region",
        kw_preset => "preset",
        kw_camera => "camera",
        kw_stage => "stage",
        kw_concept => "concept",
        kw_modifier => "modifier",
        kw_constraint => "constraint",
        kw_question => "question",
        kw_rules => "rules",
        kw_rule => "rule",
        kw_allow => "allow",
        kw_visible => "visible",
        kw_description => "description",
        kw_category => "category",
        kw_add => "add",
        kw_set => "set",
        kw_probe => "probe",
        kw_scenic => "scenic",
        kw_prompt => "prompt",
        kw_shape => "shape",
        kw_target => "target",
        kw_move => "move",
        kw_drawn_by => "drawn_by",
        kw_text => "text",
        kw_option => "option",
        kw_when => "when",
        kw_expect => "expect",
        kw_elements => "elements",
        kw_safe => "safe",
        kw_for => "for",
        kw_at => "at",
        kw_look_at => "look_at",
        kw_fov => "fov",
        kw_size => "size",
        kw_color => "color",
        kw_material => "material",
        kw_yaw => "yaw",
        kw_roll => "roll",
        kw_pitch => "pitch",
        kw_shadow => "shadow",
        kw_repeat => "repeat",
        kw_step => "step",
        kw_in => "in",
        kw_not => "not",
        kw_and => "and",
        kw_or => "or",
        kw_has => "has",
        kw_exists => "exists",
        kw_count => "count",
        kw_where => "where",
        kw_std => "std",
        _ => return None,
    })
}

/// The keywords that open an item at the top level of a file: [`block_keywords`] of
/// [`Block::File`].
pub const ITEM_KEYWORDS: &[&str] = &[
    "domain",
    "use",
    "unit",
    "enum",
    "tag",
    "relation",
    "kind",
    "look",
    "world",
    "region",
    "preset",
    "camera",
    "stage",
    "concept",
    "modifier",
    "constraint",
    "question",
    "rules",
    "allow",
    "visible",
];

/// A place where statements follow one another: the file itself, or the body of an item (or of
/// a `shape`). What may start a statement there is [`block_keywords`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Block {
    File,
    Kind,
    World,
    Region,
    Preset,
    Camera,
    /// The parts of a `shape`, `look` or `stage`.
    Parts,
    /// A concept's or a modifier's body.
    Concept,
    Question,
    /// A `rules` item's body: its rules.
    Rules,
    Rule,
}

impl Block {
    pub const ALL: &[Block] = &[
        Block::File,
        Block::Kind,
        Block::World,
        Block::Region,
        Block::Preset,
        Block::Camera,
        Block::Parts,
        Block::Concept,
        Block::Question,
        Block::Rules,
        Block::Rule,
    ];

    /// The block a `{` after this keyword opens (`concept c {`, `shape {`, `rule r {`).
    pub fn opened_by(keyword: &str) -> Option<Block> {
        Some(match keyword {
            "kind" => Block::Kind,
            "world" => Block::World,
            "region" => Block::Region,
            "preset" => Block::Preset,
            "camera" => Block::Camera,
            "shape" | "look" | "stage" => Block::Parts,
            "concept" | "modifier" => Block::Concept,
            "question" => Block::Question,
            "rules" => Block::Rules,
            "rule" => Block::Rule,
            _ => return None,
        })
    }

    /// The grammar rule one statement of the block matches (its first words are the block's
    /// keywords; a test reads them from the grammar).
    pub fn statement_rule(self) -> &'static str {
        match self {
            Block::File => "item",
            Block::Kind => "kind_stmt",
            Block::World => "attr_decl",
            Block::Region => "region_stmt",
            Block::Preset => "preset_param",
            Block::Camera => "camera_stmt",
            Block::Parts => "shape_part",
            Block::Concept => "concept_stmt",
            Block::Question => "question_stmt",
            Block::Rules => "rule_item",
            Block::Rule => "rule_stmt",
        }
    }
}

/// The words a statement of `block` may start with, as the grammar has them: what completion
/// offers at the start of a statement, and what a misspelt first word is compared with. Words
/// that are not `kw_*` rules are included where the grammar spells them out (`x`, `box`).
pub fn block_keywords(block: Block) -> &'static [&'static str] {
    match block {
        Block::File => ITEM_KEYWORDS,
        Block::Kind => &["shape", "in"],
        Block::World | Block::Preset => &[],
        Block::Region => &["x", "y", "z", "scenic"],
        Block::Camera => &["at", "look_at", "fov", "size"],
        Block::Parts => &["box", "cylinder", "capsule", "sphere", "plane", "cone"],
        Block::Concept => &[
            "description",
            "category",
            "add",
            "set",
            "probe",
            "scenic",
            "prompt",
            "shape",
            "target",
            "move",
            "drawn_by",
        ],
        Block::Question => &["text", "option"],
        Block::Rules => &["rule"],
        Block::Rule => &["when", "expect", "elements", "safe"],
    }
}

#[cfg(test)]
mod tests {
    use std::collections::{BTreeSet, HashMap};

    use pest_meta::ast::Expr;

    use super::*;

    /// The grammar's rules by name, as pest reads them.
    fn grammar() -> HashMap<String, Expr> {
        let text = include_str!("../../grammar/revelio.pest");
        let pairs = pest_meta::parser::parse(pest_meta::parser::Rule::grammar_rules, text).expect("the grammar parses");
        let rules = pest_meta::parser::consume_rules(pairs).expect("the grammar is valid");
        rules.into_iter().map(|r| (r.name, r.expr)).collect()
    }

    /// The word a `kw_*` rule spells (`kw_x = @{ "x" ~ !ident_char }`).
    fn spelled(e: &Expr) -> Option<&str> {
        match e {
            Expr::Seq(first, rest) if matches!(**rest, Expr::NegPred(_)) => match &**first {
                Expr::Str(s) => Some(s),
                _ => None,
            },
            _ => None,
        }
    }

    /// The words (keywords and spelt-out words) an expression may start with, and whether it
    /// may match nothing (so that what follows may start it too).
    fn first_words(g: &HashMap<String, Expr>, e: &Expr, seen: &mut Vec<String>, out: &mut BTreeSet<String>) -> bool {
        match e {
            Expr::Str(s) => {
                if s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') && !s.is_empty() {
                    out.insert(s.clone());
                }
                s.is_empty()
            }
            Expr::Ident(name) => {
                if let Some(w) = name.strip_prefix("kw_") {
                    out.insert(w.to_string());
                    return false;
                }
                // A name (`ident`, `path`, a number): no keyword; lookaheads match nothing.
                if matches!(name.as_str(), "ident" | "path" | "number" | "int" | "string" | "wildcard")
                    || seen.contains(name)
                {
                    return false;
                }
                let Some(body) = g.get(name) else { return false };
                seen.push(name.clone());
                let nullable = first_words(g, body, seen, out);
                seen.pop();
                nullable
            }
            Expr::PosPred(_) | Expr::NegPred(_) => true,
            Expr::Seq(a, b) => first_words(g, a, seen, out) && first_words(g, b, seen, out),
            Expr::Choice(a, b) => {
                let na = first_words(g, a, seen, out);
                first_words(g, b, seen, out) || na
            }
            Expr::Opt(a) | Expr::Rep(a) => {
                first_words(g, a, seen, out);
                true
            }
            Expr::RepOnce(a) => first_words(g, a, seen, out),
            _ => false,
        }
    }

    fn starts(g: &HashMap<String, Expr>, rule: &str) -> BTreeSet<String> {
        let mut out = BTreeSet::new();
        first_words(g, &g[rule], &mut Vec::new(), &mut out);
        out
    }

    fn set(words: &[&str]) -> BTreeSet<String> {
        words.iter().map(|w| w.to_string()).collect()
    }

    #[test]
    fn keyword_rules_and_keyword_text_agree() {
        let g = grammar();
        for (name, e) in &g {
            if let Some(word) = name.strip_prefix("kw_") {
                assert_eq!(spelled(e), Some(word), "`{name}` must spell `{word}`");
            }
        }
        for &r in Rule::all_rules() {
            let name = format!("{r:?}");
            let word = name.strip_prefix("kw_");
            assert_eq!(keyword_text(r), word, "`keyword_text` of `{name}`");
        }
    }

    #[test]
    fn block_keywords_are_what_the_grammar_starts_statements_with() {
        let g = grammar();
        for &b in Block::ALL {
            assert_eq!(set(block_keywords(b)), starts(&g, b.statement_rule()), "block_keywords({b:?})");
            let words = block_keywords(b);
            assert!(words.iter().enumerate().all(|(i, w)| !words[..i].contains(w)), "{b:?} repeats a word");
        }
        assert_eq!(set(ITEM_KEYWORDS), starts(&g, "item_start"), "where recovery resumes");
    }

    #[test]
    fn the_lexers_keyword_lists_are_the_grammars_keywords() {
        use crate::syntax::lexer::{INNER_KEYWORDS, STATEMENT_KEYWORDS};
        let g = grammar();
        let mut kws: BTreeSet<String> = g.keys().filter_map(|n| n.strip_prefix("kw_")).map(String::from).collect();
        // `true` and `false` are words of `boolean`, not keyword rules; editors show them as keywords.
        kws.extend(set(&["true", "false"]));
        let mut listed = BTreeSet::new();
        for list in [ITEM_KEYWORDS, STATEMENT_KEYWORDS, INNER_KEYWORDS] {
            for w in list {
                assert!(listed.insert(w.to_string()), "`{w}` is in two of the lexer's lists");
            }
        }
        assert_eq!(listed, kws, "the lexer's keywords and the grammar's `kw_*` rules");
        // The words that open a statement inside a body (where completion's statement starts).
        let mut statements = BTreeSet::new();
        for b in [Block::Concept, Block::Rules, Block::Rule, Block::Question] {
            statements.extend(starts(&g, b.statement_rule()));
        }
        assert_eq!(set(STATEMENT_KEYWORDS), statements);
    }
}

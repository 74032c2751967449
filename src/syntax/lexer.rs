//! The lossless token layer: every byte of a `.rev` file belongs to exactly one [`Token`],
//! whitespace and comments included, so the concatenated tokens are the file.
//!
//! pest stays the parser (it parses `&str` and cannot take tokens); this layer serves what the
//! parse tree drops: comments and blank lines for the formatter, `///` doc comments for the
//! parser, and token classes for editor highlighting. A test checks that every leaf of pest's
//! tree is exactly one token here on every shipped and corpus file.
//!
//! Tokens are lexical, not grammatical: a word is an [`TokenKind::Ident`] whether the grammar
//! reads it as a keyword or a name there (`color` is both), and a number keeps its unit suffix
//! (`2m`, `90deg`, `640x360`) as the grammar's `number` and `dims` do.

use logos::Logos;

use super::grammar::ITEM_KEYWORDS;

/// What a token is, lexically.
#[derive(Logos, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TokenKind {
    /// Spaces, tabs and line breaks (`\r\n` too).
    #[regex(r"[ \t\r\n]+")]
    Whitespace,
    /// A byte-order mark, which the grammar skips like whitespace.
    #[token("\u{FEFF}")]
    Bom,
    /// `// …` to the end of the line.
    #[regex(r"//[^\n]*")]
    Comment,
    /// `/// …` (but not `////`): documents the item, attribute or rule below it.
    #[regex(r"///([^/\n][^\n]*)?", priority = 10)]
    DocComment,
    /// A word: a name or a keyword (the grammar decides which by position).
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident,
    /// A number with its optional unit suffix (`2`, `-0.5m`, `90deg`), or an image size
    /// (`640x360`).
    #[regex(r"-?[0-9]+(\.[0-9]+)?([A-Za-z_][A-Za-z0-9_]*)?")]
    Number,
    /// `prefix_*`: a wildcard over concept names.
    #[regex(r"[A-Za-z0-9_]*\*")]
    Wildcard,
    /// `#rrggbb`.
    #[regex(r"#[A-Za-z0-9_]*")]
    Color,
    /// `"…"` with backslash escapes, on one line.
    #[regex(r#""([^"\\\n]|\\[^\n])*""#)]
    String,
    /// `"""…"""`, which may span lines.
    #[token("\"\"\"", raw_string_end)]
    RawString,
    /// A `"` string that the line ends before it is closed.
    #[regex(r#""([^"\\\n]|\\[^\n])*"#)]
    UnterminatedString,
    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token(",")]
    Comma,
    #[token(":")]
    Colon,
    #[token("::")]
    ColonColon,
    #[token(".")]
    Dot,
    #[token("..")]
    DotDot,
    #[token("=")]
    Eq,
    #[token("|")]
    Pipe,
    /// `==`, `!=`, `<`, `<=`, `>`, `>=`.
    #[regex(r"==|!=|<=|>=|<|>")]
    CmpOp,
    /// Any other character (the parser reports it).
    #[regex(r".", priority = 0)]
    Unknown,
}

impl TokenKind {
    /// Whitespace and comments: what the grammar skips between tokens.
    pub fn is_trivia(self) -> bool {
        matches!(self, TokenKind::Whitespace | TokenKind::Bom | TokenKind::Comment | TokenKind::DocComment)
    }

    pub fn is_comment(self) -> bool {
        matches!(self, TokenKind::Comment | TokenKind::DocComment)
    }
}

/// Extend a `"""` to the first `"""` after it, as the grammar reads raw strings. Unclosed, the
/// token stays three bytes long and [`lex`] reads it as pest does: `""`, then a `"`.
fn raw_string_end(lexer: &mut logos::Lexer<TokenKind>) {
    if let Some(i) = lexer.remainder().find("\"\"\"") {
        lexer.bump(i + 3);
    }
}

/// One token: its kind and byte range in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Token {
    pub kind: TokenKind,
    pub start: u32,
    pub end: u32,
}

impl Token {
    pub fn text(self, source: &str) -> &str {
        &source[self.start as usize..self.end as usize]
    }
}

/// The keywords that open a statement inside a concept, question, `rules` or rule body (a test
/// checks them, and that these lists hold every `kw_*` rule of the grammar once).
pub const STATEMENT_KEYWORDS: &[&str] = &[
    "rule",
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
    "text",
    "option",
    "when",
    "expect",
    "elements",
    "safe",
];

/// The keywords that stand inside a statement.
pub(crate) const INNER_KEYWORDS: &[&str] = &[
    "std", "for", "at", "look_at", "fov", "size", "color", "material", "yaw", "roll", "pitch", "shadow", "repeat",
    "step", "in", "not", "and", "or", "has", "exists", "count", "where", "true", "false",
];

/// Whether the grammar reads `word` as a keyword where it stands in keyword position (`true` and
/// `false` included). Some are also valid names elsewhere (`color`, `size`, `text`).
pub fn is_keyword(word: &str) -> bool {
    starts_statement(word) || INNER_KEYWORDS.contains(&word)
}

/// Whether `word` opens an item or a statement.
pub fn starts_statement(word: &str) -> bool {
    ITEM_KEYWORDS.contains(&word) || STATEMENT_KEYWORDS.contains(&word)
}

/// Split `text` into tokens; their concatenation is `text`.
pub fn lex(text: &str) -> Vec<Token> {
    let mut out = Vec::with_capacity(text.len() / 4);
    let mut offset = 0;
    'restart: loop {
        let mut lexer = TokenKind::lexer(&text[offset..]);
        while let Some(kind) = lexer.next() {
            let span = lexer.span();
            let (start, end) = ((offset + span.start) as u32, (offset + span.end) as u32);
            // Every character matches some rule (`Unknown` catches the rest), so an error can only
            // be a byte sequence no rule accepts; it stays one `Unknown` token so nothing is lost.
            let kind = kind.unwrap_or(TokenKind::Unknown);
            if kind == TokenKind::RawString && end - start == 3 {
                // An unclosed `"""`: an empty string, then lexing goes on at the third quote.
                out.push(Token { kind: TokenKind::String, start, end: start + 2 });
                offset = start as usize + 2;
                continue 'restart;
            }
            out.push(Token { kind, start, end });
        }
        return out;
    }
}

/// The index of the token that contains byte `pos` (the last token when `pos` is the end).
pub fn token_at(tokens: &[Token], pos: u32) -> Option<usize> {
    if tokens.is_empty() {
        return None;
    }
    let i = tokens.partition_point(|t| t.end <= pos);
    Some(i.min(tokens.len() - 1))
}

/// The `///` lines directly above the token that starts at byte `pos`, joined with newlines:
/// the item (or attribute, or rule) must start its line, and each doc line holds only a `///`
/// comment. One space after `///` and trailing whitespace are dropped.
pub fn doc_before(text: &str, tokens: &[Token], pos: u32) -> String {
    let Some(first) = token_at(tokens, pos) else { return String::new() };
    let blank = |t: &Token| t.text(text).trim().is_empty();
    if tokens[first].start < pos {
        // The item starts inside a token (only in broken text): the token's start is on the line.
        let before = &text[tokens[first].start as usize..pos as usize];
        match before.rfind('\n') {
            Some(nl) if before[nl + 1..].trim().is_empty() => {
                return doc_lines_above(text, tokens, first, tokens[first].start as usize + nl, &blank);
            }
            _ => return String::new(),
        }
    }
    // Back over blank tokens on the item's line to the line break that starts it.
    let mut j = first;
    while j > 0 {
        let t = tokens[j - 1];
        let s = t.text(text);
        if let Some(nl) = s.rfind('\n') {
            if !s[nl + 1..].trim().is_empty() {
                return String::new();
            }
            return doc_lines_above(text, tokens, j - 1, t.start as usize + nl, &blank);
        }
        if !blank(&t) {
            return String::new();
        }
        j -= 1;
    }
    String::new()
}

/// The doc lines ending at the line break at byte `nl` (inside token `k`), going up.
fn doc_lines_above(
    text: &str,
    tokens: &[Token],
    mut k: usize,
    mut nl: usize,
    blank: &dyn Fn(&Token) -> bool,
) -> String {
    let mut lines: Vec<&str> = Vec::new();
    loop {
        let t = tokens[k];
        // The line above ends at `nl`; only whitespace may sit between a doc comment and it.
        if t.kind != TokenKind::Whitespace || text[t.start as usize..nl].contains('\n') {
            break;
        }
        let Some(c) = k.checked_sub(1) else { break };
        if tokens[c].kind != TokenKind::DocComment {
            break;
        }
        // Only blank tokens between the start of that line and the comment.
        let mut j = c;
        let mut line_break = None;
        while j > 0 {
            let p = tokens[j - 1];
            let s = p.text(text);
            if let Some(i) = s.rfind('\n') {
                if s[i + 1..].trim().is_empty() {
                    line_break = Some((j - 1, p.start as usize + i));
                }
                break;
            }
            if !blank(&p) {
                break;
            }
            j -= 1;
        }
        let at_file_start = j == 0;
        if line_break.is_none() && !at_file_start {
            break;
        }
        let doc = &tokens[c].text(text)[3..];
        lines.push(doc.strip_prefix(' ').unwrap_or(doc).trim_end());
        match line_break {
            Some((pk, pnl)) => (k, nl) = (pk, pnl),
            None => break,
        }
    }
    lines.reverse();
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(text: &str) -> Vec<(TokenKind, &str)> {
        lex(text).into_iter().map(|t| (t.kind, t.text(text))).collect()
    }

    #[test]
    fn every_byte_belongs_to_one_token() {
        for text in
            ["", "concept c { add x: K in lane { d = 2m..4m } }", "é\u{feff}\\ \"abc\n\"\"\"x\ny\"\"\" ///d\n////e"]
        {
            let toks = lex(text);
            let joined: String = toks.iter().map(|t| t.text(text)).collect();
            assert_eq!(joined, text);
            assert!(toks.windows(2).all(|w| w[0].end == w[1].start));
        }
    }

    #[test]
    fn token_classes() {
        use TokenKind::*;
        assert_eq!(
            kinds("d: length in -8m..8.5m = 2..4"),
            [
                (Ident, "d"),
                (Colon, ":"),
                (Whitespace, " "),
                (Ident, "length"),
                (Whitespace, " "),
                (Ident, "in"),
                (Whitespace, " "),
                (Number, "-8m"),
                (DotDot, ".."),
                (Number, "8.5m"),
                (Whitespace, " "),
                (Eq, "="),
                (Whitespace, " "),
                (Number, "2"),
                (DotDot, ".."),
                (Number, "4"),
            ]
        );
        assert_eq!(kinds("size 640x360")[2], (Number, "640x360"));
        assert_eq!(kinds("town_* #a1b2c3")[0], (Wildcard, "town_*"));
        assert_eq!(kinds("town_* #a1b2c3")[2], (Color, "#a1b2c3"));
        assert_eq!(kinds("/// doc")[0], (DocComment, "/// doc"));
        assert_eq!(kinds("///")[0], (DocComment, "///"));
        assert_eq!(kinds("//// rule")[0], (Comment, "//// rule"));
        assert_eq!(kinds("std::core")[1], (ColonColon, "::"));
        assert_eq!(kinds("a.b <= c")[1], (Dot, "."));
        assert_eq!(kinds("a.b <= c")[4], (CmpOp, "<="));
    }

    #[test]
    fn strings_raw_strings_and_broken_ones() {
        use TokenKind::*;
        assert_eq!(kinds(r#""a \"b\"""#), [(String, r#""a \"b\"""#)]);
        assert_eq!(kinds("\"\"\"a\n\"b\"\n\"\"\""), [(RawString, "\"\"\"a\n\"b\"\n\"\"\"")]);
        // Like the grammar: a raw string ends at the first `"""`.
        assert_eq!(kinds("\"\"\"a\"\"\"\"")[0], (RawString, "\"\"\"a\"\"\""));
        // An unclosed raw string is an empty string and an unclosed one, as pest reads it.
        assert_eq!(kinds("\"\"\"a\nb")[..2], [(String, "\"\""), (UnterminatedString, "\"a")]);
        assert_eq!(kinds("\"abc\nx")[0], (UnterminatedString, "\"abc"));
    }

    #[test]
    fn doc_comments_attach_to_the_token_below() {
        let doc = |text: &str, pos: usize| doc_before(text, &lex(text), pos as u32);
        assert_eq!(doc("/// A.\n/// B.\nkind K {}", 14), "A.\nB.");
        assert_eq!(doc("//// not a doc\nkind K {}", 15), "");
        assert_eq!(doc("/// A.\n\nkind K {}", 8), "", "a blank line ends the doc");
        assert_eq!(doc("// plain\n/// A.\n  kind K {}", 18), "A.");
        assert_eq!(doc("/// A.\ntag T kind K {}", 13), "", "the item must start its line");
        assert_eq!(doc("x /// A.\nkind K {}", 9), "", "the doc comment must start its line");
        assert_eq!(doc("\u{feff}/// A.\nkind K {}", 10), "", "a byte-order mark is no blank");
        assert_eq!(doc("/// A.  \r\nkind K {}", 10), "A.");
    }

    /// The token class a pest leaf rule must match, or `None` for a rule that is no leaf.
    fn leaf_kinds(r: crate::syntax::grammar::Rule) -> Option<&'static [TokenKind]> {
        use crate::syntax::grammar::{Rule, is_keyword};
        use TokenKind::*;
        Some(match r {
            Rule::ident | Rule::axis | Rule::prim | Rule::boolean => &[Ident],
            _ if is_keyword(r) => &[Ident],
            Rule::number | Rule::int | Rule::dims => &[Number],
            Rule::string => &[String, RawString],
            Rule::color => &[Color],
            Rule::wildcard => &[Wildcard],
            Rule::cmp_op => &[CmpOp],
            _ => return None,
        })
    }

    /// A pest leaf: its byte range and the token kinds it may be.
    type Leaf = (u32, u32, &'static [TokenKind]);

    /// The leaves of pest's tree (and the spans of recovery nodes, whose inside is free text).
    fn leaves(text: &str) -> (Vec<Leaf>, Vec<(u32, u32)>) {
        use crate::syntax::grammar::{RevParser, Rule};
        use pest::Parser;
        fn walk(
            p: pest::iterators::Pair<Rule>,
            out: &mut Vec<(u32, u32, &'static [TokenKind])>,
            junk: &mut Vec<(u32, u32)>,
        ) {
            let (s, e) = (p.as_span().start() as u32, p.as_span().end() as u32);
            if format!("{:?}", p.as_rule()).ends_with("junk") {
                junk.push((s, e));
            } else if let Some(k) = leaf_kinds(p.as_rule()) {
                out.push((s, e, k));
            } else {
                p.into_inner().for_each(|c| walk(c, out, junk));
            }
        }
        let (mut out, mut junk) = (Vec::new(), Vec::new());
        for p in RevParser::parse(Rule::file, text).expect("corpus files parse") {
            walk(p, &mut out, &mut junk);
        }
        (out, junk)
    }

    #[test]
    fn tokens_agree_with_pest_on_every_shipped_and_corpus_file() {
        use TokenKind::*;
        let files = crate::syntax::rev_files(&["stdlib", "domains", "examples", "tests/corpus"]);
        assert!(files.len() >= 25, "{files:?}");
        let punctuation = [LBrace, RBrace, LParen, RParen, Comma, Colon, ColonColon, Dot, DotDot, Eq, Pipe];
        let mut leaves_seen = 0;
        for f in &files {
            let text = std::fs::read_to_string(f).unwrap();
            let toks = lex(&text);
            let joined: std::string::String = toks.iter().map(|t| t.text(&text)).collect();
            assert_eq!(joined, text, "{}", f.display());
            let (leaves, junk) = leaves(&text);
            let in_junk = |t: &Token| junk.iter().any(|&(s, e)| t.start >= s && t.end <= e);
            for &(s, e, kinds) in &leaves {
                let tok = toks.iter().find(|t| t.start == s && t.end == e);
                assert!(
                    tok.is_some_and(|t| kinds.contains(&t.kind)),
                    "{}: pest leaf `{}` at {s} is token {:?}",
                    f.display(),
                    &text[s as usize..e as usize],
                    toks.iter().find(|t| t.end > s).map(|t| (t.kind, t.text(&text)))
                );
            }
            for t in toks.iter().filter(|t| !t.kind.is_trivia() && !in_junk(t)) {
                let leaf = leaves.iter().any(|&(s, e, _)| s == t.start && e == t.end);
                assert!(
                    leaf || punctuation.contains(&t.kind),
                    "{}: token {:?} `{}` at {} is neither a pest leaf nor punctuation",
                    f.display(),
                    t.kind,
                    t.text(&text),
                    t.start
                );
                if !leaf {
                    let inside = leaves.iter().any(|&(s, e, _)| t.start < e && t.end > s);
                    assert!(!inside, "{}: punctuation inside a leaf at {}", f.display(), t.start);
                }
            }
            // Comments are what pest skips: none overlaps a leaf.
            for t in toks.iter().filter(|t| t.kind.is_comment()) {
                assert!(
                    !leaves.iter().any(|&(s, e, _)| t.start < e && t.end > s),
                    "{}: comment in a leaf",
                    f.display()
                );
            }
            leaves_seen += leaves.len();
        }
        assert!(leaves_seen > 10_000, "{leaves_seen}");
    }
}

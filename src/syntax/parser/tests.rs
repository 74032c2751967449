//! Parser unit tests: recovery, literals, doc comments.

use super::*;
use crate::syntax::lexer;

fn parse_ok(text: &str) -> File {
    let p = parse(0, text);
    assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics);
    p.file
}

fn concept_stmts(text: &str) -> Vec<ConceptStmt> {
    match &parse_ok(text).items[0].kind {
        ItemKind::Concept { stmts, .. } => stmts.clone(),
        other => panic!("not a concept: {other:?}"),
    }
}

#[test]
fn doc_comments_attach_to_the_next_item() {
    let f = parse_ok("// plain\n/// First line.\n///   Second.\n\nunit m: length = 1\n/// Tag doc.\ntag T");
    assert_eq!(f.items[0].doc, "", "a blank line separates a doc comment from its item");
    assert_eq!(f.items[1].doc, "Tag doc.");
    let f =
        parse_ok("kind K {\n  /// Attr doc.\n  a: bool = true\n}\nrules priority {\n  /// Why.\n  rule r { safe }\n}");
    let ItemKind::Kind { attrs, .. } = &f.items[0].kind else { panic!() };
    assert_eq!(attrs[0].doc, "Attr doc.");
    let ItemKind::Rules { rules, .. } = &f.items[1].kind else { panic!() };
    assert_eq!(rules[0].doc, "Why.");
}

#[test]
fn keywords_are_whole_words() {
    let stmts = concept_stmts("modifier m { target worldly_things }");
    assert!(matches!(&stmts[0], ConceptStmt::Target { world: None, filter, .. } if filter[0].name == "worldly_things"));
    let stmts = concept_stmts("modifier m { target world }");
    assert!(matches!(&stmts[0], ConceptStmt::Target { world: Some(_), .. }));
}

#[test]
fn add_without_relation_does_not_swallow_the_next_statement() {
    let stmts = concept_stmts("concept c { add a: K in lane add b: K in lane near a { x = 1m } }");
    assert_eq!(stmts.len(), 2);
    let ConceptStmt::Add { relation, attrs, .. } = &stmts[1] else { panic!() };
    assert_eq!(relation.as_ref().map(|r| r.1.name.as_str()), Some("a"));
    assert_eq!(attrs.len(), 1);
}

#[test]
fn strings_decode_escapes_and_raw_strings_keep_their_lines() {
    let stmts = concept_stmts("concept c { description \"a \\\"b\\\"\\n\" scenic \"\"\"\nline 1\nline \"2\"\n\"\"\" }");
    assert!(matches!(&stmts[0], ConceptStmt::Description(s) if s.value == "a \"b\"\n"));
    assert!(matches!(&stmts[1], ConceptStmt::Scenic(s) if s.value == "line 1\nline \"2\"\n"));
}

#[test]
fn numbers_ranges_and_units() {
    let f = parse_ok("kind K { d: length in -8m..8.5m = 2m..4m }");
    let ItemKind::Kind { attrs, .. } = &f.items[0].kind else { panic!() };
    let (lo, hi) = attrs[0].bounds.as_ref().unwrap();
    assert_eq!((lo.value, hi.value), (-8.0, 8.5));
    assert!(
        matches!(&attrs[0].default, ValueLit::Range(a, b) if a.value == 2.0 && b.unit.as_ref().unwrap().name == "m")
    );
}

#[test]
fn three_mistakes_three_diagnostics_and_the_rest_parses() {
    let text = "domain d\nconcept a { descriptio \"x\" probe \"p\" not \"n\" }\n@@@\nkind K { d: length = }\nregion r { x 0m y 0m }";
    let p = parse(0, text);
    let line = |d: &Diagnostic| text[..d.span.unwrap().start as usize].matches('\n').count() + 1;
    let lines: Vec<usize> = p.diagnostics.iter().map(line).collect();
    assert_eq!(lines, [2, 3, 4], "{:?}", p.diagnostics);
    assert!(p.diagnostics.iter().all(|d| d.code == codes::SYNTAX));
    assert_eq!(p.file.items.len(), 5, "domain, concept, junk, kind, region");
    assert!(p.file.items[1].broken && !p.file.items[4].broken);
    assert_eq!(p.diagnostics[0].help.as_deref(), Some("did you mean `description`?"));
    assert_eq!(p.diagnostics[2].message, "expected a value, found `}`");
}

#[test]
fn expected_tokens_point_at_the_mistake() {
    let text = "enum Color { red, green blue }";
    let p = parse(0, text);
    let d = &p.diagnostics[0];
    assert_eq!(d.message, "expected `,` or `}`, found `blue`");
    assert_eq!(&text[d.span.unwrap().start as usize..d.span.unwrap().end as usize], "blue");
}

fn deep_at(text: &str) -> Option<usize> {
    too_deep_at(text, &lexer::lex(text))
}

#[test]
fn nesting_limit_ignores_strings_and_comments() {
    let parens = "(".repeat(MAX_NESTING + 1);
    assert_eq!(deep_at(&format!("// {parens}\n\"{parens}\" \"\"\"{parens}\"\"\"")), None);
    assert_eq!(deep_at(&format!("x {parens}")), Some(2 + MAX_NESTING));
    // An unclosed string is read by recovery as plain text: its brackets count.
    assert_eq!(deep_at(&format!("x \"{parens}")), Some(3 + MAX_NESTING));
}

#[test]
fn every_nesting_construct_counts_against_one_budget() {
    let n = MAX_NESTING + 1;
    let rule = |cond: String| format!("rules p {{ rule r {{ when {cond} expect q.a }} }}");
    let over = [
        rule(format!("{}true", "exists e: K where ".repeat(n))),
        rule(format!("{}true", "not ".repeat(n))),
        rule(format!("{}true{}", "not (".repeat(n / 2 + 1), ")".repeat(n / 2 + 1))),
        rule(format!("{}true", "exists e: K where not exists f: K where ".repeat(n / 3 + 1))),
        rule(format!("{}true{}", "(exists e: K where ".repeat(n / 2 + 1), ")".repeat(n / 2 + 1))),
        format!("kind K {{ shape {{ box when {}true }} }}", "(".repeat(n - 2)),
    ];
    for text in &over {
        assert!(deep_at(text).is_some(), "{}", &text[..80]);
        let p = parse(0, text);
        assert_eq!(p.diagnostics.iter().map(|d| d.code).collect::<Vec<_>>(), [codes::TOO_DEEP]);
    }
    // `where` and `not` levels close with their bracket, and a `}` ends the statement: many
    // rules, parts and bracketed terms each within the budget add up to nothing.
    let many_rules =
        (0..500).map(|_| rule("exists e: K where not exists f: K where e near f".into())).collect::<String>();
    let many_terms = rule(vec!["(exists e: K where not e.a == 1)"; 500].join(" and "));
    let leaf_nots = rule(vec!["not has c"; 500].join(" and "));
    for text in [many_rules, many_terms, leaf_nots] {
        assert_eq!(deep_at(&text), None, "{}", &text[..80]);
    }
}

/// A random well-formed condition and its true nesting (levels of `(`, `not` and `where` around
/// its deepest point). An `and`/`or` takes a leaf or a bracketed term on its left, so that no
/// `where` there swallows the right side and the tracked nesting is the parsed one.
struct Gen(u64);

impl Gen {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }

    fn leaf(&mut self) -> &'static str {
        ["a.b == 1", "has c", "e near f", "true"][self.below(4) as usize]
    }

    /// A condition at nesting `at` that goes on nesting up to about `target`: its text and the
    /// deepest nesting inside it.
    fn expr(&mut self, at: usize, target: usize) -> (String, usize) {
        match (at < target, self.below(5)) {
            (false, 0) => (format!("not {}", self.leaf()), at + 1),
            (false, _) => (self.leaf().to_string(), at),
            (true, 0) => {
                let (inner, d) = self.expr(at, target);
                let (left, l) = if self.below(2) == 0 {
                    (self.leaf().to_string(), at)
                } else {
                    let side = at + 1 + self.below(4) as usize;
                    let (i, l) = self.expr(at + 1, side);
                    (format!("({i})"), l)
                };
                (format!("{left} {} {inner}", ["and", "or"][self.below(2) as usize]), d.max(l))
            }
            (true, 1) => {
                let (inner, d) = self.expr(at + 1, target);
                (format!("({inner})"), d)
            }
            (true, 2) => {
                // `not` takes one term: not a where-less `exists`, which the count takes for a
                // `where` to come (a harmless overcount this property does not measure).
                let (inner, d) = match self.below(2) {
                    0 => {
                        let (i, d) = self.expr(at + 2, target);
                        (format!("({i})"), d)
                    }
                    _ => {
                        let (i, d) = self.expr(at + 2, target);
                        (format!("exists g: K where {i}"), d)
                    }
                };
                (format!("not {inner}"), d.max(at + 1))
            }
            (true, _) => {
                let (inner, d) = self.expr(at + 1, target);
                (format!("exists e: K where {inner}"), d)
            }
        }
    }
}

/// The nesting of a parsed condition: how deep the later stages recurse over it.
fn expr_depth(e: &Expr) -> usize {
    1 + match &e.kind {
        ExprKind::Not(inner) => expr_depth(inner),
        ExprKind::And(ts) | ExprKind::Or(ts) => ts.iter().map(expr_depth).max().unwrap_or(0),
        ExprKind::Exists { cond: Some(c), .. } => expr_depth(c),
        _ => 0,
    }
}

/// Property, on random well-formed conditions around the budget: one past it is refused (the
/// count never falls short), one within it parses, and what parses nests at most twice the
/// budget in the tree (an `and`/`or` node between two counted levels), so no later stage
/// recurses deeper than that.
#[test]
fn the_nesting_count_is_exact_on_random_conditions() {
    let mut g = Gen(0x2545_f491_4f6c_dd1d);
    let (mut refused, mut parsed) = (0, 0);
    for _ in 0..300 {
        let target = MAX_NESTING * 3 / 4 + g.below(MAX_NESTING as u64 / 2) as usize;
        let (cond, depth) = g.expr(0, target);
        let text = format!("rules p {{ rule r {{ when {cond} expect q.a }} }}");
        let p = parse(0, &text);
        let too_deep = p.diagnostics.iter().any(|d| d.code == codes::TOO_DEEP);
        // The rule's `{` and the `rules` block's `{` are two levels more.
        assert_eq!(too_deep, depth + 2 > MAX_NESTING, "depth {depth}: {cond}");
        if too_deep {
            refused += 1;
            continue;
        }
        parsed += 1;
        assert!(p.diagnostics.is_empty(), "{:?} for {cond}", p.diagnostics);
        let ItemKind::Rules { rules, .. } = &p.file.items[0].kind else { panic!("{cond}") };
        let Some(RuleStmt::When(e, _)) = rules[0].stmts.first() else { panic!("{cond}") };
        assert!(expr_depth(e) <= 2 * MAX_NESTING + 1, "tree depth {} for {cond}", expr_depth(e));
    }
    assert!(refused > 20 && parsed > 20, "{refused} refused, {parsed} parsed");
}

/// The raw-text scan the token layer replaced, kept as the reference it must agree with.
fn doc_before_by_text(text: &str, pos: usize) -> String {
    let before = &text[..pos];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    if !before[line_start..].trim().is_empty() {
        return String::new();
    }
    let mut lines: Vec<&str> = Vec::new();
    let mut end = line_start;
    while end > 0 {
        let prev = &text[..end - 1];
        let start = prev.rfind('\n').map_or(0, |i| i + 1);
        let line = prev[start..].trim();
        match line.strip_prefix("///") {
            Some(doc) if !doc.starts_with('/') => lines.push(doc.strip_prefix(' ').unwrap_or(doc).trim_end()),
            _ => break,
        }
        end = start;
    }
    lines.reverse();
    lines.join("\n")
}

/// Every place a doc comment can attach (the start of each item, attribute and rule), as the
/// parser sees them.
fn doc_sites(file: &File) -> Vec<(u32, String)> {
    let mut out = Vec::new();
    for item in &file.items {
        out.push((item.span.start, item.doc.clone()));
        match &item.kind {
            ItemKind::Kind { attrs, .. } | ItemKind::World { attrs } => {
                out.extend(attrs.iter().map(|a| (a.span.start, a.doc.clone())));
            }
            ItemKind::Rules { rules, .. } => out.extend(rules.iter().map(|r| (r.span.start, r.doc.clone()))),
            _ => {}
        }
    }
    out
}

#[test]
fn token_doc_comments_agree_with_the_text_scan() {
    // Shipped and corpus files, and a few thousand cut-and-spliced variants of them (comments,
    // blank lines and odd characters moved into every position).
    let texts: Vec<String> = crate::syntax::rev_files(&["stdlib", "domains", "tests/corpus"])
        .into_iter()
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect();
    let pieces =
        ["/// d\n", "//// x\n", "// c\n", "\n\n", "  ", "\u{feff}", "\u{a0}", "\r\n", "/// e  \r\n", "\"", "x "];
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move |n: usize| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % n as u64) as usize
    };
    let mut checked = 0;
    for round in 0..3000 {
        let base = &texts[round % texts.len()];
        let mut text = base.clone();
        if round >= texts.len() {
            for _ in 0..1 + next(6) {
                let mut at = next(text.len() + 1);
                while !text.is_char_boundary(at) {
                    at -= 1;
                }
                text.insert_str(at, pieces[next(pieces.len())]);
            }
        }
        let parsed = parse(0, &text);
        for (pos, doc) in doc_sites(&parsed.file) {
            let expected = doc_before_by_text(&text, pos as usize);
            let around = &text[text.floor_char_boundary((pos as usize).saturating_sub(120))
                ..text.ceil_char_boundary(pos as usize + 20)];
            assert_eq!(doc, expected, "round {round}, position {pos} in:\n{around:?}");
            checked += 1;
        }
    }
    assert!(checked > 10_000, "{checked}");
    let _ = lexer::lex("");
}

#[test]
fn relations_regions_pitch_and_two_entity_conditions_parse() {
    let f = parse_ok(
        "relation near \"is near\" { distance 0m..1.5m on_top }\nkind Tree { in verge, kerb  h: length = 1m }\n\
         look Tree { box size (1m, 1m, 1m) pitch 10deg }\n\
         rules priority { rule r { when exists a: Tree where exists b: Tree where a near b and a.h < b.h expect q.a } }",
    );
    let ItemKind::Relation { placements: Some(ps), .. } = &f.items[0].kind else { panic!("{:?}", f.items[0]) };
    let words: Vec<_> = ps.iter().map(|p| (p.word.name.as_str(), p.range.is_some())).collect();
    assert_eq!(words, [("distance", true), ("on_top", false)]);
    let ItemKind::Kind { stands_in, attrs, .. } = &f.items[1].kind else { panic!() };
    assert_eq!(stands_in[0].iter().map(|r| r.name.as_str()).collect::<Vec<_>>(), ["verge", "kerb"]);
    assert_eq!(attrs.len(), 1, "`h: …` after the region list is an attribute");
    let ItemKind::Look { parts, .. } = &f.items[2].kind else { panic!() };
    assert!(matches!(parts.parts[0].props[1], PartProp::Pitch(_)));
    let ItemKind::Rules { rules, .. } = &f.items[3].kind else { panic!() };
    let RuleStmt::When(e, _) = &rules[0].stmts[0] else { panic!() };
    let ExprKind::Exists { cond: Some(inner), .. } = &e.kind else { panic!() };
    let ExprKind::Exists { cond: Some(body), .. } = &inner.kind else { panic!() };
    let ExprKind::And(terms) = &body.kind else { panic!("{body:?}") };
    assert!(matches!(&terms[0].kind, ExprKind::Related { relation, .. } if relation.name == "near"));
    assert!(matches!(&terms[1].kind, ExprKind::CmpAttrs { right, .. } if right.parts[1].name == "h"));
}

#[test]
fn a_placement_range_needs_both_bounds() {
    let p = parse(0, "relation around \"is around\" { distance 2m }");
    assert_eq!(p.diagnostics.len(), 1, "{:?}", p.diagnostics);
    assert_eq!(p.diagnostics[0].code, "R0001");
    assert!(p.diagnostics[0].message.contains("expected `..`"), "{}", p.diagnostics[0].message);
}

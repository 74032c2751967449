//! The language server's pieces without the protocol: name resolution, completion contexts,
//! hover text, quick fixes and semantic tokens on small domains. `tests/lsp.rs` drives the whole
//! server over stdio.

use std::collections::HashMap;

use super::analysis::Analysis;
use super::complete::complete;
use super::index::Sort;

const DOMAIN: &str = "domain t\nuse std::driving\n\nconcept walker {\n  description \"A walker.\"\n  add w: AdultPedestrian in lane ahead_of ego { distance = 2m..4m }\n  probe \"p\" not \"n\"\n}\n\nmodifier far {\n  description \"Far.\"\n  target Collidable\n  set distance = 15m..25m\n  probe \"p\" not \"n\"\n}\n\nconcept red {\n  description \"Red.\"\n  add l: TrafficLight in signal { color = red }\n  probe \"p\" not \"n\"\n}\n\nquestion q {\n  text \"Go?\"\n  option go \"Go on\"\n  option stop \"Stop now\"\n}\n\nrules priority {\n  /// Close things stop us.\n  rule near {\n    when exists e: Collidable where e.distance <= 4m and world.weather == foggy\n    expect q.stop\n  }\n  rule otherwise {\n    expect q.go\n  }\n}\n";

fn analyse(text: &str) -> Analysis {
    Analysis::new("t.rev", text, &HashMap::new())
}

/// The symbol named at the first `needle` (plus `skip` bytes).
fn symbol_at<'a>(a: &'a Analysis, needle: &str, skip: usize) -> &'a super::index::Symbol {
    let at = DOMAIN.find(needle).unwrap() + skip;
    let (_, id) = a.index.at(0, at as u32).unwrap_or_else(|| panic!("nothing at `{needle}`"));
    &a.index.symbols[id]
}

#[test]
fn names_resolve_through_scopes_files_and_inheritance() {
    let a = analyse(DOMAIN);
    assert!(a.compiled.diagnostics.is_empty(), "{:?}", a.compiled.diagnostics);
    let std_file = |s: &super::index::Symbol| a.compiled.files[s.decl.file as usize].name.clone();
    // An inherited attribute in `add … { distance = … }` is `Placed`'s, in std/driving.rev.
    let d = symbol_at(&a, "distance = 2m", 0);
    assert_eq!((d.sort, std_file(d).as_str()), (Sort::Attr, "std/driving.rev"));
    assert_eq!(a.index.symbols[d.parent.unwrap()].name, "Placed");
    // A modifier's `set ATTR` is an attribute of its targets.
    assert_eq!(symbol_at(&a, "distance = 15m", 0).decl, d.decl);
    // Units, variants of the attribute's enum, options, `exists` variables, world attributes.
    assert_eq!(symbol_at(&a, "4m }", 1).sort, Sort::Unit);
    let red = symbol_at(&a, "= red", 2);
    assert_eq!((red.sort, a.index.symbols[red.parent.unwrap()].name.as_str()), (Sort::Variant, "Signal"));
    assert_eq!(symbol_at(&a, "q.stop", 2).sort, Sort::Option);
    let e = symbol_at(&a, "e.distance", 0);
    assert_eq!((e.sort, e.decl.start as usize), (Sort::Var, DOMAIN.find("e: Collidable").unwrap()));
    assert_eq!(symbol_at(&a, "weather ==", 0).sort, Sort::WorldAttr);
    assert_eq!(symbol_at(&a, "foggy", 0).sort, Sort::Variant);
    assert_eq!(symbol_at(&a, "std::driving", 5).sort, Sort::Module);
    // Every occurrence of the question: its declaration and two `expect`s.
    let (_, q) = a.index.at(0, DOMAIN.find("question q").unwrap() as u32 + 9).unwrap();
    assert_eq!(a.index.occurrences_of(q).len(), 3);
    // `visible NAME { … }` names a kind, a tag or a concept.
    let text = format!("{DOMAIN}visible walker {{ pixels = 30 }}\nvisible Collidable {{ pixels = 25 }}\n");
    let a = analyse(&text);
    assert!(a.compiled.diagnostics.is_empty(), "{:?}", a.compiled.diagnostics);
    let (_, w) = a.index.at(0, text.find("visible walker").unwrap() as u32 + 9).expect("the concept is referred to");
    assert_eq!((a.index.symbols[w].sort, a.index.symbols[w].name.as_str()), (Sort::Concept, "walker"));
    assert_eq!(a.index.occurrences_of(w).len(), 2);
    let (_, t) = a.index.at(0, text.find("visible Collidable").unwrap() as u32 + 9).expect("the tag is referred to");
    assert_eq!((a.index.symbols[t].sort, a.index.symbols[t].name.as_str()), (Sort::Tag, "Collidable"));
}

#[test]
fn hover_says_what_a_name_declares() {
    let a = analyse(DOMAIN);
    let md = |needle: &str, skip: usize| {
        let (_, id) = a.index.at(0, (DOMAIN.find(needle).unwrap() + skip) as u32).unwrap();
        super::hover::markdown(&a.index, id)
    };
    let kind = md("AdultPedestrian", 0);
    assert!(kind.contains("kind AdultPedestrian: Walker") && kind.contains("distance: length in 0m..120m"), "{kind}");
    assert!(kind.contains("// from Placed") && kind.contains("also ") && kind.contains("Agent"), "{kind}");
    let rule = md("rule near", 5);
    assert!(rule.contains("Close things stop us.") && rule.contains("expects `q.stop`: Stop now"), "{rule}");
    let unit = md("4m }", 1);
    assert!(unit.contains("unit m: length = 1") && unit.contains("measures length"), "{unit}");
    let concept = md("concept walker", 8);
    assert!(concept.contains("A walker.") && concept.contains("probe: “p” / not: “n”"), "{concept}");
}

/// Completion labels with the cursor at `|` in `text` (the marker is removed).
fn labels(text: &str) -> Vec<String> {
    let at = text.find('|').unwrap();
    let text = text.replacen('|', "", 1);
    let a = analyse(&text);
    complete(&a, &text, at as u32).into_iter().map(|c| c.label).collect()
}

#[test]
fn completion_follows_the_context() {
    let with = |line: &str| {
        DOMAIN.replace(
            "  probe \"p\" not \"n\"\n}\n\nmodifier",
            &format!("  {line}\n  probe \"p\" not \"n\"\n}}\n\nmodifier"),
        )
    };
    let l = labels(&with("add x: |"));
    assert!(
        l.contains(&"AdultPedestrian".into()) && l.contains(&"Collidable".into()) && !l.contains(&"lane".into()),
        "{l:?}"
    );
    let l = labels(&with("add x: Cyclist in |"));
    assert!(l.contains(&"lane".into()) && l.contains(&"sidewalk".into()), "{l:?}");
    let l = labels(&with("add x: Cyclist in lane |"));
    assert!(l.contains(&"ahead_of".into()), "{l:?}");
    let l = labels(&with("add x: TrafficLight in signal { |"));
    assert!(l.contains(&"color".into()) && l.contains(&"distance".into()), "{l:?}");
    assert_eq!(labels(&with("set world.|")), ["town", "weather", "intersection"]);
    assert_eq!(
        labels(&with("set world.weather = |")),
        ["clear_noon", "hard_rain", "soft_rain", "foggy", "wet", "cloudy"]
    );
    let l = labels(&with("add x: Cyclist in lane { distance = 2|"));
    assert!(l.contains(&"2m".into()) && l.contains(&"2cm".into()), "units after a number: {l:?}");
    let l = labels(&with("|"));
    assert!(l.contains(&"description".into()) && l.contains(&"target".into()) && !l.contains(&"rule".into()), "{l:?}");
    let l = labels(&DOMAIN.replace("expect q.stop", "expect |"));
    assert!(l.contains(&"q.stop".into()) && l.contains(&"q.go".into()), "{l:?}");
    assert_eq!(labels(&DOMAIN.replace("expect q.stop", "expect q.|")), ["go", "stop"]);
    let l = labels(&DOMAIN.replace("e.distance <= 4m", "e.|"));
    assert!(l.contains(&"distance".into()) && !l.contains(&"color".into()), "{l:?}");
    let l = labels(&DOMAIN.replace("when exists", "when has | and exists"));
    assert!(l.contains(&"walker".into()) && l.contains(&"far".into()), "{l:?}");
    let l = labels(&format!("{DOMAIN}constraint c = exclusive(walker, |)\n"));
    assert!(l.contains(&"red".into()) && l.contains(&"category".into()), "{l:?}");
    let l = labels(&format!("{DOMAIN}allow |\n"));
    assert!(l.contains(&"R0101".into()) && l.contains(&"R0107".into()), "{l:?}");
    let l = labels(&format!("{DOMAIN}visible |\n"));
    assert!(
        l.contains(&"walker".into()) && l.contains(&"AdultPedestrian".into()) && l.contains(&"Hazard".into()),
        "{l:?}"
    );
    let l = labels(&format!("{DOMAIN}kind K {{ size: | }}\n"));
    assert!(l.contains(&"length".into()) && l.contains(&"bool".into()) && l.contains(&"Signal".into()), "{l:?}");
}

#[test]
fn semantic_tokens_tell_names_from_keywords() {
    let text = "kind K {\n  color: bool = true\n  shape {\n    box size (1m, 1m, 1m) color #ffffff when self.color == true\n  }\n}\n";
    let a = analyse(text);
    let lines = super::text::LineIndex::new(text);
    let toks = super::tokens::tokens(&a, &lines, super::text::Encoding::Utf16);
    let legend = super::tokens::legend();
    // Absolute positions back from the deltas.
    let (mut line, mut col) = (0, 0);
    let mut found = Vec::new();
    for t in toks {
        if t.delta_line > 0 {
            col = 0;
        }
        line += t.delta_line;
        col += t.delta_start;
        let start = text.lines().nth(line as usize).unwrap();
        let word = &start[col as usize..(col + t.length) as usize];
        found.push((word.to_string(), legend.token_types[t.token_type as usize].as_str().to_string()));
    }
    let kind_of = |w: &str| found.iter().filter(|(x, _)| x == w).map(|(_, k)| k.as_str()).collect::<Vec<_>>();
    // `color` declares an attribute, is a keyword in the shape part, and the attribute again in
    // `self.color`.
    assert_eq!(kind_of("color"), ["property", "keyword", "property"]);
    assert_eq!(kind_of("K"), ["struct"]);
    assert_eq!(kind_of("#ffffff"), ["number"]);
}

#[test]
fn relations_kind_regions_and_two_entity_conditions_resolve() {
    let text = "domain t\nregion path { x 0m..9m  y -1m..1m }\nrelation close \"is close to\" { distance 0m..2m }\n\
                kind K { in path  d: length in 0m..9m = 2m }\n\
                look K { box size (1m, 1m, 1m) pitch 10deg color #ffffff }\n\
                concept a { description \"a\" add x: K in path probe \"p\" not \"n\" }\n\
                concept b { description \"b\" add y: K in path close x probe \"p\" not \"n\" }\n\
                question q { text \"?\" option s \"s\" option g \"g\" }\n\
                rules priority {\n  rule r { when exists u: K where exists v: K where u close v and u.d < v.d expect q.s }\n  \
                rule o { expect q.g }\n}\n";
    let a = analyse(text);
    assert!(a.compiled.diagnostics.is_empty(), "{:?}", a.compiled.diagnostics);
    let at = |needle: &str, skip: usize| {
        let (_, id) = a.index.at(0, (text.find(needle).unwrap() + skip) as u32).unwrap_or_else(|| panic!("{needle}"));
        &a.index.symbols[id]
    };
    // `in path` of a kind names the region; `u close v` the relation and both variables;
    // `u.d < v.d` both attributes.
    assert_eq!(at("in path  d", 3).sort, Sort::Region);
    assert_eq!(at("u close v", 2).sort, Sort::Relation);
    assert_eq!(at("u close v", 8).decl.start as usize, text.find("v: K").unwrap());
    assert_eq!(at("v.d", 2).sort, Sort::Attr);
    assert_eq!(at("u.d", 2).decl, at("v.d", 2).decl);
    // Placement words are keywords in the relation's body; `pitch` is a keyword.
    let lines = super::text::LineIndex::new(text);
    let legend = super::tokens::legend();
    let (mut line, mut col) = (0, 0);
    let mut found = Vec::new();
    for t in super::tokens::tokens(&a, &lines, super::text::Encoding::Utf16) {
        if t.delta_line > 0 {
            col = 0;
        }
        line += t.delta_line;
        col += t.delta_start;
        let l = text.lines().nth(line as usize).unwrap();
        found.push((
            l[col as usize..(col + t.length) as usize].to_string(),
            legend.token_types[t.token_type as usize].as_str().to_string(),
        ));
    }
    let kind_of = |w: &str| found.iter().filter(|(x, _)| x == w).map(|(_, k)| k.as_str()).collect::<Vec<_>>();
    assert_eq!(kind_of("distance"), ["keyword"]);
    assert_eq!(kind_of("pitch"), ["keyword"]);
    assert_eq!(kind_of("close"), ["function", "function", "function"]);
}

#[test]
fn every_feature_survives_broken_text_at_every_kind_of_position() {
    // Cut-and-spliced variants of the domain: completion, hover, tokens, outline and fixes run at
    // many offsets of each, and must answer without panicking.
    let mut seed = 0x853c_49e6_748f_ea9bu64;
    let mut next = move |n: usize| {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % n.max(1) as u64) as usize
    };
    let pieces =
        ["{", "}", ".", "..", ":", "=", "\"", "\"\"\"", "é🚶", "// c\n", "exists e: ", "add x: ", "world.", "\n"];
    for round in 0..40 {
        let mut text = DOMAIN.to_string();
        for _ in 0..1 + next(4) {
            let mut at = next(text.len() + 1);
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            if next(2) == 0 {
                text.insert_str(at, pieces[next(pieces.len())]);
            } else {
                let mut end = (at + next(30)).min(text.len());
                while !text.is_char_boundary(end) {
                    end -= 1;
                }
                text.replace_range(at..end, "");
            }
        }
        let a = analyse(&text);
        let lines = super::text::LineIndex::new(&text);
        let enc = super::text::Encoding::Utf16;
        let _ = super::tokens::tokens(&a, &lines, enc);
        let _ = super::symbols::outline(&a, &lines, enc);
        for _ in 0..20 {
            let mut at = next(text.len() + 1);
            while !text.is_char_boundary(at) {
                at -= 1;
            }
            let _ = complete(&a, &text, at as u32);
            if let Some((_, id)) = a.index.at(0, at as u32) {
                let _ = super::hover::markdown(&a.index, id);
            }
        }
        let uri = lsp_types::Url::parse("file:///t.rev").unwrap();
        let diags: Vec<_> = a
            .compiled
            .diagnostics
            .iter()
            .map(|d| (d, lsp_types::Diagnostic { message: d.message.clone(), ..Default::default() }))
            .collect();
        let _ = super::actions::actions(&a, &uri, &lines, enc, &diags, 0, text.len() as u32);
        assert!(round < 40);
    }
}

/// Opening a domain in an editor reads what `revelio check` reads and nothing more: not a file
/// outside the domain's folder, not one by absolute path, not one that is open in another buffer
/// outside the folder (issue 12, item 1: the editor used to show `/proc/self/environ`).
#[test]
fn use_in_an_open_document_reads_only_what_check_would() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("d")).unwrap();
    let outside = dir.path().join("outside.rev");
    std::fs::write(&outside, "tag OutsideCanary\n").unwrap();
    let inside = dir.path().join("d/lib.rev");
    let entry = dir.path().join("d/domain.rev");
    let name = entry.to_string_lossy().into_owned();
    let mut open = HashMap::new();
    open.insert(outside.to_string_lossy().into_owned(), "tag OpenCanary\n".to_string());
    open.insert(inside.to_string_lossy().into_owned(), "tag Inside\n".to_string());
    for (path, says) in [
        ("/proc/self/environ", "is an absolute path"),
        ("/etc/shadow", "is an absolute path"),
        ("../outside.rev", "is outside the domain's folder"),
    ] {
        let a = Analysis::new(&name, &format!("use \"{path}\"\ntag T\n"), &open);
        let d = &a.compiled.diagnostics;
        assert!(d.iter().any(|d| d.code == "R0013" && d.message.contains(says)), "{path}: {d:?}");
        let loaded: Vec<&str> = a.file_names().filter(|n| !n.starts_with("std/")).collect();
        assert_eq!(loaded, [name.as_str()], "{path}: only the document itself is loaded");
        assert!(!a.compiled.files.iter().any(|f| f.text.contains("Canary") || f.text.contains("root:")));
    }
    // An unsaved buffer inside the folder stands in for its file.
    let a = Analysis::new(&name, "use \"lib.rev\"\ntag T\n", &open);
    assert!(a.compiled.diagnostics.is_empty(), "{:?}", a.compiled.diagnostics);
    assert!(a.file_names().any(|n| n.ends_with("d/lib.rev")));
}

/// Every name in the stdlib, every shipped domain and the good corpus resolves: each word of
/// each file is a keyword, a word with a fixed meaning, or a declaration or use the index has
/// (so the checker, the one resolver, recorded it).
#[test]
fn every_identifier_of_the_shipped_files_resolves() {
    use crate::syntax::ast::ItemKind;
    use crate::syntax::lexer::{self, TokenKind};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let files = crate::syntax::rev_files(&["stdlib", "domains", "tests/corpus/good"]);
    let in_subfolder = |f: &std::path::PathBuf| f.parent().and_then(|d| d.parent()) == Some(&root.join("domains"));
    assert!(files.iter().any(in_subfolder), "domains/ is walked recursively");
    assert!(files.len() >= 12, "{files:?}");
    // Words whose meaning is fixed, not declared: built-in types and names, constraint
    // functions, rule selections, materials, visibility and environment parameters.
    const FIXED: &[&str] = &[
        "ego",
        "self",
        "world",
        "bool",
        "number",
        "exclusive",
        "at_most",
        "requires",
        "forbids",
        "priority",
        "best_fit",
        "x",
        "y",
        "z",
        "box",
        "cylinder",
        "capsule",
        "sphere",
        "plane",
        "cone",
    ];
    let mut problems = Vec::new();
    let mut resolved = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let a = Analysis::new(&f.to_string_lossy(), &text, &HashMap::new());
        let errors: Vec<_> = a.compiled.diagnostics.iter().filter(|d| d.is_error()).collect();
        assert!(errors.is_empty(), "{}: {errors:?}", f.display());
        // Words a declaration gives a meaning without declaring a symbol.
        let mut fixed: Vec<(u32, u32)> = Vec::new();
        for item in &a.trees[0].items {
            match &item.kind {
                ItemKind::Domain(n) => fixed.push((n.span.start, n.span.end)),
                ItemKind::Unit { dimension, .. } => fixed.push((dimension.span.start, dimension.span.end)),
                ItemKind::Relation { placements: Some(ps), .. } => {
                    fixed.extend(ps.iter().map(|p| (p.word.span.start, p.word.span.end)))
                }
                ItemKind::Preset { params, .. } | ItemKind::Visible { params, .. } => {
                    fixed.extend(params.iter().map(|(p, _)| (p.span.start, p.span.end)))
                }
                ItemKind::Allow { code } => fixed.push((code.span.start, code.span.end)),
                _ => {}
            }
        }
        let dimensions: Vec<String> = a
            .index
            .all(&[Sort::Unit])
            .filter_map(|(_, u)| u.notes.first()?.strip_prefix("measures ").map(String::from))
            .collect();
        for t in lexer::lex(&text).into_iter().filter(|t| t.kind == TokenKind::Ident) {
            let word = t.text(&text);
            let occurrence = a.index.at(0, t.start).is_some_and(|(s, _)| s.start == t.start && s.end == t.end);
            if occurrence {
                resolved += 1;
            } else if !(lexer::is_keyword(word)
                || FIXED.contains(&word)
                || crate::ir::MATERIALS.contains(&word)
                || dimensions.iter().any(|d| d == word)
                || fixed.contains(&(t.start, t.end)))
            {
                let line = text[..t.start as usize].matches('\n').count() + 1;
                problems.push(format!("{}:{line}: `{word}` does not resolve", f.display()));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(resolved > 1000, "{resolved}");
}

//! The `.rev` front end, end to end: the corpus under `tests/corpus/` (expected diagnostics
//! written inline), every `.rev` file the project ships, the diagnostic-code table, snapshots of
//! the human and JSON renderings, and a no-panic run over a few thousand mutated inputs.
//!
//! Corpus annotations: a trailing comment `// error[R0020]: unknown kind` on a line says that a
//! diagnostic with that severity and code starts on that line and that its message contains the
//! text after the colon (the text is optional). Several annotations may share a line. Every
//! diagnostic of the file must be annotated and every annotation must be matched.

use std::path::Path;

use revelio::check::{self, Compiled};
use revelio::cli::check::{Report, line_col};
use revelio::cli::common::compile_path;
use revelio::diag::codes::CODES;
use revelio::diag::{Diagnostic, Severity};

mod common;
use common::{rev_files, root};

#[derive(Debug, PartialEq)]
struct Expected {
    line: usize,
    severity: &'static str,
    code: String,
    text: String,
}

/// Parse `// error[R0001]: text` annotations (text up to the next `//` or the line's end).
fn annotations(source: &str) -> Vec<Expected> {
    let mut out = Vec::new();
    for (i, line) in source.lines().enumerate() {
        for part in line.split("// ").skip(1) {
            let part = part.trim();
            for severity in ["error", "warning"] {
                let Some(rest) = part.strip_prefix(severity).and_then(|r| r.strip_prefix('[')) else { continue };
                let Some((code, rest)) = rest.split_once(']') else { continue };
                let text = rest.strip_prefix(':').unwrap_or("").trim().to_string();
                out.push(Expected { line: i + 1, severity, code: code.to_string(), text });
            }
        }
    }
    out
}

fn severity_word(d: &Diagnostic) -> &'static str {
    match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
    }
}

/// Compare a corpus file's diagnostics (in the file itself) with its annotations.
fn check_corpus_file(path: &Path) -> Vec<String> {
    let compiled = compile_path(path, false);
    let source = std::fs::read_to_string(path).unwrap();
    let mut expected = annotations(&source);
    let mut problems = Vec::new();
    for d in &compiled.diagnostics {
        if d.span.is_some_and(|s| s.file != 0) {
            continue;
        }
        let line = d.span.map_or(0, |s| line_col(&source, s.start as usize).0);
        let found = expected.iter().position(|e| {
            e.line == line && e.severity == severity_word(d) && e.code == d.code && d.message.contains(&e.text)
        });
        match found {
            Some(i) => {
                expected.remove(i);
            }
            None => problems.push(format!("line {line}: unexpected {}[{}]: {}", severity_word(d), d.code, d.message)),
        }
    }
    for e in expected {
        problems.push(format!("line {}: missing {}[{}]: {}", e.line, e.severity, e.code, e.text));
    }
    problems.iter().map(|p| format!("{}: {p}", path.display())).collect()
}

#[test]
fn corpus() {
    let mut problems = Vec::new();
    let good = rev_files(&root().join("tests/corpus/good"));
    let bad = rev_files(&root().join("tests/corpus/bad"));
    assert!(good.len() >= 3 && bad.len() >= 8, "the corpus is missing");
    for f in good.iter().chain(&bad) {
        problems.extend(check_corpus_file(f));
    }
    for f in &good {
        let c = compile_path(f, false);
        if c.has_errors() {
            problems.push(format!("{}: a good file has errors", f.display()));
        }
    }
    for f in &bad {
        let source = std::fs::read_to_string(f).unwrap();
        let errors = annotations(&source).iter().filter(|e| e.severity == "error").count();
        if errors < 3 {
            problems.push(format!("{}: a bad file should show at least 3 independent mistakes", f.display()));
        }
    }
    assert!(problems.is_empty(), "corpus mismatches:\n{}", problems.join("\n"));
}

#[test]
fn shipped_rev_files_check_without_errors() {
    let mut files = Vec::new();
    for dir in ["stdlib", "domains", "examples"] {
        files.extend(rev_files(&root().join(dir)));
    }
    assert!(files.iter().any(|f| f.ends_with("stdlib/core.rev")), "stdlib/core.rev is checked");
    let mut problems = Vec::new();
    for f in &files {
        let c = compile_path(f, false);
        for r in c.diagnostics.iter().filter(|d| d.is_error()) {
            problems.push(Report::new(&c.files, r).plain());
        }
    }
    assert!(problems.is_empty(), "shipped files have errors:\n{}", problems.join(""));
}

#[test]
fn every_stdlib_file_is_embedded() {
    for f in rev_files(&root().join("stdlib")) {
        let stem = f.file_stem().unwrap().to_string_lossy().into_owned();
        let Some((_, text)) = check::STDLIB.iter().find(|(n, _)| *n == stem) else {
            panic!("stdlib/{stem}.rev is not in `check::STDLIB`; add a line for it in src/check/mod.rs");
        };
        assert_eq!(*text, std::fs::read_to_string(&f).unwrap(), "embedded std::{stem} differs from the file");
    }
}

#[test]
fn every_code_is_documented_once() {
    let doc = std::fs::read_to_string(root().join("docs/diagnostics.md")).unwrap();
    for c in CODES {
        let row = format!("| `{}` | `{}` |", c.code, c.name);
        assert_eq!(doc.matches(&row).count(), 1, "docs/diagnostics.md needs exactly one row starting `{row}`");
    }
    let mut codes: Vec<&str> = CODES.iter().map(|c| c.code).collect();
    let sorted = {
        let mut s = codes.clone();
        s.sort();
        s
    };
    assert_eq!(codes, sorted, "CODES is in code order");
    codes.dedup();
    assert_eq!(codes.len(), CODES.len(), "codes are unique");
    // Every front-end code the corpus makes the checker emit is in the table.
    let mut emitted: Vec<&'static str> = Vec::new();
    for f in rev_files(&root().join("tests/corpus")) {
        emitted.extend(compile_path(&f, false).diagnostics.iter().map(|d| d.code));
    }
    for code in &emitted {
        assert!(revelio::diag::codes::info(code).is_some(), "emitted code {code} is not in CODES");
    }
    // The table has one home: the README links to it and keeps no copy that could drift.
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(readme.contains("(docs/diagnostics.md)"), "README.md links to docs/diagnostics.md");
    for c in CODES {
        for row in [format!("| {} |", c.code), format!("| `{}` |", c.code)] {
            assert!(!readme.contains(&row), "README.md has a row `{row}`: the code table lives in docs/diagnostics.md");
        }
    }
    let unused: Vec<&str> = CODES.iter().map(|c| c.code).filter(|c| !emitted.contains(c)).collect();
    // R0003, R0004 and R0044 need inputs too large for the corpus, and R0070 a lattice; they have
    // tests of their own (`tests/hostile.rs`, `src/check`, `src/source`, `src/lattice`).
    assert_eq!(unused, ["R0003", "R0004", "R0044", "R0070"], "codes without a corpus example");
}

fn render(path: &str, json: bool) -> String {
    let compiled: Compiled = compile_path(&root().join(path), false);
    let reports = revelio::cli::check::reports_of(&compiled);
    let body: String = if json {
        reports.iter().map(|r| r.json() + "\n").collect()
    } else {
        reports.iter().map(|r| r.human(&miette::GraphicalTheme::unicode_nocolor())).collect()
    };
    // Paths differ between machines; the snapshot shows them relative to the crate.
    let body = body.replace(&format!("{}/", root().display()), "");
    let source = std::fs::read_to_string(root().join(path)).unwrap();
    format!("----- SOURCE CODE\n{source}\n----- {}\n{body}", if json { "JSON" } else { "ERROR" })
}

/// Every bad corpus file, rendered as `revelio check` prints it (a new file without its
/// snapshots fails here until they are reviewed and added).
#[test]
fn snapshots_of_rendered_diagnostics() {
    let bad = rev_files(&root().join("tests/corpus/bad"));
    assert!(bad.len() >= 8, "the corpus is missing");
    for f in bad {
        let name = f.file_stem().unwrap().to_str().unwrap().to_string();
        let path = format!("tests/corpus/bad/{name}.rev");
        insta::assert_snapshot!(format!("{name}_human"), render(&path, false));
        insta::assert_snapshot!(format!("{name}_json"), render(&path, true));
    }
}

/// A small deterministic generator (xorshift), so the run needs no seed files.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

const FRAGMENTS: &[&str] = &[
    "{",
    "}",
    "(",
    ")",
    "\"",
    "\"\"\"",
    "..",
    ".",
    ",",
    ":",
    "|",
    "==",
    "<=",
    "#ff",
    "-",
    "2m",
    "0",
    "1e9",
    "é",
    "\\",
    "concept",
    "modifier",
    "kind",
    "world",
    "rules",
    "rule",
    "when",
    "exists",
    "has",
    "not",
    "and",
    "or",
    "add",
    "set",
    "target",
    "move",
    "shape",
    "box",
    "size",
    "allow",
    "use",
    "std::core",
    "// c\n",
    "/// d\n",
    "\n",
    "((((",
    "))))",
];

fn mutate(rng: &mut Rng, text: &str) -> String {
    let mut s: Vec<char> = text.chars().collect();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(s.len() + 1);
        match rng.below(5) {
            0 => {
                let end = (at + rng.below(40)).min(s.len());
                s.drain(at..end);
            }
            1 => s.splice(at..at, FRAGMENTS[rng.below(FRAGMENTS.len())].chars()).for_each(drop),
            2 => {
                let end = (at + rng.below(60)).min(s.len());
                let copy: Vec<char> = s[at..end].to_vec();
                let to = rng.below(s.len() + 1);
                s.splice(to..to, copy).for_each(drop);
            }
            3 => s.truncate(at),
            _ => {
                if at < s.len() {
                    s[at] = char::from(b' ' + rng.below(95) as u8);
                }
            }
        }
    }
    s.into_iter().collect()
}

#[test]
fn mutated_inputs_never_panic() {
    let mut seeds: Vec<String> = Vec::new();
    for dir in ["tests/corpus", "stdlib", "domains"] {
        seeds.extend(rev_files(&root().join(dir)).iter().map(|f| std::fs::read_to_string(f).unwrap()));
    }
    // Small files dominate so that thousands of inputs stay fast; domains are mutated less often.
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut compiled = 0;
    for i in 0..3000 {
        let seed = &seeds[if i % 10 == 0 { rng.below(seeds.len()) } else { rng.below(seeds.len().min(12)) }];
        let input = mutate(&mut rng, seed);
        let c = check::compile("fuzz.rev", &input, &revelio::check::std_only);
        for d in &c.diagnostics {
            if let Some(s) = d.span {
                let text = &c.files[s.file as usize].text;
                assert!(s.start <= s.end && (s.end as usize) <= text.len(), "span out of bounds for input {i}");
                assert!(text.is_char_boundary(s.start as usize) && text.is_char_boundary(s.end as usize));
            }
        }
        compiled += 1;
    }
    assert_eq!(compiled, 3000);
}

#[test]
fn deep_nesting_is_a_diagnostic_not_a_crash() {
    let deep = |open: &str, close: &str, n: usize| {
        format!("domain d\nrules priority {{ rule r {{ when {}true{} expect q.a }} }}", open.repeat(n), close.repeat(n))
    };
    for text in [deep("(", ")", 50_000), deep("not ", "", 5_000), deep("not (", ")", 250), deep("{", "}", 300)] {
        let c = check::compile("deep.rev", &text, &revelio::check::std_only);
        assert!(c.diagnostics.iter().any(|d| d.code == "R0003"), "{:?}", c.diagnostics.first());
    }
    // Reasonable nesting is fine.
    let c = check::compile("ok.rev", &deep("(", ")", 90), &revelio::check::std_only);
    assert!(c.diagnostics.iter().all(|d| d.code != "R0003"));
}

/// A `visible` override of a kind or tag applies to every kind that descends from it; the
/// nearest one wins (the kind's own, then its parents', then theirs), and a concept's override
/// wins over all of them.
#[test]
fn visible_overrides_apply_to_descendant_kinds_most_specific_first() {
    // `Hazard` is the standard library's tag (std::core).
    let text = r#"domain d
tag Sharp: Hazard
kind Thing {}
kind Knife: Thing, Sharp {}
kind Cleaver: Knife {}
kind Puddle: Hazard {}
kind Spill: Puddle {}
kind Cup: Thing {}
region r { x 1m..2m  y 0m..1m  z 0m }
concept knife { description "d" add knife: Knife in r  probe "a" not "b" }
concept cleaver { description "d" add cleaver: Cleaver in r  probe "a" not "b" }
concept spill { description "d" add spill: Spill in r  probe "a" not "b" }
visible { pixels = 30  contrast = 0.05 }
visible Hazard { pixels = 10 }
visible Sharp { pixels = 5 }
visible Cleaver { contrast = 0.2 }
visible spill { pixels = 99 }
question q { text "?" option a "A" option b "B" }
rules priority { rule r { expect q.a } }
"#;
    let d = check::compile_source("d.rev", text).unwrap_or_else(|e| panic!("{e:?}"));
    let v = &d.visibility;
    let t = |kind: &str, concept: Option<&str>| {
        let x = v.threshold(kind, concept);
        (x.pixels, x.contrast)
    };
    // Knife: Sharp is one step up, Hazard two.
    assert_eq!(t("Knife", None), (5, 0.05));
    // Cleaver's own override wins over Sharp's (two steps up); what it leaves out is the default's.
    assert_eq!(t("Cleaver", None), (30, 0.2));
    // Spill inherits through its parent kind Puddle from the tag Hazard.
    assert_eq!(t("Spill", None), (10, 0.05));
    assert_eq!(t("Spill", Some("spill")), (99, 0.05));
    // Kinds under no override keep the default.
    assert_eq!(t("Cup", None), (30, 0.05));
    assert!(!v.kinds.contains_key("Cup") && !v.kinds.contains_key("Thing"));
    // Two different overrides equally near a kind: R0027, pointing at the kind.
    let tie = text.replace(
        "kind Cup: Thing {}",
        "kind Cup: Thing {}\nkind Shard: Sharp, Puddle {}\nvisible Puddle { pixels = 12 }",
    );
    let errs = check::compile_source("d.rev", &tie).unwrap_err();
    let r0027: Vec<_> = errs.iter().filter(|e| e.code == "R0027").collect();
    assert_eq!(r0027.len(), 1, "{errs:?}");
    assert!(r0027[0].message.contains("`Shard`") && r0027[0].related.len() == 2, "{:?}", r0027[0]);
    // Equal overrides equally near are no conflict.
    let same = tie.replace("visible Puddle { pixels = 12 }", "visible Puddle { pixels = 5 }");
    let d = check::compile_source("d.rev", &same).unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!(d.visibility.threshold("Shard", None).pixels, 5);
}

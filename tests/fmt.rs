//! `revelio fmt`: every shipped file is formatted; formatting is idempotent, keeps the meaning
//! (`describe --json`, the whole IR, the syntax tree) and every comment, over the shipped and
//! corpus files and a few thousand generated variants of them; snapshots of formatted corpus
//! files show the style.

use std::path::{Path, PathBuf};

use revelio::fmt::format;
use revelio::syntax::{self, lexer};

mod common;
use common::{rev_files, root};

fn shipped() -> Vec<PathBuf> {
    let files: Vec<PathBuf> =
        ["stdlib", "domains", "examples"].iter().flat_map(|d| rev_files(&root().join(d))).collect();
    assert!(files.len() >= 7, "{files:?}");
    files
}

/// Corpus files without syntax errors (the formatter refuses the others).
fn corpus() -> Vec<PathBuf> {
    ["good", "lints", "bad", "render"]
        .iter()
        .flat_map(|d| rev_files(&root().join("tests/corpus").join(d)))
        .filter(|f| !f.ends_with("syntax_many.rev"))
        .collect()
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap()
}

fn name(p: &Path) -> String {
    p.strip_prefix(root()).unwrap().display().to_string()
}

fn fmt(p: &Path, text: &str) -> String {
    format(text).unwrap_or_else(|d| panic!("{}: {:?}", name(p), d))
}

/// The comments of `text`, in order, without trailing whitespace.
fn comments(text: &str) -> Vec<String> {
    lexer::lex(text).iter().filter(|t| t.kind.is_comment()).map(|t| t.text(text).trim_end().to_string()).collect()
}

/// The significant tokens of `text`, without commas before a closing brace (one-line lists drop
/// them, broken lists add them).
fn significant(text: &str) -> Vec<String> {
    let toks: Vec<_> = lexer::lex(text).into_iter().filter(|t| !t.kind.is_trivia()).collect();
    toks.iter()
        .enumerate()
        .filter(|(i, t)| {
            !(t.kind == lexer::TokenKind::Comma && toks.get(i + 1).is_some_and(|n| n.kind == lexer::TokenKind::RBrace))
        })
        .map(|(_, t)| t.text(text).to_string())
        .collect()
}

/// The syntax tree without spans: what the file says, wherever it says it.
fn tree_without_spans(text: &str) -> String {
    let tree = format!("{:?}", syntax::parse(0, text).file);
    let mut out = String::with_capacity(tree.len());
    let mut rest = tree.as_str();
    while let Some(i) = rest.find("Span {") {
        out.push_str(&rest[..i]);
        let close = rest[i..].find('}').expect("a span closes");
        rest = &rest[i + close + 1..];
    }
    out.push_str(rest);
    out
}

#[test]
fn every_shipped_file_is_formatted() {
    let unformatted: Vec<String> = shipped().iter().filter(|f| fmt(f, &read(f)) != read(f)).map(|f| name(f)).collect();
    assert!(unformatted.is_empty(), "run `revelio fmt` on: {unformatted:?}");
}

#[test]
fn formatting_is_idempotent_and_keeps_tokens_and_comments() {
    for f in shipped().iter().chain(&corpus()) {
        let text = read(f);
        let once = fmt(f, &text);
        assert_eq!(fmt(f, &once), once, "{}: formatting twice changes the file", name(f));
        assert_eq!(significant(&once), significant(&text), "{}: tokens changed", name(f));
        assert_eq!(comments(&once), comments(&text), "{}: comments changed", name(f));
        assert_eq!(tree_without_spans(&once), tree_without_spans(&text), "{}: syntax tree changed", name(f));
    }
}

/// What a file compiles to, through `revelio describe --json` and the whole IR (spans and file
/// texts removed: they move when the layout changes).
fn meaning(path: &Path, text: &str) -> (String, String) {
    let c = revelio::source::compile_text(path, text, &|_| None);
    let d = c.domain.unwrap_or_else(|| panic!("{} does not compile: {:?}", name(path), c.diagnostics));
    let describe = revelio::cli::describe::to_json(&d).to_string();
    let mut ir = serde_json::to_value(&d).unwrap();
    strip(&mut ir);
    (describe, ir.to_string())
}

fn strip(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.remove("span");
            m.remove("files");
            m.values_mut().for_each(strip);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
        _ => {}
    }
}

#[test]
fn formatting_keeps_describe_json_and_the_ir_of_every_shipped_file() {
    for f in shipped() {
        let text = read(&f);
        let (describe, ir) = meaning(&f, &text);
        let (describe2, ir2) = meaning(&f, &fmt(&f, &text));
        assert_eq!(describe, describe2, "{}: `describe --json` changed", name(&f));
        assert_eq!(ir, ir2, "{}: the IR changed", name(&f));
    }
}

#[test]
fn snapshots_of_formatted_corpus_files() {
    for f in ["good/small_driving", "good/kitchen_best_fit", "good/props", "lints/lost_modifier"] {
        let path = root().join(format!("tests/corpus/{f}.rev"));
        let text = read(&path);
        insta::assert_snapshot!(f.replace('/', "_"), fmt(&path, &text));
    }
}

/// xorshift: a seeded generator, so every run makes the same inputs.
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n.max(1) as u64) as usize
    }
}

/// A variant of `text`: comments of every sort put where whitespace was, and whitespace
/// squeezed or stretched elsewhere (never right after a comment, which would end it early).
fn variant(rng: &mut Rng, text: &str, serial: &mut usize) -> String {
    let toks = lexer::lex(text);
    let mut out = String::with_capacity(text.len() + 200);
    let edits = 1 + rng.below(8);
    let spaces: Vec<usize> =
        toks.iter().enumerate().filter(|(_, t)| t.kind == lexer::TokenKind::Whitespace).map(|(i, _)| i).collect();
    let chosen: Vec<usize> = (0..edits).map(|_| spaces[rng.below(spaces.len())]).collect();
    for (i, t) in toks.iter().enumerate() {
        let after_comment = i > 0 && toks[i - 1].kind.is_comment();
        if chosen.contains(&i) && !after_comment {
            *serial += 1;
            let n = *serial;
            let piece = match rng.below(9) {
                0 => format!(" // trailing {n}\n"),
                1 => format!("\n// own line {n}\n"),
                2 => format!("\n/// doc {n}\n"),
                3 => format!("\n\n\n// after blanks {n}\n\n"),
                4 => format!("\n    //tight {n}   \n  "),
                5 => format!(" /// trailing doc {n}\n"),
                6 => " ".to_string(),
                7 => "\n\n\n".to_string(),
                _ => format!("\n//// banner {n} ////\n\t"),
            };
            // Squeezing a line break out of a statement keeps the file valid: the grammar is
            // free-form outside strings and comments.
            out.push_str(&piece);
        } else {
            out.push_str(t.text(text));
        }
    }
    out
}

#[test]
fn no_comment_is_lost_on_generated_inputs() {
    let mut seeds: Vec<(PathBuf, String)> = corpus().into_iter().map(|f| (f.clone(), read(&f))).collect();
    seeds.sort_by_key(|(_, t)| t.len());
    let small = seeds.len().min(14);
    seeds.extend(shipped().into_iter().map(|f| (f.clone(), read(&f))));
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let (mut checked, mut serial) = (0, 0);
    for round in 0..2500 {
        // Small files most of the time keep a few thousand rounds quick.
        let (path, seed) = &seeds[if round % 25 == 0 { rng.below(seeds.len()) } else { rng.below(small) }];
        let input = variant(&mut rng, seed, &mut serial);
        let Ok(once) = format(&input) else { continue };
        let what = || format!("round {round} from {}:\n{input}", name(path));
        assert_eq!(comments(&once), comments(&input), "comments changed in {}", what());
        assert_eq!(significant(&once), significant(&input), "tokens changed in {}", what());
        assert_eq!(tree_without_spans(&once), tree_without_spans(&input), "syntax tree changed in {}", what());
        assert_eq!(format(&once).as_ref(), Ok(&once), "not idempotent in {}", what());
        checked += 1;
    }
    // Inserted comments never break the grammar, so almost every variant must format.
    assert!(checked >= 2400, "only {checked} inputs formatted");
}

#[test]
fn files_with_syntax_errors_are_refused_with_their_errors() {
    let f = root().join("tests/corpus/bad/syntax_many.rev");
    let errors = format(&read(&f)).unwrap_err();
    assert!(errors.len() >= 3 && errors.iter().all(|d| d.code == "R0001"), "{errors:?}");
}

fn layout(text: &str) -> String {
    format(text).unwrap_or_else(|d| panic!("{d:?}"))
}

#[test]
fn statements_go_one_per_line_and_settings_fill_lines() {
    assert_eq!(
        layout("concept c{description \"d\" add x:K in lane ahead_of ego{d=2m .. 4m,}}\nkind K{}"),
        "concept c {\n  description \"d\"\n  add x: K in lane ahead_of ego { d = 2m..4m }\n}\nkind K {}\n"
    );
    assert_eq!(layout("region r {\n x 0m\n y 1m\n}"), "region r { x 0m  y 1m }\n");
    let long = format!("preset p {{ {} }}", (0..12).map(|i| format!("param_{i} = {i}")).collect::<Vec<_>>().join(" "));
    let out = layout(&long);
    assert!(out.lines().all(|l| l.chars().count() <= revelio::fmt::MAX_WIDTH), "{out}");
    assert_eq!(out.lines().count(), 4, "{out}");
    assert!(out.contains("param_0 = 0  param_1 = 1"), "{out}");
    assert_eq!(
        layout("rules priority { rule r { when exists e: A|B where e.d<=4m and(has c) expect q.a } }"),
        "rules priority {\n  rule r {\n    when exists e: A | B where e.d <= 4m and (has c)\n    expect q.a\n  }\n}\n"
    );
    assert_eq!(layout("constraint c = at_most( 2 , a , b_* )"), "constraint c = at_most(2, a, b_*)\n");
}

#[test]
fn relations_regions_pitch_and_two_entity_conditions_are_laid_out() {
    let input = "relation near \"is near\"{distance 0m .. 1.5m\n}\n\
                 relation on \"is on\" {\n on_top }\n\
                 kind Tree:Extra{in verge ,far_kerb}\n\
                 kind Car{in far_kerb\n d: length = 1m\n}\n\
                 look Tree{box size(1m,1m,1m) pitch 10deg yaw 5deg}\n\
                 rules priority{rule r{when exists a:Car where exists b:Car where a near b and a.d<b.d expect q.a}}\n";
    let want = "relation near \"is near\" { distance 0m..1.5m }\n\
                relation on \"is on\" { on_top }\n\
                kind Tree: Extra { in verge, far_kerb }\n\
                kind Car {\n  in far_kerb\n  d: length = 1m\n}\n\
                look Tree {\n  box size (1m, 1m, 1m) pitch 10deg yaw 5deg\n}\n\
                rules priority {\n  rule r {\n    when exists a: Car where exists b: Car where a near b and a.d < b.d\n    expect q.a\n  }\n}\n";
    let out = layout(input);
    assert_eq!(out, want);
    assert_eq!(layout(&out), out, "formatting twice changes nothing");
    // Many placements fill lines, like a preset's settings.
    let long = "relation beside \"is right beside the thing it stands next to\" { distance 0m..1.5m  ahead -0.5m..0.5m  left 0.2m..1.5m }";
    let out = layout(long);
    assert!(out.lines().count() > 1 && out.lines().all(|l| l.chars().count() <= revelio::fmt::MAX_WIDTH), "{out}");
    assert_eq!(layout(&out), out);
}

#[test]
fn comments_stay_where_they_were() {
    // Trailing comments stay trailing; own-line ones stay on their own line, indented like the
    // code; blank lines collapse to one and go away after `{` and before `}`.
    let input = "// head\n\n\n\nkind K { // after brace\n\n  // before a\n  a: bool = true // trailing\n\n\n  b: bool = false\n  // at the end\n\n}\n// tail\n";
    let want = "// head\n\nkind K { // after brace\n  // before a\n  a: bool = true // trailing\n\n  b: bool = false\n  // at the end\n}\n// tail\n";
    assert_eq!(layout(input), want);
    // A comment inside a statement breaks the line there and indents the rest one step.
    assert_eq!(layout("concept c { add x: K // why\n in lane }"), "concept c {\n  add x: K // why\n    in lane\n}\n");
    // Comments keep an enum or an empty block open.
    assert_eq!(layout("enum E { a, // first\n b }"), "enum E {\n  a, // first\n  b,\n}\n");
    assert_eq!(layout("kind K { // nothing yet\n}"), "kind K { // nothing yet\n}\n");
    assert_eq!(layout("kind K {\n// nothing yet\n}"), "kind K {\n  // nothing yet\n}\n");
}

/// Run the `revelio` binary with `stdin`; (exit code, stdout, stderr).
fn revelio(args: &[&str], stdin: &str) -> (i32, String, String) {
    use std::io::Write as _;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // A command that refuses its flags exits without reading its input (`fmt --diff` without
    // `--check`): the pipe it closed is no failure of the test, its exit code says what happened.
    if let Err(e) = child.stdin.take().unwrap().write_all(stdin.as_bytes()) {
        assert_eq!(e.kind(), std::io::ErrorKind::BrokenPipe, "{e}");
    }
    let out = child.wait_with_output().unwrap();
    let text = |b: Vec<u8>| String::from_utf8(b).unwrap();
    (out.status.code().unwrap(), text(out.stdout), text(out.stderr))
}

#[test]
fn the_fmt_command_rewrites_checks_and_reads_stdin() {
    let dir = tempfile::tempdir().unwrap();
    let messy = dir.path().join("messy.rev");
    let tidy = dir.path().join("tidy.rev");
    std::fs::write(&messy, "kind K{a:bool=true}").unwrap();
    std::fs::write(&tidy, "tag T\n").unwrap();
    let d = dir.path().to_str().unwrap();
    let (code, out, _) = revelio(&["fmt", "--check", d], "");
    assert_eq!((code, out.trim()), (1, messy.to_str().unwrap()), "--check lists what it would change");
    assert_eq!(read(&messy), "kind K{a:bool=true}", "--check writes nothing");
    assert_eq!(revelio(&["fmt", d], "").0, 0);
    assert_eq!(read(&messy), "kind K {\n  a: bool = true\n}\n");
    assert_eq!(revelio(&["fmt", "--check", d], "").0, 0);
    assert_eq!(revelio(&["fmt", "-"], "tag  T"), (0, "tag T\n".to_string(), String::new()));
    assert_eq!(revelio(&["fmt", "--check", "-"], "tag  T").0, 1);
    let (code, out, err) = revelio(&["fmt", "-"], "kind K { a: bool = }");
    assert_eq!((code, out.as_str()), (1, ""), "a file with syntax errors is left alone");
    assert!(err.contains("expected a value") && err.contains("R0001"), "{err}");
}

#[test]
fn check_reads_an_unsaved_buffer_from_stdin() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("lib.rev"), "tag Shiny\n").unwrap();
    let name = dir.path().join("buffer.rev");
    let name = name.to_str().unwrap();
    let buffer = "use \"lib.rev\"\nkind K: Shinny {}\n";
    let (code, out, _) = revelio(&["check", "-", "--stdin-filename", name, "--format", "plain"], buffer);
    assert_eq!(code, 1);
    assert_eq!(out.lines().next().unwrap(), format!("{name}:2:9: error[R0020]: unknown kind or tag `Shinny`"));
    assert!(out.contains("did you mean `Shiny`?"), "the used file was read relative to the name: {out}");
    let (code, out, _) = revelio(&["check", "-", "--format", "json"], "tag A\ntag A\n");
    assert_eq!(code, 1);
    assert!(out.contains("\"file\":\"<stdin>\""), "{out}");
    assert_eq!(revelio(&["check", "--stdin-filename", name, name], "").0, 2, "a name needs `-`");
}

#[test]
fn fmt_check_diff_prints_what_formatting_would_change() {
    let messy = "// a domain\ntag T\nkind K{a:bool=true}\n\n\n\nkind L {}\n";
    let (code, out, err) = revelio(&["fmt", "--check", "--diff", "-"], messy);
    assert_eq!(code, 1, "{err}");
    insta::assert_snapshot!("fmt_check_diff", out);
    assert_eq!(revelio(&["fmt", "--check", "--diff", "-"], "tag T\n"), (0, String::new(), String::new()));
    let (code, _, err) = revelio(&["fmt", "--diff", "-"], messy);
    assert_eq!(code, 2, "--diff needs --check: {err}");
}

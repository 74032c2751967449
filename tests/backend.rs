//! The compiler back end on the shipped domains: the paper's ground-truth table (oracle), invalid
//! sets, the lattice, and the lattice lints — on `domains/*.rev` and on the deliberately broken
//! files of `tests/corpus/lints/`.

mod common;

use std::path::Path;

use revelio::check::compile_source;
use revelio::ir::Domain;
use revelio::lattice::Lattice;
use revelio::lint as lints;
use revelio::oracle::{self, OracleError};

fn domain(name: &str) -> Domain {
    common::compile_shipped(&format!("domains/{name}"))
}

/// (rule, option name, letter, question) of a set's verdict.
fn verdict(d: &Domain, names: &[&str]) -> (String, String, String, String) {
    let set = d.parse_set(names).unwrap();
    let v = oracle::evaluate(d, set).unwrap_or_else(|e| panic!("{names:?}: {e}"));
    let q = &d.questions[v.question.index()];
    (d.rules[v.rule.index()].name.clone(), q.options[v.expected as usize].name.clone(), v.letter(), q.name.clone())
}

fn invalid(d: &Domain, names: &[&str]) -> String {
    match oracle::evaluate(d, d.parse_set(names).unwrap()) {
        Err(e @ OracleError::Invalid { .. }) => e.to_string(),
        other => panic!("{names:?} should be invalid, got {other:?}"),
    }
}

#[test]
fn driving_ground_truth_follows_the_paper() {
    let d = domain("driving.rev");
    let answer = |names: &[&str]| {
        let (_, option, letter, _) = verdict(&d, names);
        (option, letter)
    };
    let stop = ("stop".to_string(), "A".to_string());
    let slow = ("slow".to_string(), "B".to_string());
    let go = ("go".to_string(), "C".to_string());
    assert_eq!(answer(&["obstruction_near"]), stop);
    assert_eq!(answer(&["obstruction_far"]), slow);
    assert_eq!(answer(&["light_green"]), go);
    assert_eq!(answer(&["obstruction_near", "light_green"]), stop, "an in-lane obstacle outranks a green light");
    assert_eq!(answer(&["cyclist", "on_sidewalk"]), go);
    assert_eq!(answer(&["pedestrian", "near"]), stop);
    assert_eq!(answer(&["pedestrian", "far", "weather_foggy"]), slow);
    assert_eq!(verdict(&d, &["obstruction_near"]).0, "near_in_lane");
}

#[test]
fn driving_rejects_impossible_sets_naming_the_constraint() {
    let d = domain("driving.rev");
    assert!(invalid(&d, &["town_town01", "town_town02"]).contains("violates constraint `one_town`"));
    assert!(invalid(&d, &["cone", "near", "far"]).contains("violates constraint `near_xor_far`"));
    assert_eq!(invalid(&d, &["near"]), "invalid concept set {`near`}: modifier `near` has no entity to apply to");
}

#[test]
fn indoor_ground_truth_follows_the_paper() {
    let d = domain("indoor.rev");
    let (rule, option, _, question) = verdict(&d, &["glass_floor", "barefoot_near_glass"]);
    assert_eq!((option.as_str(), question.as_str()), ("yes", "cut_floor"), "decided by `{rule}`");
    let (rule, option, _, _) = verdict(&d, &["barefoot_child_safe"]);
    let r = d.rules.iter().find(|r| r.name == rule).unwrap();
    assert!(r.safe, "`{rule}` should be a safe-scene rule");
    assert_eq!(option, "no");
    assert!(invalid(&d, &["child_reaching"]).contains("violates constraint `reaching_needs_open_cabinet`"));
}

#[test]
fn oracle_is_deterministic_over_the_driving_lattice() {
    let d = domain("driving.rev");
    let lattice = Lattice::enumerate(&d, 3);
    let o = oracle::Oracle::new(&d);
    for &s in &lattice.sets {
        let v = o.evaluate(s).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(oracle::evaluate(&d, s).unwrap(), v);
    }
}

#[test]
fn driving_lattice_has_the_paper_shape() {
    let d = domain("driving.rev");
    assert_eq!(d.concepts.len(), 30);
    let lattice = Lattice::enumerate(&d, 5);
    // Every concept but the four entity modifiers is a valid scene alone.
    assert_eq!(lattice.counts()[1], 26);
    assert!(lattice.sets.iter().all(|s| lattice.is_valid(*s) && s.len() <= 5));
    assert_eq!(lattice.support().len(), 30, "every concept appears in some valid set");
}

/// Lattice lints of a domain, without the codes its `allow` items silence.
fn unallowed_lints(d: &Domain) -> Vec<String> {
    lints::lint_domain(d)
        .into_iter()
        .filter(|x| !d.allow.iter().any(|a| a.code == x.code))
        .map(|x| format!("{}: {}", x.code, x.message))
        .collect()
}

/// Every shipped domain (`domains/*.rev`; a new one is judged too) has no lattice lint its
/// `allow` items do not silence.
#[test]
fn every_shipped_domain_is_lint_clean() {
    let mut names: Vec<String> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("domains"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".rev"))
        .collect();
    names.sort();
    assert!(names.len() >= 3, "{names:?}");
    for name in names {
        assert_eq!(unallowed_lints(&domain(&name)), Vec::<String>::new(), "{name}");
    }
}

/// Each corpus file says what it must report in `// expect: CODE WORDS` header lines: one
/// lattice lint with that code whose underlined text contains WORDS. Nothing else may be
/// reported.
#[test]
fn lint_corpus() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/lints");
    let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert!(files.len() >= 7, "one file per lint code");
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let d = compile_source(&name, &text).unwrap_or_else(|e| panic!("{name} does not compile: {e:#?}"));
        let mut expected: Vec<(String, String)> = text
            .lines()
            .filter_map(|l| l.strip_prefix("// expect: "))
            .map(|l| {
                let (code, words) = l.split_once(' ').unwrap();
                (code.to_string(), words.to_string())
            })
            .collect();
        assert!(!expected.is_empty(), "{name} has no `// expect:` line");
        let mut got: Vec<(String, String)> = lints::lint_domain(&d)
            .into_iter()
            .map(|x| {
                let span = x.span.unwrap_or_else(|| panic!("{name}: {} has no span", x.message));
                let underlined = &d.files[span.file as usize].text[span.start as usize..span.end as usize];
                let words = expected
                    .iter()
                    .find(|(c, w)| *c == x.code && underlined.contains(w.as_str()))
                    .map_or_else(|| format!("<{underlined}>: {}", x.message), |(_, w)| w.clone());
                (x.code.to_string(), words)
            })
            .collect();
        expected.sort();
        got.sort();
        assert_eq!(got, expected, "{name}");
    }
}

/// A concept the domain does not declare, given on the command line, is an input error (exit 1)
/// with the checker's "did you mean", for every command that takes concept names.
#[test]
fn unknown_concepts_on_the_command_line_are_input_errors_with_a_suggestion() {
    let file = common::root().join("domains/driving.rev");
    let file = file.to_str().unwrap();
    let commands: [&[&str]; 4] = [
        &["oracle", file, "debris_farr"],
        &["emit", "scene", file, "debris_farr"],
        &["ask", file, "debris_farr", "--model", "sim:examples/sim/driving_paper.toml", "--renderer", "none"],
        &["render", file, "debris_farr", "-o", "unused.png"],
    ];
    for args in commands {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_revelio"))
            .args(args)
            .current_dir(common::root())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            err.contains("unknown concept `debris_farr` in domain `driving`; did you mean `debris_far`?"),
            "{args:?}: {err}"
        );
    }
}

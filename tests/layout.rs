//! The pipeline is a straight line: no module imports one above it. Each top-level module of
//! `src/` has a floor; a `crate::X` path in a module's non-test code must name a module on a
//! lower floor (or the same module). Test code (`#[cfg(test)]` items, `tests.rs`, `testkit.rs`)
//! may reach anywhere.
//!
//! The floors, bottom first (README "Architecture" draws the same line): `diag` (spans,
//! diagnostics, codes, suggestions), `hash` and `outcome` → `ir` → `syntax` → `check` → `anchor`,
//! `scene` → `lattice` → `oracle` → `lint`, `sample` → `emit` → `search` (pure algorithms) →
//! `net`, `source` → `render` → `vlm` → `journal` → `run` → `analysis` → `report` → `fmt` → `lsp` →
//! `cli` (the language server formats through `fmt`).
//! `ir` is the compiler's output but plain data: it sits below the front end that builds it.

use std::collections::BTreeMap;
use std::path::Path;

/// Floors of the modules; a module not listed here fails the test until it is placed.
const FLOORS: &[(&str, u32)] = &[
    ("diag", 0),
    ("hash", 0),
    ("outcome", 0),
    ("ir", 1),
    ("syntax", 2),
    ("check", 3),
    ("anchor", 4),
    ("scene", 4),
    ("lattice", 5),
    ("oracle", 6),
    ("lint", 7),
    ("sample", 7),
    ("emit", 8),
    ("search", 9),
    ("net", 10),
    ("source", 10),
    ("render", 11),
    ("vlm", 12),
    ("journal", 13),
    ("run", 14),
    ("analysis", 15),
    ("report", 16),
    ("fmt", 17),
    ("lsp", 18),
    ("cli", 19),
];

/// The modules of the core, which does no I/O: no file, network, process or GPU access.
const CORE: &[&str] = &[
    "diag", "hash", "outcome", "syntax", "ir", "check", "anchor", "scene", "lattice", "oracle", "lint", "sample",
    "emit", "search",
];

/// Paths whose use in the core means I/O.
const IO: &[&str] =
    &["std::fs", "std::net", "std::process", "tokio", "reqwest", "wgpu", "std::io::stdin", "std::env::var"];

fn floor(module: &str) -> Option<u32> {
    FLOORS.iter().find(|(m, _)| *m == module).map(|(_, f)| *f)
}

/// The text of a source file without its test-only items: an item after `#[cfg(test)]` is cut
/// (a `mod x;` line, or a block up to its closing brace at the same indentation).
fn non_test_code(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        if line.trim() == "#[cfg(test)]" {
            let indent = line.len() - line.trim_start().len();
            let Some(item) = lines.next() else { break };
            if item.trim_end().ends_with('{') {
                let close = format!("{}}}", " ".repeat(indent));
                for l in lines.by_ref() {
                    if l.trim_end() == close {
                        break;
                    }
                }
            }
            continue;
        }
        // Doc comments may name modules in prose.
        if line.trim_start().starts_with("//") {
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// `crate::X` names in the text.
fn crate_paths(code: &str) -> Vec<String> {
    let mut found = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().last();
        rest = &rest[i + "crate::".len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue; // `revelio_crate::` or similar
        }
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        if !name.is_empty() {
            found.push(name);
        }
    }
    found
}

#[test]
fn no_module_imports_one_above_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    // Modules that `lib.rs` declares under `#[cfg(test)]` are tests themselves.
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let test_modules: Vec<&str> = lib
        .split("#[cfg(test)]")
        .skip(1)
        .filter_map(|rest| rest.trim_start().strip_prefix("mod ")?.split(';').next())
        .collect();
    let mut upward: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut unplaced = Vec::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap().to_string_lossy().replace('\\', "/");
        let name = f.file_name().unwrap().to_string_lossy();
        if matches!(rel.as_str(), "lib.rs" | "main.rs")
            || name == "tests.rs"
            || name == "testkit.rs"
            || rel.contains("/tests/")
        {
            continue;
        }
        let module = rel.split('/').next().unwrap().trim_end_matches(".rs").to_string();
        if test_modules.contains(&module.as_str()) {
            continue;
        }
        let Some(own) = floor(&module) else {
            unplaced.push(module);
            continue;
        };
        let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
        for dep in crate_paths(&code) {
            if dep == module {
                continue;
            }
            match floor(&dep) {
                Some(d) if d < own => {}
                _ => upward.entry(format!("{rel} ({module}, floor {own})")).or_default().push(dep),
            }
        }
    }
    unplaced.sort();
    unplaced.dedup();
    assert!(unplaced.is_empty(), "modules without a floor in tests/layout.rs: {unplaced:?}");
    for deps in upward.values_mut() {
        deps.sort();
        deps.dedup();
    }
    assert!(
        upward.is_empty(),
        "imports that run against the pipeline (file → modules on the same or a higher floor): {upward:#?}"
    );
}

#[test]
fn the_core_does_no_io() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut offenders = Vec::new();
    for module in CORE {
        let mut files = Vec::new();
        let dir = src.join(module);
        if dir.is_dir() {
            rust_files(&dir, &mut files);
        }
        let file = src.join(format!("{module}.rs"));
        if file.is_file() {
            files.push(file);
        }
        for f in files {
            let name = f.file_name().unwrap().to_string_lossy();
            if name == "tests.rs" || name == "testkit.rs" || name == "fixture.rs" {
                continue;
            }
            let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
            for io in IO {
                if code.contains(io) {
                    offenders.push(format!("{} uses `{io}`", f.strip_prefix(&src).unwrap().display()));
                }
            }
        }
    }
    assert!(offenders.is_empty(), "the core does I/O: {offenders:#?}");
}

#[test]
fn the_filter_cuts_test_items() {
    let text = "use crate::a;\n#[cfg(test)]\nmod tests {\n    use crate::z;\n}\n#[cfg(test)]\nmod kit;\nfn f() { crate::b::g() }\n// crate::c in prose\n";
    assert_eq!(crate_paths(&non_test_code(text)), vec!["a", "b"]);
}

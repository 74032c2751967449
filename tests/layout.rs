//! The pipeline is a straight line: no module imports one above it. Each top-level module of
//! `src/` has a floor; a `crate::X` path in a module's non-test code must name a module on a
//! lower floor (or the same module). Test code (`#[cfg(test)]` items, `tests.rs`, `testkit.rs`)
//! may reach anywhere.
//!
//! The floors, bottom first (README "Architecture" draws the same line): `diag` (spans,
//! diagnostics, codes, suggestions), `hash`, `date` and `outcome` → `ir` → `syntax` → `check` →
//! `anchor`, `scene` → `lattice` → `oracle` → `lint`, `sample` → `emit` → `search` (pure
//! algorithms) → `net`, `source` → `render` → `vlm` → `journal` → `run` → `analysis` → `report` →
//! `fmt` → `lsp` → `cli` (the language server formats through `fmt`).
//! `ir` is the compiler's output but plain data: it sits below the front end that builds it.
//!
//! Imports are read in full: every leaf of a grouped `use` (`use crate::{run::X, search::Y}`),
//! and `self::`, `super::` and `super::super::` paths resolved against the file's own module.
//! Within a module, files import one another without a circle (a circle means the shared piece
//! lives in the wrong file), and every file under `src/`, `tests/`, `benches/` and `examples/`
//! opens with a `//!` saying why it exists.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Floors of the modules; a module not listed here fails the test until it is placed.
const FLOORS: &[(&str, u32)] = &[
    ("diag", 0),
    ("hash", 0),
    ("date", 0),
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
    "diag", "hash", "date", "outcome", "syntax", "ir", "check", "anchor", "scene", "lattice", "oracle", "lint",
    "sample", "emit", "search",
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

/// The top-level modules a piece of code names through `crate::` (the test of the filter reads
/// these).
fn crate_paths(code: &str) -> Vec<String> {
    imports(code, &[]).into_iter().filter_map(|p| p.into_iter().next()).collect()
}

/// Every path the code names from the crate's root, as segments from there: `crate::a::b`, and
/// `self::…`, `super::…` and `super::super::…` resolved against `module` (the file's own module
/// path); a `use` with groups (`use crate::{a::B, c::{D, E}}`) counts once per leaf. A path that
/// climbs above the crate, and paths into other crates, are left out.
fn imports(code: &str, module: &[String]) -> Vec<Vec<String>> {
    let (trees, rest) = split_uses(code);
    let mut found = Vec::new();
    for tree in trees {
        let mut leaves = Vec::new();
        expand(&tree, &[], &mut leaves);
        found.extend(leaves.iter().filter_map(|(p, _)| absolute(p, module)));
    }
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut at = 0;
    while at < rest.len() {
        let tail = &rest[at..];
        let Some(word) = ["crate::", "self::", "super::"].iter().find(|w| tail.starts_with(**w)) else {
            at += tail.chars().next().map_or(1, char::len_utf8);
            continue;
        };
        let before = rest[..at].chars().last();
        if before.is_some_and(|c| ident(c) || c == ':') {
            at += word.len();
            continue; // `revelio_crate::`, `Self::`-like or a later segment
        }
        let len = path_len(tail);
        let path: Vec<String> = tail[..len].split("::").map(str::to_string).collect();
        found.extend(absolute(&path, module));
        at += len.max(1);
    }
    found
}

/// The length of the path `a::b::c` at the start of `text`, without a trailing `::` (before a
/// group, a glob or generic arguments).
fn path_len(text: &str) -> usize {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut end = 0;
    loop {
        let seg: usize = text[end..].chars().take_while(|c| ident(*c)).map(char::len_utf8).sum();
        if seg == 0 {
            return end.saturating_sub(2);
        }
        end += seg;
        if !text[end..].starts_with("::") {
            return end;
        }
        end += 2;
    }
}

/// The trees of the `use` items in the code (each may span lines), and the code without them.
fn split_uses(code: &str) -> (Vec<String>, String) {
    let (mut trees, mut rest) = (Vec::new(), String::new());
    let mut lines = code.lines();
    while let Some(line) = lines.next() {
        let Some(tree) = use_tree(line) else {
            rest.push_str(line);
            rest.push('\n');
            continue;
        };
        let mut tree = tree.to_string();
        while !tree.contains(';') {
            let Some(next) = lines.next() else { break };
            tree.push(' ');
            tree.push_str(next.trim());
        }
        trees.push(tree.split(';').next().unwrap_or_default().to_string());
    }
    (trees, rest)
}

/// The tree of a `use` item that starts on this line (`pub use`, `pub(crate) use` and so on).
fn use_tree(line: &str) -> Option<&str> {
    let mut l = line.trim_start();
    if let Some(r) = l.strip_prefix("pub") {
        l = r.trim_start();
        if l.starts_with('(') {
            l = l[l.find(')')? + 1..].trim_start();
        }
    }
    l.strip_prefix("use ")
}

/// The leaves of a `use` tree, each as its full path and the name it binds (`self` in a group
/// names the group's path; a glob binds `*`).
fn expand(tree: &str, prefix: &[String], out: &mut Vec<(Vec<String>, String)>) {
    let tree = tree.trim();
    let mut path = prefix.to_vec();
    if let (Some(open), Some(close)) = (tree.find('{'), tree.rfind('}')) {
        path.extend(segments(&tree[..open]));
        let body = &tree[open + 1..close];
        let (mut depth, mut start) = (0, 0);
        for (i, c) in body.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    expand(&body[start..i], &path, out);
                    start = i + 1;
                }
                _ => {}
            }
        }
        expand(&body[start..], &path, out);
        return;
    }
    let mut parts = tree.split(" as ");
    let leaf = parts.next().unwrap_or_default().trim();
    if leaf.is_empty() {
        return;
    }
    if leaf != "self" && leaf != "*" {
        path.extend(segments(leaf));
    }
    let name = match parts.next() {
        Some(alias) => alias.trim().to_string(),
        None if leaf == "*" => "*".to_string(),
        None => path.last().cloned().unwrap_or_default(),
    };
    out.push((path, name));
}

fn segments(path: &str) -> impl Iterator<Item = String> + '_ {
    path.split("::").map(str::trim).filter(|s| !s.is_empty()).map(str::to_string)
}

/// `path` from the crate's root, if it starts with `crate`, `self` or `super`.
fn absolute(path: &[String], module: &[String]) -> Option<Vec<String>> {
    let (first, rest) = path.split_first()?;
    let mut out = match first.as_str() {
        "crate" | "$crate" => Vec::new(),
        "self" => module.to_vec(),
        "super" => module.split_last()?.1.to_vec(),
        _ => return None,
    };
    let mut rest = rest.iter().peekable();
    while rest.next_if(|s| *s == "super").is_some() {
        out.pop()?;
    }
    out.extend(rest.cloned());
    Some(out)
}

/// The module path of a file under `src/` (`search/mod.rs` and `search.rs` are both `search`).
fn module_of(rel: &str) -> Vec<String> {
    let mut parts: Vec<String> = rel.trim_end_matches(".rs").split('/').map(str::to_string).collect();
    if matches!(parts.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        parts.pop();
    }
    parts
}

/// Whether the layering and the import graph leave this file out: the crate's roots, and test
/// code (`tests.rs`, `testkit.rs`, files under a `tests/` folder, modules `lib.rs` declares
/// under `#[cfg(test)]`).
fn skipped(rel: &str, test_modules: &[&str]) -> bool {
    let name = rel.rsplit('/').next().unwrap_or(rel);
    matches!(rel, "lib.rs" | "main.rs")
        || name == "tests.rs"
        || name == "testkit.rs"
        || rel.contains("/tests/")
        || test_modules.contains(&rel.split('/').next().unwrap().trim_end_matches(".rs"))
}

/// The modules that `lib.rs` declares under `#[cfg(test)]`: tests themselves.
fn test_modules(lib: &str) -> Vec<&str> {
    lib.split("#[cfg(test)]")
        .skip(1)
        .filter_map(|rest| rest.trim_start().strip_prefix("mod ")?.split(';').next())
        .collect()
}

/// The file-level import graph of `src/`'s non-test code: each file (path under `src/`) → the
/// files its paths lead to. A path leads to the deepest file it names, and on through that
/// file's `use` items (`crate::run::Task`, re-exported by `run/mod.rs`, leads to
/// `run/observe.rs`, which defines it). A module's own submodules do not count as its imports:
/// it declares them, and Rust lets a child see its parent; a child's use of its parent does.
fn import_graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut paths = Vec::new();
    rust_files(src, &mut paths);
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let test_modules = test_modules(&lib);
    let mut files: BTreeMap<Vec<String>, String> = BTreeMap::new();
    let mut code: BTreeMap<String, String> = BTreeMap::new();
    for f in paths {
        let rel = f.strip_prefix(src).unwrap().to_string_lossy().replace('\\', "/");
        if skipped(&rel, &test_modules) {
            continue;
        }
        files.insert(module_of(&rel), rel.clone());
        code.insert(rel, non_test_code(&std::fs::read_to_string(&f).unwrap()));
    }
    // Per file, the names its `use` items bind, as paths from the crate's root (a path that
    // starts at a submodule, `use observe::Task`, is the submodule's).
    let mut bound: BTreeMap<&str, BTreeMap<String, Vec<String>>> = BTreeMap::new();
    for (module, rel) in &files {
        let names = bound.entry(rel.as_str()).or_default();
        for tree in split_uses(&code[rel]).0 {
            let mut leaves = Vec::new();
            expand(&tree, &[], &mut leaves);
            for (path, name) in leaves {
                let child = path.first().map(|first| [module.clone(), vec![first.clone()]].concat());
                let full = match child {
                    Some(c) if files.contains_key(&c) => Some([module.clone(), path].concat()),
                    _ => absolute(&path, module),
                };
                if let Some(full) = full {
                    names.insert(name, full);
                }
            }
        }
    }
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (module, rel) in &files {
        let edges = graph.entry(rel.clone()).or_default();
        for path in imports(&code[rel], module) {
            let Some(to) = resolve(&path, &files, &bound, 0) else { continue };
            if !files.iter().any(|(m, f)| *f == to && m.starts_with(module)) {
                edges.insert(to);
            }
        }
    }
    graph
}

/// The file a path from the crate's root leads to (see [`import_graph`]); `None` for the crate
/// root itself.
fn resolve(
    path: &[String],
    files: &BTreeMap<Vec<String>, String>,
    bound: &BTreeMap<&str, BTreeMap<String, Vec<String>>>,
    depth: usize,
) -> Option<String> {
    let (k, file) = (1..=path.len()).rev().find_map(|k| files.get(&path[..k]).map(|f| (k, f)))?;
    if k < path.len()
        && depth < 8
        && let Some(target) = bound.get(file.as_str()).and_then(|b| b.get(&path[k]))
    {
        let full = [target.clone(), path[k + 1..].to_vec()].concat();
        if let Some(f) = resolve(&full, files, bound, depth + 1) {
            return Some(f);
        }
    }
    Some(file.clone())
}

/// The circles of a graph, each as the files around it from its least one, found by a
/// depth-first walk (each edge back into the walk's own path closes one).
fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> BTreeSet<Vec<String>> {
    fn walk<'a>(
        at: &'a str,
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        done: &mut BTreeSet<&'a str>,
        path: &mut Vec<&'a str>,
        found: &mut BTreeSet<Vec<String>>,
    ) {
        if let Some(i) = path.iter().position(|p| *p == at) {
            let mut circle: Vec<String> = path[i..].iter().map(|s| s.to_string()).collect();
            let least = (0..circle.len()).min_by_key(|j| &circle[*j]).unwrap_or(0);
            circle.rotate_left(least);
            found.insert(circle);
            return;
        }
        if !done.insert(at) {
            return;
        }
        path.push(at);
        for next in graph.get(at).into_iter().flatten() {
            walk(next, graph, done, path, found);
        }
        path.pop();
    }
    let mut found = BTreeSet::new();
    let mut done = BTreeSet::new();
    for start in graph.keys() {
        walk(start, graph, &mut done, &mut Vec::new(), &mut found);
    }
    found
}

#[test]
fn no_module_imports_one_above_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let test_modules = test_modules(&lib);
    let mut upward: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut unplaced = Vec::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap().to_string_lossy().replace('\\', "/");
        if skipped(&rel, &test_modules) {
            continue;
        }
        let module = rel.split('/').next().unwrap().trim_end_matches(".rs").to_string();
        let Some(own) = floor(&module) else {
            unplaced.push(module);
            continue;
        };
        let code = non_test_code(&std::fs::read_to_string(&f).unwrap());
        for path in imports(&code, &module_of(&rel)) {
            let Some(dep) = path.into_iter().next() else { continue };
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

#[test]
fn no_file_imports_itself_through_others() {
    let graph = import_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let circles: Vec<String> = circles(&graph).into_iter().map(|c| format!("{} → {}", c.join(" → "), c[0])).collect();
    assert!(circles.is_empty(), "file circles in src/ (move the shared piece to where it belongs): {circles:#?}");
}

#[test]
fn every_file_opens_with_a_module_doc() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in ["src", "tests", "benches", "examples"] {
        if root.join(dir).is_dir() {
            rust_files(&root.join(dir), &mut files);
        }
    }
    let mut missing: Vec<String> = files
        .iter()
        .filter(|f| !std::fs::read_to_string(f).unwrap().starts_with("//!"))
        .map(|f| f.strip_prefix(root).unwrap().display().to_string())
        .collect();
    missing.sort();
    assert!(missing.is_empty(), "files that do not open with a `//!` saying why they exist: {missing:#?}");
}

#[test]
fn imports_expand_groups_and_climb_super() {
    let module = ["run".to_string(), "eval".to_string()];
    let code = "use crate::{search::X, vlm::{Model, sim::{self, Profile}}};\nuse super::super::journal::J;\npub(crate) use self::inner::{self as i, *};\nfn f() { super::stop::g(); crate::ir::h(); }\n";
    let found: Vec<String> = imports(code, &module).iter().map(|p| p.join("::")).collect();
    assert_eq!(
        found,
        [
            "search::X",
            "vlm::Model",
            "vlm::sim",
            "vlm::sim::Profile",
            "journal::J",
            "run::eval::inner",
            "run::eval::inner",
            "run::stop::g",
            "ir::h"
        ]
    );
}

#[test]
fn circles_are_listed() {
    let edge = |a: &str, bs: &[&str]| (a.to_string(), bs.iter().map(|b| b.to_string()).collect::<BTreeSet<_>>());
    let graph = BTreeMap::from([edge("c", &["a"]), edge("a", &["b", "d"]), edge("b", &["c"]), edge("d", &[])]);
    assert_eq!(circles(&graph), BTreeSet::from([vec!["a".to_string(), "b".to_string(), "c".to_string()]]));
    let line = BTreeMap::from([edge("a", &["b"]), edge("b", &["c"]), edge("c", &[])]);
    assert!(circles(&line).is_empty());
}

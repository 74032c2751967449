//! Name resolution, type checking and lowering of `.rev` files to the Domain IR.
//!
//! Flow: the entry file and every module it `use`s (transitively; `std::core` always) are
//! parsed ([`crate::syntax`]); their items are gathered in *load order* — a module's items come
//! before those of the file that uses it, `std::core` first — and [`lower`] resolves names,
//! checks types and builds the [`ir::Domain`]. The core does no I/O: files named by
//! `use "path"` are read through the `load` callback the caller passes in.

mod concepts;
mod expr;
mod lower;
mod names;
mod relations;
mod rules;
mod scene;
mod shapes;
mod types;
mod values;

use std::collections::{HashMap, HashSet};

use crate::diag::suggest::suggest;
use crate::diag::{Diagnostic, codes};
use crate::ir::{self, SourceFile};
use crate::syntax::{self, ast};

/// The standard library, embedded in the binary: `use std::NAME` loads `stdlib/NAME.rev`. Every
/// file in `stdlib/` must have a line here (a test in `tests/language.rs` checks).
pub const STDLIB: &[(&str, &str)] = &[
    ("core", include_str!("../../stdlib/core.rev")),
    ("driving", include_str!("../../stdlib/driving.rev")),
    ("driving_look", include_str!("../../stdlib/driving_look.rev")),
    ("kitchen", include_str!("../../stdlib/kitchen.rev")),
    ("kitchen_look", include_str!("../../stdlib/kitchen_look.rev")),
];

/// The result of compiling a domain (or a library module).
#[derive(Debug, Clone)]
pub struct Compiled {
    /// `Some` only when there are no errors. A library module with no `domain` line compiles to
    /// a domain with an empty name, so it can be checked on its own.
    pub domain: Option<ir::Domain>,
    /// Errors and warnings, in report order (file, position, code).
    pub diagnostics: Vec<Diagnostic>,
    /// Every file that was loaded (entry first), for rendering diagnostics.
    pub files: Vec<SourceFile>,
}

impl Compiled {
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }
}

/// Compile the file `entry_name` with text `entry_text`. `load(path)` returns the text of a
/// file named by `use "…"` (the path is already resolved against the using file's folder), or
/// `None` when it cannot be read.
pub fn compile(entry_name: &str, entry_text: &str, load: &dyn Fn(&str) -> Option<String>) -> Compiled {
    let mut loader = Loader {
        load,
        files: Vec::new(),
        parsed: Vec::new(),
        by_name: HashMap::new(),
        order: Vec::new(),
        visited: HashSet::new(),
        diagnostics: Vec::new(),
    };
    let entry = loader.add(entry_name.to_string(), entry_text.to_string());
    // Checking a stdlib file itself: it stands for its module, so it is not loaded twice.
    if let Some(module) = stdlib_module_of(entry_name) {
        loader.by_name.insert(std_file_name(module), entry);
    }
    let core = match loader.by_name.get(&std_file_name("core")) {
        Some(&id) => id,
        None => loader.add(std_file_name("core"), STDLIB[0].1.to_string()),
    };
    loader.visit(core);
    loader.visit(entry);
    let Loader { files, parsed, order, mut diagnostics, .. } = loader;
    let items: Vec<(u32, &ast::Item)> =
        order.iter().flat_map(|&f| parsed[f as usize].items.iter().map(move |i| (f, i))).collect();
    let syntax_ok = !diagnostics.iter().any(Diagnostic::is_error);
    let (domain, lowered) = lower::lower(entry, &items);
    diagnostics.extend(lowered);
    let mut domain = domain.filter(|_| syntax_ok && !diagnostics.iter().any(Diagnostic::is_error));
    if let Some(d) = domain.as_mut() {
        d.files = files.clone();
    }
    sort_diagnostics(&mut diagnostics);
    Compiled { domain, diagnostics, files }
}

/// Compile one text that may only `use` standard-library modules (for tests and examples).
pub fn compile_source(name: &str, text: &str) -> Result<ir::Domain, Vec<Diagnostic>> {
    let c = compile(name, text, &|_| None);
    c.domain.ok_or(c.diagnostics)
}

/// Report order: file, then position, then code; duplicates removed.
pub fn sort_diagnostics(d: &mut Vec<Diagnostic>) {
    d.sort_by(|a, b| a.sort_key().cmp(&b.sort_key()).then_with(|| a.message.cmp(&b.message)));
    d.dedup();
}

/// The stdlib module a path names, when it is `…stdlib/NAME.rev` for an embedded module.
fn stdlib_module_of(path: &str) -> Option<&'static str> {
    let path = path.replace('\\', "/");
    let (dir, file) = path.rsplit_once('/')?;
    if !(dir == "stdlib" || dir.ends_with("/stdlib")) {
        return None;
    }
    let stem = file.strip_suffix(".rev")?;
    STDLIB.iter().find(|(n, _)| *n == stem).map(|(n, _)| *n)
}

/// Display name of a standard-library module.
pub fn std_file_name(module: &str) -> String {
    format!("std/{module}.rev")
}

struct Loader<'l> {
    load: &'l dyn Fn(&str) -> Option<String>,
    files: Vec<SourceFile>,
    parsed: Vec<ast::File>,
    by_name: HashMap<String, u32>,
    /// Files in item order (post-order: used modules before their user).
    order: Vec<u32>,
    visited: HashSet<u32>,
    diagnostics: Vec<Diagnostic>,
}

impl Loader<'_> {
    fn add(&mut self, name: String, text: String) -> u32 {
        let id = self.files.len() as u32;
        let parsed = syntax::parse(id, &text);
        self.diagnostics.extend(parsed.diagnostics);
        self.parsed.push(parsed.file);
        self.by_name.insert(name.clone(), id);
        self.files.push(SourceFile { name, text });
        id
    }

    /// Load the modules `file` uses (depth first), then place `file` in the item order. A file
    /// is visited once, so `use` cycles are harmless.
    fn visit(&mut self, file: u32) {
        if !self.visited.insert(file) {
            return;
        }
        let uses: Vec<ast::UseTarget> = self.parsed[file as usize]
            .items
            .iter()
            .filter_map(|i| match &i.kind {
                ast::ItemKind::Use(t) => Some(t.clone()),
                _ => None,
            })
            .collect();
        for target in uses {
            if let Some(dep) = self.resolve(file, &target) {
                self.visit(dep);
            }
        }
        self.order.push(file);
    }

    fn resolve(&mut self, from: u32, target: &ast::UseTarget) -> Option<u32> {
        let (name, text) = match target {
            ast::UseTarget::Std(m) => {
                let name = std_file_name(&m.name);
                if let Some(&id) = self.by_name.get(&name) {
                    return Some(id);
                }
                match STDLIB.iter().find(|(n, _)| *n == m.name) {
                    Some((_, text)) => (name, text.to_string()),
                    None => {
                        let d = Diagnostic::error(
                            codes::UNKNOWN_MODULE,
                            m.span,
                            format!("unknown module `std::{}`", m.name),
                        )
                        .with_label("not in the standard library");
                        let d = match suggest(&m.name, STDLIB.iter().map(|(n, _)| *n)) {
                            Some(s) => d.with_help(format!("did you mean `std::{s}`?")),
                            None => d.with_help(format!(
                                "the standard library has: {}",
                                STDLIB.iter().map(|(n, _)| format!("std::{n}")).collect::<Vec<_>>().join(", ")
                            )),
                        };
                        self.diagnostics.push(d);
                        return None;
                    }
                }
            }
            ast::UseTarget::File(path) => {
                let from_name = &self.files[from as usize].name;
                if from_name.starts_with("std/") {
                    self.diagnostics.push(
                        Diagnostic::error(
                            codes::FILE_NOT_FOUND,
                            path.span,
                            format!("cannot load `{}` from the standard library", path.value),
                        )
                        .with_help("standard-library modules may only `use std::…`"),
                    );
                    return None;
                }
                let name = join_relative(from_name, &path.value);
                if let Some(&id) = self.by_name.get(&name) {
                    return Some(id);
                }
                match (self.load)(&name) {
                    Some(text) => (name, text),
                    None => {
                        self.diagnostics.push(
                            Diagnostic::error(codes::FILE_NOT_FOUND, path.span, format!("cannot read `{name}`"))
                                .with_label("used here")
                                .with_help("paths in `use \"…\"` are relative to the file that uses them"),
                        );
                        return None;
                    }
                }
            }
        };
        Some(self.add(name, text))
    }
}

/// `rel` resolved against the folder of `from`, with `.` and `..` segments collapsed.
fn join_relative(from: &str, rel: &str) -> String {
    let base = if rel.starts_with('/') { "" } else { from.rsplit_once('/').map_or("", |(dir, _)| dir) };
    let mut parts: Vec<&str> = Vec::new();
    let absolute = rel.starts_with('/') || (base.starts_with('/') && !base.is_empty());
    for seg in base.split('/').chain(rel.split('/')) {
        match seg {
            "" | "." => {}
            ".." if parts.last().is_some_and(|p| *p != "..") => {
                parts.pop();
            }
            _ => parts.push(seg),
        }
    }
    let joined = parts.join("/");
    if absolute { format!("/{joined}") } else { joined }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths() {
        assert_eq!(join_relative("domains/driving.rev", "common/props.rev"), "domains/common/props.rev");
        assert_eq!(join_relative("domains/driving.rev", "../stdlib/x.rev"), "stdlib/x.rev");
        assert_eq!(join_relative("driving.rev", "./a.rev"), "a.rev");
        assert_eq!(join_relative("/abs/d.rev", "b.rev"), "/abs/b.rev");
        assert_eq!(join_relative("d.rev", "../../x.rev"), "../../x.rev");
    }

    #[test]
    fn more_concepts_than_a_set_holds_is_an_error() {
        let mut text = String::from("domain big\nworld { on: bool = false }\n");
        for i in 0..=ir::MAX_CONCEPTS {
            text.push_str(&format!("concept c{i} {{ description \"c\" probe \"p\" not \"n\" set world.on = true }}\n"));
        }
        // Members and elements past the set width must not overflow the bitset.
        text.push_str("constraint all = at_most(3, c*)\nconstraint last = exclusive(c0, c128)\n");
        text.push_str("question q { text \"q\" option a \"a\" option b \"b\" }\n");
        text.push_str("rules best_fit { rule r { when has c128 elements c128, c1 expect q.a } }\n");
        let diags = compile_source("big.rev", &text).unwrap_err();
        assert_eq!(diags.len(), 1, "{diags:?}");
        assert_eq!(diags[0].code, codes::TOO_MANY_CONCEPTS);
        assert!(diags[0].message.contains("at most 128"));
    }

    #[test]
    fn use_loads_files_relative_to_the_user_once() {
        let files = |p: &str| match p {
            "d/lib.rev" => Some("use \"sub/deep.rev\"\nenum E { a, b }".to_string()),
            "d/sub/deep.rev" => Some("use \"../lib.rev\"\ntag Deep".to_string()),
            _ => None,
        };
        let c = compile("d/main.rev", "use \"lib.rev\"\nuse \"sub/deep.rev\"\nkind K: Deep { e: E = a }", &files);
        assert!(c.diagnostics.is_empty(), "{:?}", c.diagnostics);
        let names: Vec<&str> = c.files.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["d/main.rev", "std/core.rev", "d/lib.rev", "d/sub/deep.rev"]);
        let d = c.domain.unwrap();
        assert_eq!(d.name, "", "a library module compiles to a nameless domain");
    }

    #[test]
    fn small_domain_compiles() {
        let text = include_str!("../../tests/corpus/good/small_driving.rev");
        let d = match compile_source("small_driving.rev", text) {
            Ok(d) => d,
            Err(diags) => panic!("{diags:#?}"),
        };
        assert_eq!(d.name, "small_driving");
        assert_eq!(d.concepts.len(), 9);
        assert_eq!(d.rules.len(), 3);
        let child = d.kind_by_name("Child").unwrap();
        let ped = d.kind_by_name("Pedestrian").unwrap();
        assert!(d.kinds[child.index()].attr("posture").is_some(), "attributes are inherited");
        let agent = d.tag_by_name("Agent").unwrap();
        assert!(d.kinds[child.index()].has_tag(agent), "tags are inherited through parent kinds");
        let collidable = d.tag_by_name("Collidable").unwrap();
        assert!(d.kinds[child.index()].has_tag(collidable), "tags are transitive");
        assert_eq!(d.kinds[ped.index()].shape.len(), 2);
        assert_eq!(d.files[0].name, "small_driving.rev");
    }
}

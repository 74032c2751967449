//! Name resolution, type checking and lowering of `.rev` files to the Domain IR.
//!
//! Flow: the entry file and every module it `use`s (transitively; `std::core` always) are
//! parsed ([`crate::syntax`]); their items are gathered in *load order* — a module's items come
//! before those of the file that uses it, `std::core` first — and [`lower`] resolves names,
//! checks types and builds the [`ir::Domain`]. The core does no I/O: files named by
//! `use "path"` are read through the `load` callback the caller passes in (`crate::source` is
//! the one on disk: it decides which files a domain may read, and reads them safely). The core
//! bounds what it is handed: [`MAX_FILE_BYTES`] per file, [`MAX_DOMAIN_BYTES`] in all.

mod concepts;
mod expr;
mod lower;
mod modifiers;
mod names;
mod relations;
mod rules;
mod scene;
mod shapes;
mod types;
mod values;

pub use names::Reference;

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

/// The largest `.rev` file the front end takes (1 MiB, some 40 times the largest shipped file).
/// A larger text is reported as too large (R0004) and not parsed.
pub const MAX_FILE_BYTES: usize = 1 << 20;

/// The most source text one compilation loads, all files together (8 MiB).
pub const MAX_DOMAIN_BYTES: usize = 8 << 20;

// Bounds on what a domain makes the later stages do (R0034, R0035), each far above the shipped
// domains, so that no `.rev` file sizes an allocation or a rule evaluation past them. They are
// stated in `docs/language.md`.

/// The most `exists` one condition may nest (a shape condition's `self` counts as one): a rule
/// evaluation visits at most entities^3 bindings. The shipped domains nest two.
pub const MAX_QUANTIFIERS: usize = 3;

/// The most entities a domain's concepts add, all together: the most any anchor graph or scene
/// holds (the shipped domains add at most 35).
pub const MAX_ENTITIES: usize = 128;

/// The most parts one `shape { … }`, `look` or `stage` block may list.
pub const MAX_SHAPE_PARTS: usize = 256;

/// The largest `repeat` count of a stage item.
pub const MAX_REPEAT: u32 = 1000;

/// The most stage parts a scene may hold, repeats expanded, all stage items together.
pub const MAX_STAGE_PARTS: u64 = 4096;

/// A `use "PATH"` item, as handed to the `load` callback of [`compile`].
#[derive(Debug, Clone, Copy)]
pub struct UseRequest<'a> {
    /// The path as written.
    pub path: &'a str,
    /// The path resolved against the using file's name, `.` and `..` collapsed: the name the
    /// file has in diagnostics.
    pub name: &'a str,
}

/// A file the `load` callback read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Loaded {
    /// What identifies the file (its canonical path): two spellings of one file give one key,
    /// and the file is loaded once.
    pub key: String,
    pub text: String,
}

/// Why the `load` callback did not read a file. The message never quotes the file's content.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refused {
    pub code: &'static str,
    pub message: String,
    pub help: Option<String>,
}

impl Refused {
    /// R0004 for the file `name` of `len` bytes (`None`: past the limit, read no further).
    pub fn too_large(name: &str, len: Option<usize>) -> Refused {
        let size = match len {
            Some(n) => format!("is {}; a `.rev` file may be at most", size_text(n)),
            None => "is larger than the most a `.rev` file may be,".to_string(),
        };
        Refused {
            code: codes::FILE_TOO_LARGE,
            message: format!("`{name}` {size} {}", size_text(MAX_FILE_BYTES)),
            help: Some("split the file into modules joined with `use \"…\"`".into()),
        }
    }

    /// The refusal as an error diagnostic at `span` (none: about a whole file).
    pub fn diagnostic(self, span: Option<crate::diag::Span>) -> Diagnostic {
        let mut d = Diagnostic::new(self.code, crate::diag::Severity::Error, span, self.message);
        d.help = self.help;
        d
    }
}

/// The `load` callback's answer.
pub type Load = Result<Loaded, Refused>;

/// A `load` callback that reads no file: for texts that may only use the standard library.
pub fn std_only(req: &UseRequest) -> Load {
    Err(Refused {
        code: codes::FILE_NOT_FOUND,
        message: format!("cannot read `{}`", req.name),
        help: Some("this text is compiled on its own: only `use std::…` modules are available".into()),
    })
}

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
    /// Every name that resolved, with its declaration (for the language server).
    pub references: Vec<Reference>,
}

impl Compiled {
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }
}

/// Compile the file `entry_name` with text `entry_text`. `load` reads the files named by
/// `use "…"` (or refuses to, saying why).
pub fn compile(entry_name: &str, entry_text: &str, load: &dyn Fn(&UseRequest) -> Load) -> Compiled {
    compile_entry(entry_name, entry_name, entry_text, load)
}

/// [`compile`] for an entry file identified by `entry_key` (its canonical path, as `load` gives
/// keys), so that a module using it back does not load it a second time.
pub fn compile_entry(
    entry_name: &str,
    entry_key: &str,
    entry_text: &str,
    load: &dyn Fn(&UseRequest) -> Load,
) -> Compiled {
    let mut loader = Loader {
        load,
        files: Vec::new(),
        parsed: Vec::new(),
        by_name: HashMap::new(),
        by_key: HashMap::new(),
        total_bytes: 0,
        order: Vec::new(),
        visited: HashSet::new(),
        diagnostics: Vec::new(),
        references: Vec::new(),
    };
    let entry = loader.add(entry_name.to_string(), entry_text.to_string());
    loader.by_key.insert(entry_key.to_string(), entry);
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
    let Loader { files, parsed, order, mut diagnostics, mut references, .. } = loader;
    let items: Vec<(u32, &ast::Item)> =
        order.iter().flat_map(|&f| parsed[f as usize].items.iter().map(move |i| (f, i))).collect();
    let syntax_ok = !diagnostics.iter().any(Diagnostic::is_error);
    let std_files: Vec<u32> =
        files.iter().enumerate().filter(|(_, f)| f.name.starts_with("std/")).map(|(i, _)| i as u32).collect();
    let (domain, lowered, names) = lower::lower(entry, &items, &std_files);
    diagnostics.extend(lowered);
    references.extend(names);
    let mut domain = domain.filter(|_| syntax_ok && !diagnostics.iter().any(Diagnostic::is_error));
    if let Some(d) = domain.as_mut() {
        d.files = files.clone();
    }
    sort_diagnostics(&mut diagnostics);
    Compiled { domain, diagnostics, files, references }
}

/// Compile one text that may only `use` standard-library modules (for tests and examples).
pub fn compile_source(name: &str, text: &str) -> Result<ir::Domain, Vec<Diagnostic>> {
    let c = compile(name, text, &std_only);
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
    load: &'l dyn Fn(&UseRequest) -> Load,
    files: Vec<SourceFile>,
    parsed: Vec<ast::File>,
    by_name: HashMap<String, u32>,
    /// Files by the key `load` gave them: another spelling of a loaded file is that file.
    by_key: HashMap<String, u32>,
    /// Source bytes loaded so far, against [`MAX_DOMAIN_BYTES`].
    total_bytes: usize,
    /// Files in item order (post-order: used modules before their user).
    order: Vec<u32>,
    visited: HashSet<u32>,
    diagnostics: Vec<Diagnostic>,
    /// Each `use` and the file it loaded (declared at its start).
    references: Vec<Reference>,
}

impl Loader<'_> {
    fn add(&mut self, name: String, text: String) -> u32 {
        let id = self.files.len() as u32;
        // Too large to parse: say so (the parser would only run out of its call budget and
        // blame nesting), keep no text, and go on without its items.
        let text = if text.len() > MAX_FILE_BYTES {
            self.diagnostics.push(Refused::too_large(&name, Some(text.len())).diagnostic(None));
            String::new()
        } else {
            text
        };
        self.total_bytes += text.len();
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
                let at = match &target {
                    ast::UseTarget::Std(m) => m.span,
                    ast::UseTarget::File(p) => p.span,
                };
                self.references.push(Reference { at, decl: crate::ir::Span { file: dep, start: 0, end: 0 } });
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
                let refuse = |r: Refused| {
                    Diagnostic::error(r.code, path.span, r.message).with_label("used here").with_help(
                        r.help.unwrap_or_else(|| "paths in `use \"…\"` are relative to the file that uses them".into()),
                    )
                };
                match (self.load)(&UseRequest { path: &path.value, name: &name }) {
                    Ok(loaded) => {
                        if let Some(&id) = self.by_key.get(&loaded.key) {
                            self.by_name.insert(name, id);
                            return Some(id);
                        }
                        if self.total_bytes + loaded.text.len() > MAX_DOMAIN_BYTES {
                            self.diagnostics.push(refuse(Refused {
                                code: codes::FILE_TOO_LARGE,
                                message: format!(
                                    "cannot load `{name}`: the domain's files would pass {} together",
                                    size_text(MAX_DOMAIN_BYTES)
                                ),
                                help: Some(format!(
                                    "a domain's source files may hold at most {} in all",
                                    size_text(MAX_DOMAIN_BYTES)
                                )),
                            }));
                            return None;
                        }
                        let id = self.add(name, loaded.text);
                        self.by_key.insert(loaded.key, id);
                        return Some(id);
                    }
                    Err(r) => {
                        self.diagnostics.push(refuse(r));
                        return None;
                    }
                }
            }
        };
        Some(self.add(name, text))
    }
}

/// A byte count for messages: `512 bytes`, `1 MiB`, `10.0 MB`.
pub fn size_text(bytes: usize) -> String {
    const MIB: usize = 1 << 20;
    if bytes.is_multiple_of(MIB) && bytes > 0 {
        format!("{} MiB", bytes / MIB)
    } else if bytes >= 100_000 {
        format!("{:.1} MB", bytes as f64 / 1e6)
    } else {
        format!("{bytes} bytes")
    }
}

/// `rel` resolved against the folder of `from`, with `.` and `..` segments collapsed: the file
/// a `use "…"` in `from` names.
pub(crate) fn join_relative(from: &str, rel: &str) -> String {
    let base = if rel.starts_with('/') { "" } else { from.rsplit_once('/').map_or("", |(dir, _)| dir) };
    let mut parts: Vec<&str> = Vec::new();
    let absolute = rel.starts_with('/') || base.starts_with('/');
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
        let past = format!("c{}", ir::MAX_CONCEPTS);
        text.push_str(&format!("constraint all = at_most(3, c*)\nconstraint last = exclusive(c0, {past})\n"));
        text.push_str("question q { text \"q\" option a \"a\" option b \"b\" }\n");
        text.push_str(&format!("rules best_fit {{ rule r {{ when has {past} elements {past}, c1 expect q.a }} }}\n"));
        let diags = compile_source("big.rev", &text).unwrap_err();
        assert_eq!(diags.len(), 1, "{diags:?}");
        assert_eq!(diags[0].code, codes::TOO_MANY_CONCEPTS);
        assert!(diags[0].message.contains("at most 512"));
    }

    #[test]
    fn use_loads_files_relative_to_the_user_once() {
        let files = |p: &str| match p {
            "d/lib.rev" => Some("use \"sub/deep.rev\"\nenum E { a, b }".to_string()),
            "d/sub/deep.rev" => Some("use \"../lib.rev\"\ntag Deep".to_string()),
            _ => None,
        };
        let c = compile("d/main.rev", "use \"lib.rev\"\nuse \"sub/deep.rev\"\nkind K: Deep { e: E = a }", &|r| {
            files(r.name).map(|text| Loaded { key: r.name.into(), text }).ok_or_else(|| std_only(r).unwrap_err())
        });
        assert!(c.diagnostics.is_empty(), "{:?}", c.diagnostics);
        let names: Vec<&str> = c.files.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["d/main.rev", "std/core.rev", "d/lib.rev", "d/sub/deep.rev"]);
        let d = c.domain.unwrap();
        assert_eq!(d.name, "", "a library module compiles to a nameless domain");
    }

    #[test]
    fn two_spellings_of_one_file_load_it_once() {
        // `lib.rev` and `link.rev` are one file, and `main.rev` is the entry spelled otherwise:
        // the callback gives one key per file, so nothing is declared twice.
        let load = |r: &UseRequest| match r.name {
            "d/lib.rev" | "d/link.rev" => {
                Ok(Loaded { key: "/abs/d/lib.rev".into(), text: "use \"main.rev\"\ntag T".into() })
            }
            "d/main.rev" => Ok(Loaded { key: "/abs/d/main.rev".into(), text: "tag M".into() }),
            _ => std_only(r),
        };
        let c = compile_entry("./d/main.rev", "/abs/d/main.rev", "use \"lib.rev\"\nuse \"link.rev\"\ntag M", &load);
        assert!(c.diagnostics.is_empty(), "{:?}", c.diagnostics);
        assert_eq!(c.files.len(), 3, "entry, std/core.rev and one library file");
    }

    #[test]
    fn oversized_texts_are_refused_not_parsed() {
        // A comment past the file limit: too large (R0004), not "nests too deeply" (R0003).
        let text = format!("// {}\ntag T", "x".repeat(MAX_FILE_BYTES));
        let c = compile("big.rev", &text, &std_only);
        let codes: Vec<&str> = c.diagnostics.iter().map(|d| d.code).collect();
        assert_eq!(codes, [codes::FILE_TOO_LARGE], "{:?}", c.diagnostics);
        assert!(c.diagnostics[0].message.starts_with("`big.rev` is 1.0 MB; a `.rev` file may be at most 1 MiB"));
        assert!(c.files[0].text.is_empty(), "the text is not kept");
        // Used files together past the domain limit: the one that passes it is refused.
        let chunk = format!("// {}\n", "y".repeat(MAX_FILE_BYTES - 10));
        let load = |r: &UseRequest| Ok(Loaded { key: r.name.into(), text: chunk.clone() });
        let uses: String = (0..10).map(|i| format!("use \"m{i}.rev\"\n")).collect();
        let c = compile("d.rev", &uses, &load);
        let refused: Vec<&Diagnostic> = c.diagnostics.iter().filter(|d| d.code == codes::FILE_TOO_LARGE).collect();
        assert_eq!(refused.len(), 3, "{:?}", c.diagnostics);
        assert!(refused[0].message.contains("would pass 8 MiB together"));
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

    #[test]
    fn a_sub_kind_without_a_look_draws_its_nearest_ancestors() {
        let text = include_str!("../../tests/corpus/good/inherited_look.rev");
        let d = match compile_source("inherited_look.rev", text) {
            Ok(d) => d,
            Err(diags) => panic!("{diags:#?}"),
        };
        let shape = |name: &str| &d.kinds[d.kind_by_name(name).unwrap().index()].shape;
        assert_eq!(shape("Truck").len(), 2);
        assert_eq!(shape("Forklift"), shape("Truck"), "one level down");
        assert_eq!(shape("ReachTruck"), shape("Truck"), "two levels down");
        assert_eq!(shape("Pallet").len(), 1, "an own look is kept");
        // The conditional part names the attribute, so it reads the child's own `loaded`.
        let Some(ir::Expr::Cmp { var, attr, .. }) = &shape("Forklift")[1].when else { panic!("no condition") };
        assert_eq!((var.as_deref(), attr.as_str()), (Some("self"), "loaded"));
    }
}

//! The identity of a compiled domain: what a run searched, whatever way its path was typed.
//!
//! One digest serves both places that must agree on "the same domain": the scene random stream
//! (`sample`), so `domains/driving.rev`, `./domains/driving.rev` and an absolute path give the
//! same scenes for the same seed, and the resume check of a run folder (`config.json`'s
//! `domain_hash`), so a resume is refused exactly when the scenes would differ.
//!
//! Each source file contributes a canonical module name and its text, length-prefixed, in load
//! order. The canonical name of the domain file is fixed (`<domain>`: its own path says nothing
//! about the domain); a standard-library module keeps its `std/NAME.rev` name; any other file is
//! named by its path relative to the domain file's folder, with `.` and `..` collapsed. Names
//! are kept, not only texts, because moving a file changes which `use` line reaches it.

use super::Domain;

/// SHA-256 of a domain's canonical module names and texts (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DomainId(pub [u8; 32]);

impl std::fmt::Display for DomainId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&hex::encode(self.0))
    }
}

/// The name the domain file contributes, whatever its path.
const ENTRY: &str = "<domain>";

impl Domain {
    /// The domain's identity (see [`DomainId`]).
    pub fn identity(&self) -> DomainId {
        let root = self.files.first().map(|f| parent(&normalize(&f.name))).unwrap_or_default();
        let names: Vec<String> = (self.files.iter().enumerate())
            .map(|(i, f)| if i == 0 { ENTRY.to_string() } else { module_name(&f.name, &root) })
            .collect();
        let parts = names.iter().zip(&self.files).flat_map(|(n, f)| [n.as_bytes(), f.text.as_bytes()]);
        DomainId(crate::hash::tagged_parts(b"revelio.domain.v2", parts))
    }
}

/// Path segments with `.` and `..` collapsed lexically (no file system access: the core does no
/// I/O); an absolute path keeps a leading empty segment.
fn normalize(path: &str) -> Vec<String> {
    let path = path.replace('\\', "/");
    let absolute = path.starts_with('/');
    let mut out: Vec<String> = Vec::new();
    for seg in path.split('/') {
        match seg {
            "" | "." => {}
            ".." if out.last().is_some_and(|s| s != "..") => {
                out.pop();
            }
            ".." if absolute => {}
            s => out.push(s.to_string()),
        }
    }
    if absolute {
        out.insert(0, String::new());
    }
    out
}

fn parent(segments: &[String]) -> Vec<String> {
    segments[..segments.len().saturating_sub(1)].to_vec()
}

/// The canonical name of a used file: relative to the domain file's folder `root`.
fn module_name(name: &str, root: &[String]) -> String {
    let path = normalize(name);
    if name.starts_with("std/") {
        return name.to_string();
    }
    let both_absolute = path.first().is_some_and(String::is_empty) == root.first().is_some_and(String::is_empty);
    if !both_absolute {
        // One path relative, the other absolute: nothing relates them without the file system,
        // so the file's own collapsed path names it.
        return path.join("/");
    }
    let common = path.iter().zip(root).take_while(|(a, b)| a == b).count();
    let ups = root.len() - common;
    let rel: Vec<&str> = std::iter::repeat_n("..", ups).chain(path[common..].iter().map(String::as_str)).collect();
    rel.join("/")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::SourceFile;

    fn with_files(files: &[(&str, &str)]) -> Domain {
        let mut d = crate::ir::testkit::domain(&["a"]);
        d.files = files.iter().map(|(n, t)| SourceFile { name: n.to_string(), text: t.to_string() }).collect();
        d
    }

    #[test]
    fn the_spelling_of_the_path_does_not_change_the_identity() {
        let spellings = [
            [("domains/driving.rev", "domain d"), ("std/core.rev", "core"), ("domains/lib/props.rev", "props")],
            [("./domains/driving.rev", "domain d"), ("std/core.rev", "core"), ("domains/lib/props.rev", "props")],
            [
                ("/home/u/x/domains/driving.rev", "domain d"),
                ("std/core.rev", "core"),
                ("/home/u/x/domains/lib/props.rev", "props"),
            ],
            [
                ("domains/../domains/driving.rev", "domain d"),
                ("std/core.rev", "core"),
                ("domains/lib/./props.rev", "props"),
            ],
        ];
        let ids: Vec<DomainId> = spellings.iter().map(|f| with_files(f).identity()).collect();
        assert!(ids.windows(2).all(|w| w[0] == w[1]), "{ids:?}");
    }

    #[test]
    fn texts_and_module_names_count() {
        let base = with_files(&[("d.rev", "domain d"), ("lib/a.rev", "x")]);
        let text = with_files(&[("d.rev", "domain d"), ("lib/a.rev", "y")]);
        let moved = with_files(&[("d.rev", "domain d"), ("other/a.rev", "x")]);
        let shifted = with_files(&[("d.rev", "domain dx"), ("lib/a.rev", "")]);
        assert_ne!(base.identity(), text.identity());
        assert_ne!(base.identity(), moved.identity());
        assert_ne!(base.identity(), shifted.identity());
        assert_eq!(base.identity().to_string().len(), 64);
    }

    #[test]
    fn module_names() {
        let root = parent(&normalize("domains/driving.rev"));
        assert_eq!(module_name("domains/common/props.rev", &root), "common/props.rev");
        assert_eq!(module_name("stdlib/x.rev", &root), "../stdlib/x.rev");
        assert_eq!(module_name("std/core.rev", &root), "std/core.rev");
        let abs = parent(&normalize("/a/b/d.rev"));
        assert_eq!(module_name("/a/c/x.rev", &abs), "../c/x.rev");
        assert_eq!(module_name("c/x.rev", &abs), "c/x.rev");
    }
}

//! `.rev` text → syntax tree. [`parser::parse`] never fails: syntax errors become error nodes
//! plus diagnostics, so a file with several mistakes reports each one and later stages still see
//! the rest of the file. [`lexer`] is the lossless token layer beside it (comments, blank lines,
//! token classes), [`grammar`] the pest grammar both walk.
pub mod ast;
pub mod grammar;
pub mod lexer;
pub mod parser;

/// Every `.rev` file under the checkout's folders `dirs` (tests' corpus).
#[cfg(test)]
pub(crate) fn rev_files(dirs: &[&str]) -> Vec<std::path::PathBuf> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    let mut dirs: Vec<_> = dirs.iter().map(|d| root.join(d)).collect();
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rev") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

pub use parser::{Parsed, parse};

//! One open document, compiled: the front end's result with the syntax trees, tokens and symbol
//! index of every file it loads. Files are named by their path, so `use "…"` resolves as on the
//! command line; open documents stand in for their files on disk (unsaved edits count), and the
//! embedded stdlib is named `std/NAME.rev` as everywhere else.
//!
//! Stdlib files are shown to editors as real files: the embedded texts are written once into a
//! cache folder (`$XDG_CACHE_HOME/revelio/std-<hash>/stdlib/NAME.rev`, read-only), so go to
//! definition opens them in any editor without a custom URI scheme. The folder name carries a
//! hash of the texts, so two Revelio versions never share one. Opening such a file checks it as
//! the stdlib module it is.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use lsp_types::Url;

use super::index::{Index, Source};
use crate::check::{Compiled, STDLIB};
use crate::syntax::{self, ast};

/// A compiled document.
pub struct Analysis {
    pub compiled: Compiled,
    /// Syntax tree of each file of `compiled.files`.
    pub trees: Vec<ast::File>,
    pub index: Index,
}

impl Analysis {
    /// Compile `text` as the file `name`; `open` maps names of open documents to their texts.
    /// `use "…"` reads only what [`crate::source`] allows, open documents included.
    pub fn new(name: &str, text: &str, open: &HashMap<String, String>) -> Analysis {
        // The same file policy as the command line: opening a domain in an editor must not read
        // (and show) what `revelio check` would refuse to.
        let compiled =
            crate::source::compile_text(Path::new(name), text, &|p| p.to_str().and_then(|p| open.get(p)).cloned());
        let trees: Vec<ast::File> =
            compiled.files.iter().enumerate().map(|(i, f)| syntax::parse(i as u32, &f.text).file).collect();
        let sources: Vec<Source> = compiled
            .files
            .iter()
            .zip(&trees)
            .enumerate()
            .map(|(i, (f, tree))| Source { file: i as u32, name: &f.name, text: &f.text, tree })
            .collect();
        let index = Index::build(&sources, &compiled.references);
        Analysis { compiled, trees, index }
    }

    /// The names of the files this document loaded (itself first).
    pub fn file_names(&self) -> impl Iterator<Item = &str> {
        self.compiled.files.iter().map(|f| f.name.as_str())
    }

    pub fn text(&self, file: u32) -> &str {
        self.compiled.files.get(file as usize).map_or("", |f| f.text.as_str())
    }
}

/// The compile name of a document: its path for `file:` URIs, else the URI itself.
pub fn name_of(uri: &Url) -> String {
    match uri.to_file_path() {
        Ok(p) if uri.scheme() == "file" => p.to_string_lossy().into_owned(),
        _ => uri.to_string(),
    }
}

/// Where compiled files live for the editor.
pub struct Files {
    stdlib: Option<PathBuf>,
}

impl Files {
    /// `cache` is the folder the stdlib is written into (created when first needed).
    pub fn new(cache: Option<PathBuf>) -> Files {
        Files { stdlib: cache.and_then(|c| write_stdlib(&c)) }
    }

    /// The URI of a compiled file name.
    pub fn uri(&self, name: &str) -> Option<Url> {
        if let Some(module) = name.strip_prefix("std/").and_then(|n| n.strip_suffix(".rev")) {
            return self.stdlib.as_ref().and_then(|d| Url::from_file_path(d.join(format!("{module}.rev"))).ok());
        }
        if Path::new(name).is_absolute() {
            return Url::from_file_path(name).ok();
        }
        Url::parse(name).ok()
    }
}

/// The default cache folder: `$XDG_CACHE_HOME`, else `~/.cache`, else the temp folder.
pub fn default_cache() -> PathBuf {
    match std::env::var_os("XDG_CACHE_HOME").filter(|v| !v.is_empty()) {
        Some(d) => PathBuf::from(d),
        None => match std::env::var_os("HOME").filter(|v| !v.is_empty()) {
            Some(h) => PathBuf::from(h).join(".cache"),
            None => std::env::temp_dir(),
        },
    }
    .join("revelio")
}

/// Write the embedded stdlib under `cache` (once per version); the folder, or `None` when it
/// cannot be written (definitions into the stdlib then have nowhere to go).
fn write_stdlib(cache: &Path) -> Option<PathBuf> {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for (name, text) in STDLIB {
        for b in name.bytes().chain(text.bytes()) {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
        }
    }
    let dir = cache.join(format!("std-{hash:016x}")).join("stdlib");
    std::fs::create_dir_all(&dir).ok()?;
    for (name, text) in STDLIB {
        let path = dir.join(format!("{name}.rev"));
        if std::fs::read_to_string(&path).ok().as_deref() != Some(*text) {
            // A read-only file tells the editor that edits there go nowhere.
            let _ = std::fs::remove_file(&path);
            std::fs::write(&path, text).ok()?;
            if let Ok(meta) = std::fs::metadata(&path) {
                let mut perm = meta.permissions();
                perm.set_readonly(true);
                let _ = std::fs::set_permissions(&path, perm);
            }
        }
    }
    Some(dir)
}

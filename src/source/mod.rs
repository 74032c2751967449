//! Reading `.rev` sources from disk: the one place that decides which files a domain may read
//! and reads them safely. `revelio check`, every other command and the language server compile
//! through here, so a domain file from a stranger reads the same few files everywhere.
//!
//! The policy for `use "PATH"` (refusals are R0013 unless said otherwise):
//! - the path is relative, with `/` as separator, and names a `.rev` file;
//! - it stays inside the entry file's folder tree, before and after following links (`..` may
//!   move around inside the tree but not out of it);
//! - the file is a regular file: a FIFO, a device, a socket or a folder is refused before it is
//!   opened (a FIFO would block, `/dev/zero` never ends);
//! - it is at most [`MAX_FILE_BYTES`] (R0004), read through a bounded reader, and UTF-8 (R0011);
//! - a refusal never quotes the file's content; a file that may not be read is never parsed.
//!
//! The entry file itself (what the user names on the command line, or the document an editor
//! opens) must be a regular `.rev` file of at most [`MAX_FILE_BYTES`]. Files are identified by
//! their canonical path, so one file reached by two spellings is loaded once.

use std::fs::{File, Metadata};
use std::io::Read;
use std::path::{Component, Path, PathBuf};

use crate::check::{self, Compiled, Load, Loaded, MAX_FILE_BYTES, Refused, UseRequest};
use crate::diag::codes;

/// What a non-regular file is, for messages: `a FIFO`, `a folder`, `a character device`, ….
pub fn file_kind(meta: &Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_file() {
        return "a regular file";
    }
    if t.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
    }
    "not a regular file"
}

/// The folder tree a domain may read from: the entry file's folder.
#[derive(Debug, Clone)]
pub struct Tree {
    /// The folder as an absolute path with `.` and `..` collapsed (no links followed).
    lexical: PathBuf,
    /// The folder with links followed, when it exists.
    canonical: Option<PathBuf>,
}

impl Tree {
    /// The tree of the entry file at `entry` (which need not exist: an editor's new buffer).
    pub fn of(entry: &Path) -> Tree {
        let dir = entry.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let lexical = normalize(dir);
        let canonical = std::fs::canonicalize(&lexical).ok();
        Tree { lexical, canonical }
    }

    /// Answer a `use "PATH"` item: check the policy, then read the file.
    pub fn load(&self, req: &UseRequest) -> Load {
        self.load_with(req, &|_| None)
    }

    /// [`Tree::load`] where `open` may supply a file's text instead of the disk (an editor's
    /// unsaved buffers, by absolute path). The policy applies all the same.
    pub fn load_with(&self, req: &UseRequest, open: &dyn Fn(&Path) -> Option<String>) -> Load {
        check_written_path(req)?;
        let path = normalize(Path::new(req.name));
        if !path.starts_with(&self.lexical) {
            return Err(outside(req));
        }
        if let Some(text) = open(&path) {
            let key = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
            return Ok(Loaded { key: key.to_string_lossy().into_owned(), text });
        }
        let canonical = std::fs::canonicalize(&path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => {
                Refused { code: codes::FILE_NOT_FOUND, message: format!("cannot read `{}`", req.name), help: None }
            }
            _ => not_read(req.name, &e),
        })?;
        // A link inside the tree may point anywhere: judge where it lands.
        if self.canonical.as_ref().is_some_and(|root| !canonical.starts_with(root)) {
            return Err(outside(req));
        }
        if canonical.extension().is_none_or(|x| x != "rev") {
            return Err(use_refused(
                format!("`{}` is a link to a file that is not a `.rev` file", req.name),
                "a domain may only use `.rev` files",
            ));
        }
        let text = read(&canonical, req.name)?;
        Ok(Loaded { key: canonical.to_string_lossy().into_owned(), text })
    }
}

/// The written path: relative, `/`-separated, naming a `.rev` file.
fn check_written_path(req: &UseRequest) -> Result<(), Refused> {
    let p = req.path;
    let absolute = p.starts_with('/') || p.starts_with('\\') || p.as_bytes().get(1) == Some(&b':');
    if absolute {
        return Err(use_refused(
            format!("`{p}` is an absolute path"),
            "a domain may only use files inside its own folder, by a relative path",
        ));
    }
    if p.contains('\\') {
        return Err(use_refused(format!("`{p}` contains `\\`"), "write paths with `/`, on every system"));
    }
    if !p.ends_with(".rev") {
        return Err(use_refused(format!("`{p}` is not a `.rev` file"), "a domain may only use `.rev` files"));
    }
    Ok(())
}

fn outside(req: &UseRequest) -> Refused {
    use_refused(
        format!("`{}` is outside the domain's folder", req.path),
        "a domain may only use files in the folder of the file being checked, or below it",
    )
}

fn use_refused(message: String, help: &str) -> Refused {
    Refused { code: codes::USE_REFUSED, message, help: Some(help.into()) }
}

fn not_read(name: &str, e: &std::io::Error) -> Refused {
    Refused { code: codes::FILE_NOT_FOUND, message: format!("cannot read `{name}`: {}", io_reason(e)), help: None }
}

/// A short reason for an I/O error, lowercase.
pub fn io_reason(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        std::io::ErrorKind::InvalidData => "not UTF-8 text".to_string(),
        _ => e.to_string().to_lowercase(),
    }
}

/// Read a `.rev` file: a regular file of at most [`MAX_FILE_BYTES`] of UTF-8. `name` is what
/// messages call it.
pub fn read(path: &Path, name: &str) -> Result<String, Refused> {
    // Judged before opening: opening a FIFO blocks until a writer comes.
    let meta = std::fs::metadata(path).map_err(|e| not_read(name, &e))?;
    if !meta.is_file() {
        return Err(use_refused(format!("`{name}` is {}, not a `.rev` file", file_kind(&meta)), "name a `.rev` file"));
    }
    if meta.len() > MAX_FILE_BYTES as u64 {
        return Err(Refused::too_large(name, usize::try_from(meta.len()).ok()));
    }
    let file = File::open(path).map_err(|e| not_read(name, &e))?;
    // The handle may not be the file judged above (replaced in between): judge it again.
    let meta = file.metadata().map_err(|e| not_read(name, &e))?;
    if !meta.is_file() {
        return Err(use_refused(format!("`{name}` is {}, not a `.rev` file", file_kind(&meta)), "name a `.rev` file"));
    }
    // Files like those in /proc report a length of 0 and may be any size.
    read_bounded(file, name)
}

/// The text of `reader` (a file, standard input) as the `.rev` file `name`, read no further than
/// one byte past [`MAX_FILE_BYTES`]: more is refused (R0004), not read without end.
pub fn read_bounded(reader: impl Read, name: &str) -> Result<String, Refused> {
    let mut bytes = Vec::new();
    reader.take(MAX_FILE_BYTES as u64 + 1).read_to_end(&mut bytes).map_err(|e| not_read(name, &e))?;
    if bytes.len() > MAX_FILE_BYTES {
        return Err(Refused::too_large(name, None));
    }
    String::from_utf8(bytes).map_err(|_| Refused {
        code: codes::FILE_NOT_FOUND,
        message: format!("cannot read `{name}`: not UTF-8 text"),
        help: None,
    })
}

/// Compile the `.rev` file at `path` and everything it uses, under the policy above.
pub fn compile_file(path: &Path) -> Compiled {
    let name = path.to_string_lossy().into_owned();
    if path.extension().is_none_or(|x| x != "rev") {
        return refused_entry(Refused {
            code: codes::USE_REFUSED,
            message: format!("`{name}` is not a `.rev` file"),
            help: Some("`.rev` files hold domains and modules; name one of them".into()),
        });
    }
    let canonical = match std::fs::canonicalize(path) {
        Ok(c) => c,
        Err(e) => return refused_entry(not_read(&name, &e)),
    };
    if canonical.extension().is_none_or(|x| x != "rev") {
        return refused_entry(Refused {
            code: codes::USE_REFUSED,
            message: format!("`{name}` is a link to a file that is not a `.rev` file"),
            help: Some("`.rev` files hold domains and modules; name one of them".into()),
        });
    }
    match read(&canonical, &name) {
        Ok(text) => {
            let tree = Tree::of(path);
            check::compile_entry(&name, &canonical.to_string_lossy(), &text, &|r| tree.load(r))
        }
        Err(r) => refused_entry(r),
    }
}

/// Compile `text` as the file `path` (an editor's buffer, or standard input named by
/// `--stdin-filename`): its `use "…"` items read through `open` first (other unsaved buffers,
/// by absolute path), then the disk, under the same policy as [`compile_file`].
pub fn compile_text(path: &Path, text: &str, open: &dyn Fn(&Path) -> Option<String>) -> Compiled {
    let name = path.to_string_lossy().into_owned();
    let key = std::fs::canonicalize(path).unwrap_or_else(|_| normalize(path)).to_string_lossy().into_owned();
    let tree = Tree::of(path);
    check::compile_entry(&name, &key, text, &|r| tree.load_with(r, open))
}

fn refused_entry(r: Refused) -> Compiled {
    Compiled { domain: None, diagnostics: vec![r.diagnostic(None)], files: Vec::new(), references: Vec::new() }
}

/// `path` made absolute (against the working folder) with `.` and `..` collapsed, without
/// touching the file system.
fn normalize(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other.as_os_str()),
        }
    }
    out
}

#[cfg(test)]
mod tests;

//! A content-addressed store on disk: files named by a SHA-256 key ([`crate::hash::parts_hex`]), written to a temporary name and
//! renamed, so a killed run never leaves a half-written entry that a resumed run would trust.
//! Used by the reply cache of the model clients and the image cache of the image generators.
//!
//! No link in the cache is followed, for reading or writing, and an entry is read only when it
//! is a regular file no larger than [`MAX_ENTRY_BYTES`]: a planted link must not make a put
//! overwrite another file, nor a FIFO or a device make a get hang or read without end.

use std::fs::OpenOptions;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A folder of files named by their key, fanned out by the key's first two hex digits.
#[derive(Debug, Clone)]
pub struct Store {
    dir: PathBuf,
    ext: &'static str,
}

impl Store {
    pub fn new(dir: impl Into<PathBuf>, ext: &'static str) -> Store {
        Store { dir: dir.into(), ext }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn path(&self, key: &str) -> PathBuf {
        self.dir.join(&key[..2.min(key.len())]).join(format!("{key}.{}", self.ext))
    }

    /// The entry under `key`; `None` when absent or not a regular file of a plausible size (it
    /// is then asked again and replaced).
    pub fn get(&self, key: &str) -> Option<Vec<u8>> {
        let path = self.path(key);
        if !std::fs::symlink_metadata(&path).ok()?.is_file() {
            return None;
        }
        let file = no_follow(OpenOptions::new().read(true)).open(&path).ok()?;
        if !file.metadata().ok()?.is_file() {
            return None;
        }
        let mut bytes = Vec::new();
        file.take(MAX_ENTRY_BYTES + 1).read_to_end(&mut bytes).ok()?;
        (bytes.len() as u64 <= MAX_ENTRY_BYTES).then_some(bytes)
    }

    /// Write atomically: temporary file in the same folder, then rename.
    pub fn put(&self, key: &str, bytes: &[u8]) -> Result<(), String> {
        static SEQ: AtomicU64 = AtomicU64::new(0);
        let path = self.path(key);
        let parent = path.parent().unwrap_or(&self.dir);
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create cache folder `{}`: {e}", parent.display()))?;
        if std::fs::symlink_metadata(parent).is_ok_and(|m| m.file_type().is_symlink()) {
            return Err(format!(
                "cannot write cache entry `{}`: its folder is a symbolic link, and revelio writes through no link",
                path.display()
            ));
        }
        let tmp = parent.join(format!(".{key}.{}.{}.tmp", std::process::id(), SEQ.fetch_add(1, Ordering::Relaxed)));
        // A new file (never opened through a link), renamed over the entry: a link there is
        // replaced, its target untouched.
        no_follow(OpenOptions::new().write(true).create_new(true))
            .open(&tmp)
            .and_then(|mut f| f.write_all(bytes))
            .and_then(|()| std::fs::rename(&tmp, &path))
            .map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                format!("cannot write cache entry `{}`: {e}", path.display())
            })
    }

    /// Mark the entry under `key` as just used (its modification time), so that [`Store::prune`]
    /// removes it last; a missing entry or a link is left alone.
    pub fn touch(&self, key: &str) {
        let path = self.path(key);
        if std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_file())
            && let Ok(f) = no_follow(OpenOptions::new().write(true)).open(&path)
        {
            let _ = f.set_modified(std::time::SystemTime::now());
        }
    }

    /// When the entries hold more than `cap` bytes, remove the least recently used (oldest
    /// modification time) until they hold at most three quarters of it. Only this store's own
    /// entries are counted or removed: regular files with its extension in its two-digit
    /// folders, never through a link. Returns the bytes removed.
    pub fn prune(&self, cap: u64) -> u64 {
        let mut entries: Vec<(std::time::SystemTime, u64, PathBuf)> = Vec::new();
        let Ok(folders) = std::fs::read_dir(&self.dir) else { return 0 };
        for folder in folders.flatten() {
            let name = folder.file_name();
            let is_fan = name.len() == 2 && name.to_string_lossy().chars().all(|c| c.is_ascii_hexdigit());
            if !is_fan || !folder.file_type().is_ok_and(|t| t.is_dir()) {
                continue;
            }
            let Ok(files) = std::fs::read_dir(folder.path()) else { continue };
            for f in files.flatten() {
                let path = f.path();
                if path.extension().is_none_or(|e| e != self.ext) {
                    continue;
                }
                if let Ok(m) = std::fs::symlink_metadata(&path)
                    && m.is_file()
                {
                    entries.push((m.modified().unwrap_or(std::time::UNIX_EPOCH), m.len(), path));
                }
            }
        }
        let mut total: u64 = entries.iter().map(|e| e.1).sum();
        if total <= cap {
            return 0;
        }
        entries.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| a.2.cmp(&b.2)));
        let (keep, mut removed) = (cap / 4 * 3, 0);
        for (_, len, path) in entries {
            if total <= keep {
                break;
            }
            if std::fs::remove_file(&path).is_ok() {
                total -= len;
                removed += len;
            }
        }
        removed
    }
}

/// The largest cache entry read (replies are bounded far below; images by the generators).
pub const MAX_ENTRY_BYTES: u64 = 64 << 20;

/// `O_NOFOLLOW` (the last component may not be a link) and `O_NONBLOCK` (a FIFO does not block
/// the open).
#[cfg(unix)]
fn no_follow(opts: &mut OpenOptions) -> &mut OpenOptions {
    use std::os::unix::fs::OpenOptionsExt;
    opts.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK)
}

#[cfg(not(unix))]
fn no_follow(opts: &mut OpenOptions) -> &mut OpenOptions {
    opts
}

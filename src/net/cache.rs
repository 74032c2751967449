//! A content-addressed store on disk: files named by a SHA-256 key ([`crate::hash::parts_hex`]), written to a temporary name and
//! renamed, so a killed run never leaves a half-written entry that a resumed run would trust.
//! Used by the reply cache of the model clients and the image cache of the image generators.

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

    pub fn get(&self, key: &str) -> Option<Vec<u8>> {
        std::fs::read(self.path(key)).ok()
    }

    /// Write atomically: temporary file in the same folder, then rename.
    pub fn put(&self, key: &str, bytes: &[u8]) -> Result<(), String> {
        static SEQ: AtomicU64 = AtomicU64::new(0);
        let path = self.path(key);
        let parent = path.parent().unwrap_or(&self.dir);
        std::fs::create_dir_all(parent)
            .map_err(|e| format!("cannot create cache folder `{}`: {e}", parent.display()))?;
        let tmp = parent.join(format!(".{key}.{}.{}.tmp", std::process::id(), SEQ.fetch_add(1, Ordering::Relaxed)));
        std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, &path)).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("cannot write cache entry `{}`: {e}", path.display())
        })
    }
}

//! What several integration tests share: the checkout's root and its `.rev` files.
use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `.rev` file under `dir`, in a stable order.
pub fn rev_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    let mut entries: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            out.extend(rev_files(&p));
        } else if p.extension().is_some_and(|e| e == "rev") {
            out.push(p);
        }
    }
    out
}

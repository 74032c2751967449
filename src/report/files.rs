//! The report's image files: each image a core shows is hard-linked from the run's
//! content-addressed `images/` into the report's `images/` (copied where a link cannot be made,
//! e.g. across file systems), and a thumbnail is written to `thumbs/`. Both are named by the
//! image's SHA-256, so a refresh only adds what is new; files of images no longer shown are
//! removed (only names of that form, so nothing else in the folder is touched). Images are read
//! through [`safe`] (regular files of a bounded size, no link followed), and a link found in the
//! report's `images/` or `thumbs/` is replaced, not written through.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use crate::journal::safe;

/// Width of thumbnails in pixels (shown at about 210 CSS pixels; sharp on 1.5× screens).
pub const THUMB_WIDTH: u32 = 320;

/// An image as the page links it: paths relative to the report folder, thumbnail size.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ImageRef {
    pub full: String,
    pub thumb: String,
    pub width: u32,
    pub height: u32,
}

/// A journal's image field is a SHA-256 in hex; anything else (a hostile or corrupt journal)
/// must not become a path.
fn is_hash(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase())
}

fn io_err(what: &str, path: &Path, e: std::io::Error) -> String {
    format!("cannot {what} `{}`: {}", path.display(), crate::journal::io_message(&e))
}

/// Bring the images named by `hashes` into `out/images` and `out/thumbs`. Hashes with no image
/// in the run (a `--renderer none` run hashes the scene instead) or whose file cannot be decoded
/// are left out of the map; the page shows them without a picture.
pub fn materialize(run_images: &Path, out: &Path, hashes: &[&str]) -> Result<BTreeMap<String, ImageRef>, String> {
    let (full_dir, thumb_dir) = (out.join("images"), out.join("thumbs"));
    let wanted: BTreeSet<&str> = hashes.iter().copied().filter(|h| is_hash(h)).collect();
    let mut map = BTreeMap::new();
    for hash in wanted {
        let src = run_images.join(format!("{hash}.png"));
        // Only a regular file of a plausible size (no link, FIFO or device) is shown.
        let Ok(png) = safe::read(&src, safe::MAX_IMAGE_BYTES) else { continue };
        for dir in [&full_dir, &thumb_dir] {
            safe::ensure_dir(dir).map_err(|e| io_err("create", dir, e))?;
        }
        let name = format!("{hash}.png");
        let full = full_dir.join(&name);
        if !regular_or_cleared(&full)? && std::fs::hard_link(&src, &full).is_err() {
            crate::journal::write_atomic(&full, &png).map_err(|e| e.to_string())?;
        }
        let thumb = thumb_dir.join(&name);
        let size = match regular_or_cleared(&thumb)?.then(|| image::image_dimensions(&thumb).ok()).flatten() {
            Some(size) => Some(size),
            None => write_thumbnail(&src, &png, &thumb)?,
        };
        if let Some((width, height)) = size {
            map.insert(
                hash.to_string(),
                ImageRef { full: format!("images/{name}"), thumb: format!("thumbs/{name}"), width, height },
            );
        }
    }
    for dir in [&full_dir, &thumb_dir] {
        remove_stale(dir, &map)?;
    }
    Ok(map)
}

/// Whether `path` is a regular file; anything else there (a link planted in the report
/// folder, a FIFO) is removed — a link, never its target — so that a fresh file takes its place.
fn regular_or_cleared(path: &Path) -> Result<bool, String> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_file() => Ok(true),
        Ok(_) => std::fs::remove_file(path).map(|()| false).map_err(|e| io_err("remove", path, e)),
        Err(_) => Ok(false),
    }
}

/// Write a thumbnail of `bytes` (the file `src`); `None` when it is not a readable image.
fn write_thumbnail(src: &Path, bytes: &[u8], dst: &Path) -> Result<Option<(u32, u32)>, String> {
    let Ok(img) = image::load_from_memory(bytes) else { return Ok(None) };
    let (w, h) = (img.width().max(1), img.height().max(1));
    let (tw, th) = if w <= THUMB_WIDTH {
        (w, h)
    } else {
        (THUMB_WIDTH, (u64::from(h) * u64::from(THUMB_WIDTH) / u64::from(w)).max(1) as u32)
    };
    let small = image::imageops::thumbnail(&img.to_rgb8(), tw, th);
    let mut png = Vec::new();
    small
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| format!("cannot encode a thumbnail of `{}`: {e}", src.display()))?;
    crate::journal::write_atomic(dst, &png).map_err(|e| e.to_string())?;
    Ok(Some((tw, th)))
}

fn remove_stale(dir: &Path, keep: &BTreeMap<String, ImageRef>) -> Result<(), String> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(hash) = name.strip_suffix(".png") else { continue };
        if is_hash(hash) && !keep.contains_key(hash) {
            std::fs::remove_file(e.path()).map_err(|err| io_err("remove", &e.path(), err))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_hashes_become_paths() {
        assert!(is_hash(&"ab".repeat(32)));
        assert!(!is_hash("../../etc/passwd"));
        assert!(!is_hash(&"AB".repeat(32)));
        assert!(!is_hash(&format!("{}/x", "a".repeat(62))));
    }
}

//! The builtin renderer's cache of drawn scenes, shared by every run and `check --render` (under
//! the reply cache's folder, `images/builtin`): the same scene drawn by the same build on the
//! same adapter at the same size is the same image, so it is drawn once. A search of another
//! model on the same domain and seed, a `check --render` after an edit that left most scenes as
//! they were, a second `check` with fewer scenes: each draws only what it has not drawn before.
//!
//! The key is the scene as JSON (everything the renderer reads), the image size, the adapter's
//! summary (driver and version) and a hash of the running executable (any other build, even of
//! the same version, has its own entries). An entry holds the visibility figures (a JSON line)
//! and the PNG; one that does not read back as both, for this scene's entities and size, is
//! drawn again and replaced. The cache holds at most [`CAP_BYTES`]: past it, opening the cache
//! removes the least recently used entries.

use std::sync::OnceLock;

use super::EntityVisibility;
use crate::net::cache::Store;
use crate::scene::Scene;

/// Bytes of drawn scenes kept (about 7 000 driving frames).
pub const CAP_BYTES: u64 = 1 << 30;

/// A hash of the running executable, once per process; `None` when it cannot be read (no
/// cache then: an entry of another build must never be taken for this one's).
fn build_id() -> Option<&'static str> {
    static ID: OnceLock<Option<String>> = OnceLock::new();
    ID.get_or_init(|| {
        let exe = std::env::current_exe().ok()?;
        std::fs::read(exe).ok().map(|bytes| crate::hash::sha256_hex(&bytes))
    })
    .as_deref()
}

#[derive(Debug, Clone)]
pub struct SceneCache {
    store: Store,
    /// Build, adapter and size override, hashed: the part of every key that is not the scene.
    salt: String,
}

impl SceneCache {
    /// The cache in `dir` for this build, `adapter` (its summary) and `size` override; trimmed to
    /// [`CAP_BYTES`] now. `None` when this build cannot be identified.
    pub fn open(dir: std::path::PathBuf, adapter: &str, size: Option<(u32, u32)>) -> Option<SceneCache> {
        let build = build_id()?;
        let size = size.map_or_else(|| "camera".to_string(), |(w, h)| format!("{w}x{h}"));
        let salt = crate::hash::parts_hex([build.as_bytes(), adapter.as_bytes(), size.as_bytes()]);
        let store = Store::new(dir, "scene");
        store.prune(CAP_BYTES);
        Some(SceneCache { store, salt })
    }

    /// The entry `scene` is kept under (`None`: it cannot be written as JSON, so it is not kept).
    pub fn key(&self, scene: &Scene) -> Option<String> {
        let json = serde_json::to_vec(scene).ok()?;
        Some(crate::hash::parts_hex([self.salt.as_bytes(), &json]))
    }

    /// The PNG and visibility figures kept under `key` (a scene with `entities` placed entities,
    /// drawn at `(w, h)`), if drawn before.
    pub fn get(&self, key: &str, entities: usize, (w, h): (u32, u32)) -> Option<(Vec<u8>, Vec<EntityVisibility>)> {
        let bytes = self.store.get(key)?;
        let (line, png) = bytes.split_at(bytes.iter().position(|&b| b == b'\n')?);
        let png = &png[1..];
        let seen: Vec<EntityVisibility> = serde_json::from_slice(line).ok()?;
        if seen.len() != entities || super::png_size(png) != Some((w, h)) {
            return None;
        }
        self.store.touch(key);
        Some((png.to_vec(), seen))
    }

    /// Keep a drawn scene; a cache that cannot be written only costs a drawing later.
    pub fn put(&self, key: &str, png: &[u8], seen: &[EntityVisibility]) {
        let Ok(mut bytes) = serde_json::to_vec(seen) else { return };
        bytes.push(b'\n');
        bytes.extend_from_slice(png);
        let _ = self.store.put(key, &bytes);
    }
}

//! Renderers: Scene → image. `builtin` draws the scene's resolved shapes with wgpu (the
//! embedded default, see `builtin`); image-generation renderers live in their own modules.
//!
//! The builtin renderer needs the `render` feature and the image generators the `net` feature;
//! without them `build_renderer` names the feature a spec needs.
#[cfg(feature = "net")]
pub mod imagegen;

use crate::net::BoxFuture;
use crate::scene::Scene;

#[cfg(feature = "render")]
mod atmosphere;
#[cfg(feature = "render")]
pub mod builtin;
#[cfg(all(test, feature = "render"))]
pub(crate) mod fixtures;
#[cfg(feature = "render")]
mod gpu;
#[cfg(feature = "render")]
pub mod mesh;
#[cfg(feature = "render")]
pub mod scene_cache;
#[cfg(feature = "render")]
pub mod sheet;
#[cfg(feature = "render")]
mod visibility;

#[cfg(feature = "render")]
pub use atmosphere::{Weather, project};
#[cfg(feature = "render")]
pub use builtin::{BuiltinRenderer, adapter_info, encode_png, encode_png_small};
#[cfg(feature = "render")]
pub use gpu::{AdapterSummary, DRIVER_PACKAGES};

/// An encoded image.
#[derive(Debug, Clone)]
pub struct Rendered {
    pub png: Vec<u8>,
    /// Served from an image cache.
    pub cached: bool,
    /// How visible each entity the concepts placed is in this image, in `Scene.entities`
    /// order; `None` from renderers that cannot tell (image generators).
    pub visibility: Option<Vec<EntityVisibility>>,
}

/// The width and height a PNG's header states (`None` for anything that is not a PNG): what a
/// model is billed for, and what a cached drawing must match.
pub fn png_size(bytes: &[u8]) -> Option<(u32, u32)> {
    if bytes.len() < 24 || &bytes[..8] != b"\x89PNG\r\n\x1a\n" || &bytes[12..16] != b"IHDR" {
        return None;
    }
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    Some((be(16), be(20)))
}

/// One placed entity's visibility in one image (the builtin renderer measures it from the same
/// frame as the colours, see docs/render.md).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EntityVisibility {
    pub entity: String,
    /// The concept that placed it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub concept: Option<String>,
    /// Pixels where it is seen after occlusion by everything else.
    pub pixels: u32,
    /// Root-mean-square luma difference (0..1, sRGB) between its visible pixels and its
    /// surround; fog, rain and darkness lower it.
    pub contrast: f64,
}

/// Why a scene has no image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct RenderError {
    pub message: String,
    /// The image generator refused this scene (a safety filter, a text-only reply): an outcome
    /// of the observation (`image_blocked`), not a failure of the run.
    pub blocked: bool,
}

impl RenderError {
    pub fn new(message: impl Into<String>) -> RenderError {
        RenderError { message: message.into(), blocked: false }
    }

    pub fn blocked(message: impl Into<String>) -> RenderError {
        RenderError { message: message.into(), blocked: true }
    }
}

/// Turns a scene (and its image prompt, for image-generation renderers) into an image.
pub trait Renderer: Send + Sync {
    fn id(&self) -> String;
    fn render<'a>(&'a self, scene: &'a Scene, prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>>;
    /// Whether `render` computes on the calling thread instead of waiting on I/O (the builtin
    /// renderer). The run then calls it from dedicated render threads, never from an async
    /// worker.
    fn blocking(&self) -> bool {
        false
    }
}

/// Options for building a renderer.
#[derive(Debug, Clone, Default)]
pub struct RendererOptions {
    /// Image size override `(width, height)`; defaults to the domain camera's.
    pub size: Option<(u32, u32)>,
    /// Image cache folder: the image generators' images, and the builtin renderer's scene cache
    /// in its folder `builtin`.
    pub cache_dir: Option<std::path::PathBuf>,
    /// `--renderer-base-url`: the image-generation provider's endpoint (else its provider's
    /// variable, `GEMINI_BASE_URL` or `OPENAI_BASE_URL`). Never the model's `--base-url`.
    pub base_url: Option<String>,
    /// `--allow-http`: plain `http://` to a named server other than this machine (never to a
    /// provider's own host).
    pub allow_http: bool,
    /// `--dry-run`: nothing will be drawn, so an image generator is built without its key.
    pub dry_run: bool,
}

/// `--renderer` specs: `none` (no image; models see only the prompt), `builtin` (wgpu),
/// `imagegen:gemini:MODEL`, `imagegen:openai:MODEL`.
pub fn build_renderer(spec: &str, opts: &RendererOptions) -> Result<Option<std::sync::Arc<dyn Renderer>>, String> {
    #[cfg(not(any(feature = "render", feature = "net")))]
    let _ = opts;
    match spec {
        "none" => Ok(None),
        #[cfg(feature = "render")]
        "builtin" => {
            let r = BuiltinRenderer::new(opts.size).map_err(|e| e.message)?;
            Ok(Some(std::sync::Arc::new(r.with_cache(opts.cache_dir.as_deref()))))
        }
        #[cfg(not(feature = "render"))]
        "builtin" => Err(without_feature("builtin", "render")),
        #[cfg(feature = "net")]
        s if s.starts_with("imagegen:") => imagegen::build(s, opts).map(Some),
        #[cfg(not(feature = "net"))]
        s if s.starts_with("imagegen:") => Err(without_feature(s, "net")),
        other => Err(format!(
            "unknown renderer `{other}`: expected `none`, `builtin`, `imagegen:gemini:MODEL` or `imagegen:openai:MODEL`"
        )),
    }
}

/// The error for a renderer this build leaves out.
#[cfg(any(not(feature = "render"), not(feature = "net")))]
fn without_feature(spec: &str, feature: &str) -> String {
    format!(
        "renderer `{spec}` is not in this build of revelio (built without the `{feature}` feature); use `--renderer none` or a default build"
    )
}

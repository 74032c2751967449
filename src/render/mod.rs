//! Renderers: Scene → image (being built).
pub mod imagegen;

use crate::scene::Scene;
use crate::vlm::BoxFuture;

/// An encoded image.
#[derive(Debug, Clone)]
pub struct Rendered {
    pub png: Vec<u8>,
    /// Served from an image cache.
    pub cached: bool,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct RenderError(pub String);

/// Turns a scene (and its image prompt, for image-generation renderers) into an image.
pub trait Renderer: Send + Sync {
    fn id(&self) -> String;
    fn render<'a>(&'a self, scene: &'a Scene, prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>>;
}

/// Options for building a renderer.
#[derive(Debug, Clone, Default)]
pub struct RendererOptions {
    /// Image size override `(width, height)`; defaults to the domain camera's.
    pub size: Option<(u32, u32)>,
    /// Image cache folder (image-generation renderers).
    pub cache_dir: Option<std::path::PathBuf>,
    /// `--base-url` for image-generation providers.
    pub base_url: Option<String>,
}

/// `--renderer` specs: `none` (no image; models see only the prompt), `builtin` (wgpu),
/// `imagegen:gemini:MODEL`, `imagegen:openai:MODEL`.
pub fn build_renderer(spec: &str, opts: &RendererOptions) -> Result<Option<std::sync::Arc<dyn Renderer>>, String> {
    match spec {
        "none" => Ok(None),
        s if s.starts_with("imagegen:") => imagegen::build(s, opts).map(Some),
        other => Err(format!(
            "unknown renderer `{other}`: expected `none`, `builtin`, `imagegen:gemini:MODEL` or `imagegen:openai:MODEL`"
        )),
    }
}

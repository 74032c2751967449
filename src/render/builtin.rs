//! The embedded default renderer: draws a [`Scene`] from its resolved shapes and environment
//! with wgpu, headless, on a GPU or on Mesa's CPU drivers (lavapipe, llvmpipe).

use std::sync::{Arc, OnceLock};

use image::{ImageEncoder, RgbaImage};

use super::gpu::{AdapterSummary, Gpu};
use super::{RenderError, Rendered, Renderer, atmosphere, mesh};
use crate::scene::Scene;
use crate::vlm::BoxFuture;

/// Largest image side accepted; wgpu's guaranteed minimum texture size.
pub const MAX_SIDE: u32 = 8192;

/// The process-wide device: created on first use, shared by every renderer instance.
fn shared_gpu() -> Result<Arc<Gpu>, RenderError> {
    static GPU: OnceLock<Result<Arc<Gpu>, String>> = OnceLock::new();
    GPU.get_or_init(|| Gpu::new().map(Arc::new)).clone().map_err(RenderError)
}

/// Summary of the adapter the builtin renderer uses (`revelio render --info`).
pub fn adapter_info() -> Result<AdapterSummary, RenderError> {
    Ok(shared_gpu()?.summary().clone())
}

#[derive(Clone)]
pub struct BuiltinRenderer {
    gpu: Arc<Gpu>,
    size: Option<(u32, u32)>,
}

impl std::fmt::Debug for BuiltinRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BuiltinRenderer").field("adapter", self.gpu.summary()).field("size", &self.size).finish()
    }
}

/// Check an image size from the user.
pub fn check_size(w: u32, h: u32) -> Result<(), RenderError> {
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(RenderError(format!("image size `{w}x{h}` is out of range: each side must be 1..={MAX_SIDE}")));
    }
    Ok(())
}

impl BuiltinRenderer {
    /// `size` overrides the scene camera's image size.
    pub fn new(size: Option<(u32, u32)>) -> Result<BuiltinRenderer, RenderError> {
        if let Some((w, h)) = size {
            check_size(w, h)?;
        }
        Ok(BuiltinRenderer { gpu: shared_gpu()?, size })
    }

    pub fn adapter(&self) -> &AdapterSummary {
        self.gpu.summary()
    }

    /// The image size used for `scene`.
    pub fn size_for(&self, scene: &Scene) -> (u32, u32) {
        self.size.unwrap_or((scene.camera.width, scene.camera.height))
    }

    /// Render to pixels (sRGB RGBA8).
    pub fn render_rgba(&self, scene: &Scene) -> Result<RgbaImage, RenderError> {
        let (w, h) = self.size_for(scene);
        check_size(w, h)?;
        let mesh = mesh::build(scene, scene.camera.at);
        let frame = atmosphere::frame(&scene.camera, &scene.environment, w, h, scene.seed);
        let rain = frame.wet[2] > 0.0;
        let pixels = self.gpu.draw(&mesh, &frame, rain).map_err(RenderError)?;
        RgbaImage::from_raw(w, h, pixels).ok_or_else(|| RenderError("the rendered image has the wrong size".into()))
    }

    /// Render and encode as PNG.
    pub fn render_png(&self, scene: &Scene) -> Result<Vec<u8>, RenderError> {
        encode_png(&self.render_rgba(scene)?)
    }
}

/// Encode as PNG with fast settings: the images go to models and caches, not archives.
pub fn encode_png(img: &RgbaImage) -> Result<Vec<u8>, RenderError> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut out = Vec::with_capacity(img.as_raw().len() / 4);
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgba8)
        .map_err(|e| RenderError(format!("cannot encode the image as png: {e}")))?;
    Ok(out)
}

impl Renderer for BuiltinRenderer {
    fn id(&self) -> String {
        match self.size {
            Some((w, h)) => format!("builtin@{w}x{h}"),
            None => "builtin".to_string(),
        }
    }

    fn render<'a>(&'a self, scene: &'a Scene, _prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>> {
        // Rendering is a few milliseconds of blocking work; callers that care run it on a
        // blocking thread. The future is ready when polled.
        Box::pin(async move { Ok(Rendered { png: self.render_png(scene)?, cached: false }) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::fixtures::*;

    fn renderer() -> BuiltinRenderer {
        BuiltinRenderer::new(None).expect("the tests need a graphics adapter (llvmpipe is enough)")
    }

    fn dump(name: &str, img: &RgbaImage) {
        if let Ok(dir) = std::env::var("REVELIO_RENDER_DUMP") {
            img.save(std::path::Path::new(&dir).join(format!("{name}.png"))).unwrap();
        }
    }

    #[test]
    fn renders_a_street() {
        let r = renderer();
        for (name, env) in [
            ("clear", weather(10.0, 0.0, 0.0, 0.0, 60.0)),
            ("rain", weather(90.0, 90.0, 80.0, 10.0, 60.0)),
            ("fog", weather(60.0, 0.0, 0.0, 60.0, 40.0)),
            ("night", weather(10.0, 0.0, 0.0, 0.0, -20.0)),
        ] {
            let s = scene(vec![pedestrian(8.0, 0.0), red_box(20.0), traffic_light(25.0, false)], env);
            let img = r.render_rgba(&s).unwrap();
            dump(name, &img);
            assert_eq!(img.dimensions(), (640, 360));
        }
    }
}

//! The embedded default renderer: draws a [`Scene`] from its resolved shapes and environment
//! with wgpu, headless, on a GPU or on Mesa's CPU drivers (lavapipe, llvmpipe).

use std::sync::{Arc, OnceLock};

use image::{ImageEncoder, RgbaImage};

use super::gpu::{AdapterSummary, Gpu};
use super::scene_cache::SceneCache;
use super::{EntityVisibility, RenderError, Rendered, Renderer, atmosphere, mesh, visibility};
use crate::net::BoxFuture;
use crate::scene::Scene;

/// A scene as the scene cache keeps it: its PNG and its visibility figures.
type Kept = (Vec<u8>, Vec<EntityVisibility>);

/// Largest image side accepted; wgpu's guaranteed minimum texture size.
pub const MAX_SIDE: u32 = 8192;

/// The process-wide device: created on first use, shared by every renderer instance.
fn shared_gpu() -> Result<Arc<Gpu>, RenderError> {
    static GPU: OnceLock<Result<Arc<Gpu>, String>> = OnceLock::new();
    GPU.get_or_init(|| Gpu::new().map(Arc::new)).clone().map_err(RenderError::new)
}

/// Summary of the adapter the builtin renderer uses (`revelio render --info`).
pub fn adapter_info() -> Result<AdapterSummary, RenderError> {
    Ok(shared_gpu()?.summary().clone())
}

#[derive(Clone)]
pub struct BuiltinRenderer {
    gpu: Arc<Gpu>,
    size: Option<(u32, u32)>,
    /// Scenes drawn before, by this build ([`BuiltinRenderer::with_cache`]).
    cache: Option<Arc<SceneCache>>,
}

impl std::fmt::Debug for BuiltinRenderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BuiltinRenderer").field("adapter", self.gpu.summary()).field("size", &self.size).finish()
    }
}

/// Check an image size from the user.
pub fn check_size(w: u32, h: u32) -> Result<(), RenderError> {
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(RenderError::new(format!(
            "image size `{w}x{h}` is out of range: each side must be 1..={MAX_SIDE}"
        )));
    }
    Ok(())
}

impl BuiltinRenderer {
    /// `size` overrides the scene camera's image size.
    pub fn new(size: Option<(u32, u32)>) -> Result<BuiltinRenderer, RenderError> {
        if let Some((w, h)) = size {
            check_size(w, h)?;
        }
        Ok(BuiltinRenderer { gpu: shared_gpu()?, size, cache: None })
    }

    /// Keep what is drawn in the scene cache, the folder `builtin` of the image cache `images`
    /// (none when `images` is `None`), and take a scene drawn before from it
    /// ([`super::scene_cache`]).
    pub fn with_cache(mut self, images: Option<&std::path::Path>) -> BuiltinRenderer {
        let adapter = format!("{:?}", self.gpu.summary());
        self.cache = images.and_then(|d| SceneCache::open(d.join("builtin"), &adapter, self.size)).map(Arc::new);
        self
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
        Ok(self.render_seen(scene)?.0)
    }

    /// Render to pixels, with each placed entity's visibility in that same frame (from the scene
    /// cache when it holds the scene).
    pub fn render_seen(&self, scene: &Scene) -> Result<(RgbaImage, Vec<EntityVisibility>), RenderError> {
        let (entry, hit) = self.cached(scene);
        if entry.is_none() {
            return self.draw_seen(scene);
        }
        if let Some((png, seen)) = hit
            && let Ok(img) = image::load_from_memory_with_format(&png, image::ImageFormat::Png)
        {
            return Ok((img.to_rgba8(), seen));
        }
        // Not drawn before, or kept with a header that reads right over data that does not: draw
        // it and keep the drawing (the pixels at hand, so nothing is decoded).
        let (img, _, seen) = self.draw_and_keep(scene, entry)?;
        Ok((img, seen))
    }

    /// Each placed entity's visibility in the scene's image, without its pixels (the visibility
    /// lint): a scene the cache holds is neither drawn nor decoded.
    pub fn render_visibility(&self, scene: &Scene) -> Result<Vec<EntityVisibility>, RenderError> {
        match self.cache {
            Some(_) => Ok(self.render_encoded(scene)?.1),
            None => Ok(self.draw_seen(scene)?.1),
        }
    }

    /// The scene as PNG with its visibility figures, and whether the scene cache held it (a
    /// drawing is kept there).
    fn render_encoded(&self, scene: &Scene) -> Result<(Vec<u8>, Vec<EntityVisibility>, bool), RenderError> {
        let (entry, hit) = self.cached(scene);
        if let Some((png, seen)) = hit {
            return Ok((png, seen, true));
        }
        let (_, png, seen) = self.draw_and_keep(scene, entry)?;
        Ok((png, seen, false))
    }

    /// The scene cache with the scene's key (none without a cache, or for a scene that has no
    /// key), and what the cache holds for it.
    fn cached(&self, scene: &Scene) -> (Option<(&SceneCache, String)>, Option<Kept>) {
        let entry = self.cache.as_deref().and_then(|c| Some((c, c.key(scene)?)));
        let hit = entry.as_ref().and_then(|(c, key)| c.get(key, scene.entities.len(), self.size_for(scene)));
        (entry, hit)
    }

    /// Draw the scene and encode it as PNG, kept in the scene cache under `entry`'s key.
    fn draw_and_keep(
        &self,
        scene: &Scene,
        entry: Option<(&SceneCache, String)>,
    ) -> Result<(RgbaImage, Vec<u8>, Vec<EntityVisibility>), RenderError> {
        let (img, seen) = self.draw_seen(scene)?;
        let png = encode_png(&img)?;
        if let Some((cache, key)) = entry {
            cache.put(&key, &png, &seen);
        }
        Ok((img, png, seen))
    }

    /// Draw the scene: pixels and each placed entity's visibility in that same frame.
    fn draw_seen(&self, scene: &Scene) -> Result<(RgbaImage, Vec<EntityVisibility>), RenderError> {
        let (w, h) = self.size_for(scene);
        check_size(w, h)?;
        let mesh = mesh::build(scene, scene.camera.at);
        let mut frame = atmosphere::frame(&scene.camera, &scene.environment, w, h, scene.seed);
        frame.set_lights(&mesh.lights);
        let (_, streaks) = atmosphere::rain_streaks(frame.wet[2], w, h);
        let drawn = self.gpu.draw(&mesh, &frame, streaks).map_err(RenderError::new)?;
        let seen = visibility::measure(scene, &drawn.pixels, &drawn.ids, w, h);
        let img = RgbaImage::from_raw(w, h, drawn.pixels)
            .ok_or_else(|| RenderError::new("the rendered image has the wrong size"))?;
        Ok((img, seen))
    }

    /// Render and encode as PNG.
    pub fn render_png(&self, scene: &Scene) -> Result<Vec<u8>, RenderError> {
        encode_png(&self.render_rgba(scene)?)
    }
}

/// Encode as PNG with fast settings: the images go to models and caches, not archives.
pub fn encode_png(img: &RgbaImage) -> Result<Vec<u8>, RenderError> {
    encode_png_with(img, image::codecs::png::CompressionType::Fast)
}

/// Encode as a small PNG (slower), for images that are kept: contact sheets, examples.
pub fn encode_png_small(img: &RgbaImage) -> Result<Vec<u8>, RenderError> {
    encode_png_with(img, image::codecs::png::CompressionType::Best)
}

fn encode_png_with(img: &RgbaImage, compression: image::codecs::png::CompressionType) -> Result<Vec<u8>, RenderError> {
    use image::codecs::png::{FilterType, PngEncoder};
    let mut out = Vec::with_capacity(img.as_raw().len() / 4);
    PngEncoder::new_with_quality(&mut out, compression, FilterType::Adaptive)
        .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::Rgba8)
        .map_err(|e| RenderError::new(format!("cannot encode the image as png: {e}")))?;
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
        // The future does all its work when first polled; `blocking` tells the run to poll it
        // on a render thread.
        Box::pin(async move {
            let (png, seen, cached) = self.render_encoded(scene)?;
            Ok(Rendered { png, cached, visibility: Some(seen) })
        })
    }

    fn blocking(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::Primitive;
    use crate::render::fixtures::*;
    use crate::render::project;

    fn renderer() -> BuiltinRenderer {
        BuiltinRenderer::new(None).expect("the renderer tests need a graphics adapter (Mesa llvmpipe is enough)")
    }

    fn clear() -> std::collections::BTreeMap<String, f64> {
        weather(10.0, 0.0, 0.0, 0.0, 60.0)
    }

    /// Pixel bounds of the projection of an axis-aligned box (scene frame).
    fn screen_box(s: &Scene, lo: [f64; 3], hi: [f64; 3]) -> (u32, u32, u32, u32) {
        let (w, h) = (s.camera.width, s.camera.height);
        let mut b = (f64::MAX, f64::MAX, f64::MIN, f64::MIN);
        for i in 0..8 {
            let p = [[lo[0], hi[0]][i & 1], [lo[1], hi[1]][i >> 1 & 1], [lo[2], hi[2]][i >> 2 & 1]];
            let (xy, _) = project(&s.camera, w, h, p).expect("in front of the camera");
            b = (b.0.min(xy[0]), b.1.min(xy[1]), b.2.max(xy[0]), b.3.max(xy[1]));
        }
        let c = |v: f64, m: u32| v.clamp(0.0, (m - 1) as f64) as u32;
        (c(b.0, w), c(b.1, h), c(b.2, w), c(b.3, h))
    }

    fn is_red(p: &image::Rgba<u8>) -> bool {
        let [r, g, b, _] = p.0;
        r > 90 && r as u32 > 2 * g as u32 && r as u32 > 2 * b as u32
    }

    fn count(img: &RgbaImage, (x0, y0, x1, y1): (u32, u32, u32, u32), f: impl Fn(&image::Rgba<u8>) -> bool) -> usize {
        (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| (x, y))).filter(|&(x, y)| f(img.get_pixel(x, y))).count()
    }

    #[test]
    fn an_entity_shows_its_colour_inside_its_projected_box() {
        let s = scene(vec![red_box(12.0)], clear());
        let img = renderer().render_rgba(&s).unwrap();
        let bbox = screen_box(&s, [11.5, -0.5, 0.0], [12.5, 0.5, 1.0]);
        let area = ((bbox.2 - bbox.0 + 1) * (bbox.3 - bbox.1 + 1)) as usize;
        let red = count(&img, bbox, is_red);
        assert!(red * 2 > area, "{red} of {area} pixels in the box are red");
        assert!(count(&img, (0, 0, 639, 359), is_red) < red + area / 4, "red appears only around the box");
    }

    #[test]
    fn a_near_object_covers_more_pixels_than_the_same_object_far() {
        let r = renderer();
        let reds = |d| count(&r.render_rgba(&scene(vec![red_box(d)], clear())).unwrap(), (0, 0, 639, 359), is_red);
        let (near, far) = (reds(5.0), reds(30.0));
        assert!(far > 0, "the far box is visible");
        assert!(near > 10 * far, "near {near} px, far {far} px");
    }

    #[test]
    fn fog_lowers_the_contrast_of_distant_objects() {
        let r = renderer();
        let saturation = |env| {
            let s = scene(vec![red_box(35.0)], env);
            let img = r.render_rgba(&s).unwrap();
            let (x0, y0, x1, y1) = screen_box(&s, [34.8, -0.3, 0.2], [35.2, 0.3, 0.8]);
            let px: Vec<_> = (y0..=y1).flat_map(|y| (x0..=x1).map(move |x| (x, y))).collect();
            px.iter().map(|&(x, y)| img.get_pixel(x, y).0[0] as f64 - img.get_pixel(x, y).0[1] as f64).sum::<f64>()
                / px.len() as f64
        };
        let (clear_sat, foggy_sat) = (saturation(clear()), saturation(weather(60.0, 0.0, 0.0, 70.0, 60.0)));
        assert!(clear_sat > 60.0, "clear: red minus green {clear_sat}");
        assert!(foggy_sat < clear_sat * 0.6, "foggy {foggy_sat} vs clear {clear_sat}");
    }

    #[test]
    fn an_entity_behind_another_counts_zero_visible_pixels() {
        let r = renderer();
        let mut hidden = red_box(30.0);
        hidden.name = "hidden".into();
        // A wall 4 m wide and 3 m high at 15 m covers the 1 m box at 30 m on the same line.
        let wall = entity(
            "wall",
            [15.0, 0.0, 0.0],
            vec![part(crate::ir::Primitive::Box, [0.3, 4.0, 3.0], [0.0, 0.0, 1.5], 0x808080, "matte")],
        );
        let (_, seen) = r.render_seen(&scene(vec![hidden.clone(), wall], clear())).unwrap();
        assert_eq!(seen.len(), 2);
        assert_eq!((seen[0].entity.as_str(), seen[0].pixels, seen[0].contrast), ("hidden", 0, 0.0));
        assert!(seen[1].pixels > 1000, "the wall is seen: {seen:?}");
        // Alone, the same box is seen, and its pixels match the red pixels of the image.
        let (img, alone) = r.render_seen(&scene(vec![hidden], clear())).unwrap();
        let reds = count(&img, (0, 0, 639, 359), is_red) as f64;
        assert!(alone[0].pixels > 50, "{alone:?}");
        assert!((f64::from(alone[0].pixels) - reds).abs() <= reds * 0.2, "{alone:?} vs {reds} red pixels");
        // Under the road (below z = 0) it is hidden by the ground.
        let mut buried = red_box(12.0);
        buried.position[2] = -1.5;
        let (_, under) = r.render_seen(&scene(vec![buried], clear())).unwrap();
        assert_eq!(under[0].pixels, 0, "{under:?}");
    }

    /// Glass hides nothing: an entity seen through another entity's glass pane keeps its pixels,
    /// and the pane claims only the pixels where no entity lies behind it.
    #[test]
    fn an_entity_behind_glass_is_seen() {
        let r = renderer();
        let mut behind = red_box(30.0);
        behind.name = "behind".into();
        let pane = |material: &str| {
            entity(
                "pane",
                [15.0, 0.0, 0.0],
                vec![part(crate::ir::Primitive::Box, [0.05, 4.0, 3.0], [0.0, 0.0, 1.5], 0xb8d8e8, material)],
            )
        };
        let (_, alone) = r.render_seen(&scene(vec![behind.clone()], clear())).unwrap();
        let (_, through) = r.render_seen(&scene(vec![behind.clone(), pane("glass")], clear())).unwrap();
        // Equal on CPU drivers; multisampled edges may differ by a pixel or two.
        assert!(through[0].pixels.abs_diff(alone[0].pixels) <= alone[0].pixels / 50, "{through:?} vs {alone:?}");
        assert!(through[1].pixels > 1000, "the pane is seen around the box: {through:?}");
        assert!(through[0].contrast > 0.05, "{through:?}");
        // The same pane opaque hides it.
        let (_, wall) = r.render_seen(&scene(vec![behind, pane("matte")], clear())).unwrap();
        assert_eq!(wall[0].pixels, 0, "{wall:?}");
    }

    #[test]
    fn fog_lowers_the_contrast_measure_with_distance() {
        let r = renderer();
        let contrast = |d, env| r.render_seen(&scene(vec![red_box(d)], env)).unwrap().1[0].contrast;
        let fog = || weather(60.0, 0.0, 0.0, 70.0, 60.0);
        let (near, mid, far) = (contrast(8.0, fog()), contrast(20.0, fog()), contrast(40.0, fog()));
        assert!(near > mid && mid > far, "fog: near {near}, mid {mid}, far {far}");
        let clear_far = contrast(40.0, clear());
        assert!(far < clear_far * 0.6, "fog {far} vs clear {clear_far} at 40 m");
        // Rain and darkness lower it too.
        let rain = contrast(20.0, weather(90.0, 90.0, 80.0, 0.0, 60.0));
        let night = contrast(20.0, weather(10.0, 0.0, 0.0, 0.0, -30.0));
        let clear_mid = contrast(20.0, clear());
        assert!(rain < clear_mid, "rain {rain} vs clear {clear_mid}");
        assert!(night < clear_mid * 0.5, "night {night} vs clear {clear_mid}");
    }

    /// Mean sRGB level of the pixels in a box.
    fn mean_level(img: &RgbaImage, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> f64 {
        let px: Vec<f64> = (y0..=y1)
            .flat_map(|y| (x0..=x1).map(move |x| (x, y)))
            .map(|(x, y)| img.get_pixel(x, y).0[..3].iter().map(|&c| f64::from(c)).sum::<f64>() / 3.0)
            .collect();
        px.iter().sum::<f64>() / px.len() as f64
    }

    /// A part of material `light` lights what stands near it at night; the same part as
    /// `emissive` glows but lights nothing.
    #[test]
    fn a_light_part_lights_the_scene_around_it() {
        let r = renderer();
        let night = weather(0.0, 0.0, 0.0, 0.0, -30.0);
        let lit = |material: &str| {
            let mut s = scene(vec![red_box(10.0)], night.clone());
            s.stage.push(part(Primitive::Box, [1.2, 0.6, 0.04], [8.5, 0.0, 3.0], 0xfff6e0, material));
            let img = r.render_rgba(&s).unwrap();
            mean_level(&img, screen_box(&s, [9.5, -0.5, 0.0], [10.5, 0.5, 1.0]))
        };
        let (lamp, glow) = (lit("light"), lit("emissive"));
        assert!(lamp > glow * 2.0 && lamp > 40.0, "box under a lamp {lamp:.1}, under a glowing panel {glow:.1}");
    }

    /// A glossy floor shows the lamp's reflection where a mirror would, a matte one does not;
    /// a mirror part reflects more of the lit room than a matte part of the same colour.
    #[test]
    fn a_glossy_floor_mirrors_the_lamp_and_a_mirror_reflects() {
        let r = renderer();
        let night = weather(0.0, 0.0, 0.0, 0.0, -30.0);
        let floor = |material: &str| {
            let mut s = scene(Vec::new(), night.clone());
            s.stage = vec![
                part(Primitive::Plane, [60.0, 20.0, 0.0], [20.0, 0.0, 0.0], 0x707070, material),
                part(Primitive::Box, [1.2, 0.6, 0.04], [12.0, 0.0, 3.0], 0xfff6e0, "light"),
                part(
                    Primitive::Sphere,
                    [1.0, 1.0, 1.0],
                    [9.0, 3.0, 1.5],
                    0x808080,
                    if material == "glossy" { "mirror" } else { "matte" },
                ),
            ];
            let img = r.render_rgba(&s).unwrap();
            // Where the floor mirrors the lamp: the lamp's image below the floor.
            let (xy, _) = project(&s.camera, 640, 360, [12.0, 0.0, -3.0]).unwrap();
            let (x, y) = (xy[0].round() as u32, xy[1].round() as u32);
            let spot = mean_level(&img, (x - 2, y - 2, x + 2, y + 2));
            let ball = mean_level(&img, screen_box(&s, [8.8, 2.8, 1.3], [9.2, 3.2, 1.7]));
            (spot, ball)
        };
        let ((glossy, mirror), (matte, plain)) = (floor("glossy"), floor("matte"));
        assert!(glossy > matte + 40.0, "the lamp's reflection: glossy {glossy:.1}, matte {matte:.1}");
        assert!(mirror > plain + 20.0, "mirror ball {mirror:.1}, matte ball {plain:.1}");
    }

    #[test]
    fn red_and_green_lights_differ_at_the_lamp() {
        let r = renderer();
        let lamp = |green| {
            let s = scene(vec![traffic_light(15.0, green)], clear());
            let img = r.render_rgba(&s).unwrap();
            let z = if green { 4.1 } else { 4.7 };
            let (xy, _) = project(&s.camera, 640, 360, [15.0 - 0.16, -3.0, z]).unwrap();
            let p = img.get_pixel(xy[0].round() as u32, xy[1].round() as u32).0;
            (p[0] as i32, p[1] as i32)
        };
        let ((rr, rg), (gr, gg)) = (lamp(false), lamp(true));
        assert!(rr > 200 && rr > rg + 100, "red lamp pixel r={rr} g={rg}");
        assert!(gg > 200 && gg > gr + 100, "green lamp pixel r={gr} g={gg}");
    }

    #[test]
    fn rendering_is_deterministic_and_safe_to_call_concurrently() {
        let r = renderer();
        let s = scene(vec![pedestrian(8.0, 0.5), traffic_light(20.0, true)], weather(90.0, 90.0, 80.0, 10.0, 60.0));
        let first = r.render_png(&s).unwrap();
        let others: Vec<Vec<u8>> = std::thread::scope(|sc| {
            let hs: Vec<_> = (0..3).map(|_| sc.spawn(|| r.render_png(&s).unwrap())).collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert!(others.iter().all(|o| *o == first), "same scene, same bytes");
        let mut reseeded = s.clone();
        reseeded.seed += 1;
        assert_ne!(r.render_png(&reseeded).unwrap(), first, "the rain pattern follows the seed");
    }

    #[test]
    fn rain_darkens_the_scene_and_draws_streaks() {
        let r = renderer();
        let mean = |img: &RgbaImage| img.pixels().map(|p| p.0[..3].iter().map(|&c| c as u64).sum::<u64>()).sum::<u64>();
        let dry = r.render_rgba(&scene(vec![], clear())).unwrap();
        let wet = r.render_rgba(&scene(vec![], weather(100.0, 100.0, 90.0, 7.0, 75.0))).unwrap();
        assert!(mean(&wet) < mean(&dry), "rain is darker");
        // Streaks: bright thin verticals in the sky, which is otherwise smooth.
        let streaks = |img: &RgbaImage| {
            (10..120)
                .flat_map(|y| (1..639).map(move |x| (x, y)))
                .filter(|&(x, y)| {
                    let [a, b, c] = [x - 1, x, x + 1].map(|x| img.get_pixel(x, y).0[1] as i32);
                    b - a > 4 && b - c > 4
                })
                .count()
        };
        let (wet_streaks, dry_streaks) = (streaks(&wet), streaks(&dry));
        assert!(wet_streaks > 50 && dry_streaks == 0, "streak pixels: wet {wet_streaks}, dry {dry_streaks}");
    }

    #[test]
    fn size_override_and_bad_sizes() {
        let r = BuiltinRenderer::new(Some((160, 90))).unwrap();
        assert_eq!(r.render_rgba(&scene(vec![], clear())).unwrap().dimensions(), (160, 90));
        assert_eq!(r.id(), "builtin@160x90");
        assert!(BuiltinRenderer::new(Some((0, 90))).unwrap_err().message.contains("`0x90` is out of range"));
    }

    /// Golden image of the fixture street. Backends differ in a few edge pixels, so the check
    /// allows 1% of pixels off by more than 12 levels. `REVELIO_BLESS=1` rewrites it.
    #[test]
    fn matches_the_golden_street() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/street.png");
        let s = scene(vec![pedestrian(8.0, 0.0), red_box(20.0), traffic_light(25.0, false)], clear());
        let img = renderer().render_rgba(&s).unwrap();
        if std::env::var_os("REVELIO_BLESS").is_some() {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            img.save(&path).unwrap();
        }
        let golden = image::open(&path).expect("tests/golden/street.png (REVELIO_BLESS=1 writes it)").to_rgba8();
        assert_eq!(golden.dimensions(), img.dimensions());
        let off = img
            .pixels()
            .zip(golden.pixels())
            .filter(|(a, b)| a.0.iter().zip(b.0).any(|(x, y)| x.abs_diff(y) > 12))
            .count();
        assert!(off * 100 < (img.width() * img.height()) as usize, "{off} pixels differ from the golden image");
    }

    #[test]
    fn dump_for_review() {
        // Writes the fixture scenes for a person to look at when REVELIO_RENDER_DUMP is set.
        let Ok(dir) = std::env::var("REVELIO_RENDER_DUMP") else { return };
        let r = renderer();
        for (name, env) in [
            ("clear", clear()),
            ("rain", weather(90.0, 90.0, 80.0, 10.0, 60.0)),
            ("fog", weather(60.0, 0.0, 0.0, 60.0, 40.0)),
            ("night", weather(10.0, 0.0, 0.0, 0.0, -20.0)),
        ] {
            let s = scene(vec![pedestrian(8.0, 0.0), red_box(20.0), traffic_light(25.0, false)], env);
            r.render_rgba(&s).unwrap().save(std::path::Path::new(&dir).join(format!("{name}.png"))).unwrap();
        }
    }

    /// The scene cache gives back what a drawing gives (the same PNG and figures), only for the
    /// same scene and size; an entry that does not read back is drawn again and replaced; the
    /// least recently used entries go first when it outgrows its cap.
    #[test]
    fn the_scene_cache_gives_back_only_what_the_same_drawing_gives() {
        let dir = tempfile::tempdir().unwrap();
        let cached = renderer().with_cache(Some(dir.path()));
        let s = scene(vec![red_box(12.0), pedestrian(8.0, 1.0)], clear());
        let drawn = renderer().render_encoded(&s).unwrap();
        assert!(!drawn.2);
        let first = cached.render_encoded(&s).unwrap();
        assert_eq!((&first.0, &first.1, first.2), (&drawn.0, &drawn.1, false));
        let again = cached.render_encoded(&s).unwrap();
        assert_eq!((&again.0, &again.1, again.2), (&drawn.0, &drawn.1, true));
        let (img, seen) = cached.render_seen(&s).unwrap();
        assert_eq!((img, &seen), (renderer().render_seen(&s).unwrap().0, &drawn.1));
        assert_eq!(cached.render_visibility(&s).unwrap(), seen);
        assert_eq!(renderer().render_visibility(&s).unwrap(), seen);
        // Another scene, or the same at another size, is drawn.
        let other = scene(vec![red_box(13.0)], clear());
        assert!(!cached.render_encoded(&other).unwrap().2);
        let small = BuiltinRenderer::new(Some((320, 180))).unwrap().with_cache(Some(dir.path()));
        let (png, _, hit) = small.render_encoded(&s).unwrap();
        assert!(!hit);
        assert_eq!(image::load_from_memory(&png).unwrap().width(), 320);
        // A damaged entry is drawn again and replaced.
        let entries: Vec<_> = walk(&dir.path().join("builtin"));
        assert_eq!(entries.len(), 3, "{entries:?}");
        for e in &entries {
            std::fs::write(e, b"[]\nnot a png").unwrap();
        }
        let redrawn = cached.render_encoded(&s).unwrap();
        assert_eq!((&redrawn.0, redrawn.2), (&drawn.0, false));
        assert!(cached.render_encoded(&s).unwrap().2);
        assert!(!cached.render_encoded(&other).unwrap().2 && !small.render_encoded(&s).unwrap().2);
        // Past the cap, the least recently used go.
        let store = crate::net::cache::Store::new(dir.path().join("builtin"), "scene");
        let total: u64 = walk(&dir.path().join("builtin")).iter().map(|p| p.metadata().unwrap().len()).sum();
        let old = std::time::SystemTime::now() - std::time::Duration::from_secs(3600);
        for e in walk(&dir.path().join("builtin")) {
            std::fs::File::options().write(true).open(&e).unwrap().set_modified(old).unwrap();
        }
        assert!(cached.render_encoded(&s).unwrap().2, "a hit marks its entry used");
        assert!(store.prune(total - 1) > 0);
        let left: u64 = walk(&dir.path().join("builtin")).iter().map(|p| p.metadata().unwrap().len()).sum();
        assert!(left <= (total - 1) / 4 * 3, "{left} of {total} bytes left");
        assert!(cached.render_encoded(&s).unwrap().2, "the entry used last is kept");
        assert_eq!(store.prune(u64::MAX), 0);
    }

    fn walk(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
        let mut out = Vec::new();
        for d in std::fs::read_dir(dir).unwrap().flatten() {
            out.extend(std::fs::read_dir(d.path()).unwrap().flatten().map(|f| f.path()));
        }
        out.sort();
        out
    }
}

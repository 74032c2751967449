//! Visibility figures of one frame: for each entity the concepts placed, how many pixels of it
//! are seen after occlusion, and how much it stands out from what surrounds it. Computed from
//! the colour image and the entity-id target drawn in the same passes (see `gpu::Drawn`).

use super::EntityVisibility;
use crate::scene::Scene;

/// How far an id read back may be from an entity's id and still be that entity: on a CPU
/// driver (no multisampling) ids are exact; with multisampling an edge pixel averages two ids
/// and is counted for neither, unless the average happens to land on a third id (rare, and
/// only on one-pixel edges).
const ID_TOLERANCE: f32 = 0.02;

/// An sRGB-encoded pixel as 0..1 components: contrast is judged on the image the model
/// receives, not in linear light.
fn rgb(px: &[u8]) -> [f64; 3] {
    [0, 1, 2].map(|c| f64::from(px[c]) / 255.0)
}

/// Colour distance scaled to 0..1 (black to white is 1). Colour, not luma: a red box on grey
/// tarmac of the same brightness is plainly seen.
fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>() / 3.0).sqrt()
}

/// The figures for every entity of `scene.entities`, in order. `pixels` is RGBA8 rows and `ids`
/// one id per pixel, both `w`×`h`.
///
/// The contrast is the root-mean-square colour distance between the entity's visible pixels
/// and the mean colour of its surround: the pixels around its screen bounding box
/// (widened by a quarter of its size on each side, at least 3 pixels) where no entity is seen.
/// It is absolute, not relative: fog and rain pull both towards the same grey, and darkness
/// scales both down, so all three lower it; a lit lamp at night keeps it high.
pub fn measure(scene: &Scene, pixels: &[u8], ids: &[f32], w: u32, h: u32) -> Vec<EntityVisibility> {
    let n = scene.entities.len();
    // Per entity: visible pixel count, screen bounds.
    let mut count = vec![0u32; n];
    let mut bounds = vec![(u32::MAX, u32::MAX, 0u32, 0u32); n];
    let id_at = |i: usize| -> Option<usize> {
        let v = ids[i];
        let k = v.round();
        (k >= 1.0 && (v - k).abs() <= ID_TOLERANCE && (k as usize) <= n).then(|| k as usize - 1)
    };
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if let Some(e) = id_at(i) {
                count[e] += 1;
                let b = &mut bounds[e];
                *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
            }
        }
    }
    scene
        .entities
        .iter()
        .enumerate()
        .map(|(e, entity)| {
            let contrast = if count[e] == 0 {
                0.0
            } else {
                let (x0, y0, x1, y1) = bounds[e];
                let mx = ((x1 - x0 + 1) / 4).max(3);
                let my = ((y1 - y0 + 1) / 4).max(3);
                let (sx0, sy0) = (x0.saturating_sub(mx), y0.saturating_sub(my));
                let (sx1, sy1) = ((x1 + mx).min(w - 1), (y1 + my).min(h - 1));
                let add = |acc: [f64; 3], px: &[u8]| {
                    let c = rgb(px);
                    [acc[0] + c[0], acc[1] + c[1], acc[2] + c[2]]
                };
                let (mut sum, mut m) = ([0.0; 3], 0u32);
                for y in sy0..=sy1 {
                    for x in sx0..=sx1 {
                        let i = (y * w + x) as usize;
                        if ids[i] == 0.0 {
                            sum = add(sum, &pixels[i * 4..i * 4 + 4]);
                            m += 1;
                        }
                    }
                }
                // Nothing around it (it fills its surround): compare with the whole frame.
                if m == 0 {
                    sum = pixels.chunks_exact(4).fold([0.0; 3], add);
                    m = w * h;
                }
                let surround = sum.map(|c| c / f64::from(m));
                let mut sq = 0.0;
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let i = (y * w + x) as usize;
                        if id_at(i) == Some(e) {
                            sq += distance(rgb(&pixels[i * 4..i * 4 + 4]), surround).powi(2);
                        }
                    }
                }
                (sq / f64::from(count[e])).sqrt()
            };
            EntityVisibility {
                entity: entity.name.clone(),
                concept: entity.concept.clone(),
                pixels: count[e],
                // Three decimals: journals stay readable and byte-stable across platforms.
                contrast: (contrast * 1000.0).round() / 1000.0,
            }
        })
        .collect()
}

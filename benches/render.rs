//! Builtin renderer throughput: images per second for a busy driving scene (640×360, hard
//! rain, junction, two agents) and a kitchen scene (640×480, fire), as pixels (render +
//! readback) and as PNG (render + readback + encoding), from one caller and from four at once.
//! The adapter is printed first; pick the backend with `WGPU_BACKEND=vulkan` (lavapipe) or
//! `WGPU_BACKEND=gl` (llvmpipe).
//!
//! The scenes are `revelio emit scene` outputs of the stdlib domains, stored as JSON so the
//! benchmark measures the renderer alone.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use revelio::render::{BuiltinRenderer, encode_png};
use revelio::scene::Scene;

fn scene(name: &str) -> Scene {
    let path = format!("{}/benches/render/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read `{path}`: {e}"));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("`{path}` is not a scene: {e}"))
}

fn bench(c: &mut Criterion) {
    let r = BuiltinRenderer::new(None).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("adapter: {}", r.adapter());
    let mut g = c.benchmark_group("render");
    g.throughput(Throughput::Elements(1));
    for name in ["driving", "kitchen"] {
        let s = scene(name);
        let (w, h) = r.size_for(&s);
        g.bench_function(format!("{name}_{w}x{h}_rgba"), |b| b.iter(|| black_box(r.render_rgba(&s).unwrap())));
        g.bench_function(format!("{name}_{w}x{h}_png"), |b| b.iter(|| black_box(r.render_png(&s).unwrap())));
        g.bench_function(format!("{name}_mesh_only"), |b| {
            b.iter(|| black_box(revelio::render::mesh::build(&s, s.camera.at)))
        });
        let img = r.render_rgba(&s).unwrap();
        g.bench_function(format!("{name}_{w}x{h}_png_encode_only"), |b| {
            b.iter(|| black_box(encode_png(&img).unwrap()))
        });
    }
    // The same street in clear weather: what rain and fog add.
    let mut clear = scene("driving");
    clear.environment.clear();
    g.bench_function("driving_640x360_clear_rgba", |b| b.iter(|| black_box(r.render_rgba(&clear).unwrap())));
    // A quarter of the pixels: how much of the frame is per-pixel work.
    let small = BuiltinRenderer::new(Some((320, 180))).unwrap_or_else(|e| panic!("{e}"));
    let driving = scene("driving");
    g.bench_function("driving_320x180_rgba", |b| b.iter(|| black_box(small.render_rgba(&driving).unwrap())));
    // Four callers at once, as a search's concurrent observations render: one frame's
    // tessellation and PNG encoding overlap another's rasterisation (a frame holds the device
    // from upload to readback).
    g.bench_function("driving_640x360_png_4_callers", |b| {
        b.iter_custom(|iters| {
            let start = std::time::Instant::now();
            std::thread::scope(|s| {
                for k in 0..4 {
                    let (r, d) = (&r, &driving);
                    s.spawn(move || {
                        for _ in (k..iters).step_by(4) {
                            black_box(r.render_png(d).unwrap());
                        }
                    });
                }
            });
            start.elapsed()
        })
    });
    // The fixed cost of a frame: sky only, no geometry.
    let mut empty = scene("driving");
    (empty.stage, empty.entities, empty.extras) = (Vec::new(), Vec::new(), Vec::new());
    empty.environment.clear();
    g.bench_function("empty_640x360_rgba", |b| b.iter(|| black_box(r.render_rgba(&empty).unwrap())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

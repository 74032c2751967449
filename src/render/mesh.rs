//! Scene → triangle list. Every look is made of the six `.rev` primitives, tessellated here on
//! the CPU into one vertex list per frame (a scene has a few hundred parts, so re-tessellating is
//! cheaper than managing per-part GPU buffers and keeps the output deterministic).

use bytemuck::{Pod, Zeroable};

use crate::ir::{Primitive, ShapePart};
use crate::scene::Scene;

/// Segments around a round primitive: enough for smooth silhouettes at 640×360.
const ROUND_SEGMENTS: usize = 16;
/// Fewest segments, for parts a few pixels across.
const MIN_SEGMENTS: usize = 6;
/// Most latitude bands of a sphere (a capsule cap gets half).
const SPHERE_BANDS: usize = 8;

/// Shading model of a part, as the fragment shader reads it (`Vertex::material`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Material {
    Matte = 0,
    Metal = 1,
    Glass = 2,
    Emissive = 3,
    Water = 4,
    Flame = 5,
    Smoke = 6,
    /// The blob shadow under an entity (not writable from `.rev`).
    Shadow = 7,
    /// A lamp: drawn like `Emissive`, and a light of the frame (`Mesh::lights`).
    Light = 8,
    /// A polished or wet floor: dark, with sharp reflections of the lamps.
    Glossy = 9,
    Mirror = 10,
}

impl Material {
    /// Unknown hints fall back to matte: the checker validates names, and a renderer must not
    /// fail a whole search over a look detail.
    pub fn from_hint(hint: &str) -> Material {
        match hint {
            "metal" => Material::Metal,
            "glass" => Material::Glass,
            "emissive" => Material::Emissive,
            "water" => Material::Water,
            "flame" => Material::Flame,
            "smoke" => Material::Smoke,
            "light" => Material::Light,
            "glossy" => Material::Glossy,
            "mirror" => Material::Mirror,
            _ => Material::Matte,
        }
    }

    /// Alpha used when a translucent material's colour is written fully opaque.
    fn default_alpha(self) -> Option<f32> {
        match self {
            Material::Glass => Some(0.35),
            Material::Smoke => Some(0.55),
            Material::Flame => Some(0.85),
            Material::Water => Some(0.8),
            _ => None,
        }
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Vertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
    /// Linear-light colour and alpha.
    pub color: [f32; 4],
    pub material: f32,
    /// 1 + the index in `Scene.entities` of the entity this vertex belongs to; 0 for stage
    /// parts, extras and shadows. Drawn into the id target for the visibility figures.
    pub entity: f32,
}

/// The frame's geometry as an indexed triangle list: opaque triangles first (front to back, so
/// that hidden pixels are rejected by the depth test before shading), then translucent ones
/// back to front. Indexing matters on CPU rasterisers, whose vertex stage is single-threaded:
/// a smooth sphere shares each vertex between six triangles.
///
/// Every triangle is wound counter-clockwise seen from the side its normal points to, so the
/// back faces of closed parts (boxes, cylinders, cones, spheres, capsules seen from outside) can
/// be dropped: on a CPU rasteriser that halves the triangles set up and rejected. Translucent
/// closed parts drop theirs too, so a glass or smoke volume is not blended twice in an
/// unsorted order.
#[derive(Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
    /// `indices[..opaque_len]` are drawn with depth writes, the rest blended.
    pub opaque_len: u32,
    /// The parts of material `light`, nearest the camera first, at most [`MAX_LIGHTS`].
    pub lights: Vec<Light>,
}

/// Most lamps that light one frame (the shader's uniform arrays hold this many).
pub const MAX_LIGHTS: usize = 8;

/// A lamp of the frame: a part of material `light`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Its centre in the scene frame.
    pub at: [f32; 3],
    /// Linear-light colour.
    pub color: [f32; 3],
    /// Strength: grows with the square root of its largest face (a 1.2 × 0.6 m panel is 1.7).
    pub strength: f32,
}

/// The multiply-rotate hash of rustc (FxHash): vertex keys are a few words, and SipHash's DoS
/// resistance buys nothing here, while its cost showed in the frame time.
#[derive(Default)]
struct FxHasher(u64);

impl std::hash::Hasher for FxHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(w));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

/// Appends one part's triangles, sharing vertices with equal local position and normal.
struct PartWriter<'a> {
    mesh: &'a mut Mesh,
    xf: &'a Xf,
    /// The camera in the part's frame, for a closed part whose back faces are dropped.
    cull_from: Option<[f64; 3]>,
    color: [f32; 4],
    material: Material,
    entity: f32,
    seen: std::collections::HashMap<[u64; 6], u32, std::hash::BuildHasherDefault<FxHasher>>,
}

impl PartWriter<'_> {
    fn index(&mut self, p: [f64; 3], n: [f64; 3]) -> u32 {
        let key = [p[0].to_bits(), p[1].to_bits(), p[2].to_bits(), n[0].to_bits(), n[1].to_bits(), n[2].to_bits()];
        if let Some(&i) = self.seen.get(&key) {
            return i;
        }
        let i = self.mesh.vertices.len() as u32;
        self.mesh.vertices.push(vertex(self.xf, p, n, self.color, self.material, self.entity));
        self.seen.insert(key, i);
        i
    }
    /// One triangle, wound counter-clockwise around the mean of its vertex normals (outwards),
    /// whatever order the tessellator produced; dropped when it faces away from `cull_from`.
    fn tri(&mut self, a: ([f64; 3], [f64; 3]), b: ([f64; 3], [f64; 3]), c: ([f64; 3], [f64; 3])) {
        let (u, v) = (sub(b.0, a.0), sub(c.0, a.0));
        let mut face = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
        let n = [a.1[0] + b.1[0] + c.1[0], a.1[1] + b.1[1] + c.1[1], a.1[2] + b.1[2] + c.1[2]];
        let (b, c) = if dot(face, n) < 0.0 {
            face = face.map(|x| -x);
            (c, b)
        } else {
            (b, c)
        };
        if let Some(eye) = self.cull_from
            && dot(face, sub(eye, a.0)) <= 0.0
        {
            return;
        }
        let ids = [self.index(a.0, a.1), self.index(b.0, b.1), self.index(c.0, c.1)];
        self.mesh.indices.extend(ids);
    }
}

/// A rigid transform: rotation (row-major 3×3) then translation.
#[derive(Debug, Clone, Copy)]
struct Xf {
    r: [[f64; 3]; 3],
    t: [f64; 3],
}

impl Xf {
    fn identity() -> Xf {
        Xf { r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], t: [0.0; 3] }
    }
    fn yaw(deg: f64, t: [f64; 3]) -> Xf {
        let (s, c) = deg.to_radians().sin_cos();
        Xf { r: [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], t }
    }
    /// A part's rotation (docs/language.md, "Shape parts"; [`crate::ir::rotation`]):
    /// R = Rz(yaw) · Ry(pitch) · Rx(roll), so a point is rolled about x, then pitched about y,
    /// then yawed about z, all about the part's own centre. Positive pitch tilts the part's top
    /// towards +x (forward).
    fn yaw_pitch_roll(yaw: f64, pitch: f64, roll: f64, t: [f64; 3]) -> Xf {
        Xf { r: crate::ir::rotation(yaw, pitch, roll), t }
    }
    fn rot(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.r;
        [
            r[0][0] * v[0] + r[0][1] * v[1] + r[0][2] * v[2],
            r[1][0] * v[0] + r[1][1] * v[1] + r[1][2] * v[2],
            r[2][0] * v[0] + r[2][1] * v[1] + r[2][2] * v[2],
        ]
    }
    fn point(&self, v: [f64; 3]) -> [f64; 3] {
        let p = self.rot(v);
        [p[0] + self.t[0], p[1] + self.t[1], p[2] + self.t[2]]
    }
    /// `self ∘ inner`: apply `inner` first.
    fn then(&self, inner: &Xf) -> Xf {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, cell) in row.iter_mut().enumerate() {
                *cell = (0..3).map(|k| self.r[i][k] * inner.r[k][j]).sum();
            }
        }
        Xf { r, t: self.point(inner.t) }
    }
}

/// sRGB component → linear light.
pub fn srgb_to_linear(c: f64) -> f32 {
    let c = c.clamp(0.0, 1.0);
    (if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }) as f32
}

/// One part placed in the scene, before tessellation.
struct Placed<'a> {
    part: &'a ShapePart,
    xf: Xf,
    /// `Vertex::entity` of the part.
    entity: f32,
}

/// Build the frame's triangles. `eye` orders translucent parts back to front.
pub fn build(scene: &Scene, eye: [f64; 3]) -> Mesh {
    // A stage part that stands for an entity (`drawn_by`) carries the entity's id, so the
    // visibility figures measure it as that entity.
    let mut stage_ids = vec![0.0f32; scene.stage.len()];
    for (i, e) in scene.entities.iter().enumerate() {
        for &p in e.drawn_by.iter().flat_map(|s| &s.parts) {
            if let Some(id) = stage_ids.get_mut(p as usize) {
                *id = (i + 1) as f32;
            }
        }
    }
    let mut placed: Vec<Placed> = scene
        .stage
        .iter()
        .zip(stage_ids)
        .map(|(part, entity)| Placed { part, xf: part_xf(&Xf::identity(), part), entity })
        .collect();
    let mut shadows = Vec::new();
    let ids = (1..=scene.entities.len()).map(|i| i as f32).chain(std::iter::repeat(0.0));
    for (e, entity) in scene.entities.iter().chain(&scene.extras).zip(ids) {
        let exf = Xf::yaw(e.yaw_deg, e.position);
        placed.extend(e.shape.iter().map(|part| Placed { part, xf: part_xf(&exf, part), entity }));
        if let Some(s) = blob_shadow(&e.shape, &exf) {
            shadows.push(s);
        }
    }
    let mut lights: Vec<(f64, Light)> = placed
        .iter()
        .filter(|p| Material::from_hint(&p.part.material) == Material::Light)
        .map(|p| {
            let [sx, sy, sz] = p.part.size;
            let face = (sx * sy).max(sy * sz).max(sx * sz);
            let c = p.part.color;
            let light = Light {
                at: p.xf.t.map(|x| x as f32),
                color: [srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2])],
                strength: (2.4 * face.sqrt()).clamp(0.3, 6.0) as f32,
            };
            (dist2(p.xf.t, eye), light)
        })
        .collect();
    lights.sort_by(|a, b| a.0.total_cmp(&b.0));
    let lights: Vec<Light> = lights.into_iter().take(MAX_LIGHTS).map(|(_, l)| l).collect();
    let (mut opaque, mut translucent): (Vec<_>, Vec<_>) =
        placed.into_iter().partition(|p| part_alpha(p.part, Material::from_hint(&p.part.material)) >= 1.0);
    // Stable sorts by centre distance keep equal distances in source order, so the output
    // bytes depend on nothing but the scene. Opaque parts go near to far, except huge ones
    // (ground, road) whose centre says little about what they cover: those go last.
    let key = |p: &Placed| {
        let huge = p.part.size[0].max(p.part.size[1]) > 50.0;
        (huge, dist2(p.xf.t, eye))
    };
    opaque.sort_by(|a, b| {
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
    translucent.sort_by(|a, b| dist2(b.xf.t, eye).total_cmp(&dist2(a.xf.t, eye)));

    // Closed parts before open ones (planes: floors, roads, markings, which solids stand on
    // and cover), so that covered plane pixels fail the depth test instead of being shaded.
    let (closed, open): (Vec<_>, Vec<_>) = opaque.into_iter().partition(|p| is_closed(p, eye));
    let mut mesh = Mesh::default();
    for (p, closed) in closed.iter().map(|p| (p, true)).chain(open.iter().map(|p| (p, false))) {
        emit_part(&mut mesh, p, eye, closed);
    }
    mesh.opaque_len = mesh.indices.len() as u32;
    mesh.lights = lights;
    // Shadows lie on the ground under everything translucent, so they go first.
    for s in &shadows {
        emit_shadow(&mut mesh, s);
    }
    for p in &translucent {
        emit_part(&mut mesh, p, eye, is_closed(p, eye));
    }
    mesh
}

/// A part whose back faces can never be seen: a closed primitive with the camera outside it
/// (checked against its bounding sphere, so a room built as a box around the camera stays
/// two-sided).
fn is_closed(p: &Placed, eye: [f64; 3]) -> bool {
    if p.part.prim == Primitive::Plane {
        return false;
    }
    let [sx, sy, sz] = p.part.size;
    let sy = if sy > 0.0 { sy } else { sx };
    let radius = (sx * sx + sy * sy + sz * sz).sqrt() / 2.0;
    dist2(p.xf.t, eye) > radius * radius
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dist2(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).powi(2)).sum()
}

fn part_xf(parent: &Xf, part: &ShapePart) -> Xf {
    parent.then(&Xf::yaw_pitch_roll(part.yaw_deg, part.pitch_deg, part.roll_deg, part.at))
}

fn part_alpha(part: &ShapePart, material: Material) -> f32 {
    let a = part.color[3].clamp(0.0, 1.0) as f32;
    match material.default_alpha() {
        Some(d) if a >= 1.0 => d,
        _ => a,
    }
}

/// A dark ellipse on the ground under an entity's footprint: the cheapest cue that tells a
/// viewer where an object stands (and so how far away it is).
struct Shadow {
    xf: Xf,
    half: [f64; 2],
}

fn blob_shadow(parts: &[ShapePart], exf: &Xf) -> Option<Shadow> {
    let solid = parts.iter().filter(|p| {
        !matches!(
            Material::from_hint(&p.material),
            Material::Emissive | Material::Smoke | Material::Flame | Material::Light
        ) && p.prim != Primitive::Plane
            && p.shadow
    });
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in solid {
        // Yawed parts are bounded by their circumscribed square.
        let r = if p.yaw_deg.rem_euclid(180.0) == 0.0 {
            [p.size[0] / 2.0, p.size[1] / 2.0]
        } else {
            let m = p.size[0].hypot(p.size[1]) / 2.0;
            [m, m]
        };
        for i in 0..2 {
            lo[i] = lo[i].min(p.at[i] - r[i]);
            hi[i] = hi[i].max(p.at[i] + r[i]);
        }
    }
    if !lo[0].is_finite() {
        return None;
    }
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0, 0.02];
    Some(Shadow {
        xf: exf.then(&Xf::yaw(0.0, centre)),
        half: [(hi[0] - lo[0]) * 0.5 + 0.15, (hi[1] - lo[1]) * 0.5 + 0.15],
    })
}

fn emit_shadow(mesh: &mut Mesh, s: &Shadow) {
    // A fan whose rim is transparent gives a soft edge without a texture.
    let centre = mesh.vertices.len() as u32;
    mesh.vertices.push(vertex(&s.xf, [0.0; 3], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.55], Material::Shadow, 0.0));
    for k in 0..ROUND_SEGMENTS {
        let a = k as f64 / ROUND_SEGMENTS as f64 * std::f64::consts::TAU;
        let rim = [a.cos() * s.half[0], a.sin() * s.half[1], 0.0];
        mesh.vertices.push(vertex(&s.xf, rim, [0.0, 0.0, 1.0], [0.0; 4], Material::Shadow, 0.0));
    }
    for k in 0..ROUND_SEGMENTS as u32 {
        mesh.indices.extend([centre, centre + 1 + k, centre + 1 + (k + 1) % ROUND_SEGMENTS as u32]);
    }
}

fn vertex(xf: &Xf, p: [f64; 3], n: [f64; 3], color: [f32; 4], m: Material, entity: f32) -> Vertex {
    let pos = xf.point(p);
    let nr = xf.rot(n);
    Vertex {
        pos: [pos[0] as f32, pos[1] as f32, pos[2] as f32],
        normal: [nr[0] as f32, nr[1] as f32, nr[2] as f32],
        color,
        material: m as u32 as f32,
        entity,
    }
}

/// Level of detail of a round part: `(segments around, bands per quarter circle)`, from its
/// angular size seen from `eye`. Far heads and wheels need few triangles, and the triangle
/// count is what a CPU rasteriser pays for; the choice depends only on the scene.
fn detail(p: &Placed, eye: [f64; 3]) -> (usize, usize) {
    let size = p.part.size.iter().fold(0.0f64, |m, s| m.max(*s));
    let angle = size / dist2(p.xf.t, eye).sqrt().max(1e-3);
    let segments = ((angle * 80.0).round() as usize).clamp(MIN_SEGMENTS, ROUND_SEGMENTS);
    (segments, (segments / 2).clamp(3, SPHERE_BANDS))
}

/// `closed`: [`is_closed`] holds, so back faces are dropped.
fn emit_part(mesh: &mut Mesh, p: &Placed, eye: [f64; 3], closed: bool) {
    let (segs, bands) = detail(p, eye);
    let part = p.part;
    let m = Material::from_hint(&part.material);
    let c = part.color;
    let color = [srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]), part_alpha(part, m)];
    let [sx, sy, sz] = part.size;
    // A round primitive written with y = 0 is round: x is its diameter.
    let sy_round = if sy > 0.0 { sy } else { sx };
    // The camera in the part frame: the inverse of a rotation is its transpose.
    let cull_from = closed.then(|| {
        let d = sub(eye, p.xf.t);
        let r = &p.xf.r;
        [0, 1, 2].map(|j| r[0][j] * d[0] + r[1][j] * d[1] + r[2][j] * d[2])
    });
    let mut w =
        PartWriter { mesh, xf: &p.xf, cull_from, color, material: m, entity: p.entity, seen: Default::default() };
    let mut tri = |a, b, c| w.tri(a, b, c);
    match part.prim {
        Primitive::Box => unit_box(&mut tri, [sx, sy, sz]),
        Primitive::Plane => {
            let (hx, hy) = (sx / 2.0, sy / 2.0);
            let n = [0.0, 0.0, 1.0];
            quad(&mut tri, [[-hx, -hy, 0.0], [hx, -hy, 0.0], [hx, hy, 0.0], [-hx, hy, 0.0]], n);
        }
        Primitive::Cylinder => lathe(&mut tri, &[(0.5, -0.5), (0.5, 0.5)], [sx, sy_round, sz], true, segs),
        Primitive::Cone => lathe(&mut tri, &[(0.5, -0.5), (0.0, 0.5)], [sx, sy_round, sz], true, segs),
        Primitive::Sphere => {
            lathe(&mut tri, &sphere_profile(0.0, 0.5, -1.0, 1.0, bands), [sx, sy_round, sz], false, segs)
        }
        Primitive::Capsule => {
            // Caps keep a round radius (r = x/2) whatever the height, as a capsule should.
            let r = (sx / 2.0).min(sz / 2.0);
            let profile = sphere_profile(-sz / 2.0 + r, r, -1.0, 0.0, (bands / 2).max(2))
                .into_iter()
                .chain(sphere_profile(sz / 2.0 - r, r, 0.0, 1.0, (bands / 2).max(2)))
                .map(|(rad, z)| (rad / sx, z))
                .collect::<Vec<_>>();
            lathe(&mut tri, &profile, [sx, sy_round, 1.0], false, segs);
        }
    }
}

type Tri<'a> = dyn FnMut(([f64; 3], [f64; 3]), ([f64; 3], [f64; 3]), ([f64; 3], [f64; 3])) + 'a;

fn quad(tri: &mut Tri, v: [[f64; 3]; 4], n: [f64; 3]) {
    tri((v[0], n), (v[1], n), (v[2], n));
    tri((v[0], n), (v[2], n), (v[3], n));
}

fn unit_box(tri: &mut Tri, s: [f64; 3]) {
    let h = [s[0] / 2.0, s[1] / 2.0, s[2] / 2.0];
    for axis in 0..3 {
        for sign in [-1.0, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f64, b: f64| {
                let mut p = [0.0; 3];
                p[axis] = sign * h[axis];
                p[u] = a * h[u];
                p[v] = b * h[v];
                p
            };
            let mut n = [0.0; 3];
            n[axis] = sign;
            quad(tri, [corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)], n);
        }
    }
}

/// Points `(radius, z)` of a circle of radius `r` centred at height `zc`, from latitude `from`
/// to `to` (in quarter turns: -1 = bottom pole, 0 = equator, 1 = top pole).
fn sphere_profile(zc: f64, r: f64, from: f64, to: f64, bands: usize) -> Vec<(f64, f64)> {
    (0..=bands)
        .map(|i| {
            let lat = (from + (to - from) * i as f64 / bands as f64) * std::f64::consts::FRAC_PI_2;
            (r * lat.cos(), zc + r * lat.sin())
        })
        .collect()
}

/// Revolve a profile of `(radius, z)` points about z, scaling x, y, z by `s`. Vertex normals
/// average the adjacent profile segments, so spheres and capsules shade smoothly while a
/// cylinder's side stays straight. `caps` closes the end rings with flat discs.
fn lathe(tri: &mut Tri, profile: &[(f64, f64)], s: [f64; 3], caps: bool, segments: usize) {
    let ring = |k: usize| {
        let a = (k % segments) as f64 / segments as f64 * std::f64::consts::TAU;
        (a.cos(), a.sin())
    };
    let seg_normal = |i: usize| {
        let (dr, dz) = (profile[i + 1].0 - profile[i].0, profile[i + 1].1 - profile[i].1);
        let l = dr.hypot(dz).max(1e-12);
        (dz / l, -dr / l)
    };
    let segs = profile.len() - 1;
    let vert_normal = |i: usize, seg: usize| {
        // Within one segment of a capped lathe the normal is the segment's own (hard edges).
        if caps {
            return seg_normal(seg);
        }
        let (a, b) = (seg_normal(i.saturating_sub(1).min(segs - 1)), seg_normal(i.min(segs - 1)));
        (a.0 + b.0, a.1 + b.1)
    };
    // Normals transform by the inverse scale (non-uniformly scaled spheres are ellipsoids).
    let world_n = |(nr, nz): (f64, f64), (c, sn): (f64, f64)| normalize([nr * c / s[0], nr * sn / s[1], nz / s[2]]);
    let at = |(r, z): (f64, f64), (c, sn): (f64, f64)| [r * c * s[0], r * sn * s[1], z * s[2]];
    for i in 0..segs {
        let (n0, n1) = (vert_normal(i, i), vert_normal(i + 1, i));
        for k in 0..segments {
            let (a, b) = (ring(k), ring(k + 1));
            let v = |p: usize, n: (f64, f64), r: (f64, f64)| (at(profile[p], r), world_n(n, r));
            tri(v(i, n0, a), v(i, n0, b), v(i + 1, n1, b));
            tri(v(i, n0, a), v(i + 1, n1, b), v(i + 1, n1, a));
        }
    }
    if caps {
        for (p, nz) in [(profile[0], -1.0), (profile[segs], 1.0)] {
            if p.0 <= 0.0 {
                continue;
            }
            let (centre, n) = ([0.0, 0.0, p.1 * s[2]], [0.0, 0.0, nz]);
            for k in 0..segments {
                tri((centre, n), (at(p, ring(k)), n), (at(p, ring(k + 1)), n));
            }
        }
    }
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l < 1e-12 { [0.0, 0.0, 1.0] } else { [v[0] / l, v[1] / l, v[2] / l] }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The renderer blends exactly the materials the IR calls translucent (the sampler's view of
    /// the scene lets entities be seen through them).
    #[test]
    fn blended_materials_are_the_irs_translucent_ones() {
        for m in crate::ir::MATERIALS {
            let blended = Material::from_hint(m).default_alpha().is_some_and(|a| a < 1.0);
            assert_eq!(blended, crate::ir::TRANSLUCENT_MATERIALS.contains(m), "{m}");
        }
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
    }

    #[test]
    fn rotation_is_roll_then_pitch_then_yaw() {
        let up = [0.0, 0.0, 1.0];
        // Pitch tilts the top forward (+x), roll to the right (-y), yaw turns x towards y.
        assert!(close(Xf::yaw_pitch_roll(0.0, 90.0, 0.0, [0.0; 3]).rot(up), [1.0, 0.0, 0.0]));
        assert!(close(Xf::yaw_pitch_roll(0.0, 0.0, 90.0, [0.0; 3]).rot(up), [0.0, -1.0, 0.0]));
        assert!(close(Xf::yaw_pitch_roll(90.0, 0.0, 0.0, [0.0; 3]).rot([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        // The order: a part pitched forward and then yawed by 90° leans towards +y.
        assert!(close(Xf::yaw_pitch_roll(90.0, 90.0, 0.0, [0.0; 3]).rot(up), [0.0, 1.0, 0.0]));
        // The matrix is the product Rz · Ry · Rx of the single rotations.
        let (y, p, r) = (30.0, -20.0, 45.0);
        let z_only = Xf::yaw_pitch_roll(y, 0.0, 0.0, [0.0; 3]);
        let y_only = Xf::yaw_pitch_roll(0.0, p, 0.0, [0.0; 3]);
        let x_only = Xf::yaw_pitch_roll(0.0, 0.0, r, [0.0; 3]);
        let product = z_only.then(&y_only).then(&x_only);
        let direct = Xf::yaw_pitch_roll(y, p, r, [0.0; 3]);
        for v in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], up, [0.3, -0.7, 0.2]] {
            assert!(close(product.rot(v), direct.rot(v)));
        }
    }

    /// `shadow false` keeps a part out of its entity's blob shadow (a lamp 1.7 m up casts none
    /// on the floor), and lamps are the frame's lights, nearest first.
    #[test]
    fn shadow_false_parts_cast_no_blob_and_light_parts_are_lights() {
        let body = crate::render::fixtures::part(Primitive::Box, [0.6, 0.6, 0.6], [0.0, 0.0, 0.3], 0x808080, "matte");
        let mut lamp =
            crate::render::fixtures::part(Primitive::Box, [2.0, 2.0, 0.1], [0.0, 0.0, 1.7], 0xffffff, "matte");
        let wide = blob_shadow(&[body.clone(), lamp.clone()], &Xf::identity()).unwrap();
        lamp.shadow = false;
        let narrow = blob_shadow(&[body.clone(), lamp.clone()], &Xf::identity()).unwrap();
        assert!(
            (wide.half[0] - 1.15).abs() < 1e-9 && (narrow.half[0] - 0.45).abs() < 1e-9,
            "{:?} {:?}",
            wide.half,
            narrow.half
        );
        assert!(blob_shadow(&[lamp], &Xf::identity()).is_none());

        let mut s =
            crate::render::fixtures::scene(Vec::new(), crate::render::fixtures::weather(0.0, 0.0, 0.0, 0.0, -30.0));
        for x in [30.0, 10.0] {
            s.stage.push(crate::render::fixtures::part(
                Primitive::Box,
                [1.2, 0.6, 0.04],
                [x, 0.0, 3.0],
                0xffffff,
                "light",
            ));
        }
        let mesh = build(&s, s.camera.at);
        assert_eq!(mesh.lights.len(), 2);
        assert_eq!(mesh.lights[0].at, [10.0, 0.0, 3.0], "nearest first");
        assert!((mesh.lights[0].strength - (2.4 * 0.72f32.sqrt())).abs() < 1e-5);
    }
}

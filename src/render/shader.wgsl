// Revelio builtin renderer: one uniform block; pipelines for geometry (closed, open, blended),
// the sky and rain.
// Everything is in linear light; the target is sRGB, so the hardware encodes on write.

struct Frame {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    // xyz: direction towards the sun; w: direct light strength.
    sun_dir: vec4<f32>,
    sun_color: vec4<f32>,
    // rgb: sky ambient; w: blob shadow strength.
    ambient: vec4<f32>,
    sky_zenith: vec4<f32>,
    // rgb: horizon; w: how visible the sun disc is.
    sky_horizon: vec4<f32>,
    // rgb: fog colour; w: extinction per metre.
    fog: vec4<f32>,
    // x: wetness, y: puddles (precipitation deposits), z: rain, w: seed in 0..1.
    wet: vec4<f32>,
    // x: width, y: height, z: fog start distance, w: number of near rain streaks.
    viewport: vec4<f32>,
    // Lamps (parts of material `light`, mesh.rs): xyz centre, w strength; their colours; x of
    // `light_count` is how many are in use.
    lights: array<vec4<f32>, 8>,
    light_colors: array<vec4<f32>, 8>,
    light_count: vec4<f32>,
};

@group(0) @binding(0) var<uniform> frame: Frame;

const MATTE: i32 = 0;
const METAL: i32 = 1;
const GLASS: i32 = 2;
const EMISSIVE: i32 = 3;
const WATER: i32 = 4;
const FLAME: i32 = 5;
const SMOKE: i32 = 6;
const SHADOW: i32 = 7;
const LIGHT: i32 = 8;
const GLOSSY: i32 = 9;
const MIRROR: i32 = 10;

fn sky(dir: vec3<f32>) -> vec3<f32> {
    let up = clamp(dir.z, -1.0, 1.0);
    var c = mix(frame.sky_horizon.rgb, frame.sky_zenith.rgb, pow(max(up, 0.0), 0.55));
    if up < 0.0 {
        c = frame.sky_horizon.rgb * (1.0 + up * 0.4);
    }
    let s = dot(dir, frame.sun_dir.xyz);
    c += frame.sun_color.rgb * frame.sky_horizon.w * (smoothstep(0.9990, 0.9996, s) * 4.0 + pow(max(s, 0.0), 64.0) * 0.35);
    return c;
}

fn fog_amount(dist: f32) -> f32 {
    return 1.0 - exp(-frame.fog.w * max(dist - frame.viewport.z, 0.0));
}

fn hash2(p: vec2<f32>) -> f32 {
    let q = fract(p * vec2<f32>(0.1031, 0.1030));
    let r = q + dot(q, q.yx + 33.33);
    return fract((r.x + r.y) * r.x);
}

fn value_noise(p: vec2<f32>) -> f32 {
    let i = floor(p);
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = hash2(i);
    let b = hash2(i + vec2<f32>(1.0, 0.0));
    let c = hash2(i + vec2<f32>(0.0, 1.0));
    let d = hash2(i + vec2<f32>(1.0, 1.0));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

// ---- sky: a full-screen triangle behind everything ----

struct SkyOut {
    @builtin(position) clip: vec4<f32>,
    // Unnormalised view ray: the near-plane point minus the eye, linear across the screen, so
    // it is computed at the three vertices and interpolated.
    @location(0) ray: vec3<f32>,
};

@vertex
fn vs_fullscreen(@builtin(vertex_index) i: u32) -> SkyOut {
    let xy = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u)) * 2.0 - 1.0;
    var o: SkyOut;
    // Depth 0: infinitely far (reversed z), where nothing else is drawn.
    o.clip = vec4<f32>(xy, 0.0, 1.0);
    let near = frame.inv_view_proj * vec4<f32>(xy, 1.0, 1.0);
    o.ray = near.xyz / near.w - frame.eye.xyz;
    return o;
}

@fragment
fn fs_sky(in: SkyOut) -> @location(0) vec4<f32> {
    let dir = normalize(in.ray);
    // Fog thick enough to hide things at 200 m hides the sky too.
    let c = mix(sky(dir), frame.fog.rgb, fog_amount(200.0));
    return vec4<f32>(c, 1.0);
}

// ---- rain: screen-space streaks, a fixed pattern from the scene seed ----
// Each streak is a thin quad (six vertices) placed here from its index and the scene seed, so
// only the streaks' own pixels are shaded. Streaks below `viewport.w` are long and bright (near
// drops), the rest short and faint (far drops).

struct RainOut {
    @builtin(position) clip: vec4<f32>,
    // 0 at the top of the streak, 1 at the bottom.
    @location(0) along: f32,
    @location(1) strength: f32,
};

@vertex
fn vs_rain(@builtin(vertex_index) vi: u32) -> RainOut {
    let i = f32(vi / 6u);
    let corner = vi % 6u;
    let w = frame.viewport.x;
    let h = frame.viewport.y;
    let near = i < frame.viewport.w;
    let len = select(h / 18.0, h / 10.0, near);
    let salt = select(17.0, 0.0, near);
    let seed = frame.wet.w * 613.0;
    // The top end: anywhere from which the slanted streak still reaches the screen.
    let top = vec2<f32>(
        hash2(vec2<f32>(i + seed, 1.0 + salt)) * (w + 0.18 * h + len * 0.18),
        hash2(vec2<f32>(i * 1.7 + 5.0, seed + salt)) * (h + len) - len,
    );
    // Corners of the quad as (side, along): two triangles.
    var c = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 1.0), vec2<f32>(1.0, 0.0),
        vec2<f32>(0.0, 0.0), vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 1.0),
    );
    let k = c[corner];
    // One pixel wide, slanting left as it falls.
    let px = vec2<f32>(top.x - 0.18 * k.y * len + k.x - 0.5, top.y + k.y * len);
    var o: RainOut;
    o.clip = vec4<f32>(px.x / w * 2.0 - 1.0, 1.0 - px.y / h * 2.0, 0.0, 1.0);
    o.along = k.y;
    o.strength = select(0.6, 1.0, near);
    return o;
}

@fragment
fn fs_rain(in: RainOut) -> @location(0) vec4<f32> {
    // Lighter than the sky behind, whatever the light: streaks must read as rain.
    let a = (0.4 + 0.6 * in.along) * in.strength * 0.5;
    return vec4<f32>(frame.sky_horizon.rgb * 1.6 + vec3<f32>(0.08, 0.085, 0.09), a);
}

// ---- geometry ----

struct VsIn {
    @location(0) pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) material: f32,
    @location(4) entity: f32,
};

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    // Constant over a part: not interpolated.
    @location(3) @interpolate(flat) material: i32,
    @location(4) @interpolate(flat) entity: f32,
};

// Colour, and the id target for the visibility figures: r = 1 + the entity's index (0 for
// stage, extras, shadows), a = whether the fragment claims the pixel. Opaque fragments replace
// the id; in blended passes (gpu.rs, ID_UNDER) a claiming fragment takes only a pixel no entity
// holds yet (an entity behind glass or smoke stays seen), and a = 0 leaves the pixel as it is.
struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) id: vec4<f32>,
};

@vertex
fn vs_main(v: VsIn) -> VsOut {
    var o: VsOut;
    o.clip = frame.view_proj * vec4<f32>(v.pos, 1.0);
    o.world = v.pos;
    o.normal = v.normal;
    o.color = v.color;
    o.material = i32(round(v.material));
    o.entity = v.entity;
    return o;
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    var o: FsOut;
    o.color = shade(in);
    // A fragment that does not claim writes zeros: under the translucent pass's additive id
    // blend (ID_UNDER) it then leaves the pixel's id as it is.
    let claims = in.entity > 0.0 && in.material != SHADOW;
    o.id = select(vec4<f32>(0.0), vec4<f32>(in.entity, 0.0, 0.0, 1.0), claims);
    return o;
}

fn shade(in: VsOut) -> vec4<f32> {
    let m = in.material;
    let to_eye = frame.eye.xyz - in.world;
    let dist = length(to_eye);
    let v = to_eye / max(dist, 1e-4);
    let fog = fog_amount(dist);

    if m == SHADOW {
        return vec4<f32>(0.0, 0.0, 0.0, in.color.a * frame.ambient.w * (1.0 - fog));
    }
    if m == EMISSIVE || m == FLAME || m == LIGHT {
        // Light sources are not darkened by weather and pierce fog better than lit surfaces.
        let c = mix(in.color.rgb * 1.15, frame.fog.rgb, fog * 0.45);
        return vec4<f32>(c, in.color.a);
    }

    var n = normalize(in.normal);
    // Planes and thin parts seen from behind: shade the side facing the camera.
    if dot(n, v) < -0.2 {
        n = -n;
    }
    let l = frame.sun_dir.xyz;
    let sun = frame.sun_color.rgb * frame.sun_dir.w;
    let diffuse = sun * max(dot(n, l), 0.0);
    let hemi = frame.ambient.rgb * (0.7 + 0.3 * n.z);
    var albedo = in.color.rgb;
    var alpha = in.color.a;

    if m == SMOKE {
        let c = albedo * (hemi * 1.3 + diffuse * 0.4);
        return vec4<f32>(mix(c, frame.fog.rgb, fog), alpha);
    }

    // Wet ground: up-facing surfaces near z = 0 darken and mirror the sky; puddles (from
    // precipitation deposits) are patches where the mirror is complete.
    var mirror = 0.0;
    var shine = 16.0;
    var spec_k = 0.03;
    if m == MATTE && n.z > 0.9 && in.world.z < 0.35 {
        let puddle = smoothstep(0.6, 0.68, value_noise(in.world.xy * vec2<f32>(0.25, 0.6))) * frame.wet.y;
        // Saturated ground (grass, paint) shows less of the sky than tarmac and tiles do.
        let sat = max(albedo.r, max(albedo.g, albedo.b)) - min(albedo.r, min(albedo.g, albedo.b));
        mirror = max(frame.wet.x * 0.45, puddle) * (1.0 - clamp(sat * 3.0, 0.0, 0.8));
        albedo = albedo * (1.0 - 0.5 * mirror);
        shine = mix(16.0, 96.0, mirror);
        spec_k = mix(0.03, 0.9, mirror);
    } else if m == WATER {
        mirror = 0.9;
        shine = 128.0;
        spec_k = 1.0;
    } else if m == METAL {
        mirror = 0.25;
        shine = 48.0;
        spec_k = 0.7;
    } else if m == GLASS {
        mirror = 0.3;
        shine = 96.0;
        spec_k = 0.9;
    } else if m == GLOSSY {
        // A polished or wet floor: darker than dry, with sharp reflections of the lamps.
        albedo = albedo * 0.6;
        mirror = 0.35;
        shine = 160.0;
        spec_k = 1.0;
    } else if m == MIRROR {
        albedo = albedo * 0.15;
        mirror = 0.92;
        shine = 512.0;
        spec_k = 1.0;
    }

    var c = albedo * (diffuse + hemi + frame.light_count.yzw);
    let h = normalize(l + v);
    c += sun * spec_k * pow(max(dot(n, h), 0.0), shine);
    let fresnel = 0.04 + 0.96 * pow(1.0 - max(dot(n, v), 0.0), 5.0);
    let r = reflect(-v, n);
    if mirror > 0.0 {
        // Indoors (lamps lit) a glossy floor or a mirror shows the lit room, brighter towards
        // the ceiling, not the sky.
        var env = sky(r) * 0.9;
        if (m == GLOSSY || m == MIRROR) && frame.light_count.x > 0.0 {
            env = (frame.ambient.rgb + frame.light_count.yzw * 8.0) * (0.7 + 0.5 * r.z) * select(1.0, 0.5, m == GLOSSY);
        }
        let k = select(0.3 + 0.7 * fresnel, 1.0, m == MIRROR);
        c = mix(c, env, clamp(mirror * k, 0.0, 1.0));
    }
    // Lamps: diffuse and highlight falling off with distance, and on shiny surfaces a sharp
    // reflection of the lamp itself (what makes a floor read as wet).
    for (var i = 0; i < i32(frame.light_count.x); i = i + 1) {
        let to_l = frame.lights[i].xyz - in.world;
        let dl = length(to_l);
        let ld = to_l / max(dl, 1e-4);
        let lc = frame.light_colors[i].rgb * frame.lights[i].w / (1.0 + dl * dl / 6.25);
        c += albedo * lc * max(dot(n, ld), 0.0);
        c += lc * spec_k * pow(max(dot(n, normalize(ld + v)), 0.0), shine);
        if mirror > 0.0 {
            c += frame.light_colors[i].rgb * mirror * 3.0 * pow(max(dot(r, ld), 0.0), 300.0);
        }
    }
    if m == GLASS {
        alpha = clamp(alpha + fresnel * 0.4, 0.0, 1.0);
    }
    return vec4<f32>(mix(c, frame.fog.rgb, fog), alpha);
}

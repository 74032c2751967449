//! `Scene.environment` (CARLA-style weather parameters) and `Scene.camera` → the frame uniforms.
//! Nothing here knows a domain: any scene with the same parameters gets the same light.

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};

use super::mesh::{Light, MAX_LIGHTS};
use crate::ir::Camera;

/// Near clip plane (metres): small enough for a kitchen close-up.
const NEAR: f32 = 0.05;
/// Scene-frame azimuth (degrees from +x towards +y) of CARLA's `sun_azimuth_angle = 0`.
const SUN_AZIMUTH_ZERO: f64 = 215.0;

/// Mirrors `struct Frame` in `shader.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Frame {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    pub eye: [f32; 4],
    pub sun_dir: [f32; 4],
    pub sun_color: [f32; 4],
    pub ambient: [f32; 4],
    pub sky_zenith: [f32; 4],
    pub sky_horizon: [f32; 4],
    pub fog: [f32; 4],
    pub wet: [f32; 4],
    pub viewport: [f32; 4],
    /// Lamps (`light` parts): xyz centre, w strength; `light_colors` rgb; `light_count.x` in use,
    /// `light_count.yzw` the light they bounce off a room's walls and ceiling (linear rgb).
    pub lights: [[f32; 4]; MAX_LIGHTS],
    pub light_colors: [[f32; 4]; MAX_LIGHTS],
    pub light_count: [f32; 4],
}

impl Frame {
    /// Light the frame with the mesh's lamps; each also adds light from every direction, as a
    /// room's walls and ceiling bounce it (so a ceiling above the lamps is not black).
    pub fn set_lights(&mut self, lights: &[Light]) {
        let n = lights.len().min(MAX_LIGHTS);
        let mut bounce = [0.0f32; 3];
        for (i, l) in lights.iter().take(n).enumerate() {
            self.lights[i] = v4(l.at, l.strength);
            self.light_colors[i] = v4(l.color, 1.0);
            for (b, c) in bounce.iter_mut().zip(l.color) {
                *b += c * l.strength * 0.05;
            }
        }
        self.light_count = [n as f32, bounce[0], bounce[1], bounce[2]];
    }
}

/// Weather in renderer terms, each in 0..1 (the angle in degrees).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weather {
    pub cloudiness: f32,
    pub precipitation: f32,
    pub deposits: f32,
    pub wetness: f32,
    pub fog_density: f32,
    pub fog_distance: f32,
    pub sun_altitude: f32,
    pub sun_azimuth: f32,
}

impl Weather {
    /// Missing parameters mean a clear noon; CARLA's percentages are clamped to 0..100.
    pub fn from_environment(env: &BTreeMap<String, f64>) -> Weather {
        let pct = |k: &str| (env.get(k).copied().unwrap_or(0.0).clamp(0.0, 100.0) / 100.0) as f32;
        Weather {
            cloudiness: pct("cloudiness"),
            precipitation: pct("precipitation"),
            deposits: pct("precipitation_deposits"),
            wetness: pct("wetness"),
            fog_density: pct("fog_density"),
            fog_distance: env.get("fog_distance").copied().unwrap_or(0.0).max(0.0) as f32,
            sun_altitude: env.get("sun_altitude_angle").copied().unwrap_or(60.0).clamp(-90.0, 90.0) as f32,
            // CARLA's azimuth is in map coordinates, which mean nothing in the ego frame; the
            // renderer turns it so that azimuth 0 puts the sun behind the camera and to its
            // right, where it lights what the camera sees.
            sun_azimuth: (SUN_AZIMUTH_ZERO + env.get("sun_azimuth_angle").copied().unwrap_or(0.0)) as f32,
        }
    }
}

fn mix3(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

fn scale3(a: [f32; 3], k: f32) -> [f32; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

fn v4(a: [f32; 3], w: f32) -> [f32; 4] {
    [a[0], a[1], a[2], w]
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Build the uniforms for one frame of `width × height`. `seed` fixes the rain pattern.
pub fn frame(camera: &Camera, env: &BTreeMap<String, f64>, width: u32, height: u32, seed: u64) -> Frame {
    let w = Weather::from_environment(env);
    let (view_proj, inv_view_proj) = camera_matrices(camera, width as f32 / height as f32);
    let (alt, az) = (w.sun_altitude.to_radians(), w.sun_azimuth.to_radians());
    let sun_dir = [alt.cos() * az.cos(), alt.cos() * az.sin(), alt.sin()];

    let day = smoothstep(-8.0, 12.0, w.sun_altitude);
    let low_sun = 1.0 - smoothstep(5.0, 30.0, w.sun_altitude);
    let overcast = w.cloudiness.max(w.precipitation * 0.9);
    // Rain darkens everything; cloud flattens the light (less sun, relatively more sky).
    let gloom = 1.0 - 0.45 * w.precipitation;
    let sun_strength = day * (1.0 - 0.9 * overcast) * gloom * 1.7;
    let sun_color = mix3([1.0, 0.96, 0.9], [1.0, 0.6, 0.32], low_sun);

    let clear_zenith = [0.16, 0.34, 0.78];
    let clear_horizon = mix3([0.62, 0.74, 0.92], [0.95, 0.62, 0.4], low_sun * 0.8);
    let grey = [0.52, 0.54, 0.57];
    let night = [0.02, 0.028, 0.06];
    let bright = (0.25 + 0.75 * day) * gloom;
    let zenith = mix3(night, scale3(mix3(clear_zenith, grey, overcast), bright), day);
    let horizon = mix3(scale3(night, 1.6), scale3(mix3(clear_horizon, scale3(grey, 1.15), overcast), bright), day);
    let ambient = scale3(mix3(zenith, horizon, 0.5), 0.55 + 0.45 * overcast + 0.25 * (1.0 - day));
    // Blob shadows fade when the light is flat, but never vanish (contact shadow).
    let shadow = 0.55 + 0.45 * (1.0 - overcast) * day;

    let fog_color = mix3(horizon, scale3(grey, bright * 1.1), w.fog_density);
    let extinction = 0.0015 + 0.06 * w.fog_density.powf(1.5);

    Frame {
        view_proj,
        inv_view_proj,
        eye: v4(camera.at.map(|x| x as f32), 1.0),
        sun_dir: v4(sun_dir, sun_strength),
        sun_color: v4(sun_color, 1.0),
        ambient: v4(ambient, shadow),
        sky_zenith: v4(zenith, 1.0),
        sky_horizon: v4(horizon, day * (1.0 - overcast)),
        fog: v4(fog_color, extinction),
        wet: [w.wetness.max(w.precipitation * 0.6), w.deposits, w.precipitation, (seed % 1000) as f32 / 1000.0],
        viewport: [width as f32, height as f32, w.fog_distance, rain_streaks(w.precipitation, width, height).0 as f32],
        lights: [[0.0; 4]; MAX_LIGHTS],
        light_colors: [[0.0; 4]; MAX_LIGHTS],
        light_count: [0.0; 4],
    }
}

/// Rain streaks for a frame: `(near, total)`. At full rain there are about 112 near streaks
/// (long, bright) per image-height-wide square of the slanted screen and 2.8 times as many far
/// ones (short, faint), in proportion to precipitation: a 640×360 frame in hard rain gets
/// 220 + 616.
pub fn rain_streaks(precipitation: f32, width: u32, height: u32) -> (u32, u32) {
    let (w, h) = (width as f32, height as f32);
    let per_unit = precipitation.clamp(0.0, 1.0) * (w + 0.18 * h) / h / 1.78;
    let near = (200.0 * per_unit).round() as u32;
    let far = (560.0 * per_unit).round() as u32;
    (near, near + far)
}

/// View-projection and its inverse, column-major, wgpu clip space (reversed z: 1 at the near
/// plane, 0 at infinity). The camera's
/// `fov_deg` is horizontal, as in CARLA's camera blueprint.
pub fn camera_matrices(camera: &Camera, aspect: f32) -> ([[f32; 4]; 4], [[f32; 4]; 4]) {
    use nalgebra::{Matrix4, Point3, Vector3};
    let eye = Point3::from(camera.at.map(|x| x as f32));
    let mut target = Point3::from(camera.look_at.map(|x| x as f32));
    if (target - eye).norm() < 1e-6 {
        target = eye + Vector3::x();
    }
    let mut up = Vector3::z();
    if (target - eye).normalize().cross(&up).norm() < 1e-4 {
        up = Vector3::x();
    }
    let view = Matrix4::look_at_rh(&eye, &target, &up);
    let hfov = (camera.fov_deg as f32).clamp(1.0, 170.0).to_radians();
    let f_x = 1.0 / (hfov / 2.0).tan();
    let f_y = f_x * aspect;
    // Reversed-Z with an infinite far plane (depth = NEAR / distance): with a float depth
    // buffer this keeps road markings a few millimetres above the road apart at 100 m.
    #[rustfmt::skip]
    let proj = Matrix4::new(
        f_x, 0.0, 0.0, 0.0,
        0.0, f_y, 0.0, 0.0,
        0.0, 0.0, 0.0, NEAR,
        0.0, 0.0, -1.0, 0.0,
    );
    let vp = proj * view;
    let inv = vp.try_inverse().unwrap_or_else(Matrix4::identity);
    (vp.into(), inv.into())
}

/// Project a scene-frame point to pixel coordinates (x right, y down) and its distance along
/// the view axis; `None` behind the camera. Tests use it to find entities in images.
pub fn project(camera: &Camera, width: u32, height: u32, p: [f64; 3]) -> Option<([f64; 2], f64)> {
    let (vp, _) = camera_matrices(camera, width as f32 / height as f32);
    let v = [p[0] as f32, p[1] as f32, p[2] as f32, 1.0];
    let clip: Vec<f32> = (0..4).map(|r| (0..4).map(|c| vp[c][r] * v[c]).sum()).collect();
    if clip[3] <= 1e-4 {
        return None;
    }
    let (x, y) = (clip[0] / clip[3], clip[1] / clip[3]);
    Some(([((x + 1.0) / 2.0 * width as f32) as f64, ((1.0 - y) / 2.0 * height as f32) as f64], clip[3] as f64))
}

#[cfg(test)]
mod tests {
    use super::rain_streaks;

    /// The sampler's view of the scene (which keeps entities from hiding one another) projects
    /// as the renderer does.
    #[test]
    fn the_samplers_view_projects_as_the_renderer_does() {
        let cameras = [
            crate::ir::Camera {
                at: [-1.6, 0.0, 1.45],
                look_at: [30.0, 0.0, 0.6],
                fov_deg: 80.0,
                width: 640,
                height: 360,
            },
            crate::ir::Camera {
                at: [-1.0, 0.0, 2.2],
                look_at: [3.0, 0.0, 0.5],
                fov_deg: 75.0,
                width: 640,
                height: 480,
            },
        ];
        for c in cameras {
            let view = crate::sample::view::View::new(&c);
            for p in [[10.0, 2.0, 0.5], [2.7, -0.8, 0.95], [40.0, -3.0, 4.0], [1.5, 1.2, 0.0]] {
                let (a, da) = super::project(&c, c.width, c.height, p).unwrap();
                let (b, db) = view.project(p).unwrap();
                assert!((a[0] - b[0]).abs() < 0.05 && (a[1] - b[1]).abs() < 0.05, "{p:?}: {a:?} vs {b:?}");
                assert!((da - db).abs() < 1e-3 * db, "{p:?}: depth {da} vs {db}");
            }
        }
    }

    #[test]
    fn rain_streaks_follow_precipitation_and_width() {
        assert_eq!(rain_streaks(0.0, 640, 360), (0, 0));
        assert_eq!(rain_streaks(1.0, 640, 360), (220, 836));
        // Out-of-range precipitation is clamped, never a huge or negative count.
        assert_eq!(rain_streaks(7.0, 640, 360), rain_streaks(1.0, 640, 360));
        assert_eq!(rain_streaks(-1.0, 640, 360), (0, 0));
        let (near, total) = rain_streaks(0.5, 640, 360);
        assert!((109..=111).contains(&near) && (417..=419).contains(&total), "{near} {total}");
        // Twice the width (at the same height) holds nearly twice the streaks (the slant adds
        // a fixed margin).
        let (_, wide) = rain_streaks(1.0, 1280, 360);
        assert!(wide > 1_550 && wide < 1_650, "{wide}");
    }
}

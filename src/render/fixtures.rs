//! Scenes built in Rust for the renderer's unit tests: a road with a pedestrian, a car, a
//! traffic light, under a chosen weather.

use std::collections::BTreeMap;

use crate::ir::{Camera, Primitive, ShapePart};
use crate::scene::{Scene, SceneEntity};

pub fn part(prim: Primitive, size: [f64; 3], at: [f64; 3], rgb: u32, material: &str) -> ShapePart {
    let c = |s: u32| ((rgb >> s) & 0xff) as f64 / 255.0;
    ShapePart {
        prim,
        size,
        at,
        color: [c(16), c(8), c(0), 1.0],
        yaw_deg: 0.0,
        roll_deg: 0.0,
        pitch_deg: 0.0,
        material: material.to_string(),
        when: None,
        shadow: true,
    }
}

pub fn entity(name: &str, position: [f64; 3], shape: Vec<ShapePart>) -> SceneEntity {
    SceneEntity {
        name: name.to_string(),
        kind: name.to_string(),
        concept: Some(name.to_string()),
        region: "lane".to_string(),
        position,
        yaw_deg: 0.0,
        attrs: BTreeMap::new(),
        shape,
        drawn_by: None,
    }
}

/// A red box 1 m on a side, standing on the ground at `distance` ahead.
pub fn red_box(distance: f64) -> SceneEntity {
    entity("box", [distance, 0.0, 0.0], vec![part(Primitive::Box, [1.0, 1.0, 1.0], [0.0, 0.0, 0.5], 0xd02020, "matte")])
}

pub fn pedestrian(distance: f64, lateral: f64) -> SceneEntity {
    entity(
        "pedestrian",
        [distance, lateral, 0.0],
        vec![
            part(Primitive::Capsule, [0.45, 0.35, 1.3], [0.0, 0.0, 0.95], 0x2f4f8f, "matte"),
            part(Primitive::Sphere, [0.24, 0.24, 0.26], [0.0, 0.0, 1.72], 0xe0b090, "matte"),
            part(Primitive::Cylinder, [0.16, 0.16, 0.85], [0.0, 0.12, 0.42], 0x303030, "matte"),
            part(Primitive::Cylinder, [0.16, 0.16, 0.85], [0.0, -0.12, 0.42], 0x303030, "matte"),
        ],
    )
}

pub fn traffic_light(distance: f64, green: bool) -> SceneEntity {
    let (lit, lamp_z) = if green { (0x30ff60, 4.1) } else { (0xff2020, 4.7) };
    entity(
        "traffic_light",
        [distance, -3.0, 0.0],
        vec![
            part(Primitive::Cylinder, [0.15, 0.15, 4.0], [0.0, 0.0, 2.0], 0x404040, "metal"),
            part(Primitive::Box, [0.3, 0.4, 1.3], [0.0, 0.0, 4.4], 0x202020, "matte"),
            part(Primitive::Sphere, [0.28, 0.28, 0.28], [-0.16, 0.0, lamp_z], lit, "emissive"),
        ],
    )
}

pub fn road_stage() -> Vec<ShapePart> {
    let mut stage = vec![
        part(Primitive::Plane, [400.0, 400.0, 0.0], [150.0, 0.0, -0.02], 0x6b7a4a, "matte"),
        part(Primitive::Plane, [300.0, 7.0, 0.0], [140.0, 0.0, 0.0], 0x3a3a3c, "matte"),
        part(Primitive::Box, [300.0, 3.0, 0.15], [140.0, 5.0, 0.075], 0xa8a49c, "matte"),
        part(Primitive::Box, [300.0, 3.0, 0.15], [140.0, -5.0, 0.075], 0xa8a49c, "matte"),
    ];
    for i in 0..30 {
        stage.push(part(Primitive::Plane, [3.0, 0.15, 0.0], [4.0 + 9.0 * i as f64, 1.75, 0.01], 0xf0f0f0, "matte"));
    }
    stage
}

pub fn weather(cloud: f64, rain: f64, wet: f64, fog: f64, sun: f64) -> BTreeMap<String, f64> {
    [
        ("cloudiness", cloud),
        ("precipitation", rain),
        ("precipitation_deposits", rain),
        ("wetness", wet),
        ("fog_density", fog),
        ("sun_altitude_angle", sun),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

pub fn scene(entities: Vec<SceneEntity>, environment: BTreeMap<String, f64>) -> Scene {
    Scene {
        domain: "fixture".into(),
        domain_hash: String::new(),
        concepts: entities.iter().map(|e| e.name.clone()).collect(),
        seed: 7,
        world: BTreeMap::new(),
        environment,
        entities,
        extras: Vec::new(),
        stage: road_stage(),
        camera: Camera::default(),
    }
}

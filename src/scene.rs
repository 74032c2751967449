//! A concrete scene: one sample of a concept set's anchor graph (made by `sample`), consumed by
//! the renderers and emitters. Everything here is plain data, serialisable to JSON
//! (`revelio emit scene`), with all shape conditions already resolved.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::ir::{Camera, ShapePart};

/// A concrete attribute value (ranges already sampled).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SceneValue {
    Bool(bool),
    Number(f64),
    /// An enum variant by name.
    Enum(String),
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// Domain name and the SHA-256 of its source files (hex), so a scene names what made it.
    pub domain: String,
    pub domain_hash: String,
    /// Concept names of the set, in index order.
    pub concepts: Vec<String>,
    pub seed: u64,
    /// World attributes by name (town, weather, intersection …).
    pub world: BTreeMap<String, SceneValue>,
    /// Resolved preset parameters (e.g. CARLA weather: cloudiness, precipitation,
    /// precipitation_deposits, wetness, fog_density, sun_altitude_angle …).
    pub environment: BTreeMap<String, f64>,
    /// Entities mandated by the concepts (the anchor graph, concretised).
    pub entities: Vec<SceneEntity>,
    /// Seeded environmental extras that do not change the ground truth (parked cars, trees,
    /// clutter on the counter).
    pub extras: Vec<SceneEntity>,
    /// Static scenery with conditions resolved and repeats expanded, in the scene frame.
    pub stage: Vec<ShapePart>,
    pub camera: Camera,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneEntity {
    pub name: String,
    pub kind: String,
    /// The concept that added it (`None` for extras).
    pub concept: Option<String>,
    pub region: String,
    /// Position of the entity origin in the scene frame: x forward, y left, z up (metres).
    pub position: [f64; 3],
    /// Heading about z, degrees.
    pub yaw_deg: f64,
    pub attrs: BTreeMap<String, SceneValue>,
    /// The parts to draw (entity-local frame), conditions resolved.
    pub shape: Vec<ShapePart>,
    /// What draws the entity when it has no part of its own: its concept's `drawn_by STAGE`.
    /// The visibility figures measure these stage parts for it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawn_by: Option<StandIn>,
}

impl SceneEntity {
    /// Whether nothing in the frame is the entity's: no part of its own and no stand-in, so no
    /// renderer figure can say whether it is seen.
    pub fn draws_nothing(&self) -> bool {
        self.shape.is_empty() && self.drawn_by.is_none()
    }
}

/// The stage item that stands for an entity with no part of its own, and which parts of
/// [`Scene::stage`] it drew in this scene (none when its `when` does not hold: then the entity
/// is measured at 0 px, not excused).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StandIn {
    pub stage: String,
    pub parts: Vec<u32>,
}

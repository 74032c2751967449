//! Scenic 3 programs for the CARLA world model (`model scenic.simulators.carla.model`).
//!
//! The program fixes what the scene fixes and leaves the rest to Scenic: the map comes from the
//! world's `town`, the weather from the scene's `environment`, and every entity is placed
//! relative to ego by its concept's `scenic` fragment, whose placeholders are filled with the
//! sampled values (so the distances Scenic uses are the sampled ones). Where on the map ego
//! stands is Scenic's choice: a random lane, or, when the world's `intersection` is true, a lane
//! leading into a junction, 11–25 m before it (or the range of a world attribute
//! `intersection_distance`). `require` statements keep each entity's distance from ego inside
//! its concept's range (measured from ego's front), so a Scenic sample never contradicts the
//! ground truth.
//!
//! Placeholders in fragments: `{id}` (the entity's Scenic variable), `{at}` or `{region}` (the
//! region's `scenic` text, itself filled), `{distance}`/`{x}` (metres ahead), `{lateral}`/`{y}` (metres
//! to the left), `{right}` (metres to the right: Scenic's x axis), `{z}`, `{yaw}`, every
//! attribute of the entity by name, and `world.NAME` for world attributes. For an entity added
//! with a relation: `{target}` (the target's Scenic variable, or `ego`) and its offset from the
//! target, `{rel_ahead}`, `{rel_left}` and `{rel_right}`, so that a fragment can place it
//! relative to its target. `{{`/`}}` are literal braces.
//!
//! Relations: objects are created targets first, and for every entity related to another entity
//! a `require` keeps the relation's placement (distance, ahead, left) between the two objects'
//! near edges in ego's frame, so Scenic enforces the relation itself.

use std::fmt::Write as _;

use crate::anchor::{self, AnchorGraph};
use crate::ir::{ConceptId, ConceptKind, Domain};
use crate::scene::{Scene, SceneEntity, SceneValue};

use super::EmitError;
use super::template::{fill, num};

/// Where the CARLA `.xodr` maps live, written into `param map`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScenicOptions {
    pub map_dir: String,
}

/// Blueprint of the ego car (a name present in every CARLA 0.9.x and 0.10 release).
pub const EGO_BLUEPRINT: &str = "vehicle.lincoln.mkz_2017";
/// The `carla.WeatherParameters` fields the emitter sets, with a clear-noon baseline used for
/// any field the scene's environment does not give. CARLA has no named presets for every
/// domain weather (there is no "morning" preset), so the program always spells the parameters
/// out rather than naming a preset.
pub const WEATHER_BASELINE: [(&str, f64); 9] = [
    ("cloudiness", 5.0),
    ("precipitation", 0.0),
    ("precipitation_deposits", 0.0),
    ("wind_intensity", 10.0),
    ("sun_azimuth_angle", 0.0),
    ("sun_altitude_angle", 75.0),
    ("fog_density", 0.0),
    ("fog_distance", 0.0),
    ("wetness", 0.0),
];
/// Default distance range from ego to the junction ahead when approaching an intersection
/// (paper: `intersection_ego`, 11–25 m).
pub const JUNCTION_DISTANCE: (f64, f64) = (11.0, 25.0);
/// Without an intersection concept, ego stays at least this far from every junction, so that
/// no junction is in the near field of the image.
pub const JUNCTION_CLEARANCE: f64 = 30.0;

/// The Scenic program of a sampled scene of `domain`.
pub fn scenic(domain: &Domain, scene: &Scene, opts: &ScenicOptions) -> Result<String, EmitError> {
    let set =
        domain.parse_set(&scene.concepts).map_err(|e| EmitError(format!("the scene does not fit the domain: {e}")))?;
    let anchor = anchor::build(domain, set).map_err(|e| EmitError(format!("the concept set has no scene: {e}")))?;
    if anchor.entities.len() != scene.entities.len() {
        return Err(EmitError(
            "the scene's entities do not match its concept set (was it sampled from this domain?)".into(),
        ));
    }
    let town = carla_town(scene)?;
    let ids = scenic_ids(&scene.entities);
    let mut out = String::new();
    header(&mut out, domain, scene, &town, opts, &anchor);
    ego(&mut out, domain, scene, &anchor);
    body(&mut out, domain, scene, &anchor, &ids)?;
    requirements(&mut out, domain, scene, &anchor, &ids);
    relations(&mut out, domain, &anchor, &ids);
    Ok(out)
}

/// The CARLA map name from the world's `town` (`town01` → `Town01`).
fn carla_town(scene: &Scene) -> Result<String, EmitError> {
    let Some(SceneValue::Enum(v)) = scene.world.get("town") else {
        return Err(EmitError(format!(
            "domain `{}` has no enum world attribute `town`: the Scenic emitter needs a CARLA map",
            scene.domain
        )));
    };
    if v.is_empty() || !v.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(EmitError(format!("town `{v}` is not a CARLA map name")));
    }
    let mut t = v.clone();
    t[..1].make_ascii_uppercase();
    Ok(t)
}

fn py_str(s: &str) -> String {
    format!("'{}'", s.replace('\\', "\\\\").replace('\'', "\\'"))
}

fn header(out: &mut String, domain: &Domain, scene: &Scene, town: &str, opts: &ScenicOptions, anchor: &AnchorGraph) {
    let _ = writeln!(out, "# Generated by Revelio from domain `{}` (sha256 {}).", domain.name, scene.domain_hash);
    let _ = writeln!(out, "# Concepts: {}; seed {}.", scene.concepts.join(", "), scene.seed);
    let path = format!("{}/{town}.xodr", opts.map_dir.trim_end_matches(['/', '\\']));
    let _ = writeln!(out, "param map = localPath({})", py_str(&path));
    let _ = writeln!(out, "param carla_map = {}", py_str(town));
    let weather: Vec<String> = WEATHER_BASELINE
        .iter()
        .map(|(k, base)| format!("{}: {}", py_str(k), num(scene.environment.get(*k).copied().unwrap_or(*base))))
        .collect();
    let _ = writeln!(out, "param weather = {{{}}}", weather.join(", "));
    let _ = writeln!(out, "model scenic.simulators.carla.model\n");
    // Distances are measured to an object's near (back) face, as "2 m ahead" means the gap a
    // driver sees; fragments may also create plain points (a junction's signal).
    out.push_str("def revelioNearEdge(obj):\n    return (back of obj) if isinstance(obj, Object) else obj\n\n");
    if anchor.entities.iter().any(|e| e.target.is_some()) {
        // The ground offset of one object's near edge from another's, in ego's frame (Scenic's
        // local frame has x to the right and y ahead).
        out.push_str(
            "def revelioOffset(obj, target):\n    d = (revelioNearEdge(obj).position - revelioNearEdge(target).position).rotatedBy(-ego.heading)\n    return (d.y, -d.x)\n\n",
        );
    }
}

/// Bounds of a numeric world attribute on the anchor graph.
fn world_range(domain: &Domain, anchor: &AnchorGraph, name: &str) -> Option<(f64, f64)> {
    domain.world.iter().position(|a| a.name == name).and_then(|i| anchor.world[i].bounds())
}

fn ego(out: &mut String, domain: &Domain, scene: &Scene, anchor: &AnchorGraph) {
    let bp = py_str(EGO_BLUEPRINT);
    if scene.world.get("intersection") == Some(&SceneValue::Bool(true)) {
        let (lo, hi) = world_range(domain, anchor, "intersection_distance").unwrap_or(JUNCTION_DISTANCE);
        out.push_str("# Ego approaches a junction on one of its incoming lanes.\n");
        out.push_str("junction = Uniform(*network.intersections)\n");
        out.push_str("egoLane = Uniform(*junction.incomingLanes)\n");
        let _ = writeln!(out, "ego = new Car on egoLane.centerline, with blueprint {bp}");
        let _ = writeln!(out, "require {} <= junction.distanceTo(ego) <= {}\n", num(lo), num(hi));
    } else {
        // Lanes of ordinary roads: connecting lanes lie inside junctions.
        out.push_str("# Ego drives on a lane away from junctions.\n");
        out.push_str("egoLane = Uniform(*[lane for road in network.roads for lane in road.lanes])\n");
        let _ = writeln!(out, "ego = new Car on egoLane.centerline, with blueprint {bp}");
        let _ = writeln!(out, "require intersection.distanceTo(ego) >= {}\n", num(JUNCTION_CLEARANCE));
    }
}

/// Names an entity's Scenic variable must not take: the program's own variables, the CARLA
/// model's regions, and Python/Scenic keywords that entity names could plausibly collide with.
const RESERVED: &[&str] = &[
    "ego",
    "junction",
    "egoLane",
    "revelioNearEdge",
    "network",
    "road",
    "lane",
    "sidewalk",
    "curb",
    "intersection",
    "shoulder",
    "workspace",
    "model",
    "param",
    "require",
    "behavior",
    "monitor",
    "scenario",
    "new",
    "with",
    "at",
    "on",
    "in",
    "of",
    "by",
    "from",
    "to",
    "ahead",
    "behind",
    "left",
    "right",
    "front",
    "back",
    "facing",
    "visible",
    "following",
    "offset",
    "along",
    "relative",
    "beyond",
    "distance",
    "angle",
    "heading",
    "not",
    "and",
    "or",
    "is",
    "if",
    "else",
    "for",
    "while",
    "def",
    "class",
    "import",
    "lambda",
    "pass",
    "return",
    "None",
    "True",
    "False",
];

/// Scenic identifiers for the entities: their names made identifiers, de-duplicated in order.
fn scenic_ids(entities: &[SceneEntity]) -> Vec<String> {
    let mut ids: Vec<String> = Vec::with_capacity(entities.len());
    for e in entities {
        let mut base: String = e.name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
        if base.is_empty() || base.starts_with(|c: char| c.is_ascii_digit()) || RESERVED.contains(&base.as_str()) {
            base.insert_str(0, "obj_");
        }
        let mut id = base.clone();
        let mut n = 2;
        while ids.contains(&id) {
            id = format!("{base}_{n}");
            n += 1;
        }
        ids.push(id);
    }
    ids
}

fn value_text(v: &SceneValue) -> String {
    match v {
        SceneValue::Bool(b) => if *b { "True" } else { "False" }.to_owned(),
        SceneValue::Number(x) => num(*x),
        SceneValue::Enum(s) => s.clone(),
    }
}

/// Placeholder values of one fragment: the entity's (when there is one), then the world's.
struct Placeholders<'a> {
    scene: &'a Scene,
    entity: Option<(&'a SceneEntity, &'a str)>,
    /// The relation's target: its Scenic variable and ground position (ego: the origin).
    target: Option<(&'a str, [f64; 3])>,
    /// The entity's region placement, already filled (`None`: the region has no `scenic` text).
    at: Option<String>,
}

impl<'a> Placeholders<'a> {
    fn world(scene: &'a Scene) -> Self {
        Placeholders { scene, entity: None, target: None, at: None }
    }

    fn entity(
        domain: &Domain,
        scene: &'a Scene,
        e: &'a SceneEntity,
        id: &'a str,
        target: Option<(&'a str, [f64; 3])>,
    ) -> Result<Self, EmitError> {
        let mut p = Placeholders { scene, entity: Some((e, id)), target, at: None };
        let region = domain.region_by_name(&e.region).map(|r| &domain.regions[r.index()]);
        if let Some(text) = region.and_then(|r| r.scenic.as_deref()) {
            let filled = fill(text, |n| if matches!(n, "at" | "region") { None } else { p.get(n) }).map_err(|err| {
                EmitError(format!("the `scenic` placement of region `{}` cannot be filled: {err}", e.region))
            })?;
            p.at = Some(filled);
        }
        Ok(p)
    }

    fn get(&self, name: &str) -> Option<String> {
        if let Some(w) = name.strip_prefix("world.") {
            return self.scene.world.get(w).map(value_text);
        }
        let (e, id) = self.entity?;
        let p = e.position;
        Some(match name {
            "id" => id.to_owned(),
            "at" | "region" => return self.at.clone(),
            "distance" | "x" => num(p[0]),
            "lateral" | "y" => num(p[1]),
            "right" => num(-p[1]),
            "z" => num(p[2]),
            "yaw" => num(e.yaw_deg),
            "target" => self.target.map_or("ego", |t| t.0).to_owned(),
            "rel_ahead" => num(p[0] - self.target.map_or(0.0, |t| t.1[0])),
            "rel_left" => num(p[1] - self.target.map_or(0.0, |t| t.1[1])),
            "rel_right" => num(self.target.map_or(0.0, |t| t.1[1]) - p[1]),
            attr => return e.attrs.get(attr).map(value_text),
        })
    }

    /// Fill a concept's fragment, explaining a missing region placement.
    fn fill(&self, concept: &str, fragment: &str) -> Result<String, EmitError> {
        fill(fragment, |n| self.get(n)).map_err(|err| match self.entity {
            Some((e, _)) if self.at.is_none() && (err.contains("`{at}`") || err.contains("`{region}`")) => {
                EmitError(format!("region `{}` has no `scenic` placement, which concept `{concept}` uses", e.region))
            }
            _ => EmitError(format!("the `scenic` fragment of concept `{concept}` cannot be filled: {err}")),
        })
    }
}

fn body(
    out: &mut String,
    domain: &Domain,
    scene: &Scene,
    anchor: &AnchorGraph,
    ids: &[String],
) -> Result<(), EmitError> {
    let order = anchor::placement_order(anchor);
    for cid in concept_order(anchor) {
        let c = &domain.concepts[cid.index()];
        // Entities in placement order, so that a fragment never names a target created later.
        let mine: Vec<usize> = match c.kind {
            ConceptKind::Concept => order.iter().copied().filter(|&i| anchor.entities[i].concept == cid).collect(),
            ConceptKind::Modifier => {
                order.iter().copied().filter(|&i| anchor.entities[i].modified_by.contains(&cid)).collect()
            }
        };
        let Some(fragment) = c.render.scenic.as_deref() else {
            if c.kind == ConceptKind::Concept && !mine.is_empty() {
                return Err(EmitError(format!(
                    "concept `{}` adds `{}` but has no `scenic` fragment to create it",
                    c.name, anchor.entities[mine[0]].name
                )));
            }
            continue;
        };
        let _ = writeln!(out, "# {}: {}", c.name, c.description.trim());
        if mine.is_empty() {
            let _ = writeln!(out, "{}", Placeholders::world(scene).fill(&c.name, fragment)?.trim_end());
        }
        for i in mine {
            let target = anchor.entities[i].target.map(|t| (ids[t].as_str(), scene.entities[t].position));
            let p = Placeholders::entity(domain, scene, &scene.entities[i], &ids[i], target)?;
            let _ = writeln!(out, "{}", p.fill(&c.name, fragment)?.trim_end());
        }
    }
    Ok(())
}

/// The set's concepts in index order, except that a concept comes after the concepts that add
/// the targets of its entities' relations.
fn concept_order(anchor: &AnchorGraph) -> Vec<ConceptId> {
    let concepts: Vec<ConceptId> = anchor.set.iter().collect();
    let needs = |c: ConceptId| -> Vec<ConceptId> {
        anchor
            .entities
            .iter()
            .filter(|e| e.concept == c)
            .filter_map(|e| e.target.map(|t| anchor.entities[t].concept))
            .filter(|&t| t != c)
            .collect()
    };
    let mut out: Vec<ConceptId> = Vec::with_capacity(concepts.len());
    while out.len() < concepts.len() {
        let before = out.len();
        for &c in &concepts {
            if !out.contains(&c) && needs(c).iter().all(|t| out.contains(t)) {
                out.push(c);
                break;
            }
        }
        if out.len() == before {
            // A cycle (the checker rejects them): the rest in index order.
            out.extend(concepts.iter().copied().filter(|c| !out.contains(c)).collect::<Vec<_>>());
        }
    }
    out
}

/// For every entity placed relative to another entity, the relation's bounds between their
/// near edges, in ego's frame (millimetre slack: the program's numbers are rounded). The near
/// edge is the point the driving regions place an object at (`ahead of` a point); `on_top` has
/// no bound here, as stacked objects' near edges differ: a fragment places it `on {target}`.
fn relations(out: &mut String, domain: &Domain, anchor: &AnchorGraph, ids: &[String]) {
    let mut first = true;
    for (i, e) in anchor.entities.iter().enumerate() {
        let (Some(t), Some(p)) = (e.target, anchor::placement_of(domain, e)) else { continue };
        let has_fragment = |c: ConceptId| domain.concepts[c.index()].render.scenic.is_some();
        let bounded = p.distance.is_some() || p.ahead.is_some() || p.left.is_some();
        if !bounded || !has_fragment(e.concept) || !has_fragment(anchor.entities[t].concept) {
            continue;
        }
        if first {
            out.push_str("\n# Relations between objects hold (near edges, in ego's frame).\n");
            first = false;
        }
        let (a, b) = (&ids[i], &ids[t]);
        let _ = writeln!(out, "# `{}` {} `{}`", e.name, e.relation.name, anchor.entities[t].name);
        let slack = 0.002;
        let off = format!("revelioOffset({a}, {b})");
        let bound =
            |what: &str, (lo, hi): (f64, f64)| format!("require {} <= {what} <= {}", num(lo - slack), num(hi + slack));
        if let Some((lo, hi)) = p.distance {
            // A distance is never negative: no slack below a zero bound.
            let lo = if lo > 0.0 { lo } else { slack };
            let _ = writeln!(out, "{}", bound(&format!("(({off})[0] ** 2 + ({off})[1] ** 2) ** 0.5"), (lo, hi)));
        }
        if let Some(r) = p.ahead {
            let _ = writeln!(out, "{}", bound(&format!("({off})[0]"), r));
        }
        if let Some(r) = p.left {
            let _ = writeln!(out, "{}", bound(&format!("({off})[1]"), r));
        }
    }
}

/// Keep each entity's distance from ego within its concept's range. Distances are measured from
/// ego's front (`front of ego`: "2 m ahead" from the car's centre would be inside the car) to the
/// entity's near face. The entity sits `x` ahead and `y` to the side, x in `lo..=hi`, so its
/// distance lies in `lo..=hypot(hi, y)`.
fn requirements(out: &mut String, domain: &Domain, scene: &Scene, anchor: &AnchorGraph, ids: &[String]) {
    let mut first = true;
    for (i, a) in anchor.entities.iter().enumerate() {
        let k = &domain.kinds[a.kind.index()];
        let Some((lo, hi)) = k.attr("distance").and_then(|j| a.attrs[j].bounds()) else { continue };
        if domain.concepts[a.concept.index()].render.scenic.is_none() {
            continue;
        }
        if first {
            out.push_str("\n# Distances from ego stay inside the concepts' ranges.\n");
            first = false;
        }
        let y = scene.entities[i].position[1];
        // Millimetre slack: the program's numbers are rounded to millimetres.
        let (lo, hi) = ((lo - 0.001).max(0.0), hi.hypot(y) + 0.001);
        let id = &ids[i];
        let d = format!("(distance from (front of ego) to revelioNearEdge({id}))");
        let _ = writeln!(out, "require {d} >= {} and {d} <= {}", num(lo), num(hi));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::Value;
    use crate::sample::fixture::{set, tiny_domain};

    fn opts() -> ScenicOptions {
        ScenicOptions { map_dir: "/maps/carla".into() }
    }

    fn emit(d: &Domain, names: &[&str], seed: u64) -> Result<String, EmitError> {
        let scene = crate::sample::sample(d, set(d, names), seed).unwrap();
        scenic(d, &scene, &opts())
    }

    #[test]
    fn pedestrian_near_in_rain() {
        let d = tiny_domain();
        insta::assert_snapshot!(emit(&d, &["pedestrian", "weather_hard_rain", "near"], 5).unwrap());
    }

    #[test]
    fn obstruction_and_pedestrian_on_sidewalk_in_town02() {
        let d = tiny_domain();
        insta::assert_snapshot!(
            emit(&d, &["pedestrian", "obstruction_near", "town_town02", "on_sidewalk"], 11).unwrap()
        );
    }

    /// The driving domain with its sources pinned: the sample stream is seeded by the sources'
    /// hash, and these snapshots should change only when the domain's meaning does, not with
    /// every comment edited in `domains/driving.rev`.
    fn pinned_driving() -> Domain {
        let mut d = crate::sample::fixture::driving();
        d.files = vec![crate::ir::SourceFile { name: "driving.rev".into(), text: "pinned for snapshots".into() }];
        d
    }

    #[test]
    fn driving_pedestrian_near_in_fog() {
        let d = pinned_driving();
        insta::assert_snapshot!(emit(&d, &["pedestrian", "near", "weather_foggy"], 3).unwrap());
    }

    #[test]
    fn driving_red_light_and_sidewalk_props_in_town02() {
        let d = pinned_driving();
        insta::assert_snapshot!(emit(&d, &["town_town02", "light_red", "debris_near", "bus_stop"], 8).unwrap());
    }

    #[test]
    fn every_small_driving_set_emits() {
        let d = crate::sample::fixture::driving();
        let lattice = crate::lattice::Lattice::enumerate(&d, 2);
        for &s in lattice.of_size(1).iter().chain(lattice.of_size(2)) {
            let scene = crate::sample::sample(&d, s, 1).unwrap();
            let program = scenic(&d, &scene, &opts()).unwrap_or_else(|e| panic!("{:?}: {e}", scene.concepts));
            assert!(program.matches(" = new ").count() > scene.entities.len(), "{program}");
            crate::emit::prompt(&d, &scene).unwrap();
        }
    }

    fn walk_the_dog(text: &str) -> Domain {
        let mut d = crate::check::compile_source("walk_the_dog.rev", text).unwrap_or_else(|e| panic!("{e:?}"));
        // Pinned like the driving snapshots: the stream is seeded by the sources' hash.
        d.files = vec![crate::ir::SourceFile { name: "walk_the_dog.rev".into(), text: "pinned".into() }];
        d
    }

    const WALK_THE_DOG: &str = include_str!("../../tests/corpus/good/walk_the_dog.rev");

    #[test]
    fn related_entities_are_placed_relative_to_their_targets() {
        let d = walk_the_dog(WALK_THE_DOG);
        let names = ["owner", "dog", "barrier", "cone_behind_barrier"];
        let program = emit(&d, &names, 2).unwrap();
        // The dog's fragment names its owner and its offset from it; Scenic checks the relation.
        assert!(program.contains("revelioNearEdge(owner) offset along ego.heading by ("), "{program}");
        assert!(program.contains("# `dog` near `owner`\nrequire 0 <= ((revelioOffset(dog, owner))[0] ** 2"));
        assert!(
            program
                .contains("# `cone` behind `barrier`\nrequire 0.998 <= (revelioOffset(cone, barrier))[0] <= 3.002\n")
        );
        insta::assert_snapshot!(program);
        // The offsets filled in are the sampled ones.
        let scene = crate::sample::sample(&d, set(&d, &names), 2).unwrap();
        let (owner, dog) = (&scene.entities[0], &scene.entities[1]);
        let rel =
            format!("by ({}, {})", num(owner.position[1] - dog.position[1]), num(dog.position[0] - owner.position[0]));
        assert!(program.contains(&rel), "{rel} in {program}");
    }

    #[test]
    fn targets_are_created_before_the_entities_placed_relative_to_them() {
        // Declare the dog before its owner: the owner's object must still come first.
        let owner_start = WALK_THE_DOG.find("concept owner").unwrap();
        let dog_start = WALK_THE_DOG.find("concept dog").unwrap();
        let barrier_start = WALK_THE_DOG.find("concept barrier").unwrap();
        let text = format!(
            "{}{}{}{}",
            &WALK_THE_DOG[..owner_start],
            &WALK_THE_DOG[dog_start..barrier_start],
            &WALK_THE_DOG[owner_start..dog_start],
            &WALK_THE_DOG[barrier_start..]
        );
        let d = walk_the_dog(&text);
        assert_eq!(d.concepts[0].name, "dog");
        let program = emit(&d, &["dog", "owner"], 0).unwrap();
        let (o, g) = (program.find("owner = new").unwrap(), program.find("dog = new").unwrap());
        assert!(o < g, "{program}");
    }

    #[test]
    fn intersection_places_ego_before_a_junction() {
        let mut d = tiny_domain();
        d.world[2].default = Value::Bool(true);
        let p = emit(&d, &["pedestrian"], 0).unwrap();
        assert!(p.contains("egoLane = Uniform(*junction.incomingLanes)"));
        assert!(p.contains("require 11 <= junction.distanceTo(ego) <= 25"));
    }

    #[test]
    fn unusable_fragments_are_explained() {
        let mut d = tiny_domain();
        d.concepts[0].render.scenic = Some("{id} = new Pedestrian at {nowhere}".into());
        assert_eq!(
            emit(&d, &["pedestrian"], 0).unwrap_err().to_string(),
            "the `scenic` fragment of concept `pedestrian` cannot be filled: unknown placeholder `{nowhere}`"
        );
        d.concepts[0].render.scenic = None;
        assert_eq!(
            emit(&d, &["pedestrian"], 0).unwrap_err().to_string(),
            "concept `pedestrian` adds `ped` but has no `scenic` fragment to create it"
        );
        let mut d = tiny_domain();
        d.regions[0].scenic = None;
        assert_eq!(
            emit(&d, &["pedestrian"], 0).unwrap_err().to_string(),
            "region `lane` has no `scenic` placement, which concept `pedestrian` uses"
        );
        let mut d = tiny_domain();
        d.regions[0].scenic = Some("at {far}".into());
        assert_eq!(
            emit(&d, &["pedestrian"], 0).unwrap_err().to_string(),
            "the `scenic` placement of region `lane` cannot be filled: unknown placeholder `{far}`"
        );
        let mut d = tiny_domain();
        d.world.remove(0);
        d.presets.clear();
        assert!(emit(&d, &["pedestrian"], 0).unwrap_err().to_string().contains("no enum world attribute `town`"));
    }

    #[test]
    fn ids_are_unique_identifiers() {
        let mk = |name: &str| SceneEntity {
            name: name.into(),
            kind: String::new(),
            concept: None,
            region: String::new(),
            position: [0.0; 3],
            yaw_deg: 0.0,
            attrs: Default::default(),
            shape: vec![],
            drawn_by: None,
        };
        let ids = scenic_ids(&[mk("ped"), mk("ped"), mk("2x"), mk("ego"), mk("a-b"), mk("junction")]);
        assert_eq!(ids, ["ped", "ped_2", "obj_2x", "obj_ego", "a_b", "obj_junction"]);
    }
}

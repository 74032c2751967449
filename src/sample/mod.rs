//! Seeded scene sampler: a concept set's anchor graph (paper §3.1) concretised into a [`Scene`].
//!
//! What a sample fixes, in this order (the order of the random draws, so it is part of the
//! reproducibility contract):
//! 1. world attributes: ranges drawn uniformly, enums and booleans copied;
//! 2. each entity's attributes, in the kind's attribute order, the same way;
//! 3. each entity's position in its region: x from a `distance` attribute and y from a `lateral`
//!    attribute when the kind has one whose range meets the region's extent (drawn inside the
//!    intersection), otherwise uniformly in the region; z uniformly in the region. Entities in
//!    one region do not overlap (see [`place`]), and where their bounds leave room the entities
//!    of a set do not stand behind one another in the camera's view (see [`view`]; a layout
//!    that still hides one is drawn again, up to [`LAYOUTS`] times). Entities are placed
//!    targets first (otherwise in anchor order); an entity added with a relation to another
//!    entity (`near stove`) is drawn where its region meets the relation's placement around
//!    where the target stands, and the target is drawn where that meeting is possible. `on_top`
//!    puts the entity at its target's ground position, on the target's highest face. When
//!    region and relation cannot both hold, the relation decides: it holds in every scene;
//! 4. environmental extras (see below);
//! 5. for a set that places no entity (only world concepts: a town, a weather, a junction),
//!    continuous variation of the view (see below).
//!
//! Sets that are not valid (`lattice::validate`: constraints, modifier targets, the empty set)
//! are refused with the reason.
//!
//! Shape and stage `when` conditions are evaluated with [`anchor::eval`] on the *concrete*
//! graph (every range replaced by its drawn value), `self` bound to the entity.
//!
//! **Extras.** Kinds carrying the tag `Extra` are scenery: each scene gets 0 to [`MAX_EXTRAS`]
//! of them (count, kind, then region drawn from the seed), placed in the *scenery regions*: the
//! regions no concept places anything in (no `add … in R`, no `move R`), so by construction
//! away from everything the rules look at (the far kerb, the verge behind the sidewalk, the far
//! end of a counter). A kind that says where it may stand (`in far_kerb`) is only placed in those
//! of its regions that are scenery regions, and a kind with none is never drawn. Extras are not
//! in the concept set's anchor graph, so they never change the expected answer. A domain with no
//! `Extra` kind or no scenery region gets no extras.
//!
//! **Variation of entity-less sets.** A set such as `{weather_foggy}` would otherwise differ
//! between seeds only by its extras (and none in a quarter of the scenes), so it has few
//! distinct scenes, and a run that must not show a set the same image twice would run out of
//! them. Its scenes get, drawn last from the same stream ([`vary`]): ego's lateral position
//! within its lane (the camera, the point it looks at and ego's own body — stage parts within
//! [`EGO_BODY_M`] of the camera — moved sideways by up to ±[`LATERAL_JITTER_M`]), camera jitter (height ±[`HEIGHT_JITTER_M`], yaw ±[`YAW_JITTER_DEG`],
//! pitch ±[`PITCH_JITTER_DEG`]), and a time within the preset: every resolved preset parameter
//! drawn within ±[`PRESET_JITTER`] of its value (a parameter at 0, such as no fog, stays 0; one
//! at most 100 stays at most 100), so the sun's altitude and the fog's density vary within what
//! the preset names. None of it changes the ground truth (rules read the anchor graph), and a
//! set with entities keeps exactly the scenes it had (its distances already vary). The backdrop
//! (the empty set) stays the fixed baseline.
//!
//! **Determinism.** The stream is ChaCha8 seeded by SHA-256 of (domain hash, set bits, seed);
//! nothing iterates a hash map. The same inputs give the same scene on any machine.

mod place;
mod rng;
pub(crate) mod view;

use std::collections::BTreeMap;

use rand_chacha::ChaCha8Rng;

use crate::anchor::{self, AnchorEntity, AnchorGraph, Tri};
use crate::ir::{
    ConceptSet, Domain, Effect, GroundBounds, KindId, Placement, Region, RegionId, Relation, ShapePart, StageItem,
    Value,
};
use crate::lattice::Validity;
use crate::scene::{Scene, SceneEntity, SceneValue, StandIn};
use place::{Axis, Footprint, Must, Placed};
pub use rng::domain_hash;
use view::{Sight, View};

/// Most extras in one scene.
pub const MAX_EXTRAS: u64 = 3;
/// Entity-less sets: ego's lateral offset within its lane, at most (metres).
pub const LATERAL_JITTER_M: f64 = 0.3;
/// Entity-less sets: stage parts this close to the camera (horizontally, metres) are ego's own
/// body (the bonnet, a robot's front) and move sideways with it.
pub const EGO_BODY_M: f64 = 1.0;
/// Entity-less sets: camera height offset, at most (metres).
pub const HEIGHT_JITTER_M: f64 = 0.05;
/// Entity-less sets: camera yaw, at most (degrees).
pub const YAW_JITTER_DEG: f64 = 1.5;
/// Entity-less sets: camera pitch, at most (degrees).
pub const PITCH_JITTER_DEG: f64 = 1.0;
/// Entity-less sets: relative change of each preset parameter, at most.
pub const PRESET_JITTER: f64 = 0.1;
/// Layouts tried for a scene whose entities hide one another (see [`view`]).
const LAYOUTS: usize = 6;
pub use view::MAX_HIDDEN;
/// The tag that marks scenery kinds.
pub const EXTRA_TAG: &str = "Extra";

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SampleError(pub String);

/// Sample one scene of `set`. For many samples of one domain use a [`Sampler`], which hashes
/// the domain's sources once.
pub fn sample(domain: &Domain, set: ConceptSet, seed: u64) -> Result<Scene, SampleError> {
    Sampler::new(domain).sample(set, seed)
}

/// A sampler for one domain, with the domain's hash and extras catalogue precomputed.
#[derive(Debug, Clone)]
pub struct Sampler<'d> {
    domain: &'d Domain,
    digest: [u8; 32],
    hash: String,
    /// Scenery kinds, each with the scenery regions it may stand in (never empty).
    extras: Vec<(KindId, Vec<RegionId>)>,
    validity: Validity,
}

impl<'d> Sampler<'d> {
    pub fn new(domain: &'d Domain) -> Self {
        let digest = rng::domain_digest(domain);
        let extra_kinds: Vec<KindId> = match domain.tag_by_name(EXTRA_TAG) {
            Some(t) => {
                (0..domain.kinds.len() as u32).map(KindId).filter(|k| domain.kinds[k.index()].has_tag(t)).collect()
            }
            None => Vec::new(),
        };
        let used: Vec<RegionId> = domain
            .concepts
            .iter()
            .flat_map(|c| &c.effects)
            .filter_map(|e| match e {
                Effect::Add { region, .. } | Effect::MoveTarget { region, .. } => Some(*region),
                _ => None,
            })
            .collect();
        let scenery: Vec<RegionId> =
            (0..domain.regions.len() as u32).map(RegionId).filter(|r| !used.contains(r)).collect();
        let extras = extra_kinds
            .into_iter()
            .map(|k| {
                let kind = &domain.kinds[k.index()];
                (k, scenery.iter().copied().filter(|r| kind.may_stand_in(*r)).collect::<Vec<_>>())
            })
            .filter(|(_, regions)| !regions.is_empty())
            .collect();
        Sampler { domain, digest, hash: hex::encode(digest), extras, validity: Validity::new(domain) }
    }

    pub fn domain(&self) -> &'d Domain {
        self.domain
    }

    pub fn sample(&self, set: ConceptSet, seed: u64) -> Result<Scene, SampleError> {
        let d = self.domain;
        if let Err(v) = self.validity.check(set) {
            let names: Vec<&str> =
                set.iter().filter_map(|c| d.concepts.get(c.index())).map(|c| c.name.as_str()).collect();
            return Err(SampleError(format!("invalid concept set {{{}}}: {}", names.join(", "), v.resolve(d))));
        }
        self.draw_scene(set, seed)
    }

    /// The backdrop: a scene of no concept (the world's defaults, the stage and the seeded
    /// extras). It is outside the lattice, so it has no ground truth; renderers and their tests
    /// use it as the baseline a concept is seen against.
    pub fn backdrop(&self, seed: u64) -> Result<Scene, SampleError> {
        self.draw_scene(ConceptSet::EMPTY, seed)
    }

    fn draw_scene(&self, set: ConceptSet, seed: u64) -> Result<Scene, SampleError> {
        let d = self.domain;
        let anchor = anchor::build(d, set).map_err(|e| SampleError(format!("the concept set has no scene: {e}")))?;
        let mut rng = rng::scene_rng(&self.digest, set, seed);
        let mut concrete = anchor.clone();
        for v in &mut concrete.world {
            *v = draw(&mut rng, v);
        }
        for e in &mut concrete.entities {
            for v in &mut e.attrs {
                *v = draw(&mut rng, v);
            }
        }
        let shapes: Vec<Vec<ShapePart>> = (0..concrete.entities.len()).map(|i| entity_shape(d, &concrete, i)).collect();
        let n = concrete.entities.len();
        let view = View::new(&d.camera);
        let on_top = anchor.entities.iter().map(|e| anchor::placement_of(d, e).is_some_and(|p| p.on_top)).collect();
        let bounds = anchor::ground_bounds(d, &anchor);
        let poses = (0..n)
            .map(|j| {
                let z = d.regions[anchor.entities[j].region.index()].z;
                (yaw_of(d, &concrete.entities[j]), (z.0 + z.1) / 2.0)
            })
            .collect();
        let probes = (0..n).map(|_| std::cell::OnceCell::new()).collect();
        let layout = Layout { bounds, anchor: &anchor, shapes: &shapes, view: &view, on_top, probes, poses };
        let order = anchor::placement_order(&anchor);
        // Lay the entities out; when one ends up hidden behind another, lay them all out again
        // (fresh positions, the same attributes), keeping the layout that hides least.
        let mut best: Option<(f64, Arrangement)> = None;
        for attempt in 0..LAYOUTS {
            let mut a = Arrangement {
                placed: Vec::with_capacity(n),
                positions: vec![[0.0; 3]; n],
                sights: vec![None; n],
                entities: concrete.entities.clone(),
            };
            for &i in &order {
                layout.position(d, &mut rng, &mut a, i, attempt > 0);
            }
            let worst = layout.worst_hidden(&a);
            if best.as_ref().is_none_or(|(w, _)| worst < *w) {
                best = Some((worst, a));
            }
            if worst <= view::MAX_HIDDEN {
                break;
            }
        }
        let (_, a) = best.expect("LAYOUTS is at least 1");
        let Arrangement { mut placed, positions, sights, entities: laid_out } = a;
        concrete.entities = laid_out;
        let mut entities = Vec::with_capacity(n);
        for (i, shape) in shapes.into_iter().enumerate() {
            let e = &concrete.entities[i];
            entities.push(scene_entity(d, e, Some(&d.concepts[e.concept.index()].name), positions[i], shape));
        }
        let guarded: Vec<Sight> = sights.into_iter().flatten().collect();
        let extras = self.extras(&mut rng, &mut concrete, &mut placed, &view, &guarded);
        // Stage parts in item order, remembering which item drew which (for `drawn_by`).
        let mut stage = Vec::new();
        let mut drawn: Vec<(&str, std::ops::Range<u32>)> = Vec::with_capacity(d.stage.len());
        for s in &d.stage {
            let start = stage.len() as u32;
            stage.extend(stage_parts(d, &concrete, s));
            drawn.push((&s.name, start..stage.len() as u32));
        }
        for (e, a) in entities.iter_mut().zip(&concrete.entities).filter(|(e, _)| e.shape.is_empty()) {
            let by = d.concepts[a.concept.index()].render.drawn_by.as_ref();
            if let Some((name, parts)) = by.and_then(|by| drawn.iter().find(|(n, _)| n == by)) {
                e.drawn_by = Some(StandIn { stage: (*name).to_owned(), parts: parts.clone().collect() });
            }
        }
        let mut scene = Scene {
            domain: d.name.clone(),
            domain_hash: self.hash.clone(),
            concepts: d.set_names(set).into_iter().map(str::to_owned).collect(),
            seed,
            world: d.world.iter().zip(&concrete.world).map(|(a, v)| (a.name.clone(), scene_value(d, v))).collect(),
            environment: environment(d, &concrete.world),
            entities,
            extras,
            stage,
            camera: d.camera.clone(),
        };
        if n == 0 && !set.is_empty() {
            vary(&mut rng, &mut scene);
        }
        Ok(scene)
    }

    /// Draw the scenery extras. They are evaluated on the concrete graph (for their own shape
    /// conditions) but removed again, so they never take part in anything the concepts decide.
    fn extras(
        &self,
        rng: &mut ChaCha8Rng,
        g: &mut AnchorGraph,
        placed: &mut Vec<Placed>,
        view: &View,
        guarded: &[Sight],
    ) -> Vec<SceneEntity> {
        if self.extras.is_empty() {
            return Vec::new();
        }
        let d = self.domain;
        let n = rng::below(rng, MAX_EXTRAS + 1);
        let mut out = Vec::with_capacity(n as usize);
        for i in 0..n {
            let (kind, regions) = &self.extras[rng::below(rng, self.extras.len() as u64) as usize];
            let kind = *kind;
            let region = regions[rng::below(rng, regions.len() as u64) as usize];
            let k = &d.kinds[kind.index()];
            let ranged = AnchorEntity {
                name: format!("extra{}", i + 1),
                kind,
                concept: crate::ir::ConceptId(0),
                region,
                relation: Relation { name: String::new(), to: None },
                target: None,
                attrs: k.attrs.iter().map(|a| a.default.clone()).collect(),
                modified_by: Vec::new(),
            };
            let mut e = ranged.clone();
            for v in &mut e.attrs {
                *v = draw(rng, v);
            }
            g.entities.push(e);
            let shape = resolve_parts(d, g, Some(g.entities.len() - 1), &k.shape);
            let mut e = g.entities.pop().expect("pushed above");
            let position = position(d, rng, placed, (&ranged, &mut e, &shape), view, guarded);
            out.push(scene_entity(d, &e, None, position, shape));
        }
        out
    }
}

/// The continuous variation of an entity-less set's scene (see the module docs): the view, then
/// the preset parameters in name order.
fn vary(rng: &mut ChaCha8Rng, scene: &mut Scene) {
    let mut jitter = |max: f64| rng::uniform(rng, -max, max);
    let (lateral, height) = (jitter(LATERAL_JITTER_M), jitter(HEIGHT_JITTER_M));
    let (yaw, pitch) = (jitter(YAW_JITTER_DEG).to_radians(), jitter(PITCH_JITTER_DEG).to_radians());
    let c = &mut scene.camera;
    // Ego's own body (a bonnet, a robot's front) moves sideways with it.
    for part in &mut scene.stage {
        if (part.at[0] - c.at[0]).hypot(part.at[1] - c.at[1]) < EGO_BODY_M {
            part.at[1] += lateral;
        }
    }
    c.at[1] += lateral;
    c.look_at[1] += lateral;
    c.at[2] += height;
    let (dx, dy) = (c.look_at[0] - c.at[0], c.look_at[1] - c.at[1]);
    let (sin, cos) = yaw.sin_cos();
    c.look_at[0] = c.at[0] + dx * cos - dy * sin;
    c.look_at[1] = c.at[1] + dx * sin + dy * cos;
    c.look_at[2] += dx.hypot(dy) * pitch.tan();
    for v in scene.environment.values_mut() {
        let varied = *v * (1.0 + jitter(PRESET_JITTER));
        *v = if *v <= 100.0 { varied.min(100.0) } else { varied };
    }
}

/// A concrete value: ranges drawn, everything else copied.
fn draw(rng: &mut ChaCha8Rng, v: &Value) -> Value {
    match *v {
        Value::Range(lo, hi) => Value::Number(rng::uniform(rng, lo, hi)),
        ref other => other.clone(),
    }
}

fn scene_value(d: &Domain, v: &Value) -> SceneValue {
    match *v {
        Value::Bool(b) => SceneValue::Bool(b),
        Value::Number(x) => SceneValue::Number(x),
        // Not reached after `draw`; the midpoint keeps the function total.
        Value::Range(lo, hi) => SceneValue::Number((lo + hi) / 2.0),
        Value::Enum(e, i) => SceneValue::Enum(d.variant_name(e, i).to_owned()),
    }
}

fn scene_entity(
    d: &Domain,
    e: &AnchorEntity,
    concept: Option<&str>,
    position: [f64; 3],
    shape: Vec<ShapePart>,
) -> SceneEntity {
    let k = &d.kinds[e.kind.index()];
    SceneEntity {
        name: e.name.clone(),
        kind: k.name.clone(),
        concept: concept.map(str::to_owned),
        region: d.regions[e.region.index()].name.clone(),
        position,
        yaw_deg: yaw_of(d, e),
        attrs: k.attrs.iter().zip(&e.attrs).map(|(a, v)| (a.name.clone(), scene_value(d, v))).collect(),
        shape,
        drawn_by: None,
    }
}

/// Heading from an attribute named `yaw`, else facing along x.
fn yaw_of(d: &Domain, e: &AnchorEntity) -> f64 {
    match d.kinds[e.kind.index()].attr("yaw").map(|i| &e.attrs[i]) {
        Some(Value::Number(y)) => *y,
        _ => 0.0,
    }
}

/// Where an axis comes from: the attribute `attr` of the entity when it has a numeric one whose
/// (anchor) range meets the region's extent, else the region's extent.
fn axis(d: &Domain, ranged: &AnchorEntity, attr: &str, extent: (f64, f64)) -> (Axis, Option<usize>) {
    let (rlo, rhi) = (extent.0.min(extent.1), extent.0.max(extent.1));
    let slot = d.kinds[ranged.kind.index()].attr(attr);
    if let Some((lo, hi)) = slot.and_then(|i| ranged.attrs[i].bounds()) {
        let (lo, hi) = (lo.max(rlo), hi.min(rhi));
        if lo < hi {
            return (Axis::Range(lo, hi), slot);
        }
        if lo == hi {
            return (Axis::Fixed(lo), slot);
        }
    }
    (Axis::Range(rlo, rhi), slot.filter(|&i| ranged.attrs[i].bounds().is_some()))
}

/// What placing a concept set's entities needs: the anchor graph, where each entity can stand
/// ([`anchor::ground_bounds`]) and the resolved shapes.
struct Layout<'a> {
    anchor: &'a AnchorGraph,
    bounds: Vec<GroundBounds>,
    shapes: &'a [Vec<ShapePart>],
    view: &'a View,
    /// Whether each entity stands on its target (`on_top`).
    on_top: Vec<bool>,
    /// Each entity seen from a few points of where it can stand (the corners, edge midpoints
    /// and centre of its ground bounds), made when first needed: an entity placed earlier must
    /// leave one of them in view for each entity placed after it.
    probes: Vec<std::cell::OnceCell<Vec<Sight>>>,
    /// The resolved yaw and region height of each entity, for its probes.
    poses: Vec<(f64, f64)>,
}

/// One layout of a scene's entities, being built.
struct Arrangement {
    placed: Vec<Placed>,
    positions: Vec<[f64; 3]>,
    /// What the camera sees of each entity placed so far.
    sights: Vec<Option<Sight>>,
    /// The concrete entities, their `distance`/`lateral` set to where they stand.
    entities: Vec<AnchorEntity>,
}

impl Layout<'_> {
    /// Position entity `i` (its target, if any, is already placed); like [`position`], plus its
    /// relation: drawn where its region meets the relation around its target, and only where
    /// each entity related to it will still find room. With `fresh`, the first draw ignores the
    /// `distance`/`lateral` drawn with the attributes (a second layout must not repeat the first).
    fn position(&self, d: &Domain, rng: &mut ChaCha8Rng, a: &mut Arrangement, i: usize, fresh: bool) {
        let ranged = &self.anchor.entities[i];
        let region: &Region = &d.regions[ranged.region.index()];
        let placement = anchor::placement_of(d, ranged);
        let target = ranged.target.map(|t| a.positions[t]);
        let origin = target.unwrap_or([0.0; 3]);
        let (bx, by) = self.bounds[i];
        let (zx, zy) = match (placement, target) {
            (Some(p), Some(t)) => {
                let (ox, oy) = p.offset_box();
                ((t[0] + ox.0, t[0] + ox.1), (t[1] + oy.0, t[1] + oy.1))
            }
            // Around ego the bounds already hold the relation.
            _ => ((f64::NEG_INFINITY, f64::INFINITY), (f64::NEG_INFINITY, f64::INFINITY)),
        };
        let (xr, yr) = (meet_or(bx, zx), meet_or(by, zy));
        let (ax0, xslot) = axis(d, ranged, "distance", region.x);
        let (ay0, yslot) = axis(d, ranged, "lateral", region.y);
        // Where the relation does not narrow an axis, it is drawn exactly as without one.
        let ax = if ax0.extent() == xr { ax0 } else { Axis::of(xr) };
        let ay = if ay0.extent() == yr { ay0 } else { Axis::of(yr) };
        let e = &a.entities[i];
        let (x0, y0) = if fresh {
            (ax.draw(rng), ay.draw(rng))
        } else {
            let x0 = first_draw(rng, ax, xslot, e);
            (x0, first_draw(rng, ay, yslot, e))
        };
        let mut z = rng::uniform(rng, region.z.0.min(region.z.1), region.z.0.max(region.z.1));
        let yaw = yaw_of(d, e);
        let fp = Footprint::of(&self.shapes[i], yaw);
        let dependents: Vec<(usize, &Placement)> = (0..self.anchor.entities.len())
            .filter(|&j| self.anchor.entities[j].target == Some(i))
            .filter_map(|j| anchor::placement_of(d, &self.anchor.entities[j]).map(|p| (j, p)))
            .collect();
        let test = |x: f64, y: f64| {
            placement.is_none_or(|p| p.allows(x - origin[0], y - origin[1]))
                && dependents.iter().all(|&(j, p)| room(p, self.bounds[j], (x, y)).is_some())
        };
        let on_top = placement.is_some_and(|p| p.on_top) && target.is_some();
        if on_top && let Some(t) = ranged.target {
            z = origin[2] + top_of(&self.shapes[t]);
        }
        let others: Vec<&Sight> =
            (0..a.sights.len()).filter(|&j| !self.stand_together(i, j)).filter_map(|j| a.sights[j].as_ref()).collect();
        let later: Vec<usize> =
            (0..a.sights.len()).filter(|&j| a.sights[j].is_none() && !self.stand_together(i, j)).collect();
        let hidden = |x: f64, y: f64| {
            let me = self.view.sight(&self.shapes[i], yaw, [x, y, z]);
            let own = view::hidden_share(&me, others.iter().copied());
            let placed = others.iter().map(|o| view::hidden_share(o, std::iter::once(&me))).fold(own, f64::max);
            if placed > view::MAX_HIDDEN {
                return placed;
            }
            // How well the best spot left for each later entity does: the first probe hidden by
            // at most half of what is allowed (room to spare: the later entity still has to
            // find it), else the least hidden one, doubled (0 when it has no probe).
            let mutual = |p: &Sight| {
                view::hidden_share(p, std::iter::once(&me)).max(view::hidden_share(&me, std::iter::once(p)))
            };
            let best_spot = |j: usize| {
                let mut least = f64::INFINITY;
                for p in self.probes(j) {
                    least = least.min(mutual(p));
                    if least <= view::MAX_HIDDEN / 2.0 {
                        break;
                    }
                }
                if least.is_finite() { (2.0 * least).min(1.0) } else { 0.0 }
            };
            later.iter().map(|&j| best_spot(j)).fold(placed, f64::max)
        };
        let must = Must {
            test: &test,
            overlaps_ok: if on_top { ranged.target } else { None },
            rescue: placement.and_then(|p| room(p, (xr, yr), (origin[0], origin[1]))),
            hidden: &hidden,
        };
        let (x, y) = place::place(rng, &a.placed, (ranged.region.index(), region), (ax, ay), (x0, y0), fp, &must);
        a.placed.push(Placed { id: i, region: ranged.region.index(), x, y, fp });
        a.sights[i] = Some(self.view.sight(&self.shapes[i], yaw, [x, y, z]));
        for (slot, v) in [(xslot, x), (yslot, y)] {
            if let Some(s) = slot {
                a.entities[i].attrs[s] = Value::Number(v);
            }
        }
        a.positions[i] = [x, y, z];
    }

    /// Entity `j` seen from the probe points of its ground bounds.
    fn probes(&self, j: usize) -> &[Sight] {
        self.probes[j].get_or_init(|| {
            let ((x0, x1), (y0, y1)) = self.bounds[j];
            let (yaw, z) = self.poses[j];
            grid_spots((x0, x1), (y0, y1))
                .into_iter()
                .map(|(x, y)| self.view.sight(&self.shapes[j], yaw, [x, y, z]))
                .collect()
        })
    }

    /// Whether entity `i` or `j` stands on the other (or they are one): such a pair covers itself
    /// by design and is not judged for occlusion.
    fn stand_together(&self, i: usize, j: usize) -> bool {
        let on = |a: usize, b: usize| self.on_top[a] && self.anchor.entities[a].target == Some(b);
        i == j || on(i, j) || on(j, i)
    }

    /// The largest share of an entity's projected area that the others of the layout cover.
    fn worst_hidden(&self, a: &Arrangement) -> f64 {
        (0..a.sights.len())
            .filter_map(|i| {
                let me = a.sights[i].as_ref()?;
                let others =
                    (0..a.sights.len()).filter(|&j| !self.stand_together(i, j)).filter_map(|j| a.sights[j].as_ref());
                Some(view::hidden_share(me, others))
            })
            .fold(0.0, f64::max)
    }
}

/// The centre, edge midpoints and corners of a ground box, centre first.
fn grid_spots((x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Vec<(f64, f64)> {
    let (xm, ym) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    vec![(xm, ym), (xm, y0), (xm, y1), (x0, ym), (x1, ym), (x0, y0), (x0, y1), (x1, y0), (x1, y1)]
}

/// The intersection of `own` and `zone`, or `zone` when they do not meet (the relation decides).
fn meet_or(own: (f64, f64), zone: (f64, f64)) -> (f64, f64) {
    let m = (own.0.max(zone.0), own.1.min(zone.1));
    if m.0 <= m.1 { m } else { zone }
}

/// A point of `bounds` that the placement allows around `at`, if there is one: the nearest to
/// `at` first (it decides an upper distance bound), else a corner or the centre.
fn room(p: &Placement, bounds: GroundBounds, at: (f64, f64)) -> Option<(f64, f64)> {
    let (ox, oy) = p.offset_box();
    let (x, y) = (meet(bounds.0, (at.0 + ox.0, at.0 + ox.1))?, meet(bounds.1, (at.1 + oy.0, at.1 + oy.1))?);
    let nearest = (at.0.clamp(x.0, x.1), at.1.clamp(y.0, y.1));
    let centre = ((x.0 + x.1) / 2.0, (y.0 + y.1) / 2.0);
    [nearest, (x.0, y.0), (x.0, y.1), (x.1, y.0), (x.1, y.1), centre]
        .into_iter()
        .find(|&(px, py)| p.allows(px - at.0, py - at.1))
}

fn meet(a: (f64, f64), b: (f64, f64)) -> Option<(f64, f64)> {
    let m = (a.0.max(b.0), a.1.min(b.1));
    (m.0 <= m.1).then_some(m)
}

/// The height of a shape's highest face above its origin (what stands on it stands there).
fn top_of(parts: &[ShapePart]) -> f64 {
    parts.iter().map(|p| p.at[2] + p.size[2] / 2.0).fold(0.0, f64::max)
}

/// The first value of an axis: the attribute already drawn with the entity when it fits.
fn first_draw(rng: &mut ChaCha8Rng, a: Axis, slot: Option<usize>, e: &AnchorEntity) -> f64 {
    match (a, slot.map(|i| &e.attrs[i])) {
        (Axis::Range(lo, hi), Some(Value::Number(v))) if (lo..=hi).contains(v) => *v,
        (Axis::Fixed(v), _) => v,
        (Axis::Range(lo, hi), _) => rng::uniform(rng, lo, hi),
    }
}

/// Position an extra in its region, where it hides none of the `guarded` entities (those the
/// concepts placed) by more than [`view::MAX_HIDDEN`] if it can; the `distance`/`lateral`
/// attributes are updated to the coordinates actually used, so the scene never contradicts itself.
fn position(
    d: &Domain,
    rng: &mut ChaCha8Rng,
    placed: &mut Vec<Placed>,
    (ranged, e, shape): (&AnchorEntity, &mut AnchorEntity, &[ShapePart]),
    view: &View,
    guarded: &[Sight],
) -> [f64; 3] {
    let region: &Region = &d.regions[e.region.index()];
    let (ax, xslot) = axis(d, ranged, "distance", region.x);
    let (ay, yslot) = axis(d, ranged, "lateral", region.y);
    let x0 = first_draw(rng, ax, xslot, e);
    let y0 = first_draw(rng, ay, yslot, e);
    let z = rng::uniform(rng, region.z.0.min(region.z.1), region.z.0.max(region.z.1));
    let yaw = yaw_of(d, e);
    let fp = Footprint::of(shape, yaw);
    let hidden = |x: f64, y: f64| {
        let me = view.sight(shape, yaw, [x, y, z]);
        guarded.iter().map(|o| view::hidden_share(o, std::iter::once(&me))).fold(0.0, f64::max)
    };
    let must = Must { test: &|_, _| true, overlaps_ok: None, rescue: None, hidden: &hidden };
    let (x, y) = place::place(rng, placed, (e.region.index(), region), (ax, ay), (x0, y0), fp, &must);
    placed.push(Placed { id: usize::MAX, region: e.region.index(), x, y, fp });
    for (slot, v) in [(xslot, x), (yslot, y)] {
        if let Some(i) = slot {
            e.attrs[i] = Value::Number(v);
        }
    }
    [x, y, z]
}

/// The parts drawn for entity `i`: its concept's shape override, else its kind's look.
fn entity_shape(d: &Domain, g: &AnchorGraph, i: usize) -> Vec<ShapePart> {
    let e = &g.entities[i];
    let parts = d.concepts[e.concept.index()].render.shape.as_deref().unwrap_or(&d.kinds[e.kind.index()].shape);
    resolve_parts(d, g, Some(i), parts)
}

/// Keep the parts whose `when` holds (with `self` bound to entity `me`), conditions dropped.
fn resolve_parts(d: &Domain, g: &AnchorGraph, me: Option<usize>, parts: &[ShapePart]) -> Vec<ShapePart> {
    parts
        .iter()
        .filter(|p| p.when.as_ref().is_none_or(|w| holds(d, g, me, w)))
        .map(|p| ShapePart { when: None, ..p.clone() })
        .collect()
}

fn holds(d: &Domain, g: &AnchorGraph, me: Option<usize>, expr: &crate::ir::Expr) -> bool {
    let mut bindings: Vec<(String, usize)> = me.map(|i| ("self".to_owned(), i)).into_iter().collect();
    anchor::eval(d, g, expr, &mut bindings) == Tri::True
}

/// A stage item's parts in the scene frame, once per repeat, if its condition holds.
fn stage_parts(d: &Domain, g: &AnchorGraph, item: &StageItem) -> Vec<ShapePart> {
    if item.when.as_ref().is_some_and(|w| !holds(d, g, None, w)) {
        return Vec::new();
    }
    let parts = resolve_parts(d, g, None, &item.parts);
    let (count, step) = item.repeat.unwrap_or((1, [0.0; 3]));
    let mut out = Vec::with_capacity(parts.len() * count as usize);
    for n in 0..count {
        let n = f64::from(n);
        for p in &parts {
            let mut p = p.clone();
            for ((a, base), step) in p.at.iter_mut().zip(item.at).zip(step) {
                *a += base + n * step;
            }
            out.push(p);
        }
    }
    out
}

/// Parameters of the presets bound to the world's enum values, in preset declaration order
/// (a later preset overrides a parameter an earlier one set). Unbound presets do not apply.
fn environment(d: &Domain, world: &[Value]) -> BTreeMap<String, f64> {
    let mut env = BTreeMap::new();
    for p in &d.presets {
        let Some((e, v)) = p.for_variant else { continue };
        if world.contains(&Value::Enum(e, v)) {
            env.extend(p.params.iter().cloned());
        }
    }
    env
}

#[cfg(test)]
pub(crate) mod fixture;

#[cfg(test)]
mod tests;

//! Seeded scene sampler: a concept set's anchor graph (paper §3.1) concretised into a [`Scene`].
//!
//! What a sample fixes, in this order (the order of the random draws, so it is part of the
//! reproducibility contract):
//! 1. world attributes: ranges drawn uniformly, enums and booleans copied;
//! 2. each entity's attributes, in the kind's attribute order, the same way;
//! 3. each entity's position in its region: x from a `distance` attribute and y from a `lateral`
//!    attribute when the kind has one whose range meets the region's extent (drawn inside the
//!    intersection), otherwise uniformly in the region; z uniformly in the region. Entities in
//!    one region do not overlap (see [`place`]);
//! 4. environmental extras (see below).
//!
//! Sets that are not valid (`lattice::validate`: constraints, modifier targets, the empty set)
//! are refused with the reason.
//!
//! Shape and stage `when` conditions are evaluated with [`anchor::eval`] on the *concrete*
//! graph (every range replaced by its drawn value), `self` bound to the entity.
//!
//! **Extras.** Kinds carrying the tag `Extra` are scenery: each scene gets 0 to [`MAX_EXTRAS`]
//! of them (kind, region and count drawn from the seed), placed in the *scenery regions*: the
//! regions no concept places anything in (no `add … in R`, no `move R`), so by construction
//! away from everything the rules look at (the far kerb, the verge behind the sidewalk, the far
//! end of a counter). They are not in the concept set's anchor graph, so they never change the
//! expected answer. A domain with no `Extra` kind or no scenery region gets no extras.
//!
//! **Determinism.** The stream is ChaCha8 seeded by SHA-256 of (domain hash, set bits, seed);
//! nothing iterates a hash map. The same inputs give the same scene on any machine.

mod place;
mod rng;

use std::collections::BTreeMap;

use rand_chacha::ChaCha8Rng;

use crate::anchor::{self, AnchorEntity, AnchorGraph, Tri};
use crate::ir::{ConceptSet, Domain, Effect, KindId, Region, RegionId, Relation, ShapePart, StageItem, Value};
use crate::lattice::Validity;
use crate::scene::{Scene, SceneEntity, SceneValue};
use place::{Axis, Footprint, Placed};
pub use rng::domain_hash;

/// Most extras in one scene.
pub const MAX_EXTRAS: u64 = 3;
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
    extra_kinds: Vec<KindId>,
    extra_regions: Vec<RegionId>,
    validity: Validity,
}

impl<'d> Sampler<'d> {
    pub fn new(domain: &'d Domain) -> Self {
        let digest = rng::domain_digest(domain);
        let extra_kinds = match domain.tag_by_name(EXTRA_TAG) {
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
        let extra_regions = (0..domain.regions.len() as u32).map(RegionId).filter(|r| !used.contains(r)).collect();
        Sampler {
            domain,
            digest,
            hash: hex::encode(digest),
            extra_kinds,
            extra_regions,
            validity: Validity::new(domain),
        }
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
        let mut placed = Vec::with_capacity(concrete.entities.len());
        let mut entities = Vec::with_capacity(concrete.entities.len());
        for (i, shape) in shapes.into_iter().enumerate() {
            let (ranged, e) = (&anchor.entities[i], &mut concrete.entities[i]);
            let position = position(d, &mut rng, &mut placed, ranged, e, &shape);
            entities.push(scene_entity(d, e, Some(&d.concepts[e.concept.index()].name), position, shape));
        }
        let extras = self.extras(&mut rng, &mut concrete, &mut placed);
        Ok(Scene {
            domain: d.name.clone(),
            domain_hash: self.hash.clone(),
            concepts: d.set_names(set).into_iter().map(str::to_owned).collect(),
            seed,
            world: d.world.iter().zip(&concrete.world).map(|(a, v)| (a.name.clone(), scene_value(d, v))).collect(),
            environment: environment(d, &concrete.world),
            entities,
            extras,
            stage: d.stage.iter().flat_map(|s| stage_parts(d, &concrete, s)).collect(),
            camera: d.camera.clone(),
        })
    }

    /// Draw the scenery extras. They are evaluated on the concrete graph (for their own shape
    /// conditions) but removed again, so they never take part in anything the concepts decide.
    fn extras(&self, rng: &mut ChaCha8Rng, g: &mut AnchorGraph, placed: &mut Vec<Placed>) -> Vec<SceneEntity> {
        if self.extra_kinds.is_empty() || self.extra_regions.is_empty() {
            return Vec::new();
        }
        let d = self.domain;
        let n = rng::below(rng, MAX_EXTRAS + 1);
        let mut out = Vec::with_capacity(n as usize);
        for i in 0..n {
            let kind = self.extra_kinds[rng::below(rng, self.extra_kinds.len() as u64) as usize];
            let region = self.extra_regions[rng::below(rng, self.extra_regions.len() as u64) as usize];
            let k = &d.kinds[kind.index()];
            let ranged = AnchorEntity {
                name: format!("extra{}", i + 1),
                kind,
                concept: crate::ir::ConceptId(0),
                region,
                relation: Relation { name: String::new(), to: None },
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
            let position = position(d, rng, placed, &ranged, &mut e, &shape);
            out.push(scene_entity(d, &e, None, position, shape));
        }
        out
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

/// Position an entity in its region; the `distance`/`lateral` attributes are updated to the
/// coordinates actually used, so the scene never contradicts itself.
fn position(
    d: &Domain,
    rng: &mut ChaCha8Rng,
    placed: &mut Vec<Placed>,
    ranged: &AnchorEntity,
    e: &mut AnchorEntity,
    shape: &[ShapePart],
) -> [f64; 3] {
    let region: &Region = &d.regions[e.region.index()];
    let (ax, xslot) = axis(d, ranged, "distance", region.x);
    let (ay, yslot) = axis(d, ranged, "lateral", region.y);
    let first_draw =
        |rng: &mut ChaCha8Rng, a: Axis, slot: Option<usize>, e: &AnchorEntity| match (a, slot.map(|i| &e.attrs[i])) {
            // The attribute was already drawn with the entity; keep that draw when it fits.
            (Axis::Range(lo, hi), Some(Value::Number(v))) if (lo..=hi).contains(v) => *v,
            (Axis::Fixed(v), _) => v,
            (Axis::Range(lo, hi), _) => rng::uniform(rng, lo, hi),
        };
    let x0 = first_draw(rng, ax, xslot, e);
    let y0 = first_draw(rng, ay, yslot, e);
    let z = rng::uniform(rng, region.z.0.min(region.z.1), region.z.0.max(region.z.1));
    let fp = Footprint::of(shape, yaw_of(d, e));
    let (x, y) = place::place(rng, placed, (e.region.index(), region), (ax, ay), (x0, y0), fp);
    placed.push(Placed { region: e.region.index(), x, y, fp });
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

//! The Domain IR: the one contract between the compiler and everything after it.
//!
//! The front end (`syntax` → `check`) lowers `.rev` files into a [`Domain`]. Every later stage
//! (lattice, oracle, sampler, emitters, renderer, search) reads only this module's types, never
//! syntax. All collections are in declaration order, and every index (`ConceptId`, `KindId`, …)
//! is stable for a given source: a concept's index is its bit in a [`ConceptSet`].
//!
//! Spans are kept (as byte ranges into a named source file) so that lattice lints can point at
//! the declaration that causes them.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

mod identity;
#[cfg(test)]
pub(crate) mod testkit;

pub use identity::DomainId;

/// Maximum number of concepts a domain may declare (the width of a [`ConceptSet`]).
pub const MAX_CONCEPTS: usize = 512;

pub use crate::diag::Span;

macro_rules! id_type {
    ($($(#[$m:meta])* $name:ident;)*) => {$(
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub u32);
        impl $name {
            pub fn index(self) -> usize { self.0 as usize }
        }
    )*};
}

id_type! {
    /// Index into [`Domain::concepts`]; also the concept's bit in a [`ConceptSet`].
    ConceptId;
    /// Index into [`Domain::kinds`].
    KindId;
    /// Index into [`Domain::tags`].
    TagId;
    /// Index into [`Domain::enums`].
    EnumId;
    /// Index into [`Domain::regions`].
    RegionId;
    /// Index into [`Domain::questions`].
    QuestionId;
    /// Index into [`Domain::rules`].
    RuleId;
    /// Index into [`Domain::presets`].
    PresetId;
}

/// Words in a [`ConceptSet`].
const WORDS: usize = MAX_CONCEPTS / 64;

/// A set of concepts as a fixed-width bitset (bit i = concept i), [`MAX_CONCEPTS`] wide. Ordered
/// (as the number its bits spell) and hashable so that sets can be used as map keys; the
/// canonical order of sets is defined in `lattice`.
///
/// Serialised as that number while it fits 64 bits (the shipped domains' sets, unchanged from
/// the 128-bit sets of earlier versions), else as its 64-bit words, least significant first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct ConceptSet([u64; WORDS]);

impl Ord for ConceptSet {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.iter().rev().cmp(o.0.iter().rev())
    }
}

impl PartialOrd for ConceptSet {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl ConceptSet {
    pub const EMPTY: ConceptSet = ConceptSet([0; WORDS]);
    /// The set whose bits are `bits` (concepts 0 to 127).
    pub const fn from_bits(bits: u128) -> Self {
        let mut w = [0; WORDS];
        w[0] = bits as u64;
        w[1] = (bits >> 64) as u64;
        ConceptSet(w)
    }
    /// Concepts `0..n` (all of [`MAX_CONCEPTS`] past it).
    pub fn first_n(n: usize) -> Self {
        let mut w = [0; WORDS];
        for (i, x) in w.iter_mut().enumerate() {
            let lo = i * 64;
            *x = if n >= lo + 64 {
                u64::MAX
            } else if n > lo {
                (1u64 << (n - lo)) - 1
            } else {
                0
            };
        }
        ConceptSet(w)
    }
    /// The concepts from `c` on (all of them past it).
    pub fn from_concept(c: ConceptId) -> Self {
        ConceptSet::first_n(MAX_CONCEPTS).difference(ConceptSet::first_n(c.index()))
    }
    pub fn single(c: ConceptId) -> Self {
        ConceptSet::EMPTY.with(c)
    }
    pub fn from_ids(ids: impl IntoIterator<Item = ConceptId>) -> Self {
        ids.into_iter().fold(Self::EMPTY, |s, c| s.with(c))
    }
    /// The low 128 bits (concepts 0 to 127), for tests and narrow hashes.
    pub fn low_bits(self) -> u128 {
        self.0[0] as u128 | (self.0[1] as u128) << 64
    }
    /// The 64-bit words, least significant (concepts 0 to 63) first.
    pub fn words(&self) -> &[u64] {
        &self.0
    }
    /// Whether only concepts 0 to 127 are in the set.
    pub fn fits_128(self) -> bool {
        self.0[2..].iter().all(|&w| w == 0)
    }
    /// Bytes for a content hash: 16 bytes (the 128-bit set of earlier versions, so scene streams
    /// of the shipped domains do not change) when the set fits, else every word.
    pub fn hash_bytes(self) -> Vec<u8> {
        if self.fits_128() {
            self.low_bits().to_le_bytes().to_vec()
        } else {
            self.0.iter().flat_map(|w| w.to_le_bytes()).collect()
        }
    }
    pub fn contains(self, c: ConceptId) -> bool {
        let i = c.index();
        i < MAX_CONCEPTS && self.0[i / 64] >> (i % 64) & 1 == 1
    }
    /// The set with `c` added. Panics past [`MAX_CONCEPTS`]: the checker refuses such concepts.
    #[must_use]
    pub fn with(mut self, c: ConceptId) -> Self {
        let i = c.index();
        self.0[i / 64] |= 1 << (i % 64);
        self
    }
    #[must_use]
    pub fn without(mut self, c: ConceptId) -> Self {
        let i = c.index();
        if i < MAX_CONCEPTS {
            self.0[i / 64] &= !(1 << (i % 64));
        }
        self
    }
    pub fn insert(&mut self, c: ConceptId) {
        *self = self.with(c);
    }
    pub fn remove(&mut self, c: ConceptId) {
        *self = self.without(c);
    }
    pub fn len(self) -> usize {
        // Zero words are skipped: a count of ones is a dozen instructions without POPCNT, and a
        // domain of fewer than 128 concepts leaves six words empty.
        self.0.iter().filter(|&&w| w != 0).map(|w| w.count_ones() as usize).sum()
    }
    pub fn is_empty(self) -> bool {
        self.0.iter().all(|&w| w == 0)
    }
    #[inline]
    fn zip(self, o: Self, f: impl Fn(u64, u64) -> u64) -> Self {
        let mut w = [0; WORDS];
        for (i, x) in w.iter_mut().enumerate() {
            *x = f(self.0[i], o.0[i]);
        }
        ConceptSet(w)
    }
    pub fn union(self, o: Self) -> Self {
        self.zip(o, |a, b| a | b)
    }
    pub fn intersection(self, o: Self) -> Self {
        self.zip(o, |a, b| a & b)
    }
    /// The concepts of `self` not in `o`.
    pub fn difference(self, o: Self) -> Self {
        self.zip(o, |a, b| a & !b)
    }
    /// The concepts in exactly one of the two sets.
    pub fn symmetric_difference(self, o: Self) -> Self {
        self.zip(o, |a, b| a ^ b)
    }
    /// Whether the sets share a concept.
    pub fn intersects(self, o: Self) -> bool {
        (0..WORDS).any(|i| self.0[i] & o.0[i] != 0)
    }
    pub fn is_subset_of(self, o: Self) -> bool {
        (0..WORDS).all(|i| self.0[i] & !o.0[i] == 0)
    }
    /// The lowest concept index in the set.
    pub fn first(self) -> Option<ConceptId> {
        let i = self.0.iter().position(|&w| w != 0)?;
        Some(ConceptId((i * 64) as u32 + self.0[i].trailing_zeros()))
    }
    /// The highest concept index in the set.
    pub fn last(self) -> Option<ConceptId> {
        let i = self.0.iter().rposition(|&w| w != 0)?;
        Some(ConceptId((i * 64) as u32 + 63 - self.0[i].leading_zeros()))
    }
    /// Concept ids in ascending index (declaration) order.
    pub fn iter(self) -> impl Iterator<Item = ConceptId> + Clone {
        let mut word = 0usize;
        let mut bits = self.0[0];
        std::iter::from_fn(move || {
            while bits == 0 {
                word += 1;
                if word == WORDS {
                    return None;
                }
                bits = self.0[word];
            }
            let i = bits.trailing_zeros();
            bits &= bits - 1;
            Some(ConceptId((word * 64) as u32 + i))
        })
    }
    /// The non-empty subsets one concept smaller, in concept order (none for a single concept).
    pub fn one_smaller(self) -> impl Iterator<Item = ConceptSet> {
        self.iter().map(move |c| self.without(c)).filter(|s| !s.is_empty())
    }
    /// Every non-empty proper subset, largest (as a number) first. The set has few members in
    /// practice (2^len − 2 subsets).
    pub fn proper_subsets(self) -> impl Iterator<Item = ConceptSet> {
        let ids: Vec<ConceptId> = self.iter().collect();
        let full = if ids.is_empty() { 0u64 } else { (1u64 << ids.len().min(63)) - 1 };
        let mut sub = full.wrapping_sub(1) & full;
        std::iter::from_fn(move || {
            if sub == 0 {
                return None;
            }
            let s = ConceptSet::from_ids(ids.iter().enumerate().filter(|(i, _)| sub >> i & 1 == 1).map(|(_, c)| *c));
            sub = sub.wrapping_sub(1) & full;
            Some(s)
        })
    }
    /// Jaccard similarity |a∩b| / |a∪b| (1.0 for two empty sets).
    pub fn jaccard(self, o: Self) -> f64 {
        let u = self.union(o).len();
        if u == 0 { 1.0 } else { self.intersection(o).len() as f64 / u as f64 }
    }
}

impl Serialize for ConceptSet {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0[1..].iter().all(|&w| w == 0) {
            return s.serialize_u64(self.0[0]);
        }
        let used = self.0.iter().rposition(|&w| w != 0).map_or(0, |i| i + 1);
        s.collect_seq(&self.0[..used])
    }
}

impl<'de> Deserialize<'de> for ConceptSet {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = ConceptSet;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "a concept set: a number or at most {WORDS} 64-bit words")
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<ConceptSet, E> {
                Ok(ConceptSet::from_bits(v as u128))
            }
            fn visit_u128<E: serde::de::Error>(self, v: u128) -> Result<ConceptSet, E> {
                Ok(ConceptSet::from_bits(v))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<ConceptSet, A::Error> {
                let mut w = [0u64; WORDS];
                let mut i = 0;
                while let Some(x) = seq.next_element::<u64>()? {
                    if i == WORDS {
                        return Err(serde::de::Error::invalid_length(i + 1, &self));
                    }
                    w[i] = x;
                    i += 1;
                }
                Ok(ConceptSet(w))
            }
        }
        d.deserialize_any(V)
    }
}

/// A source file the domain was compiled from (stdlib modules included), for diagnostics.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SourceFile {
    /// Display name: a path as given by the user, or `std/<module>.rev` for the stdlib.
    pub name: String,
    pub text: String,
}

/// A compiled domain.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Domain {
    pub name: String,
    /// Every file that contributed, in load order (the domain file first).
    pub files: Vec<SourceFile>,
    pub units: Vec<Unit>,
    pub relations: Vec<RelationDef>,
    pub enums: Vec<EnumDef>,
    pub tags: Vec<TagDef>,
    pub kinds: Vec<Kind>,
    /// Attributes of the world (map, weather, intersection ahead, …) with their defaults.
    pub world: Vec<AttrDef>,
    /// Named placement regions (lane, sidewalk, counter top, floor, …) in the scene frame.
    pub regions: Vec<Region>,
    /// Named bundles of renderer/simulator parameters (weather presets).
    pub presets: Vec<Preset>,
    /// Static scenery (road, buildings, kitchen fixtures) drawn in every scene of the domain.
    pub stage: Vec<StageItem>,
    /// Concepts and modifiers; the index is the bit index.
    pub concepts: Vec<Concept>,
    pub constraints: Vec<Constraint>,
    pub questions: Vec<Question>,
    pub selection: Selection,
    /// Rules in selection order (priority order for `Selection::Priority`; declaration order,
    /// which is also the tie-break order, for `Selection::BestFit`).
    pub rules: Vec<Rule>,
    /// Where the scene's camera sits (renderer).
    pub camera: Camera,
    /// Lattice-lint codes silenced by `allow CODE` items (with their doc comments as reasons).
    pub allow: Vec<Allow>,
    /// What counts as visible in a rendered scene (`visible` items).
    #[serde(default)]
    pub visibility: Visibility,
}

/// When an entity a concept placed counts as seen in a rendered image: at least `pixels`
/// pixels of it after occlusion, with at least `contrast` against its surround (the builtin
/// renderer's figures, see docs/render.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct VisibleIf {
    pub pixels: u32,
    pub contrast: f64,
}

impl VisibleIf {
    /// Without a `visible { … }` item: a few dozen pixels (a pedestrian at 60 m on a 640×360
    /// frame covers about 60) that differ from their surround by more than rendering noise.
    pub const DEFAULT: VisibleIf = VisibleIf { pixels: 20, contrast: 0.02 };

    pub fn holds(&self, pixels: u32, contrast: f64) -> bool {
        pixels >= self.pixels && contrast >= self.contrast
    }
}

/// A domain's visibility thresholds: the default, then overrides per entity kind and per
/// concept (a concept's override wins over its entity's kind's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Visibility {
    pub default: VisibleIf,
    /// Per kind, already resolved by the checker: the kind's own `visible` override or the one
    /// it inherits from its nearest parent kind or tag. A kind without any is not listed.
    pub kinds: BTreeMap<String, VisibleIf>,
    pub concepts: BTreeMap<String, VisibleIf>,
}

impl Default for Visibility {
    fn default() -> Visibility {
        Visibility { default: VisibleIf::DEFAULT, kinds: BTreeMap::new(), concepts: BTreeMap::new() }
    }
}

impl Visibility {
    /// The threshold for an entity of `kind` placed by `concept`.
    pub fn threshold(&self, kind: &str, concept: Option<&str>) -> VisibleIf {
        concept.and_then(|c| self.concepts.get(c)).or_else(|| self.kinds.get(kind)).copied().unwrap_or(self.default)
    }
}

/// `allow CODE`: a deliberate, documented exception to a lattice lint.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Allow {
    pub code: String,
    pub reason: String,
    pub span: Span,
}

/// A unit of measure. Numbers are stored in the unit's base (e.g. metres), `scale` converts.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Unit {
    /// The suffix written in source (`m`, `cm`, `deg`, `s`, `pct`).
    pub name: String,
    /// The dimension it measures (`length`, `angle`, `time`, `ratio`).
    pub dimension: String,
    /// Multiply a source value by this to get the dimension's base unit.
    pub scale: f64,
}

/// A relation usable in `add … RELATION (ego | ENTITY)` (`ahead_of`, `on`, `near` …) and in
/// rule conditions (`e near g`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RelationDef {
    pub name: String,
    /// How it reads ("is ahead of").
    pub text: String,
    /// Where the relation puts an entity relative to its target.
    pub placement: Placement,
    pub span: Span,
}

/// Ground-position bounds: x (ahead) and y (left) ranges, in the scene frame (metres).
pub type GroundBounds = ((f64, f64), (f64, f64));

/// Where a relation puts an entity relative to its target, in the scene frame (x ahead of the
/// camera, y to its left): every given bound holds at once. Offsets are between the two
/// entities' origins (on the ground under their centres; ego's is the scene origin).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Placement {
    /// Ground-plane distance between the two origins (metres, inclusive).
    pub distance: Option<(f64, f64)>,
    /// How far ahead of the target (along x; negative: behind it).
    pub ahead: Option<(f64, f64)>,
    /// How far to the left of the target (along y; negative: to its right).
    pub left: Option<(f64, f64)>,
    /// Standing on top of the target: at its ground position, on its highest face.
    pub on_top: bool,
}

impl Placement {
    /// The box of ground offsets `(dx, dy)` from the target that the placement can allow
    /// (tight for `ahead`/`left`/`on_top`; a disc's bounding square for `distance`).
    pub fn offset_box(&self) -> ((f64, f64), (f64, f64)) {
        let mut x = (f64::NEG_INFINITY, f64::INFINITY);
        let mut y = x;
        let meet = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.min(b.1));
        if let Some((_, hi)) = self.distance {
            x = meet(x, (-hi, hi));
            y = meet(y, (-hi, hi));
        }
        if let Some(r) = self.ahead {
            x = meet(x, r);
        }
        if let Some(r) = self.left {
            y = meet(y, r);
        }
        if self.on_top {
            x = meet(x, (0.0, 0.0));
            y = meet(y, (0.0, 0.0));
        }
        (x, y)
    }

    /// Whether the ground offset `(dx, dy)` from the target satisfies the placement (with a
    /// nanometre of slack for rounding).
    pub fn allows(&self, dx: f64, dy: f64) -> bool {
        const EPS: f64 = 1e-9;
        let within = |v: f64, (lo, hi): (f64, f64)| v >= lo - EPS && v <= hi + EPS;
        self.distance.is_none_or(|r| within(dx.hypot(dy), r))
            && self.ahead.is_none_or(|r| within(dx, r))
            && self.left.is_none_or(|r| within(dy, r))
            && (!self.on_top || (dx.abs() <= EPS && dy.abs() <= EPS))
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EnumDef {
    pub name: String,
    pub variants: Vec<String>,
    pub span: Span,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TagDef {
    pub name: String,
    pub doc: String,
    pub span: Span,
}

/// The type of an attribute.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum AttrType {
    Bool,
    /// A number of a dimension (`length`, …; `""` for a plain number), within `[min, max]`
    /// (base units).
    Number {
        dimension: String,
        min: f64,
        max: f64,
    },
    Enum(EnumId),
}

/// A value on the anchor scene graph: a number may be a range (sampled later).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Value {
    Bool(bool),
    /// A number in base units.
    Number(f64),
    /// An inclusive range in base units, `lo <= hi`.
    Range(f64, f64),
    /// An enum variant: (enum, variant index).
    Enum(EnumId, u32),
}

impl Value {
    /// Inclusive bounds of a numeric value.
    pub fn bounds(&self) -> Option<(f64, f64)> {
        match *self {
            Value::Number(x) => Some((x, x)),
            Value::Range(a, b) => Some((a, b)),
            _ => None,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AttrDef {
    pub name: String,
    pub ty: AttrType,
    pub default: Value,
    pub doc: String,
    pub span: Span,
}

/// An entity kind (`Pedestrian`, `Glass`, …). Attributes include those inherited from tags and
/// parents, already flattened by the checker.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Kind {
    pub name: String,
    pub doc: String,
    /// Every tag the kind carries: its parent tags, their ancestors, and the tags of its parent
    /// kinds, transitively. Parent *kinds* are not tags: a filter that names a kind lists that
    /// kind and its descendants in [`TargetFilter::kinds`].
    pub tags: Vec<TagId>,
    pub attrs: Vec<AttrDef>,
    /// Default look in the builtin renderer.
    pub shape: Vec<ShapePart>,
    /// The only regions an entity of this kind may stand in (`in REGION, …`); empty: any.
    #[serde(default)]
    pub regions: Vec<RegionId>,
    pub span: Span,
}

impl Kind {
    pub fn attr(&self, name: &str) -> Option<usize> {
        self.attrs.iter().position(|a| a.name == name)
    }
    pub fn has_tag(&self, t: TagId) -> bool {
        self.tags.contains(&t)
    }
    /// Whether an entity of this kind may stand in region `r`.
    pub fn may_stand_in(&self, r: RegionId) -> bool {
        self.regions.is_empty() || self.regions.contains(&r)
    }
}

/// A placement region in the scene frame: x forward (metres ahead of the ego/camera), y left,
/// z up. The sampler draws positions uniformly inside; an entity attribute named `distance`
/// (if the kind has one) overrides x, and `lateral` overrides y.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Region {
    pub name: String,
    pub doc: String,
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub z: (f64, f64),
    /// Scenic placement text for this region (e.g. `on visible ego.lane` or a sidewalk
    /// specifier); `{distance}` is substituted by the emitter.
    pub scenic: Option<String>,
    pub span: Span,
}

/// The parameters a preset may set: the environment the renderers and the Scenic emitter read,
/// named after CARLA's `carla.WeatherParameters` fields (percentages 0–100 unless said).
pub const ENVIRONMENT_PARAMS: &[(&str, &str)] = &[
    ("cloudiness", "cloud cover, 0–100"),
    ("precipitation", "rain intensity, 0–100"),
    ("precipitation_deposits", "puddles on the ground, 0–100"),
    ("wind_intensity", "wind, 0–100 (Scenic/CARLA only)"),
    ("sun_azimuth_angle", "sun azimuth in degrees"),
    ("sun_altitude_angle", "sun altitude in degrees, -90–90 (below 0: night)"),
    ("fog_density", "fog thickness, 0–100"),
    ("fog_distance", "where fog starts, metres"),
    ("wetness", "wet surfaces, 0–100"),
];

/// A named bundle of numeric parameters (e.g. a CARLA weather preset: cloudiness,
/// precipitation, fog_density, wetness, sun_altitude_angle, …). World attributes of an enum type
/// can map each variant to a preset (see [`Domain::presets`] and `Preset::for_variant`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Preset {
    pub name: String,
    pub doc: String,
    /// When `Some((enum, variant))`, this preset applies when a world attribute of that enum
    /// type has that variant.
    pub for_variant: Option<(EnumId, u32)>,
    pub params: Vec<(String, f64)>,
    pub span: Span,
}

/// One primitive of a builtin-renderer shape, in the entity's local frame (metres; origin on the
/// ground under the entity's centre; x forward/away from camera, y left, z up).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapePart {
    pub prim: Primitive,
    /// Full extents along x, y, z (a cylinder/capsule uses x as diameter, z as height).
    pub size: [f64; 3],
    /// Centre offset of the primitive from the entity origin.
    pub at: [f64; 3],
    /// sRGB colour components in 0..=1 (as written in `#rrggbb[aa]`) plus alpha.
    pub color: [f64; 4],
    /// Rotation in degrees: `roll` about x (a tipped glass; positive tips the top to the
    /// right, towards -y), then `pitch` about y (positive tilts the top forward, towards +x),
    /// then `yaw` about z (positive turns x towards y). As a matrix: R = Rz(yaw)·Ry(pitch)·Rx(roll).
    pub yaw_deg: f64,
    pub roll_deg: f64,
    #[serde(default, skip_serializing_if = "is_zero")]
    pub pitch_deg: f64,
    /// Material hint: `matte`, `metal`, `glass`, `emissive`, `water`, `flame`, `smoke`.
    pub material: String,
    /// Only draw this part when the condition holds for the entity/world (e.g. a lit lamp).
    pub when: Option<Expr>,
    /// Whether the part counts in its entity's blob shadow (`shadow false`: a lamp or a sign
    /// high above the ground casts none).
    #[serde(default = "yes", skip_serializing_if = "is_yes")]
    pub shadow: bool,
}

fn yes() -> bool {
    true
}

fn is_yes(b: &bool) -> bool {
    *b
}

/// Materials the builtin renderer knows (the checker rejects others). `light` is a lamp: drawn
/// like `emissive`, and it lights the scene around it (a ceiling panel, a strip light); `glossy`
/// is a polished or wet floor that mirrors the lamps; `mirror` reflects nearly everything.
pub const MATERIALS: &[&str] =
    &["matte", "metal", "glass", "emissive", "water", "flame", "smoke", "light", "glossy", "mirror"];

/// Materials the builtin renderer draws see-through: what stands behind a part of one of them
/// stays seen (its colour's alpha below 1 does the same).
pub const TRANSLUCENT_MATERIALS: &[&str] = &["glass", "water", "flame", "smoke"];

impl ShapePart {
    /// Whether what stands behind the part stays seen through it.
    pub fn is_translucent(&self) -> bool {
        self.color[3] < 1.0 || TRANSLUCENT_MATERIALS.contains(&self.material.as_str())
    }

    /// The part's rotation as a row-major matrix, R = Rz(yaw)·Ry(pitch)·Rx(roll): a point is
    /// rolled about x, then pitched about y, then yawed about z, about the part's own centre.
    /// The renderer and the sampler's view of the scene both turn parts with it.
    pub fn rotation(&self) -> [[f64; 3]; 3] {
        rotation(self.yaw_deg, self.pitch_deg, self.roll_deg)
    }
}

/// R = Rz(yaw)·Ry(pitch)·Rx(roll), angles in degrees, row-major (see [`ShapePart::rotation`]).
pub fn rotation(yaw_deg: f64, pitch_deg: f64, roll_deg: f64) -> [[f64; 3]; 3] {
    let (sz, cz) = yaw_deg.to_radians().sin_cos();
    let (sy, cy) = pitch_deg.to_radians().sin_cos();
    let (sx, cx) = roll_deg.to_radians().sin_cos();
    [
        [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
        [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
        [-sy, cy * sx, cy * cx],
    ]
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Primitive {
    Box,
    Cylinder,
    Capsule,
    Sphere,
    /// A flat quad in the xy plane (size z ignored).
    Plane,
    /// A cone (traffic cone), base diameter size x, height size z.
    Cone,
}

/// A piece of static scenery (the road, buildings, kitchen counter …): shapes placed in the
/// scene frame, optionally conditional on world attributes (e.g. Town02 buildings).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StageItem {
    pub name: String,
    pub parts: Vec<ShapePart>,
    /// Scene-frame origin of the parts.
    pub at: [f64; 3],
    /// Repeat the item `count` times, offset by `step` each time (rows of buildings, lane
    /// markings).
    pub repeat: Option<(u32, [f64; 3])>,
    pub when: Option<Expr>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Position in the scene frame (metres).
    pub at: [f64; 3],
    /// Point looked at.
    pub look_at: [f64; 3],
    pub fov_deg: f64,
    /// Default image size.
    pub width: u32,
    pub height: u32,
}

impl Default for Camera {
    fn default() -> Self {
        Camera { at: [0.0, 0.0, 1.4], look_at: [30.0, 0.0, 1.0], fov_deg: 70.0, width: 640, height: 360 }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ConceptKind {
    /// Adds entities and/or sets world attributes.
    Concept,
    /// Overrides attributes of an entity another concept added (or of the world); invalid
    /// without a target.
    Modifier,
}

/// A concept or modifier.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Concept {
    pub name: String,
    pub id: ConceptId,
    pub kind: ConceptKind,
    /// The sentence a person reads (the paper's table).
    pub description: String,
    /// Grouping for reports (the paper's category column).
    pub category: String,
    pub probe: Probe,
    pub effects: Vec<Effect>,
    /// For modifiers: which entities it can apply to. It applies to the *target entity*: among
    /// the entities added by the set's concepts that match this filter, the one added by the
    /// concept declared last (highest index) — the deterministic meaning of the paper's "most
    /// recently added entity" for unordered sets.
    pub target: Option<TargetFilter>,
    pub render: RenderBindings,
    pub span: Span,
}

/// Recognition probe (paper appendix G): a positive statement and its counterfactual.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Probe {
    pub positive: String,
    pub negative: String,
}

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct RenderBindings {
    /// Scenic fragment; `{name}` placeholders are filled by the emitter (`{distance}`,
    /// `{region}`, `{id}` …). For entities, one Scenic statement creating the object.
    pub scenic: Option<String>,
    /// Image-generation prompt snippet (verbatim sentence).
    pub prompt: Option<String>,
    /// Builtin-renderer shape overriding the kind's default look for the entities this concept
    /// adds.
    pub shape: Option<Vec<ShapePart>>,
    /// `drawn_by STAGE`: the stage item that draws the entities of this concept that have no
    /// part of their own in a scene (a staircase drawn as steps); the visibility figures measure
    /// that item's parts for them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drawn_by: Option<String>,
}

/// What a concept does to the anchor scene graph.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum Effect {
    /// Add an entity of `kind`, placed in `region`, related to `relation`, with attribute
    /// overrides (on top of the kind's defaults).
    Add { name: String, kind: KindId, region: RegionId, relation: Relation, attrs: Vec<(String, Value)>, span: Span },
    /// Set a world attribute.
    SetWorld { attr: String, value: Value, span: Span },
    /// (modifiers) Set an attribute of the target entity.
    SetTarget { attr: String, value: Value, span: Span },
    /// (modifiers) Move the target entity to another region.
    MoveTarget { region: RegionId, span: Span },
}

/// An edge of the anchor scene graph from an entity to ego / another entity; the relation's
/// [`Placement`] says where the sampler puts the entity.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Relation {
    /// Relation name from the stdlib (`ahead_of`, `on`, `near`, `in`, `reaching_into` …).
    pub name: String,
    /// `None` = ego / the camera's owner; otherwise the name of an entity added by a concept.
    pub to: Option<String>,
}

/// Which entities a modifier can target: any of `kinds` or carrying any of `tags` (empty both =
/// any entity). `world = true`: the modifier targets the world (always present). The checker
/// expands a kind named in source to the kind and all kinds that descend from it.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TargetFilter {
    pub kinds: Vec<KindId>,
    pub tags: Vec<TagId>,
    pub world: bool,
}

/// Compatibility constraints, compiled to bitmasks over concept ids.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Constraint {
    pub name: String,
    /// Comment/rationale from source, shown in diagnostics.
    pub doc: String,
    pub rule: ConstraintRule,
    pub span: Span,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum ConstraintRule {
    /// At most `max` of `members` may be in a set (exclusive group: `max = 1`).
    AtMost { members: ConceptSet, max: u32 },
    /// If the set holds `concept`, it must hold at least one of `any_of`.
    Requires { concept: ConceptId, any_of: ConceptSet },
    /// No set may hold all of `all` together.
    Forbids { all: ConceptSet },
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Question {
    pub name: String,
    pub text: String,
    /// Options in display order; their letters are A, B, C … by position.
    pub options: Vec<AnswerOption>,
    pub span: Span,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AnswerOption {
    /// Identifier used by rules (`stop`, `slow`, `go`, `yes`, `no`).
    pub name: String,
    pub text: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Selection {
    /// First matching rule in order decides; all rules share the domain's question.
    Priority,
    /// Among the rules whose `when` holds (and, for `safe` rules, whose elements include the
    /// whole set), the highest element-fit score wins; ties go to the more specific rule (higher
    /// fraction of its elements covered), then to the rule declared first.
    BestFit,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Rule {
    pub name: String,
    pub id: RuleId,
    /// The rationale (the rule's doc comment).
    pub rationale: String,
    pub question: QuestionId,
    /// Index into the question's options.
    pub expect: u32,
    /// Precondition over the anchor scene graph. A rule with no condition always matches.
    pub when: Option<Expr>,
    /// Best fit: the concepts whose presence makes this rule specific (its "visual elements");
    /// the element-fit score is the number of the set's concepts among them.
    pub elements: ConceptSet,
    /// Marks a safe-scene rule (expected answer is "no hazard"): it only matches sets made
    /// entirely of its `elements`.
    pub safe: bool,
    pub span: Span,
}

/// Rule and shape conditions, evaluated on the anchor scene graph with three-valued logic
/// (a numeric range that straddles a threshold is *unknown*).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Expr {
    Bool(bool),
    Not(Box<Expr>),
    And(Vec<Expr>),
    Or(Vec<Expr>),
    /// The set contains this concept.
    Has(ConceptId),
    /// Some entity matching the filter satisfies `cond` (which may use `Attr(Some(var))`).
    Exists {
        var: String,
        filter: TargetFilter,
        cond: Option<Box<Expr>>,
    },
    /// Number of entities matching the filter, compared.
    Count {
        filter: TargetFilter,
        op: CmpOp,
        n: u32,
    },
    /// Compare an attribute to a value: entity attribute (`Some(var)`), the current entity in a
    /// shape condition (`Some("self")`), or a world attribute (`None`).
    Cmp {
        var: Option<String>,
        attr: String,
        op: CmpOp,
        value: Value,
    },
    /// Entity is placed in a region (`x in lane`).
    InRegion {
        var: String,
        region: RegionId,
    },
    /// Two attributes compared (`a.distance < b.distance`), three-valued like [`Expr::Cmp`]:
    /// ranges that overlap where the comparison flips are unknown.
    CmpAttrs {
        left: AttrRef,
        op: CmpOp,
        right: AttrRef,
    },
    /// The entity bound to `var` was added with `relation` to the entity bound to `to`
    /// (`None`: to ego). Reads the scene graph's edges, not positions.
    Related {
        var: String,
        relation: String,
        to: Option<String>,
    },
}

/// An attribute in a condition: of the entity bound to `var`, or of the world (`None`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AttrRef {
    pub var: Option<String>,
    pub attr: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CmpOp {
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
}

impl Domain {
    pub fn concept_by_name(&self, name: &str) -> Option<&Concept> {
        self.concepts.iter().find(|c| c.name == name)
    }
    pub fn kind_by_name(&self, name: &str) -> Option<KindId> {
        self.kinds.iter().position(|k| k.name == name).map(|i| KindId(i as u32))
    }
    pub fn tag_by_name(&self, name: &str) -> Option<TagId> {
        self.tags.iter().position(|t| t.name == name).map(|i| TagId(i as u32))
    }
    pub fn region_by_name(&self, name: &str) -> Option<RegionId> {
        self.regions.iter().position(|r| r.name == name).map(|i| RegionId(i as u32))
    }
    pub fn world_attr(&self, name: &str) -> Option<&AttrDef> {
        self.world.iter().find(|a| a.name == name)
    }
    /// Parse a list of concept names into a set; the error names the first unknown one, with a
    /// "did you mean" when a declared concept is close.
    pub fn parse_set<S: AsRef<str>>(&self, names: &[S]) -> Result<ConceptSet, UnknownConcept> {
        let mut set = ConceptSet::EMPTY;
        for n in names {
            let n = n.as_ref();
            match self.concept_by_name(n) {
                Some(c) => set = set.with(c.id),
                None => {
                    let suggestion = crate::diag::suggest::suggest(n, self.concepts.iter().map(|c| c.name.as_str()));
                    return Err(UnknownConcept {
                        name: n.to_string(),
                        domain: self.name.clone(),
                        suggestion: suggestion.map(String::from),
                    });
                }
            }
        }
        Ok(set)
    }
    /// Concept names of a set, in index order.
    pub fn set_names(&self, set: ConceptSet) -> Vec<&str> {
        set.iter().map(|c| self.concepts[c.index()].name.as_str()).collect()
    }
    /// Mask of all modifiers.
    pub fn modifier_mask(&self) -> ConceptSet {
        ConceptSet::from_ids(self.concepts.iter().filter(|c| c.kind == ConceptKind::Modifier).map(|c| c.id))
    }
    /// The enum variant name of an enum value.
    pub fn variant_name(&self, e: EnumId, v: u32) -> &str {
        &self.enums[e.index()].variants[v as usize]
    }
}

/// A concept name that the domain does not declare (from [`Domain::parse_set`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown concept `{name}` in domain `{domain}`{}", did_you_mean(suggestion.as_deref()))]
pub struct UnknownConcept {
    pub name: String,
    pub domain: String,
    pub suggestion: Option<String>,
}

fn did_you_mean(s: Option<&str>) -> String {
    s.map(|s| format!("; did you mean `{s}`?")).unwrap_or_default()
}

/// Whether an entity of `kind` matches a target filter.
impl TargetFilter {
    pub fn matches(&self, domain: &Domain, kind: KindId) -> bool {
        if self.kinds.is_empty() && self.tags.is_empty() {
            return !self.world;
        }
        self.kinds.contains(&kind) || self.tags.iter().any(|t| domain.kinds[kind.index()].has_tag(*t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_ops() {
        let s = ConceptSet::from_ids([ConceptId(0), ConceptId(5), ConceptId(127)]);
        assert_eq!(s.len(), 3);
        assert!(s.contains(ConceptId(127)));
        assert_eq!(s.iter().collect::<Vec<_>>(), vec![ConceptId(0), ConceptId(5), ConceptId(127)]);
        let t = ConceptSet::from_ids([ConceptId(5), ConceptId(6)]);
        assert!((s.jaccard(t) - 0.25).abs() < 1e-12);
        assert!(ConceptSet::single(ConceptId(5)).is_subset_of(s));
        assert_eq!(s.without(ConceptId(0)).len(), 2);
        let ids = |xs: &[u32]| ConceptSet::from_ids(xs.iter().map(|&i| ConceptId(i)));
        let smaller: Vec<ConceptSet> = s.one_smaller().collect();
        assert_eq!(smaller, vec![ids(&[5, 127]), ids(&[0, 127]), ids(&[0, 5])]);
        assert_eq!(ConceptSet::single(ConceptId(3)).one_smaller().count(), 0, "no empty set");
        let mut proper: Vec<ConceptSet> = s.proper_subsets().collect();
        proper.sort();
        let mut want = vec![ids(&[0]), ids(&[5]), ids(&[127]), ids(&[0, 5]), ids(&[0, 127]), ids(&[5, 127])];
        want.sort();
        assert_eq!(proper, want, "every non-empty proper subset, once");
        assert_eq!(ConceptSet::EMPTY.proper_subsets().count(), 0);
    }
}

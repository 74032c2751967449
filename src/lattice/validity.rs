//! Validity of a concept set, compiled to bitmask checks.
//!
//! A set is valid when it is non-empty, names only declared concepts, satisfies every
//! constraint, every modifier in it has a target entity that has the attributes the modifier
//! sets, and every entity placed relative to another entity (`add … near b`) finds that entity in
//! the set — exactly the sets [`anchor::build`](crate::anchor::build) accepts, plus the
//! constraints. The target rules are compiled to masks (see [`ModifierTarget`]) so that the
//! check is a few word operations instead of building the anchor graph.

use std::fmt;

use crate::ir::{ConceptId, ConceptKind, ConceptSet, Constraint, ConstraintRule, Domain, Effect, TargetFilter};

/// Why a set is not valid. Names are resolved, so the value outlives the domain.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Violation {
    /// The empty set has no scene.
    Empty,
    /// A bit beyond the domain's concepts is set.
    UnknownConcept { index: u32 },
    /// A constraint is violated: its name, what it says, and its doc comment.
    Constraint { name: String, says: String, doc: String },
    /// A modifier has no entity to apply to.
    NoTarget { modifier: String },
    /// A modifier's target entity lacks an attribute the modifier sets.
    TargetLacksAttr { modifier: String, attr: String, target: String },
    /// An entity is placed relative to an entity that no concept of the set adds.
    NoRelationTarget { concept: String, entity: String, relation: String, target: String },
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Violation::Empty => write!(f, "the empty set has no scene"),
            Violation::UnknownConcept { index } => write!(f, "concept index {index} is not declared in the domain"),
            Violation::Constraint { name, says, .. } => write!(f, "violates constraint `{name}` ({says})"),
            Violation::NoTarget { modifier } => {
                write!(f, "modifier `{modifier}` has no entity to apply to")
            }
            Violation::TargetLacksAttr { modifier, attr, target } => {
                write!(f, "modifier `{modifier}` sets `{attr}`, which its target `{target}` does not have")
            }
            Violation::NoRelationTarget { concept, entity, relation, target } => write!(
                f,
                "concept `{concept}` places `{entity}` {relation} `{target}`, which no concept of the set adds"
            ),
        }
    }
}

impl std::error::Error for Violation {}

/// Check one set against the domain's validity rules, naming the first violation: constraints
/// in declaration order first, then modifiers in index order, then relation targets.
pub fn validate(domain: &Domain, set: ConceptSet) -> Result<(), Violation> {
    Validity::new(domain).check(set).map_err(|v| v.resolve(domain))
}

/// What a modifier can apply to, as masks over concept ids.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModifierTarget {
    pub modifier: ConceptId,
    /// Concepts that add at least one entity matching the modifier's target filter.
    pub providers: ConceptSet,
    /// Providers whose *last* matching entity (the one the modifier would pick when that
    /// provider is the highest-index provider in the set) lacks an attribute the modifier sets.
    pub lacking: ConceptSet,
}

/// A violation found by [`Validity::check`], by index (cheap); [`ViolationAt::resolve`] names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ViolationAt {
    Empty,
    UnknownConcept(u32),
    Constraint(usize),
    NoTarget(ConceptId),
    /// The modifier and the provider concept whose entity lacks the attribute.
    TargetLacksAttr(ConceptId, ConceptId),
    /// The concept and the index of its `add` whose relation target is missing.
    NoRelationTarget(ConceptId, usize),
}

impl ViolationAt {
    pub fn resolve(self, domain: &Domain) -> Violation {
        let name = |c: ConceptId| domain.concepts[c.index()].name.clone();
        match self {
            ViolationAt::Empty => Violation::Empty,
            ViolationAt::UnknownConcept(index) => Violation::UnknownConcept { index },
            ViolationAt::Constraint(i) => {
                let c = &domain.constraints[i];
                Violation::Constraint { name: c.name.clone(), says: describe_constraint(domain, c), doc: c.doc.clone() }
            }
            ViolationAt::NoTarget(m) => Violation::NoTarget { modifier: name(m) },
            ViolationAt::TargetLacksAttr(m, provider) => {
                let (attr, target) = lacking_attr(domain, m, provider).unwrap_or_default();
                Violation::TargetLacksAttr { modifier: name(m), attr, target }
            }
            ViolationAt::NoRelationTarget(c, effect) => {
                let (entity, relation, target) = match domain.concepts[c.index()].effects.get(effect) {
                    Some(Effect::Add { name, relation, .. }) => {
                        (name.clone(), relation.name.clone(), relation.to.clone().unwrap_or_default())
                    }
                    _ => Default::default(),
                };
                Violation::NoRelationTarget { concept: name(c), entity, relation, target }
            }
        }
    }
}

/// A domain's validity rules compiled to bitmasks.
#[derive(Debug, Clone)]
pub struct Validity {
    /// Mask of the declared concepts.
    universe: ConceptSet,
    /// Constraints by declaration index, split by monotonicity.
    at_most: Vec<(usize, ConceptSet, u32)>,
    forbids: Vec<(usize, ConceptSet)>,
    requires: Vec<(usize, ConceptId, ConceptSet)>,
    modifiers: Vec<ModifierTarget>,
    /// Per `add` related to an entity its own concept does not add: (concept, effect index,
    /// the concepts that add an entity of that name).
    relation_targets: Vec<(ConceptId, usize, ConceptSet)>,
}

impl Validity {
    pub fn new(domain: &Domain) -> Validity {
        let universe = ConceptSet::first_n(domain.concepts.len());
        let mut v = Validity {
            universe,
            at_most: vec![],
            forbids: vec![],
            requires: vec![],
            modifiers: vec![],
            relation_targets: relation_targets(domain),
        };
        for (i, c) in domain.constraints.iter().enumerate() {
            match c.rule {
                ConstraintRule::AtMost { members, max } => v.at_most.push((i, members, max)),
                ConstraintRule::Forbids { all } => v.forbids.push((i, all)),
                ConstraintRule::Requires { concept, any_of } => {
                    v.requires.push((i, concept, any_of));
                }
            }
        }
        v.modifiers = domain
            .concepts
            .iter()
            .filter(|c| c.kind == ConceptKind::Modifier)
            .filter_map(|c| modifier_target(domain, c.id))
            .collect();
        v
    }

    /// Mask of the declared concepts.
    pub fn universe(&self) -> ConceptSet {
        self.universe
    }

    /// Per-modifier target masks (modifiers that target the world are always satisfied and
    /// are not listed).
    pub fn modifier_targets(&self) -> &[ModifierTarget] {
        &self.modifiers
    }

    pub fn is_valid(&self, set: ConceptSet) -> bool {
        self.check(set).is_ok()
    }

    /// The first violation of `set`, if any (see [`validate`] for the order).
    pub fn check(&self, set: ConceptSet) -> Result<(), ViolationAt> {
        if set.is_empty() {
            return Err(ViolationAt::Empty);
        }
        if let Some(unknown) = set.difference(self.universe).first() {
            return Err(ViolationAt::UnknownConcept(unknown.0));
        }
        let first = [self.first_monotone(set), self.first_requires(set)].into_iter().flatten().min();
        if let Some(i) = first {
            return Err(ViolationAt::Constraint(i));
        }
        self.check_targets(set)
    }

    /// Whether the constraints that stay violated in every superset (at-most, forbids) hold.
    pub fn monotone_ok(&self, set: ConceptSet) -> bool {
        self.first_monotone(set).is_none()
    }

    /// Whether the constraints that a superset can repair (requires, modifier targets) hold.
    pub fn closure_ok(&self, set: ConceptSet) -> bool {
        self.first_requires(set).is_none() && self.check_targets(set).is_ok()
    }

    /// Whether some requirement or modifier of `set` is unmet and no concept in `remaining`
    /// could meet it, so no superset drawn from `remaining` is valid.
    pub fn hopeless(&self, set: ConceptSet, remaining: ConceptSet) -> bool {
        let unmet = |needs: ConceptSet| !set.intersects(needs) && !remaining.intersects(needs);
        self.requires.iter().any(|&(_, c, any)| set.contains(c) && unmet(any))
            || self.modifiers.iter().any(|m| set.contains(m.modifier) && unmet(m.providers))
            || self.relation_targets.iter().any(|&(c, _, providers)| set.contains(c) && unmet(providers))
    }

    fn first_monotone(&self, set: ConceptSet) -> Option<usize> {
        let at_most =
            self.at_most.iter().find(|&&(_, mask, max)| set.intersection(mask).len() > max as usize).map(|c| c.0);
        let forbids = self.forbids.iter().find(|&&(_, all)| all.is_subset_of(set)).map(|c| c.0);
        at_most.into_iter().chain(forbids).min()
    }

    fn first_requires(&self, set: ConceptSet) -> Option<usize> {
        self.requires.iter().find(|&&(_, c, any)| set.contains(c) && !set.intersects(any)).map(|c| c.0)
    }

    pub(crate) fn check_targets(&self, set: ConceptSet) -> Result<(), ViolationAt> {
        for m in &self.modifiers {
            if !set.contains(m.modifier) {
                continue;
            }
            // The target comes from the highest-index provider in the set.
            let Some(top) = set.intersection(m.providers).last() else {
                return Err(ViolationAt::NoTarget(m.modifier));
            };
            if m.lacking.contains(top) {
                return Err(ViolationAt::TargetLacksAttr(m.modifier, top));
            }
        }
        for &(c, effect, providers) in &self.relation_targets {
            if set.contains(c) && !set.intersects(providers) {
                return Err(ViolationAt::NoRelationTarget(c, effect));
            }
        }
        Ok(())
    }

    /// The constraints as compiled: at-most `(index, members, max)`.
    pub fn at_most(&self) -> &[(usize, ConceptSet, u32)] {
        &self.at_most
    }

    /// Forbids constraints: `(index, members that may not all appear)`.
    pub fn forbids(&self) -> &[(usize, ConceptSet)] {
        &self.forbids
    }

    /// Requires constraints: `(index, concept, any of)`.
    pub fn requires(&self) -> &[(usize, ConceptId, ConceptSet)] {
        &self.requires
    }

    /// Entities placed relative to another concept's entity: `(concept, add index, providers)`.
    pub fn relation_targets(&self) -> &[(ConceptId, usize, ConceptSet)] {
        &self.relation_targets
    }
}

/// Every `add` related to an entity that its own concept does not add, with the concepts that
/// add an entity of that name (mirrors `anchor::build`, which looks for the target by name).
fn relation_targets(domain: &Domain) -> Vec<(ConceptId, usize, ConceptSet)> {
    let mut out = Vec::new();
    for c in domain.concepts.iter().take(crate::ir::MAX_CONCEPTS) {
        for (i, e) in c.effects.iter().enumerate() {
            let Effect::Add { relation, .. } = e else { continue };
            let Some(to) = &relation.to else { continue };
            let adds =
                |k: &crate::ir::Concept| k.effects.iter().any(|e| matches!(e, Effect::Add { name, .. } if name == to));
            if adds(c) {
                continue;
            }
            let providers = domain
                .concepts
                .iter()
                .take(crate::ir::MAX_CONCEPTS)
                .filter(|k| k.kind == ConceptKind::Concept && adds(k))
                .fold(ConceptSet::EMPTY, |m, k| m.with(k.id));
            out.push((c.id, i, providers));
        }
    }
    out
}

/// The target masks of one modifier; `None` for a modifier that targets the world.
fn modifier_target(domain: &Domain, modifier: ConceptId) -> Option<ModifierTarget> {
    let m = &domain.concepts[modifier.index()];
    let filter = m.target.clone().unwrap_or_default();
    if targets_world(&filter) {
        return None;
    }
    let mut t = ModifierTarget { modifier, providers: ConceptSet::EMPTY, lacking: ConceptSet::EMPTY };
    for c in domain.concepts.iter().take(crate::ir::MAX_CONCEPTS) {
        if c.kind != ConceptKind::Concept {
            continue;
        }
        if last_match(domain, c.id, &filter).is_some() {
            t.providers.insert(c.id);
            if lacking_attr(domain, modifier, c.id).is_some() {
                t.lacking.insert(c.id);
            }
        }
    }
    Some(t)
}

/// Mirrors `anchor::build`: a filter with only `world` set targets the world.
pub(crate) fn targets_world(filter: &TargetFilter) -> bool {
    filter.world && filter.kinds.is_empty() && filter.tags.is_empty()
}

/// The last entity `concept` adds that matches `filter`: (entity name, kind).
fn last_match<'d>(domain: &'d Domain, concept: ConceptId, filter: &TargetFilter) -> Option<(&'d str, usize)> {
    domain.concepts[concept.index()].effects.iter().rev().find_map(|e| match e {
        Effect::Add { name, kind, .. } if filter.matches(domain, *kind) => Some((name.as_str(), kind.index())),
        _ => None,
    })
}

/// The first attribute `modifier` sets that the entity it would pick from `provider` lacks:
/// (attribute, entity name).
fn lacking_attr(domain: &Domain, modifier: ConceptId, provider: ConceptId) -> Option<(String, String)> {
    let m = &domain.concepts[modifier.index()];
    let filter = m.target.clone().unwrap_or_default();
    let (entity, kind) = last_match(domain, provider, &filter)?;
    m.effects.iter().find_map(|e| match e {
        Effect::SetTarget { attr, .. } if domain.kinds[kind].attr(attr).is_none() => {
            Some((attr.clone(), entity.to_string()))
        }
        _ => None,
    })
}

/// What a constraint says, in words, e.g. "at most 1 of `near`, `far`".
pub fn describe_constraint(domain: &Domain, c: &Constraint) -> String {
    let names = |s: ConceptSet| domain.set_names(s).iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ");
    match c.rule {
        ConstraintRule::AtMost { members, max } => format!("at most {max} of {}", names(members)),
        ConstraintRule::Requires { concept, any_of } => {
            let who = &domain.concepts[concept.index()].name;
            if any_of.len() == 1 {
                format!("`{who}` requires {}", names(any_of))
            } else {
                format!("`{who}` requires one of {}", names(any_of))
            }
        }
        ConstraintRule::Forbids { all } => format!("{} may not appear together", names(all)),
    }
}

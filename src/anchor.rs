//! The anchor scene graph of a concept set (paper §3.1): the union of the entities and world
//! settings its concepts add, then its modifiers applied. Rules are evaluated here, with
//! three-valued logic, so every image of a set shares one expected answer.
//!
//! Modifier targets: a modifier applies to the *most recently added* matching entity, which for
//! an unordered set means: the matching entity added by the concept with the highest index
//! (declared last); within one concept, the entity added last. Modifiers are applied in index
//! order, so when two modifiers set the same attribute the one declared later wins.
//!
//! Relation targets: `add a: K in R near b` relates `a` to the entity named `b` that the same
//! concept adds, else to the one added by the highest-index concept of the set; a set with no
//! such entity has no anchor graph (like a modifier without a target). Once every entity is
//! known, each related entity's `distance` (x) and `lateral` (y) are narrowed to where its
//! relation can place it given where its target can stand ([`ground_bounds`]), so that rules
//! see what every sampled scene shows.

use crate::ir::{
    AttrRef, CmpOp, ConceptId, ConceptKind, ConceptSet, Domain, Effect, Expr, GroundBounds, KindId, Placement,
    RegionId, Relation, TargetFilter, Value,
};

/// An entity on the anchor graph.
#[derive(Debug, Clone, PartialEq)]
pub struct AnchorEntity {
    pub name: String,
    pub kind: KindId,
    /// The concept that added it.
    pub concept: ConceptId,
    pub region: RegionId,
    pub relation: Relation,
    /// Index of the entity the relation places this one relative to (`None`: ego).
    pub target: Option<usize>,
    /// One value per attribute of the kind (`Domain::kinds[kind].attrs`), defaults applied.
    pub attrs: Vec<Value>,
    /// Modifiers that changed this entity, in application order.
    pub modified_by: Vec<ConceptId>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct AnchorGraph {
    pub set: ConceptSet,
    pub entities: Vec<AnchorEntity>,
    /// One value per world attribute (`Domain::world`).
    pub world: Vec<Value>,
}

/// Why a set has no anchor graph.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AnchorError {
    #[error("modifier `{modifier}` has no entity to apply to")]
    NoTarget { modifier: String },
    #[error("modifier `{modifier}` sets `{attr}`, which its target `{target}` does not have")]
    MissingAttr { modifier: String, attr: String, target: String },
    #[error("concept `{concept}` places `{entity}` {relation} `{target}`, which no concept of the set adds")]
    NoRelationTarget { concept: String, entity: String, relation: String, target: String },
}

/// Build the anchor graph of `set`. Constraints are *not* checked here (see `lattice`); only the
/// structural rule that every modifier needs a target.
pub fn build(domain: &Domain, set: ConceptSet) -> Result<AnchorGraph, AnchorError> {
    let mut g =
        AnchorGraph { set, entities: Vec::new(), world: domain.world.iter().map(|a| a.default.clone()).collect() };
    for cid in set.iter() {
        let c = &domain.concepts[cid.index()];
        if c.kind == ConceptKind::Modifier {
            continue;
        }
        for e in &c.effects {
            match e {
                Effect::Add { name, kind, region, relation, attrs, .. } => {
                    let k = &domain.kinds[kind.index()];
                    let mut values: Vec<Value> = k.attrs.iter().map(|a| a.default.clone()).collect();
                    for (a, v) in attrs {
                        if let Some(i) = k.attr(a) {
                            values[i] = v.clone();
                        }
                    }
                    g.entities.push(AnchorEntity {
                        name: name.clone(),
                        kind: *kind,
                        concept: cid,
                        region: *region,
                        relation: relation.clone(),
                        target: None,
                        attrs: values,
                        modified_by: Vec::new(),
                    });
                }
                Effect::SetWorld { attr, value, .. } => set_world(domain, &mut g, attr, value),
                Effect::SetTarget { .. } | Effect::MoveTarget { .. } => {}
            }
        }
    }
    for cid in set.iter() {
        let c = &domain.concepts[cid.index()];
        if c.kind != ConceptKind::Modifier {
            continue;
        }
        let filter = c.target.clone().unwrap_or_default();
        let target = if filter.world && filter.kinds.is_empty() && filter.tags.is_empty() {
            None
        } else {
            match target_of(domain, &g, &filter) {
                Some(t) => Some(t),
                None => return Err(AnchorError::NoTarget { modifier: c.name.clone() }),
            }
        };
        for e in &c.effects {
            match (e, target) {
                (Effect::SetWorld { attr, value, .. }, _) => set_world(domain, &mut g, attr, value),
                (Effect::SetTarget { attr, value, .. }, Some(t)) => {
                    let ent = &mut g.entities[t];
                    let k = &domain.kinds[ent.kind.index()];
                    match k.attr(attr) {
                        Some(i) => ent.attrs[i] = value.clone(),
                        None => {
                            return Err(AnchorError::MissingAttr {
                                modifier: c.name.clone(),
                                attr: attr.clone(),
                                target: ent.name.clone(),
                            });
                        }
                    }
                }
                (Effect::MoveTarget { region, .. }, Some(t)) => g.entities[t].region = *region,
                _ => {}
            }
        }
        if let Some(t) = target {
            g.entities[t].modified_by.push(cid);
        }
    }
    resolve_targets(domain, &mut g)?;
    narrow_to_relations(domain, &mut g);
    Ok(g)
}

/// Point each related entity at its target: the entity of that name its own concept adds, else
/// the one added by the concept declared last.
fn resolve_targets(domain: &Domain, g: &mut AnchorGraph) -> Result<(), AnchorError> {
    for i in 0..g.entities.len() {
        let Some(to) = g.entities[i].relation.to.clone() else { continue };
        let e = &g.entities[i];
        let same = g.entities.iter().position(|t| t.name == to && t.concept == e.concept);
        let target = same.or_else(|| {
            (0..g.entities.len()).filter(|&j| j != i && g.entities[j].name == to).max_by_key(|&j| g.entities[j].concept)
        });
        match target {
            Some(t) => g.entities[i].target = Some(t),
            None => {
                return Err(AnchorError::NoRelationTarget {
                    concept: domain.concepts[e.concept.index()].name.clone(),
                    entity: e.name.clone(),
                    relation: e.relation.name.clone(),
                    target: to,
                });
            }
        }
    }
    Ok(())
}

/// The placement of an entity's relation (none for an unknown relation name).
pub fn placement_of<'d>(domain: &'d Domain, e: &AnchorEntity) -> Option<&'d Placement> {
    domain.relations.iter().find(|r| r.name == e.relation.name).map(|r| &r.placement)
}

/// Entities in placement order: every target before the entities related to it, otherwise in
/// index order.
pub fn placement_order(g: &AnchorGraph) -> Vec<usize> {
    let n = g.entities.len();
    let mut order = Vec::with_capacity(n);
    let mut done = vec![false; n];
    while order.len() < n {
        let before = order.len();
        for i in 0..n {
            if !done[i] && g.entities[i].target.is_none_or(|t| done[t]) {
                done[i] = true;
                order.push(i);
            }
        }
        if order.len() == before {
            // A cycle (the checker rejects them): place the rest in index order.
            order.extend((0..n).filter(|&i| !done[i]));
            break;
        }
    }
    order
}

/// Where the sampler can put each entity: its region's extent, narrowed by a `distance` (x) or
/// `lateral` (y) attribute whose range meets it, then by its relation around where its target
/// can stand (ego: the scene origin). When the region and the relation cannot both hold, the
/// relation decides.
pub fn ground_bounds(domain: &Domain, g: &AnchorGraph) -> Vec<GroundBounds> {
    let mut out: Vec<GroundBounds> = vec![((0.0, 0.0), (0.0, 0.0)); g.entities.len()];
    for i in placement_order(g) {
        let e = &g.entities[i];
        let region = &domain.regions[e.region.index()];
        let own = (axis_extent(domain, e, "distance", region.x), axis_extent(domain, e, "lateral", region.y));
        let Some(p) = placement_of(domain, e) else {
            out[i] = own;
            continue;
        };
        let at = e.target.map_or(((0.0, 0.0), (0.0, 0.0)), |t| out[t]);
        let (ox, oy) = p.offset_box();
        let zone = ((at.0.0 + ox.0, at.0.1 + ox.1), (at.1.0 + oy.0, at.1.1 + oy.1));
        out[i] = (meet_or(own.0, zone.0), meet_or(own.1, zone.1));
    }
    out
}

/// The intersection of `own` and `zone`, or `zone` when they do not meet (the relation decides).
fn meet_or(own: (f64, f64), zone: (f64, f64)) -> (f64, f64) {
    let m = (own.0.max(zone.0), own.1.min(zone.1));
    if m.0 <= m.1 { m } else { zone }
}

/// An axis's extent: the attribute's range where it meets the region's, else the region's.
fn axis_extent(domain: &Domain, e: &AnchorEntity, attr: &str, extent: (f64, f64)) -> (f64, f64) {
    let (rlo, rhi) = (extent.0.min(extent.1), extent.0.max(extent.1));
    let bounds = domain.kinds[e.kind.index()].attr(attr).and_then(|i| e.attrs[i].bounds());
    match bounds {
        Some((lo, hi)) if lo.max(rlo) <= hi.min(rhi) => (lo.max(rlo), hi.min(rhi)),
        _ => (rlo, rhi),
    }
}

/// Narrow `distance`/`lateral` of entities whose relation cuts where they can stand.
fn narrow_to_relations(domain: &Domain, g: &mut AnchorGraph) {
    let bounds = ground_bounds(domain, g);
    for (i, b) in bounds.into_iter().enumerate() {
        let region = &domain.regions[g.entities[i].region.index()];
        let kind = &domain.kinds[g.entities[i].kind.index()];
        for (attr, extent, range) in [("distance", region.x, b.0), ("lateral", region.y, b.1)] {
            let Some(slot) = kind.attr(attr) else { continue };
            if g.entities[i].attrs[slot].bounds().is_none()
                || axis_extent(domain, &g.entities[i], attr, extent) == range
            {
                continue;
            }
            g.entities[i].attrs[slot] =
                if range.0 == range.1 { Value::Number(range.0) } else { Value::Range(range.0, range.1) };
        }
    }
}

fn set_world(domain: &Domain, g: &mut AnchorGraph, attr: &str, value: &Value) {
    if let Some(i) = domain.world.iter().position(|a| a.name == attr) {
        g.world[i] = value.clone();
    }
}

/// Index of the entity a modifier with this filter applies to: the last matching entity.
pub fn target_of(domain: &Domain, g: &AnchorGraph, filter: &TargetFilter) -> Option<usize> {
    g.entities.iter().rposition(|e| filter.matches(domain, e.kind))
}

/// Kleene three-valued truth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tri {
    False,
    Unknown,
    True,
}

impl std::ops::Not for Tri {
    type Output = Tri;
    fn not(self) -> Tri {
        match self {
            Tri::True => Tri::False,
            Tri::False => Tri::True,
            Tri::Unknown => Tri::Unknown,
        }
    }
}

impl Tri {
    fn from_bool(b: bool) -> Tri {
        if b { Tri::True } else { Tri::False }
    }
}

/// Evaluate an expression on the anchor graph. `bindings` maps quantified variable names to
/// entity indices (and `self` in shape conditions).
pub fn eval(domain: &Domain, g: &AnchorGraph, expr: &Expr, bindings: &mut Vec<(String, usize)>) -> Tri {
    match expr {
        Expr::Bool(b) => Tri::from_bool(*b),
        Expr::Not(e) => !eval(domain, g, e, bindings),
        Expr::And(es) => {
            let mut acc = Tri::True;
            for e in es {
                match eval(domain, g, e, bindings) {
                    Tri::False => return Tri::False,
                    Tri::Unknown => acc = Tri::Unknown,
                    Tri::True => {}
                }
            }
            acc
        }
        Expr::Or(es) => {
            let mut acc = Tri::False;
            for e in es {
                match eval(domain, g, e, bindings) {
                    Tri::True => return Tri::True,
                    Tri::Unknown => acc = Tri::Unknown,
                    Tri::False => {}
                }
            }
            acc
        }
        Expr::Has(c) => Tri::from_bool(g.set.contains(*c)),
        Expr::Exists { var, filter, cond } => {
            let mut acc = Tri::False;
            for (i, e) in g.entities.iter().enumerate() {
                if !filter.matches(domain, e.kind) {
                    continue;
                }
                let t = match cond {
                    None => Tri::True,
                    Some(c) => {
                        bindings.push((var.clone(), i));
                        let t = eval(domain, g, c, bindings);
                        bindings.pop();
                        t
                    }
                };
                match t {
                    Tri::True => return Tri::True,
                    Tri::Unknown => acc = Tri::Unknown,
                    Tri::False => {}
                }
            }
            acc
        }
        Expr::Count { filter, op, n } => {
            let k = g.entities.iter().filter(|e| filter.matches(domain, e.kind)).count() as f64;
            Tri::from_bool(cmp_num(k, *op, f64::from(*n)))
        }
        Expr::Cmp { var, attr, op, value } => {
            let current = match var {
                None => domain.world.iter().position(|a| &a.name == attr).map(|i| &g.world[i]),
                Some(v) => lookup(bindings, v).and_then(|ei| {
                    let e = &g.entities[ei];
                    domain.kinds[e.kind.index()].attr(attr).map(|i| &e.attrs[i])
                }),
            };
            match current {
                None => Tri::Unknown,
                Some(cur) => compare(cur, *op, value),
            }
        }
        Expr::InRegion { var, region } => match lookup(bindings, var) {
            Some(ei) => Tri::from_bool(g.entities[ei].region == *region),
            None => Tri::Unknown,
        },
        Expr::CmpAttrs { left, op, right } => {
            let (Some(l), Some(r)) = (attr_value(domain, g, left, bindings), attr_value(domain, g, right, bindings))
            else {
                return Tri::Unknown;
            };
            // One attribute of one entity is one value, however wide its range.
            if l.0 == r.0 && left.attr == right.attr {
                return Tri::from_bool(matches!(op, CmpOp::Eq | CmpOp::Le | CmpOp::Ge));
            }
            match (l.0, r.0) {
                (Some(a), Some(b)) if left.attr == right.attr => match related_offset(domain, g, a, b, &left.attr) {
                    // `a - b` lies in the relation's offset: compare it with 0.
                    Some(diff) => compare(&diff, *op, &Value::Number(0.0)),
                    None => compare(l.1, *op, r.1),
                },
                _ => compare(l.1, *op, r.1),
            }
        }
        Expr::Related { var, relation, to } => {
            let Some(ei) = lookup(bindings, var) else { return Tri::Unknown };
            let e = &g.entities[ei];
            let target = match to {
                None => e.relation.to.is_none(),
                Some(v) => match lookup(bindings, v) {
                    Some(ti) => e.target == Some(ti),
                    None => return Tri::Unknown,
                },
            };
            Tri::from_bool(e.relation.name == *relation && target)
        }
    }
}

/// When one of `a`, `b` is placed relative to the other, the range of `a.attr - b.attr` for the
/// ground axes (`distance` is x, `lateral` is y): the relation's offset met with the difference
/// of the two ranges. Comparing two related entities this way keeps what the relation fixes
/// (a cone 1–3 m behind a barrier is always further away), which two overlapping ranges lose.
fn related_offset(domain: &Domain, g: &AnchorGraph, a: usize, b: usize, attr: &str) -> Option<Value> {
    let (ea, eb) = (&g.entities[a], &g.entities[b]);
    let (from, to, sign) = if ea.target == Some(b) {
        (ea, eb, 1.0)
    } else if eb.target == Some(a) {
        (eb, ea, -1.0)
    } else {
        return None;
    };
    let (ox, oy) = placement_of(domain, from)?.offset_box();
    let offset = match attr {
        "distance" => ox,
        "lateral" => oy,
        _ => return None,
    };
    let bounds = |e: &AnchorEntity| domain.kinds[e.kind.index()].attr(attr).and_then(|i| e.attrs[i].bounds());
    let ((flo, fhi), (tlo, thi)) = (bounds(from)?, bounds(to)?);
    // from - to, met with the offset, then signed as `a - b`.
    let (lo, hi) = ((flo - thi).max(offset.0), (fhi - tlo).min(offset.1));
    if lo > hi {
        return None;
    }
    let (lo, hi) = if sign > 0.0 { (lo, hi) } else { (-hi, -lo) };
    Some(if lo == hi { Value::Number(lo) } else { Value::Range(lo, hi) })
}

/// The value an attribute reference reads, with who owns it (`None`: the world).
fn attr_value<'g>(
    domain: &Domain,
    g: &'g AnchorGraph,
    r: &AttrRef,
    bindings: &[(String, usize)],
) -> Option<(Option<usize>, &'g Value)> {
    match &r.var {
        None => domain.world.iter().position(|a| a.name == r.attr).map(|i| (None, &g.world[i])),
        Some(v) => {
            let ei = lookup(bindings, v)?;
            let e = &g.entities[ei];
            domain.kinds[e.kind.index()].attr(&r.attr).map(|i| (Some(ei), &e.attrs[i]))
        }
    }
}

fn lookup(bindings: &[(String, usize)], var: &str) -> Option<usize> {
    bindings.iter().rev().find(|(n, _)| n == var).map(|(_, i)| *i)
}

fn cmp_num(a: f64, op: CmpOp, b: f64) -> bool {
    match op {
        CmpOp::Eq => a == b,
        CmpOp::Ne => a != b,
        CmpOp::Lt => a < b,
        CmpOp::Le => a <= b,
        CmpOp::Gt => a > b,
        CmpOp::Ge => a >= b,
    }
}

/// Compare a (possibly ranged) value with a constant. A range is `True` when every value in it
/// satisfies the comparison, `False` when none does, `Unknown` otherwise.
pub fn compare(cur: &Value, op: CmpOp, rhs: &Value) -> Tri {
    match (cur, rhs) {
        (Value::Bool(a), Value::Bool(b)) => match op {
            CmpOp::Eq => Tri::from_bool(a == b),
            CmpOp::Ne => Tri::from_bool(a != b),
            _ => Tri::Unknown,
        },
        (Value::Enum(ea, a), Value::Enum(eb, b)) if ea == eb => match op {
            CmpOp::Eq => Tri::from_bool(a == b),
            CmpOp::Ne => Tri::from_bool(a != b),
            _ => Tri::Unknown,
        },
        _ => {
            let (Some((lo, hi)), Some((rlo, rhi))) = (cur.bounds(), rhs.bounds()) else {
                return Tri::Unknown;
            };
            // Every pair (x in cur, y in rhs) vs. some pair.
            let all = cmp_num(lo, op, rlo) && cmp_num(lo, op, rhi) && cmp_num(hi, op, rlo) && cmp_num(hi, op, rhi);
            let any = match op {
                CmpOp::Eq => lo <= rhi && rlo <= hi,
                CmpOp::Ne => !(lo == hi && rlo == rhi && lo == rlo),
                CmpOp::Lt => lo < rhi,
                CmpOp::Le => lo <= rhi,
                CmpOp::Gt => hi > rlo,
                CmpOp::Ge => hi >= rlo,
            };
            if all && (op != CmpOp::Eq || (lo == hi && rlo == rhi)) {
                Tri::True
            } else if !any {
                Tri::False
            } else {
                Tri::Unknown
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Things on a lane: a barrier, a cone behind it, a post, and a tag for rules.
    const LANE: &str = r#"
domain lane_things
kind Thing { distance: length in 0m..100m = 5m..9m  lateral: length in -5m..5m = -1m..1m }
region lane { x 0m..40m  y -1m..1m }
relation behind "is behind" { ahead 1m..3m  left -1m..1m }
concept barrier { description "b" add barrier: Thing in lane probe "b" not "no b" }
concept cone { description "c" add cone: Thing in lane behind barrier probe "c" not "no c" }
concept post { description "p" add post: Thing in lane { distance = 6m..7m } probe "p" not "no p" }
question q { text "?" option yes "y" option no "n" }
rules priority {
  rule behind_it { when exists c: Thing where exists b: Thing where c behind b expect q.yes }
  rule other { expect q.no }
}
"#;

    fn lane() -> Domain {
        crate::check::compile_source("lane.rev", LANE).unwrap_or_else(|d| panic!("{d:?}"))
    }

    /// Evaluate `when` of a rule written in `.rev` syntax on the graph of `names`, with `a` and
    /// `b` bound to the named entities.
    fn eval_with(d: &Domain, names: &[&str], cond: &str, a: &str, b: &str) -> Tri {
        let text = LANE.replace("when exists c: Thing where exists b: Thing where c behind b", cond);
        let d2 = crate::check::compile_source("lane.rev", &text).unwrap_or_else(|e| panic!("{cond}: {e:?}"));
        let g = build(d, d.parse_set(names).unwrap()).unwrap();
        let find = |n: &str| g.entities.iter().position(|e| e.name == n).unwrap();
        let Some(Expr::Exists { cond: Some(inner), .. }) = d2.rules[0].when.clone() else { panic!("{cond}") };
        let Expr::Exists { cond: Some(body), .. } = *inner else { panic!("{cond}") };
        eval(d, &g, &body, &mut vec![("x".into(), find(a)), ("y".into(), find(b))])
    }

    #[test]
    fn relations_are_edges_of_the_graph() {
        let d = lane();
        let rel = |cond: &str, a, b| eval_with(&d, &["barrier", "cone", "post"], cond, a, b);
        let w = |c: &str| format!("when exists x: Thing where exists y: Thing where {c}");
        assert_eq!(rel(&w("x behind y"), "cone", "barrier"), Tri::True);
        assert_eq!(rel(&w("x behind y"), "barrier", "cone"), Tri::False);
        assert_eq!(rel(&w("x behind y"), "post", "barrier"), Tri::False, "close by, but no edge");
        assert_eq!(rel(&w("x near y"), "cone", "barrier"), Tri::False, "another relation");
        assert_eq!(rel(&w("x ahead_of ego"), "barrier", "cone"), Tri::True, "the default relation");
        assert_eq!(rel(&w("x ahead_of ego"), "cone", "barrier"), Tri::False);
    }

    #[test]
    fn two_entities_compare_three_valued() {
        let d = lane();
        let cmp = |cond: &str, a, b| {
            let c = format!("when exists x: Thing where exists y: Thing where {cond}");
            eval_with(&d, &["barrier", "cone", "post"], &c, a, b)
        };
        // The relation fixes the order, which the overlapping ranges alone would not.
        assert_eq!(cmp("x.distance > y.distance", "cone", "barrier"), Tri::True);
        assert_eq!(cmp("x.distance < y.distance", "barrier", "cone"), Tri::True);
        assert_eq!(cmp("x.distance == y.distance", "cone", "barrier"), Tri::False);
        assert_eq!(cmp("x.lateral < y.lateral", "cone", "barrier"), Tri::Unknown);
        // Unrelated, overlapping ranges: unknown; one attribute of one entity is one value.
        assert_eq!(cmp("x.distance < y.distance", "post", "barrier"), Tri::Unknown);
        assert_eq!(cmp("x.distance < y.distance", "post", "post"), Tri::False);
        assert_eq!(cmp("x.distance >= y.distance", "post", "post"), Tri::True);
    }

    #[test]
    fn related_entities_are_narrowed_to_their_relation() {
        let d = lane();
        let g = build(&d, d.parse_set(&["barrier", "cone"]).unwrap()).unwrap();
        // The cone is 1-3 m beyond a barrier at 5-9 m: 6-12 m, within its own 5-9 m.
        assert_eq!(g.entities[1].target, Some(0));
        assert_eq!(g.entities[1].attrs[0], Value::Range(6.0, 9.0));
        assert_eq!(g.entities[0].attrs[0], Value::Range(5.0, 9.0), "the target keeps its range");
        let err = build(&d, d.parse_set(&["cone"]).unwrap()).unwrap_err();
        assert_eq!(err.to_string(), "concept `cone` places `cone` behind `barrier`, which no concept of the set adds");
    }

    #[test]
    fn ranges_compare_three_valued() {
        let near = Value::Range(2.0, 4.0);
        let far = Value::Range(15.0, 25.0);
        assert_eq!(compare(&near, CmpOp::Le, &Value::Number(4.0)), Tri::True);
        assert_eq!(compare(&far, CmpOp::Le, &Value::Number(4.0)), Tri::False);
        assert_eq!(compare(&Value::Range(3.0, 6.0), CmpOp::Le, &Value::Number(4.0)), Tri::Unknown);
        assert_eq!(compare(&far, CmpOp::Gt, &Value::Number(4.0)), Tri::True);
        assert_eq!(compare(&Value::Number(3.0), CmpOp::Eq, &Value::Number(3.0)), Tri::True);
        assert_eq!(compare(&near, CmpOp::Eq, &Value::Number(3.0)), Tri::Unknown);
    }
}

//! The anchor scene graph of a concept set (paper §3.1): the union of the entities and world
//! settings its concepts add, then its modifiers applied. Rules are evaluated here, with
//! three-valued logic, so every image of a set shares one expected answer.
//!
//! Modifier targets: a modifier applies to the *most recently added* matching entity, which for
//! an unordered set means: the matching entity added by the concept with the highest index
//! (declared last); within one concept, the entity added last. Modifiers are applied in index
//! order, so when two modifiers set the same attribute the one declared later wins.

use crate::ir::{
    CmpOp, ConceptId, ConceptKind, ConceptSet, Domain, Effect, Expr, KindId, RegionId, Relation, TargetFilter, Value,
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
    Ok(g)
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

//! Words for the oracle's answers: rule conditions printed in `.rev` syntax, values with their
//! units, the entity that satisfies a condition, and what makes a condition unknown.

use crate::anchor::{self, AnchorGraph, Tri};
use crate::ir::{AttrRef, AttrType, ConceptSet, Domain, Expr, TargetFilter, Value};

/// A set as `{`a`, `b`}`, concepts in index order.
pub fn set_text(domain: &Domain, set: ConceptSet) -> String {
    let names: Vec<String> = set
        .iter()
        .map(|c| domain.concepts.get(c.index()).map_or_else(|| format!("#{}", c.0), |k| format!("`{}`", k.name)))
        .collect();
    format!("{{{}}}", names.join(", "))
}

/// The letter of option `i`: A … Z, then AA, AB, … (bijective base 26).
pub fn option_letter(i: u32) -> String {
    let mut n = i + 1;
    let mut out = Vec::new();
    while n > 0 {
        n -= 1;
        out.push(b'A' + (n % 26) as u8);
        n /= 26;
    }
    out.reverse();
    String::from_utf8(out).unwrap_or_default()
}

/// An expression in `.rev` syntax.
pub fn expr_text(domain: &Domain, e: &Expr) -> String {
    fmt_expr(domain, e, 0)
}

/// Precedence: 0 = or, 1 = and, 2 = unary.
fn fmt_expr(domain: &Domain, e: &Expr, outer: u8) -> String {
    let (text, prec) = match e {
        Expr::Bool(b) => (b.to_string(), 2),
        Expr::Not(inner) => (format!("not {}", fmt_expr(domain, inner, 2)), 2),
        Expr::And(es) => (join(domain, es, " and ", 1), 1),
        Expr::Or(es) => (join(domain, es, " or ", 0), 0),
        Expr::Has(c) => (format!("has {}", concept_name(domain, c.index())), 2),
        Expr::Exists { var, filter, cond } => {
            let head = format!("exists {var}: {}", filter_text(domain, filter));
            match cond {
                None => (head, 2),
                // `where` extends to the end, so it binds loosest.
                Some(c) => (format!("{head} where {}", fmt_expr(domain, c, 0)), 0),
            }
        }
        Expr::Count { filter, op, n } => (format!("count({}) {} {n}", filter_text(domain, filter), op_text(*op)), 2),
        Expr::Cmp { var, attr, op, value } => {
            let target = var.as_deref().unwrap_or("world");
            let dim = attr_dimension(domain, var.is_none(), attr);
            (format!("{target}.{attr} {} {}", op_text(*op), value_text(domain, value, dim.as_deref())), 2)
        }
        Expr::InRegion { var, region } => {
            let r = domain.regions.get(region.index()).map_or("?", |r| r.name.as_str());
            (format!("{var} in {r}"), 2)
        }
        Expr::CmpAttrs { left, op, right } => (format!("{} {} {}", ref_text(left), op_text(*op), ref_text(right)), 2),
        Expr::Related { var, relation, to } => (format!("{var} {relation} {}", to.as_deref().unwrap_or("ego")), 2),
    };
    if prec < outer { format!("({text})") } else { text }
}

fn ref_text(r: &AttrRef) -> String {
    format!("{}.{}", r.var.as_deref().unwrap_or("world"), r.attr)
}

fn join(domain: &Domain, es: &[Expr], sep: &str, prec: u8) -> String {
    es.iter().map(|e| fmt_expr(domain, e, prec + 1)).collect::<Vec<_>>().join(sep)
}

fn concept_name(domain: &Domain, i: usize) -> &str {
    domain.concepts.get(i).map_or("?", |c| c.name.as_str())
}

pub fn filter_text(domain: &Domain, f: &TargetFilter) -> String {
    let kinds = f.kinds.iter().map(|k| domain.kinds.get(k.index()).map_or("?", |k| k.name.as_str()));
    let tags = f.tags.iter().map(|t| domain.tags.get(t.index()).map_or("?", |t| t.name.as_str()));
    let names: Vec<&str> = kinds.chain(tags).collect();
    if names.is_empty() { if f.world { "world".into() } else { "any".into() } } else { names.join(" | ") }
}

pub fn op_text(op: crate::ir::CmpOp) -> &'static str {
    use crate::ir::CmpOp::*;
    match op {
        Eq => "==",
        Ne => "!=",
        Lt => "<",
        Le => "<=",
        Gt => ">",
        Ge => ">=",
    }
}

/// The dimension of an attribute by name: the world's, or the first kind declaring it (the
/// checker gives an attribute name one type across the kinds a condition can reach).
fn attr_dimension(domain: &Domain, world: bool, attr: &str) -> Option<String> {
    let ty = if world {
        domain.world_attr(attr).map(|a| &a.ty)
    } else {
        domain.kinds.iter().find_map(|k| k.attr(attr).map(|i| &k.attrs[i].ty))
    };
    match ty {
        Some(AttrType::Number { dimension, .. }) => Some(dimension.clone()),
        _ => None,
    }
}

/// A value as written in source: numbers in the dimension's base unit (`4m`), ranges `a..b`.
pub fn value_text(domain: &Domain, v: &Value, dimension: Option<&str>) -> String {
    let unit = dimension
        .filter(|d| !d.is_empty())
        .and_then(|d| domain.units.iter().find(|u| u.dimension == d && u.scale == 1.0))
        .map_or("", |u| u.name.as_str());
    match v {
        Value::Bool(b) => b.to_string(),
        Value::Number(x) => format!("{x}{unit}"),
        Value::Range(a, b) => format!("{a}{unit}..{b}{unit}"),
        Value::Enum(e, i) => domain
            .enums
            .get(e.index())
            .and_then(|d| d.variants.get(*i as usize))
            .cloned()
            .unwrap_or_else(|| format!("#{i}")),
    }
}

/// The entity that makes a true condition true, when the condition is (or conjoins) an
/// `exists`: "`obstruction`, added by `obstruction_near`".
pub fn witness(domain: &Domain, g: &AnchorGraph, e: &Expr) -> Option<String> {
    match e {
        Expr::And(es) => es.iter().find_map(|c| witness(domain, g, c)),
        Expr::Exists { var, filter, cond } => {
            let ent = g.entities.iter().enumerate().find(|(i, ent)| {
                filter.matches(domain, ent.kind)
                    && cond
                        .as_ref()
                        .is_none_or(|c| anchor::eval(domain, g, c, &mut vec![(var.clone(), *i)]) == Tri::True)
            })?;
            Some(format!("`{}`, added by `{}`", ent.1.name, concept_name(domain, ent.1.concept.index())))
        }
        _ => None,
    }
}

/// Why an expression evaluates to unknown on `g`: the comparison that straddles its threshold
/// (or cannot be evaluated), e.g. "`obstruction.distance` is 3m..6m, which straddles `<= 4m`".
pub fn unknown_cause(
    domain: &Domain,
    g: &AnchorGraph,
    e: &Expr,
    bindings: &mut Vec<(String, usize)>,
) -> Option<String> {
    match e {
        Expr::Not(inner) => unknown_cause(domain, g, inner, bindings),
        Expr::And(es) | Expr::Or(es) => es
            .iter()
            .find(|c| anchor::eval(domain, g, c, bindings) == Tri::Unknown)
            .and_then(|c| unknown_cause(domain, g, c, bindings)),
        Expr::Exists { var, filter, cond: Some(cond) } => {
            for (i, ent) in g.entities.iter().enumerate() {
                if !filter.matches(domain, ent.kind) {
                    continue;
                }
                bindings.push((var.clone(), i));
                let cause = if anchor::eval(domain, g, cond, bindings) == Tri::Unknown {
                    unknown_cause(domain, g, cond, bindings)
                } else {
                    None
                };
                bindings.pop();
                if cause.is_some() {
                    return cause;
                }
            }
            None
        }
        Expr::Cmp { var, attr, op, value } => Some(cmp_cause(domain, g, var.as_deref(), attr, *op, value, bindings)),
        Expr::InRegion { var, .. } | Expr::Related { var, .. } => Some(format!("variable `{var}` is not bound")),
        Expr::CmpAttrs { left, op, right } => {
            let side = |r: &AttrRef| -> Result<(String, String), String> {
                let (subject, value, dim) = attr_of(domain, g, r, bindings)?;
                Ok((format!("`{subject}.{}`", r.attr), value_text(domain, value, dim.as_deref())))
            };
            Some(match (side(left), side(right)) {
                (Ok((l, lv)), Ok((r, rv))) => {
                    format!("{l} is {lv} and {r} is {rv}, which overlap where `{}` flips", op_text(*op))
                }
                (Err(e), _) | (_, Err(e)) => e,
            })
        }
        _ => None,
    }
}

/// The owner's name, the value and the dimension of an attribute reference (or why there is
/// none).
fn attr_of<'g>(
    domain: &Domain,
    g: &'g AnchorGraph,
    r: &AttrRef,
    bindings: &[(String, usize)],
) -> Result<(String, &'g Value, Option<String>), String> {
    match &r.var {
        None => {
            let i = domain.world.iter().position(|a| a.name == r.attr).ok_or(format!("`world` has no `{}`", r.attr))?;
            Ok(("world".into(), &g.world[i], attr_dimension(domain, true, &r.attr)))
        }
        Some(v) => {
            let Some(&(_, ei)) = bindings.iter().rev().find(|(n, _)| n == v) else {
                return Err(format!("variable `{v}` is not bound"));
            };
            let ent = &g.entities[ei];
            let kind = &domain.kinds[ent.kind.index()];
            let i = kind.attr(&r.attr).ok_or(format!("`{}` has no attribute `{}`", ent.name, r.attr))?;
            let dim = match &kind.attrs[i].ty {
                AttrType::Number { dimension, .. } => Some(dimension.clone()),
                _ => None,
            };
            Ok((ent.name.clone(), &ent.attrs[i], dim))
        }
    }
}

fn cmp_cause(
    domain: &Domain,
    g: &AnchorGraph,
    var: Option<&str>,
    attr: &str,
    op: crate::ir::CmpOp,
    rhs: &Value,
    bindings: &[(String, usize)],
) -> String {
    let (subject, current, dimension) = match var {
        None => {
            let i = domain.world.iter().position(|a| a.name == attr);
            let dim = attr_dimension(domain, true, attr);
            ("world".to_string(), i.map(|i| &g.world[i]), dim)
        }
        Some(v) => {
            let Some(&(_, ei)) = bindings.iter().rev().find(|(n, _)| n == v) else {
                return format!("variable `{v}` is not bound");
            };
            let ent = &g.entities[ei];
            let kind = &domain.kinds[ent.kind.index()];
            let current = kind.attr(attr).map(|i| &ent.attrs[i]);
            let dim = match kind.attr(attr).map(|i| &kind.attrs[i].ty) {
                Some(AttrType::Number { dimension, .. }) => Some(dimension.clone()),
                _ => None,
            };
            (ent.name.clone(), current, dim)
        }
    };
    let threshold = format!("{} {}", op_text(op), value_text(domain, rhs, dimension.as_deref()));
    match current {
        None => format!("`{subject}` has no attribute `{attr}`"),
        Some(cur @ Value::Range(..)) => format!(
            "`{subject}.{attr}` is {}, which straddles `{threshold}`",
            value_text(domain, cur, dimension.as_deref())
        ),
        Some(cur) => format!(
            "`{subject}.{attr}` is {}, which cannot be compared with `{threshold}`",
            value_text(domain, cur, dimension.as_deref())
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letters_are_bijective_base_26() {
        let got: Vec<String> = [0, 1, 25, 26, 27, 51, 52, 701, 702].into_iter().map(option_letter).collect();
        assert_eq!(got, ["A", "B", "Z", "AA", "AB", "AZ", "BA", "ZZ", "AAA"]);
    }
}

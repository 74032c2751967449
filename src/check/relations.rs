//! Relations: what a `relation` item says about placement (`{ distance 0m..1.5m }`), and the
//! checks on `add … RELATION TARGET` that need every concept lowered first: an entity placed
//! relative to itself or in a cycle, a region that is out of reach of the relation's target, and
//! kinds added to or moved into regions they may not stand in.

use super::lower::{Checker, RelatedAdd, duplicate_statement};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::diag::suggest::suggest;
use crate::ir::*;
use crate::syntax::ast::{self, Ident, Item};

/// The placement words, and whether each takes a `MIN..MAX` length range.
const PLACEMENT_WORDS: &[(&str, bool)] = &[("distance", true), ("ahead", true), ("left", true), ("on_top", false)];

impl Checker<'_> {
    pub(super) fn lower_relation(
        &mut self,
        item: &Item,
        name: &Ident,
        text: &ast::Str,
        placements: Option<&[ast::Placement]>,
    ) {
        let mut p = Placement::default();
        let mut seen: Vec<(&str, Span)> = Vec::new();
        let mut ok = true;
        for w in placements.unwrap_or_default() {
            let Some(&(word, ranged)) = PLACEMENT_WORDS.iter().find(|(n, _)| *n == w.word.name) else {
                let d = Diagnostic::error(
                    codes::RELATION_PLACEMENT,
                    w.word.span,
                    format!("unknown placement `{}`", w.word.name),
                )
                .with_label("not a placement word");
                let words = PLACEMENT_WORDS.iter().map(|(n, _)| *n);
                let d = match suggest(&w.word.name, words) {
                    Some(s) => d.with_help(format!("did you mean `{s}`?")),
                    None => d.with_help("the placement words are `distance`, `ahead`, `left` and `on_top`"),
                };
                self.error(d);
                ok = false;
                continue;
            };
            if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == word) {
                let prev = *prev;
                self.error(duplicate_statement(word, w.span, prev));
                ok = false;
                continue;
            }
            seen.push((word, w.span));
            let range = match (&w.range, ranged) {
                (None, false) => None,
                (Some(_), false) => {
                    self.error(
                        Diagnostic::error(codes::RELATION_PLACEMENT, w.span, format!("`{word}` takes no range"))
                            .with_label("remove the range")
                            .with_help("`on_top` puts the entity on its target's highest face, at its position"),
                    );
                    ok = false;
                    continue;
                }
                (None, true) => {
                    self.error(
                        Diagnostic::error(codes::RELATION_PLACEMENT, w.span, format!("`{word}` needs a range"))
                            .with_label("no range")
                            .with_help(format!("write `{word} MIN..MAX` in metres, e.g. `{word} 0m..1.5m`")),
                    );
                    ok = false;
                    continue;
                }
                (Some((lo, hi)), true) => {
                    let (lo_v, hi_v) = (self.number(lo, "length"), self.number(hi, "length"));
                    let (Some(lo_v), Some(hi_v)) = (lo_v, hi_v) else {
                        ok = false;
                        continue;
                    };
                    if lo_v > hi_v {
                        self.error(super::values::empty_range(super::lower::join(lo.span, hi.span)));
                        ok = false;
                        continue;
                    }
                    if word == "distance" && lo_v < 0.0 {
                        self.error(
                            Diagnostic::error(codes::OUT_OF_RANGE, lo.span, "a distance cannot be negative")
                                .with_label("below 0m")
                                .with_help("use `ahead` or `left` for signed offsets"),
                        );
                        ok = false;
                        continue;
                    }
                    Some((lo_v, hi_v))
                }
            };
            match word {
                "distance" => p.distance = range,
                "ahead" => p.ahead = range,
                "left" => p.left = range,
                _ => p.on_top = true,
            }
        }
        let given = p.distance.is_some() || p.ahead.is_some() || p.left.is_some() || p.on_top;
        if !given && ok && !item.broken {
            self.error(
                Diagnostic::error(
                    codes::RELATION_PLACEMENT,
                    name.span,
                    format!("relation `{}` does not say where it places an entity", name.name),
                )
                .with_label("no placement")
                .with_help(
                    "add one, e.g. `{ distance 0m..1.5m }`; the words are `distance`, `ahead`, `left` and `on_top`",
                ),
            );
        } else if given && ok && !placement_possible(&p) {
            self.error(
                Diagnostic::error(
                    codes::RELATION_PLACEMENT,
                    name.span,
                    format!("the placement of relation `{}` allows no position", name.name),
                )
                .with_label("contradictory placement")
                .with_help("its bounds exclude one another; widen one of them"),
            );
        }
        if self.relations.span(&name.name) != Some(name.span) {
            return; // a duplicate, already reported
        }
        self.d.relations.push(RelationDef {
            name: name.name.clone(),
            text: text.value.clone(),
            placement: p,
            span: item.span,
        });
    }

    /// Checks over every `add … RELATION TARGET` and `move`, once all concepts are lowered.
    pub(super) fn check_relations(&mut self) {
        self.relation_cycles();
        let adds = std::mem::take(&mut self.related_adds);
        for a in &adds {
            self.reachable(a);
        }
        self.related_adds = adds;
        self.check_moves();
    }

    /// An entity may not be placed relative to itself, directly or through other entities.
    fn relation_cycles(&mut self) {
        let edges: Vec<(String, String, Span)> =
            self.related_adds.iter().filter_map(|a| a.target.clone().map(|t| (a.entity.clone(), t, a.span))).collect();
        let mut reported: Vec<String> = Vec::new();
        for (from, to, span) in &edges {
            // Follow targets from `to`; coming back to `from` closes a cycle.
            let start = vec![from.clone(), to.clone()];
            let mut cycle = (from == to).then(|| start.clone());
            let mut frontier = vec![(to.clone(), start)];
            let mut seen: Vec<String> = vec![to.clone()];
            while cycle.is_none() {
                let Some((node, p)) = frontier.pop() else { break };
                for (f, t, _) in &edges {
                    if *f != node {
                        continue;
                    }
                    let mut next = p.clone();
                    next.push(t.clone());
                    if t == from {
                        cycle = Some(next);
                        break;
                    }
                    if !seen.contains(t) {
                        seen.push(t.clone());
                        frontier.push((t.clone(), next));
                    }
                }
            }
            let Some(cycle) = cycle else { continue };
            if reported.contains(from) {
                continue;
            }
            reported.extend(cycle.iter().cloned());
            let message = if cycle.len() == 2 {
                format!("`{from}` is placed relative to itself")
            } else {
                let chain: Vec<String> = cycle.iter().map(|n| format!("`{n}`")).collect();
                format!("entities are placed relative to each other in a cycle: {}", chain.join(" → "))
            };
            self.error(
                Diagnostic::error(codes::UNPLACEABLE_RELATION, *span, message)
                    .with_label("no entity of the cycle can be placed first")
                    .with_help("relate one of them to `ego` or to an entity outside the cycle"),
            );
        }
    }

    /// The entity's region must be able to meet the relation around every place its target can
    /// be added in (ego: the scene origin).
    fn reachable(&mut self, a: &RelatedAdd) {
        let Some(rel) = self.d.relations.iter().find(|r| r.name == a.relation) else { return };
        let placement = rel.placement.clone();
        if placement == Placement::default() {
            return; // reported at the relation
        }
        let own = &self.d.regions[a.region.index()];
        let own_box = (span_of(own.x), span_of(own.y));
        let targets: Vec<(String, RegionId)> = match &a.target {
            None => vec![],
            Some(t) => self
                .d
                .concepts
                .iter()
                .flat_map(|c| &c.effects)
                .filter_map(|e| match e {
                    Effect::Add { name, region, .. } if name == t => Some((name.clone(), *region)),
                    _ => None,
                })
                .collect(),
        };
        let places: Vec<(String, GroundBounds)> = match &a.target {
            None => vec![("ego".to_string(), ((0.0, 0.0), (0.0, 0.0)))],
            Some(_) => targets
                .iter()
                .map(|(_, r)| {
                    let reg = &self.d.regions[r.index()];
                    (format!("region `{}`", reg.name), (span_of(reg.x), span_of(reg.y)))
                })
                .collect(),
        };
        for (where_, target_box) in places {
            if reaches(&placement, own_box, target_box) {
                continue;
            }
            let target = a.target.as_deref().unwrap_or("ego");
            let whom = if a.target.is_some() { format!("`{target}` in {where_}") } else { "ego".to_string() };
            self.error(
                Diagnostic::error(
                    codes::UNPLACEABLE_RELATION,
                    a.span,
                    format!(
                        "`{}` in region `{}` can never be `{}` {whom}",
                        a.entity,
                        self.d.regions[a.region.index()].name,
                        a.relation
                    ),
                )
                .with_label(format!("out of reach: `{}` allows {}", a.relation, placement_text(&placement)))
                .with_help(format!(
                    "place `{}` in a region within reach of `{target}`, or widen the placement of relation `{}`",
                    a.entity, a.relation
                )),
            );
            return;
        }
    }

    /// `move REGION` into a region that a kind the modifier can move may not stand in.
    fn check_moves(&mut self) {
        let added: Vec<(KindId, String)> = self
            .d
            .concepts
            .iter()
            .flat_map(|c| &c.effects)
            .filter_map(|e| match e {
                Effect::Add { kind, name, .. } => Some((*kind, name.clone())),
                _ => None,
            })
            .collect();
        let mut errors = Vec::new();
        for c in &self.d.concepts {
            let Some(filter) = &c.target else { continue };
            for e in &c.effects {
                let Effect::MoveTarget { region, span } = e else { continue };
                let barred = added
                    .iter()
                    .find(|(k, _)| filter.matches(&self.d, *k) && !self.d.kinds[k.index()].may_stand_in(*region));
                if let Some((k, entity)) = barred {
                    let kind = &self.d.kinds[k.index()];
                    errors.push(
                        Diagnostic::error(
                            codes::REGION_NOT_ALLOWED,
                            *span,
                            format!(
                                "modifier `{}` can move `{entity}` into `{}`, where kind `{}` may not stand",
                                c.name,
                                self.d.regions[region.index()].name,
                                kind.name
                            ),
                        )
                        .with_label(format!("`{}` stands only in {}", kind.name, self.region_list(&kind.regions)))
                        .with_help("narrow the modifier's `target`, or add the region to the kind's `in` list"),
                    );
                }
            }
        }
        for d in errors {
            self.error(d);
        }
    }

    /// `add NAME: KIND in REGION` where the kind may not stand.
    pub(super) fn check_stand(&mut self, kind: KindId, region: RegionId, region_name: &Ident) -> bool {
        let k = &self.d.kinds[kind.index()];
        if k.may_stand_in(region) {
            return true;
        }
        let d = Diagnostic::error(
            codes::REGION_NOT_ALLOWED,
            region_name.span,
            format!("kind `{}` may not stand in region `{}`", k.name, region_name.name),
        )
        .with_label(format!("`{}` stands only in {}", k.name, self.region_list(&k.regions)))
        .with_help("add it in one of those regions, or add this region to the kind's `in` list");
        self.error(d);
        false
    }

    pub(super) fn region_list(&self, regions: &[RegionId]) -> String {
        let names: Vec<String> = regions.iter().map(|r| format!("`{}`", self.d.regions[r.index()].name)).collect();
        names.join(", ")
    }
}

fn span_of((a, b): (f64, f64)) -> (f64, f64) {
    (a.min(b), a.max(b))
}

/// Whether some point of `own` lies within the placement around some point of `target`.
fn reaches(p: &Placement, own: GroundBounds, target: GroundBounds) -> bool {
    let (ox, oy) = p.offset_box();
    // Offsets from a target point to an own point range over own ⊖ target.
    let dx = (own.0.0 - target.0.1, own.0.1 - target.0.0);
    let dy = (own.1.0 - target.1.1, own.1.1 - target.1.0);
    let meet = |a: (f64, f64), b: (f64, f64)| (a.0.max(b.0), a.1.min(b.1));
    let (mx, my) = (meet(dx, ox), meet(dy, oy));
    if mx.0 > mx.1 + 1e-9 || my.0 > my.1 + 1e-9 {
        return false;
    }
    match p.distance {
        None => true,
        Some((lo, hi)) => {
            // The nearest and farthest offsets in the met box.
            let near = |r: (f64, f64)| {
                if r.0 > 0.0 {
                    r.0
                } else if r.1 < 0.0 {
                    -r.1
                } else {
                    0.0
                }
            };
            let far = |r: (f64, f64)| r.0.abs().max(r.1.abs());
            near(mx).hypot(near(my)) <= hi + 1e-9 && far(mx).hypot(far(my)) >= lo - 1e-9
        }
    }
}

/// Whether some offset satisfies every bound of the placement.
fn placement_possible(p: &Placement) -> bool {
    let zero = ((0.0, 0.0), (0.0, 0.0));
    let any = ((f64::MIN / 4.0, f64::MAX / 4.0), (f64::MIN / 4.0, f64::MAX / 4.0));
    // The own box is unbounded, the target a point: `reaches` then tests the placement alone.
    reaches(p, any, zero) && {
        let (x, y) = p.offset_box();
        x.0 <= x.1 && y.0 <= y.1
    }
}

/// "0m..1.5m away", "0m..1000m ahead", "on top".
pub(crate) fn placement_text(p: &Placement) -> String {
    let fmt = super::values::fmt_num;
    let mut parts = Vec::new();
    if let Some((a, b)) = p.distance {
        parts.push(format!("{}m..{}m away", fmt(a), fmt(b)));
    }
    if let Some((a, b)) = p.ahead {
        parts.push(format!("{}m..{}m ahead", fmt(a), fmt(b)));
    }
    if let Some((a, b)) = p.left {
        parts.push(format!("{}m..{}m to the left", fmt(a), fmt(b)));
    }
    if p.on_top {
        parts.push("on top".to_string());
    }
    parts.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reach_between_boxes() {
        let near = Placement { distance: Some((0.0, 1.5)), ..Placement::default() };
        let unit = ((0.0, 1.0), (0.0, 1.0));
        assert!(reaches(&near, unit, ((2.0, 3.0), (0.0, 1.0))));
        assert!(!reaches(&near, unit, ((3.0, 4.0), (0.0, 1.0))));
        assert!(!reaches(&near, unit, ((2.2, 3.0), (2.2, 3.0))), "the corners are 1.7m apart");
        let ahead = Placement { ahead: Some((0.0, 1000.0)), ..Placement::default() };
        assert!(reaches(&ahead, unit, ((0.0, 0.0), (0.0, 0.0))));
        assert!(!reaches(&ahead, ((-5.0, -1.0), (0.0, 1.0)), ((0.0, 0.0), (0.0, 0.0))));
        let far = Placement { distance: Some((5.0, 6.0)), ..Placement::default() };
        assert!(!reaches(&far, unit, unit), "no two points of a unit box are 5m apart");
        let top = Placement { on_top: true, ..Placement::default() };
        assert!(reaches(&top, unit, ((0.5, 2.0), (0.5, 2.0))));
        assert!(!reaches(&top, unit, ((1.5, 2.0), (0.0, 1.0))));
    }

    #[test]
    fn contradictory_placements() {
        assert!(placement_possible(&Placement { distance: Some((0.0, 1.0)), ..Placement::default() }));
        assert!(!placement_possible(&Placement {
            distance: Some((0.0, 1.0)),
            ahead: Some((2.0, 3.0)),
            ..Placement::default()
        }));
        assert!(!placement_possible(&Placement { distance: Some((1.0, 2.0)), on_top: true, ..Placement::default() }));
        assert!(placement_possible(&Placement {
            ahead: Some((1.0, 2.0)),
            left: Some((-1.0, 1.0)),
            ..Placement::default()
        }));
    }
}

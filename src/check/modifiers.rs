//! What a modifier does to the entities it can land on, checked once every concept is lowered
//! (R0037): a `set` whose range cannot hold for a target kind — outside the attribute's bounds
//! on that kind, or a `distance`/`lateral` range outside the region the entity stands in, where
//! the sampler lets the region win and the image contradicts the rules and the probe — and a
//! modifier that leaves every entity it can land on as it was. A concept that a constraint keeps
//! out of every set with the modifier (`forbids`, `exclusive`) is no landing.

use super::lower::Checker;
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;

/// The attributes that place an entity along a region's axis (`sample::axis`), with the axis.
const POSITION_ATTRS: &[(&str, char)] = &[("distance", 'x'), ("lateral", 'y')];

/// A number or range as the language writes it, in `unit`.
fn range_text((lo, hi): (f64, f64), unit: &str) -> String {
    if lo == hi { format!("{lo}{unit}") } else { format!("{lo}{unit}..{hi}{unit}") }
}

impl Checker<'_> {
    /// Whether a `forbids` or `at_most` constraint rules out every set holding both concepts.
    fn kept_apart(&self, a: ConceptId, b: ConceptId) -> bool {
        let pair = ConceptSet::single(a).with(b);
        self.d.constraints.iter().any(|k| match &k.rule {
            ConstraintRule::AtMost { members, max } => members.intersection(pair).len() > *max as usize,
            ConstraintRule::Forbids { all } => !all.is_empty() && all.is_subset_of(pair),
            ConstraintRule::Requires { .. } => false,
        })
    }

    pub(super) fn check_modifier_effects(&mut self) {
        let mut out = Vec::new();
        for m in self.d.concepts.iter().filter(|c| c.kind == ConceptKind::Modifier) {
            let Some(filter) = m.target.as_ref().filter(|f| !f.world) else { continue };
            let moved_to = m.effects.iter().find_map(|e| match e {
                Effect::MoveTarget { region, .. } => Some(*region),
                _ => None,
            });
            // Every entity a concept adds that the modifier can land on.
            let landings: Vec<(&Concept, &Effect)> = self
                .d
                .concepts
                .iter()
                .filter(|c| c.kind == ConceptKind::Concept)
                .flat_map(|c| c.effects.iter().map(move |e| (c, e)))
                .filter(|(c, _)| !self.kept_apart(c.id, m.id))
                .filter(|(_, e)| matches!(e, Effect::Add { kind, .. } if filter.matches(&self.d, *kind)))
                .collect();
            if landings.is_empty() {
                continue; // no possible target: the lattice lint R0105 says so
            }
            let mut changes_something = false;
            let mut reported: Vec<(KindId, String)> = Vec::new();
            for (c, add) in &landings {
                let Effect::Add { name, kind, region: added_in, attrs, span: add_span, .. } = add else { continue };
                let k = &self.d.kinds[kind.index()];
                let region = moved_to.unwrap_or(*added_in);
                if region != *added_in {
                    changes_something = true;
                }
                for e in &m.effects {
                    let Effect::SetTarget { attr, value, span } = e else { continue };
                    let Some(slot) = k.attr(attr) else { continue }; // R0045
                    let def = &k.attrs[slot];
                    let now = attrs.iter().find(|(a, _)| a == attr).map_or(&def.default, |(_, v)| v);
                    if now != value {
                        changes_something = true;
                    }
                    let (Some((lo, hi)), AttrType::Number { min, max, dimension }) = (value.bounds(), &def.ty) else {
                        continue;
                    };
                    let unit = if dimension == "length" { "m" } else { "" };
                    let reason = if lo < *min || hi > *max {
                        Some((
                            format!("`{}` of `{}` lies in {}", attr, k.name, range_text((*min, *max), unit)),
                            "the bounds",
                        ))
                    } else {
                        POSITION_ATTRS.iter().find(|(a, _)| a == attr).and_then(|&(_, axis)| {
                            let r = &self.d.regions[region.index()];
                            let ext = if axis == 'x' { r.x } else { r.y };
                            let (rlo, rhi) = (ext.0.min(ext.1), ext.0.max(ext.1));
                            (lo < rlo || hi > rhi).then(|| {
                                (
                                    format!(
                                        "`{}` stands in region `{}`, whose {axis} is {}",
                                        name,
                                        r.name,
                                        range_text((rlo, rhi), "m")
                                    ),
                                    if hi < rlo || lo > rhi { "the region" } else { "part of the region" },
                                )
                            })
                        })
                    };
                    let Some((why, whose)) = reason else { continue };
                    if reported.iter().any(|(rk, ra)| rk == kind && ra == attr) {
                        continue;
                    }
                    reported.push((*kind, attr.clone()));
                    let set = range_text((lo, hi), unit);
                    out.push(
                        Diagnostic::warning(
                            codes::INEFFECTIVE_MODIFIER,
                            *span,
                            format!(
                                "modifier `{}` sets `{attr}` to {set}, which cannot hold for kind `{}`: {why}",
                                m.name, k.name
                            ),
                        )
                        .with_label(format!("{set} is outside {whose}"))
                        .with_related(*add_span, format!("`{name}` of kind `{}` added by `{}`", k.name, c.name))
                        .with_help(if whose == "the bounds" {
                            format!("set a range inside the bounds, narrow the `target`, or widen the bounds of `{attr}` on `{}`", k.name)
                        } else {
                            format!("the sampler keeps `{name}` in its region, so the image, the rules and the probe would disagree; set a range inside the region, narrow the `target`, keep the two apart with a constraint, or widen the region")
                        }),
                    );
                }
            }
            let acts = m.effects.iter().any(|e| matches!(e, Effect::SetTarget { .. } | Effect::MoveTarget { .. }));
            if acts && !changes_something {
                out.push(
                    Diagnostic::warning(
                        codes::INEFFECTIVE_MODIFIER,
                        m.span,
                        format!("modifier `{}` changes nothing on any entity it can land on", m.name),
                    )
                    .with_label(format!("every `set` and `move` of `{}` repeats what its targets already have", m.name))
                    .with_help("set a value, or move into a region, that differs from what the concepts add; or remove the modifier"),
                );
            }
        }
        for d in out {
            self.error(d);
        }
    }
}

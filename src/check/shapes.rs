//! Builtin-renderer shapes: kinds' looks (`shape { … }` or `look KIND { … }`), stage items, and
//! the shape parts they are made of.

use super::expr::Scope;
use super::lower::{Checker, TypeSym, duplicate_statement};
use super::{MAX_REPEAT, MAX_SHAPE_PARTS, MAX_STAGE_PARTS};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;
use crate::syntax::ast::{self, Item, ItemKind};

impl Checker<'_> {
    /// Give each kind its look: its own `shape { … }` or one `look KIND { … }`, not both.
    pub(crate) fn lower_looks(&mut self, items: &[(u32, &Item)]) {
        for k in 0..self.kind_items.len() {
            let item = self.kind_items[k];
            let ItemKind::Kind { shapes, .. } = &item.kind else { continue };
            for parts in shapes {
                self.set_look(KindId(k as u32), parts, "`shape` block");
            }
        }
        for (_, item) in items {
            let ItemKind::Look { kind, parts } = &item.kind else { continue };
            match self.resolve_type(kind, "kind") {
                Some(TypeSym::Kind(k)) => self.set_look(k, parts, "`look`"),
                Some(other) => self.error(
                    Diagnostic::error(
                        codes::WRONG_SORT,
                        kind.span,
                        format!("`{}` is {}, not a kind", kind.name, other.sort()),
                    )
                    .with_label("only kinds have a look"),
                ),
                None => {}
            }
        }
    }

    fn set_look(&mut self, k: KindId, parts: &ast::Parts, source: &'static str) {
        if let Some((first, first_source)) = self.look_spans[k.index()] {
            let name = self.d.kinds[k.index()].name.clone();
            self.error(
                Diagnostic::error(codes::DUPLICATE_LOOK, parts.span, format!("kind `{name}` already has a look"))
                    .with_label(format!("second look, from a {source}"))
                    .with_related(first, format!("first look, from a {first_source}"))
                    .with_help("give each kind one look: either `shape { … }` in the kind or one `look` item"),
            );
            return;
        }
        self.look_spans[k.index()] = Some((parts.span, source));
        let mut scope = Scope::for_self(vec![k]);
        if let Some(shape) = self.lower_parts(parts, &mut scope) {
            self.d.kinds[k.index()].shape = shape;
        }
    }

    /// A kind without its own look takes its nearest ancestor kind's (tags have no looks): parent
    /// kinds are searched level by level, and two different looks equally near are an error,
    /// as for `visible`. Shape parts name attributes, not positions, so a copy reads the child's
    /// own attributes. Returns which kinds now have a look, own or inherited.
    pub(crate) fn inherit_looks(&mut self) -> Vec<bool> {
        let n = self.d.kinds.len();
        let own: Vec<bool> = self.look_spans.iter().map(Option::is_some).collect();
        let mut has = own.clone();
        for k in 0..n {
            if own[k] {
                continue;
            }
            let mut level = self.kind_parents[k].clone();
            let mut visited = level.clone();
            while !level.is_empty() {
                let hits: Vec<KindId> = level.iter().copied().filter(|p| own[p.index()]).collect();
                if let Some(&first) = hits.first() {
                    let shape = self.d.kinds[first.index()].shape.clone();
                    match hits.iter().find(|p| self.d.kinds[p.index()].shape != shape) {
                        None => {
                            self.d.kinds[k].shape = shape;
                            has[k] = true;
                        }
                        Some(&other) => {
                            let kind = &self.d.kinds[k];
                            let (a, b) = (&self.d.kinds[first.index()], &self.d.kinds[other.index()]);
                            let mut d = Diagnostic::error(
                                codes::AMBIGUOUS_INHERITANCE,
                                kind.span,
                                format!(
                                    "kind `{}` inherits two different looks, from `{}` and `{}`",
                                    kind.name, a.name, b.name
                                ),
                            )
                            .with_label("equally near to both");
                            if let Some((span, _)) = self.look_spans[first.index()] {
                                d = d.with_related(span, "one look");
                            }
                            if let Some((span, _)) = self.look_spans[other.index()] {
                                d = d.with_related(span, "the other");
                            }
                            let d = d.with_help(format!("say which applies with `look {} {{ … }}`", kind.name));
                            // The kind still counts as drawn: the error is the one to fix.
                            has[k] = true;
                            self.error(d);
                        }
                    }
                    break;
                }
                let mut next = Vec::new();
                for p in &level {
                    for q in self.kind_parents[p.index()].clone() {
                        if !visited.contains(&q) {
                            visited.push(q);
                            next.push(q);
                        }
                    }
                }
                level = next;
            }
        }
        has
    }

    /// Warn about a kind some concept places that still draws nothing (a concept with its own
    /// `shape { … }` or a `drawn_by STAGE` draws what it adds), and about a look that
    /// nothing placed ever wears: no concept adds its kind nor any kind below it, and it is no
    /// scenery (`Extra`, which the sampler places). Only a domain is linted: a module checked
    /// alone is a part whose concepts or looks may live elsewhere. Looks in the stdlib are
    /// vocabulary a domain may leave unused. A domain that accepts undrawn entities with
    /// `allow R0108` (the render lint's code, `run::observe::UNDRAWN`, named here as the check
    /// sits below it) is not warned about placing one: runs after the `allow` items.
    pub(crate) fn lint_looks(&mut self, has_look: &[bool], std_files: &[u32]) {
        if self.d.name.is_empty() {
            return;
        }
        let undrawn_allowed = self.d.allow.iter().any(|a| a.code == "R0108");
        let n = self.d.kinds.len();
        // `placed`: some concept adds the kind; `bare`: one that draws it no other way (no
        // `shape { … }` of its own, no `drawn_by STAGE`) adds it.
        let mut placed: Vec<Option<Span>> = vec![None; n];
        let mut bare: Vec<Option<Span>> = vec![None; n];
        for c in &self.d.concepts {
            let drawn = c.render.drawn_by.is_some() || c.render.shape.as_ref().is_some_and(|s| !s.is_empty());
            for e in &c.effects {
                if let Effect::Add { kind, span, .. } = e {
                    placed[kind.index()].get_or_insert(*span);
                    if !drawn {
                        bare[kind.index()].get_or_insert(*span);
                    }
                }
            }
        }
        // The sampler's scenery tag (`sample::EXTRA_TAG`, named here as the check sits below it).
        let extra = self.d.tags.iter().position(|t| t.name == "Extra").map(|t| TagId(t as u32));
        // A kind is worn if it, or a kind below it, is placed or is scenery.
        let mut worn = vec![false; n];
        for k in (0..n).filter(|&k| placed[k].is_some() || extra.is_some_and(|t| self.d.kinds[k].has_tag(t))) {
            let mut stack = vec![k];
            while let Some(j) = stack.pop() {
                if !worn[j] {
                    worn[j] = true;
                    stack.extend(self.kind_parents[j].iter().map(|p| p.index()));
                }
            }
        }
        for k in 0..n {
            let name = self.d.kinds[k].name.clone();
            if let Some(add) = bare[k]
                && !has_look[k]
                && !undrawn_allowed
            {
                let d = Diagnostic::warning(
                    codes::DRAWS_NOTHING,
                    self.d.kinds[k].span,
                    format!("kind `{name}` is placed but draws nothing: it has no look, own or inherited"),
                )
                .with_label("no `shape { … }`, no `look`, and no ancestor kind with one")
                .with_related(add, "placed here")
                .with_help(format!(
                    "give it a look with `look {name} {{ … }}`, or on a kind it descends from; if a `stage` draws it, say so with `drawn_by STAGE` in the concept; or accept it undrawn with `allow R0108` and a `///` reason"
                ));
                self.error(d);
            }
            if let Some((span, source)) = self.look_spans[k]
                && !worn[k]
                && !std_files.contains(&span.file)
            {
                let d = Diagnostic::warning(
                    codes::DRAWS_NOTHING,
                    span,
                    format!("the look of kind `{name}` is never drawn: no concept places `{name}` or a kind below it"),
                )
                .with_label(format!("unused {source}"))
                .with_help(format!("add `{name}` in a concept, or remove the look"));
                self.error(d);
            }
        }
    }

    pub(crate) fn lower_stage(&mut self, items: &[(u32, &Item)]) {
        let (mut stage_parts, mut reported) = (0u64, false);
        for (_, item) in items {
            let ItemKind::Stage { name, opts, parts } = &item.kind else { continue };
            let mut at = [0.0; 3];
            let mut repeat = None;
            let mut when = None;
            let mut seen: Vec<(&'static str, Span)> = Vec::new();
            for o in opts {
                let (key, span) = match o {
                    ast::StageOpt::At(_, s) => ("at", *s),
                    ast::StageOpt::Repeat { span, .. } => ("repeat", *span),
                    ast::StageOpt::When(_, s) => ("when", *s),
                };
                if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == key) {
                    let prev = *prev;
                    self.error(duplicate_statement(key, span, prev));
                    continue;
                }
                seen.push((key, span));
                match o {
                    ast::StageOpt::At(v, _) => at = self.vec3(v, "length").unwrap_or(at),
                    ast::StageOpt::Repeat { count, step, span } => {
                        if *count > MAX_REPEAT {
                            self.error(
                                Diagnostic::error(
                                    codes::COUNT_TOO_LARGE,
                                    *span,
                                    format!("`repeat {count}` is over the most a stage item repeats, {MAX_REPEAT}"),
                                )
                                .with_label("too many copies")
                                .with_help("use a longer `step` and fewer copies"),
                            );
                            continue;
                        }
                        repeat = self.vec3(step, "length").map(|s| (*count, s));
                    }
                    ast::StageOpt::When(e, _) => when = self.lower_expr(e, &mut Scope::default()),
                }
            }
            let mut scope = Scope::default();
            let Some(parts) = self.lower_parts(parts, &mut scope) else { continue };
            let copies = u64::from(repeat.map_or(1, |(n, _)| n));
            stage_parts += parts.len() as u64 * copies;
            if stage_parts > MAX_STAGE_PARTS && !reported {
                reported = true;
                self.error(
                    Diagnostic::error(
                        codes::COUNT_TOO_LARGE,
                        name.span,
                        format!(
                            "stage `{}` brings the scene past {MAX_STAGE_PARTS} stage parts, repeats counted",
                            name.name
                        ),
                    )
                    .with_label(format!("{stage_parts} parts so far"))
                    .with_help("repeat fewer copies, or draw fewer stage items"),
                );
            }
            if self.stages.span(&name.name) == Some(name.span) {
                self.d.stage.push(StageItem { name: name.name.clone(), parts, at, repeat, when, span: item.span });
            }
        }
    }

    /// Lower a list of shape parts; `None` when any part has an error.
    pub(crate) fn lower_parts(&mut self, parts: &ast::Parts, scope: &mut Scope) -> Option<Vec<ShapePart>> {
        let mut out = Vec::new();
        let mut ok = true;
        if let Some(past) = parts.parts.get(MAX_SHAPE_PARTS) {
            self.error(
                Diagnostic::error(
                    codes::COUNT_TOO_LARGE,
                    past.span,
                    format!("a block may list at most {MAX_SHAPE_PARTS} parts; this one lists {}", parts.parts.len()),
                )
                .with_label(format!("part {}", MAX_SHAPE_PARTS + 1))
                .with_help("split the block into several stage items, or use `repeat`"),
            );
            return None;
        }
        for p in &parts.parts {
            match self.lower_part(p, scope) {
                Some(part) => out.push(part),
                None => ok = false,
            }
        }
        ok.then_some(out)
    }

    fn lower_part(&mut self, p: &ast::ShapePart, scope: &mut Scope) -> Option<ShapePart> {
        let mut part = ShapePart {
            prim: p.prim,
            size: [0.0; 3],
            at: [0.0; 3],
            color: [0.0, 0.0, 0.0, 1.0],
            yaw_deg: 0.0,
            roll_deg: 0.0,
            pitch_deg: 0.0,
            material: "matte".to_string(),
            when: None,
            shadow: true,
        };
        let mut ok = true;
        let mut seen: Vec<(&'static str, Span)> = Vec::new();
        for prop in &p.props {
            let (key, span) = prop_key(prop);
            if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == key) {
                let prev = *prev;
                self.error(duplicate_statement(key, span, prev));
                ok = false;
                continue;
            }
            seen.push((key, span));
            let done = match prop {
                ast::PartProp::Size(v, _) => self.vec3(v, "length").map(|v| part.size = v),
                ast::PartProp::At(v, _) => self.vec3(v, "length").map(|v| part.at = v),
                ast::PartProp::Color(text, _) => parse_color(text).map(|c| part.color = c),
                ast::PartProp::Material(m) => {
                    if MATERIALS.contains(&m.name.as_str()) {
                        part.material = m.name.clone();
                        Some(())
                    } else {
                        let d = super::names::unknown("material", m, MATERIALS.iter().copied())
                            .with_label(format!("materials: {}", MATERIALS.join(", ")));
                        self.error(d);
                        None
                    }
                }
                ast::PartProp::Yaw(n) => self.number(n, "angle").map(|v| part.yaw_deg = v),
                ast::PartProp::Roll(n) => self.number(n, "angle").map(|v| part.roll_deg = v),
                ast::PartProp::Pitch(n) => self.number(n, "angle").map(|v| part.pitch_deg = v),
                ast::PartProp::Shadow(b, _) => {
                    part.shadow = *b;
                    Some(())
                }
                ast::PartProp::When(e, _) => self.lower_expr(e, scope).map(|e| part.when = Some(e)),
            };
            ok &= done.is_some();
        }
        for required in ["size", "color"] {
            if !seen.iter().any(|(k, _)| *k == required) {
                self.error(
                    Diagnostic::error(codes::MISSING_STATEMENT, p.span, format!("shape part has no `{required}`"))
                        .with_label(format!("add `{required} …`"))
                        .with_help(if required == "size" {
                            "give the full extents, e.g. `size (1m, 1m, 1m)`"
                        } else {
                            "give an sRGB colour, e.g. `color #808080`"
                        }),
                );
                ok = false;
            }
        }
        ok.then_some(part)
    }
}

fn prop_key(p: &ast::PartProp) -> (&'static str, Span) {
    match p {
        ast::PartProp::Size(_, s) => ("size", *s),
        ast::PartProp::At(_, s) => ("at", *s),
        ast::PartProp::Color(_, s) => ("color", *s),
        ast::PartProp::Material(m) => ("material", m.span),
        ast::PartProp::Yaw(n) => ("yaw", n.span),
        ast::PartProp::Roll(n) => ("roll", n.span),
        ast::PartProp::Pitch(n) => ("pitch", n.span),
        ast::PartProp::Shadow(_, s) => ("shadow", *s),
        ast::PartProp::When(_, s) => ("when", *s),
    }
}

/// `#rrggbb` or `#rrggbbaa` to components in 0..=1 (the parser already reported other lengths).
fn parse_color(text: &str) -> Option<[f64; 4]> {
    let hex = text.strip_prefix('#')?;
    if !matches!(hex.len(), 6 | 8) {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok().map(|b| f64::from(b) / 255.0);
    let alpha = if hex.len() == 8 { byte(6)? } else { 1.0 };
    Some([byte(0)?, byte(2)?, byte(4)?, alpha])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colors() {
        assert_eq!(parse_color("#ff0000"), Some([1.0, 0.0, 0.0, 1.0]));
        assert_eq!(parse_color("#00000000"), Some([0.0, 0.0, 0.0, 0.0]));
        assert_eq!(parse_color("#fff"), None);
    }
}

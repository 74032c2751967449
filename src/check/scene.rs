//! The scene-level items: world attributes, regions, presets, the camera and the visibility
//! thresholds (`visible` items).

use super::lower::{Checker, TypeSym, duplicate_statement};
use super::names::Namespace;
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;
use crate::syntax::ast::{self, Ident, Item, ItemKind, Num, ValueLit};

impl Checker<'_> {
    pub(super) fn lower_world(&mut self, attrs: &[ast::AttrDecl]) {
        for a in attrs {
            let idx = self.d.world.len();
            if !self.world_attrs.declare(&a.name, idx, |_| "a world attribute", &mut self.diags) {
                continue;
            }
            match self.lower_attr(a) {
                Some(def) => self.d.world.push(def),
                // Keep the index stable for later names; a placeholder never reaches the IR
                // because the error stops compilation.
                None => self.d.world.push(AttrDef {
                    name: a.name.name.clone(),
                    ty: AttrType::Bool,
                    default: Value::Bool(false),
                    doc: String::new(),
                    span: a.span,
                }),
            }
        }
    }

    pub(super) fn lower_region(&mut self, item: &Item, name: &Ident, stmts: &[ast::RegionStmt]) {
        let mut axes: [Option<(f64, f64)>; 3] = [None; 3];
        let mut spans: [Option<Span>; 3] = [None; 3];
        let mut scenic: Option<(String, Span)> = None;
        for s in stmts {
            match s {
                ast::RegionStmt::Axis { axis, value } => {
                    let i = match axis.name.as_str() {
                        "x" => 0,
                        "y" => 1,
                        _ => 2,
                    };
                    if let Some(prev) = spans[i] {
                        self.error(duplicate_statement(&axis.name, axis.span, prev));
                        continue;
                    }
                    spans[i] = Some(axis.span);
                    let ty = AttrType::Number { dimension: "length".into(), min: f64::MIN, max: f64::MAX };
                    axes[i] = match self.lower_value(value, &ty, &axis.name) {
                        Some(Value::Number(x)) => Some((x, x)),
                        Some(Value::Range(a, b)) => Some((a, b)),
                        _ => None,
                    };
                }
                ast::RegionStmt::Scenic(s) => {
                    if let Some((_, prev)) = &scenic {
                        self.error(duplicate_statement("scenic", s.span, *prev));
                    } else {
                        scenic = Some((s.value.clone(), s.span));
                    }
                }
            }
        }
        for (i, axis) in ["x", "y"].iter().enumerate() {
            if spans[i].is_none() && !item.broken {
                self.error(
                    Diagnostic::error(
                        codes::MISSING_STATEMENT,
                        name.span,
                        format!("region `{}` has no `{axis}` extent", name.name),
                    )
                    .with_help(format!("add `{axis} MIN..MAX` (metres; x ahead of the camera, y to the left)")),
                );
            }
        }
        if self.regions.get(&name.name) == Some(&RegionId(self.d.regions.len() as u32)) {
            self.d.regions.push(Region {
                name: name.name.clone(),
                doc: item.doc.clone(),
                x: axes[0].unwrap_or((0.0, 0.0)),
                y: axes[1].unwrap_or((0.0, 0.0)),
                z: axes[2].unwrap_or((0.0, 0.0)),
                scenic: scenic.map(|s| s.0),
                span: item.span,
            });
        }
    }

    pub(super) fn lower_preset(
        &mut self,
        item: &Item,
        name: &Ident,
        for_variant: Option<&ast::Path>,
        params: &[(Ident, Num)],
    ) {
        let for_variant = for_variant.and_then(|p| self.enum_variant_path(p));
        let mut seen = Namespace::<()>::default();
        let mut out = Vec::new();
        for (p, n) in params {
            if !seen.declare(p, (), |_| "a parameter of this preset", &mut self.diags) {
                continue;
            }
            if !ENVIRONMENT_PARAMS.iter().any(|(k, _)| *k == p.name) {
                let known = ENVIRONMENT_PARAMS.iter().map(|(k, _)| *k);
                let d =
                    Diagnostic::error(codes::UNKNOWN_ATTR, p.span, format!("unknown preset parameter `{}`", p.name))
                        .with_label("no renderer or emitter reads this parameter");
                let d = match crate::diag::suggest::suggest(&p.name, known.clone()) {
                    Some(s) => d.with_help(format!("did you mean `{s}`?")),
                    None => d.with_help(format!("the parameters are: {}", known.collect::<Vec<_>>().join(", "))),
                };
                self.error(d);
                continue;
            }
            let value = match &n.unit {
                None => Some(n.value),
                Some(u) => {
                    let scale = self.units.get(&u.name).map(|i| i.scale);
                    self.refer(u, self.units.span(&u.name));
                    scale.map(|s| s * n.value)
                }
            };
            match value {
                Some(v) => out.push((p.name.clone(), v)),
                None => {
                    self.number(n, "");
                }
            }
        }
        if self.presets.span(&name.name) == Some(name.span) {
            self.d.presets.push(Preset {
                name: name.name.clone(),
                doc: item.doc.clone(),
                for_variant,
                params: out,
                span: item.span,
            });
        }
    }

    /// Resolve `Enum.variant`.
    fn enum_variant_path(&mut self, p: &ast::Path) -> Option<(EnumId, u32)> {
        let [e, v] = p.parts.as_slice() else {
            self.error(
                Diagnostic::error(codes::BAD_REFERENCE, p.span, "expected `ENUM.VARIANT`")
                    .with_label("not an enum variant")
                    .with_help("a preset binds to one value of an enum, e.g. `for Weather.hard_rain`"),
            );
            return None;
        };
        match self.resolve_type(e, "enum")? {
            TypeSym::Enum(id) => {
                let ty = AttrType::Enum(id);
                match self.lower_value(&ValueLit::Name(v.clone()), &ty, &e.name)? {
                    Value::Enum(id, i) => Some((id, i)),
                    _ => None,
                }
            }
            other => {
                self.error(
                    Diagnostic::error(
                        codes::WRONG_SORT,
                        e.span,
                        format!("`{}` is {}, not an enum", e.name, other.sort()),
                    )
                    .with_label("expected an enum"),
                );
                None
            }
        }
    }

    /// The camera. One in the domain file itself overrides those of the modules it uses (the
    /// stdlib looks give each domain family a default camera); otherwise only one may be given.
    pub(super) fn lower_camera(&mut self, entry: u32, items: &[(u32, &Item)]) {
        let mut first: Option<Span> = None;
        let entry_has_camera = items.iter().any(|(f, i)| *f == entry && matches!(i.kind, ItemKind::Camera { .. }));
        for (file, item) in items {
            let ItemKind::Camera { stmts } = &item.kind else { continue };
            if entry_has_camera && *file != entry {
                continue;
            }
            if let Some(f) = first {
                self.error(duplicate_statement("camera", item.span, f));
                continue;
            }
            first = Some(item.span);
            let mut seen: Vec<(&'static str, Span)> = Vec::new();
            for s in stmts {
                let (key, span) = match s {
                    ast::CameraStmt::At(_, sp) => ("at", *sp),
                    ast::CameraStmt::LookAt(_, sp) => ("look_at", *sp),
                    ast::CameraStmt::Fov(n) => ("fov", n.span),
                    ast::CameraStmt::Size { span, .. } => ("size", *span),
                };
                if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == key) {
                    let prev = *prev;
                    self.error(duplicate_statement(key, span, prev));
                    continue;
                }
                seen.push((key, span));
                match s {
                    ast::CameraStmt::At(v, _) => {
                        if let Some(v) = self.vec3(v, "length") {
                            self.d.camera.at = v;
                        }
                    }
                    ast::CameraStmt::LookAt(v, _) => {
                        if let Some(v) = self.vec3(v, "length") {
                            self.d.camera.look_at = v;
                        }
                    }
                    ast::CameraStmt::Fov(n) => {
                        if let Some(f) = self.number(n, "angle") {
                            if f <= 0.0 || f >= 180.0 {
                                self.error(
                                    Diagnostic::error(
                                        codes::OUT_OF_RANGE,
                                        n.span,
                                        "the field of view must be between 0 and 180 degrees",
                                    )
                                    .with_label("outside 0..180deg"),
                                );
                            }
                            self.d.camera.fov_deg = f;
                        }
                    }
                    ast::CameraStmt::Size { width, height, span } => {
                        if *width == 0 || *height == 0 || *width > 8192 || *height > 8192 {
                            self.error(
                                Diagnostic::error(
                                    codes::INVALID_LITERAL,
                                    *span,
                                    format!("image size `{width}x{height}` is not usable"),
                                )
                                .with_label("each side must be 1 to 8192 pixels"),
                            );
                        }
                        self.d.camera.width = *width;
                        self.d.camera.height = *height;
                    }
                }
            }
        }
    }

    /// `visible [NAME] { pixels = N  contrast = X }` items: the default (no name) and overrides
    /// for a kind, a tag or a concept. Parameters left out keep the default's value. Kind and
    /// tag overrides are resolved here into one threshold per kind (see [`Self::inherit_visibility`]).
    pub(super) fn lower_visibility(&mut self, items: &[(u32, &Item)]) {
        let mut firsts: Vec<(Option<String>, Span)> = Vec::new();
        // Overrides written for a kind or a tag, applied to kinds once all are read.
        let mut typed: Vec<(TypeSym, VisibleIf, Span)> = Vec::new();
        // The default first, so that overrides inherit what it sets.
        let mut ordered: Vec<&Item> = items.iter().map(|(_, i)| *i).collect();
        ordered.sort_by_key(|i| !matches!(i.kind, ItemKind::Visible { target: None, .. }));
        for item in ordered {
            let ItemKind::Visible { target, params } = &item.kind else { continue };
            let key = target.as_ref().map(|t| t.name.clone());
            if let Some((_, first)) = firsts.iter().find(|(k, _)| *k == key) {
                let what = key.as_ref().map_or("visible".to_string(), |k| format!("visible {k}"));
                let first = *first;
                self.error(duplicate_statement(&what, item.span, first));
                continue;
            }
            firsts.push((key.clone(), item.span));
            let is_concept = target.as_ref().is_some_and(|t| self.d.concepts.iter().any(|c| c.name == t.name));
            let sym = target.as_ref().filter(|_| !is_concept).and_then(|t| self.types.get(&t.name).copied());
            if let Some(t) = target {
                let decl = if is_concept { self.concepts.span(&t.name) } else { self.types.span(&t.name) };
                self.refer(t, decl);
            }
            if let Some(t) = target
                && !is_concept
            {
                match sym {
                    Some(TypeSym::Kind(_) | TypeSym::Tag(_)) => {}
                    Some(TypeSym::Enum(_)) => {
                        self.error(
                            Diagnostic::error(
                                codes::WRONG_SORT,
                                t.span,
                                format!("`{}` is an enum, not a kind, tag or concept", t.name),
                            )
                            .with_label("`visible` names a kind, a tag or a concept"),
                        );
                        continue;
                    }
                    None => {
                        let names: Vec<&str> = self
                            .d
                            .kinds
                            .iter()
                            .map(|k| k.name.as_str())
                            .chain(self.d.tags.iter().map(|t| t.name.as_str()))
                            .chain(self.d.concepts.iter().map(|c| c.name.as_str()))
                            .collect();
                        self.error(super::names::unknown("kind, tag or concept", t, names));
                        continue;
                    }
                }
            }
            let mut v = self.d.visibility.default;
            let mut seen: Vec<(&str, Span)> = Vec::new();
            for (name, n) in params {
                if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == name.name) {
                    let prev = *prev;
                    self.error(duplicate_statement(&name.name, name.span, prev));
                    continue;
                }
                seen.push((&name.name, name.span));
                if let Some(u) = &n.unit {
                    self.error(
                        Diagnostic::error(
                            codes::TYPE_MISMATCH,
                            u.span,
                            format!("`{}` is a plain number, without a unit", name.name),
                        )
                        .with_label("no unit here"),
                    );
                    continue;
                }
                match name.name.as_str() {
                    "pixels" if n.value >= 0.0 && n.value.fract() == 0.0 && n.value <= f64::from(u32::MAX) => {
                        v.pixels = n.value as u32;
                    }
                    "pixels" => self.error(
                        Diagnostic::error(codes::OUT_OF_RANGE, n.span, "`pixels` must be a whole number, 0 or more")
                            .with_label("not a pixel count"),
                    ),
                    "contrast" if (0.0..=1.0).contains(&n.value) => v.contrast = n.value,
                    "contrast" => self.error(
                        Diagnostic::error(codes::OUT_OF_RANGE, n.span, "`contrast` must be between 0 and 1")
                            .with_label("outside 0..1"),
                    ),
                    _ => {
                        let d = Diagnostic::error(
                            codes::UNKNOWN_ATTR,
                            name.span,
                            format!("unknown visibility parameter `{}`", name.name),
                        )
                        .with_label("`visible` takes `pixels` and `contrast`");
                        let d = match crate::diag::suggest::suggest(&name.name, ["pixels", "contrast"]) {
                            Some(s) => d.with_help(format!("did you mean `{s}`?")),
                            None => d,
                        };
                        self.error(d);
                    }
                }
            }
            match (target, sym) {
                (None, _) => self.d.visibility.default = v,
                (Some(t), _) if is_concept => {
                    self.d.visibility.concepts.insert(t.name.clone(), v);
                }
                (Some(_), Some(s)) => typed.push((s, v, target.as_ref().map_or(item.span, |t| t.span))),
                (Some(_), None) => {}
            }
        }
        self.inherit_visibility(&typed);
    }

    /// Give every kind the most specific kind or tag override that applies to it: its own, else
    /// that of the nearest ancestor — parent kinds and tags one step up, their parents two
    /// steps up, and so on. Two different overrides equally near a kind are an error (R0027):
    /// nothing says which one is meant.
    fn inherit_visibility(&mut self, typed: &[(TypeSym, VisibleIf, Span)]) {
        if typed.is_empty() {
            return;
        }
        for k in 0..self.d.kinds.len() {
            let mut level = vec![TypeSym::Kind(KindId(k as u32))];
            let mut visited = level.clone();
            while !level.is_empty() {
                let hits: Vec<&(TypeSym, VisibleIf, Span)> =
                    typed.iter().filter(|(s, _, _)| level.contains(s)).collect();
                if let Some(&&(first, v, first_span)) = hits.first() {
                    match hits.iter().find(|(_, w, _)| *w != v) {
                        None => {
                            let name = self.d.kinds[k].name.clone();
                            self.d.visibility.kinds.insert(name, v);
                        }
                        Some(&&(other, _, span)) => {
                            let kind = &self.d.kinds[k];
                            let d = Diagnostic::error(
                                codes::AMBIGUOUS_INHERITANCE,
                                kind.span,
                                format!(
                                    "kind `{}` inherits two different `visible` overrides, from `{}` and `{}`",
                                    kind.name,
                                    self.sym_name(first),
                                    self.sym_name(other)
                                ),
                            )
                            .with_label("equally near to both")
                            .with_related(first_span, "one override")
                            .with_related(span, "the other")
                            .with_help(format!("say which applies with `visible {} {{ … }}`", kind.name));
                            self.error(d);
                        }
                    }
                    break;
                }
                let mut next = Vec::new();
                for s in &level {
                    for p in self.type_parents(*s) {
                        if !visited.contains(&p) {
                            visited.push(p);
                            next.push(p);
                        }
                    }
                }
                level = next;
            }
        }
    }

    /// The direct parents of a kind (kinds and tags) or a tag (tags), as written.
    fn type_parents(&self, s: TypeSym) -> Vec<TypeSym> {
        let (item, kinds) = match s {
            TypeSym::Kind(k) => (self.kind_items[k.index()], self.kind_parents[k.index()].clone()),
            TypeSym::Tag(t) => (self.tag_items[t.index()], Vec::new()),
            TypeSym::Enum(_) => return Vec::new(),
        };
        let parents = match &item.kind {
            ItemKind::Kind { parents, .. } | ItemKind::Tag { parents, .. } => parents.as_slice(),
            _ => &[],
        };
        let tags = parents.iter().filter_map(|p| match self.types.get(&p.name) {
            Some(TypeSym::Tag(t)) => Some(TypeSym::Tag(*t)),
            _ => None,
        });
        kinds.into_iter().map(TypeSym::Kind).chain(tags).collect()
    }

    fn sym_name(&self, s: TypeSym) -> &str {
        match s {
            TypeSym::Kind(k) => &self.d.kinds[k.index()].name,
            TypeSym::Tag(t) => &self.d.tags[t.index()].name,
            TypeSym::Enum(e) => &self.d.enums[e.index()].name,
        }
    }
}

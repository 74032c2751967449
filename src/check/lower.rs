//! Gathering declarations and lowering the type-level items (units, enums, tags, kinds, world,
//! regions, presets, camera, stage) to the IR. Concepts, constraints and rules live in
//! `concepts.rs` and `rules.rs`; expressions in `expr.rs`; shapes in `shapes.rs`.
//!
//! Kinds, tags and enums share one namespace (a filter `Collidable | Pedestrian` may name
//! either). A kind's parents may be tags and kinds: it inherits the attributes of its parent
//! kinds, and [`Kind::tags`] holds every tag it carries, directly or through a parent tag or
//! kind. A filter that names a kind matches that kind and all kinds that descend from it (the
//! checker lists them in [`TargetFilter::kinds`]).

use super::names::{Namespace, unknown};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;
use crate::syntax::ast::{self, Ident, Item, ItemKind, Num, ValueLit};

/// A name in the type namespace.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TypeSym {
    Enum(EnumId),
    Tag(TagId),
    Kind(KindId),
}

impl TypeSym {
    pub fn sort(&self) -> &'static str {
        match self {
            TypeSym::Enum(_) => "an enum",
            TypeSym::Tag(_) => "a tag",
            TypeSym::Kind(_) => "a kind",
        }
    }
}

#[derive(Debug, Clone)]
pub(crate) struct UnitInfo {
    pub dimension: String,
    pub scale: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Progress {
    Todo,
    Doing,
    Done,
}

/// The checker's state while lowering one compilation.
pub(crate) struct Checker<'a> {
    pub diags: Vec<Diagnostic>,
    pub d: Domain,
    pub units: Namespace<UnitInfo>,
    pub types: Namespace<TypeSym>,
    pub relations: Namespace<()>,
    pub regions: Namespace<RegionId>,
    pub presets: Namespace<()>,
    pub stages: Namespace<()>,
    pub concepts: Namespace<ConceptId>,
    pub constraints: Namespace<()>,
    pub questions: Namespace<QuestionId>,
    pub world_attrs: Namespace<usize>,
    /// Per kind: its item, its direct parent kinds, and the lowering progress (cycle check).
    pub kind_items: Vec<&'a Item>,
    pub kind_parents: Vec<Vec<KindId>>,
    kind_progress: Vec<Progress>,
    tag_items: Vec<&'a Item>,
    tag_ancestors: Vec<Option<Vec<TagId>>>,
    tag_progress: Vec<Progress>,
    /// Where each kind's look came from (`shape {}` or `look`), for duplicate reports.
    pub look_spans: Vec<Option<(Span, &'static str)>>,
    /// Names of the entities that any concept adds (targets of `add … RELATION NAME`).
    pub entity_names: Vec<String>,
}

/// Lower the gathered items. `entry` is the file whose `domain` line names the domain.
pub(crate) fn lower(entry: u32, items: &[(u32, &Item)]) -> (Option<Domain>, Vec<Diagnostic>) {
    let mut c = Checker::new();
    c.domain_line(entry, items);
    c.declare(items);
    c.lower_tags();
    c.lower_kinds();
    for (_, item) in items {
        match &item.kind {
            ItemKind::World { attrs } => c.lower_world(attrs),
            ItemKind::Relation { name, text } => {
                c.d.relations.push(RelationDef { name: name.name.clone(), text: text.value.clone(), span: item.span })
            }
            _ => {}
        }
    }
    for (_, item) in items {
        match &item.kind {
            ItemKind::Region { name, stmts } => c.lower_region(item, name, stmts),
            ItemKind::Preset { name, for_variant, params } => c.lower_preset(item, name, for_variant.as_ref(), params),
            _ => {}
        }
    }
    c.lower_camera(entry, items);
    c.lower_looks(items);
    c.lower_stage(items);
    c.lower_concepts(items);
    c.lower_visibility(items);
    c.lower_constraints(items);
    c.lower_questions(items);
    c.lower_rules(entry, items);
    c.lower_allows(items);
    let has_errors = c.diags.iter().any(Diagnostic::is_error);
    let Checker { d, diags, .. } = c;
    (if has_errors { None } else { Some(d) }, diags)
}

impl<'a> Checker<'a> {
    fn new() -> Self {
        Checker {
            diags: Vec::new(),
            d: Domain {
                name: String::new(),
                files: Vec::new(),
                units: Vec::new(),
                relations: Vec::new(),
                enums: Vec::new(),
                tags: Vec::new(),
                kinds: Vec::new(),
                world: Vec::new(),
                regions: Vec::new(),
                presets: Vec::new(),
                stage: Vec::new(),
                concepts: Vec::new(),
                constraints: Vec::new(),
                questions: Vec::new(),
                selection: Selection::Priority,
                rules: Vec::new(),
                camera: Camera::default(),
                allow: Vec::new(),
                visibility: Default::default(),
            },
            units: Namespace::default(),
            types: Namespace::default(),
            relations: Namespace::default(),
            regions: Namespace::default(),
            presets: Namespace::default(),
            stages: Namespace::default(),
            concepts: Namespace::default(),
            constraints: Namespace::default(),
            questions: Namespace::default(),
            world_attrs: Namespace::default(),
            kind_items: Vec::new(),
            kind_parents: Vec::new(),
            kind_progress: Vec::new(),
            tag_items: Vec::new(),
            tag_ancestors: Vec::new(),
            tag_progress: Vec::new(),
            look_spans: Vec::new(),
            entity_names: Vec::new(),
        }
    }

    pub fn error(&mut self, d: Diagnostic) {
        self.diags.push(d);
    }

    fn domain_line(&mut self, entry: u32, items: &[(u32, &Item)]) {
        let mut first: Option<Span> = None;
        for (file, item) in items {
            let ItemKind::Domain(name) = &item.kind else { continue };
            if *file != entry {
                self.error(
                    Diagnostic::error(codes::MISPLACED_DOMAIN, item.span, "a used module cannot declare a domain")
                        .with_label("`domain` line in a module")
                        .with_help("remove this line; only the file given to the command names the domain"),
                );
            } else if let Some(f) = first {
                self.error(
                    Diagnostic::error(codes::MISPLACED_DOMAIN, item.span, "a file can declare only one domain")
                        .with_label("second `domain` line")
                        .with_related(f, "first `domain` line"),
                );
            } else {
                first = Some(item.span);
                self.d.name = name.name.clone();
            }
        }
    }

    /// Pass 1: declare every name, so that item order does not matter for resolution.
    fn declare(&mut self, items: &[(u32, &'a Item)]) {
        let sort_type = |t: &TypeSym| t.sort();
        for &(_, item) in items {
            match &item.kind {
                ItemKind::Unit { name, dimension, scale } => self.declare_unit(name, dimension, scale),
                ItemKind::Enum { name, variants } => {
                    let id = EnumId(self.d.enums.len() as u32);
                    if self.types.declare(name, TypeSym::Enum(id), sort_type, &mut self.diags) {
                        let mut seen = Namespace::<()>::default();
                        for v in variants {
                            seen.declare(v, (), |_| "a variant of this enum", &mut self.diags);
                        }
                        self.d.enums.push(EnumDef {
                            name: name.name.clone(),
                            variants: seen.names().map(str::to_string).collect(),
                            span: item.span,
                        });
                    }
                }
                ItemKind::Tag { name, .. } => {
                    let id = TagId(self.d.tags.len() as u32);
                    if self.types.declare(name, TypeSym::Tag(id), sort_type, &mut self.diags) {
                        self.d.tags.push(TagDef { name: name.name.clone(), doc: item.doc.clone(), span: item.span });
                        self.tag_items.push(item);
                    }
                }
                ItemKind::Kind { name, .. } => {
                    let id = KindId(self.d.kinds.len() as u32);
                    if self.types.declare(name, TypeSym::Kind(id), sort_type, &mut self.diags) {
                        self.d.kinds.push(Kind {
                            name: name.name.clone(),
                            doc: item.doc.clone(),
                            tags: Vec::new(),
                            attrs: Vec::new(),
                            shape: Vec::new(),
                            span: item.span,
                        });
                        self.kind_items.push(item);
                    }
                }
                ItemKind::Relation { name, .. } => {
                    self.relations.declare(name, (), |_| "a relation", &mut self.diags);
                }
                ItemKind::Region { name, .. } => {
                    let id = RegionId(self.regions.len() as u32);
                    self.regions.declare(name, id, |_| "a region", &mut self.diags);
                }
                ItemKind::Preset { name, .. } => {
                    self.presets.declare(name, (), |_| "a preset", &mut self.diags);
                }
                ItemKind::Stage { name, .. } => {
                    self.stages.declare(name, (), |_| "a stage item", &mut self.diags);
                }
                ItemKind::Concept { name, modifier, stmts } => {
                    let id = ConceptId(self.concepts.len() as u32);
                    let sort = |_: &ConceptId| "a concept or modifier";
                    if self.concepts.declare(name, id, sort, &mut self.diags) && id.index() == MAX_CONCEPTS {
                        self.error(
                            Diagnostic::error(
                                codes::TOO_MANY_CONCEPTS,
                                name.span,
                                format!("too many concepts: a domain may declare at most {MAX_CONCEPTS}"),
                            )
                            .with_label(if *modifier {
                                "this modifier is one too many"
                            } else {
                                "this concept is one too many"
                            })
                            .with_help("split the domain, or merge concepts that always go together"),
                        );
                    }
                    for s in stmts {
                        if let ast::ConceptStmt::Add { name, .. } = s {
                            self.entity_names.push(name.name.clone());
                        }
                    }
                }
                ItemKind::Constraint { name, .. } => {
                    self.constraints.declare(name, (), |_| "a constraint", &mut self.diags);
                }
                ItemKind::Question { name, .. } => {
                    let id = QuestionId(self.questions.len() as u32);
                    self.questions.declare(name, id, |_| "a question", &mut self.diags);
                }
                _ => {}
            }
        }
        self.kind_parents = vec![Vec::new(); self.d.kinds.len()];
        self.kind_progress = vec![Progress::Todo; self.d.kinds.len()];
        self.look_spans = vec![None; self.d.kinds.len()];
        self.tag_ancestors = vec![None; self.d.tags.len()];
        self.tag_progress = vec![Progress::Todo; self.d.tags.len()];
    }

    fn declare_unit(&mut self, name: &Ident, dimension: &Ident, scale: &Num) {
        if let Some(u) = &scale.unit {
            self.error(
                Diagnostic::error(
                    codes::TYPE_MISMATCH,
                    u.span,
                    format!("the scale of unit `{}` must be a plain number", name.name),
                )
                .with_label("remove this unit")
                .with_help("the scale says how many base units of the dimension one unit is"),
            );
        }
        if scale.value <= 0.0 {
            self.error(
                Diagnostic::error(
                    codes::OUT_OF_RANGE,
                    scale.span,
                    format!("the scale of unit `{}` must be positive", name.name),
                )
                .with_label("not positive"),
            );
        }
        let info = UnitInfo { dimension: dimension.name.clone(), scale: scale.value };
        if self.units.declare(name, info, |_| "a unit", &mut self.diags) {
            self.d.units.push(Unit { name: name.name.clone(), dimension: dimension.name.clone(), scale: scale.value });
        }
    }

    /// `allow CODE` items: only lattice-lint codes can be silenced, each once, with a reason.
    fn lower_allows(&mut self, items: &[(u32, &Item)]) {
        for (_, item) in items {
            let ItemKind::Allow { code } = &item.kind else { continue };
            let digits =
                code.name.strip_prefix("R01").filter(|d| d.len() == 2 && d.bytes().all(|b| b.is_ascii_digit()));
            if digits.is_none() {
                self.error(
                    Diagnostic::error(
                        codes::BAD_ALLOW,
                        code.span,
                        format!("`{}` is not a lattice-lint code", code.name),
                    )
                    .with_label("cannot be allowed")
                    .with_help("only lattice-lint warnings (`R0100`–`R0199`) can be allowed; fix errors instead"),
                );
                continue;
            }
            if let Some(prev) = self.d.allow.iter().find(|a| a.code == code.name) {
                let prev = prev.span;
                self.error(duplicate_statement(&format!("allow {}", code.name), item.span, prev));
                continue;
            }
            if item.doc.trim().is_empty() {
                self.error(
                    Diagnostic::warning(
                        codes::ALLOW_WITHOUT_REASON,
                        item.span,
                        format!("`allow {}` gives no reason", code.name),
                    )
                    .with_label("no `///` comment above")
                    .with_help("say in a `///` comment why this lint does not apply to the domain"),
                );
            }
            self.d.allow.push(Allow { code: code.name.clone(), reason: item.doc.clone(), span: item.span });
        }
    }

    // ------------------------------------------------------------------ tags and kinds

    fn lower_tags(&mut self) {
        for t in 0..self.d.tags.len() {
            self.tag_closure(TagId(t as u32));
        }
    }

    /// The tag and all its ancestors (memoised; a cycle is reported once and cut).
    fn tag_closure(&mut self, t: TagId) -> Vec<TagId> {
        match self.tag_progress[t.index()] {
            Progress::Done => return self.tag_ancestors[t.index()].clone().unwrap_or_default(),
            Progress::Doing => {
                let item = self.tag_items[t.index()];
                let name = match &item.kind {
                    ItemKind::Tag { name, .. } => name.clone(),
                    _ => unreachable!("tag items are tags"),
                };
                self.error(
                    Diagnostic::error(codes::CYCLE, name.span, format!("tag `{}` is its own ancestor", name.name))
                        .with_label("part of an inheritance cycle")
                        .with_help("remove one of the parent links in the cycle"),
                );
                return vec![t];
            }
            Progress::Todo => {}
        }
        self.tag_progress[t.index()] = Progress::Doing;
        let item = self.tag_items[t.index()];
        let mut out = vec![t];
        if let ItemKind::Tag { parents, .. } = &item.kind {
            for p in parents {
                match self.resolve_type(p, "tag") {
                    Some(TypeSym::Tag(pt)) => {
                        for a in self.tag_closure(pt) {
                            if !out.contains(&a) {
                                out.push(a);
                            }
                        }
                    }
                    Some(other) => self.error(
                        Diagnostic::error(
                            codes::WRONG_SORT,
                            p.span,
                            format!("`{}` is {}, not a tag", p.name, other.sort()),
                        )
                        .with_label("a tag's parents must be tags"),
                    ),
                    None => {}
                }
            }
        }
        self.tag_progress[t.index()] = Progress::Done;
        self.tag_ancestors[t.index()] = Some(out.clone());
        out
    }

    /// Look a name up in the type namespace, reporting it when unknown.
    pub fn resolve_type(&mut self, name: &Ident, sort: &str) -> Option<TypeSym> {
        match self.types.get(&name.name) {
            Some(t) => Some(*t),
            None => {
                let d = unknown(sort, name, self.types.names());
                self.error(d);
                None
            }
        }
    }

    fn lower_kinds(&mut self) {
        for k in 0..self.d.kinds.len() {
            self.lower_kind(KindId(k as u32));
        }
    }

    fn lower_kind(&mut self, k: KindId) {
        let item = self.kind_items[k.index()];
        let ItemKind::Kind { name, parents, attrs, .. } = &item.kind else { unreachable!("kind items are kinds") };
        match self.kind_progress[k.index()] {
            Progress::Done => return,
            Progress::Doing => {
                self.error(
                    Diagnostic::error(codes::CYCLE, name.span, format!("kind `{}` is its own ancestor", name.name))
                        .with_label("part of an inheritance cycle")
                        .with_help("remove one of the parent links in the cycle"),
                );
                return;
            }
            Progress::Todo => {}
        }
        self.kind_progress[k.index()] = Progress::Doing;
        let mut tags: Vec<TagId> = Vec::new();
        let mut inherited: Vec<AttrDef> = Vec::new();
        for p in parents {
            match self.resolve_type(p, "kind or tag") {
                Some(TypeSym::Tag(t)) => {
                    for a in self.tag_closure(t) {
                        push_unique(&mut tags, a);
                    }
                }
                Some(TypeSym::Kind(pk)) => {
                    self.lower_kind(pk);
                    self.kind_parents[k.index()].push(pk);
                    for a in self.d.kinds[pk.index()].tags.clone() {
                        push_unique(&mut tags, a);
                    }
                    for a in self.d.kinds[pk.index()].attrs.clone() {
                        match inherited.iter().position(|x| x.name == a.name) {
                            Some(i) => inherited[i] = a,
                            None => inherited.push(a),
                        }
                    }
                }
                Some(TypeSym::Enum(_)) => self.error(
                    Diagnostic::error(codes::WRONG_SORT, p.span, format!("`{}` is an enum, not a kind or tag", p.name))
                        .with_label("a kind's parents must be kinds or tags"),
                ),
                None => {}
            }
        }
        let own = self.lower_attrs(attrs);
        for a in own {
            match inherited.iter().position(|x| x.name == a.name) {
                Some(i) => inherited[i] = a,
                None => inherited.push(a),
            }
        }
        let kind = &mut self.d.kinds[k.index()];
        kind.tags = tags;
        kind.attrs = inherited;
        self.kind_progress[k.index()] = Progress::Done;
    }

    /// The kind and every kind that descends from it.
    pub fn descendants(&self, k: KindId) -> Vec<KindId> {
        let mut out = vec![k];
        let mut i = 0;
        while i < out.len() {
            let cur = out[i];
            for (child, parents) in self.kind_parents.iter().enumerate() {
                let child = KindId(child as u32);
                if parents.contains(&cur) && !out.contains(&child) {
                    out.push(child);
                }
            }
            i += 1;
        }
        out
    }

    /// Resolve a `A | B | C` filter of kinds and tags.
    pub fn lower_filter(&mut self, names: &[Ident]) -> TargetFilter {
        let mut f = TargetFilter::default();
        for n in names {
            match self.resolve_type(n, "kind or tag") {
                Some(TypeSym::Kind(k)) => {
                    for d in self.descendants(k) {
                        push_unique(&mut f.kinds, d);
                    }
                }
                Some(TypeSym::Tag(t)) => push_unique(&mut f.tags, t),
                Some(TypeSym::Enum(_)) => self.error(
                    Diagnostic::error(codes::WRONG_SORT, n.span, format!("`{}` is an enum, not a kind or tag", n.name))
                        .with_label("expected a kind or tag"),
                ),
                None => {}
            }
        }
        f
    }

    /// The kinds a filter matches.
    pub fn matching_kinds(&self, f: &TargetFilter) -> Vec<KindId> {
        (0..self.d.kinds.len() as u32).map(KindId).filter(|k| f.matches(&self.d, *k)).collect()
    }

    // ------------------------------------------------------------------ attributes and values

    /// Lower `NAME: TYPE [in MIN..MAX] = DEFAULT` declarations; duplicates are reported.
    fn lower_attrs(&mut self, attrs: &[ast::AttrDecl]) -> Vec<AttrDef> {
        let mut seen = Namespace::<()>::default();
        let mut out = Vec::new();
        for a in attrs {
            if !seen.declare(&a.name, (), |_| "an attribute of the same owner", &mut self.diags) {
                continue;
            }
            if let Some(def) = self.lower_attr(a) {
                out.push(def);
            }
        }
        out
    }

    fn lower_attr(&mut self, a: &ast::AttrDecl) -> Option<AttrDef> {
        let ty = self.attr_type(a)?;
        // A bad default is reported; the attribute still exists, so uses of it are checked
        // instead of failing as unknown.
        let default = self.lower_value(&a.default, &ty, &a.name.name).unwrap_or_else(|| placeholder(&ty));
        Some(AttrDef { name: a.name.name.clone(), ty, default, doc: a.doc.clone(), span: a.span })
    }

    fn attr_type(&mut self, a: &ast::AttrDecl) -> Option<AttrType> {
        let ty_name = a.ty.name.as_str();
        let dimension = if ty_name == "number" {
            Some(String::new())
        } else if self.d.units.iter().any(|u| u.dimension == ty_name) {
            Some(ty_name.to_string())
        } else {
            None
        };
        let ty = match (ty_name, dimension) {
            ("bool", _) => AttrType::Bool,
            (_, Some(dimension)) => {
                let (min, max) = match &a.bounds {
                    None => (f64::MIN, f64::MAX),
                    Some((lo, hi)) => {
                        let lo = self.number(lo, &dimension);
                        let hi = self.number(hi, &dimension);
                        let (lo, hi) = (lo?, hi?);
                        if lo > hi {
                            let span = join(a.bounds.as_ref().map(|b| b.0.span)?, a.bounds.as_ref().map(|b| b.1.span)?);
                            self.error(empty_range(span));
                            return None;
                        }
                        (lo, hi)
                    }
                };
                AttrType::Number { dimension, min, max }
            }
            _ => match self.types.get(ty_name) {
                Some(TypeSym::Enum(e)) => AttrType::Enum(*e),
                Some(other) => {
                    let sort = other.sort();
                    self.error(
                        Diagnostic::error(codes::WRONG_SORT, a.ty.span, format!("`{ty_name}` is {sort}, not a type"))
                            .with_label("expected a type")
                            .with_help(
                                "attribute types are `bool`, `number`, a dimension such as `length`, or an enum",
                            ),
                    );
                    return None;
                }
                None => {
                    let mut candidates: Vec<&str> = vec!["bool", "number"];
                    candidates.extend(self.d.units.iter().map(|u| u.dimension.as_str()));
                    candidates.extend(self.d.enums.iter().map(|e| e.name.as_str()));
                    let d =
                        unknown("type", &a.ty, candidates).with_label("not `bool`, `number`, a dimension or an enum");
                    self.error(d);
                    return None;
                }
            },
        };
        if a.bounds.is_some() && !matches!(ty, AttrType::Number { .. }) {
            let span = a.bounds.as_ref().map(|b| join(b.0.span, b.1.span))?;
            self.error(
                Diagnostic::error(
                    codes::TYPE_MISMATCH,
                    span,
                    format!("only numeric attributes take bounds, `{}` does not", a.name.name),
                )
                .with_label("remove these bounds"),
            );
            return None;
        }
        Some(ty)
    }

    /// Convert a number to the base unit of `dimension` (`""`: a plain number).
    pub fn number(&mut self, n: &Num, dimension: &str) -> Option<f64> {
        let (found, scale) = match &n.unit {
            None => (String::new(), 1.0),
            Some(u) => match self.units.get(&u.name) {
                Some(info) => (info.dimension.clone(), info.scale),
                None => {
                    let d = Diagnostic::error(codes::UNKNOWN_UNIT, u.span, format!("unknown unit `{}`", u.name))
                        .with_label("no `unit` declares this suffix");
                    let d = match crate::diag::suggest::suggest(&u.name, self.units.names()) {
                        Some(s) => d.with_help(format!("did you mean `{s}`?")),
                        None => d.with_help("declare it with `unit NAME: DIMENSION = SCALE`"),
                    };
                    self.error(d);
                    return None;
                }
            },
        };
        if found != dimension {
            self.error(dimension_mismatch(n, dimension, &found, self.example_unit(dimension)));
            return None;
        }
        Some(n.value * scale)
    }

    fn example_unit(&self, dimension: &str) -> Option<String> {
        self.d.units.iter().find(|u| u.dimension == dimension && u.scale == 1.0).map(|u| u.name.clone())
    }

    /// Type-check a value literal against an attribute type, converting it to the IR.
    pub fn lower_value(&mut self, v: &ValueLit, ty: &AttrType, attr: &str) -> Option<Value> {
        match (ty, v) {
            (AttrType::Bool, ValueLit::Bool(b, _)) => Some(Value::Bool(*b)),
            (AttrType::Enum(e), ValueLit::Name(n)) => {
                let def = &self.d.enums[e.index()];
                match def.variants.iter().position(|x| *x == n.name) {
                    Some(i) => Some(Value::Enum(*e, i as u32)),
                    None => {
                        let d = Diagnostic::error(
                            codes::UNKNOWN_VARIANT,
                            n.span,
                            format!("`{}` is not a variant of enum `{}`", n.name, def.name),
                        )
                        .with_label(format!("`{attr}` is a `{}`", def.name));
                        let d = match crate::diag::suggest::suggest(&n.name, def.variants.iter().map(String::as_str)) {
                            Some(s) => d.with_help(format!("did you mean `{s}`?")),
                            None => d.with_help(format!("the variants are: {}", def.variants.join(", "))),
                        };
                        self.error(d);
                        None
                    }
                }
            }
            (AttrType::Number { dimension, min, max }, ValueLit::Num(n)) => {
                let x = self.number(n, dimension)?;
                self.check_bounds(x, x, *min, *max, n.span, attr)?;
                Some(Value::Number(x))
            }
            (AttrType::Number { dimension, min, max }, ValueLit::Range(a, b)) => {
                let lo = self.number(a, dimension);
                let hi = self.number(b, dimension);
                let (lo, hi) = (lo?, hi?);
                if lo > hi {
                    self.error(empty_range(v.span()));
                    return None;
                }
                self.check_bounds(lo, hi, *min, *max, v.span(), attr)?;
                Some(Value::Range(lo, hi))
            }
            _ => {
                let expected = self.type_name(ty);
                self.error(
                    Diagnostic::error(
                        codes::TYPE_MISMATCH,
                        v.span(),
                        format!("`{attr}` is {expected}, but this is {}", value_sort(v)),
                    )
                    .with_label(format!("expected {expected}")),
                );
                None
            }
        }
    }

    fn check_bounds(&mut self, lo: f64, hi: f64, min: f64, max: f64, span: Span, attr: &str) -> Option<()> {
        if lo < min || hi > max {
            self.error(
                Diagnostic::error(codes::OUT_OF_RANGE, span, format!("value is outside the range of `{attr}`"))
                    .with_label(format!("not within {}..{}", fmt_num(min), fmt_num(max)))
                    .with_help(format!("`{attr}` is declared `in {}..{}` (base units)", fmt_num(min), fmt_num(max))),
            );
            return None;
        }
        Some(())
    }

    pub fn type_name(&self, ty: &AttrType) -> String {
        match ty {
            AttrType::Bool => "a `bool`".to_string(),
            AttrType::Number { dimension, .. } if dimension.is_empty() => "a plain `number`".to_string(),
            AttrType::Number { dimension, .. } => format!("a `{dimension}`"),
            AttrType::Enum(e) => format!("a `{}`", self.d.enums[e.index()].name),
        }
    }

    /// A length triple `(x, y, z)` in metres.
    pub fn vec3(&mut self, v: &[Num; 3], dimension: &str) -> Option<[f64; 3]> {
        let x = self.number(&v[0], dimension);
        let y = self.number(&v[1], dimension);
        let z = self.number(&v[2], dimension);
        Some([x?, y?, z?])
    }

    // ------------------------------------------------------------------ world, regions, presets, camera

    fn lower_world(&mut self, attrs: &[ast::AttrDecl]) {
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

    fn lower_region(&mut self, item: &Item, name: &Ident, stmts: &[ast::RegionStmt]) {
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

    fn lower_preset(&mut self, item: &Item, name: &Ident, for_variant: Option<&ast::Path>, params: &[(Ident, Num)]) {
        let for_variant = for_variant.and_then(|p| self.enum_variant_path(p));
        let mut seen = Namespace::<()>::default();
        let mut out = Vec::new();
        for (p, n) in params {
            if !seen.declare(p, (), |_| "a parameter of this preset", &mut self.diags) {
                continue;
            }
            let value = match &n.unit {
                None => Some(n.value),
                Some(u) => self.units.get(&u.name).map(|i| i.scale * n.value),
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
    fn lower_camera(&mut self, entry: u32, items: &[(u32, &Item)]) {
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
}

impl Checker<'_> {
    /// `visible [NAME] { pixels = N  contrast = X }` items: the default (no name) and overrides
    /// for a kind or a concept. Parameters left out keep the default's value.
    fn lower_visibility(&mut self, items: &[(u32, &Item)]) {
        let mut firsts: Vec<(Option<String>, Span)> = Vec::new();
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
            let is_kind = target.as_ref().is_some_and(|t| self.d.kinds.iter().any(|k| k.name == t.name));
            let is_concept = target.as_ref().is_some_and(|t| self.d.concepts.iter().any(|c| c.name == t.name));
            if let Some(t) = target
                && !is_kind
                && !is_concept
            {
                let names: Vec<&str> = self
                    .d
                    .kinds
                    .iter()
                    .map(|k| k.name.as_str())
                    .chain(self.d.concepts.iter().map(|c| c.name.as_str()))
                    .collect();
                self.error(super::names::unknown("kind or concept", t, names));
                continue;
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
            match target {
                None => self.d.visibility.default = v,
                Some(t) if is_concept => {
                    self.d.visibility.concepts.insert(t.name.clone(), v);
                }
                Some(t) => {
                    self.d.visibility.kinds.insert(t.name.clone(), v);
                }
            }
        }
    }
}

pub(crate) fn push_unique<T: PartialEq>(v: &mut Vec<T>, x: T) {
    if !v.contains(&x) {
        v.push(x);
    }
}

pub(crate) fn join(a: Span, b: Span) -> Span {
    Span { file: a.file, start: a.start.min(b.start), end: a.end.max(b.end) }
}

pub(crate) fn duplicate_statement(what: &str, span: Span, first: Span) -> Diagnostic {
    Diagnostic::error(codes::DUPLICATE_STATEMENT, span, format!("`{what}` is given twice"))
        .with_label("given again here")
        .with_related(first, "first given here")
        .with_help("keep one of them")
}

fn empty_range(span: Span) -> Diagnostic {
    Diagnostic::error(codes::EMPTY_RANGE, span, "the range is empty: its start is above its end")
        .with_label("empty range")
        .with_help("write ranges low to high, `a..b` with `a <= b`")
}

/// A value of the type, standing in for a default that had an error (never reaches the IR).
fn placeholder(ty: &AttrType) -> Value {
    match ty {
        AttrType::Bool => Value::Bool(false),
        AttrType::Enum(e) => Value::Enum(*e, 0),
        AttrType::Number { min, max, .. } => Value::Number(0f64.clamp(*min, *max)),
    }
}

/// "a `length`", "an `angle`".
fn a_dim(dim: &str) -> String {
    let article = if dim.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} `{dim}`")
}

fn dimension_mismatch(n: &Num, expected: &str, found: &str, example: Option<String>) -> Diagnostic {
    let written = match &n.unit {
        Some(u) => format!("{}{}", fmt_num(n.value), u.name),
        None => fmt_num(n.value),
    };
    let (message, help) = match (expected.is_empty(), found.is_empty()) {
        (true, _) => {
            (format!("expected a plain number, found `{written}` ({})", a_dim(found)), "remove the unit".to_string())
        }
        (false, true) => (
            format!("expected {}, found `{written}` with no unit", a_dim(expected)),
            match example {
                Some(u) => format!("add {} unit, e.g. `{written}{u}`", a_dim(expected)),
                None => format!("add {} unit", a_dim(expected)),
            },
        ),
        (false, false) => (
            format!("expected {}, found `{written}` ({})", a_dim(expected), a_dim(found)),
            match example {
                Some(u) => format!("use {} unit such as `{u}`", a_dim(expected)),
                None => format!("use {} unit", a_dim(expected)),
            },
        ),
    };
    Diagnostic::error(codes::DIMENSION_MISMATCH, n.span, message)
        .with_label(if expected.is_empty() {
            "expected a plain number".to_string()
        } else {
            format!("expected {}", a_dim(expected))
        })
        .with_help(help)
}

fn value_sort(v: &ValueLit) -> &'static str {
    match v {
        ValueLit::Num(n) if n.unit.is_some() => "a number with a unit",
        ValueLit::Num(_) => "a number",
        ValueLit::Range(..) => "a range",
        ValueLit::Bool(..) => "a boolean",
        ValueLit::Name(_) => "a name",
    }
}

/// A number for messages: integers without a fraction, huge bounds as `…`.
pub(crate) fn fmt_num(x: f64) -> String {
    if x <= f64::MIN / 2.0 || x >= f64::MAX / 2.0 {
        "…".to_string()
    } else if x == x.trunc() && x.abs() < 1e15 {
        format!("{}", x as i64)
    } else {
        format!("{x}")
    }
}

//! The checker's state, the order of the lowering passes, and the first pass: declaring every
//! name (units, enums, tags, kinds, relations, regions, …) so that item order does not matter.
//! The passes themselves live beside this file: tags and kinds in `types.rs`, attributes and
//! values in `values.rs`, world/regions/presets/camera and `visible` thresholds in `scene.rs`,
//! looks and stage in `shapes.rs`, concepts and constraints in `concepts.rs`, questions and rules
//! in `rules.rs`, conditions in `expr.rs`.
//!
//! Kinds, tags and enums share one namespace (a filter `Collidable | Pedestrian` may name
//! either).

use super::names::{Namespace, Reference};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;
use crate::syntax::ast::{self, Ident, Item, ItemKind, Num};

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
pub(crate) enum Progress {
    Todo,
    Doing,
    Done,
}

/// One `add … RELATION TARGET` to check once every concept is known.
#[derive(Debug, Clone)]
pub(crate) struct RelatedAdd {
    pub entity: String,
    pub region: RegionId,
    pub relation: String,
    /// `None`: ego.
    pub target: Option<String>,
    pub span: Span,
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
    pub kind_progress: Vec<Progress>,
    pub tag_items: Vec<&'a Item>,
    pub tag_ancestors: Vec<Option<Vec<TagId>>>,
    pub tag_progress: Vec<Progress>,
    /// Where each kind's look came from (`shape {}` or `look`), for duplicate reports.
    pub look_spans: Vec<Option<(Span, &'static str)>>,
    /// Names of the entities that any concept adds (targets of `add … RELATION NAME`).
    pub entity_names: Vec<String>,
    /// Every `add`, with its relation, for the checks that need all concepts.
    pub related_adds: Vec<RelatedAdd>,
    /// Where each entity name is first declared (by any concept).
    pub entity_spans: std::collections::HashMap<String, Span>,
    /// Where each variant of each enum is declared.
    pub variant_spans: Vec<Vec<Span>>,
    /// Where each option of each question is declared.
    pub option_spans: Vec<Vec<Span>>,
    /// Every name resolved so far, and its declaration.
    pub refs: Vec<Reference>,
}

/// Lower the gathered items. `entry` is the file whose `domain` line names the domain.
/// `std_files`: the files that are the stdlib, whose looks are vocabulary a domain may leave unused.
pub(crate) fn lower(
    entry: u32,
    items: &[(u32, &Item)],
    std_files: &[u32],
) -> (Option<Domain>, Vec<Diagnostic>, Vec<Reference>) {
    let mut c = Checker::new();
    c.domain_line(entry, items);
    c.declare(items);
    c.lower_tags();
    c.lower_kinds();
    for (_, item) in items {
        match &item.kind {
            ItemKind::World { attrs } => c.lower_world(attrs),
            ItemKind::Relation { name, text, placements } => c.lower_relation(item, name, text, placements.as_deref()),
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
    let has_look = c.inherit_looks();
    c.lower_stage(items);
    c.lower_concepts(items);
    c.lower_visibility(items);
    c.check_relations();
    c.lower_constraints(items);
    c.check_modifier_effects();
    c.lower_questions(items);
    c.lower_rules(entry, items);
    c.lower_allows(items);
    // After the allows: `allow R0108` accepts a placed entity that draws nothing.
    c.lint_looks(&has_look, std_files);
    let has_errors = c.diags.iter().any(Diagnostic::is_error);
    let Checker { d, diags, refs, .. } = c;
    (if has_errors { None } else { Some(d) }, diags, refs)
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
            related_adds: Vec::new(),
            entity_spans: std::collections::HashMap::new(),
            variant_spans: Vec::new(),
            option_spans: Vec::new(),
            refs: Vec::new(),
        }
    }

    /// Record that the name at `at` resolved to the declaration at `decl`.
    pub fn refer(&mut self, at: &Ident, decl: Option<Span>) {
        if let Some(decl) = decl {
            self.refs.push(Reference { at: at.span, decl });
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
                        self.variant_spans.push(seen.names().filter_map(|v| seen.span(v)).collect());
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
                            regions: Vec::new(),
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
                            self.entity_spans.entry(name.name.clone()).or_insert(name.span);
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

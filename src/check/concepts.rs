//! Concepts, modifiers and compatibility constraints.

use super::MAX_ENTITIES;
use super::expr::Scope;
use super::lower::{Checker, TypeSym, duplicate_statement, push_unique};
use super::names::{Namespace, unknown};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::diag::suggest::suggest;
use crate::ir::*;
use crate::syntax::ast::{self, ConceptStmt, Ident, Item, ItemKind, Member};

/// The constraint functions.
const CONSTRAINT_FUNCS: &[&str] = &["exclusive", "at_most", "requires", "forbids"];

impl Checker<'_> {
    pub(crate) fn lower_concepts(&mut self, items: &[(u32, &Item)]) {
        for (_, item) in items {
            let ItemKind::Concept { modifier, name, stmts } = &item.kind else { continue };
            let concept = self.lower_concept(item, *modifier, name, stmts);
            // A duplicate (already reported) is still checked, but takes no bit.
            if self.concepts.span(&name.name) == Some(name.span) {
                self.d.concepts.push(concept);
            }
        }
        self.check_entity_count();
    }

    /// Every entity of a scene comes from an `add`; bounding them all bounds every anchor graph
    /// and every scene, whichever concepts a set holds.
    fn check_entity_count(&mut self) {
        let adds = self.d.concepts.iter().flat_map(|c| &c.effects).filter_map(|e| match e {
            Effect::Add { span, .. } => Some(*span),
            _ => None,
        });
        if let Some(span) = adds.clone().nth(MAX_ENTITIES) {
            let total = adds.count();
            self.error(
                Diagnostic::error(
                    codes::COUNT_TOO_LARGE,
                    span,
                    format!("the concepts add {total} entities; a domain may add at most {MAX_ENTITIES}"),
                )
                .with_label(format!("entity {}", MAX_ENTITIES + 1))
                .with_help("merge concepts that add the same entity, or split the domain"),
            );
        }
    }

    fn lower_concept(&mut self, item: &Item, modifier: bool, name: &Ident, stmts: &[ConceptStmt]) -> Concept {
        let id = ConceptId(self.d.concepts.len() as u32);
        let mut c = Concept {
            name: name.name.clone(),
            id,
            kind: if modifier { ConceptKind::Modifier } else { ConceptKind::Concept },
            description: String::new(),
            category: String::new(),
            probe: Probe::default(),
            effects: Vec::new(),
            target: None,
            render: RenderBindings::default(),
            span: item.span,
        };
        let what = if modifier { "modifier" } else { "concept" };
        // The target first: `set ATTR` and `shape` statements are checked against it wherever
        // they appear in the body.
        let target_kinds = if modifier { self.lower_target(&mut c, item, name, stmts) } else { Vec::new() };
        let mut seen: Vec<(&'static str, Span)> = Vec::new();
        let mut entities: Namespace<()> = Namespace::default();
        let mut added_kinds: Vec<KindId> = Vec::new();
        for s in stmts {
            let single = matches!(
                s,
                ConceptStmt::Description(_)
                    | ConceptStmt::Category(_)
                    | ConceptStmt::Probe { .. }
                    | ConceptStmt::Scenic(_)
                    | ConceptStmt::Prompt(_)
                    | ConceptStmt::Shape(_)
                    | ConceptStmt::Target { .. }
                    | ConceptStmt::DrawnBy { .. }
            );
            if single {
                let span = stmt_span(s);
                if let Some((_, prev)) = seen.iter().find(|(k, _)| *k == s.keyword()) {
                    let prev = *prev;
                    self.error(duplicate_statement(s.keyword(), span, prev));
                    continue;
                }
                seen.push((s.keyword(), span));
            }
            match s {
                ConceptStmt::Description(t) => c.description = t.value.clone(),
                ConceptStmt::Category(t) => c.category = t.value.clone(),
                ConceptStmt::Probe { positive, negative, .. } => {
                    c.probe = Probe { positive: positive.value.clone(), negative: negative.value.clone() }
                }
                ConceptStmt::Scenic(t) => c.render.scenic = Some(t.value.clone()),
                ConceptStmt::Prompt(t) => c.render.prompt = Some(t.value.clone()),
                ConceptStmt::Target { span, .. } if !modifier => self.error(
                    Diagnostic::error(codes::MISPLACED_STATEMENT, *span, "a concept has no `target`")
                        .with_label("only modifiers have a target")
                        .with_help("declare it as `modifier` to change entities that other concepts add"),
                ),
                ConceptStmt::Target { .. } => {}
                ConceptStmt::Add { span, .. } if modifier => self.error(
                    Diagnostic::error(codes::MISPLACED_STATEMENT, *span, "a modifier cannot add entities")
                        .with_label("`add` in a modifier")
                        .with_help("add entities in a concept; a modifier changes an entity that a concept added"),
                ),
                ConceptStmt::Add { name, kind, region, relation, attrs, span } => {
                    if let Some(effect) =
                        self.lower_add(&mut entities, name, kind, region, relation.as_ref(), attrs, *span)
                    {
                        if let Effect::Add { kind, .. } = &effect {
                            push_unique(&mut added_kinds, *kind);
                        }
                        c.effects.push(effect);
                    }
                }
                ConceptStmt::Set { path, value, span } => {
                    if let Some(e) = self.lower_set(&c, path, value, *span, &target_kinds) {
                        c.effects.push(e);
                    }
                }
                ConceptStmt::Move { region, span } => {
                    if let Some(e) = self.lower_move(&c, region, *span) {
                        c.effects.push(e);
                    }
                }
                ConceptStmt::Shape(_) | ConceptStmt::DrawnBy { .. } => {}
            }
        }
        if let Some(ConceptStmt::DrawnBy { stage, span }) =
            stmts.iter().find(|s| matches!(s, ConceptStmt::DrawnBy { .. }))
        {
            c.render.drawn_by = self.lower_drawn_by(&c, stage, *span);
        }
        // Shapes last, so `self` knows every kind this concept adds.
        for s in stmts {
            if let ConceptStmt::Shape(parts) = s {
                let kinds = if modifier { target_kinds.clone() } else { added_kinds.clone() };
                let mut scope = Scope::for_self(kinds);
                c.render.shape = self.lower_parts(parts, &mut scope);
            }
        }
        for (needed, hint) in [("description", "description \"…\""), ("probe", "probe \"…\" not \"…\"")] {
            if !item.broken && !seen.iter().any(|(k, _)| *k == needed) {
                self.error(
                    Diagnostic::warning(
                        codes::MISSING_TEXT,
                        name.span,
                        format!("{what} `{}` has no `{needed}`", name.name),
                    )
                    .with_label(format!("add `{hint}`"))
                    .with_help(if needed == "probe" {
                        "the probe is what the recognition analysis asks the model about this concept"
                    } else {
                        "the description is the sentence reports show for this concept"
                    }),
                );
            }
        }
        c
    }

    /// Resolve a modifier's `target`; returns the kinds it can apply to.
    fn lower_target(&mut self, c: &mut Concept, item: &Item, name: &Ident, stmts: &[ConceptStmt]) -> Vec<KindId> {
        let Some(ConceptStmt::Target { world, filter, .. }) =
            stmts.iter().find(|s| matches!(s, ConceptStmt::Target { .. }))
        else {
            if item.broken {
                return Vec::new(); // the `target` may be the statement that failed to parse
            }
            self.error(
                Diagnostic::error(
                    codes::MISSING_STATEMENT,
                    name.span,
                    format!("modifier `{}` has no `target`", name.name),
                )
                .with_label("what does it apply to?")
                .with_help("add `target KIND | TAG …`, or `target world` for a modifier of world attributes"),
            );
            return Vec::new();
        };
        if world.is_some() {
            c.target = Some(TargetFilter { kinds: Vec::new(), tags: Vec::new(), world: true });
            return Vec::new();
        }
        let f = self.lower_filter(filter);
        let kinds = self.matching_kinds(&f);
        c.target = Some(f);
        kinds
    }

    #[allow(clippy::too_many_arguments)]
    fn lower_add(
        &mut self,
        entities: &mut Namespace<()>,
        name: &Ident,
        kind: &Ident,
        region: &Ident,
        relation: Option<&(Ident, Ident)>,
        attrs: &[(Ident, ast::ValueLit)],
        span: Span,
    ) -> Option<Effect> {
        if name.name == "ego" || name.name == "world" || name.name == "self" {
            self.error(
                Diagnostic::error(codes::BAD_REFERENCE, name.span, format!("`{}` cannot name an entity", name.name))
                    .with_label("reserved name")
                    .with_help("`ego`, `world` and `self` have fixed meanings; pick another name"),
            );
            return None;
        }
        let fresh = entities.declare(name, (), |_| "an entity of this concept", &mut self.diags);
        let k = match self.resolve_type(kind, "kind")? {
            TypeSym::Kind(k) => k,
            other => {
                self.error(
                    Diagnostic::error(
                        codes::WRONG_SORT,
                        kind.span,
                        format!("`{}` is {}, not a kind", kind.name, other.sort()),
                    )
                    .with_label("expected a kind")
                    .with_help("entities are added by kind; pick a kind that carries this tag"),
                );
                return None;
            }
        };
        let region_name = region;
        let region = self.resolve_region(region)?;
        let stands = self.check_stand(k, region, region_name);
        // Where relation diagnostics point: the relation as written, else the region.
        let relation_span = relation.map_or(region_name.span, |(r, t)| super::lower::join(r.span, t.span));
        let relation = match relation {
            None => Relation { name: "ahead_of".to_string(), to: None },
            Some((rel, to)) => {
                if self.relations.get(&rel.name).is_none() {
                    let d = unknown("relation", rel, self.relations.names());
                    self.error(d);
                    return None;
                }
                self.refer(rel, self.relations.span(&rel.name));
                let to = if to.name == "ego" {
                    None
                } else if to.name == name.name {
                    self.error(
                        Diagnostic::error(
                            codes::UNPLACEABLE_RELATION,
                            to.span,
                            format!("`{}` is placed relative to itself", name.name),
                        )
                        .with_label("the entity being added")
                        .with_help("relate it to `ego` or to another entity"),
                    );
                    return None;
                } else if self.entity_names.contains(&to.name) {
                    // An entity of this concept, else the first concept's that adds one so named.
                    let decl = entities.span(&to.name).or_else(|| self.entity_spans.get(&to.name).copied());
                    self.refer(to, decl);
                    Some(to.name.clone())
                } else {
                    let mut d = unknown("entity", to, self.entity_names.iter().map(String::as_str));
                    d = d.with_label("no concept adds an entity with this name");
                    if d.help.is_none() {
                        d = d.with_help("relate to `ego` or to an entity that some concept adds");
                    }
                    self.error(d);
                    return None;
                };
                Relation { name: rel.name.clone(), to }
            }
        };
        let mut values = Vec::new();
        let mut seen = Namespace::<()>::default();
        let mut ok = fresh;
        for (attr, v) in attrs {
            if !seen.declare(attr, (), |_| "an attribute of this entity", &mut self.diags) {
                ok = false;
                continue;
            }
            let kd = &self.d.kinds[k.index()];
            match kd.attr(&attr.name) {
                Some(i) => {
                    let ty = kd.attrs[i].ty.clone();
                    let decl = kd.attrs[i].span;
                    self.refer(attr, Some(decl));
                    match self.lower_value(v, &ty, &attr.name) {
                        Some(val) => values.push((attr.name.clone(), val)),
                        None => ok = false,
                    }
                }
                None => {
                    let kname = kd.name.clone();
                    let mut d = unknown("attribute", attr, kd.attrs.iter().map(|a| a.name.as_str()))
                        .with_label(format!("kind `{kname}` has no such attribute"));
                    d.code = codes::UNKNOWN_ATTR;
                    self.error(d);
                    ok = false;
                }
            }
        }
        self.related_adds.push(super::lower::RelatedAdd {
            entity: name.name.clone(),
            region,
            relation: relation.name.clone(),
            target: relation.to.clone(),
            span: relation_span,
        });
        (ok && stands).then(|| Effect::Add { name: name.name.clone(), kind: k, region, relation, attrs: values, span })
    }

    fn resolve_region(&mut self, region: &Ident) -> Option<RegionId> {
        match self.regions.get(&region.name) {
            Some(&r) => {
                self.refer(region, self.regions.span(&region.name));
                Some(r)
            }
            None => {
                let d = unknown("region", region, self.regions.names());
                self.error(d);
                None
            }
        }
    }

    fn lower_set(
        &mut self,
        c: &Concept,
        path: &ast::Path,
        value: &ast::ValueLit,
        span: Span,
        targets: &[KindId],
    ) -> Option<Effect> {
        let on_world_target = c.target.as_ref().is_some_and(|t| t.world);
        match path.parts.as_slice() {
            [w, attr] if w.name == "world" => self.lower_set_world(attr, value, span),
            [attr] if c.kind == ConceptKind::Modifier && on_world_target => self.lower_set_world(attr, value, span),
            [attr] if c.kind == ConceptKind::Modifier => self.lower_set_target(c, attr, value, span, targets),
            [attr] => {
                self.error(
                    Diagnostic::error(
                        codes::MISPLACED_STATEMENT,
                        span,
                        format!("a concept cannot set `{}` on a target", attr.name),
                    )
                    .with_label("only modifiers have a target")
                    .with_help(
                        "set world attributes with `set world.ATTR = …`, or entity attributes in `add … { ATTR = … }`",
                    ),
                );
                None
            }
            _ => {
                self.error(
                    Diagnostic::error(
                        codes::BAD_REFERENCE,
                        path.span,
                        "expected `world.ATTR` or, in a modifier, `ATTR`",
                    )
                    .with_label("cannot set this"),
                );
                None
            }
        }
    }

    fn lower_set_world(&mut self, attr: &Ident, value: &ast::ValueLit, span: Span) -> Option<Effect> {
        let Some(&i) = self.world_attrs.get(&attr.name) else {
            let mut d = unknown("world attribute", attr, self.world_attrs.names());
            d.code = codes::UNKNOWN_ATTR;
            self.error(d);
            return None;
        };
        self.refer(attr, self.world_attrs.span(&attr.name));
        let ty = self.d.world[i].ty.clone();
        let value = self.lower_value(value, &ty, &attr.name)?;
        Some(Effect::SetWorld { attr: attr.name.clone(), value, span })
    }

    fn lower_set_target(
        &mut self,
        c: &Concept,
        attr: &Ident,
        value: &ast::ValueLit,
        span: Span,
        targets: &[KindId],
    ) -> Option<Effect> {
        let having: Vec<KindId> =
            targets.iter().copied().filter(|k| self.d.kinds[k.index()].attr(&attr.name).is_some()).collect();
        let Some(first) = having.first() else {
            if targets.is_empty() {
                return None; // no target kinds: reported by `target` or left to the lattice lints
            }
            let mut names: Vec<&str> = Vec::new();
            for k in targets {
                for a in &self.d.kinds[k.index()].attrs {
                    push_unique(&mut names, a.name.as_str());
                }
            }
            let mut d =
                unknown("attribute", attr, names).with_label(format!("no kind that `{}` targets has it", c.name));
            d.code = codes::UNKNOWN_ATTR;
            self.error(d);
            return None;
        };
        if having.len() < targets.len() {
            let lacking: Vec<String> = targets
                .iter()
                .filter(|k| !having.contains(k))
                .map(|k| format!("`{}`", self.d.kinds[k.index()].name))
                .collect();
            self.error(
                Diagnostic::warning(
                    codes::PARTIAL_TARGET,
                    attr.span,
                    format!("some kinds that `{}` targets have no `{}`", c.name, attr.name),
                )
                .with_label(format!("missing on {}", lacking.join(", ")))
                .with_help("sets where this modifier lands on such an entity are invalid; narrow the `target`"),
            );
        }
        let kd = &self.d.kinds[first.index()];
        let def = &kd.attrs[kd.attr(&attr.name)?];
        let (ty, decl) = (def.ty.clone(), def.span);
        self.refer(attr, Some(decl));
        let value = self.lower_value(value, &ty, &attr.name)?;
        Some(Effect::SetTarget { attr: attr.name.clone(), value, span })
    }

    fn lower_move(&mut self, c: &Concept, region: &Ident, span: Span) -> Option<Effect> {
        if c.kind != ConceptKind::Modifier {
            self.error(
                Diagnostic::error(codes::MISPLACED_STATEMENT, span, "a concept cannot `move` a target")
                    .with_label("only modifiers have a target")
                    .with_help("place the entities of a concept with `add … in REGION`"),
            );
            return None;
        }
        if c.target.as_ref().is_some_and(|t| t.world) {
            self.error(
                Diagnostic::error(codes::MISPLACED_STATEMENT, span, "a modifier of the world cannot `move` it")
                    .with_label("the target is the world")
                    .with_help("`move` needs an entity target, e.g. `target Collidable`"),
            );
            return None;
        }
        let region = self.resolve_region(region)?;
        Some(Effect::MoveTarget { region, span })
    }

    /// `drawn_by STAGE`: only a concept that adds an entity has something for a stage to draw.
    fn lower_drawn_by(&mut self, c: &Concept, stage: &Ident, span: Span) -> Option<String> {
        if c.kind == ConceptKind::Modifier {
            self.error(
                Diagnostic::error(codes::MISPLACED_STATEMENT, span, "a modifier adds nothing a stage could draw")
                    .with_label("`drawn_by` in a modifier")
                    .with_help("put `drawn_by STAGE` in the concept that adds the entity the stage draws"),
            );
            return None;
        }
        if !c.effects.iter().any(|e| matches!(e, Effect::Add { .. })) {
            self.error(
                Diagnostic::error(
                    codes::MISPLACED_STATEMENT,
                    span,
                    format!("concept `{}` adds no entity for a stage to draw", c.name),
                )
                .with_label("`drawn_by` without an `add`")
                .with_help("`drawn_by STAGE` names what draws an entity the concept adds; a world setting needs none"),
            );
            return None;
        }
        if self.stages.get(&stage.name).is_none() {
            let d = unknown("stage", stage, self.stages.names());
            self.error(d);
            return None;
        }
        self.refer(stage, self.stages.span(&stage.name));
        Some(stage.name.clone())
    }

    // ------------------------------------------------------------------ constraints

    pub(crate) fn lower_constraints(&mut self, items: &[(u32, &Item)]) {
        for (_, item) in items {
            let ItemKind::Constraint { name, func, count, members } = &item.kind else { continue };
            if self.constraints.span(&name.name) != Some(name.span) {
                continue;
            }
            if let Some(rule) = self.lower_constraint(func, *count, members) {
                self.d.constraints.push(Constraint {
                    name: name.name.clone(),
                    doc: item.doc.clone(),
                    rule,
                    span: item.span,
                });
            }
        }
    }

    fn lower_constraint(
        &mut self,
        func: &Ident,
        count: Option<(u32, Span)>,
        members: &[Member],
    ) -> Option<ConstraintRule> {
        if !CONSTRAINT_FUNCS.contains(&func.name.as_str()) {
            let d =
                Diagnostic::error(codes::UNKNOWN_CONSTRAINT, func.span, format!("unknown constraint `{}`", func.name))
                    .with_label("not a constraint");
            let d = match suggest(&func.name, CONSTRAINT_FUNCS.iter().copied()) {
                Some(s) => d.with_help(format!("did you mean `{s}`?")),
                None => d.with_help("the constraints are `exclusive`, `at_most`, `requires` and `forbids`"),
            };
            self.error(d);
            return None;
        }
        let resolved: Vec<Option<ConceptSet>> = members.iter().map(|m| self.lower_member(m)).collect();
        let resolved: Vec<ConceptSet> = resolved.into_iter().collect::<Option<_>>()?;
        let all = resolved.iter().fold(ConceptSet::EMPTY, |a, s| a.union(*s));
        let arity = |msg: &str, help: &str| {
            Diagnostic::error(codes::CONSTRAINT_ARITY, func.span, msg.to_string()).with_help(help.to_string())
        };
        match (func.name.as_str(), count) {
            ("at_most", None) => {
                self.error(arity("`at_most` needs a count", "write `at_most(N, a, b, …)`"));
                None
            }
            ("at_most", Some((n, _))) => Some(ConstraintRule::AtMost { members: all, max: n }),
            (f, Some((_, span))) => {
                self.error(
                    Diagnostic::error(codes::CONSTRAINT_ARITY, span, format!("`{f}` takes no count"))
                        .with_label("remove this count")
                        .with_help("only `at_most` takes a count"),
                );
                None
            }
            ("requires", None) => {
                let first = match &members[0] {
                    Member::Name(_) => resolved[0],
                    _ => {
                        self.error(arity(
                            "the first member of `requires` must be one concept",
                            "write `requires(concept, alternative, …)`",
                        ));
                        return None;
                    }
                };
                let concept = first.iter().next()?;
                let any_of = resolved[1..].iter().fold(ConceptSet::EMPTY, |a, s| a.union(*s)).without(concept);
                if any_of.is_empty() {
                    self.error(arity(
                        "`requires` needs at least one concept to require",
                        "write `requires(concept, alternative, …)`",
                    ));
                    return None;
                }
                Some(ConstraintRule::Requires { concept, any_of })
            }
            (f, None) => {
                if all.len() < 2 {
                    self.error(arity(
                        &format!("`{f}` needs at least two concepts"),
                        "a constraint over one concept says nothing",
                    ));
                    return None;
                }
                Some(if f == "exclusive" {
                    ConstraintRule::AtMost { members: all, max: 1 }
                } else {
                    ConstraintRule::Forbids { all }
                })
            }
        }
    }

    /// Ids of the concepts that satisfy `pred` and fit in a concept set.
    fn concept_ids(&self, pred: impl Fn(&Concept) -> bool) -> Vec<ConceptId> {
        self.d.concepts.iter().filter(|c| c.id.index() < MAX_CONCEPTS && pred(c)).map(|c| c.id).collect()
    }

    fn lower_member(&mut self, m: &Member) -> Option<ConceptSet> {
        match m {
            Member::Name(n) => match self.concepts.get(&n.name) {
                // A concept past the set width was reported (R0044) and takes no bit.
                Some(&id) => {
                    self.refer(n, self.concepts.span(&n.name));
                    (id.index() < MAX_CONCEPTS).then(|| ConceptSet::single(id))
                }
                None => {
                    let d = unknown("concept", n, self.concepts.names());
                    self.error(d);
                    None
                }
            },
            Member::Wildcard(w) => {
                let prefix = w.name.trim_end_matches('*');
                let set = ConceptSet::from_ids(self.concept_ids(|c| c.name.starts_with(prefix)));
                if set.is_empty() {
                    self.error(
                        Diagnostic::error(codes::EMPTY_MEMBER, w.span, format!("`{}` matches no concept", w.name))
                            .with_label("empty wildcard")
                            .with_help(format!("no concept name starts with `{prefix}`")),
                    );
                    return None;
                }
                Some(set)
            }
            Member::Category(cat) => {
                let set = ConceptSet::from_ids(self.concept_ids(|c| c.category == cat.value));
                if set.is_empty() {
                    let mut cats: Vec<&str> = Vec::new();
                    for c in &self.d.concepts {
                        push_unique(&mut cats, c.category.as_str());
                    }
                    let d = Diagnostic::error(
                        codes::EMPTY_MEMBER,
                        cat.span,
                        format!("no concept has category `{}`", cat.value),
                    )
                    .with_label("empty category");
                    let d = match suggest(&cat.value, cats) {
                        Some(s) => d.with_help(format!("did you mean `{s}`?")),
                        None => d,
                    };
                    self.error(d);
                    return None;
                }
                Some(set)
            }
        }
    }
}

fn stmt_span(s: &ConceptStmt) -> Span {
    match s {
        ConceptStmt::Description(t) | ConceptStmt::Category(t) | ConceptStmt::Scenic(t) | ConceptStmt::Prompt(t) => {
            t.span
        }
        ConceptStmt::Add { span, .. }
        | ConceptStmt::Set { span, .. }
        | ConceptStmt::Probe { span, .. }
        | ConceptStmt::Target { span, .. }
        | ConceptStmt::Move { span, .. }
        | ConceptStmt::DrawnBy { span, .. } => *span,
        ConceptStmt::Shape(p) => p.span,
    }
}

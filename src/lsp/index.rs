//! Every named thing of a compilation and every place it is named: what hover, go to
//! definition, find references, completion and semantic tokens read.
//!
//! Built from the syntax trees of all files a document loads (its `use`d modules and the
//! embedded stdlib included), with the language's scoping: item names are global across the
//! loaded files; attributes belong to a kind (and are inherited) or to the world; variants to an
//! enum; options to a question; entities to the concept that adds them; `exists` variables to
//! their expression. A name that does not resolve is simply not indexed — the checker reports
//! it.

use std::collections::HashMap;

use crate::ir::Span;
use crate::syntax::ast::*;

/// What sort of thing a symbol is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sort {
    Module,
    Unit,
    Enum,
    Variant,
    Tag,
    Relation,
    Kind,
    Attr,
    WorldAttr,
    Region,
    Preset,
    Stage,
    Concept,
    Modifier,
    Constraint,
    Question,
    Option,
    Rule,
    /// An entity a concept adds (`add NAME: …`).
    Entity,
    /// A variable bound by `exists`.
    Var,
}

impl Sort {
    /// The word for it in prose.
    pub fn word(self) -> &'static str {
        match self {
            Sort::Module => "module",
            Sort::Unit => "unit",
            Sort::Enum => "enum",
            Sort::Variant => "variant",
            Sort::Tag => "tag",
            Sort::Relation => "relation",
            Sort::Kind => "kind",
            Sort::Attr => "attribute",
            Sort::WorldAttr => "world attribute",
            Sort::Region => "region",
            Sort::Preset => "preset",
            Sort::Stage => "stage item",
            Sort::Concept => "concept",
            Sort::Modifier => "modifier",
            Sort::Constraint => "constraint",
            Sort::Question => "question",
            Sort::Option => "option",
            Sort::Rule => "rule",
            Sort::Entity => "entity",
            Sort::Var => "variable",
        }
    }
}

/// One named thing.
#[derive(Debug, Clone)]
pub struct Symbol {
    pub sort: Sort,
    pub name: String,
    /// Where its name is declared.
    pub decl: Span,
    /// The whole declaration.
    pub full: Span,
    /// The enum of a variant, kind of an attribute, question of an option, concept of an entity.
    pub parent: Option<usize>,
    /// Its `///` comment.
    pub doc: String,
    /// Its declaration as written (first lines), for hover.
    pub snippet: String,
    /// Further hover paragraphs (a concept's description and probe, a rule's expectation …).
    pub notes: Vec<String>,
}

/// The symbols of a compilation and their occurrences.
#[derive(Debug, Default)]
pub struct Index {
    pub symbols: Vec<Symbol>,
    /// Every occurrence, declarations included, sorted by file and position.
    pub occurrences: Vec<(Span, usize)>,
    globals: HashMap<(Space, String), usize>,
    variants: HashMap<(usize, String), usize>,
    options: HashMap<(usize, String), usize>,
    /// Own attributes of a kind (or of the world, under `usize::MAX`), in order.
    attrs: HashMap<usize, Vec<usize>>,
    /// Parent kinds and tags of a kind or tag.
    parents: HashMap<usize, Vec<usize>>,
    /// The enum an attribute's type names.
    attr_enum: HashMap<usize, usize>,
}

/// Namespaces of global names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Space {
    Unit,
    Enum,
    KindOrTag,
    Relation,
    Region,
    Preset,
    Stage,
    Concept,
    Constraint,
    Question,
    Rule,
}

const WORLD: usize = usize::MAX;

/// One loaded file: its number in the compilation, text and tree.
pub struct Source<'a> {
    pub file: u32,
    pub name: &'a str,
    pub text: &'a str,
    pub tree: &'a File,
}

fn text_of(text: &str, s: Span) -> &str {
    text.get(s.start as usize..s.end as usize).unwrap_or("")
}

/// The first `max` lines of a declaration, for hover.
fn snippet(text: &str, s: Span, max: usize) -> String {
    let t = text_of(text, s);
    let mut lines: Vec<&str> = t.lines().take(max + 1).collect();
    if lines.len() > max {
        lines.truncate(max);
        lines.push("…");
    }
    lines.join("\n")
}

impl Index {
    pub fn build(sources: &[Source]) -> Index {
        let mut ix = Index::default();
        for s in sources {
            ix.declare_file(s);
        }
        // Parents and attribute types first: references anywhere may go through them.
        for s in sources {
            for item in &s.tree.items {
                ix.link_item(item);
            }
        }
        for s in sources {
            ix.resolve_file(s);
        }
        ix.occurrences.sort_by_key(|(s, _)| (s.file, s.start, s.end));
        ix.occurrences.dedup();
        ix
    }

    /// The symbol named at byte `offset` of `file`, and the span of that occurrence.
    pub fn at(&self, file: u32, offset: u32) -> Option<(Span, usize)> {
        let i = self.occurrences.partition_point(|(s, _)| (s.file, s.end) < (file, offset));
        self.occurrences[i..]
            .iter()
            .take_while(|(s, _)| s.file == file && s.start <= offset)
            .find(|(s, _)| s.start <= offset && offset <= s.end)
            .copied()
    }

    /// Every occurrence of symbol `id`, its declaration first.
    pub fn occurrences_of(&self, id: usize) -> Vec<Span> {
        let decl = self.symbols[id].decl;
        let mut out = vec![decl];
        out.extend(self.occurrences.iter().filter(|(s, i)| *i == id && *s != decl).map(|(s, _)| *s));
        out
    }

    pub fn global(&self, sorts: &[Sort], name: &str) -> Option<usize> {
        sorts.iter().find_map(|s| self.globals.get(&(space_of(*s)?, name.to_string())).copied())
    }

    /// Symbols of the given sorts, in declaration order.
    pub fn all(&self, sorts: &[Sort]) -> impl Iterator<Item = (usize, &Symbol)> {
        self.symbols.iter().enumerate().filter(move |(_, s)| sorts.contains(&s.sort))
    }

    pub fn variants_of(&self, en: usize) -> Vec<usize> {
        self.children(en, Sort::Variant)
    }

    pub fn options_of(&self, q: usize) -> Vec<usize> {
        self.children(q, Sort::Option)
    }

    fn children(&self, parent: usize, sort: Sort) -> Vec<usize> {
        self.all(&[sort]).filter(|(_, s)| s.parent == Some(parent)).map(|(i, _)| i).collect()
    }

    pub fn world_attrs(&self) -> Vec<usize> {
        self.attrs.get(&WORLD).cloned().unwrap_or_default()
    }

    /// The enum an attribute's values come from.
    pub fn enum_of_attr(&self, attr: usize) -> Option<usize> {
        self.attr_enum.get(&attr).copied()
    }

    /// A kind's or tag's parents as written.
    pub fn parents_of(&self, id: usize) -> Vec<usize> {
        self.parents.get(&id).cloned().unwrap_or_default()
    }

    /// A kind's or tag's ancestors (parents, their parents, …), without repeats.
    pub fn ancestors(&self, id: usize) -> Vec<usize> {
        let mut out: Vec<usize> = Vec::new();
        let mut todo = self.parents.get(&id).cloned().unwrap_or_default();
        while let Some(p) = todo.pop() {
            if p != id && !out.contains(&p) {
                out.push(p);
                todo.extend(self.parents.get(&p).into_iter().flatten());
            }
        }
        out
    }

    /// The kinds a filter of kinds and tags admits.
    pub fn kinds_matching(&self, filter: &[usize]) -> Vec<usize> {
        self.all(&[Sort::Kind])
            .map(|(i, _)| i)
            .filter(|&k| filter.contains(&k) || self.ancestors(k).iter().any(|a| filter.contains(a)))
            .collect()
    }

    /// A kind's attributes, its own first, then inherited ones.
    pub fn attrs_of_kind(&self, kind: usize) -> Vec<usize> {
        let mut out = self.attrs.get(&kind).cloned().unwrap_or_default();
        for a in self.ancestors(kind) {
            for &attr in self.attrs.get(&a).into_iter().flatten() {
                if !out.iter().any(|&o| self.symbols[o].name == self.symbols[attr].name) {
                    out.push(attr);
                }
            }
        }
        out
    }

    /// The attributes called `name` of any of `kinds`.
    fn attr_in(&self, kinds: &[usize], name: &str) -> Option<usize> {
        kinds.iter().flat_map(|&k| self.attrs_of_kind(k)).find(|&a| self.symbols[a].name == name)
    }

    // ------------------------------------------------------------------ declarations

    fn add(&mut self, sort: Sort, name: &Ident, full: Span, text: &str) -> usize {
        let id = self.symbols.len();
        self.symbols.push(Symbol {
            sort,
            name: name.name.clone(),
            decl: name.span,
            full,
            parent: None,
            doc: String::new(),
            snippet: snippet(text, full, 12),
            notes: Vec::new(),
        });
        self.occurrences.push((name.span, id));
        if let Some(space) = space_of(sort) {
            // The first declaration wins, as in the checker (which reports the second).
            self.globals.entry((space, name.name.clone())).or_insert(id);
        }
        id
    }

    fn declare_file(&mut self, s: &Source) {
        let module = Ident { name: s.name.to_string(), span: Span { file: s.file, start: 0, end: 0 } };
        let id = self.add(Sort::Module, &module, Span { file: s.file, start: 0, end: s.text.len() as u32 }, s.text);
        self.symbols[id].snippet = String::new();
        self.occurrences.pop();
        for item in &s.tree.items {
            self.declare_item(s, item);
        }
    }

    fn declare_item(&mut self, s: &Source, item: &Item) {
        let text = s.text;
        let id = match &item.kind {
            ItemKind::Unit { name, dimension, .. } => {
                let id = self.add(Sort::Unit, name, item.span, text);
                self.symbols[id].notes.push(format!("measures {}", dimension.name));
                id
            }
            ItemKind::Enum { name, variants } => {
                let id = self.add(Sort::Enum, name, item.span, text);
                for v in variants {
                    let vid = self.add(Sort::Variant, v, v.span, text);
                    self.symbols[vid].parent = Some(id);
                    self.symbols[vid].snippet = format!("{}.{}", name.name, v.name);
                    self.variants.entry((id, v.name.clone())).or_insert(vid);
                }
                id
            }
            ItemKind::Tag { name, .. } => self.add(Sort::Tag, name, item.span, text),
            ItemKind::Relation { name, .. } => self.add(Sort::Relation, name, item.span, text),
            ItemKind::Kind { name, attrs, .. } => {
                let header = Span { end: name.span.end, ..item.span };
                let id = self.add(Sort::Kind, name, item.span, text);
                self.symbols[id].snippet = snippet(text, header, 1);
                self.declare_attrs(s, attrs, id, Sort::Attr);
                id
            }
            ItemKind::World { attrs } => {
                self.declare_attrs(s, attrs, WORLD, Sort::WorldAttr);
                return;
            }
            ItemKind::Region { name, .. } => self.add(Sort::Region, name, item.span, text),
            ItemKind::Preset { name, .. } => self.add(Sort::Preset, name, item.span, text),
            ItemKind::Stage { name, .. } => self.add(Sort::Stage, name, item.span, text),
            ItemKind::Concept { modifier, name, stmts } => {
                let sort = if *modifier { Sort::Modifier } else { Sort::Concept };
                let id = self.add(sort, name, item.span, text);
                let word = if *modifier { "modifier" } else { "concept" };
                self.symbols[id].snippet = format!("{word} {}", name.name);
                self.symbols[id].notes = concept_notes(stmts);
                id
            }
            ItemKind::Constraint { name, .. } => self.add(Sort::Constraint, name, item.span, text),
            ItemKind::Question { name, stmts } => {
                let id = self.add(Sort::Question, name, item.span, text);
                for st in stmts {
                    if let QuestionStmt::Option { name: o, text: t } = st {
                        let oid = self.add(Sort::Option, o, Span { end: t.span.end, ..o.span }, text);
                        self.symbols[oid].parent = Some(id);
                        self.symbols[oid].snippet = format!("{}.{}", name.name, o.name);
                        self.symbols[oid].notes.push(t.value.clone());
                        self.options.entry((id, o.name.clone())).or_insert(oid);
                    }
                }
                id
            }
            ItemKind::Rules { selection, rules } => {
                for r in rules {
                    let id = self.add(Sort::Rule, &r.name, r.span, text);
                    self.symbols[id].doc = r.doc.clone();
                    self.symbols[id].snippet = format!("rule {}  // in `rules {}`", r.name.name, selection.name);
                }
                return;
            }
            _ => return,
        };
        self.symbols[id].doc = item.doc.clone();
    }

    fn declare_attrs(&mut self, s: &Source, attrs: &[AttrDecl], owner: usize, sort: Sort) {
        for a in attrs {
            let id = self.add(sort, &a.name, a.span, s.text);
            self.symbols[id].doc = a.doc.clone();
            self.symbols[id].parent = (owner != WORLD).then_some(owner);
            self.attrs.entry(owner).or_default().push(id);
        }
    }

    // ------------------------------------------------------------------ references

    fn refer(&mut self, span: Span, id: Option<usize>) -> Option<usize> {
        if let Some(id) = id {
            self.occurrences.push((span, id));
        }
        id
    }

    fn refer_global(&mut self, name: &Ident, sorts: &[Sort]) -> Option<usize> {
        let id = self.global(sorts, &name.name);
        self.refer(name.span, id)
    }

    fn resolve_file(&mut self, s: &Source) {
        for item in &s.tree.items {
            self.resolve_item(s, item);
        }
    }

    fn resolve_item(&mut self, s: &Source, item: &Item) {
        const KT: &[Sort] = &[Sort::Kind, Sort::Tag];
        match &item.kind {
            ItemKind::Use(target) => {
                let (name, span) = match target {
                    UseTarget::Std(m) => (format!("std/{}.rev", m.name), m.span),
                    UseTarget::File(p) => (crate::check::join_relative(s.name, &p.value), p.span),
                };
                let module = self.all(&[Sort::Module]).find(|(_, m)| m.name == name).map(|(i, _)| i);
                self.refer(span, module);
            }
            ItemKind::Unit { scale, .. } => self.num(scale),
            ItemKind::Kind { name, attrs, shapes, stands_in, .. } => {
                let me = self.global(KT, &name.name);
                for region in stands_in.iter().flatten() {
                    self.refer_global(region, &[Sort::Region]);
                }
                self.attr_values(attrs);
                for parts in shapes {
                    self.parts(parts, me);
                }
            }
            ItemKind::World { attrs } => self.attr_values(attrs),
            ItemKind::Look { kind, parts } => {
                let k = self.refer_global(kind, KT);
                self.parts(parts, k);
            }
            ItemKind::Region { stmts, .. } => {
                for st in stmts {
                    if let RegionStmt::Axis { value, .. } = st {
                        self.value(value, None);
                    }
                }
            }
            ItemKind::Preset { for_variant, params, .. } => {
                if let Some(p) = for_variant
                    && let [en, v] = p.parts.as_slice()
                    && let Some(e) = self.refer_global(en, &[Sort::Enum])
                {
                    let vid = self.variants.get(&(e, v.name.clone())).copied();
                    self.refer(v.span, vid);
                }
                for (_, n) in params {
                    self.num(n);
                }
            }
            ItemKind::Visible { target, params } => {
                if let Some(t) = target {
                    self.refer_global(t, &[Sort::Kind, Sort::Tag, Sort::Concept, Sort::Modifier]);
                }
                for (_, n) in params {
                    self.num(n);
                }
            }
            ItemKind::Camera { stmts } => {
                for st in stmts {
                    match st {
                        CameraStmt::At(v, _) | CameraStmt::LookAt(v, _) => v.iter().for_each(|n| self.num(n)),
                        CameraStmt::Fov(n) => self.num(n),
                        CameraStmt::Size { .. } => {}
                    }
                }
            }
            ItemKind::Stage { opts, parts, .. } => {
                for o in opts {
                    match o {
                        StageOpt::At(v, _) => v.iter().for_each(|n| self.num(n)),
                        StageOpt::Repeat { step, .. } => step.iter().for_each(|n| self.num(n)),
                        StageOpt::When(e, _) => self.expr(e, &mut Vec::new(), None),
                    }
                }
                self.parts(parts, None);
            }
            ItemKind::Concept { name, stmts, .. } => self.concept(s, name, stmts),
            ItemKind::Constraint { members, .. } => {
                for m in members {
                    if let Member::Name(n) = m {
                        self.refer_global(n, &[Sort::Concept, Sort::Modifier]);
                    }
                }
            }
            ItemKind::Rules { rules, .. } => {
                for r in rules {
                    for st in &r.stmts {
                        match st {
                            RuleStmt::When(e, _) => self.expr(e, &mut Vec::new(), None),
                            RuleStmt::Expect(p) => self.expect(p, r),
                            RuleStmt::Elements(names, _) => {
                                for n in names {
                                    self.refer_global(n, &[Sort::Concept, Sort::Modifier]);
                                }
                            }
                            RuleStmt::Safe(_) => {}
                        }
                    }
                }
            }
            _ => {}
        }
    }

    /// Parents of kinds and tags, and the enums attribute types name.
    fn link_item(&mut self, item: &Item) {
        const KT: &[Sort] = &[Sort::Kind, Sort::Tag];
        if let ItemKind::Tag { name, parents } | ItemKind::Kind { name, parents, .. } = &item.kind {
            let me = self.global(KT, &name.name);
            let ps: Vec<usize> = parents.iter().filter_map(|p| self.refer_global(p, KT)).collect();
            if let Some(me) = me.filter(|&m| self.symbols[m].decl == name.span) {
                self.parents.insert(me, ps);
            }
        }
        if let ItemKind::Kind { attrs, .. } | ItemKind::World { attrs } = &item.kind {
            for a in attrs {
                let en = self.refer_global(&a.ty, &[Sort::Enum]);
                if let (Some(e), Some(id)) = (en, self.attr_id_at(a.name.span)) {
                    self.attr_enum.insert(id, e);
                }
            }
        }
    }

    /// Bounds and defaults of attribute declarations.
    fn attr_values(&mut self, attrs: &[AttrDecl]) {
        for a in attrs {
            if let Some((lo, hi)) = &a.bounds {
                self.num(lo);
                self.num(hi);
            }
            let id = self.attr_id_at(a.name.span);
            self.value(&a.default, id);
        }
    }

    fn attr_id_at(&self, span: Span) -> Option<usize> {
        self.symbols.iter().position(|s| s.decl == span && matches!(s.sort, Sort::Attr | Sort::WorldAttr))
    }

    fn num(&mut self, n: &Num) {
        if let Some(u) = &n.unit {
            self.refer_global(u, &[Sort::Unit]);
        }
    }

    /// A value given to attribute `attr`: a variant of its enum, or a number with a unit.
    fn value(&mut self, v: &ValueLit, attr: Option<usize>) {
        match v {
            ValueLit::Num(n) => self.num(n),
            ValueLit::Range(a, b) => {
                self.num(a);
                self.num(b);
            }
            ValueLit::Bool(..) => {}
            ValueLit::Name(name) => {
                let id = match attr.and_then(|a| self.enum_of_attr(a)) {
                    Some(e) => self.variants.get(&(e, name.name.clone())).copied(),
                    // The attribute is unknown: a variant of that name, if only one enum has it.
                    None => {
                        let mut found = self.variants.iter().filter(|((_, n), _)| *n == name.name).map(|(_, &v)| v);
                        match (found.next(), found.next()) {
                            (Some(v), None) => Some(v),
                            _ => None,
                        }
                    }
                };
                self.refer(name.span, id);
            }
        }
    }

    fn concept(&mut self, s: &Source, concept: &Ident, stmts: &[ConceptStmt]) {
        let me = self.global(&[Sort::Concept, Sort::Modifier], &concept.name);
        // Entities added so far, with their kind; a modifier's target kinds.
        let mut entities: Vec<(String, usize, Option<usize>)> = Vec::new();
        let mut targets: Option<Vec<usize>> = None;
        let mut world_target = false;
        for st in stmts {
            match st {
                ConceptStmt::Add { name, kind, region, relation, attrs, span } => {
                    let id = self.add(Sort::Entity, name, *span, s.text);
                    self.symbols[id].parent = me;
                    let k = self.refer_global(kind, &[Sort::Kind, Sort::Tag]);
                    self.refer_global(region, &[Sort::Region]);
                    if let Some((rel, target)) = relation {
                        self.refer_global(rel, &[Sort::Relation]);
                        let e = entities.iter().find(|(n, _, _)| *n == target.name).map(|(_, e, _)| *e);
                        self.refer(target.span, e);
                    }
                    let kinds = k.map(|k| self.kinds_matching(&[k])).unwrap_or_default();
                    for (n, v) in attrs {
                        let a = self.attr_in(&kinds, &n.name);
                        self.refer(n.span, a);
                        self.value(v, a);
                    }
                    entities.push((name.name.clone(), id, k));
                }
                ConceptStmt::Set { path, value, .. } => {
                    let attr = match path.parts.as_slice() {
                        [w, a] if w.name == "world" => {
                            let id = self.world_attr(&a.name);
                            self.refer(a.span, id)
                        }
                        [a] if world_target => {
                            let id = self.world_attr(&a.name);
                            self.refer(a.span, id)
                        }
                        [a] => {
                            let kinds = targets.clone().unwrap_or_default();
                            let id = self.attr_in(&kinds, &a.name);
                            self.refer(a.span, id)
                        }
                        _ => None,
                    };
                    self.value(value, attr);
                }
                ConceptStmt::Target { world, filter, .. } => {
                    world_target = world.is_some();
                    let ids: Vec<usize> =
                        filter.iter().filter_map(|f| self.refer_global(f, &[Sort::Kind, Sort::Tag])).collect();
                    targets = Some(self.kinds_matching(&ids));
                }
                ConceptStmt::Move { region, .. } => {
                    self.refer_global(region, &[Sort::Region]);
                }
                ConceptStmt::Shape(parts) => self.parts(parts, None),
                _ => {}
            }
        }
    }

    fn world_attr(&self, name: &str) -> Option<usize> {
        self.world_attrs().into_iter().find(|&a| self.symbols[a].name == name)
    }

    fn parts(&mut self, parts: &Parts, kind: Option<usize>) {
        for part in &parts.parts {
            for p in &part.props {
                match p {
                    PartProp::Size(v, _) | PartProp::At(v, _) => v.iter().for_each(|n| self.num(n)),
                    PartProp::Yaw(n) | PartProp::Roll(n) | PartProp::Pitch(n) => self.num(n),
                    PartProp::When(e, _) => self.expr(e, &mut Vec::new(), kind),
                    PartProp::Color(..) | PartProp::Material(_) => {}
                }
            }
        }
    }

    fn expect(&mut self, p: &Path, rule: &RuleDecl) {
        let [q, o] = p.parts.as_slice() else { return };
        let Some(qid) = self.refer_global(q, &[Sort::Question]) else { return };
        let oid = self.options.get(&(qid, o.name.clone())).copied();
        self.refer(o.span, oid);
        if let (Some(oid), Some(rid)) = (oid, self.global(&[Sort::Rule], &rule.name.name)) {
            let text = self.symbols[oid].notes.first().cloned().unwrap_or_default();
            self.symbols[rid].notes.push(format!("expects `{}.{}`: {text}", q.name, o.name));
        }
    }

    /// Resolve the names of an expression; `vars` are the `exists` variables in scope (name,
    /// symbol, kinds they range over), `self_kind` the kind a look or shape draws.
    fn expr(&mut self, e: &Expr, vars: &mut Vec<(String, usize, Vec<usize>)>, self_kind: Option<usize>) {
        match &e.kind {
            ExprKind::Bool(_) => {}
            ExprKind::Not(x) => self.expr(x, vars, self_kind),
            ExprKind::And(xs) | ExprKind::Or(xs) => xs.iter().for_each(|x| self.expr(x, vars, self_kind)),
            ExprKind::Has(c) => {
                self.refer_global(c, &[Sort::Concept, Sort::Modifier]);
            }
            ExprKind::Exists { var, filter, cond } => {
                let ids: Vec<usize> =
                    filter.iter().filter_map(|f| self.refer_global(f, &[Sort::Kind, Sort::Tag])).collect();
                let full = Span { end: filter.last().map_or(var.span.end, |f| f.span.end), ..var.span };
                let id = self.add(Sort::Var, var, full, "");
                let names: Vec<&str> = filter.iter().map(|f| f.name.as_str()).collect();
                self.symbols[id].snippet = format!("exists {}: {}", var.name, names.join(" | "));
                vars.push((var.name.clone(), id, self.kinds_matching(&ids)));
                if let Some(c) = cond {
                    self.expr(c, vars, self_kind);
                }
                vars.pop();
            }
            ExprKind::Count { filter, .. } => {
                for f in filter {
                    self.refer_global(f, &[Sort::Kind, Sort::Tag]);
                }
            }
            ExprKind::In { var, region } => {
                let v = vars.iter().rev().find(|(n, _, _)| *n == var.name).map(|(_, id, _)| *id);
                self.refer(var.span, v);
                self.refer_global(region, &[Sort::Region]);
            }
            ExprKind::Cmp { path, value, .. } => {
                let attr = self.path_attr(path, vars, self_kind);
                self.value(value, attr);
            }
            ExprKind::CmpAttrs { left, right, .. } => {
                self.path_attr(left, vars, self_kind);
                self.path_attr(right, vars, self_kind);
            }
            ExprKind::Related { var, relation, to } => {
                for v in [var, to] {
                    if v.name != "ego" {
                        let id = vars.iter().rev().find(|(n, _, _)| *n == v.name).map(|(_, id, _)| *id);
                        self.refer(v.span, id);
                    }
                }
                self.refer_global(relation, &[Sort::Relation]);
            }
        }
    }

    /// Resolve `world.ATTR`, `self.ATTR` or `VAR.ATTR` in a condition; the attribute's symbol.
    fn path_attr(
        &mut self,
        path: &Path,
        vars: &[(String, usize, Vec<usize>)],
        self_kind: Option<usize>,
    ) -> Option<usize> {
        match path.parts.as_slice() {
            [w, a] if w.name == "world" => {
                let id = self.world_attr(&a.name);
                self.refer(a.span, id)
            }
            [s, a] if s.name == "self" => {
                let kinds = self_kind.map(|k| self.kinds_matching(&[k])).unwrap_or_default();
                let id = self.attr_in(&kinds, &a.name);
                self.refer(a.span, id)
            }
            [v, a] => match vars.iter().rev().find(|(n, _, _)| *n == v.name).cloned() {
                Some((_, vid, kinds)) => {
                    self.refer(v.span, Some(vid));
                    let id = self.attr_in(&kinds, &a.name);
                    self.refer(a.span, id)
                }
                None => None,
            },
            _ => None,
        }
    }
}

fn space_of(sort: Sort) -> Option<Space> {
    Some(match sort {
        Sort::Unit => Space::Unit,
        Sort::Enum => Space::Enum,
        Sort::Kind | Sort::Tag => Space::KindOrTag,
        Sort::Relation => Space::Relation,
        Sort::Region => Space::Region,
        Sort::Preset => Space::Preset,
        Sort::Stage => Space::Stage,
        Sort::Concept | Sort::Modifier => Space::Concept,
        Sort::Constraint => Space::Constraint,
        Sort::Question => Space::Question,
        Sort::Rule => Space::Rule,
        _ => return None,
    })
}

/// Hover paragraphs of a concept: description, category, probe.
fn concept_notes(stmts: &[ConceptStmt]) -> Vec<String> {
    let mut out = Vec::new();
    for st in stmts {
        match st {
            ConceptStmt::Description(d) => out.push(d.value.clone()),
            ConceptStmt::Category(c) => out.push(format!("category: {}", c.value)),
            ConceptStmt::Probe { positive, negative, .. } => {
                out.push(format!("probe: “{}” / not: “{}”", positive.value, negative.value));
            }
            _ => {}
        }
    }
    out
}

//! Every named thing of a compilation and every place it is named: what hover, go to
//! definition, find references, completion and semantic tokens read.
//!
//! The symbols come from the syntax trees of all files a document loads (its `use`d modules and
//! the embedded stdlib included): items, attributes (of a kind or of the world), variants of an
//! enum, options of a question, entities a concept adds, `exists` variables. Where each name is
//! used comes from the checker, which records every name it resolves
//! ([`crate::check::Compiled::references`]): there is one resolver, so the editor and
//! `revelio check` never disagree on what a name means. A name that does not resolve is simply
//! not indexed — the checker reports it.

use std::collections::HashMap;

use crate::check::Reference;
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
    /// The symbols the syntax trees declare, and the occurrences the checker resolved
    /// (`references`, from [`crate::check::Compiled`]): names are resolved once, by the checker.
    pub fn build(sources: &[Source], references: &[Reference]) -> Index {
        let mut ix = Index::default();
        for s in sources {
            ix.declare_file(s);
        }
        for s in sources {
            for item in &s.tree.items {
                ix.declare_locals(s, item);
            }
        }
        ix.link(sources, references);
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

    /// Where a condition binds a variable (`exists v: …`): a symbol for each, so that the
    /// checker's references to it have somewhere to point.
    fn declare_vars(&mut self, e: &Expr) {
        match &e.kind {
            ExprKind::Not(x) => self.declare_vars(x),
            ExprKind::And(xs) | ExprKind::Or(xs) => xs.iter().for_each(|x| self.declare_vars(x)),
            ExprKind::Exists { var, filter, cond } => {
                let full = Span { end: filter.last().map_or(var.span.end, |f| f.span.end), ..var.span };
                let id = self.add(Sort::Var, var, full, "");
                let names: Vec<&str> = filter.iter().map(|f| f.name.as_str()).collect();
                self.symbols[id].snippet = format!("exists {}: {}", var.name, names.join(" | "));
                if let Some(c) = cond {
                    self.declare_vars(c);
                }
            }
            _ => {}
        }
    }

    /// The entities a concept adds, and the variables its conditions bind.
    fn declare_locals(&mut self, s: &Source, item: &Item) {
        if let ItemKind::Concept { name, stmts, .. } = &item.kind {
            let me = self.global(&[Sort::Concept, Sort::Modifier], &name.name);
            for st in stmts {
                if let ConceptStmt::Add { name, span, .. } = st {
                    let id = self.add(Sort::Entity, name, *span, s.text);
                    self.symbols[id].parent = me;
                }
            }
        }
        for e in conditions(item) {
            self.declare_vars(e);
        }
    }

    /// The checker's references as occurrences, and what hover and completion derive from
    /// them: the parents of kinds and tags, the enum an attribute's type names, and the option
    /// each rule expects.
    fn link(&mut self, sources: &[Source], references: &[Reference]) {
        let mut by_decl: HashMap<Span, usize> = HashMap::new();
        for (id, sym) in self.symbols.iter().enumerate() {
            by_decl.entry(sym.decl).or_insert(id);
            // The checker names an attribute by its whole declaration.
            if matches!(sym.sort, Sort::Attr | Sort::WorldAttr) {
                by_decl.entry(sym.full).or_insert(id);
            }
        }
        let mut by_use: HashMap<Span, usize> = HashMap::new();
        for r in references {
            if let Some(&id) = by_decl.get(&r.decl) {
                self.occurrences.push((r.at, id));
                by_use.insert(r.at, id);
            }
        }
        let of = |name: &Ident| by_use.get(&name.span).copied();
        for s in sources {
            for item in &s.tree.items {
                if let ItemKind::Tag { name, parents } | ItemKind::Kind { name, parents, .. } = &item.kind {
                    let me = by_decl.get(&name.span).copied();
                    let ps: Vec<usize> = parents.iter().filter_map(of).collect();
                    if let Some(me) = me {
                        self.parents.insert(me, ps);
                    }
                }
                if let ItemKind::Kind { attrs, .. } | ItemKind::World { attrs } = &item.kind {
                    for a in attrs {
                        let en = of(&a.ty).filter(|&e| self.symbols[e].sort == Sort::Enum);
                        if let (Some(e), Some(&id)) = (en, by_decl.get(&a.name.span)) {
                            self.attr_enum.insert(id, e);
                        }
                    }
                }
                if let ItemKind::Rules { rules, .. } = &item.kind {
                    for r in rules {
                        for st in &r.stmts {
                            if let RuleStmt::Expect(p) = st
                                && let [q, o] = p.parts.as_slice()
                                && let (Some(oid), Some(&rid)) = (of(o), by_decl.get(&r.name.span))
                            {
                                let text = self.symbols[oid].notes.first().cloned().unwrap_or_default();
                                self.symbols[rid].notes.push(format!("expects `{}.{}`: {text}", q.name, o.name));
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The conditions of an item: `when` of rules, stage items and shape parts.
fn conditions(item: &Item) -> Vec<&Expr> {
    fn parts_conditions<'a>(parts: &'a Parts, out: &mut Vec<&'a Expr>) {
        for part in &parts.parts {
            for p in &part.props {
                if let PartProp::When(e, _) = p {
                    out.push(e);
                }
            }
        }
    }
    let mut out = Vec::new();
    match &item.kind {
        ItemKind::Kind { shapes, .. } => shapes.iter().for_each(|p| parts_conditions(p, &mut out)),
        ItemKind::Look { parts, .. } => parts_conditions(parts, &mut out),
        ItemKind::Stage { opts, parts, .. } => {
            for o in opts {
                if let StageOpt::When(e, _) = o {
                    out.push(e);
                }
            }
            parts_conditions(parts, &mut out);
        }
        ItemKind::Concept { stmts, .. } => {
            for st in stmts {
                if let ConceptStmt::Shape(parts) = st {
                    parts_conditions(parts, &mut out);
                }
            }
        }
        ItemKind::Rules { rules, .. } => {
            for r in rules {
                for st in &r.stmts {
                    if let RuleStmt::When(e, _) = st {
                        out.push(e);
                    }
                }
            }
        }
        _ => {}
    }
    out
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

//! Tags and kinds: tag ancestry, kind inheritance (attributes and tags), and kind/tag filters.
//!
//! A kind's parents may be tags and kinds: it inherits the attributes of its parent kinds, and
//! [`Kind::tags`] holds every tag it carries, directly or through a parent tag or kind. A filter
//! that names a kind matches that kind and all kinds that descend from it (the checker lists
//! them in [`TargetFilter::kinds`]). Cycles are reported once and cut.

use super::lower::{Checker, Progress, TypeSym, push_unique};
use super::names::unknown;
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::*;
use crate::syntax::ast::{Ident, ItemKind};

impl Checker<'_> {
    pub(super) fn lower_tags(&mut self) {
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
            Some(&t) => {
                self.refer(name, self.types.span(&name.name));
                Some(t)
            }
            None => {
                let d = unknown(sort, name, self.types.names());
                self.error(d);
                None
            }
        }
    }

    pub(super) fn lower_kinds(&mut self) {
        for k in 0..self.d.kinds.len() {
            self.lower_kind(KindId(k as u32));
        }
    }

    fn lower_kind(&mut self, k: KindId) {
        let item = self.kind_items[k.index()];
        let ItemKind::Kind { name, parents, attrs, stands_in, .. } = &item.kind else {
            unreachable!("kind items are kinds")
        };
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
        // Regions a parent kind restricts its entities to; a child stays inside every such list.
        let mut parent_regions: Option<Vec<RegionId>> = None;
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
                    let theirs = self.d.kinds[pk.index()].regions.clone();
                    if !theirs.is_empty() {
                        parent_regions = Some(match parent_regions {
                            None => theirs,
                            Some(mine) => mine.into_iter().filter(|r| theirs.contains(r)).collect(),
                        });
                    }
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
        let regions = self.lower_stands_in(stands_in).or(parent_regions).unwrap_or_default();
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
        kind.regions = regions;
        self.kind_progress[k.index()] = Progress::Done;
    }

    /// `in REGION, …` statements of a kind (`None` when it has none); unknown regions are
    /// reported, and a second statement is a duplicate.
    fn lower_stands_in(&mut self, lists: &[Vec<Ident>]) -> Option<Vec<RegionId>> {
        let first = lists.first()?;
        if let Some(second) = lists.get(1).and_then(|l| l.first()) {
            let prev = first.first().map_or(second.span, |i| i.span);
            self.error(super::lower::duplicate_statement("in", second.span, prev));
        }
        let mut out = Vec::new();
        for r in first {
            match self.regions.get(&r.name) {
                Some(&id) => {
                    self.refer(r, self.regions.span(&r.name));
                    push_unique(&mut out, id);
                }
                None => {
                    let d = unknown("region", r, self.regions.names());
                    self.error(d);
                }
            }
        }
        Some(out)
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
}

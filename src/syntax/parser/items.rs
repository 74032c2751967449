//! Items: the top-level declarations of a file.

use pest::iterators::Pair;

use super::{Builder, Children};
use crate::syntax::ast::*;
use crate::syntax::grammar::Rule;

impl Builder<'_> {
    pub(super) fn item(&mut self, p: Pair<Rule>) -> Item {
        let span = self.span(&p);
        let doc = self.doc_at(span.start);
        let rule = p.as_rule();
        let errors_before = self.diagnostics.len();
        let mut c = Children::of(p.clone());
        let kind = match rule {
            Rule::domain_item => ItemKind::Domain(self.ident(c.next())),
            Rule::use_item => self.use_item(c.next()),
            Rule::unit_item => {
                let name = self.ident(c.next());
                let dimension = self.ident(c.next());
                ItemKind::Unit { name, dimension, scale: self.number(c.next()) }
            }
            Rule::enum_item => {
                let name = self.ident(c.next());
                ItemKind::Enum { name, variants: self.idents(c) }
            }
            Rule::tag_item => {
                let name = self.ident(c.next());
                let parents = c.next_if(Rule::parents).map(|p| self.idents(Children::of(p))).unwrap_or_default();
                ItemKind::Tag { name, parents }
            }
            Rule::relation_item => {
                let name = self.ident(c.next());
                let text = self.string(c.next());
                let placements = c.next_if(Rule::placements).map(|b| self.placements(b));
                ItemKind::Relation { name, text, placements }
            }
            Rule::kind_item => self.kind_item(c),
            Rule::look_item => {
                let kind = self.ident(c.next());
                ItemKind::Look { kind, parts: self.parts(c.next()) }
            }
            Rule::world_item => ItemKind::World { attrs: self.attr_list(c) },
            Rule::region_item => {
                let name = self.ident(c.next());
                let stmts = c.rest().filter_map(|p| self.region_stmt(p)).collect();
                ItemKind::Region { name, stmts }
            }
            Rule::preset_item => self.preset_item(c),
            Rule::visible_item => self.visible_item(c),
            Rule::camera_item => ItemKind::Camera { stmts: c.rest().filter_map(|p| self.camera_stmt(p)).collect() },
            Rule::stage_item => self.stage_item(c),
            Rule::concept_item | Rule::modifier_item => {
                let name = self.ident(c.next());
                let stmts = self.concept_body(c.next());
                ItemKind::Concept { modifier: rule == Rule::modifier_item, name, stmts }
            }
            Rule::constraint_item => self.constraint_item(c),
            Rule::question_item => {
                let name = self.ident(c.next());
                ItemKind::Question { name, stmts: c.rest().filter_map(|p| self.question_stmt(p)).collect() }
            }
            Rule::allow_item => ItemKind::Allow { code: self.ident(c.next()) },
            Rule::rules_item => {
                let selection = self.ident(c.next());
                let rules = c.rest().filter_map(|p| self.rule_item(p)).collect();
                ItemKind::Rules { selection, rules }
            }
            _ => {
                self.junk(p);
                ItemKind::Error
            }
        };
        Item { doc, span, kind, broken: self.diagnostics.len() > errors_before }
    }

    pub(super) fn use_item(&mut self, p: Pair<Rule>) -> ItemKind {
        match p.as_rule() {
            Rule::std_path => ItemKind::Use(UseTarget::Std(self.ident(Children::of(p).next()))),
            _ => ItemKind::Use(UseTarget::File(self.string(p))),
        }
    }

    pub(super) fn kind_item(&mut self, mut c: Children) -> ItemKind {
        let name = self.ident(c.next());
        let parents = c.next_if(Rule::parents).map(|p| self.idents(Children::of(p))).unwrap_or_default();
        let mut attrs = Vec::new();
        let mut shapes = Vec::new();
        let mut stands_in = Vec::new();
        for p in c.rest() {
            match p.as_rule() {
                Rule::shape_block => shapes.push(self.parts(Children::of(p).next())),
                Rule::attr_decl => attrs.push(self.attr_decl(p)),
                Rule::stands_in => stands_in.push(self.idents(Children::of(p))),
                _ => self.junk(p),
            }
        }
        ItemKind::Kind { name, parents, attrs, shapes, stands_in }
    }

    /// A relation's `{ distance 0m..1.5m  on_top }` body.
    pub(super) fn placements(&mut self, p: Pair<Rule>) -> Vec<Placement> {
        let mut out = Vec::new();
        for w in Children::of(p).rest() {
            if w.as_rule() != Rule::placement {
                self.junk(w);
                continue;
            }
            let span = self.span(&w);
            let mut c = Children::of(w);
            let word = self.ident(c.next());
            let range = c.next_if(Rule::number).map(|lo| {
                let lo = self.number(lo);
                (lo, self.number(c.next()))
            });
            out.push(Placement { word, range, span });
        }
        out
    }

    pub(super) fn attr_list(&mut self, c: Children) -> Vec<AttrDecl> {
        let mut attrs = Vec::new();
        for p in c.rest() {
            match p.as_rule() {
                Rule::attr_decl => attrs.push(self.attr_decl(p)),
                _ => self.junk(p),
            }
        }
        attrs
    }

    pub(super) fn attr_decl(&mut self, p: Pair<Rule>) -> AttrDecl {
        let span = self.span(&p);
        let doc = self.doc_at(span.start);
        let mut c = Children::of(p);
        let name = self.ident(c.next());
        let ty = self.ident(c.next());
        let bounds = c.next_if(Rule::attr_bounds).map(|b| {
            let mut bc = Children::of(b);
            let lo = self.number(bc.next());
            (lo, self.number(bc.next()))
        });
        let default = self.value(c.next());
        AttrDecl { doc, name, ty, bounds, default, span }
    }

    /// `name = number` parameters (of a preset or a `visible` item) up to the block's end.
    fn preset_params(&mut self, c: Children) -> Vec<(Ident, Num)> {
        let mut params = Vec::new();
        for p in c.rest() {
            if p.as_rule() == Rule::preset_param {
                let mut pc = Children::of(p);
                let n = self.ident(pc.next());
                params.push((n, self.number(pc.next())));
            } else {
                self.junk(p);
            }
        }
        params
    }

    pub(super) fn preset_item(&mut self, mut c: Children) -> ItemKind {
        let name = self.ident(c.next());
        let for_variant = c.next_if(Rule::path).map(|p| self.path(p));
        let params = self.preset_params(c);
        ItemKind::Preset { name, for_variant, params }
    }

    pub(super) fn visible_item(&mut self, mut c: Children) -> ItemKind {
        let target = c.next_if(Rule::ident).map(|p| self.ident(p));
        let params = self.preset_params(c);
        ItemKind::Visible { target, params }
    }

    pub(super) fn stage_item(&mut self, mut c: Children) -> ItemKind {
        let name = self.ident(c.next());
        let mut opts = Vec::new();
        let mut parts = None;
        for p in c.rest() {
            match p.as_rule() {
                Rule::stage_opt => opts.push(self.stage_opt(p)),
                _ => parts = Some(self.parts(p)),
            }
        }
        let parts = parts.expect("a stage item ends with its parts");
        ItemKind::Stage { name, opts, parts }
    }

    pub(super) fn stage_opt(&mut self, p: Pair<Rule>) -> StageOpt {
        let span = self.span(&p);
        let mut c = Children::of(p);
        match c.first_token() {
            Some(Rule::kw_at) => StageOpt::At(self.vec3(c.next()), span),
            Some(Rule::kw_repeat) => {
                let count = self.int(c.next());
                StageOpt::Repeat { count, step: self.vec3(c.next()), span }
            }
            _ => StageOpt::When(self.expr(c.next()), span),
        }
    }

    pub(super) fn constraint_item(&mut self, mut c: Children) -> ItemKind {
        let name = self.ident(c.next());
        let func = self.ident(c.next());
        let count = c.next_if(Rule::int).map(|p| {
            let s = self.span(&p);
            (self.int(p), s)
        });
        let members = c
            .rest()
            .map(|m| {
                let mut mc = Children::of(m);
                match mc.first_token() {
                    Some(Rule::kw_category) => Member::Category(self.string(mc.next())),
                    _ => {
                        let p = mc.next();
                        if p.as_rule() == Rule::wildcard {
                            Member::Wildcard(self.ident(p))
                        } else {
                            Member::Name(self.ident(p))
                        }
                    }
                }
            })
            .collect();
        ItemKind::Constraint { name, func, count, members }
    }
}

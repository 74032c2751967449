//! Statements inside item bodies, and shape parts.

use pest::iterators::Pair;

use super::{Builder, Children};
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::Primitive;
use crate::syntax::ast::*;
use crate::syntax::grammar::Rule;

impl Builder<'_> {
    pub(super) fn concept_body(&mut self, p: Pair<Rule>) -> Vec<ConceptStmt> {
        Children::of(p).rest().filter_map(|s| self.concept_stmt(s)).collect()
    }

    pub(super) fn concept_stmt(&mut self, p: Pair<Rule>) -> Option<ConceptStmt> {
        if p.as_rule() != Rule::concept_stmt {
            self.junk(p);
            return None;
        }
        // A statement ends at its last token, not at the blank lines or comment after it (the
        // lookahead for the next statement consumed those).
        let mut span = self.span(&p);
        span.end = p.clone().into_inner().last().map_or(span.end, |t| t.as_span().end() as u32);
        let mut c = Children::of(p);
        let first = c.first_token();
        Some(match first {
            Some(Rule::kw_description) => ConceptStmt::Description(self.string(c.next())),
            Some(Rule::kw_category) => ConceptStmt::Category(self.string(c.next())),
            Some(Rule::kw_add) => {
                let name = self.ident(c.next());
                let kind = self.ident(c.next());
                let region = self.ident(c.next());
                let relation = c.next_if(Rule::relation_to).map(|r| {
                    let mut rc = Children::of(r);
                    let rel = self.ident(rc.next());
                    (rel, self.ident(rc.next()))
                });
                let attrs = c
                    .next_if(Rule::attr_values)
                    .map(|a| {
                        Children::of(a)
                            .rest()
                            .map(|av| {
                                let mut ac = Children::of(av);
                                let n = self.ident(ac.next());
                                (n, self.value(ac.next()))
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                ConceptStmt::Add { name, kind, region, relation, attrs, span }
            }
            Some(Rule::kw_set) => {
                let path = self.path(c.next());
                ConceptStmt::Set { path, value: self.value(c.next()), span }
            }
            Some(Rule::kw_probe) => {
                let positive = self.string(c.next());
                ConceptStmt::Probe { positive, negative: self.string(c.next()), span }
            }
            Some(Rule::kw_scenic) => ConceptStmt::Scenic(self.string(c.next())),
            Some(Rule::kw_prompt) => ConceptStmt::Prompt(self.string(c.next())),
            Some(Rule::shape_block) => ConceptStmt::Shape(self.parts(Children::of(c.next()).next())),
            Some(Rule::kw_target) => {
                c.pairs.next();
                match c.first_token() {
                    Some(Rule::kw_world) => {
                        let w = c.pairs.next().expect("peeked");
                        ConceptStmt::Target { world: Some(self.span(&w)), filter: Vec::new(), span }
                    }
                    _ => ConceptStmt::Target { world: None, filter: self.idents(Children::of(c.next())), span },
                }
            }
            Some(Rule::kw_drawn_by) => ConceptStmt::DrawnBy { stage: self.ident(c.next()), span },
            _ => ConceptStmt::Move { region: self.ident(c.next()), span },
        })
    }

    pub(super) fn region_stmt(&mut self, p: Pair<Rule>) -> Option<RegionStmt> {
        if p.as_rule() != Rule::region_stmt {
            self.junk(p);
            return None;
        }
        let mut c = Children::of(p);
        Some(match c.first_token() {
            Some(Rule::axis) => {
                let axis = self.ident(c.next());
                RegionStmt::Axis { axis, value: self.value(c.next()) }
            }
            _ => RegionStmt::Scenic(self.string(c.next())),
        })
    }

    pub(super) fn camera_stmt(&mut self, p: Pair<Rule>) -> Option<CameraStmt> {
        if p.as_rule() != Rule::camera_stmt {
            self.junk(p);
            return None;
        }
        let span = self.span(&p);
        let mut c = Children::of(p);
        Some(match c.first_token() {
            Some(Rule::kw_at) => CameraStmt::At(self.vec3(c.next()), span),
            Some(Rule::kw_look_at) => CameraStmt::LookAt(self.vec3(c.next()), span),
            Some(Rule::kw_fov) => CameraStmt::Fov(self.number(c.next())),
            _ => {
                let dims = c.next();
                let dspan = self.span(&dims);
                let mut dc = Children::of(dims);
                let width = self.int(dc.next());
                let height = self.int(dc.next());
                CameraStmt::Size { width, height, span: dspan }
            }
        })
    }

    pub(super) fn question_stmt(&mut self, p: Pair<Rule>) -> Option<QuestionStmt> {
        if p.as_rule() != Rule::question_stmt {
            self.junk(p);
            return None;
        }
        let mut c = Children::of(p);
        Some(match c.first_token() {
            Some(Rule::kw_text) => QuestionStmt::Text(self.string(c.next())),
            _ => {
                let name = self.ident(c.next());
                QuestionStmt::Option { name, text: self.string(c.next()) }
            }
        })
    }

    pub(super) fn rule_item(&mut self, p: Pair<Rule>) -> Option<RuleDecl> {
        if p.as_rule() != Rule::rule_item {
            self.junk(p);
            return None;
        }
        let span = self.span(&p);
        let doc = self.doc_at(span.start);
        let mut c = Children::of(p);
        let name = self.ident(c.next());
        let stmts = c.rest().filter_map(|s| self.rule_stmt(s)).collect();
        Some(RuleDecl { doc, name, stmts, span })
    }

    pub(super) fn rule_stmt(&mut self, p: Pair<Rule>) -> Option<RuleStmt> {
        if p.as_rule() != Rule::rule_stmt {
            self.junk(p);
            return None;
        }
        let span = self.span(&p);
        let mut c = Children::of(p);
        Some(match c.first_token() {
            Some(Rule::kw_when) => RuleStmt::When(self.expr(c.next()), span),
            Some(Rule::kw_expect) => RuleStmt::Expect(self.path(c.next())),
            Some(Rule::kw_elements) => RuleStmt::Elements(self.idents(c), span),
            _ => RuleStmt::Safe(span),
        })
    }

    // ------------------------------------------------------------------ shapes

    pub(super) fn parts(&mut self, p: Pair<Rule>) -> Parts {
        let span = self.span(&p);
        let mut parts = Vec::new();
        for part in Children::of(p).rest() {
            if part.as_rule() == Rule::shape_part {
                parts.push(self.shape_part(part));
            } else {
                self.junk(part);
            }
        }
        Parts { parts, span }
    }

    pub(super) fn shape_part(&mut self, p: Pair<Rule>) -> ShapePart {
        let span = self.span(&p);
        let mut c = Children::of(p);
        let prim = match c.next().as_str() {
            "box" => Primitive::Box,
            "cylinder" => Primitive::Cylinder,
            "capsule" => Primitive::Capsule,
            "sphere" => Primitive::Sphere,
            "plane" => Primitive::Plane,
            _ => Primitive::Cone,
        };
        let props = c.rest().map(|prop| self.part_prop(prop)).collect();
        ShapePart { prim, props, span }
    }

    pub(super) fn part_prop(&mut self, p: Pair<Rule>) -> PartProp {
        let span = self.span(&p);
        let mut c = Children::of(p);
        match c.first_token() {
            Some(Rule::kw_size) => PartProp::Size(self.vec3(c.next()), span),
            Some(Rule::kw_at) => PartProp::At(self.vec3(c.next()), span),
            Some(Rule::kw_color) => {
                let col = c.next();
                let cspan = self.span(&col);
                let text = col.as_str().to_string();
                if !matches!(text.len(), 7 | 9) {
                    self.diagnostics.push(
                        Diagnostic::error(codes::INVALID_LITERAL, cspan, format!("invalid colour `{text}`"))
                            .with_label("expected 6 or 8 hex digits")
                            .with_help("write colours as `#rrggbb` or `#rrggbbaa`"),
                    );
                }
                PartProp::Color(text, cspan)
            }
            Some(Rule::kw_material) => PartProp::Material(self.ident(c.next())),
            Some(Rule::kw_yaw) => PartProp::Yaw(self.number(c.next())),
            Some(Rule::kw_roll) => PartProp::Roll(self.number(c.next())),
            Some(Rule::kw_pitch) => PartProp::Pitch(self.number(c.next())),
            Some(Rule::kw_shadow) => PartProp::Shadow(c.next().as_str() == "true", span),
            _ => PartProp::When(self.expr(c.next()), span),
        }
    }
}

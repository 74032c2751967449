//! Text → syntax tree, with error recovery (grammar: `grammar/revelio.pest`).
//!
//! Naming rule: a function named after a grammar rule (`concept_stmt`, `value`, `vec3`, …)
//! takes one pest pair *of that rule* and returns its syntax-tree node; it never fails, because
//! the grammar already guaranteed the shape (malformed literals are reported and replaced by a
//! neutral value). `junk_*` functions turn a recovery node into a diagnostic. `next_*` helpers
//! pull the next child of a given sort from a [`Children`] cursor, skipping keyword tokens.
//!
//! Parsing never fails: pest only errs at the file level when the call limit stops
//! pathological nesting, and that becomes a diagnostic too.

use std::num::NonZeroUsize;

use pest::Parser;
use pest::iterators::Pair;

use super::ast::*;
use crate::diag::Diagnostic;
use crate::diag::codes;
use crate::ir::{CmpOp, Primitive, Span};

#[derive(pest_derive::Parser)]
#[grammar = "../grammar/revelio.pest"]
struct RevParser;

/// Rule calls allowed per parse: plenty for real files (a domain takes well under a million),
/// small enough to stop `((((…` bombs quickly.
const CALL_LIMIT: usize = 20_000_000;

/// The result of parsing one file: the tree (with error nodes) and the syntax diagnostics.
#[derive(Debug, Clone)]
pub struct Parsed {
    pub file: File,
    pub diagnostics: Vec<Diagnostic>,
}

/// Parse the text of file number `file` (its index in the compilation's file list).
pub fn parse(file: u32, text: &str) -> Parsed {
    pest::set_call_limit(NonZeroUsize::new(CALL_LIMIT));
    pest::set_error_detail(true);
    let mut b = Builder { file, text, diagnostics: Vec::new() };
    if let Some(pos) = too_deep_at(text) {
        // The tree builder and the checker recurse over nesting; refuse before either runs.
        let span = b.span_at(pos, pos + 1);
        b.diagnostics.push(too_deep(span));
        return Parsed { file: File { items: Vec::new() }, diagnostics: b.diagnostics };
    }
    let items = match RevParser::parse(Rule::file, text) {
        Ok(mut pairs) => {
            let file_pair = pairs.next().expect("the file rule yields one pair");
            file_pair.into_inner().filter(|p| p.as_rule() != Rule::EOI).map(|p| b.item(p)).collect()
        }
        Err(e) => {
            let pos = match e.location {
                pest::error::InputLocation::Pos(p) => p,
                pest::error::InputLocation::Span((s, _)) => s,
            };
            let span = b.span_at(pos, token_end(text, pos));
            b.diagnostics.push(too_deep(span));
            Vec::new()
        }
    };
    Parsed { file: File { items }, diagnostics: b.diagnostics }
}

/// Deepest `(`/`{` nesting accepted; real files stay below 10.
pub const MAX_NESTING: usize = 200;

fn too_deep(span: Span) -> Diagnostic {
    Diagnostic::error(codes::TOO_DEEP, span, "the input nests too deeply to parse")
        .with_label(format!("more than {MAX_NESTING} levels of `(` and `{{`"))
        .with_help("split deeply nested expressions into several rules or `and` terms")
}

/// How many `not`s are chained at this node.
fn not_chain(mut p: Pair<Rule>) -> usize {
    let mut depth = 0;
    while p.as_rule() == Rule::not_expr {
        depth += 1;
        match Children::of(p).rest().next() {
            Some(inner) => p = inner,
            None => break,
        }
    }
    depth
}

/// Where `(`/`{` nesting first exceeds [`MAX_NESTING`], outside strings and comments.
fn too_deep_at(text: &str) -> Option<usize> {
    let bytes = text.as_bytes();
    let (mut depth, mut i) = (0usize, 0usize);
    while i < bytes.len() {
        match bytes[i] {
            b'(' | b'{' => {
                depth += 1;
                if depth > MAX_NESTING {
                    return Some(i);
                }
            }
            b')' | b'}' => depth = depth.saturating_sub(1),
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                i += text[i..].find('\n').unwrap_or(text.len() - i);
            }
            b'"' if text[i..].starts_with("\"\"\"") => {
                i += 3 + text[i + 3..].find("\"\"\"").map_or(text.len() - i - 3, |e| e + 2);
            }
            b'"' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' && bytes[i] != b'\n' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
            }
            _ => {}
        }
        i += 1;
    }
    None
}

struct Builder<'t> {
    file: u32,
    text: &'t str,
    diagnostics: Vec<Diagnostic>,
}

/// Children of a pair, with keyword tokens (`kw_*`) skipped unless asked for.
struct Children<'i> {
    pairs: std::iter::Peekable<pest::iterators::Pairs<'i, Rule>>,
}

impl<'i> Children<'i> {
    fn of(p: Pair<'i, Rule>) -> Self {
        Children { pairs: p.into_inner().peekable() }
    }
    /// The next child that is not a keyword.
    fn next(&mut self) -> Pair<'i, Rule> {
        self.skip_keywords();
        self.pairs.next().expect("grammar guarantees the child")
    }
    fn peek_rule(&mut self) -> Option<Rule> {
        self.skip_keywords();
        self.pairs.peek().map(|p| p.as_rule())
    }
    /// The next child if it has rule `r`.
    fn next_if(&mut self, r: Rule) -> Option<Pair<'i, Rule>> {
        if self.peek_rule() == Some(r) { self.pairs.next() } else { None }
    }
    /// The first token of the node (keywords included): what a statement starts with.
    fn first_token(&mut self) -> Option<Rule> {
        self.pairs.peek().map(|p| p.as_rule())
    }
    fn rest(self) -> impl Iterator<Item = Pair<'i, Rule>> {
        self.pairs.filter(|p| !is_keyword(p.as_rule()))
    }
    fn skip_keywords(&mut self) {
        while self.pairs.peek().is_some_and(|p| is_keyword(p.as_rule())) {
            self.pairs.next();
        }
    }
}

fn is_keyword(r: Rule) -> bool {
    keyword_text(r).is_some()
}

/// The source text of a keyword rule.
fn keyword_text(r: Rule) -> Option<&'static str> {
    use Rule::*;
    Some(match r {
        kw_domain => "domain",
        kw_use => "use",
        kw_unit => "unit",
        kw_enum => "enum",
        kw_tag => "tag",
        kw_relation => "relation",
        kw_kind => "kind",
        kw_look => "look",
        kw_world => "world",
        kw_region => "region",
        kw_preset => "preset",
        kw_camera => "camera",
        kw_stage => "stage",
        kw_concept => "concept",
        kw_modifier => "modifier",
        kw_constraint => "constraint",
        kw_question => "question",
        kw_rules => "rules",
        kw_rule => "rule",
        kw_allow => "allow",
        kw_description => "description",
        kw_category => "category",
        kw_add => "add",
        kw_set => "set",
        kw_probe => "probe",
        kw_scenic => "scenic",
        kw_prompt => "prompt",
        kw_shape => "shape",
        kw_target => "target",
        kw_move => "move",
        kw_text => "text",
        kw_option => "option",
        kw_when => "when",
        kw_expect => "expect",
        kw_elements => "elements",
        kw_safe => "safe",
        kw_for => "for",
        kw_at => "at",
        kw_look_at => "look_at",
        kw_fov => "fov",
        kw_size => "size",
        kw_color => "color",
        kw_material => "material",
        kw_yaw => "yaw",
        kw_roll => "roll",
        kw_pitch => "pitch",
        kw_repeat => "repeat",
        kw_step => "step",
        kw_in => "in",
        kw_not => "not",
        kw_and => "and",
        kw_or => "or",
        kw_has => "has",
        kw_exists => "exists",
        kw_count => "count",
        kw_where => "where",
        kw_std => "std",
        _ => return None,
    })
}

/// The item keywords, for messages and recovery.
pub const ITEM_KEYWORDS: &[&str] = &[
    "domain",
    "use",
    "unit",
    "enum",
    "tag",
    "relation",
    "kind",
    "look",
    "world",
    "region",
    "preset",
    "camera",
    "stage",
    "concept",
    "modifier",
    "constraint",
    "question",
    "rules",
    "allow",
];

/// End of the token starting at `pos`: a word, or one character.
fn token_end(text: &str, pos: usize) -> usize {
    let rest = &text[pos..];
    let word = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(rest.len());
    if word > 0 { pos + word } else { rest.chars().next().map_or(pos, |c| pos + c.len_utf8()) }
}

fn describe_found(text: &str, pos: usize) -> String {
    if pos >= text.len() { "end of file".to_string() } else { format!("`{}`", &text[pos..token_end(text, pos)]) }
}

impl<'t> Builder<'t> {
    fn span_at(&self, start: usize, end: usize) -> Span {
        Span { file: self.file, start: start as u32, end: end as u32 }
    }
    fn span(&self, p: &Pair<Rule>) -> Span {
        let s = p.as_span();
        self.span_at(s.start(), s.end())
    }
    fn ident(&self, p: Pair<Rule>) -> Ident {
        Ident { name: p.as_str().to_string(), span: self.span(&p) }
    }
    fn idents(&self, c: Children) -> Vec<Ident> {
        c.rest().filter(|p| p.as_rule() == Rule::ident).map(|p| self.ident(p)).collect()
    }

    // ------------------------------------------------------------------ items

    fn item(&mut self, p: Pair<Rule>) -> Item {
        let span = self.span(&p);
        let doc = doc_before(self.text, span.start as usize);
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

    fn use_item(&mut self, p: Pair<Rule>) -> ItemKind {
        match p.as_rule() {
            Rule::std_path => ItemKind::Use(UseTarget::Std(self.ident(Children::of(p).next()))),
            _ => ItemKind::Use(UseTarget::File(self.string(p))),
        }
    }

    fn kind_item(&mut self, mut c: Children) -> ItemKind {
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

    fn placements(&mut self, p: Pair<Rule>) -> Vec<Placement> {
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

    fn attr_list(&mut self, c: Children) -> Vec<AttrDecl> {
        let mut attrs = Vec::new();
        for p in c.rest() {
            match p.as_rule() {
                Rule::attr_decl => attrs.push(self.attr_decl(p)),
                _ => self.junk(p),
            }
        }
        attrs
    }

    fn attr_decl(&mut self, p: Pair<Rule>) -> AttrDecl {
        let span = self.span(&p);
        let doc = doc_before(self.text, span.start as usize);
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

    fn preset_item(&mut self, mut c: Children) -> ItemKind {
        let name = self.ident(c.next());
        let for_variant = c.next_if(Rule::path).map(|p| self.path(p));
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
        ItemKind::Preset { name, for_variant, params }
    }

    fn stage_item(&mut self, mut c: Children) -> ItemKind {
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

    fn stage_opt(&mut self, p: Pair<Rule>) -> StageOpt {
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

    fn constraint_item(&mut self, mut c: Children) -> ItemKind {
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

    // ------------------------------------------------------------------ statements

    fn concept_body(&mut self, p: Pair<Rule>) -> Vec<ConceptStmt> {
        Children::of(p).rest().filter_map(|s| self.concept_stmt(s)).collect()
    }

    fn concept_stmt(&mut self, p: Pair<Rule>) -> Option<ConceptStmt> {
        if p.as_rule() != Rule::concept_stmt {
            self.junk(p);
            return None;
        }
        let span = self.span(&p);
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
            _ => ConceptStmt::Move { region: self.ident(c.next()), span },
        })
    }

    fn region_stmt(&mut self, p: Pair<Rule>) -> Option<RegionStmt> {
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

    fn camera_stmt(&mut self, p: Pair<Rule>) -> Option<CameraStmt> {
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

    fn question_stmt(&mut self, p: Pair<Rule>) -> Option<QuestionStmt> {
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

    fn rule_item(&mut self, p: Pair<Rule>) -> Option<RuleDecl> {
        if p.as_rule() != Rule::rule_item {
            self.junk(p);
            return None;
        }
        let span = self.span(&p);
        let doc = doc_before(self.text, span.start as usize);
        let mut c = Children::of(p);
        let name = self.ident(c.next());
        let stmts = c.rest().filter_map(|s| self.rule_stmt(s)).collect();
        Some(RuleDecl { doc, name, stmts, span })
    }

    fn rule_stmt(&mut self, p: Pair<Rule>) -> Option<RuleStmt> {
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

    fn parts(&mut self, p: Pair<Rule>) -> Parts {
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

    fn shape_part(&mut self, p: Pair<Rule>) -> ShapePart {
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

    fn part_prop(&mut self, p: Pair<Rule>) -> PartProp {
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
            _ => PartProp::When(self.expr(c.next()), span),
        }
    }

    // ------------------------------------------------------------------ expressions

    fn expr(&mut self, p: Pair<Rule>) -> Expr {
        let span = self.span(&p);
        let rule = p.as_rule();
        if rule == Rule::not_expr && not_chain(p.clone()) > MAX_NESTING {
            // `not not not …` nests without parentheses; the same limit applies.
            self.diagnostics.push(too_deep(span));
            return Expr { kind: ExprKind::Bool(false), span };
        }
        let mut c = Children::of(p);
        let kind = match rule {
            Rule::expr | Rule::and_expr => {
                let mut terms: Vec<Expr> = c.rest().map(|t| self.expr(t)).collect();
                if terms.len() == 1 {
                    return terms.pop().expect("one term");
                }
                if rule == Rule::expr { ExprKind::Or(terms) } else { ExprKind::And(terms) }
            }
            Rule::not_expr => ExprKind::Not(Box::new(self.expr(c.next()))),
            Rule::boolean => ExprKind::Bool(span_text(self.text, span) == "true"),
            Rule::has_expr => ExprKind::Has(self.ident(c.next())),
            Rule::exists_expr => {
                let var = self.ident(c.next());
                let filter = self.idents(Children::of(c.next()));
                let cond = c.peek_rule().map(|_| Box::new(self.expr(c.next())));
                ExprKind::Exists { var, filter, cond }
            }
            Rule::count_expr => {
                let filter = self.idents(Children::of(c.next()));
                let op = cmp_op(c.next().as_str());
                ExprKind::Count { filter, op, n: self.int(c.next()) }
            }
            Rule::in_expr => {
                let var = self.ident(c.next());
                ExprKind::In { var, region: self.ident(c.next()) }
            }
            Rule::related_expr => {
                let var = self.ident(c.next());
                let relation = self.ident(c.next());
                ExprKind::Related { var, relation, to: self.ident(c.next()) }
            }
            _ => {
                let path = self.path(c.next());
                let op = cmp_op(c.next().as_str());
                let rhs = c.next();
                if rhs.as_rule() == Rule::attr_ref {
                    ExprKind::CmpAttrs { left: path, op, right: self.path(rhs) }
                } else {
                    ExprKind::Cmp { path, op, value: self.value(rhs) }
                }
            }
        };
        Expr { kind, span }
    }

    // ------------------------------------------------------------------ literals

    fn path(&self, p: Pair<Rule>) -> Path {
        let span = self.span(&p);
        Path { parts: Children::of(p).rest().map(|i| self.ident(i)).collect(), span }
    }

    fn value(&mut self, p: Pair<Rule>) -> ValueLit {
        let mut c = Children::of(p);
        let first = c.next();
        match first.as_rule() {
            Rule::number => {
                let lo = self.number(first);
                match c.peek_rule() {
                    Some(_) => ValueLit::Range(lo, self.number(c.next())),
                    None => ValueLit::Num(lo),
                }
            }
            Rule::boolean => ValueLit::Bool(first.as_str() == "true", self.span(&first)),
            _ => ValueLit::Name(self.ident(first)),
        }
    }

    fn number(&mut self, p: Pair<Rule>) -> Num {
        let span = self.span(&p);
        let mut c = Children::of(p);
        let digits = c.next();
        let value = digits.as_str().parse::<f64>().unwrap_or(f64::NAN);
        if !value.is_finite() {
            self.diagnostics.push(Diagnostic::error(
                codes::INVALID_LITERAL,
                span,
                format!("number `{}` is too large", digits.as_str()),
            ));
        }
        let unit = c.peek_rule().map(|_| self.ident(c.next()));
        Num { value: if value.is_finite() { value } else { 0.0 }, unit, span }
    }

    fn vec3(&mut self, p: Pair<Rule>) -> [Num; 3] {
        let mut c = Children::of(p);
        let x = self.number(c.next());
        let y = self.number(c.next());
        [x, y, self.number(c.next())]
    }

    fn int(&mut self, p: Pair<Rule>) -> u32 {
        p.as_str().parse::<u32>().unwrap_or_else(|_| {
            let span = self.span(&p);
            self.diagnostics.push(Diagnostic::error(
                codes::INVALID_LITERAL,
                span,
                format!("integer `{}` is too large", p.as_str()),
            ));
            0
        })
    }

    fn string(&mut self, p: Pair<Rule>) -> Str {
        let span = self.span(&p);
        let raw = p.as_str();
        let value = if let Some(inner) = raw.strip_prefix("\"\"\"").and_then(|s| s.strip_suffix("\"\"\"")) {
            // A raw string that starts on the next line keeps only its content lines.
            inner.strip_prefix('\n').or_else(|| inner.strip_prefix("\r\n")).unwrap_or(inner).to_string()
        } else {
            self.unescape(&raw[1..raw.len() - 1], span.start as usize + 1)
        };
        Str { value, span }
    }

    fn unescape(&mut self, s: &str, offset: usize) -> String {
        let mut out = String::with_capacity(s.len());
        let mut chars = s.char_indices();
        while let Some((i, ch)) = chars.next() {
            if ch != '\\' {
                out.push(ch);
                continue;
            }
            match chars.next() {
                Some((_, '"')) => out.push('"'),
                Some((_, '\\')) => out.push('\\'),
                Some((_, 'n')) => out.push('\n'),
                Some((_, 't')) => out.push('\t'),
                Some((j, other)) => {
                    let span = self.span_at(offset + i, offset + j + other.len_utf8());
                    self.diagnostics.push(
                        Diagnostic::error(
                            codes::INVALID_LITERAL,
                            span,
                            format!("unknown escape `\\{other}` in string"),
                        )
                        .with_help("the escapes are `\\\"`, `\\\\`, `\\n` and `\\t`"),
                    );
                }
                None => {}
            }
        }
        out
    }

    // ------------------------------------------------------------------ recovery

    /// Report a recovery node: re-parse from its start with the rule it should have matched,
    /// and report where and why that fails.
    fn junk(&mut self, p: Pair<Rule>) {
        let start = p.as_span().start();
        let (rule, what) = match p.as_rule() {
            Rule::junk => match item_rule(self.text, start) {
                Some(r) => (Some(r), "an item"),
                None => (None, "an item"),
            },
            Rule::attrs_junk if self.text[start..].starts_with("shape") => (Some(Rule::shape_block), "an attribute"),
            Rule::attrs_junk if self.text[start..].starts_with("in") && !is_word_char(&self.text[start + 2..]) => {
                (Some(Rule::stands_in), "regions `in REGION, …`")
            }
            Rule::placement_junk => (Some(Rule::placement), "a placement (`distance`, `ahead`, `left`, `on_top`)"),
            Rule::attrs_junk => (Some(Rule::attr_decl), "an attribute `NAME: TYPE = DEFAULT`"),
            Rule::parts_junk => {
                (Some(Rule::shape_part), "a shape part (`box`, `cylinder`, `capsule`, `sphere`, `plane`, `cone`)")
            }
            Rule::region_junk => (Some(Rule::region_stmt), "`x`, `y`, `z` or `scenic`"),
            Rule::preset_junk => (Some(Rule::preset_param), "a parameter `NAME = NUMBER`"),
            Rule::camera_junk => (Some(Rule::camera_stmt), "`at`, `look_at`, `fov` or `size`"),
            Rule::concept_junk => (Some(Rule::concept_stmt), "a concept statement"),
            Rule::question_junk => (Some(Rule::question_stmt), "`text` or `option`"),
            Rule::rules_junk => (Some(Rule::rule_item), "`rule`"),
            _ => (Some(Rule::rule_stmt), "`when`, `expect`, `elements` or `safe`"),
        };
        let d = self.syntax_error(start, rule, what);
        self.diagnostics.push(d);
    }

    fn syntax_error(&self, start: usize, rule: Option<Rule>, what: &str) -> Diagnostic {
        let rest = &self.text[start..];
        let failure = rule.map(|r| match RevParser::parse(r, rest) {
            Ok(pairs) => {
                let consumed = pairs.last().map_or(0, |p| p.as_span().end());
                (start + consumed, Vec::new())
            }
            Err(e) => {
                let (pos, expected) = failure_point(&e);
                (start + pos, expected)
            }
        });
        let (pos, expected) = failure.unwrap_or((start, Vec::new()));
        // Skip the whitespace and comments between the last good token and the bad one.
        let pos = skip_trivia(self.text, pos);
        let found = describe_found(self.text, pos);
        let span = self.span_at(pos, token_end(self.text, pos).max(pos));
        if pos == start || expected.is_empty() {
            let d = Diagnostic::error(codes::SYNTAX, span, format!("expected {what}, found {found}"))
                .with_label(format!("expected {what}"));
            let word = &self.text[pos..token_end(self.text, pos)];
            let d = keyword_typo_help(d, word, &statement_keywords(rule));
            if d.help.is_none() && what == "an item" {
                return d.with_help(format!("an item starts with one of: {}", ITEM_KEYWORDS.join(", ")));
            }
            return d;
        }
        if expected.len() > MAX_EXPECTED {
            // A long list (typically "any statement or item may follow") reads worse than none.
            return Diagnostic::error(codes::SYNTAX, span, format!("unexpected {found}"))
                .with_label("unexpected here")
                .with_help(if what == "an item" {
                    format!("an item ends here; the next one starts with one of: {}", ITEM_KEYWORDS.join(", "))
                } else {
                    format!("a statement ends here; expected {what} or `}}` next")
                });
        }
        let list = join_or(&expected);
        let d = Diagnostic::error(codes::SYNTAX, span, format!("expected {list}, found {found}"))
            .with_label(format!("expected {list}"));
        keyword_typo_help(d, &self.text[pos..token_end(self.text, pos)], &expected)
    }
}

/// The item rule for the item keyword at `pos`, if there is one.
fn item_rule(text: &str, pos: usize) -> Option<Rule> {
    let word = &text[pos..token_end(text, pos)];
    Some(match word {
        "domain" => Rule::domain_item,
        "use" => Rule::use_item,
        "unit" => Rule::unit_item,
        "enum" => Rule::enum_item,
        "tag" => Rule::tag_item,
        "relation" => Rule::relation_item,
        "kind" => Rule::kind_item,
        "look" => Rule::look_item,
        "world" => Rule::world_item,
        "region" => Rule::region_item,
        "preset" => Rule::preset_item,
        "camera" => Rule::camera_item,
        "stage" => Rule::stage_item,
        "concept" => Rule::concept_item,
        "modifier" => Rule::modifier_item,
        "constraint" => Rule::constraint_item,
        "question" => Rule::question_item,
        "rules" => Rule::rules_item,
        "allow" => Rule::allow_item,
        _ => return None,
    })
}

/// Where a parse failed and what was expected there, as readable words (sorted, deduplicated).
/// pest's own location is where the outermost failing rule started; its parse attempts know the
/// furthest position reached, which is where the mistake is.
fn failure_point(e: &pest::error::Error<Rule>) -> (usize, Vec<String>) {
    let mut pos = match e.location {
        pest::error::InputLocation::Pos(p) => p,
        pest::error::InputLocation::Span((s, _)) => s,
    };
    let mut out: Vec<String> = Vec::new();
    let attempts = e.parse_attempts();
    let further = attempts.as_ref().is_some_and(|a| a.max_position > pos);
    if !further && let pest::error::ErrorVariant::ParsingError { positives, .. } = &e.variant {
        out.extend(positives.iter().filter_map(|r| describe_rule(*r)));
    }
    if let Some(attempts) = attempts {
        pos = pos.max(attempts.max_position);
        for stack in attempts.call_stacks() {
            // The deepest rule says what was wanted; the parent is the outermost rule, too broad
            // (and a bare token is already among the expected tokens).
            out.extend(stack.deepest.get_rule().and_then(|r| describe_rule(*r)));
        }
        // pest does not export its token type; its display is the literal, `a..z` for a
        // character range and `BUILTIN_RULE` for builtins, which say nothing to a user.
        for t in attempts.expected_tokens() {
            let token = t.to_string();
            let is_range = token.chars().count() == 4 && token.chars().nth(1) == Some('.');
            let noise = token.trim_matches(|c: char| c.is_whitespace() || c == '\u{feff}').is_empty()
                || matches!(token.as_str(), "//" | "BUILTIN_RULE" | "_" | "\"" | "\"\"\"");
            if !noise && !is_range {
                out.push(format!("`{token}`"));
            }
        }
    }
    drop_covered(&mut out);
    out.sort();
    out.dedup();
    (pos, out)
}

/// Remove the tokens a listed summary already covers (`a value` covers `-`, `true`, a name …).
fn drop_covered(out: &mut Vec<String>) {
    const COVERS: &[(&str, &[&str])] = &[
        ("a value", &["a number", "a name", "`true` or `false`", "`true`", "`false`", "`-`"]),
        (
            "an expression",
            &["a name", "`true` or `false`", "`true`", "`false`", "`not`", "`has`", "`exists`", "`count`", "`(`"],
        ),
        ("a number", &["`-`"]),
    ];
    for (summary, covered) in COVERS {
        if out.iter().any(|t| t == summary) {
            out.retain(|t| !covered.contains(&t.as_str()));
        }
    }
}

fn describe_rule(r: Rule) -> Option<String> {
    if let Some(k) = keyword_text(r) {
        return Some(format!("`{k}`"));
    }
    Some(
        match r {
            Rule::ident | Rule::path => "a name",
            Rule::wildcard => "a wildcard",
            Rule::number | Rule::num_value => "a number",
            Rule::int | Rule::int_part => "an integer",
            Rule::dims => "an image size `WIDTHxHEIGHT`",
            Rule::boolean => "`true` or `false`",
            Rule::color => "a colour `#rrggbb`",
            Rule::string | Rule::quoted | Rule::raw_string => "a string",
            Rule::vec3 => "a triple `(x, y, z)`",
            Rule::value => "a value",
            Rule::filter => "a kind or tag",
            Rule::axis => "`x`, `y` or `z`",
            Rule::prim => "a shape part",
            Rule::cmp_op => "a comparison (`==`, `!=`, `<`, `<=`, `>`, `>=`)",
            Rule::expr
            | Rule::and_expr
            | Rule::not_expr
            | Rule::has_expr
            | Rule::exists_expr
            | Rule::count_expr
            | Rule::in_expr
            | Rule::related_expr
            | Rule::cmp_expr => "an expression",
            Rule::attr_ref => "an attribute `VAR.ATTR`",
            Rule::placement => "a placement",
            Rule::stands_in => "regions `in REGION, …`",
            Rule::attr_decl => "an attribute",
            Rule::attr_values => "`{`",
            Rule::relation_to => "a relation",
            Rule::std_path => "`std::NAME`",
            Rule::member => "a concept, `prefix_*` or `category \"…\"`",
            Rule::parts => "`{`",
            Rule::shape_part => "a shape part",
            Rule::part_prop => "a shape property",
            Rule::rule_item => "`rule`",
            Rule::concept_body => "`{`",
            Rule::EOI => "end of file",
            _ => return None,
        }
        .to_string(),
    )
}

/// More expected tokens than this are not listed.
const MAX_EXPECTED: usize = 6;

/// "did you mean `description`?" when the bad word is a near miss of an expected keyword.
fn keyword_typo_help(d: Diagnostic, word: &str, expected: &[String]) -> Diagnostic {
    if word.is_empty() || !word.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return d;
    }
    let keywords = expected.iter().filter_map(|e| e.strip_prefix('`').and_then(|e| e.strip_suffix('`')));
    match crate::diag::suggest::suggest(word, keywords) {
        Some(k) => d.with_help(format!("did you mean `{k}`?")),
        None => d,
    }
}

/// The keywords a statement of this rule may start with, quoted as in expected lists.
fn statement_keywords(rule: Option<Rule>) -> Vec<String> {
    let words: &[&str] = match rule {
        None | Some(Rule::domain_item) => ITEM_KEYWORDS,
        Some(Rule::concept_stmt) => {
            &["description", "category", "add", "set", "probe", "scenic", "prompt", "shape", "target", "move"]
        }
        Some(Rule::rule_stmt) => &["when", "expect", "elements", "safe"],
        Some(Rule::question_stmt) => &["text", "option"],
        Some(Rule::camera_stmt) => &["at", "look_at", "fov", "size"],
        Some(Rule::rule_item) => &["rule"],
        Some(Rule::shape_part) => &["box", "cylinder", "capsule", "sphere", "plane", "cone"],
        Some(Rule::region_stmt) => &["scenic"],
        _ => &[],
    };
    words.iter().map(|w| format!("`{w}`")).collect()
}

fn join_or(items: &[String]) -> String {
    const MAX: usize = MAX_EXPECTED;
    let shown: Vec<&str> = items.iter().take(MAX).map(String::as_str).collect();
    match shown.len() {
        0 => String::new(),
        1 => shown[0].to_string(),
        n if items.len() > MAX => format!("{}, …", shown[..n].join(", ")),
        n => format!("{} or {}", shown[..n - 1].join(", "), shown[n - 1]),
    }
}

fn cmp_op(s: &str) -> CmpOp {
    match s {
        "==" => CmpOp::Eq,
        "!=" => CmpOp::Ne,
        "<" => CmpOp::Lt,
        "<=" => CmpOp::Le,
        ">" => CmpOp::Gt,
        _ => CmpOp::Ge,
    }
}

fn span_text(text: &str, s: Span) -> &str {
    &text[s.start as usize..s.end as usize]
}

/// Skip whitespace and `//` comments from `pos`.
/// Whether `rest` starts with a character that continues a word.
fn is_word_char(rest: &str) -> bool {
    rest.starts_with(|c: char| c.is_ascii_alphanumeric() || c == '_')
}

fn skip_trivia(text: &str, mut pos: usize) -> usize {
    loop {
        let rest = &text[pos..];
        let trimmed = rest.trim_start();
        pos += rest.len() - trimmed.len();
        if trimmed.starts_with("//") {
            pos += trimmed.find('\n').unwrap_or(trimmed.len());
        } else {
            return pos;
        }
    }
}

/// The `///` lines directly above `pos` (only whitespace between), joined with newlines.
pub fn doc_before(text: &str, pos: usize) -> String {
    let before = &text[..pos];
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    if !before[line_start..].trim().is_empty() {
        return String::new();
    }
    let mut lines: Vec<&str> = Vec::new();
    let mut end = line_start;
    while end > 0 {
        let prev = &text[..end - 1];
        let start = prev.rfind('\n').map_or(0, |i| i + 1);
        let line = prev[start..].trim();
        match line.strip_prefix("///") {
            Some(doc) if !doc.starts_with('/') => lines.push(doc.strip_prefix(' ').unwrap_or(doc).trim_end()),
            _ => break,
        }
        end = start;
    }
    lines.reverse();
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse_ok(text: &str) -> File {
        let p = parse(0, text);
        assert!(p.diagnostics.is_empty(), "{:?}", p.diagnostics);
        p.file
    }

    fn concept_stmts(text: &str) -> Vec<ConceptStmt> {
        match &parse_ok(text).items[0].kind {
            ItemKind::Concept { stmts, .. } => stmts.clone(),
            other => panic!("not a concept: {other:?}"),
        }
    }

    #[test]
    fn doc_comments_attach_to_the_next_item() {
        let f = parse_ok("// plain\n/// First line.\n///   Second.\n\nunit m: length = 1\n/// Tag doc.\ntag T");
        assert_eq!(f.items[0].doc, "", "a blank line separates a doc comment from its item");
        assert_eq!(f.items[1].doc, "Tag doc.");
        assert_eq!(doc_before("/// A.\n/// B.\nkind K {}", 14), "A.\nB.");
        assert_eq!(doc_before("//// not a doc\nkind K {}", 15), "");
    }

    #[test]
    fn keywords_are_whole_words() {
        let stmts = concept_stmts("modifier m { target worldly_things }");
        assert!(
            matches!(&stmts[0], ConceptStmt::Target { world: None, filter, .. } if filter[0].name == "worldly_things")
        );
        let stmts = concept_stmts("modifier m { target world }");
        assert!(matches!(&stmts[0], ConceptStmt::Target { world: Some(_), .. }));
    }

    #[test]
    fn add_without_relation_does_not_swallow_the_next_statement() {
        let stmts = concept_stmts("concept c { add a: K in lane add b: K in lane near a { x = 1m } }");
        assert_eq!(stmts.len(), 2);
        let ConceptStmt::Add { relation, attrs, .. } = &stmts[1] else { panic!() };
        assert_eq!(relation.as_ref().map(|r| r.1.name.as_str()), Some("a"));
        assert_eq!(attrs.len(), 1);
    }

    #[test]
    fn strings_decode_escapes_and_raw_strings_keep_their_lines() {
        let stmts =
            concept_stmts("concept c { description \"a \\\"b\\\"\\n\" scenic \"\"\"\nline 1\nline \"2\"\n\"\"\" }");
        assert!(matches!(&stmts[0], ConceptStmt::Description(s) if s.value == "a \"b\"\n"));
        assert!(matches!(&stmts[1], ConceptStmt::Scenic(s) if s.value == "line 1\nline \"2\"\n"));
    }

    #[test]
    fn numbers_ranges_and_units() {
        let f = parse_ok("kind K { d: length in -8m..8.5m = 2m..4m }");
        let ItemKind::Kind { attrs, .. } = &f.items[0].kind else { panic!() };
        let (lo, hi) = attrs[0].bounds.as_ref().unwrap();
        assert_eq!((lo.value, hi.value), (-8.0, 8.5));
        assert!(
            matches!(&attrs[0].default, ValueLit::Range(a, b) if a.value == 2.0 && b.unit.as_ref().unwrap().name == "m")
        );
    }

    #[test]
    fn three_mistakes_three_diagnostics_and_the_rest_parses() {
        let text = "domain d\nconcept a { descriptio \"x\" probe \"p\" not \"n\" }\n@@@\nkind K { d: length = }\nregion r { x 0m y 0m }";
        let p = parse(0, text);
        let line = |d: &Diagnostic| text[..d.span.unwrap().start as usize].matches('\n').count() + 1;
        let lines: Vec<usize> = p.diagnostics.iter().map(line).collect();
        assert_eq!(lines, [2, 3, 4], "{:?}", p.diagnostics);
        assert!(p.diagnostics.iter().all(|d| d.code == codes::SYNTAX));
        assert_eq!(p.file.items.len(), 5, "domain, concept, junk, kind, region");
        assert!(p.file.items[1].broken && !p.file.items[4].broken);
        assert_eq!(p.diagnostics[0].help.as_deref(), Some("did you mean `description`?"));
        assert_eq!(p.diagnostics[2].message, "expected a value, found `}`");
    }

    #[test]
    fn expected_tokens_point_at_the_mistake() {
        let text = "enum Color { red, green blue }";
        let p = parse(0, text);
        let d = &p.diagnostics[0];
        assert_eq!(d.message, "expected `,` or `}`, found `blue`");
        assert_eq!(&text[d.span.unwrap().start as usize..d.span.unwrap().end as usize], "blue");
    }

    #[test]
    fn nesting_limit_ignores_strings_and_comments() {
        let parens = "(".repeat(MAX_NESTING + 1);
        assert_eq!(too_deep_at(&format!("// {parens}\n\"{parens}\" \"\"\"{parens}\"\"\"")), None);
        assert_eq!(too_deep_at(&format!("x {parens}")), Some(2 + MAX_NESTING));
    }
}

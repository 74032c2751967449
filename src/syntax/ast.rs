//! The syntax tree of one `.rev` file, with spans (byte ranges into the file).
//!
//! The tree keeps what the source says, not what it means: names are unresolved, numbers keep
//! their unit suffix, and every part that failed to parse is an [`ItemKind::Error`] or a
//! `*::Error` statement so that editor features keep working on broken code.

use crate::ir::{CmpOp, Primitive, Span};

#[derive(Debug, Clone, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

/// A string literal, escapes already decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct Str {
    pub value: String,
    pub span: Span,
}

/// A number as written: value and optional unit suffix (`2m`, `90deg`, `0.5`).
#[derive(Debug, Clone, PartialEq)]
pub struct Num {
    pub value: f64,
    pub unit: Option<Ident>,
    pub span: Span,
}

/// A value literal: number, range, boolean or bare name (an enum variant).
#[derive(Debug, Clone, PartialEq)]
pub enum ValueLit {
    Num(Num),
    Range(Num, Num),
    Bool(bool, Span),
    Name(Ident),
}

impl ValueLit {
    pub fn span(&self) -> Span {
        match self {
            ValueLit::Num(n) => n.span,
            ValueLit::Range(a, b) => Span { file: a.span.file, start: a.span.start, end: b.span.end },
            ValueLit::Bool(_, s) => *s,
            ValueLit::Name(i) => i.span,
        }
    }
}

/// A dotted name (`world.weather`, `e.distance`, `drive.stop`).
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pub parts: Vec<Ident>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct File {
    pub items: Vec<Item>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// The `///` lines right before the item, joined with newlines.
    pub doc: String,
    pub span: Span,
    pub kind: ItemKind,
    /// The item holds a syntax error; checks for missing statements skip it, since the
    /// statement may be the one that failed to parse.
    pub broken: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub enum ItemKind {
    Domain(Ident),
    Use(UseTarget),
    Unit {
        name: Ident,
        dimension: Ident,
        scale: Num,
    },
    Enum {
        name: Ident,
        variants: Vec<Ident>,
    },
    Tag {
        name: Ident,
        parents: Vec<Ident>,
    },
    Relation {
        name: Ident,
        text: Str,
        /// The `{ … }` placement words with their ranges; `None` when there is no body.
        placements: Option<Vec<Placement>>,
    },
    Kind {
        name: Ident,
        parents: Vec<Ident>,
        attrs: Vec<AttrDecl>,
        shapes: Vec<Parts>,
        /// `in REGION, …` statements: where entities of the kind may stand.
        stands_in: Vec<Vec<Ident>>,
    },
    Look {
        kind: Ident,
        parts: Parts,
    },
    World {
        attrs: Vec<AttrDecl>,
    },
    Region {
        name: Ident,
        stmts: Vec<RegionStmt>,
    },
    Preset {
        name: Ident,
        for_variant: Option<Path>,
        params: Vec<(Ident, Num)>,
    },
    Camera {
        stmts: Vec<CameraStmt>,
    },
    /// `visible [NAME] { pixels = N  contrast = X }`.
    Visible {
        target: Option<Ident>,
        params: Vec<(Ident, Num)>,
    },
    Stage {
        name: Ident,
        opts: Vec<StageOpt>,
        parts: Parts,
    },
    Concept {
        modifier: bool,
        name: Ident,
        stmts: Vec<ConceptStmt>,
    },
    Constraint {
        name: Ident,
        func: Ident,
        count: Option<(u32, Span)>,
        members: Vec<Member>,
    },
    Question {
        name: Ident,
        stmts: Vec<QuestionStmt>,
    },
    Rules {
        selection: Ident,
        rules: Vec<RuleDecl>,
    },
    /// `allow CODE`: silence a lattice-lint code for the domain.
    Allow {
        code: Ident,
    },
    /// Text that is no item; its diagnostic was reported by the parser.
    Error,
}

/// One placement word of a relation (`distance 0m..1.5m`, `on_top`).
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    pub word: Ident,
    pub range: Option<(Num, Num)>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum UseTarget {
    Std(Ident),
    File(Str),
}

/// `NAME: TYPE [in MIN..MAX] = DEFAULT`
#[derive(Debug, Clone, PartialEq)]
pub struct AttrDecl {
    pub doc: String,
    pub name: Ident,
    pub ty: Ident,
    pub bounds: Option<(Num, Num)>,
    pub default: ValueLit,
    pub span: Span,
}

/// A `{ … }` list of shape parts (a kind's `shape`, a `look`, a concept's `shape`, a stage item).
#[derive(Debug, Clone, PartialEq)]
pub struct Parts {
    pub parts: Vec<ShapePart>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub struct ShapePart {
    pub prim: Primitive,
    pub props: Vec<PartProp>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum PartProp {
    Size([Num; 3], Span),
    At([Num; 3], Span),
    Color(String, Span),
    Material(Ident),
    Yaw(Num),
    Roll(Num),
    Pitch(Num),
    /// `shadow false`: the part casts no blob shadow (a lamp 1.7 m up, a sign on a pole).
    Shadow(bool, Span),
    When(Expr, Span),
}

#[derive(Debug, Clone, PartialEq)]
pub enum RegionStmt {
    Axis { axis: Ident, value: ValueLit },
    Scenic(Str),
}

#[derive(Debug, Clone, PartialEq)]
pub enum CameraStmt {
    At([Num; 3], Span),
    LookAt([Num; 3], Span),
    Fov(Num),
    Size { width: u32, height: u32, span: Span },
}

#[derive(Debug, Clone, PartialEq)]
pub enum StageOpt {
    At([Num; 3], Span),
    Repeat { count: u32, step: [Num; 3], span: Span },
    When(Expr, Span),
}

#[derive(Debug, Clone, PartialEq)]
pub enum ConceptStmt {
    Description(Str),
    Category(Str),
    Add {
        name: Ident,
        kind: Ident,
        region: Ident,
        relation: Option<(Ident, Ident)>,
        attrs: Vec<(Ident, ValueLit)>,
        span: Span,
    },
    Set {
        path: Path,
        value: ValueLit,
        span: Span,
    },
    Probe {
        positive: Str,
        negative: Str,
        span: Span,
    },
    Scenic(Str),
    Prompt(Str),
    Shape(Parts),
    /// `target world` is `world: Some(span)`.
    Target {
        world: Option<Span>,
        filter: Vec<Ident>,
        span: Span,
    },
    Move {
        region: Ident,
        span: Span,
    },
    /// `drawn_by STAGE`: the stage item that draws the concept's entities that draw nothing
    /// themselves.
    DrawnBy {
        stage: Ident,
        span: Span,
    },
}

impl ConceptStmt {
    /// The statement's keyword, for messages.
    pub fn keyword(&self) -> &'static str {
        match self {
            ConceptStmt::Description(_) => "description",
            ConceptStmt::Category(_) => "category",
            ConceptStmt::Add { .. } => "add",
            ConceptStmt::Set { .. } => "set",
            ConceptStmt::Probe { .. } => "probe",
            ConceptStmt::Scenic(_) => "scenic",
            ConceptStmt::Prompt(_) => "prompt",
            ConceptStmt::Shape(_) => "shape",
            ConceptStmt::Target { .. } => "target",
            ConceptStmt::Move { .. } => "move",
            ConceptStmt::DrawnBy { .. } => "drawn_by",
        }
    }
}

/// A constraint member: a concept name, a `prefix_*` wildcard, or `category "…"`.
#[derive(Debug, Clone, PartialEq)]
pub enum Member {
    Name(Ident),
    Wildcard(Ident),
    Category(Str),
}

#[derive(Debug, Clone, PartialEq)]
pub enum QuestionStmt {
    Text(Str),
    Option { name: Ident, text: Str },
}

#[derive(Debug, Clone, PartialEq)]
pub struct RuleDecl {
    pub doc: String,
    pub name: Ident,
    pub stmts: Vec<RuleStmt>,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum RuleStmt {
    When(Expr, Span),
    Expect(Path),
    Elements(Vec<Ident>, Span),
    Safe(Span),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    Bool(bool),
    Not(Box<Expr>),
    And(Vec<Expr>),
    Or(Vec<Expr>),
    Has(Ident),
    Exists {
        var: Ident,
        filter: Vec<Ident>,
        cond: Option<Box<Expr>>,
    },
    Count {
        filter: Vec<Ident>,
        op: CmpOp,
        n: u32,
    },
    In {
        var: Ident,
        region: Ident,
    },
    Cmp {
        path: Path,
        op: CmpOp,
        value: ValueLit,
    },
    /// Two attributes compared: `a.distance < b.distance`.
    CmpAttrs {
        left: Path,
        op: CmpOp,
        right: Path,
    },
    /// A relation edge of the scene graph: `e near g`, `e ahead_of ego`.
    Related {
        var: Ident,
        relation: Ident,
        to: Ident,
    },
}

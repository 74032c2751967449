//! `revelio describe FILE [--json]`: what a domain compiles to — its concepts (with their bit
//! index), constraints, questions and rules in selection order.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::{Value as Json, json};

use crate::ir::*;
use crate::vlm::prompt::letter;

#[derive(clap::Args, Debug)]
pub struct DescribeArgs {
    /// The domain file
    #[arg(value_name = "FILE")]
    pub file: PathBuf,
    /// Print one JSON object instead of a readable summary
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: DescribeArgs) -> ExitCode {
    if !args.file.is_file() {
        eprintln!("error: `{}` does not exist or is not a file", args.file.display());
        return ExitCode::from(2);
    }
    let domain = match super::load_domain(&args.file) {
        Ok(d) => d,
        Err(code) => return code,
    };
    if args.json {
        super::check::write_stdout(&format!("{}\n", to_json(&domain)));
    } else {
        super::check::write_stdout(&summary(&domain));
    }
    ExitCode::SUCCESS
}

/// The domain as one JSON object (see docs/language.md, "describe").
pub fn to_json(d: &Domain) -> Json {
    json!({
        "name": d.name,
        "files": d.files.iter().map(|f| f.name.clone()).collect::<Vec<_>>(),
        "concepts": d.concepts.iter().map(|c| concept_json(d, c)).collect::<Vec<_>>(),
        "constraints": d.constraints.iter().map(|c| constraint_json(d, c)).collect::<Vec<_>>(),
        "questions": d.questions.iter().map(|q| json!({
            "name": q.name,
            "text": q.text,
            "options": q.options.iter().enumerate().map(|(i, o)| json!({
                "letter": letter(i).to_string(), "name": o.name, "text": o.text,
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "selection": selection_word(d.selection),
        "rules": d.rules.iter().map(|r| rule_json(d, r)).collect::<Vec<_>>(),
        "kinds": d.kinds.iter().map(|k| json!({
            "name": k.name,
            "tags": k.tags.iter().map(|t| d.tags[t.index()].name.clone()).collect::<Vec<_>>(),
            "attributes": k.attrs.iter().map(|a| a.name.clone()).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "world": d.world.iter().map(|a| json!({ "name": a.name, "default": value_text(d, &a.default) })).collect::<Vec<_>>(),
    })
}

fn concept_json(d: &Domain, c: &Concept) -> Json {
    json!({
        "name": c.name,
        "index": c.id.0,
        "kind": match c.kind { ConceptKind::Concept => "concept", ConceptKind::Modifier => "modifier" },
        "description": c.description,
        "category": c.category,
        "probe": { "positive": c.probe.positive, "negative": c.probe.negative },
        "target": c.target.as_ref().map(|t| filter_text(d, t)),
        "effects": c.effects.iter().map(|e| effect_text(d, e)).collect::<Vec<_>>(),
        "scenic": c.render.scenic,
        "prompt": c.render.prompt,
        "shape_parts": c.render.shape.as_ref().map(Vec::len),
    })
}

fn constraint_json(d: &Domain, c: &Constraint) -> Json {
    let names = |s: ConceptSet| d.set_names(s).into_iter().map(str::to_string).collect::<Vec<_>>();
    let rule = match &c.rule {
        ConstraintRule::AtMost { members, max } => json!({ "kind": "at_most", "max": max, "members": names(*members) }),
        ConstraintRule::Requires { concept, any_of } => json!({
            "kind": "requires", "concept": d.concepts[concept.index()].name, "any_of": names(*any_of),
        }),
        ConstraintRule::Forbids { all } => json!({ "kind": "forbids", "all": names(*all) }),
    };
    let mut o = json!({ "name": c.name, "doc": c.doc });
    if let (Some(o), Json::Object(r)) = (o.as_object_mut(), rule) {
        o.extend(r);
    }
    o
}

fn rule_json(d: &Domain, r: &Rule) -> Json {
    let q = &d.questions[r.question.index()];
    json!({
        "name": r.name,
        "rationale": r.rationale,
        "question": q.name,
        "expect": q.options[r.expect as usize].name,
        "when": r.when.as_ref().map(|e| expr_text(d, e)),
        "elements": d.set_names(r.elements),
        "safe": r.safe,
    })
}

fn selection_word(s: Selection) -> &'static str {
    match s {
        Selection::Priority => "priority",
        Selection::BestFit => "best_fit",
    }
}

/// A readable one-line summary of the domain.
pub fn summary(d: &Domain) -> String {
    let mut s = String::new();
    let n_mod = d.concepts.iter().filter(|c| c.kind == ConceptKind::Modifier).count();
    let _ = writeln!(s, "domain {}", d.name);
    let _ = writeln!(
        s,
        "  concepts: {}, modifiers: {}, kinds: {}, constraints: {}, questions: {}, rules: {} ({})",
        d.concepts.len(),
        n_mod,
        d.kinds.len(),
        d.constraints.len(),
        d.questions.len(),
        d.rules.len(),
        selection_word(d.selection)
    );
    let _ = writeln!(s, "\nconcepts:");
    for c in &d.concepts {
        let tag = if c.kind == ConceptKind::Modifier { " (modifier)" } else { "" };
        let _ = writeln!(s, "  {:>3}  {}{}  [{}]  {}", c.id.0, c.name, tag, c.category, c.description);
    }
    let _ = writeln!(s, "\nconstraints:");
    for c in &d.constraints {
        let _ = writeln!(s, "  {}: {}", c.name, constraint_json(d, c));
    }
    for q in &d.questions {
        let _ = writeln!(s, "\nquestion {}: {}", q.name, q.text);
        for (i, o) in q.options.iter().enumerate() {
            let _ = writeln!(s, "  ({}) {}: {}", letter(i), o.name, o.text);
        }
    }
    let _ = writeln!(s, "\nrules ({}):", selection_word(d.selection));
    for r in &d.rules {
        let q = &d.questions[r.question.index()];
        let when = r.when.as_ref().map_or("always".to_string(), |e| expr_text(d, e));
        let safe = if r.safe { " (safe)" } else { "" };
        let _ =
            writeln!(s, "  {}{}: when {} expect {}.{}", r.name, safe, when, q.name, q.options[r.expect as usize].name);
    }
    s
}

fn filter_text(d: &Domain, f: &TargetFilter) -> String {
    if f.world {
        return "world".to_string();
    }
    let mut names: Vec<&str> = f.kinds.iter().map(|k| d.kinds[k.index()].name.as_str()).collect();
    names.extend(f.tags.iter().map(|t| d.tags[t.index()].name.as_str()));
    if names.is_empty() { "any entity".to_string() } else { names.join(" | ") }
}

fn effect_text(d: &Domain, e: &Effect) -> String {
    match e {
        Effect::Add { name, kind, region, relation, attrs, .. } => {
            let to = relation.to.as_deref().unwrap_or("ego");
            let mut s = format!(
                "add {name}: {} in {} {} {to}",
                d.kinds[kind.index()].name,
                d.regions[region.index()].name,
                relation.name
            );
            if !attrs.is_empty() {
                let a: Vec<String> = attrs.iter().map(|(n, v)| format!("{n} = {}", value_text(d, v))).collect();
                let _ = write!(s, " {{ {} }}", a.join(", "));
            }
            s
        }
        Effect::SetWorld { attr, value, .. } => format!("set world.{attr} = {}", value_text(d, value)),
        Effect::SetTarget { attr, value, .. } => format!("set {attr} = {}", value_text(d, value)),
        Effect::MoveTarget { region, .. } => format!("move {}", d.regions[region.index()].name),
    }
}

/// A value in base units (`2..4`, `true`, `foggy`).
pub fn value_text(d: &Domain, v: &Value) -> String {
    match v {
        Value::Bool(b) => b.to_string(),
        Value::Number(x) => format!("{x}"),
        Value::Range(a, b) => format!("{a}..{b}"),
        Value::Enum(e, i) => d.variant_name(*e, *i).to_string(),
    }
}

fn op_text(op: CmpOp) -> &'static str {
    match op {
        CmpOp::Eq => "==",
        CmpOp::Ne => "!=",
        CmpOp::Lt => "<",
        CmpOp::Le => "<=",
        CmpOp::Gt => ">",
        CmpOp::Ge => ">=",
    }
}

/// An expression in source-like syntax (numbers in base units).
pub fn expr_text(d: &Domain, e: &Expr) -> String {
    let join =
        |es: &[Expr], sep: &str| es.iter().map(|x| format!("({})", expr_text(d, x))).collect::<Vec<_>>().join(sep);
    match e {
        Expr::Bool(b) => b.to_string(),
        Expr::Not(x) => format!("not ({})", expr_text(d, x)),
        Expr::And(es) => join(es, " and "),
        Expr::Or(es) => join(es, " or "),
        Expr::Has(c) => format!("has {}", d.concepts[c.index()].name),
        Expr::Exists { var, filter, cond } => match cond {
            Some(c) => format!("exists {var}: {} where {}", filter_text(d, filter), expr_text(d, c)),
            None => format!("exists {var}: {}", filter_text(d, filter)),
        },
        Expr::Count { filter, op, n } => format!("count({}) {} {n}", filter_text(d, filter), op_text(*op)),
        Expr::Cmp { var, attr, op, value } => {
            format!("{}.{attr} {} {}", var.as_deref().unwrap_or("world"), op_text(*op), value_text(d, value))
        }
        Expr::InRegion { var, region } => format!("{var} in {}", d.regions[region.index()].name),
    }
}

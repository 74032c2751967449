//! `revelio describe FILE [--json]`: what a domain compiles to — its concepts (with their bit
//! index), constraints, questions and rules in selection order.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::{Value as Json, json};

use crate::ir::*;
use crate::oracle::explain::{self, expr_text};
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
        super::common::write_stdout(&format!("{}\n", to_json(&domain)));
    } else {
        super::common::write_stdout(&summary(&domain));
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
            "regions": k.regions.iter().map(|r| d.regions[r.index()].name.clone()).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "relations": d.relations.iter().map(|r| json!({
            "name": r.name,
            "text": r.text,
            "distance": r.placement.distance,
            "ahead": r.placement.ahead,
            "left": r.placement.left,
            "on_top": r.placement.on_top,
        })).collect::<Vec<_>>(),
        "world": d.world.iter().map(|a| json!({ "name": a.name, "default": default_text(d, a) })).collect::<Vec<_>>(),
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

/// A readable summary of the domain.
pub fn summary(d: &Domain) -> String {
    let mut s = String::new();
    let n_mod = d.concepts.iter().filter(|c| c.kind == ConceptKind::Modifier).count();
    let _ = writeln!(s, "domain {}", d.name);
    let _ = writeln!(
        s,
        "  concepts: {}, modifiers: {}, kinds: {}, constraints: {}, questions: {}, rules: {} ({})",
        d.concepts.len() - n_mod,
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
        let _ = writeln!(s, "  {}: {}", c.name, constraint_text(d, &c.rule));
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

fn constraint_text(d: &Domain, rule: &ConstraintRule) -> String {
    let names = |s: ConceptSet| d.set_names(s).join(", ");
    match rule {
        ConstraintRule::AtMost { members, max } => format!("at most {max} of {}", names(*members)),
        ConstraintRule::Requires { concept, any_of } => {
            format!("{} requires one of {}", d.concepts[concept.index()].name, names(*any_of))
        }
        ConstraintRule::Forbids { all } => format!("never all of {}", names(*all)),
    }
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
            let k = &d.kinds[kind.index()];
            let to = relation.to.as_deref().unwrap_or("ego");
            let mut s = format!("add {name}: {} in {} {} {to}", k.name, d.regions[region.index()].name, relation.name);
            if !attrs.is_empty() {
                let a: Vec<String> = attrs
                    .iter()
                    .map(|(n, v)| {
                        let dim = k.attr(n).and_then(|i| dimension(&k.attrs[i].ty));
                        format!("{n} = {}", explain::value_text(d, v, dim))
                    })
                    .collect();
                let _ = write!(s, " {{ {} }}", a.join(", "));
            }
            s
        }
        Effect::SetWorld { attr, value, .. } => {
            let dim = d.world_attr(attr).and_then(|a| dimension(&a.ty));
            format!("set world.{attr} = {}", explain::value_text(d, value, dim))
        }
        Effect::SetTarget { attr, value, .. } => {
            let dim = d.kinds.iter().find_map(|k| k.attr(attr).and_then(|i| dimension(&k.attrs[i].ty)));
            format!("set {attr} = {}", explain::value_text(d, value, dim))
        }
        Effect::MoveTarget { region, .. } => format!("move {}", d.regions[region.index()].name),
    }
}

fn dimension(ty: &AttrType) -> Option<&str> {
    match ty {
        AttrType::Number { dimension, .. } => Some(dimension),
        _ => None,
    }
}

/// A world attribute's default as written in source, with its unit (`2m..4m`, `true`, `foggy`).
fn default_text(d: &Domain, a: &AttrDef) -> String {
    explain::value_text(d, &a.default, dimension(&a.ty))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> Domain {
        let text = include_str!("../../tests/corpus/good/small_driving.rev");
        crate::check::compile_source("small_driving.rev", text).expect("the corpus domain compiles")
    }

    #[test]
    fn json_lists_concepts_rules_and_questions() {
        let j = to_json(&small());
        let near = &j["concepts"][6];
        assert_eq!(
            (near["name"].as_str(), near["index"].as_u64(), near["kind"].as_str()),
            (Some("near"), Some(6), Some("modifier"))
        );
        assert_eq!(near["probe"]["negative"], "It is not within a few meters.");
        assert_eq!(near["target"], "Collidable | LaneHazard");
        assert_eq!(j["selection"], "priority");
        let rules: Vec<&str> = j["rules"].as_array().unwrap().iter().map(|r| r["name"].as_str().unwrap()).collect();
        assert_eq!(rules, ["near_in_lane", "hazard_ahead", "clear"]);
        assert_eq!(j["rules"][0]["expect"], "stop");
        // Conditions and values print as written, with their units.
        assert_eq!(j["rules"][0]["when"], "exists e: Collidable | LaneHazard where e in lane and e.distance <= 4m");
        assert_eq!(
            j["concepts"][0]["effects"][0],
            "add barrier: ChainBarrier in lane ahead_of ego { distance = 2m..4m }"
        );
        assert_eq!(j["relations"][2]["name"], "near");
        assert_eq!(j["relations"][2]["distance"], serde_json::json!([0.0, 1.5]));
        assert_eq!(j["questions"][0]["options"][2]["letter"], "C");
        insta::assert_json_snapshot!("describe_small_driving", j);
    }

    #[test]
    fn summary_names_every_concept() {
        let d = small();
        let s = summary(&d);
        for c in &d.concepts {
            assert!(s.contains(&c.name), "{} missing from the summary", c.name);
        }
        assert!(s.contains("(C) go: Continue"));
        // Concepts and modifiers are counted apart: 6 + 3 = the 9 listed.
        assert!(s.contains("concepts: 6, modifiers: 3,"), "{s}");
        assert!(s.contains("e.distance <= 4m"), "{s}");
        assert!(s.contains("one_town: at most 1 of town_town01, town_town02"));
        assert!(s.contains("child_needs_ped: child_near_ped requires one of pedestrian_crossing"));
    }
}

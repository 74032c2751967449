//! `revelio oracle FILE CONCEPT... [--json]`: the ground truth of one concept set — question,
//! lettered options, expected answer, the deciding rule, its rationale and why it decided.

use std::io::{self, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use crate::ir::{ConceptSet, Domain, Selection};
use crate::oracle::{self, Verdict, option_letter};

#[derive(clap::Args, Debug)]
pub struct OracleArgs {
    /// The domain file (`.rev`)
    pub file: PathBuf,
    /// The concepts of the set (order does not matter)
    #[arg(required = true, num_args = 1..)]
    pub concepts: Vec<String>,
    /// Print JSON
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: OracleArgs) -> ExitCode {
    let domain = match crate::cli::load_domain(&args.file) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let set = match domain.parse_set(&args.concepts) {
        Ok(s) => s,
        Err(msg) => {
            // A concept the domain lacks is an input error (1), with the checker's "did you mean".
            eprintln!("error: {msg}");
            return ExitCode::from(1);
        }
    };
    let verdict = match oracle::evaluate(&domain, set) {
        Ok(v) => v,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let out = &mut io::stdout().lock();
    match write_verdict(&domain, set, &verdict, args.json, out).and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: cannot write the verdict: {e}");
            ExitCode::from(1)
        }
    }
}

pub fn write_verdict(
    domain: &Domain,
    set: ConceptSet,
    v: &Verdict,
    json: bool,
    out: &mut impl Write,
) -> io::Result<()> {
    let q = &domain.questions[v.question.index()];
    let rule = &domain.rules[v.rule.index()];
    let expected = &q.options[v.expected as usize];
    let selection = match domain.selection {
        Selection::Priority => "priority",
        Selection::BestFit => "best_fit",
    };
    if json {
        let options: Vec<_> = q
            .options
            .iter()
            .enumerate()
            .map(|(i, o)| serde_json::json!({ "letter": option_letter(i as u32), "name": o.name, "text": o.text }))
            .collect();
        let value = serde_json::json!({
            "set": domain.set_names(set),
            "selection": selection,
            "question": { "name": q.name, "text": q.text },
            "options": options,
            "expected": { "letter": v.letter(), "name": expected.name, "text": expected.text },
            "rule": rule.name,
            "safe": rule.safe,
            "score": v.score,
            "rationale": rule.rationale,
            "explanation": v.explanation,
        });
        return writeln!(out, "{value}");
    }
    writeln!(out, "set:         {}", domain.set_names(set).join(" "))?;
    writeln!(out, "question:    {}", q.text)?;
    for (i, o) in q.options.iter().enumerate() {
        writeln!(out, "  {}. {}", option_letter(i as u32), o.text)?;
    }
    writeln!(out, "expected:    {}. {} ({})", v.letter(), expected.text, expected.name)?;
    let score = v.score.map(|s| format!(", element fit {s}")).unwrap_or_default();
    let safe = if rule.safe { ", safe scene" } else { "" };
    writeln!(out, "rule:        {} ({selection}{score}{safe})", rule.name)?;
    if !rule.rationale.is_empty() {
        writeln!(out, "rationale:   {}", rule.rationale)?;
    }
    writeln!(out, "explanation: {}", v.explanation)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lattice::testkit::driving;

    fn render(names: &[&str], json: bool) -> String {
        let d = driving();
        let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
        let set = d.parse_set(&names).unwrap();
        let v = oracle::evaluate(&d, set).unwrap();
        let mut buf = Vec::new();
        write_verdict(&d, set, &v, json, &mut buf).unwrap();
        String::from_utf8(buf).unwrap()
    }

    #[test]
    fn verdict_human() {
        insta::assert_snapshot!(render(&["obstruction_near", "intersection_ego", "light_green"], false));
    }

    #[test]
    fn verdict_json() {
        insta::assert_snapshot!(render(&["cyclist", "on_sidewalk"], true));
    }

    #[test]
    fn unknown_concepts_get_a_suggestion() {
        let d = driving();
        let err = |n: &str| d.parse_set(&[n]).unwrap_err().to_string();
        assert_eq!(
            err("obstruction_nera"),
            "unknown concept `obstruction_nera` in domain `test`; did you mean `obstruction_near`?"
        );
        assert_eq!(err("zebra"), "unknown concept `zebra` in domain `test`");
    }
}

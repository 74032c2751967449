//! `failure_modes.csv`, `sets.csv`, `concepts.csv` and `pairs.csv` (RFC 4180: comma-separated, CRLF-free, fields quoted when
//! they hold a comma, quote or line break). Concept sets are written as `a + b + c`.

use std::collections::BTreeSet;

use super::{Findings, Run};
use crate::analysis::anytime95;
use crate::analysis::probe::ProbeReport;
use crate::analysis::transfer::Transfer;
use crate::outcome::Outcome;

fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

fn line(out: &mut String, fields: &[String]) {
    let f: Vec<String> = fields.iter().map(|s| field(s)).collect();
    out.push_str(&f.join(","));
    out.push('\n');
}

fn num(x: Option<f64>) -> String {
    x.map_or_else(String::new, |x| format!("{x:.4}"))
}

fn ci(c: Option<(f64, f64)>) -> [String; 2] {
    [num(c.map(|c| c.0)), num(c.map(|c| c.1))]
}

/// One row per failure mode, highest FR first: its interval, the core it belongs to, and its
/// validated FR where the run was validated.
pub fn failure_modes(run: &Run, f: &Findings<'_>) -> String {
    let mut out = String::new();
    let head = "rank,concepts,size,fr,ci95_lo,ci95_hi,wrong,answered,observations,core,validated_fr,validated_ci95_lo,validated_ci95_hi,validated_answered";
    line(&mut out, &head.split(',').map(String::from).collect::<Vec<_>>());
    for (i, m) in run.summary.failure_modes.iter().enumerate() {
        let [lo, hi] = ci(run.mode_ci(i));
        let core = f.mode_core[i].map(|c| f.cores[c].concepts.join(" + ")).unwrap_or_default();
        let v = run.validated(&m.concepts);
        let [vlo, vhi] = ci(v.and_then(super::row_ci));
        line(
            &mut out,
            &[
                (i + 1).to_string(),
                m.concepts.join(" + "),
                m.concepts.len().to_string(),
                num(m.fr),
                lo,
                hi,
                m.wrong.to_string(),
                m.answered.to_string(),
                m.observations.to_string(),
                core,
                num(v.and_then(|v| v.fr)),
                vlo,
                vhi,
                v.map(|v| v.answered.to_string()).unwrap_or_default(),
            ],
        );
    }
    out
}

/// One row per evaluated set, in evaluation order, with a column per unanswered outcome that
/// occurs in the run.
pub fn sets(run: &Run) -> String {
    let s = &run.summary;
    let outcomes: BTreeSet<Outcome> = s.sets.iter().flat_map(|r| r.unanswered.keys().copied()).collect();
    let mut head: Vec<String> = "order,concepts,size,fr,ci95_lo,ci95_hi,wrong,answered,observations,failure_mode"
        .split(',')
        .map(String::from)
        .collect();
    head.extend(outcomes.iter().map(|o| o.name().to_string()));
    let mut out = String::new();
    line(&mut out, &head);
    for (i, r) in s.sets.iter().enumerate() {
        let [lo, hi] = ci(run.set_ci(i));
        let mut row = vec![
            (i + 1).to_string(),
            r.concepts.join(" + "),
            r.concepts.len().to_string(),
            num(r.fr),
            lo,
            hi,
            r.wrong.to_string(),
            r.answered.to_string(),
            r.observations.to_string(),
            r.fr.is_some_and(|f| f >= s.threshold).to_string(),
        ];
        row.extend(outcomes.iter().map(|o| r.unanswered.get(o).copied().unwrap_or(0).to_string()));
        line(&mut out, &row);
    }
    out
}

/// `concepts.csv`: one row per concept of an evaluated set, highest F(c) first (the page's
/// table, which shows the first rows only).
pub fn concepts(f: &Findings<'_>) -> String {
    let mut out = String::new();
    line(&mut out, &["concept", "f", "n", "failure_modes"].map(String::from));
    for c in &f.concepts {
        line(&mut out, &[c.concept.clone(), num(Some(c.f)), c.n.to_string(), c.failure_modes.to_string()]);
    }
    out
}

/// `pairs.csv`: one row per evaluated pair (a single concept on the diagonal), highest rate
/// first (the page's pair table, which shows the first rows only).
pub fn pairs(f: &Findings<'_>) -> String {
    let mut out = String::new();
    line(&mut out, &["concepts", "fr", "n"].map(String::from));
    for (pair, c) in super::scale::ranked_pairs(&f.pairs) {
        line(&mut out, &[pair, num(Some(c.fr)), c.n.to_string()]);
    }
    out
}

/// `recognition.csv`: one row per probed concept (highest F(c) first): R(c) with its interval
/// and the statements behind it, F(c), n and the mechanism.
pub fn recognition(p: &ProbeReport) -> String {
    let mut out = String::new();
    let head = "concept,r,r_ci95_lo,r_ci95_hi,statements_right,statements_answered,statements_unanswered,f,n,mechanism";
    line(&mut out, &head.split(',').map(String::from).collect::<Vec<_>>());
    for c in &p.analysis.concepts {
        let m = &c.marks;
        let (right, answered) = (m.pos_correct + m.neg_correct, m.pos_total + m.neg_total);
        let [lo, hi] = ci(anytime95(u64::from(right), u64::from(answered)));
        line(
            &mut out,
            &[
                c.concept.clone(),
                num(c.recognition),
                lo,
                hi,
                right.to_string(),
                answered.to_string(),
                m.unanswered.to_string(),
                num(c.failure),
                c.n.to_string(),
                c.mechanism.map_or("", |m| m.name()).to_string(),
            ],
        );
    }
    out
}

/// `transfer.csv`: one row per transferred set (in the source's order), then per random set;
/// the source run's FR, and each model's FR and answered count (columns named by model).
pub fn transfer(t: &Transfer) -> String {
    let mut head: Vec<String> = ["kind", "rank", "concepts", "search_fr"].map(String::from).to_vec();
    for m in &t.models {
        head.push(format!("fr {m}"));
        head.push(format!("answered {m}"));
    }
    let mut out = String::new();
    line(&mut out, &head);
    for (kind, lines) in [("transferred", &t.sets), ("random", &t.random)] {
        for (i, s) in lines.iter().enumerate() {
            let mut row = vec![kind.to_string(), (i + 1).to_string(), s.concepts.join(" + "), num(s.source_fr)];
            for m in 0..t.models.len() {
                row.push(num(s.target_fr.get(m).copied().flatten()));
                row.push(s.answered.get(m).map(u32::to_string).unwrap_or_default());
            }
            line(&mut out, &row);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_quoted_only_when_needed() {
        assert_eq!(field("a + b"), "a + b");
        assert_eq!(field("a,b"), "\"a,b\"");
        assert_eq!(field("say \"B\"\nnow"), "\"say \"\"B\"\"\nnow\"");
    }
}

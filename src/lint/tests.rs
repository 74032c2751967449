//! The lattice lints on the fixture domains: excluded concepts and lost modifiers, shadowed and
//! undetermined rules, best-fit ties, determinism, and linear time in the number of rules.
use super::*;
use crate::ir::{CmpOp, ConceptSet, ConstraintRule, Expr, Selection};
use crate::lattice::testkit::*;

/// (code, message, underlined span start) of each diagnostic.
fn findings(d: &Domain) -> Vec<(&'static str, String, u32)> {
    lint_domain(d).into_iter().map(|x| (x.code, x.message, x.span.map_or(0, |s| s.start))).collect()
}

fn span_of_rule(d: &Domain, name: &str) -> u32 {
    d.rules.iter().find(|r| r.name == name).unwrap().span.start
}

fn span_of_concept(d: &Domain, name: &str) -> u32 {
    d.concept_by_name(name).unwrap().span.start
}

#[test]
fn the_driving_fixture_is_clean() {
    assert_eq!(findings(&driving()), vec![]);
}

#[test]
fn excluded_concepts_and_lost_modifiers() {
    let mut b = Dom::new(Selection::Priority);
    let k = b.kind("K", &[], &[("distance", num(5.0))]);
    let bare = b.kind("Bare", &[], &[]);
    let other = b.kind("Other", &[], &[]);
    let x = b.concept("x", &[("e", k, "lane", &[])]);
    b.concept("y", &[("f", bare, "lane", &[])]);
    b.modifier("lost", filter(&[other], &[]), &[]);
    b.modifier("closer", filter(&[bare], &[]), &[("distance", num(1.0))]);
    b.constraint("never_x", ConstraintRule::AtMost { members: ConceptSet::single(x), max: 0 });
    let q = b.question("q", &["yes"]);
    b.rule("always", q, 0, None, &[]);
    let d = b.build();
    let diags = lint_domain(&d);
    let got: Vec<_> = diags.iter().map(|x| (x.code, x.message.as_str(), x.span.unwrap().start)).collect();
    assert_eq!(
        got,
        vec![
            ("R0100", "concept `x` appears in no valid set of up to 5 concepts", span_of_concept(&d, "x")),
            (
                "R0105",
                "modifier `lost` has no possible target: no concept adds an entity matching `Other`",
                span_of_concept(&d, "lost")
            ),
            (
                "R0105",
                "modifier `closer` has no possible target: every entity it can apply to lacks an attribute it sets",
                span_of_concept(&d, "closer")
            ),
        ]
    );
    assert_eq!(diags[0].help.as_deref(), Some("constraint `never_x` (at most 0 of `x`) excludes it even alone"));
}

/// Priority rules where a broad rule shadows a narrower one placed after it.
fn shadowing() -> Domain {
    let mut b = Dom::new(Selection::Priority);
    let x = b.concept("x", &[]);
    let y = b.concept("y", &[]);
    let z = b.concept("z", &[]);
    b.constraint("not_yz", ConstraintRule::Forbids { all: ConceptSet::from_ids([y, z]) });
    let q = b.question("act", &["stop", "slow", "go", "wave"]);
    b.rule("any_x", q, 0, Some(Expr::Has(x)), &[]);
    b.rule("x_and_y", q, 1, Some(Expr::And(vec![Expr::Has(x), Expr::Has(y)])), &[]);
    b.rule("y_and_z", q, 3, Some(Expr::And(vec![Expr::Has(y), Expr::Has(z)])), &[]);
    b.rule("otherwise", q, 2, None, &[]);
    b.build()
}

#[test]
fn shadowed_rules_name_the_rule_that_wins() {
    let d = shadowing();
    let diags = lint_domain(&d);
    let got: Vec<_> = diags.iter().map(|x| (x.code, x.message.as_str(), x.span.unwrap().start)).collect();
    assert_eq!(
        got,
        vec![
            ("R0101", "rule `x_and_y` is shadowed by `any_x`", span_of_rule(&d, "x_and_y")),
            (
                "R0101",
                "rule `y_and_z` is never selected: its condition holds for no valid set of up to 5 concepts",
                span_of_rule(&d, "y_and_z")
            ),
            ("R0104", "option `act.slow` is never the expected answer", d.questions[0].span.start),
            ("R0104", "option `act.wave` is never the expected answer", d.questions[0].span.start),
        ]
    );
    assert_eq!(diags[0].related[0].span, d.rules[0].span);
    assert_eq!(diags[0].related[0].message, "selected instead, e.g. for {`x`, `y`}");
    assert_eq!(diags[0].help.as_deref(), Some("move `x_and_y` before `any_x`, or narrow the condition of `any_x`"));
    assert_eq!(diags[2].help.as_deref(), Some("the rules that expect it (`x_and_y`) are never selected"));
}

#[test]
fn undetermined_rules_name_an_example_and_the_attribute() {
    let mut b = Dom::new(Selection::Priority);
    let k = b.kind("Box", &[], &[("distance", range(3.0, 6.0))]);
    b.concept("parcel", &[("parcel", k, "lane", &[])]);
    b.concept("other", &[]);
    let q = b.question("drive", &["stop", "go"]);
    let close = exists(filter(&[k], &[]), Some(attr_cmp("distance", CmpOp::Le, num(4.0))));
    b.rule("close", q, 0, Some(close), &[]);
    let parcel = b.d.concept_by_name("parcel").unwrap().id;
    // Applies only where `close`, before it, is undetermined: never selected, never shadowed.
    b.rule("parcel_seen", q, 0, Some(Expr::Has(parcel)), &[]);
    b.rule("open", q, 1, None, &[]);
    let d = b.build();
    let all = lint_domain(&d);
    assert_eq!(all.len(), 3, "{all:#?}");
    assert_eq!(
        all[1].message,
        "rule `parcel_seen` is never selected: wherever its condition holds, the answer is undetermined"
    );
    let diags = [all[0].clone(), all[2].clone()];
    assert_eq!(diags[0].code, "R0102");
    assert_eq!(
        diags[0].message,
        "rule `close` leaves the expected answer undetermined for {`parcel`} and 1 other valid set"
    );
    assert_eq!(diags[0].label, "`parcel.distance` is 3..6, which straddles `<= 4`");
    assert_eq!(diags[0].span, Some(d.rules[0].span));
    assert_eq!(diags[1].message, "option `drive.stop` is never the expected answer");
}

#[test]
fn best_fit_ties_and_unmatched_sets() {
    let mut b = Dom::new(Selection::BestFit);
    let kitchen = b.concept("kitchen", &[]);
    let glass = b.concept("glass_floor", &[]);
    let stove = b.concept("stove_on", &[]);
    let cut = b.question("cut_risk", &["yes", "no"]);
    let burn = b.question("burn_risk", &["yes", "no"]);
    b.rule("loose_glass", cut, 0, Some(Expr::Has(glass)), &[glass, kitchen]);
    b.rule("hot_stove", burn, 0, Some(Expr::Has(stove)), &[stove, kitchen]);
    // Same condition and elements as `loose_glass`, other answer: always tied, always losing.
    b.rule("glass_fine", cut, 1, Some(Expr::Has(glass)), &[glass, kitchen]);
    let d = b.build();
    let rule = |n: &str| span_of_rule(&d, n);
    let question = |i: usize| d.questions[i].span.start;
    let expected: Vec<(&str, &str, u32)> = vec![
        (
            "R0103",
            "rules `loose_glass` and `hot_stove` tie with different answers for {`glass_floor`, `stove_on`} and 1 \
             other valid set",
            rule("hot_stove"),
        ),
        ("R0101", "rule `glass_fine` is shadowed by `loose_glass`", rule("glass_fine")),
        (
            "R0103",
            "rules `loose_glass` and `glass_fine` tie with different answers for {`glass_floor`} and 3 other valid sets",
            rule("glass_fine"),
        ),
        ("R0104", "option `cut_risk.no` is never the expected answer", question(0)),
        ("R0104", "option `burn_risk.no` is never the expected answer", question(1)),
        ("R0106", "no rule matches {`kitchen`}", rule("glass_fine")),
    ];
    let got = findings(&d);
    assert_eq!(got, expected.into_iter().map(|(c, m, s)| (c, m.to_string(), s)).collect::<Vec<_>>());
    let diags = lint_domain(&d);
    assert_eq!(diags[0].related[0].span, d.rules[0].span, "the tie's winner is the related span");
}

#[test]
fn specificity_decides_before_declaration_order_so_it_is_no_tie() {
    let mut b = Dom::new(Selection::BestFit);
    let glass = b.concept("glass_floor", &[]);
    let toddler = b.concept("toddler", &[]);
    let q = b.question("cut_risk", &["yes", "no"]);
    b.rule("broad", q, 0, Some(Expr::Has(glass)), &[glass, toddler]);
    b.rule("narrow", q, 1, Some(Expr::Has(glass)), &[glass]);
    b.rule("default", q, 1, None, &[]);
    let d = b.build();
    // {glass_floor}: `narrow` covers 1/1 and beats `broad` (1/2); with the toddler `broad` wins.
    assert_eq!(findings(&d), vec![]);
}

#[test]
fn lints_are_deterministic() {
    let d = shadowing();
    assert_eq!(lint_domain(&d), lint_domain(&d));
}

#[test]
fn an_undetermined_rule_is_not_also_called_shadowed() {
    let mut b = Dom::new(Selection::Priority);
    let k = b.kind("Box", &[], &[("distance", range(3.0, 6.0))]);
    b.concept("parcel", &[("parcel", k, "lane", &[])]);
    let crate_near = b.concept("crate_near", &[("crate", k, "lane", &[("distance", range(1.0, 2.0))])]);
    b.concept("empty_road", &[]);
    let q = b.question("drive", &["stop", "go"]);
    b.rule("crate_seen", q, 0, Some(Expr::Has(crate_near)), &[]);
    // True only with the crate (where `crate_seen` wins), unknown with the parcel alone.
    let close = exists(filter(&[k], &[]), Some(attr_cmp("distance", CmpOp::Le, num(4.0))));
    b.rule("close", q, 0, Some(close), &[]);
    b.rule("open", q, 1, None, &[]);
    let d = b.build();
    let diags = lint_domain(&d);
    let codes: Vec<&str> = diags.iter().map(|x| x.code).collect();
    // Before, R0101 also advised moving `close` before `crate_seen`, which leaves it undetermined.
    assert_eq!(codes, ["R0102"], "{diags:#?}");
    assert_eq!(diags[0].span, Some(span_of_rule_at(&d, "close")));
    assert_eq!(diags[0].related.len(), 1);
    assert_eq!(diags[0].related[0].span, d.rules[0].span);
    assert_eq!(
        diags[0].related[0].message,
        "where `close` holds it is never selected: this rule is, e.g. for {`crate_near`}"
    );
}

fn span_of_rule_at(d: &Domain, name: &str) -> crate::ir::Span {
    d.rules.iter().find(|r| r.name == name).unwrap().span
}

#[test]
fn forty_thousand_rules_lint_in_memory_linear_in_rules() {
    // Rule × rule tables were 2 × 1.6 × 10^9 entries here (over 100 GB: the process aborted);
    // the tallies are per rule.
    const RULES: usize = 40_000;
    let mut b = Dom::new(Selection::Priority);
    let cs: Vec<_> = (0..4).map(|i| b.concept(&format!("c{i}"), &[])).collect();
    let q = b.question("q", &["a", "b"]);
    for j in 0..RULES {
        b.rule(&format!("r{j}"), q, (j % 2) as u32, Some(Expr::Has(cs[j % 4])), &[]);
    }
    let d = b.build();
    let diags = lint_domain(&d);
    assert_eq!(diags.len(), RULES - 4, "every rule after the first four is shadowed");
    assert_eq!(diags[0].message, "rule `r4` is shadowed by `r0`");
}

#[test]
fn a_rule_shadowed_by_many_names_one_and_counts_at_least() {
    let mut b = Dom::new(Selection::Priority);
    let cs: Vec<_> = (0..10).map(|i| b.concept(&format!("c{i}"), &[])).collect();
    let q = b.question("q", &["a", "b"]);
    for (i, &c) in cs.iter().enumerate() {
        b.rule(&format!("r{i}"), q, 0, Some(Expr::Has(c)), &[]);
    }
    b.rule("late", q, 1, Some(Expr::Or(cs.iter().map(|&c| Expr::Has(c)).collect())), &[]);
    let d = b.build();
    let diags = lint_domain(&d);
    let late: Vec<&str> = diags.iter().filter(|x| x.code == "R0101").map(|x| x.message.as_str()).collect();
    // `r0` takes the most sets (every set holding `c0`); ten rules shadow `late`, eight are tallied.
    assert_eq!(late, ["rule `late` is shadowed by `r0` and at least 8 other rules"]);
}

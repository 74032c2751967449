//! The oracle's verdicts and explanations on the fixture domains: the priority and best-fit
//! rule choices, straddling ranges, safe rules, invalid sets and determinism over the lattice.
use super::*;
use crate::ir::{CmpOp, Expr};
use crate::lattice::Lattice;
use crate::lattice::testkit::*;

fn set(d: &Domain, names: &[&str]) -> ConceptSet {
    d.parse_set(names).expect("fixture concept")
}

/// (rule name, option name, letter) of a set's verdict.
fn answer(d: &Domain, names: &[&str]) -> (String, String, String) {
    let v = evaluate(d, set(d, names)).unwrap_or_else(|e| panic!("{names:?}: {e}"));
    let q = &d.questions[v.question.index()];
    (d.rules[v.rule.index()].name.clone(), q.options[v.expected as usize].name.clone(), v.letter())
}

fn expect(d: &Domain, names: &[&str], rule: &str, option: &str, letter: &str) {
    assert_eq!(answer(d, names), (rule.into(), option.into(), letter.into()), "{names:?}");
}

#[test]
fn driving_priority_table() {
    let d = driving();
    expect(&d, &["obstruction_near"], "near_in_lane", "stop", "A");
    expect(&d, &["obstruction_far"], "hazard_ahead", "slow", "B");
    expect(&d, &["intersection_ego", "light_green"], "clear", "go", "C");
    expect(&d, &["obstruction_near", "intersection_ego", "light_green"], "near_in_lane", "stop", "A");
    expect(&d, &["intersection_ego", "light_red"], "red_light", "stop", "A");
    expect(&d, &["cyclist", "on_sidewalk"], "clear", "go", "C");
    // `near` moves the cone (declared last among the entities) into braking distance.
    expect(&d, &["cone", "near"], "near_in_lane", "stop", "A");
    expect(&d, &["obstruction_near", "far"], "hazard_ahead", "slow", "B");
    expect(&d, &["weather_foggy"], "clear", "go", "C");
}

#[test]
fn explanation_names_the_rule_and_the_witness() {
    let d = driving();
    let v = evaluate(&d, set(&d, &["obstruction_near", "weather_foggy"])).unwrap();
    assert_eq!(
        v.explanation,
        "`near_in_lane` is the first rule (#1 of 4) that applies: \
         `exists e: Collidable where e in lane and e.distance <= 4` holds for `obstruction`, added by `obstruction_near`"
    );
    assert_eq!(v.score, None);
    let v = evaluate(&d, set(&d, &["weather_foggy"])).unwrap();
    assert_eq!(v.explanation, "`clear` is the first rule (#4 of 4) that applies: it has no condition");
}

#[test]
fn invalid_sets_name_the_violation() {
    let d = driving();
    let err = |names: &[&str]| evaluate(&d, set(&d, names)).unwrap_err().to_string();
    assert_eq!(
        err(&["town_town01", "town_town02"]),
        "invalid concept set {`town_town01`, `town_town02`}: violates constraint `one_town` (at most 1 of `town_town01`, `town_town02`)"
    );
    assert_eq!(
        err(&["cone", "near", "far"]),
        "invalid concept set {`cone`, `near`, `far`}: violates constraint `near_xor_far` (at most 1 of `near`, `far`)"
    );
    assert_eq!(err(&["near"]), "invalid concept set {`near`}: modifier `near` has no entity to apply to");
    assert_eq!(
        evaluate(&d, ConceptSet::EMPTY).unwrap_err().to_string(),
        "invalid concept set {}: the empty set has no scene"
    );
}

/// A domain where `parcel` lies 3–6 m ahead, straddling the 4 m braking threshold.
fn straddling(selection: Selection) -> Domain {
    let mut b = Dom::new(selection);
    let k = b.kind("Box", &[], &[("distance", range(3.0, 6.0))]);
    let parcel = b.concept("parcel", &[("parcel", k, "lane", &[])]);
    let far = b.concept("far_box", &[("far_box", k, "lane", &[("distance", range(20.0, 30.0))])]);
    let q = b.question("drive", &["stop", "go"]);
    let close = exists(filter(&[k], &[]), Some(attr_cmp("distance", CmpOp::Le, num(4.0))));
    b.rule("close", q, 0, Some(close), &[parcel]);
    b.rule("open", q, 1, Some(Expr::Has(far)), &[far]);
    b.build()
}

#[test]
fn straddling_range_is_undetermined_under_priority() {
    let d = straddling(Selection::Priority);
    let err = evaluate(&d, set(&d, &["parcel"])).unwrap_err();
    assert_eq!(
        err.to_string(),
        "the expected answer for {`parcel`} is undetermined: rule `close` may or may not apply, \
         because `parcel.distance` is 3..6, which straddles `<= 4`"
    );
    // A rule before the unknown one decides regardless of it: here `close` comes first, so
    // `far_box` alone is decided by `open`.
    expect(&d, &["far_box"], "open", "go", "B");
    assert!(matches!(evaluate(&d, set(&d, &["parcel", "far_box"])), Err(OracleError::Undetermined { .. })));
}

#[test]
fn straddling_range_matters_under_best_fit_only_when_it_could_win() {
    let d = straddling(Selection::BestFit);
    assert!(matches!(evaluate(&d, set(&d, &["parcel"])), Err(OracleError::Undetermined { .. })));
    // `open` scores 1, `close` would score 1 too and is declared first: it could pre-empt.
    assert!(matches!(evaluate(&d, set(&d, &["parcel", "far_box"])), Err(OracleError::Undetermined { .. })));
    expect(&d, &["far_box"], "open", "go", "B");
}

/// The paper's indoor shape: best fit over rules with their own questions.
fn indoor() -> Domain {
    let mut b = Dom::new(Selection::BestFit);
    let k = b.kind("Thing", &[], &[]);
    let kitchen = b.concept("kitchen", &[]);
    let glass = b.concept("glass_floor", &[("glass", k, "lane", &[])]);
    let barefoot = b.concept("barefoot_near_glass", &[("toddler", k, "lane", &[])]);
    let toddler = b.concept("toddler_standing", &[("toddler", k, "lane", &[])]);
    let safe = b.concept("barefoot_child_safe", &[("toddler", k, "lane", &[])]);
    let stove = b.concept("stove_on", &[("stove", k, "lane", &[])]);
    let cut = b.question("cut_risk", &["yes", "no"]);
    let burn = b.question("burn_risk", &["yes", "no"]);
    let both = Expr::And(vec![Expr::Has(glass), Expr::Has(barefoot)]);
    b.rule("glass_cut", cut, 0, Some(both), &[glass, barefoot, toddler]);
    b.rule("loose_glass", cut, 0, Some(Expr::Has(glass)), &[glass, kitchen]);
    b.rule("safe_child", cut, 1, Some(Expr::Has(safe)), &[safe, kitchen]);
    b.rule("hot_stove", burn, 0, Some(Expr::Has(stove)), &[stove, kitchen]);
    b.rule("safe_scene", cut, 1, None, &[safe, toddler, kitchen]);
    b.safe();
    b.build()
}

#[test]
fn best_fit_picks_the_highest_element_fit() {
    let d = indoor();
    expect(&d, &["glass_floor", "barefoot_near_glass"], "glass_cut", "yes", "A");
    expect(&d, &["barefoot_child_safe"], "safe_child", "no", "B");
    expect(&d, &["glass_floor", "kitchen"], "loose_glass", "yes", "A");
    expect(&d, &["stove_on"], "hot_stove", "yes", "A");
    let v = evaluate(&d, set(&d, &["glass_floor", "barefoot_near_glass", "toddler_standing", "kitchen"])).unwrap();
    assert_eq!(v.score, Some(3));
    assert_eq!(d.rules[v.rule.index()].name, "glass_cut");
    assert_eq!(
        v.explanation,
        "`glass_cut` fits best among 2 matching rules: 3 of the set's concepts are among its elements \
         (`glass_floor`, `barefoot_near_glass`, `toddler_standing`); `has glass_floor and has barefoot_near_glass` holds"
    );
}

#[test]
fn best_fit_ties_go_to_the_rule_declared_first() {
    let d = indoor();
    // `loose_glass` (glass_floor, kitchen) and `hot_stove` (stove_on, kitchen) both score 2.
    let v = evaluate(&d, set(&d, &["kitchen", "glass_floor", "stove_on"])).unwrap();
    assert_eq!(d.rules[v.rule.index()].name, "loose_glass");
    assert_eq!(v.score, Some(2));
    assert!(v.explanation.contains("it ties with `hot_stove` and is declared first"), "{}", v.explanation);
    assert_eq!(evaluate(&d, set(&d, &["stove_on"])).unwrap().score, Some(1));
}

#[test]
fn best_fit_prefers_the_more_specific_rule_on_equal_scores() {
    let d = indoor();
    // `glass_cut` covers 2 of 3 elements, `loose_glass` 1 of 2: the score decides first.
    expect(&d, &["glass_floor", "barefoot_near_glass"], "glass_cut", "yes", "A");
    let v = evaluate(&d, set(&d, &["kitchen", "barefoot_child_safe"])).unwrap();
    // `safe_child` covers 2/2, `safe_scene` 2/3: same score, the more specific rule wins.
    assert_eq!(d.rules[v.rule.index()].name, "safe_child");
    assert!(v.explanation.contains("it is more specific than `safe_scene`"), "{}", v.explanation);
}

#[test]
fn safe_rules_match_only_sets_made_of_their_elements() {
    let d = indoor();
    expect(&d, &["kitchen"], "safe_scene", "no", "B");
    expect(&d, &["kitchen", "toddler_standing"], "safe_scene", "no", "B");
    // A hazard concept outside its elements turns the safe rule off.
    assert_eq!(
        evaluate(&d, set(&d, &["kitchen", "toddler_standing", "barefoot_near_glass"])).unwrap_err().to_string(),
        "no rule matches {`kitchen`, `barefoot_near_glass`, `toddler_standing`}"
    );
}

#[test]
fn verdicts_are_deterministic_over_the_lattice() {
    for d in [driving(), indoor()] {
        let lattice = Lattice::enumerate(&d, 3);
        let oracle = Oracle::new(&d);
        let first: Vec<_> = lattice.sets.iter().map(|s| oracle.evaluate(*s)).collect();
        let again: Vec<_> = lattice.sets.iter().map(|s| evaluate(&d, *s)).collect();
        assert_eq!(first, again);
        if d.selection == Selection::Priority {
            // The driving rules end in a catch-all over ranges that never straddle 4 m.
            assert!(first.iter().all(Result::is_ok));
        }
    }
}

#[test]
fn every_image_of_a_set_shares_its_answer_because_ranges_are_decided_on_the_anchor() {
    // `near` overrides a 6–12 m pedestrian to 2–4 m: the whole range is within 4 m.
    let d = driving();
    expect(&d, &["pedestrian", "near"], "near_in_lane", "stop", "A");
    expect(&d, &["pedestrian"], "hazard_ahead", "slow", "B");
}

#[test]
fn best_fit_ties_go_to_the_more_specific_rule_before_declaration_order() {
    let mut b = Dom::new(Selection::BestFit);
    let k = b.kind("Thing", &[], &[]);
    let outlet = b.concept("outlet_covered", &[("outlet", k, "lane", &[])]);
    let toddler = b.concept("toddler_standing", &[("toddler", k, "lane", &[])]);
    let glass = b.concept("glass_upright", &[("glass", k, "lane", &[])]);
    let shock = b.question("shock", &["yes", "no"]);
    let hazard = b.question("hazard", &["yes", "no"]);
    // Declared first but broader: 2 of 3 elements covered vs. 2 of 2.
    b.rule("broad", hazard, 1, None, &[outlet, toddler, glass]);
    b.rule("narrow", shock, 1, Some(Expr::Has(outlet)), &[outlet, toddler]);
    let d = b.build();
    expect(&d, &["outlet_covered", "toddler_standing"], "narrow", "no", "B");
    expect(&d, &["glass_upright", "toddler_standing"], "broad", "no", "B");
}

#[test]
fn safe_rules_only_match_sets_made_of_their_elements() {
    let mut b = Dom::new(Selection::BestFit);
    let k = b.kind("Thing", &[], &[]);
    let safe = b.concept("barefoot_child_safe", &[("toddler", k, "lane", &[])]);
    let stove = b.concept("stove_on", &[("stove", k, "lane", &[])]);
    let cut = b.question("cut_floor", &["yes", "no"]);
    let fire = b.question("fire", &["yes", "no"]);
    b.rule("safe_barefoot", cut, 1, Some(Expr::Has(safe)), &[safe]);
    b.rule("stove_lit", fire, 0, Some(Expr::Has(stove)), &[stove]);
    let mut d = b.build();
    d.rules[0].safe = true;
    expect(&d, &["barefoot_child_safe"], "safe_barefoot", "no", "B");
    // The stove is not one of the safe rule's elements, so the scene is not a safe scene.
    expect(&d, &["barefoot_child_safe", "stove_on"], "stove_lit", "yes", "A");
}

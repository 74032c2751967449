//! Run analysis on hand-built journals and rows: the Wilson interval against published values,
//! per-concept and per-pair rates, retried observations, discovery curves and minimal failure
//! modes.
use std::collections::BTreeMap;

use super::*;
use crate::outcome::Answer;

fn names(s: &[&str]) -> Vec<String> {
    s.iter().map(|c| c.to_string()).collect()
}

fn row(concepts: &[&str], wrong: u32, answered: u32) -> SetRow {
    SetRow::from_counts(concepts, wrong, answered)
}

fn record(phase: Phase, set: &[&str], obs: u32, outcome: Outcome) -> Record {
    Record { answer: Some(Answer::Unparsed), ..Record::test(phase, set, obs, outcome) }
}

#[test]
fn wilson_matches_published_values() {
    // Newcombe (1998), Statistics in Medicine 17:857–872, Table II, method 3 (score, no
    // continuity correction), to the four decimals printed there.
    for (k, n, lo, hi) in
        [(81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611), (1, 29, 0.0061, 0.1718)]
    {
        let (l, h) = wilson95(k, n).unwrap();
        assert!((l - lo).abs() < 5e-5 && (h - hi).abs() < 5e-5, "{k}/{n}: [{l:.4}, {h:.4}], expected [{lo}, {hi}]");
    }
    assert_eq!(wilson95(0, 0), None);
    let (l, h) = wilson95(5, 5).unwrap();
    assert!((h - 1.0).abs() < 1e-12 && (l - 0.5655).abs() < 5e-5, "{l} {h}");
}

#[test]
fn concept_rates_average_the_sets_containing_each_concept() {
    let sets = [row(&["a", "b"], 4, 4), row(&["a"], 1, 4), row(&["b", "c"], 0, 5), row(&["c"], 0, 0)];
    let rates = concept_rates(&sets, 0.6);
    let got: Vec<(&str, f64, u32, u32)> =
        rates.iter().map(|r| (r.concept.as_str(), r.f, r.n, r.failure_modes)).collect();
    // c's second set has no failure rate and does not count.
    assert_eq!(got, vec![("a", 0.625, 2, 1), ("b", 0.5, 2, 1), ("c", 0.0, 1, 0)]);
}

#[test]
fn pair_rates_hold_the_diagonal_and_leave_unseen_pairs_empty() {
    let sets = [row(&["a", "b"], 4, 4), row(&["a"], 1, 4), row(&["b", "c"], 0, 5)];
    let p = pair_rates(&sets, &names(&["a", "b", "c"]));
    assert_eq!(p.cells[0][0], Some(PairRate { fr: 0.625, n: 2 }));
    assert_eq!(p.cells[0][1], Some(PairRate { fr: 1.0, n: 1 }));
    assert_eq!(p.cells[1][0], p.cells[0][1]);
    assert_eq!(p.cells[0][2], None);
    assert_eq!(p.cells[1][2], Some(PairRate { fr: 0.0, n: 1 }));
}

#[test]
fn newest_line_wins_for_a_retried_observation() {
    let records = [
        record(Phase::Search, &["a"], 0, Outcome::ApiError),
        record(Phase::Search, &["a"], 1, Outcome::Correct),
        record(Phase::Search, &["a"], 0, Outcome::Wrong),
        record(Phase::Validate, &["a"], 0, Outcome::Correct),
    ];
    let obs = latest_observations(&records);
    let got: Vec<(Phase, u32, Outcome)> = obs.iter().map(|r| (r.phase, r.obs, r.outcome)).collect();
    assert_eq!(
        got,
        vec![
            (Phase::Search, 1, Outcome::Correct),
            (Phase::Search, 0, Outcome::Wrong),
            (Phase::Validate, 0, Outcome::Correct)
        ]
    );
    let counts = outcome_counts(&obs);
    assert_eq!(counts[&Phase::Search], BTreeMap::from([(Outcome::Correct, 1), (Outcome::Wrong, 1)]));
    assert_eq!(counts[&Phase::Validate], BTreeMap::from([(Outcome::Correct, 1)]));
}

#[test]
fn discovery_counts_modes_at_their_last_observation_and_cores_at_their_first_mode() {
    use Outcome::*;
    let records = [
        record(Phase::Search, &["a", "b"], 0, Wrong),
        record(Phase::Search, &["c"], 0, Correct),
        record(Phase::Search, &["a", "b"], 1, Wrong), // {a, b} found after 3 inferences
        record(Phase::Search, &["c"], 1, Correct),
        record(Phase::Search, &["a", "b", "c"], 0, Wrong),
        record(Phase::Search, &["a", "b", "c"], 1, Wrong), // found after 6; its core {a} is not new
        record(Phase::Search, &["d", "e"], 0, Wrong),
        record(Phase::Search, &["d", "e"], 1, Wrong), // found after 8, with the second core
        record(Phase::Validate, &["a", "b"], 0, Wrong), // validation finds nothing new
        record(Phase::Search, &["f"], 0, Correct),
    ];
    let obs: Vec<&Record> = records.iter().collect();
    let modes = [names(&["b", "a"]), names(&["a", "b", "c"]), names(&["d", "e"])];
    let cores = [names(&["a"]), names(&["e"]), names(&["z"])];
    let d = discovery(&obs, &modes, &cores);
    let got: Vec<(u64, usize, usize)> = d.points.iter().map(|p| (p.inferences, p.failure_modes, p.cores)).collect();
    assert_eq!(got, vec![(0, 0, 0), (3, 1, 1), (6, 2, 1), (8, 3, 2), (9, 3, 2)]);
    assert_eq!(d.inferences, 9);
    assert!(d.phase_starts.is_empty());
}

#[test]
fn minimal_failure_modes_are_those_without_a_failing_subset() {
    let modes = [
        row(&["a", "b", "c"], 5, 5),
        row(&["a", "b"], 4, 5),
        row(&["a", "b", "d"], 5, 5),
        row(&["c", "d"], 5, 5),
        row(&["e", "f", "g"], 3, 5),
    ];
    let minimal = minimal_failure_modes(&modes);
    // {a, b} (in three failure modes) first, then {c, d} (FR 1.0), then {e, f, g} (0.6).
    assert_eq!(minimal, vec![1, 3, 4]);
    assert_eq!(supersets(&modes[1].concepts, &modes), 3);
    assert_eq!(supersets(&names(&["d"]), &modes), 2);
    assert_eq!(supersets(&names(&["z"]), &modes), 0);
}

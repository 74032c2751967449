//! The pattern model on small lattices: each set's subsets, the binomial evidence, and the
//! scores that make a failing core the likeliest explanation.
use super::*;
use crate::ir::ConceptId;
use crate::ir::testkit::lattice;
use crate::outcome::Outcome;

fn set(ids: &[u32]) -> ConceptSet {
    ConceptSet::from_ids(ids.iter().map(|&i| ConceptId(i)))
}

fn stats(s: ConceptSet, wrong: u32, correct: u32) -> SetStats {
    let mut st = SetStats::new(s);
    (0..wrong).for_each(|_| st.add(Outcome::Wrong));
    (0..correct).for_each(|_| st.add(Outcome::Correct));
    st
}

fn space(n: usize, max: usize) -> Space {
    Space::new(lattice(n, max), n)
}

#[test]
fn every_set_lists_exactly_its_valid_subsets_of_at_most_three() {
    let sp = space(7, 5);
    let pats = Patterns::new(&sp);
    assert_eq!(pats.max, MAX_PATTERN);
    for (i, s) in sp.sets.iter().enumerate() {
        let mut got: Vec<ConceptSet> = pats.subs(i).iter().map(|&j| pats.pattern(j)).collect();
        got.sort();
        let mut want: Vec<ConceptSet> =
            sp.sets.iter().copied().filter(|p| p.len() <= MAX_PATTERN && p.is_subset_of(*s)).collect();
        want.sort();
        assert_eq!(got, want, "{s:?}");
        let (from, to) = (pats.offsets[i] as usize, pats.offsets[i + 1] as usize);
        for (&j, &k) in pats.subs[from..to].iter().zip(&pats.extra[from..to]) {
            assert_eq!(usize::from(k), s.len() - pats.pattern(j).len());
        }
    }
}

#[test]
fn a_large_lattice_models_smaller_patterns() {
    assert_eq!(sub_count(5, 3), 5 + 10 + 10);
    assert_eq!(sub_count(2, 3), 2 + 1);
    assert_eq!(sub_count(8, 2), 8 + 28);
}

/// The evidence of one tested set is the closed-form binomial log-likelihood ratio, per dilution
/// hypothesis, against the base rate (no tested subset) or against its tested subsets' rate.
#[test]
fn evidence_is_the_binomial_likelihood_ratio() {
    let sp = space(6, 4);
    let pats = Patterns::new(&sp);
    let (a, b) = (set(&[2]), set(&[2, 3]));
    let history = vec![stats(a, 1, 9), stats(b, 4, 1)];
    let fit = pats.fit(&sp, &history, &[], 0.6);
    // Base rate: both sets fail less than half the time? {2, 3} fails 4/5: left out.
    let base = (1.0 + 1.0) / (10.0 + 20.0);
    assert!((fit.base - base).abs() < 1e-12);
    let smoothed_a = (1.0 + base * PRIOR_WEIGHT) / (10.0 + PRIOR_WEIGHT);
    let lr = |w: f64, n: f64, alt: f64, bg: f64| w * (alt / bg).ln() + (n - w) * ((1.0 - alt) / (1.0 - bg)).ln();
    for (di, d) in DILUTIONS.iter().enumerate() {
        let r = |k: i32| base + (CORE_RATE - base) * (1.0 - d).powi(k);
        // Pattern {2, 3}: tested once, as itself (k = 0), against {2}'s smoothed rate.
        let j = pats.position(b).unwrap() as usize;
        assert!((fit.llr[j][di] - lr(4.0, 5.0, r(0), smoothed_a)).abs() < 1e-9);
        // Pattern {2}: tested alone (k = 0, against the base) and inside {2, 3} (k = 1).
        let j = pats.position(a).unwrap() as usize;
        let want = lr(1.0, 10.0, r(0), base) + lr(4.0, 5.0, r(1).max(smoothed_a + 1e-6), smoothed_a);
        assert!((fit.llr[j][di] - want).abs() < 1e-9, "d = {d}");
        // Pattern {3}: only inside {2, 3}.
        let j = pats.position(set(&[3])).unwrap() as usize;
        assert!((fit.llr[j][di] - lr(4.0, 5.0, r(1).max(smoothed_a + 1e-6), smoothed_a)).abs() < 1e-9);
    }
    // The posterior over d sums to one.
    assert!((fit.pd.iter().sum::<f64>() - 1.0).abs() < 1e-12);
}

/// A failing pair whose parts pass explains its supersets: the pair becomes the likeliest core,
/// its parts are none, its supersets' other sub-patterns stay behind it.
#[test]
fn a_failing_pair_with_passing_parts_is_the_likeliest_core() {
    let sp = space(6, 4);
    let pats = Patterns::new(&sp);
    let pair = set(&[2, 3]);
    let history = vec![
        stats(set(&[2]), 0, 5),
        stats(set(&[3]), 0, 5),
        stats(set(&[2, 3, 4]), 5, 0),
        stats(pair, 6, 0),
        stats(set(&[4]), 0, 5),
        stats(set(&[0, 5]), 0, 5),
    ];
    let fit = pats.fit(&sp, &history, &[], 0.6);
    let q = |s: ConceptSet| fit.q_mean(&pats, pats.position(s).unwrap());
    assert!(q(pair) > 0.9, "{}", q(pair));
    // A pattern whose own answers pass is no core, whatever its supersets did.
    for cleared in [set(&[2]), set(&[3]), set(&[4]), set(&[0, 5])] {
        assert_eq!(q(cleared), 0.0, "{cleared:?}");
    }
    // The triple's other sub-patterns stay behind the pair that explains it (under the prior's
    // likeliest d = 0 a core one concept smaller fails like the triple did, so they are lifted
    // too, a fifth of the way less); the triple itself fails too (it is likely a core as far as
    // its own answers go) but ranks after the pair.
    for other in [set(&[2, 4]), set(&[3, 4])] {
        assert!(q(other) < q(pair) - 0.2, "{other:?}: {} vs {}", q(other), q(pair));
    }
    assert!(q(set(&[2, 3, 4])) < q(pair));
}

/// Weak heredity: a pattern whose part fails more often than the base rate starts likelier.
#[test]
fn a_part_that_fails_lifts_the_patterns_that_hold_it() {
    let sp = space(6, 4);
    let pats = Patterns::new(&sp);
    let history = vec![stats(set(&[2]), 3, 7), stats(set(&[4]), 0, 10)];
    let fit = pats.fit(&sp, &history, &[], 0.6);
    let q = |s: ConceptSet| fit.q_mean(&pats, pats.position(s).unwrap());
    assert!(q(set(&[2, 3])) > 2.0 * q(set(&[4, 5])), "{} vs {}", q(set(&[2, 3])), q(set(&[4, 5])));
    assert!(fit.lift[pats.position(set(&[2, 3])).unwrap() as usize] > 0.0);
    assert_eq!(fit.lift[pats.position(set(&[3, 5])).unwrap() as usize], 0.0);
}

/// The dilution posterior: supersets of a core that fail as often as the core favour d = 0;
/// supersets that pass favour the strongest dilution.
#[test]
fn supersets_of_a_core_tell_the_dilution() {
    let sp = space(8, 5);
    let pats = Patterns::new(&sp);
    let core = set(&[2, 3]);
    let mut history = vec![stats(core, 9, 1), stats(set(&[2]), 0, 10), stats(set(&[3]), 0, 10)];
    let supersets = [set(&[2, 3, 4, 5, 6]), set(&[2, 3, 4, 5, 7]), set(&[2, 3, 5, 6, 7]), set(&[2, 3, 4, 6, 7])];
    let mut kept = history.clone();
    kept.extend(supersets.iter().map(|&s| stats(s, 9, 1)));
    history.extend(supersets.iter().map(|&s| stats(s, 1, 9)));
    let undiluted = pats.fit(&sp, &kept, &[core], 0.6);
    let diluted = pats.fit(&sp, &history, &[core], 0.6);
    assert!(undiluted.pd[0] > 0.9, "{:?}", undiluted.pd);
    assert!(diluted.pd[D - 1] > 0.9, "{:?}", diluted.pd);
    // A draw follows the posterior.
    assert_eq!(undiluted.draw_dilution(0.5), 0);
    assert_eq!(diluted.draw_dilution(0.5), D - 1);
}

/// With no tested set the dilution posterior is its prior, no dilution the likeliest; evidence
/// moves it (above).
#[test]
fn without_evidence_the_dilution_posterior_is_its_prior() {
    let sp = space(8, 5);
    let pats = Patterns::new(&sp);
    let fit = pats.fit(&sp, &[], &[], 0.6);
    for (p, prior) in fit.pd.iter().zip(DILUTION_PRIOR) {
        assert!((p - prior).abs() < 1e-12, "{:?}", fit.pd);
    }
    assert_eq!(fit.draw_dilution(0.69), 0);
    assert_eq!(fit.draw_dilution(0.71), 1);
}

/// The score prefers a set whose sub-patterns are untested over one whose sub-patterns were all
/// cleared, and expects a set holding a concept that fails a third of the time to cost more (its
/// screen would escalate for nothing).
#[test]
fn the_score_prefers_untested_and_clean_sets() {
    let sp = space(8, 3);
    let pats = Patterns::new(&sp);
    let cleared = set(&[2, 3, 4]);
    let noisy = set(&[5]);
    let history = vec![stats(cleared, 0, 20), stats(noisy, 3, 7)];
    let fit = pats.fit(&sp, &history, &[], 0.6);
    let open = vec![true; pats.len()];
    let scorer = fit.scorer(&pats, &open, 0, 2, 5, 0.6);
    let score = |s: ConceptSet| scorer.score(&pats, sp.position(s).unwrap());
    let cost = |s: ConceptSet| {
        let i = sp.position(s).unwrap();
        scorer.value(&pats, i) / scorer.score(&pats, i)
    };
    // {2, 3, 6} shares {2, 3} and singles with the cleared set: fewer untested patterns.
    assert!(score(set(&[2, 6, 7])) > score(set(&[2, 3, 6])));
    assert!(cost(set(&[5, 6, 7])) > cost(set(&[2, 6, 7])), "the noisy concept costs escalations");
    // Closed patterns (a confirmed core and its supersets) add nothing.
    let closed: Vec<bool> = (0..pats.len() as u32).map(|j| !set(&[6, 7]).is_subset_of(pats.pattern(j))).collect();
    let without = fit.scorer(&pats, &closed, 0, 2, 5, 0.6);
    let i = sp.position(set(&[2, 6, 7])).unwrap();
    assert!(without.value(&pats, i) < scorer.value(&pats, i));
}

/// A pick's score computed alone (a fit refitted since the scorer was built) is the scorer's,
/// to the bit, for every set, open and closed patterns and every dilution.
#[test]
fn a_score_computed_alone_is_the_scorers() {
    let sp = space(8, 3);
    let pats = Patterns::new(&sp);
    let history = vec![stats(set(&[2, 3, 4]), 0, 20), stats(set(&[5]), 3, 7), stats(set(&[1, 6]), 4, 1)];
    let fit = pats.fit(&sp, &history, &[], 0.6);
    let closed: Vec<bool> = (0..pats.len() as u32).map(|j| !set(&[6, 7]).is_subset_of(pats.pattern(j))).collect();
    for open in [vec![true; pats.len()], closed] {
        for di in 0..D {
            let scorer = fit.scorer(&pats, &open, di, 1, 5, 0.6);
            for i in 0..sp.sets.len() {
                assert_eq!(scorer.score(&pats, i).to_bits(), fit.score_one(&pats, &open, di, 1, 5, 0.6, i).to_bits());
            }
        }
    }
}

#[test]
fn binomial_tail() {
    assert!((at_least(5, 3, 0.5) - 0.5).abs() < 1e-12);
    assert!((at_least(5, 0, 0.3) - 1.0).abs() < 1e-12);
    assert!((at_least(2, 1, 0.1) - 0.19).abs() < 1e-12);
}

/// Twelve concepts: `c10` needs `c1`, `c11` needs `c2` or `c3` (a towel by the hob needs the hob
/// on; a puddle needs rain, falling or recent); sets of up to 4. Listed and sampled.
fn needing() -> (Space, Space) {
    use crate::ir::ConstraintRule;
    use crate::lattice::testkit::{Dom, num};
    use crate::lattice::{Diagram, Validity};
    let mut b = Dom::new(crate::ir::Selection::Priority);
    b.world("on", num(0.0));
    let ids: Vec<_> = (0..12).map(|i| b.world_concept(&format!("c{i}"), "on", num(1.0))).collect();
    b.constraint("towel", ConstraintRule::Requires { concept: ids[10], any_of: set(&[1]) });
    b.constraint("puddle", ConstraintRule::Requires { concept: ids[11], any_of: set(&[2, 3]) });
    let d = b.build();
    let validity = Validity::new(&d);
    let listed = (1u128..1 << 12).map(ConceptSet::from_bits).filter(|s| s.len() <= 4 && validity.is_valid(*s));
    let listed = Space::new(listed.collect(), 12);
    let sampled = Space::sampled(std::sync::Arc::new(Diagram::build(&validity, 4)), std::sync::Arc::new(|_| true), 12);
    (listed, sampled)
}

#[test]
fn a_pattern_names_the_concepts_it_does_not_hold_only_to_be_valid() {
    let (sp, _) = needing();
    let valid = |s: ConceptSet| sp.contains(s);
    assert_eq!(unforced(set(&[1, 10]), valid), set(&[10]), "c10 needs c1");
    assert_eq!(unforced(set(&[2, 11]), valid), set(&[11]));
    assert_eq!(unforced(set(&[0, 2, 11]), valid), set(&[0, 11]));
    assert_eq!(unforced(set(&[1, 2]), valid), set(&[1, 2]), "neither needs the other");
    assert_eq!(unforced(set(&[4]), valid), set(&[4]));
}

/// A concept that cannot stand alone is as likely a core, in the sets that make it valid, as one
/// that can: its share of the Occam prior spread over them, never below its size's share. The
/// listed lattice and a sampled one (patterns met as sets are drawn) give the same prior.
#[test]
fn a_concept_that_needs_another_keeps_a_single_concepts_prior() {
    let (listed, sampled) = needing();
    let pats = Patterns::new(&listed);
    let per_size = |k: usize| listed.sets.iter().filter(|s| s.len() == k).count() as f64;
    let (singles, pairs, triples) = (per_size(1), per_size(2), per_size(3));
    assert_eq!((singles, pairs, triples), (10.0, 48.0, 146.0));
    let logit = |q: f64| (q / (1.0 - q)).ln();
    let prior_of = |p: &Patterns, s: &[u32]| p.logit_prior[p.position(set(s)).unwrap() as usize];
    let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
    // The hob-and-towel pair: one concept's prior (c10 has one way to be valid).
    assert!(close(prior_of(&pats, &[1, 10]), logit(EXPECTED_CORES / singles)));
    // The puddle has two weathers: half each, still above a pair's.
    assert!(close(prior_of(&pats, &[2, 11]), logit(EXPECTED_CORES / singles / 2.0)));
    assert!(close(prior_of(&pats, &[3, 11]), logit(EXPECTED_CORES / singles / 2.0)));
    assert!(close(prior_of(&pats, &[1, 2]), logit(EXPECTED_CORES / pairs)));
    // The puddle beside c0 is a pair's prior spread over the two weathers: {0, 2, 11}, {0, 3, 11}.
    assert!(close(prior_of(&pats, &[0, 2, 11]), logit(EXPECTED_CORES / pairs / 2.0)));
    assert!(close(prior_of(&pats, &[0, 1, 2]), logit(EXPECTED_CORES / triples)));
    // Both spaces count the valid sets holding a subset alike (the sampled one by its diagram).
    for (sub, size) in [(set(&[11]), 2), (set(&[0, 11]), 3), (set(&[10]), 2), (set(&[1]), 3), (set(&[0, 1]), 4)] {
        assert_eq!(listed.count_containing(sub, size), sampled.count_containing(sub, size), "{sub:?} {size}");
    }
    assert_eq!(listed.count_containing(set(&[11]), 2), 2, "a puddle's two weathers");
    // A sampled space meets the same patterns as sets are drawn and gives them the same prior.
    let mut pooled = Patterns::pooled(&sampled);
    for s in [set(&[1, 10]), set(&[0, 2, 11]), set(&[3, 11]), set(&[0, 1, 2])] {
        assert!(pooled.add(s, &sampled));
    }
    for p in [&[1, 10][..], &[2, 11], &[3, 11], &[0, 2, 11], &[0, 1, 2], &[1, 2], &[2]] {
        assert!(close(prior_of(&pooled, p), prior_of(&pats, p)), "{p:?}");
    }
}

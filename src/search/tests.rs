//! Algorithm tests on synthetic evaluators.

use super::*;
use crate::ir::ConceptSet;
use crate::ir::testkit::lattice;
use crate::outcome::Outcome;

/// Evaluates a set as `f(set)` wrong answers out of `m`; records what it was asked.
struct FnEval<F> {
    f: F,
    m: u32,
    asked: Vec<Vec<ConceptSet>>,
}

impl<F: Fn(ConceptSet) -> u32> Evaluate for FnEval<F> {
    async fn evaluate(&mut self, sets: &[ConceptSet]) -> Result<Vec<SetStats>, String> {
        self.asked.push(sets.to_vec());
        Ok(sets
            .iter()
            .map(|&s| {
                let mut st = SetStats::new(s);
                let w = (self.f)(s).min(self.m);
                (0..self.m).for_each(|i| st.add(if i < w { Outcome::Wrong } else { Outcome::Correct }));
                st
            })
            .collect())
    }
}

fn block_on<T>(f: impl std::future::Future<Output = T>) -> T {
    tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap().block_on(f)
}

fn bits(ids: &[u32]) -> ConceptSet {
    ConceptSet::from_ids(ids.iter().map(|&i| crate::ir::ConceptId(i)))
}

/// Planted landscape: {2, 5} fails always, {2} alone sometimes, {6, 7} fails always.
fn landscape(s: ConceptSet) -> u32 {
    if bits(&[2, 5]).is_subset_of(s) || bits(&[6, 7]).is_subset_of(s) {
        5
    } else if s.contains(crate::ir::ConceptId(2)) {
        2
    } else {
        0
    }
}

fn params(algo: Algo, budget: u64) -> Params {
    Params { algo, budget, beam_budget: budget / 2, ..Params::default() }
}

fn run_fn(p: &Params, space: &Space) -> (Vec<SetStats>, Vec<Vec<ConceptSet>>) {
    let mut e = FnEval { f: landscape, m: p.samples, asked: vec![] };
    let h = block_on(run(p, space, &mut e)).unwrap();
    (h, e.asked)
}

fn assert_sound(h: &[SetStats], space: &Space, p: &Params) {
    assert!(h.len() <= p.max_sets());
    let distinct: std::collections::HashSet<_> = h.iter().map(|s| s.set).collect();
    assert_eq!(distinct.len(), h.len(), "a set was evaluated twice");
    assert!(h.iter().all(|s| space.contains(s.set)), "an invalid set was evaluated");
}

#[test]
fn random_is_seeded_uniform_and_without_repeats() {
    let space = Space::new(lattice(8, 4), 8);
    let p = params(Algo::Random, 500);
    let (a, _) = run_fn(&p, &space);
    assert_eq!(a.len(), 100);
    assert_sound(&a, &space, &p);
    assert_eq!(a, run_fn(&p, &space).0);
    let (b, _) = run_fn(&Params { seed: 1, ..p.clone() }, &space);
    assert_ne!(a, b);
    // A budget larger than the lattice evaluates every valid set once.
    let all = run_fn(&params(Algo::Random, 100_000), &space).0;
    assert_eq!(all.len(), space.sets.len());
}

#[test]
fn beam_expands_levels_in_order_and_follows_the_failure_gradient() {
    let space = Space::new(lattice(8, 4), 8);
    let p = Params { beam_width: 2, ..params(Algo::Beam, 5 * 30) };
    let (h, asked) = run_fn(&p, &space);
    assert_sound(&h, &space, &p);
    // Level 1: the valid singletons in concept order.
    assert_eq!(asked[0], (0..8).map(|i| bits(&[i])).collect::<Vec<_>>());
    // Level 2 expands the frontier {2} (highest FR) then the most diverse runner-up {0}.
    assert_eq!(asked[1][0], bits(&[0, 2]), "frontier order: {:?}", &asked[1][..3]);
    assert!(asked[1].contains(&bits(&[2, 5])));
    assert!(h.iter().any(|s| s.set == bits(&[2, 5]) && s.is_failure_mode(0.6)));
    assert_eq!(h.len(), 30, "the budget is spent");
    assert_eq!(h, run_fn(&p, &space).0);
}

#[test]
fn beam_stops_at_max_depth() {
    let space = Space::new(lattice(6, 5), 6);
    let p = Params { max_depth: 1, ..params(Algo::Beam, 1000) };
    let (h, asked) = run_fn(&p, &space);
    assert_eq!(asked.len(), 1);
    assert_eq!(h.len(), 6);
}

#[test]
fn gpts_beats_random_on_a_planted_landscape() {
    let space = Space::new(lattice(10, 4), 10);
    let modes = |h: &[SetStats]| h.iter().filter(|s| s.is_failure_mode(0.6)).count();
    let p = params(Algo::Gpts, 300);
    let (g, _) = run_fn(&p, &space);
    assert_sound(&g, &space, &p);
    assert_eq!(g.len(), 60);
    let (r, _) = run_fn(&params(Algo::Random, 300), &space);
    assert!(modes(&g) > 2 * modes(&r), "gpts {} vs random {}", modes(&g), modes(&r));
    assert_eq!(g, run_fn(&p, &space).0, "gpts is reproducible");
}

#[test]
fn gpts_batches_distinct_argmaxes_and_runs_without_a_beam_phase() {
    let space = Space::new(lattice(10, 4), 10);
    let p = Params { batch: 4, beam_budget: 0, ..params(Algo::Gpts, 200) };
    let (h, asked) = run_fn(&p, &space);
    assert_sound(&h, &space, &p);
    assert_eq!(h.len(), 40);
    assert!(asked.iter().all(|b| (1..=4).contains(&b.len())));
    assert!(asked.iter().any(|b| b.len() > 1), "parallel rounds");
}

#[test]
fn params_are_validated() {
    let ok = Params::default();
    assert!(ok.validate().is_ok());
    let e = |p: Params| p.validate().unwrap_err();
    assert_eq!(e(Params { samples: 0, ..ok.clone() }), "invalid `--samples`: must be at least 1");
    assert_eq!(e(Params { threshold: 1.5, ..ok.clone() }), "invalid `--threshold`: must be between 0 and 1, got 1.5");
    assert_eq!(e(Params { beam_budget: 2000, ..ok.clone() }), "invalid `--beam-budget`: 2000 exceeds the budget 1000");
    assert_eq!(e(Params { budget: 3, ..ok }), "invalid `--budget`: 3 inferences cannot evaluate one set of 5 samples");
}

/// Two planted pairs and a planted triple whose parts never fail; everything else fails one
/// time in five (below τ = 0.6).
fn three_modes(s: ConceptSet) -> u32 {
    let modes = [bits(&[2, 5]), bits(&[6, 9]), bits(&[3, 7, 10])];
    if modes.iter().any(|m| m.is_subset_of(s)) { 5 } else { u32::from(s.len() == 4) }
}

/// Failing sets whose every valid one-smaller subset was evaluated and passes.
fn minimal_failures(h: &[SetStats], space: &Space) -> Vec<ConceptSet> {
    let fr: std::collections::HashMap<ConceptSet, &SetStats> = h.iter().map(|s| (s.set, s)).collect();
    h.iter()
        .filter(|s| s.is_failure_mode(0.6))
        .filter(|s| {
            s.set
                .iter()
                .map(|c| s.set.without(c))
                .filter(|sub| !sub.is_empty() && space.contains(*sub))
                .all(|sub| fr.get(&sub).is_some_and(|t| !t.is_failure_mode(0.6)))
        })
        .map(|s| s.set)
        .collect()
}

#[test]
fn interact_reports_two_pairs_and_a_triple_exactly() {
    let space = Space::new(lattice(12, 4), 12);
    for seed in 0..3 {
        let p = Params { algo: Algo::Interact, budget: 1000, seed, ..Params::default() };
        let mut e = FnEval { f: three_modes, m: p.samples, asked: vec![] };
        let h = block_on(run(&p, &space, &mut e)).unwrap();
        assert_sound(&h, &space, &p);
        let mut cores = minimal_failures(&h, &space);
        cores.sort();
        let mut planted = vec![bits(&[2, 5]), bits(&[6, 9]), bits(&[3, 7, 10])];
        planted.sort();
        assert_eq!(cores, planted, "seed {seed}");
        assert_eq!(h, block_on(run(&p, &space, &mut FnEval { f: three_modes, m: p.samples, asked: vec![] })).unwrap());
    }
}

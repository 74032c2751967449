//! One `--algo interact` iteration on the driving lattice at 200 evaluated sets, for both kinds of
//! surrogate: the pattern surrogate (the default: the evidence of every pattern of at most three
//! concepts, the dilution posterior, one draw and the score of every unexplored valid set) and
//! the pairwise horseshoe regression (four warm-started Gibbs sweeps with n×n Cholesky factors
//! from faer, one Thompson draw, the argmax of the draw over every unexplored valid set). The
//! issue's target is under 10 ms. Figures are in docs/search.md.
//!
//! `cargo bench --bench interact`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use revelio::ir::{ConceptId, ConceptSet};
use revelio::lattice::Lattice;
use revelio::outcome::Outcome;
use revelio::run::eval::DomainWorld;
use revelio::run::runner::search_space;
use revelio::search::interact::{PatternSearcher, Searcher, Surrogate};
use revelio::search::{Algo, Params, SetStats};

const EVALUATED: usize = 200;

fn bench(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("domains/driving.rev");
    let text = std::fs::read_to_string(&path).expect("shipped domain");
    let domain = revelio::check::compile_source("driving.rev", &text).expect("shipped domain compiles");
    let lattice = Lattice::enumerate(&domain, 5);
    let world = DomainWorld::new(&domain);
    let (space, _) = search_space(lattice.sets, domain.concepts.len(), &world);
    eprintln!("driving: {} valid sets in the search space", space.sets.len());

    // 200 evaluated sets drawn from the lattice, failing when they hold one of two planted pairs.
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let pairs =
        [ConceptSet::from_ids([ConceptId(0), ConceptId(7)]), ConceptSet::from_ids([ConceptId(3), ConceptId(12)])];
    let mut history: Vec<SetStats> = Vec::with_capacity(EVALUATED);
    while history.len() < EVALUATED {
        let set = space.sets[rng.random_range(0..space.sets.len())];
        if history.iter().any(|s| s.set == set) {
            continue;
        }
        let p = if pairs.iter().any(|p| p.is_subset_of(set)) { 0.9 } else { 0.1 };
        let mut stats = SetStats::new(set);
        (0..5).for_each(|_| stats.add(if rng.random::<f64>() < p { Outcome::Wrong } else { Outcome::Correct }));
        history.push(stats);
    }

    let params = Params { algo: Algo::Interact, ..Params::default() };
    let mut g = c.benchmark_group("interact");
    g.sample_size(20);

    let mut patterns = PatternSearcher::new(&params, &space);
    for s in &history {
        patterns.explored(s.set);
    }
    g.bench_function("iteration driving n=200 patterns (fit + draw + score every set)", |b| {
        b.iter(|| patterns.propose(black_box(&history)))
    });

    let horseshoe = Surrogate::Horseshoe.parts().expect("a regression surrogate");
    let mut searcher = Searcher::new(&params, &space, horseshoe);
    for s in &history {
        searcher.explored(s.set);
    }
    // Warm the chain up as a run would have by the time it holds 200 sets.
    for _ in 0..20 {
        searcher.propose(&history);
    }
    g.bench_function("iteration driving n=200 horseshoe (4 sweeps + draw + argmax)", |b| {
        b.iter(|| searcher.propose(black_box(&history)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

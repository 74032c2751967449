//! One GPTS iteration (paper Algorithm 2): fit the GP on 200 observations over 30 concepts, draw
//! one Thompson sample, score a lattice-sized list of ~120k concept sets and take the argmax over
//! the unexplored ones. Figures are in docs/gp.md.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use revelio::ir::{ConceptId, ConceptSet};
use revelio::search::gp::{Draw, Gp};

const D: u32 = 30;
const OBSERVATIONS: usize = 200;
const LATTICE: usize = 120_000;

/// A set of 1–5 distinct concepts.
fn random_set(rng: &mut ChaCha8Rng) -> ConceptSet {
    let size = rng.random_range(1..=5);
    let mut set = ConceptSet::EMPTY;
    while set.len() < size {
        set = set.with(ConceptId(rng.random_range(0..D)));
    }
    set
}

struct Problem {
    x: Vec<ConceptSet>,
    y: Vec<f64>,
    lattice: Vec<ConceptSet>,
    explored: Vec<bool>,
}

/// Observations are lattice members (as in GPTS), with additive failure rates quantised to m = 5.
fn problem() -> Problem {
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let w: Vec<f64> = (0..D).map(|_| rng.random::<f64>() * 0.3 - 0.1).collect();
    let lattice: Vec<ConceptSet> = (0..LATTICE).map(|_| random_set(&mut rng)).collect();
    let mut explored = vec![false; LATTICE];
    let (x, y) = (0..OBSERVATIONS)
        .map(|_| {
            let i = rng.random_range(0..LATTICE);
            explored[i] = true;
            let p = 0.1 + lattice[i].iter().map(|c| w[c.index()]).sum::<f64>() + 0.1 * (rng.random::<f64>() - 0.5);
            (lattice[i], (p.clamp(0.0, 1.0) * 5.0).round() / 5.0)
        })
        .unzip();
    Problem { x, y, lattice, explored }
}

fn argmax_unexplored(draw: &Draw, p: &Problem) -> Option<usize> {
    let mut best: Option<(usize, f64)> = None;
    for (i, (&set, &done)) in p.lattice.iter().zip(&p.explored).enumerate() {
        let score = draw.score(set);
        if !done && best.is_none_or(|(_, b)| score > b) {
            best = Some((i, score));
        }
    }
    best.map(|(i, _)| i)
}

fn bench(c: &mut Criterion) {
    let p = problem();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let gp = Gp::fit(&p.x, &p.y, D as usize).unwrap();
    c.bench_function("gp/fit n=200 d=30", |b| b.iter(|| Gp::fit(black_box(&p.x), black_box(&p.y), D as usize)));
    c.bench_function("gp/draw d=30", |b| b.iter(|| gp.draw(&mut rng)));
    c.bench_function("gp/score+argmax 120k sets", |b| {
        let draw = gp.draw(&mut rng);
        b.iter(|| argmax_unexplored(black_box(&draw), &p))
    });
    c.bench_function("gp/gpts iteration (fit+draw+argmax 120k)", |b| {
        b.iter(|| {
            let gp = Gp::fit(black_box(&p.x), black_box(&p.y), D as usize).unwrap();
            argmax_unexplored(&gp.draw(&mut rng), &p)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);

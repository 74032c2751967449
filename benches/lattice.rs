//! Lattice, oracle and lint costs on a 30-concept driving domain (the paper's size).
//!
//! `cargo bench --bench lattice`. Figures are recorded in `docs/lattice.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use revelio::lattice::{Lattice, lints};
use revelio::oracle::Oracle;

// The unit tests' Rust-built fixture domains, reused verbatim: the file names its types through
// `crate::ir`, which this shim provides outside the library.
mod ir {
    pub use revelio::ir::*;
}
#[allow(dead_code)]
#[path = "../src/lattice/testkit.rs"]
mod testkit;

fn benches(c: &mut Criterion) {
    let domain = testkit::driving();
    let lattice = Lattice::enumerate(&domain, 5);
    eprintln!("driving fixture: {} concepts, {} valid sets up to size 5", domain.concepts.len(), lattice.len());

    c.bench_function("enumerate/driving30/size5", |b| b.iter(|| Lattice::enumerate(black_box(&domain), 5)));
    c.bench_function("contains/driving30/all_sets", |b| {
        b.iter(|| lattice.sets.iter().filter(|s| lattice.contains(black_box(**s))).count())
    });
    let sample: Vec<_> = lattice.sets.iter().step_by(97).copied().collect();
    c.bench_function("extensions/driving30/every_97th_set", |b| {
        b.iter(|| sample.iter().map(|s| lattice.extensions(black_box(*s)).len()).sum::<usize>())
    });
    let oracle = Oracle::new(&domain);
    c.bench_function("oracle/driving30/every_97th_set", |b| {
        b.iter(|| sample.iter().filter(|s| oracle.evaluate(black_box(**s)).is_ok()).count())
    });
    let mut g = c.benchmark_group("lints");
    g.sample_size(10);
    g.bench_function("lint_domain/driving30/size5", |b| b.iter(|| lints::lint_domain(black_box(&domain))));
    g.finish();
}

criterion_group!(lattice_benches, benches);
criterion_main!(lattice_benches);

//! Lattice, oracle and lint costs on the shipped domains: driving (30 concepts, priority rules,
//! the paper's size), indoor (33 concepts, best-fit rules) and delivery (27 concepts, written in
//! `.rev` only, with `use` modules).
//!
//! `cargo bench --bench lattice`. Figures are recorded in `docs/lattice.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use revelio::ir::Domain;
use revelio::lattice::{self, Diagram, Lattice, Validity};
use revelio::lint as lints;
use revelio::oracle::Oracle;

fn domain(name: &str) -> Domain {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("domains").join(name);
    revelio::source::compile_file(&path).domain.expect("shipped domain compiles")
}

fn benches(c: &mut Criterion) {
    for name in ["driving", "indoor", "delivery"] {
        let domain = domain(&format!("{name}.rev"));
        let lattice = Lattice::enumerate(&domain, 5);
        let nodes = Diagram::build(&Validity::new(&domain), 5).nodes();
        eprintln!(
            "{name}: {} concepts, {} valid sets up to size 5, {nodes} diagram nodes",
            domain.concepts.len(),
            lattice.len()
        );
        c.bench_function(&format!("enumerate/{name}/size5"), |b| b.iter(|| Lattice::enumerate(black_box(&domain), 5)));
        // What `search` and `check`'s lints build: counted first, then filled in place.
        c.bench_function(&format!("build/{name}/size5"), |b| {
            b.iter(|| Lattice::build(black_box(&domain), 5, lattice::DEFAULT_MAX_SETS, &mut lattice::quiet))
        });
        // What `revelio lattice` counts with.
        c.bench_function(&format!("diagram/{name}/size5"), |b| {
            b.iter(|| Diagram::build(&Validity::new(black_box(&domain)), 5).total())
        });
        c.bench_function(&format!("contains/{name}/all_sets"), |b| {
            b.iter(|| lattice.sets.iter().filter(|s| lattice.contains(black_box(**s))).count())
        });
        let sample: Vec<_> = lattice.sets.iter().step_by(97).copied().collect();
        c.bench_function(&format!("extensions/{name}/every_97th_set"), |b| {
            b.iter(|| sample.iter().map(|s| lattice.extensions(black_box(*s)).len()).sum::<usize>())
        });
        let oracle = Oracle::new(&domain);
        c.bench_function(&format!("oracle/{name}/every_97th_set"), |b| {
            b.iter(|| sample.iter().filter(|s| oracle.evaluate(black_box(**s)).is_ok()).count())
        });
        let mut g = c.benchmark_group("lints");
        g.sample_size(10);
        g.bench_function(format!("lint_domain/{name}/size5"), |b| b.iter(|| lints::lint_domain(black_box(&domain))));
        g.finish();
    }
}

criterion_group!(lattice_benches, benches);
criterion_main!(lattice_benches);

//! Lattice, oracle and lint costs on the shipped domains: driving (30 concepts, priority rules,
//! the paper's size) and indoor (33 concepts, best-fit rules).
//!
//! `cargo bench --bench lattice`. Figures are recorded in `docs/lattice.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use revelio::ir::Domain;
use revelio::lattice::Lattice;
use revelio::lint as lints;
use revelio::oracle::Oracle;

fn domain(name: &str) -> Domain {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("domains").join(name);
    let text = std::fs::read_to_string(&path).expect("shipped domain");
    revelio::check::compile_source(name, &text).expect("shipped domain compiles")
}

fn benches(c: &mut Criterion) {
    for name in ["driving", "indoor"] {
        let domain = domain(&format!("{name}.rev"));
        let lattice = Lattice::enumerate(&domain, 5);
        eprintln!("{name}: {} concepts, {} valid sets up to size 5", domain.concepts.len(), lattice.len());
        c.bench_function(&format!("enumerate/{name}/size5"), |b| b.iter(|| Lattice::enumerate(black_box(&domain), 5)));
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

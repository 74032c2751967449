//! Compile time of the shipped domains (parse, resolve, type-check, lower; no lattice lints):
//! what `revelio check` and every subcommand pay before any real work.

use criterion::{Criterion, criterion_group, criterion_main};

fn compile_domains(c: &mut Criterion) {
    for name in ["driving", "indoor"] {
        let path = format!("{}/domains/{name}.rev", env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(&path).expect("the shipped domain exists");
        c.bench_function(&format!("compile domains/{name}.rev"), |b| {
            b.iter(|| {
                let d = revelio::check::compile_source(&path, std::hint::black_box(&text));
                assert!(d.is_ok());
            })
        });
    }
    let text = std::fs::read_to_string(format!("{}/domains/indoor.rev", env!("CARGO_MANIFEST_DIR"))).unwrap();
    c.bench_function("parse domains/indoor.rev", |b| {
        b.iter(|| revelio::syntax::parse(0, std::hint::black_box(&text)).diagnostics.len())
    });
}

criterion_group!(benches, compile_domains);
criterion_main!(benches);

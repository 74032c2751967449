//! Scene sampling and emission speed on the driving domain (`cargo bench --bench sample`).

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use revelio::emit::{ScenicOptions, prompt, scenic};
use revelio::sample::Sampler;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("domains").join("driving.rev");
    let Ok(domain) = revelio::cli::load_domain(&path) else {
        panic!("domains/driving.rev does not compile");
    };
    let sampler = Sampler::new(&domain);
    let set = domain
        .parse_set(&[
            "town_town02",
            "intersection_ego",
            "pedestrian",
            "debris_far",
            "obstruction_near",
            "weather_foggy",
        ])
        .expect("paper concepts");
    let mut seed = 0u64;
    c.bench_function("sample 6-concept driving set", |b| {
        b.iter(|| {
            seed += 1;
            black_box(sampler.sample(black_box(set), seed).unwrap())
        })
    });
    // Two entities that rarely stand behind one another, and a near container that hides
    // what stands behind it unless the sampler moves them apart.
    for names in [&["pedestrian", "cone"][..], &["obstruction_near", "pedestrian"]] {
        let pair = domain.parse_set(names).expect("paper concepts");
        let mut seed = 0u64;
        c.bench_function(&format!("sample {}", names.join(" + ")), |b| {
            b.iter(|| {
                seed += 1;
                black_box(sampler.sample(black_box(pair), seed).unwrap())
            })
        });
    }
    c.bench_function("sample via sample() (hashes the domain)", |b| {
        b.iter(|| black_box(revelio::sample::sample(&domain, black_box(set), 7).unwrap()))
    });
    let scene = sampler.sample(set, 7).unwrap();
    let opts = ScenicOptions { map_dir: "/maps/carla".into() };
    c.bench_function("emit scenic", |b| b.iter(|| black_box(scenic(&domain, black_box(&scene), &opts).unwrap())));
    c.bench_function("emit prompt", |b| b.iter(|| black_box(prompt(&domain, black_box(&scene)).unwrap())));
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! How long a default synthetic scene takes to generate (and to write).

use criterion::{criterion_group, criterion_main, Criterion};
use splatseg_synth::{generate, write, SynthConfig};

fn bench_generate(c: &mut Criterion) {
    let config = SynthConfig::default();
    let mut group = c.benchmark_group("synth");
    group.sample_size(10);
    group.bench_function("generate_default_12x320x240", |b| {
        b.iter(|| generate(&config).expect("valid config"))
    });
    let scene = generate(&config).expect("valid config");
    let dir = tempfile::tempdir().expect("temp dir");
    group
        .bench_function("write_default_12x320x240", |b| b.iter(|| write(dir.path(), &scene).expect("write")));
    group.finish();
}

criterion_group!(benches, bench_generate);
criterion_main!(benches);

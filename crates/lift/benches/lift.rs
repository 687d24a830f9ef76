//! Criterion benchmark of lifting (each view's visibility pass and votes, then fusion and the
//! variance filter) at a reduced size; the full-size run (1M Gaussians × 100 views at 1 MP) is
//! `examples/lift_bench.rs`.

mod data;

use criterion::{criterion_group, criterion_main, Criterion};
use splatseg_lift::{view_visibility, LiftConfig, ObjectFeatures, PreparedGaussians, VoteAccumulator};

fn bench_lift(c: &mut Criterion) {
    let n = 100_000;
    let g = data::gaussians(n, 1);
    let camera = data::camera(500, 500);
    let poses = data::poses(10);
    let maps = data::id_maps(&camera, &poses);
    let features = data::object_features();
    let config = LiftConfig::default();
    let mut group = c.benchmark_group("lift");
    group.sample_size(10);
    group.bench_function("100k_gaussians_10_views_500px", |b| {
        b.iter(|| {
            let prepared = PreparedGaussians::new(&g).expect("finite");
            let mut votes = VoteAccumulator::new(n);
            for (pose, map) in poses.iter().zip(&maps) {
                let vis = view_visibility(&prepared, &camera, pose, None, &config).visible;
                let ids: Vec<u32> = vis.pixels.iter().map(|&p| map.data[p as usize]).collect();
                votes.add_view(&vis.gaussians, &vis.weights, &ids).expect("a valid list");
            }
            votes.finish(ObjectFeatures { dim: 8, values: &features }, &config).expect("known ids")
        })
    });
    group.finish();
}

criterion_group!(benches, bench_lift);
criterion_main!(benches);

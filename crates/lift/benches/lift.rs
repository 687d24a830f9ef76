//! Criterion benchmark of lifting (visibility + vote/fusion) at a reduced size; the full-size
//! run (1M Gaussians × 100 views at 1 MP) is `examples/lift_bench.rs`.

mod data;

use criterion::{criterion_group, criterion_main, Criterion};
use splatseg_lift::{
    lift_labels, visibility_all, LiftConfig, ObjectFeatures, PosedCamera, PreparedGaussians,
};

fn bench_lift(c: &mut Criterion) {
    let n = 100_000;
    let g = data::gaussians(n, 1);
    let camera = data::camera(500, 500);
    let poses = data::poses(10);
    let maps = data::id_maps(&camera, &poses);
    let features = data::object_features();
    let cams: Vec<PosedCamera> =
        poses.iter().map(|p| PosedCamera { camera: &camera, world_from_cam: p }).collect();
    let config = LiftConfig::default();
    let mut group = c.benchmark_group("lift");
    group.sample_size(10);
    group.bench_function("100k_gaussians_10_views_500px", |b| {
        b.iter(|| {
            let prepared = PreparedGaussians::new(&g).expect("finite");
            let vis = visibility_all(&prepared, &cams, None, &config).expect("sizes");
            lift_labels(n, &vis, &maps, ObjectFeatures { dim: 8, values: &features }, &config).expect("maps")
        })
    });
    group.finish();
}

criterion_group!(benches, bench_lift);
criterion_main!(benches);

//! PLY read/write speed on a 1M-Gaussian, SH-degree-3 file (62 floats per Gaussian, the INRIA
//! layout) generated in a temporary folder. Target: read under 1 s.
//!
//! `cargo bench -p splatseg-scene --features bench --bench ply_read`

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::ply::{read_ply, write_ply};
use splatseg_scene::Gaussians;
use std::time::Duration;

const N: usize = 1_000_000;

/// `n` random degree-3 Gaussians with normals (62 floats each, as 3DGS writes them).
fn random_gaussians(n: usize) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut v3 = || -> Vec<[f32; 3]> { (0..n).map(|_| rng.gen()).collect() };
    let (means, normals, sh_dc, log_scales) = (v3(), v3(), v3(), v3());
    Gaussians {
        means,
        normals: Some(normals),
        sh_dc,
        sh_degree: 3,
        sh_rest: (0..n * 45).map(|_| rng.gen()).collect(),
        raw_opacities: (0..n).map(|_| rng.gen()).collect(),
        log_scales,
        rotations: (0..n).map(|_| rng.gen()).collect(),
        ..Default::default()
    }
}

fn bench_ply(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temporary folder");
    let path = dir.path().join("bench_1m.ply");
    let g = random_gaussians(N);
    write_ply(&path, &g).expect("write benchmark file");
    let mut group = c.benchmark_group("ply_1m_sh3");
    group.sample_size(10).measurement_time(Duration::from_secs(10));
    group.bench_function("ply_read", |b| b.iter(|| read_ply(&path).expect("read")));
    let out = dir.path().join("bench_out.ply");
    group.bench_function("ply_write", |b| b.iter(|| write_ply(&out, &g).expect("write")));
    group.finish();
}

criterion_group!(benches, bench_ply);
criterion_main!(benches);

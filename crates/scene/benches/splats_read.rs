//! Reading 1M Gaussians of SH degree 3 as SPZ (version 3, gzip) against the same Gaussians as a
//! PLY, and as the other compact formats, through `splats::read_gaussians` (what every command
//! calls). Issue 61: reading the SPZ takes no longer than reading the PLY.
//!
//! `cargo bench -p splatseg-scene --features bench --bench splats_read`

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use splatseg_scene::splats::{read_gaussians, write_gaussians};
use splatseg_scene::Gaussians;
use std::time::Duration;

const N: usize = 1_000_000;

/// `n` random degree-3 Gaussians inside every format's ranges (a 20 m scene, SH within ±0.5).
fn random_gaussians(n: usize) -> Gaussians {
    let mut rng = ChaCha8Rng::seed_from_u64(61);
    let mut v3 = |lo: f32, hi: f32| -> Vec<[f32; 3]> {
        (0..n).map(|_| [0; 3].map(|_| rng.gen_range(lo..hi))).collect()
    };
    let (means, sh_dc, log_scales) = (v3(-10.0, 10.0), v3(-1.5, 1.5), v3(-7.0, -2.0));
    Gaussians {
        means,
        sh_dc,
        sh_degree: 3,
        sh_rest: (0..n * 45).map(|_| rng.gen_range(-0.5..0.5)).collect(),
        raw_opacities: (0..n).map(|_| rng.gen_range(-4.0..4.0)).collect(),
        log_scales,
        rotations: (0..n).map(|_| [0; 4].map(|_| rng.gen_range(-1.0..1.0))).collect(),
        ..Default::default()
    }
}

fn bench_formats(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("temporary folder");
    let g = random_gaussians(N);
    let mut group = c.benchmark_group("read_1m_sh3");
    group.sample_size(10).measurement_time(Duration::from_secs(10));
    for name in ["scene.ply", "scene.spz", "scene.compressed.ply", "scene.ksplat", "scene.splat"] {
        let path = dir.path().join(name);
        write_gaussians(&path, &g).expect("write benchmark file");
        let bytes = std::fs::metadata(&path).expect("written").len();
        eprintln!("{name}: {:.1} MB", bytes as f64 / 1e6);
        group.bench_function(name, |b| b.iter(|| read_gaussians(&path).expect("read")));
    }
    group.finish();
}

criterion_group!(benches, bench_formats);
criterion_main!(benches);

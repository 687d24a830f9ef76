//! Speed of scoring: one 1 MP view, and 100 views of 1 MP counted in parallel then combined
//! (the scale: "100 views of 1 MP in seconds").

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use splatseg_eval::{EvalConfig, Metrics, ViewCounts};
use splatseg_scene::Plane;

/// A 1000×1000 ground truth of 30 discs on background, and a prediction with each disc's radius
/// and centre perturbed and a few ids split, seeded by `seed`.
fn synthetic_view(seed: u64) -> (Plane<u32>, Plane<u32>) {
    let (w, h) = (1000usize, 1000usize);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut gt = Plane::filled(w, h, 0u32);
    let mut pred = Plane::filled(w, h, 0u32);
    for id in 1..=30u32 {
        let (cx, cy, r) =
            (rng.gen_range(0.0..w as f64), rng.gen_range(0.0..h as f64), rng.gen_range(30.0..160.0));
        let (px, py, pr) =
            (cx + rng.gen_range(-6.0..6.0), cy + rng.gen_range(-6.0..6.0), r + rng.gen_range(-5.0..5.0));
        let split = rng.gen_bool(0.2);
        let rows =
            |c: f64, r: f64, n: usize| ((c - r).max(0.0) as usize)..((c + r + 1.0).min(n as f64) as usize);
        for y in rows(cy, r, h) {
            for x in rows(cx, r, w) {
                let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
                if (fx - cx).powi(2) + (fy - cy).powi(2) <= r * r {
                    *gt.get_mut(x, y) = id;
                }
            }
        }
        for y in rows(py, pr, h) {
            for x in rows(px, pr, w) {
                let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
                if (fx - px).powi(2) + (fy - py).powi(2) <= pr * pr {
                    *pred.get_mut(x, y) = if split && fx > px { 100 + id } else { id };
                }
            }
        }
    }
    (gt, pred)
}

fn bench(c: &mut Criterion) {
    let cfg = EvalConfig::default();
    let views: Vec<(Plane<u32>, Plane<u32>)> = (0..100).into_par_iter().map(synthetic_view).collect();
    let mut group = c.benchmark_group("eval");
    group.sample_size(10);
    group.bench_function("one_view_1mp", |b| {
        b.iter(|| ViewCounts::compute("v", &views[0].0, &views[0].1, &cfg).map(|v| v.band.len()))
    });
    group.bench_function("hundred_views_1mp", |b| {
        b.iter(|| {
            let counts: Vec<ViewCounts> = views
                .par_iter()
                .enumerate()
                .map(|(i, (g, p))| ViewCounts::compute(&format!("v{i}"), g, p, &cfg))
                .collect::<Result<_, _>>()?;
            Metrics::from_views(&counts, &cfg).map(|m| m.miou)
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

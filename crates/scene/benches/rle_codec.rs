//! COCO RLE speed on a 1-megapixel (1000×1000) mask with a few hundred runs per column.
//! Target: encode and decode well under 10 ms.
//!
//! `cargo bench -p splatseg-scene --features bench --bench rle_codec`

use criterion::{criterion_group, criterion_main, Criterion};
use splatseg_scene::rle::Rle;
use splatseg_scene::Plane;

/// A 1000×1000 mask of overlapping discs and stripes.
fn test_mask() -> Plane<bool> {
    let (w, h) = (1000usize, 1000usize);
    let data = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let disc = |cx: f64, cy: f64, r: f64| (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) < r * r;
            disc(300.0, 400.0, 180.0) || disc(700.0, 600.0, 250.0) || (x / 9 + y / 13) % 5 == 0
        })
        .collect();
    Plane { width: w, height: h, data }
}

fn bench_rle(c: &mut Criterion) {
    let mask = test_mask();
    let rle = Rle::encode(&mask);
    let s = rle.to_coco_string();
    let mut group = c.benchmark_group("rle_1mp");
    group.bench_function("encode", |b| b.iter(|| Rle::encode(&mask)));
    group.bench_function("decode", |b| b.iter(|| rle.decode().expect("valid")));
    group.bench_function("to_coco_string", |b| b.iter(|| rle.to_coco_string()));
    group.bench_function("from_coco_string", |b| {
        b.iter(|| Rle::from_coco_string(1000, 1000, &s).expect("valid"))
    });
    group.finish();
}

criterion_group!(benches, bench_rle);
criterion_main!(benches);

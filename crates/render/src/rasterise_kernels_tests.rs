//! The AVX2 tile kernels give the portable kernels' bits, forward and backward, for every
//! channel count the dispatch specialises (1, 3, 4, 19) and a generic one (5), on random splats
//! that reach every branch: clamped α, pixels that stop, splats cut by tile and image borders.

use super::*;
use crate::bin::bin;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `[n]` random splats over a `width × height` image: sizes from sub-pixel to a few tiles,
/// opacities up to 1 (so `alpha_max` clamps), some centres outside the image.
fn random_splats(rng: &mut ChaCha8Rng, n: usize, width: usize, height: usize) -> Vec<Splat2d> {
    (0..n)
        .map(|_| {
            let sx: f32 = rng.gen_range(0.4..12.0);
            let sy: f32 = rng.gen_range(0.4..12.0);
            let rho: f32 = rng.gen_range(-0.8..0.8);
            let (cxx, cyy, cxy) = (sx * sx, sy * sy, rho * sx * sy);
            let det = cxx * cyy - cxy * cxy;
            let radius = (3.0 * sx.max(sy)).ceil() as i32;
            Splat2d {
                mean2d: [rng.gen_range(-8.0..width as f32 + 8.0), rng.gen_range(-8.0..height as f32 + 8.0)],
                conic: [cyy / det, -cxy / det, cxx / det],
                opacity: if rng.gen_bool(0.2) { 1.0 } else { rng.gen_range(0.01..1.0) },
                depth: rng.gen_range(0.5..10.0),
                radii: [radius, radius],
            }
        })
        .collect()
}

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn avx2_kernels_give_the_portable_bits() {
    if Kernels::detect() == Kernels::Portable {
        eprintln!("SKIPPED: this CPU has no AVX2 + FMA, so only the portable kernels exist here");
        return;
    }
    let (width, height) = (45, 37);
    let settings = RasterSettings::default();
    for (seed, channel_count) in [(1u64, 1usize), (2, 3), (3, 4), (4, 19), (5, 5), (6, 3), (7, 19)] {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let splats = random_splats(&mut rng, 300, width, height);
        let channels: Vec<f32> =
            (0..splats.len() * channel_count).map(|_| rng.gen_range(-1.0..2.0)).collect();
        let background: Vec<f32> = (0..channel_count).map(|_| rng.gen_range(0.0..1.0)).collect();
        let inp = RasterInputs {
            splats: &splats,
            channels: &channels,
            channel_count,
            background: &background,
            width,
            height,
            settings: &settings,
        };
        let bins = bin(&splats, width, height);
        let portable = rasterise_with(&inp, &bins, Kernels::Portable);
        let avx2 = rasterise_with(&inp, &bins, Kernels::detect());
        let what = format!("seed {seed}, {channel_count} channels");
        assert!(portable.blends > 1000, "{what}: the scene blends too little to test ({})", portable.blends);
        assert!(
            portable.walked.iter().zip(&portable.final_t).any(|(&w, &t)| w > 0 && t < 0.01),
            "{what}: no pixel stops"
        );
        assert_eq!(bits(&avx2.channels), bits(&portable.channels), "{what}: channels");
        assert_eq!(bits(&avx2.final_t), bits(&portable.final_t), "{what}: final transmittance");
        assert_eq!(avx2.walked, portable.walked, "{what}: walked");
        assert_eq!(avx2.max_weight_ids, portable.max_weight_ids, "{what}: max-weight ids");
        assert_eq!(avx2.blends, portable.blends, "{what}: blends");

        let g_channels: Vec<f32> =
            (0..width * height * channel_count).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let g_final_t: Vec<f32> = (0..width * height).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let grads = RasterOutputGrads { channels: &g_channels, final_t: Some(&g_final_t) };
        let portable = rasterise_bwd_with(&inp, &bins, &portable, &grads, Kernels::Portable);
        let avx2 = rasterise_bwd_with(&inp, &bins, &avx2, &grads, Kernels::detect());
        let flat2 = |v: &[[f32; 2]]| bits(&v.iter().flatten().copied().collect::<Vec<_>>());
        let flat3 = |v: &[[f32; 3]]| bits(&v.iter().flatten().copied().collect::<Vec<_>>());
        assert!(portable.opacity.iter().filter(|g| **g != 0.0).count() > 100, "{what}: few gradients");
        assert_eq!(flat2(&avx2.mean2d), flat2(&portable.mean2d), "{what}: ∂mean2d");
        assert_eq!(flat3(&avx2.conic), flat3(&portable.conic), "{what}: ∂conic");
        assert_eq!(bits(&avx2.opacity), bits(&portable.opacity), "{what}: ∂opacity");
        assert_eq!(bits(&avx2.channels), bits(&portable.channels), "{what}: ∂channels");
    }
}

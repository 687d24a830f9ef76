//! SAM masks (COCO RLE counts) → row runs (`MaskInput::from_coco_counts`), per mask, on a
//! 1280×960 view: 300 SAM-like masks, the simulated SAM masks of generated synthetic views
//! (`splatseg_synth`) taken in view order until there are 300. Single thread; the time of one
//! iteration divided by 300 is the cost per mask.

use criterion::{criterion_group, criterion_main, Criterion};
use splatseg_cues::MaskInput;
use splatseg_synth::{generate, SynthConfig};

const WIDTH: u32 = 1280;
const HEIGHT: u32 = 960;
const MASKS: usize = 300;

/// `[MASKS]` COCO counts of `WIDTH × HEIGHT` masks.
fn sam_like_counts() -> Vec<Vec<u32>> {
    let config = SynthConfig { width: WIDTH, height: HEIGHT, views: 4, ..SynthConfig::default() };
    let scene = generate(&config).expect("valid synthetic config");
    let all: Vec<Vec<u32>> =
        scene.views.iter().flat_map(|v| v.sam_masks.iter().map(|m| m.segmentation.counts.clone())).collect();
    assert!(!all.is_empty(), "the synthetic views have SAM masks");
    eprintln!("{} distinct SAM masks from {} views, cycled to {MASKS}", all.len(), config.views);
    all.iter().cycle().take(MASKS).cloned().collect()
}

fn bench_mask_runs(c: &mut Criterion) {
    let counts = sam_like_counts();
    let (w, h) = (WIDTH as usize, HEIGHT as usize);
    let mut group = c.benchmark_group("mask_runs");
    group.sample_size(10);
    group.bench_function("from_coco_counts_300_masks_1280x960", |b| {
        let mut scratch = Vec::new();
        b.iter(|| {
            counts
                .iter()
                .map(|c| {
                    MaskInput::from_coco_counts(c, w, h, &mut scratch, (0.0, 0.0)).expect("valid counts")
                })
                .map(|m| m.runs.len())
                .sum::<usize>()
        })
    });
    group.finish();
}

criterion_group!(benches, bench_mask_runs);
criterion_main!(benches);

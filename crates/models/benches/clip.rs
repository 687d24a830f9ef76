//! CLIP ViT-B/16 with random weights (the released shapes: image tower width 768, 12 layers, 12 heads,
//! patch 16, 224²; text tower width 512, 12 layers, 8 heads, 77 tokens, 49,408 ids; embeddings 512):
//! one 224² image, five 224² crops in one batch (an object's views), and one short text query
//! tokenized and embedded. Threads: rayon's default (every core).
//!
//! Before criterion's wall times it prints the process CPU time per call (all threads, from
//! `/proc/self/stat`), which a loaded machine inflates far less than the wall time: on idle cores the
//! wall time is at least CPU time / cores.
//!
//! `cargo bench -p splatseg-models --features bench --bench clip`

use std::collections::HashMap;
use std::path::Path;

use candle_core::{Device, Tensor};
use criterion::{criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use splatseg_models::clip::{Activation, Clip, ClipHints, ClipTokenizer};
use splatseg_models::weights::Weights;
use splatseg_models::ModelKind;

/// `shape` of seeded uniform values in ±`scale`.
fn random(rng: &mut rand_chacha::ChaCha8Rng, shape: &[usize], scale: f32) -> Tensor {
    let n: usize = shape.iter().product();
    let values: Vec<f32> = (0..n).map(|_| rng.gen_range(-scale..scale)).collect();
    Tensor::from_vec(values, shape, &Device::Cpu).expect("shape matches")
}

fn add_blocks(
    tensors: &mut HashMap<String, Tensor>,
    rng: &mut rand_chacha::ChaCha8Rng,
    prefix: &str,
    (width, layers): (usize, usize),
) {
    let s = 1.0 / (width as f32).sqrt();
    for i in 0..layers {
        let p = format!("{prefix}{i}.");
        let mut put = |name: &str, shape: &[usize], scale: f32| {
            tensors.insert(format!("{p}{name}"), random(rng, shape, scale));
        };
        put("ln_1.weight", &[width], 1.0);
        put("ln_1.bias", &[width], 0.1);
        put("attn.in_proj_weight", &[3 * width, width], s);
        put("attn.in_proj_bias", &[3 * width], 0.1);
        put("attn.out_proj.weight", &[width, width], s);
        put("attn.out_proj.bias", &[width], 0.1);
        put("ln_2.weight", &[width], 1.0);
        put("ln_2.bias", &[width], 0.1);
        put("mlp.c_fc.weight", &[4 * width, width], s);
        put("mlp.c_fc.bias", &[4 * width], 0.1);
        put("mlp.c_proj.weight", &[width, 4 * width], s / 2.0);
        put("mlp.c_proj.bias", &[width], 0.1);
    }
}

/// A ViT-B/16 CLIP state dict (OpenAI names) of random values.
fn vit_b16() -> Clip {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(16);
    let mut t = HashMap::new();
    let (vw, tw, embed) = (768, 512, 512);
    t.insert("visual.class_embedding".into(), random(&mut rng, &[vw], 0.1));
    t.insert("visual.positional_embedding".into(), random(&mut rng, &[197, vw], 0.1));
    t.insert("visual.conv1.weight".into(), random(&mut rng, &[vw, 3, 16, 16], 0.05));
    for ln in ["visual.ln_pre", "visual.ln_post", "ln_final"] {
        let width = if ln == "ln_final" { tw } else { vw };
        t.insert(format!("{ln}.weight"), random(&mut rng, &[width], 1.0));
        t.insert(format!("{ln}.bias"), random(&mut rng, &[width], 0.1));
    }
    add_blocks(&mut t, &mut rng, "visual.transformer.resblocks.", (vw, 12));
    t.insert("visual.proj".into(), random(&mut rng, &[vw, embed], 0.05));
    t.insert("token_embedding.weight".into(), random(&mut rng, &[49_408, tw], 0.1));
    t.insert("positional_embedding".into(), random(&mut rng, &[77, tw], 0.1));
    add_blocks(&mut t, &mut rng, "transformer.resblocks.", (tw, 12));
    t.insert("text_projection".into(), random(&mut rng, &[tw, embed], 0.05));
    let weights = Weights::from_tensors(t, Path::new("random ViT-B/16"), ModelKind::Clip);
    let hints = ClipHints { activation: Some(Activation::Gelu), ..ClipHints::default() };
    Clip::from_weights(&weights, hints).expect("the ViT-B/16 shapes")
}

/// User + system CPU seconds of this process so far (Linux; `None` elsewhere). `/proc` counts in
/// USER_HZ ticks, 100 per second on Linux.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// Prints the CPU time per call of `f` over `calls` calls.
fn print_cpu_time(label: &str, calls: usize, mut f: impl FnMut()) {
    f(); // warm-up
    let (start, wall) = (cpu_seconds(), std::time::Instant::now());
    for _ in 0..calls {
        f();
    }
    let wall = wall.elapsed().as_secs_f64() / calls as f64;
    match (start, cpu_seconds()) {
        (Some(a), Some(b)) => eprintln!(
            "{label}: {:.3} s CPU per call ({wall:.3} s wall), {calls} calls",
            (b - a) / calls as f64
        ),
        _ => eprintln!("{label}: no /proc/self/stat, CPU time not measured ({wall:.3} s wall)"),
    }
}

fn bench_clip(c: &mut Criterion) {
    let model = vit_b16();
    let image = model.image_tower().expect("image tower");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(224);
    let one = random(&mut rng, &[1, 3, 224, 224], 2.0);
    let five = random(&mut rng, &[5, 3, 224, 224], 2.0);
    // the OpenAI merges the fixtures keep (ids below 49,408); a short query's tokens are what matter
    let merges = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/clip_bpe_openai_subset.txt.gz");
    let tokenizer = ClipTokenizer::load(&merges).expect("committed merges fixture");
    print_cpu_time("image_224_one", 5, || drop(image.embed(&one).expect("embeds")));
    print_cpu_time("image_224_batch_of_5", 2, || drop(image.embed(&five).expect("embeds")));
    print_cpu_time("text_query", 10, || {
        drop(model.embed_texts(&tokenizer, &["a red mug on the table"]).expect("embeds"))
    });
    let mut group = c.benchmark_group("clip_vit_b16");
    group.sample_size(10);
    group.bench_function("image_224_one", |b| b.iter(|| image.embed(&one).expect("embeds")));
    group.bench_function("image_224_batch_of_5", |b| b.iter(|| image.embed(&five).expect("embeds")));
    group.bench_function("text_query", |b| {
        b.iter(|| model.embed_texts(&tokenizer, &["a red mug on the table"]).expect("embeds"))
    });
    group.finish();
}

criterion_group!(benches, bench_clip);
criterion_main!(benches);

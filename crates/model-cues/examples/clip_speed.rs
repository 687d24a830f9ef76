//! Times issue 30's object embeddings and queries with a random-weight CLIP of ViT-B/16's shapes (image
//! tower 768 wide, 12 blocks, 224², patches of 16; text tower 512 wide, 12 blocks; 49,408 token ids):
//! `embed_objects` on a finished run (seconds per crop, per object, in all), then `ObjectSearch::open`
//! (the text tower loaded once) and the median latency of a query after it.
//!
//! ```sh
//! splatseg synth --out /tmp/speed/scene --views 20 --size 320x240
//! splatseg run /tmp/speed/scene --masks /tmp/speed/scene/sam --out /tmp/speed/out
//! cargo run --release -p splatseg-model-cues --features bench --example clip_speed -- /tmp/speed/scene /tmp/speed/out
//! ```
//!
//! The checkpoint is written to `OUT/../clip_vit_b16_random/` with the OpenAI merges subset the models'
//! fixtures keep (a query's ids are what matter). Its `OUT/objects/` is removed first so the embeddings
//! are computed, not read from the cache.

use splatseg_model_cues::clip_objects::{embed_objects, ObjectEmbeddingRequest, ObjectSearch};
use splatseg_models::clip::testing::{write_random_checkpoint, RandomClipSpec};
use splatseg_models::clip::MERGES_FILE;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [scene, out] = args.as_slice() else {
        return Err("usage: clip_speed SCENE OUT (OUT: a finished `splatseg run` on SCENE)".into());
    };
    let clip = out.parent().unwrap_or(Path::new(".")).join("clip_vit_b16_random");
    write_random_checkpoint(&clip, RandomClipSpec::vit_b16(49_408), 16)?;
    let merges =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/tests/fixtures/clip_bpe_openai_subset.txt.gz");
    std::fs::copy(merges, clip.join(MERGES_FILE))?;
    let _ = std::fs::remove_dir_all(out.join("objects"));
    let request = ObjectEmbeddingRequest {
        scene: scene.clone(),
        out: out.clone(),
        clip: clip.clone(),
        show_progress: false,
    };
    let start = Instant::now();
    let summary = embed_objects(&request)?;
    let total = start.elapsed().as_secs_f64();
    let per_crop = summary.embed_seconds / summary.crops.max(1) as f64;
    println!(
        "embed_objects: {} objects ({} embedded) from {} crops: {:.2} s in all, image tower {:.2} s = {:.3} s per \
         crop, {:.3} s per embedded object",
        summary.objects,
        summary.embedded,
        summary.crops,
        total,
        summary.embed_seconds,
        per_crop,
        summary.embed_seconds / summary.embedded.max(1) as f64
    );
    let start = Instant::now();
    let search = ObjectSearch::open(out)?;
    println!(
        "ObjectSearch::open (index, embeddings, text tower, negatives): {:.3} s",
        start.elapsed().as_secs_f64()
    );
    let queries = ["a red mug", "a wooden chair", "a lamp", "the floor", "a green box"];
    let mut times: Vec<f64> = Vec::new();
    for round in 0..4 {
        for q in queries {
            let start = Instant::now();
            let found = search.find(q, 5)?;
            times.push(start.elapsed().as_secs_f64());
            if round == 0 && q == queries[0] {
                println!("{q:?}: best {:?}", found.first().map(|f| (f.id, f.relevancy)));
            }
        }
    }
    times.sort_by(f64::total_cmp);
    println!(
        "query after load: median {:.1} ms, max {:.1} ms over {} queries",
        1e3 * times[times.len() / 2],
        1e3 * times[times.len() - 1],
        times.len()
    );
    Ok(())
}

//! One CLIP embedding per object of a finished run (issue 30), and text queries against them.
//!
//! [`embed_objects`] (`splatseg run --clip CKPT`): for each object of the final label maps
//! (`OUT/masks/<stem>.png`), the views where it is largest and least cut by the frame (at most
//! [`VIEWS_PER_OBJECT`]), each cropped LERF-style (its box grown by a margin and made square, the pixels
//! outside its mask greyed), embedded by the image tower; the L2-normalised mean of its crops'
//! normalised embeddings is its row of `OUT/objects/clip.npy` (`[N, E]` f32), and `OUT/objects/objects.json`
//! indexes the rows (id, colour, views), names the checkpoint and records what it belongs to (the run's
//! key, the PLY's digest, the checkpoint's identity: [`crate::object_index`]). Cached: a rerun whose
//! run, checkpoint and settings are unchanged does nothing.
//!
//! [`ObjectSearch`] (`splatseg find`, `extract`/`remove` with a query, the viewer's search): the index,
//! once shown to belong to the run, the PLY and the checkpoint as they are now, the embeddings and the
//! text tower loaded once; a query (not empty, within CLIP's context) is ranked with LERF's relevancy
//! against the canonical negatives ([`splatseg_models::clip::relevancy`]).

use crate::cached_output::{fnv1a, FNV_OFFSET};
use crate::object_index::{checkpoint_identity, ply_digest, run_key, FORMAT};
pub use crate::object_index::{IndexedObject, ObjectIndex, RunIdentity, UsedView};
use crate::{Context, ModelCuesError};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use splatseg_models::clip::relevancy::{rank_objects, Embeddings, CANONICAL_NEGATIVES, LERF_SCALE};
use splatseg_models::clip::{Clip, ClipHints, ClipTokenizer, CLIP_MEAN, CLIP_STD, CLIP_WEIGHT_NAMES};
use splatseg_models::resample::{resize_planes, AxisResize, AxisTaps, Resample};
use splatseg_models::ModelKind;
use splatseg_scene::image_io::RgbImage;
use splatseg_scene::images::load_image_rgb;
use splatseg_scene::{load_scene, LoadOptions, Plane};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A view an object could be cropped from: (score, view index, its footprint there).
type ScoredView = (f64, usize, Footprint);

/// The folder under a run's OUT.
pub const OBJECTS_DIR: &str = "objects";
/// The embeddings, `[N, E]` f32.
pub const EMBEDDINGS_FILE: &str = "clip.npy";
/// The index of the embeddings' rows.
pub const INDEX_FILE: &str = "objects.json";
/// Most views (crops) per object.
pub const VIEWS_PER_OBJECT: usize = 5;
/// An object smaller than this many pixels in a view is not cropped from it (16 × 16).
pub const MIN_PIXELS: u64 = 256;
/// Crop margin: this share of the box's longer side on every side, at least [`MIN_MARGIN_PX`].
pub const MARGIN_SHARE: f64 = 0.1;
/// The smallest crop margin, in pixels.
pub const MIN_MARGIN_PX: usize = 8;
/// The mask is grown by this many pixels (in x and y) before the rest of the crop is greyed.
pub const MASK_DILATION_PX: usize = 2;
/// The grey outside the mask (and outside the image).
pub const GREY: u8 = 128;
/// Crops per image-tower call; the batches follow the objects' order, so results do not depend on
/// the thread count.
pub const CROPS_PER_BATCH: usize = 8;

/// What [`embed_objects`] needs.
#[derive(Clone, Debug)]
pub struct ObjectEmbeddingRequest {
    /// The scene folder the run read (its images are cropped).
    pub scene: PathBuf,
    /// The finished run's output folder.
    pub out: PathBuf,
    /// The CLIP checkpoint (file, folder or Hugging Face cache id), with its tokenizer file beside
    /// (`bpe_simple_vocab_16e6.txt.gz` or `tokenizer.json`).
    pub clip: PathBuf,
    /// Draw a progress bar on stderr.
    pub show_progress: bool,
}

impl ObjectEmbeddingRequest {
    /// Checks the checkpoint before the run, so that a bad one fails at once rather than after the
    /// pipeline: its weights resolve (a FIFO or a device in their place is refused as not a regular
    /// file), load with finite values (a NaN names its tensor and the file), the tokenizer beside them
    /// loads and fits the text tower, and the text tower embeds the canonical phrases.
    pub fn check(&self) -> crate::Result<()> {
        let model = Clip::load(&self.clip, ClipHints::default()).context("the CLIP checkpoint (--clip)")?;
        model.image_tower().context("the CLIP checkpoint (--clip)")?;
        let (tokenizer, _) = text_side(&self.clip, &model).context("the CLIP checkpoint (--clip)")?;
        texts(&model, &tokenizer, &CANONICAL_NEGATIVES).context("the CLIP checkpoint (--clip)")?;
        Ok(())
    }
}

/// The tokenizer beside `checkpoint` (and the weights file), checked against `model`'s text tower:
/// present, readable, and with no id past the tower's token table.
fn text_side(checkpoint: &Path, model: &Clip) -> crate::Result<(ClipTokenizer, PathBuf)> {
    let files = splatseg_models::checkpoint::resolve_named(checkpoint, ModelKind::Clip, &CLIP_WEIGHT_NAMES)?;
    let vocabulary = splatseg_models::clip::tokenizer_beside(&files.weights).with_context(|| {
        format!(
            "no tokenizer ({} or {}) beside the CLIP checkpoint {}",
            splatseg_models::clip::MERGES_FILE,
            splatseg_models::clip::HF_TOKENIZER_FILE,
            checkpoint.display()
        )
    })?;
    let tokenizer = ClipTokenizer::load(&vocabulary)?;
    let tower = model.text_tower()?.config().vocab_size;
    if tokenizer.vocab_size() > tower {
        return Err(ModelCuesError::Invalid(format!(
            "the tokenizer has {} token ids but the checkpoint's text tower {} (not the checkpoint's own tokenizer?): {} \
             beside {}",
            tokenizer.vocab_size(),
            tower,
            vocabulary.display(),
            files.weights.display()
        )));
    }
    Ok((tokenizer, files.weights))
}

/// What [`embed_objects`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectEmbeddingSummary {
    /// Objects in the final label maps.
    pub objects: usize,
    /// Objects with an embedding (the others are smaller than [`MIN_PIXELS`] in every view).
    pub embedded: usize,
    /// Crops embedded (0 when cached).
    pub crops: usize,
    /// The outputs were already there for these inputs.
    pub cached: bool,
    /// Wall time of the image tower, seconds (0 when cached).
    pub embed_seconds: f64,
    /// `OUT/objects/`.
    pub dir: PathBuf,
}

impl ObjectEmbeddingSummary {
    /// One line for the terminal.
    pub fn to_text(&self) -> String {
        if self.cached {
            return format!(
                "object embeddings: {} of {} objects, unchanged (cached) in {}\n",
                self.embedded,
                self.objects,
                self.dir.display()
            );
        }
        let per_crop = if self.crops > 0 { self.embed_seconds / self.crops as f64 } else { 0.0 };
        format!(
            "object embeddings: {} of {} objects from {} crops ({:.3} s per crop) in {}\n",
            self.embedded,
            self.objects,
            self.crops,
            per_crop,
            self.dir.display()
        )
    }
}

/// An object's footprint in one view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Footprint {
    pixels: u64,
    /// Inclusive box.
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

impl Footprint {
    fn new(x: usize, y: usize) -> Self {
        Self { pixels: 0, x0: x, y0: y, x1: x, y1: y }
    }

    fn add(&mut self, x: usize, y: usize) {
        self.pixels += 1;
        self.x0 = self.x0.min(x);
        self.x1 = self.x1.max(x);
        self.y0 = self.y0.min(y);
        self.y1 = self.y1.max(y);
    }

    /// `pixels · (1 − b)`, `b` the share of the box's perimeter lying on the image border (the
    /// object cut by the frame).
    fn score(&self, (width, height): (usize, usize)) -> f64 {
        let (w, h) = ((self.x1 - self.x0 + 1) as f64, (self.y1 - self.y0 + 1) as f64);
        let mut on_border = 0.0;
        if self.x0 == 0 {
            on_border += h;
        }
        if self.x1 + 1 == width {
            on_border += h;
        }
        if self.y0 == 0 {
            on_border += w;
        }
        if self.y1 + 1 == height {
            on_border += w;
        }
        self.pixels as f64 * (1.0 - on_border / (2.0 * (w + h)))
    }
}

/// Every object's footprint in one label map, by id (0 = unlabelled left out).
fn footprints(labels: &Plane<u32>) -> BTreeMap<u32, Footprint> {
    let mut found: BTreeMap<u32, Footprint> = BTreeMap::new();
    for y in 0..labels.height {
        for (x, &id) in labels.row(y).iter().enumerate() {
            if id != 0 {
                found.entry(id).or_insert_with(|| Footprint::new(x, y)).add(x, y);
            }
        }
    }
    found
}

/// The square crop around `f` (LERF-style): the box grown by the margin, pixels outside the image or
/// outside the object's mask (grown by [`MASK_DILATION_PX`]) grey; `[3, S, S]` in [0, 1] before
/// resizing to `size` with PIL's bicubic (antialiased), then normalised with CLIP's mean and std.
fn crop(image: &RgbImage, labels: &Plane<u32>, id: u32, f: &Footprint, size: usize) -> Vec<f32> {
    let side = (f.x1 - f.x0 + 1).max(f.y1 - f.y0 + 1);
    let margin = ((MARGIN_SHARE * side as f64).ceil() as usize).max(MIN_MARGIN_PX);
    let full = side + 2 * margin;
    // top-left corner: the box's centre minus half the crop (in doubled coordinates to stay integral)
    let left = ((f.x0 + f.x1 + 1) as i64 - full as i64).div_euclid(2);
    let top = ((f.y0 + f.y1 + 1) as i64 - full as i64).div_euclid(2);
    let inside = |i: usize, j: usize| -> Option<(usize, usize)> {
        let (x, y) = (left + i as i64, top + j as i64);
        (x >= 0 && y >= 0 && (x as usize) < labels.width && (y as usize) < labels.height)
            .then_some((x as usize, y as usize))
    };
    let mask: Vec<bool> = (0..full * full)
        .map(|k| inside(k % full, k / full).is_some_and(|(x, y)| *labels.get(x, y) == id))
        .collect();
    let grown = dilate(&mask, full, MASK_DILATION_PX);
    let plane = full * full;
    let mut chw = vec![GREY as f32 / 255.0; 3 * plane];
    for k in 0..plane {
        if let Some((x, y)) = inside(k % full, k / full).filter(|_| grown[k]) {
            let p = (y * image.width + x) * 3;
            for c in 0..3 {
                chw[c * plane + k] = image.data[p + c] as f32 / 255.0;
            }
        }
    }
    let taps = AxisTaps::new(AxisResize::to_len(full, size), Resample::BicubicAntialias);
    let mut resized = resize_planes(&chw, 3, &taps, &taps, full, full);
    let out_plane = size * size;
    for (c, values) in resized.chunks_mut(out_plane).enumerate() {
        for v in values {
            *v = (v.clamp(0.0, 1.0) - CLIP_MEAN[c]) / CLIP_STD[c];
        }
    }
    resized
}

/// `mask` (`[n, n]`) grown by `radius` pixels along x and y (a square structuring element).
fn dilate(mask: &[bool], n: usize, radius: usize) -> Vec<bool> {
    let pass = |src: &[bool], along_x: bool| -> Vec<bool> {
        (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let c = if along_x { i } else { j };
                (c.saturating_sub(radius)..(c + radius + 1).min(n)).any(|t| {
                    if along_x {
                        src[j * n + t]
                    } else {
                        src[t * n + i]
                    }
                })
            })
            .collect()
    };
    pass(&pass(mask, true), false)
}

/// Embeds every object of the finished run in `request.out` (see the module docs).
pub fn embed_objects(request: &ObjectEmbeddingRequest) -> crate::Result<ObjectEmbeddingSummary> {
    let out = &request.out;
    let _lock = splatseg_pipeline::lock::lock_output(out, "run --clip")?;
    let files =
        splatseg_models::checkpoint::resolve_named(&request.clip, ModelKind::Clip, &CLIP_WEIGHT_NAMES)
            .context("the CLIP checkpoint (--clip)")?;
    // a path made absolute (queries may run elsewhere); a Hugging Face cache id as it is
    let checkpoint = match request.clip.exists() {
        true => std::path::absolute(&request.clip)
            .with_context(|| format!("cannot resolve the path {}", request.clip.display()))?,
        false => request.clip.clone(),
    };
    let weights_id = checkpoint_identity(&files.weights)?;
    let run_key = run_key(out)?;
    let ply_digest = ply_digest(&out.join("gaussians.ply"))?;
    let settings = format!(
        "clip objects v{FORMAT} views {VIEWS_PER_OBJECT} min {MIN_PIXELS} margin {MARGIN_SHARE}/{MIN_MARGIN_PX} \
         dilation {MASK_DILATION_PX} grey {GREY}"
    );
    let ply_text = ply_digest.as_deref().unwrap_or("no PLY");
    let key = format!(
        "{:016x}",
        fnv1a(format!("{run_key}\n{ply_text}\n{weights_id}\n{settings}").as_bytes(), FNV_OFFSET)
    );
    let dir = out.join(OBJECTS_DIR);
    let (index_path, npy_path) = (dir.join(INDEX_FILE), dir.join(EMBEDDINGS_FILE));
    if npy_path.is_file() {
        if let Ok(index) = ObjectIndex::read(&index_path) {
            if index.key == key && index.checkpoint == checkpoint {
                let embedded = index.objects.iter().filter(|o| o.row.is_some()).count();
                return Ok(ObjectEmbeddingSummary {
                    objects: index.objects.len(),
                    embedded,
                    crops: 0,
                    cached: true,
                    embed_seconds: 0.0,
                    dir,
                });
            }
        }
    }
    let model = Clip::load(&request.clip, ClipHints::default()).context("the CLIP checkpoint (--clip)")?;
    let size = model.image_tower()?.config().image_size;
    let dim = model.config().embed_dim;

    // 1. every object's footprint in every view, and its best views
    let scene = load_scene(&request.scene, &LoadOptions::default())?;
    let masks = out.join("masks");
    let mut candidates: BTreeMap<u32, Vec<(f64, usize, Footprint)>> = BTreeMap::new();
    let mut shown = Vec::new(); // views with a label map
    for (v, view) in scene.views.iter().enumerate() {
        let path = masks.join(format!("{}.png", view.stem));
        if !path.is_file() {
            continue;
        }
        let labels = splatseg_scene::labels::read_label_png(&path)?;
        shown.push(v);
        for (id, f) in footprints(&labels) {
            let score = f.score((labels.width, labels.height));
            candidates.entry(id).or_default().push((score, v, f));
        }
    }
    if shown.is_empty() {
        return Err(ModelCuesError::Invalid(format!(
            "no label map of the scene's views in {} (was the run made on this scene?)",
            masks.display()
        )));
    }
    let chosen: Vec<(u32, Vec<ScoredView>)> = candidates
        .into_iter()
        .map(|(id, mut views)| {
            views.retain(|(_, _, f)| f.pixels >= MIN_PIXELS);
            views.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            views.truncate(VIEWS_PER_OBJECT);
            (id, views)
        })
        .collect();

    // 2. the crops, view by view (each image and label map read once), kept in object order
    let mut wanted: BTreeMap<usize, Vec<(usize, u32, Footprint)>> = BTreeMap::new(); // view → (slot, id, f)
    let mut slots = 0;
    for (id, views) in &chosen {
        for (_, v, f) in views {
            wanted.entry(*v).or_default().push((slots, *id, *f));
            slots += 1;
        }
    }
    let style = ProgressStyle::with_template("{prefix:>9} [{bar:30}] {pos}/{len} {msg} {elapsed_precise}")
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    let bar = ProgressBar::new((wanted.len() + slots) as u64).with_style(style).with_prefix("clip");
    if !request.show_progress {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut crops: Vec<Vec<f32>> = vec![Vec::new(); slots];
    for (&v, list) in &wanted {
        let view = &scene.views[v];
        bar.set_message(format!("cropping {}", view.name));
        let image = load_image_rgb(&scene, view, &LoadOptions::default())?;
        let labels = splatseg_scene::labels::read_label_png(&masks.join(format!("{}.png", view.stem)))?;
        if (image.width, image.height) != (labels.width, labels.height) {
            return Err(ModelCuesError::Invalid(format!(
                "view {}: the image is {}×{} but its label map {}×{}: {}",
                view.name,
                image.width,
                image.height,
                labels.width,
                labels.height,
                masks.join(format!("{}.png", view.stem)).display()
            )));
        }
        for (slot, id, f) in list {
            crops[*slot] = crop(&image, &labels, *id, f, size);
        }
        bar.inc(1);
    }

    // 3. the image tower over fixed batches, then per object the normalised mean
    let started = std::time::Instant::now();
    let mut embeddings: Vec<Vec<f64>> = Vec::with_capacity(slots);
    for batch in crops.chunks(CROPS_PER_BATCH) {
        bar.set_message("embedding");
        let rows = model.embed_images_flat(batch.concat(), batch.len())?;
        for row in rows.chunks(dim) {
            embeddings.push(unit(row.iter().map(|&v| f64::from(v)).collect()));
        }
        bar.inc(batch.len() as u64);
    }
    let embed_seconds = started.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let mut values: Vec<f32> = Vec::new();
    let mut objects = Vec::with_capacity(chosen.len());
    let mut next = embeddings.iter();
    let mut rows = 0;
    for (id, views) in &chosen {
        let row = if views.is_empty() {
            None
        } else {
            let mut mean = vec![0f64; dim];
            for e in next.by_ref().take(views.len()) {
                for (m, x) in mean.iter_mut().zip(e) {
                    *m += x;
                }
            }
            values.extend(unit(mean).into_iter().map(|v| v as f32));
            rows += 1;
            Some(rows - 1)
        };
        let used = views
            .iter()
            .map(|(score, v, f)| UsedView {
                stem: scene.views[*v].stem.clone(),
                pixels: f.pixels,
                score: *score,
            })
            .collect();
        objects.push(IndexedObject {
            id: *id,
            row,
            colour: splatseg_scene::labels::colour_of_id(*id),
            views: used,
        });
    }
    let index = ObjectIndex {
        format: FORMAT,
        key,
        run_key,
        ply_digest,
        checkpoint,
        checkpoint_id: weights_id,
        dim,
        image_size: size,
        objects,
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    // the index last: it names the embeddings' rows and holds the key a rerun checks
    let _ = std::fs::remove_file(&index_path);
    splatseg_scene::npy::write_npy_f32(&npy_path, &[rows, dim], &values)?;
    let json = serde_json::to_string_pretty(&index)
        .map_err(|e| ModelCuesError::Invalid(format!("cannot serialise the object index: {e}")))?;
    splatseg_scene::atomic::write_bytes_atomic(&index_path, format!("{json}\n").as_bytes())?;
    Ok(ObjectEmbeddingSummary {
        objects: index.objects.len(),
        embedded: rows,
        crops: slots,
        cached: false,
        embed_seconds,
        dir,
    })
}

/// `v / |v|` (a zero vector stays zero).
fn unit(v: Vec<f64>) -> Vec<f64> {
    let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
    if norm > 0.0 && norm.is_finite() {
        v.into_iter().map(|x| x / norm).collect()
    } else {
        v
    }
}

/// One object found by a query.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FoundObject {
    /// Rank, 1 = best.
    pub rank: usize,
    /// The object's id.
    pub id: u32,
    /// LERF relevancy in (0, 1): above 0.5, closer to the query than to every canonical phrase.
    pub relevancy: f32,
    /// Cosine between the object's and the query's embeddings.
    pub cosine: f32,
    /// Its palette colour.
    pub colour: [u8; 3],
    /// The views its embedding came from.
    pub views: Vec<String>,
    /// The name `splatseg apply` gave it (`OUT/objects.json`); left out of the JSON when none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
}

/// A run's object embeddings with the text tower that queries them, loaded once.
#[derive(Debug)]
pub struct ObjectSearch {
    index: ObjectIndex,
    /// `clip.npy`, `[rows, dim]`.
    embeddings: Vec<f32>,
    clip: Clip,
    tokenizer: ClipTokenizer,
    /// The canonical phrases' embeddings, `[4, dim]`.
    negatives: Vec<f32>,
    /// The names `splatseg apply` gave the objects (id → name).
    names: BTreeMap<i32, String>,
}

impl ObjectSearch {
    /// Opens `OUT/objects/` for the run's own `OUT/gaussians.ply` (see [`ObjectSearch::open_beside`]).
    pub fn open(out: &Path) -> crate::Result<ObjectSearch> {
        Self::open_for(out, &out.join("gaussians.ply"))
    }

    /// Opens the object embeddings `run --clip` wrote beside `ply` (a run's `gaussians.ply`: its
    /// folder is the run's OUT), for queries on the objects of `ply`.
    pub fn open_beside(ply: &Path) -> crate::Result<ObjectSearch> {
        let out = match ply.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        Self::open_for(out, ply)
    }

    /// Opens `OUT/objects/` and the text tower of the checkpoint its index names (with the tokenizer
    /// file beside it), once the index is shown to belong to the run in `out`, to `ply` and to the
    /// checkpoint as they are now ([`ObjectIndex::check_belongs`]); errors name the file that is
    /// missing or wrong, or what differs.
    fn open_for(out: &Path, ply: &Path) -> crate::Result<ObjectSearch> {
        let dir = out.join(OBJECTS_DIR);
        let index_path = dir.join(INDEX_FILE);
        let index = ObjectIndex::read(&index_path)?;
        let named = || format!("the CLIP checkpoint that {} names", index_path.display());
        let files = splatseg_models::checkpoint::resolve_named(
            &index.checkpoint,
            ModelKind::Clip,
            &CLIP_WEIGHT_NAMES,
        )
        .with_context(named)?;
        index.check_belongs(&index_path, &RunIdentity::of(out, ply, &files.weights)?)?;
        let npy_path = dir.join(EMBEDDINGS_FILE);
        let npy = splatseg_scene::npy::read_npy(&npy_path).context("the object embeddings")?;
        let rows = index.objects.iter().filter(|o| o.row.is_some()).count();
        if npy.shape != [rows, index.dim] {
            return Err(ModelCuesError::Invalid(format!(
                "expected [{rows}, {}] embeddings as {} says, found shape {:?}: {}",
                index.dim,
                index_path.display(),
                npy.shape,
                npy_path.display()
            )));
        }
        let clip = Clip::load_text_only(&index.checkpoint, ClipHints::default())
            .with_context(|| format!("{}: {}", named(), index.checkpoint.display()))?;
        let (tokenizer, _) = text_side(&index.checkpoint, &clip)?;
        if clip.config().embed_dim != index.dim {
            return Err(ModelCuesError::Invalid(format!(
                "the checkpoint embeds in {} dimensions but the embeddings have {}: {}",
                clip.config().embed_dim,
                index.dim,
                index.checkpoint.display()
            )));
        }
        let negatives = texts(&clip, &tokenizer, &CANONICAL_NEGATIVES)?;
        let names = splatseg_pipeline::apply::object_names(out)?;
        Ok(ObjectSearch { index, embeddings: npy.data, clip, tokenizer, negatives, names })
    }

    /// The index.
    pub fn index(&self) -> &ObjectIndex {
        &self.index
    }

    /// The embedded objects' ids `[N]` and embeddings `[N, E]`, in the index's (id) order.
    pub fn embedded(&self) -> (Vec<u32>, &[f32]) {
        let ids = self.index.objects.iter().filter(|o| o.row.is_some()).map(|o| o.id).collect();
        (ids, &self.embeddings)
    }

    /// The canonical phrases' embeddings, `[4, E]`, L2-normalised.
    pub fn negatives(&self) -> &[f32] {
        &self.negatives
    }

    /// L2-normalised text embeddings `[texts, E]` by the run's text tower.
    pub fn embed_texts(&self, texts_in: &[&str]) -> crate::Result<Vec<f32>> {
        texts(&self.clip, &self.tokenizer, texts_in)
    }

    /// The `top` objects most relevant to `query`, best first (ties by id).
    pub fn find(&self, query: &str, top: usize) -> crate::Result<Vec<FoundObject>> {
        let q = texts(&self.clip, &self.tokenizer, &[query])?;
        let dim = self.index.dim;
        let embedded: Vec<&IndexedObject> = self.index.objects.iter().filter(|o| o.row.is_some()).collect();
        let ids: Vec<u32> = embedded.iter().map(|o| o.id).collect();
        // rows in the index's order: row r of clip.npy is the r-th embedded object
        let ranked = rank_objects(
            &ids,
            Embeddings::new(&self.embeddings, dim, "object embeddings")?,
            &q,
            Embeddings::new(&self.negatives, dim, "canonical phrases")?,
            LERF_SCALE,
            top,
        )?;
        Ok(ranked
            .into_iter()
            .enumerate()
            .map(|(i, r)| {
                let object = embedded.iter().find(|o| o.id == r.id);
                FoundObject {
                    rank: i + 1,
                    id: r.id,
                    relevancy: r.relevancy,
                    cosine: r.cosine,
                    colour: object.map_or([0; 3], |o| o.colour),
                    views: object.map_or_else(Vec::new, |o| o.views.iter().map(|v| v.stem.clone()).collect()),
                    name: i32::try_from(r.id).ok().and_then(|id| self.names.get(&id).cloned()),
                }
            })
            .collect())
    }

    /// The one object most relevant to `query` (what `extract` / `remove` take for a query).
    pub fn best(&self, query: &str) -> crate::Result<FoundObject> {
        self.find(query, 1)?
            .into_iter()
            .next()
            .with_context(|| format!("no object has an embedding in {}", self.index.checkpoint.display()))
    }
}

/// The object `query` matches best among the embeddings `run --clip` wrote beside `ply` (a run's
/// `gaussians.ply`: its folder is the run's OUT).
pub fn best_match_beside(ply: &Path, query: &str) -> crate::Result<FoundObject> {
    ObjectSearch::open_beside(ply)
        .with_context(|| {
            format!("a query needs the object embeddings of the run that wrote {}", ply.display())
        })?
        .best(query)
}

/// L2-normalised text embeddings, `[texts, dim]` row-major; an empty text or one longer than the
/// tower's context is an error ([`ClipTokenizer::tokenize_query`]), for every caller alike.
fn texts(clip: &Clip, tokenizer: &ClipTokenizer, texts: &[&str]) -> crate::Result<Vec<f32>> {
    Ok(clip.embed_queries_flat(tokenizer, texts)?)
}

/// The ranked objects as `find --json` prints them: a JSON array, best first, each object
/// `{"rank", "id", "relevancy", "cosine", "colour": [r, g, b], "views": [stems]}` and `"name"` for an
/// object `splatseg apply` named (the fields of [`FoundObject`], in that order), one object per line.
pub fn found_json(found: &[FoundObject]) -> crate::Result<String> {
    let rows = found
        .iter()
        .map(serde_json::to_string)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| ModelCuesError::Invalid(format!("cannot serialise the ranking: {e}")))?;
    Ok(match rows.is_empty() {
        true => "[]\n".to_string(),
        false => format!("[\n  {}\n]\n", rows.join(",\n  ")),
    })
}

/// The ranked objects as a table: rank, id, relevancy, cosine, colour, views, and the name
/// `splatseg apply` gave (quoted, after the views) when any object has one.
pub fn found_table(query: &str, found: &[FoundObject]) -> String {
    let named = found.iter().any(|f| f.name.is_some());
    let mut text = format!("{query:?}: {} objects ranked by relevancy\n", found.len());
    text.push_str("rank     id  relevancy   cosine  colour   views");
    text.push_str(if named { "  name\n" } else { "\n" });
    for f in found {
        let [r, g, b] = f.colour;
        let name = match (&f.name, named) {
            (Some(name), _) => format!("  {name:?}"),
            (None, true) => "  -".to_string(),
            (None, false) => String::new(),
        };
        text.push_str(&format!(
            "{:>4} {:>6}  {:>9.4}  {:>7.4}  #{r:02x}{g:02x}{b:02x}  {}{name}\n",
            f.rank,
            f.id,
            f.relevancy,
            f.cosine,
            f.views.join(" ")
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn footprints_and_scores_see_the_frame() {
        // id 1: a 2×2 block inside a 6×4 map; id 2: the right column, cut by the frame on three sides
        let mut labels = Plane::filled(6, 4, 0u32);
        for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
            *labels.get_mut(x, y) = 1;
        }
        for y in 0..4 {
            *labels.get_mut(5, y) = 2;
        }
        let f = footprints(&labels);
        assert_eq!(f[&1], Footprint { pixels: 4, x0: 1, y0: 1, x1: 2, y1: 2 });
        assert_eq!(f[&1].score((6, 4)), 4.0);
        // box 1×4: perimeter 10; right side (4), top (1) and bottom (1) on the border → 4 · (1 − 6/10)
        assert!((f[&2].score((6, 4)) - 1.6).abs() < 1e-12);
    }

    #[test]
    fn crops_grey_everything_but_the_grown_mask() {
        // a 40×40 image of colour (200, 10, 10) with a 4×4 object at (18..22, 18..22)
        let image = RgbImage { width: 40, height: 40, data: [200u8, 10, 10].repeat(1600) };
        let mut labels = Plane::filled(40, 40, 0u32);
        for y in 18..22 {
            for x in 18..22 {
                *labels.get_mut(x, y) = 7;
            }
        }
        let f = footprints(&labels)[&7];
        // side 4, margin 8 → a 20×20 crop centred on the object, resized 20 → 20 (no change)
        let out = crop(&image, &labels, 7, &f, 20);
        let red = |k: usize| out[k] * CLIP_STD[0] + CLIP_MEAN[0];
        let grey = GREY as f32 / 255.0;
        assert!((red(10 * 20 + 10) - 200.0 / 255.0).abs() < 1e-3, "the object's centre keeps its colour");
        assert!((red(0) - grey).abs() < 1e-3, "the corner is grey");
        // the mask spans crop columns 8..12; grown by 2 → 6..14; column 5 is grey, 6 is not
        assert!((red(10 * 20 + 6) - 200.0 / 255.0).abs() < 1e-3);
        assert!((red(10 * 20 + 5) - grey).abs() < 1e-3);
    }

    #[test]
    fn crops_past_the_frame_are_grey_there() {
        let image = RgbImage { width: 10, height: 10, data: vec![255u8; 300] };
        let labels = Plane::filled(10, 10, 3u32);
        let f = footprints(&labels)[&3];
        // side 10, margin 8 → 26×26 starting at (−8, −8)
        let out = crop(&image, &labels, 3, &f, 26);
        let red = |k: usize| out[k] * CLIP_STD[0] + CLIP_MEAN[0];
        assert!((red(0) - GREY as f32 / 255.0).abs() < 1e-3);
        assert!((red(13 * 26 + 13) - 1.0).abs() < 1e-3);
    }
}

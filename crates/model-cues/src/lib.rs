//! The models stage: runs the foundation models on every view of a scene and caches their
//! outputs, for `splatseg cues` and for `splatseg run` given checkpoints. Per view: SAM automatic
//! masks (`OUT/sam/<stem>.json`), DINOv2 patch features (`OUT/features/<stem>.npy`,
//! `[h/14, w/14, C]`, L2-normalised), Depth Anything V2 relative inverse depth
//! (`OUT/depth/<stem>.npy`, `[H, W]`) and the LoG edge map (`OUT/log/<stem>.npy`).
//!
//! Over a folder the work streams: the next view's image is decoded (and resized) on another thread
//! while the models run, and a progress bar with an ETA is drawn on a terminal, or written as a log
//! line at least every 30 s when stderr is piped. Each output is written atomically and then recorded
//! by its key (`OUT/cache/<cue>/<stem>.key`: model, settings, image size and content, see
//! [`cached_output`]): a rerun, after a kill too, only computes what is missing or changed. Shards ([`Shard`]) may run at once on the same `OUT`. Kept apart
//! from `splatseg-pipeline` so that the pipeline does not depend on candle. [`args`]: the arguments of
//! `splatseg cues` and `splatseg run` (clap's `Args` with the `cli` feature).

pub mod apply_edits;
pub mod args;
pub mod cached_output;
pub mod clip_objects;
mod error;
pub mod object_index;
pub mod object_names;

pub use args::{CuesArgs, FindArgs, RunArgs};
use cached_output::{cue_key, is_complete, write_then_record, ImageIdentity};
pub use error::{Context, ModelCuesError, Result};
use indicatif::{ProgressBar, ProgressStyle};
use splatseg_models::depth_anything::DepthAnything;
use splatseg_models::dinov2::{l2_normalise, Dinov2};
use splatseg_models::sam::{generate_masks, AmgConfig, Sam};
use splatseg_models::ModelsError;
use splatseg_pipeline::Shard;
use splatseg_scene::images::load_image_rgb;
use splatseg_scene::{load_scene, LoadOptions, Plane, View};
use std::path::{Path, PathBuf};

/// What to compute: the scene, the models (a checkpoint file, a Hugging Face snapshot folder,
/// or a model id found in the local Hugging Face cache; nothing is downloaded) and their settings.
#[derive(Clone, Debug)]
pub struct CuesRequest {
    /// Scene folder.
    pub scene: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// DINOv2 checkpoint.
    pub dinov2: Option<PathBuf>,
    /// Depth Anything V2 checkpoint.
    pub depth_model: Option<PathBuf>,
    /// Segment Anything checkpoint.
    pub sam: Option<PathBuf>,
    /// Long side (px) of the image DINOv2 sees, rounded to multiples of 14.
    pub dinov2_size: usize,
    /// Short side (px) of the image Depth Anything sees, rounded to multiples of 14.
    pub depth_size: usize,
    /// SAM prompt grid points per side.
    pub points_per_side: usize,
    /// SAM crop layers (0 = whole image only).
    pub crop_layers: usize,
    /// SAM: holes and islands smaller than this many pixels are removed (0 = off).
    pub min_region_area: usize,
    /// Compute the LoG edge maps.
    pub log: bool,
    /// Image down-scaling factor (as 3DGS `--resolution`).
    pub resolution: u32,
    /// Blender split to read.
    pub split: String,
    /// Only the first N views.
    pub max_views: Option<usize>,
    /// Only the views `v` with `v mod N = K` (after `max_views`).
    pub shard: Option<Shard>,
    /// Draw a progress bar on stderr.
    pub show_progress: bool,
    /// When stderr is not a terminal: a progress line at least this often
    /// ([`splatseg_pipeline::progress_log::LOG_EVERY`] by default).
    pub log_every: std::time::Duration,
}

impl CuesRequest {
    /// The defaults for `scene` → `out`, with no model: the references' input sizes (518 px: 37
    /// patches of 14), SAM's automatic mask generator settings (32 points per side, no crops, no
    /// clean-up), LoG edges, the train split, every view.
    pub fn defaults_for(scene: PathBuf, out: PathBuf) -> CuesRequest {
        CuesRequest {
            scene,
            out,
            dinov2: None,
            depth_model: None,
            sam: None,
            dinov2_size: 518,
            depth_size: 518,
            points_per_side: 32,
            crop_layers: 0,
            min_region_area: 0,
            log: true,
            resolution: 1,
            split: "train".to_string(),
            max_views: None,
            shard: None,
            show_progress: true,
            log_every: splatseg_pipeline::progress_log::LOG_EVERY,
        }
    }
}

/// What [`compute_cues`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CuesSummary {
    /// Views processed.
    pub views: usize,
    /// Cues per view.
    pub cues: usize,
    /// Outputs computed (the rest came from the cache).
    pub computed: usize,
}

/// One model run per view, with its cache key.
trait Cue {
    /// Folder name under OUT and file extension.
    fn folder(&self) -> (&'static str, &'static str);
    /// Model and settings, part of the cache key.
    fn identity(&self) -> String;
    /// Computes and writes the output for one image.
    fn write(&self, rgb: &[u8], size: (usize, usize), path: &Path) -> crate::Result<()>;
}

struct FeatureCue {
    model: Dinov2,
    id: String,
    long_side: usize,
}

impl Cue for FeatureCue {
    fn folder(&self) -> (&'static str, &'static str) {
        ("features", "npy")
    }
    fn identity(&self) -> String {
        format!("dinov2 {} size {}", self.id, self.long_side)
    }
    fn write(&self, rgb: &[u8], size: (usize, usize), path: &Path) -> crate::Result<()> {
        let (features, _) = self.model.image_features(rgb, size, self.long_side)?;
        let features = l2_normalise(&features)?;
        let shape = features.dims().to_vec();
        let data = features.flatten_all().and_then(|f| f.to_vec1::<f32>()).map_err(ModelsError::Candle)?;
        splatseg_scene::npy::write_npy_f32(path, &shape, &data)?;
        Ok(())
    }
}

struct DepthCue {
    model: DepthAnything,
    id: String,
    short_side: usize,
}

impl Cue for DepthCue {
    fn folder(&self) -> (&'static str, &'static str) {
        ("depth", "npy")
    }
    fn identity(&self) -> String {
        format!("depth-anything-v2 {} size {}", self.id, self.short_side)
    }
    fn write(&self, rgb: &[u8], (h, w): (usize, usize), path: &Path) -> crate::Result<()> {
        let unit: Vec<f32> = rgb.iter().map(|&v| v as f32 / 255.0).collect();
        let depth = self.model.predict(&unit, h, w, self.short_side)?;
        splatseg_scene::npy::write_npy_f32(path, &[h, w], &depth)?;
        Ok(())
    }
}

struct SamCue {
    model: Sam,
    id: String,
    config: AmgConfig,
}

impl Cue for SamCue {
    fn folder(&self) -> (&'static str, &'static str) {
        ("sam", "json")
    }
    fn identity(&self) -> String {
        format!("sam {} {}", self.id, serde_json::to_string(&self.config).unwrap_or_default())
    }
    fn write(&self, rgb: &[u8], size: (usize, usize), path: &Path) -> crate::Result<()> {
        let masks = generate_masks(&self.model, rgb, size, &self.config, &|_, _| {})?;
        splatseg_scene::sam::write_sam_json(path, &masks)?;
        Ok(())
    }
}

struct LogCue;

impl Cue for LogCue {
    fn folder(&self) -> (&'static str, &'static str) {
        ("log", "npy")
    }
    fn identity(&self) -> String {
        format!("log sigma {}", splatseg_cues::edges::LOG_SIGMA_PX)
    }
    fn write(&self, rgb: &[u8], (h, w): (usize, usize), path: &Path) -> crate::Result<()> {
        let pixels =
            rgb.chunks_exact(3).map(|p| [p[0] as f32 / 255.0, p[1] as f32 / 255.0, p[2] as f32 / 255.0]);
        let plane = Plane::from_vec(w, h, pixels.collect()).context("image size")?;
        let edges = splatseg_cues::log_edges(
            &splatseg_cues::grey_from_rgb(&plane),
            splatseg_cues::edges::LOG_SIGMA_PX,
        );
        splatseg_scene::npy::write_npy_f32(path, &[h, w], &edges.data)?;
        Ok(())
    }
}

/// Identity of a checkpoint: resolved path, size and modification time (hashing gigabytes per run
/// would cost more than it saves).
fn checkpoint_id(path: &Path) -> String {
    let meta = std::fs::metadata(path).ok();
    let size = meta.as_ref().map(|m| m.len()).unwrap_or(0);
    let modified = meta
        .and_then(|m| m.modified().ok())
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| d.as_secs())
        .unwrap_or(0);
    format!("{} ({size} bytes, mtime {modified})", path.display())
}

/// Runs the chosen models on every view of `args.scene` (or of its shard), into `args.out`.
pub fn compute_cues(args: &CuesRequest) -> crate::Result<CuesSummary> {
    let options =
        LoadOptions { resolution: args.resolution, split: args.split.clone(), ..LoadOptions::default() };
    let scene = load_scene(&args.scene, &options)?;
    let _lock = match args.shard {
        Some(_) => splatseg_pipeline::lock::lock_output_shared(&args.out, "cues")?,
        None => splatseg_pipeline::lock::lock_output(&args.out, "cues")?,
    };
    let shard = args.shard.unwrap_or(Shard::ALL);
    let views: Vec<&View> = scene
        .views
        .iter()
        .take(args.max_views.unwrap_or(usize::MAX))
        .enumerate()
        .filter(|(v, _)| shard.contains(*v))
        .map(|(_, view)| view)
        .collect();
    let mut cues: Vec<Box<dyn Cue>> = Vec::new();
    if let Some(path) = &args.sam {
        let model = Sam::load(path)?;
        let config = AmgConfig {
            points_per_side: args.points_per_side,
            crop_n_layers: args.crop_layers,
            min_mask_region_area: args.min_region_area,
            ..AmgConfig::default()
        };
        cues.push(Box::new(SamCue { model, id: checkpoint_id(path), config }));
    }
    if let Some(path) = &args.dinov2 {
        cues.push(Box::new(FeatureCue {
            model: Dinov2::load(path)?,
            id: checkpoint_id(path),
            long_side: args.dinov2_size,
        }));
    }
    if let Some(path) = &args.depth_model {
        let model = DepthAnything::load(path)?;
        cues.push(Box::new(DepthCue { model, id: checkpoint_id(path), short_side: args.depth_size }));
    }
    if args.log {
        cues.push(Box::new(LogCue));
    }
    let style = ProgressStyle::with_template(
        "{prefix:>9} [{bar:30}] {pos}/{len} views {elapsed_precise} (eta {eta}) {msg}",
    )
    .map(|s| s.progress_chars("=> "))
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    for cue in &cues {
        let folder = cue.folder().0;
        for dir in [args.out.join(folder), args.out.join("cache").join(folder)] {
            std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        }
    }
    let bar = ProgressBar::new(views.len() as u64).with_style(style).with_prefix("cues");
    if !args.show_progress {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    } else {
        splatseg_pipeline::progress_log::log_when_piped_every(&bar, args.log_every);
    }
    let mut computed = 0;
    std::thread::scope(|scope| -> crate::Result<()> {
        // the next image is decoded (and resized) while the models run on this one
        let (sender, receiver) = std::sync::mpsc::sync_channel(1);
        let (scene, options, views) = (&scene, &options, &views);
        scope.spawn(move || {
            for view in views.iter() {
                if sender.send(load_image_rgb(scene, view, options)).is_err() {
                    break;
                }
            }
        });
        for view in views.iter() {
            let image = receiver.recv().ok().context("the image loader stopped")??;
            let size = (image.height, image.width);
            let identity = ImageIdentity::of(&image.data, size);
            let computed_before = computed;
            for cue in &cues {
                let (folder, ext) = cue.folder();
                bar.set_message(format!("{folder} {}", view.name));
                let key = cue_key(&cue.identity(), identity);
                let out = args.out.join(folder).join(format!("{}.{ext}", view.stem));
                let key_path = args.out.join("cache").join(folder).join(format!("{}.key", view.stem));
                if !is_complete(&out, &key_path, &key) {
                    write_then_record(&out, &key_path, &key, |out| cue.write(&image.data, size, out))
                        .with_context(|| format!("{folder} for view {}", view.name))?;
                    computed += 1;
                }
            }
            bar.inc(1);
            if computed == computed_before {
                // a view from the cache (a resumed run) says nothing of how long the others take
                bar.reset_eta();
            }
        }
        Ok(())
    })?;
    bar.finish_with_message("done");
    Ok(CuesSummary { views: views.len(), cues: cues.len(), computed })
}

/// Cue folders computed by [`models_for_run`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ComputedCues {
    /// `OUT/cues/sam`, when SAM was given.
    pub masks: Option<PathBuf>,
    /// `OUT/cues/features`, when DINOv2 was given.
    pub features: Option<PathBuf>,
    /// `OUT/cues/depth`, when Depth Anything was given.
    pub depth: Option<PathBuf>,
}

/// What `splatseg run` does with model checkpoints: [`compute_cues`] into `OUT/cues` for the
/// models given (no LoG maps), and the folders it wrote; nothing when no model is given.
pub fn models_for_run(
    scene: &Path,
    out: &Path,
    sam: Option<&Path>,
    dinov2: Option<&Path>,
    depth_model: Option<&Path>,
    show_progress: bool,
) -> crate::Result<ComputedCues> {
    if sam.is_none() && dinov2.is_none() && depth_model.is_none() {
        return Ok(ComputedCues::default());
    }
    let out = out.join("cues");
    compute_cues(&CuesRequest {
        dinov2: dinov2.map(Path::to_path_buf),
        depth_model: depth_model.map(Path::to_path_buf),
        sam: sam.map(Path::to_path_buf),
        log: false,
        show_progress,
        ..CuesRequest::defaults_for(scene.to_path_buf(), out.clone())
    })
    .context("computing cues with the given models")?;
    let folder = |given: bool, name: &str| given.then(|| out.join(name));
    Ok(ComputedCues {
        masks: folder(sam.is_some(), "sam"),
        features: folder(dinov2.is_some(), "features"),
        depth: folder(depth_model.is_some(), "depth"),
    })
}

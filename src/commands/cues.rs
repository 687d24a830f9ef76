//! `splatseg cues`: run the foundation models on every view of a scene and cache their outputs.

use anyhow::Context;
use clap::Args as ClapArgs;
use indicatif::{ProgressBar, ProgressStyle};
use splatseg_models::depth_anything::DepthAnything;
use splatseg_models::dinov2::{l2_normalise, Dinov2};
use splatseg_models::sam::{generate_masks, AmgConfig, Sam};
use splatseg_scene::images::load_image_rgb;
use splatseg_scene::{load_scene, LoadOptions, Plane, View};
use std::path::{Path, PathBuf};

/// Compute per-view cues with in-process models: SAM automatic masks (`OUT/sam/<stem>.json`),
/// DINOv2 patch features (`OUT/features/<stem>.npy`, `[h/14, w/14, C]`, L2-normalised),
/// Depth Anything V2 relative inverse depth (`OUT/depth/<stem>.npy`, `[H, W]`) and the LoG edge map
/// (`OUT/log/<stem>.npy`). Feed them to `splatseg run --masks OUT/sam --features OUT/features
/// --depth OUT/depth`.
///
/// Models are given as a checkpoint file, a Hugging Face snapshot folder, or a model id found in the
/// local Hugging Face cache (`facebook/dinov2-small`); nothing is downloaded. Outputs are cached by
/// model, settings and image content: a rerun only computes what changed.
#[derive(Debug, ClapArgs)]
pub struct Args {
    /// Scene folder (COLMAP `sparse/0` + `images/`, or transforms.json).
    pub scene: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// DINOv2 checkpoint (`.safetensors`/`.pth`, HF folder or model id).
    #[arg(long)]
    pub dinov2: Option<PathBuf>,
    /// Depth Anything V2 checkpoint.
    #[arg(long = "depth-model")]
    pub depth_model: Option<PathBuf>,
    /// Segment Anything checkpoint (`sam_vit_{b,l,h}_*.pth`).
    #[arg(long)]
    pub sam: Option<PathBuf>,
    /// Skip the LoG edge maps (not an option: `run` computes its own).
    #[arg(skip)]
    pub no_log: bool,
    /// Image down-scaling factor (as 3DGS `--resolution`).
    #[arg(long, default_value_t = 1)]
    pub resolution: u32,
    /// Shard `K/N` (0 ≤ K < N): only the views `v` with `v mod N = K`. Shards
    /// may run at once on the same --out (a Slurm job array, a Kubernetes indexed Job); together
    /// they write exactly what one unsharded run writes.
    #[arg(long)]
    pub shard: Option<splatseg_pipeline::Shard>,
}

/// Side (px) of the image DINOv2 (long side) and Depth Anything (short side) see: both
/// reference implementations' 518 (37 patches of 14).
const MODEL_INPUT_PX: usize = 518;

impl Args {
    /// The command-line defaults for `scene` → `out`, with no model (for callers such as `run`).
    pub fn defaults_for(scene: PathBuf, out: PathBuf) -> Args {
        Args {
            scene,
            out,
            dinov2: None,
            depth_model: None,
            sam: None,
            no_log: false,
            resolution: 1,
            shard: None,
        }
    }
}

/// One model run per view, with its cache key.
trait Cue {
    /// Folder name under OUT and file extension.
    fn folder(&self) -> (&'static str, &'static str);
    /// Model and settings, part of the cache key.
    fn identity(&self) -> String;
    /// Computes and writes the output for one image.
    fn write(&self, rgb: &[u8], size: (usize, usize), path: &Path) -> anyhow::Result<()>;
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
    fn write(&self, rgb: &[u8], size: (usize, usize), path: &Path) -> anyhow::Result<()> {
        let (features, _) = self.model.image_features(rgb, size, self.long_side)?;
        let features = l2_normalise(&features)?;
        let shape = features.dims().to_vec();
        let data = features.flatten_all()?.to_vec1::<f32>()?;
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
    fn write(&self, rgb: &[u8], (h, w): (usize, usize), path: &Path) -> anyhow::Result<()> {
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
    fn write(&self, rgb: &[u8], size: (usize, usize), path: &Path) -> anyhow::Result<()> {
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
    fn write(&self, rgb: &[u8], (h, w): (usize, usize), path: &Path) -> anyhow::Result<()> {
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

/// FNV-1a, 64 bit: a stable content hash for cache keys.
fn fnv1a(bytes: &[u8], mut hash: u64) -> u64 {
    for &b in bytes {
        hash ^= b as u64;
        hash = hash.wrapping_mul(0x100_0000_01b3);
    }
    hash
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

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

/// Runs the chosen models on every view.
pub fn run(args: Args) -> anyhow::Result<()> {
    let options = LoadOptions { resolution: args.resolution, ..LoadOptions::default() }; // Blender: the train split, as `run`
    let scene = load_scene(&args.scene, &options)?;
    let _lock = match args.shard {
        Some(_) => splatseg_pipeline::lock::lock_output_shared(&args.out, "cues")?,
        None => splatseg_pipeline::lock::lock_output(&args.out, "cues")?,
    };
    let shard = args.shard.unwrap_or(splatseg_pipeline::Shard::ALL);
    let views: Vec<&View> =
        scene.views.iter().enumerate().filter(|(v, _)| shard.contains(*v)).map(|(_, view)| view).collect();
    let mut cues: Vec<Box<dyn Cue>> = Vec::new();
    if let Some(path) = &args.sam {
        let model = Sam::load(path)?;
        let config = AmgConfig::default(); // SAM's automatic mask generator defaults, as `run`
        cues.push(Box::new(SamCue { model, id: checkpoint_id(path), config }));
    }
    if let Some(path) = &args.dinov2 {
        cues.push(Box::new(FeatureCue {
            model: Dinov2::load(path)?,
            id: checkpoint_id(path),
            long_side: MODEL_INPUT_PX,
        }));
    }
    if let Some(path) = &args.depth_model {
        let model = DepthAnything::load(path)?;
        cues.push(Box::new(DepthCue { model, id: checkpoint_id(path), short_side: MODEL_INPUT_PX }));
    }
    if !args.no_log {
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
    if super::logging::quiet() {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let mut computed = 0;
    std::thread::scope(|scope| -> anyhow::Result<()> {
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
            let image = receiver.recv().context("the image loader stopped")??;
            let size = (image.height() as usize, image.width() as usize);
            for cue in &cues {
                let (folder, ext) = cue.folder();
                bar.set_message(format!("{folder} {}", view.name));
                let key =
                    format!("{:016x}", fnv1a(image.as_raw(), fnv1a(cue.identity().as_bytes(), FNV_OFFSET)));
                let out = args.out.join(folder).join(format!("{}.{ext}", view.stem));
                let key_path = args.out.join("cache").join(folder).join(format!("{}.key", view.stem));
                let cached = out.is_file()
                    && std::fs::read_to_string(&key_path).map(|k| k.trim() == key).unwrap_or(false);
                if !cached {
                    cue.write(image.as_raw(), size, &out)
                        .with_context(|| format!("{folder} for view {}", view.name))?;
                    splatseg_scene::atomic::write_bytes_atomic(&key_path, key.as_bytes())?;
                    computed += 1;
                }
            }
            bar.inc(1);
        }
        Ok(())
    })?;
    bar.finish_with_message("done");
    println!(
        "{} views × {} cues: {computed} computed, {} cached, in {}",
        views.len(),
        cues.len(),
        views.len() * cues.len() - computed,
        args.out.display()
    );
    Ok(())
}

//! `synth`: synthetic multi-object scenes with ground truth, in the formats users bring.
//!
//! A room corner (floor, two walls) with 7–10 textured boxes, spheres and cylinders, seen by
//! pinhole cameras on an arc and rendered by CPU ray casting. The scene always contains the
//! paper's hard cases: the white-on-white pair (a white box in front of a white cylinder ~1.5 m
//! further back, touching in the image), two different boxes touching at the same depth,
//! occlusion, and an object cut by the image frame. [`generate`] builds everything in memory;
//! [`write`] writes it as a capture folder:
//!
//! ```text
//! DIR/images/<stem>.png              8-bit RGB
//! DIR/sparse/0/{cameras,images,points3D}.txt   COLMAP text model (PINHOLE, world_from_cam inverted)
//! DIR/gaussians.ply                  INRIA 3DGS PLY, SH degree 0, Gaussians on the visible surfaces
//! DIR/gt/instance/<stem>.png         16-bit instance ids, equal across views (0 = no surface)
//! DIR/gt/depth/<stem>.npy            float32 [H, W] metric z (0 = no surface)
//! DIR/gt/gaussian_ids.npy            float32 [N] instance id of each Gaussian (PLY order)
//! DIR/gt/objects.json                config, objects (id, name, kind, tags, shape, texture, failure
//!                                    classes — not for the default family), hard cases
//! DIR/sam/<stem>.json                simulated SAM automatic masks (COCO RLE JSON)
//! DIR/features/<stem>.npy            float32 [ceil(H/14), ceil(W/14), C] DINOv2-like features
//! DIR/depth/<stem>.npy               float32 [H, W] relative inverse depth in [0, 1] (1 = near)
//! ```
//!
//! Stems are `view_000`, `view_001`, …; instance ids: 1 floor, 2 left wall, 3 back wall, 4.. the
//! objects (see [`layout`]). Everything is a pure function of [`SynthConfig`] (seeded RNGs,
//! counter-based per-pixel noise), so the same seed gives byte-identical files.
//!
//! The stress suite's families ([`family`]) draw random rooms ([`rooms`]) with multi-tone walls
//! and floors, thin posts, border-cut foreground objects, stacked and touching objects and
//! heavier SAM noise; every instance gets its failure classes ([`classes`]).

pub mod args;
pub mod cameras;
pub mod classes;
pub mod components;
pub mod config;
pub mod error;
pub mod family;
pub mod features;
pub mod gaussians;
pub mod geometry;
pub mod hard_cases;
pub mod layout;
pub mod mono_depth;
pub mod noise;
pub mod render;
pub mod rooms;
pub mod sam_sim;
pub mod texture;
mod write;

pub use args::{parse_family, parse_size, SynthArgs};
pub use classes::FailureClass;
pub use config::{CueConfig, FloorPattern, LayoutKind, RoomConfig, SamSimConfig, SynthConfig, WallPaint};
pub use error::SynthError;
pub use family::Family;
pub use features::PatchFeatures;
pub use hard_cases::HardCases;
pub use layout::{HardCase, ObjectKind, SceneObject};
pub use write::{write, SynthSummary};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use splatseg_scene::load::SceneFormat;
use splatseg_scene::sam::SamMask;
use splatseg_scene::{Gaussians, Plane, Scene, SparsePoint, View};
use std::path::PathBuf;

/// Everything [`generate`] produces for one view.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthView {
    /// Image stem (`view_000`, …): the file name of every per-view output.
    pub stem: String,
    /// `[H, W]` 8-bit RGB image.
    pub image: Plane<[u8; 3]>,
    /// `[H, W]` ground-truth instance ids (0 = no surface).
    pub gt_instance: Plane<u32>,
    /// `[H, W]` ground-truth texture parts (what the SAM simulation splits along).
    pub gt_part: Plane<u8>,
    /// `[H, W]` ground-truth metric z depth (0 = no surface).
    pub gt_depth_z: Plane<f32>,
    /// Simulated SAM automatic masks, in random order.
    pub sam_masks: Vec<SamMask>,
    /// Simulated DINOv2-like patch features `[ceil(H/14), ceil(W/14), C]`.
    pub features: PatchFeatures,
    /// `[H, W]` simulated monocular relative inverse depth in [0, 1] (1 = near).
    pub relative_depth: Plane<f32>,
}

/// What `gt/objects.json` says about one instance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectInfo {
    /// Instance id (label-map value and Gaussian id).
    pub id: u32,
    /// Stable name.
    pub name: String,
    /// Kind.
    pub kind: ObjectKind,
    /// Hard cases it takes part in.
    pub tags: Vec<HardCase>,
    /// Geometry (world frame, z up, metres).
    pub shape: geometry::Shape,
    /// Appearance.
    pub texture: texture::Texture,
    /// Number of its Gaussians in `gaussians.ply`.
    pub gaussians: usize,
    /// Views (indices) where it has visible pixels.
    pub visible_in_views: Vec<usize>,
    /// Its failure classes (see [`classes`]). Left out of the default family's
    /// `objects.json`, which stays as it was before the classes existed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub classes: Vec<FailureClass>,
}

/// A generated scene, in memory.
#[derive(Clone, Debug)]
pub struct SynthScene {
    /// The config it was generated from.
    pub config: SynthConfig,
    /// The instances (floor, walls, objects) with their geometry; index = id − 1.
    pub objects: Vec<SceneObject>,
    /// Cameras, posed views (`image_path` relative to the output folder, e.g.
    /// `images/view_000.png`; `root` empty until written) and sparse points.
    pub scene: Scene,
    /// Per-view images, ground truth and simulated inputs, in view order.
    pub views: Vec<SynthView>,
    /// Gaussians on the visible surfaces.
    pub gaussians: Gaussians,
    /// `[N]` ground-truth instance id of each Gaussian.
    pub gaussian_ids: Vec<u32>,
    /// Where the hard cases appear.
    pub hard_cases: HardCases,
}

impl SynthScene {
    /// The `gt/objects.json` records.
    pub fn object_infos(&self) -> Vec<ObjectInfo> {
        let mut classes = if self.config.family.is_default() {
            vec![Vec::new(); self.objects.len()]
        } else {
            self.failure_classes()
        };
        self.objects
            .iter()
            .zip(classes.iter_mut())
            .map(|(o, classes)| ObjectInfo {
                id: o.id,
                name: o.name.clone(),
                kind: o.kind,
                tags: o.tags.clone(),
                shape: o.shape.clone(),
                texture: o.texture.clone(),
                gaussians: self.gaussian_ids.iter().filter(|&&g| g == o.id).count(),
                visible_in_views: (0..self.views.len())
                    .filter(|&v| self.views[v].gt_instance.data.contains(&o.id))
                    .collect(),
                classes: std::mem::take(classes),
            })
            .collect()
    }

    /// The failure classes of every instance (index = id − 1), for every family.
    pub fn failure_classes(&self) -> Vec<Vec<FailureClass>> {
        let mut seen = vec![0usize; self.objects.len()];
        for v in &self.views {
            let mut present = vec![false; self.objects.len() + 1];
            for &id in &v.gt_instance.data {
                if let Some(p) = present.get_mut(id as usize) {
                    *p = true;
                }
            }
            for (k, s) in seen.iter_mut().enumerate() {
                *s += usize::from(present[k + 1]);
            }
        }
        classes::failure_classes(&self.objects, &self.hard_cases, &seen)
    }

    /// Ids of the white-on-white pair.
    pub fn white_pair(&self) -> [u32; 2] {
        self.hard_cases.white_on_white.ids
    }
}

fn validate(config: &SynthConfig) -> Result<(), SynthError> {
    let bad = |m: &str| Err(SynthError::Config(m.to_string()));
    if config.views == 0 || config.views > 10_000 {
        return bad("views must be between 1 and 10000");
    }
    if !(16..=8192).contains(&config.width) || !(16..=8192).contains(&config.height) {
        return bad("image width and height must be between 16 and 8192 pixels");
    }
    if !(config.fov_x_deg > 1.0 && config.fov_x_deg < 170.0) {
        return bad("fov_x_deg must be between 1 and 170");
    }
    if !(config.arc_deg >= 0.0 && config.arc_deg <= 90.0) {
        return bad("arc_deg must be between 0 and 90 (the room has two walls)");
    }
    if !(config.gaussian_spacing_px >= 0.5 && config.gaussian_spacing_px.is_finite()) {
        return bad("gaussian_spacing_px must be at least 0.5");
    }
    if config.feature_dim == 0 || config.feature_dim > 4096 || config.feature_patch_px == 0 {
        return bad("feature_dim must be 1..=4096 and feature_patch_px at least 1");
    }
    let room = &config.room;
    if room.objects[0] > room.objects[1] || room.objects[1] > 40 {
        return bad("room.objects must be [min, max] with min <= max <= 40");
    }
    let random_only = room.thin_posts + room.foreground_objects + room.stacked + room.touching;
    if room.layout == LayoutKind::Plan && random_only > 0 {
        return bad(
            "room.thin_posts, foreground_objects, stacked and touching need room.layout = \"random\"",
        );
    }
    if random_only > 12 {
        return bad("room.thin_posts + foreground_objects + stacked + touching must be at most 12");
    }
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !positive(room.wall_scale_m) || !positive(room.floor_scale_m) || !positive(room.thin_post_px) {
        return bad("room.wall_scale_m, floor_scale_m and thin_post_px must be positive");
    }
    if !(0.0..=1.0).contains(&room.multi_tone_share) {
        return bad("room.multi_tone_share must be between 0 and 1");
    }
    let fit = &config.cues;
    let in_range = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
    let knobs_in_range = in_range(fit.gaussian_tilt_deg, 0.0, 90.0)
        && positive(fit.gaussian_thickness)
        && fit.gaussian_thickness <= 10.0
        && in_range(fit.gaussian_offset, 0.0, 10.0)
        && in_range(fit.gaussian_scale_spread, 0.0, 3.0)
        && in_range(fit.gaussian_floaters, 0.0, 1.0);
    if !knobs_in_range {
        return bad(
            "cues.gaussian_tilt_deg must be 0..=90, gaussian_thickness in (0, 10], gaussian_offset 0..=10, \
             gaussian_scale_spread 0..=3 and gaussian_floaters 0..=1",
        );
    }
    let [lo, hi] = config.sam.hole_radius_px;
    if lo < 1 || lo > hi || hi > 64 {
        return bad("sam.hole_radius_px must be [min, max] with 1 <= min <= max <= 64");
    }
    Ok(())
}

/// Generates the scene described by `config` (deterministic per config).
pub fn generate(config: &SynthConfig) -> Result<SynthScene, SynthError> {
    validate(config)?;
    let objects = match config.room.layout {
        LayoutKind::Plan => layout::build_plan_layout(config.seed, &config.room),
        LayoutKind::Random => rooms::build_random_layout(config),
    };
    let camera = cameras::camera(config);
    let poses = cameras::orbit_poses(config);
    let rendered: Vec<render::RenderedView> = poses
        .iter()
        .enumerate()
        .map(|(v, pose)| render::render_view(&objects, &camera, pose, config.seed, v))
        .collect();
    let spacing_m = config.gaussian_spacing_px * cameras::ORBIT_RADIUS / camera.fx;
    let surface = gaussians::surface_gaussians(
        &objects,
        &camera,
        &poses,
        &rendered,
        (spacing_m, &config.cues),
        config.seed,
    );
    let hard_cases = hard_cases::find_hard_cases(&objects, &rendered);
    let max_id = objects.iter().map(|o| o.id).max().unwrap_or(0);
    let white = hard_cases.white_on_white.ids;
    let embeddings = features::Embeddings::new(
        config.seed,
        config.feature_dim,
        max_id,
        &[(white[0], white[1], 0.45), (2, 3, 1.0)],
        &config.cues,
    );
    let (gh, gw) =
        features::grid_size(config.width as usize, config.height as usize, config.feature_patch_px);
    let drift = features::drift_table(&embeddings, gh, gw);
    let views: Vec<SynthView> = rendered
        .into_par_iter()
        .enumerate()
        .map(|(v, r)| {
            let sam_input = sam_sim::SamSimInput {
                instance: &r.instance,
                part: &r.part,
                white_pair: white,
                seed: config.seed,
                view: v,
            };
            let sam_masks = sam_sim::simulate_sam(&sam_input, &config.sam);
            let features = features::patch_features_with_drift(
                &r.instance,
                &r.part,
                &embeddings,
                config.feature_patch_px,
                v,
                &drift,
            );
            let relative_depth = mono_depth::relative_depth(&r.depth_z, config.seed, v, &config.cues);
            SynthView {
                stem: view_stem(v),
                image: r.rgb,
                gt_instance: r.instance,
                gt_part: r.part,
                gt_depth_z: r.depth_z,
                sam_masks,
                features,
                relative_depth,
            }
        })
        .collect();
    let scene = build_scene(camera, &poses, &views, &surface.gaussians);
    Ok(SynthScene {
        config: config.clone(),
        objects,
        scene,
        views,
        gaussians: surface.gaussians,
        gaussian_ids: surface.ids,
        hard_cases,
    })
}

/// Stem of view `v`: `view_000`, `view_001`, …
pub fn view_stem(v: usize) -> String {
    format!("view_{v:03}")
}

/// Maximum number of sparse points written to `points3D.txt` (a sample of Gaussian centres).
const MAX_SPARSE_POINTS: usize = 4000;

fn build_scene(
    camera: splatseg_scene::Camera,
    poses: &[splatseg_scene::Pose],
    views: &[SynthView],
    g: &Gaussians,
) -> Scene {
    let scene_views = views
        .iter()
        .zip(poses)
        .enumerate()
        .map(|(i, (v, pose))| View {
            name: format!("{}.png", v.stem),
            stem: v.stem.clone(),
            image_path: PathBuf::from("images").join(format!("{}.png", v.stem)),
            camera_index: 0,
            world_from_cam: *pose,
            image_id: i as u32 + 1,
            keypoints: Vec::new(),
        })
        .collect();
    let step = g.len().div_ceil(MAX_SPARSE_POINTS).max(1);
    let points = (0..g.len())
        .step_by(step)
        .enumerate()
        .map(|(k, i)| SparsePoint {
            id: k as u64 + 1,
            xyz: glam::Vec3::from_array(g.means[i]).as_dvec3(),
            rgb: g.base_colour(i).map(|c| (c * 255.0).round() as u8),
            error: 0.0,
            track: Vec::new(),
        })
        .collect();
    Scene {
        root: PathBuf::new(),
        format: SceneFormat::ColmapText,
        cameras: vec![camera],
        views: scene_views,
        points: Some(points),
        warnings: Vec::new(),
    }
}

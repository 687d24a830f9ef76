//! `scene` stage: everything splatseg reads and writes in formats people already have.
//!
//! - [`camera`]: intrinsics, lens distortion and `world_from_cam` poses (see `CONVENTIONS.md`).
//! - [`colmap`]: COLMAP sparse models, binary and text, read and write.
//! - [`transforms`]: NeRF/Blender `transforms_*.json` and instant-ngp/nerfstudio `transforms.json`.
//! - [`gaussians`] + [`ply`]: the INRIA 3DGS PLY layout, with round-tripped extra properties.
//! - [`splats`]: SPZ, `.splat`, `.ksplat` and compressed PLY beside the PLY; [`splats::read_gaussians`] reads any of them by content.
//! - [`rle`] + [`sam`]: Segment Anything automatic-mask output (COCO RLE JSON and PNG folders).
//! - [`labels`]: 8/16-bit label-map PNGs (0 = unlabelled).
//! - [`image_io`]: PNG and JPEG files to and from pixel buffers ([`image_io::RgbImage`]), resizing.
//! - [`npy`]: NumPy `.npy`/`.npz` arrays (dense features, depth).
//! - [`limits`]: the one cap on pixels per image and Gaussians per PLY.
//! - [`plane`]: the row-major 2D array type every per-pixel map uses.
//! - [`fuzzing`]: one bytes entry point per reader, for the fuzz targets and the corpus replay.
//! - [`atomic`]: write-to-temp-then-rename helpers: nothing half-written.

pub mod atomic;
pub mod camera;
pub mod colmap;
pub mod error;
pub mod fuzzing;
pub mod gaussians;
pub mod image_io;
pub mod images;
pub mod labels;
pub mod limits;
pub mod load;
pub mod npy;
pub mod paths;
pub mod plane;
pub mod ply;
pub mod rle;
pub mod sam;
pub mod splats;
pub mod transforms;

pub use camera::{Camera, CameraModel, Distortion, Pose};
pub use error::{SceneError, SceneResult};
pub use gaussians::Gaussians;
pub use load::{load_scene, LoadOptions, Scene, SparsePoint, View};
pub use plane::Plane;

//! The COLMAP model exactly as the files store it (cam_from_world quaternions, raw camera
//! parameters), and its conversion to and from [`Scene`] cameras and poses.

use crate::camera::{Camera, CameraModel, Distortion, Pose};
use crate::load::{Keypoint, SparsePoint};
use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

/// A COLMAP sparse model as stored on disk: reading then writing it reproduces the files.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColmapModel {
    /// `cameras.{bin,txt}` in file order.
    pub cameras: Vec<ColmapCamera>,
    /// `images.{bin,txt}` in file order.
    pub images: Vec<ColmapImage>,
    /// `points3D.{bin,txt}` in file order.
    pub points: Vec<SparsePoint>,
}

/// One `cameras` entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ColmapCamera {
    /// `CAMERA_ID`.
    pub id: u32,
    /// Camera model.
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// `[model.num_params()]` parameters in COLMAP's order for the model.
    pub params: Vec<f64>,
}

/// One `images` entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ColmapImage {
    /// `IMAGE_ID`.
    pub id: u32,
    /// `cam_from_world` rotation as `QW QX QY QZ`.
    pub qvec: [f64; 4],
    /// `cam_from_world` translation `TX TY TZ`.
    pub tvec: [f64; 3],
    /// `CAMERA_ID`.
    pub camera_id: u32,
    /// Image name relative to the images folder.
    pub name: String,
    /// `POINTS2D[]`.
    pub keypoints: Vec<Keypoint>,
}

impl ColmapCamera {
    /// The camera's intrinsics (`params` must have `model.num_params()` entries).
    pub fn to_camera(&self) -> Camera {
        let p = &self.params;
        let (fx, fy, cx, cy, distortion) = match self.model {
            CameraModel::SimplePinhole => (p[0], p[0], p[1], p[2], Distortion::default()),
            CameraModel::Pinhole => (p[0], p[1], p[2], p[3], Distortion::default()),
            CameraModel::SimpleRadial => {
                (p[0], p[0], p[1], p[2], Distortion { k1: p[3], ..Distortion::default() })
            }
            CameraModel::Radial => {
                (p[0], p[0], p[1], p[2], Distortion { k1: p[3], k2: p[4], ..Distortion::default() })
            }
            CameraModel::OpenCv => {
                (p[0], p[1], p[2], p[3], Distortion { k1: p[4], k2: p[5], p1: p[6], p2: p[7] })
            }
        };
        Camera {
            id: self.id,
            model: self.model,
            width: self.width,
            height: self.height,
            fx,
            fy,
            cx,
            cy,
            distortion,
        }
    }

    /// The COLMAP entry for `camera`: its own model when that model can hold the intrinsics
    /// exactly, otherwise the smallest of PINHOLE / OPENCV that can (e.g. a SIMPLE_PINHOLE
    /// camera with `fx != fy` after non-uniform down-scaling is written as PINHOLE).
    pub fn from_camera(camera: &Camera) -> ColmapCamera {
        let c = camera;
        let d = c.distortion;
        let square = c.fx == c.fy;
        let fits = match c.model {
            CameraModel::SimplePinhole => square && d.is_zero(),
            CameraModel::Pinhole => d.is_zero(),
            CameraModel::SimpleRadial => square && d.k2 == 0.0 && d.p1 == 0.0 && d.p2 == 0.0,
            CameraModel::Radial => square && d.p1 == 0.0 && d.p2 == 0.0,
            CameraModel::OpenCv => true,
        };
        let model = match (fits, d.is_zero()) {
            (true, _) => c.model,
            (false, true) => CameraModel::Pinhole,
            (false, false) => CameraModel::OpenCv,
        };
        let params = match model {
            CameraModel::SimplePinhole => vec![c.fx, c.cx, c.cy],
            CameraModel::Pinhole => vec![c.fx, c.fy, c.cx, c.cy],
            CameraModel::SimpleRadial => vec![c.fx, c.cx, c.cy, d.k1],
            CameraModel::Radial => vec![c.fx, c.cx, c.cy, d.k1, d.k2],
            CameraModel::OpenCv => vec![c.fx, c.fy, c.cx, c.cy, d.k1, d.k2, d.p1, d.p2],
        };
        ColmapCamera { id: c.id, model, width: c.width, height: c.height, params }
    }
}

impl ColmapImage {
    /// `world_from_cam`, the inverse of the stored `cam_from_world`. `None` for a zero quaternion.
    pub fn world_from_cam(&self) -> Option<Pose> {
        let [w, x, y, z] = self.qvec;
        let q = DQuat::from_xyzw(x, y, z, w);
        if q.length_squared().partial_cmp(&1e-20) != Some(std::cmp::Ordering::Greater) {
            return None;
        }
        let [tx, ty, tz] = self.tvec;
        Some(Pose::from_quat_translation(q, DVec3::new(tx, ty, tz)).inverse())
    }

    /// `(qvec, tvec)` of `cam_from_world` for a `world_from_cam` pose; the quaternion is
    /// normalised with `QW >= 0`.
    pub fn qvec_tvec_of(world_from_cam: &Pose) -> ([f64; 4], [f64; 3]) {
        let cam_from_world = world_from_cam.inverse();
        let mut q = cam_from_world.quat();
        if q.w < 0.0 {
            q = -q;
        }
        let t = cam_from_world.translation;
        ([q.w, q.x, q.y, q.z], [t.x, t.y, t.z])
    }
}

/// COLMAP's names of the camera models splatseg does not read, by model id (for messages).
pub(crate) fn unsupported_model_name(id: i32) -> Option<&'static str> {
    Some(match id {
        5 => "OPENCV_FISHEYE",
        6 => "FULL_OPENCV",
        7 => "FOV",
        8 => "SIMPLE_RADIAL_FISHEYE",
        9 => "RADIAL_FISHEYE",
        10 => "THIN_PRISM_FISHEYE",
        11 => "RAD_TAN_THIN_PRISM_FISHEYE",
        _ => return None,
    })
}

/// The sentence listing the supported models, for error messages.
pub(crate) const SUPPORTED_MODELS: &str = "supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV";

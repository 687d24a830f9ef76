//! Cameras: intrinsics, lens distortion and poses.
//!
//! Conventions (full text in `CONVENTIONS.md`): camera axes are OpenCV/COLMAP (x right, y down,
//! z forward); poses are stored as `world_from_cam` (camera-to-world); pixel `(u, v)` has its
//! top-left corner at `(0, 0)` and the centre of pixel `(i, j)` at `(i + 0.5, j + 0.5)`.

use glam::{DMat3, DQuat, DVec2, DVec3};
use serde::{Deserialize, Serialize};

/// A rigid transform `p_in_world = rotation * p_in_cam + translation` when used as `world_from_cam`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Rotation part (orthonormal, det +1).
    pub rotation: DMat3,
    /// Translation part.
    pub translation: DVec3,
}

impl Pose {
    /// The identity transform.
    pub const IDENTITY: Pose = Pose { rotation: DMat3::IDENTITY, translation: DVec3::ZERO };

    /// Builds a pose from a unit quaternion and a translation.
    pub fn from_quat_translation(q: DQuat, translation: DVec3) -> Self {
        Pose { rotation: DMat3::from_quat(q.normalize()), translation }
    }

    /// Applies the transform to a point.
    #[inline]
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// The inverse transform (`cam_from_world` from `world_from_cam`).
    pub fn inverse(&self) -> Pose {
        let rt = self.rotation.transpose();
        Pose { rotation: rt, translation: -(rt * self.translation) }
    }

    /// Camera centre in world coordinates when `self` is `world_from_cam`.
    pub fn centre(&self) -> DVec3 {
        self.translation
    }

    /// Rotation as a unit quaternion.
    pub fn quat(&self) -> DQuat {
        DQuat::from_mat3(&self.rotation).normalize()
    }

    /// 4×4 row-major matrix `[R t; 0 0 0 1]`.
    pub fn to_rows(&self) -> [[f64; 4]; 4] {
        let r = self.rotation;
        let t = self.translation;
        [
            [r.x_axis.x, r.y_axis.x, r.z_axis.x, t.x],
            [r.x_axis.y, r.y_axis.y, r.z_axis.y, t.y],
            [r.x_axis.z, r.y_axis.z, r.z_axis.z, t.z],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    /// From a 4×4 (or 3×4) row-major matrix `[R t]`. The rotation is re-orthonormalised.
    pub fn from_rows(m: &[[f64; 4]]) -> Self {
        let rotation = DMat3::from_cols(
            DVec3::new(m[0][0], m[1][0], m[2][0]),
            DVec3::new(m[0][1], m[1][1], m[2][1]),
            DVec3::new(m[0][2], m[1][2], m[2][2]),
        );
        let q = DQuat::from_mat3(&rotation).normalize();
        Pose { rotation: DMat3::from_quat(q), translation: DVec3::new(m[0][3], m[1][3], m[2][3]) }
    }
}

/// The COLMAP camera model a camera was read as, kept so a model can be written back unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CameraModel {
    /// `f, cx, cy`
    SimplePinhole,
    /// `fx, fy, cx, cy`
    Pinhole,
    /// `f, cx, cy, k`
    SimpleRadial,
    /// `f, cx, cy, k1, k2`
    Radial,
    /// `fx, fy, cx, cy, k1, k2, p1, p2`
    OpenCv,
}

impl CameraModel {
    /// COLMAP's numeric model id.
    pub fn colmap_id(self) -> i32 {
        match self {
            CameraModel::SimplePinhole => 0,
            CameraModel::Pinhole => 1,
            CameraModel::SimpleRadial => 2,
            CameraModel::Radial => 3,
            CameraModel::OpenCv => 4,
        }
    }

    /// From COLMAP's numeric id; `None` for models splatseg does not support.
    pub fn from_colmap_id(id: i32) -> Option<Self> {
        Some(match id {
            0 => CameraModel::SimplePinhole,
            1 => CameraModel::Pinhole,
            2 => CameraModel::SimpleRadial,
            3 => CameraModel::Radial,
            4 => CameraModel::OpenCv,
            _ => return None,
        })
    }

    /// COLMAP's model name (as in `cameras.txt`).
    pub fn colmap_name(self) -> &'static str {
        match self {
            CameraModel::SimplePinhole => "SIMPLE_PINHOLE",
            CameraModel::Pinhole => "PINHOLE",
            CameraModel::SimpleRadial => "SIMPLE_RADIAL",
            CameraModel::Radial => "RADIAL",
            CameraModel::OpenCv => "OPENCV",
        }
    }

    /// From COLMAP's model name.
    pub fn from_colmap_name(name: &str) -> Option<Self> {
        [
            CameraModel::SimplePinhole,
            CameraModel::Pinhole,
            CameraModel::SimpleRadial,
            CameraModel::Radial,
            CameraModel::OpenCv,
        ]
        .into_iter()
        .find(|m| m.colmap_name() == name)
    }

    /// Number of parameters COLMAP stores for this model.
    pub fn num_params(self) -> usize {
        match self {
            CameraModel::SimplePinhole => 3,
            CameraModel::Pinhole => 4,
            CameraModel::SimpleRadial => 4,
            CameraModel::Radial => 5,
            CameraModel::OpenCv => 8,
        }
    }
}

/// Lens distortion in OpenCV's radial-tangential form, applied to normalised image coordinates.
/// All-zero means a pinhole.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Distortion {
    /// Radial coefficient of r².
    pub k1: f64,
    /// Radial coefficient of r⁴.
    pub k2: f64,
    /// Tangential coefficient.
    pub p1: f64,
    /// Tangential coefficient.
    pub p2: f64,
}

impl Distortion {
    /// True when all coefficients are zero.
    pub fn is_zero(&self) -> bool {
        self.k1 == 0.0 && self.k2 == 0.0 && self.p1 == 0.0 && self.p2 == 0.0
    }

    /// Distorts normalised coordinates `(x/z, y/z)`.
    pub fn distort(&self, p: DVec2) -> DVec2 {
        if self.is_zero() {
            return p;
        }
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + self.k1 * r2 + self.k2 * r2 * r2;
        DVec2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Inverts [`Distortion::distort`] by fixed-point iteration (as COLMAP and OpenCV do).
    pub fn undistort(&self, distorted: DVec2) -> DVec2 {
        if self.is_zero() {
            return distorted;
        }
        let mut p = distorted;
        for _ in 0..50 {
            let err = self.distort(p) - distorted;
            if err.length_squared() < 1e-24 {
                break;
            }
            p -= err;
        }
        p
    }
}

/// A camera's intrinsics at the resolution its images are used at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Identifier (COLMAP `CAMERA_ID`; for transforms.json, assigned in file order).
    pub id: u32,
    /// The model the camera was read as (written back unchanged).
    pub model: CameraModel,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length in pixels, x.
    pub fx: f64,
    /// Focal length in pixels, y.
    pub fy: f64,
    /// Principal point x in pixels (pixel-corner origin, see `CONVENTIONS.md`).
    pub cx: f64,
    /// Principal point y in pixels.
    pub cy: f64,
    /// Lens distortion (zero for pinhole models).
    pub distortion: Distortion,
}

impl Camera {
    /// Why these intrinsics cannot project anything, if so: a zero width or height, a focal
    /// length that is not a positive finite number, a non-finite principal point or distortion.
    pub fn defect(&self) -> Option<String> {
        let d = self.distortion;
        if self.width == 0 || self.height == 0 {
            Some(format!("image size {}×{} has no pixels", self.width, self.height))
        } else if !(self.fx.is_finite() && self.fy.is_finite() && self.fx > 0.0 && self.fy > 0.0) {
            Some(format!("focal lengths fx {}, fy {} must be positive pixels", self.fx, self.fy))
        } else if ![self.cx, self.cy, d.k1, d.k2, d.p1, d.p2].iter().all(|v| v.is_finite()) {
            Some(format!("the principal point ({}, {}) or the distortion is not finite", self.cx, self.cy))
        } else {
            None
        }
    }

    /// A distortion-free pinhole camera.
    pub fn pinhole(id: u32, width: u32, height: u32, fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Camera {
            id,
            model: CameraModel::Pinhole,
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            distortion: Distortion::default(),
        }
    }

    /// Projects a point in camera coordinates to pixel coordinates (distortion applied).
    /// Returns `None` for points at or behind the camera plane (`z <= 1e-9`).
    pub fn project(&self, p_in_cam: DVec3) -> Option<DVec2> {
        if p_in_cam.z <= 1e-9 {
            return None;
        }
        let n = self.distortion.distort(DVec2::new(p_in_cam.x / p_in_cam.z, p_in_cam.y / p_in_cam.z));
        Some(DVec2::new(self.fx * n.x + self.cx, self.fy * n.y + self.cy))
    }

    /// The unit-depth ray direction (`z = 1`) in camera coordinates through pixel position `uv`.
    pub fn unproject(&self, uv: DVec2) -> DVec3 {
        let d = DVec2::new((uv.x - self.cx) / self.fx, (uv.y - self.cy) / self.fy);
        let n = self.distortion.undistort(d);
        DVec3::new(n.x, n.y, 1.0)
    }

    /// The same camera for images down-scaled by `factor` (3DGS `--resolution factor`):
    /// focal lengths and principal point divided by `factor`, size rounded as 3DGS does
    /// (`round(width / factor)`).
    pub fn downscaled(&self, factor: f64) -> Camera {
        let w = (self.width as f64 / factor).round().max(1.0) as u32;
        let h = (self.height as f64 / factor).round().max(1.0) as u32;
        let sx = w as f64 / self.width as f64;
        let sy = h as f64 / self.height as f64;
        Camera {
            width: w,
            height: h,
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: self.cx * sx,
            cy: self.cy * sy,
            ..self.clone()
        }
    }

    /// Horizontal field of view in radians.
    pub fn fov_x(&self) -> f64 {
        2.0 * (self.width as f64 / (2.0 * self.fx)).atan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pose_inverse_round_trips() {
        let pose = Pose::from_quat_translation(
            DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.2, 1.1),
            DVec3::new(1.0, 2.0, -3.0),
        );
        let p = DVec3::new(0.5, -0.7, 2.0);
        let back = pose.inverse().transform_point(pose.transform_point(p));
        assert!((back - p).length() < 1e-12);
    }

    #[test]
    fn distortion_undistort_inverts_distort() {
        let d = Distortion { k1: -0.1, k2: 0.02, p1: 0.001, p2: -0.002 };
        for &(x, y) in &[(0.0, 0.0), (0.3, -0.2), (-0.5, 0.4)] {
            let p = DVec2::new(x, y);
            assert!((d.undistort(d.distort(p)) - p).length() < 1e-10);
        }
    }

    #[test]
    fn project_unproject_round_trip_with_distortion() {
        let mut cam = Camera::pinhole(1, 640, 480, 500.0, 510.0, 320.0, 240.0);
        cam.distortion = Distortion { k1: 0.05, k2: -0.01, p1: 0.0, p2: 0.001 };
        let uv = cam.project(DVec3::new(0.4, -0.3, 2.0)).expect("in front");
        let ray = cam.unproject(uv);
        assert!((ray * 2.0 - DVec3::new(0.4, -0.3, 2.0)).length() < 1e-9);
        assert!(cam.project(DVec3::new(0.0, 0.0, -1.0)).is_none());
    }
}

//! [`RenderCamera`]: a pinhole camera in the single-precision form the rasteriser uses.

use crate::error::{RenderError, RenderResult};
use splatseg_scene::{Camera, Pose};

/// A distortion-free pinhole camera with a pose and depth range.
///
/// Axes are OpenCV's (x right, y down, z forward); the centre of pixel `(i, j)` is at
/// `(i + 0.5, j + 0.5)` (see `CONVENTIONS.md`).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderCamera {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal length x, px.
    pub fx: f32,
    /// Focal length y, px.
    pub fy: f32,
    /// Principal point x, px (pixel-corner origin).
    pub cx: f32,
    /// Principal point y, px.
    pub cy: f32,
    /// Camera-to-world pose.
    pub world_from_cam: Pose,
    /// Gaussians whose centre has camera z ≤ `near` are culled (gsplat: 0.01).
    pub near: f32,
    /// Gaussians whose centre has camera z ≥ `far` are culled (gsplat: 1e10).
    pub far: f32,
}

/// Default near plane (gsplat's).
pub const DEFAULT_NEAR: f32 = 0.01;
/// Default far plane (gsplat's).
pub const DEFAULT_FAR: f32 = 1e10;

impl RenderCamera {
    /// From a scene camera and its `world_from_cam` pose. Lens distortion is **ignored**: the
    /// image is rendered as if the camera were a pinhole with the same intrinsics (as 3DGS does
    /// after undistortion).
    pub fn from_scene(camera: &Camera, world_from_cam: &Pose) -> Self {
        RenderCamera {
            width: camera.width,
            height: camera.height,
            fx: camera.fx as f32,
            fy: camera.fy as f32,
            cx: camera.cx as f32,
            cy: camera.cy as f32,
            world_from_cam: *world_from_cam,
            near: DEFAULT_NEAR,
            far: DEFAULT_FAR,
        }
    }

    /// The same camera for images scaled by `1 / factor` (focal lengths and principal point
    /// scaled with the rounded size, as [`Camera::downscaled`]).
    pub fn downscaled(&self, factor: f64) -> Self {
        let w = (self.width as f64 / factor).round().max(1.0) as u32;
        let h = (self.height as f64 / factor).round().max(1.0) as u32;
        let sx = (w as f64 / self.width as f64) as f32;
        let sy = (h as f64 / self.height as f64) as f32;
        RenderCamera {
            width: w,
            height: h,
            fx: self.fx * sx,
            fy: self.fy * sy,
            cx: self.cx * sx,
            cy: self.cy * sy,
            ..self.clone()
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// `cam_from_world` as a row-major rotation `[3][3]` and translation `[3]`, in f32.
    pub fn cam_from_world_f32(&self) -> ([[f32; 3]; 3], [f32; 3]) {
        let inv = self.world_from_cam.inverse();
        let rows = inv.to_rows();
        let r = [0, 1, 2].map(|i| [0, 1, 2].map(|j| rows[i][j] as f32));
        let t = [0, 1, 2].map(|i| rows[i][3] as f32);
        (r, t)
    }

    /// Camera centre in world coordinates, f32.
    pub fn centre_f32(&self) -> [f32; 3] {
        let c = self.world_from_cam.centre();
        [c.x as f32, c.y as f32, c.z as f32]
    }

    /// Checks the camera can be rendered.
    pub fn validate(&self) -> RenderResult<()> {
        if self.width == 0 || self.height == 0 {
            return Err(RenderError::Camera(format!("image size {}×{}", self.width, self.height)));
        }
        let finite = [self.fx, self.fy, self.cx, self.cy].iter().all(|v| v.is_finite());
        if !finite || self.fx <= 0.0 || self.fy <= 0.0 {
            return Err(RenderError::Camera(format!(
                "focal lengths must be finite and positive (fx {}, fy {}, cx {}, cy {})",
                self.fx, self.fy, self.cx, self.cy
            )));
        }
        if self.near.partial_cmp(&self.far) != Some(std::cmp::Ordering::Less) || !self.near.is_finite() {
            return Err(RenderError::Camera(format!("near {} must be below far {}", self.near, self.far)));
        }
        Ok(())
    }
}
